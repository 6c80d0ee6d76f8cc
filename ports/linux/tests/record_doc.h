/*
 * record_doc.h - for the host tests: the output document of a runner
 * driven through the registry's operations only, written by the output
 * writer (output.h) into a temporary file and read back. The caller
 * defines _POSIX_C_SOURCE 200809L (mkstemp) and includes cmocka.h.
 */
#ifndef DKF_TEST_RECORD_DOC_H
#define DKF_TEST_RECORD_DOC_H

#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include <jansson.h>

#include "registry.h"

/* Steps every k of s through runner r of filter f, recording each step,
 * and returns the document (new reference); fails the test on any error. */
static json_t *record_doc(const dkf_filter_t *f, dkf_runner_t *r, const dkf_scenario_t *s)
{
    char tmp[] = "/tmp/dkf_test_record_XXXXXX", err[DKF_SCN_ERR_LEN];
    int fd = mkstemp(tmp);
    dkf_out_t *out;
    json_t *doc;
    long k;
    assert_true(fd >= 0);
    close(fd);
    out = dkf_out_open(tmp, DKF_OUT_JSON, 1, s->k_first, err, sizeof err);
    if (out == NULL) fail_msg("%s", err);
    for (k = s->k_first; k < s->k_first + (long)s->steps; ++k) {
        if (f->family->step(r, k, err, sizeof err) != DKF_EXIT_OK) fail_msg("%s", err);
        dkf_out_step(out, k);
        f->family->record(r, out);
    }
    if (f->family->record_end != NULL) f->family->record_end(r, out);
    if (dkf_out_close(out, 1, err, sizeof err) != DKF_EXIT_OK) fail_msg("%s", err);
    doc = json_load_file(tmp, 0, NULL);
    remove(tmp);
    assert_non_null(doc);
    return doc;
}

#endif /* DKF_TEST_RECORD_DOC_H */
