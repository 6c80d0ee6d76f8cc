/*
 * dkf/mat_riccati.h - steady-state equations of the matrix core: the
 * filtering discrete algebraic Riccati equation (DARE) and the Stein
 * (discrete Sylvester / Lyapunov) equation, both by doubling
 * (docs/matrix.md, "Riccati and Stein equations", gives the methods and
 * why: each iteration squares the closed loop, so a stable one converges
 * in a few dozen steps even at spectral radius 0.999, never forms a
 * Kronecker system of size n^2, and the iterates stay symmetric PSD).
 *
 * Seed 002 uses them for the steady local Kalman filters (the predictor
 * covariance Sigma = lim Sigma(t+1|t) of Theorem 1) and the steady cross
 * covariances P_ij of every pair of local filters.
 */
#ifndef DKF_MAT_RICCATI_H
#define DKF_MAT_RICCATI_H

#include <stddef.h>

#include "dkf/mat.h"

/* Doubling steps before DKF_ERR_NO_CONVERGENCE (or DKF_ERR_UNSTABLE when
 * the iterates show no contraction). Step k accounts for 2^k terms of the
 * series, so 64 is far more than any stable problem needs. */
#ifndef DKF_MAT_DOUBLING_MAX_ITER
#define DKF_MAT_DOUBLING_MAX_ITER 64
#endif

/* Scratch (reals) of dkf_mat_dare for state n, measurement m. */
#define DKF_MAT_DARE_WORK(n, m) (7 * (n) * (n) + 2 * (m) * (m) + 2 * (n) * (m))
/* Scratch (reals) of dkf_mat_stein for X r x c. */
#define DKF_MAT_STEIN_WORK(r, c) (2 * (r) * (r) + 2 * (c) * (c) + 3 * (r) * (c))

/* The stabilising solution X (n x n, symmetric PSD) of the filtering DARE
 *   X = F X F^T - F X H^T (H X H^T + R)^{-1} H X F^T + Q,
 * F n x n, H m x n, Q n x n symmetric PSD, R m x m SPD: X is the steady
 * one-step predictor covariance, and F (I - K H) with
 * K = X H^T (H X H^T + R)^{-1} has every eigenvalue inside the unit
 * circle. Structure-preserving doubling (SDA) on the dual (F^T, H^T).
 * work: DKF_MAT_DARE_WORK(n, m), not overlapping X.
 * DKF_ERR_NOT_SPD: R not SPD or Q not symmetric PSD (beyond rounding).
 * DKF_ERR_UNSTABLE: no stabilising solution ((F, H) not detectable, or
 * an unobservable or unreachable mode on the unit circle).
 * DKF_ERR_NO_CONVERGENCE: no convergence within DKF_MAT_DOUBLING_MAX_ITER.
 * DKF_ERR_NONFINITE: a non-finite input or an overflow. X is written only
 * on success. */
dkf_status_t dkf_mat_dare(dkf_mat_t *X, const dkf_mat_t *F, const dkf_mat_t *H,
                          const dkf_mat_t *Q, const dkf_mat_t *R, dkf_real_t *work);

/* The solution X (r x c) of the Stein equation X = A X B^T + C, A r x r,
 * B c x c, C r x c: X = sum_k A^k C (B^T)^k, unique when
 * rho(A) rho(B) < 1 (with A = B and C symmetric it is the discrete
 * Lyapunov equation and X is symmetric). Smith doubling.
 * work: DKF_MAT_STEIN_WORK(r, c), not overlapping X.
 * DKF_ERR_UNSTABLE: rho(A) rho(B) >= 1 (the series does not contract).
 * DKF_ERR_NO_CONVERGENCE, DKF_ERR_NONFINITE as dkf_mat_dare. X is written
 * only on success. */
dkf_status_t dkf_mat_stein(dkf_mat_t *X, const dkf_mat_t *A, const dkf_mat_t *B,
                           const dkf_mat_t *C, dkf_real_t *work);

#endif /* DKF_MAT_RICCATI_H */
