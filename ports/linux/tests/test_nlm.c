/*
 * The host's nonlinear models (nlm.h) and the nonlinear cases reader
 * (scn_nlcases.c):
 *
 *  - every case of the seed-001 vector files loads, with the dimensions
 *    the files state;
 *  - the built-in lin_x_sin_d against nertsif.json's stored
 *    intermediates: f(x_{k-1}, d_{k-1}) = x_pred, the Jacobians A, G at
 *    (x_{k-1}, d_{k-1}), C, H at (x_pred, d_{k-1}) and z_hat = g(x_pred,
 *    d_{k-1}) - H d_{k-1}, every step (an independent check of the
 *    model: the vectors were made by another program);
 *  - expression models equal the built-in ones at many points (f, g and
 *    the Jacobians given as expressions), for lin_x_sin_d and the seed-001
 *    radar (atan2, angle channel);
 *  - the built-in coordinated turn's analytic Jacobians against central
 *    differences, and its small-turn-rate series against the closed form;
 *  - bearings wrap to [-pi, pi) through y_diff, other channels do not;
 *  - malformed expressions, unknown variables, assignments, several
 *    values, division by zero at the initial point: one "FILE: KEY:
 *    problem" line each, and nothing loaded; a division by zero at run
 *    time fails the callback (the filters' DKF_ERR_MODEL) and says where.
 *
 * Tolerances are in the comments where they are used.
 */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "nlm.h"
#include "scenario.h"

#define VEC DKF_VECTOR_DIR "/infofusion/"
#define PI 3.14159265358979323846

/* the library's real type's rounding unit */
#define EPS (DKF_USE_FLOAT ? (double)FLT_EPSILON : DBL_EPSILON)

static dkf_scenario_t *load(const char *file, const char *c)
{
    char err[DKF_SCN_ERR_LEN];
    dkf_scenario_t *s = dkf_scenario_load(file, c, err, sizeof err);
    if (s == NULL) fail_msg("%s", err);
    return s;
}

static double json_at(const json_t *a, size_t i)
{
    return json_number_value(json_array_get(a, i));
}

/* max |a - ref| / max(1, max |ref|) over n values; ref a JSON vector or
 * matrix (rows x cols, row-major). */
static double rel_err(const double *a, const json_t *ref, size_t rows, size_t cols)
{
    double e = 0, sc = 1;
    size_t i, j;
    for (i = 0; i < rows; ++i)
        for (j = 0; j < cols; ++j) {
            const double r = cols == 1 && !json_is_array(json_array_get(ref, i))
                                 ? json_at(ref, i)
                                 : json_at(json_array_get(ref, i), j);
            if (fabs(r) > sc) sc = fabs(r);
            if (fabs(a[i * cols + j] - r) > e) e = fabs(a[i * cols + j] - r);
        }
    return e / sc;
}

/* The model's callbacks in double through the core's table. */
static int call_f(const dkf_nlm_t *m, const double *x, const double *d, double *out)
{
    dkf_real_t xr[DKF_MAX_DIM], dr[DKF_MAX_DIM], o[DKF_MAX_DIM];
    size_t i;
    int rc;
    for (i = 0; i < m->n; ++i) xr[i] = (dkf_real_t)x[i];
    for (i = 0; i < m->p; ++i) dr[i] = (dkf_real_t)d[i];
    rc = m->model.f(m->model.ctx, 0, xr, dr, NULL, o);
    for (i = 0; i < m->n; ++i) out[i] = (double)o[i];
    return rc;
}

static int call_h(const dkf_nlm_t *m, const double *x, const double *d, double *out)
{
    dkf_real_t xr[DKF_MAX_DIM], dr[DKF_MAX_DIM], o[DKF_MAX_DIM];
    size_t i;
    int rc;
    for (i = 0; i < m->n; ++i) xr[i] = (dkf_real_t)x[i];
    for (i = 0; i < m->p; ++i) dr[i] = (dkf_real_t)d[i];
    rc = m->model.h(m->model.ctx, 0, xr, dr, NULL, o);
    for (i = 0; i < m->m; ++i) out[i] = (double)o[i];
    return rc;
}

/* which = 0: f_jac (J1 n x n, J2 n x p); 1: h_jac (m x n, m x p). */
static int call_jac(const dkf_nlm_t *m, int which, const double *x, const double *d, double *J1,
                    double *J2)
{
    static dkf_real_t a[DKF_MAX_DIM * DKF_MAX_DIM], b[DKF_MAX_DIM * DKF_MAX_DIM];
    dkf_real_t xr[DKF_MAX_DIM] = {0}, dr[DKF_MAX_DIM] = {0}; /* GCC -O3 cannot see n, p >= 1 */
    const size_t r = which == 0 ? m->n : m->m;
    size_t i;
    int rc;
    for (i = 0; i < m->n; ++i) xr[i] = (dkf_real_t)x[i];
    for (i = 0; i < m->p; ++i) dr[i] = (dkf_real_t)d[i];
    rc = which == 0 ? m->model.f_jac(m->model.ctx, 0, xr, dr, NULL, a, b)
                    : m->model.h_jac(m->model.ctx, 0, xr, dr, NULL, a, b);
    for (i = 0; i < r * m->n; ++i) J1[i] = (double)a[i];
    for (i = 0; i < r * m->p; ++i) J2[i] = (double)b[i];
    return rc;
}

static void vec_of(const json_t *a, double *out, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) out[i] = json_at(a, i);
}

/* ---- every case loads ---------------------------------------------------------- */

static void test_vector_cases_load(void **state)
{
    static const struct {
        const char *file, *c;
        size_t nodes, n, m, p;
        const char *source;
    } rows[] = {
        {"nertsif.json", "0", 1, 3, 3, 1, "lin_x_sin_d"},
        {"dnertsif_single.json", "0", 1, 4, 3, 1, "s1_radar"},
        {"dnertsif_single.json", "1", 1, 4, 36, 1, "s1_radar_stacked"},
        {"df_dnertsif.json", "0", 4, 4, 3, 1, "s1_radar"},
        {"df_dnertsif.json", "3", 4, 4, 3, 1, "s1_radar"},
        {"df_dnertsif.json", "4", 4, 4, 2, 0, "s1_ckf"},
    };
    size_t i, j;
    (void)state;
    for (i = 0; i < sizeof rows / sizeof rows[0]; ++i) {
        char path[512];
        dkf_scenario_t *s;
        snprintf(path, sizeof path, VEC "%s", rows[i].file);
        s = load(path, rows[i].c);
        assert_int_equal(s->layout, DKF_SCN_LAYOUT_NLCASES);
        assert_int_equal(s->nsensors, rows[i].nodes);
        assert_int_equal(s->n, rows[i].n);
        assert_int_equal(s->nl->p, rows[i].p);
        assert_int_equal(s->nl->network, rows[i].nodes > 1);
        for (j = 0; j < s->nsensors; ++j) {
            const dkf_nlm_t *m = s->nl->models[j];
            assert_int_equal(m->m, rows[i].m);
            assert_int_equal(s->sensors[j].m, rows[i].m);
            assert_string_equal(m->source, rows[i].source);
            /* the radars' bearings are the angle channels: 1 per sensor block */
            if (strncmp(rows[i].source, "s1_", 3) == 0) {
                assert_int_equal(m->nangles, rows[i].m / (rows[i].p == 0 ? 2 : 3));
                assert_non_null(m->model.y_diff);
            } else {
                assert_int_equal(m->nangles, 0);
                assert_null(m->model.y_diff);
            }
            assert_non_null(dkf_scn_y(s, j, 1));
            assert_non_null(dkf_scn_y(s, j, (long)s->steps));
            assert_null(dkf_scn_y(s, j, (long)s->steps + 1));
        }
        if (s->nl->network) {
            assert_non_null(s->net);
            assert_true(s->net->eta == 3 || s->net->eta == 45);
            assert_int_equal(s->net->nW, 12); /* 4 self weights + 2 x 4 edges */
        }
        dkf_scenario_free(s);
    }
}

/* ---- lin_x_sin_d against nertsif.json ------------------------------------------ */

static void test_lin_builtin_vs_vector(void **state)
{
    dkf_scenario_t *s = load(VEC "nertsif.json", "0");
    const dkf_nlm_t *m = s->nl->models[0];
    json_t *root = json_load_file(VEC "nertsif.json", 0, NULL);
    const json_t *cj = json_array_get(json_object_get(root, "cases"), 0);
    const json_t *steps = json_object_get(cj, "steps"), *init = json_object_get(cj, "init");
    double x[3], d[1], xp[3], v[9], w[3], worst = 0;
    size_t k, i;
    (void)state;
    assert_non_null(root);
    vec_of(json_object_get(init, "x0"), x, 3);
    vec_of(json_object_get(init, "d0"), d, 1);
    for (k = 0; k < json_array_size(steps); ++k) {
        const json_t *e = json_object_get(json_array_get(steps, k), "expected");
        double z[3];
        assert_int_equal(call_f(m, x, d, xp), 0);
        worst = fmax(worst, rel_err(xp, json_object_get(e, "x_pred"), 3, 1));
        assert_int_equal(call_jac(m, 0, x, d, v, w), 0);
        worst = fmax(worst, rel_err(v, json_object_get(e, "A"), 3, 3));
        worst = fmax(worst, rel_err(w, json_object_get(e, "G"), 3, 1));
        /* C, H and z_hat at the vector's own x_pred */
        vec_of(json_object_get(e, "x_pred"), xp, 3);
        assert_int_equal(call_jac(m, 1, xp, d, v, w), 0);
        worst = fmax(worst, rel_err(v, json_object_get(e, "C"), 3, 3));
        worst = fmax(worst, rel_err(w, json_object_get(e, "H"), 3, 1));
        assert_int_equal(call_h(m, xp, d, z), 0);
        for (i = 0; i < 3; ++i) z[i] -= w[i] * d[0];
        worst = fmax(worst, rel_err(z, json_object_get(e, "z_hat"), 3, 1));
        vec_of(json_object_get(e, "x"), x, 3);
        vec_of(json_object_get(e, "d"), d, 1);
    }
    /* a few roundings of O(1) values: 16 eps (double 3.6e-15, float 1.9e-6) */
    print_message("lin_x_sin_d vs nertsif.json: worst scaled error %.3g\n", worst);
    assert_true(worst <= 16 * EPS);
    json_decref(root);
    dkf_scenario_free(s);
}

/* ---- expressions = built-in ---------------------------------------------------- */

static dkf_nlm_t *load_model(const char *text, size_t n, size_t p, const double *x0,
                             const double *d0, char *err)
{
    json_error_t je;
    json_t *j = json_loads(text, 0, &je);
    dkf_nlm_t *m;
    if (j == NULL) fail_msg("test JSON: %s (%s)", je.text, text);
    m = dkf_nlm_load(j, "t.json", "model", n, p, x0, d0, err, DKF_SCN_ERR_LEN);
    json_decref(j);
    return m;
}

/* A deterministic point in [lo, hi] (xorshift). */
static double urand(unsigned *st, double lo, double hi)
{
    *st ^= *st << 13;
    *st ^= *st >> 17;
    *st ^= *st << 5;
    return lo + (hi - lo) * (double)(*st % 1000003u) / 1000003.0;
}

/* max scaled difference of f, g and both Jacobians of a and b at count
 * points of [lo, hi]^n x [dlo, dhi]^p. */
static double model_gap(const dkf_nlm_t *a, const dkf_nlm_t *b, double lo, double hi,
                        double dlo, double dhi, size_t count)
{
    static double u1[DKF_MAX_DIM * DKF_MAX_DIM], u2[DKF_MAX_DIM * DKF_MAX_DIM];
    static double w1[DKF_MAX_DIM * DKF_MAX_DIM], w2[DKF_MAX_DIM * DKF_MAX_DIM];
    double x[DKF_MAX_DIM], d[DKF_MAX_DIM], worst = 0;
    unsigned st = 12345u;
    size_t c, i, which;
    for (c = 0; c < count; ++c) {
        for (i = 0; i < a->n; ++i) x[i] = urand(&st, lo, hi);
        for (i = 0; i < a->p; ++i) d[i] = urand(&st, dlo, dhi);
        assert_int_equal(call_f(a, x, d, u1), 0);
        assert_int_equal(call_f(b, x, d, u2), 0);
        for (i = 0; i < a->n; ++i) worst = fmax(worst, fabs(u1[i] - u2[i]) / fmax(1, fabs(u2[i])));
        assert_int_equal(call_h(a, x, d, u1), 0);
        assert_int_equal(call_h(b, x, d, u2), 0);
        for (i = 0; i < a->m; ++i) worst = fmax(worst, fabs(u1[i] - u2[i]) / fmax(1, fabs(u2[i])));
        for (which = 0; which < 2; ++which) {
            const size_t r = which == 0 ? a->n : a->m;
            assert_int_equal(call_jac(a, (int)which, x, d, u1, w1), 0);
            assert_int_equal(call_jac(b, (int)which, x, d, u2, w2), 0);
            for (i = 0; i < r * a->n; ++i)
                worst = fmax(worst, fabs(u1[i] - u2[i]) / fmax(1, fabs(u2[i])));
            for (i = 0; i < r * a->p; ++i)
                worst = fmax(worst, fabs(w1[i] - w2[i]) / fmax(1, fabs(w2[i])));
        }
    }
    return worst;
}

static const char lin_builtin[] =
    "{\"family\": \"lin_x_sin_d\", \"A\": [[1, 0.1, 0], [0, 0.95, 0.1], [0, 0, 0.9]],"
    " \"b\": [0.0, 0.1, 0.05], \"C\": [[1, 0, 0], [0, 0, 1], [1, 1, 0]],"
    " \"H\": [[0.0], [0.5], [1.0]], \"Q\": [[0.001, 0, 0], [0, 0.002, 0], [0, 0, 0.001]],"
    " \"R\": [[0.02, 0.005, 0], [0.005, 0.03, 0], [0, 0, 0.01]]}";
static const char lin_expr[] =
    "{\"expr\": {\"f\": [\"x1 + 0.1*x2\", \"0.95*x2 + 0.1*x3 + 0.1*sin(d1)\","
    "                   \"0.9*x3 + 0.05*sin(d1)\"],"
    "            \"g\": [\"x1\", \"x3 + 0.5*d1\", \"x1 + x2 + d1\"],"
    "            \"A\": [[1, 0.1, 0], [0, 0.95, 0.1], [0, 0, 0.9]],"
    "            \"G\": [[\"0\"], [\"0.1*cos(d1)\"], [\"0.05*cos(d1)\"]],"
    "            \"C\": [[1, 0, 0], [0, 0, 1], [1, 1, 0]], \"H\": [[0], [0.5], [1]]},"
    " \"Q\": [[0.001, 0, 0], [0, 0.002, 0], [0, 0, 0.001]],"
    " \"R\": [[0.02, 0.005, 0], [0.005, 0.03, 0], [0, 0, 0.01]]}";

static void test_expr_equals_builtin_lin(void **state)
{
    char err[DKF_SCN_ERR_LEN];
    const double x0[3] = {0, 0, 0}, d0[1] = {0};
    dkf_nlm_t *a = load_model(lin_expr, 3, 1, x0, d0, err), *b;
    double gap;
    (void)state;
    if (a == NULL) fail_msg("%s", err);
    b = load_model(lin_builtin, 3, 1, x0, d0, err);
    if (b == NULL) fail_msg("%s", err);
    assert_string_equal(a->source, "expr");
    assert_int_equal(a->m, 3);
    assert_null(a->model.y_diff); /* no angle channel */
    gap = model_gap(a, b, -5, 5, -3, 3, 200);
    /* the same sums in another order: a few roundings, 8 eps */
    print_message("lin_x_sin_d: expressions vs built-in %.3g\n", gap);
    assert_true(gap <= 8 * EPS);
    assert_memory_equal(a->Q, b->Q, 9 * sizeof *a->Q);
    assert_memory_equal(a->R, b->R, 9 * sizeof *a->R);
    dkf_nlm_free(a);
    dkf_nlm_free(b);
}

/* seed 001's radar written out; (1 - cos u)/w as 2 sin(u/2)^2 / w, as the
 * built-in model computes it, so the two agree to rounding (the turn
 * rates drawn are away from 0, where the built-in model uses its series). */
static const char radar_expr[] =
    "{\"expr\": {\"f\": [\"x1 + sin(d1)/d1*x2 - 2*sin(d1/2)^2/d1*x4\","
    "                   \"cos(d1)*x2 - sin(d1)*x4\","
    "                   \"2*sin(d1/2)^2/d1*x2 + x3 + sin(d1)/d1*x4\","
    "                   \"sin(d1)*x2 + cos(d1)*x4\"],"
    "            \"g\": [\"hypot(x1 - 20, x3 + 40)\", \"atan2(x3 + 40, x1 - 20)\", \"10*d1\"],"
    "            \"C\": [[\"(x1-20)/hypot(x1-20, x3+40)\", 0, \"(x3+40)/hypot(x1-20, x3+40)\", 0],"
    "                    [\"-(x3+40)/((x1-20)^2+(x3+40)^2)\", 0,"
    "                     \"(x1-20)/((x1-20)^2+(x3+40)^2)\", 0], [0, 0, 0, 0]],"
    "            \"H\": [[0], [0], [10]],"
    "            \"angles\": [1]},"
    " \"Q\": [[0.01, 0.02, 0, 0], [0.02, 0.04, 0, 0], [0, 0, 0.01, 0.02], [0, 0, 0.02, 0.04]],"
    " \"R\": [[0.04, 0, 0], [0, 0.000225, 0], [0, 0, 8.803443431835878e-08]]}";
static const char radar_builtin[] =
    "{\"family\": \"s1_radar\", \"sensor_xy\": [20.0, -40.0],"
    " \"Q\": [[0.01, 0.02, 0, 0], [0.02, 0.04, 0, 0], [0, 0, 0.01, 0.02], [0, 0, 0.02, 0.04]],"
    " \"R\": [[0.04, 0, 0], [0, 0.000225, 0], [0, 0, 8.803443431835878e-08]]}";

static void test_expr_equals_builtin_radar(void **state)
{
    char err[DKF_SCN_ERR_LEN];
    const double x0[4] = {-40, 3, 10, 1}, d0[1] = {-0.05};
    dkf_nlm_t *a = load_model(radar_expr, 4, 1, x0, d0, err), *b;
    double gap, x[4], d[1], z1[4], z2[4], J1[12], J2[3];
    (void)state;
    if (a == NULL) fail_msg("%s", err);
    b = load_model(radar_builtin, 4, 1, x0, d0, err);
    if (b == NULL) fail_msg("%s", err);
    assert_int_equal(a->nangles, 1);
    assert_true(a->angle[1] && !a->angle[0] && !a->angle[2]);
    /* f, g, C, H compared (f_jac only in b: compare it separately below) */
    {
        unsigned st = 777u;
        size_t c, i;
        gap = 0;
        for (c = 0; c < 200; ++c) {
            for (i = 0; i < 4; ++i) x[i] = urand(&st, -60, 60);
            d[0] = urand(&st, 0.02, 0.2) * (c % 2 ? 1 : -1);
            assert_int_equal(call_f(a, x, d, z1), 0);
            assert_int_equal(call_f(b, x, d, z2), 0);
            for (i = 0; i < 4; ++i) gap = fmax(gap, fabs(z1[i] - z2[i]) / fmax(1, fabs(z2[i])));
            assert_int_equal(call_h(a, x, d, z1), 0);
            assert_int_equal(call_h(b, x, d, z2), 0);
            for (i = 0; i < 3; ++i) gap = fmax(gap, fabs(z1[i] - z2[i]) / fmax(1, fabs(z2[i])));
            assert_int_equal(call_jac(a, 1, x, d, J1, J2), 0);
            {
                double K1[12], K2[3];
                assert_int_equal(call_jac(b, 1, x, d, K1, K2), 0);
                for (i = 0; i < 12; ++i) gap = fmax(gap, fabs(J1[i] - K1[i]) / fmax(1, fabs(K1[i])));
                for (i = 0; i < 3; ++i) gap = fmax(gap, fabs(J2[i] - K2[i]) / fmax(1, fabs(K2[i])));
            }
        }
    }
    /* sin(w)/w etc. evaluated alike; |x| <= 60 scales the sums: 64 eps */
    print_message("s1_radar: expressions vs built-in %.3g\n", gap);
    assert_true(gap <= 64 * EPS);
    assert_null(a->model.f_jac); /* no A, G given: the core differences f */
    dkf_nlm_free(a);
    dkf_nlm_free(b);
}

/* ---- the coordinated turn's Jacobians ------------------------------------------ */

static void test_ct_jacobians(void **state)
{
    char err[DKF_SCN_ERR_LEN];
    const double x0[4] = {-40, 3, 10, 1}, d0[1] = {-0.05};
    static const double omegas[] = {-0.2, -0.05236, -0.0100001, -0.0099999, -1e-6, 0.0, 3e-9,
                                    0.0099999, 0.0100001, 0.1047, 0.1745};
    double worst = 0, jump = 0;
    size_t c, i, j;
    dkf_nlm_t *b;
    (void)state;
    if (DKF_USE_FLOAT) skip(); /* the differences below need double arithmetic */
    b = load_model(radar_builtin, 4, 1, x0, d0, err);
    if (b == NULL) fail_msg("%s", err);
    for (c = 0; c < sizeof omegas / sizeof omegas[0]; ++c) {
        const double x[4] = {-36.3, 2.88, 7.15, 0.75}, d[1] = {omegas[c]};
        double Fx[16], Fd[4], Hx[12], Hd[3], fp[4], fm[4], hp[3], hm[3];
        assert_int_equal(call_jac(b, 0, x, d, Fx, Fd), 0);
        assert_int_equal(call_jac(b, 1, x, d, Hx, Hd), 0);
        /* central differences, step 1e-4: truncation h^2/6 |f'''| <= 2e-9
         * here (|f'''| <= 1 for the turn, |x| <= 40 at most for the
         * range terms, r ~ 50), rounding eps |f| / h <= 1e-10: 1e-8 */
        for (j = 0; j < 5; ++j) {
            double xp[4], xm[4], dp[1] = {d[0]}, dm[1] = {d[0]};
            const double h = 1e-4;
            memcpy(xp, x, sizeof xp);
            memcpy(xm, x, sizeof xm);
            if (j < 4) {
                xp[j] += h;
                xm[j] -= h;
            } else {
                dp[0] += h;
                dm[0] -= h;
            }
            assert_int_equal(call_f(b, xp, dp, fp), 0);
            assert_int_equal(call_f(b, xm, dm, fm), 0);
            assert_int_equal(call_h(b, xp, dp, hp), 0);
            assert_int_equal(call_h(b, xm, dm, hm), 0);
            for (i = 0; i < 4; ++i) {
                const double fd = (fp[i] - fm[i]) / (2 * h);
                worst = fmax(worst, fabs(fd - (j < 4 ? Fx[i * 4 + j] : Fd[i])));
            }
            for (i = 0; i < 3; ++i) {
                const double fd = (hp[i] - hm[i]) / (2 * h);
                worst = fmax(worst, fabs(fd - (j < 4 ? Hx[i * 4 + j] : Hd[i])));
            }
        }
    }
    /* the series / closed-form switch at |wT| = 1e-2 is continuous: f on
     * either side of it differs by what the step in w explains (2e-7 *
     * |dF/dw x| <= 2e-7 * 10) plus rounding */
    {
        const double x[4] = {-36.3, 2.88, 7.15, 0.75}, lo[1] = {0.0099999}, hi[1] = {0.0100001};
        double a[4], c2[4];
        assert_int_equal(call_f(b, x, lo, a), 0);
        assert_int_equal(call_f(b, x, hi, c2), 0);
        for (i = 0; i < 4; ++i) jump = fmax(jump, fabs(a[i] - c2[i]));
    }
    print_message("coordinated turn: analytic vs central differences %.3g, switch %.3g\n",
                  worst, jump);
    assert_true(worst <= 1e-8);
    assert_true(jump <= 2e-6);
    dkf_nlm_free(b);
}

/* ---- bearings wrap -------------------------------------------------------------- */

static void test_angle_wrap(void **state)
{
    char err[DKF_SCN_ERR_LEN];
    const double x0[4] = {-40, 3, 10, 1}, d0[1] = {-0.05};
    dkf_nlm_t *b = load_model(radar_builtin, 4, 1, x0, d0, err);
    dkf_real_t a[3] = {(dkf_real_t)10, (dkf_real_t)3.1, (dkf_real_t)0.5};
    dkf_real_t c[3] = {(dkf_real_t)2, (dkf_real_t)-3.1, (dkf_real_t)-0.5};
    dkf_real_t out[3];
    (void)state;
    if (b == NULL) fail_msg("%s", err);
    b->model.y_diff(b->model.ctx, a, c, out);
    assert_true(fabs((double)out[0] - 8.0) < 1e-6); /* range: plain difference */
    /* bearing: 6.2 - 2 pi = -0.0832 (float: the inputs' rounding, 1e-6) */
    assert_true(fabs((double)out[1] - ((double)a[1] - (double)c[1] - 2 * PI)) < 1e-6);
    assert_true(fabs((double)out[2] - 1.0) < 1e-6); /* phi: not an angle, 1 unchanged */
    /* -3.1 - 3.1 = -6.2 -> 0.0832; the result is in [-pi, pi) */
    b->model.y_diff(b->model.ctx, c, a, out);
    assert_true(fabs((double)out[1] - ((double)c[1] - (double)a[1] + 2 * PI)) < 1e-6);
    assert_true((double)out[1] >= -PI && (double)out[1] < PI);
    /* far from the range too (a diverged filter's bearings): still in
     * [-pi, pi) (in float to the cast's rounding, 4e-7); v - 2 pi floor(...)
     * gave -4 for 1e16 */
    {
        static const double big[] = {1e16, 3e17, -7e25, 1e30};
        size_t i;
        for (i = 0; i < sizeof big / sizeof big[0]; ++i) {
            a[1] = (dkf_real_t)big[i];
            c[1] = (dkf_real_t)0.5;
            b->model.y_diff(b->model.ctx, a, c, out);
            assert_true((double)out[1] >= -PI - 4e-7 && (double)out[1] < PI + 4e-7);
        }
    }
    dkf_nlm_free(b);
}

/* ---- errors --------------------------------------------------------------------- */

typedef struct {
    const char *model;  /* the model object (n = 3, p = 1, x0 = (1, 0, 0), d0 = 0) */
    const char *expect; /* the message after "t.json: " */
} bad_t;

#define QR3 ", \"Q\": [[1,0,0],[0,1,0],[0,0,1]], \"R\": [[1,0],[0,1]]}"
#define F3 "\"f\": [\"x1\", \"x2\", \"x3\"]"

static void test_expr_errors(void **state)
{
    static const bad_t rows[] = {
        {"{\"expr\": {" F3 ", \"g\": [\"x1 +\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'x1 +': unexpected end of the expression at position"},
        {"{\"expr\": {" F3 ", \"g\": [\"x4\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'x4': unknown variable or function 'x4' at position 1 "
         "(variables: x1..x3, d1)"},
        {"{\"expr\": {" F3 ", \"g\": [\"x1 + y1\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'x1 + y1': unknown variable or function 'y1'"},
        {"{\"expr\": {" F3 ", \"g\": [\"foo(x1)\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'foo(x1)': unknown variable or function 'foo'"},
        {"{\"expr\": {" F3 ", \"g\": [\"x1/(x2 - x2)\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'x1/(x2 - x2)' = inf at x1=1 x2=0 x3=0 d1=0 (division by zero"},
        {"{\"expr\": {" F3 ", \"g\": [\"log(x2)\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'log(x2)' = -inf at"},
        {"{\"expr\": {" F3 ", \"g\": [\"sqrt(x1 - 2)\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'sqrt(x1 - 2)' = "},
        {"{\"expr\": {" F3 ", \"g\": [\"x1 = 2\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'x1 = 2': assignment '=' at position 4 is not allowed"},
        {"{\"expr\": {" F3 ", \"g\": [\"x1, x2\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'x1, x2': gives 2 values, expected one"},
        {"{\"expr\": {" F3 ", \"g\": [\"sin(x1\", \"d1\"]}" QR3,
         "model.expr.g[0]: 'sin(x1': missing ')'"},
        {"{\"expr\": {" F3 ", \"g\": [\"\", \"d1\"]}" QR3,
         "model.expr.g[0]: '': empty expression"},
        {"{\"expr\": {" F3 ", \"g\": [[1], \"d1\"]}" QR3,
         "model.expr.g[0]: expected an expression string, got a list"},
        {"{\"expr\": {\"f\": [\"x1\", \"x2\"], \"g\": [\"x1\", \"d1\"]}" QR3,
         "model.expr.f: expected 3 expressions, got 2"},
        {"{\"expr\": {" F3 "}" QR3, "model.expr.g: missing key"},
        {"{\"expr\": {" F3 ", \"g\": [\"x1\", \"d1\"], \"F\": []}" QR3,
         "model.expr.F: unknown key"},
        {"{\"expr\": {" F3 ", \"g\": [\"x1\", \"d1\"], \"C\": [[1,0,0],[0,0,0]]}" QR3,
         "model.expr.H: missing key (C is given: give both or neither)"},
        {"{\"expr\": {" F3 ", \"g\": [\"x1\", \"d1\"], \"A\": [[1,0],[0,1],[0,0]], "
         "\"G\": [[0],[0],[0]]}" QR3,
         "model.expr.A[0]: expected 3 expressions, got 2"},
        {"{\"expr\": {" F3 ", \"g\": [\"x1\", \"d1\"], \"angles\": [2]}" QR3,
         "model.expr.angles[0]: "},
        {"{\"expr\": {" F3 ", \"g\": [\"x1\", \"d1\"], \"angles\": [0, 0]}" QR3,
         "model.expr.angles[1]: index 0 listed twice"},
        {"{\"expr\": {" F3 ", \"g\": [\"x1\", \"d1\"]}, \"Q\": [[1,0,0],[0,1,0],[0,0,1]], "
         "\"R\": [[1,0,0],[0,1,0],[0,0,1]]}",
         "model.R: expected 2 x 2, got 3 x 3"},
        {"{\"expr\": {" F3 ", \"g\": [\"x1\", \"d1\"]}, \"R\": [[1,0],[0,1]]}",
         "model.Q: missing key"},
        {"{\"family\": \"s2_radar\"" QR3, "model.family: unknown family 's2_radar'"},
        {"{\"Q\": [[1]]}", "model.expr: missing key (give \"expr\""},
        {"{\"family\": \"s1_radar\", \"sensor_xy\": [0, 0]" QR3,
         "model: family s1_radar has n = 4 (xi, xi_dot, eta, eta_dot) and p = 1 (omega); the "
         "case's init gives n = 3, p = 1"},
    };
    const double x0[3] = {1, 0, 0}, d0[1] = {0};
    size_t i;
    (void)state;
    for (i = 0; i < sizeof rows / sizeof rows[0]; ++i) {
        char err[DKF_SCN_ERR_LEN], want[DKF_SCN_ERR_LEN];
        dkf_nlm_t *m = load_model(rows[i].model, 3, 1, x0, d0, err);
        snprintf(want, sizeof want, "t.json: %s", rows[i].expect);
        if (m != NULL) fail_msg("row %zu loaded: %s", i, rows[i].model);
        if (strncmp(err, want, strlen(want)) != 0)
            fail_msg("row %zu:\n  got  %s\n  want %s...", i, err, want);
        assert_null(strchr(err, '\n'));
    }
}

/* The last row above is accepted once g has m >= p: m = 1 = p works. */
static void test_expr_minimal(void **state)
{
    char err[DKF_SCN_ERR_LEN];
    const double x0[1] = {2}, d0[1] = {0.5};
    dkf_nlm_t *m = load_model("{\"expr\": {\"f\": [\"x1 + d1\"], \"g\": [\"2*x1 + pi*d1\"]},"
                              " \"Q\": [[1]], \"R\": [[1]]}", 1, 1, x0, d0, err);
    double z;
    (void)state;
    if (m == NULL) fail_msg("%s", err);
    assert_int_equal(call_h(m, x0, d0, &z), 0);
    /* pi at full precision (muparser's own _pi has 13 digits) */
    assert_true(fabs(z - (4 + PI / 2)) <= 4 * EPS * 6);
    dkf_nlm_free(m);
}

/* Division by zero at run time: the callback fails and says where. */
static void test_runtime_failure(void **state)
{
    char err[DKF_SCN_ERR_LEN];
    const double x0[2] = {1, 0}, d0[1] = {0};
    dkf_nlm_t *m = load_model("{\"expr\": {\"f\": [\"x1/(x2 - 1)\", \"sqrt(x2)\"],"
                              " \"g\": [\"x1\", \"x2 + d1\"]},"
                              " \"Q\": [[1, 0], [0, 1]], \"R\": [[1, 0], [0, 1]]}",
                              2, 1, x0, d0, err);
    const double at_pole[2] = {1, 1}, negative[2] = {1, -4};
    double out[2];
    (void)state;
    if (m == NULL) fail_msg("%s", err);
    assert_string_equal(dkf_nlm_failure(m), "");
    assert_int_equal(call_f(m, x0, d0, out), 0);
    assert_int_not_equal(call_f(m, at_pole, d0, out), 0);
    assert_non_null(strstr(dkf_nlm_failure(m), "model.expr.f[0]: 'x1/(x2 - 1)' = inf at x1=1 "
                                                "x2=1 d1=0 (division by zero"));
    assert_int_not_equal(call_f(m, negative, d0, out), 0);
    assert_non_null(strstr(dkf_nlm_failure(m), "model.expr.f[1]: 'sqrt(x2)' = "));
    dkf_nlm_free(m);
}

/* A built-in family made without JSON (nlm_model.h, as the Python package
 * makes it) is the loaded model: the same f, h, Jacobians, bearings and
 * default R, bit for bit (the 12-sensor stacked radar, no R in the file). */
static void test_family_without_json(void **state)
{
    dkf_scenario_t *s = load(VEC "dnertsif_single.json", "1");
    const dkf_nlm_t *ref = s->nl->models[0];
    const dkf_nlm_family_t *rb = ref->impl;
    dkf_nlm_t *m = calloc(1, sizeof *m);
    dkf_nlm_family_t *b = calloc(1, sizeof *b);
    static double J1[2][DKF_MAX_DIM * DKF_MAX_DIM], J2[2][DKF_MAX_DIM];
    double x[4] = {3.0, -1.5, 20.0, 0.75}, d[1] = {0.04}, o1[DKF_MAX_DIM], o2[DKF_MAX_DIM];
    int w;
    (void)state;
    assert_non_null(m);
    assert_non_null(b);
    m->path = calloc(1, 8);
    assert_non_null(m->path);
    assert_int_equal(dkf_nlm_family_index("s1_radar_stacked"), 2);
    assert_int_equal(dkf_nlm_family_index("s1_radr"), -1);
    m->n = 4, m->p = 1, m->impl = b;
    b->T = 1.0, b->gain = 10.0, b->L = rb->L, b->per = 3;
    memcpy(b->sxy, rb->sxy, sizeof b->sxy);
    dkf_nlm_s1_layout(m, b);
    assert_int_equal(m->m, ref->m);
    assert_memory_equal(m->angle, ref->angle, sizeof m->angle);
    m->R = calloc(m->m * m->m, sizeof *m->R);
    assert_non_null(m->R);
    dkf_nlm_s1_default_R(m->R, m->m, b);
    assert_memory_equal(m->R, ref->R, m->m * m->m * sizeof *m->R);
    assert_int_equal(dkf_nlm_finish(m), 0);
    assert_ptr_equal(m->model.y_diff, ref->model.y_diff);
    assert_int_equal(call_f(m, x, d, o1), 0);
    assert_int_equal(call_f(ref, x, d, o2), 0);
    assert_memory_equal(o1, o2, 4 * sizeof *o1);
    assert_int_equal(call_h(m, x, d, o1), 0);
    assert_int_equal(call_h(ref, x, d, o2), 0);
    assert_memory_equal(o1, o2, m->m * sizeof *o1);
    for (w = 0; w < 2; ++w) {
        const size_t r = w == 0 ? 4 : m->m;
        assert_int_equal(call_jac(m, w, x, d, J1[0], J2[0]), 0);
        assert_int_equal(call_jac(ref, w, x, d, J1[1], J2[1]), 0);
        assert_memory_equal(J1[0], J1[1], r * 4 * sizeof(double));
        assert_memory_equal(J2[0], J2[1], r * sizeof(double));
    }
    dkf_nlm_free(m);
    dkf_scenario_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vector_cases_load),
        cmocka_unit_test(test_lin_builtin_vs_vector),
        cmocka_unit_test(test_expr_equals_builtin_lin),
        cmocka_unit_test(test_expr_equals_builtin_radar),
        cmocka_unit_test(test_ct_jacobians),
        cmocka_unit_test(test_angle_wrap),
        cmocka_unit_test(test_expr_errors),
        cmocka_unit_test(test_expr_minimal),
        cmocka_unit_test(test_runtime_failure),
        cmocka_unit_test(test_family_without_json),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
