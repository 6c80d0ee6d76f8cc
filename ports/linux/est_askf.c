/*
 * est_askf.c - the augmented-state KF kind (dkf/askf.h) of the estimator:
 * the KF on [x; d] from d_{0|0}, P_{d0|0}; one sensor.
 */
#include "est_internal.h"

#include <stdlib.h>

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
    dkf_est_input_prior(e, p, d0.data, Pd0.data);
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
    dkf_ui_dyn_t dyn = dkf_est_group_dyn(e, &e->groups[0]);
    dkf_status_t st;
    *what = "dkf_askf_predict";
    st = dkf_askf_predict(&e->askf, &dyn);
    if (st != DKF_OK) return st;
    *what = "dkf_askf_state";
    st = dkf_askf_state(&e->askf, &e->xview, &e->Pbuf);
    if (st != DKF_OK) return st;
    dkf_est_record_mat(e, "Xp", &e->askf.kf.x, 1);
    dkf_est_record_mat(e, "PXp", &e->askf.kf.P, 0);
    return DKF_OK;
}

static dkf_status_t askf_update(dkf_est_t *e, const char **what)
{
    dkf_est_group_t *g = &e->groups[0];
    dkf_status_t st;
    *what = "dkf_askf_update";
    st = dkf_askf_update(&e->askf, &g->meas, &g->y);
    if (st != DKF_OK) return st;
    *what = "dkf_askf_state";
    st = dkf_askf_state(&e->askf, &e->xview, &e->Pbuf);
    if (st != DKF_OK) return st;
    dkf_est_record_mat(e, "Xf", &e->askf.kf.x, 1);
    dkf_est_record_mat(e, "PXf", &e->askf.kf.P, 0);
    return DKF_OK;
}

static const dkf_est_kind_t dkf_est_askf = {
    .name = "askf", .needs_ui = 1, .input_prior = 1, .init = askf_init, .predict = askf_predict,
    .update = askf_update};

/* its registry family (est_run.c's operations) */
DKF_EST_FAMILY(askf, "ASKF", DKF_RUN_OPT_D00, NULL,
              "augmented-state KF (dkf/askf.h) on [x; d]; needs D, B,\n"
              "                           Rd, init.d00, init.Pd00; one sensor");
