/*
 * Elementary matrix routines of dkf/mat.h: views, element-wise operations,
 * products, congruence, symmetrisation, blocks, finiteness.
 *
 * Results are compared with double-precision references computed from the
 * exact double images of the library's (possibly float) inputs, so only
 * the library's own rounding is measured. Every error status is provoked
 * and the outputs are checked bit for bit to be untouched.
 *
 * Product tolerance (used throughout): a k-term sum of products computed
 * in any order satisfies |fl(AB) - AB| <= gamma_k |A||B| componentwise,
 * gamma_k = k u / (1 - k u) with u = EPS/2 (Higham, Accuracy and Stability
 * of Numerical Algorithms, 2nd ed., eq. 3.13). The double reference carries
 * the same bound in double, so |got - ref| <= 2 gamma_k |A||B|
 * <= 2 k EPS |A||B| for k u <= 1/2. No condition number enters a product.
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
/* the largest product and congruence: the build's limit, at most 96 (a
 * DKF_MAX_DIM = 1024 build spent 36 s on O(n^3) references at n = 1024;
 * the loops are the same at every size, and the capacity checks below
 * still use the limit itself) */
#define SIZE_TOP (DKF_MAX_DIM < 96 ? DKF_MAX_DIM : 96)
#define SENTINEL ((dkf_real_t)-1234.5)

/* Scratch shared by the tests (static: too large for a comfortable stack). */
static dkf_real_t ra[MAXSQ], rb[MAXSQ], rc[MAXSQ], rd[MAXSQ], rw[MAXSQ], snap[2 * MAXSQ];
static double da[MAXSQ], db[MAXSQ], dc[MAXSQ], dd[MAXSQ], de[MAXSQ], dw[MAXSQ];


/* r x c N(0,1) matrix in the library type (a) and the exact double image
 * of those same values (ad). */
static void rand_pair(test_rng_t *g, dkf_real_t *a, double *ad, size_t r, size_t c)
{
    test_rand_gauss(g, ad, r, c);
    test_to_real(a, ad, r * c);
    test_to_double(ad, a, r * c);
}

static void abs_of(double *dst, const double *src, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) dst[i] = fabs(src[i]);
}

/* Componentwise |got - ref| <= rel * bound (+ a denormal floor). */
static void assert_within(const char *what, const dkf_real_t *got, const double *ref,
                          const double *bound, size_t n, double rel)
{
    size_t i;
    for (i = 0; i < n; ++i) {
        double err = fabs((double)got[i] - ref[i]);
        double tol = rel * bound[i] + 1e-300;
        if (!(err <= tol)) {
            print_error("%s[%zu]: |%.17g - %.17g| = %.3e > %.3e\n", what, i, (double)got[i], ref[i],
                        err, tol);
            fail();
        }
    }
}


/* ---- bad-view harness ------------------------------------------------------ */

typedef dkf_status_t (*binop_fn)(dkf_mat_t *, const dkf_mat_t *, const dkf_mat_t *);

/* Replaces each of the first nargs arguments in turn by a NULL view, a view
 * with NULL data, and views of 0 or DKF_MAX_DIM+1 rows/cols; expects
 * DKF_ERR_NULL / DKF_ERR_CAPACITY and an untouched output (argument 0). */
static void check_bad_views(binop_fn f, int nargs, dkf_mat_t C, dkf_mat_t A, dkf_mat_t B)
{
    const size_t nout = C.rows * C.cols;
    int arg, variant;
    for (arg = 0; arg < nargs; ++arg)
        for (variant = 0; variant < 6; ++variant) {
            dkf_mat_t v[3];
            dkf_mat_t *p[3];
            dkf_status_t expect = DKF_ERR_CAPACITY;
            v[0] = C;
            v[1] = A;
            v[2] = B;
            p[0] = &v[0];
            p[1] = &v[1];
            p[2] = &v[2];
            switch (variant) {
            case 0: p[arg] = NULL; expect = DKF_ERR_NULL; break;
            case 1: v[arg].data = NULL; expect = DKF_ERR_NULL; break;
            case 2: v[arg].rows = 0; break;
            case 3: v[arg].cols = 0; break;
            case 4: v[arg].rows = DKF_MAX_DIM + 1; break;
            default: v[arg].cols = DKF_MAX_DIM + 1; break;
            }
            TEST_FAILS_UNTOUCHED(snap, expect, f(p[0], p[1], p[2]), C.data, nout);
        }
}

static dkf_status_t scale_fn(dkf_mat_t *B, const dkf_mat_t *A, const dkf_mat_t *unused)
{
    (void)unused;
    return dkf_mat_scale(B, A, (dkf_real_t)-0.75);
}
static dkf_status_t axpy_fn(dkf_mat_t *Y, const dkf_mat_t *X, const dkf_mat_t *unused)
{
    (void)unused;
    return dkf_mat_axpy(Y, (dkf_real_t)0.375, X);
}
static dkf_status_t copy_fn(dkf_mat_t *B, const dkf_mat_t *A, const dkf_mat_t *unused)
{
    (void)unused;
    return dkf_mat_copy(B, A);
}
static dkf_status_t transpose_fn(dkf_mat_t *B, const dkf_mat_t *A, const dkf_mat_t *unused)
{
    (void)unused;
    return dkf_mat_transpose(B, A);
}
static dkf_status_t congruence_fn(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *P)
{
    return dkf_mat_congruence(C, A, P, rw);
}
static dkf_status_t get_block_fn(dkf_mat_t *B, const dkf_mat_t *A, const dkf_mat_t *unused)
{
    (void)unused;
    return dkf_mat_get_block(B, A, 0, 0);
}
static dkf_status_t set_block_fn(dkf_mat_t *A, const dkf_mat_t *B, const dkf_mat_t *unused)
{
    (void)unused;
    return dkf_mat_set_block(A, 0, 0, B);
}

/* ---- views ------------------------------------------------------------------ */

static void test_init(void **state)
{
    dkf_real_t buf[6];
    dkf_mat_t m = {7, 9, NULL}, keep;
    (void)state;
    assert_int_equal(dkf_mat_init(&m, 2, 3, buf), DKF_OK);
    assert_true(m.rows == 2 && m.cols == 3 && m.data == buf);
    assert_int_equal(dkf_mat_init(NULL, 2, 3, buf), DKF_ERR_NULL);
    keep = m;
    assert_int_equal(dkf_mat_init(&m, 2, 3, NULL), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_init(&m, 0, 3, buf), DKF_ERR_CAPACITY);
    assert_int_equal(dkf_mat_init(&m, 2, 0, buf), DKF_ERR_CAPACITY);
    assert_int_equal(dkf_mat_init(&m, DKF_MAX_DIM + 1, 1, buf), DKF_ERR_CAPACITY);
    assert_int_equal(dkf_mat_init(&m, 1, DKF_MAX_DIM + 1, buf), DKF_ERR_CAPACITY);
    assert_memory_equal(&keep, &m, sizeof m);
    assert_int_equal(dkf_mat_init(&m, DKF_MAX_DIM, DKF_MAX_DIM, ra), DKF_OK);
    assert_int_equal(dkf_mat_init(&m, 1, 1, buf), DKF_OK);
}

static void test_zero_identity_set(void **state)
{
    dkf_mat_t A = DKF_MAT(3, 3, ra), R = DKF_MAT(2, 3, rb), bad = DKF_MAT(0, 3, ra);
    dkf_real_t vals[6] = {1, -2, 3.5, 4, 5, -6.25};
    size_t i, j;
    (void)state;
    test_fill(ra, 9, SENTINEL);
    assert_int_equal(dkf_mat_identity(&A), DKF_OK);
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) assert_true(DKF_AT(&A, i, j) == (i == j ? 1 : 0));
    assert_int_equal(dkf_mat_zero(&A), DKF_OK);
    for (i = 0; i < 9; ++i) assert_true(ra[i] == 0);
    assert_int_equal(dkf_mat_set(&R, vals), DKF_OK);
    assert_memory_equal(rb, vals, sizeof vals);

    test_fill(rb, 6, SENTINEL);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_identity(&R), rb, 6);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_set(&R, NULL), rb, 6);
    assert_int_equal(dkf_mat_zero(NULL), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_identity(NULL), DKF_ERR_NULL);
    assert_int_equal(dkf_mat_set(NULL, vals), DKF_ERR_NULL);
    test_fill(ra, 9, SENTINEL);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_zero(&bad), ra, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_identity(&bad), ra, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_set(&bad, vals), ra, 9);
    bad.rows = DKF_MAX_DIM + 1;
    bad.cols = DKF_MAX_DIM + 1;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_identity(&bad), ra, 9);
}

static void test_copy_transpose(void **state)
{
    test_rng_t g;
    dkf_mat_t A = DKF_MAT(3, 5, ra), B = DKF_MAT(3, 5, rb), T = DKF_MAT(5, 3, rc),
              TT = DKF_MAT(3, 5, rd), W = DKF_MAT(5, 5, ra), Wrong = DKF_MAT(5, 2, rc);
    dkf_mat_t Part = DKF_MAT(3, 5, ra + 1), Sq = DKF_MAT(4, 4, ra);
    size_t i, j;
    (void)state;
    test_rng_seed(&g, 11);
    rand_pair(&g, ra, da, 3, 5);
    assert_int_equal(dkf_mat_copy(&B, &A), DKF_OK);
    assert_memory_equal(ra, rb, 15 * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_copy(&A, &A), DKF_OK); /* identical: allowed, a no-op */
    assert_memory_equal(ra, rb, 15 * sizeof(dkf_real_t));

    /* transpose is a permutation: exact; twice gives A back */
    assert_int_equal(dkf_mat_transpose(&T, &A), DKF_OK);
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 5; ++j) assert_true(DKF_AT(&T, j, i) == DKF_AT(&A, i, j));
    assert_int_equal(dkf_mat_transpose(&TT, &T), DKF_OK);
    assert_memory_equal(rd, ra, 15 * sizeof(dkf_real_t));

    test_fill(rb, 15, SENTINEL);
    test_fill(rc, 15, SENTINEL);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_copy(&B, &T), rb, 15);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_transpose(&Wrong, &A), rc, 15);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_transpose(&B, &A), rb, 15);
    /* partial overlap is refused even where identical views are fine */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_copy(&Part, &A), ra, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_transpose(&Sq, &Sq), ra, 16);
    W.data = ra + 2;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_transpose(&W, &W), ra, 27);
    check_bad_views(copy_fn, 2, B, A, A);
    check_bad_views(transpose_fn, 2, T, A, A);
}

/* ---- element-wise ---------------------------------------------------------- */

static void test_elementwise(void **state)
{
    test_rng_t g;
    const size_t r = 4, c = 6, n = 24;
    dkf_mat_t A = DKF_MAT(r, c, ra), B = DKF_MAT(r, c, rb), C = DKF_MAT(r, c, rc),
              D = DKF_MAT(r, c, rd), Wrong = DKF_MAT(c, r, rb), Part = DKF_MAT(r, c, rc + 3);
    const dkf_real_t s = (dkf_real_t)-0.75, t = (dkf_real_t)0.375;
    size_t i;
    (void)state;
    test_rng_seed(&g, 12);
    rand_pair(&g, ra, da, r, c);
    rand_pair(&g, rb, db, r, c);

    /* A single rounded operation: |fl(x op y) - (x op y)| <= u |x op y|;
     * the double reference is exact for these float inputs and within
     * u_double otherwise, hence the bound EPS * |x op y|. axpy rounds
     * twice: <= 2 u (|y| + |s x|) <= EPS * (|y| + |s x|), bound 2 EPS. */
    assert_int_equal(dkf_mat_add(&C, &A, &B), DKF_OK);
    for (i = 0; i < n; ++i) {
        dc[i] = da[i] + db[i];
        dw[i] = fabs(dc[i]);
    }
    assert_within("add", rc, dc, dw, n, TEST_EPS);
    assert_int_equal(dkf_mat_sub(&C, &A, &B), DKF_OK);
    for (i = 0; i < n; ++i) {
        dc[i] = da[i] - db[i];
        dw[i] = fabs(dc[i]);
    }
    assert_within("sub", rc, dc, dw, n, TEST_EPS);
    assert_int_equal(dkf_mat_scale(&C, &A, s), DKF_OK);
    for (i = 0; i < n; ++i) {
        dc[i] = (double)s * da[i];
        dw[i] = fabs(dc[i]);
    }
    assert_within("scale", rc, dc, dw, n, TEST_EPS);
    memcpy(rc, rb, n * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_axpy(&C, t, &A), DKF_OK);
    for (i = 0; i < n; ++i) {
        dc[i] = db[i] + (double)t * da[i];
        dw[i] = fabs(db[i]) + fabs((double)t * da[i]);
    }
    assert_within("axpy", rc, dc, dw, n, 2 * TEST_EPS);

    /* in place (output identical to an input) == out of place, bitwise */
    assert_int_equal(dkf_mat_add(&C, &A, &B), DKF_OK);
    memcpy(rd, ra, n * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_add(&D, &D, &B), DKF_OK);
    assert_memory_equal(rc, rd, n * sizeof(dkf_real_t));
    memcpy(rd, rb, n * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_add(&D, &A, &D), DKF_OK);
    assert_memory_equal(rc, rd, n * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_sub(&C, &A, &B), DKF_OK);
    memcpy(rd, rb, n * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_sub(&D, &A, &D), DKF_OK);
    assert_memory_equal(rc, rd, n * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_sub(&C, &A, &A), DKF_OK); /* A - A == 0 exactly */
    for (i = 0; i < n; ++i) assert_true(rc[i] == 0);
    assert_int_equal(dkf_mat_scale(&C, &A, s), DKF_OK);
    memcpy(rd, ra, n * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_scale(&D, &D, s), DKF_OK);
    assert_memory_equal(rc, rd, n * sizeof(dkf_real_t));
    memcpy(rc, ra, n * sizeof(dkf_real_t));
    memcpy(rd, ra, n * sizeof(dkf_real_t));
    assert_int_equal(dkf_mat_axpy(&C, t, &A), DKF_OK);
    assert_int_equal(dkf_mat_axpy(&D, t, &D), DKF_OK); /* Y == X */
    assert_memory_equal(rc, rd, n * sizeof(dkf_real_t));

    /* errors */
    test_fill(rc, n + 3, SENTINEL);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_add(&C, &A, &Wrong), rc, n);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_sub(&C, &Wrong, &B), rc, n);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_scale(&C, &Wrong, s), rc, n);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_axpy(&C, s, &Wrong), rc, n);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_add(&Part, &C, &B), rc, n + 3);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_sub(&Part, &A, &C), rc, n + 3);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_scale(&Part, &C, s), rc, n + 3);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_axpy(&Part, s, &C), rc, n + 3);
    check_bad_views(dkf_mat_add, 3, C, A, B);
    check_bad_views(dkf_mat_sub, 3, C, A, B);
    check_bad_views(scale_fn, 2, C, A, A);
    check_bad_views(axpy_fn, 2, C, A, A);
}

/* ---- products ---------------------------------------------------------------- */

/* C = op(A) op(B) against the double reference for r x k times k x c. */
static void check_products(test_rng_t *g, size_t r, size_t k, size_t c)
{
    dkf_mat_t A = DKF_MAT(r, k, ra), B = DKF_MAT(k, c, rb), C = DKF_MAT(r, c, rc);
    dkf_mat_t At = DKF_MAT(k, r, rd), Bt = DKF_MAT(c, k, rw);
    const double rel = 2.0 * (double)k * TEST_EPS; /* see file comment */
    rand_pair(g, ra, da, r, k);
    rand_pair(g, rb, db, k, c);
    test_ref_mul(dc, da, db, r, k, c);
    abs_of(dw, da, r * k);
    abs_of(dd, db, k * c);
    test_ref_mul(de, dw, dd, r, k, c); /* |A||B| */
    test_fill(rc, r * c, SENTINEL);
    assert_int_equal(dkf_mat_mul(&C, &A, &B), DKF_OK);
    assert_within("mul", rc, dc, de, r * c, rel);

    /* A B^T with B^T given as Bt, and A^T B with A^T given as At */
    assert_int_equal(dkf_mat_transpose(&Bt, &B), DKF_OK);
    test_fill(rc, r * c, SENTINEL);
    assert_int_equal(dkf_mat_mul_abt(&C, &A, &Bt), DKF_OK);
    assert_within("mul_abt", rc, dc, de, r * c, rel);
    assert_int_equal(dkf_mat_transpose(&At, &A), DKF_OK);
    test_fill(rc, r * c, SENTINEL);
    assert_int_equal(dkf_mat_mul_atb(&C, &At, &B), DKF_OK);
    assert_within("mul_atb", rc, dc, de, r * c, rel);
}

static void test_products_reference(void **state)
{
    static const size_t shapes[][3] = {{1, 1, 1}, {1, 7, 1}, {5, 1, 4}, {1, 4, 6}, {6, 4, 1},
                                       {3, 5, 2}, {2, 2, 2}, {12, 12, 12}, {7, 3, 9},
                                       {9, 12, 5}, {SIZE_TOP, SIZE_TOP, SIZE_TOP}};
    test_rng_t g;
    size_t s;
    (void)state;
    test_rng_seed(&g, 13);
    for (s = 0; s < sizeof shapes / sizeof shapes[0]; ++s)
        check_products(&g, shapes[s][0], shapes[s][1], shapes[s][2]);
}

static void test_products_closed_forms(void **state)
{
    test_rng_t g;
    const size_t r = 4, k = 5, c = 3;
    dkf_mat_t A = DKF_MAT(r, k, ra), B = DKF_MAT(k, c, rb), C = DKF_MAT(r, c, rc),
              I = DKF_MAT(k, k, rd), Ir = DKF_MAT(r, r, rd), Ct = DKF_MAT(c, r, rw),
              At = DKF_MAT(k, r, rw + 32), Bt = DKF_MAT(c, k, rw + 64),
              BtAt = DKF_MAT(c, r, rw + 96);
    double bound[64], ref[64];
    size_t i;
    (void)state;
    test_rng_seed(&g, 14);
    rand_pair(&g, ra, da, r, k);
    rand_pair(&g, rb, db, k, c);
    /* A I = A and I A = A exactly: every sum is a + (+-0) terms */
    assert_int_equal(dkf_mat_identity(&I), DKF_OK);
    assert_int_equal(dkf_mat_mul(&C, &A, &B), DKF_OK);
    {
        dkf_mat_t AI = DKF_MAT(r, k, rc);
        assert_int_equal(dkf_mat_mul(&AI, &A, &I), DKF_OK);
        assert_memory_equal(rc, ra, r * k * sizeof(dkf_real_t));
        assert_int_equal(dkf_mat_mul_abt(&AI, &A, &I), DKF_OK);
        assert_memory_equal(rc, ra, r * k * sizeof(dkf_real_t));
        assert_int_equal(dkf_mat_identity(&Ir), DKF_OK);
        assert_int_equal(dkf_mat_mul(&AI, &Ir, &A), DKF_OK);
        assert_memory_equal(rc, ra, r * k * sizeof(dkf_real_t));
        assert_int_equal(dkf_mat_mul_atb(&AI, &Ir, &A), DKF_OK);
        assert_memory_equal(rc, ra, r * k * sizeof(dkf_real_t));
    }
    /* (A B)^T = B^T A^T: both sides are the same k products summed, so
     * they agree within twice the product bound. */
    assert_int_equal(dkf_mat_mul(&C, &A, &B), DKF_OK);
    assert_int_equal(dkf_mat_transpose(&Ct, &C), DKF_OK);
    assert_int_equal(dkf_mat_transpose(&At, &A), DKF_OK);
    assert_int_equal(dkf_mat_transpose(&Bt, &B), DKF_OK);
    assert_int_equal(dkf_mat_mul(&BtAt, &Bt, &At), DKF_OK);
    abs_of(dw, da, r * k);
    abs_of(dd, db, k * c);
    test_ref_mul(dc, dw, dd, r, k, c);
    for (i = 0; i < r * c; ++i) { /* transpose bound and Ct into ref */
        size_t ii = i / c, jj = i % c;
        bound[jj * r + ii] = dc[i];
        ref[jj * r + ii] = (double)rc[i];
    }
    assert_within("(AB)^T = B^T A^T", BtAt.data, ref, bound, r * c, 2.0 * (double)k * TEST_EPS);
    /* NaN is not scanned for by products: it propagates */
    ra[0] = (dkf_real_t)NAN;
    assert_int_equal(dkf_mat_mul(&C, &A, &B), DKF_OK);
    assert_true(isnan(rc[0]));
}

static void test_products_errors(void **state)
{
    dkf_mat_t A = DKF_MAT(3, 4, ra), B = DKF_MAT(4, 2, rb), C = DKF_MAT(3, 2, rc),
              B5 = DKF_MAT(5, 2, rb), C33 = DKF_MAT(3, 3, rc), S = DKF_MAT(4, 4, ra),
              Bt = DKF_MAT(2, 4, rb), At = DKF_MAT(4, 3, ra), Part = DKF_MAT(3, 2, ra + 5);
    (void)state;
    test_fill(ra, 16, 1);
    test_fill(rb, 10, 2);
    test_fill(rc, 9, SENTINEL);
    /* inner dimensions disagree / output has the wrong shape */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_mul(&C, &A, &B5), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_mul(&C33, &A, &B), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_mul_abt(&C, &A, &B), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_mul_abt(&C33, &A, &Bt), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_mul_atb(&C, &A, &B), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_mul_atb(&C33, &At, &B), rc, 9);
    /* output overlapping an input, identical or partial */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_mul(&S, &S, &S), ra, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_mul_abt(&S, &S, &S), ra, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_mul_atb(&S, &S, &S), ra, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_mul(&Part, &A, &B), ra, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_mul_abt(&Part, &A, &Bt), ra, 16);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_mul_atb(&Part, &At, &B), ra, 16);
    Part.data = rb + 3;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_mul(&Part, &A, &B), rb, 10);
    check_bad_views(dkf_mat_mul, 3, C, A, B);
    check_bad_views(dkf_mat_mul_abt, 3, C, A, Bt);
    check_bad_views(dkf_mat_mul_atb, 3, C, At, B);
}

/* ---- congruence, symmetrise -------------------------------------------------- */

static void test_congruence(void **state)
{
    static const size_t shapes[][2] = {{1, 1}, {1, 4}, {4, 1}, {3, 5}, {6, 6}, {12, 4},
                                       {SIZE_TOP, SIZE_TOP}};
    test_rng_t g;
    size_t s, i, j;
    (void)state;
    test_rng_seed(&g, 15);
    for (s = 0; s < sizeof shapes / sizeof shapes[0]; ++s) {
        const size_t r = shapes[s][0], c = shapes[s][1];
        dkf_mat_t A = DKF_MAT(r, c, ra), P = DKF_MAT(c, c, rb), C = DKF_MAT(r, r, rc);
        rand_pair(&g, ra, da, r, c);
        test_rand_spd(&g, db, c, 100.0, 1.0);
        test_to_real(rb, db, c * c);
        test_to_double(db, rb, c * c);
        /* reference A P A^T and bound |A||P||A|^T in double */
        test_ref_mul(dw, da, db, r, c, c);
        for (i = 0; i < r; ++i)
            for (j = 0; j < r; ++j) {
                size_t l;
                double acc = 0;
                for (l = 0; l < c; ++l) acc += dw[i * c + l] * da[j * c + l];
                dc[i * r + j] = acc;
            }
        abs_of(dw, da, r * c);
        abs_of(dd, db, c * c);
        test_ref_mul(de, dw, dd, r, c, c);
        for (i = 0; i < r * r; ++i) {
            size_t l, ii = i / r, jj = i % r;
            double acc = 0;
            for (l = 0; l < c; ++l) acc += de[ii * c + l] * dw[jj * c + l];
            dd[i] = acc;
        }
        test_fill(rc, r * r, SENTINEL);
        assert_int_equal(dkf_mat_congruence(&C, &A, &P, rw), DKF_OK);
        /* two chained c-term products: gamma_{2c} |A||P||A^T|, for the
         * library and for the double reference alike */
        assert_within("congruence", rc, dc, dd, r * r, 4.0 * (double)c * TEST_EPS);
        for (i = 0; i < r; ++i)
            for (j = 0; j < i; ++j) assert_true(DKF_AT(&C, i, j) == DKF_AT(&C, j, i));
    }
}

static void test_congruence_errors(void **state)
{
    dkf_mat_t A = DKF_MAT(2, 3, ra), P = DKF_MAT(3, 3, rb), C = DKF_MAT(2, 2, rc),
              P2 = DKF_MAT(2, 2, rb), C3 = DKF_MAT(3, 3, rc), Sq = DKF_MAT(3, 3, ra);
    (void)state;
    test_fill(ra, 9, 1);
    test_fill(rb, 9, 1);
    test_fill(rc, 9, SENTINEL);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_congruence(&C, &A, &P2, rw), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_congruence(&C3, &A, &P, rw), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_congruence(&C, &A, &P, NULL), rc, 9);
    /* C over A or P, and workspace over C, A or P */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_congruence(&Sq, &Sq, &P, rw), ra, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_congruence(&C3, &Sq, &C3, rw), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_congruence(&C, &A, &P, rc + 3), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_congruence(&C, &A, &P, ra + 5), rc, 9);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_congruence(&C, &A, &P, rb + 8), rc, 9);
    check_bad_views(congruence_fn, 3, C, A, P);
}

static void test_symmetrise(void **state)
{
    test_rng_t g;
    const size_t n = 7;
    dkf_mat_t A = DKF_MAT(n, n, ra), R = DKF_MAT(2, 3, rb);
    size_t i, j;
    (void)state;
    test_rng_seed(&g, 16);
    rand_pair(&g, ra, da, n, n);
    assert_int_equal(dkf_mat_symmetrise(&A), DKF_OK);
    for (i = 0; i < n; ++i) {
        assert_true(DKF_AT(&A, i, i) == (dkf_real_t)da[i * n + i]); /* diagonal kept */
        for (j = 0; j < n; ++j) {
            /* (a + b) / 2: one rounding of the sum, exact halving */
            double exact = 0.5 * (da[i * n + j] + da[j * n + i]);
            assert_true(DKF_AT(&A, i, j) == DKF_AT(&A, j, i));
            assert_true(fabs((double)DKF_AT(&A, i, j) - exact) <= TEST_EPS * fabs(exact));
        }
    }
    test_fill(rb, 6, SENTINEL);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_symmetrise(&R), rb, 6);
    assert_int_equal(dkf_mat_symmetrise(NULL), DKF_ERR_NULL);
    R.rows = 0;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_symmetrise(&R), rb, 6);
}

/* ---- blocks ------------------------------------------------------------------- */

static void test_blocks(void **state)
{
    test_rng_t g;
    const size_t R = 6, C = 7;
    dkf_mat_t A = DKF_MAT(R, C, ra), Big = DKF_MAT(8, 2, rc), Part = DKF_MAT(2, 2, ra + 4);
    size_t br, bc, r0, c0, i, j;
    (void)state;
    test_rng_seed(&g, 17);
    /* every block shape at every position: set then get is the identity,
     * and set leaves everything outside the block as it was */
    for (br = 1; br <= R; br += 2)
        for (bc = 1; bc <= C; bc += 3)
            for (r0 = 0; r0 + br <= R; ++r0)
                for (c0 = 0; c0 + bc <= C; ++c0) {
                    dkf_mat_t B = DKF_MAT(br, bc, rb), G = DKF_MAT(br, bc, rc);
                    rand_pair(&g, ra, da, R, C);
                    rand_pair(&g, rb, db, br, bc);
                    assert_int_equal(dkf_mat_set_block(&A, r0, c0, &B), DKF_OK);
                    for (i = 0; i < R; ++i)
                        for (j = 0; j < C; ++j) {
                            int in = i >= r0 && i < r0 + br && j >= c0 && j < c0 + bc;
                            double want = in ? db[(i - r0) * bc + j - c0] : da[i * C + j];
                            assert_true((double)DKF_AT(&A, i, j) == want);
                        }
                    test_fill(rc, br * bc, SENTINEL);
                    assert_int_equal(dkf_mat_get_block(&G, &A, r0, c0), DKF_OK);
                    assert_memory_equal(rc, rb, br * bc * sizeof(dkf_real_t));
                }
    {
        dkf_mat_t B = DKF_MAT(2, 3, rb);
        test_fill(rb, 6, SENTINEL);
        /* blocks that leave A by one row / column, or by a wrapped index */
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_get_block(&B, &A, R - 1, 0), rb, 6);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_get_block(&B, &A, 0, C - 2), rb, 6);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_get_block(&B, &A, SIZE_MAX, 0), rb, 6);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_get_block(&Big, &A, 0, 0), rc, 16);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_set_block(&A, R - 1, 0, &B), ra, R * C);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_set_block(&A, 0, C - 2, &B), ra, R * C);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_set_block(&A, 0, SIZE_MAX, &B), ra, R * C);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_set_block(&A, 0, 0, &Big), ra, R * C);
        /* a block view inside A's own storage */
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_get_block(&Part, &A, 1, 1), ra, R * C);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_set_block(&A, 1, 1, &Part), ra, R * C);
        check_bad_views(get_block_fn, 2, B, A, A);
        check_bad_views(set_block_fn, 2, A, B, B);
    }
}

static void test_blkdiag(void **state)
{
    test_rng_t g;
    dkf_mat_t B0 = DKF_MAT(1, 2, ra), B1 = DKF_MAT(3, 1, ra + 2), B2 = DKF_MAT(2, 2, ra + 5);
    dkf_mat_t D = DKF_MAT(6, 5, rc), Dbig = DKF_MAT(7, 5, rc), Dsmall = DKF_MAT(6, 4, rc);
    const dkf_mat_t *blocks[3];
    const size_t ro[3] = {0, 1, 4}, co[3] = {0, 2, 3};
    size_t b, i, j;
    (void)state;
    blocks[0] = &B0;
    blocks[1] = &B1;
    blocks[2] = &B2;
    test_rng_seed(&g, 18);
    rand_pair(&g, ra, da, 1, 9);
    test_fill(rc, 30, SENTINEL);
    assert_int_equal(dkf_mat_blkdiag(&D, blocks, 3), DKF_OK);
    /* shape rule: (1+3+2) x (2+1+2); each block at its offset, zeros elsewhere */
    for (i = 0; i < 6; ++i)
        for (j = 0; j < 5; ++j) {
            dkf_real_t want = 0;
            for (b = 0; b < 3; ++b)
                if (i >= ro[b] && i < ro[b] + blocks[b]->rows && j >= co[b] &&
                    j < co[b] + blocks[b]->cols)
                    want = DKF_AT(blocks[b], i - ro[b], j - co[b]);
            assert_true(DKF_AT(&D, i, j) == want);
        }
    /* a single block is a copy; two 1x1 blocks give a diagonal */
    {
        dkf_mat_t D2 = DKF_MAT(3, 1, rd), E = DKF_MAT(2, 2, rd);
        dkf_mat_t s0 = DKF_MAT(1, 1, rb), s1 = DKF_MAT(1, 1, rb + 1);
        const dkf_mat_t *one[1], *two[2];
        one[0] = &B1;
        two[0] = &s0;
        two[1] = &s1;
        assert_int_equal(dkf_mat_blkdiag(&D2, one, 1), DKF_OK);
        assert_memory_equal(rd, ra + 2, 3 * sizeof(dkf_real_t));
        rb[0] = 2;
        rb[1] = -3;
        assert_int_equal(dkf_mat_blkdiag(&E, two, 2), DKF_OK);
        assert_true(rd[0] == 2 && rd[1] == 0 && rd[2] == 0 && rd[3] == -3);
    }
    test_fill(rc, 35, SENTINEL);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_blkdiag(&Dbig, blocks, 3), rc, 35);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_blkdiag(&Dsmall, blocks, 3), rc, 35);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_blkdiag(&D, blocks, 2), rc, 35);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_mat_blkdiag(&D, blocks, 0), rc, 35);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_blkdiag(&D, NULL, 3), rc, 35);
    assert_int_equal(dkf_mat_blkdiag(NULL, blocks, 3), DKF_ERR_NULL);
    blocks[1] = NULL;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NULL, dkf_mat_blkdiag(&D, blocks, 3), rc, 35);
    B1.rows = DKF_MAX_DIM + 1;
    blocks[1] = &B1;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_blkdiag(&D, blocks, 3), rc, 35);
    B1.rows = 0;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_blkdiag(&D, blocks, 3), rc, 35);
    B1.rows = 3;
    B1.data = rc + 29; /* a block sharing D's storage */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ALIAS, dkf_mat_blkdiag(&D, blocks, 3), rc, 35);
    D.rows = 0;
    B1.data = ra + 2;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_mat_blkdiag(&D, blocks, 3), rc, 35);
}

static void test_check_finite(void **state)
{
    dkf_mat_t A = DKF_MAT(3, 4, ra);
    const dkf_real_t bad[3] = {(dkf_real_t)NAN, (dkf_real_t)INFINITY, -(dkf_real_t)INFINITY};
    const size_t where[3] = {0, 5, 11};
    size_t b, w;
    (void)state;
    test_fill(ra, 12, 1);
    ra[1] = DKF_REAL_MAX;
    ra[2] = -DKF_REAL_MAX;
    ra[3] = DKF_REAL_MIN / 4; /* subnormal */
    ra[4] = -(dkf_real_t)0.0;
    assert_int_equal(dkf_mat_check_finite(&A), DKF_OK);
    for (b = 0; b < 3; ++b)
        for (w = 0; w < 3; ++w) {
            dkf_real_t keep = ra[where[w]];
            ra[where[w]] = bad[b];
            assert_int_equal(dkf_mat_check_finite(&A), DKF_ERR_NONFINITE);
            ra[where[w]] = keep;
        }
    assert_int_equal(dkf_mat_check_finite(NULL), DKF_ERR_NULL);
    A.cols = DKF_MAX_DIM + 1;
    assert_int_equal(dkf_mat_check_finite(&A), DKF_ERR_CAPACITY);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_init),
        cmocka_unit_test(test_zero_identity_set),
        cmocka_unit_test(test_copy_transpose),
        cmocka_unit_test(test_elementwise),
        cmocka_unit_test(test_products_reference),
        cmocka_unit_test(test_products_closed_forms),
        cmocka_unit_test(test_products_errors),
        cmocka_unit_test(test_congruence),
        cmocka_unit_test(test_congruence_errors),
        cmocka_unit_test(test_symmetrise),
        cmocka_unit_test(test_blocks),
        cmocka_unit_test(test_blkdiag),
        cmocka_unit_test(test_check_finite),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
