/*
 * est_kf.c - the Kalman filter kind (dkf/kf.h, covariance form) of the estimator:
 * predict/update on F, Q, H, R; unknown-input terms are ignored.
 */
#include "est_internal.h"

#include <stdlib.h>

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
    return dkf_kf_predict(&e->kf, &(dkf_kf_dyn_t){&e->F, &e->Q}, NULL);
}

static dkf_status_t kf_update(dkf_est_t *e, const char **what)
{
    dkf_est_group_t *g = &e->groups[0];
    *what = "dkf_kf_update";
    return dkf_kf_update(&e->kf, &(dkf_kf_meas_t){&g->H, &g->R}, &g->y);
}

static const dkf_est_kind_t dkf_est_kf = {
    .name = "kf", .init = kf_init, .predict = kf_predict, .update = kf_update};

/* its registry family (est_run.c's operations) */
DKF_EST_FAMILY(kf, "KF", 0, NULL,
              "Kalman filter (dkf/kf.h) on F, Q, H, R;\n"
              "                           unknown-input terms (D, B, Rd, ...) are ignored");
