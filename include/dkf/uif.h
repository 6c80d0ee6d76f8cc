/*
 * dkf/uif.h - joint state and unknown-input filters (seed 004: Hua, Wang,
 * Zhao 2021, with the corrections of docs/design/uif.md).
 *
 *   x_k = F_{k-1} x_{k-1} + G_{k-1} d_{k-1} + w_{k-1},   w ~ (0, Q_{k-1})
 *   y_k = H_k x_k + D_k d_k + v_k,                        v ~ (0, R_k), R_k > 0
 *
 * Library letters (dkf/ui_model.h): state n, measurement m, unknown input
 * p; the paper writes F, H, D as A, C, H, the input dimension m and the
 * measurement dimension p. d_k is arbitrary (no model, no prior). Three
 * filters share one filter type; the kind is fixed at init:
 *
 *   DKF_UIF_RTSF      Gillijns-De Moor recursive three-step filter with
 *                     direct feedthrough; needs rank D_k = p at every step.
 *   DKF_UIF_NRTSF_DF  the paper's NRTSF-DF (eqs 27-29): any D_k. D_k = Dbar T
 *                     (full-rank decomposition, rank r_k), estimates the
 *                     virtual input T d_k and returns the minimum-norm
 *                     d_{k|k} = T^+ dbar_{k|k}. Equals RTSF when rank D = p.
 *   DKF_UIF_NRTSF     the paper's NRTSF (eqs 51-53), no feedthrough (D = 0):
 *                     G_{k-1} = Gbar T, needs rank(H_k Gbar) = rank G_{k-1};
 *                     the input estimate is one step late, d_{k-1|k}.
 *
 * Every model matrix is an argument of the step that uses it, so all of
 * them (and the ranks r_k) may change from step to step; n, m, p may not.
 *
 * Steps. RTSF / NRTSF-DF: (x0, P0) of init is the PRIOR of x_0
 * (x_{0|-1}, P_{0|-1}); the first dkf_uif_step takes dyn == NULL (input
 * estimation and measurement update with y_0, no time update); every later
 * step takes dyn = (F_{k-1}, G_{k-1}, Q_{k-1}) and the measurement model
 * (H_k, D_k, R_k) with y_k. NRTSF: (x0, P0) = (x_{0|0}, P_{0|0}); every
 * step k = 1, 2, ... takes dyn = (F_{k-1}, G_{k-1}, Q_{k-1}) and (H_k, R_k)
 * with y_k (meas->D must be NULL). A dyn that is NULL when it must not be,
 * or given when it must be NULL, is DKF_ERR_STATE.
 *
 * Statuses of dkf_uif_step (the filter is bit-identical after any error):
 *   DKF_ERR_NOT_SPD    R~_k = H_k P_{k|k-1} H_k^T + R_k is not SPD, or
 *                      P_{k|k} or P_{k|k-1} is not PSD within 4 n eps tr
 *                      (an indefinite Q or R)
 *   DKF_ERR_RANK       RTSF: rank D_k < p.  NRTSF-DF: Dbar^T R~^-1 Dbar
 *                      numerically singular.  NRTSF: rank(H_k Gbar_{k-1}) <
 *                      rank G_{k-1} ((H Gbar)^T R~^-1 H Gbar singular)
 *   DKF_ERR_NONFINITE  NaN/Inf in an input, or produced by the step
 *   DKF_ERR_DIM, DKF_ERR_NULL, DKF_ERR_STATE, DKF_ERR_ARG (meas->D given to
 *   NRTSF), DKF_ERR_NO_CONVERGENCE (SVD)
 * Ranks are decided by singular values with the filter's rank_tol
 * (DKF_RANK_TOL_DEFAULT: max(rows, cols) * eps * sigma_max, docs/reference/matrix.md).
 *
 * Estimability and bias (both informational; the step still returns
 * DKF_OK). After each step, proj = T^+ T (p x p) is the orthogonal
 * projector onto the estimable input subspace (row space of D_k, or of
 * G_{k-1} for NRTSF): d = T^+ T d + (I - T^+ T) d, and only the first part
 * is estimated; d's component along null(D) is returned as exactly 0 and
 * Pd is the covariance of d_hat - proj d, NOT of d_hat - d. estimable[i]
 * summarises column i of proj: DKF_UIF_EST_FULL (d_i itself is estimated,
 * proj e_i = e_i), DKF_UIF_EST_NONE (e_i in null: d_hat_i = 0 carries no
 * information), DKF_UIF_EST_PARTIAL (only a combination involving d_i is).
 * NRTSF-DF feeds the minimum-norm d_{k-1|k-1} into the time update, so its
 * x_{k|k} is biased by G_{k-1} (I - proj_{k-1}) d_{k-1} whenever that
 * matrix is nonzero (the paper's own example): such a step sets
 * bias_risk = 1 and increments bias_steps. RTSF (proj = I) and NRTSF
 * (unbiased for every d) never set it.
 */
#ifndef DKF_UIF_H
#define DKF_UIF_H

#include <stddef.h>

#include "dkf/mat.h"
#include "dkf/ui_model.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    DKF_UIF_RTSF = 0,     /* rank D_k = p required */
    DKF_UIF_NRTSF_DF = 1, /* any D_k; minimum-norm input estimate */
    DKF_UIF_NRTSF = 2     /* D = 0, rank-deficient G allowed; d_{k-1|k} */
} dkf_uif_kind_t;

/* estimable[i] values. */
enum {
    DKF_UIF_EST_NONE = 0,    /* proj(i,i) <= sqrt(eps): d_i not observed at all */
    DKF_UIF_EST_PARTIAL = 1, /* in between: d_i only within a combination */
    DKF_UIF_EST_FULL = 2     /* proj(i,i) >= 1 - sqrt(eps): d_i estimated */
};

/* The model: dkf_uif_dyn_t {F, G, Q} (dynamics from k-1 to k) and
 * dkf_ui_meas_t {H, D, R} (the model at k), dkf/ui_model.h. Of R the step
 * reads the upper triangle for R~ and all of it in the Joseph update: pass
 * a symmetric R (SPD). */

/* Storage layout helpers (private): q = rows of the decomposed matrix
 * (D m x p, or G n x p), outputs = the reals behind the views below. */
#define DKF__UIF_Q(n, m) ((n) > (m) ? (n) : (m))
#define DKF__UIF_OUT_LEN(n, m, p) \
    (2 * (n) + 2 * (n) * (n) + (p) + 2 * (p) * (p) + (n) * (p) + (m) * (m) + 2 * (n) * (m) + \
     (p) * (m))

/* Reals of storage for dimensions (n, m, p): the outputs, the
 * decomposition cache, the outputs' pending copy, scratch for one step
 * (with room for a new decomposition) and SVD workspace. */
#define DKF_UIF_STORAGE_LEN(n, m, p) \
    (2 * DKF__UIF_OUT_LEN(n, m, p) + 3 * DKF__UIF_Q(n, m) * (p) + 2 * (p) * (p) /* caches */ \
     + 2 * (m) * (n) + (m) * (m) + 4 * (m) * (p) + 4 * (p) * (p) + (n) * (n) + 2 * (n) * (p) + \
     (n) * (m) + DKF_MAT_SVD_WORK(DKF__UIF_Q(n, m), p) + \
     2 * ((n) + (m)) * (n) + (m) * (m) /* Joseph-form workspace */)
/* The first DKF_UIF_STATE_LEN(n, m, p) reals of the storage hold the
 * outputs (the views below) and the decomposition cache: a failed call
 * leaves them and the struct bit-identical. The rest is scratch. */
#define DKF_UIF_STATE_LEN(n, m, p) \
    (DKF__UIF_OUT_LEN(n, m, p) + 2 * DKF__UIF_Q(n, m) * (p) + (p) * (p))

typedef struct {
    size_t n, m, p;
    dkf_uif_kind_t kind;
    size_t k; /* successful steps since init */
    /* estimates after the last step */
    dkf_mat_t x;   /* x_{k|k}, n x 1 */
    dkf_mat_t Px;  /* its error covariance, n x n */
    dkf_mat_t d;   /* d_{k|k} (RTSF, NRTSF-DF) or d_{k-1|k} (NRTSF), p x 1;
                      0 before the first step */
    dkf_mat_t Pd;  /* covariance of d_hat - proj d (of d_hat - d when rank = p), p x p */
    dkf_mat_t Pxd; /* E[(x - x_hat)(d - d_hat)^T] (estimable part), n x p */
    /* the last step's intermediates (inspection, tests) */
    dkf_mat_t x_pred, P_pred; /* x_{k|k-1}, P_{k|k-1} (the prior at the first DF step) */
    dkf_mat_t Rtilde;         /* R~_k = H P_{k|k-1} H^T + R, m x m */
    dkf_mat_t K;              /* P_{k|k-1} H^T R~^{-1}, n x m */
    dkf_mat_t L;              /* state gain: x_{k|k} = x_{k|k-1} + L (y - H x_{k|k-1}), n x m */
    dkf_mat_t M;              /* input gain: d_hat = M (y - H x_{k|k-1}), p x m (= T^+ Mbar) */
    dkf_mat_t proj;           /* T^+ T, p x p (I for RTSF) */
    size_t rank;              /* r_k = rank D_k (RTSF, NRTSF-DF) or rank G_{k-1} (NRTSF) */
    unsigned char estimable[DKF_MAX_DIM]; /* DKF_UIF_EST_* per input component */
    int bias_risk;     /* NRTSF-DF: G_{k-1} (I - proj_{k-1}) != 0 in this step */
    size_t bias_steps; /* steps since init with bias_risk set */
    /* Rank tolerance for every rank decision; DKF_RANK_TOL_DEFAULT after
     * init. May be changed between steps. */
    dkf_real_t rank_tol;
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *mem;
        size_t cache_rows, cache_rank;
        dkf_real_t cache_tol;
        int cached;
        int ready;
    } priv;
} dkf_uif_t;

/* `name` and `name_storage`, storage class sc (static, extern or empty):
 * the form of DKF_KF_DECLARE (dkf/kf.h). */
#define DKF_UIF_DECLARE(sc, name, n, m, p) \
    sc dkf_real_t name##_storage[DKF_UIF_STORAGE_LEN(n, m, p)]; \
    sc dkf_uif_t name

/* Binds f to storage (storage_len >= DKF_UIF_STORAGE_LEN(n, m, p) reals)
 * and sets x = x0 (n x 1), Px = P0 (n x n, SPD); d, Pd, Pxd = 0.
 * DKF_ERR_ARG for an unknown kind, DKF_ERR_RANK for RTSF with m < p (rank
 * D = p is impossible), DKF_ERR_CAPACITY, DKF_ERR_NOT_SPD (P0). */
dkf_status_t dkf_uif_init(dkf_uif_t *f, dkf_uif_kind_t kind, size_t n, size_t m, size_t p,
                          dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                          const dkf_mat_t *P0);

/* One step of the filter chosen at init (see the top of this file for the
 * sequence, the statuses and the estimability / bias reporting). */
dkf_status_t dkf_uif_step(dkf_uif_t *f, const dkf_uif_dyn_t *dyn, const dkf_ui_meas_t *meas,
                          const dkf_mat_t *y);

#ifdef __cplusplus
}
#endif

#endif /* DKF_UIF_H */
