/*
 * scn_wfcases.c - the weighted-fusion cases layout (seed 002, the vector
 * tests/vectors/infofusion/s2_weighted_fusion.json and scenarios written
 * like it; docs/reference/scenario-format.md, "Weighted-fusion cases"). One case:
 *
 *   Phi (n x n), Gamma (n x r), Qe (r x r), H [l matrices m_i x n],
 *   R [l matrices m_i x m_i], H_signal (1 x n), P0 (n x n), x_hat0 (n),
 *   steps [{t: j + 1, y: [l lists of m_i numbers], expected {...}}],
 *   optional x_true (N + 1 states, k = 0..N)
 *
 * normalised onto the accessors every user reads (scenario.h):
 *   model F = Phi, Q = Gamma Qe Gamma^T (computed here, mirrored so it is
 *   exactly symmetric), Hs = H_signal, and Gamma, Qe as given;
 *   sensor i's H = H[i], R = R[i] (m_i = rows of H[i]; the sensors may
 *   differ); init x00 = x_hat0, P00 = P0; y of sensor i at t = 1..N from
 *   steps[t-1].y[i]; truth x_k from x_true[k]. `expected` and every other
 *   key are ignored. R[i] must be positive definite (the local filters of
 *   seed 002 assume R_i > 0): a Cholesky factorisation in double, here.
 * Detected (scn_cases.c) by the case keys Phi, Gamma, Qe and H_signal.
 */
#include "scn_parse.h"
#include "util.h"

/* The keys of the layout's objects (`steady_state`, `held_out`, `expected`:
 * the vector's own). */
static const char *const case_keys[] = {"Phi", "Gamma", "Qe", "H", "R", "H_signal", "x_hat0",
                                        "P0", "steps", "x_true", "steady_state", "held_out",
                                        NULL};
static const char *const step_keys[] = {"t", "y", "expected", NULL};
/* steps[t-1].y: one vector per sensor, of H[i]'s rows. */
static const dkf_scn_case_steps_t measured = {"t", "y", step_keys, "sensor, as H",
                                              "the rows of H"};

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Case key `key` as a matrix into set under `as`; rows x cols must be
 * er x ec (0: any, up to DKF_MAX_DIM). The pointer returned is valid
 * until the next dkf_scn_mats_add to the same set (it may move the items). */
static dkf_scn_mat_t *wf_matrix(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const json_t *cj,
                                const char *cpath, const char *key, const char *as, size_t er,
                                size_t ec)
{
    const json_t *v = json_object_get(cj, key);
    dkf_scn_mat_t *m;
    char p[DKF_SCN_PATH_LEN];
    dkf_scn_subkey(p, cpath, key);
    if (v == NULL) {
        dkf_scn_fail(c, p, "missing key");
        return NULL;
    }
    if ((m = dkf_scn_mats_add(c, set, as, p)) == NULL) return NULL;
    if (dkf_scn_parse_matrix(c, v, p, &m->rows, &m->cols, &m->data) != 0) return NULL;
    if (dkf_scn_check_dims(c, m) != 0) return NULL;
    if ((er != 0 && m->rows != er) || (ec != 0 && m->cols != ec)) {
        dkf_scn_shape_error(c, p, er != 0 ? er : m->rows, ec != 0 ? ec : m->cols, m->rows,
                            m->cols);
        return NULL;
    }
    return m;
}

/* Q = Gamma Qe Gamma^T (n x n) into model "Q": the upper triangle summed
 * in one order and mirrored, so Q is exactly symmetric. (Adding to a set
 * moves its items: Gamma and Qe are looked up here, and Q is computed
 * before it is added.) */
static int wf_Q(dkf_scn_ctx_t *c, dkf_scenario_t *s, const char *cpath)
{
    const dkf_scn_mat_t *G = dkf_scn_mats_find(&s->model, "Gamma"),
                        *Qe = dkf_scn_mats_find(&s->model, "Qe");
    const size_t n = G->rows, r = G->cols;
    dkf_scn_mat_t *Q;
    double *q;
    char p[DKF_SCN_PATH_LEN];
    size_t i, j, a, b;
    dkf_scn_pathf(p, "%s.Gamma Qe Gamma^T", cpath);
    if ((q = dkf_scn_calloc(c, n * n, sizeof *q)) == NULL) return -1;
    for (i = 0; i < n; ++i)
        for (j = i; j < n; ++j) {
            double acc = 0.0;
            for (a = 0; a < r; ++a) {
                double t = 0.0;
                for (b = 0; b < r; ++b) t += Qe->data[a * r + b] * G->data[j * r + b];
                acc += G->data[i * r + a] * t;
            }
            if (!isfinite(acc)) {
                free(q);
                return dkf_scn_fail(c, p, "entry (%zu,%zu) is not finite", i, j);
            }
            q[i * n + j] = q[j * n + i] = acc;
        }
    if ((Q = dkf_scn_mats_add(c, &s->model, "Q", p)) == NULL) {
        free(q);
        return -1;
    }
    Q->data = q;
    Q->rows = Q->cols = n;
    return 0;
}

/* H[i], R[i] of every sensor (l = len(H) = len(R)). */
static int wf_sensors(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj, const char *cpath)
{
    const json_t *H = json_object_get(cj, "H"), *R = json_object_get(cj, "R");
    char ph[DKF_SCN_PATH_LEN], pr[DKF_SCN_PATH_LEN], p[DKF_SCN_PATH_LEN];
    size_t i, l;
    dkf_scn_subkey(ph, cpath, "H");
    dkf_scn_subkey(pr, cpath, "R");
    if (H == NULL) return dkf_scn_fail(c, ph, "missing key");
    if (R == NULL) return dkf_scn_fail(c, pr, "missing key");
    if (dkf_scn_list_len(c, H, ph, "sensor matrices H_i", "sensors", DKF_SCN_MAX_SENSORS, &l) !=
        0)
        return -1;
    if (!json_is_array(R) || json_array_size(R) != l)
        return json_is_array(R)
                   ? dkf_scn_fail(c, pr, "expected a list of %zu matrices (one per H_i), got "
                                  "%zu", l, json_array_size(R))
                   : dkf_scn_fail(c, pr, "expected a list of %zu matrices (one per H_i), got "
                                  "%s", l, dkf_scn_json_kind(R));
    s->nsensors = l;
    if ((s->sensors = dkf_scn_calloc(c, l, sizeof *s->sensors)) == NULL) return -1;
    for (i = 0; i < l; ++i) {
        dkf_scn_mat_t *m;
        dkf_scn_subidx(p, ph, i);
        if ((m = dkf_scn_mats_add(c, &s->sensors[i].mats, "H", p)) == NULL) return -1;
        if (dkf_scn_parse_matrix(c, json_array_get(H, i), p, &m->rows, &m->cols, &m->data) != 0)
            return -1;
        if (dkf_scn_check_dims(c, m) != 0) return -1;
        if (m->cols != s->n)
            return dkf_scn_shape_error(c, p, m->rows, s->n, m->rows, m->cols);
        s->sensors[i].m = m->rows;
        dkf_scn_subidx(p, pr, i);
        if ((m = dkf_scn_mats_add(c, &s->sensors[i].mats, "R", p)) == NULL) return -1;
        if (dkf_scn_parse_matrix(c, json_array_get(R, i), p, &m->rows, &m->cols, &m->data) != 0)
            return -1;
        if (m->rows != s->sensors[i].m || m->cols != s->sensors[i].m)
            return dkf_scn_shape_error(c, p, s->sensors[i].m, s->sensors[i].m, m->rows,
                                       m->cols);
        if (dkf_scn_check_symmetric(c, p, m->data, m->rows) != 0) return -1;
        if (dkf_scn_check_definite(c, p, m->data, m->rows, 1,
                                   "a measurement noise covariance R_i") != 0)
            return -1;
    }
    return 0;
}

/* x_true: N + 1 states of n values (k = 0..N), optional. */
static int wf_truth(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj, const char *cpath)
{
    const json_t *xt = json_object_get(cj, "x_true");
    char p[DKF_SCN_PATH_LEN];
    dkf_scn_subkey(p, cpath, "x_true");
    if (xt == NULL || json_is_null(xt)) return 0;
    if (!json_is_array(xt))
        return dkf_scn_fail(c, p, "expected a list of %zu states (k = 0..%zu), got %s",
                            s->steps + 1, s->steps, dkf_scn_json_kind(xt));
    if (json_array_size(xt) != s->steps + 1)
        return dkf_scn_fail(c, p, "expected %zu states (k = 0..%zu, one more than the "
                            "steps), got %zu", s->steps + 1, s->steps, json_array_size(xt));
    return dkf_scn_cases_truth(c, xt, p, s->n, "the rows of Phi", 0, &s->ntruth, &s->truth_k,
                               &s->truth_x);
}

int dkf_scn_is_wfcase(const json_t *cj)
{
    return json_object_get(cj, "Phi") != NULL && json_object_get(cj, "Gamma") != NULL &&
           json_object_get(cj, "Qe") != NULL && json_object_get(cj, "H_signal") != NULL;
}

int dkf_scn_load_wfcases(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj,
                         const char *cpath)
{
    const json_t *steps, *x0 = json_object_get(cj, "x_hat0");
    const dkf_scn_mat_t *F, *G, *Qe, *P0;
    dkf_scn_mat_t *x;
    char p[DKF_SCN_PATH_LEN];
    size_t len, r;

    s->layout = DKF_SCN_LAYOUT_WFCASES;
    s->multi = 1;
    if (dkf_scn_check_keys(c, cj, cpath, case_keys, NULL) != 0) return -1;
    if ((F = wf_matrix(c, &s->model, cj, cpath, "Phi", "F", 0, 0)) == NULL) return -1;
    if (F->rows != F->cols) {
        dkf_scn_subkey(p, cpath, "Phi");
        return dkf_scn_fail(c, p, "expected a square matrix (the transition), got %zux%zu",
                            F->rows, F->cols);
    }
    s->n = F->rows;
    /* every pointer into a set is used before the next add to that set */
    if ((G = wf_matrix(c, &s->model, cj, cpath, "Gamma", "Gamma", s->n, 0)) == NULL) return -1;
    r = G->cols;
    if ((Qe = wf_matrix(c, &s->model, cj, cpath, "Qe", "Qe", r, r)) == NULL) return -1;
    if (dkf_scn_check_symmetric(c, Qe->path, Qe->data, r) != 0 ||
        dkf_scn_check_definite(c, Qe->path, Qe->data, r, 0,
                               "the noise covariance Qe must be symmetric PSD") != 0)
        return -1;
    if (wf_Q(c, s, cpath) != 0) return -1;
    if (wf_matrix(c, &s->model, cj, cpath, "H_signal", "Hs", 1, s->n) == NULL) return -1;
    if ((P0 = wf_matrix(c, &s->init, cj, cpath, "P0", "P00", s->n, s->n)) == NULL) return -1;
    if (dkf_scn_check_symmetric(c, P0->path, P0->data, s->n) != 0 ||
        dkf_scn_check_definite(c, P0->path, P0->data, s->n, 0,
                               "the initial covariance P0 must be symmetric PSD") != 0)
        return -1;
    dkf_scn_subkey(p, cpath, "x_hat0");
    if (x0 == NULL) return dkf_scn_fail(c, p, "missing key");
    if ((x = dkf_scn_mats_add(c, &s->init, "x00", p)) == NULL) return -1;
    if (dkf_scn_parse_vector(c, x0, p, &len, &x->data) != 0) return -1;
    if (len != s->n)
        return dkf_scn_fail(c, p, "expected a vector of %zu values (the rows of Phi), got %zu",
                            s->n, len);
    x->rows = len;
    x->cols = 1;
    if (wf_sensors(c, s, cj, cpath) != 0) return -1;

    if ((steps = dkf_scn_cases_steps(c, s, cj, cpath)) == NULL) return -1;
    if (dkf_scn_cases_measurements(c, s, steps, cpath, &measured) != 0) return -1;
    if (dkf_scn_alloc_runs(c, s, 1) != 0) return -1;
    dkf_scn_adopt_y(s, 0);
    if (wf_truth(c, s, cj, cpath) != 0) return -1;
    dkf_scn_adopt_truth(s, 0);
    dkf_scn_select_run(s, 0);
    return 0;
}
