/*
 * est_askf.c - the augmented-state KF kind (dkf/askf.h) of the estimator:
 * the KF on [x; d] from d_{0|0}, P_{d0|0}; one sensor.
 */
#include <stdlib.h>

#include "dkf/askf.h"
#include "est_family.h"
#include "est_kind.h"

/* The kind's state (e->state). */
typedef struct {
    dkf_askf_t askf;
    dkf_mat_t x; /* the x block of X */
    dkf_mat_t P; /* the P_x block, copied out of P^a (its own n x n after the core's storage) */
} askf_state_t;

static askf_state_t *askf_of(const dkf_est_t *e)
{
    return (askf_state_t *)e->state;
}

/* x, P of the current X, P^a. */
static dkf_status_t askf_state(dkf_est_t *e, const char **what)
{
    askf_state_t *a = askf_of(e);
    *what = "dkf_askf_state";
    return dkf_askf_state(&a->askf, &a->x, &a->P);
}

static dkf_status_t askf_init(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                              const char **what)
{
    size_t n = e->n, m = e->groups[0].m, p = e->groups[0].p;
    size_t len = DKF_ASKF_STORAGE_LEN(n, m, p);
    askf_state_t *a = askf_of(e);
    dkf_mat_t d0, Pd0;
    dkf_status_t st;
    *what = "dkf_askf_init";
    e->storage = calloc(len + p + p * p + n * n, sizeof *e->storage);
    if (e->storage == NULL) return DKF_ERR_CAPACITY;
    d0 = (dkf_mat_t)DKF_MAT(p, 1, e->storage + len);
    Pd0 = (dkf_mat_t)DKF_MAT(p, p, e->storage + len + p);
    a->P = (dkf_mat_t)DKF_MAT(n, n, e->storage + len + p + p * p);
    dkf_est_input_prior(e, p, d0.data, Pd0.data);
    st = dkf_askf_init(&a->askf, n, m, p, e->storage, len, x0, P0, &d0, &Pd0, NULL);
    if (st != DKF_OK) return st;
    st = askf_state(e, what);
    e->x = &a->x;
    e->P = &a->P;
    return st;
}

static dkf_status_t askf_predict(dkf_est_t *e, const char **what)
{
    dkf_askf_t *f = &askf_of(e)->askf;
    dkf_ui_dyn_t dyn = dkf_est_group_dyn(e, &e->groups[0]);
    dkf_status_t st;
    *what = "dkf_askf_predict";
    st = dkf_askf_predict(f, &dyn);
    if (st != DKF_OK) return st;
    st = askf_state(e, what);
    if (st != DKF_OK) return st;
    dkf_est_record_mat(e, "Xp", &f->kf.x, 1);
    dkf_est_record_mat(e, "PXp", &f->kf.P, 0);
    return DKF_OK;
}

static dkf_status_t askf_update(dkf_est_t *e, const char **what)
{
    dkf_askf_t *f = &askf_of(e)->askf;
    dkf_est_group_t *g = &e->groups[0];
    dkf_status_t st;
    *what = "dkf_askf_update";
    st = dkf_askf_update(f, &g->meas, &g->y);
    if (st != DKF_OK) return st;
    st = askf_state(e, what);
    if (st != DKF_OK) return st;
    dkf_est_record_mat(e, "Xf", &f->kf.x, 1);
    dkf_est_record_mat(e, "PXf", &f->kf.P, 0);
    return DKF_OK;
}

static const dkf_est_kind_t dkf_est_askf = {
    .name = "askf", .needs_ui = 1, .input_prior = 1, .state_size = sizeof(askf_state_t),
    .init = askf_init, .predict = askf_predict, .update = askf_update};

/* its registry family (est_run.c's operations) */
DKF_EST_FAMILY(askf, "ASKF", DKF_EST_OPT_D00, NULL,
              "augmented-state KF (dkf/askf.h) on [x; d]; needs D, B,\n"
              "                           Rd, init.d00, init.Pd00; one sensor");
