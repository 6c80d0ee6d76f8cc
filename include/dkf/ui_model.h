/*
 * dkf/ui_model.h - the unknown-input measurement model of seed 000, shared
 * by the Difference KF and its baselines (ASKF, OTSKF):
 *
 *   x_{k+1} = F_k x_k + v_k,              v_k ~ (0, Q_k)     [nu_k, R_nu]
 *   y_k     = H_k x_k + A_k d_k + w_k,    w_k ~ (0, R_k)     [omega_k, R_omega]
 *   d_{k+1} = B_k d_k + wd_k,             wd_k ~ (0, Rd_k)   [omega_d, R_d]
 *
 * Library dimensions: state n [paper m], measurement m [paper n], unknown
 * input p. All noises white, mutually independent, independent of x_0, d_0.
 */
#ifndef DKF_UI_MODEL_H
#define DKF_UI_MODEL_H

#include "dkf/mat.h"

/* Dynamics from k to k+1. */
typedef struct {
    const dkf_mat_t *F;  /* F_k, n x n */
    const dkf_mat_t *Q;  /* Q_k = Cov(v_k), n x n, symmetric PSD */
    const dkf_mat_t *B;  /* B_k, p x p, nonsingular */
    const dkf_mat_t *Rd; /* Rd_k = Cov(wd_k), p x p, symmetric PSD */
} dkf_ui_dyn_t;

/* Measurement model at one time k. */
typedef struct {
    const dkf_mat_t *H; /* H_k, m x n */
    const dkf_mat_t *A; /* A_k, m x p, full column rank */
    const dkf_mat_t *R; /* R_k = Cov(w_k), m x m, symmetric PSD */
} dkf_ui_meas_t;

#endif /* DKF_UI_MODEL_H */
