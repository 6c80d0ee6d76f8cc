/*
 * est_otskf.c - the optimal two-stage KF kind (dkf/otskf.h) of the estimator;
 * like ASKF, one sensor.
 */
#include <stdlib.h>

#include "dkf/otskf.h"
#include "est_family.h"
#include "est_kind.h"

/* The kind's state (e->state). */
typedef struct {
    dkf_otskf_t otskf;
} otskf_state_t;

static dkf_otskf_t *otskf_of(const dkf_est_t *e)
{
    return &((otskf_state_t *)e->state)->otskf;
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
    dkf_est_input_prior(e, p, d0.data, Pd0.data);
    e->x = &otskf_of(e)->x;
    e->P = &otskf_of(e)->P;
    return dkf_otskf_init(otskf_of(e), n, m, p, e->storage, len, x0, P0, &d0, &Pd0);
}

static dkf_status_t otskf_predict(dkf_est_t *e, const char **what)
{
    dkf_otskf_t *f = otskf_of(e);
    dkf_ui_dyn_t dyn = dkf_est_group_dyn(e, &e->groups[0]);
    dkf_status_t st;
    *what = "dkf_otskf_predict";
    st = dkf_otskf_predict(f, &dyn);
    if (st != DKF_OK) return st;
    dkf_est_record_mat(e, "xtp", &f->xt, 1);
    dkf_est_record_mat(e, "Pxp", &f->Px, 0);
    dkf_est_record_mat(e, "dp", &f->d, 1);
    dkf_est_record_mat(e, "Pdp", &f->Pd, 0);
    dkf_est_record_mat(e, "U", &f->U, 0);
    return DKF_OK;
}

static dkf_status_t otskf_update(dkf_est_t *e, const char **what)
{
    dkf_otskf_t *f = otskf_of(e);
    dkf_est_group_t *g = &e->groups[0];
    dkf_status_t st;
    *what = "dkf_otskf_update";
    st = dkf_otskf_update(f, &g->meas, &g->y);
    if (st != DKF_OK) return st;
    dkf_est_record_mat(e, "xtf", &f->xt, 1);
    dkf_est_record_mat(e, "Pxf", &f->Px, 0);
    dkf_est_record_mat(e, "df", &f->d, 1);
    dkf_est_record_mat(e, "Pdf", &f->Pd, 0);
    dkf_est_record_mat(e, "V", &f->V, 0);
    return DKF_OK;
}

static const dkf_est_kind_t dkf_est_otskf = {
    .name = "otskf", .needs_ui = 1, .input_prior = 1, .state_size = sizeof(otskf_state_t),
    .init = otskf_init,
    .predict = otskf_predict, .update = otskf_update};

/* its registry family (est_run.c's operations) */
DKF_EST_FAMILY(otskf, "OTSKF", DKF_EST_OPT_D00, NULL,
              "optimal two-stage KF (dkf/otskf.h); like askf");
