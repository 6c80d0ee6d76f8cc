/*
 * uif_run.c - dkf/uif.h filters over a steps-layout scenario (see uif_run.h).
 */
#include "uif_run.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "util.h"

static const char *const kind_names[] = {"rtsf", "nrtsf_df", "nrtsf"};
static const char *const kind_labels[] = {"RTSF", "NRTSF_DF", "NRTSF"};

int dkf_uifrun_kind(const char *name)
{
    int i;
    for (i = 0; i < 3; ++i)
        if (strcmp(name, kind_names[i]) == 0) return i;
    return -1;
}

const char *dkf_uifrun_label(dkf_uif_kind_t kind)
{
    return (unsigned)kind < 3 ? kind_labels[kind] : "?";
}

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

/* What a kind needs from the file beyond the loader's checks. */
static int check_file(const dkf_scenario_t *s, dkf_uif_kind_t kind, char *err, size_t errlen)
{
    const char *who = kind_names[kind];
    if (s->layout != DKF_SCN_LAYOUT_STEPS && s->layout != DKF_SCN_LAYOUT_NETWORK)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                     "%s: steps: missing key (filter %s reads the seed-004 steps layout)",
                     s->file, who);
    if (s->layout != DKF_SCN_LAYOUT_STEPS)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                     "%s: graph: filter %s needs a seed-004 file (model A, G, Q, C, H, R), not a "
                     "seed-003 network", s->file, who);
    if (kind == DKF_UIF_NRTSF) {
        if (dkf_scn_model(s, "H") != NULL)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: %s: filter nrtsf has no direct feedthrough (H = 0): the file must "
                         "not give H", s->file, dkf_scn_model(s, "H")->path);
        if (s->k_first != 1)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: steps[0].k: filter nrtsf starts at k = 1 ((x0, P0) = x_{0|0}, "
                         "y_0 unused), got %ld", s->file, s->k_first);
    } else {
        if (dkf_scn_model(s, "H") == NULL)
            return dkf_failf(err, errlen, DKF_EXIT_USAGE,
                         "%s: model.H: missing key (filter %s needs the feedthrough H)", s->file,
                         who);
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
    /* proj is m x m even when m = 1 */
    dkf_json_append(series, "proj", dkf_json_from_mat(&f->proj, 0));
    for (i = 0; i < f->m; ++i) json_array_append_new(est, json_integer(f->estimable[i]));
    dkf_json_append(series, "estimable", est);
    dkf_json_append(series, "bias_risk", json_integer(f->bias_risk));
    dkf_json_append(series, "bias_steps", json_integer((json_int_t)f->bias_steps));
}

static void summarise(dkf_uifrun_summary_t *sum, const dkf_scenario_t *s, const dkf_uif_t *f,
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
    if (dt != NULL && s->m_u == f->m) {
        for (i = 0; i < f->m; ++i) {
            const double e = (double)f->d.data[i] - dt[i];
            sd[i] += e * e;
        }
        ++*nd;
    }
    for (i = 0; i < f->m; ++i) sum->est_count[i][f->estimable[i] <= 2 ? f->estimable[i] : 0]++;
    if (f->rank < sum->rank_min) sum->rank_min = f->rank;
    if (f->rank > sum->rank_max) sum->rank_max = f->rank;
}

int dkf_uifrun(const dkf_scenario_t *s, dkf_uif_kind_t kind, json_t *series,
               dkf_uifrun_summary_t *sum, char *err, size_t errlen)
{
    const dkf_scn_mat_t *mA = dkf_scn_model(s, "A"), *mG = dkf_scn_model(s, "G");
    const dkf_scn_mat_t *mQ = dkf_scn_model(s, "Q"), *mC = dkf_scn_model(s, "C");
    const dkf_scn_mat_t *mH = dkf_scn_model(s, "H"), *mR = dkf_scn_model(s, "R");
    size_t n, m, p, len, i, nx = 0, nd = 0, dmax;
    dkf_real_t *mem = NULL;
    slot_t A, G, Q, C, H, R, y, x0, P0;
    dkf_uif_t f;
    dkf_status_t st;
    double sx = 0, sd[DKF_MAX_DIM] = {0};
    long k;
    int rc = check_file(s, kind, err, errlen);
    if (rc != DKF_EXIT_OK) return rc;
    n = s->n;
    m = mG->cols;
    p = mC->rows;
    len = DKF_UIF_STORAGE_LEN(n, m, p);
    /* model scratch: 7 matrices of at most max(n, m, p)^2 reals, y, x0 */
    dmax = n > p ? n : p;
    if (m > dmax) dmax = m;
    mem = calloc(len + 8 * dmax * dmax + 2 * (n + p + m), sizeof *mem);
    if (mem == NULL) return dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
    {
        dkf_real_t *q = mem + len;
        const size_t sq = dmax * dmax;
        slot_t *all[] = {&A, &G, &Q, &C, &H, &R, &P0};
        for (i = 0; i < 7; ++i, q += sq) all[i]->buf = q;
        y.buf = q;
        x0.buf = q + p + m;
    }
    load_at(&x0, dkf_scn_init(s, "x00"), 0);
    load_at(&P0, dkf_scn_init(s, "P00"), 0);
    st = dkf_uif_init(&f, kind, n, m, p, mem, len, &x0.view, &P0.view);
    if (st != DKF_OK) {
        free(mem);
        return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: %s: dkf_uif_init failed: %s (%d)", s->file,
                     kind_labels[kind], dkf_status_str(st), (int)st);
    }
    memset(sum, 0, sizeof *sum);
    sum->m = m;
    sum->rank_min = (size_t)-1;
    for (k = s->k_first; k < s->k_first + (long)s->steps; ++k) {
        dkf_uif_dyn_t dyn;
        dkf_uif_meas_t meas;
        const int first_df = kind != DKF_UIF_NRTSF && k == 0;
        if (!first_df) {
            load_at(&A, mA, k - 1);
            load_at(&G, mG, k - 1);
            load_at(&Q, mQ, k - 1);
            dyn.A = &A.view;
            dyn.G = &G.view;
            dyn.Q = &Q.view;
        }
        load_at(&C, mC, k);
        load_at(&R, mR, k);
        meas.C = &C.view;
        meas.R = &R.view;
        meas.H = NULL;
        if (kind != DKF_UIF_NRTSF) {
            load_at(&H, mH, k);
            meas.H = &H.view;
        }
        dkf_scn_to_real(y.buf, dkf_scn_y(s, 0, k), p);
        dkf_mat_init(&y.view, p, 1, y.buf);
        st = dkf_uif_step(&f, first_df ? NULL : &dyn, &meas, &y.view);
        if (st != DKF_OK) {
            free(mem);
            return dkf_failf(err, errlen, DKF_EXIT_RUN, "%s: step k=%ld: %s: dkf_uif_step failed: "
                         "%s (%d)", s->file, k, kind_labels[kind], dkf_status_str(st), (int)st);
        }
        if (series != NULL) record_step(series, &f);
        summarise(sum, s, &f, k, &sx, &nx, sd, &nd);
    }
    sum->steps = s->steps;
    sum->bias_steps = f.bias_steps;
    sum->rmse_x = nx > 0 ? sqrt(sx / (double)(nx * n)) : NAN;
    for (i = 0; i < m; ++i) sum->rmse_d[i] = nd > 0 ? sqrt(sd[i] / (double)nd) : NAN;
    free(mem);
    return DKF_EXIT_OK;
}
