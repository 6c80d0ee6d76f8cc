/*
 * One-sided Jacobi SVD and its clients (dkf_mat_svd, _pinv, _rank, _frd):
 * prescribed singular values, factor residuals and orthonormality, the
 * Moore-Penrose conditions, exact ranks, the tolerance rule, the
 * full-rank-decomposition golden vectors (tests/vectors/uif/frd.json),
 * and error statuses with untouched outputs.
 *
 * Tolerances, with q = max(r, c) and eps the library's unit roundoff:
 *  - The SVD is backward stable: U S V^T = A + E, ||E|| <= p(q) eps ||A||,
 *    U and V orthonormal to p(q) eps (each sweep's rotations are
 *    orthogonal to rounding; the stopping rule leaves |cos(g_i, g_j)| <=
 *    q eps). By Weyl, |s_i - s_i*| <= ||E||_2. We assert p(q) = 10 q:
 *    SVD_TOL = 10 q eps, relative to sigma_max (absolute accuracy: the
 *    test matrices are not graded, so no relative accuracy is claimed for
 *    small singular values). Rounding A to the real type adds at most
 *    sqrt(r c) eps/2 max|A| <= q eps sigma_max/2, inside that.
 *  - Quantities that divide by the smallest kept singular value (A+ and
 *    the projector T^T T) carry a further factor kappa = s_1 / s_rank
 *    (Wedin's sin-theta theorem: subspaces move by ||E|| / s_rank).
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
#define WORKN DKF_MAT_SVD_WORK(MAXN, MAXN)
#define SENTINEL ((dkf_real_t)-7.25)

typedef struct {
    size_t r, c;
} shape_t;

static double svd_tol(size_t r, size_t c) { return 10.0 * (double)(r > c ? r : c) * TEST_EPS; }
static size_t min_sz(size_t a, size_t b) { return a < b ? a : b; }




/* max |A - U diag(s) V^T|, U r x k, V c x k. */
static double recon_err(const dkf_real_t *A, const dkf_real_t *U, const dkf_real_t *s,
                        const dkf_real_t *V, size_t r, size_t c)
{
    size_t k = min_sz(r, c), i, j, l;
    double m = 0.0;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) {
            double acc = (double)A[i * c + j];
            for (l = 0; l < k; ++l) acc -= (double)U[i * k + l] * (double)s[l] * (double)V[j * k + l];
            if (fabs(acc) > m) m = fabs(acc);
        }
    return m;
}

static int cmp_desc(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x < y) - (x > y);
}

/* Worst errors over the SVD tests, printed at the end of each. */
static double worst_s, worst_recon, worst_orth;

/* Factorises the real matrix A and checks every documented property of
 * the result against the prescribed singular values sref (any order). */
static void check_svd(const dkf_real_t *A, size_t r, size_t c, const double *sref_in)
{
    static dkf_real_t U[MAXN * MAXN], V[MAXN * MAXN], U2[MAXN * MAXN], V2[MAXN * MAXN],
        work[WORKN];
    dkf_real_t s[MAXN], s2[MAXN];
    double sref[MAXN];
    size_t k = min_sz(r, c), j;
    double tol = svd_tol(r, c), smax, e;
    dkf_mat_t mA = DKF_MAT(r, c, (dkf_real_t *)(void *)A), mU = DKF_MAT(r, k, U),
              mV = DKF_MAT(c, k, V), mU2 = DKF_MAT(r, k, U2), mV2 = DKF_MAT(c, k, V2);

    memcpy(sref, sref_in, k * sizeof(double));
    qsort(sref, k, sizeof(double), cmp_desc);
    smax = sref[0];

    assert_int_equal(dkf_mat_svd(&mU, s, &mV, &mA, work), DKF_OK);
    for (j = 0; j < k; ++j) {
        assert_true(s[j] >= (dkf_real_t)0);
        if (j > 0) assert_true(s[j] <= s[j - 1]);
        e = fabs((double)s[j] - sref[j]);
        if (smax > 0.0) e /= smax;
        if (e > worst_s) worst_s = e;
        assert_true(e <= tol);
    }
    e = recon_err(A, U, s, V, r, c);
    if (smax > 0.0) e /= smax;
    if (e > worst_recon) worst_recon = e;
    assert_true(e <= tol);
    e = test_orth_err(U, r, k);
    if (e > worst_orth) worst_orth = e;
    assert_true(e <= tol);
    e = test_orth_err(V, c, k);
    if (e > worst_orth) worst_orth = e;
    assert_true(e <= tol);

    /* Optional factors: the sweeps do not depend on what is wanted, so the
     * same values and vectors must come out bit for bit. */
    assert_int_equal(dkf_mat_svd(NULL, s2, NULL, &mA, work), DKF_OK);
    assert_memory_equal(s, s2, k * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_svd(&mU2, s2, NULL, &mA, work), DKF_OK);
    assert_memory_equal(U, U2, r * k * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_svd(NULL, s2, &mV2, &mA, work), DKF_OK);
    assert_memory_equal(V, V2, c * k * sizeof(dkf_real_t));
}

static const shape_t svd_shapes[] = {{1, 1},  {1, 5},   {5, 1},   {3, 3},   {6, 4},
                                     {4, 6},  {10, 10}, {20, 7},  {7, 20},  {48, 48},
                                     {48, 30}, {30, 48}, {2, 48}, {48, 2}};
#define NSVD (sizeof svd_shapes / sizeof svd_shapes[0])

/* Builds A = U diag(s) V^T in double (test support) and rounds it. */
static void make_matrix(test_rng_t *g, dkf_real_t *A, size_t r, size_t c, const double *s)
{
    static double Ad[MAXN * MAXN];
    test_mat_with_singular_values(g, Ad, r, c, s);
    test_to_real(A, Ad, r * c);
}

typedef enum { SV_RANDOM, SV_DEFICIENT, SV_ILLCOND, SV_EQUAL, SV_ZERO } sv_kind_t;

/* Ill-conditioning used for the SVD: 1e8 in double leaves the small values
 * 1e8 eps ~ 2e-8 above the absolute error floor; float gets 1e3 for the
 * same reason (1e3 * 1.2e-7 ~ 1e-4). */
#if DKF_USE_FLOAT
#define ILL_COND 1e3
#else
#define ILL_COND 1e8
#endif

/* Prescribed singular values, deliberately unsorted (the routine sorts). */
static void make_sv(test_rng_t *g, double *s, size_t k, sv_kind_t kind)
{
    size_t i;
    for (i = 0; i < k; ++i) {
        switch (kind) {
        case SV_RANDOM: s[i] = 1.0 + 9.0 * test_rng_uniform(g); break;
        case SV_DEFICIENT: s[i] = (i % 2 == 0) ? 1.0 + (double)i : 0.0; break;
        case SV_ILLCOND:
            /* logspaced in [1/cond, 1], reversed order */
            s[i] = k > 1 ? pow(ILL_COND, -(double)(k - 1 - i) / (double)(k - 1)) : 1.0;
            break;
        case SV_EQUAL: s[i] = 2.0; break;
        case SV_ZERO: s[i] = 0.0; break;
        }
    }
}

static void run_svd_kind(sv_kind_t kind, uint64_t seed, const char *name)
{
    static dkf_real_t A[MAXN * MAXN];
    double s[MAXN];
    test_rng_t g;
    size_t i;
    test_rng_seed(&g, seed);
    worst_s = worst_recon = worst_orth = 0.0;
    for (i = 0; i < NSVD; ++i) {
        size_t r = svd_shapes[i].r, c = svd_shapes[i].c;
        make_sv(&g, s, min_sz(r, c), kind);
        make_matrix(&g, A, r, c, s);
        check_svd(A, r, c, s);
    }
    print_message("svd %-10s worst |s-s*|/s1 %.2e  |A-USV'|/s1 %.2e  |Q'Q-I| %.2e  (eps %.2e)\n",
                  name, worst_s, worst_recon, worst_orth, TEST_EPS);
}

static void test_svd_random(void **state)
{
    (void)state;
    run_svd_kind(SV_RANDOM, 1, "random");
}
static void test_svd_rank_deficient(void **state)
{
    (void)state;
    run_svd_kind(SV_DEFICIENT, 2, "deficient");
}
static void test_svd_ill_conditioned(void **state)
{
    (void)state;
    run_svd_kind(SV_ILLCOND, 3, "ill-cond");
}
static void test_svd_equal_values(void **state)
{
    (void)state;
    run_svd_kind(SV_EQUAL, 4, "equal");
}
static void test_svd_zero(void **state)
{
    (void)state;
    run_svd_kind(SV_ZERO, 5, "zero");
}

/* Exact zero rows and columns and a huge/tiny scale: the zero columns of G
 * are completed to an orthonormal basis, and the 1/max|A| prescaling keeps
 * squared norms in range (1e150^2 would overflow a double, 1e30^2 a float). */
static void test_svd_structure_and_scale(void **state)
{
    static dkf_real_t A[7 * 5];
    double s[5];
    /* far enough out that squares of the raw entries would under/overflow */
    const double scales[] = {1.0, DKF_USE_FLOAT ? 1e-30 : 1e-170, DKF_USE_FLOAT ? 1e30 : 1e170};
    test_rng_t g;
    size_t i, j, sc;
    (void)state;
    test_rng_seed(&g, 6);
    for (sc = 0; sc < 3; ++sc) {
        /* a 7 x 5 with rows 1, 4 and columns 0, 3 zero: rank <= 3 */
        double Ad[7 * 5];
        test_rand_gauss(&g, Ad, 7, 5);
        for (i = 0; i < 7; ++i)
            for (j = 0; j < 5; ++j)
                if (i == 1 || i == 4 || j == 0 || j == 3) Ad[i * 5 + j] = 0.0;
        for (i = 0; i < 35; ++i) Ad[i] *= scales[sc];
        test_to_real(A, Ad, 35);
        /* no prescribed values here: check the invariant
         * sum s_i^2 = ||A||_F^2 (relative error SVD_TOL) instead */
        {
            static dkf_real_t U[7 * 5], V[5 * 5], work[DKF_MAT_SVD_WORK(7, 5)];
            dkf_real_t sv[5];
            dkf_mat_t mA = DKF_MAT(7, 5, A), mU = DKF_MAT(7, 5, U), mV = DKF_MAT(5, 5, V);
            double fro = 0.0, ssum = 0.0, tol = svd_tol(7, 5);
            assert_int_equal(dkf_mat_svd(&mU, sv, &mV, &mA, work), DKF_OK);
            /* unscaled first: the squares would underflow in the test too */
            for (i = 0; i < 35; ++i) fro += pow((double)A[i] / scales[sc], 2.0);
            for (i = 0; i < 5; ++i) ssum += pow((double)sv[i] / scales[sc], 2.0);
            assert_true(fabs(ssum - fro) <= tol * fro);
            assert_true(sv[3] == (dkf_real_t)0 && sv[4] == (dkf_real_t)0);
            assert_true(test_orth_err(U, 7, 5) <= tol);
            assert_true(test_orth_err(V, 5, 5) <= tol);
            assert_true(recon_err(A, U, sv, V, 7, 5) <= tol * (double)sv[0]);
        }
        /* and the transposed shape */
        {
            static dkf_real_t At[5 * 7], U[5 * 5], V[7 * 5], work[DKF_MAT_SVD_WORK(5, 7)];
            dkf_real_t sv[5];
            dkf_mat_t mA = DKF_MAT(5, 7, At), mU = DKF_MAT(5, 5, U), mV = DKF_MAT(7, 5, V);
            double tol = svd_tol(7, 5);
            for (i = 0; i < 7; ++i)
                for (j = 0; j < 5; ++j) At[j * 7 + i] = A[i * 5 + j];
            assert_int_equal(dkf_mat_svd(&mU, sv, &mV, &mA, work), DKF_OK);
            assert_true(sv[3] == (dkf_real_t)0 && sv[4] == (dkf_real_t)0);
            assert_true(test_orth_err(U, 5, 5) <= tol);
            assert_true(test_orth_err(V, 7, 5) <= tol);
            assert_true(recon_err(At, U, sv, V, 5, 7) <= tol * (double)sv[0]);
        }
    }
    /* singular values of a scaled random matrix scale exactly with it */
    {
        static dkf_real_t U[6 * 4], V[4 * 4], work[DKF_MAT_SVD_WORK(6, 4)];
        dkf_real_t sv[4];
        dkf_mat_t mA = DKF_MAT(6, 4, A), mU = DKF_MAT(6, 4, U), mV = DKF_MAT(4, 4, V);
        const double big = DKF_USE_FLOAT ? 1e30 : 1e300;
        make_sv(&g, s, 4, SV_RANDOM);
        {
            double s2[4];
            for (i = 0; i < 4; ++i) s2[i] = s[i] * big;
            make_matrix(&g, A, 6, 4, s2);
            qsort(s2, 4, sizeof(double), cmp_desc);
            assert_int_equal(dkf_mat_svd(&mU, sv, &mV, &mA, work), DKF_OK);
            for (i = 0; i < 4; ++i) assert_true(fabs((double)sv[i] - s2[i]) <= svd_tol(6, 4) * s2[0]);
            assert_true(test_orth_err(U, 6, 4) <= svd_tol(6, 4));
        }
    }
}

/* ---- pseudo-inverse ----------------------------------------------------- */

/* The four Moore-Penrose conditions for X = pinv(A), in double:
 *   |A X A - A| <= t kappa s1 + s_drop,  |X A X - X| <= t kappa |X|_2,
 *   |A X - (A X)^T| <= t kappa,  |X A - (X A)^T| <= t kappa,
 * t = SVD_TOL, kappa = s1 / s_rank, |X|_2 = 1/s_rank. The SVD's backward
 * error E (|E| <= t s1, see top) enters as E X or X E, and forming
 * X = sum v_j u_j^T / s_j in floating point perturbs it by dX ~ t / s_rank,
 * which A dX A turns into t kappa s1. s_drop is the largest singular value
 * the tolerance discarded: A X A misses it by construction. */
static double worst_mp; /* worst (residual / bound) over the four conditions */

static void mp_assert(double residual, double bound)
{
    if (residual / bound > worst_mp) worst_mp = residual / bound;
    assert_true(residual <= bound);
}

static void check_moore_penrose(const dkf_real_t *A, const dkf_real_t *X, size_t r, size_t c,
                                double s1, double srank, double s_drop)
{
    static double Ad[MAXN * MAXN], Xd[MAXN * MAXN], AX[MAXN * MAXN], XA[MAXN * MAXN],
        T[MAXN * MAXN];
    double t = svd_tol(r, c), kappa = s1 / srank, m;
    size_t i, j;
    test_to_double(Ad, A, r * c);
    test_to_double(Xd, X, r * c);
    test_ref_mul(AX, Ad, Xd, r, c, r);
    test_ref_mul(XA, Xd, Ad, c, r, c);
    /* 1: A X A = A */
    test_ref_mul(T, AX, Ad, r, r, c);
    m = 0.0;
    for (i = 0; i < r * c; ++i) m = fmax(m, fabs(T[i] - Ad[i]));
    mp_assert(m, t * kappa * s1 + s_drop);
    /* 2: X A X = X */
    test_ref_mul(T, XA, Xd, c, c, r);
    m = 0.0;
    for (i = 0; i < r * c; ++i) m = fmax(m, fabs(T[i] - Xd[i]));
    mp_assert(m, t * kappa / srank);
    /* 3, 4: A X and X A symmetric */
    m = 0.0;
    for (i = 0; i < r; ++i)
        for (j = 0; j < r; ++j) m = fmax(m, fabs(AX[i * r + j] - AX[j * r + i]));
    mp_assert(m, t * kappa);
    m = 0.0;
    for (i = 0; i < c; ++i)
        for (j = 0; j < c; ++j) m = fmax(m, fabs(XA[i * c + j] - XA[j * c + i]));
    mp_assert(m, t * kappa);
}

/* ||X||_F^2 = sum over kept singular values of 1/s_i^2, an exact identity
 * for the pseudo-inverse of the truncated SVD; relative error t kappa^2. */
static void check_pinv_frobenius(const dkf_real_t *X, size_t n, const double *s, size_t rank,
                                 double t)
{
    double fx = 0.0, fs = 0.0;
    size_t i;
    for (i = 0; i < n; ++i) fx += (double)X[i] * (double)X[i];
    for (i = 0; i < rank; ++i) fs += 1.0 / (s[i] * s[i]);
    assert_true(fabs(fx - fs) <= t * s[0] * s[0] / (s[rank - 1] * s[rank - 1]) * fs);
}

static void test_pinv_moore_penrose(void **state)
{
    static const struct {
        size_t r, c, rank;
        double s[6];
    } cases[] = {
        {8, 5, 5, {1.0, 0.3, 0.1, 0.03, 0.01}},   /* tall, kappa 100 */
        {5, 8, 5, {0.01, 1.0, 0.03, 0.1, 0.3}},   /* wide, unsorted */
        {6, 6, 6, {1.0, 0.5, 0.25, 0.1, 0.05, 0.01}},
        {7, 5, 3, {4.0, 0.0, 2.0, 0.0, 1.0}},     /* rank-deficient */
        {5, 7, 3, {4.0, 2.0, 1.0, 0.0, 0.0}},
        {6, 6, 2, {1.0, 0.0, 0.0, 0.0, 0.5, 0.0}},
        {1, 1, 1, {2.0}},
        {1, 4, 1, {3.0}},
        {4, 1, 1, {0.5}},
    };
    static dkf_real_t A[MAXN * MAXN], X[MAXN * MAXN], work[WORKN];
    test_rng_t g;
    size_t i;
    (void)state;
    test_rng_seed(&g, 11);
    for (i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        size_t r = cases[i].r, c = cases[i].c, k = min_sz(r, c), rank = 99;
        double s[6];
        dkf_mat_t mA = DKF_MAT(r, c, A), mX = DKF_MAT(c, r, X);
        memcpy(s, cases[i].s, sizeof s);
        make_matrix(&g, A, r, c, s);
        qsort(s, k, sizeof(double), cmp_desc);
        assert_int_equal(dkf_mat_pinv(&mX, &rank, &mA, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
        assert_int_equal(rank, cases[i].rank);
        check_moore_penrose(A, X, r, c, s[0], s[rank - 1], 0.0);
        check_pinv_frobenius(X, r * c, s, rank, svd_tol(r, c));
        /* rank pointer optional */
        assert_int_equal(dkf_mat_pinv(&mX, NULL, &mA, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
    }
    print_message("pinv: worst Moore-Penrose residual / bound %.2e\n", worst_mp);
}

static void test_pinv_zero(void **state)
{
    static dkf_real_t A[3 * 4], X[4 * 3], work[DKF_MAT_PINV_WORK(3, 4)];
    dkf_mat_t mA = DKF_MAT(3, 4, A), mX = DKF_MAT(4, 3, X);
    size_t rank = 99, i;
    (void)state;
    test_fill(A, 12, 0);
    test_fill(X, 12, SENTINEL);
    assert_int_equal(dkf_mat_pinv(&mX, &rank, &mA, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
    assert_int_equal(rank, 0);
    for (i = 0; i < 12; ++i) assert_true(X[i] == (dkf_real_t)0);
}

/* A singular value just above / below an explicit tol. The computed s_4
 * is within SVD_TOL s_1 of 1e-3 (Weyl), so tol = s_4 (1 +- margin) with
 * margin = 100 SVD_TOL s_1 / s_4 decides unambiguously (double 1.2e-9,
 * float 0.7). */
static void test_pinv_tolerance(void **state)
{
    static dkf_real_t A[6 * 4], X[4 * 6], work[DKF_MAT_PINV_WORK(6, 4)];
    double s[4] = {1.0, 0.5, 0.25, 1e-3};
    const double margin = 100.0 * svd_tol(6, 4) / s[3];
    dkf_mat_t mA = DKF_MAT(6, 4, A), mX = DKF_MAT(4, 6, X);
    test_rng_t g;
    size_t rank;
    (void)state;
    assert_true(margin < 1.0);
    test_rng_seed(&g, 12);
    make_matrix(&g, A, 6, 4, s);

    assert_int_equal(dkf_mat_pinv(&mX, &rank, &mA, (dkf_real_t)(s[3] * (1.0 + margin)), work),
                     DKF_OK);
    assert_int_equal(rank, 3);
    check_pinv_frobenius(X, 24, s, 3, svd_tol(6, 4));
    check_moore_penrose(A, X, 6, 4, 1.0, s[2], s[3]);
    assert_int_equal(dkf_mat_rank(&rank, &mA, (dkf_real_t)(s[3] * (1.0 + margin)), work), DKF_OK);
    assert_int_equal(rank, 3);

    assert_int_equal(dkf_mat_pinv(&mX, &rank, &mA, (dkf_real_t)(s[3] * (1.0 - margin)), work),
                     DKF_OK);
    assert_int_equal(rank, 4);
    check_pinv_frobenius(X, 24, s, 4, svd_tol(6, 4));
    check_moore_penrose(A, X, 6, 4, 1.0, s[3], 0.0);
    assert_int_equal(dkf_mat_rank(&rank, &mA, (dkf_real_t)(s[3] * (1.0 - margin)), work), DKF_OK);
    assert_int_equal(rank, 4);

    /* tol = 0 keeps every nonzero value; a huge tol keeps none */
    assert_int_equal(dkf_mat_rank(&rank, &mA, (dkf_real_t)0, work), DKF_OK);
    assert_int_equal(rank, 4);
    assert_int_equal(dkf_mat_pinv(&mX, &rank, &mA, (dkf_real_t)2, work), DKF_OK);
    assert_int_equal(rank, 0);
    /* the default tol q eps s1 ~ 1e-15 / 7e-7 keeps 1e-3 */
    assert_int_equal(dkf_mat_rank(&rank, &mA, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
    assert_int_equal(rank, 4);
}

/* ---- rank --------------------------------------------------------------- */

/* Exact ranks with the default tolerance max(r, c) eps s1: the kept values
 * are >= 1 (>= s1/48), the zero ones come out at the rounding level of A,
 * sqrt(r c) eps/2 max|A| plus the SVD's own error, both well below q eps s1
 * for these random (unstructured) perturbations. */
static void test_rank_exact(void **state)
{
    static const shape_t shapes[] = {{1, 1}, {3, 3}, {6, 4}, {4, 6}, {12, 12}, {48, 20}, {20, 48},
                                     {48, 48}};
    static dkf_real_t A[MAXN * MAXN], work[WORKN];
    test_rng_t g;
    size_t i, want, k;
    (void)state;
    test_rng_seed(&g, 21);
    for (i = 0; i < sizeof shapes / sizeof shapes[0]; ++i) {
        size_t r = shapes[i].r, c = shapes[i].c, got = 999;
        dkf_mat_t mA = DKF_MAT(r, c, A);
        k = min_sz(r, c);
        for (want = 0; want <= k; want += (k > 8 ? 5 : 1)) {
            double s[MAXN];
            size_t j;
            for (j = 0; j < k; ++j) s[j] = j < want ? 1.0 + (double)j : 0.0;
            make_matrix(&g, A, r, c, s);
            assert_int_equal(dkf_mat_rank(&got, &mA, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
            assert_int_equal(got, want);
        }
    }
    /* classic small integer matrices */
    {
        static dkf_real_t m123[9] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
        static dkf_real_t ones[4 * 6];
        static dkf_real_t eye[5 * 5];
        size_t got;
        dkf_mat_t M = DKF_MAT(3, 3, m123), O = DKF_MAT(4, 6, ones), E = DKF_MAT(5, 5, eye);
        test_fill(ones, 24, 1);
        test_fill(eye, 25, 0);
        for (i = 0; i < 5; ++i) eye[i * 6] = 1;
        assert_int_equal(dkf_mat_rank(&got, &M, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
        assert_int_equal(got, 2);
        assert_int_equal(dkf_mat_rank(&got, &O, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
        assert_int_equal(got, 1);
        assert_int_equal(dkf_mat_rank(&got, &E, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
        assert_int_equal(got, 5);
    }
}

/* ---- full-rank decomposition: golden vectors ----------------------------- */

/* Tolerances for frd.json (README: factors not unique, check invariants).
 * Double: the file's 1e-12 (reconstruction relative to max|H|, projector
 * absolute); the theory gives ~q eps kappa ~ 1e-14 here.
 * Float: reconstruction SVD_TOL s1 (backward error), projector SVD_TOL
 * kappa (Wedin), kappa = s1 / s_rank from the file's singular values;
 * rounding H to float is a perturbation inside both. */
static void test_frd_golden(void **state)
{
    static double H[MAXN * MAXN], P[MAXN * MAXN], sv[MAXN];
    static dkf_real_t Hr[MAXN * MAXN], Abar[MAXN * MAXN], T[MAXN * MAXN], work[WORKN];
    json_t *root = test_load_vector("uif/frd.json"), *cases = test_json_get(root, "cases");
    size_t ci, ncases = json_array_size(cases);
    double fr_recon = 0.0, fr_proj = 0.0, fr_tt = 0.0;
    (void)state;
    assert_true(ncases >= 9);
    for (ci = 0; ci < ncases; ++ci) {
        const json_t *cs = json_array_get(cases, ci);
        size_t p, m, pr, pc, nsv, k, rank = 999, want, i, j, l, chk;
        double hmax, tol_recon, tol_proj, kappa, e;
        dkf_mat_t mH, mAbar, mT;
        want = test_json_size(cs, "rank");
        test_json_array(test_json_get(cs, "H"), H, MAXN * MAXN, &p, &m);
        test_json_array(test_json_get(cs, "proj_TpT"), P, MAXN * MAXN, &pr, &pc);
        nsv = test_json_array(test_json_get(cs, "singular_values"), sv, MAXN, NULL, NULL);
        assert_int_equal(pr, m);
        assert_int_equal(pc, m);
        k = min_sz(p, m);
        assert_true(nsv >= k);
        test_to_real(Hr, H, p * m);
        mH = test_view(p, m, Hr);
        mAbar = test_view(p, k, Abar);
        mT = test_view(k, m, T);
        test_fill(Abar, p * k, SENTINEL);
        test_fill(T, k * m, SENTINEL);
        hmax = test_max_abs(H, p * m);

        if (want == 0) {
            /* the zero case: refused, nothing written, rank() says 0 */
            static dkf_real_t a0[MAXN * MAXN], t0[MAXN * MAXN];
            memcpy(a0, Abar, p * k * sizeof(dkf_real_t));
            memcpy(t0, T, k * m * sizeof(dkf_real_t));
            assert_int_equal(dkf_mat_frd(&mAbar, &mT, &rank, &mH, DKF_RANK_TOL_DEFAULT, work),
                             DKF_ERR_RANK);
            assert_int_equal(rank, 999);
            assert_int_equal(mAbar.cols, k);
            assert_int_equal(mT.rows, k);
            assert_memory_equal(Abar, a0, p * k * sizeof(dkf_real_t));
            assert_memory_equal(T, t0, k * m * sizeof(dkf_real_t));
            assert_int_equal(dkf_mat_rank(&rank, &mH, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
            assert_int_equal(rank, 0);
            continue;
        }

        assert_int_equal(dkf_mat_frd(&mAbar, &mT, &rank, &mH, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
        assert_int_equal(rank, want);
        assert_int_equal(mAbar.rows, p);
        assert_int_equal(mAbar.cols, want);
        assert_int_equal(mT.rows, want);
        assert_int_equal(mT.cols, m);
        assert_int_equal(dkf_mat_rank(&chk, &mH, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
        assert_int_equal(chk, want);
        /* Abar full column rank, T full row rank */
        assert_int_equal(dkf_mat_rank(&chk, &mAbar, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
        assert_int_equal(chk, want);
        assert_int_equal(dkf_mat_rank(&chk, &mT, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
        assert_int_equal(chk, want);

        kappa = sv[0] / sv[want - 1];
#if DKF_USE_FLOAT
        tol_recon = svd_tol(p, m) * sv[0];
        tol_proj = svd_tol(p, m) * kappa;
#else
        tol_recon = 1e-12 * hmax;
        tol_proj = 1e-12;
        (void)kappa;
#endif
        /* Abar T = H */
        e = 0.0;
        for (i = 0; i < p; ++i)
            for (j = 0; j < m; ++j) {
                double acc = -H[i * m + j];
                for (l = 0; l < want; ++l)
                    acc += (double)Abar[i * want + l] * (double)T[l * m + j];
                e = fmax(e, fabs(acc));
            }
        fr_recon = fmax(fr_recon, e / hmax);
        assert_true(e <= tol_recon);
        /* T T^T = I: T's rows are V's orthonormal columns (SVD_TOL) */
        e = 0.0;
        for (i = 0; i < want; ++i)
            for (j = 0; j < want; ++j) {
                double acc = (i == j) ? -1.0 : 0.0;
                for (l = 0; l < m; ++l) acc += (double)T[i * m + l] * (double)T[j * m + l];
                e = fmax(e, fabs(acc));
            }
        fr_tt = fmax(fr_tt, e);
        assert_true(e <= svd_tol(p, m));
        /* T^+ T = T^T T = the projector onto row(H) */
        e = 0.0;
        for (i = 0; i < m; ++i)
            for (j = 0; j < m; ++j) {
                double acc = -P[i * m + j];
                for (l = 0; l < want; ++l) acc += (double)T[l * m + i] * (double)T[l * m + j];
                e = fmax(e, fabs(acc));
            }
        fr_proj = fmax(fr_proj, e);
        assert_true(e <= tol_proj);
    }
    print_message("frd: worst |Abar T - H|/max|H| %.2e, |T T' - I| %.2e, |T'T - proj| %.2e\n",
                  fr_recon, fr_tt, fr_proj);
    json_decref(root);
}

/* Storage larger than needed: the views shrink to the rank and the data is
 * packed row-major for the new shape. */
static void test_frd_resize(void **state)
{
    static dkf_real_t A[6 * 4], Abar[6 * 4], T[4 * 4], work[DKF_MAT_FRD_WORK(6, 4)];
    double s[4] = {3.0, 0.0, 1.0, 0.0};
    dkf_mat_t mA = DKF_MAT(6, 4, A), mAbar = DKF_MAT(6, 4, Abar), mT = DKF_MAT(4, 4, T);
    test_rng_t g;
    size_t rank = 0, i, j, l;
    double e = 0.0;
    (void)state;
    test_rng_seed(&g, 31);
    make_matrix(&g, A, 6, 4, s);
    assert_int_equal(dkf_mat_frd(&mAbar, &mT, &rank, &mA, DKF_RANK_TOL_DEFAULT, work), DKF_OK);
    assert_int_equal(rank, 2);
    assert_int_equal(mAbar.cols, 2);
    assert_int_equal(mT.rows, 2);
    for (i = 0; i < 6; ++i)
        for (j = 0; j < 4; ++j) {
            double acc = -(double)A[i * 4 + j];
            for (l = 0; l < 2; ++l) acc += (double)Abar[i * 2 + l] * (double)T[l * 4 + j];
            e = fmax(e, fabs(acc));
        }
    assert_true(e <= svd_tol(6, 4) * 3.0);
    /* Abar = U_k S_k: its column norms are the kept singular values */
    for (l = 0; l < 2; ++l) {
        double nrm = 0.0;
        for (i = 0; i < 6; ++i) nrm += (double)Abar[i * 2 + l] * (double)Abar[i * 2 + l];
        assert_true(fabs(sqrt(nrm) - (l == 0 ? 3.0 : 1.0)) <= svd_tol(6, 4) * 3.0);
    }
}

/* ---- errors: status and untouched outputs ------------------------------ */

typedef struct {
    dkf_real_t A[5 * 3], U[5 * 3], s[3], V[3 * 3], X[3 * 5], Abar[5 * 3], T[3 * 3],
        work[DKF_MAT_SVD_WORK(5, 3)];
    size_t rank;
} svd_bufs_t;

static void assert_untouched(const svd_bufs_t *b, const svd_bufs_t *ref)
{
    static const test_member_t all[] = {
        TEST_MEMBER(svd_bufs_t, A), TEST_MEMBER(svd_bufs_t, U),    TEST_MEMBER(svd_bufs_t, s),
        TEST_MEMBER(svd_bufs_t, V), TEST_MEMBER(svd_bufs_t, X),    TEST_MEMBER(svd_bufs_t, Abar),
        TEST_MEMBER(svd_bufs_t, T), TEST_MEMBER(svd_bufs_t, rank),
    };
    test_assert_same_members(b, ref, all, sizeof all / sizeof all[0]);
}

static void test_svd_errors(void **state)
{
    static svd_bufs_t b, ref;
    const dkf_real_t nan = (dkf_real_t)NAN, inf = (dkf_real_t)INFINITY;
    test_rng_t g;
    dkf_mat_t A = DKF_MAT(5, 3, b.A), U = DKF_MAT(5, 3, b.U), V = DKF_MAT(3, 3, b.V),
              X = DKF_MAT(3, 5, b.X), Abar = DKF_MAT(5, 3, b.Abar), T = DKF_MAT(3, 3, b.T), bad;
    const dkf_real_t dflt = DKF_RANK_TOL_DEFAULT;
    (void)state;
    test_rng_seed(&g, 41);
    {
        double s[3] = {2.0, 1.0, 0.5};
        make_matrix(&g, b.A, 5, 3, s);
    }
    test_fill(b.U, 15, SENTINEL);
    test_fill(b.s, 3, SENTINEL);
    test_fill(b.V, 9, SENTINEL);
    test_fill(b.X, 15, SENTINEL);
    test_fill(b.Abar, 15, SENTINEL);
    test_fill(b.T, 9, SENTINEL);
    test_fill(b.work, DKF_MAT_SVD_WORK(5, 3), SENTINEL);
    b.rank = 777;
    ref = b;

    /* capacity */
    bad = test_view(0, 3, b.A);
    assert_int_equal(dkf_mat_svd(&U, b.s, &V, &bad, b.work), DKF_ERR_CAPACITY);
    bad = test_view(5, DKF_MAX_DIM + 1, b.A);
    assert_int_equal(dkf_mat_rank(&b.rank, &bad, dflt, b.work), DKF_ERR_CAPACITY);
    assert_int_equal(dkf_mat_pinv(&X, &b.rank, &bad, dflt, b.work), DKF_ERR_CAPACITY);
    assert_int_equal(dkf_mat_frd(&Abar, &T, &b.rank, &bad, dflt, b.work), DKF_ERR_CAPACITY);
    bad = test_view(5, 0, b.U);
    assert_int_equal(dkf_mat_svd(&bad, b.s, &V, &A, b.work), DKF_ERR_CAPACITY);
    assert_untouched(&b, &ref);

    /* dimensions */
    bad = test_view(5, 2, b.U);
    assert_int_equal(dkf_mat_svd(&bad, b.s, &V, &A, b.work), DKF_ERR_DIM);
    bad = test_view(3, 2, b.V);
    assert_int_equal(dkf_mat_svd(&U, b.s, &bad, &A, b.work), DKF_ERR_DIM);
    bad = test_view(5, 3, b.X);
    assert_int_equal(dkf_mat_pinv(&bad, &b.rank, &A, dflt, b.work), DKF_ERR_DIM);
    bad = test_view(4, 3, b.Abar);
    assert_int_equal(dkf_mat_frd(&bad, &T, &b.rank, &A, dflt, b.work), DKF_ERR_DIM);
    bad = test_view(3, 2, b.T);
    assert_int_equal(dkf_mat_frd(&Abar, &bad, &b.rank, &A, dflt, b.work), DKF_ERR_DIM);
    assert_untouched(&b, &ref);

    /* frd: storage smaller than the rank (3) is reported after the SVD,
     * still before anything is written */
    bad = test_view(5, 2, b.Abar);
    assert_int_equal(dkf_mat_frd(&bad, &T, &b.rank, &A, dflt, b.work), DKF_ERR_CAPACITY);
    assert_int_equal(bad.cols, 2);
    bad = test_view(2, 3, b.T);
    assert_int_equal(dkf_mat_frd(&Abar, &bad, &b.rank, &A, dflt, b.work), DKF_ERR_CAPACITY);
    assert_int_equal(bad.rows, 2);
    assert_int_equal(Abar.cols, 3);
    assert_untouched(&b, &ref);

#if DKF_DEBUG_CHECKS
    /* NULL */
    assert_int_equal(dkf_mat_svd(&U, NULL, &V, &A, b.work), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_svd(&U, b.s, &V, &A, NULL), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_svd(&U, b.s, &V, NULL, b.work), DKF_ERR_NULL);
    bad = test_view(5, 3, NULL);
    assert_int_equal(dkf_mat_svd(&bad, b.s, &V, &A, b.work), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_pinv(NULL, &b.rank, &A, dflt, b.work), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_pinv(&X, &b.rank, &A, dflt, NULL), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_rank(NULL, &A, dflt, b.work), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_rank(&b.rank, NULL, dflt, b.work), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_frd(&Abar, &T, NULL, &A, dflt, b.work), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_frd(NULL, &T, &b.rank, &A, dflt, b.work), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_frd(&Abar, NULL, &b.rank, &A, dflt, b.work), DKF_ERR_NULL);
    assert_untouched(&b, &ref);

    /* aliasing */
    bad = test_view(5, 3, b.A);
    assert_int_equal(dkf_mat_svd(&bad, b.s, &V, &A, b.work), DKF_ERR_ALIAS);
    bad = test_view(3, 3, b.U + 6);
    assert_int_equal(dkf_mat_svd(&U, b.s, &bad, &A, b.work), DKF_ERR_ALIAS);
    assert_int_equal(dkf_mat_svd(&U, b.U + 14, &V, &A, b.work), DKF_ERR_ALIAS);
    assert_int_equal(dkf_mat_svd(&U, b.A + 13, &V, &A, b.work), DKF_ERR_ALIAS);
    assert_int_equal(dkf_mat_svd(&U, b.work + 20, &V, &A, b.work), DKF_ERR_ALIAS);
    assert_int_equal(dkf_mat_svd(NULL, b.s, NULL, &A, b.A + 2), DKF_ERR_ALIAS);
    assert_int_equal(dkf_mat_svd(&U, b.s, NULL, &A, b.U + 14), DKF_ERR_ALIAS);
    assert_int_equal(dkf_mat_svd(NULL, b.s, &V, &A, b.V + 8), DKF_ERR_ALIAS);
    bad = test_view(3, 5, b.A);
    assert_int_equal(dkf_mat_pinv(&bad, &b.rank, &A, dflt, b.work), DKF_ERR_ALIAS);
    assert_int_equal(dkf_mat_pinv(&X, &b.rank, &A, dflt, b.X + 10), DKF_ERR_ALIAS);
    assert_int_equal(dkf_mat_rank(&b.rank, &A, dflt, b.A + 14), DKF_ERR_ALIAS);
    bad = test_view(5, 3, b.A);
    assert_int_equal(dkf_mat_frd(&bad, &T, &b.rank, &A, dflt, b.work), DKF_ERR_ALIAS);
    bad = test_view(3, 3, b.Abar + 6);
    assert_int_equal(dkf_mat_frd(&Abar, &bad, &b.rank, &A, dflt, b.work), DKF_ERR_ALIAS);
    assert_int_equal(dkf_mat_frd(&Abar, &T, &b.rank, &A, dflt, b.T + 8), DKF_ERR_ALIAS);
    assert_untouched(&b, &ref);
#endif

    /* non-finite A or tol */
    b.A[4] = ref.A[4] = nan;
    assert_int_equal(dkf_mat_svd(&U, b.s, &V, &A, b.work), DKF_ERR_NONFINITE);
    assert_int_equal(dkf_mat_svd(NULL, b.s, NULL, &A, b.work), DKF_ERR_NONFINITE);
    assert_int_equal(dkf_mat_pinv(&X, &b.rank, &A, dflt, b.work), DKF_ERR_NONFINITE);
    assert_int_equal(dkf_mat_rank(&b.rank, &A, dflt, b.work), DKF_ERR_NONFINITE);
    assert_int_equal(dkf_mat_frd(&Abar, &T, &b.rank, &A, dflt, b.work), DKF_ERR_NONFINITE);
    b.A[4] = ref.A[4] = -inf;
    assert_int_equal(dkf_mat_svd(&U, b.s, &V, &A, b.work), DKF_ERR_NONFINITE);
    assert_int_equal(dkf_mat_frd(&Abar, &T, &b.rank, &A, dflt, b.work), DKF_ERR_NONFINITE);
    b.A[4] = ref.A[4] = 1;
    assert_int_equal(dkf_mat_pinv(&X, &b.rank, &A, nan, b.work), DKF_ERR_NONFINITE);
    assert_int_equal(dkf_mat_rank(&b.rank, &A, inf, b.work), DKF_ERR_NONFINITE);
    assert_int_equal(dkf_mat_frd(&Abar, &T, &b.rank, &A, nan, b.work), DKF_ERR_NONFINITE);
    assert_untouched(&b, &ref);

    /* frd of a matrix whose rank is 0 under the given tol */
    assert_int_equal(dkf_mat_frd(&Abar, &T, &b.rank, &A, (dkf_real_t)10, b.work), DKF_ERR_RANK);
    assert_untouched(&b, &ref);
}

/* ---- DKF_SVD_MAX_SWEEPS ---------------------------------------------------
 * With the default limit (60) no matrix here fails to converge, so the
 * error path is exercised by a build with -DDKF_SVD_MAX_SWEEPS=1 (or 2) in
 * CMAKE_C_FLAGS: in such a build only the tests below run. */
static void test_svd_no_convergence(void **state)
{
    static dkf_real_t A[10 * 10], U[100], V[100], s[10], X[100], Abar[100], T[100],
        work[DKF_MAT_SVD_WORK(10, 10)];
    static dkf_real_t U0[100], V0[100], s0[10], X0[100], Abar0[100], T0[100];
    dkf_mat_t mA = DKF_MAT(10, 10, A), mU = DKF_MAT(10, 10, U), mV = DKF_MAT(10, 10, V),
              mX = DKF_MAT(10, 10, X), mAbar = DKF_MAT(10, 10, Abar), mT = DKF_MAT(10, 10, T);
    size_t rank = 555;
    test_rng_t g;
    double d[100];
    (void)state;
#if DKF_SVD_MAX_SWEEPS >= 3
    skip(); /* only meaningful in a build with a tiny sweep limit */
#endif
    test_rng_seed(&g, 51);
    test_rand_gauss(&g, d, 10, 10);
    test_to_real(A, d, 100);
    test_fill(U, 100, SENTINEL);
    test_fill(V, 100, SENTINEL);
    test_fill(s, 10, SENTINEL);
    test_fill(X, 100, SENTINEL);
    test_fill(Abar, 100, SENTINEL);
    test_fill(T, 100, SENTINEL);
    memcpy(U0, U, sizeof U);
    memcpy(V0, V, sizeof V);
    memcpy(s0, s, sizeof s);
    memcpy(X0, X, sizeof X);
    memcpy(Abar0, Abar, sizeof Abar);
    memcpy(T0, T, sizeof T);
    assert_int_equal(dkf_mat_svd(&mU, s, &mV, &mA, work), DKF_ERR_NO_CONVERGENCE);
    assert_int_equal(dkf_mat_pinv(&mX, &rank, &mA, DKF_RANK_TOL_DEFAULT, work),
                     DKF_ERR_NO_CONVERGENCE);
    assert_int_equal(dkf_mat_rank(&rank, &mA, DKF_RANK_TOL_DEFAULT, work), DKF_ERR_NO_CONVERGENCE);
    assert_int_equal(dkf_mat_frd(&mAbar, &mT, &rank, &mA, DKF_RANK_TOL_DEFAULT, work),
                     DKF_ERR_NO_CONVERGENCE);
    assert_memory_equal(U, U0, sizeof U);
    assert_memory_equal(V, V0, sizeof V);
    assert_memory_equal(s, s0, sizeof s);
    assert_memory_equal(X, X0, sizeof X);
    assert_memory_equal(Abar, Abar0, sizeof Abar);
    assert_memory_equal(T, T0, sizeof T);
    assert_int_equal(mAbar.cols, 10);
    assert_int_equal(rank, 555);
}

/* Convergence is declared by a sweep without rotations: a matrix with
 * orthogonal columns needs none, so it succeeds under any sweep limit. */
static void test_svd_orthogonal_columns_converge_at_once(void **state)
{
    /* powers of two: the 1/max|A| scaling and the norms are exact */
    static dkf_real_t A[4 * 3] = {0, 4, 0, 2, 0, 0, 0, 0, -1, 0, 0, 0};
    dkf_real_t U[12], V[9], s[3], work[DKF_MAT_SVD_WORK(4, 3)];
    dkf_mat_t mA = DKF_MAT(4, 3, A), mU = DKF_MAT(4, 3, U), mV = DKF_MAT(3, 3, V);
    (void)state;
    assert_int_equal(dkf_mat_svd(&mU, s, &mV, &mA, work), DKF_OK);
    assert_true(s[0] == (dkf_real_t)4 && s[1] == (dkf_real_t)2 && s[2] == (dkf_real_t)1);
    assert_true(recon_err(A, U, s, V, 4, 3) == 0.0);
}

int main(void)
{
    const struct CMUnitTest full[] = {
        cmocka_unit_test(test_svd_random),
        cmocka_unit_test(test_svd_rank_deficient),
        cmocka_unit_test(test_svd_ill_conditioned),
        cmocka_unit_test(test_svd_equal_values),
        cmocka_unit_test(test_svd_zero),
        cmocka_unit_test(test_svd_structure_and_scale),
        cmocka_unit_test(test_svd_orthogonal_columns_converge_at_once),
        cmocka_unit_test(test_pinv_moore_penrose),
        cmocka_unit_test(test_pinv_zero),
        cmocka_unit_test(test_pinv_tolerance),
        cmocka_unit_test(test_rank_exact),
        cmocka_unit_test(test_frd_golden),
        cmocka_unit_test(test_frd_resize),
        cmocka_unit_test(test_svd_errors),
        cmocka_unit_test(test_svd_no_convergence),
    };
    /* a build with a tiny sweep limit can only check the limit itself */
    const struct CMUnitTest few_sweeps[] = {
        cmocka_unit_test(test_svd_no_convergence),
        cmocka_unit_test(test_svd_orthogonal_columns_converge_at_once),
    };
#if DKF_SVD_MAX_SWEEPS < 3
    (void)full;
    return cmocka_run_group_tests(few_sweeps, NULL, NULL);
#else
    (void)few_sweeps;
    return cmocka_run_group_tests(full, NULL, NULL);
#endif
}
