/*
 * Test models of seed 001 for the nerts filters (dkf/nerts.h), written
 * here from the vector files' `equations` texts, independent of the
 * library: the lin_x_sin_d model (nertsif.json) and the constant-turn
 * radar (dnertsif_single.json), each with analytic Jacobians, and the
 * bearing's wrapped difference. Static inline: each test file gets its own
 * copy of what it uses.
 */
#ifndef NERTS_FIXTURE_H
#define NERTS_FIXTURE_H

#include <math.h>
#include <stddef.h>

#include "dkf/nl_model.h"

#define FX_PI 3.14159265358979323846

/* ---- lin_x_sin_d: f(x, d) = A x + B sin(d), h(x, d) = C x + H d ---------- */
#define LXS_MAX 8
typedef struct {
    size_t n, m, p;
    double A[LXS_MAX * LXS_MAX], B[LXS_MAX * LXS_MAX], C[LXS_MAX * LXS_MAX],
        H[LXS_MAX * LXS_MAX];
    int fail_f, fail_h; /* callbacks report failure (error tests) */
    int nan_h;          /* h writes a NaN */
    int linear;         /* f = A x + B d (sin dropped): a linear model */
} lxs_t;

static inline double lxs_s(const lxs_t *c, double d)
{
    return c->linear ? d : sin(d);
}

static inline int lxs_f(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                 const dkf_real_t *u, dkf_real_t *xn)
{
    const lxs_t *c = ctx;
    size_t i, j;
    (void)k, (void)u;
    if (c->fail_f) return 1;
    for (i = 0; i < c->n; ++i) {
        double v = 0.0;
        for (j = 0; j < c->n; ++j) v += c->A[i * c->n + j] * (double)x[j];
        for (j = 0; j < c->p; ++j) v += c->B[i * c->p + j] * lxs_s(c, (double)d[j]);
        xn[i] = (dkf_real_t)v;
    }
    return 0;
}

static inline int lxs_h(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                 const dkf_real_t *u, dkf_real_t *y)
{
    const lxs_t *c = ctx;
    size_t i, j;
    (void)k, (void)u;
    if (c->fail_h) return 1;
    for (i = 0; i < c->m; ++i) {
        double v = 0.0;
        for (j = 0; j < c->n; ++j) v += c->C[i * c->n + j] * (double)x[j];
        for (j = 0; j < c->p; ++j) v += c->H[i * c->p + j] * (double)d[j];
        y[i] = (dkf_real_t)v;
    }
    if (c->nan_h) y[0] = (dkf_real_t)NAN;
    return 0;
}

static inline int lxs_f_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                     const dkf_real_t *u, dkf_real_t *Fx, dkf_real_t *Fd)
{
    const lxs_t *c = ctx;
    size_t i, j;
    (void)k, (void)x, (void)u;
    if (c->fail_f) return 1;
    for (i = 0; i < c->n * c->n; ++i) Fx[i] = (dkf_real_t)c->A[i];
    for (i = 0; i < c->n; ++i)
        for (j = 0; j < c->p; ++j)
            Fd[i * c->p + j] =
                (dkf_real_t)(c->B[i * c->p + j] * (c->linear ? 1.0 : cos((double)d[j])));
    return 0;
}

static inline int lxs_h_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                     const dkf_real_t *u, dkf_real_t *Hx, dkf_real_t *Hd)
{
    const lxs_t *c = ctx;
    size_t i;
    (void)k, (void)x, (void)d, (void)u;
    if (c->fail_h) return 1;
    for (i = 0; i < c->m * c->n; ++i) Hx[i] = (dkf_real_t)c->C[i];
    for (i = 0; i < c->m * c->p; ++i) Hd[i] = (dkf_real_t)c->H[i];
    return 0;
}

static inline dkf_nl_model_t lxs_model(lxs_t *c, int jacobians)
{
    dkf_nl_model_t md;
    md.ctx = c;
    md.n = c->n;
    md.m = c->m;
    md.p = c->p;
    md.q = 0;
    md.f = lxs_f;
    md.h = lxs_h;
    md.f_jac = jacobians ? lxs_f_jac : NULL;
    md.h_jac = jacobians ? lxs_h_jac : NULL;
    md.y_diff = NULL;
    return md;
}

/* ---- the seed-001 radar: x = [xi, xi', eta, eta'], d = [omega] ----------- */
typedef struct {
    double sx, sy;      /* sensor position */
    int with_omega;     /* m = 3 (range, bearing, 10 omega) or 2 (DF-CKF) */
    double omega_fixed; /* p = 0 (DF-CKF): the frozen turn rate */
    double rot;         /* the bearing is measured from direction rot (0: the x axis),
                           so its branch cut lies at rot + pi */
} radar_t;

/* F_CT(w) x, T = 1 (eq 62). */
static inline void radar_ct(double w, const dkf_real_t *x, dkf_real_t *xn)
{
    const double s = sin(w), c = cos(w);
    const double a = fabs(w) > 1e-12 ? s / w : 1.0, b = fabs(w) > 1e-12 ? (1.0 - c) / w : 0.0;
    const double xi = (double)x[0], xd = (double)x[1], eta = (double)x[2], ed = (double)x[3];
    xn[0] = (dkf_real_t)(xi + a * xd - b * ed);
    xn[1] = (dkf_real_t)(c * xd - s * ed);
    xn[2] = (dkf_real_t)(eta + b * xd + a * ed);
    xn[3] = (dkf_real_t)(s * xd + c * ed);
}

static inline int radar_f(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                   const dkf_real_t *u, dkf_real_t *xn)
{
    const radar_t *r = ctx;
    (void)k, (void)u;
    radar_ct(r->with_omega ? (double)d[0] : r->omega_fixed, x, xn);
    return 0;
}

/* Fx = F_CT(w), Fd = d(F_CT(w) x)/dw (radar's d = [w]). */
static inline int radar_f_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                              const dkf_real_t *u, dkf_real_t *Fx, dkf_real_t *Fd)
{
    const radar_t *r = ctx;
    const double w = r->with_omega ? (double)d[0] : r->omega_fixed, s = sin(w), c = cos(w);
    const double a = s / w, b = (1.0 - c) / w;
    const double da = (w * c - s) / (w * w), db = (w * s - (1.0 - c)) / (w * w);
    const double xd = (double)x[1], ed = (double)x[3];
    const double J[16] = {1, a, 0, -b, 0, c, 0, -s, 0, b, 1, a, 0, s, 0, c};
    size_t i;
    (void)k, (void)u;
    for (i = 0; i < 16; ++i) Fx[i] = (dkf_real_t)J[i];
    if (r->with_omega) {
        Fd[0] = (dkf_real_t)(da * xd - db * ed);
        Fd[1] = (dkf_real_t)(-s * xd - c * ed);
        Fd[2] = (dkf_real_t)(db * xd + da * ed);
        Fd[3] = (dkf_real_t)(c * xd - s * ed);
    }
    return 0;
}

static inline int radar_h(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                   const dkf_real_t *u, dkf_real_t *y)
{
    const radar_t *r = ctx;
    const double dx = (double)x[0] - r->sx, dy = (double)x[2] - r->sy;
    const double c = cos(r->rot), s = sin(r->rot);
    (void)k, (void)u;
    y[0] = (dkf_real_t)hypot(dx, dy);
    y[1] = (dkf_real_t)atan2(c * dy - s * dx, c * dx + s * dy);
    if (r->with_omega) y[2] = (dkf_real_t)(10.0 * (double)d[0]);
    return 0;
}

static inline int radar_h_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                       const dkf_real_t *u, dkf_real_t *Hx, dkf_real_t *Hd)
{
    const radar_t *r = ctx;
    const double dx = (double)x[0] - r->sx, dy = (double)x[2] - r->sy;
    const double q = dx * dx + dy * dy, rr = sqrt(q);
    size_t i;
    (void)k, (void)d, (void)u;
    for (i = 0; i < (size_t)(r->with_omega ? 12 : 8); ++i) Hx[i] = 0;
    Hx[0] = (dkf_real_t)(dx / rr);
    Hx[2] = (dkf_real_t)(dy / rr);
    Hx[4] = (dkf_real_t)(-dy / q);
    Hx[6] = (dkf_real_t)(dx / q);
    if (r->with_omega) {
        Hd[0] = 0;
        Hd[1] = 0;
        Hd[2] = 10;
    }
    return 0;
}

/* v wrapped into [-pi, pi). */
static inline double fx_wrap(double v)
{
    double w = fmod(v + FX_PI, 2.0 * FX_PI);
    if (w < 0) w += 2.0 * FX_PI;
    return w - FX_PI;
}

/* a - b with the bearing (channel 1) wrapped. */
static inline void radar_y_diff(void *ctx, const dkf_real_t *a, const dkf_real_t *b, dkf_real_t *out)
{
    const radar_t *r = ctx;
    out[0] = a[0] - b[0];
    out[1] = (dkf_real_t)fx_wrap((double)a[1] - (double)b[1]);
    if (r->with_omega) out[2] = a[2] - b[2];
}

static inline dkf_nl_model_t radar_model(radar_t *r, int jacobian)
{
    dkf_nl_model_t md;
    md.ctx = r;
    md.n = 4;
    md.m = r->with_omega ? 3 : 2;
    md.p = r->with_omega ? 1 : 0;
    md.q = 0;
    md.f = radar_f;
    md.h = radar_h;
    md.f_jac = jacobian ? radar_f_jac : NULL;
    md.h_jac = jacobian ? radar_h_jac : NULL;
    md.y_diff = radar_y_diff;
    return md;
}

#endif /* NERTS_FIXTURE_H */
