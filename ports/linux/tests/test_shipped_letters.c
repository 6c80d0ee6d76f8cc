/*
 * test_shipped_letters.c - every scenario file the repository ships (the
 * files named on the command line: tests/vectors/ and scenarios/, listed by
 * ports/linux/tests/cases.cmake) is in the library's letters: read as dkf-run
 * reads it (dkf_scenario_load), none has the old letters' notice, and none
 * is refused for mixing the two conventions (docs/reference/scenario-format.md,
 * "Letters"; docs/decisions.md item 54). A file the reader refuses for
 * another reason (a vector only the cmocka tests read) prints no notice
 * either, as dkf-run prints it only with a loaded scenario.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "scenario.h"

static int n_files;
static char **files;

static void test_no_old_letters(void **state)
{
    int i, loaded = 0;
    (void)state;
    for (i = 0; i < n_files; ++i) {
        char err[DKF_SCN_ERR_LEN] = "";
        dkf_scenario_t *s = dkf_scenario_load(files[i], NULL, err, sizeof err);
        if (s == NULL) {
            if (strstr(err, "letters") != NULL) fail_msg("%s", err);
            continue;
        }
        if (s->notice[0] != '\0') fail_msg("%s", s->notice);
        ++loaded;
        dkf_scenario_free(s);
    }
    print_message("%d of %d shipped files read as scenarios, none in the old letters\n", loaded,
                  n_files);
    assert_true(loaded > 0);
}

int main(int argc, char **argv)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_old_letters),
    };
    n_files = argc - 1;
    files = argv + 1;
    return cmocka_run_group_tests(tests, NULL, NULL);
}
