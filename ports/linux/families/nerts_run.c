/*
 * nerts_run.c - seed 001's single-node nonlinear unknown-input filters
 * (dkf/nerts.h) over a nonlinear-cases scenario (scn_nlcases.c): the
 * registry family "nerts", filters nertsf, nertsif, dnertsf, dnertsif
 * and cf_dnertsf.
 *
 *   nertsf ... dnertsif  a single-node case (`model`, `init`);
 *   cf_dnertsf           the centralised DNERTSF: on a single-node case
 *                        the case's model (a stacked one such as
 *                        s1_radar_stacked), on a network case every
 *                        node's model stacked (dkf_nerts_stack; z the
 *                        nodes' z one after another, R = blkdiag of the
 *                        nodes' R, Q and the initial estimate node 0's:
 *                        seed 001 starts every filter from the same x0;
 *                        a node whose f or Q differs from node 0's is
 *                        refused, naming it; m_l, g and R may differ).
 *
 * Step k (k = 1..N): dkf_nerts_step with the model's Q and R and z_k.
 * Recorded per step under outputs.<LABEL>, with the vector files'
 * `expected` names (docs/reference/scenario-format.md, "Nonlinear cases"):
 *   every kind      x_pred P_pred z_hat nu R_tilde Pzz Pxz H (= Hd) M C
 *                   Rbar x Px d Pd Pxd
 *   EKF kinds       A, G (Fx, Fd: the time update's Jacobians at the
 *                   previous posterior)
 *   information     Y_pred y_pred Rbar_inv i I Y y
 * so tools/dkf_compare.py compares them with `cases[c].steps[*].expected`.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/nerts.h"
#include "family.h"
#include "nerts_run.h"
#include "nlm.h"
#include "status_text.h"
#include "util.h"

/* A --filter row's data. */
typedef struct {
    dkf_nerts_kind_t kind;
    int central; /* cf_dnertsf: every node's model stacked on a network case */
} nerts_impl_t;

typedef struct {
    const dkf_filter_t *fl;
    const dkf_scenario_t *s;
    nerts_impl_t impl;
    size_t n, m, p;
    dkf_nl_model_t model;      /* the node's table or the stack */
    dkf_nl_model_t *tables;    /* the nodes' tables, for the stack */
    dkf_nerts_stack_t stack;
    dkf_real_t *mem;           /* the filter's storage, then Q R z */
    dkf_real_t *Q, *R, *z;
    dkf_mat_t Qv, Rv, zv;
    dkf_nerts_t f;
    json_t *series;            /* NULL: record nothing */
    double sx, sd;             /* squared errors against the truth */
    size_t nx, nd;
} nerts_runner_t;

static int is_info(dkf_nerts_kind_t k)
{
    return k == DKF_NERTS_NERTSIF || k == DKF_NERTS_DNERTSIF;
}

static int is_ekf(dkf_nerts_kind_t k)
{
    return k == DKF_NERTS_NERTSF || k == DKF_NERTS_NERTSIF;
}

/* 1 if node i's f gives node 0's values, bit for bit, at node 0's initial
 * estimate and at a point beside it (the stack runs node 0's f alone). */
static int same_dynamics(const dkf_scenario_t *s, size_t i)
{
    const dkf_nl_model_t *a = &s->nl->models[0]->model, *b = &s->nl->models[i]->model;
    const dkf_scn_mat_t *x0 = dkf_scn_node_init(s, 0, "x00"), *d0 = dkf_scn_node_init(s, 0, "d00");
    const size_t n = s->n, p = s->nl->p;
    dkf_real_t x[DKF_MAX_DIM], d[DKF_MAX_DIM], fa[DKF_MAX_DIM], fb[DKF_MAX_DIM];
    size_t t, j;
    for (t = 0; t < 2; ++t) {
        for (j = 0; j < n; ++j) x[j] = (dkf_real_t)(x0->data[j] + 0.1 * (double)(t * (j + 1)));
        for (j = 0; j < p; ++j) d[j] = (dkf_real_t)(d0->data[j] + 0.1 * (double)t);
        if (a->f(a->ctx, 0, x, d, NULL, fa) != 0 || b->f(b->ctx, 0, x, d, NULL, fb) != 0 ||
            memcmp(fa, fb, n * sizeof *fa) != 0)
            return 0;
    }
    return 1;
}

static int nerts_check(const dkf_filter_t *fl, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                       char *err, size_t errlen)
{
    const nerts_impl_t *im = fl->impl;
    (void)o;
    if (s->layout != DKF_SCN_LAYOUT_NLCASES || s->nl == NULL)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases: filter %s needs a case with a nonlinear model (`model` or "
                         "`node_models`: docs/reference/scenario-format.md, \"Nonlinear cases\")",
                         s->file, fl->name);
    if (s->nl->network && !im->central)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: cases[%zu].node_models: filter %s runs one node (`model`); this "
                         "network case runs with cf_dnertsf or a network filter", s->file,
                         s->case_index, fl->name);
    if (im->central && s->nl->network) {
        size_t i, m = 0;
        const size_t n = s->n;
        for (i = 0; i < s->nsensors; ++i) m += s->nl->models[i]->m;
        /* one system: node 0's f and Q are the stacked model's dynamics */
        for (i = 1; i < s->nsensors; ++i)
            if (memcmp(s->nl->models[i]->Q, s->nl->models[0]->Q, n * n * sizeof(double)) != 0)
                return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                                 "%s: cases[%zu].node_models[%zu].Q: differs from node 0's (the "
                                 "centralised filter has one dynamics: node 0's f and Q)",
                                 s->file, s->case_index, i);
        for (i = 1; i < s->nsensors; ++i)
            if (!same_dynamics(s, i))
                return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                                 "%s: cases[%zu].node_models[%zu].%s: its f differs from node "
                                 "0's (the centralised filter has one dynamics: node 0's f and Q)",
                                 s->file, s->case_index, i,
                                 strcmp(s->nl->models[i]->source, "expr") == 0 ? "expr.f"
                                                                                : "family");
        if (m > DKF_MAX_DIM)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                             "%s: cases[%zu].node_models: the stacked measurement has %zu "
                             "components, more than the core's %d", s->file, s->case_index, m,
                             DKF_MAX_DIM);
    }
    return DKF_EXIT_OK;
}

static void nerts_destroy(dkf_runner_t *r)
{
    nerts_runner_t *u = (nerts_runner_t *)(void *)r;
    if (u == NULL) return;
    free(u->mem);
    free(u->tables);
    json_decref(u->series);
    free(u);
}

/* The model the filter runs: node 0's, or every node's stacked (R, z
 * stacked into the runner's buffers at each step). */
static dkf_status_t bind_model(nerts_runner_t *u)
{
    const dkf_scenario_t *s = u->s;
    size_t i;
    if (!(u->impl.central && s->nl->network)) {
        u->model = s->nl->models[0]->model;
        return DKF_OK;
    }
    u->tables = calloc(s->nsensors, sizeof *u->tables);
    if (u->tables == NULL) return DKF_ERR_CAPACITY;
    for (i = 0; i < s->nsensors; ++i) u->tables[i] = s->nl->models[i]->model;
    return dkf_nerts_stack(&u->model, &u->stack, u->tables, s->nsensors);
}

/* R = blkdiag of the nodes' R (one node: its R). */
static void load_R(nerts_runner_t *u)
{
    const dkf_scenario_t *s = u->s;
    const size_t nodes = u->tables != NULL ? s->nsensors : 1;
    size_t i, a, b, off = 0;
    memset(u->R, 0, u->m * u->m * sizeof *u->R);
    for (i = 0; i < nodes; ++i) {
        const dkf_nlm_t *nm = s->nl->models[i];
        for (a = 0; a < nm->m; ++a)
            for (b = 0; b < nm->m; ++b)
                u->R[(off + a) * u->m + off + b] = (dkf_real_t)nm->R[a * nm->m + b];
        off += nm->m;
    }
}

/* z_k: node 0's, or the nodes' one after another. */
static void load_z(nerts_runner_t *u, long k)
{
    const dkf_scenario_t *s = u->s;
    const size_t nodes = u->tables != NULL ? s->nsensors : 1;
    size_t i, off = 0;
    for (i = 0; i < nodes; ++i) {
        dkf_scn_to_real(u->z + off, dkf_scn_y(s, i, k), s->sensors[i].m);
        off += s->sensors[i].m;
    }
}

/* View over the node-0 init entry `name` (r x c) converted into buf. */
static const dkf_mat_t *init_view(const dkf_scenario_t *s, const char *name, dkf_mat_t *v,
                                  dkf_real_t *buf)
{
    const dkf_scn_mat_t *m = dkf_scn_node_init(s, 0, name);
    if (m == NULL) return NULL;
    dkf_scn_to_real(buf, m->data, m->rows * m->cols);
    dkf_mat_init(v, m->rows, m->cols, buf);
    return v;
}

static dkf_status_t start(nerts_runner_t *u, size_t len)
{
    const dkf_scenario_t *s = u->s;
    const size_t n = u->n, p = u->p;
    dkf_real_t *b = calloc(n + n * n + p + p * p + n * p, sizeof *b);
    dkf_mat_t x0, P0, d0, Pd0, Pxd0;
    dkf_status_t st;
    if (b == NULL) return DKF_ERR_CAPACITY;
    st = dkf_nerts_init(&u->f, u->impl.kind, n, u->m, p, u->mem, len,
                        init_view(s, "x00", &x0, b), init_view(s, "P00", &P0, b + n),
                        p > 0 ? init_view(s, "d00", &d0, b + n + n * n) : NULL,
                        p > 0 ? init_view(s, "Pd00", &Pd0, b + n + n * n + p) : NULL,
                        p > 0 ? init_view(s, "Pxd00", &Pxd0, b + n + n * n + p + p * p) : NULL);
    free(b);
    return st;
}

static dkf_runner_t *nerts_create(const dkf_filter_t *fl, const dkf_run_opts_t *o,
                                  const dkf_scenario_t *s, char *err, size_t errlen, int *rc)
{
    nerts_runner_t *u = dkf_runner_calloc(sizeof *u, s, err, errlen, rc);
    size_t len, extra, i;
    dkf_status_t st;
    if (u == NULL) return NULL;
    u->fl = fl;
    u->s = s;
    u->impl = *(const nerts_impl_t *)fl->impl;
    u->n = s->n;
    u->p = s->nl->p;
    st = bind_model(u);
    if (st != DKF_OK) {
        char text[DKF_STATUS_TEXT_LEN];
        *rc = dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: cases[%zu]: %s: dkf_nerts_stack failed: "
                        "%s", s->file, s->case_index, fl->label,
                        dkf_host_status_text(text, sizeof text, "dkf_nerts_stack", st));
        nerts_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    u->m = u->model.m;
    len = DKF_NERTS_STORAGE_LEN(u->n, u->m, u->p);
    extra = u->n * u->n + u->m * u->m + u->m;
    u->mem = calloc(len + extra, sizeof *u->mem);
    u->series = o->record ? json_object() : NULL;
    if (u->mem == NULL || (o->record && u->series == NULL)) {
        *rc = dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
        nerts_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    u->Q = u->mem + len;
    u->R = u->Q + u->n * u->n;
    u->z = u->R + u->m * u->m;
    for (i = 0; i < u->n * u->n; ++i) u->Q[i] = (dkf_real_t)s->nl->models[0]->Q[i];
    load_R(u);
    dkf_mat_init(&u->Qv, u->n, u->n, u->Q);
    dkf_mat_init(&u->Rv, u->m, u->m, u->R);
    dkf_mat_init(&u->zv, u->m, 1, u->z);
    st = start(u, len);
    if (st != DKF_OK) {
        char text[DKF_STATUS_TEXT_LEN];
        *rc = dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: cases[%zu]: %s: dkf_nerts_init failed: "
                        "%s", s->file, s->case_index, fl->label,
                        dkf_host_status_text(text, sizeof text, "dkf_nerts_init", st));
        nerts_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    *rc = DKF_EXIT_OK;
    return (dkf_runner_t *)(void *)u;
}

/* A matrix as a list of rows (also when it has one column: G, H, Pd, Pxd). */
static void put(json_t *series, const char *key, const dkf_mat_t *A)
{
    dkf_json_append(series, key, dkf_json_from_mat(A, 0));
}

/* A vector view (n x 1) as a flat list, also when n = 0. */
static void put_vec(json_t *series, const char *key, const dkf_mat_t *v)
{
    dkf_json_append(series, key, dkf_json_from_mat(v, 1));
}

void dkf_host_nerts_record(json_t *series, const dkf_nerts_t *f)
{
    if (is_ekf(f->kind)) {
        put(series, "A", &f->Fx);
        put(series, "G", &f->Fd);
    }
    put_vec(series, "x_pred", &f->x_pred);
    put(series, "P_pred", &f->P_pred);
    put_vec(series, "z_hat", &f->z_hat);
    put_vec(series, "nu", &f->nu);
    put(series, "R_tilde", &f->R_tilde);
    put(series, "Pzz", &f->Pzz);
    put(series, "Pxz", &f->Pxz);
    put(series, "H", &f->Hd);
    put(series, "M", &f->M);
    put(series, "C", &f->C);
    put(series, "Rbar", &f->Rbar);
    if (is_info(f->kind)) {
        put(series, "Y_pred", &f->Y_pred);
        put_vec(series, "y_pred", &f->y_pred);
        put(series, "Rbar_inv", &f->Rbar_inv);
        put_vec(series, "i", &f->i);
        put(series, "I", &f->I);
        put(series, "Y", &f->Y);
        put_vec(series, "y", &f->y);
    }
    put_vec(series, "x", &f->x);
    put(series, "Px", &f->Px);
    put_vec(series, "d", &f->d);
    put(series, "Pd", &f->Pd);
    put(series, "Pxd", &f->Pxd);
}

static void errors_against_truth(nerts_runner_t *u, long k)
{
    const double *xt = dkf_scn_truth(u->s, k), *dt = dkf_scn_truth_u(u->s, k);
    size_t i;
    if (xt != NULL) {
        for (i = 0; i < u->n; ++i) {
            const double e = (double)u->f.x.data[i] - xt[i];
            u->sx += e * e;
        }
        u->nx++;
    }
    if (dt != NULL && u->s->m_u == u->p) {
        for (i = 0; i < u->p; ++i) {
            const double e = (double)u->f.d.data[i] - dt[i];
            u->sd += e * e;
        }
        u->nd++;
    }
}

static int nerts_step(dkf_runner_t *r, long k, char *err, size_t errlen)
{
    nerts_runner_t *u = (nerts_runner_t *)(void *)r;
    const dkf_scenario_t *s = u->s;
    dkf_status_t st;
    size_t i;
    load_z(u, k);
    st = dkf_nerts_step(&u->f, &u->model, NULL, &u->Qv, NULL, &u->Rv, &u->zv);
    if (st != DKF_OK) {
        const char *why = "";
        char text[DKF_STATUS_TEXT_LEN];
        for (i = 0; i < s->nsensors && why[0] == '\0'; ++i)
            why = dkf_nlm_failure(s->nl->models[i]);
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: cases[%zu] step k=%ld: %s: "
                         "dkf_nerts_step failed: %s%s%s", s->file, s->case_index, k,
                         u->fl->label, dkf_host_status_text(text, sizeof text, "dkf_nerts_step", st),
                         why[0] != '\0' ? "; " : "", why);
    }
    if (u->series != NULL) dkf_host_nerts_record(u->series, &u->f);
    errors_against_truth(u, k);
    return DKF_EXIT_OK;
}

static void nerts_record(dkf_runner_t *r, dkf_out_t *out)
{
    const nerts_runner_t *u = (const nerts_runner_t *)(const void *)r;
    dkf_out_outputs(out, u->fl->label, u->series);
}

static void nerts_summary(const dkf_runner_t *r, FILE *out)
{
    const nerts_runner_t *u = (const nerts_runner_t *)(const void *)r;
    const dkf_scenario_t *s = u->s;
    const dkf_nlm_t *m0 = s->nl->models[0];
    fprintf(out, "scenario %s, case %s: %zu steps, n = %zu, m = %zu, p = %zu (model %s%s); "
            "filter %s (%s)\n", s->file, s->case_name != NULL ? s->case_name : "", s->steps,
            u->n, u->m, u->p, m0->source, u->tables != NULL ? ", every node stacked" : "",
            u->fl->name, DKF_USE_FLOAT ? "float" : "double");
    if (u->nx > 0)
        fprintf(out, "  RMSE(x) %.6g over %zu steps\n", sqrt(u->sx / (double)(u->nx * u->n)),
                u->nx);
    else
        fprintf(out, "  RMSE(x) (no truth)\n");
    if (u->nd > 0 && u->p > 0)
        fprintf(out, "  RMSE(d) %.6g vs truth %s\n", sqrt(u->sd / (double)(u->nd * u->p)),
                s->truth_u_key);
}

/* ---- the registry family ---- */

extern const dkf_family_t dkf_family_nerts;
static const nerts_impl_t impls[] = {
    {DKF_NERTS_NERTSF, 0}, {DKF_NERTS_NERTSIF, 0}, {DKF_NERTS_DNERTSF, 0},
    {DKF_NERTS_DNERTSIF, 0}, {DKF_NERTS_DNERTSF, 1},
};
static const dkf_filter_t filters[] = {
    {"nertsf", "NERTSF",
     "seed 001: NERTSF, EKF joint state / unknown-input filter,\n"
     "                           covariance form (dkf/nerts.h); nonlinear cases, one node",
     0, &dkf_family_nerts, &impls[0]},
    {"nertsif", "NERTSIF",
     "seed 001: NERTSIF (Algorithm 1), its information form",
     0, &dkf_family_nerts, &impls[1]},
    {"dnertsf", "DNERTSF",
     "seed 001: DNERTSF, cubature, covariance form",
     0, &dkf_family_nerts, &impls[2]},
    {"dnertsif", "DNERTSIF",
     "seed 001: DNERTSIF (Algorithm 2), cubature, information form",
     0, &dkf_family_nerts, &impls[3]},
    {"cf_dnertsf", "CF_DNERTSF",
     "seed 001: centralised DNERTSF over every node's sensor\n"
     "                           stacked (a network case), or a stacked model",
     0, &dkf_family_nerts, &impls[4]},
};
const dkf_family_t dkf_family_nerts = {
    .name = "nerts",
    .filters = filters,
    .nfilters = sizeof filters / sizeof filters[0],
    .layouts = 1u << DKF_SCN_LAYOUT_NLCASES,
    .check = nerts_check,
    .create = nerts_create,
    .step = nerts_step,
    .record = nerts_record,
    .errors = NULL,
    .summary = nerts_summary,
    .destroy = nerts_destroy,
};
