/*
 * estimator.c - core filters driven over a scenario, with JSON recording
 * (estimator.h). What every kind shares: sensor groups (a stacked
 * estimator has one group holding all its sensors, H stacked and R, D, B,
 * Rd block-diagonal; a fused one has a group per sensor), loading a step's
 * model, the step sequence, errors against the truth. The kinds
 * themselves, each with its own state: families/est_kf.c, est_info.c,
 * est_diffkf.c, est_askf.c, est_otskf.c.
 */
#include "est_kind.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "status_text.h"
#include "util.h"

/* Key names of the two golden-vector families (see estimator.h). */
static const dkf_est_names_t canonical_names = {"xp", "Pp", "xf", "Pf", "yp", "Yp", "yf", "Yf",
                                                "i", "I"};
static const dkf_est_names_t cases_names = {"x_pred", "P_pred", "x", "P", "y_pred", "Y_pred",
                                            "y", "Y", "i", "I"};

/* ---- model loading and recording ------------------------------------------------ */

void dkf_est_record_mat(dkf_est_t *e, const char *key, const dkf_mat_t *A, int as_vector)
{
    if (e->opts.no_record) return;
    dkf_json_append(e->series, key, dkf_json_from_mat(A, as_vector));
}

void dkf_est_load_FQ(dkf_est_t *e, long k)
{
    size_t n = e->n;
    /* The loader (and dkf_scn_require_ui) checked coverage of every per_k list. */
    dkf_scn_to_real(e->F.data, dkf_scn_at(dkf_scn_model(e->s, "F"), (size_t)k), n * n);
    dkf_scn_to_real(e->Q.data, dkf_scn_at(dkf_scn_model(e->s, "Q"), (size_t)k), n * n);
}

/* Entry (r0 + r, c0 + c) of D = src (rows x cols doubles). */
static void put_block(dkf_mat_t *D, size_t r0, size_t c0, const double *src, size_t rows,
                      size_t cols)
{
    size_t r, c;
    for (r = 0; r < rows; ++r)
        for (c = 0; c < cols; ++c) DKF_AT(D, r0 + r, c0 + c) = (dkf_real_t)src[r * cols + c];
}

static void zero(dkf_mat_t *M)
{
    memset(M->data, 0, M->rows * M->cols * sizeof *M->data);
}

/* H_k stacked; R_k, A_k block-diagonal; y_k stacked over the group's sensors. */
void dkf_est_group_meas(dkf_est_group_t *g, const dkf_scenario_t *s, long k)
{
    size_t j, r0 = 0, c0 = 0, n = g->H.cols;
    zero(&g->R);
    if (g->p > 0) zero(&g->D);
    for (j = 0; j < g->nsens; ++j) {
        size_t si = g->idx[j], m = s->sensors[si].m;
        put_block(&g->H, r0, 0, dkf_scn_at(dkf_scn_sensor_model(s, si, "H"), (size_t)k), m, n);
        put_block(&g->R, r0, r0, dkf_scn_at(dkf_scn_sensor_model(s, si, "R"), (size_t)k), m, m);
        dkf_scn_to_real(g->y.data + r0, dkf_scn_y(s, si, k), m);
        if (g->p > 0) {
            const dkf_scn_mat_t *D = dkf_scn_sensor_model(s, si, "D");
            put_block(&g->D, r0, c0, dkf_scn_at(D, (size_t)k), m, D->cols);
            c0 += D->cols;
        }
        r0 += m;
    }
}

/* B_k, Rd_k block-diagonal over the group's sensors. */
void dkf_est_group_load_dyn(dkf_est_group_t *g, const dkf_scenario_t *s, long k)
{
    size_t j, c0 = 0;
    zero(&g->B);
    zero(&g->Rd);
    for (j = 0; j < g->nsens; ++j) {
        size_t si = g->idx[j], p = dkf_scn_sensor_model(s, si, "D")->cols;
        put_block(&g->B, c0, c0, dkf_scn_at(dkf_scn_sensor_model(s, si, "B"), (size_t)k), p, p);
        put_block(&g->Rd, c0, c0, dkf_scn_at(dkf_scn_sensor_model(s, si, "Rd"), (size_t)k), p,
                  p);
        c0 += p;
    }
}

dkf_ui_dyn_t dkf_est_group_dyn(dkf_est_t *e, dkf_est_group_t *g)
{
    dkf_ui_dyn_t d;
    d.F = &e->F;
    d.Q = &e->Q;
    d.B = &g->B;
    d.Rd = &g->Rd;
    return d;
}

/* d_{0|0}, P_{d0|0} (p doubles each way) from init or the options. */
void dkf_est_input_prior(const dkf_est_t *e, size_t p, dkf_real_t *d0, dkf_real_t *Pd0)
{
    const double *d = e->opts.d00 != NULL ? e->opts.d00 : dkf_scn_at(dkf_scn_init(e->s, "d00"), 0);
    const double *Pd = dkf_scn_at(dkf_scn_init(e->s, "Pd00"), 0);
    double scale = e->opts.Pd00_scale > 0 ? e->opts.Pd00_scale : 1.0;
    size_t i;
    dkf_scn_to_real(d0, d, p);
    for (i = 0; i < p * p; ++i) Pd0[i] = (dkf_real_t)(scale * Pd[i]);
}

/* ---- groups and the estimator ----------------------------------------------------- */

static int group_init(dkf_est_group_t *g, const dkf_scenario_t *s, const size_t *idx, size_t count,
                      size_t n, int needs_ui)
{
    size_t j, m = 0, p = 0, len;
    dkf_real_t *q;
    for (j = 0; j < count; ++j) {
        m += s->sensors[idx[j]].m;
        if (needs_ui) p += dkf_scn_sensor_model(s, idx[j], "D")->cols;
    }
    g->nsens = count;
    g->m = m;
    g->p = p;
    g->idx = malloc(count * sizeof *g->idx);
    if (g->idx == NULL) return -1;
    memcpy(g->idx, idx, count * sizeof *idx);
    len = m * n + m * m + m + m * p + 2 * p * p;
    g->buf = q = calloc(len, sizeof *g->buf);
    if (q == NULL) return -1;
    g->H = (dkf_mat_t)DKF_MAT(m, n, q);
    q += m * n;
    g->R = (dkf_mat_t)DKF_MAT(m, m, q);
    q += m * m;
    g->y = (dkf_mat_t)DKF_MAT(m, 1, q);
    q += m;
    g->D = (dkf_mat_t)DKF_MAT(m, p, q);
    q += m * p;
    g->B = (dkf_mat_t)DKF_MAT(p, p, q);
    q += p * p;
    g->Rd = (dkf_mat_t)DKF_MAT(p, p, q);
    g->meas.H = &g->H;
    g->meas.D = &g->D;
    g->meas.R = &g->R;
    return 0;
}

dkf_est_t *dkf_est_create(const dkf_est_kind_t *kind, dkf_est_mode_t mode,
                          const dkf_scenario_t *s, const size_t *sensors, size_t count,
                          const double *P00, const dkf_est_opts_t *opts, char *err,
                          size_t errlen)
{
    dkf_est_t *e;
    dkf_real_t *q;
    dkf_mat_t x0, P0;
    dkf_status_t st;
    const char *what = "?";
    size_t j, n = s->n, N = s->steps;

    if (kind == NULL || count == 0 || (mode == DKF_EST_FUSED && !kind->fused)) {
        snprintf(err, errlen, "unsupported estimator configuration");
        return NULL;
    }
    e = calloc(1, sizeof *e);
    if (e == NULL) goto oom;
    e->kind = kind;
    e->mode = mode;
    e->s = s;
    e->n = n;
    if (opts != NULL) e->opts = *opts;
    e->names = s->layout == DKF_SCN_LAYOUT_CASES ? &cases_names : &canonical_names;
    e->ngroups = mode == DKF_EST_FUSED ? count : 1;
    e->groups = calloc(e->ngroups, sizeof *e->groups);
    e->state = calloc(1, kind->state_size);
    e->FQ = calloc(3 * n * n + 2 * n, sizeof *e->FQ);
    e->sq = calloc(n, sizeof *e->sq);
    e->err_f = calloc(N, sizeof *e->err_f);
    e->err_p = calloc(N, sizeof *e->err_p);
    e->series = json_object();
    if (e->groups == NULL || e->state == NULL || e->FQ == NULL ||
        e->sq == NULL || e->err_f == NULL || e->err_p == NULL || e->series == NULL)
        goto oom;
    for (j = 0; j < N; ++j) e->err_f[j] = e->err_p[j] = NAN;
    for (j = 0; j < e->ngroups; ++j) {
        int rc = mode == DKF_EST_FUSED
                     ? group_init(&e->groups[j], s, &sensors[j], 1, n, e->kind->needs_ui)
                     : group_init(&e->groups[j], s, sensors, count, n, e->kind->needs_ui);
        if (rc != 0) goto oom;
    }
    q = e->FQ;
    e->F = (dkf_mat_t)DKF_MAT(n, n, q);
    e->Q = (dkf_mat_t)DKF_MAT(n, n, q + n * n);
    P0 = (dkf_mat_t)DKF_MAT(n, n, q + 2 * n * n);
    x0 = (dkf_mat_t)DKF_MAT(n, 1, q + 3 * n * n);
    e->xpk = (dkf_mat_t)DKF_MAT(n, 1, q + 3 * n * n + n);
    dkf_scn_to_real(x0.data, dkf_scn_at(dkf_scn_init(s, "x00"), 0), n);
    dkf_scn_to_real(P0.data, P00, n * n);
    st = e->kind->init(e, &x0, &P0, &what);
    if (st != DKF_OK) {
        char text[DKF_STATUS_TEXT_LEN];
        snprintf(err, errlen, "%s failed: %s", what, dkf_host_status_text(text, sizeof text, what, st));
        dkf_est_free(e);
        return NULL;
    }
    return e;
oom:
    snprintf(err, errlen, "out of memory");
    dkf_est_free(e);
    return NULL;
}

void dkf_est_free(dkf_est_t *e)
{
    size_t j;
    if (e == NULL) return;
    if (e->state != NULL && e->kind->release != NULL) e->kind->release(e);
    for (j = 0; e->groups != NULL && j < e->ngroups; ++j) {
        free(e->groups[j].idx);
        free(e->groups[j].buf);
    }
    free(e->groups);
    free(e->state);
    free(e->FQ);
    free(e->sq);
    free(e->err_f);
    free(e->err_p);
    free(e->storage);
    json_decref(e->series);
    free(e);
}

static double sqdist(const dkf_real_t *x, const double *t, size_t n)
{
    double s = 0;
    size_t i;
    for (i = 0; i < n; ++i) {
        double d = (double)x[i] - t[i];
        s += d * d;
    }
    return s;
}

/* Squared errors of step k, and (x_{k|k} - truth_k)^2 per component. */
static void accumulate_error(dkf_est_t *e, long k)
{
    const double *t = dkf_scn_truth(e->s, k);
    size_t i;
    if (t == NULL) return;
    e->err_f[k - 1] = sqdist(e->x->data, t, e->n);
    e->err_p[k - 1] = sqdist(e->xpk.data, t, e->n);
    for (i = 0; i < e->n; ++i) {
        double d = (double)e->x->data[i] - t[i];
        e->sq[i] += d * d;
    }
    e->nsq++;
}

/* Predict with the dynamics at k-1, update with the model and y at k. */
static dkf_status_t predict_update_step(dkf_est_t *e, long k, const char **what)
{
    dkf_status_t st;
    size_t j;
    dkf_est_load_FQ(e, k - 1);
    if (e->kind->needs_ui) dkf_est_group_load_dyn(&e->groups[0], e->s, k - 1);
    st = e->kind->predict(e, what);
    if (st != DKF_OK) return st;
    memcpy(e->xpk.data, e->x->data, e->n * sizeof *e->xpk.data);
    dkf_est_record_mat(e, e->names->xp, e->x, 1);
    dkf_est_record_mat(e, e->names->Pp, e->P, 0);
    for (j = 0; j < e->ngroups; ++j) dkf_est_group_meas(&e->groups[j], e->s, k);
    return e->kind->update(e, what);
}

dkf_status_t dkf_est_step(dkf_est_t *e, long k, const char **what)
{
    dkf_status_t st;
    if (k < 1 || (size_t)k > e->s->steps) {
        *what = "dkf_est_step (k outside 1..N)";
        return DKF_ERR_ARG;
    }
    st = e->kind->step != NULL ? e->kind->step(e, k, what) : predict_update_step(e, k, what);
    if (st != DKF_OK) return st;
    dkf_est_record_mat(e, e->names->xf, e->x, 1);
    dkf_est_record_mat(e, e->names->Pf, e->P, 0);
    accumulate_error(e, k);
    return DKF_OK;
}

json_t *dkf_est_series(const dkf_est_t *e)
{
    return e->series;
}

const double *dkf_est_sqerr(const dkf_est_t *e, int predicted)
{
    return predicted ? e->err_p : e->err_f;
}

double dkf_est_trace_P(const dkf_est_t *e)
{
    double t = 0;
    size_t i;
    for (i = 0; i < e->n; ++i) t += (double)DKF_AT(e->P, i, i);
    return t;
}

size_t dkf_est_rmse(const dkf_est_t *e, double *rmse, double *rmse_comp)
{
    double tot = 0;
    size_t i;
    for (i = 0; i < e->n; ++i) {
        double c = e->nsq > 0 ? sqrt(e->sq[i] / (double)e->nsq) : NAN;
        tot += e->sq[i];
        if (rmse_comp != NULL) rmse_comp[i] = c;
    }
    if (rmse != NULL) *rmse = e->nsq > 0 ? sqrt(tot / ((double)e->nsq * (double)e->n)) : NAN;
    return e->nsq;
}
