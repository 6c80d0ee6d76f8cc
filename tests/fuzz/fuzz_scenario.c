/*
 * fuzz_scenario.c - the scenario reader (ports/linux/scenario/scenario.h) on any
 * document (docs/guide/fuzzing.md). The input is the file's content; the reader
 * takes a path, so each input is written to one temporary file first.
 *
 * Besides "no crash, no sanitizer report":
 *   - a refused file gives a one-line "FILE: ..." message;
 *   - a loaded one is what scenario.h says: every y_k of every run holds m
 *     values, every truth x_k n values, every model/init matrix its rows x
 *     cols for each k it covers (all read here, so a buffer sized smaller
 *     than its accessor's promise is an ASan report), and the checks the
 *     filters run before starting (every registry family's check, as
 *     dkf-run and the network processes call it) answer 0 or a message.
 */
#define _POSIX_C_SOURCE 200809L

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fuzz_check.h"
#include "registry.h"
#include "scenario.h"

static char path[4096];
static int fd = -1;

static void remove_file(void)
{
    if (fd >= 0) {
        close(fd);
        unlink(path);
    }
}

/* The temporary file holding the current input. */
static int write_input(const uint8_t *data, size_t size)
{
    size_t done = 0;
    if (fd < 0) {
        const char *tmp = getenv("TMPDIR");
        snprintf(path, sizeof path, "%s/dkf-fuzz-scenario-XXXXXX",
                 tmp != NULL && tmp[0] != '\0' ? tmp : "/tmp");
        fd = mkstemp(path);
        if (fd < 0) return -1;
        atexit(remove_file);
    }
    if (ftruncate(fd, 0) != 0) return -1;
    while (done < size) {
        ssize_t w = pwrite(fd, data + done, size - done, (off_t)done);
        if (w <= 0) return -1;
        done += (size_t)w;
    }
    return 0;
}

static volatile double sink;

static void read_values(const double *v, size_t n)
{
    size_t i;
    double s = 0.0;
    FUZZ_REQUIRE(v != NULL || n == 0);
    for (i = 0; i < n; ++i) s += v[i];
    sink = s;
}

static void read_mats(const dkf_scn_mats_t *set)
{
    size_t i, k;
    for (i = 0; i < set->len; ++i) {
        const dkf_scn_mat_t *m = &set->items[i];
        const size_t count = m->count == 0 ? 1 : m->count;
        for (k = 0; k < count; ++k)
            read_values(dkf_scn_at(m, m->count == 0 ? 0 : m->k0 + k), m->rows * m->cols);
    }
}

static void read_run(const dkf_scenario_t *s)
{
    size_t i, j;
    for (i = 0; i < s->nsensors; ++i) {
        const dkf_scn_sensor_t *se = &s->sensors[i];
        for (j = 0; j < se->ny; ++j) read_values(dkf_scn_y(s, i, se->yk[j]), se->m);
        read_mats(&se->mats);
    }
    for (j = 0; j < s->ntruth; ++j) read_values(dkf_scn_truth(s, s->truth_k[j]), s->n);
    for (j = 0; j < s->ntruth_u; ++j)
        read_values(dkf_scn_truth_u(s, s->truth_u_k[j]), s->m_u);
}

/* A message of the reader: one non-empty line. */
static void require_message(const char *err)
{
    FUZZ_REQUIRE(memchr(err, '\0', DKF_SCN_ERR_LEN) != NULL);
    FUZZ_REQUIRE(err[0] != '\0' && strchr(err, '\n') == NULL);
}

/* Every filter's check (default options): 0 or a message. */
static void check_every_filter(const dkf_scenario_t *s, char *err)
{
    dkf_run_opts_t o;
    size_t i, j;
    memset(&o, 0, sizeof o);
    for (i = 0; dkf_registry[i] != NULL; ++i)
        for (j = 0; j < dkf_registry[i]->nfilters; ++j) {
            const dkf_filter_t *f = &dkf_registry[i]->filters[j];
            memset(err, 'x', DKF_SCN_ERR_LEN);
            if (f->family->check(f, &o, s, err, DKF_SCN_ERR_LEN) != DKF_EXIT_OK)
                require_message(err);
        }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char err[DKF_SCN_ERR_LEN];
    dkf_scenario_t *s;
    size_t r;
    if (write_input(data, size) != 0) abort(); /* the machine, not the reader */
    memset(err, 'x', sizeof err);
    s = dkf_scenario_load(path, NULL, err, sizeof err);
    if (s == NULL) {
        require_message(err);
        return 0;
    }
    FUZZ_REQUIRE(s->n >= 1 && s->nsensors >= 1 && s->nruns >= 1);
    read_mats(&s->model);
    read_mats(&s->init);
    for (r = 0; r < s->nruns; ++r) {
        dkf_scn_select_run(s, r);
        read_run(s);
    }
    dkf_scn_select_run(s, 0);
    read_values(dkf_scn_P00_central(s), s->n * s->n);
    if (dkf_scn_require_truth(s, err, sizeof err) != 0) require_message(err);
    if (s->layout != DKF_SCN_LAYOUT_STEPS && s->layout != DKF_SCN_LAYOUT_NETWORK &&
        dkf_scn_require_ui(s, s->steps, s->steps, 0, "fuzz", err, sizeof err) != 0)
        require_message(err);
    check_every_filter(s, err);
    dkf_scenario_free(s);
    return 0;
}
