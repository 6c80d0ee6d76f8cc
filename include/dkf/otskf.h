/*
 * dkf/otskf.h - the optimal two-stage Kalman filter (OTSKF, Hsieh & Chen
 * 1999 structure, derived for d_{k+1} = B_k d_k + wd_k; docs/design/diffkf.md and
 * the corrected equations of docs/design/derivation-seed000.md §5). A bias-free filter
 * (x~, P^x) and a bias filter (d, P^d) are coupled by the blending matrices
 * U_k, V_k:
 *   x_{k|k-1} = x~_{k|k-1} + U_k d_{k|k-1},   x_{k|k} = x~_{k|k} + V_k d_{k|k}.
 * It is exactly equivalent to the ASKF initialised alike (tests check
 * 1e-9), at lower cost: it never forms an (n+p)-dimensional matrix.
 *
 * Every model matrix may change with k (the dimensions may not). B_k must
 * be nonsingular (Ubar_k = F V B^{-1}) and D_k of full column rank (the
 * model of dkf/ui_model.h; checked at every update). Predict and update need not
 * alternate: a predict without an update (missing measurement) or several
 * updates at one time (sequential sensors sharing d) are exact, because
 * each step starts from the blending matrix of the last call (V after an
 * update or init, U after a predict). A failed call leaves the filter
 * bit-identical.
 */
#ifndef DKF_OTSKF_H
#define DKF_OTSKF_H

#include <stddef.h>

#include "dkf/ui_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The first DKF_OTSKF_STATE_LEN(n, p) reals of the storage hold the state
 * (x~, x, P^x, P, d, P^d, U, V): a failed call leaves them and the struct
 * bit-identical. */
#define DKF_OTSKF_STATE_LEN(n, p) \
    (2 * (n) + 2 * (n) * (n) + (p) + (p) * (p) + 2 * (n) * (p))
/* Private (the layouts of src/otskf.c, named here only because
 * DKF_OTSKF_STORAGE_LEN must be a constant expression): the scratch of
 * the time update, of the measurement update, and the Joseph-form
 * workspace of the updates of P^x (N = n) and P^d (N = p) in it. */
#define DKF__OTSKF_PREDICT_LEN(n, p) \
    (5 * (p) * (p) + 4 * (n) * (p) + 3 * (n) * (n) + (p) + 2 * (n))
#define DKF__OTSKF_UPDATE_LEN(n, m, p) \
    (3 * (m) * (m) + 2 * (m) * (n) + 3 * (m) * (p) + 2 * (n) * (n) + (p) * (p) + \
     2 * (n) * (p) + (m) + 2 * (n) + (p) + DKF__OTSKF_JOSEPH_LEN((n) > (p) ? (n) : (p), m))
#define DKF__OTSKF_JOSEPH_LEN(N, m) (2 * ((N) + (m)) * (N) + (m) * (m))
/* Storage, in reals, for state n, measurement m, input p: the state, then
 * scratch for the larger of the two steps, then a copy of the last D_k
 * found of full column rank (m p; the rank check's SVD is skipped while
 * D_k is bitwise that matrix). Exact: dkf_otskf_init accepts no less. */
#define DKF_OTSKF_STORAGE_LEN(n, m, p) \
    (DKF_OTSKF_STATE_LEN(n, p) + \
     (DKF__OTSKF_PREDICT_LEN(n, p) > DKF__OTSKF_UPDATE_LEN(n, m, p) \
          ? DKF__OTSKF_PREDICT_LEN(n, p) \
          : DKF__OTSKF_UPDATE_LEN(n, m, p)) + \
     (m) * (p))

typedef struct {
    size_t n, m, p;
    dkf_mat_t xt, Px;  /* bias-free estimate x~ and its covariance P^x */
    dkf_mat_t d, Pd;   /* bias estimate d and its covariance P^d */
    dkf_mat_t U, V;    /* blending matrices U_k (after predict), V_k (after update) */
    dkf_mat_t x, P;    /* combined estimate x = x~ + U d (or V d) and its
                          covariance P = P^x + U P^d U^T (or V P^d V^T) */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *work;  /* step scratch (not state) */
        dkf_real_t *D_ok;  /* m x p: the last D_k that passed the rank check */
        int d_checked;     /* 1 once D_ok holds such a matrix */
        int blend_is_v;    /* 1 after init/update (x = x~ + V d), 0 after predict */
        int ready;
    } priv;
} dkf_otskf_t;

/* `name` and `name_storage`, storage class sc (static, extern or empty):
 * the form of DKF_KF_DECLARE (dkf/kf.h). */
#define DKF_OTSKF_DECLARE(sc, name, n, m, p) \
    sc dkf_real_t name##_storage[DKF_OTSKF_STORAGE_LEN(n, m, p)]; \
    sc dkf_otskf_t name

/* Start from x_{0|0} = x0, P0 and the bias prior d00 = d0, Pd00 = Pd0, with
 * V_0 = U_0 = 0 (x and d uncorrelated a priori). P0 and Pd0 must be SPD
 * (DKF_ERR_NOT_SPD). A failed init writes neither *f nor the state part
 * of `storage` (it may use the scratch part). */
dkf_status_t dkf_otskf_init(dkf_otskf_t *f, size_t n, size_t m, size_t p, dkf_real_t *storage,
                            size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0,
                            const dkf_mat_t *d0, const dkf_mat_t *Pd0);
/* Time update with the dynamics at k-1. DKF_ERR_SINGULAR if B is singular,
 * DKF_ERR_NOT_SPD if P^d_{k|k-1} = B P^d B^T + Rd is not SPD, or if
 * P^x, P^d or P is not PSD within 4 n eps tr (an indefinite Q or Rd). */
dkf_status_t dkf_otskf_predict(dkf_otskf_t *f, const dkf_ui_dyn_t *dyn);
/* Measurement update with y_k and the model at k. DKF_ERR_RANK if D_k
 * lacks full column rank p (numerical rank by SVD with
 * DKF_RANK_TOL_DEFAULT; so also whenever p > m; skipped while D_k is
 * bitwise the last D that passed), DKF_ERR_NOT_SPD if the
 * bias-free innovation covariance H P^x H^T + R or the bias filter's
 * H P^x H^T + R + S P^d S^T (S = H U + D) is not SPD, or if the updated
 * P^x, P^d or P is not PSD within 4 n eps tr. P^x and P^d are updated in
 * Joseph form (DKF_JOSEPH; docs/design/diffkf.md). */
dkf_status_t dkf_otskf_update(dkf_otskf_t *f, const dkf_ui_meas_t *meas, const dkf_mat_t *y);

#ifdef __cplusplus
}
#endif

#endif /* DKF_OTSKF_H */
