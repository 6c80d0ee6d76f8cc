/*
 * nlm_model.c - the core's callbacks over a host nonlinear model
 * (nlm_model.h): dkf_real_t <-> double around the source's functions,
 * every value checked for finiteness, the angle channels wrapped; no
 * JSON here (nlm.c loads).
 */
#include "nlm_model.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void dkf_nlm_set_failure(dkf_nlm_t *m, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(m->failure, sizeof m->failure, fmt, ap);
    va_end(ap);
}

const char *dkf_nlm_failure(const dkf_nlm_t *m)
{
    return m != NULL ? m->failure : "";
}

/* ---- the core's callbacks ------------------------------------------------------ */

static void to_double(double *dst, const dkf_real_t *src, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) dst[i] = (double)src[i];
}

/* dst = src in the library's real type; -1 (reason in m) if a value is not
 * finite there (in float also a finite double above FLT_MAX). */
static int to_real(dkf_nlm_t *m, dkf_real_t *dst, const double *src, size_t n, const char *what)
{
    size_t i;
    for (i = 0; i < n; ++i) {
        dst[i] = (dkf_real_t)src[i];
        if (!isfinite(dst[i])) {
            dkf_nlm_set_failure(m, "%s: %s[%zu] = %g is not finite", m->path, what, i, src[i]);
            return -1;
        }
    }
    return 0;
}

typedef int (*value_fn)(dkf_nlm_t *m, const double *x, const double *d, double *out);

/* out (count) = fn(x, d), converted and checked. */
static int value(dkf_nlm_t *m, value_fn fn, const dkf_real_t *x, const dkf_real_t *d,
                 dkf_real_t *out, size_t count, const char *what)
{
    double xd[DKF_MAX_DIM], dd[DKF_MAX_DIM], o[DKF_MAX_DIM];
    to_double(xd, x, m->n);
    to_double(dd, d, m->p);
    if (fn(m, xd, dd, o) != 0) return -1;
    return to_real(m, out, o, count, what);
}

static int cb_f(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                const dkf_real_t *u, dkf_real_t *x_next)
{
    dkf_nlm_t *m = ctx;
    (void)k;
    (void)u;
    return value(m, m->ops->f, x, d, x_next, m->n, "f");
}

static int cb_h(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                const dkf_real_t *u, dkf_real_t *z)
{
    dkf_nlm_t *m = ctx;
    (void)k;
    (void)u;
    return value(m, m->ops->h, x, d, z, m->m, "g");
}

/* The Jacobians' two blocks (r x n, r x p) through the model's double
 * scratch (jac_a, jac_b, sized at load). */
typedef int (*jac_fn)(dkf_nlm_t *m, const double *x, const double *d, double *J1, double *J2);

static int jac(dkf_nlm_t *m, jac_fn fn, size_t rows, const dkf_real_t *x, const dkf_real_t *d,
               dkf_real_t *J1, dkf_real_t *J2, const char *n1, const char *n2)
{
    double xd[DKF_MAX_DIM], dd[DKF_MAX_DIM];
    to_double(xd, x, m->n);
    to_double(dd, d, m->p);
    if (fn(m, xd, dd, m->jac_a, m->jac_b) != 0) return -1;
    if (to_real(m, J1, m->jac_a, rows * m->n, n1) != 0) return -1;
    return m->p == 0 ? 0 : to_real(m, J2, m->jac_b, rows * m->p, n2);
}

static int cb_f_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                    const dkf_real_t *u, dkf_real_t *Fx, dkf_real_t *Fd)
{
    dkf_nlm_t *m = ctx;
    (void)k;
    (void)u;
    return jac(m, m->ops->f_jac, m->n, x, d, Fx, Fd, "A", "G");
}

static int cb_h_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                    const dkf_real_t *u, dkf_real_t *Hx, dkf_real_t *Hd)
{
    dkf_nlm_t *m = ctx;
    (void)k;
    (void)u;
    return jac(m, m->ops->h_jac, m->m, x, d, Hx, Hd, "C", "H");
}

/* v wrapped into [-pi, pi). fmod is exact, so the result is right for any
 * finite v (v - 2 pi floor(...) lost every digit past |v| ~ 1e16). */
static double wrap_angle(double v)
{
    const double pi = 3.14159265358979323846, two_pi = 2 * pi;
    const double w = fmod(v, two_pi); /* exact, in (-2 pi, 2 pi) */
    if (w >= pi) return w - two_pi;
    return w < -pi ? w + two_pi : w;
}

/* a - b, the angle channels wrapped (seed 001's bearings, note section 2). */
static void cb_y_diff(void *ctx, const dkf_real_t *a, const dkf_real_t *b, dkf_real_t *out)
{
    const dkf_nlm_t *m = ctx;
    size_t i;
    for (i = 0; i < m->m; ++i) {
        const double v = (double)a[i] - (double)b[i];
        out[i] = (dkf_real_t)(m->angle[i] ? wrap_angle(v) : v);
    }
}

/* ---- the table ----------------------------------------------------------------- */

void dkf_nlm_free(dkf_nlm_t *m)
{
    if (m == NULL) return;
    if (m->ops != NULL && m->ops->destroy != NULL) m->ops->destroy(m->impl);
    free(m->Q);
    free(m->R);
    free(m->path);
    free(m->jac_a);
    free(m->jac_b);
    free(m);
}

static int alloc_jac(dkf_nlm_t *m)
{
    const size_t rows = m->n > m->m ? m->n : m->m;
    m->jac_a = calloc(rows * m->n, sizeof(double));
    m->jac_b = calloc(rows * (m->p > 0 ? m->p : 1), sizeof(double));
    return m->jac_a != NULL && m->jac_b != NULL ? 0 : -1;
}

static void bind_table(dkf_nlm_t *m)
{
    size_t i;
    m->model.ctx = m;
    m->model.n = m->n;
    m->model.m = m->m;
    m->model.p = m->p;
    m->model.q = 0;
    m->model.f = cb_f;
    m->model.h = cb_h;
    m->model.f_jac = m->ops->f_jac != NULL ? cb_f_jac : NULL;
    m->model.h_jac = m->ops->h_jac != NULL ? cb_h_jac : NULL;
    m->model.y_diff = NULL;
    for (i = 0; i < m->m; ++i)
        if (m->angle[i]) m->model.y_diff = cb_y_diff;
}

int dkf_nlm_finish(dkf_nlm_t *m)
{
    if (alloc_jac(m) != 0) return -1;
    bind_table(m);
    return 0;
}
