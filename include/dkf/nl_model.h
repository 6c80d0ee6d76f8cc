/*
 * dkf/nl_model.h - the nonlinear model with unknown inputs, as a table of
 * callbacks with a user context (the form of littlefs's lfs_config).
 *
 *   x_{k+1} = f(x_k, d_k, u_k) + w_k        w_k ~ N(0, Q_k)
 *   y_k     = h(x_k, d_k, u_k) + v_k        v_k ~ N(0, R_k)
 *
 * x state (n), y measurement (m), d unknown input (p, no model of its
 * own), u known input (q, may be 0). Seed 001 writes the measurement
 * function g and its Jacobians A = df/dx, G = df/dd, C = dg/dx,
 * H = dg/dd (eqs 6-9); here they are Fx, Fd, Hx, Hd, named for the
 * function and the variable, so the letters cannot clash with the linear
 * modules' F, H (docs/layout.md).
 *
 * Every filter that takes a dkf_nl_model_t calls the callbacks only from
 * inside its own step and never keeps a pointer they return. A callback
 * returns 0 on success; anything else makes the step fail with
 * DKF_ERR_MODEL, and a non-finite value in what it wrote with
 * DKF_ERR_NONFINITE; either way the filter is left exactly as it was.
 * Matrices are row-major, the layout of dkf_mat_t.
 */
#ifndef DKF_NL_MODEL_H
#define DKF_NL_MODEL_H

#include <stddef.h>

#include "dkf/mat.h"
#include "dkf/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct dkf_nl_model {
    /* Passed unchanged as the first argument of every callback. */
    void *ctx;
    /* Dimensions: state n, measurement m, unknown input p, known input q
     * (q = 0: u is NULL in every call). Each at most DKF_MAX_DIM. */
    size_t n, m, p, q;

    /* f: x_next (n) = f(x (n), d (p), u (q)) for the step k -> k+1.
     * Required. Writes only x_next, which never aliases an input. */
    int (*f)(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
             const dkf_real_t *u, dkf_real_t *x_next);

    /* h: y (m) = h(x (n), d (p), u (q)) at time k.
     * Required. Writes only y, which never aliases an input. */
    int (*h)(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
             const dkf_real_t *u, dkf_real_t *y);

    /* f_jac: Fx = df/dx (n x n) and Fd = df/dd (n x p) at (x, d, u).
     * Optional: NULL means forward differences (dkf_nl_f_jacobian). */
    int (*f_jac)(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                 const dkf_real_t *u, dkf_real_t *Fx, dkf_real_t *Fd);

    /* h_jac: Hx = dh/dx (m x n) and Hd = dh/dd (m x p) at (x, d, u).
     * Optional: NULL means forward differences (dkf_nl_h_jacobian). */
    int (*h_jac)(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                 const dkf_real_t *u, dkf_real_t *Hx, dkf_real_t *Hd);

    /* y_diff: out (m) = a - b for two measurements, e.g. a bearing wrapped
     * into [-pi, pi). Optional: NULL means plain subtraction. Pure; out may
     * alias a. Filters form innovations and sample spreads only through it. */
    void (*y_diff)(void *ctx, const dkf_real_t *a, const dkf_real_t *b, dkf_real_t *out);
} dkf_nl_model_t;

/* The forward differences' step: DKF_NL_FD_STEP (dkf/config.h). */

/* Scratch, in reals, of dkf_nl_f_jacobian / dkf_nl_h_jacobian: the two
 * Jacobians (r x (n + p), r = max(n, m)), two function values (r each)
 * and the moved point (n + p). */
#define DKF_NL_R_(n, m) ((n) > (m) ? (n) : (m))
#define DKF_NL_JAC_WORK(n, m, p) \
    (DKF_NL_R_(n, m) * ((n) + (p)) + 2 * DKF_NL_R_(n, m) + (n) + (p))

/* DKF_OK if the table can be used: f and h set (DKF_ERR_NULL), n and m
 * at least 1, and n, m, p, q at most DKF_MAX_DIM (DKF_ERR_CAPACITY); p = 0
 * is a model without unknown input (seed 001's DF-CKF). */
dkf_status_t dkf_nl_model_check(const dkf_nl_model_t *model);

/* Fx (n x n) and Fd (n x p) at (x, d, u): model->f_jac, or forward
 * differences of f when it is NULL (Fd is not touched when p = 0). work:
 * DKF_NL_JAC_WORK(n, m, p) reals, disjoint from everything else.
 * DKF_ERR_MODEL if a callback failed, DKF_ERR_NONFINITE if a value it gave
 * or a difference quotient is not finite; Fx, Fd are written only on
 * success. */
dkf_status_t dkf_nl_f_jacobian(const dkf_nl_model_t *model, size_t k, const dkf_real_t *x,
                               const dkf_real_t *d, const dkf_real_t *u, dkf_real_t *Fx,
                               dkf_real_t *Fd, dkf_real_t *work);

/* Hx (m x n) and Hd (m x p) at (x, d, u): model->h_jac, or forward
 * differences of h (each column through y_diff) when it is NULL. As
 * dkf_nl_f_jacobian otherwise. */
dkf_status_t dkf_nl_h_jacobian(const dkf_nl_model_t *model, size_t k, const dkf_real_t *x,
                               const dkf_real_t *d, const dkf_real_t *u, dkf_real_t *Hx,
                               dkf_real_t *Hd, dkf_real_t *work);

/* out (m) = a - b through model->y_diff (plain subtraction when NULL). */
void dkf_nl_y_diff(const dkf_nl_model_t *model, const dkf_real_t *a, const dkf_real_t *b,
                   dkf_real_t *out);

#ifdef __cplusplus
}
#endif

#endif /* DKF_NL_MODEL_H */
