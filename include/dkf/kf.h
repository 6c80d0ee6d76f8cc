/*
 * dkf/kf.h - linear Kalman filter, covariance form.
 *
 *   x_{k+1} = F_k x_k + u_k + v_k,   v_k ~ (0, Q_k)
 *   y_k     = H_k x_k + w_k,         w_k ~ (0, R_k)
 *
 * Every model matrix is an argument of the step that uses it, so F, Q, H, R
 * (and the measurement dimension, up to the capacity m_max) may change from
 * step to step. The filter keeps x, P, and the last innovation nu = y - H x
 * with its covariance S = H P H^T + R and NIS = nu^T S^{-1} nu, for gating
 * and consistency (NEES/NIS) checks.
 *
 * Storage: the caller declares DKF_KF_STORAGE_LEN(n, m_max) reals (or uses
 * DKF_KF_DECLARE) and passes them to dkf_kf_init. A failed predict or
 * update returns its status and leaves the filter bit-identical.
 */
#ifndef DKF_KF_H
#define DKF_KF_H

#include <stddef.h>

#include "dkf/mat.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The model of one step without an unknown input (letters of
 * dkf/ui_model.h; docs/decisions.md item 18). kf and info take the
 * dynamics and the measurement model as these structs, the data (y, u)
 * as arguments; dkf/tw.h's sensors are dkf_kf_meas_t. */
typedef struct {
    const dkf_mat_t *F; /* F_k, n x n */
    const dkf_mat_t *Q; /* Q_k, n x n, symmetric PSD */
} dkf_kf_dyn_t;

typedef struct {
    const dkf_mat_t *H; /* H_k, m x n */
    const dkf_mat_t *R; /* R_k, m x m, SPD */
} dkf_kf_meas_t;

/* Reals a filter of state dimension n and measurement capacity m needs:
 * x, P, nu, S, and scratch for one step (Joseph form included). */
#define DKF_KF_STORAGE_LEN(n, m) \
    ((n) + (n) * (n) + (m) + (m) * (m) + (n) + (n) * (n) + \
     2 * ((n) > (m) ? (n) * (n) : (n) * (m)) + 2 * (n) * (m) + 2 * (m) * (m))

/* The first DKF_KF_STATE_LEN(n, m) reals of the storage hold x, P, nu and
 * S: a failed call leaves them and the struct bit-identical. The rest is
 * scratch. */
#define DKF_KF_STATE_LEN(n, m) ((n) + (n) * (n) + (m) + (m) * (m))

typedef struct {
    size_t n;         /* state dimension */
    size_t m_max;     /* largest measurement dimension accepted */
    dkf_mat_t x;      /* x_{k|k} or x_{k|k-1}: n x 1 */
    dkf_mat_t P;      /* its error covariance: n x n */
    dkf_mat_t nu;     /* last innovation y - H x_{k|k-1}: m x 1 (m of the last update) */
    dkf_mat_t S;      /* its covariance H P H^T + R: m x m */
    dkf_real_t nis;   /* nu^T S^{-1} nu of the last update */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *work; /* scratch for one step */
        int ready;        /* set by dkf_kf_init */
    } priv;
} dkf_kf_t;

/* Declares a filter `name` and exactly-sized storage `name_storage`, both
 * with the storage class `sc` (static, extern, or empty): at file scope
 * DKF_KF_DECLARE(static, kf, 4, 2); in a function DKF_KF_DECLARE(, kf, 4, 2);
 * The other filters' DKF_*_DECLARE macros take the same form
 * (docs/layout.md, "Storage model"). */
#define DKF_KF_DECLARE(sc, name, n, m) \
    sc dkf_real_t name##_storage[DKF_KF_STORAGE_LEN(n, m)]; \
    sc dkf_kf_t name

/* Binds kf to storage (storage_len reals) and sets x = x0 (n x 1), P = P0
 * (n x n, must be SPD). Returns DKF_ERR_CAPACITY if storage_len is too
 * small, DKF_ERR_NOT_SPD if P0 is not. A failed init writes neither *kf
 * nor the state part of storage (P0 is factored in the scratch part), so
 * an init over a live filter that is refused leaves it as it was. */
dkf_status_t dkf_kf_init(dkf_kf_t *kf, size_t n, size_t m_max, dkf_real_t *storage,
                         size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0);

/* Time update with dyn = {F, Q}: x = F x + u, P = F P F^T + Q. u may be NULL (no known
 * input). Q must be finite and symmetric positive semi-definite:
 * DKF_ERR_NONFINITE if it is not finite, DKF_ERR_NOT_SPD if the new P is
 * not PSD within 4 n eps tr(P) (an indefinite Q). */
dkf_status_t dkf_kf_predict(dkf_kf_t *kf, const dkf_kf_dyn_t *dyn, const dkf_mat_t *u);

/* Measurement update with y (m x 1) and meas = {H (m x n), R (m x m)}, m <= m_max:
 *   nu = y - H x, S = H P H^T + R, K = P H^T S^{-1},
 *   x = x + K nu, P = (I-KH) P (I-KH)^T + K R K^T (DKF_JOSEPH=1, A = I-KH
 *   formed) or P - K H P (DKF_JOSEPH=0).
 * DKF_ERR_NOT_SPD if S is not SPD or the new P is not PSD within
 * 4 n eps tr(P) (an indefinite R; the short form when P+ << P),
 * DKF_ERR_NONFINITE for NaN/Inf in y, H, R or an overflow. */
dkf_status_t dkf_kf_update(dkf_kf_t *kf, const dkf_kf_meas_t *meas, const dkf_mat_t *y);

#ifdef __cplusplus
}
#endif

#endif /* DKF_KF_H */
