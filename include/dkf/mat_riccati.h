/*
 * dkf/mat_riccati.h - steady-state equations of the matrix core: the
 * filtering discrete algebraic Riccati equation (DARE) and the Stein
 * (discrete Sylvester / Lyapunov) equation, both by doubling
 * (docs/reference/matrix.md, "Riccati and Stein equations", gives the methods and
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

#ifdef __cplusplus
extern "C" {
#endif

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
 * circle. Structure-preserving doubling (SDA) on the dual (F^T, H^T),
 * stopped when ||H_{k+1} - H_k||_1 <= n eps ||H_{k+1}||_1; the returned X
 * is certified: ||Phi^(2^j)||_1 <= 1/2 for Phi = F (I - K H) and some j
 * with 2^j n eps < 1 (so rho(Phi) < 1 by a margin the rounding cannot
 * fake), X exactly symmetric and PSD within 4 n eps tr(X).
 * work: DKF_MAT_DARE_WORK(n, m), overlapping no argument; on success
 * work[0] holds the number of doubling steps taken (a small integer).
 * DKF_ERR_NOT_SPD: R not SPD, or Q not symmetric PSD, beyond rounding
 * (asymmetry above 4 n eps max|Q|; Q + 4 n eps tr(Q) I not SPD).
 * DKF_ERR_UNSTABLE: no stabilising solution: (F, H) not detectable (the
 * iterates diverge, or converge to an X whose closed loop keeps the
 * unobservable mode), or a mode on the unit circle that Q does not reach
 * or H does not see (e.g. a rotation F with Q = 0: H_k stays exactly 0,
 * X = 0 is reached at once and its closed loop is F, rho = 1), counting a
 * closed loop within ~n eps of the unit circle as on it; also a
 * breakdown (non-finite iterate) while ||A_k||_1 >= 1.
 * DKF_ERR_NO_CONVERGENCE: no convergence within DKF_MAT_DOUBLING_MAX_ITER
 * while the doubled closed loop contracts (||A_k||_1 < 1).
 * DKF_ERR_NONFINITE: a non-finite input, or an overflow while
 * ||A_k||_1 < 1. X is written only on success. */
dkf_status_t dkf_mat_dare(dkf_mat_t *X, const dkf_mat_t *F, const dkf_mat_t *H,
                          const dkf_mat_t *Q, const dkf_mat_t *R, dkf_real_t *work);

/* The solution X (r x c) of the Stein equation X = A X B^T + C, A r x r,
 * B c x c, C r x c: X = sum_k A^k C (B^T)^k, unique when
 * rho(A) rho(B) < 1 (with A = B and C symmetric it is the discrete
 * Lyapunov equation; A and B with identical elements and C exactly
 * symmetric give an exactly symmetric X). Smith doubling, A_k and B_k
 * rescaled by powers of two (the series is unchanged) so that neither
 * overflows while the other underflows; stopped when
 * ||X_{k+1} - X_k||_1 <= max(r, c) eps ||X_{k+1}||_1 and
 * ||A_k||_1 ||B_k||_1 <= 1/2 for some k with 2^k max(r, c) eps < 1.
 * work: DKF_MAT_STEIN_WORK(r, c), overlapping no argument; on success
 * work[0] holds the number of doubling steps taken.
 * DKF_ERR_UNSTABLE: rho(A) rho(B) >= 1 (the series does not contract),
 * counting a product within ~max(r, c) eps of 1 as 1, also when C = 0.
 * DKF_ERR_NO_CONVERGENCE, DKF_ERR_NONFINITE as dkf_mat_dare. X is written
 * only on success. */
dkf_status_t dkf_mat_stein(dkf_mat_t *X, const dkf_mat_t *A, const dkf_mat_t *B,
                           const dkf_mat_t *C, dkf_real_t *work);

#ifdef __cplusplus
}
#endif

#endif /* DKF_MAT_RICCATI_H */
