/*
 * dkf/askf.h - the augmented-state Kalman filter (ASKF), the classical
 * baseline of seed 000: a Kalman filter on X = [x; d] with
 *   Phi_k = blockdiag(F_k, B_k),  Q^a_k = blockdiag(Q_k, Rd_k),
 *   H^a_k = [H_k  D_k],           R_k,
 * for the model of dkf/ui_model.h. It needs a prior for d_0 (d00, Pd00);
 * with a wrong d00 its estimates suffer, which is what the Difference KF
 * avoids.
 *
 * The augmented matrices are rebuilt from the model at every step, so
 * every model matrix may change with k (the dimensions may not). The ASKF
 * itself needs neither B_k nonsingular nor D_k of full column rank (the
 * model of ui_model.h asks for both; the DKF and the OTSKF use them).
 * A failed call leaves the filter bit-identical (dkf_kf_* are atomic and
 * the augmented matrices are scratch).
 */
#ifndef DKF_ASKF_H
#define DKF_ASKF_H

#include <stddef.h>

#include "dkf/kf.h"
#include "dkf/ui_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reals of storage for state n, measurement m, input p: the KF on n + p
 * states, then Phi and Q^a ((n+p)^2 each) and H^a (m x (n+p)). */
#define DKF_ASKF_STORAGE_LEN(n, m, p) \
    (DKF_KF_STORAGE_LEN((n) + (p), m) + 2 * ((n) + (p)) * ((n) + (p)) + (m) * ((n) + (p)))

/* The first DKF_ASKF_STATE_LEN(n, m, p) reals of the storage are the KF's
 * state (X, P^a, nu, S): a failed call leaves them and the struct
 * bit-identical. The rest is scratch. */
#define DKF_ASKF_STATE_LEN(n, m, p) DKF_KF_STATE_LEN((n) + (p), m)

typedef struct {
    size_t n, m, p;
    dkf_kf_t kf;      /* the KF on X = [x; d]: kf.x = X (n+p), kf.P = P^a */
    /* private: the library's own; the caller neither reads nor writes it */
    struct {
        dkf_real_t *aug; /* Phi, Q^a (n+p)^2 each and H^a (m x (n+p)), built per step */
        int ready;
    } priv;
} dkf_askf_t;

/* `name` and `name_storage`, storage class sc (static, extern or empty):
 * the form of DKF_KF_DECLARE (dkf/kf.h). */
#define DKF_ASKF_DECLARE(sc, name, n, m, p) \
    sc dkf_real_t name##_storage[DKF_ASKF_STORAGE_LEN(n, m, p)]; \
    sc dkf_askf_t name

/* X_{0|0} = [x0; d0], P^a_{0|0} = [[P0, Pxd0], [Pxd0^T, Pd0]] (Pxd0 may be
 * NULL for zero). P^a must be SPD (DKF_ERR_NOT_SPD). n + p must not
 * exceed DKF_MAX_DIM (DKF_ERR_CAPACITY). Like dkf_kf_init, a failed init
 * writes neither *f nor the state part of `storage` (it may use the
 * scratch part). */
dkf_status_t dkf_askf_init(dkf_askf_t *f, size_t n, size_t m, size_t p, dkf_real_t *storage,
                           size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0,
                           const dkf_mat_t *d0, const dkf_mat_t *Pd0, const dkf_mat_t *Pxd0);
/* X = Phi X, P^a = Phi P^a Phi^T + Q^a with the dynamics at k. */
dkf_status_t dkf_askf_predict(dkf_askf_t *f, const dkf_ui_dyn_t *dyn);
/* Update with y_k and the measurement model at k. DKF_ERR_NOT_SPD if the
 * innovation covariance H^a P^a H^a^T + R is not SPD. */
dkf_status_t dkf_askf_update(dkf_askf_t *f, const dkf_ui_meas_t *meas, const dkf_mat_t *y);
/* The state block: x (may be NULL) becomes a view (n x 1) of the filter's
 * x; P_x, the leading n x n block of P^a, is copied into Px (may be NULL;
 * else it must be n x n). Nothing is written unless both are valid. */
dkf_status_t dkf_askf_state(const dkf_askf_t *f, dkf_mat_t *x, dkf_mat_t *Px);
/* The input block, likewise: d (may be NULL) becomes a view (p x 1) of
 * the filter's d; P_d, the trailing p x p block of P^a, is copied into Pd
 * (may be NULL; else p x p). */
dkf_status_t dkf_askf_input(const dkf_askf_t *f, dkf_mat_t *d, dkf_mat_t *Pd);

#ifdef __cplusplus
}
#endif

#endif /* DKF_ASKF_H */
