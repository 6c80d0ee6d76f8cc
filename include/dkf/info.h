/*
 * dkf/info.h - linear information filter and exact multi-sensor fusion.
 *
 * Information form of the Kalman filter: Y = P^{-1}, y = Y x. A sensor j
 * measuring z_j = H_j x + w_j, w_j ~ (0, R_j) (seed 001's C_j is H_j; z
 * names the measurement here because y is the information vector),
 * contributes
 *   i_j = H_j^T R_j^{-1} z_j,   I_j = H_j^T R_j^{-1} H_j          (seed 001 (29)-(34))
 * and the fused update is a plain sum (seed 001 (54)-(55), linear case):
 *   Y_{k|k} = Y_{k|k-1} + sum_j I_j,   y_{k|k} = y_{k|k-1} + sum_j i_j,
 * which equals the Kalman update on the stacked measurement [z_1; ...; z_L]
 * whenever the sensor noises are mutually uncorrelated. A node computes its
 * (i_j, I_j) with dkf_info_contribution and sends them; the fusion centre
 * adds them with dkf_info_fuse.
 * PER SENSOR: m_j, H_j, R_j and z_j may differ (every contribution is n x n
 * whatever m_j); n is common.
 *
 * The filter keeps both forms (x, P, Y, y): the time update needs P, the
 * measurement update needs Y.
 */
#ifndef DKF_INFO_H
#define DKF_INFO_H

#include <stddef.h>

#include "dkf/kf.h"
#include "dkf/mat.h"

#ifdef __cplusplus
extern "C" {
#endif

/* x, P, y, Y, and scratch for one step. */
#define DKF_INFO_STORAGE_LEN(n) (2 * (n) + 2 * (n) * (n) + 2 * (n) + 3 * (n) * (n))
/* The first DKF_INFO_STATE_LEN(n) reals of the storage hold x, P, y, Y: a
 * failed call leaves them and the struct bit-identical (the rest is
 * scratch). */
#define DKF_INFO_STATE_LEN(n) (2 * (n) + 2 * (n) * (n))
/* Scratch of dkf_info_contribution for state n, measurement m. */
#define DKF_INFO_CONTRIB_WORK(n, m) ((m) * (m) + (n) * (m))

typedef struct {
    size_t n;
    dkf_mat_t x; /* P y: n x 1 */
    dkf_mat_t P; /* Y^{-1}: n x n */
    dkf_mat_t y; /* information vector: n x 1 */
    dkf_mat_t Y; /* information matrix: n x n */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *work;
        int ready;
    } priv;
} dkf_info_t;

/* `name` and `name_storage`, storage class sc (static, extern or empty):
 * the form of DKF_KF_DECLARE (dkf/kf.h). */
#define DKF_INFO_DECLARE(sc, name, n) \
    sc dkf_real_t name##_storage[DKF_INFO_STORAGE_LEN(n)]; \
    sc dkf_info_t name

/* Binds f to storage and starts from x0, P0 (SPD). */
dkf_status_t dkf_info_init(dkf_info_t *f, size_t n, dkf_real_t *storage, size_t storage_len,
                           const dkf_mat_t *x0, const dkf_mat_t *P0);

/* Time update (seed 001 (29)-(30), linear) with dyn = {F, Q} (dkf/kf.h):
 * P- = F P F^T + Q, x- = F x,
 * Y- = (P-)^{-1}, y- = Y- x-. DKF_ERR_NOT_SPD if P- is not SPD (every
 * commit also checks P and Y PSD within 4 n eps tr), DKF_ERR_NONFINITE if
 * a result overflows (finite inputs whose products exceed the real type's
 * range), never NOT_SPD for that. */
dkf_status_t dkf_info_predict(dkf_info_t *f, const dkf_kf_dyn_t *dyn);

/* A sensor's contribution: I = H^T R^{-1} H (n x n), i = H^T R^{-1} z
 * (n x 1), for meas = {H (m x n), R (m x m, SPD)} (dkf/kf.h) and the
 * measurement z (m x 1), in square-root form (R = L L^T, W = L^{-1} H,
 * I = W^T W: a Gram matrix, PSD up to rounding, i = W^T L^{-1} z).
 * Touches no filter: a node computes it and sends (i, I). work:
 * DKF_INFO_CONTRIB_WORK(n, m). DKF_ERR_NOT_SPD (R),
 * DKF_ERR_NONFINITE (NaN/Inf in H, R, z, or an overflow of the results);
 * i and I are written only on success. */
dkf_status_t dkf_info_contribution(dkf_mat_t *i, dkf_mat_t *I, const dkf_kf_meas_t *meas,
                                   const dkf_mat_t *z, dkf_real_t *work);

/* Measurement update with `count` contributions (count may be 0):
 * Y += sum I[j], y += sum i[j], then P = Y^{-1}, x = P y. DKF_ERR_NOT_SPD
 * if Y is not SPD, DKF_ERR_NONFINITE for NaN/Inf in a contribution or an
 * overflow of the sums or results. */
dkf_status_t dkf_info_fuse(dkf_info_t *f, const dkf_mat_t i[], const dkf_mat_t I[],
                           size_t count);

#ifdef __cplusplus
}
#endif

#endif /* DKF_INFO_H */
