/*
 * estimator.h - runs one core filter over a scenario and records its
 * per-step estimates as JSON series (host side, reused by dkf-run and the
 * network processes).
 *
 * An estimator is a filter kind (KF, information filter, ...) applied to a
 * set of sensors: one sensor (a "local" filter), all sensors stacked into
 * one measurement with block-diagonal R ("central"), or - information
 * filter only - all sensors' contributions summed ("fused"). Each call of
 * dkf_est_step performs step k: predict with F_{k-1}, Q_{k-1}, update with
 * the sensors' H_k, R_k, y_k, and appends the estimates to the series.
 *
 * Series key names follow the scenario's layout so an output compares key
 * by key with the golden-vector file it came from (docs/scenario-format.md):
 *   canonical: xp Pp xf Pf (+ information form yp Yp yf Yf, fused i I)
 *   cases:     x_pred P_pred x P (+ y_pred Y_pred y Y, fused i I)
 */
#ifndef DKF_HOST_ESTIMATOR_H
#define DKF_HOST_ESTIMATOR_H

#include <stddef.h>

#include <jansson.h>

#include "dkf/status.h"
#include "scenario.h"

typedef enum {
    DKF_EST_KF = 0,  /* dkf/kf.h, covariance form */
    DKF_EST_INFO = 1 /* dkf/info.h, information form */
} dkf_est_kind_t;

typedef enum {
    DKF_EST_STACKED = 0, /* one measurement: the listed sensors stacked */
    DKF_EST_FUSED = 1    /* information filter: sum of per-sensor contributions */
} dkf_est_mode_t;

typedef struct dkf_est dkf_est_t;

/* Creates an estimator of `kind` over sensors[0..count-1] of s, started from
 * x00 and the given P00 (n x n doubles). On failure returns NULL and writes a
 * one-line message (naming the core call and its status) into err. */
dkf_est_t *dkf_est_create(dkf_est_kind_t kind, dkf_est_mode_t mode, const dkf_scenario_t *s,
                          const size_t *sensors, size_t count, const double *P00, char *err,
                          size_t errlen);
void dkf_est_free(dkf_est_t *e);

/* Step k (predict from k-1, update with y_k). On a core error returns its
 * status and sets *what to the failing operation ("predict", "update",
 * "contribution of sensor 2", ...). */
dkf_status_t dkf_est_step(dkf_est_t *e, long k, const char **what);

/* The per-step series recorded so far (borrowed reference). */
json_t *dkf_est_series(const dkf_est_t *e);

/* trace of the current P, and the RMSE of the filtered x against the
 * scenario's truth over the steps that had truth: overall (root mean over
 * steps and components) and per component (rmse_comp, n values; may be
 * NULL). Returns the number of steps compared (0: no truth, RMSE = NaN). */
double dkf_est_trace_P(const dkf_est_t *e);
size_t dkf_est_rmse(const dkf_est_t *e, double *rmse, double *rmse_comp);

/* A as JSON: a flat list of numbers when as_vector (A is n x 1), else a
 * list of rows. New reference; NULL if out of memory. */
json_t *dkf_json_from_mat(const dkf_mat_t *A, int as_vector);

#endif /* DKF_HOST_ESTIMATOR_H */
