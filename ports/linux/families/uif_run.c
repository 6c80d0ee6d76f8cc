/*
 * uif_run.c - the seed-004 joint state / unknown-input filters (dkf/uif.h:
 * RTSF, NRTSF-DF, NRTSF) over a steps-layout scenario: the registry family
 * "uif" (family.h), filters rtsf, nrtsf_df, nrtsf.
 *
 * Step sequence (the vector files' convention, docs/reference/scenario-format.md):
 *   rtsf, nrtsf_df: steps start at k = 0; (x0, P0) is the prior of x_0;
 *     step 0 has no time update (dyn = NULL), step k >= 1 uses F, G, Q of
 *     k - 1 and H, D, R, y of k.
 *   nrtsf: steps start at k = 1; (x0, P0) = x_{0|0}; no D in the file.
 * Recorded per step (the vectors' `expected` names): x_pred P_pred Rtilde d
 * Pd x Px L K M rank proj, Pxd (Pxd_extra for nrtsf, where the library's Pxd
 * is E[(x_k - x_{k|k})(d_{k-1} - d_{k-1|k})^T]); plus extra keys
 * `estimable` (per input component: 0 none, 1 partial, 2 full;
 * DKF_UIF_EST_*), `bias_risk` (0/1) and `bias_steps`.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/uif.h"
#include "family.h"
#include "status_text.h"
#include "util.h"

/* What a run counts for its summary. */
typedef struct {
    size_t steps;
    size_t p;                         /* unknown inputs */
    size_t est_count[DKF_MAX_DIM][3]; /* steps with estimable[i] = NONE, PARTIAL, FULL */
    size_t rank_min, rank_max;
} counts_t;

/* A model matrix at absolute time k, converted into buf (a view on it). */
typedef struct {
    dkf_real_t *buf;
    dkf_mat_t view;
} slot_t;

static void load_at(slot_t *sl, const dkf_scn_mat_t *m, long k)
{
    dkf_scn_to_real(sl->buf, dkf_scn_at(m, (size_t)k), m->rows * m->cols);
    dkf_mat_init(&sl->view, m->rows, m->cols, sl->buf);
}

/* What a kind needs from the file beyond the reader's checks (the
 * registry's check). */
static int uif_check(const dkf_filter_t *fl, const dkf_run_opts_t *o, const dkf_scenario_t *s,
                     char *err, size_t errlen)
{
    const dkf_uif_kind_t kind = *(const dkf_uif_kind_t *)fl->impl;
    const char *who = fl->name;
    (void)o;
    if (s->layout != DKF_SCN_LAYOUT_STEPS && s->layout != DKF_SCN_LAYOUT_NETWORK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: steps: missing key (filter %s reads the seed-004 steps layout)",
                         s->file, who);
    if (s->layout != DKF_SCN_LAYOUT_STEPS)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: graph: filter %s needs a seed-004 file (model F, G, Q, H, D, R), "
                         "not a seed-003 network", s->file, who);
    if (kind == DKF_UIF_NRTSF) {
        if (dkf_scn_model(s, "D") != NULL)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                             "%s: %s: filter nrtsf has no direct feedthrough (D = 0): the file "
                             "must not give D", s->file, dkf_scn_model(s, "D")->path);
        if (s->k_first != 1)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                             "%s: steps[0].k: filter nrtsf starts at k = 1 ((x0, P0) = x_{0|0}, "
                             "y_0 unused), got %ld", s->file, s->k_first);
    } else {
        if (dkf_scn_model(s, "D") == NULL)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                             "%s: model.D: missing key (filter %s needs the feedthrough D)",
                             s->file, who);
        if (s->k_first != 0)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                             "%s: steps[0].k: filter %s starts at k = 0 ((x0, P0) is the prior of "
                             "x_0), got %ld", s->file, who, s->k_first);
    }
    return DKF_EXIT_OK;
}

static void put_mat(json_t *series, const char *key, const dkf_mat_t *A)
{
    dkf_json_append(series, key, dkf_json_from_mat(A, A->cols == 1));
}

static void record_step(json_t *series, const dkf_uif_t *f)
{
    json_t *est = json_array();
    size_t i;
    put_mat(series, "x_pred", &f->x_pred);
    put_mat(series, "P_pred", &f->P_pred);
    put_mat(series, "Rtilde", &f->Rtilde);
    put_mat(series, "d", &f->d);
    put_mat(series, "Pd", &f->Pd);
    put_mat(series, "x", &f->x);
    put_mat(series, "Px", &f->Px);
    put_mat(series, f->kind == DKF_UIF_NRTSF ? "Pxd_extra" : "Pxd", &f->Pxd);
    put_mat(series, "L", &f->L);
    put_mat(series, "K", &f->K);
    put_mat(series, "M", &f->M);
    dkf_json_append(series, "rank", json_integer((json_int_t)f->rank));
    /* proj is p x p even when p = 1 */
    dkf_json_append(series, "proj", dkf_json_from_mat(&f->proj, 0));
    for (i = 0; i < f->p; ++i) json_array_append_new(est, json_integer(f->estimable[i]));
    dkf_json_append(series, "estimable", est);
    dkf_json_append(series, "bias_risk", json_integer(f->bias_risk));
    dkf_json_append(series, "bias_steps", json_integer((json_int_t)f->bias_steps));
}

static void summarise(counts_t *sum, const dkf_scenario_t *s, const dkf_uif_t *f,
                      long k, double *sx, size_t *nx, double *sd, size_t *nd)
{
    const double *xt = dkf_scn_truth(s, k), *dt = dkf_scn_truth_u(s, k);
    size_t i;
    if (xt != NULL) {
        for (i = 0; i < f->n; ++i) {
            const double e = (double)f->x.data[i] - xt[i];
            *sx += e * e;
        }
        ++*nx;
    }
    if (dt != NULL && s->m_u == f->p) {
        for (i = 0; i < f->p; ++i) {
            const double e = (double)f->d.data[i] - dt[i];
            sd[i] += e * e;
        }
        ++*nd;
    }
    for (i = 0; i < f->p; ++i) sum->est_count[i][f->estimable[i] <= 2 ? f->estimable[i] : 0]++;
    if (f->rank < sum->rank_min) sum->rank_min = f->rank;
    if (f->rank > sum->rank_max) sum->rank_max = f->rank;
}

/* A running filter: the core filter, its model scratch, what it records
 * and measures against the file's truth. */
typedef struct {
    const dkf_filter_t *fl;
    const dkf_scenario_t *s;
    dkf_uif_kind_t kind;
    const dkf_scn_mat_t *mF, *mG, *mQ, *mH, *mD, *mR;
    size_t n, m, p; /* state, measurement (rows of H), unknown input (columns of G) */
    dkf_real_t *mem;
    slot_t F, G, Q, H, D, R, y, x0, P0;
    dkf_uif_t f;
    json_t *series;              /* NULL: record nothing */
    counts_t sum;
    double sx, sd[DKF_MAX_DIM];  /* sums of squared errors of x, of each d_i */
    size_t nx, nd;
} uif_runner_t;

static void uif_destroy(dkf_runner_t *r)
{
    uif_runner_t *u = (uif_runner_t *)(void *)r;
    if (u == NULL) return;
    free(u->mem);
    json_decref(u->series);
    free(u);
}

static dkf_runner_t *uif_create(const dkf_filter_t *fl, const dkf_run_opts_t *o,
                                const dkf_scenario_t *s, char *err, size_t errlen, int *rc)
{
    uif_runner_t *u = dkf_runner_calloc(sizeof *u, s, err, errlen, rc);
    size_t len, i, dmax;
    dkf_status_t st;
    if (u == NULL) return NULL;
    u->fl = fl;
    u->s = s;
    u->kind = *(const dkf_uif_kind_t *)fl->impl;
    u->mF = dkf_scn_model(s, "F");
    u->mG = dkf_scn_model(s, "G");
    u->mQ = dkf_scn_model(s, "Q");
    u->mH = dkf_scn_model(s, "H");
    u->mD = dkf_scn_model(s, "D");
    u->mR = dkf_scn_model(s, "R");
    u->n = s->n;
    u->p = u->mG->cols;
    u->m = u->mH->rows;
    len = DKF_UIF_STORAGE_LEN(u->n, u->m, u->p);
    /* model scratch: 7 matrices of at most max(n, m, p)^2 reals, y, x0 */
    dmax = u->n > u->m ? u->n : u->m;
    if (u->p > dmax) dmax = u->p;
    u->mem = calloc(len + 8 * dmax * dmax + 2 * (u->n + u->m + u->p), sizeof *u->mem);
    u->series = o->record ? json_object() : NULL;
    if (u->mem == NULL || (o->record && u->series == NULL)) {
        uif_destroy((dkf_runner_t *)(void *)u);
        *rc = dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
        return NULL;
    }
    {
        dkf_real_t *q = u->mem + len;
        const size_t sq = dmax * dmax;
        slot_t *all[] = {&u->F, &u->G, &u->Q, &u->H, &u->D, &u->R, &u->P0};
        for (i = 0; i < 7; ++i, q += sq) all[i]->buf = q;
        u->y.buf = q;
        u->x0.buf = q + u->m + u->p;
    }
    load_at(&u->x0, dkf_scn_init(s, "x00"), 0);
    load_at(&u->P0, dkf_scn_init(s, "P00"), 0);
    st = dkf_uif_init(&u->f, u->kind, u->n, u->m, u->p, u->mem, len, &u->x0.view, &u->P0.view);
    if (st != DKF_OK) {
        char text[DKF_STATUS_TEXT_LEN];
        *rc = dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: %s: dkf_uif_init failed: %s", s->file,
                        fl->label, dkf_host_status_text(text, sizeof text, "dkf_uif_init", st));
        uif_destroy((dkf_runner_t *)(void *)u);
        return NULL;
    }
    u->sum.p = u->p;
    u->sum.rank_min = (size_t)-1;
    *rc = DKF_EXIT_OK;
    return (dkf_runner_t *)(void *)u;
}

static int uif_step(dkf_runner_t *r, long k, char *err, size_t errlen)
{
    uif_runner_t *u = (uif_runner_t *)(void *)r;
    const dkf_scenario_t *s = u->s;
    dkf_uif_dyn_t dyn;
    dkf_ui_meas_t meas;
    dkf_status_t st;
    const int first_df = u->kind != DKF_UIF_NRTSF && k == 0;
    if (!first_df) {
        load_at(&u->F, u->mF, k - 1);
        load_at(&u->G, u->mG, k - 1);
        load_at(&u->Q, u->mQ, k - 1);
        dyn.F = &u->F.view;
        dyn.G = &u->G.view;
        dyn.Q = &u->Q.view;
    }
    load_at(&u->H, u->mH, k);
    load_at(&u->R, u->mR, k);
    meas.H = &u->H.view;
    meas.R = &u->R.view;
    meas.D = NULL;
    if (u->kind != DKF_UIF_NRTSF) {
        load_at(&u->D, u->mD, k);
        meas.D = &u->D.view;
    }
    dkf_scn_to_real(u->y.buf, dkf_scn_y(s, 0, k), u->m);
    dkf_mat_init(&u->y.view, u->m, 1, u->y.buf);
    st = dkf_uif_step(&u->f, first_df ? NULL : &dyn, &meas, &u->y.view);
    if (st != DKF_OK) {
        char text[DKF_STATUS_TEXT_LEN];
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: step k=%ld: %s: dkf_uif_step failed: "
                         "%s", s->file, k, u->fl->label,
                         dkf_host_status_text(text, sizeof text, "dkf_uif_step", st));
    }
    if (u->series != NULL) record_step(u->series, &u->f);
    summarise(&u->sum, s, &u->f, k, &u->sx, &u->nx, u->sd, &u->nd);
    u->sum.steps++;
    return DKF_EXIT_OK;
}

static void uif_record(dkf_runner_t *r, dkf_out_t *out)
{
    const uif_runner_t *u = (const uif_runner_t *)(const void *)r;
    dkf_out_outputs(out, u->fl->label, u->series);
}

static void uif_summary(const dkf_runner_t *r, FILE *out)
{
    static const char *const est[] = {"none", "partial", "full"};
    const uif_runner_t *u = (const uif_runner_t *)(const void *)r;
    const dkf_scenario_t *s = u->s;
    const counts_t *sm = &u->sum;
    const double rmse_x = u->nx > 0 ? sqrt(u->sx / (double)(u->nx * u->n)) : NAN;
    size_t i;
    fprintf(out,
            "scenario %s: %zu steps (k = %ld..%ld), n = %zu, m = %zu, p = %zu; filter %s (%s)\n",
            s->file, s->steps, s->k_first, s->k_first + (long)s->steps - 1, s->n, u->m, sm->p,
            u->fl->name, DKF_USE_FLOAT ? "float" : "double");
    fprintf(out, "  rank %zu..%zu; steps with bias risk: %zu\n", sm->rank_min, sm->rank_max,
            u->f.bias_steps);
    fprintf(out, "  RMSE(x) %s%.6g\n", isnan(rmse_x) ? "(no truth) " : "", rmse_x);
    for (i = 0; i < sm->p; ++i) {
        const double rmse_d = u->nd > 0 ? sqrt(u->sd[i] / (double)u->nd) : NAN;
        size_t e, best = 0;
        for (e = 1; e < 3; ++e)
            if (sm->est_count[i][e] > sm->est_count[i][best]) best = e;
        fprintf(out, "  d%zu: estimable %s (%zu/%zu steps), RMSE vs truth %s %.6g\n", i + 1,
                est[best], sm->est_count[i][best], sm->steps,
                s->truth_u_key[0] != '\0' ? s->truth_u_key : "(none)", rmse_d);
    }
}

/* ---- the registry family ---- */

extern const dkf_family_t dkf_family_uif;
static const dkf_uif_kind_t kinds[] = {DKF_UIF_RTSF, DKF_UIF_NRTSF_DF, DKF_UIF_NRTSF};
static const dkf_filter_t filters[] = {
    {"rtsf", "RTSF",
     "seed 004: recursive three-step filter with direct\n"
     "                           feedthrough (dkf/uif.h); needs rank H = m; steps from k = 0",
     0, &dkf_family_uif, &kinds[0]},
    {"nrtsf_df", "NRTSF_DF",
     "seed 004: NRTSF-DF, any rank of H (minimum-norm\n"
     "                           input estimate); steps from k = 0",
     0, &dkf_family_uif, &kinds[1]},
    {"nrtsf", "NRTSF",
     "seed 004: NRTSF, no feedthrough (no H), any rank of G;\n"
     "                           d = d_{k-1|k}; steps from k = 1",
     0, &dkf_family_uif, &kinds[2]},
};
const dkf_family_t dkf_family_uif = {
    "uif", filters, sizeof filters / sizeof filters[0], 1u << DKF_SCN_LAYOUT_STEPS,
    uif_check, uif_create, uif_step, uif_record, NULL, NULL, uif_summary, uif_destroy, NULL, NULL,
};
