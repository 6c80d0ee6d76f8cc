/*
 * A linear model with unknown input as a dkf_nl_model_t, for tests of the
 * nonlinear filters whose answer is known on linear models:
 *   x_{k+1} = F x_k + G d_k + w_k,   z_k = H x_k + D d_k + v_k
 * (n <= LIN_NMAX, m <= LIN_MMAX, p <= LIN_PMAX; row-major doubles). The
 * Jacobians are exact (f_jac, h_jac). fail_h makes h fail (DKF_ERR_MODEL
 * tests). Include after <cmocka.h>; everything is static inline.
 */
#ifndef LIN_MODEL_H
#define LIN_MODEL_H

#include <string.h>

#include "dkf/nl_model.h"

#define LIN_NMAX 4
#define LIN_MMAX 4
#define LIN_PMAX 2

typedef struct {
    size_t n, m, p;
    double F[LIN_NMAX * LIN_NMAX], G[LIN_NMAX * LIN_PMAX];
    double H[LIN_MMAX * LIN_NMAX], D[LIN_MMAX * LIN_PMAX];
    int fail_h;
} lin_ctx_t;

/* out (r) = A (r x n) x + B (r x p) d */
static inline void lin_apply(dkf_real_t *out, const double *A, const double *B, size_t r, size_t n,
                             size_t p, const dkf_real_t *x, const dkf_real_t *d)
{
    size_t i, j;
    for (i = 0; i < r; ++i) {
        double v = 0;
        for (j = 0; j < n; ++j) v += A[i * n + j] * (double)x[j];
        for (j = 0; j < p; ++j) v += B[i * p + j] * (double)d[j];
        out[i] = (dkf_real_t)v;
    }
}

static inline int lin_f(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                        const dkf_real_t *u, dkf_real_t *x_next)
{
    const lin_ctx_t *c = ctx;
    (void)k;
    (void)u;
    lin_apply(x_next, c->F, c->G, c->n, c->n, c->p, x, d);
    return 0;
}

static inline int lin_h(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                        const dkf_real_t *u, dkf_real_t *y)
{
    const lin_ctx_t *c = ctx;
    (void)k;
    (void)u;
    if (c->fail_h) return -1;
    lin_apply(y, c->H, c->D, c->m, c->n, c->p, x, d);
    return 0;
}

static inline void lin_copy(dkf_real_t *dst, const double *src, size_t len)
{
    size_t i;
    for (i = 0; i < len; ++i) dst[i] = (dkf_real_t)src[i];
}

static inline int lin_f_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                            const dkf_real_t *u, dkf_real_t *Fx, dkf_real_t *Fd)
{
    const lin_ctx_t *c = ctx;
    (void)k;
    (void)x;
    (void)d;
    (void)u;
    lin_copy(Fx, c->F, c->n * c->n);
    lin_copy(Fd, c->G, c->n * c->p);
    return 0;
}

static inline int lin_h_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                            const dkf_real_t *u, dkf_real_t *Hx, dkf_real_t *Hd)
{
    const lin_ctx_t *c = ctx;
    (void)k;
    (void)x;
    (void)d;
    (void)u;
    lin_copy(Hx, c->H, c->m * c->n);
    lin_copy(Hd, c->D, c->m * c->p);
    return 0;
}

static inline dkf_nl_model_t lin_model(lin_ctx_t *c)
{
    dkf_nl_model_t md;
    memset(&md, 0, sizeof md);
    md.ctx = c;
    md.n = c->n;
    md.m = c->m;
    md.p = c->p;
    md.f = lin_f;
    md.h = lin_h;
    md.f_jac = lin_f_jac;
    md.h_jac = lin_h_jac;
    return md;
}

#endif /* LIN_MODEL_H */
