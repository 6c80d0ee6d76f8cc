/*
 * wfusion_run.c - seed 002's weighted fusion of local Kalman filters
 * (dkf/wfusion.h) over a weighted-fusion case (scn_wfcases.c, the model
 * from wf_model.h), every sensor and the fusion in process: the registry
 * family "wfusion", filters
 *
 *   local_kf       the l local filters (Theorem 1) and the cross
 *                  covariances: per step x_local, K, Sigma_pred, s_local
 *                  (= Hs x_i), P_ij (the joint covariance's l x l blocks)
 *   fusion_scalar  the scalar-weight fusion of s (Theorem 2): w, P_S,
 *                  s_fused, P_S0
 *   fusion_matrix  the matrix-weight fusion of x (Sun and Deng):
 *                  matrix_weights (the blocks A_i), matrix_weights_unique,
 *                  x_fused_matrix, P0_matrix
 *   fusion_steady  the steady filters (dkf_wfusion_steady, DARE + Stein)
 *                  from the prior: steady_state's keys once (K, Sigma_pred,
 *                  P_ij, P_S, w, P_S0, matrix_weights, P0_matrix), then per
 *                  step x_local, s_fused, x_fused_matrix of the steady
 *                  filters (steps_x_local, steps_s_fused, steps_x_fused_matrix)
 *   central_kf     the centralized Kalman filter of the stacked
 *                  measurements [y_1; ...; y_l] (dkf/kf.h, R block-diagonal)
 *                  beside the fusion, the bound every fusion is measured
 *                  against: per step x_central, P_central
 *   fusion_selftune  the self-tuning form (dkf/selftune.h): the identifier
 *                  fed with every y_i(t), the local filters, P_ij and both
 *                  fusions on the model of its current estimate; per step
 *                  a_hat, c1_hat, sigma_w2_hat, guard (dkf_selftune_guard_t),
 *                  w, P_S, s_fused, P_S0, x_fused_matrix. Known: P(q^-1) (the
 *                  file's noise block of Phi), sigma_xi^2 (Qe[1][1]) and the
 *                  sigma_vi^2 (R_i); the file's model must be the observer
 *                  form dkf_selftune_model builds (checked: F and Q of the
 *                  file's own a, c_1, sigma_w^2 = Qe[0][0] reproduce Phi and
 *                  Gamma Qe Gamma^T), its H_i = (1 0..0 1 0..0), Hs = (1 0..0);
 *                  orders na (the second 1 of H), np = n - na, nc = 1 (0 if
 *                  na = 1), lags K = max(5, na + nc), t_min 50, the guesses
 *                  a = 0, c_1 = 0, sigma_w^2 = 1 (dkf_selftune_config_default)
 *
 * Every filter runs the whole fusion (dkf_wfusion_step, fuse_scalar,
 * fuse_matrix at every step); the filter chooses what is recorded, under
 * outputs.<LABEL> with the vector's key names, every per-step key a list
 * over steps, so tools/dkf_compare.py compares it with
 * cases[c].steps[*].expected (and fusion_steady with cases[c].steady_state).
 * The summary gives the RMSE of every local filter's x and of the fused
 * x and s against x_true, when the file has it. The node role
 * (est_wfusion_node.c: one sensor's local KF for dkf-node; its fusion
 * centre is net/wfusion_centre.c, docs/guide/network.md).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/selftune.h"
#include "dkf/wfusion.h"
#include "family.h"
#include "node_roles.h"
#include "status_text.h"
#include "util.h"
#include "wf_model.h"

typedef enum { WF_LOCAL, WF_SCALAR, WF_MATRIX, WF_STEADY, WF_SELFTUNE, WF_CENTRAL } wf_kind_t;

/* The self-tuning form's identifier and the model of its estimate. */
typedef struct {
    dkf_selftune_cfg_t cfg;
    dkf_selftune_t id;
    dkf_selftune_est_t est;
    dkf_real_t *mem;           /* identifier storage */
    dkf_real_t p[DKF_SELFTUNE_MAX_NP];
    dkf_real_t *sigma_v2;      /* l */
    dkf_real_t *ybar_in;       /* l: the step's y_i */
    dkf_real_t *buf;           /* F_hat, Q_hat: 2 n n */
    dkf_mat_t F, Q;
    dkf_kf_dyn_t dyn;
    /* the file's own parameters (the model checked against Phi, Q) */
    dkf_real_t a_file[DKF_SELFTUNE_MAX_NA], c1_file, sigma_w2_file;
} wf_st_t;

typedef struct {
    const dkf_filter_t *fl;
    const dkf_scenario_t *s;
    wf_kind_t kind;
    dkf_wf_model_t mdl;
    dkf_wfusion_local_t *nodes;
    dkf_wfusion_t fu;
    dkf_real_t *mem;
    size_t len;
    json_t *series; /* NULL: record nothing */
    json_t *once;   /* fusion_steady: the steady values, until the first record */
    /* squared errors against x_true: every local x_i, fused x, fused s */
    double *sq_local;
    double sq_x, sq_s, sq_c; /* sq_c: central_kf's x */
    size_t nerr;
    size_t nonunique; /* steps where the matrix weights were not unique */
    wf_st_t *st;      /* fusion_selftune only */
    /* central_kf only: the stacked filter, its model and measurement */
    dkf_kf_t kf;
    dkf_real_t *kmem, *Hc, *Rc, *yc;
    dkf_mat_t mHc, mRc, myc;
    dkf_kf_meas_t cmeas;
    size_t ms;
} wf_runner_t;

static void st_free(wf_st_t *st)
{
    if (st == NULL) return;
    free(st->mem);
    free(st->sigma_v2);
    free(st->ybar_in);
    free(st->buf);
    free(st);
}

/* The identifier of s's self-tuning form, initialised, with F, Q of the
 * file's own parameters checked against the file's Phi and Q. NULL with
 * err (DKF_EXIT_USAGE: the file is not of that form; *rc). */
static wf_st_t *st_setup(const dkf_filter_t *fl, const dkf_scenario_t *s, char *err,
                         size_t errlen, int *rc)
{
    const dkf_scn_mat_t *F = dkf_scn_model(s, "F"), *Q = dkf_scn_model(s, "Q"),
                        *G = dkf_scn_model(s, "Gamma"), *Qe = dkf_scn_model(s, "Qe"),
                        *Hs = dkf_scn_model(s, "Hs");
    const size_t n = s->n, l = s->nsensors;
    size_t na = 0, np, i, j, len;
    double scale = 0.0, worst = 0.0;
    dkf_status_t stt;
    wf_st_t *st;
    *rc = DKF_EXIT_USAGE;
    /* H_i = (1 0..0 1 0..0), one row each: na is the place of the second 1 */
    for (i = 0; i < l; ++i) {
        const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, i, "H");
        size_t second = 0;
        int ok = H->rows == 1 && H->data[0] == 1.0;
        for (j = 1; ok && j < n; ++j) {
            if (H->data[j] == 0.0) continue;
            if (H->data[j] != 1.0 || second != 0) ok = 0;
            second = j;
        }
        if (!ok || second == 0 || (i > 0 && second != na)) {
            dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: %s: filter %s needs every H_i = "
                      "(1 0..0 1 0..0) (y_i = s + eta + v_i, one row; the same for every "
                      "sensor)", s->file, H->path, fl->name);
            return NULL;
        }
        na = second;
    }
    np = n - na;
    if (na > DKF_SELFTUNE_MAX_NA || np > DKF_SELFTUNE_MAX_NP) {
        dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: cases[%zu].H: filter %s identifies A of "
                  "order na = %zu with P of order %zu: at most %d and %d", s->file,
                  s->case_index, fl->name, na, np, DKF_SELFTUNE_MAX_NA, DKF_SELFTUNE_MAX_NP);
        return NULL;
    }
    for (j = 1; j < n; ++j)
        if (Hs->data[0] != 1.0 || Hs->data[j] != 0.0) {
            dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: %s: filter %s needs H_signal = "
                      "(1 0..0) (s = the first state)", s->file, Hs->path, fl->name);
            return NULL;
        }
    if (G->cols != 2) {
        dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: %s: filter %s needs two noises (w, xi), "
                  "got %zu columns", s->file, G->path, fl->name, G->cols);
        return NULL;
    }
    if ((st = calloc(1, sizeof *st)) == NULL || (st->sigma_v2 = calloc(l, sizeof *st->sigma_v2)) == NULL ||
        (st->ybar_in = calloc(l, sizeof *st->ybar_in)) == NULL ||
        (st->buf = calloc(2 * n * n, sizeof *st->buf)) == NULL) {
        st_free(st);
        dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
        return NULL;
    }
    dkf_selftune_config_default(&st->cfg);
    st->cfg.na = na;
    st->cfg.np = np;
    st->cfg.nc = na > 1 ? 1 : 0;
    st->cfg.lags = na + st->cfg.nc > 5 ? na + st->cfg.nc : 5;
    st->cfg.L = l;
    for (j = 0; j < np; ++j) st->p[j] = (dkf_real_t)-F->data[(na + j) * n + na];
    st->cfg.p = np > 0 ? st->p : NULL;
    st->cfg.sigma_xi2 = (dkf_real_t)Qe->data[3];
    for (i = 0; i < l; ++i) st->sigma_v2[i] = (dkf_real_t)dkf_scn_sensor_model(s, i, "R")->data[0];
    st->cfg.sigma_v2 = st->sigma_v2;
    len = dkf_selftune_storage_len(na, np, st->cfg.nc, st->cfg.lags);
    if (len == 0 || (st->mem = calloc(len, sizeof *st->mem)) == NULL) {
        st_free(st);
        dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
        return NULL;
    }
    if ((stt = dkf_selftune_init(&st->id, &st->cfg, st->mem, len)) != DKF_OK) {
        st_free(st);
        dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: cases[%zu].Phi: filter %s: the noise "
                  "block's P(q^-1) and Qe, R give no identifier (dkf_selftune_init: %s)",
                  s->file, s->case_index, fl->name, dkf_status_str(stt));
        return NULL;
    }
    dkf_mat_init(&st->F, n, n, st->buf);
    dkf_mat_init(&st->Q, n, n, st->buf + n * n);
    st->dyn.F = &st->F;
    st->dyn.Q = &st->Q;
    /* the file's own a, c_1, sigma_w^2 must give back its F and Q */
    dkf_selftune_estimate(&st->id, &st->est);
    for (j = 0; j < na; ++j) st->est.a[j] = st->a_file[j] = (dkf_real_t)-F->data[j * n];
    st->est.c1 = st->c1_file = st->cfg.nc ? (dkf_real_t)G->data[1 * 2 + 0] : (dkf_real_t)0;
    st->est.sigma_w2 = st->sigma_w2_file = (dkf_real_t)Qe->data[0];
    if ((stt = dkf_selftune_model(&st->id, &st->est, &st->F, &st->Q)) != DKF_OK) {
        st_free(st);
        dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: cases[%zu]: filter %s: "
                  "dkf_selftune_model: %s", s->file, s->case_index, fl->name,
                  dkf_status_str(stt));
        return NULL;
    }
    for (i = 0; i < n * n; ++i) {
        scale = fmax(scale, fmax(fabs(F->data[i]), fabs(Q->data[i])));
        worst = fmax(worst, fmax(fabs((double)st->F.data[i] - F->data[i]),
                                 fabs((double)st->Q.data[i] - Q->data[i])));
    }
    /* the same numbers up to the rounding of the real type */
    if (!(worst <= 64.0 * (double)DKF_REAL_EPSILON * fmax(1.0, scale))) {
        st_free(st);
        dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: cases[%zu].Phi: filter %s needs the "
                  "observer form of dkf/selftune.h (F = blkdiag([-a | I; 0], [-p | I; 0]), "
                  "Gamma = blkdiag([1; c_1; 0..], [1; 0..]), Qe = diag(sigma_w^2, "
                  "sigma_xi^2)): off by %.3g", s->file, s->case_index, fl->name, worst);
        return NULL;
    }
    dkf_selftune_estimate(&st->id, &st->est);
    *rc = DKF_EXIT_OK;
    return st;
}

static int wf_check(const dkf_filter_t *fl, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                    char *err, size_t errlen)
{
    (void)o;
    if (s->layout != DKF_SCN_LAYOUT_WFCASES)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases: filter %s needs a weighted-fusion case (Phi, Gamma, Qe, "
                         "H, R, H_signal: docs/reference/scenario-format.md, \"Weighted-fusion cases\")",
                         s->file, fl->name);
    if (s->n * s->nsensors + s->n > DKF_MAX_DIM)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases[%zu].H: %zu sensors of state n = %zu: the fusion's KKT "
                         "system is n l + n = %zu, above DKF_MAX_DIM = %d", s->file,
                         s->case_index, s->nsensors, s->n, s->n * s->nsensors + s->n,
                         DKF_MAX_DIM);
    if (*(const wf_kind_t *)fl->impl == WF_SELFTUNE) {
        int rc;
        wf_st_t *st = st_setup(fl, s, err, errlen, &rc);
        if (st == NULL) return rc;
        st_free(st);
    }
    return DKF_EXIT_OK;
}

static void wf_destroy(dkf_runner_t *r)
{
    wf_runner_t *u = (wf_runner_t *)(void *)r;
    if (u == NULL) return;
    dkf_wf_model_free(&u->mdl);
    free(u->nodes);
    free(u->mem);
    free(u->sq_local);
    st_free(u->st);
    free(u->kmem);
    free(u->Hc);
    free(u->Rc);
    free(u->yc);
    json_decref(u->series);
    json_decref(u->once);
    free(u);
}

static int fail_core(const wf_runner_t *u, char *err, size_t errlen, long k, const char *call,
                     dkf_status_t st)
{
    char text[DKF_STATUS_TEXT_LEN];
    dkf_host_status_text(text, sizeof text, call, st);
    if (k < 0)
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: %s: %s failed: %s", u->s->file,
                         u->fl->label, call, text);
    return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: step t=%ld: %s: %s failed: %s",
                     u->s->file, k, u->fl->label, call, text);
}

/* ---- recording ---- */

static json_t *mat_json(const dkf_mat_t *A, int as_vector)
{
    return dkf_json_from_mat(A, as_vector);
}

/* Block (bi, bj) (rows r0.., cols c0.., rows x cols) of A as a list of rows. */
static json_t *block_json(const dkf_mat_t *A, size_t r0, size_t c0, size_t rows, size_t cols)
{
    json_t *out = json_array();
    size_t i, j;
    for (i = 0; i < rows; ++i) {
        json_t *row = json_array();
        for (j = 0; j < cols; ++j)
            json_array_append_new(row, json_real((double)A->data[(r0 + i) * A->cols + c0 + j]));
        json_array_append_new(out, row);
    }
    return out;
}

/* Per sensor i: f(node i) as JSON, a list over sensors. */
static json_t *per_node(const wf_runner_t *u, int what)
{
    json_t *out = json_array();
    size_t i;
    for (i = 0; i < u->mdl.l; ++i) {
        const dkf_wfusion_local_t *nd = &u->fu.nodes[i];
        json_t *v = NULL;
        switch (what) {
        case 0: v = mat_json(&nd->x, 1); break;
        case 1: v = mat_json(&nd->K, 0); break;
        case 2: v = mat_json(&nd->Sp, 0); break;
        default: {
            double sv = 0.0;
            size_t j;
            for (j = 0; j < u->mdl.n; ++j)
                sv += (double)u->mdl.Hs.data[j] * (double)nd->x.data[j];
            v = json_real(sv);
        }
        }
        json_array_append_new(out, v);
    }
    return out;
}

/* P_ij: the l x l blocks (n x n) of the joint covariance. */
static json_t *pij_json(const wf_runner_t *u)
{
    const size_t n = u->mdl.n, l = u->mdl.l;
    json_t *out = json_array();
    size_t i, j;
    for (i = 0; i < l; ++i) {
        json_t *row = json_array();
        for (j = 0; j < l; ++j) json_array_append_new(row, block_json(&u->fu.Pj, i * n, j * n, n, n));
        json_array_append_new(out, row);
    }
    return out;
}

/* matrix_weights: the l blocks A_i (n x n) of [A_1 ... A_l]. */
static json_t *weights_json(const wf_runner_t *u)
{
    const size_t n = u->mdl.n;
    json_t *out = json_array();
    size_t i;
    for (i = 0; i < u->mdl.l; ++i) json_array_append_new(out, block_json(&u->fu.A, 0, i * n, n, n));
    return out;
}

/* dst[key]: appended to the per-step list, or (once: the steady values)
 * the value itself. Steals value. */
static void put(json_t *dst, const char *key, json_t *value, int once)
{
    if (once)
        json_object_set_new(dst, key, value);
    else
        dkf_json_append(dst, key, value);
}

static void record_local(json_t *dst, const wf_runner_t *u, int steady_keys)
{
    if (!steady_keys) {
        put(dst, "x_local", per_node(u, 0), steady_keys);
        put(dst, "s_local", per_node(u, 3), steady_keys);
    }
    put(dst, "K", per_node(u, 1), steady_keys);
    put(dst, "Sigma_pred", per_node(u, 2), steady_keys);
    put(dst, "P_ij", pij_json(u), steady_keys);
}

static void record_scalar(json_t *dst, const wf_runner_t *u, int steady_keys)
{
    put(dst, "w", mat_json(&u->fu.w, 1), steady_keys);
    put(dst, "P_S", mat_json(&u->fu.PS, 0), steady_keys);
    if (!steady_keys) put(dst, "s_fused", json_real((double)u->fu.s0), steady_keys);
    put(dst, "P_S0", json_real((double)u->fu.PS0), steady_keys);
}

static void record_matrix(json_t *dst, const wf_runner_t *u, int steady_keys)
{
    put(dst, "matrix_weights", weights_json(u), steady_keys);
    if (!steady_keys) {
        put(dst, "matrix_weights_unique", json_boolean(u->fu.A_unique), steady_keys);
        put(dst, "x_fused_matrix", mat_json(&u->fu.xf, 1), steady_keys);
    }
    put(dst, "P0_matrix", mat_json(&u->fu.Pf, 0), steady_keys);
}

static int fuse(wf_runner_t *u, char *err, size_t errlen, long k)
{
    dkf_status_t st = dkf_wfusion_fuse_scalar(&u->fu, NULL);
    if (st != DKF_OK) return fail_core(u, err, errlen, k, "dkf_wfusion_fuse_scalar", st);
    st = dkf_wfusion_fuse_matrix(&u->fu, NULL);
    if (st != DKF_OK) return fail_core(u, err, errlen, k, "dkf_wfusion_fuse_matrix", st);
    return DKF_EXIT_OK;
}

/* central_kf: the stacked model H = [H_1; ...; H_l], R = blkdiag(R_i) and
 * a Kalman filter from the common prior. 0, or -1 (out of memory, or a
 * stack above DKF_MAX_DIM: *st says which). */
static int central_setup(wf_runner_t *u, dkf_status_t *st)
{
    const size_t n = u->mdl.n;
    size_t i, r, c, row = 0, ms = 0;
    for (i = 0; i < u->mdl.l; ++i) ms += u->mdl.m[i];
    u->ms = ms;
    u->kmem = calloc(DKF_KF_STORAGE_LEN(n, ms), sizeof *u->kmem);
    u->Hc = calloc(ms * n, sizeof *u->Hc);
    u->Rc = calloc(ms * ms, sizeof *u->Rc);
    u->yc = calloc(ms, sizeof *u->yc);
    *st = DKF_ERR_CAPACITY;
    if (u->kmem == NULL || u->Hc == NULL || u->Rc == NULL || u->yc == NULL) return -1;
    for (i = 0; i < u->mdl.l; row += u->mdl.m[i], ++i)
        for (r = 0; r < u->mdl.m[i]; ++r) {
            for (c = 0; c < n; ++c) u->Hc[(row + r) * n + c] = u->mdl.H[i].data[r * n + c];
            for (c = 0; c < u->mdl.m[i]; ++c)
                u->Rc[(row + r) * ms + row + c] = u->mdl.R[i].data[r * u->mdl.m[i] + c];
        }
    if (dkf_mat_init(&u->mHc, ms, n, u->Hc) != DKF_OK || dkf_mat_init(&u->mRc, ms, ms, u->Rc) != DKF_OK ||
        dkf_mat_init(&u->myc, ms, 1, u->yc) != DKF_OK)
        return -1;
    u->cmeas.H = &u->mHc;
    u->cmeas.R = &u->mRc;
    *st = dkf_kf_init(&u->kf, n, ms, u->kmem, DKF_KF_STORAGE_LEN(n, ms), &u->mdl.x0, &u->mdl.P0);
    return *st == DKF_OK ? 0 : -1;
}

/* central_kf's step t: predict, then the stacked update with y(t). */
static int central_step(wf_runner_t *u, char *err, size_t errlen, long k)
{
    size_t i, j, row = 0;
    dkf_status_t st;
    for (i = 0; i < u->mdl.l; row += u->mdl.m[i], ++i)
        for (j = 0; j < u->mdl.m[i]; ++j) u->yc[row + j] = u->mdl.y[i].data[j];
    if ((st = dkf_kf_predict(&u->kf, &u->mdl.dyn, NULL)) != DKF_OK)
        return fail_core(u, err, errlen, k, "dkf_kf_predict", st);
    if ((st = dkf_kf_update(&u->kf, &u->cmeas, &u->myc)) != DKF_OK)
        return fail_core(u, err, errlen, k, "dkf_kf_update", st);
    return DKF_EXIT_OK;
}

static dkf_runner_t *wf_create(const dkf_filter_t *fl, const dkf_run_opts_t *o,
                               const dkf_scenario_t *s, char *err, size_t errlen, int *rc)
{
    wf_runner_t *u = dkf_runner_calloc(sizeof *u, s, err, errlen, rc);
    dkf_status_t st;
    if (u == NULL) return NULL;
    u->fl = fl;
    u->s = s;
    u->kind = *(const wf_kind_t *)fl->impl;
    if (dkf_wf_model_load(s, &u->mdl, err, errlen) != 0) {
        free(u);
        *rc = DKF_EXIT_USAGE;
        return NULL;
    }
    u->len = dkf_wfusion_storage_len(u->mdl.n, u->mdl.l, u->mdl.m);
    u->nodes = calloc(u->mdl.l, sizeof *u->nodes);
    u->mem = u->len > 0 ? calloc(u->len, sizeof *u->mem) : NULL;
    u->sq_local = calloc(u->mdl.l, sizeof *u->sq_local);
    u->series = o->record ? json_object() : NULL;
    u->once = o->record ? json_object() : NULL;
    if (u->nodes == NULL || u->mem == NULL || u->sq_local == NULL ||
        (o->record && (u->series == NULL || u->once == NULL))) {
        *rc = dkf_failf(err, errlen, u->len == 0 ? DKF_EXIT_RUN : DKF_EXIT_USAGE,
                        u->len == 0 ? "%s: %s: dkf_wfusion_storage_len: 0 (dimensions above "
                                      "DKF_MAX_DIM)"
                                    : "%s: %s: out of memory",
                        s->file, fl->label);
        wf_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    st = dkf_wfusion_init(&u->fu, u->mdl.n, u->mdl.l, u->mdl.m, u->nodes, u->mem, u->len,
                          &u->mdl.Hs, &u->mdl.x0, &u->mdl.P0);
    if (st != DKF_OK) {
        *rc = fail_core(u, err, errlen, -1, "dkf_wfusion_init", st);
        wf_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    if (u->kind == WF_CENTRAL && central_setup(u, &st) != 0) {
        *rc = fail_core(u, err, errlen, -1, "dkf_kf_init (the stacked sensors)", st);
        wf_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    if (u->kind == WF_SELFTUNE && (u->st = st_setup(fl, s, err, errlen, rc)) == NULL) {
        wf_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    if (u->kind == WF_STEADY) {
        st = dkf_wfusion_steady(&u->fu, &u->mdl.dyn, u->mdl.meas);
        if (st != DKF_OK) {
            *rc = fail_core(u, err, errlen, -1, "dkf_wfusion_steady", st);
            wf_destroy((dkf_runner_t *)(void *)u);
            return NULL;
        }
        if ((*rc = fuse(u, err, errlen, -1)) != DKF_EXIT_OK) {
            wf_destroy((dkf_runner_t *)(void *)u);
            return NULL;
        }
        if (u->once != NULL) {
            record_local(u->once, u, 1);
            record_scalar(u->once, u, 1);
            record_matrix(u->once, u, 1);
        }
    }
    *rc = DKF_EXIT_OK;
    return (dkf_runner_t *)(void *)u;
}

static void errors_at(wf_runner_t *u, long k)
{
    const double *xt = dkf_scn_truth(u->s, k);
    const size_t n = u->mdl.n;
    double st = 0.0, e;
    size_t i, j;
    if (xt == NULL) return;
    for (j = 0; j < n; ++j) st += (double)u->mdl.Hs.data[j] * xt[j];
    for (i = 0; i < u->mdl.l; ++i)
        for (j = 0; j < n; ++j) {
            e = (double)u->fu.nodes[i].x.data[j] - xt[j];
            u->sq_local[i] += e * e;
        }
    for (j = 0; j < n; ++j) {
        e = (double)u->fu.xf.data[j] - xt[j];
        u->sq_x += e * e;
    }
    e = (double)u->fu.s0 - st;
    u->sq_s += e * e;
    if (u->kind == WF_CENTRAL)
        for (j = 0; j < n; ++j) {
            e = (double)u->kf.x.data[j] - xt[j];
            u->sq_c += e * e;
        }
    u->nerr++;
}

static int wf_step(dkf_runner_t *r, long k, char *err, size_t errlen)
{
    wf_runner_t *u = (wf_runner_t *)(void *)r;
    dkf_status_t st;
    int rc;
    if (dkf_wf_model_y(&u->mdl, u->s, k) != 0)
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: step t=%ld: no measurement", u->s->file,
                         k);
    if (u->st != NULL) {
        /* the identifier on y(t), then the model of its estimate for the step */
        wf_st_t *id = u->st;
        size_t i;
        for (i = 0; i < u->mdl.l; ++i) id->ybar_in[i] = u->mdl.y[i].data[0];
        if ((st = dkf_selftune_update(&id->id, id->ybar_in)) != DKF_OK)
            return fail_core(u, err, errlen, k, "dkf_selftune_update", st);
        if ((st = dkf_selftune_estimate(&id->id, &id->est)) != DKF_OK)
            return fail_core(u, err, errlen, k, "dkf_selftune_estimate", st);
        if ((st = dkf_selftune_model(&id->id, &id->est, &id->F, &id->Q)) != DKF_OK)
            return fail_core(u, err, errlen, k, "dkf_selftune_model", st);
    }
    st = dkf_wfusion_step(&u->fu, u->st != NULL ? &u->st->dyn : &u->mdl.dyn, u->mdl.meas,
                          u->mdl.y);
    if (st != DKF_OK) return fail_core(u, err, errlen, k, "dkf_wfusion_step", st);
    if ((rc = fuse(u, err, errlen, k)) != DKF_EXIT_OK) return rc;
    if (u->kind == WF_CENTRAL && (rc = central_step(u, err, errlen, k)) != DKF_EXIT_OK) return rc;
    if (!u->fu.A_unique) u->nonunique++;
    errors_at(u, k);
    if (u->series == NULL) return DKF_EXIT_OK;
    switch (u->kind) {
    case WF_LOCAL: record_local(u->series, u, 0); break;
    case WF_SCALAR: record_scalar(u->series, u, 0); break;
    case WF_MATRIX: record_matrix(u->series, u, 0); break;
    case WF_CENTRAL:
        dkf_json_append(u->series, "x_central", mat_json(&u->kf.x, 1));
        dkf_json_append(u->series, "P_central", mat_json(&u->kf.P, 0));
        break;
    case WF_STEADY:
        dkf_json_append(u->series, "steps_x_local", per_node(u, 0));
        dkf_json_append(u->series, "steps_s_fused", json_real((double)u->fu.s0));
        dkf_json_append(u->series, "steps_x_fused_matrix", mat_json(&u->fu.xf, 1));
        break;
    case WF_SELFTUNE: {
        const dkf_selftune_est_t *e = &u->st->est;
        json_t *a = json_array();
        size_t j;
        for (j = 0; j < e->na; ++j) json_array_append_new(a, json_real((double)e->a[j]));
        dkf_json_append(u->series, "a_hat", a);
        dkf_json_append(u->series, "c1_hat", json_real((double)e->c1));
        dkf_json_append(u->series, "sigma_w2_hat", json_real((double)e->sigma_w2));
        dkf_json_append(u->series, "guard", json_integer((json_int_t)e->guard));
        record_scalar(u->series, u, 0);
        dkf_json_append(u->series, "x_fused_matrix", mat_json(&u->fu.xf, 1));
        break;
    }
    }
    return DKF_EXIT_OK;
}

/* fusion_steady's steady values (once, first), then the step's values. */
static void wf_record(dkf_runner_t *r, dkf_out_t *out)
{
    const wf_runner_t *u = (const wf_runner_t *)(const void *)r;
    char path[128];
    const char *key;
    json_t *v;
    json_object_foreach(u->once, key, v) {
        snprintf(path, sizeof path, "outputs.%s.%s", u->fl->label, key);
        dkf_out_value(out, path, json_incref(v));
    }
    json_object_clear(u->once);
    dkf_out_outputs(out, u->fl->label, u->series);
}

static void wf_summary(const dkf_runner_t *r, FILE *out)
{
    const wf_runner_t *u = (const wf_runner_t *)(const void *)r;
    const dkf_scenario_t *s = u->s;
    const double ne = (double)u->nerr;
    double tr = 0.0;
    size_t i;
    for (i = 0; i < u->mdl.n; ++i) tr += (double)u->fu.Pf.data[i * u->mdl.n + i];
    fprintf(out, "scenario %s case %s: %zu steps, %zu sensors, n = %zu; filter %s (%s)\n",
            s->file, s->case_name != NULL ? s->case_name : "", s->steps, u->mdl.l, u->mdl.n,
            u->fl->name, DKF_USE_FLOAT ? "float" : "double");
    fprintf(out, "  last step: P_S0 %.9g, tr P0_matrix %.9g; matrix weights not unique at "
            "%zu steps\n", (double)u->fu.PS0, tr,
            u->nonunique);
    if (u->st != NULL) {
        const dkf_selftune_est_t *e = &u->st->est;
        fprintf(out, "  identified (accepted at t = %zu, last guard %d): a =", e->t_accepted,
                (int)e->guard);
        for (i = 0; i < e->na; ++i) fprintf(out, " %.6g", (double)e->a[i]);
        fprintf(out, ", c1 = %.6g, sigma_w^2 = %.6g; the file's: a =", (double)e->c1,
                (double)e->sigma_w2);
        for (i = 0; i < e->na; ++i) fprintf(out, " %.6g", (double)u->st->a_file[i]);
        fprintf(out, ", c1 = %.6g, sigma_w^2 = %.6g\n", (double)u->st->c1_file,
                (double)u->st->sigma_w2_file);
    }
    if (u->nerr == 0) {
        fprintf(out, "  (no x_true: no errors)\n");
        return;
    }
    fprintf(out, "  RMSE against x_true over %zu steps:\n", u->nerr);
    for (i = 0; i < u->mdl.l; ++i)
        fprintf(out, "    local[%zu]        x %.6g\n", i,
                sqrt(u->sq_local[i] / (ne * (double)u->mdl.n)));
    fprintf(out, "    fused (matrix)  x %.6g\n", sqrt(u->sq_x / (ne * (double)u->mdl.n)));
    fprintf(out, "    fused (scalar)  s %.6g\n", sqrt(u->sq_s / ne));
    if (u->kind == WF_CENTRAL)
        fprintf(out, "    centralized     x %.6g\n", sqrt(u->sq_c / (ne * (double)u->mdl.n)));
}

/* ---- the registry family ---- */

extern const dkf_family_t dkf_family_wfusion;
static const wf_kind_t kinds[] = {WF_LOCAL, WF_SCALAR, WF_MATRIX, WF_STEADY, WF_SELFTUNE,
                                  WF_CENTRAL};
static const dkf_filter_t filters[] = {
    {"local_kf", "LOCAL_KF",
     "seed 002: every sensor's local KF (Theorem 1) and the\n"
     "                           cross covariances P_ij (dkf/wfusion.h)",
     0, &dkf_family_wfusion, &kinds[0]},
    {"fusion_scalar", "FUSION_SCALAR",
     "seed 002: scalar-weight fusion of the signal s = Hs x\n"
     "                           (Theorem 2): w, P_S, s_fused, P_S0",
     0, &dkf_family_wfusion, &kinds[1]},
    {"fusion_matrix", "FUSION_MATRIX",
     "seed 002: matrix-weight fusion of x (Sun and Deng):\n"
     "                           matrix_weights, x_fused_matrix, P0_matrix",
     0, &dkf_family_wfusion, &kinds[2]},
    {"fusion_steady", "FUSION_STEADY",
     "seed 002: the steady local filters and weights (DARE,\n"
     "                           Stein): steady_state's keys once, then the steady estimates",
     0, &dkf_family_wfusion, &kinds[3]},
    {"fusion_selftune", "FUSION_SELFTUNE",
     "seed 002: self-tuning fusion (dkf/selftune.h): A, C,\n"
     "                           sigma_w^2 identified from the y_i, filters on the estimate",
     0, &dkf_family_wfusion, &kinds[4]},
    {"central_kf", "CENTRAL_KF",
     "seed 002: the centralized KF of the stacked sensors beside\n"
     "                           the fusion (the bound): x_central, P_central",
     0, &dkf_family_wfusion, &kinds[5]},
};
const dkf_family_t dkf_family_wfusion = {
    "wfusion", filters, sizeof filters / sizeof filters[0], 1u << DKF_SCN_LAYOUT_WFCASES,
    wf_check, wf_create, wf_step, wf_record, NULL, NULL, wf_summary, wf_destroy,
    &dkf_host_wfusion_node_ops, NULL,
};
