/*
 * Seed 001's radar models as dkf_nl_model_t callbacks, for the tests of
 * the seed-001 filters (the vector files' model families):
 *   s1_radar  x = [xi, xi', eta, eta'], d = [omega] (rad/s), T = 1,
 *             f(x, d) = F_CT(omega) x (eq. 62),
 *             h(x, d) = [hypot(r), atan2(r_y, r_x), 10 omega], r = pos - s
 *             (eq. 64), Hd = [0, 0, 10]^T given analytically (h_jac).
 *   s1_ckf    p = 0: f(x) = F_CT(omega_fixed) x, h = [hypot, atan2]
 *             (DF-CKF: the turn rate frozen at omega_hat_0).
 * Evaluated in double, rounded to the library's real type. The bearing
 * (channel 1) is an angle: y_diff wraps it into [-pi, pi).
 * Include after <cmocka.h>; everything is static inline.
 */
#ifndef S1_MODEL_H
#define S1_MODEL_H

#include <math.h>
#include <string.h>

#include "dkf/nl_model.h"

#define S1_N 4
#define S1_PI 3.14159265358979323846

typedef struct {
    double sx, sy;      /* the sensor's position */
    double omega_fixed; /* s1_ckf: the frozen turn rate */
    int ckf;            /* 1: s1_ckf (p = 0, m = 2) */
    int fail_h;         /* h returns -1 when set (error tests) */
} s1_ctx_t;

/* F_CT(w) x, T = 1, with the w -> 0 limits of sin(w)/w, (1 - cos w)/w. */
static inline void s1_ct(const double *x, double w, double *out)
{
    double a, b;
    if (fabs(w) < 1e-3) {
        a = 1 - w * w / 6;
        b = w / 2 - w * w * w / 24;
    } else {
        a = sin(w) / w;
        b = (1 - cos(w)) / w;
    }
    out[0] = x[0] + a * x[1] - b * x[3];
    out[1] = cos(w) * x[1] - sin(w) * x[3];
    out[2] = x[2] + b * x[1] + a * x[3];
    out[3] = sin(w) * x[1] + cos(w) * x[3];
}

static inline int s1_f(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                       const dkf_real_t *u, dkf_real_t *x_next)
{
    const s1_ctx_t *c = ctx;
    double xd[S1_N], out[S1_N];
    size_t i;
    (void)k;
    (void)u;
    for (i = 0; i < S1_N; ++i) xd[i] = (double)x[i];
    s1_ct(xd, c->ckf ? c->omega_fixed : (double)d[0], out);
    for (i = 0; i < S1_N; ++i) x_next[i] = (dkf_real_t)out[i];
    return 0;
}

static inline int s1_h(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                       const dkf_real_t *u, dkf_real_t *y)
{
    const s1_ctx_t *c = ctx;
    const double rx = (double)x[0] - c->sx, ry = (double)x[2] - c->sy;
    (void)k;
    (void)u;
    if (c->fail_h) return -1;
    y[0] = (dkf_real_t)hypot(rx, ry);
    y[1] = (dkf_real_t)atan2(ry, rx);
    if (!c->ckf) y[2] = (dkf_real_t)(10.0 * (double)d[0]);
    return 0;
}

/* Hx (analytic) and Hd = [0, 0, 10]^T of s1_radar. */
static inline int s1_h_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                           const dkf_real_t *u, dkf_real_t *Hx, dkf_real_t *Hd)
{
    const s1_ctx_t *c = ctx;
    const double rx = (double)x[0] - c->sx, ry = (double)x[2] - c->sy;
    const double r2 = rx * rx + ry * ry, r = sqrt(r2);
    const double J[12] = {rx / r, 0, ry / r, 0, -ry / r2, 0, rx / r2, 0, 0, 0, 0, 0};
    size_t i;
    (void)k;
    (void)d;
    (void)u;
    for (i = 0; i < 12; ++i) Hx[i] = (dkf_real_t)J[i];
    Hd[0] = 0;
    Hd[1] = 0;
    Hd[2] = 10;
    return 0;
}

/* a - b, the bearing wrapped into [-pi, pi) */
static inline void s1_y_diff(void *ctx, const dkf_real_t *a, const dkf_real_t *b,
                             dkf_real_t *out)
{
    const s1_ctx_t *c = ctx;
    double e = (double)a[1] - (double)b[1];
    out[0] = a[0] - b[0];
    if (!c->ckf) out[2] = a[2] - b[2];
    e = fmod(e + S1_PI, 2 * S1_PI);
    if (e < 0) e += 2 * S1_PI;
    out[1] = (dkf_real_t)(e - S1_PI);
}

/* The model table over c (c's fields set by the caller). */
static inline dkf_nl_model_t s1_model(s1_ctx_t *c)
{
    dkf_nl_model_t md;
    memset(&md, 0, sizeof md);
    md.ctx = c;
    md.n = S1_N;
    md.m = c->ckf ? 2 : 3;
    md.p = c->ckf ? 0 : 1;
    md.f = s1_f;
    md.h = s1_h;
    md.h_jac = c->ckf ? NULL : s1_h_jac;
    md.y_diff = s1_y_diff;
    return md;
}

#endif /* S1_MODEL_H */
