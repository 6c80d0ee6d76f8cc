/*
 * The nonlinear model interface (dkf/nl_model.h) on seed 001's target
 * model: a coordinated turn, x = [px, vx, py, vy], T = 1, the turn rate
 * omega the unknown input (p = 1), and a range / bearing / 10 omega sensor
 * at s = (sx, sy) (m = 3), y = [|r|, atan2(r_y, r_x), 10 omega], r = pos - s.
 *
 * Forward differences against the analytic Jacobians (written out below,
 * in double, from the model's formulas). Bound per entry (i, j), step s_j
 * = the step the library takes for component j: the truncation error of a
 * forward difference is s_j / 2 |d^2 f_i / dv_j^2| at most, and the
 * rounding error of (f(v + s_j e_j) - f(v)) / s_j is ~ 2 eps max(1, |f_i|)
 * / s_j (two rounded values of size |f_i|, and the model's own rounding,
 * which the factor 4 below covers). The second derivative is estimated by
 * the change of the analytic Jacobian over the same step,
 * |J_ij(v + s_j e_j) - J_ij(v)| / s_j, so
 *   tol_ij = 2 (s_j |J_ij(v + s_j e_j) - J_ij(v)| / s_j) + 4 eps max(1, |f_i|) / s_j
 *          + 4 eps |J_ij|
 * (the last term: the analytic reference's own rounding). The worst
 * observed ratio err / tol is printed; it is asserted below 1 (external)
 * and below 2x the worst seen in double and float (regression).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/nl_model.h"
#include "dkf_test.h"

#define NX 4
#define MY 3
#define PD 1
#define WORK DKF_NL_JAC_WORK(NX, MY, PD)
#define SENTINEL ((dkf_real_t)-1234.5)
#define PI 3.14159265358979323846

/* the worst err / tol seen when the bounds were set: float 0.134, double
 * 0.25 (= the forward difference's s/2 f'' against the bound's 2 s f'': the
 * truncation term dominates in double) */
#define SEEN_RATIO (DKF_USE_FLOAT ? 0.134 : 0.25)

typedef struct {
    double sx, sy;  /* the sensor's position */
    int fail_f;     /* f returns -1 when set */
    int nan_h;      /* h writes NaN when set */
    int inf_jac;    /* f_jac writes Inf when set */
    int calls;      /* callback calls */
} ct_ctx_t;

/* sin(w)/w, (1 - cos w)/w and their derivatives in w, with the w -> 0
 * limits (series to w^4: the error is below 1e-17 for |w| < 1e-3). */
static void turn_terms(double w, double *a, double *b, double *da, double *db)
{
    if (fabs(w) < 1e-3) {
        *a = 1 - w * w / 6;
        *b = w / 2 - w * w * w / 24;
        *da = -w / 3;
        *db = 0.5 - w * w / 8;
        return;
    }
    *a = sin(w) / w;
    *b = (1 - cos(w)) / w;
    *da = (w * cos(w) - sin(w)) / (w * w);
    *db = (w * sin(w) - (1 - cos(w))) / (w * w);
}

static void ct_f_double(const double *x, double w, double *out)
{
    double a, b, da, db;
    turn_terms(w, &a, &b, &da, &db);
    out[0] = x[0] + a * x[1] - b * x[3];
    out[1] = cos(w) * x[1] - sin(w) * x[3];
    out[2] = x[2] + b * x[1] + a * x[3];
    out[3] = sin(w) * x[1] + cos(w) * x[3];
}

/* Fx (4 x 4), Fd (4 x 1) of ct_f_double */
static void ct_f_jac_double(const double *x, double w, double *Fx, double *Fd)
{
    double a, b, da, db;
    const double c = cos(w), s = sin(w);
    const double J[16] = {1, 0, 0, 0, 0, c, 0, -s, 0, 0, 1, 0, 0, s, 0, c};
    turn_terms(w, &a, &b, &da, &db);
    memcpy(Fx, J, sizeof J);
    Fx[1] = a;
    Fx[3] = -b;
    Fx[9] = b;
    Fx[11] = a;
    Fd[0] = da * x[1] - db * x[3];
    Fd[1] = -s * x[1] - c * x[3];
    Fd[2] = db * x[1] + da * x[3];
    Fd[3] = c * x[1] - s * x[3];
}

static void ct_h_double(const ct_ctx_t *c, const double *x, double w, double *y)
{
    const double rx = x[0] - c->sx, ry = x[2] - c->sy;
    y[0] = hypot(rx, ry);
    y[1] = atan2(ry, rx);
    y[2] = 10 * w;
}

static void ct_h_jac_double(const ct_ctx_t *c, const double *x, double *Hx, double *Hd)
{
    const double rx = x[0] - c->sx, ry = x[2] - c->sy, r2 = rx * rx + ry * ry, r = sqrt(r2);
    const double J[12] = {rx / r, 0, ry / r, 0, -ry / r2, 0, rx / r2, 0, 0, 0, 0, 0};
    memcpy(Hx, J, sizeof J);
    Hd[0] = 0;
    Hd[1] = 0;
    Hd[2] = 10;
}

static void to_double(double *dst, const dkf_real_t *src, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) dst[i] = (double)src[i];
}

static void to_real(dkf_real_t *dst, const double *src, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) dst[i] = (dkf_real_t)src[i];
}

/* ---- the callbacks (the library's real type) --------------------------- */

static int cb_f(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                const dkf_real_t *u, dkf_real_t *x_next)
{
    ct_ctx_t *c = ctx;
    double xd[NX], out[NX];
    (void)k;
    (void)u;
    ++c->calls;
    if (c->fail_f) return -1;
    to_double(xd, x, NX);
    ct_f_double(xd, (double)d[0], out);
    to_real(x_next, out, NX);
    return 0;
}

static int cb_h(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                const dkf_real_t *u, dkf_real_t *y)
{
    ct_ctx_t *c = ctx;
    double xd[NX], out[MY];
    (void)k;
    (void)u;
    ++c->calls;
    to_double(xd, x, NX);
    ct_h_double(c, xd, (double)d[0], out);
    to_real(y, out, MY);
    if (c->nan_h) y[1] = (dkf_real_t)NAN;
    return 0;
}

static int cb_f_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                    const dkf_real_t *u, dkf_real_t *Fx, dkf_real_t *Fd)
{
    ct_ctx_t *c = ctx;
    double xd[NX], Jx[NX * NX], Jd[NX];
    (void)k;
    (void)u;
    ++c->calls;
    to_double(xd, x, NX);
    ct_f_jac_double(xd, (double)d[0], Jx, Jd);
    to_real(Fx, Jx, NX * NX);
    to_real(Fd, Jd, NX);
    if (c->inf_jac) Fd[2] = (dkf_real_t)INFINITY;
    return 0;
}

/* the bearing difference wrapped into [-pi, pi) */
static void cb_y_diff(void *ctx, const dkf_real_t *a, const dkf_real_t *b, dkf_real_t *out)
{
    double e = (double)a[1] - (double)b[1];
    (void)ctx;
    out[0] = a[0] - b[0];
    out[2] = a[2] - b[2];
    e = fmod(e + PI, 2 * PI);
    if (e < 0) e += 2 * PI;
    out[1] = (dkf_real_t)(e - PI);
}

static dkf_nl_model_t ct_model(ct_ctx_t *c)
{
    dkf_nl_model_t md;
    memset(&md, 0, sizeof md);
    memset(c, 0, sizeof *c);
    c->sx = 3.0;
    c->sy = -2.0;
    md.ctx = c;
    md.n = NX;
    md.m = MY;
    md.p = PD;
    md.q = 0;
    md.f = cb_f;
    md.h = cb_h;
    md.y_diff = cb_y_diff;
    return md;
}

/* The step the library takes for v (dkf/nl_model.h). */
static double step_of(dkf_real_t v)
{
    const dkf_real_t a = v < 0 ? -v : v;
    const dkf_real_t moved = v + (dkf_real_t)DKF_NL_FD_STEP * (a > 1 ? a : (dkf_real_t)1);
    return (double)(moved - v);
}

/* The worst err / tol over J = [Jx Jd] (r x (n + p)) against the analytic
 * [Ax Ad] at v and [Bx Bd] at the moved points (column j from v + s_j e_j),
 * fvals the function values at v (for the rounding term). */
static double worst_ratio(const dkf_real_t *Jx, const dkf_real_t *Jd, const double *Ax,
                          const double *Ad, const double (*moved)[NX * (NX + PD)],
                          const double *fvals, const double *steps, size_t r)
{
    const size_t c = NX + PD;
    double worst = 0;
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) {
            const double got = j < NX ? (double)Jx[i * NX + j] : (double)Jd[i * PD + j - NX];
            const double ref = j < NX ? Ax[i * NX + j] : Ad[i * PD + j - NX];
            const double tol = 2 * fabs(moved[j][i * c + j] - ref) +
                               4 * TEST_EPS * fmax(1, fabs(fvals[i])) / steps[j] +
                               4 * TEST_EPS * fabs(ref);
            const double ratio = fabs(got - ref) / tol;
            if (ratio > worst) worst = ratio;
        }
    return worst;
}

/* Forward-difference Jacobians of f and h at a point off and near the
 * bearing's branch cut (the target almost due west of the sensor: a step
 * in py crosses +-pi, which only y_diff makes harmless). */
static void test_fd_jacobians_within_the_bound(void **state)
{
    static const double pts[2][NX + PD] = {
        {10.0, 1.5, 4.0, -0.7, -0.0523}, /* omega = -3 deg/s */
        {-5.0, 0.4, -2.0 - 1e-7, 2.0, 0.1745}};
    ct_ctx_t c;
    dkf_nl_model_t md = ct_model(&c);
    dkf_real_t x[NX], d[PD], Fx[NX * NX], Fd[NX], Hx[MY * NX], Hd[MY], work[WORK];
    double xd[NX], Ax[NX * NX], Ad[NX], Cx[MY * NX], Cd[MY], fv[NX], hv[MY], steps[NX + PD];
    double mf[NX + PD][NX * (NX + PD)], mh[NX + PD][NX * (NX + PD)], wf = 0, wh = 0;
    size_t t, j, i;
    (void)state;
    for (t = 0; t < 2; ++t) {
        to_real(x, pts[t], NX);
        d[0] = (dkf_real_t)pts[t][NX];
        assert_int_equal(dkf_nl_f_jacobian(&md, 0, x, d, NULL, Fx, Fd, work), DKF_OK);
        assert_int_equal(dkf_nl_h_jacobian(&md, 0, x, d, NULL, Hx, Hd, work), DKF_OK);
        /* the analytic references at the library's exact point and at each moved point */
        to_double(xd, x, NX);
        ct_f_jac_double(xd, (double)d[0], Ax, Ad);
        ct_h_jac_double(&c, xd, Cx, Cd);
        ct_f_double(xd, (double)d[0], fv);
        ct_h_double(&c, xd, (double)d[0], hv);
        for (j = 0; j < NX + PD; ++j) {
            double v[NX], w = (double)d[0], Jx[NX * NX], Jd[NX], Kx[MY * NX], Kd[MY];
            memcpy(v, xd, sizeof v);
            steps[j] = step_of(j < NX ? x[j] : d[0]);
            if (j < NX) v[j] += steps[j];
            else w += steps[j];
            ct_f_jac_double(v, w, Jx, Jd);
            ct_h_jac_double(&c, v, Kx, Kd);
            for (i = 0; i < NX; ++i) {
                memcpy(&mf[j][i * (NX + PD)], &Jx[i * NX], NX * sizeof(double));
                mf[j][i * (NX + PD) + NX] = Jd[i];
            }
            for (i = 0; i < MY; ++i) {
                memcpy(&mh[j][i * (NX + PD)], &Kx[i * NX], NX * sizeof(double));
                mh[j][i * (NX + PD) + NX] = Kd[i];
            }
        }
        wf = fmax(wf, worst_ratio(Fx, Fd, Ax, Ad, (const double(*)[NX * (NX + PD)])mf, fv,
                                  steps, NX));
        wh = fmax(wh, worst_ratio(Hx, Hd, Cx, Cd, (const double(*)[NX * (NX + PD)])mh, hv,
                                  steps, MY));
    }
    print_message("forward differences: worst err/tol f %.3g, h %.3g\n", wf, wh);
    assert_true(wf < 1);
    assert_true(wh < 1);
    assert_true(wf < 2 * SEEN_RATIO);
    assert_true(wh < 2 * SEEN_RATIO);
}

/* Without y_diff the step in py at the second point crosses the branch cut
 * and the bearing's column is off by ~2 pi / step: y_diff is what makes
 * dkf_nl_h_jacobian right there. */
static void test_h_jacobian_goes_through_y_diff(void **state)
{
    ct_ctx_t c;
    dkf_nl_model_t md = ct_model(&c);
    dkf_real_t x[NX] = {DKF_R(-5.0), DKF_R(0.4), DKF_R(-2.0), DKF_R(2.0)}, d[PD] = {DKF_R(0.1)};
    dkf_real_t Hx[MY * NX], Hd[MY], work[WORK];
    (void)state;
    /* py just below the sensor's: the bearing is just above -pi, and the
     * step in py (twice as large) takes it to just below +pi */
    x[2] = (dkf_real_t)(-2.0) - (dkf_real_t)DKF_NL_FD_STEP;
    assert_int_equal(dkf_nl_h_jacobian(&md, 0, x, d, NULL, Hx, Hd, work), DKF_OK);
    /* d bearing / d py = rx / r^2 = -8 / 64 */
    assert_true(fabs((double)Hx[1 * NX + 2] + 0.125) < 0.01);
    md.y_diff = NULL;
    assert_int_equal(dkf_nl_h_jacobian(&md, 0, x, d, NULL, Hx, Hd, work), DKF_OK);
    assert_true(fabs((double)Hx[1 * NX + 2]) > 1e3);
}

/* A given Jacobian callback is used as it is, bit for bit, and f is not
 * called. */
static void test_jacobian_callback_used(void **state)
{
    ct_ctx_t c;
    dkf_nl_model_t md = ct_model(&c);
    dkf_real_t x[NX] = {DKF_R(1.0), DKF_R(2.0), DKF_R(3.0), DKF_R(4.0)}, d[PD] = {DKF_R(0.2)};
    dkf_real_t Fx[NX * NX], Fd[NX], Gx[NX * NX], Gd[NX], work[WORK];
    (void)state;
    md.f_jac = cb_f_jac;
    assert_int_equal(dkf_nl_f_jacobian(&md, 0, x, d, NULL, Fx, Fd, work), DKF_OK);
    assert_int_equal(c.calls, 1);
    assert_int_equal(cb_f_jac(&c, 0, x, d, NULL, Gx, Gd), 0);
    assert_memory_equal(Fx, Gx, sizeof Fx);
    assert_memory_equal(Fd, Gd, sizeof Fd);
}

static void fill(dkf_real_t *p, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) p[i] = SENTINEL;
}

static int untouched(const dkf_real_t *p, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i)
        if (p[i] != SENTINEL) return 0;
    return 1;
}

/* Every failure is a status and leaves the outputs as they were. */
static void test_errors_leave_outputs_untouched(void **state)
{
    ct_ctx_t c;
    dkf_nl_model_t md = ct_model(&c), bad;
    dkf_real_t x[NX] = {DKF_R(1.0), DKF_R(2.0), DKF_R(3.0), DKF_R(4.0)}, d[PD] = {DKF_R(0.2)};
    dkf_real_t u[1] = {DKF_R(0.0)}, xn[NX], Fx[NX * NX], Fd[NX], Hx[MY * NX], Hd[MY];
    dkf_real_t work[WORK];
    (void)state;
    fill(Fx, NX * NX);
    fill(Fd, NX);
    fill(Hx, MY * NX);
    fill(Hd, MY);
    c.fail_f = 1;
    assert_int_equal(dkf_nl_f_jacobian(&md, 0, x, d, NULL, Fx, Fd, work), DKF_ERR_MODEL);
    c.fail_f = 0;
    c.nan_h = 1;
    assert_int_equal(dkf_nl_h_jacobian(&md, 0, x, d, NULL, Hx, Hd, work), DKF_ERR_NONFINITE);
    c.nan_h = 0;
    md.f_jac = cb_f_jac;
    c.inf_jac = 1;
    assert_int_equal(dkf_nl_f_jacobian(&md, 0, x, d, NULL, Fx, Fd, work), DKF_ERR_NONFINITE);
    c.inf_jac = 0;
    md.f_jac = NULL;
    x[3] = (dkf_real_t)NAN;
    assert_int_equal(dkf_nl_f_jacobian(&md, 0, x, d, NULL, Fx, Fd, work), DKF_ERR_NONFINITE);
    x[3] = DKF_R(4.0);
    /* a component near the largest real: the step overflows */
    d[0] = (dkf_real_t)DKF_REAL_MAX;
    assert_int_equal(dkf_nl_f_jacobian(&md, 0, x, d, NULL, Fx, Fd, work), DKF_ERR_NONFINITE);
    d[0] = DKF_R(0.2);
    assert_true(untouched(Fx, NX * NX) && untouched(Fd, NX));
    assert_true(untouched(Hx, MY * NX) && untouched(Hd, MY));

    /* the table itself */
    assert_int_equal(dkf_nl_model_check(NULL), DKF_ERR_NULL);
    bad = md;
    bad.h = NULL;
    assert_int_equal(dkf_nl_model_check(&bad), DKF_ERR_NULL);
    assert_int_equal(dkf_nl_h_jacobian(&bad, 0, x, d, NULL, Hx, Hd, work), DKF_ERR_NULL);
    bad = md;
    bad.n = 0;
    assert_int_equal(dkf_nl_model_check(&bad), DKF_ERR_CAPACITY);
    bad = md;
    bad.m = DKF_MAX_DIM + 1;
    assert_int_equal(dkf_nl_model_check(&bad), DKF_ERR_CAPACITY);
    bad = md;
    bad.q = 1; /* a known input declared: u is required */
    assert_int_equal(dkf_nl_f_jacobian(&bad, 0, x, d, NULL, Fx, Fd, work), DKF_ERR_NULL);
    u[0] = (dkf_real_t)INFINITY;
    assert_int_equal(dkf_nl_f_jacobian(&bad, 0, x, d, u, Fx, Fd, work), DKF_ERR_NONFINITE);
    assert_int_equal(dkf_nl_f_jacobian(&md, 0, x, NULL, NULL, Fx, Fd, work), DKF_ERR_NULL);
    assert_true(untouched(Fx, NX * NX) && untouched(Fd, NX));
    assert_true(untouched(Hx, MY * NX) && untouched(Hd, MY));
    (void)xn;
}

/* p = 0 (no unknown input, seed 001's DF-CKF): d and Fd may be NULL. */
static int lin_f(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                 const dkf_real_t *u, dkf_real_t *x_next)
{
    (void)ctx;
    (void)k;
    (void)u;
    assert_null(d);
    x_next[0] = x[0] + x[1];
    x_next[1] = DKF_R(0.5) * x[1];
    return 0;
}

static int lin_h(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                 const dkf_real_t *u, dkf_real_t *y)
{
    (void)ctx;
    (void)k;
    (void)d;
    (void)u;
    y[0] = x[0];
    return 0;
}

static void test_no_unknown_input(void **state)
{
    dkf_nl_model_t md;
    dkf_real_t x[2] = {DKF_R(3.0), DKF_R(-1.0)}, Fx[4], work[DKF_NL_JAC_WORK(2, 1, 0)];
    (void)state;
    memset(&md, 0, sizeof md);
    md.n = 2;
    md.m = 1;
    md.f = lin_f;
    md.h = lin_h;
    assert_int_equal(dkf_nl_model_check(&md), DKF_OK);
    assert_int_equal(dkf_nl_f_jacobian(&md, 0, x, NULL, NULL, Fx, NULL, work), DKF_OK);
    /* a linear f: forward differences exact up to rounding of x + s - x */
    assert_true(fabs((double)Fx[0] - 1) < 8 * TEST_EPS / DKF_NL_FD_STEP);
    assert_true(fabs((double)Fx[1] - 1) < 8 * TEST_EPS / DKF_NL_FD_STEP);
    assert_true(fabs((double)Fx[2]) < 8 * TEST_EPS / DKF_NL_FD_STEP);
    assert_true(fabs((double)Fx[3] - 0.5) < 8 * TEST_EPS / DKF_NL_FD_STEP);
}

/* y_diff: the callback when set, plain subtraction otherwise. */
static void test_y_diff(void **state)
{
    ct_ctx_t c;
    dkf_nl_model_t md = ct_model(&c);
    dkf_real_t a[MY] = {DKF_R(5.0), DKF_R(3.1), DKF_R(1.0)};
    dkf_real_t b[MY] = {DKF_R(4.0), DKF_R(-3.1), DKF_R(0.5)}, out[MY];
    (void)state;
    dkf_nl_y_diff(&md, a, b, out);
    assert_true(fabs((double)out[1] - (6.2 - 2 * PI)) < 1e-5);
    md.y_diff = NULL;
    dkf_nl_y_diff(&md, a, b, out);
    assert_true(out[0] == DKF_R(1.0) && out[1] == a[1] - b[1] && out[2] == DKF_R(0.5));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fd_jacobians_within_the_bound),
        cmocka_unit_test(test_h_jacobian_goes_through_y_diff),
        cmocka_unit_test(test_jacobian_callback_used),
        cmocka_unit_test(test_errors_leave_outputs_untouched),
        cmocka_unit_test(test_no_unknown_input),
        cmocka_unit_test(test_y_diff),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
