/*
 * The kernels of the large stacked Difference KF (src/kernels.c; docs/design/diffkf-fusion.md §9):
 * the wide Cholesky and the products that skip exact zeros claim the
 * values of the plain textbook loops, so each is compared with those loops
 * here, on random inputs of every size up to 67 (8-, 4-, 2- and 1-wide
 * blocks, odd and even counts), with random row spans (the block-diagonal
 * C of a stacked model, and arbitrary ones).
 *
 *  - dkf__chol_wide: bit for bit equal to dkf__chol and to the
 *    Cholesky-Banachiewicz loop (memcmp), also in place, and -1 for a
 *    matrix that is not positive definite;
 *  - each kernel in both instances (kernels.h: baseline and, where this CPU
 *    has it, AVX), the AVX one bit for bit the baseline one's;
 *  - dkf__whiten_spans, dkf__tn_self_spans, dkf__mul_nt_spans: equal (==)
 *    to the dense loops, which sum every term from +0 in index order; the
 *    skipped terms are exact zeros, which can change only the sign of a
 *    zero result, and == does not see that sign. tn_self's result is
 *    exactly symmetric (memcmp of the mirror).
 *  - the fusion centre's snapshot length DKF__DIFFKF_CARRY_LEN equals the
 *    core's layout (dkf__diffkf_carry_len);
 *  - A^+ and B^{-1} of a block-diagonal model, computed block by block,
 *    keep the whole matrix's rank and singularity conditions;
 *  - dkf__mul_nn_sym, whose vector builds mirror square blocks by
 *    shuffles, gives the textbook loop's bits (memcmp) at every shape up
 *    to NCAP; so does dkf__mul_nn at every column count up to NCAP.
 * A test that could fail: changing any one term's order (e.g. the +0 start
 * of chol_wide_cols) or span start breaks the memcmp / == checks.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "diffkf_internal.h"
#include "dkf/diffkf.h"
#include "dkf_test.h"
#include "kernels.h"

#define NMAX 67
#define NCAP (NMAX < DKF_MAX_DIM ? NMAX : DKF_MAX_DIM)

static dkf_real_t A[NMAX * NMAX], W[NMAX * NMAX], W2[NMAX * NMAX], T[NMAX * NMAX];
static dkf_real_t Y[NMAX * NMAX], O[NMAX * NMAX], R[NMAX * NMAX], inv[NMAX], inv2[NMAX];
static size_t lo[NMAX], hi[NMAX];

static void rand_spd(test_rng_t *g, dkf_real_t *a, size_t n)
{
    static double d[NMAX * NMAX];
    test_rand_spd(g, d, n, 1e3, 1.0);
    test_to_real(a, d, n * n);
}

/* 1 if every element of a equals b's (==: +0 and -0 are equal). */
static int same_values(const dkf_real_t *a, const dkf_real_t *b, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i)
        if (!(a[i] == b[i])) return 0;
    return 1;
}

/* The instances to check: the baseline one, and the AVX one where this
 * CPU runs it (kernels.h); isa_count() of them. */
static int isa_count(void)
{
    static int said;
    if (!said) {
        print_message("kernels: baseline instance%s\n",
                      dkf__isa_avx() ? " and AVX instance (this CPU has AVX)" : " only");
        said = 1;
    }
    return dkf__isa_avx() ? 2 : 1;
}

static void test_chol_wide_bits(void **state)
{
    test_rng_t g;
    size_t n;
    int isa;
    (void)state;
    test_rng_seed(&g, 1401);
    for (n = 1; n <= NCAP; ++n)
        for (isa = 0; isa < isa_count(); ++isa) {
            rand_spd(&g, A, n);
            assert_int_equal(dkf__chol(W, inv, A, n), 0);
            test_textbook_chol(W2, A, n);
            assert_memory_equal(W, W2, n * n * sizeof *W);
            memset(W2, 0x5a, sizeof W2);
            assert_int_equal(dkf__chol_wide_isa(isa, W2, inv2, A, n, T), 0);
            assert_memory_equal(W, W2, n * n * sizeof *W);
            assert_memory_equal(inv, inv2, n * sizeof *inv);
            /* in place (W == A) */
            memcpy(W2, A, n * n * sizeof *A);
            assert_int_equal(dkf__chol_wide_isa(isa, W2, inv2, W2, n, T), 0);
            assert_memory_equal(W, W2, n * n * sizeof *W);
        }
}

static void test_chol_wide_refuses(void **state)
{
    test_rng_t g;
    size_t n, bad;
    (void)state;
    test_rng_seed(&g, 1402);
    for (n = 2; n <= NCAP; n += 3)
        for (bad = 0; bad < n; bad += 5) {
            rand_spd(&g, A, n);
            A[bad * n + bad] = -A[bad * n + bad]; /* a negative diagonal: not SPD */
            assert_int_equal(dkf__chol(W, inv, A, n), -1);
            assert_int_equal(dkf__chol_wide_isa(0, W2, inv2, A, n, T), -1);
            assert_int_equal(dkf__chol_wide(W2, inv2, A, n, T), -1);
            A[bad * n + bad] = (dkf_real_t)NAN;
            assert_int_equal(dkf__chol_wide_isa(0, W2, inv2, A, n, T), -1);
            assert_int_equal(dkf__chol_wide(W2, inv2, A, n, T), -1);
        }
}

/* Y (r x p): row i random on [lo[i], hi[i]), zero elsewhere; the spans of
 * a block-diagonal matrix (blocks of bw columns) when bw > 0, else random. */
static void spanned(test_rng_t *g, dkf_real_t *y, size_t r, size_t p, size_t bw)
{
    size_t i, j;
    for (i = 0; i < r; ++i) {
        size_t a, b;
        if (bw > 0) {
            a = (i / bw) * bw % p;
            b = a + bw < p ? a + bw : p;
        } else {
            a = (size_t)(test_rng_uniform(g) * (double)p);
            b = a + 1 + (size_t)(test_rng_uniform(g) * (double)(p - a));
            if (test_rng_uniform(g) < 0.1) b = a; /* a zero row */
        }
        for (j = 0; j < p; ++j)
            y[i * p + j] = j >= a && j < b ? (dkf_real_t)test_rng_normal(g) : DKF_R(0.0);
    }
}

static void test_whiten_spans_values(void **state)
{
    test_rng_t g;
    size_t p, r, bw, i, j, l;
    (void)state;
    test_rng_seed(&g, 1403);
    for (p = 1; p <= NCAP; p += (p < 12 ? 1 : 7))
        for (r = 1; r <= NCAP; r += (r < 12 ? 1 : 9))
            for (bw = 0; bw <= 3; ++bw) {
                rand_spd(&g, A, p);
                assert_int_equal(dkf__chol(W, inv, A, p), 0);
                spanned(&g, Y, r, p, bw);
                dkf__row_spans(lo, hi, Y, r, p);
                dkf__whiten_spans_isa(0, O, Y, W, inv, r, p, lo);
                if (isa_count() > 1) { /* the AVX instance: the same bits */
                    dkf__whiten_spans_isa(1, W2, Y, W, inv, r, p, lo);
                    assert_memory_equal(O, W2, p * r * sizeof *O);
                }
                /* textbook: column j of Y^T, forward substitution from row 0 */
                for (j = 0; j < r; ++j)
                    for (i = 0; i < p; ++i) {
                        dkf_real_t t = Y[j * p + i];
                        for (l = 0; l < i; ++l) t -= W[i * p + l] * R[l * r + j];
                        R[i * r + j] = t * inv[i];
                    }
                assert_true(same_values(O, R, p * r));
            }
}

static void test_tn_self_and_mul_nt_spans_values(void **state)
{
    test_rng_t g;
    size_t k, r, bw, i, j, l;
    (void)state;
    test_rng_seed(&g, 1404);
    for (k = 1; k <= NCAP; k += (k < 10 ? 1 : 8))
        for (r = 1; r <= NCAP; r += (r < 12 ? 1 : 5))
            for (bw = 0; bw <= 2; ++bw) {
                /* A (k x r) with column spans: the transpose of a spanned r x k */
                spanned(&g, Y, r, k, bw);
                dkf__transpose(A, Y, r, k);
                dkf__tn_self_spans_isa(0, O, A, r, k, lo);
                if (isa_count() > 1) { /* the AVX instance: the same bits */
                    dkf__tn_self_spans_isa(1, W2, A, r, k, lo);
                    assert_memory_equal(O, W2, r * r * sizeof *O);
                }
                for (i = 0; i < r; ++i)
                    for (j = 0; j < r; ++j) {
                        dkf_real_t s = DKF_R(0.0);
                        for (l = 0; l < k; ++l) s += A[l * r + i] * A[l * r + j];
                        R[i * r + j] = s;
                        assert_memory_equal(&O[i * r + j], &O[j * r + i], sizeof *O);
                    }
                assert_true(same_values(O, R, r * r));
                /* Out (k x r) = Z Y^T, Z (k x k) dense, Y's rows spanned */
                spanned(&g, W, k, k, 0);
                for (i = 0; i < k * k; ++i) W[i] += DKF_R(1.0);
                dkf__row_spans(lo, hi, Y, r, k);
                dkf__mul_nt_spans(O, W, Y, k, k, r, lo, hi);
                for (i = 0; i < k; ++i)
                    for (j = 0; j < r; ++j) {
                        dkf_real_t s = DKF_R(0.0);
                        for (l = 0; l < k; ++l) s += W[i * k + l] * Y[j * k + l];
                        R[i * r + j] = s;
                    }
                assert_true(same_values(O, R, k * r));
            }
}

/* The fusion centre snapshots the first DKF__DIFFKF_CARRY_LEN reals of its
 * central filter every step and mirrors the rest of its state: the macro
 * must be the core's layout. */
static void test_carry_len_matches_layout(void **state)
{
    static const size_t dims[][3] = {{1, 1, 1}, {4, 2, 2}, {4, 3, 2}, {3, 8, 6}, {5, 9, 9}};
    static dkf_real_t st[DKF_DIFFKF_STORAGE_LEN(5, 9, 9)], x0[5], P0[25];
    size_t c, i;
    (void)state;
    for (c = 0; c < sizeof dims / sizeof dims[0]; ++c) {
        const size_t n = dims[c][0], m = dims[c][1], p = dims[c][2];
        dkf_diffkf_t f;
        dkf_mat_t x = DKF_MAT(n, 1, x0), P = DKF_MAT(n, n, P0);
        if (m > DKF_MAX_DIM) continue;
        for (i = 0; i < n * n; ++i) P0[i] = i % (n + 1) == 0 ? DKF_R(1.0) : DKF_R(0.0);
        assert_int_equal(dkf_diffkf_init(&f, n, m, p, st, DKF_DIFFKF_STORAGE_LEN(n, m, p), &x, &P),
                         DKF_OK);
        assert_int_equal(dkf__diffkf_carry_len(&f), DKF__DIFFKF_CARRY_LEN(n, p));
        assert_true(DKF__DIFFKF_CARRY_LEN(n, p) < DKF_DIFFKF_STATE_LEN(n, m, p));
    }
}

/* A^+ and B^{-1} of a block-diagonal model are computed block by block
 * (src/diffkf.c, diag_blocks), with the whole matrix's conditions: rank
 * counts singular values above max(m, p) eps sigma_max of all of A, and a
 * pivot of B must exceed p eps max|B|. Blocks judged alone would accept
 * both matrices below (each 1 x 1 block is full rank / nonsingular by its
 * own tolerance); the whole-matrix conditions refuse them. */
static void test_block_diagonal_conditions(void **state)
{
    static dkf_real_t st[DKF_DIFFKF_STORAGE_LEN(2, 2, 2)];
    dkf_real_t I2[4] = {1, 0, 0, 1}, x0[2] = {0, 0}, H[4] = {1, 0.5, 0, 1}, Rm[4] = {1, 0, 0, 1};
    dkf_real_t D[4] = {1, 0, 0, 1}, B[4] = {0.9, 0, 0, 0.9}, Rd[4] = {0.1, 0, 0, 0.1};
    dkf_mat_t mI = DKF_MAT(2, 2, I2), mx = DKF_MAT(2, 1, x0), mH = DKF_MAT(2, 2, H),
              mR = DKF_MAT(2, 2, Rm), mA = DKF_MAT(2, 2, D), mB = DKF_MAT(2, 2, B),
              mRd = DKF_MAT(2, 2, Rd);
    dkf_ui_meas_t meas;
    dkf_ui_dyn_t dyn;
    dkf_diffkf_t f;
    (void)state;
    meas.H = &mH, meas.D = &mA, meas.R = &mR;
    dyn.F = &mI, dyn.Q = &mI, dyn.B = &mB, dyn.Rd = &mRd;
    /* A = diag(1, 1e-20): rank 1 for the whole matrix */
    D[3] = DKF_R(1e-20);
    assert_int_equal(dkf_diffkf_init(&f, 2, 2, 2, st, DKF_DIFFKF_STORAGE_LEN(2, 2, 2), &mx, &mI),
                     DKF_OK);
    assert_int_equal(dkf_diffkf_start(&f, &mI, &mI, &meas, NULL), DKF_ERR_RANK);
    /* A = diag(1, 1e-3) is full rank; B = diag(0.9, 1e-30) singular for the
     * whole matrix (1e-30 <= 2 eps 0.9) */
    D[3] = DKF_R(1e-3);
    assert_int_equal(dkf_diffkf_start(&f, &mI, &mI, &meas, NULL), DKF_OK);
    B[3] = DKF_R(1e-30);
    assert_int_equal(dkf_diffkf_gain(&f, &dyn, &meas), DKF_ERR_SINGULAR);
    B[3] = DKF_R(0.9);
    assert_int_equal(dkf_diffkf_gain(&f, &dyn, &meas), DKF_OK);
    /* the blocks' A^+ and B^{-1} against the closed form: with F = I and
     * the same H and D at both times, M = B^{-1} A^+ H F - A^+ H =
     * (1/0.9 - 1) diag(1, 1000) H */
    {
        dkf_mat_t M, K, zc;
        const double dinv[2] = {1.0, 1000.0};
        size_t r, c;
        assert_int_equal(dkf_diffkf_pending(&f, &M, &K, &zc), DKF_OK);
        for (r = 0; r < 2; ++r)
            for (c = 0; c < 2; ++c) {
                const double want = (1.0 / 0.9 - 1.0) * dinv[r] * (double)H[r * 2 + c];
                assert_true(fabs((double)M.data[r * 2 + c] - want) <=
                            64.0 * DKF_REAL_EPSILON * (1.0 + fabs(want)));
            }
    }
}

/* A random r x c matrix of reals in (-1, 1) into a. */
static void rand_mat(test_rng_t *g, dkf_real_t *a, size_t r, size_t c)
{
    size_t i;
    for (i = 0; i < r * c; ++i) a[i] = (dkf_real_t)(2.0 * test_rng_uniform(g) - 1.0);
}

/* The textbook (A B)(i,j), A r x k and B k x c row-major: summed from the
 * first product in index order, as every product kernel must. */
static dkf_real_t textbook_ij(const dkf_real_t *a, const dkf_real_t *b, size_t k, size_t c,
                              size_t i, size_t j)
{
    dkf_real_t s = a[i * k] * b[j];
    size_t l;
    for (l = 1; l < k; ++l) s += a[i * k + l] * b[l * c + j];
    return s;
}

/* dkf__mul_nn_sym: with vectors (DKF__SIMD) the product's mirror moves
 * square blocks by shuffles (kernels_inline.h, mirror_upper and
 * transpose_block), the rest one by one; it must be the textbook loop's
 * bits at every shape (every remainder of the 2- and 4-wide blocks):
 * C(i,j) = C(j,i) = D(i,j) + sum_l A(i,l) B(l,j) for j >= i, summed from
 * the first product in index order (D = NULL adds +0). The Kalman step's
 * transposes by blocks (inl_transpose_input) are compared with a build
 * without vectors by kf_paths_identical. */
static void test_sym_product_bits(void **state)
{
    static const size_t ks[] = {1, 2, 3, 5, 8, 13};
    test_rng_t g;
    size_t r, q, i, j;
    (void)state;
    test_rng_seed(&g, 1407);
    for (r = 1; r <= NCAP; ++r)
        for (q = 0; q <= sizeof ks / sizeof ks[0]; ++q) {
            const size_t k = q < sizeof ks / sizeof ks[0] ? ks[q] : r;
            int with_d;
            if (k > NCAP) continue;
            rand_mat(&g, A, r, k);
            rand_mat(&g, Y, k, r);
            rand_mat(&g, R, r, r);
            for (with_d = 0; with_d < 2; ++with_d) {
                dkf__mul_nn_sym(W, A, Y, with_d ? R : NULL, r, k);
                for (i = 0; i < r; ++i)
                    for (j = i; j < r; ++j)
                        W2[i * r + j] = W2[j * r + i] =
                            textbook_ij(A, Y, k, r, i, j) + (with_d ? R[i * r + j] : DKF_R(0.0));
                if (memcmp(W, W2, r * r * sizeof *W) != 0)
                    fail_msg("mul_nn_sym r=%zu k=%zu D %s", r, k, with_d ? "given" : "NULL");
            }
        }
}

/* dkf__mul_nn: every column count up to NCAP takes its own mix of the
 * 12- (where a vector holds 4 reals: float with SSE or NEON; the AVX
 * Kalman step's are checked by test_kf_isa and kf_paths_identical),
 * 8-, 4-, 2- and 1-wide blocks, for two rows at a time and the last of an
 * odd count; each C(i,j) must be textbook_ij's bits. */
static void test_mul_nn_bits(void **state)
{
    static const size_t ks[] = {1, 2, 3, 5, 8, 13};
    static const size_t rs[] = {1, 2, 3, 4, 5};
    test_rng_t g;
    size_t qr, qk, c, i, j;
    (void)state;
    test_rng_seed(&g, 1408);
    for (qr = 0; qr < sizeof rs / sizeof rs[0]; ++qr)
        for (qk = 0; qk < sizeof ks / sizeof ks[0]; ++qk)
            for (c = 1; c <= NCAP; ++c) {
                const size_t r = rs[qr], k = ks[qk];
                rand_mat(&g, A, r, k);
                rand_mat(&g, Y, k, c);
                dkf__mul_nn(W, A, Y, r, k, c);
                for (i = 0; i < r; ++i)
                    for (j = 0; j < c; ++j) W2[i * c + j] = textbook_ij(A, Y, k, c, i, j);
                if (memcmp(W, W2, r * c * sizeof *W) != 0)
                    fail_msg("mul_nn r=%zu k=%zu c=%zu", r, k, c);
            }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_chol_wide_bits),
        cmocka_unit_test(test_chol_wide_refuses),
        cmocka_unit_test(test_whiten_spans_values),
        cmocka_unit_test(test_tn_self_and_mul_nt_spans_values),
        cmocka_unit_test(test_carry_len_matches_layout),
        cmocka_unit_test(test_block_diagonal_conditions),
        cmocka_unit_test(test_sym_product_bits),
        cmocka_unit_test(test_mul_nn_bits),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
