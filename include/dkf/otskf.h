/*
 * dkf/otskf.h - the optimal two-stage Kalman filter (OTSKF, Hsieh & Chen
 * 1999 structure, derived for d_{k+1} = B_k d_k + wd_k; docs/diffkf.md and
 * the corrected equations of the reference note §5). A bias-free filter
 * (x~, P^x) and a bias filter (d, P^d) are coupled by the blending matrices
 * U_k, V_k:
 *   x_{k|k-1} = x~_{k|k-1} + U_k d_{k|k-1},   x_{k|k} = x~_{k|k} + V_k d_{k|k}.
 * It is exactly equivalent to the ASKF initialised alike (tests check
 * 1e-9), at lower cost.
 */
#ifndef DKF_OTSKF_H
#define DKF_OTSKF_H

#include <stddef.h>

#include "dkf/ui_model.h"

/* Reals of storage for state n, measurement m, input p: the helper that
 * implements src/otskf.c sizes this exactly. */
#define DKF_OTSKF_STORAGE_LEN(n, m, p) \
    (4 * (n) + 4 * (n) * (n) + 2 * (p) + 2 * (p) * (p) + 2 * (n) * (p) /* state */ \
     + 6 * (n) * (n) + 6 * (n) * (p) + 4 * (p) * (p) + 4 * (m) * (m) + 4 * (m) * ((n) + (p)) \
     + 2 * (m) + 2 * (n) + 2 * (p) /* scratch */)

typedef struct {
    size_t n, m, p;
    dkf_mat_t xt, Px;  /* bias-free estimate x~ and its covariance P^x */
    dkf_mat_t d, Pd;   /* bias estimate d and its covariance P^d */
    dkf_mat_t U, V;    /* blending matrices U_k (after predict), V_k (after update) */
    dkf_mat_t x, P;    /* combined estimate x = x~ + U d (or V d) and its
                          covariance P = P^x + U P^d U^T (or V P^d V^T) */
    dkf_real_t *work;
    int ready;
} dkf_otskf_t;

#define DKF_OTSKF_DECLARE(name, n, m, p) \
    dkf_real_t name##_storage[DKF_OTSKF_STORAGE_LEN(n, m, p)]; \
    dkf_otskf_t name

/* Start from x_{0|0} = x0, P0 and the bias prior d00 = d0, Pd00 = Pd0, with
 * V_0 = 0 (x and d uncorrelated a priori). */
dkf_status_t dkf_otskf_init(dkf_otskf_t *f, size_t n, size_t m, size_t p, dkf_real_t *storage,
                            size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0,
                            const dkf_mat_t *d0, const dkf_mat_t *Pd0);
dkf_status_t dkf_otskf_predict(dkf_otskf_t *f, const dkf_ui_dyn_t *dyn);
dkf_status_t dkf_otskf_update(dkf_otskf_t *f, const dkf_ui_meas_t *meas, const dkf_mat_t *y);

#endif /* DKF_OTSKF_H */
