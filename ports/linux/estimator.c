/*
 * estimator.c - core filters driven over a scenario, with JSON recording.
 *
 * Each filter kind is one row of `kinds`: init plus either predict/update
 * (filters that take y_k at step k) or a whole step (the Difference KF,
 * which takes y_{k+1}). Sensors are grouped: a stacked estimator has one
 * group holding all its sensors (H stacked; R, A, B, Rd block-diagonal), a
 * fused one has a group per sensor.
 */
#include "estimator.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/askf.h"
#include "dkf/diffkf.h"
#include "dkf/info.h"
#include "dkf/kf.h"
#include "dkf/otskf.h"
#include "dkf/diffkf_fusion.h"
#include "util.h"

typedef struct {
    const char *xp, *Pp, *xf, *Pf, *yp, *Yp, *yf, *Yf, *i, *I;
} names_t;

/* Key names of the two golden-vector families (see estimator.h). */
static const names_t canonical_names = {"xp", "Pp", "xf", "Pf", "yp", "Yp", "yf", "Yf", "i", "I"};
static const names_t cases_names = {"x_pred", "P_pred", "x", "P", "y_pred", "Y_pred",
                                    "y", "Y", "i", "I"};

/* The measurement a filter takes per step: its sensors stacked, with the
 * unknown-input model (A, B, Rd block-diagonal) when the kind needs it. */
typedef struct {
    size_t nsens;
    size_t *idx;
    size_t m, p;     /* stacked dimensions (p = 0: no unknown-input model) */
    dkf_real_t *buf; /* H, R, y, A, B, Rd, i, I, contribution work */
    dkf_mat_t H, R, y, A, B, Rd;
    dkf_mat_t i, I;  /* information contribution (info kinds) */
    dkf_real_t *work;
    dkf_ui_meas_t meas; /* views of H, A, R */
} group_t;

typedef struct kind kind_t;

struct dkf_est {
    const kind_t *kind;
    dkf_est_mode_t mode;
    const dkf_scenario_t *s;
    const names_t *names;
    dkf_est_opts_t opts;
    size_t n;
    size_t ngroups;
    group_t *groups;
    dkf_mat_t *ivec, *Imat;  /* views of every group's i, I for dkf_info_fuse */
    dkf_real_t *storage;     /* the core filter's storage */
    dkf_real_t *FQ;          /* F, Q of the current step, x0, P0, x_{k|k-1}, P_x */
    dkf_mat_t F, Q;
    dkf_mat_t xpk;           /* x_{k|k-1} of the current step (copy) */
    dkf_mat_t Pbuf;          /* ASKF: P_x block, copied out of P^a */
    dkf_mat_t xview;         /* ASKF: the x block of X */
    dkf_kf_t kf;
    dkf_info_t info;
    dkf_diffkf_t dkf;
    dkf_askf_t askf;
    dkf_otskf_t otskf;
    dkf_diffkf_t *locals;    /* fused DKF: node filters, one per group */
    dkf_real_t **local_storage;
    dkf_diffkf_fc_t fc;
    dkf_diffkf_fc_node_t *nodes;
    dkf_real_t *fc_storage;
    dkf_diffkf_msg_t *msgs;
    dkf_diffkf_sensor_t *fcs;
    const dkf_mat_t *x, *P;  /* current x_{k|k}, P_{k|k} */
    json_t *series;
    double *sq;              /* per-component sum of squared errors against truth */
    size_t nsq;
    double *err_f, *err_p;   /* per-step squared errors of x_{k|k}, x_{k|k-1} */
    char what[128];          /* the failing operation, for messages */
};

struct kind {
    const char *name;
    int needs_ui; /* reads A, B, Rd */
    dkf_status_t (*init)(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                         const char **what);
    /* predict/update kinds: step k = predict with F_{k-1}, Q_{k-1}, B_{k-1},
     * Rd_{k-1}, then update with the model and y at k */
    dkf_status_t (*predict)(dkf_est_t *e, const char **what);
    dkf_status_t (*update)(dkf_est_t *e, const char **what);
    /* whole-step kinds (NULL for the others): fill xpk, run step k */
    dkf_status_t (*step)(dkf_est_t *e, long k, const char **what);
};

/* ---- JSON recording ---------------------------------------------------------- */

static void record_mat(dkf_est_t *e, const char *key, const dkf_mat_t *A, int as_vector)
{
    if (e->opts.no_record) return;
    dkf_json_append(e->series, key, dkf_json_from_mat(A, as_vector));
}

/* ---- model loading ------------------------------------------------------------- */

static void load_FQ(dkf_est_t *e, long k)
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
static void group_load_meas(group_t *g, const dkf_scenario_t *s, long k)
{
    size_t j, r0 = 0, c0 = 0, n = g->H.cols;
    zero(&g->R);
    if (g->p > 0) zero(&g->A);
    for (j = 0; j < g->nsens; ++j) {
        size_t si = g->idx[j], m = s->sensors[si].m;
        put_block(&g->H, r0, 0, dkf_scn_at(dkf_scn_sensor_model(s, si, "H"), (size_t)k), m, n);
        put_block(&g->R, r0, r0, dkf_scn_at(dkf_scn_sensor_model(s, si, "R"), (size_t)k), m, m);
        dkf_scn_to_real(g->y.data + r0, dkf_scn_y(s, si, k), m);
        if (g->p > 0) {
            const dkf_scn_mat_t *A = dkf_scn_sensor_model(s, si, "A");
            put_block(&g->A, r0, c0, dkf_scn_at(A, (size_t)k), m, A->cols);
            c0 += A->cols;
        }
        r0 += m;
    }
}

/* B_k, Rd_k block-diagonal over the group's sensors. */
static void group_load_dyn(group_t *g, const dkf_scenario_t *s, long k)
{
    size_t j, c0 = 0;
    zero(&g->B);
    zero(&g->Rd);
    for (j = 0; j < g->nsens; ++j) {
        size_t si = g->idx[j], p = dkf_scn_sensor_model(s, si, "A")->cols;
        put_block(&g->B, c0, c0, dkf_scn_at(dkf_scn_sensor_model(s, si, "B"), (size_t)k), p, p);
        put_block(&g->Rd, c0, c0, dkf_scn_at(dkf_scn_sensor_model(s, si, "Rd"), (size_t)k), p,
                  p);
        c0 += p;
    }
}

static dkf_ui_dyn_t group_dyn(dkf_est_t *e, group_t *g)
{
    dkf_ui_dyn_t d;
    d.F = &e->F;
    d.Q = &e->Q;
    d.B = &g->B;
    d.Rd = &g->Rd;
    return d;
}

/* ---- KF and information filter --------------------------------------------------- */

static dkf_status_t kf_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                            const char **what)
{
    size_t m = e->groups[0].m;
    size_t len = DKF_KF_STORAGE_LEN(e->n, m);
    *what = "dkf_kf_init";
    e->storage = calloc(len, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    e->x = &e->kf.x;
    e->P = &e->kf.P;
    return dkf_kf_init(&e->kf, e->n, m, e->storage, len, x0, P0);
}

static dkf_status_t kf_predict(dkf_est_t *e, const char **what)
{
    *what = "dkf_kf_predict";
    return dkf_kf_predict(&e->kf, &e->F, &e->Q, NULL);
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

static dkf_status_t info_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                              const char **what)
{
    size_t len = DKF_INFO_STORAGE_LEN(e->n);
    *what = "dkf_info_init";
    e->storage = calloc(len, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    e->x = &e->info.x;
    e->P = &e->info.P;
    return dkf_info_init(&e->info, e->n, e->storage, len, x0, P0);
}

static dkf_status_t info_predict(dkf_est_t *e, const char **what)
{
    dkf_status_t st;
    *what = "dkf_info_predict";
    st = dkf_info_predict(&e->info, &e->F, &e->Q);
    if (st == DKF_OK) record_info(e, e->names->yp, e->names->Yp);
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
    if (e->mode == DKF_EST_FUSED && !e->opts.no_record) {
        json_t *il = json_array(), *Il = json_array();
        for (j = 0; j < e->ngroups; ++j) {
            json_array_append_new(il, dkf_json_from_mat(&e->groups[j].i, 1));
            json_array_append_new(Il, dkf_json_from_mat(&e->groups[j].I, 0));
        }
        dkf_json_append(e->series, e->names->i, il);
        dkf_json_append(e->series, e->names->I, Il);
    }
    *what = "dkf_info_fuse";
    st = dkf_info_fuse(&e->info, e->ivec, e->Imat, e->ngroups);
    if (st == DKF_OK) record_info(e, e->names->yf, e->names->Yf);
    return st;
}

/* ---- ASKF and OTSKF ---------------------------------------------------------------- */

/* d_{0|0}, P_{d0|0} (p doubles each way) from init or the options. */
static void input_prior(const dkf_est_t *e, size_t p, dkf_real_t *d0, dkf_real_t *Pd0)
{
    const double *d = e->opts.d00 != NULL ? e->opts.d00 : dkf_scn_at(dkf_scn_init(e->s, "d00"), 0);
    const double *Pd = dkf_scn_at(dkf_scn_init(e->s, "Pd00"), 0);
    double scale = e->opts.Pd00_scale > 0 ? e->opts.Pd00_scale : 1.0;
    size_t i;
    dkf_scn_to_real(d0, d, p);
    for (i = 0; i < p * p; ++i) Pd0[i] = (dkf_real_t)(scale * Pd[i]);
}

static dkf_status_t askf_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                              const char **what)
{
    size_t n = e->n, m = e->groups[0].m, p = e->groups[0].p;
    size_t len = DKF_ASKF_STORAGE_LEN(n, m, p);
    dkf_mat_t d0, Pd0;
    dkf_status_t st;
    *what = "dkf_askf_init";
    e->storage = calloc(len + p + p * p, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    d0 = (dkf_mat_t)DKF_MAT(p, 1, e->storage + len);
    Pd0 = (dkf_mat_t)DKF_MAT(p, p, e->storage + len + p);
    input_prior(e, p, d0.data, Pd0.data);
    st = dkf_askf_init(&e->askf, n, m, p, e->storage, len, x0, P0, &d0, &Pd0, NULL);
    if (st != DKF_OK) return st;
    *what = "dkf_askf_state";
    st = dkf_askf_state(&e->askf, &e->xview, &e->Pbuf);
    e->x = &e->xview;
    e->P = &e->Pbuf;
    return st;
}

static dkf_status_t askf_predict(dkf_est_t *e, const char **what)
{
    dkf_ui_dyn_t dyn = group_dyn(e, &e->groups[0]);
    dkf_status_t st;
    *what = "dkf_askf_predict";
    st = dkf_askf_predict(&e->askf, &dyn);
    if (st != DKF_OK) return st;
    *what = "dkf_askf_state";
    st = dkf_askf_state(&e->askf, &e->xview, &e->Pbuf);
    if (st != DKF_OK) return st;
    record_mat(e, "Xp", &e->askf.kf.x, 1);
    record_mat(e, "PXp", &e->askf.kf.P, 0);
    return DKF_OK;
}

static dkf_status_t askf_update(dkf_est_t *e, const char **what)
{
    group_t *g = &e->groups[0];
    dkf_status_t st;
    *what = "dkf_askf_update";
    st = dkf_askf_update(&e->askf, &g->meas, &g->y);
    if (st != DKF_OK) return st;
    *what = "dkf_askf_state";
    st = dkf_askf_state(&e->askf, &e->xview, &e->Pbuf);
    if (st != DKF_OK) return st;
    record_mat(e, "Xf", &e->askf.kf.x, 1);
    record_mat(e, "PXf", &e->askf.kf.P, 0);
    return DKF_OK;
}

static dkf_status_t otskf_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                               const char **what)
{
    size_t n = e->n, m = e->groups[0].m, p = e->groups[0].p;
    size_t len = DKF_OTSKF_STORAGE_LEN(n, m, p);
    dkf_mat_t d0, Pd0;
    *what = "dkf_otskf_init";
    e->storage = calloc(len + p + p * p, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    d0 = (dkf_mat_t)DKF_MAT(p, 1, e->storage + len);
    Pd0 = (dkf_mat_t)DKF_MAT(p, p, e->storage + len + p);
    input_prior(e, p, d0.data, Pd0.data);
    e->x = &e->otskf.x;
    e->P = &e->otskf.P;
    return dkf_otskf_init(&e->otskf, n, m, p, e->storage, len, x0, P0, &d0, &Pd0);
}

static dkf_status_t otskf_predict(dkf_est_t *e, const char **what)
{
    dkf_ui_dyn_t dyn = group_dyn(e, &e->groups[0]);
    dkf_status_t st;
    *what = "dkf_otskf_predict";
    st = dkf_otskf_predict(&e->otskf, &dyn);
    if (st != DKF_OK) return st;
    record_mat(e, "xtp", &e->otskf.xt, 1);
    record_mat(e, "Pxp", &e->otskf.Px, 0);
    record_mat(e, "dp", &e->otskf.d, 1);
    record_mat(e, "Pdp", &e->otskf.Pd, 0);
    record_mat(e, "U", &e->otskf.U, 0);
    return DKF_OK;
}

static dkf_status_t otskf_update(dkf_est_t *e, const char **what)
{
    group_t *g = &e->groups[0];
    dkf_status_t st;
    *what = "dkf_otskf_update";
    st = dkf_otskf_update(&e->otskf, &g->meas, &g->y);
    if (st != DKF_OK) return st;
    record_mat(e, "xtf", &e->otskf.xt, 1);
    record_mat(e, "Pxf", &e->otskf.Px, 0);
    record_mat(e, "df", &e->otskf.d, 1);
    record_mat(e, "Pdf", &e->otskf.Pd, 0);
    record_mat(e, "V", &e->otskf.V, 0);
    return DKF_OK;
}

/* ---- Difference KF (stacked) ------------------------------------------------------ */

/* Start: x_{1|0} = F_0 x_{0|0} and the first measurement y_1 (diffkf.h). */
static dkf_status_t dkf_stacked_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                                     const char **what)
{
    group_t *g = &e->groups[0];
    size_t len = DKF_DIFFKF_STORAGE_LEN(e->n, g->m, g->p);
    dkf_status_t st;
    *what = "dkf_diffkf_init";
    e->storage = calloc(len, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    st = dkf_diffkf_init(&e->dkf, e->n, g->m, g->p, e->storage, len, x0, P0);
    if (st != DKF_OK) return st;
    load_FQ(e, 0);
    group_load_meas(g, e->s, 1);
    *what = "dkf_diffkf_start";
    e->x = &e->dkf.xf;
    e->P = &e->dkf.Pf;
    return dkf_diffkf_start(&e->dkf, &e->F, &e->Q, &g->meas, &g->y);
}

static void record_dkf_step(dkf_est_t *e, const dkf_diffkf_t *f)
{
    record_mat(e, "z", &f->z, 1);
    record_mat(e, "dz", &f->dz, 1);
    record_mat(e, "J", &f->J, 0);
    record_mat(e, "L", &f->L, 0);
    record_mat(e, "K", &f->K, 0);
}

/* Step k consumes y_{k+1}: dynamics at k (F, Q, B, Rd), model at k+1. */
static dkf_status_t dkf_stacked_step(dkf_est_t *e, long k, const char **what)
{
    group_t *g = &e->groups[0];
    dkf_ui_dyn_t dyn = group_dyn(e, g);
    dkf_status_t st;
    load_FQ(e, k);
    group_load_dyn(g, e->s, k);
    group_load_meas(g, e->s, k + 1);
    *what = "dkf_diffkf_step";
    st = dkf_diffkf_step(&e->dkf, &dyn, &g->meas, &g->y);
    if (st == DKF_OK) record_dkf_step(e, &e->dkf);
    return st;
}

/* ---- Difference KF, distributed: local filters + fusion centre ------------------------ */

static const char *fc_cond_str(dkf_diffkf_fc_cond_t c)
{
    static const char *const names[] = {
        "no fault", "bad argument", "storage", "p_i > n", "p_i > m_i", "stacked capacity",
        "prior", "model", "A rank", "B singular", "L not SPD", "K rank", "non-finite",
        "message node", "message step", "message dimension", "message non-finite", "sequence"};
    size_t i = (size_t)c;
    return i < sizeof names / sizeof names[0] ? names[i] : "?";
}

static const char *fc_what(dkf_est_t *e, const char *call, const dkf_diffkf_fc_fault_t *f)
{
    if (f->node == DKF_DIFFKF_FC_NO_NODE)
        snprintf(e->what, sizeof e->what, "%s (%s)", call, fc_cond_str(f->which));
    else
        snprintf(e->what, sizeof e->what, "%s (node %zu: %s)", call, f->node,
                 fc_cond_str(f->which));
    return e->what;
}

static dkf_status_t dkf_fused_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                                   const char **what)
{
    size_t l = e->ngroups, n = e->n, i, len;
    size_t *m = calloc(l, sizeof *m), *p = calloc(l, sizeof *p);
    dkf_real_t *Pl = calloc(l * n * n, sizeof *Pl);
    const dkf_mat_t **Pv = calloc(l, sizeof *Pv);
    dkf_mat_t *Pm = calloc(l, sizeof *Pm);
    dkf_diffkf_fc_fault_t fault;
    dkf_status_t st = DKF_ERR_CAPACITY;
    *what = "out of memory";
    e->locals = calloc(l, sizeof *e->locals);
    e->local_storage = calloc(l, sizeof *e->local_storage);
    e->nodes = calloc(l, sizeof *e->nodes);
    e->msgs = calloc(l, sizeof *e->msgs);
    e->fcs = calloc(l, sizeof *e->fcs);
    if (m == NULL || p == NULL || Pl == NULL || Pv == NULL || Pm == NULL || e->locals == NULL ||
        e->local_storage == NULL || e->nodes == NULL || e->msgs == NULL || e->fcs == NULL)
        goto done;
    /* node filters, each from its own prior P00_local[i] */
    for (i = 0; i < l; ++i) {
        group_t *g = &e->groups[i];
        m[i] = g->m;
        p[i] = g->p;
        dkf_scn_to_real(Pl + i * n * n, dkf_scn_P00_local(e->s, g->idx[0]), n * n);
        Pm[i] = (dkf_mat_t)DKF_MAT(n, n, Pl + i * n * n);
        Pv[i] = &Pm[i];
        len = DKF_DIFFKF_STORAGE_LEN(n, g->m, g->p);
        if ((e->local_storage[i] = calloc(len, sizeof **e->local_storage)) == NULL) goto done;
        st = dkf_diffkf_init(&e->locals[i], n, g->m, g->p, e->local_storage[i], len, x0, &Pm[i]);
        if (st != DKF_OK) {
            snprintf(e->what, sizeof e->what, "dkf_diffkf_init of node %zu", i);
            *what = e->what;
            goto done;
        }
    }
    len = dkf_diffkf_fc_storage_len(n, l, m, p);
    st = DKF_ERR_CAPACITY;
    *what = "dkf_diffkf_fc_storage_len";
    if (len == 0 || (e->fc_storage = calloc(len, sizeof *e->fc_storage)) == NULL) goto done;
    st = dkf_diffkf_fc_init(&e->fc, e->nodes, l, n, m, p, e->fc_storage, len, x0, P0,
                            (const dkf_mat_t *const *)Pv, &fault);
    if (st != DKF_OK) {
        *what = fc_what(e, "dkf_diffkf_fc_init", &fault);
        goto done;
    }
    /* start: every node and the FC predict to k = 1 and take y_1 */
    load_FQ(e, 0);
    for (i = 0; i < l; ++i) {
        group_t *g = &e->groups[i];
        group_load_meas(g, e->s, 1);
        group_load_dyn(g, e->s, 1); /* fc_start checks B of step 1 */
        st = dkf_diffkf_start(&e->locals[i], &e->F, &e->Q, &g->meas, &g->y);
        if (st != DKF_OK) {
            snprintf(e->what, sizeof e->what, "dkf_diffkf_start of node %zu", i);
            *what = e->what;
            goto done;
        }
        e->fcs[i].B = &g->B;
        e->fcs[i].Rd = NULL;
        e->fcs[i].meas = g->meas;
    }
    st = dkf_diffkf_fc_start(&e->fc, &e->F, &e->Q, e->fcs, &fault);
    if (st != DKF_OK) *what = fc_what(e, "dkf_diffkf_fc_start", &fault);
    e->x = &e->fc.central.xf;
    e->P = &e->fc.central.Pf;
done:
    free(m);
    free(p);
    free(Pl);
    free(Pv);
    free(Pm);
    return st;
}

static json_t *json_vec(const dkf_real_t *v, size_t n)
{
    dkf_mat_t M = DKF_MAT(n, 1, (dkf_real_t *)v);
    return dkf_json_from_mat(&M, 1);
}

static dkf_status_t dkf_fused_step(dkf_est_t *e, long k, const char **what)
{
    size_t l = e->ngroups, i, n = e->n;
    dkf_diffkf_fc_fault_t fault;
    dkf_status_t st;
    load_FQ(e, k);
    for (i = 0; i < l; ++i) {
        group_t *g = &e->groups[i];
        dkf_ui_dyn_t dyn = group_dyn(e, g);
        group_load_dyn(g, e->s, k);
        group_load_meas(g, e->s, k + 1);
        st = dkf_diffkf_step(&e->locals[i], &dyn, &g->meas, &g->y);
        if (st == DKF_OK) st = dkf_diffkf_msg_fill(&e->msgs[i], (uint16_t)i, &e->locals[i]);
        if (st != DKF_OK) {
            snprintf(e->what, sizeof e->what, "node %zu: dkf_diffkf_step", i);
            *what = e->what;
            return st;
        }
        e->fcs[i].B = &g->B;
        e->fcs[i].Rd = &g->Rd;
        e->fcs[i].meas = g->meas;
    }
    st = dkf_diffkf_fc_step(&e->fc, &e->F, &e->Q, e->fcs, e->msgs, &fault);
    if (st != DKF_OK) {
        *what = fc_what(e, "dkf_diffkf_fc_step", &fault);
        return st;
    }
    record_dkf_step(e, &e->fc.central);
    if (!e->opts.no_record) {
        json_t *msgs = json_array(), *rec = json_array();
        for (i = 0; i < l; ++i) {
            json_array_append_new(msgs, json_pack("{s:o, s:o}", "xf", json_vec(e->msgs[i].xf, n),
                                                  "xp", json_vec(e->msgs[i].xp, n)));
            json_array_append_new(rec, json_pack("{s:o, s:o, s:o}", "dz",
                                                 dkf_json_from_mat(&e->nodes[i].dz, 1), "z",
                                                 dkf_json_from_mat(&e->nodes[i].z, 1), "K",
                                                 dkf_json_from_mat(&e->nodes[i].rep.K, 0)));
        }
        dkf_json_append(e->series, "messages", msgs);
        dkf_json_append(e->series, "fc_recovered", rec);
    }
    return DKF_OK;
}

static dkf_status_t dkf_kind_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                                  const char **what)
{
    if (e->mode == DKF_EST_FUSED) return dkf_fused_init(e, x0, P0, what);
    return dkf_stacked_init(e, x0, P0, what);
}

/* Records x_{k|k-1} (before the step: the DKF's step k updates it), then steps. */
static dkf_status_t dkf_kind_step(dkf_est_t *e, long k, const char **what)
{
    const dkf_diffkf_t *f = &e->dkf;
    if (e->mode == DKF_EST_FUSED) f = &e->fc.central;
    memcpy(e->xpk.data, f->xn.data, e->n * sizeof *e->xpk.data);
    record_mat(e, e->names->xp, &f->xn, 1);
    record_mat(e, e->names->Pp, &f->Pn, 0);
    if (e->mode == DKF_EST_FUSED) return dkf_fused_step(e, k, what);
    return dkf_stacked_step(e, k, what);
}

static const kind_t kinds[] = {
    /* DKF_EST_KF */ {"kf", 0, kf_init, kf_predict, kf_update, NULL},
    /* DKF_EST_INFO */ {"info", 0, info_init, info_predict, info_update, NULL},
    /* DKF_EST_DKF */ {"dkf", 1, dkf_kind_init, NULL, NULL, dkf_kind_step},
    /* DKF_EST_ASKF */ {"askf", 1, askf_init, askf_predict, askf_update, NULL},
    /* DKF_EST_OTSKF */ {"otskf", 1, otskf_init, otskf_predict, otskf_update, NULL},
};

/* ---- groups ---------------------------------------------------------------------- */

static int group_init(group_t *g, const dkf_scenario_t *s, const size_t *idx, size_t count,
                      size_t n, int needs_ui)
{
    size_t j, m = 0, p = 0, len;
    dkf_real_t *q;
    for (j = 0; j < count; ++j) {
        m += s->sensors[idx[j]].m;
        if (needs_ui) p += dkf_scn_sensor_model(s, idx[j], "A")->cols;
    }
    g->nsens = count;
    g->m = m;
    g->p = p;
    g->idx = malloc(count * sizeof *g->idx);
    if (g->idx == NULL) return -1;
    memcpy(g->idx, idx, count * sizeof *idx);
    len = m * n + m * m + m + m * p + 2 * p * p + n + n * n + DKF_INFO_CONTRIB_WORK(n, m);
    g->buf = q = calloc(len, sizeof *g->buf);
    if (q == NULL) return -1;
    g->H = (dkf_mat_t)DKF_MAT(m, n, q);
    q += m * n;
    g->R = (dkf_mat_t)DKF_MAT(m, m, q);
    q += m * m;
    g->y = (dkf_mat_t)DKF_MAT(m, 1, q);
    q += m;
    g->A = (dkf_mat_t)DKF_MAT(m, p, q);
    q += m * p;
    g->B = (dkf_mat_t)DKF_MAT(p, p, q);
    q += p * p;
    g->Rd = (dkf_mat_t)DKF_MAT(p, p, q);
    q += p * p;
    g->i = (dkf_mat_t)DKF_MAT(n, 1, q);
    q += n;
    g->I = (dkf_mat_t)DKF_MAT(n, n, q);
    q += n * n;
    g->work = q;
    g->meas.H = &g->H;
    g->meas.A = &g->A;
    g->meas.R = &g->R;
    return 0;
}

/* ---- public ----------------------------------------------------------------------- */

dkf_est_t *dkf_est_create(dkf_est_kind_t kind, dkf_est_mode_t mode, const dkf_scenario_t *s,
                          const size_t *sensors, size_t count, const double *P00,
                          const dkf_est_opts_t *opts, char *err, size_t errlen)
{
    dkf_est_t *e;
    dkf_real_t *q;
    dkf_mat_t x0, P0;
    dkf_status_t st;
    const char *what = "?";
    size_t j, n = s->n, N = s->steps;

    if ((size_t)kind >= sizeof kinds / sizeof kinds[0] || count == 0 ||
        (mode == DKF_EST_FUSED && kind != DKF_EST_INFO && kind != DKF_EST_DKF)) {
        snprintf(err, errlen, "unsupported estimator configuration");
        return NULL;
    }
    e = calloc(1, sizeof *e);
    if (e == NULL) goto oom;
    e->kind = &kinds[kind];
    e->mode = mode;
    e->s = s;
    e->n = n;
    if (opts != NULL) e->opts = *opts;
    e->names = s->layout == DKF_SCN_LAYOUT_CASES ? &cases_names : &canonical_names;
    e->ngroups = mode == DKF_EST_FUSED ? count : 1;
    e->groups = calloc(e->ngroups, sizeof *e->groups);
    e->ivec = calloc(e->ngroups, sizeof *e->ivec);
    e->Imat = calloc(e->ngroups, sizeof *e->Imat);
    e->FQ = calloc(4 * n * n + 2 * n, sizeof *e->FQ);
    e->sq = calloc(n, sizeof *e->sq);
    e->err_f = calloc(N, sizeof *e->err_f);
    e->err_p = calloc(N, sizeof *e->err_p);
    e->series = json_object();
    if (e->groups == NULL || e->ivec == NULL || e->Imat == NULL || e->FQ == NULL ||
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
    e->Pbuf = (dkf_mat_t)DKF_MAT(n, n, q + 3 * n * n);
    x0 = (dkf_mat_t)DKF_MAT(n, 1, q + 4 * n * n);
    e->xpk = (dkf_mat_t)DKF_MAT(n, 1, q + 4 * n * n + n);
    dkf_scn_to_real(x0.data, dkf_scn_at(dkf_scn_init(s, "x00"), 0), n);
    dkf_scn_to_real(P0.data, P00, n * n);
    st = e->kind->init(e, &x0, &P0, &what);
    if (st != DKF_OK) {
        snprintf(err, errlen, "%s failed: %s (%d)", what, dkf_status_str(st), (int)st);
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
    for (j = 0; e->local_storage != NULL && j < e->ngroups; ++j) free(e->local_storage[j]);
    free(e->local_storage);
    free(e->locals);
    free(e->nodes);
    free(e->msgs);
    free(e->fcs);
    free(e->fc_storage);
    free(e->groups);
    free(e->ivec);
    free(e->Imat);
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
    load_FQ(e, k - 1);
    if (e->kind->needs_ui) group_load_dyn(&e->groups[0], e->s, k - 1);
    st = e->kind->predict(e, what);
    if (st != DKF_OK) return st;
    memcpy(e->xpk.data, e->x->data, e->n * sizeof *e->xpk.data);
    record_mat(e, e->names->xp, e->x, 1);
    record_mat(e, e->names->Pp, e->P, 0);
    for (j = 0; j < e->ngroups; ++j) group_load_meas(&e->groups[j], e->s, k);
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
    record_mat(e, e->names->xf, e->x, 1);
    record_mat(e, e->names->Pf, e->P, 0);
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
