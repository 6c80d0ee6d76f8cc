/*
 * nlm_family.c - the built-in named models' arithmetic (nlm_model.h): every
 * `model.family` of the seed-001 vector files (tests/vectors/infofusion),
 * with analytic Jacobians; nlm_builtin.c reads their parameters from JSON.
 *
 *   lin_x_sin_d       f = A x + b sin(d), g = C x + H d (keys A, b, C, H;
 *                     b: n values for p = 1, or n x p with sin per
 *                     component); Fx = A, Fd = b cos(d), Hx = C, Hd = H.
 *   s1_radar          seed 001's coordinated turn (62), x = [xi, xi_dot,
 *                     eta, eta_dot], d = [omega] (rad/s), one radar at
 *                     sensor_xy: g = [hypot(xi - sx, eta - sy),
 *                     atan2(eta - sy, xi - sx), 10 omega] (64); the
 *                     bearing is an angle channel. Optional "T" (1) and
 *                     "phi_gain" (10).
 *   s1_radar_stacked  the same with sensor_xy a list of L positions:
 *                     z = [z^1; ...; z^L] (3 L, sensor-major), the CF
 *                     model; R defaults to blkdiag of seed 001's
 *                     diag(0.2^2, 0.015^2, (0.017 deg/s in rad/s)^2).
 *   s1_ckf            the DF-CKF model: p = 0, omega fixed at
 *                     "omega_fixed", g = [range, bearing].
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "nlm_model.h"

#define PI 3.14159265358979323846

static void destroy(void *impl)
{
    dkf_nlm_family_t *b = impl;
    if (b == NULL) return;
    free(b->A);
    free(b->B);
    free(b->C);
    free(b->H);
    free(b);
}

/* ---- lin_x_sin_d ---------------------------------------------------------------- */

/* y (r) = M (r x c) v (c) + add */
static void mat_vec(double *y, const double *M, const double *v, size_t r, size_t c)
{
    size_t i, j;
    for (i = 0; i < r; ++i) {
        double s = 0;
        for (j = 0; j < c; ++j) s += M[i * c + j] * v[j];
        y[i] = s;
    }
}

static int lin_f(dkf_nlm_t *m, const double *x, const double *d, double *x_next)
{
    const dkf_nlm_family_t *b = m->impl;
    double sd[DKF_MAX_DIM], t[DKF_MAX_DIM];
    size_t i;
    mat_vec(x_next, b->A, x, m->n, m->n);
    for (i = 0; i < m->p; ++i) sd[i] = sin(d[i]);
    mat_vec(t, b->B, sd, m->n, m->p);
    for (i = 0; i < m->n; ++i) x_next[i] += t[i];
    return 0;
}

static int lin_h(dkf_nlm_t *m, const double *x, const double *d, double *z)
{
    const dkf_nlm_family_t *b = m->impl;
    double t[DKF_MAX_DIM];
    size_t i;
    mat_vec(z, b->C, x, m->m, m->n);
    mat_vec(t, b->H, d, m->m, m->p);
    for (i = 0; i < m->m; ++i) z[i] += t[i];
    return 0;
}

static int lin_f_jac(dkf_nlm_t *m, const double *x, const double *d, double *Fx, double *Fd)
{
    const dkf_nlm_family_t *b = m->impl;
    size_t i, j;
    (void)x;
    memcpy(Fx, b->A, m->n * m->n * sizeof *Fx);
    for (i = 0; i < m->n; ++i)
        for (j = 0; j < m->p; ++j) Fd[i * m->p + j] = b->B[i * m->p + j] * cos(d[j]);
    return 0;
}

static int lin_h_jac(dkf_nlm_t *m, const double *x, const double *d, double *Hx, double *Hd)
{
    const dkf_nlm_family_t *b = m->impl;
    (void)x;
    (void)d;
    memcpy(Hx, b->C, m->m * m->n * sizeof *Hx);
    memcpy(Hd, b->H, m->m * m->p * sizeof *Hd);
    return 0;
}

const dkf_nlm_ops_t dkf_nlm_lin_ops = {lin_f, lin_h, lin_f_jac, lin_h_jac, destroy};

/* ---- the coordinated turn (seed 001, eq. 62) ---------------------------------- */

/* a = sin(wT)/w, b = (1 - cos wT)/w and their derivatives in w; series
 * below |wT| = 1e-2 (the next terms are < 1e-16 relative there; above it
 * the closed forms lose at most 3 eps / (wT)^2 <= 7e-12 in da). */
static void turn_terms(double w, double T, double *a, double *b, double *da, double *db)
{
    const double u = w * T, u2 = u * u;
    if (fabs(u) < 1e-2) {
        *a = T * (1 - u2 / 6 * (1 - u2 / 20 * (1 - u2 / 42)));
        *b = T * u / 2 * (1 - u2 / 12 * (1 - u2 / 30 * (1 - u2 / 56)));
        *da = T * T * u * (-1.0 / 3 + u2 / 30 - u2 * u2 / 840);
        *db = T * T * (0.5 - u2 / 8 + u2 * u2 / 144 - u2 * u2 * u2 / 5760);
    } else {
        const double s = sin(u), c = cos(u), h = sin(u / 2);
        *a = s / w;
        *b = 2 * h * h / w;
        *da = (T * c * w - s) / (w * w);
        *db = (T * s - *b) / w;
    }
}

/* x_next = F_CT(w) x */
static void ct_f(const double *x, double w, double T, double *x_next)
{
    double a, b, da, db;
    const double c = cos(w * T), s = sin(w * T);
    turn_terms(w, T, &a, &b, &da, &db);
    x_next[0] = x[0] + a * x[1] - b * x[3];
    x_next[1] = c * x[1] - s * x[3];
    x_next[2] = b * x[1] + x[2] + a * x[3];
    x_next[3] = s * x[1] + c * x[3];
}

/* Fx = F_CT(w) (4 x 4), dF = dF_CT/dw x (4 values) */
static void ct_jac(const double *x, double w, double T, double *Fx, double *dF)
{
    double a, b, da, db;
    const double c = cos(w * T), s = sin(w * T), dc = -T * s, ds = T * c;
    turn_terms(w, T, &a, &b, &da, &db);
    {
        const double F[16] = {1, a, 0, -b, 0, c, 0, -s, 0, b, 1, a, 0, s, 0, c};
        memcpy(Fx, F, sizeof F);
    }
    if (dF != NULL) {
        dF[0] = da * x[1] - db * x[3];
        dF[1] = dc * x[1] - ds * x[3];
        dF[2] = db * x[1] + da * x[3];
        dF[3] = ds * x[1] + dc * x[3];
    }
}

/* The turn rate of a step: the input (s1_radar*) or the fixed one (s1_ckf). */
static double turn_rate(const dkf_nlm_t *m, const double *d)
{
    const dkf_nlm_family_t *b = m->impl;
    return m->p > 0 ? d[0] : b->omega;
}

static int s1_f(dkf_nlm_t *m, const double *x, const double *d, double *x_next)
{
    const dkf_nlm_family_t *b = m->impl;
    ct_f(x, turn_rate(m, d), b->T, x_next);
    return 0;
}

static int s1_f_jac(dkf_nlm_t *m, const double *x, const double *d, double *Fx, double *Fd)
{
    const dkf_nlm_family_t *b = m->impl;
    ct_jac(x, turn_rate(m, d), b->T, Fx, m->p > 0 ? Fd : NULL);
    return 0;
}

/* Range and bearing of sensor l; -1 at the sensor itself (bearing undefined). */
static int range_bearing(dkf_nlm_t *m, size_t l, const double *x, double *dx, double *dy,
                         double *r)
{
    const dkf_nlm_family_t *b = m->impl;
    *dx = x[0] - b->sxy[2 * l];
    *dy = x[2] - b->sxy[2 * l + 1];
    *r = hypot(*dx, *dy);
    if (*r > 0) return 0;
    dkf_nlm_set_failure(m, "%s: the state's position is at sensor %zu (bearing undefined)",
                        m->path, l);
    return -1;
}

/* z = [r, bearing(, gain * omega)] per sensor (eq. 64) */
static int s1_h(dkf_nlm_t *m, const double *x, const double *d, double *z)
{
    const dkf_nlm_family_t *b = m->impl;
    size_t l;
    for (l = 0; l < b->L; ++l) {
        double dx, dy, r, *zl = z + l * b->per;
        if (range_bearing(m, l, x, &dx, &dy, &r) != 0) return -1;
        zl[0] = r;
        zl[1] = atan2(dy, dx);
        if (b->per == 3) zl[2] = b->gain * d[0];
    }
    return 0;
}

static int s1_h_jac(dkf_nlm_t *m, const double *x, const double *d, double *Hx, double *Hd)
{
    const dkf_nlm_family_t *b = m->impl;
    size_t l;
    (void)d;
    memset(Hx, 0, m->m * m->n * sizeof *Hx);
    if (m->p > 0) memset(Hd, 0, m->m * m->p * sizeof *Hd);
    for (l = 0; l < b->L; ++l) {
        double dx, dy, r, *row = Hx + l * b->per * 4;
        if (range_bearing(m, l, x, &dx, &dy, &r) != 0) return -1;
        row[0] = dx / r;
        row[2] = dy / r;
        row[4] = -dy / (r * r);
        row[6] = dx / (r * r);
        if (b->per == 3) Hd[l * 3 + 2] = b->gain;
    }
    return 0;
}

const dkf_nlm_ops_t dkf_nlm_s1_ops = {s1_f, s1_h, s1_f_jac, s1_h_jac, destroy};

/* ---- the names, the s1 layout and noise ---------------------------------------- */

static const char *const families[] = {"lin_x_sin_d", "s1_radar", "s1_radar_stacked", "s1_ckf",
                                       NULL};

int dkf_nlm_family_index(const char *name)
{
    int i;
    for (i = 0; families[i] != NULL; ++i)
        if (strcmp(families[i], name) == 0) return i;
    return -1;
}

const char *dkf_nlm_builtin_names(void)
{
    return "lin_x_sin_d, s1_radar, s1_radar_stacked, s1_ckf";
}

/* seed 001's sensor noise diag(0.2^2, 0.015^2, sigma_phi^2), sigma_phi =
 * 0.017 deg/s in rad/s (the derivation's (docs/design/derivation-seed001-002.md) section 2), per sensor block. */
void dkf_nlm_s1_default_R(double *R, size_t m, const dkf_nlm_family_t *b)
{
    const double sphi = 0.017 * PI / 180.0, var[3] = {0.2 * 0.2, 0.015 * 0.015, sphi * sphi};
    size_t l, i;
    memset(R, 0, m * m * sizeof *R);
    for (l = 0; l < b->L; ++l)
        for (i = 0; i < b->per; ++i) {
            const size_t r = l * b->per + i;
            R[r * m + r] = var[i];
        }
}

void dkf_nlm_s1_layout(dkf_nlm_t *m, const dkf_nlm_family_t *b)
{
    size_t l;
    m->m = b->per * b->L;
    for (l = 0; l < b->L; ++l) {
        m->angle[l * b->per + 1] = 1;
        m->nangles++;
    }
    m->ops = &dkf_nlm_s1_ops;
}

