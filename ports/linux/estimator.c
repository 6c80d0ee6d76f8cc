/*
 * estimator.c - core filters driven over a scenario, with JSON recording.
 *
 * Each filter kind is one row of `kinds` (init / predict / update plus the
 * state it exposes); adding a filter means adding a row and its three
 * functions. Sensors are grouped: a stacked estimator has one group holding
 * all its sensors (H stacked, R block-diagonal), a fused one has a group per
 * sensor whose information contributions are summed.
 */
#include "estimator.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/info.h"
#include "dkf/kf.h"

typedef struct {
    const char *xp, *Pp, *xf, *Pf, *yp, *Yp, *yf, *Yf, *i, *I;
} names_t;

/* Key names of the two golden-vector families (see estimator.h). */
static const names_t canonical_names = {"xp", "Pp", "xf", "Pf", "yp", "Yp", "yf", "Yf", "i", "I"};
static const names_t cases_names = {"x_pred", "P_pred", "x", "P", "y_pred", "Y_pred",
                                    "y", "Y", "i", "I"};

/* One measurement the filter takes per step: sensors stacked. */
typedef struct {
    size_t nsens;
    size_t *idx;
    size_t m;
    dkf_real_t *buf; /* H, R, y, i, I, contribution work */
    dkf_mat_t H, R, y;
    dkf_mat_t i, I;  /* information contribution (info kinds) */
    dkf_real_t *work;
} group_t;

typedef struct {
    const char *name;
    const char *predict_name; /* the core call predict makes, for messages */
    dkf_status_t (*init)(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0);
    dkf_status_t (*predict)(dkf_est_t *e, const dkf_mat_t *F, const dkf_mat_t *Q);
    dkf_status_t (*update)(dkf_est_t *e, const char **what);
} kind_t;

struct dkf_est {
    const kind_t *kind;
    dkf_est_mode_t mode;
    const dkf_scenario_t *s;
    const names_t *names;
    size_t n;
    size_t ngroups;
    group_t *groups;
    dkf_mat_t *ivec, *Imat;  /* views of every group's i, I for dkf_info_fuse */
    dkf_real_t *storage;     /* the core filter's storage */
    dkf_real_t *FQ;          /* F, Q of the current step */
    dkf_kf_t kf;
    dkf_info_t info;
    const dkf_mat_t *x, *P;  /* current estimate (points into kf or info) */
    json_t *series;
    double *sq;              /* per-component sum of squared errors against truth */
    size_t nsq;
    char what[96];           /* the failing operation, for messages */
};

/* ---- JSON recording ---------------------------------------------------------- */

json_t *dkf_json_from_mat(const dkf_mat_t *A, int as_vector)
{
    size_t r, c;
    json_t *out = json_array();
    if (out == NULL) return NULL;
    for (r = 0; r < A->rows; ++r) {
        json_t *row = as_vector ? out : json_array();
        if (row == NULL) goto oom;
        for (c = 0; c < A->cols; ++c)
            if (json_array_append_new(row, json_real((double)DKF_AT(A, r, c))) != 0) goto oom;
        if (!as_vector && json_array_append_new(out, row) != 0) goto oom;
    }
    return out;
oom:
    json_decref(out);
    return NULL;
}

/* series[key].append(value); the value reference is stolen. */
static void record(dkf_est_t *e, const char *key, json_t *value)
{
    json_t *list = json_object_get(e->series, key);
    if (list == NULL) {
        list = json_array();
        json_object_set_new(e->series, key, list);
    }
    json_array_append_new(list, value);
}

static void record_mat(dkf_est_t *e, const char *key, const dkf_mat_t *A, int as_vector)
{
    record(e, key, dkf_json_from_mat(A, as_vector));
}

/* ---- kinds --------------------------------------------------------------------- */

static dkf_status_t kf_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0)
{
    size_t m = e->groups[0].m;
    size_t len = DKF_KF_STORAGE_LEN(e->n, m);
    dkf_status_t st;
    e->storage = calloc(len, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    st = dkf_kf_init(&e->kf, e->n, m, e->storage, len, x0, P0);
    e->x = &e->kf.x;
    e->P = &e->kf.P;
    return st;
}

static dkf_status_t kf_predict(dkf_est_t *e, const dkf_mat_t *F, const dkf_mat_t *Q)
{
    dkf_status_t st = dkf_kf_predict(&e->kf, F, Q, NULL);
    if (st == DKF_OK) {
        record_mat(e, e->names->xp, &e->kf.x, 1);
        record_mat(e, e->names->Pp, &e->kf.P, 0);
    }
    return st;
}

static dkf_status_t kf_update(dkf_est_t *e, const char **what)
{
    group_t *g = &e->groups[0];
    *what = "dkf_kf_update";
    return dkf_kf_update(&e->kf, &g->H, &g->R, &g->y);
}

static void record_info(dkf_est_t *e, const char *ykey, const char *Ykey)
{
    record_mat(e, ykey, &e->info.y, 1);
    record_mat(e, Ykey, &e->info.Y, 0);
}

static dkf_status_t info_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0)
{
    size_t len = DKF_INFO_STORAGE_LEN(e->n);
    e->storage = calloc(len, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    e->x = &e->info.x;
    e->P = &e->info.P;
    return dkf_info_init(&e->info, e->n, e->storage, len, x0, P0);
}

static dkf_status_t info_predict(dkf_est_t *e, const dkf_mat_t *F, const dkf_mat_t *Q)
{
    dkf_status_t st = dkf_info_predict(&e->info, F, Q);
    if (st == DKF_OK) {
        record_mat(e, e->names->xp, &e->info.x, 1);
        record_mat(e, e->names->Pp, &e->info.P, 0);
        record_info(e, e->names->yp, e->names->Yp);
    }
    return st;
}

static dkf_status_t info_update(dkf_est_t *e, const char **what)
{
    dkf_status_t st;
    size_t j;
    for (j = 0; j < e->ngroups; ++j) {
        group_t *g = &e->groups[j];
        st = dkf_info_contribution(&g->i, &g->I, &g->H, &g->R, &g->y, g->work);
        if (st != DKF_OK) {
            if (e->mode == DKF_EST_FUSED)
                snprintf(e->what, sizeof e->what, "dkf_info_contribution of sensor %zu",
                         g->idx[0]);
            else
                snprintf(e->what, sizeof e->what, "dkf_info_contribution");
            *what = e->what;
            return st;
        }
        e->ivec[j] = g->i;
        e->Imat[j] = g->I;
    }
    if (e->mode == DKF_EST_FUSED) {
        json_t *il = json_array(), *Il = json_array();
        for (j = 0; j < e->ngroups; ++j) {
            json_array_append_new(il, dkf_json_from_mat(&e->groups[j].i, 1));
            json_array_append_new(Il, dkf_json_from_mat(&e->groups[j].I, 0));
        }
        record(e, e->names->i, il);
        record(e, e->names->I, Il);
    }
    *what = "dkf_info_fuse";
    st = dkf_info_fuse(&e->info, e->ivec, e->Imat, e->ngroups);
    if (st == DKF_OK) record_info(e, e->names->yf, e->names->Yf);
    return st;
}

static const kind_t kinds[] = {
    /* DKF_EST_KF */ {"kf", "dkf_kf_predict", kf_init, kf_predict, kf_update},
    /* DKF_EST_INFO */ {"info", "dkf_info_predict", info_init, info_predict, info_update},
};

/* ---- groups ---------------------------------------------------------------------- */

static int group_init(group_t *g, const dkf_scenario_t *s, const size_t *idx, size_t count,
                      size_t n)
{
    size_t j, m = 0, len;
    dkf_real_t *p;
    for (j = 0; j < count; ++j) m += s->sensors[idx[j]].m;
    g->nsens = count;
    g->m = m;
    g->idx = malloc(count * sizeof *g->idx);
    if (g->idx == NULL) return -1;
    memcpy(g->idx, idx, count * sizeof *idx);
    len = m * n + m * m + m + n + n * n + DKF_INFO_CONTRIB_WORK(n, m);
    g->buf = p = calloc(len, sizeof *g->buf);
    if (p == NULL) return -1;
    g->H = (dkf_mat_t)DKF_MAT(m, n, p);
    p += m * n;
    g->R = (dkf_mat_t)DKF_MAT(m, m, p);
    p += m * m;
    g->y = (dkf_mat_t)DKF_MAT(m, 1, p);
    p += m;
    g->i = (dkf_mat_t)DKF_MAT(n, 1, p);
    p += n;
    g->I = (dkf_mat_t)DKF_MAT(n, n, p);
    p += n * n;
    g->work = p;
    return 0;
}

/* H_k stacked, R_k block-diagonal, y_k stacked over the group's sensors. */
static void group_load(group_t *g, const dkf_scenario_t *s, long k)
{
    size_t j, r0 = 0, n = g->H.cols, r, c;
    for (j = 0; j < g->m * g->m; ++j) g->R.data[j] = 0;
    for (j = 0; j < g->nsens; ++j) {
        size_t si = g->idx[j], m = s->sensors[si].m;
        const double *H = dkf_scn_at(dkf_scn_sensor_model(s, si, "H"), (size_t)k);
        const double *R = dkf_scn_at(dkf_scn_sensor_model(s, si, "R"), (size_t)k);
        const double *y = dkf_scn_y(s, si, k);
        dkf_scn_to_real(g->H.data + r0 * n, H, m * n);
        dkf_scn_to_real(g->y.data + r0, y, m);
        for (r = 0; r < m; ++r)
            for (c = 0; c < m; ++c) DKF_AT(&g->R, r0 + r, r0 + c) = (dkf_real_t)R[r * m + c];
        r0 += m;
    }
}

/* ---- public ----------------------------------------------------------------------- */

dkf_est_t *dkf_est_create(dkf_est_kind_t kind, dkf_est_mode_t mode, const dkf_scenario_t *s,
                          const size_t *sensors, size_t count, const double *P00, char *err,
                          size_t errlen)
{
    dkf_est_t *e;
    dkf_real_t *x0d, *P0d;
    dkf_mat_t x0, P0;
    dkf_status_t st;
    size_t j, n = s->n;

    if ((size_t)kind >= sizeof kinds / sizeof kinds[0] || count == 0 ||
        (mode == DKF_EST_FUSED && kind != DKF_EST_INFO)) {
        snprintf(err, errlen, "unsupported estimator configuration");
        return NULL;
    }
    e = calloc(1, sizeof *e);
    if (e == NULL) goto oom;
    e->kind = &kinds[kind];
    e->mode = mode;
    e->s = s;
    e->n = n;
    e->names = s->layout == DKF_SCN_LAYOUT_CASES ? &cases_names : &canonical_names;
    e->ngroups = mode == DKF_EST_FUSED ? count : 1;
    e->groups = calloc(e->ngroups, sizeof *e->groups);
    e->ivec = calloc(e->ngroups, sizeof *e->ivec);
    e->Imat = calloc(e->ngroups, sizeof *e->Imat);
    e->FQ = calloc(2 * n * n + n + n * n, sizeof *e->FQ);
    e->sq = calloc(n, sizeof *e->sq);
    e->series = json_object();
    if (e->groups == NULL || e->ivec == NULL || e->Imat == NULL || e->FQ == NULL ||
        e->sq == NULL || e->series == NULL)
        goto oom;
    for (j = 0; j < e->ngroups; ++j) {
        int rc = mode == DKF_EST_FUSED ? group_init(&e->groups[j], s, &sensors[j], 1, n)
                                       : group_init(&e->groups[j], s, sensors, count, n);
        if (rc != 0) goto oom;
    }
    x0d = e->FQ + 2 * n * n;
    P0d = x0d + n;
    dkf_scn_to_real(x0d, dkf_scn_at(dkf_scn_init(s, "x00"), 0), n);
    dkf_scn_to_real(P0d, P00, n * n);
    x0 = (dkf_mat_t)DKF_MAT(n, 1, x0d);
    P0 = (dkf_mat_t)DKF_MAT(n, n, P0d);
    st = e->kind->init(e, &x0, &P0);
    if (st != DKF_OK) {
        snprintf(err, errlen, "dkf_%s_init failed: %s (%d)", e->kind->name, dkf_status_str(st),
                 (int)st);
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
    for (j = 0; e->groups != NULL && j < e->ngroups; ++j) {
        free(e->groups[j].idx);
        free(e->groups[j].buf);
    }
    free(e->groups);
    free(e->ivec);
    free(e->Imat);
    free(e->FQ);
    free(e->sq);
    free(e->storage);
    json_decref(e->series);
    free(e);
}

/* Accumulates (x_k - truth_k)^2 per component when the scenario has truth. */
static void accumulate_error(dkf_est_t *e, long k)
{
    const double *t = dkf_scn_truth(e->s, k);
    size_t i;
    if (t == NULL) return;
    for (i = 0; i < e->n; ++i) {
        double d = (double)e->x->data[i] - t[i];
        e->sq[i] += d * d;
    }
    e->nsq++;
}

dkf_status_t dkf_est_step(dkf_est_t *e, long k, const char **what)
{
    size_t n = e->n, j;
    dkf_mat_t F = DKF_MAT(n, n, e->FQ), Q = DKF_MAT(n, n, e->FQ + n * n);
    dkf_status_t st;
    /* The loader checked coverage of every per_k list for k = 1..steps. */
    dkf_scn_to_real(F.data, dkf_scn_at(dkf_scn_model(e->s, "F"), (size_t)(k - 1)), n * n);
    dkf_scn_to_real(Q.data, dkf_scn_at(dkf_scn_model(e->s, "Q"), (size_t)(k - 1)), n * n);
    *what = e->kind->predict_name;
    st = e->kind->predict(e, &F, &Q);
    if (st != DKF_OK) return st;
    for (j = 0; j < e->ngroups; ++j) group_load(&e->groups[j], e->s, k);
    st = e->kind->update(e, what);
    if (st != DKF_OK) return st;
    record_mat(e, e->names->xf, e->x, 1);
    record_mat(e, e->names->Pf, e->P, 0);
    accumulate_error(e, k);
    return DKF_OK;
}

json_t *dkf_est_series(const dkf_est_t *e)
{
    return e->series;
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
