/*
 * estimator.h - runs one core filter over a scenario and records its
 * per-step estimates as JSON series (host side, reused by dkf-run and the
 * network processes).
 *
 * An estimator is a filter kind (KF, information filter, Difference KF,
 * ASKF, OTSKF) applied to a set of sensors: one sensor (a "local" filter),
 * all sensors stacked into one measurement with block-diagonal R, A, B, Rd
 * ("central"), or all sensors fused ("fused": the information filter sums
 * per-sensor contributions; the Difference KF runs one local filter per
 * sensor and a fusion centre, dkf/diffkf_fusion.h, fed with their
 * messages). Each call of dkf_est_step performs step k = 1, 2, ... and
 * appends the estimates to the series:
 *   KF, IF, ASKF, OTSKF: predict with the dynamics at k-1, update with y_k;
 *   DKF: the step consuming y_{k+1} (dynamics at k, measurement model at
 *   k+1), so it records x_{k|k-1} (the estimate compared with the others'
 *   x_{k|k}), then x_{k|k}.
 *
 * Series key names follow the scenario's layout so an output compares key
 * by key with the golden-vector file it came from (docs/reference/scenario-format.md):
 *   canonical: xp Pp xf Pf (+ information form yp Yp yf Yf, fused i I;
 *              DKF z dz J L K; ASKF Xp PXp Xf PXf; OTSKF xtp Pxp xtf Pxf
 *              dp Pdp df Pdf U V; fused DKF messages fc_recovered)
 *   cases:     x_pred P_pred x P (+ y_pred Y_pred y Y, fused i I)
 */
#ifndef DKF_HOST_ESTIMATOR_H
#define DKF_HOST_ESTIMATOR_H

#include <stddef.h>

#include <jansson.h>

#include "dkf/status.h"
#include "scenario.h"

typedef struct dkf_est dkf_est_t;

/* A filter kind: what it needs of the scenario and the operations that
 * drive its core filter (over the object of est_kind.h). Each kind is one
 * file, which also defines its registry family (DKF_EST_FAMILY,
 * families/private/est_family.h): families/est_kf.c (dkf/kf.h, covariance
 * form; ignores A, B, Rd), est_info.c (dkf/info.h), est_diffkf.c
 * (dkf/diffkf.h, the Difference KF; fused: dkf/diffkf_fusion.h),
 * est_askf.c (dkf/askf.h), est_otskf.c (dkf/otskf.h). */
typedef struct dkf_est_kind {
    const char *name;
    int needs_ui;    /* reads A, B, Rd (dkf_scn_require_ui before create) */
    int fused;       /* has a fused mode (DKF_EST_FUSED) */
    int y_ahead;     /* step k takes y_{k+1} (the Difference KF: y up to N+1) */
    int input_prior; /* starts from d00, Pd00 (init or the options); one sensor */
    size_t state_size; /* bytes of the kind's own state (e->state, zeroed at create) */
    dkf_status_t (*init)(dkf_est_t *e, const dkf_mat_t *x0, const dkf_mat_t *P0,
                         const char **what);
    /* predict/update kinds: step k = predict with F_{k-1}, Q_{k-1}, B_{k-1},
     * Rd_{k-1}, then update with the model and y at k */
    dkf_status_t (*predict)(dkf_est_t *e, const char **what);
    dkf_status_t (*update)(dkf_est_t *e, const char **what);
    /* whole-step kinds (NULL for the others): fill xpk, run step k */
    dkf_status_t (*step)(dkf_est_t *e, long k, const char **what);
    /* frees what init allocated in the state beyond e->storage (NULL: nothing) */
    void (*release)(dkf_est_t *e);
} dkf_est_kind_t;

typedef enum {
    DKF_EST_STACKED = 0, /* one measurement: the listed sensors stacked */
    DKF_EST_FUSED = 1    /* INFO: sum of contributions; DKF: local filters + fusion centre */
} dkf_est_mode_t;

/* Options of dkf_est_create; a zeroed struct (or NULL) means the defaults. */
typedef struct {
    int no_record;     /* 1: record no JSON series (Monte-Carlo error mode) */
    const double *d00; /* ASKF/OTSKF: d_{0|0} (p values) instead of init.d00 */
    double Pd00_scale; /* ASKF/OTSKF: P_{d0|0} = scale * init.Pd00 (0 means 1) */
} dkf_est_opts_t;

/* Creates an estimator of `kind` over sensors[0..count-1] of s, started from
 * x00 and the given P00 (n x n doubles). The scenario must have passed
 * dkf_scn_require_ui for DKF, ASKF, OTSKF. On failure returns NULL and
 * writes a one-line message (naming the core call and its status) into err. */
dkf_est_t *dkf_est_create(const dkf_est_kind_t *kind, dkf_est_mode_t mode,
                          const dkf_scenario_t *s, const size_t *sensors, size_t count,
                          const double *P00, const dkf_est_opts_t *opts, char *err,
                          size_t errlen);
void dkf_est_free(dkf_est_t *e);

/* Step k (k = 1, 2, ... in order). On a core error returns its status and
 * sets *what to the failing operation ("dkf_kf_update", "dkf_info_contribution
 * of sensor 2", ...). */
dkf_status_t dkf_est_step(dkf_est_t *e, long k, const char **what);

/* The per-step series recorded so far (borrowed reference; empty with
 * no_record). */
json_t *dkf_est_series(const dkf_est_t *e);

/* Squared errors against the scenario's truth, one per step taken:
 * ||x_{k|k} - x_k||^2 (predicted = 0) or ||x_{k|k-1} - x_k||^2
 * (predicted = 1); NaN where the scenario has no truth for k. */
const double *dkf_est_sqerr(const dkf_est_t *e, int predicted);

/* trace of the current P_{k|k}, and the RMSE of the filtered x against the
 * scenario's truth over the steps that had truth: overall (root mean over
 * steps and components) and per component (rmse_comp, n values; may be
 * NULL). Returns the number of steps compared (0: no truth, RMSE = NaN). */
double dkf_est_trace_P(const dkf_est_t *e);
size_t dkf_est_rmse(const dkf_est_t *e, double *rmse, double *rmse_comp);

#endif /* DKF_HOST_ESTIMATOR_H */
