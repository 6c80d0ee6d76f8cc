/*
 * dkf/ui_model.h - the linear models with an unknown input d, shared by the
 * unknown-input filters.
 *
 * Library letters (every public header; docs/decisions.md item 18): state
 * n, measurement m, unknown input p; F the transition matrix, H the
 * measurement matrix, G the input's matrix into the state, D its
 * feedthrough into the measurement, Q and R the process and measurement
 * noise covariances. The papers' own letters appear only in comments.
 *
 * Measurement at time k, for every unknown-input filter (dkf_ui_meas_t):
 *   y_k = H_k x_k + D_k d_k + w_k,      w_k ~ (0, R_k)
 * Dynamics, one of two kinds:
 *   d modelled (seed 000: Difference KF, ASKF, OTSKF; dkf_ui_dyn_t):
 *     x_{k+1} = F_k x_k + v_k,          v_k ~ (0, Q_k)
 *     d_{k+1} = B_k d_k + wd_k,         wd_k ~ (0, Rd_k)
 *   d arbitrary, no model and no prior, entering the state (seed 004 uif,
 *   seed 003 tw; dkf_uif_dyn_t):
 *     x_k = F_{k-1} x_{k-1} + G_{k-1} d_{k-1} + w_{k-1},   w ~ (0, Q_{k-1})
 * All noises white, mutually independent, independent of x_0 (and d_0).
 *
 * The papers' letters: seed 000 writes the state dimension m, the
 * measurement dimension n, D_k as A_k and the noises nu_k (R_nu), omega_k
 * (R_omega), omega_d (R_d); seed 004 writes F, H, D as A, C, H, the input
 * dimension m and the measurement dimension p; seed 003 writes F, G, Q, R
 * as A, B, Sv, Sw and d as z. Which of the fields a filter needs, and the
 * conditions on them (rank of D, B nonsingular), are in its own header.
 */
#ifndef DKF_UI_MODEL_H
#define DKF_UI_MODEL_H

#include "dkf/mat.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Dynamics from k to k+1 with a modelled input (seed 000). */
typedef struct {
    const dkf_mat_t *F;  /* F_k, n x n */
    const dkf_mat_t *Q;  /* Q_k = Cov(v_k), n x n, symmetric PSD */
    const dkf_mat_t *B;  /* B_k, p x p (nonsingular for the DKF, OTSKF) */
    const dkf_mat_t *Rd; /* Rd_k = Cov(wd_k), p x p, symmetric PSD */
} dkf_ui_dyn_t;

/* Dynamics from k-1 to k with an arbitrary input entering the state
 * (seeds 004 and 003). */
typedef struct {
    const dkf_mat_t *F; /* F_{k-1}, n x n (seed 004: A_{k-1}, seed 003: A) */
    const dkf_mat_t *G; /* G_{k-1}, n x p (seed 003: B) */
    const dkf_mat_t *Q; /* Q_{k-1} = Cov(w_{k-1}), n x n, symmetric PSD (seed 003: Sv) */
} dkf_uif_dyn_t;

/* Measurement model at one time k. */
typedef struct {
    const dkf_mat_t *H; /* H_k, m x n (seed 004: C_k) */
    const dkf_mat_t *D; /* D_k, m x p (seed 000: A_k, seed 004: H_k; NULL where a
                           filter has no feedthrough) */
    const dkf_mat_t *R; /* R_k = Cov(w_k), m x m, symmetric PSD */
} dkf_ui_meas_t;

#ifdef __cplusplus
}
#endif

#endif /* DKF_UI_MODEL_H */
