/*
 * Cholesky and LU routines of dkf/mat.h: closed forms, backward-error
 * residuals on random well- and ill-conditioned matrices, aliasing, and
 * every error status with its outputs left untouched.
 *
 * Tolerances. u = EPS/2 is the unit roundoff of the library type and
 * gamma_m = m u / (1 - m u) <= m EPS whenever m u <= 1/2 (so every bound
 * below written as m * EPS carries a factor of 2 of slack over the theory).
 * The library divides by a pivot through its reciprocal, one extra
 * rounding per substitution step, which adds 1 to m for the factorisation
 * and 1 per triangular solve. Residuals are evaluated in long double (at
 * least double) from the exact double images of the library's inputs, so
 * their own error is negligible against u in float and covered by the
 * factor-2 slack in double. Theorem numbers refer to Higham, Accuracy and
 * Stability of Numerical Algorithms, 2nd ed. Factorisation and solve
 * residuals are backward errors: no condition number enters them.
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
#include "dkf_test.h"

#define MAXN DKF_MAX_DIM
#define MAXSQ (DKF_MAX_DIM * DKF_MAX_DIM)
#define SENTINEL ((dkf_real_t)-1234.5)
#define NRHS 3

static dkf_real_t ra[MAXSQ], rb[MAXSQ], rl[MAXSQ], rx[MAXSQ], ry[MAXSQ], rw[2 * MAXSQ],
    snap[2 * MAXSQ];
static double da[MAXSQ], db[MAXSQ], dl[MAXSQ], dx[MAXSQ], dbound[MAXSQ];
static size_t piv[MAXN], piv2[MAXN];

/* Worst measured error / (unit of its bound), reported at the end. */
static double worst_chol, worst_chol_solve, worst_spd_inv, worst_spd_fwd, worst_lu, worst_lu_solve,
    worst_inv_comp, worst_inv_norm;

#if DKF_USE_FLOAT
static const double conds[] = {1e1, 1e2, 1e3};
#else
static const double conds[] = {1e1, 1e3, 1e6};
#endif
/* the largest: the build's limit, at most 96 (a DKF_MAX_DIM = 1024 build would
 * spend minutes on O(n^3) references at n = 1024; the kernels are the same) */
#define SIZE_TOP (DKF_MAX_DIM < 96 ? DKF_MAX_DIM : 96)
static const size_t sizes[] = {1, 2, 3, 4, 6, 8, 12, 24, SIZE_TOP};
#define NCONDS (sizeof conds / sizeof conds[0])
#define NSIZES (sizeof sizes / sizeof sizes[0])
#define TRIALS 3

/* Random SPD matrix of condition number cond in the library type, and the
 * exact double image of the rounded values. */
static void spd_pair(test_rng_t *g, dkf_real_t *a, double *ad, size_t n, double cond)
{
    test_rand_spd(g, ad, n, cond, 1.0);
    test_to_real(a, ad, n * n);
    test_to_double(ad, a, n * n);
}

/* Random general matrix with singular values log-spaced in [1/cond, 1]. */
static void general_pair(test_rng_t *g, dkf_real_t *a, double *ad, size_t n, double cond)
{
    double s[MAXN] = {0}; /* initialised: GCC -O3 cannot see that n >= 1 */
    size_t i;
    for (i = 0; i < n; ++i) s[i] = n > 1 ? pow(cond, -(double)i / (double)(n - 1)) : 1.0;
    test_mat_with_singular_values(g, ad, n, n, s);
    test_to_real(a, ad, n * n);
    test_to_double(ad, a, n * n);
}

static void rand_pair(test_rng_t *g, dkf_real_t *a, double *ad, size_t r, size_t c)
{
    test_rand_gauss(g, ad, r, c);
    test_to_real(a, ad, r * c);
    test_to_double(ad, a, r * c);
}

/* max over entries of |R_ij| / (m EPS B_ij): <= 1 means the bound holds. */
static double ratio_to_bound(const long double *R, const double *B, size_t n, double m)
{
    double worst = 0;
    size_t i;
    for (i = 0; i < n; ++i) {
        double r = fabs((double)R[i]) / (m * TEST_EPS * B[i] + 1e-300);
        if (!(r <= worst)) worst = r;
    }
    return worst;
}

static void update(double *worst, double r)
{
    if (!(r <= *worst)) *worst = r;
}

/* trial(g, n, cond) TRIALS times for every size and condition number, all
 * drawing from one generator seeded with seed. */
static void sweep(uint64_t seed, void (*trial)(test_rng_t *g, size_t n, double cond))
{
    test_rng_t g;
    size_t si, ci, t;
    test_rng_seed(&g, seed);
    for (si = 0; si < NSIZES; ++si)
        for (ci = 0; ci < NCONDS; ++ci)
            for (t = 0; t < TRIALS; ++t) trial(&g, sizes[si], conds[ci]);
}

/* ---- Cholesky ------------------------------------------------------------------ */

static void test_chol_closed_form(void **state)
{
    /* [4 2; 2 5] = [2 0; 1 2][2 1; 0 2], all exact; NaN in the upper
     * triangle shows it is never read, and L's upper triangle is zeroed. */
    dkf_real_t a[4] = {4, (dkf_real_t)NAN, 2, 5}, l[4] = {9, 9, 9, 9}, w[4];
    dkf_real_t inv[4];
    const dkf_real_t want_l[4] = {2, 0, 1, 2};
    /* (L L^T)^{-1} = [5 -2; -2 4] / 16, exact in binary */
    const dkf_real_t want_inv[4] = {(dkf_real_t)0.3125, (dkf_real_t)-0.125, (dkf_real_t)-0.125,
                                    (dkf_real_t)0.25};
    dkf_mat_t A = DKF_MAT(2, 2, a), L = DKF_MAT(2, 2, l), Inv = DKF_MAT(2, 2, inv);
    dkf_real_t b[2] = {8, 14}, x[2];
    dkf_mat_t B = DKF_MAT(2, 1, b), X = DKF_MAT(2, 1, x);
    (void)state;
    assert_int_equal(dkf_mat_chol(&L, &A, w), DKF_OK);
    assert_memory_equal(l, want_l, sizeof l);
    assert_int_equal(dkf_mat_chol_inverse(&Inv, &L), DKF_OK);
    assert_memory_equal(inv, want_inv, sizeof inv);
    a[1] = 2; /* spd_inverse reads the lower triangle only as well */
    assert_int_equal(dkf_mat_spd_inverse(&Inv, &A, w), DKF_OK);
    assert_memory_equal(inv, want_inv, sizeof inv);
    /* [4 2; 2 5] x = [8; 14]: x = [0.75; 2.5], every step exact */
    assert_int_equal(dkf_mat_chol_solve(&X, &L, &B), DKF_OK);
    assert_true(x[0] == (dkf_real_t)0.75 && x[1] == (dkf_real_t)2.5);
    /* 1 x 1 */
    {
        dkf_real_t s = 9, t;
        dkf_mat_t S = DKF_MAT(1, 1, &s), T = DKF_MAT(1, 1, &t);
        assert_int_equal(dkf_mat_chol(&T, &S, w), DKF_OK);
        assert_true(t == 3);
        assert_int_equal(dkf_mat_spd_inverse(&S, &S, w), DKF_OK);
        /* (1/3)^2 rounded twice: relative error <= 2 u (1 + u) < EPS * 1.01 */
        assert_true(fabs((double)s - 1.0 / 9.0) <= 1.01 * TEST_EPS / 9.0);
    }
}

/* A - L L^T (long double) and the Theorem 10.3 bound |L||L^T|. */
static void chol_residual(long double *R, double *bound, const double *A, const double *L,
                          size_t n)
{
    size_t i, j, k;
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) {
            long double acc = 0;
            double b = 0;
            for (k = 0; k < n; ++k) {
                acc += (long double)L[i * n + k] * L[j * n + k];
                b += fabs(L[i * n + k] * L[j * n + k]);
            }
            R[i * n + j] = (long double)A[i * n + j] - acc;
            bound[i * n + j] = b;
        }
}

/* B - A X for n x m B (long double) and the bound M |X| for a given n x n
 * nonnegative M (the |L||L^T| or P^T|L||U| of the backward error). */
static void solve_residual(long double *R, double *bound, const double *A, const double *X,
                           const double *B, const double *M, size_t n, size_t m)
{
    size_t i, j, k;
    for (i = 0; i < n; ++i)
        for (j = 0; j < m; ++j) {
            long double acc = B[i * m + j];
            double b = 0;
            for (k = 0; k < n; ++k) {
                acc -= (long double)A[i * n + k] * X[k * m + j];
                b += M[i * n + k] * fabs(X[k * m + j]);
            }
            R[i * m + j] = acc;
            bound[i * m + j] = b;
        }
}

/* One random SPD A of size n and condition cond: chol, chol_solve,
 * chol_inverse and spd_inverse against their bounds, aliasing. */
static void chol_trial(test_rng_t *g, size_t n, double cond)
{
    static long double res[MAXSQ];
    static double llt[MAXSQ];
    size_t i, j;
    dkf_mat_t A = DKF_MAT(n, n, ra), L = DKF_MAT(n, n, rl), B = DKF_MAT(n, NRHS, rb),
              X = DKF_MAT(n, NRHS, rx), Inv = DKF_MAT(n, n, ry);
    double r;
    spd_pair(g, ra, da, n, cond);
    test_fill(rl, n * n, SENTINEL);
    assert_int_equal(dkf_mat_chol(&L, &A, rw), DKF_OK);
    test_to_double(dl, rl, n * n);
    for (i = 0; i < n; ++i) {
        assert_true(rl[i * n + i] > 0);
        for (j = i + 1; j < n; ++j) assert_true(rl[i * n + j] == 0);
    }
    /* Theorem 10.3: A + dA = L L^T, |dA| <= gamma_{n+1}|L||L^T|;
     * +1 for the reciprocal pivots. |L||L^T|_ij <= sqrt(a_ii a_jj)
     * (1 + O(u)), so this is ~ n EPS ||A|| whatever cond is. */
    chol_residual(res, llt, da, dl, n);
    r = ratio_to_bound(res, llt, n * n, (double)(n + 2));
    update(&worst_chol, r);
    assert_true(r <= 1.0);

    /* Theorem 10.4: (A + dA) X = B, |dA| <= gamma_{3n+1}|L||L^T|;
     * +2 for the reciprocals in factor and solves. */
    rand_pair(g, rb, db, n, NRHS);
    assert_int_equal(dkf_mat_chol_solve(&X, &L, &B), DKF_OK);
    test_to_double(dx, rx, n * NRHS);
    solve_residual(res, dbound, da, dx, db, llt, n, NRHS);
    r = ratio_to_bound(res, dbound, n * NRHS, (double)(3 * n + 3));
    update(&worst_chol_solve, r);
    assert_true(r <= 1.0);
    /* in place: X == B gives the same bits */
    memcpy(ry, rb, n * NRHS * sizeof(dkf_real_t));
    {
        dkf_mat_t Y = DKF_MAT(n, NRHS, ry);
        assert_int_equal(dkf_mat_chol_solve(&Y, &L, &Y), DKF_OK);
        assert_memory_equal(ry, rx, n * NRHS * sizeof(dkf_real_t));
    }

    /* Inverse. Forward error (Higham sec. 14.2-14.3: triangular
     * inversion, then the product M^T M): ||X - A^{-1}||_2 <=
     * c n u kappa ||A^{-1}||_2. The eigenvalues of A lie in
     * [1, cond], so ||A^{-1}||_2 = 1 and kappa = cond; the max
     * norm is below the 2-norm. Asserted as 2 n EPS cond against a
     * long double Gauss-Jordan reference.
     * Residual: theory only gives ||AX - I|| <= ||A|| ||X - A^{-1}||
     * ~ n u cond^2 for this method; the usual behaviour is
     * ~ n u cond and that is what is asserted (2 n EPS cond,
     * observed ratio printed below, ~0.25 at most), so a change
     * that loses the usual accuracy is caught. */
    test_fill(ry, n * n, SENTINEL);
    assert_int_equal(dkf_mat_chol_inverse(&Inv, &L), DKF_OK);
    for (i = 0; i < n; ++i)
        for (j = 0; j < i; ++j) assert_true(ry[i * n + j] == ry[j * n + i]);
    test_to_double(dx, ry, n * n);
    {
        static long double W[MAXSQ];
        for (i = 0; i < n * n; ++i) W[i] = da[i];
        test_ref_inverse(res, W, n); /* long double: independent */
    }
    {
        double worst = 0, fwd = 0;
        size_t k;
        for (i = 0; i < n; ++i)
            for (j = 0; j < n; ++j) {
                long double acc = i == j ? -1.0L : 0.0L;
                double e = (double)fabsl((long double)dx[i * n + j] - res[i * n + j]);
                for (k = 0; k < n; ++k) acc += (long double)da[i * n + k] * dx[k * n + j];
                if (fabsl(acc) > worst) worst = (double)fabsl(acc);
                if (e > fwd) fwd = e;
            }
        r = fwd / ((double)n * TEST_EPS * cond);
        update(&worst_spd_fwd, r);
        assert_true(r <= 2.0);
        r = worst / ((double)n * TEST_EPS * cond);
        update(&worst_spd_inv, r);
        assert_true(r <= 2.0);
    }
    /* spd_inverse (out of place and in place) is the same computation */
    {
        dkf_mat_t Z = DKF_MAT(n, n, rx);
        assert_int_equal(dkf_mat_spd_inverse(&Z, &A, rw), DKF_OK);
        assert_memory_equal(rx, ry, n * n * sizeof(dkf_real_t));
        assert_int_equal(dkf_mat_spd_inverse(&A, &A, rw), DKF_OK);
        assert_memory_equal(ra, ry, n * n * sizeof(dkf_real_t));
    }
    /* L may alias A: same bits as out of place */
    spd_pair(g, ra, da, n, cond);
    assert_int_equal(dkf_mat_chol(&L, &A, rw), DKF_OK);
    assert_int_equal(dkf_mat_chol(&A, &A, rw), DKF_OK);
    assert_memory_equal(ra, rl, n * n * sizeof(dkf_real_t));
}

static void test_chol_residuals(void **state)
{
    (void)state;
    sweep(21, chol_trial);
    print_message("chol: worst |A - LL^T| / ((n+2) EPS |L||L^T|) = %.3g\n", worst_chol);
    print_message("chol_solve: worst |B - AX| / ((3n+3) EPS |L||L^T||X|) = %.3g\n",
                  worst_chol_solve);
    print_message("chol_inverse: worst ||X - A^-1||_max / (n EPS cond) = %.3g, "
                  "||AX - I||_max / (n EPS cond) = %.3g\n",
                  worst_spd_fwd, worst_spd_inv);
}

/* The factor's and the solve's kernels take 4 columns and two rows at a
 * time for speed, and claim to sum every element's terms in the textbook order
 * (forward: l ascending; backward: i descending; each row times the
 * reciprocal pivot), so their result is that of the plain row-by-row loops
 * below, bit for bit. Every n up to 13 (odd and even row counts) and c up
 * to 9 (full 4-column blocks and remainders). */
static void textbook_chol_solve(dkf_real_t *X, const dkf_real_t *L, size_t n, size_t c)
{
    size_t i, j, l;
    for (j = 0; j < c; ++j) {
        for (i = 0; i < n; ++i) {
            dkf_real_t t = X[i * c + j];
            for (l = 0; l < i; ++l) t -= L[i * n + l] * X[l * c + j];
            X[i * c + j] = t * (DKF_R(1.0) / L[i * n + i]);
        }
        for (l = n; l-- > 0;) {
            dkf_real_t t = X[l * c + j];
            for (i = n - 1; i > l; --i) t -= L[i * n + l] * X[i * c + j];
            X[l * c + j] = t * (DKF_R(1.0) / L[l * n + l]);
        }
    }
}

static void test_chol_solve_textbook_order(void **state)
{
    test_rng_t g;
    size_t n, c;
    (void)state;
    test_rng_seed(&g, 23);
    for (n = 1; n <= 13 && n <= DKF_MAX_DIM; ++n)
        for (c = 1; c <= 9 && c <= DKF_MAX_DIM; ++c) {
            dkf_mat_t A = DKF_MAT(n, n, ra), L = DKF_MAT(n, n, rl), B = DKF_MAT(n, c, rb),
                      X = DKF_MAT(n, c, rx);
            spd_pair(&g, ra, da, n, 1e2);
            assert_int_equal(dkf_mat_chol(&L, &A, rw), DKF_OK);
            test_textbook_chol(ry, ra, n);
            assert_memory_equal(rl, ry, n * n * sizeof(dkf_real_t));
            rand_pair(&g, rb, db, n, c);
            assert_int_equal(dkf_mat_chol_solve(&X, &L, &B), DKF_OK);
            memcpy(ry, rb, n * c * sizeof(dkf_real_t));
            textbook_chol_solve(ry, rl, n, c);
            assert_memory_equal(rx, ry, n * c * sizeof(dkf_real_t));
        }
}

static void test_chol_errors(void **state)
{
    /* [4 2 2; 2 2 0; 2 0 2] = B B^T, B = [2 0; 1 1; 1 -1]: rank 2 and every
     * step exact, so the last pivot is exactly 0 (semi-definite). */
    dkf_real_t psd[9] = {4, 2, 2, 2, 2, 0, 2, 0, 2};
    dkf_real_t ones[4] = {1, 1, 1, 1}, zero[4] = {0, 0, 0, 0}, indef[4] = {1, 0, 0, -1};
    dkf_real_t neg1[1] = {-1}, nan1[1];
    /* symmetric indefinite with a positive leading entry: pivots 2, then
     * 4 - 9/2 < 0 */
    dkf_real_t indef3[9] = {2, 3, 0, 3, 4, 1, 0, 1, 7};
    dkf_real_t good[9] = {4, 2, 2, 2, 5, 1, 2, 1, 6};
    dkf_mat_t L3 = DKF_MAT(3, 3, rl), L2 = DKF_MAT(2, 2, rl), L1 = DKF_MAT(1, 1, rl);
    dkf_mat_t A3 = DKF_MAT(3, 3, psd), Ao = DKF_MAT(2, 2, ones), Az = DKF_MAT(2, 2, zero),
              Ai = DKF_MAT(2, 2, indef), An = DKF_MAT(1, 1, neg1), Ai3 = DKF_MAT(3, 3, indef3),
              G = DKF_MAT(3, 3, good), R = DKF_MAT(2, 3, ra), Nan = DKF_MAT(1, 1, nan1);
    size_t pos;
    (void)state;
    nan1[0] = (dkf_real_t)NAN;
    test_fill(rl, 16, SENTINEL);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_chol(&L3, &A3, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_chol(&L2, &Ao, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_chol(&L2, &Az, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_chol(&L2, &Ai, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_chol(&L1, &An, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_chol(&L3, &Ai3, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_chol(&L1, &Nan, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_spd_inverse(&L3, &A3, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_spd_inverse(&L3, &Ai3, rw), rl, 16);
    /* in place failure leaves A itself untouched */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_chol(&A3, &A3, rw), psd, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_mat_spd_inverse(&Ai3, &Ai3, rw), indef3, 9);

    /* NaN / +-Inf anywhere in the lower triangle gives NONFINITE, even when
     * an earlier pivot would fail first; the upper triangle is not read. */
    for (pos = 0; pos < 9; ++pos) {
        const dkf_real_t bad[3] = {(dkf_real_t)NAN, (dkf_real_t)INFINITY, -(dkf_real_t)INFINITY};
        size_t b;
        for (b = 0; b < 3; ++b) {
            const dkf_real_t keep = good[pos];
            const int lower = pos % 3 <= pos / 3;
            const dkf_status_t want = lower ? DKF_ERR_NONFINITE : DKF_OK;
            good[pos] = bad[b];
            test_fill(rl, 9, SENTINEL);
            if (lower) {
                TEST_FAILS_UNTOUCHED(snap, want, dkf_mat_chol(&L3, &G, rw), rl, 9);
                TEST_FAILS_UNTOUCHED(snap, want, dkf_mat_spd_inverse(&L3, &G, rw), rl, 9);
                good[0] = -1; /* pivot 0 fails before the bad value is reached */
                if (pos != 0) TEST_FAILS_UNTOUCHED(snap, want, dkf_mat_chol(&L3, &G, rw), rl, 9);
                good[0] = 4;
            } else {
                assert_int_equal(dkf_mat_chol(&L3, &G, rw), DKF_OK);
            }
            good[pos] = keep;
        }
    }

    /* argument errors */
    test_fill(rl, 16, SENTINEL);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_chol(&L3, &R, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_chol(&L2, &G, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_spd_inverse(&L2, &G, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_chol(&L3, &G, NULL), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_chol(&L3, NULL, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_spd_inverse(&L3, &G, NULL), rl, 16);
    assert_int_equal(dkf_mat_chol(NULL, &G, rw), DKF_ERR_NULL);
    L3.rows = 0;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_chol(&L3, &G, rw), rl, 16);
    L3.rows = DKF_MAX_DIM + 1;
    L3.cols = DKF_MAX_DIM + 1;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_chol(&L3, &G, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_spd_inverse(&L3, &G, rw), rl, 16);
    L3.rows = L3.cols = 3;
    /* workspace over L or over A; L partly over A */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_chol(&L3, &G, rl + 2), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_chol(&L3, &G, good + 8), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_spd_inverse(&L3, &G, rl + 8), rl, 16);
    {
        dkf_mat_t Gs = DKF_MAT(3, 3, rl), Gp = DKF_MAT(3, 3, rl + 1);
        memcpy(rl, good, sizeof good);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_chol(&Gp, &Gs, rw), rl, 16);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_spd_inverse(&Gp, &Gs, rw), rl, 16);
    }
}

static void test_chol_solve_inverse_errors(void **state)
{
    dkf_real_t l[9] = {2, (dkf_real_t)NAN, (dkf_real_t)NAN, 1, 3, (dkf_real_t)NAN, -1, 2, 1};
    dkf_mat_t L = DKF_MAT(3, 3, l), B = DKF_MAT(3, 2, rb), X = DKF_MAT(3, 2, rx),
              Inv = DKF_MAT(3, 3, ry), X4 = DKF_MAT(4, 2, rx), B4 = DKF_MAT(4, 2, rb),
              R = DKF_MAT(3, 2, ra);
    size_t i;
    (void)state;
    test_fill(rb, 6, 1);
    /* NaN in the strict upper triangle of L is never read */
    assert_int_equal(dkf_mat_chol_solve(&X, &L, &B), DKF_OK);
    assert_int_equal(dkf_mat_chol_inverse(&Inv, &L), DKF_OK);
    assert_true(dkf_mat_check_finite(&Inv) == DKF_OK);

    test_fill(rx, 8, SENTINEL);
    test_fill(ry, 9, SENTINEL);
    /* a non-positive diagonal element: SINGULAR */
    for (i = 0; i < 3; ++i) {
        const dkf_real_t keep = l[4 * i];
        l[4 * i] = 0;
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_SINGULAR, dkf_mat_chol_solve(&X, &L, &B), rx, 8);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_SINGULAR, dkf_mat_chol_inverse(&Inv, &L), ry, 9);
        l[4 * i] = -keep;
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_SINGULAR, dkf_mat_chol_solve(&X, &L, &B), rx, 8);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_SINGULAR, dkf_mat_chol_inverse(&Inv, &L), ry, 9);
        l[4 * i] = keep;
    }
    /* non-finite factor (lower triangle) or right-hand side */
    l[7] = (dkf_real_t)INFINITY;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_chol_solve(&X, &L, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_chol_inverse(&Inv, &L), ry, 9);
    l[7] = 2;
    l[8] = (dkf_real_t)NAN;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_chol_solve(&X, &L, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_chol_inverse(&Inv, &L), ry, 9);
    l[8] = 1;
    rb[5] = (dkf_real_t)NAN;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_chol_solve(&X, &L, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_chol_solve(&B, &L, &B), rb, 6);
    rb[5] = 1;
    /* shapes */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_chol_solve(&X4, &L, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_chol_solve(&X4, &L, &B4), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_chol_solve(&X, &R, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_chol_inverse(&X, &L), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_chol_inverse(&Inv, &R), ry, 9);
    /* X over L, X partly over B, Ainv over L */
    {
        dkf_mat_t XL = DKF_MAT(3, 3, l), Bp = DKF_MAT(3, 2, rb + 1);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_chol_solve(&XL, &L, &XL), l, 9);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_chol_solve(&Bp, &L, &B), rb, 7);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_chol_inverse(&L, &L), l, 9);
    }
    /* NULL and capacity */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_chol_solve(&X, NULL, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_chol_solve(&X, &L, NULL), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_chol_inverse(&Inv, NULL), ry, 9);
    assert_int_equal(dkf_mat_chol_solve(NULL, &L, &B), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_chol_inverse(NULL, &L), DKF_ERR_NULL);
    B.cols = DKF_MAX_DIM + 1;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_chol_solve(&X, &L, &B), rx, 8);
    B.cols = 0;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_chol_solve(&X, &L, &B), rx, 8);
    L.rows = 0;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_chol_inverse(&Inv, &L), ry, 9);
}

/* ---- LU -------------------------------------------------------------------------- */

static void test_lu_closed_form(void **state)
{
    /* [0 1; 2 3]: the zero pivot forces a swap; P A = [2 3; 0 1] = I U */
    dkf_real_t a[4] = {0, 1, 2, 3}, lu[4], inv[4], x[2], b[2] = {5, 13};
    const dkf_real_t want_lu[4] = {2, 3, 0, 1};
    /* A^{-1} = [-1.5 0.5; 1 0], exact */
    const dkf_real_t want_inv[4] = {(dkf_real_t)-1.5, (dkf_real_t)0.5, 1, 0};
    dkf_mat_t A = DKF_MAT(2, 2, a), LU = DKF_MAT(2, 2, lu), Inv = DKF_MAT(2, 2, inv),
              X = DKF_MAT(2, 1, x), B = DKF_MAT(2, 1, b);
    (void)state;
    assert_int_equal(dkf_mat_lu(&LU, piv, &A, rw), DKF_OK);
    assert_memory_equal(lu, want_lu, sizeof lu);
    assert_true(piv[0] == 1 && piv[1] == 0);
    assert_int_equal(dkf_mat_lu_solve(&X, &LU, piv, &B), DKF_OK); /* x = [-1; 5] exactly */
    assert_true(x[0] == -1 && x[1] == 5);
    assert_int_equal(dkf_mat_inverse(&Inv, &A, piv2, rw), DKF_OK);
    assert_memory_equal(inv, want_inv, sizeof inv);
    /* 3 x 3, all steps exact (power-of-two pivots):
     * A = [1 2 3; 2 5 7; 4 2 2]. Step 1 pivots on row 2, [4 2 2]:
     * [2 5 7] - 0.5 [4 2 2] = [. 4 6], [1 2 3] - 0.25 [4 2 2] = [. 1.5 2.5].
     * Step 2 pivots on 4 (no swap): l = 0.375, 2.5 - 0.375 * 6 = 0.25. */
    {
        dkf_real_t a3[9] = {1, 2, 3, 2, 5, 7, 4, 2, 2}, lu3[9];
        dkf_mat_t A3 = DKF_MAT(3, 3, a3), LU3 = DKF_MAT(3, 3, lu3);
        const dkf_real_t want3[9] = {4, 2, 2, (dkf_real_t)0.5, 4, 6,
                                     (dkf_real_t)0.25, (dkf_real_t)0.375, (dkf_real_t)0.25};
        assert_int_equal(dkf_mat_lu(&LU3, piv, &A3, rw), DKF_OK);
        assert_memory_equal(lu3, want3, sizeof lu3);
        assert_true(piv[0] == 2 && piv[1] == 1 && piv[2] == 0);
    }
}

/* P^T |L||U| (the Theorem 9.3/9.4 bound matrix, in A's row order) and
 * P A - L U in long double. */
static void lu_residual(long double *R, double *M, const double *A, const double *LU,
                        const size_t *p, size_t n)
{
    size_t i, j, k;
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) {
            long double acc = A[p[i] * n + j];
            double b = 0;
            for (k = 0; k <= (i < j ? i : j); ++k) {
                const double lik = k == i ? 1.0 : LU[i * n + k];
                acc -= (long double)lik * LU[k * n + j];
                b += fabs(lik * LU[k * n + j]);
            }
            R[i * n + j] = acc;
            M[p[i] * n + j] = b;
        }
}

/* One random general A of size n and condition cond: lu, lu_solve and
 * inverse against their bounds, aliasing. */
static void lu_trial(test_rng_t *g, size_t n, double cond)
{
    static long double res[MAXSQ];
    static double M[MAXSQ];
    size_t i, j;
    dkf_mat_t A = DKF_MAT(n, n, ra), LU = DKF_MAT(n, n, rl),
              B = DKF_MAT(n, NRHS, rb), X = DKF_MAT(n, NRHS, rx),
              Inv = DKF_MAT(n, n, ry);
    double r;
    unsigned char seen[MAXN];
    general_pair(g, ra, da, n, cond);
    assert_int_equal(dkf_mat_lu(&LU, piv, &A, rw), DKF_OK);
    test_to_double(dl, rl, n * n);
    /* piv is a permutation; partial pivoting keeps |L_ij| <= 1 */
    memset(seen, 0, sizeof seen);
    for (i = 0; i < n; ++i) {
        assert_true(piv[i] < n && !seen[piv[i]]);
        seen[piv[i]] = 1;
        for (j = 0; j < i; ++j) assert_true(fabs(dl[i * n + j]) <= 1.0);
    }
    /* Theorem 9.3: P A + dA = L U, |dA| <= gamma_n |L||U|; +1 for
     * the reciprocal pivot. */
    lu_residual(res, M, da, dl, piv, n);
    {
        /* M is in A's row order; compare with res in P A's order */
        static double Mp[MAXSQ];
        for (i = 0; i < n; ++i)
            for (j = 0; j < n; ++j) Mp[i * n + j] = M[piv[i] * n + j];
        r = ratio_to_bound(res, Mp, n * n, (double)(n + 1));
    }
    update(&worst_lu, r);
    assert_true(r <= 1.0);

    /* Theorem 9.4: (A + dA) X = B, |dA| <= gamma_{3n} P^T|L||U|;
     * +2 for the reciprocals. */
    rand_pair(g, rb, db, n, NRHS);
    assert_int_equal(dkf_mat_lu_solve(&X, &LU, piv, &B), DKF_OK);
    test_to_double(dx, rx, n * NRHS);
    solve_residual(res, dbound, da, dx, db, M, n, NRHS);
    r = ratio_to_bound(res, dbound, n * NRHS, (double)(3 * n + 2));
    update(&worst_lu_solve, r);
    assert_true(r <= 1.0);
    {
        dkf_mat_t Y = DKF_MAT(n, NRHS, ry);
        memcpy(ry, rb, n * NRHS * sizeof(dkf_real_t));
        assert_int_equal(dkf_mat_lu_solve(&Y, &LU, piv, &Y), DKF_OK);
        assert_memory_equal(ry, rx, n * NRHS * sizeof(dkf_real_t));
    }

    /* Inverse, column by column: column j solves A x = e_j, so
     * Theorem 9.4 bounds |A X - I| <= gamma_{3n+2} P^T|L||U||X|
     * componentwise. Normwise that is ~ n EPS cond: with
     * ||A||_2 = 1, ||A X - I|| <= c n EPS ||X|| ~ c n EPS cond. */
    test_fill(ry, n * n, SENTINEL);
    assert_int_equal(dkf_mat_inverse(&Inv, &A, piv2, rw), DKF_OK);
    assert_memory_equal(piv2, piv, n * sizeof(size_t));
    test_to_double(dx, ry, n * n);
    for (i = 0; i < n * n; ++i) db[i] = (i / n == i % n) ? 1.0 : 0.0;
    solve_residual(res, dbound, da, dx, db, M, n, n);
    r = ratio_to_bound(res, dbound, n * n, (double)(3 * n + 2));
    update(&worst_inv_comp, r);
    assert_true(r <= 1.0);
    {
        double worst = 0;
        for (i = 0; i < n * n; ++i)
            if (fabsl(res[i]) > worst) worst = (double)fabsl(res[i]);
        r = worst / ((double)n * TEST_EPS * cond);
        update(&worst_inv_norm, r);
        assert_true(r <= 2.0);
    }
    /* in place */
    assert_int_equal(dkf_mat_inverse(&A, &A, piv2, rw), DKF_OK);
    assert_memory_equal(ra, ry, n * n * sizeof(dkf_real_t));
    /* LU may alias A */
    general_pair(g, ra, da, n, cond);
    assert_int_equal(dkf_mat_lu(&LU, piv, &A, rw), DKF_OK);
    assert_int_equal(dkf_mat_lu(&A, piv2, &A, rw), DKF_OK);
    assert_memory_equal(ra, rl, n * n * sizeof(dkf_real_t));
    assert_memory_equal(piv2, piv, n * sizeof(size_t));
}

static void test_lu_residuals(void **state)
{
    (void)state;
    sweep(22, lu_trial);
    print_message("lu: worst |PA - LU| / ((n+1) EPS |L||U|) = %.3g\n", worst_lu);
    print_message("lu_solve: worst |B - AX| / ((3n+2) EPS P^T|L||U||X|) = %.3g\n",
                  worst_lu_solve);
    print_message("inverse: worst componentwise ratio %.3g, ||AX - I||_max / (n EPS cond) = %.3g\n",
                  worst_inv_comp, worst_inv_norm);
}

static void test_lu_errors(void **state)
{
    /* exactly singular: zero, a repeated row, a zero column, rank 2 of 3 */
    dkf_real_t zero[4] = {0, 0, 0, 0}, dup[9] = {1, 2, 3, 4, 5, 6, 1, 2, 3},
               zcol[9] = {1, 0, 3, 4, 0, 6, 7, 0, 9}, rank2[9] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
    dkf_real_t good[9] = {2, 1, 0, 1, 3, 1, 0, 1, 4}, tiny[4] = {1, 0, 0, 0};
    dkf_mat_t LU = DKF_MAT(3, 3, rl), LU2 = DKF_MAT(2, 2, rl), Inv = DKF_MAT(3, 3, ry),
              Inv2 = DKF_MAT(2, 2, ry);
    dkf_mat_t Z = DKF_MAT(2, 2, zero), D = DKF_MAT(3, 3, dup), C = DKF_MAT(3, 3, zcol),
              K = DKF_MAT(3, 3, rank2), G = DKF_MAT(3, 3, good), T = DKF_MAT(2, 2, tiny),
              R = DKF_MAT(2, 3, ra);
    size_t pos, keep_piv[MAXN];
    (void)state;
    test_fill(rl, 16, SENTINEL);
    test_fill(ry, 16, SENTINEL);
    for (pos = 0; pos < MAXN; ++pos) piv[pos] = piv2[pos] = 777;
    memcpy(keep_piv, piv, sizeof keep_piv);
#define ASSERT_LU_FAILS(st, Amat, LUmat) \
    do { \
        TEST_FAILS_UNTOUCHED(snap, st, dkf_mat_lu(&LUmat, piv, &Amat, rw), rl, 16); \
        assert_memory_equal(piv, keep_piv, sizeof keep_piv); \
    } while (0)
    ASSERT_LU_FAILS(DKF_ERR_SINGULAR, Z, LU2);
    ASSERT_LU_FAILS(DKF_ERR_SINGULAR, D, LU);
    ASSERT_LU_FAILS(DKF_ERR_SINGULAR, C, LU);
    /* rank2's last pivot is O(eps), far below 3 * eps * 9 */
    ASSERT_LU_FAILS(DKF_ERR_SINGULAR, K, LU);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_SINGULAR, dkf_mat_inverse(&Inv, &K, piv2, rw), ry, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_SINGULAR, dkf_mat_inverse(&Inv2, &Z, piv2, rw), ry, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_SINGULAR, dkf_mat_inverse(&D, &D, piv2, rw), dup, 9);
    /* the threshold n * eps * max|A| itself: diag(1, 2 EPS) with n = 2 sits
     * on it (SINGULAR, the test is <=), diag(1, 4 EPS) is above it */
    tiny[3] = 2 * DKF_REAL_EPSILON;
    ASSERT_LU_FAILS(DKF_ERR_SINGULAR, T, LU2);
    tiny[3] = 4 * DKF_REAL_EPSILON;
    assert_int_equal(dkf_mat_lu(&LU2, piv, &T, rw), DKF_OK);
    /* the threshold scales with max|A| */
    tiny[0] = 1024;
    tiny[3] = 1024 * 2 * DKF_REAL_EPSILON;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_SINGULAR, dkf_mat_lu(&LU2, piv2, &T, rw), rl, 16);
    memcpy(keep_piv, piv, sizeof keep_piv);

    /* NaN / Inf anywhere (LU reads all of A) */
    for (pos = 0; pos < 9; ++pos) {
        const dkf_real_t keep = good[pos];
        good[pos] = pos % 2 ? (dkf_real_t)NAN : (dkf_real_t)-INFINITY;
        ASSERT_LU_FAILS(DKF_ERR_NONFINITE, G, LU);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_inverse(&Inv, &G, piv2, rw), ry, 16);
        good[pos] = keep;
    }
    /* NONFINITE outranks singularity */
    dup[8] = (dkf_real_t)INFINITY;
    ASSERT_LU_FAILS(DKF_ERR_NONFINITE, D, LU);
    dup[8] = 3;

    /* arguments */
    ASSERT_LU_FAILS(DKF_ERR_DIM, R, LU);
    ASSERT_LU_FAILS(DKF_ERR_DIM, G, LU2);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_inverse(&Inv2, &G, piv2, rw), ry, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_lu(&LU, NULL, &G, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_lu(&LU, piv, &G, NULL), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_lu(&LU, piv, NULL, rw), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_inverse(&Inv, &G, NULL, rw), ry, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_inverse(&Inv, &G, piv2, NULL), ry, 16);
    assert_int_equal(dkf_mat_lu(NULL, piv, &G, rw), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_inverse(NULL, &G, piv2, rw), DKF_ERR_NULL);
    LU.rows = LU.cols = DKF_MAX_DIM + 1;
    ASSERT_LU_FAILS(DKF_ERR_CAPACITY, G, LU);
    LU.rows = LU.cols = 0;
    ASSERT_LU_FAILS(DKF_ERR_CAPACITY, G, LU);
    LU.rows = LU.cols = 3;
    Inv.cols = DKF_MAX_DIM + 1;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_inverse(&Inv, &G, piv2, rw), ry, 16);
    Inv.cols = 3;
    /* workspace over the output or the input, partial overlap of LU and A */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_lu(&LU, piv, &G, rl + 8), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_lu(&LU, piv, &G, good + 8), rl, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_inverse(&Inv, &G, piv2, ry + 8), ry, 16);
    {
        dkf_mat_t Gs = DKF_MAT(3, 3, rl), Gp = DKF_MAT(3, 3, rl + 3);
        memcpy(rl, good, sizeof good);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_lu(&Gp, piv, &Gs, rw), rl, 16);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_inverse(&Gp, &Gs, piv2, rw), rl, 16);
    }
#undef ASSERT_LU_FAILS
}

static void test_lu_solve_errors(void **state)
{
    dkf_real_t good[9] = {2, 1, 0, 1, 3, 1, 0, 1, 4}, lu[9];
    dkf_mat_t G = DKF_MAT(3, 3, good), LU = DKF_MAT(3, 3, lu), B = DKF_MAT(3, 2, rb),
              X = DKF_MAT(3, 2, rx), X4 = DKF_MAT(4, 2, rx), B4 = DKF_MAT(4, 2, rb),
              R = DKF_MAT(3, 2, ra);
    size_t p[3];
    (void)state;
    assert_int_equal(dkf_mat_lu(&LU, piv, &G, rw), DKF_OK);
    memcpy(p, piv, sizeof p);
    test_fill(rb, 8, 1);
    test_fill(rx, 8, SENTINEL);
    /* piv must be a permutation of 0..n-1 */
    p[1] = 3;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ARG, dkf_mat_lu_solve(&X, &LU, p, &B), rx, 8);
    p[1] = p[0];
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ARG, dkf_mat_lu_solve(&X, &LU, p, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_lu_solve(&X, &LU, NULL, &B), rx, 8);
    /* exact zero on U's diagonal */
    lu[8] = 0;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_SINGULAR, dkf_mat_lu_solve(&X, &LU, piv, &B), rx, 8);
    /* non-finite factor or right-hand side */
    lu[8] = (dkf_real_t)NAN;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_lu_solve(&X, &LU, piv, &B), rx, 8);
    assert_int_equal(dkf_mat_lu(&LU, piv, &G, rw), DKF_OK);
    lu[1] = (dkf_real_t)INFINITY; /* in U's strict upper part: still read */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_lu_solve(&X, &LU, piv, &B), rx, 8);
    assert_int_equal(dkf_mat_lu(&LU, piv, &G, rw), DKF_OK);
    rb[3] = (dkf_real_t)-INFINITY;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_lu_solve(&X, &LU, piv, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_mat_lu_solve(&B, &LU, piv, &B), rb, 6);
    rb[3] = 1;
    /* shapes, aliasing, NULL, capacity */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_lu_solve(&X4, &LU, piv, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_lu_solve(&X4, &LU, piv, &B4), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_lu_solve(&X, &R, piv, &B), rx, 8);
    {
        dkf_mat_t XL = DKF_MAT(3, 3, lu), Bp = DKF_MAT(3, 2, rb + 2);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_lu_solve(&XL, &LU, piv, &XL), lu, 9);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_lu_solve(&Bp, &LU, piv, &B), rb, 8);
    }
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_lu_solve(&X, NULL, piv, &B), rx, 8);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_lu_solve(&X, &LU, piv, NULL), rx, 8);
    assert_int_equal(dkf_mat_lu_solve(NULL, &LU, piv, &B), DKF_ERR_NULL);
    B.cols = DKF_MAX_DIM + 1;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_lu_solve(&X, &LU, piv, &B), rx, 8);
    B.cols = 2;
    LU.rows = 0;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_lu_solve(&X, &LU, piv, &B), rx, 8);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_chol_closed_form),
        cmocka_unit_test(test_chol_residuals),
        cmocka_unit_test(test_chol_solve_textbook_order),
        cmocka_unit_test(test_chol_errors),
        cmocka_unit_test(test_chol_solve_inverse_errors),
        cmocka_unit_test(test_lu_closed_form),
        cmocka_unit_test(test_lu_residuals),
        cmocka_unit_test(test_lu_errors),
        cmocka_unit_test(test_lu_solve_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
