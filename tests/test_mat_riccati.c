/*
 * Steady-state solvers of dkf/mat_riccati.h: dkf_mat_dare (SDA) and
 * dkf_mat_stein (Smith doubling).
 *
 * What is checked and how:
 *  - closed forms: the scalar DARE (root of a quadratic), the Lyapunov
 *    series q / (1 - a^2), a Stein equation against the Kronecker solve
 *    (I - A (x) B) vec_r X = vec_r C (row-major vec, so the Kronecker
 *    factor order is A (x) B) by dkf_mat_lu, the Lyapunov case A = B;
 *  - residuals of random stable and unstable-F systems (fixed seeds),
 *    evaluated in long double from the double images of the library's
 *    inputs and output, relative to max|X|;
 *  - the certificate independently of the library: the closed loop
 *    F (I - K H) built in long double from the returned X must have
 *    ||Phi^(2^j)||_1 <= 1/2 for some j (so rho < 1), X symmetric, PSD;
 *  - seed 002's example against tests/vectors/infofusion/s2_weighted_fusion.json
 *    (the model and cases[0].steady_state.Sigma_pred, read from the file);
 *  - ill-conditioned and marginal cases, every error status, outputs
 *    untouched on every error (bytes), the exact work size (no write past
 *    DKF_MAT_*_WORK reals).
 *
 * Tolerances, in units of EPS = DKF_REAL_EPSILON (so the float build runs
 * the same bounds scaled to its precision; the few fixed ones say so).
 * Rounding the exact X to the library type alone leaves a DARE residual
 * of about EPS (1 + ||F||^2) max|X|; SDA adds a few n EPS per doubling
 * step on the same scale. The residual bound is 20 n EPS (1 + ||F||_1^2)
 * relative to max|X| (measured worst: double 2.4e-14 = 0.02 of its bound
 * at n = 8, float 1.6e-5 = 0.03). Errors against closed forms are
 * forward errors and carry the condition number: 16 EPS / (1 - phi^2)
 * for the scalar DARE with closed loop phi; the Kronecker comparison of
 * the Stein solution 200 N EPS (N = r c, both solutions carry ~N EPS
 * times a condition of ~10 for these draws); seed 002 the file's rule in
 * double (and 64 EPS relative as the tight regression bound), 64 EPS
 * relative to max|expected| in float.
 */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/mat.h"
#include "dkf/mat_riccati.h"
#include "dkf_test.h"

#define NMAX 8
#define SQ (NMAX * NMAX)
#define DWORK DKF_MAT_DARE_WORK(NMAX, NMAX)
#define SWORK DKF_MAT_STEIN_WORK(NMAX, NMAX)
#define PAD 16
#define SENT ((dkf_real_t)-7777.25)

static dkf_real_t rF[SQ], rH[SQ], rQ[SQ], rR[SQ], rX[SQ], rC[SQ], snapbuf[SQ];
static dkf_real_t work[(DWORK > SWORK ? DWORK : SWORK) + PAD];
static double worst_res_rand, worst_res_unst, worst_seed002, worst_kron, worst_lyap;

/* ---- long double references ---------------------------------------------- */

static void lmul(long double *C, const long double *A, const long double *B, size_t r, size_t k,
                 size_t c)
{
    size_t i, j, l;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) {
            long double s = 0;
            for (l = 0; l < k; ++l) s += A[i * k + l] * B[l * c + j];
            C[i * c + j] = s;
        }
}

static void ltrans(long double *At, const long double *A, size_t r, size_t c)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) At[j * r + i] = A[i * c + j];
}

static void tol(long double *d, const dkf_real_t *s, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) d[i] = (long double)s[i];
}

static double lmaxabs(const long double *a, size_t n)
{
    long double m = 0;
    size_t i;
    for (i = 0; i < n; ++i)
        if (fabsl(a[i]) > m) m = fabsl(a[i]);
    return (double)m;
}

static double lnorm1(const long double *A, size_t n)
{
    long double best = 0;
    size_t i, j;
    for (j = 0; j < n; ++j) {
        long double s = 0;
        for (i = 0; i < n; ++i) s += fabsl(A[i * n + j]);
        if (!(s <= best)) best = s;
    }
    return (double)best;
}

/* max|F X F^T - F X H^T S^{-1} H X F^T + Q - X| / max|X| (S = H X H^T + R)
 * and, in *phi, the closed loop F (I - K H), K = X H^T S^{-1}. */
static double dare_residual(long double *phi, size_t n, size_t m)
{
    long double F[SQ], H[SQ], Q[SQ], R[SQ], X[SQ], Ht[SQ], Ft[SQ], FX[SQ], HX[SQ], S[SQ],
        Si[SQ], K[SQ], T[SQ], T2[SQ], Res[SQ];
    size_t i;
    /* zeroed for GCC -O3's -Wmaybe-uninitialized (the loops fill them) */
    memset(Ht, 0, sizeof Ht);
    memset(T2, 0, sizeof T2);
    memset(S, 0, sizeof S);
    tol(F, rF, n * n);
    tol(H, rH, m * n);
    tol(Q, rQ, n * n);
    tol(R, rR, m * m);
    tol(X, rX, n * n);
    ltrans(Ht, H, m, n);
    ltrans(Ft, F, n, n);
    lmul(HX, H, X, m, n, n);
    lmul(S, HX, Ht, m, n, m);
    for (i = 0; i < m * m; ++i) S[i] += R[i];
    test_ref_inverse(Si, S, m); /* S is overwritten */
    lmul(T, X, Ht, n, n, m);  /* X H^T */
    lmul(K, T, Si, n, m, m);  /* K */
    lmul(T, K, HX, n, m, n);  /* K H X */
    for (i = 0; i < n * n; ++i) T2[i] = X[i] - T[i]; /* X - K H X = (I - K H) X */
    lmul(FX, F, T2, n, n, n);
    lmul(Res, FX, Ft, n, n, n);
    for (i = 0; i < n * n; ++i) Res[i] += Q[i] - X[i];
    if (phi != NULL) {
        lmul(T, K, H, n, m, n);
        for (i = 0; i < n * n; ++i) T2[i] = ((i / n == i % n) ? 1.0L : 0.0L) - T[i];
        lmul(phi, F, T2, n, n, n);
    }
    return lmaxabs(Res, n * n) / (lmaxabs(X, n * n) + 1e-300);
}

/* Number of squarings after which ||M^(2^j)||_1 <= 1/2, or -1 (not within
 * 80 squarings, or overflow): an independent stability certificate. */
static int squarings_to_contract(const long double *M, size_t n)
{
    long double P[SQ], T[SQ];
    int j;
    memcpy(P, M, n * n * sizeof *P);
    for (j = 0; j < 80; ++j) {
        double nr = lnorm1(P, n);
        if (nr <= 0.5) return j;
        if (!(nr < 1e300)) return -1;
        lmul(T, P, P, n, n, n);
        memcpy(P, T, n * n * sizeof *P);
    }
    return -1;
}

static int exactly_symmetric(const dkf_real_t *X, size_t n)
{
    size_t i, j;
    for (i = 0; i < n; ++i)
        for (j = i + 1; j < n; ++j)
            if (X[i * n + j] != X[j * n + i]) return 0;
    return 1;
}

static void upd(double *w, double v)
{
    if (!(v <= *w)) *w = v;
}

/* Solves the DARE for the model in rF, rH, rQ, rR; asserts success, the
 * residual bound, exact symmetry, PSD and the independent certificate.
 * Returns the relative residual; *iters the doubling steps (work[0]). */
static double solve_check(size_t n, size_t m, const char *what, int *iters)
{
    dkf_mat_t X = test_view(n, n, rX), F = test_view(n, n, rF), H = test_view(m, n, rH),
              Q = test_view(n, n, rQ), R = test_view(m, m, rR);
    long double phi[SQ], Fl[SQ];
    double res, fn, bound;
    test_fill(work, (size_t)DKF_MAT_DARE_WORK(n, m) + PAD, SENT);
    assert_int_equal(dkf_mat_dare(&X, &F, &H, &Q, &R, work), DKF_OK);
    {
        size_t i;
        for (i = (size_t)DKF_MAT_DARE_WORK(n, m); i < (size_t)DKF_MAT_DARE_WORK(n, m) + PAD; ++i)
            assert_true(work[i] == SENT); /* nothing written past the work size */
    }
    *iters = (int)work[0];
    res = dare_residual(phi, n, m);
    tol(Fl, rF, n * n);
    fn = lnorm1(Fl, n);
    bound = 20.0 * (double)n * TEST_EPS * (1.0 + fn * fn);
    print_message("dare %-28s n=%zu m=%zu: %2d doublings, residual/max|X| = %.3g (bound %.3g)\n",
                  what, n, m, *iters, res, bound);
    test_assert_below(what, res, bound);
    assert_true(exactly_symmetric(rX, n));
    assert_true(test_psd_within(rX, n, 8.0 * (double)n * TEST_EPS));
    assert_true(squarings_to_contract(phi, n) >= 0);
    return res;
}

static void set_d(dkf_real_t *dst, const double *src, size_t k)
{
    test_to_real(dst, src, k);
}

/* The DARE's model in rF, rH, rQ, rR from doubles: F, Q n x n, H m x n,
 * R m x m. */
static void set_model(size_t n, size_t m, const double *F, const double *H, const double *Q,
                      const double *R)
{
    set_d(rF, F, n * n);
    set_d(rH, H, m * n);
    set_d(rQ, Q, n * n);
    set_d(rR, R, m * m);
}

/* ---- scalar closed form ---------------------------------------------------- */

/* Positive root of h^2 x^2 + b x - q r = 0, b = r - q h^2 - a^2 r. */
static double scalar_dare(double a, double h, double q, double r)
{
    long double b = (long double)r - (long double)q * h * h - (long double)a * a * r;
    long double disc = sqrtl(b * b + 4.0L * h * h * q * r);
    if (h == 0.0) return q / (1.0 - a * a);
    return (double)(b <= 0 ? (-b + disc) / (2.0L * h * h) : 2.0L * q * r / (b + disc));
}

static void test_dare_scalar(void **state)
{
    /* a, h, q, r: stable, unstable 1.05, marginal 0.999 unobserved
     * (Lyapunov series, slowest doubling), rho(F) = 1 observed, tiny R */
    static const double cases[][4] = {
        {0.5, 1.0, 1.0, 1.0},  {1.05, 1.0, 0.3, 0.2},  {0.999, 0.0, 1.0, 1.0},
        {0.999, 1.0, 1e-6, 1.0}, {1.0, 1.0, 1.0, 1.0}, {3.0, 2.0, 0.1, 1e-8},
        {-0.9, 0.5, 2.0, 5.0},
    };
    size_t c;
    (void)state;
    for (c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        const double *p = cases[c];
        dkf_mat_t X = test_view(1, 1, rX), F = test_view(1, 1, rF), H = test_view(1, 1, rH),
                  Q = test_view(1, 1, rQ), R = test_view(1, 1, rR);
        double want, got, rel;
        rF[0] = (dkf_real_t)p[0];
        rH[0] = (dkf_real_t)p[1];
        rQ[0] = (dkf_real_t)p[2];
        rR[0] = (dkf_real_t)p[3];
        want = scalar_dare((double)rF[0], (double)rH[0], (double)rQ[0], (double)rR[0]);
        assert_int_equal(dkf_mat_dare(&X, &F, &H, &Q, &R, work), DKF_OK);
        got = (double)rX[0];
        rel = fabs(got - want) / want;
        print_message("scalar dare a=%g h=%g q=%g r=%g: x=%.17g want %.17g rel %.3g, %d doublings\n",
                      p[0], p[1], p[2], p[3], got, want, rel, (int)work[0]);
        /* 16 EPS cond relative, cond = max(1, 1 / (1 - phi^2)) with the
         * closed loop phi = a r / (h^2 x + r): a doubling step's rounding
         * is amplified by the sum of the closed loop's squares, as for a
         * Lyapunov series (cond = 500 for a = 0.999 unobserved, ~355 for
         * the q = 1e-6 case; measured ~0.75 EPS cond in float, <= 11 EPS
         * in double) */
        {
            const double phi = (double)rF[0] * (double)rR[0] /
                               ((double)rH[0] * (double)rH[0] * want + (double)rR[0]);
            const double cond = phi * phi < 1.0 ? fmax(1.0, 1.0 / (1.0 - phi * phi)) : 1e300;
            test_assert_below("scalar dare", rel, 16.0 * TEST_EPS * cond);
        }
    }
}

/* ---- random systems -------------------------------------------------------- */

/* F = s * G / sqrt(n) with G Gaussian (rho(F) ~ s), H Gaussian m x n,
 * Q = B B^T (B Gaussian n x n), R SPD of condition 10. */
static void random_model(test_rng_t *g, size_t n, size_t m, double s)
{
    double F[SQ], H[SQ], B[SQ], Q[SQ], R[SQ], Bt[SQ];
    size_t i, j;
    test_rand_gauss(g, F, n, n);
    for (i = 0; i < n * n; ++i) F[i] *= s / sqrt((double)n);
    test_rand_gauss(g, H, m, n);
    test_rand_gauss(g, B, n, n);
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) Bt[j * n + i] = B[i * n + j];
    test_ref_mul(Q, B, Bt, n, n, n);
    for (i = 0; i < n; ++i) /* exactly symmetric after rounding */
        for (j = 0; j < i; ++j) Q[i * n + j] = Q[j * n + i];
    test_rand_spd(g, R, m, 10.0, 1.0);
    for (i = 0; i < m; ++i)
        for (j = 0; j < i; ++j) R[i * m + j] = R[j * m + i];
    set_model(n, m, F, H, Q, R);
}

static long double spectral_radius_bound_gt1(size_t n)
{
    /* 1 if F has rho > 1 (||F^(2^j)|| grows to overflow) */
    long double Fl[SQ];
    tol(Fl, rF, n * n);
    return squarings_to_contract(Fl, n) < 0 ? 1.0L : 0.0L;
}

static void test_dare_random(void **state)
{
    static const size_t dims[][2] = {{2, 1}, {3, 1}, {3, 2}, {4, 2}, {6, 3}, {8, 2}, {8, 8}};
    test_rng_t g;
    size_t d, t;
    int unstable_seen = 0, maxit = 0;
    (void)state;
    test_rng_seed(&g, 0x5da7e001u);
    for (d = 0; d < sizeof dims / sizeof dims[0]; ++d)
        for (t = 0; t < 4; ++t) {
            const size_t n = dims[d][0], m = dims[d][1];
            const double s = (t < 2) ? 0.8 : 1.6; /* stable / (typically) unstable F */
            int it;
            double r;
            random_model(&g, n, m, s);
            r = solve_check(n, m, t < 2 ? "random stable F" : "random unstable F", &it);
            if (spectral_radius_bound_gt1(n) > 0) {
                unstable_seen++;
                upd(&worst_res_unst, r);
            } else {
                upd(&worst_res_rand, r);
            }
            if (it > maxit) maxit = it;
        }
    print_message("random: %d systems with rho(F) > 1; worst residual/max|X| stable %.3g, "
                  "unstable %.3g; max %d doublings\n",
                  unstable_seen, worst_res_rand, worst_res_unst, maxit);
    assert_true(unstable_seen >= 8); /* the unstable-F half really is unstable */
}

/* ---- seed 002's example ------------------------------------------------------ */

/* The numbers of node, flattened into out; there must be exactly n. */
static void get_n(double *out, const json_t *node, size_t n)
{
    assert_int_equal(test_json_flatten(node, out, n), n);
}

/* The model of sensor s of cases[0] of tests/vectors/infofusion/
 * s2_weighted_fusion.json: F = Phi, Q = Gamma Qe Gamma^T, H[s], R[s]
 * (R = 0.1 .. 0.5 for sensors 1..5); *r is that R. */
static void seed002_model(const json_t *c, size_t s, double *r)
{
    double F[16], Gam[8], Qe[4], H[4], Q[16];
    size_t i, j, l, m;
    get_n(F, test_json_get(c, "Phi"), 16);
    get_n(Gam, test_json_get(c, "Gamma"), 8);
    get_n(Qe, test_json_get(c, "Qe"), 4);
    get_n(H, json_array_get(test_json_get(c, "H"), s), 4);
    get_n(r, json_array_get(test_json_get(c, "R"), s), 1);
    for (i = 0; i < 4; ++i)
        for (j = 0; j < 4; ++j) {
            double q = 0;
            for (l = 0; l < 2; ++l)
                for (m = 0; m < 2; ++m) q += Gam[i * 2 + l] * Qe[l * 2 + m] * Gam[j * 2 + m];
            Q[i * 4 + j] = q;
        }
    set_model(4, 1, F, H, Q, r);
}

static void test_dare_seed002(void **state)
{
    json_t *root = test_load_vector("infofusion/s2_weighted_fusion.json");
    const json_t *c = json_array_get(test_json_get(root, "cases"), 0);
    const json_t *sig = test_json_get(test_json_get(c, "steady_state"), "Sigma_pred");
    size_t s;
    (void)state;
    assert_int_equal(json_array_size(sig), 5);
    for (s = 0; s < 5; ++s) {
        double want[16], emax, err, bound, r;
        int it;
        get_n(want, json_array_get(sig, s), 16);
        emax = test_max_abs(want, 16);
        seed002_model(c, s, &r);
        (void)solve_check(4, 1, "seed 002 sensor", &it);
        err = test_max_abs_diff(rX, want, 16);
#if DKF_USE_FLOAT
        /* float: the solution of a problem of condition ~10 rounded to
         * float, 64 EPS relative to max|expected| */
        bound = 64.0 * TEST_EPS * emax;
#else
        /* the file's rule: atol + rtol max(1, max|expected|) */
        bound = 1e-10 + 1e-8 * (emax > 1.0 ? emax : 1.0);
#endif
        print_message("seed 002 sensor %zu (R = %.1f): max|X - Sigma_pred| = %.3g "
                      "(%.3g relative to max|expected| %.4g; bound %.3g), %d doublings\n",
                      s + 1, r, err, err / emax, emax, bound, it);
        test_assert_below("seed 002 Sigma_pred", err, bound);
        upd(&worst_seed002, err / emax);
#if !DKF_USE_FLOAT
        /* regression bound beside the file's: measured ~1e-15 */
        test_assert_below("seed 002 Sigma_pred (tight)", err / emax, 64.0 * TEST_EPS);
#endif
    }
    json_decref(root);
}

/* ---- ill-conditioned and marginal --------------------------------------------- */

static void test_dare_ill_marginal(void **state)
{
    int it;
    double F2[4], Q2[4], H2[2], R1;
    (void)state;
    /* R tiny: nearly noise-free measurement, X ~ R-scaled on the observed part */
    {
        static const double F[9] = {1.1, 0.2, 0, 0, 0.9, 0.3, 0.1, 0, 0.5};
        static const double H[3] = {1, 0, 0};
        static const double Q[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        set_model(3, 1, F, H, Q, (const double[1]){1e-10});
        (void)solve_check(3, 1, "R = 1e-10", &it);
    }
    /* Q nearly singular: rank one plus 1e-9 I */
    {
        static const double F[9] = {0.9, 1, 0, 0, 0.9, 1, 0, 0, 0.9};
        static const double H[3] = {0, 0, 1};
        double Q[9];
        size_t i;
        for (i = 0; i < 9; ++i) Q[i] = (i == 0 ? 1.0 : 0.0) + (i % 4 == 0 ? 1e-9 : 0.0);
        set_model(3, 1, F, H, Q, (const double[1]){1});
        (void)solve_check(3, 1, "Q rank 1 + 1e-9 I", &it);
    }
    /* large ||X||: a weakly observed mode at 0.9999 with big Q */
    {
        static const double F[4] = {0.9999, 0, 0, 0.5};
        static const double H[2] = {1e-3, 1};
        static const double Q[4] = {1e4, 0, 0, 1};
        set_model(2, 1, F, H, Q, (const double[1]){1});
        (void)solve_check(2, 1, "large ||X|| (1e4 Q, 0.9999)", &it);
        print_message("  max|X| = %.4g\n", (double)rX[0]);
        assert_true(rX[0] > (dkf_real_t)1e5);
    }
    /* spectral radius 0.999: a rotation scaled by 0.999, one output, small Q
     * (closed loop near the unit circle) */
    {
        const double a = 0.999, th = 0.3;
        F2[0] = a * cos(th);
        F2[1] = -a * sin(th);
        F2[2] = a * sin(th);
        F2[3] = a * cos(th);
        H2[0] = 1;
        H2[1] = 0;
        Q2[0] = 1e-6;
        Q2[1] = Q2[2] = 0;
        Q2[3] = 1e-6;
        R1 = 1;
        set_model(2, 1, F2, H2, Q2, &R1);
        (void)solve_check(2, 1, "rho(F) = 0.999 rotation", &it);
    }
    /* spectral radius 0.999 unobserved (detectable: closed loop keeps 0.999) */
    {
        static const double F[4] = {0.999, 0.3, 0, 0.5};
        static const double H[2] = {0, 1};
        static const double Q[4] = {1, 0, 0, 1};
        set_model(2, 1, F, H, Q, (const double[1]){1});
        (void)solve_check(2, 1, "rho 0.999 unobserved mode", &it);
        assert_true(it >= 12); /* 0.999^(2^k) reaches EPS only for 2^k ~ 1e4..4e4 */
    }
    /* unstable but detectable: eigenvalue 1.05 observed */
    {
        static const double F[9] = {1.05, 0.4, 0, 0, 0.6, 0.2, 0, 0, -0.3};
        static const double H[3] = {1, 0, 1};
        static const double Q[9] = {0.5, 0.1, 0, 0.1, 0.5, 0, 0, 0, 0.5};
        set_model(3, 1, F, H, Q, (const double[1]){0.3});
        (void)solve_check(3, 1, "eigenvalue 1.05 detectable", &it);
    }
}

/* ---- DARE statuses and untouched outputs --------------------------------------- */

static dkf_status_t dare_call(size_t n, size_t m)
{
    dkf_mat_t X = test_view(n, n, rX), F = test_view(n, n, rF), H = test_view(m, n, rH),
              Q = test_view(n, n, rQ), R = test_view(m, m, rR);
    return dkf_mat_dare(&X, &F, &H, &Q, &R, work);
}

/* Asserts dare_call(n, m) == st with rX bit-identical. */
static void dare_fails(size_t n, size_t m, dkf_status_t st, const char *what)
{
    test_fill(rX, SQ, (dkf_real_t)0.125);
    memcpy(snapbuf, rX, sizeof snapbuf);
    {
        dkf_status_t got = dare_call(n, m);
        if (got != st) fail_msg("%s: status %d, want %d", what, (int)got, (int)st);
    }
    assert_memory_equal(snapbuf, rX, sizeof snapbuf);
}

static void base2(void)
{
    static const double F[4] = {0.9, 0.2, 0, 0.7};
    static const double H[4] = {1, 0, 0, 1};
    static const double Q[4] = {1, 0.2, 0.2, 1};
    static const double R[4] = {1, 0.1, 0.1, 2};
    set_model(2, 2, F, H, Q, R);
}

static void test_dare_statuses(void **state)
{
    int it;
    (void)state;
    base2();
    (void)solve_check(2, 2, "status base model", &it);

    /* (F, H) not detectable: eigenvalue 1.2 unobserved, excited by Q
     * (X does not exist: the iterates diverge) */
    {
        static const double F[4] = {1.2, 0, 0, 0.5};
        static const double H[2] = {0, 1};
        static const double Q[4] = {1, 0, 0, 1};
        set_model(2, 1, F, H, Q, (const double[1]){1});
        dare_fails(2, 1, DKF_ERR_UNSTABLE, "not detectable, excited");
        /* the same mode not excited (Q = diag(0, 1)): a finite X exists
         * (zero on that mode) but F (I - K H) keeps the 1.2: refused */
        rQ[0] = 0;
        dare_fails(2, 1, DKF_ERR_UNSTABLE, "not detectable, unexcited");
    }
    /* uncontrollable unit-circle modes: a rotation with Q = 0. H_k stays
     * exactly 0 (the series has no term), so the iteration converges at
     * once to X = 0, whose closed loop is F itself (rho = 1): the
     * certificate refuses it, DKF_ERR_UNSTABLE. */
    {
        const double th = 0.7;
        double F[4];
        static const double H[2] = {1, 0};
        static const double Q[4] = {0, 0, 0, 0};
        F[0] = cos(th);
        F[1] = -sin(th);
        F[2] = sin(th);
        F[3] = cos(th);
        set_model(2, 1, F, H, Q, (const double[1]){1});
        dare_fails(2, 1, DKF_ERR_UNSTABLE, "rotation, Q = 0");
        /* the rotation beside an excited, observed stable mode (Q = 0 on
         * the rotation only): H_k is nonzero on the stable block, stays
         * zero on the rotation's, and X's closed loop keeps the rotation */
        {
            double F3[9] = {0}, H3[3] = {1, 0, 1}, Q3[9] = {0};
            F3[0] = cos(th);
            F3[1] = -sin(th);
            F3[3] = sin(th);
            F3[4] = cos(th);
            F3[8] = 0.5;
            Q3[8] = 1;
            set_model(3, 1, F3, H3, Q3, (const double[1]){1});
            dare_fails(3, 1, DKF_ERR_UNSTABLE, "rotation unreachable beside a stable mode");
            set_model(2, 1, F, H, Q, (const double[1]){1});
        }
        /* the same with Q = 0 but a stable F: X = 0 is stabilising */
        rF[0] = rF[3] = (dkf_real_t)(0.5 * cos(th));
        rF[1] = (dkf_real_t)(-0.5 * sin(th));
        rF[2] = (dkf_real_t)(0.5 * sin(th));
        assert_int_equal(dare_call(2, 1), DKF_OK);
        assert_true(rX[0] == 0 && rX[1] == 0 && rX[2] == 0 && rX[3] == 0);
    }
    /* non-finite inputs, each matrix, NaN and infinity */
    {
        dkf_real_t *bufs[4] = {rF, rH, rQ, rR};
        const dkf_real_t bad[2] = {(dkf_real_t)NAN, (dkf_real_t)INFINITY};
        size_t b, v;
        for (b = 0; b < 4; ++b)
            for (v = 0; v < 2; ++v) {
                dkf_real_t keep;
                base2();
                keep = bufs[b][3];
                bufs[b][3] = bad[v];
                dare_fails(2, 2, DKF_ERR_NONFINITE, "non-finite input");
                bufs[b][3] = keep;
            }
    }
    /* R not SPD: indefinite, singular, asymmetric; Q not PSD or asymmetric */
    base2();
    rR[1] = rR[2] = 2;
    dare_fails(2, 2, DKF_ERR_NOT_SPD, "R indefinite");
    rR[0] = rR[3] = 1;
    rR[1] = rR[2] = 1;
    dare_fails(2, 2, DKF_ERR_NOT_SPD, "R singular");
    base2();
    rR[1] = (dkf_real_t)0.5;
    dare_fails(2, 2, DKF_ERR_NOT_SPD, "R asymmetric");
    base2();
    rQ[3] = -1;
    dare_fails(2, 2, DKF_ERR_NOT_SPD, "Q indefinite");
    base2();
    rQ[1] = (dkf_real_t)0.3;
    dare_fails(2, 2, DKF_ERR_NOT_SPD, "Q asymmetric");
    base2();
    rQ[1] = rQ[2] = (dkf_real_t)(1.0 + 1e-3); /* det < 0 by 2e-3: beyond rounding */
    dare_fails(2, 2, DKF_ERR_NOT_SPD, "Q slightly indefinite");
    /* Q PSD singular is fine (rank one) */
    base2();
    rQ[0] = rQ[1] = rQ[2] = rQ[3] = 1;
    assert_int_equal(dare_call(2, 2), DKF_OK);
    /* lambda_min(Q) ~ -EPS, inside the 4 n EPS tr(Q) = 16 EPS allowance */
    rQ[3] = 1 - 2 * DKF_REAL_EPSILON;
    assert_int_equal(dare_call(2, 2), DKF_OK);
    /* lambda_min(Q) ~ -50 EPS: beyond it */
    rQ[3] = 1 - 100 * DKF_REAL_EPSILON;
    dare_fails(2, 2, DKF_ERR_NOT_SPD, "Q indefinite by 50 EPS");

    /* shapes */
    base2();
    {
        dkf_mat_t X = test_view(2, 2, rX), F = test_view(2, 2, rF), H = test_view(2, 2, rH),
                  Q = test_view(2, 2, rQ), R = test_view(2, 2, rR);
        dkf_mat_t Fb = test_view(2, 3, rF), Hb = test_view(2, 3, rH), Qb = test_view(3, 3, rQ),
                  Rb = test_view(1, 1, rR), Xb = test_view(2, 1, rX), Z = test_view(0, 2, rF),
                  Big = test_view(DKF_MAX_DIM + 1, DKF_MAX_DIM + 1, rF), Nul = test_view(2, 2, NULL);
        test_fill(rX, SQ, (dkf_real_t)0.125);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_DIM, dkf_mat_dare(&X, &Fb, &H, &Q, &R, work), rX, SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_DIM, dkf_mat_dare(&X, &F, &Hb, &Q, &R, work), rX, SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_DIM, dkf_mat_dare(&X, &F, &H, &Qb, &R, work), rX, SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_DIM, dkf_mat_dare(&X, &F, &H, &Q, &Rb, work), rX, SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_DIM, dkf_mat_dare(&Xb, &F, &H, &Q, &R, work), rX, SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_CAPACITY, dkf_mat_dare(&X, &Z, &H, &Q, &R, work), rX,
                             SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_CAPACITY, dkf_mat_dare(&X, &Big, &H, &Q, &R, work),
                             rX, SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_NULL, dkf_mat_dare(&X, &Nul, &H, &Q, &R, work), rX,
                             SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_NULL, dkf_mat_dare(&X, &F, NULL, &Q, &R, work), rX,
                             SQ);
#if DKF_DEBUG_CHECKS
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_NULL, dkf_mat_dare(&X, &F, &H, &Q, &R, NULL), rX, SQ);
        /* aliasing: X on an input, work on X or on an input */
        {
            dkf_mat_t XQ = test_view(2, 2, rQ);
            memcpy(snapbuf, rQ, 4 * sizeof *rQ);
            assert_int_equal(dkf_mat_dare(&XQ, &F, &H, &Q, &R, work), DKF_ERR_ALIAS);
            assert_memory_equal(snapbuf, rQ, 4 * sizeof *rQ);
        }
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_ALIAS, dkf_mat_dare(&X, &F, &H, &Q, &R, rX), rX, SQ);
        {
            /* a work area too short to end before X: X inside its
             * DKF_MAT_DARE_WORK span (the last real of the span is X's first) */
            static dkf_real_t arena[DKF_MAT_DARE_WORK(2, 2) + 8];
            dkf_real_t *xa = arena + DKF_MAT_DARE_WORK(2, 2) - 1;
            dkf_mat_t Xa = test_view(2, 2, xa);
            test_fill(xa, 4, (dkf_real_t)0.5);
            TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_ALIAS, dkf_mat_dare(&Xa, &F, &H, &Q, &R, arena),
                                 xa, 4);
        }
        {
            /* work whose DKF_MAT_DARE_WORK span reaches into R */
            static dkf_real_t arena[DKF_MAT_DARE_WORK(2, 2) + 8];
            dkf_mat_t Ra = test_view(2, 2, arena + DKF_MAT_DARE_WORK(2, 2) - 1);
            memcpy(arena + DKF_MAT_DARE_WORK(2, 2) - 1, rR, 4 * sizeof *rR);
            TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_ALIAS, dkf_mat_dare(&X, &F, &H, &Q, &Ra, arena),
                                 rX, SQ);
        }
#endif
    }
}

/* ---- Stein --------------------------------------------------------------------- */

/* Kronecker reference: (I - A (x) B) vec_r X = vec_r C by dkf_mat_lu in
 * the library type, into ref (r c reals). */
static void stein_kron(dkf_real_t *ref, const dkf_real_t *A, const dkf_real_t *B,
                       const dkf_real_t *C, size_t r, size_t c)
{
    static dkf_real_t M[DKF_MAX_DIM * DKF_MAX_DIM], LU[DKF_MAX_DIM * DKF_MAX_DIM],
        lw[DKF_MAX_DIM * DKF_MAX_DIM];
    static size_t piv[DKF_MAX_DIM];
    const size_t N = r * c;
    size_t i, j, k, l;
    dkf_mat_t Mv, LUv, bv, xv;
    assert_true(N <= DKF_MAX_DIM);
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j)
            for (k = 0; k < r; ++k)
                for (l = 0; l < c; ++l)
                    M[(i * c + j) * N + k * c + l] =
                        (dkf_real_t)(((i == k && j == l) ? 1.0 : 0.0) -
                                     (double)A[i * r + k] * (double)B[j * c + l]);
    Mv = test_view(N, N, M);
    LUv = test_view(N, N, LU);
    bv = test_view(N, 1, (dkf_real_t *)(uintptr_t)C);
    xv = test_view(N, 1, ref);
    assert_int_equal(dkf_mat_lu(&LUv, piv, &Mv, lw), DKF_OK);
    assert_int_equal(dkf_mat_lu_solve(&xv, &LUv, piv, &bv), DKF_OK);
}

static dkf_status_t stein_call(size_t r, size_t c)
{
    dkf_mat_t X = test_view(r, c, rX), A = test_view(r, r, rF), B = test_view(c, c, rH),
              C = test_view(r, c, rC);
    return dkf_mat_stein(&X, &A, &B, &C, work);
}

/* Random A (r x r), B (c x c) scaled to rho ~ sa, sb, C Gaussian; solves
 * and compares with the Kronecker solve. */
static void stein_case(test_rng_t *g, size_t r, size_t c, double sa, double sb, int lyap)
{
    double A[SQ], B[SQ], C[SQ];
    dkf_real_t ref[SQ];
    double err, xmax, bound;
    size_t i, j;
    test_rand_gauss(g, A, r, r);
    for (i = 0; i < r * r; ++i) A[i] *= sa / sqrt((double)r);
    test_rand_gauss(g, B, c, c);
    for (i = 0; i < c * c; ++i) B[i] *= sb / sqrt((double)c);
    test_rand_gauss(g, C, r, c);
    if (lyap) {
        memcpy(B, A, r * r * sizeof *A);
        for (i = 0; i < r; ++i)
            for (j = 0; j < i; ++j) C[i * r + j] = C[j * r + i];
    }
    set_d(rF, A, r * r);
    set_d(rH, B, c * c);
    set_d(rC, C, r * c);
    test_fill(work, (size_t)DKF_MAT_STEIN_WORK(r, c) + PAD, SENT);
    assert_int_equal(stein_call(r, c), DKF_OK);
    for (i = (size_t)DKF_MAT_STEIN_WORK(r, c); i < (size_t)DKF_MAT_STEIN_WORK(r, c) + PAD; ++i)
        assert_true(work[i] == SENT);
    stein_kron(ref, rF, rH, rC, r, c);
    {
        double refd[SQ];
        test_to_double(refd, ref, r * c);
        xmax = test_max_abs(refd, r * c);
        err = test_max_abs_diff(rX, refd, r * c) / xmax;
    }
    /* both solutions carry ~ (N EPS) cond(I - A (x) B) relative error,
     * cond <= 1 / (1 - ||A|| ||B||)-like ~ 10 here: 200 N EPS */
    bound = 200.0 * (double)(r * c) * TEST_EPS;
    print_message("stein %s r=%zu c=%zu scales %.2f, %.2f: %d doublings, |X - X_kron|/max|X| = %.3g "
                  "(bound %.3g)\n",
                  lyap ? "lyapunov" : "general ", r, c, sa, sb, (int)work[0], err, bound);
    test_assert_below("stein vs kronecker", err, bound);
    if (lyap) {
        assert_true(exactly_symmetric(rX, r));
        upd(&worst_lyap, err);
    } else {
        upd(&worst_kron, err);
    }
}

static void test_stein_kron(void **state)
{
    test_rng_t g;
    (void)state;
    test_rng_seed(&g, 0x57e1a002u);
    stein_case(&g, 1, 1, 0.9, 0.9, 0);
    stein_case(&g, 3, 2, 0.8, 0.9, 0);
    stein_case(&g, 2, 4, 1.4, 0.5, 0);
    /* this draw has rho(A) ~ 1.57, rho(B) ~ 0.63 (product ~ 0.99): A_k
     * overflowed while B_k underflowed before the power-of-two balancing */
    stein_case(&g, 4, 3, 0.95, 0.95, 0);
    stein_case(&g, 6, 6, 0.7, 0.6, 0);
    stein_case(&g, 3, 3, 0.9, 0.9, 1);
    stein_case(&g, 5, 5, 0.95, 0.95, 1);
    stein_case(&g, 6, 6, 0.5, 0.5, 1);
    print_message("stein: worst |X - X_kron| / max|X| general %.3g, lyapunov %.3g\n", worst_kron,
                  worst_lyap);
}

static void test_stein_closed_forms(void **state)
{
    (void)state;
    /* scalar Lyapunov x = a^2 x + q: x = q / (1 - a^2), a = 0.999 */
    rF[0] = rH[0] = (dkf_real_t)0.999;
    rC[0] = 1;
    assert_int_equal(stein_call(1, 1), DKF_OK);
    {
        const double a = (double)rF[0], want = 1.0 / (1.0 - a * a);
        const double rel = fabs((double)rX[0] - want) / want;
        print_message("stein a=b=0.999: x = %.17g want %.17g rel %.3g, %d doublings\n",
                      (double)rX[0], want, rel, (int)work[0]);
        test_assert_below("scalar lyapunov", rel, 2048.0 * TEST_EPS);
    }
    /* A nilpotent: X = C + A C B^T exactly */
    {
        static const double A[4] = {0, 2, 0, 0}, B[4] = {3, 0, 0, 0.5}, C[4] = {1, 2, 3, 4};
        set_d(rF, A, 4);
        set_d(rH, B, 4);
        set_d(rC, C, 4);
        assert_int_equal(stein_call(2, 2), DKF_OK);
        /* A C B^T = [[2*3*3, 2*4*0.5], [0, 0]] = [[18, 4], [0, 0]] */
        assert_true(rX[0] == 19 && rX[1] == 6 && rX[2] == 3 && rX[3] == 4);
    }
    /* non-normal A with ||A||_1 > 1, rho(A) = 0.5: still converges */
    {
        static const double A[4] = {0.5, 10, 0, 0.5}, B[1] = {0.9}, C[2] = {1, 1};
        dkf_real_t ref[2];
        set_d(rF, A, 4);
        set_d(rH, B, 1);
        set_d(rC, C, 2);
        assert_int_equal(stein_call(2, 1), DKF_OK);
        stein_kron(ref, rF, rH, rC, 2, 1);
        test_assert_below("non-normal stein", fabs((double)(rX[0] - ref[0])) / fabs((double)ref[0]),
                          1e3 * TEST_EPS);
    }
}

static void test_stein_statuses(void **state)
{
    (void)state;
    /* rho(A) rho(B) = 1 exactly and > 1: DKF_ERR_UNSTABLE */
    {
        static const double A[4] = {2, 0, 0, 0.3}, B[1] = {0.5}, C[2] = {1, 1};
        set_d(rF, A, 4);
        set_d(rH, B, 1);
        set_d(rC, C, 2);
        test_fill(rX, SQ, (dkf_real_t)0.125);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_UNSTABLE, stein_call(2, 1), rX, SQ);
        rH[0] = (dkf_real_t)0.6;
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_UNSTABLE, stein_call(2, 1), rX, SQ);
        /* C = 0: X = 0 would satisfy the equation, but it is not unique */
        rH[0] = (dkf_real_t)0.5;
        rC[0] = rC[1] = 0;
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_UNSTABLE, stein_call(2, 1), rX, SQ);
        /* a rotation times a rotation: rho product 1 */
        {
            const double th = 0.4;
            double R[4];
            R[0] = cos(th);
            R[1] = -sin(th);
            R[2] = sin(th);
            R[3] = cos(th);
            set_d(rF, R, 4);
            set_d(rH, R, 4);
            rC[0] = 1;
            rC[1] = rC[2] = 0;
            rC[3] = 1;
            TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_UNSTABLE, stein_call(2, 2), rX, SQ);
        }
    }
    /* non-finite, shapes, NULL, aliasing */
    {
        static const double A[4] = {0.5, 0.1, 0, 0.4}, B[4] = {0.3, 0, 0.2, 0.1},
                            C[4] = {1, 2, 3, 4};
        dkf_real_t *bufs[3] = {rF, rH, rC};
        size_t b;
        dkf_mat_t X = test_view(2, 2, rX), Av = test_view(2, 2, rF), Bv = test_view(2, 2, rH),
                  Cv = test_view(2, 2, rC), Ab = test_view(2, 3, rF), Cb = test_view(2, 3, rC),
                  Xb = test_view(3, 2, rX), Z = test_view(2, 0, rC);
        set_d(rF, A, 4);
        set_d(rH, B, 4);
        set_d(rC, C, 4);
        for (b = 0; b < 3; ++b) {
            const dkf_real_t keep = bufs[b][2];
            bufs[b][2] = (dkf_real_t)NAN;
            TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_NONFINITE, stein_call(2, 2), rX, SQ);
            bufs[b][2] = (dkf_real_t)-INFINITY;
            TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_NONFINITE, stein_call(2, 2), rX, SQ);
            bufs[b][2] = keep;
        }
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_DIM, dkf_mat_stein(&X, &Ab, &Bv, &Cv, work), rX, SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_DIM, dkf_mat_stein(&X, &Av, &Bv, &Cb, work), rX, SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_DIM, dkf_mat_stein(&Xb, &Av, &Bv, &Cv, work), rX, SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_CAPACITY, dkf_mat_stein(&X, &Av, &Bv, &Z, work), rX,
                             SQ);
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_NULL, dkf_mat_stein(&X, NULL, &Bv, &Cv, work), rX,
                             SQ);
#if DKF_DEBUG_CHECKS
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_NULL, dkf_mat_stein(&X, &Av, &Bv, &Cv, NULL), rX, SQ);
        {
            dkf_mat_t XC = test_view(2, 2, rC);
            memcpy(snapbuf, rC, 4 * sizeof *rC);
            assert_int_equal(dkf_mat_stein(&XC, &Av, &Bv, &Cv, work), DKF_ERR_ALIAS);
            assert_memory_equal(snapbuf, rC, 4 * sizeof *rC);
        }
        TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_ALIAS, dkf_mat_stein(&X, &Av, &Bv, &Cv, rX), rX, SQ);
        {
            static dkf_real_t arena[DKF_MAT_STEIN_WORK(2, 2) + 8];
            dkf_mat_t Ca = test_view(2, 2, arena + DKF_MAT_STEIN_WORK(2, 2) - 1);
            memcpy(arena + DKF_MAT_STEIN_WORK(2, 2) - 1, rC, 4 * sizeof *rC);
            TEST_FAILS_UNTOUCHED(snapbuf, DKF_ERR_ALIAS, dkf_mat_stein(&X, &Av, &Bv, &Ca, arena),
                                 rX, SQ);
        }
#endif
        assert_int_equal(stein_call(2, 2), DKF_OK); /* the base model itself is fine */
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_dare_scalar),       cmocka_unit_test(test_dare_random),
        cmocka_unit_test(test_dare_seed002),      cmocka_unit_test(test_dare_ill_marginal),
        cmocka_unit_test(test_dare_statuses),     cmocka_unit_test(test_stein_kron),
        cmocka_unit_test(test_stein_closed_forms), cmocka_unit_test(test_stein_statuses),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
