/*
 * est_kf.c - the Kalman filter kind (dkf/kf.h, covariance form) of the estimator:
 * predict/update on F, Q, H, R; unknown-input terms are ignored.
 */
#include <stdlib.h>

#include "dkf/kf.h"
#include "est_family.h"
#include "est_kind.h"

/* The kind's state (e->state). */
typedef struct {
    dkf_kf_t kf;
} kf_state_t;

static dkf_kf_t *kf_of(const dkf_est_t *e)
{
    return &((kf_state_t *)e->state)->kf;
}

static dkf_status_t kf_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                            const char **what)
{
    size_t m = e->groups[0].m;
    size_t len = DKF_KF_STORAGE_LEN(e->n, m);
    *what = "dkf_kf_init";
    e->storage = calloc(len, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    e->x = &kf_of(e)->x;
    e->P = &kf_of(e)->P;
    return dkf_kf_init(kf_of(e), e->n, m, e->storage, len, x0, P0);
}

static dkf_status_t kf_predict(dkf_est_t *e, const char **what)
{
    *what = "dkf_kf_predict";
    return dkf_kf_predict(kf_of(e), &(dkf_kf_dyn_t){&e->F, &e->Q}, NULL);
}

static dkf_status_t kf_update(dkf_est_t *e, const char **what)
{
    dkf_est_group_t *g = &e->groups[0];
    *what = "dkf_kf_update";
    return dkf_kf_update(kf_of(e), &(dkf_kf_meas_t){&g->H, &g->R}, &g->y);
}

static const dkf_est_kind_t dkf_est_kf = {
    .name = "kf", .state_size = sizeof(kf_state_t), .init = kf_init, .predict = kf_predict,
    .update = kf_update};

/* its registry family (est_run.c's operations) */
DKF_EST_FAMILY(kf, "KF", 0, NULL,
              "Kalman filter (dkf/kf.h) on F, Q, H, R;\n"
              "                           unknown-input terms (D, B, Rd, ...) are ignored");
