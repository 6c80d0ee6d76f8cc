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
 *                  s_fused, P_S0 (and w_unique)
 *   fusion_matrix  the matrix-weight fusion of x (Sun and Deng):
 *                  matrix_weights (the blocks A_i), matrix_weights_unique,
 *                  x_fused_matrix, P0_matrix
 *   fusion_steady  the steady filters (dkf_wfusion_steady, DARE + Stein)
 *                  from the prior: steady_state's keys once (K, Sigma_pred,
 *                  P_ij, P_S, w, P_S0, matrix_weights, P0_matrix), then per
 *                  step x_local, s_fused, x_fused_matrix of the steady
 *                  filters (steps_x_local, steps_s_fused, steps_x_fused_matrix)
 *
 * Every filter runs the whole fusion (dkf_wfusion_step, fuse_scalar,
 * fuse_matrix at every step); the filter chooses what is recorded, under
 * outputs.<LABEL> with the vector's key names, every per-step key a list
 * over steps, so tools/dkf_compare.py compares it with
 * cases[c].steps[*].expected (and fusion_steady with cases[c].steady_state).
 * The summary gives the RMSE of every local filter's x and of the fused
 * x and s against x_true, when the file has it. The node role
 * (est_wfusion_node.c: one sensor's local KF for dkf-node; its fusion
 * centre is net/wfusion_centre.c, docs/network.md).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/wfusion.h"
#include "est_internal.h"
#include "registry.h"
#include "util.h"
#include "wf_model.h"

typedef enum { WF_LOCAL, WF_SCALAR, WF_MATRIX, WF_STEADY } wf_kind_t;

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
    /* squared errors against x_true: every local x_i, fused x, fused s */
    double *sq_local;
    double sq_x, sq_s;
    size_t nerr;
    size_t nonunique; /* steps where the matrix weights were not unique */
} wf_runner_t;

static int wf_check(const dkf_filter_t *fl, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                    char *err, size_t errlen)
{
    (void)o;
    if (s->layout != DKF_SCN_LAYOUT_WFCASES)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases: filter %s needs a weighted-fusion case (Phi, Gamma, Qe, "
                         "H, R, H_signal: docs/scenario-format.md, \"Weighted-fusion cases\")",
                         s->file, fl->name);
    if (s->n * s->nsensors + s->n > DKF_MAX_DIM)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases[%zu].H: %zu sensors of state n = %zu: the fusion's KKT "
                         "system is n l + n = %zu, above DKF_MAX_DIM = %d", s->file,
                         s->case_index, s->nsensors, s->n, s->n * s->nsensors + s->n,
                         DKF_MAX_DIM);
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
    json_decref(u->series);
    free(u);
}

static int fail_core(const wf_runner_t *u, char *err, size_t errlen, long k, const char *call,
                     dkf_status_t st)
{
    if (k < 0)
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: %s: %s failed: %s (%d)", u->s->file,
                         u->fl->label, call, dkf_status_str(st), (int)st);
    return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: step t=%ld: %s: %s failed: %s (%d)",
                     u->s->file, k, u->fl->label, call, dkf_status_str(st), (int)st);
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
        put(dst, "x_fused_matrix", mat_json(&u->fu.x0, 1), steady_keys);
    }
    put(dst, "P0_matrix", mat_json(&u->fu.P0, 0), steady_keys);
}

static int fuse(wf_runner_t *u, char *err, size_t errlen, long k)
{
    dkf_status_t st = dkf_wfusion_fuse_scalar(&u->fu, NULL);
    if (st != DKF_OK) return fail_core(u, err, errlen, k, "dkf_wfusion_fuse_scalar", st);
    st = dkf_wfusion_fuse_matrix(&u->fu, NULL);
    if (st != DKF_OK) return fail_core(u, err, errlen, k, "dkf_wfusion_fuse_matrix", st);
    return DKF_EXIT_OK;
}

static dkf_runner_t *wf_create(const dkf_filter_t *fl, const dkf_run_opts_t *o,
                               const dkf_scenario_t *s, char *err, size_t errlen, int *rc)
{
    wf_runner_t *u = calloc(1, sizeof *u);
    dkf_status_t st;
    if (u == NULL) {
        *rc = dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
        return NULL;
    }
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
    if (u->nodes == NULL || u->mem == NULL || u->sq_local == NULL ||
        (o->record && u->series == NULL)) {
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
        if (u->series != NULL) {
            record_local(u->series, u, 1);
            record_scalar(u->series, u, 1);
            record_matrix(u->series, u, 1);
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
        e = (double)u->fu.x0.data[j] - xt[j];
        u->sq_x += e * e;
    }
    e = (double)u->fu.s0 - st;
    u->sq_s += e * e;
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
    st = dkf_wfusion_step(&u->fu, &u->mdl.dyn, u->mdl.meas, u->mdl.y);
    if (st != DKF_OK) return fail_core(u, err, errlen, k, "dkf_wfusion_step", st);
    if ((rc = fuse(u, err, errlen, k)) != DKF_EXIT_OK) return rc;
    if (!u->fu.A_unique) u->nonunique++;
    errors_at(u, k);
    if (u->series == NULL) return DKF_EXIT_OK;
    switch (u->kind) {
    case WF_LOCAL: record_local(u->series, u, 0); break;
    case WF_SCALAR: record_scalar(u->series, u, 0); break;
    case WF_MATRIX: record_matrix(u->series, u, 0); break;
    case WF_STEADY:
        dkf_json_append(u->series, "steps_x_local", per_node(u, 0));
        dkf_json_append(u->series, "steps_s_fused", json_real((double)u->fu.s0));
        dkf_json_append(u->series, "steps_x_fused_matrix", mat_json(&u->fu.x0, 1));
        break;
    }
    return DKF_EXIT_OK;
}

static void wf_record(const dkf_runner_t *r, json_t *doc)
{
    const wf_runner_t *u = (const wf_runner_t *)(const void *)r;
    json_t *outs = json_object();
    json_object_set_new(outs, u->fl->label, json_copy(u->series));
    json_object_set_new(doc, "outputs", outs);
}

static void wf_summary(const dkf_runner_t *r, FILE *out)
{
    const wf_runner_t *u = (const wf_runner_t *)(const void *)r;
    const dkf_scenario_t *s = u->s;
    const double ne = (double)u->nerr;
    double tr = 0.0;
    size_t i;
    for (i = 0; i < u->mdl.n; ++i) tr += (double)u->fu.P0.data[i * u->mdl.n + i];
    fprintf(out, "scenario %s case %s: %zu steps, %zu sensors, n = %zu; filter %s (%s)\n",
            s->file, s->case_name != NULL ? s->case_name : "", s->steps, u->mdl.l, u->mdl.n,
            u->fl->name, DKF_USE_FLOAT ? "float" : "double");
    fprintf(out, "  last step: P_S0 %.9g, tr P0_matrix %.9g; matrix weights not unique at "
            "%zu steps\n", (double)u->fu.PS0, tr,
            u->nonunique);
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
}

/* ---- the registry family ---- */

extern const dkf_family_t dkf_family_wfusion;
static const wf_kind_t kinds[] = {WF_LOCAL, WF_SCALAR, WF_MATRIX, WF_STEADY};
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
};
const dkf_family_t dkf_family_wfusion = {
    "wfusion", filters, sizeof filters / sizeof filters[0], 1u << DKF_SCN_LAYOUT_WFCASES,
    wf_check, wf_create, wf_step, wf_record, NULL, wf_summary, wf_destroy,
    &dkf_wfusion_node_ops,
};
