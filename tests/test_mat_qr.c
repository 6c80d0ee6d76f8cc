/*
 * Householder QR (dkf_mat_qr, _q, _r, _solve): factor residuals,
 * orthogonality, triangularity, least squares against a double-precision
 * normal-equation reference, the documented rank rule, aliasing, and
 * untouched outputs on every error.
 *
 * Tolerances. Householder QR is backward stable: A + dA = Q R with
 * ||dA||_F <= gamma(r c) ||A||_F and Q orthonormal to gamma(r c) (Higham,
 * ASNA 2nd ed., thm 19.4 / 19.13), a worst case that grows linearly only
 * through accumulated rounding; observed errors grow like sqrt. We assert
 * 10 max(r, c) eps, i.e. the first-order worst case per column with a
 * factor 10 of head room (measured worst: see the report / comments).
 */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/mat.h"
#include "dkf_test.h"

#define MAXN DKF_MAX_DIM
#define SENTINEL ((dkf_real_t)-7.25)

typedef struct {
    size_t r, c;
} shape_t;

static const shape_t shapes[] = {{1, 1}, {2, 1}, {3, 3}, {5, 3}, {8, 8},   {12, 5},
                                 {20, 20}, {48, 1}, {48, 17}, {48, 48}, {30, 29}};
#define NSHAPES (sizeof shapes / sizeof shapes[0])

static double qr_tol(size_t r, size_t c) { return 10.0 * (double)(r > c ? r : c) * TEST_EPS; }




/* max |A - Q R| / max|A|, Q r x k whose first c columns multiply R (c x c). */
static double factor_err(const dkf_real_t *A, const dkf_real_t *Q, size_t k, const dkf_real_t *R,
                         size_t r, size_t c)
{
    double m = 0.0, amax = 0.0;
    size_t i, j, l;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) {
            double acc = (double)A[i * c + j];
            for (l = 0; l < c; ++l) acc -= (double)Q[i * k + l] * (double)R[l * c + j];
            if (fabs(acc) > m) m = fabs(acc);
            if (fabs((double)A[i * c + j]) > amax) amax = fabs((double)A[i * c + j]);
        }
    return amax > 0.0 ? m / amax : m;
}

static void rand_real(test_rng_t *g, dkf_real_t *A, size_t r, size_t c)
{
    static double tmp[MAXN * MAXN]; /* static: 8 MB at DKF_MAX_DIM = 1024 */
    test_rand_gauss(g, tmp, r, c);
    test_to_real(A, tmp, r * c);
}

static void test_qr_factors(void **state)
{
    static dkf_real_t A[MAXN * MAXN], QR[MAXN * MAXN], Qt[MAXN * MAXN], Qf[MAXN * MAXN],
        R[MAXN * MAXN], tau[MAXN];
    test_rng_t g;
    double worst_fact = 0.0, worst_orth = 0.0;
    size_t s, i, j;
    (void)state;
    test_rng_seed(&g, 0x51A7ULL);
    for (s = 0; s < NSHAPES; ++s) {
        size_t r = shapes[s].r, c = shapes[s].c;
        dkf_mat_t mA = DKF_MAT(r, c, A), mQR = DKF_MAT(r, c, QR), mQt = DKF_MAT(r, c, Qt),
                  mQf = DKF_MAT(r, r, Qf), mR = DKF_MAT(c, c, R);
        double tol = qr_tol(r, c), e;
        rand_real(&g, A, r, c);
        test_fill(R, c * c, SENTINEL);
        assert_int_equal(dkf_mat_qr(&mQR, tau, &mA), DKF_OK);
        assert_int_equal(dkf_mat_qr_q(&mQt, &mQR, tau), DKF_OK);
        assert_int_equal(dkf_mat_qr_q(&mQf, &mQR, tau), DKF_OK);
        assert_int_equal(dkf_mat_qr_r(&mR, &mQR, tau), DKF_OK);

        /* R: the upper triangle of QR, exact zeros below */
        for (i = 0; i < c; ++i)
            for (j = 0; j < c; ++j) {
                if (j < i) assert_true(R[i * c + j] == (dkf_real_t)0);
                else assert_true(R[i * c + j] == QR[i * c + j]);
            }
        e = factor_err(A, Qt, c, R, r, c);
        worst_fact = e > worst_fact ? e : worst_fact;
        assert_true(e <= tol);
        e = factor_err(A, Qf, r, R, r, c);
        assert_true(e <= tol);
        e = test_orth_err(Qt, r, c);
        worst_orth = e > worst_orth ? e : worst_orth;
        assert_true(e <= tol);
        e = test_orth_err(Qf, r, r);
        worst_orth = e > worst_orth ? e : worst_orth;
        assert_true(e <= tol);
        /* the thin Q is the leading c columns of the full Q */
        for (i = 0; i < r; ++i)
            for (j = 0; j < c; ++j)
                assert_true(fabs((double)Qt[i * c + j] - (double)Qf[i * r + j]) <= tol);
        /* the trailing columns of the full Q span range(A)^perp:
         * |Q(:, c:)^T A| <= tol max|A| (same backward-error argument) */
        {
            double amax = 0.0, m = 0.0;
            size_t l;
            for (i = 0; i < r * c; ++i)
                if (fabs((double)A[i]) > amax) amax = fabs((double)A[i]);
            for (i = c; i < r; ++i)
                for (j = 0; j < c; ++j) {
                    double acc = 0.0;
                    for (l = 0; l < r; ++l) acc += (double)Qf[l * r + i] * (double)A[l * c + j];
                    if (fabs(acc) > m) m = fabs(acc);
                }
            assert_true(m <= tol * amax);
        }
    }
    print_message("qr: worst |A-QR|/|A| = %.2e, worst |Q^TQ-I| = %.2e (eps %.2e)\n", worst_fact,
                  worst_orth, TEST_EPS);
}

/* dkf_mat_qr(A, tau, A) must produce bit for bit what the out-of-place call
 * does: the routine copies then factorises in place either way. */
static void test_qr_in_place(void **state)
{
    static dkf_real_t A[MAXN * MAXN], B[MAXN * MAXN], tau1[MAXN], tau2[MAXN];
    test_rng_t g;
    size_t s;
    (void)state;
    test_rng_seed(&g, 77);
    for (s = 0; s < NSHAPES; ++s) {
        size_t r = shapes[s].r, c = shapes[s].c;
        dkf_mat_t mA = DKF_MAT(r, c, A), mB = DKF_MAT(r, c, B);
        rand_real(&g, A, r, c);
        assert_int_equal(dkf_mat_qr(&mB, tau1, &mA), DKF_OK);
        assert_int_equal(dkf_mat_qr(&mA, tau2, &mA), DKF_OK);
        assert_memory_equal(A, B, r * c * sizeof(dkf_real_t));
        assert_memory_equal(tau1, tau2, c * sizeof(dkf_real_t));
    }
}

/* Solves the c x c SPD system M x = b (x c x k) in place by Cholesky, in
 * double. */
static void ref_spd_solve(const double *M, double *b, size_t c, size_t k)
{
    static double L[MAXN * MAXN];
    test_dchol(L, M, c);
    test_dchol_solve(L, b, c, k);
}

/* Least squares vs the normal equations A^T A x = A^T b solved in double
 * on the same (rounded) A and B. A has prescribed singular values
 * logspaced in [1/kappa, 1]. Forward error of a backward-stable LS solver
 * (Higham, ASNA thm 20.1; Wedin): per column
 *   |x - x*| / |x*| <= eps' kappa (2 + (kappa + 1) eta),
 *   eta = |b - A x*| / (|A|_2 |x*|),  eps' = 10 max(r, c) eps
 * (eps' as for the factors above). The reference itself is accurate to
 * ~c DBL_EPSILON kappa^2 <= 1e-10 relative for kappa = 100, inside eps'
 * kappa^2 eta in double too (eta is O(1) for random b). */
static void test_qr_solve_least_squares(void **state)
{
    static const shape_t ls[] = {{1, 1}, {4, 4}, {6, 3}, {12, 5}, {30, 10}, {48, 48}, {48, 7}};
    static double Ad[MAXN * MAXN], At[MAXN * MAXN], Bd[MAXN * 4], M[MAXN * MAXN], x[MAXN * 4];
    static dkf_real_t A[MAXN * MAXN], B[MAXN * 4], X[MAXN * 4],
        work[DKF_MAT_QR_SOLVE_WORK(MAXN, MAXN)];
    const size_t k = 3;
    const double kappa = 100.0;
    test_rng_t g;
    double worst = 0.0;
    size_t s, i, j, l;
    (void)state;
    test_rng_seed(&g, 2024);
    for (s = 0; s < sizeof ls / sizeof ls[0]; ++s) {
        size_t r = ls[s].r, c = ls[s].c;
        double sv[MAXN];
        dkf_mat_t mA = DKF_MAT(r, c, A), mB = DKF_MAT(r, k, B), mX = DKF_MAT(c, k, X);
        for (i = 0; i < c; ++i) sv[i] = c > 1 ? pow(kappa, -(double)i / (double)(c - 1)) : 1.0;
        test_mat_with_singular_values(&g, Ad, r, c, sv);
        test_rand_gauss(&g, Bd, r, k);
        test_to_real(A, Ad, r * c);
        test_to_real(B, Bd, r * k);
        test_to_double(Ad, A, r * c);
        test_to_double(Bd, B, r * k);
        assert_int_equal(dkf_mat_qr_solve(&mX, &mA, &mB, work), DKF_OK);

        /* the normal equations A^T A x = A^T b */
        test_ref_transpose(At, Ad, r, c);
        test_ref_mul(M, At, Ad, c, r, c);
        test_ref_mul(x, At, Bd, c, r, k);
        ref_spd_solve(M, x, c, k);

        for (j = 0; j < k; ++j) {
            double ex = 0.0, nx = 0.0, nres = 0.0, eta, tol, rel;
            for (i = 0; i < c; ++i) {
                double d = (double)X[i * k + j] - x[i * k + j];
                ex += d * d;
                nx += x[i * k + j] * x[i * k + j];
            }
            for (i = 0; i < r; ++i) {
                double acc = Bd[i * k + j];
                for (l = 0; l < c; ++l) acc -= Ad[i * c + l] * x[l * k + j];
                nres += acc * acc;
            }
            eta = sqrt(nres) / (1.0 * sqrt(nx)); /* |A|_2 = sv[0] = 1 */
            tol = qr_tol(r, c) * kappa * (2.0 + (kappa + 1.0) * eta);
            rel = sqrt(ex / nx);
            if (rel / tol > worst) worst = rel / tol;
            assert_true(rel <= tol);
        }
    }
    print_message("qr_solve: worst forward error / bound = %.2e\n", worst);
}

/* The rank rule |R_ii| <= c eps max|R_jj|, probed on triangular inputs
 * whose R is exact (no reflector does anything: the columns are already
 * zero below the diagonal), so the threshold is hit exactly. */
static void test_qr_solve_rank(void **state)
{
    static dkf_real_t A[6 * 3], B[6 * 2], X[3 * 2], Xs[3 * 2], work[DKF_MAT_QR_SOLVE_WORK(6, 3)];
    const dkf_real_t c_eps = (dkf_real_t)3 * DKF_REAL_EPSILON;
    dkf_mat_t mA = DKF_MAT(6, 3, A), mB = DKF_MAT(6, 2, B), mX = DKF_MAT(3, 2, X);
    size_t i;
    (void)state;
    for (i = 0; i < 12; ++i) B[i] = (dkf_real_t)(i % 5) - (dkf_real_t)2;

    /* R = diag(1, 2, d) plus an upper off-diagonal */
    memset(A, 0, sizeof A);
    A[0] = 1;
    A[1] = (dkf_real_t)0.5;
    A[2] = 1;
    A[4] = 2;
    A[5] = (dkf_real_t)0.25;

    /* d = c eps max|R_jj| / 2 and d = c eps max|R_jj| exactly: rank deficient */
    A[8] = c_eps;
    test_fill(X, 6, SENTINEL);
    memcpy(Xs, X, sizeof X);
    assert_int_equal(dkf_mat_qr_solve(&mX, &mA, &mB, work), DKF_ERR_RANK);
    assert_memory_equal(X, Xs, sizeof X);
    A[8] = c_eps * 2; /* = c eps max|R_jj| with max|R_jj| = 2: still <= */
    assert_int_equal(dkf_mat_qr_solve(&mX, &mA, &mB, work), DKF_ERR_RANK);
    assert_memory_equal(X, Xs, sizeof X);
    /* just above the threshold: solvable, and X(2, :) = B(2, :) / d */
    A[8] = c_eps * 4;
    assert_int_equal(dkf_mat_qr_solve(&mX, &mA, &mB, work), DKF_OK);
    assert_true(fabs((double)X[4] - (double)B[4] / (double)A[8]) <=
                4.0 * TEST_EPS * fabs((double)B[4] / (double)A[8]));

    /* a zero column anywhere */
    {
        static dkf_real_t Z[5 * 3];
        test_rng_t g;
        dkf_mat_t mZ = DKF_MAT(5, 3, Z), mB5 = DKF_MAT(5, 2, B);
        test_rng_seed(&g, 5);
        for (i = 0; i < 3; ++i) {
            size_t row;
            rand_real(&g, Z, 5, 3);
            for (row = 0; row < 5; ++row) Z[row * 3 + i] = 0;
            test_fill(X, 6, SENTINEL);
            assert_int_equal(dkf_mat_qr_solve(&mX, &mZ, &mB5, work), DKF_ERR_RANK);
            assert_memory_equal(X, Xs, sizeof X);
        }
    }
    /* the zero matrix */
    memset(A, 0, sizeof A);
    assert_int_equal(dkf_mat_qr_solve(&mX, &mA, &mB, work), DKF_ERR_RANK);
    assert_memory_equal(X, Xs, sizeof X);
}

/* ---- errors: status and untouched outputs ------------------------------ */

typedef struct {
    dkf_real_t A[6 * 4], QR[6 * 4], tau[4], Q[6 * 6], R[4 * 4], B[6 * 2], X[4 * 2],
        work[DKF_MAT_QR_SOLVE_WORK(6, 4)];
} qr_bufs_t;

static void setup_bufs(qr_bufs_t *b)
{
    test_rng_t g;
    test_rng_seed(&g, 99);
    rand_real(&g, b->A, 6, 4);
    rand_real(&g, b->B, 6, 2);
    test_fill(b->QR, 24, SENTINEL);
    test_fill(b->tau, 4, SENTINEL);
    test_fill(b->Q, 36, SENTINEL);
    test_fill(b->R, 16, SENTINEL);
    test_fill(b->X, 8, SENTINEL);
    test_fill(b->work, DKF_MAT_QR_SOLVE_WORK(6, 4), SENTINEL);
}

/* Every output buffer still holds the sentinel (A, B are inputs). */
static void assert_untouched(const qr_bufs_t *b, const qr_bufs_t *before)
{
    static const test_member_t all[] = {
        TEST_MEMBER(qr_bufs_t, QR), TEST_MEMBER(qr_bufs_t, tau), TEST_MEMBER(qr_bufs_t, Q),
        TEST_MEMBER(qr_bufs_t, R),  TEST_MEMBER(qr_bufs_t, X),   TEST_MEMBER(qr_bufs_t, A),
        TEST_MEMBER(qr_bufs_t, B),
    };
    test_assert_same_members(b, before, all, sizeof all / sizeof all[0]);
}

static void test_qr_errors(void **state)
{
    static qr_bufs_t b, ref;
    dkf_real_t nan = (dkf_real_t)NAN, inf = (dkf_real_t)INFINITY;
    (void)state;
    setup_bufs(&b);
    ref = b;
    {
        dkf_mat_t A = DKF_MAT(6, 4, b.A), QR = DKF_MAT(6, 4, b.QR), Q = DKF_MAT(6, 5, b.Q),
                  R = DKF_MAT(4, 4, b.R), B = DKF_MAT(6, 2, b.B), X = DKF_MAT(4, 2, b.X);
        dkf_mat_t bad;

        /* capacity: zero and oversize dimensions */
        bad = A;
        bad.cols = 0;
        assert_int_equal(dkf_mat_qr(&QR, b.tau, &bad), DKF_ERR_CAPACITY);
        bad.rows = DKF_MAX_DIM + 1;
        bad.cols = 4;
        assert_int_equal(dkf_mat_qr(&QR, b.tau, &bad), DKF_ERR_CAPACITY);
        assert_int_equal(dkf_mat_qr_solve(&X, &bad, &B, b.work), DKF_ERR_CAPACITY);
        assert_untouched(&b, &ref);

        /* dimensions */
        bad = test_view(4, 6, b.A); /* r < c */
        {
            dkf_mat_t QRw = DKF_MAT(4, 6, b.QR), Xw = DKF_MAT(6, 2, b.Q);
            assert_int_equal(dkf_mat_qr(&QRw, b.tau, &bad), DKF_ERR_DIM);
            assert_int_equal(dkf_mat_qr_solve(&Xw, &bad, &B, b.work), DKF_ERR_DIM);
        }
        bad = test_view(6, 3, b.QR);
        assert_int_equal(dkf_mat_qr(&bad, b.tau, &A), DKF_ERR_DIM);
        bad = test_view(6, 3, b.Q); /* k < c */
        assert_int_equal(dkf_mat_qr_q(&bad, &QR, b.tau), DKF_ERR_DIM);
        bad = test_view(5, 4, b.Q); /* rows != r */
        assert_int_equal(dkf_mat_qr_q(&bad, &QR, b.tau), DKF_ERR_DIM);
        {
            static dkf_real_t q7[6 * 7], q7s[6 * 7];
            dkf_mat_t Q7 = DKF_MAT(6, 7, q7); /* k > r */
            test_fill(q7, 42, SENTINEL);
            memcpy(q7s, q7, sizeof q7);
            assert_int_equal(dkf_mat_qr_q(&Q7, &QR, b.tau), DKF_ERR_DIM);
            assert_memory_equal(q7, q7s, sizeof q7);
        }
        bad = test_view(3, 4, b.R);
        assert_int_equal(dkf_mat_qr_r(&bad, &QR, b.tau), DKF_ERR_DIM);
        bad = test_view(4, 1, b.X);
        assert_int_equal(dkf_mat_qr_solve(&bad, &A, &B, b.work), DKF_ERR_DIM);
        bad = test_view(5, 2, b.B);
        assert_int_equal(dkf_mat_qr_solve(&X, &A, &bad, b.work), DKF_ERR_DIM);
        assert_untouched(&b, &ref);

#if DKF_DEBUG_CHECKS
        /* NULL */
        assert_int_equal(dkf_mat_qr(&QR, NULL, &A), DKF_ERR_NULL);
        assert_int_equal(dkf_mat_qr(NULL, b.tau, &A), DKF_ERR_NULL);
        assert_int_equal(dkf_mat_qr(&QR, b.tau, NULL), DKF_ERR_NULL);
        assert_int_equal(dkf_mat_qr_q(&Q, &QR, NULL), DKF_ERR_NULL);
        assert_int_equal(dkf_mat_qr_q(NULL, &QR, b.tau), DKF_ERR_NULL);
        assert_int_equal(dkf_mat_qr_r(NULL, &QR, b.tau), DKF_ERR_NULL);
        assert_int_equal(dkf_mat_qr_r(&R, NULL, b.tau), DKF_ERR_NULL);
        assert_int_equal(dkf_mat_qr_solve(&X, &A, &B, NULL), DKF_ERR_NULL);
        assert_int_equal(dkf_mat_qr_solve(NULL, &A, &B, b.work), DKF_ERR_NULL);
        bad = A;
        bad.data = NULL;
        assert_int_equal(dkf_mat_qr_solve(&X, &bad, &B, b.work), DKF_ERR_NULL);
        assert_untouched(&b, &ref);

        /* aliasing */
        {
            static dkf_real_t big[8 * 4];
            dkf_mat_t in = DKF_MAT(6, 4, big), out = DKF_MAT(6, 4, big + 4);
            test_fill(big, 32, SENTINEL);
            assert_int_equal(dkf_mat_qr(&out, b.tau, &in), DKF_ERR_ALIAS); /* partial */
            assert_int_equal(dkf_mat_qr(&QR, b.QR + 2, &A), DKF_ERR_ALIAS); /* tau in QR */
            assert_int_equal(dkf_mat_qr(&QR, b.A + 20, &A), DKF_ERR_ALIAS); /* tau in A */
            bad = test_view(6, 4, b.QR);
            assert_int_equal(dkf_mat_qr_q(&bad, &QR, b.tau), DKF_ERR_ALIAS);
            bad = test_view(6, 4, b.Q);
            assert_int_equal(dkf_mat_qr_q(&bad, &QR, b.Q + 3), DKF_ERR_ALIAS);
            bad = test_view(4, 4, b.QR + 8);
            assert_int_equal(dkf_mat_qr_r(&bad, &QR, b.tau), DKF_ERR_ALIAS);
            bad = test_view(4, 2, b.A);
            assert_int_equal(dkf_mat_qr_solve(&bad, &A, &B, b.work), DKF_ERR_ALIAS);
            bad = test_view(4, 2, b.B + 4);
            assert_int_equal(dkf_mat_qr_solve(&bad, &A, &B, b.work), DKF_ERR_ALIAS);
            assert_int_equal(dkf_mat_qr_solve(&X, &A, &B, b.X), DKF_ERR_ALIAS);
            assert_int_equal(dkf_mat_qr_solve(&X, &A, &B, b.A), DKF_ERR_ALIAS);
            assert_int_equal(dkf_mat_qr_solve(&X, &A, &B, b.B), DKF_ERR_ALIAS);
            assert_untouched(&b, &ref);
        }
#endif

        /* non-finite inputs */
        b.A[7] = nan;
        ref.A[7] = nan;
        assert_int_equal(dkf_mat_qr(&QR, b.tau, &A), DKF_ERR_NONFINITE);
        assert_int_equal(dkf_mat_qr_solve(&X, &A, &B, b.work), DKF_ERR_NONFINITE);
        assert_int_equal(dkf_mat_qr(&A, b.tau, &A), DKF_ERR_NONFINITE); /* in place */
        b.A[7] = inf;
        ref.A[7] = inf;
        assert_int_equal(dkf_mat_qr(&QR, b.tau, &A), DKF_ERR_NONFINITE);
        assert_int_equal(dkf_mat_qr(&A, b.tau, &A), DKF_ERR_NONFINITE);
        b.A[7] = ref.A[7] = 1;
        b.B[11] = ref.B[11] = -inf;
        assert_int_equal(dkf_mat_qr_solve(&X, &A, &B, b.work), DKF_ERR_NONFINITE);
        b.B[11] = ref.B[11] = 1;
        assert_untouched(&b, &ref);

        /* a factorisation with a NaN in it is refused by _q and _r */
        assert_int_equal(dkf_mat_qr(&QR, b.tau, &A), DKF_OK);
        ref = b;
        b.QR[9] = ref.QR[9] = nan;
        assert_int_equal(dkf_mat_qr_q(&Q, &QR, b.tau), DKF_ERR_NONFINITE);
        assert_int_equal(dkf_mat_qr_r(&R, &QR, b.tau), DKF_ERR_NONFINITE);
        b.QR[9] = ref.QR[9] = 0;
        b.tau[1] = ref.tau[1] = inf;
        assert_int_equal(dkf_mat_qr_q(&Q, &QR, b.tau), DKF_ERR_NONFINITE);
        assert_untouched(&b, &ref);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_qr_factors),
        cmocka_unit_test(test_qr_in_place),
        cmocka_unit_test(test_qr_solve_least_squares),
        cmocka_unit_test(test_qr_solve_rank),
        cmocka_unit_test(test_qr_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
