/*
 * nlm.c - a scenario's nonlinear model object -> dkf_nl_model_t (nlm.h):
 * the dispatch to the built-in families (nlm_builtin.c) and the
 * expression models (nlm_expr.c), the numeric Q and R, the angle
 * channels, and the callbacks the core calls (dkf_real_t <-> double, every
 * value checked for finiteness).
 */
#include "nlm.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scn_values.h"

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

/* ---- loading ------------------------------------------------------------------- */

/* The keys a model object may have: the expression form, every built-in
 * family's parameters (nlm_builtin.c), the noises; `sensor`, `sensors`:
 * the vectors' descriptions of the sensors. */
static const char *const model_keys[] = {"family", "expr", "angles", "Q", "R", "A", "b", "C", "H",
                                         "T", "omega_fixed", "phi_gain", "sensor_xy", "sensor",
                                         "sensors", NULL};

/* model[key] as an r x r matrix into *out (NULL if absent and !required). */
static int square_matrix(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *key,
                         size_t r, int required, double **out)
{
    const json_t *v = json_object_get(j, key);
    char p[DKF_SCN_PATH_LEN];
    size_t rows, cols;
    double *a;
    dkf_scn_subkey(p, path, key);
    if (v == NULL) {
        if (!required) return 0;
        return dkf_scn_fail(c, p, "missing key (the %zu x %zu %s noise covariance)", r, r,
                            key[0] == 'Q' ? "state" : "measurement");
    }
    if (dkf_scn_parse_matrix(c, v, p, &rows, &cols, &a) != 0) return -1;
    if (rows != r || cols != r) {
        free(a);
        return dkf_scn_fail(c, p, "expected %zu x %zu, got %zu x %zu", r, r, rows, cols);
    }
    if (dkf_scn_check_symmetric(c, p, a, r) != 0 ||
        dkf_scn_check_definite(c, p, a, r, key[0] == 'R',
                               key[0] == 'R' ? "the measurement noise covariance R must be SPD"
                                             : "the process noise covariance Q must be symmetric "
                                               "PSD") != 0) {
        free(a);
        return -1;
    }
    free(*out);
    *out = a;
    return 0;
}

/* "angles": [0-based indices of g], each at most once. */
static int parse_angles(dkf_scn_ctx_t *c, dkf_nlm_t *m, const json_t *a, const char *path)
{
    size_t i;
    char p[DKF_SCN_PATH_LEN];
    if (!json_is_array(a))
        return dkf_scn_fail(c, path, "expected a list of measurement indices, got %s",
                            dkf_scn_json_kind(a));
    memset(m->angle, 0, sizeof m->angle);
    m->nangles = 0;
    for (i = 0; i < json_array_size(a); ++i) {
        long v;
        dkf_scn_subidx(p, path, i);
        if (dkf_scn_get_integer(c, json_array_get(a, i), p, 0.0, (double)m->m - 1.0, &v) != 0)
            return -1;
        if (m->angle[v])
            return dkf_scn_fail(c, p, "index %ld listed twice", v);
        m->angle[v] = 1;
        m->nangles++;
    }
    return 0;
}

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

dkf_nlm_t *dkf_nlm_load(const json_t *j, const char *file, const char *path, size_t n, size_t p,
                        const double *x0, const double *d0, char *err, size_t errlen)
{
    dkf_scn_ctx_t c;
    dkf_nlm_t *m;
    const json_t *expr, *family, *angles;
    char pk[DKF_SCN_PATH_LEN];
    int rc;
    c.file = file != NULL ? file : "(null)";
    c.err = err;
    c.errlen = errlen;
    if (!json_is_object(j)) {
        dkf_scn_fail(&c, path, "expected a model object, got %s", dkf_scn_json_kind(j));
        return NULL;
    }
    if (n == 0 || n > DKF_MAX_DIM || p > DKF_MAX_DIM) {
        dkf_scn_fail(&c, path, "state of %zu and input of %zu components: the core takes 1..%d "
                     "and 0..%d", n, p, DKF_MAX_DIM, DKF_MAX_DIM);
        return NULL;
    }
    if ((m = calloc(1, sizeof *m)) == NULL || (m->path = dkf_scn_dupstr(path)) == NULL) {
        free(m);
        dkf_scn_fail(&c, NULL, "out of memory");
        return NULL;
    }
    m->n = n;
    m->p = p;
    if (dkf_scn_check_keys(&c, j, path, model_keys, NULL) != 0) {
        dkf_nlm_free(m);
        return NULL;
    }
    expr = json_object_get(j, "expr");
    family = json_object_get(j, "family");
    if (expr != NULL) {
        dkf_scn_subkey(pk, path, "expr");
        snprintf(m->source, sizeof m->source, "expr");
        rc = dkf_nlm_load_expr(&c, m, expr, pk, x0, d0);
    } else if (json_is_string(family)) {
        snprintf(m->source, sizeof m->source, "%.31s", json_string_value(family));
        rc = dkf_nlm_load_builtin(&c, m, j, path);
    } else {
        dkf_scn_subkey(pk, path, family != NULL ? "family" : "expr");
        rc = dkf_scn_fail(&c, pk, family != NULL
                          ? "expected the name of a built-in model (one of %s)"
                          : "missing key (give \"expr\": {\"f\": [...], \"g\": [...]} or a "
                            "built-in \"family\": one of %s)", dkf_nlm_builtin_names());
    }
    /* "angles" beside "expr" or inside it, not both */
    angles = json_object_get(j, "angles");
    dkf_scn_subkey(pk, path, "angles");
    if (expr != NULL && json_object_get(expr, "angles") != NULL) {
        if (rc == 0 && angles != NULL)
            rc = dkf_scn_fail(&c, pk, "given twice (also in expr.angles): keep one");
        angles = json_object_get(expr, "angles");
        dkf_scn_subkey(pk, path, "expr.angles");
    }
    if (rc == 0 && angles != NULL) rc = parse_angles(&c, m, angles, pk);
    if (rc == 0) rc = square_matrix(&c, j, path, "Q", n, 1, &m->Q);
    if (rc == 0) rc = square_matrix(&c, j, path, "R", m->m, m->R == NULL, &m->R);
    if (rc == 0 && alloc_jac(m) != 0) rc = dkf_scn_fail(&c, NULL, "out of memory");
    if (rc != 0) {
        dkf_nlm_free(m);
        return NULL;
    }
    bind_table(m);
    return m;
}
