/*
 * nlm_builtin.c - the built-in named models (nlm.h): every `model.family`
 * of the seed-001 vector files (tests/vectors/infofusion), with analytic
 * Jacobians.
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
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nlm.h"
#include "scn_values.h"

#define PI 3.14159265358979323846
#define MAX_SENSORS (DKF_MAX_DIM / 2)

typedef struct {
    /* lin_x_sin_d */
    double *A, *B, *C, *H; /* n x n, n x p, m x n, m x p */
    /* s1_* */
    double T, gain, omega; /* sample time, phi gain, the fixed turn rate (s1_ckf) */
    size_t L;              /* sensors */
    double sxy[2 * MAX_SENSORS];
    size_t per;            /* measurements per sensor: 3 (with phi) or 2 */
} model_t;

static void destroy(void *impl)
{
    model_t *b = impl;
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
    const model_t *b = m->impl;
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
    const model_t *b = m->impl;
    double t[DKF_MAX_DIM];
    size_t i;
    mat_vec(z, b->C, x, m->m, m->n);
    mat_vec(t, b->H, d, m->m, m->p);
    for (i = 0; i < m->m; ++i) z[i] += t[i];
    return 0;
}

static int lin_f_jac(dkf_nlm_t *m, const double *x, const double *d, double *Fx, double *Fd)
{
    const model_t *b = m->impl;
    size_t i, j;
    (void)x;
    memcpy(Fx, b->A, m->n * m->n * sizeof *Fx);
    for (i = 0; i < m->n; ++i)
        for (j = 0; j < m->p; ++j) Fd[i * m->p + j] = b->B[i * m->p + j] * cos(d[j]);
    return 0;
}

static int lin_h_jac(dkf_nlm_t *m, const double *x, const double *d, double *Hx, double *Hd)
{
    const model_t *b = m->impl;
    (void)x;
    (void)d;
    memcpy(Hx, b->C, m->m * m->n * sizeof *Hx);
    memcpy(Hd, b->H, m->m * m->p * sizeof *Hd);
    return 0;
}

static const dkf_nlm_ops_t lin_ops = {lin_f, lin_h, lin_f_jac, lin_h_jac, destroy};

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
    const model_t *b = m->impl;
    return m->p > 0 ? d[0] : b->omega;
}

static int s1_f(dkf_nlm_t *m, const double *x, const double *d, double *x_next)
{
    const model_t *b = m->impl;
    ct_f(x, turn_rate(m, d), b->T, x_next);
    return 0;
}

static int s1_f_jac(dkf_nlm_t *m, const double *x, const double *d, double *Fx, double *Fd)
{
    const model_t *b = m->impl;
    ct_jac(x, turn_rate(m, d), b->T, Fx, m->p > 0 ? Fd : NULL);
    return 0;
}

/* Range and bearing of sensor l; -1 at the sensor itself (bearing undefined). */
static int range_bearing(dkf_nlm_t *m, size_t l, const double *x, double *dx, double *dy,
                         double *r)
{
    const model_t *b = m->impl;
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
    const model_t *b = m->impl;
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
    const model_t *b = m->impl;
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

static const dkf_nlm_ops_t s1_ops = {s1_f, s1_h, s1_f_jac, s1_h_jac, destroy};

/* ---- loading ------------------------------------------------------------------- */

/* j[key]: a matrix of rows x cols (rows 0: any number of rows, returned). */
static int get_matrix(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *key,
                      size_t *rows, size_t cols, double **out)
{
    const json_t *v = json_object_get(j, key);
    char p[DKF_SCN_PATH_LEN];
    size_t r, cc;
    dkf_scn_subkey(p, path, key);
    if (v == NULL) return dkf_scn_fail(c, p, "missing key");
    if (dkf_scn_parse_matrix(c, v, p, &r, &cc, out) != 0) return -1;
    if ((*rows != 0 && r != *rows) || cc != cols || r > DKF_MAX_DIM)
        return dkf_scn_fail(c, p, "expected %s%zu x %zu, got %zu x %zu",
                            *rows == 0 ? "at most " : "", *rows == 0 ? (size_t)DKF_MAX_DIM : *rows,
                            cols, r, cc);
    *rows = r;
    return 0;
}

static int get_number(dkf_scn_ctx_t *c, const json_t *j, const char *path, const char *key,
                      double def, int required, double *out)
{
    const json_t *v = json_object_get(j, key);
    char p[DKF_SCN_PATH_LEN];
    dkf_scn_subkey(p, path, key);
    if (v == NULL) {
        if (required) return dkf_scn_fail(c, p, "missing key");
        *out = def;
        return 0;
    }
    if (!json_is_number(v) || !isfinite(json_number_value(v)))
        return dkf_scn_fail(c, p, "expected a finite number, got %s", dkf_scn_json_kind(v));
    *out = json_number_value(v);
    return 0;
}

static int load_lin(dkf_scn_ctx_t *c, dkf_nlm_t *m, model_t *b, const json_t *j,
                    const char *path)
{
    size_t rows = m->n, mm = 0;
    const json_t *bj = json_object_get(j, "b");
    char p[DKF_SCN_PATH_LEN];
    if (m->p == 0)
        return dkf_scn_fail(c, path, "family lin_x_sin_d needs an unknown input (init d0 of "
                            "at least one value)");
    if (get_matrix(c, j, path, "A", &rows, m->n, &b->A) != 0) return -1;
    dkf_scn_subkey(p, path, "b");
    if (bj != NULL && dkf_scn_nest_depth(bj) == 1) {
        size_t len;
        if (m->p != 1)
            return dkf_scn_fail(c, p, "a vector b is for p = 1; give an n x p matrix (p = %zu)",
                                m->p);
        if (dkf_scn_parse_vector(c, bj, p, &len, &b->B) != 0) return -1;
        if (len != m->n) return dkf_scn_fail(c, p, "expected %zu values, got %zu", m->n, len);
    } else {
        rows = m->n;
        if (get_matrix(c, j, path, "b", &rows, m->p, &b->B) != 0) return -1;
    }
    if (get_matrix(c, j, path, "C", &mm, m->n, &b->C) != 0) return -1;
    m->m = mm;
    if (get_matrix(c, j, path, "H", &mm, m->p, &b->H) != 0) return -1;
    m->ops = &lin_ops;
    return 0;
}

/* seed 001's sensor noise diag(0.2^2, 0.015^2, sigma_phi^2), sigma_phi =
 * 0.017 deg/s in rad/s (the derivation's (docs/design/derivation-seed001-002.md) section 2), per sensor block. */
static int default_R(dkf_scn_ctx_t *c, dkf_nlm_t *m, const model_t *b)
{
    const double sphi = 0.017 * PI / 180.0, var[3] = {0.2 * 0.2, 0.015 * 0.015, sphi * sphi};
    size_t l, i;
    if ((m->R = calloc(m->m * m->m, sizeof *m->R)) == NULL)
        return dkf_scn_fail(c, NULL, "out of memory");
    for (l = 0; l < b->L; ++l)
        for (i = 0; i < b->per; ++i) {
            const size_t r = l * b->per + i;
            m->R[r * m->m + r] = var[i];
        }
    return 0;
}

static int load_s1(dkf_scn_ctx_t *c, dkf_nlm_t *m, model_t *b, const json_t *j,
                   const char *path, int stacked, int ckf)
{
    const json_t *xy = json_object_get(j, "sensor_xy");
    char p[DKF_SCN_PATH_LEN];
    size_t l, len;
    double *v = NULL;
    const size_t want_p = ckf ? 0 : 1;
    if (m->n != 4 || m->p != want_p)
        return dkf_scn_fail(c, path, "family %s has n = 4 (xi, xi_dot, eta, eta_dot) and p = "
                            "%zu%s; the case's init gives n = %zu, p = %zu", m->source, want_p,
                            ckf ? "" : " (omega)", m->n, m->p);
    if (get_number(c, j, path, "T", 1.0, 0, &b->T) != 0) return -1;
    if (get_number(c, j, path, "phi_gain", 10.0, 0, &b->gain) != 0) return -1;
    if (get_number(c, j, path, "omega_fixed", 0.0, ckf, &b->omega) != 0) return -1;
    dkf_scn_subkey(p, path, "sensor_xy");
    if (xy == NULL) return dkf_scn_fail(c, p, "missing key");
    if (!stacked) {
        if (dkf_scn_parse_vector(c, xy, p, &len, &v) != 0) return -1;
        if (len != 2) {
            free(v);
            return dkf_scn_fail(c, p, "expected [x, y], got %zu values", len);
        }
        b->L = 1;
        memcpy(b->sxy, v, 2 * sizeof *v);
        free(v);
    } else {
        size_t rows = 0;
        if (get_matrix(c, j, path, "sensor_xy", &rows, 2, &v) != 0) {
            free(v);
            return -1;
        }
        if (rows > MAX_SENSORS || 3 * rows > DKF_MAX_DIM) {
            free(v);
            return dkf_scn_fail(c, p, "%zu sensors: at most %d (3 per sensor <= %d)", rows,
                                DKF_MAX_DIM / 3, DKF_MAX_DIM);
        }
        b->L = rows;
        memcpy(b->sxy, v, 2 * rows * sizeof *v);
        free(v);
    }
    for (l = 0; l < 2 * b->L; ++l)
        if (!isfinite(b->sxy[l])) return dkf_scn_fail(c, p, "not finite");
    b->per = ckf ? 2 : 3;
    m->m = b->per * b->L;
    for (l = 0; l < b->L; ++l) {
        m->angle[l * b->per + 1] = 1;
        m->nangles++;
    }
    m->ops = &s1_ops;
    return json_object_get(j, "R") == NULL && stacked ? default_R(c, m, b) : 0;
}

static const char *const families[] = {"lin_x_sin_d", "s1_radar", "s1_radar_stacked", "s1_ckf",
                                       NULL};

const char *dkf_nlm_builtin_names(void)
{
    return "lin_x_sin_d, s1_radar, s1_radar_stacked, s1_ckf";
}

int dkf_nlm_load_builtin(dkf_scn_ctx_t *c, dkf_nlm_t *m, const json_t *j, const char *path)
{
    model_t *b;
    char p[DKF_SCN_PATH_LEN];
    size_t i;
    for (i = 0; families[i] != NULL && strcmp(families[i], m->source) != 0; ++i) continue;
    dkf_scn_subkey(p, path, "family");
    if (families[i] == NULL)
        return dkf_scn_fail(c, p, "unknown family '%s' (built-in: %s; or give \"expr\")",
                            json_string_value(json_object_get(j, "family")),
                            dkf_nlm_builtin_names());
    if ((b = calloc(1, sizeof *b)) == NULL) return dkf_scn_fail(c, NULL, "out of memory");
    m->impl = b;
    m->ops = &lin_ops; /* destroy from here on; the loaders set the real table */
    if (i == 0) return load_lin(c, m, b, j, path);
    return load_s1(c, m, b, j, path, i == 2, i == 3);
}
