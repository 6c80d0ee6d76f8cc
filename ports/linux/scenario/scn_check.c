/*
 * scn_check.c - what the scenario reader checks on every layout (shapes,
 * time coverage, symmetric covariances, the measurements of every run) and
 * the queries a runner asks before it starts (scenario.h:
 * dkf_scn_require_ui, dkf_scn_require_truth).
 */
#include "scn_parse.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "util.h"

/* The covariances the filters read, and the definiteness they need
 * (dkf/kf.h, dkf/ui_model.h, dkf/uif.h, dkf/tw.h): Q and Rd are PSD (a
 * noise may be absent in some direction), R and the initial covariances
 * SPD (the filters invert R, H P H^T + R, P0). */
typedef struct {
    const char *name;
    int spd;
    const char *what;
} cov_t;

static const cov_t model_cov[] = {
    {"Q", 0, "the process noise covariance Q must be symmetric PSD"},
    {"R", 1, "the measurement noise covariance R must be SPD"},
    {"Rd", 0, "the input noise covariance Rd must be symmetric PSD"},
};
static const cov_t init_cov[] = {
    {"P00", 1, "the initial state covariance must be SPD"},
    {"P00_local", 1, "the initial state covariance must be SPD"},
    {"P00_central", 1, "the initial state covariance must be SPD"},
    {"Pd00", 1, "the initial input covariance must be SPD"},
};

static int require_covariance(dkf_scn_ctx_t *c, const dkf_scenario_t *s, const dkf_scn_mat_t *m,
                              int is_list, const cov_t *cov)
{
    size_t e, n, count;
    char p[DKF_SCN_PATH_LEN];
    if (m == NULL || m->rows != m->cols) return 0; /* shapes are checked elsewhere */
    n = m->rows;
    count = m->count > 0 ? m->count : 1;
    for (e = 0; e < count; ++e) {
        if (m->count == 0)
            dkf_scn_pathf(p, "%s", m->path);
        else if (is_list)
            dkf_scn_pathf(p, "%s[%zu]", m->path, e);
        else if (s->layout == DKF_SCN_LAYOUT_CANONICAL)
            dkf_scn_pathf(p, "%s.per_k[%zu]", m->path, e);
        else
            dkf_scn_pathf(p, "%s (entry for k = %zu)", m->path, m->k0 + e);
        if (dkf_scn_check_symmetric(c, p, m->data + e * n * n, n) != 0 ||
            dkf_scn_check_definite(c, p, m->data + e * n * n, n, cov->spd, cov->what) != 0)
            return -1;
    }
    return 0;
}

/* Every covariance of the model (Q, R, Rd; each sensor's own) and of init
 * (P00, P00_local, P00_central, Pd00): symmetric, and as definite as
 * model_cov / init_cov say. */
int dkf_scn_check_covariances(dkf_scn_ctx_t *c, const dkf_scenario_t *s)
{
    size_t i, l;
    for (i = 0; i < sizeof model_cov / sizeof *model_cov; ++i) {
        if (require_covariance(c, s, dkf_scn_mats_find(&s->model, model_cov[i].name), 0,
                               &model_cov[i]) != 0)
            return -1;
        for (l = 0; l < s->nsensors; ++l)
            if (require_covariance(c, s, dkf_scn_mats_find(&s->sensors[l].mats, model_cov[i].name),
                                   0, &model_cov[i]) != 0)
                return -1;
    }
    for (i = 0; i < sizeof init_cov / sizeof *init_cov; ++i)
        if (require_covariance(c, s, dkf_scn_mats_find(&s->init, init_cov[i].name), 1,
                               &init_cov[i]) != 0)
            return -1;
    return 0;
}

/* Matrix `name` must exist (in set or, for sensors, the fallback) with shape r x c. */
int dkf_scn_require_shape(dkf_scn_ctx_t *c, const dkf_scn_mat_t *m, const char *missing_path,
                          size_t r,
                          size_t cc)
{
    if (m == NULL) return dkf_scn_fail(c, missing_path, "missing key");
    if (m->rows != r || m->cols != cc) {
        char p[DKF_SCN_PATH_LEN];
        dkf_scn_pathf(p, "%s%s", m->path, m->count > 0 ? ".per_k" : "");
        return dkf_scn_shape_error(c, m->count > 0 ? p : m->path, r, cc, m->rows, m->cols);
    }
    return 0;
}

/* A per_k matrix must cover absolute times 0..last. */
int dkf_scn_require_times(dkf_scn_ctx_t *c, const dkf_scn_mat_t *m, size_t last, const char *why)
{
    char p[DKF_SCN_PATH_LEN];
    if (m == NULL || m->count == 0 || last < m->count) return 0;
    dkf_scn_pathf(p, "%s.per_k", m->path);
    return dkf_scn_fail(c, p, "has %zu entries (k = 0..%zu) but %s needs k up to %zu", m->count,
                        m->count - 1, why, last);
}

/* An optional init covariance: absent, or exactly one n x n matrix. */
int dkf_scn_require_single(dkf_scn_ctx_t *c, const dkf_scn_mat_t *m, const char *path, size_t n)
{
    if (m == NULL) return 0;
    if (m->count != 0)
        return dkf_scn_fail(c, m->path, "expected one %zux%zu matrix, got a list", n, n);
    return dkf_scn_require_shape(c, m, path, n, n);
}

/* The key path of the times of sensor i's measurements in run r. */
void dkf_scn_y_path(const dkf_scenario_t *s, size_t r, size_t i, char *p)
{
    if (s->layout == DKF_SCN_LAYOUT_CASES)
        dkf_scn_pathf(p, "cases[%zu].steps", s->case_index);
    else if (s->has_runs && s->multi)
        dkf_scn_pathf(p, "runs[%zu].y[%zu].k", r, i);
    else if (s->has_runs)
        dkf_scn_pathf(p, "runs[%zu].y.k", r);
    else if (s->multi)
        dkf_scn_pathf(p, "y[%zu].k", i);
    else
        dkf_scn_pathf(p, "y.k");
}

int dkf_scn_validate(dkf_scn_ctx_t *c, dkf_scenario_t *s, const char *model_path,
                     const char *sensor_fmt_path)
{
    const dkf_scn_mat_t *F = dkf_scn_model(s, "F"), *Q, *x00, *P00, *Pl, *Pc;
    size_t i, n, r;
    char p[DKF_SCN_PATH_LEN], why[64];
    long k;

    dkf_scn_subkey(p, model_path, "F");
    if (F == NULL) return dkf_scn_fail(c, p, "missing key");
    if (F->rows != F->cols) return dkf_scn_fail(c, F->path, "expected a square matrix, got %zux%zu",
                                                F->rows, F->cols);
    n = s->n = F->rows;
    if (n > DKF_MAX_DIM)
        return dkf_scn_fail(c, F->path, "state dimension %zu exceeds DKF_MAX_DIM = %d", n,
                            DKF_MAX_DIM);
    Q = dkf_scn_model(s, "Q");
    dkf_scn_subkey(p, model_path, "Q");
    if (dkf_scn_require_shape(c, Q, p, n, n) != 0) return -1;
    snprintf(why, sizeof why, "steps k = 1..%zu", s->steps);
    if (dkf_scn_require_times(c, F, s->steps - 1, why) != 0) return -1;
    if (dkf_scn_require_times(c, Q, s->steps - 1, why) != 0) return -1;

    for (i = 0; i < s->nsensors; ++i) {
        dkf_scn_sensor_t *se = &s->sensors[i];
        const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, i, "H");
        const dkf_scn_mat_t *R = dkf_scn_sensor_model(s, i, "R");
        const dkf_scn_mat_t *D = dkf_scn_sensor_model(s, i, "D");
        char sp[DKF_SCN_PATH_LEN];
        dkf_scn_pathf(sp, sensor_fmt_path, i);
        dkf_scn_subkey(p, sp, "H");
        if (H == NULL) return dkf_scn_fail(c, p, "missing key");
        if (dkf_scn_require_shape(c, H, p, H->rows, n) != 0) return -1;
        if (se->m != 0 && se->m != H->rows)
            return dkf_scn_fail(c, H->path, "has %zu rows but the measurements have %zu values",
                                H->rows, se->m);
        se->m = H->rows;
        if (se->m > DKF_MAX_DIM)
            return dkf_scn_fail(c, H->path, "measurement dimension %zu exceeds DKF_MAX_DIM = %d",
                                se->m,
                                DKF_MAX_DIM);
        dkf_scn_subkey(p, sp, "R");
        if (dkf_scn_require_shape(c, R, p, se->m, se->m) != 0) return -1;
        /* Unknown-input pieces are not used by kf/info; check what is unambiguous. */
        if (D != NULL && D->rows != se->m)
            return dkf_scn_fail(c, D->path, "expected %zu rows (like H), got %zu", se->m, D->rows);
        if (D != NULL) {
            const dkf_scn_mat_t *B = dkf_scn_sensor_model(s, i, "B");
            const dkf_scn_mat_t *Rd = dkf_scn_sensor_model(s, i, "Rd");
            if (B != NULL && dkf_scn_require_shape(c, B, B->path, D->cols, D->cols) != 0) return -1;
            if (Rd != NULL && dkf_scn_require_shape(c, Rd, Rd->path, D->cols, D->cols) != 0)
                return -1;
        }
        if (dkf_scn_require_times(c, H, s->steps, why) != 0) return -1;
        if (dkf_scn_require_times(c, R, s->steps, why) != 0) return -1;
    }

    x00 = dkf_scn_init(s, "x00");
    if (dkf_scn_require_shape(c, x00, "init.x00", n, 1) != 0) return -1;
    P00 = dkf_scn_init(s, "P00");
    Pl = dkf_scn_init(s, "P00_local");
    Pc = dkf_scn_init(s, "P00_central");
    if (dkf_scn_require_single(c, P00, "init.P00", n) != 0) return -1;
    if (dkf_scn_require_single(c, Pc, "init.P00_central", n) != 0) return -1;
    if (Pl != NULL) {
        if (dkf_scn_require_shape(c, Pl, "init.P00_local", n, n) != 0) return -1;
        if (Pl->count != s->nsensors)
            return dkf_scn_fail(c, Pl->path,
                                "expected a list of %zu %zux%zu matrices (one per sensor)",
                                s->nsensors, n, n);
    }
    if (P00 == NULL && (Pc == NULL || (Pl == NULL && s->multi)))
        return dkf_scn_fail(c, "init.P00",
                            "missing key (needed unless init.P00_central%s are given)",
                            s->multi ? " and init.P00_local" : "");

    for (r = 0; r < s->nruns; ++r) {
        dkf_scn_select_run(s, r);
        for (i = 0; i < s->nsensors; ++i)
            for (k = 1; k <= (long)s->steps; ++k)
                if (dkf_scn_y(s, i, k) == NULL) {
                    dkf_scn_y_path(s, r, i, p);
                    return dkf_scn_fail(c, p,
                                        "no measurement for k = %ld (steps k = 1..%zu need one)",
                                        k, s->steps);
                }
    }
    dkf_scn_select_run(s, 0);
    return dkf_scn_check_covariances(c, s);
}

/* The key path of sensor i's matrix `name` when it is missing. */
static void sensor_key(const dkf_scenario_t *s, size_t i, const char *name, char *p)
{
    if (s->layout == DKF_SCN_LAYOUT_CASES)
        dkf_scn_pathf(p, "cases[%zu].%s[%zu]", s->case_index, name, i);
    else if (s->multi)
        dkf_scn_pathf(p, "model.sensors[%zu].%s", i, name);
    else
        dkf_scn_pathf(p, "model.%s", name);
}

int dkf_scn_require_ui(const dkf_scenario_t *s, size_t last_dyn, size_t last_meas, int need_d0,
                       const char *who, char *err, size_t errlen)
{
    dkf_scn_ctx_t c;
    size_t i, r, j, p = 0;
    char path[DKF_SCN_PATH_LEN], why[96];
    static const char *const dyn_names[] = {"B", "Rd"};
    static const char *const meas_names[] = {"H", "R", "D"};
    dkf_scenario_t *sm = (dkf_scenario_t *)s; /* run selection only; restored below */
    size_t run0 = s->run;
    c.file = s->file;
    c.err = err;
    c.errlen = errlen;
    snprintf(why, sizeof why, "filter %s", who);
    if (dkf_scn_require_times(&c, dkf_scn_model(s, "F"), last_dyn, why) != 0) return -1;
    if (dkf_scn_require_times(&c, dkf_scn_model(s, "Q"), last_dyn, why) != 0) return -1;
    for (i = 0; i < s->nsensors; ++i) {
        const dkf_scn_mat_t *D = dkf_scn_sensor_model(s, i, "D");
        sensor_key(s, i, "D", path);
        if (D == NULL) return dkf_scn_fail(&c, path, "missing key (filter %s needs D, B, Rd)", who);
        p = D->cols;
        if (p > s->sensors[i].m)
            return dkf_scn_fail(&c, D->path,
                                "has %zu columns but %zu rows: D must have full column "
                                "rank (p <= m)", p, s->sensors[i].m);
        for (j = 0; j < 2; ++j) {
            const dkf_scn_mat_t *M = dkf_scn_sensor_model(s, i, dyn_names[j]);
            sensor_key(s, i, dyn_names[j], path);
            if (M == NULL)
                return dkf_scn_fail(&c, path, "missing key (filter %s needs D, B, Rd)", who);
            if (dkf_scn_require_shape(&c, M, path, p, p) != 0) return -1;
            if (dkf_scn_require_times(&c, M, last_dyn, why) != 0) return -1;
        }
        for (j = 0; j < 3; ++j)
            if (dkf_scn_require_times(&c, dkf_scn_sensor_model(s, i, meas_names[j]), last_meas, why)
                != 0)
                return -1;
    }
    for (r = 0; r < s->nruns; ++r) {
        dkf_scn_select_run(sm, r);
        for (i = 0; i < s->nsensors; ++i)
            if (dkf_scn_y(s, i, (long)last_meas) == NULL) {
                dkf_scn_y_path(s, r, i, path);
                dkf_scn_select_run(sm, run0);
                return dkf_scn_fail(&c, path,
                                    "no measurement for k = %zu (filter %s needs y_1..y_%zu)",
                                    last_meas, who, last_meas);
            }
    }
    dkf_scn_select_run(sm, run0);
    if (need_d0) {
        const dkf_scn_mat_t *d00 = dkf_scn_init(s, "d00"), *Pd00 = dkf_scn_init(s, "Pd00");
        if (d00 == NULL)
            return dkf_scn_fail(&c, "init.d00", "missing key (filter %s needs it)", who);
        if (dkf_scn_require_shape(&c, d00, "init.d00", p, 1) != 0) return -1;
        if (Pd00 == NULL)
            return dkf_scn_fail(&c, "init.Pd00", "missing key (filter %s needs it)", who);
        if (dkf_scn_require_single(&c, Pd00, "init.Pd00", p) != 0) return -1;
    }
    return 0;
}

int dkf_scn_require_truth(const dkf_scenario_t *s, char *err, size_t errlen)
{
    dkf_scn_ctx_t c;
    size_t r;
    long k;
    char path[DKF_SCN_PATH_LEN];
    c.file = s->file;
    c.err = err;
    c.errlen = errlen;
    for (r = 0; r < s->nruns; ++r) {
        const dkf_scn_run_t *run = &s->runs[r];
        for (k = 1; k <= (long)s->steps; ++k)
            if (dkf_scn_find_time(run->truth_k, run->ntruth, k) < 0) {
                if (s->has_runs)
                    dkf_scn_pathf(path, "runs[%zu].truth", r);
                else
                    dkf_scn_pathf(path, "truth");
                return dkf_scn_fail(&c, path, "no true state x for k = %ld (the error mode needs "
                                    "x_1..x_%zu)", k, s->steps);
            }
    }
    return 0;
}
