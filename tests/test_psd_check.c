/*
 * dkf__psd_within_rounding (src/kernels.h), the check every filter runs
 * on the covariances it is about to commit: for a symmetric n x n P
 * (lower triangle read), 1 if lambda_min(P) >= -delta with
 * delta = 4 n eps tr(P) + REAL_MIN, else 0, up to rounding; 0 if P has a
 * NaN or Inf. Its pivots
 * are those of an LDL^T factorisation (psd_pivots in kernels_inline.h).
 *
 * The matrices have known eigenvalues: P = Q diag(lambda) Q^T with Q a
 * random orthogonal matrix, computed in double and rounded once to the
 * build's real type. Rounding P's entries moves an eigenvalue by at most
 * n eps max|P(i,j)| <= n eps tr|P| = delta / 4, and the LDL^T's backward
 * error, (n + 1) eps |P|, is about as much again; so the verdict is fixed
 * wherever lambda_min is more than delta / 2 away from -delta:
 *  - PSD and singular (lambda_min = 0, and half of the eigenvalues 0),
 *    P = 0, and lambda_min = -delta / 8 (inside the threshold) must be
 *    accepted;
 *  - lambda_min = -2 delta must be refused, whatever the spread of the
 *    other eigenvalues (1 .. 1e-3) and wherever Q puts the negative
 *    direction; the two bounds bracket the threshold within a factor 16;
 *  - a negative diagonal entry beyond delta and a negative trace are
 *    refused at their pivot;
 *  - only the lower triangle is read: an upper triangle that makes the
 *    matrix indefinite (or one that makes an indefinite one PSD) changes
 *    nothing;
 *  - a NaN, +Inf or -Inf at any position of a symmetric P (both mirror
 *    entries) is refused, from a PSD P and from P = I: the Kalman step
 *    and the DKF rely on it and scan a P only when the check fails.
 *    Every position up to n = 17; above, the diagonal and the columns 0,
 *    1, n/2, n-2, n-1 (a bounded run time under ASan and qemu).
 * dkf__psd_sym_within_rounding, the variant the Kalman step and the DKF
 * run on their mirrored covariances, must give the same verdict in every
 * case, for P's lower triangle mirrored (check()).
 * Sizes 1 .. 17 (every remainder of the vector loops in double and
 * float), 24, 33, 48 and, in builds whose DKF_MAX_DIM allows, 67;
 * 8 random Q per size. A check that always passes, one without the shift
 * delta, one with twice the shift, or one that reads the upper triangle
 * fails a case here (each tried by hand on the source, 2026-12-05).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "dkf_test.h"
#include "kernels.h"

#define NMAX 67
#define SEEDS 8

static double Pd[NMAX * NMAX];
static dkf_real_t P[NMAX * NMAX], Ps[NMAX * NMAX], W[NMAX * NMAX], P0[NMAX * NMAX];

static const size_t sizes[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 24, 33,
                               48, 67};
#define NSIZES (sizeof sizes / sizeof sizes[0])

/* P = Q diag(lambda) Q^T, Q random orthogonal, rounded to dkf_real_t. */
static void with_eigenvalues(test_rng_t *g, const double *lambda, size_t n)
{
    test_sym_with_eigenvalues(g, Pd, lambda, n);
    test_to_real(P, Pd, n * n);
}

/* lambda = 1 .. 1e-3, log-spaced, in a random order, then its last
 * `low` entries replaced by `value`; returns the trace. */
static double spectrum(test_rng_t *g, double *lambda, size_t n, size_t low, double value)
{
    double tr = 0.0;
    size_t i;
    for (i = 0; i < n; ++i)
        lambda[i] = n == 1 ? 1.0 : pow(10.0, -3.0 * (double)i / (double)(n - 1));
    for (i = n; i > 1; --i) { /* Fisher-Yates */
        size_t k = (size_t)(test_rng_uniform(g) * (double)i);
        double t = lambda[i - 1];
        lambda[i - 1] = lambda[k];
        lambda[k] = t;
    }
    for (i = n - low; i < n; ++i) lambda[i] = value;
    for (i = 0; i < n; ++i) tr += lambda[i];
    return tr;
}

/* P with eigenvalues 1 .. 1e-3 (random order), one of them, at a random
 * place, replaced by v = -a delta of that P: delta = 4 n eps tr and
 * tr = rest + v give v = -c rest / (1 + c), c = 4 a n eps. */
static void with_lambda_min(test_rng_t *g, size_t n, double a)
{
    double lambda[NMAX];
    const double c = 4.0 * a * (double)n * TEST_EPS;
    const size_t z = (size_t)(test_rng_uniform(g) * (double)n);
    const double rest = spectrum(g, lambda, n, 0, 0.0) - lambda[z];
    lambda[z] = -c * rest / (1.0 + c);
    with_eigenvalues(g, lambda, n);
}

/* P with eigenvalues 1 .. 1e-3 (random order), the last `zeros` of them
 * replaced by 0. */
static void with_zeros(test_rng_t *g, size_t n, size_t zeros)
{
    double lambda[NMAX];
    (void)spectrum(g, lambda, n, zeros, 0.0);
    with_eigenvalues(g, lambda, n);
}

/* P = I (n x n). */
static void identity(size_t n)
{
    size_t i;
    memset(P, 0, sizeof P);
    for (i = 0; i < n; ++i) P[i * n + i] = DKF_R(1.0);
}

/* The verdict of dkf__psd_within_rounding, which reads P's lower
 * triangle; dkf__psd_sym_within_rounding, the variant for an exactly
 * symmetric P, must give the same one for P's lower triangle mirrored. */
static int check(size_t n)
{
    const int v = dkf__psd_within_rounding(W, P, n);
    size_t i, j;
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) Ps[i * n + j] = j <= i ? P[i * n + j] : P[j * n + i];
    if (dkf__psd_sym_within_rounding(W, Ps, n) != v)
        fail_msg("n=%zu: the symmetric variant says %d, the check %d", n, !v, v);
    return v;
}

static size_t cap(void)
{
    size_t k = 0;
    while (k < NSIZES && sizes[k] <= DKF_MAX_DIM) ++k;
    return k;
}

static void test_psd_singular_accepted(void **state)
{
    test_rng_t g;
    size_t k, s;
    (void)state;
    test_rng_seed(&g, 0x5eed0001u);
    for (k = 0; k < cap(); ++k) {
        const size_t n = sizes[k];
        for (s = 0; s < SEEDS; ++s) {
            with_zeros(&g, n, 1); /* one zero eigenvalue */
            if (!check(n)) fail_msg("n=%zu seed %zu: PSD, lambda_min = 0, refused", n, s);
            with_zeros(&g, n, (n + 1) / 2); /* half of them 0 */
            if (!check(n)) fail_msg("n=%zu seed %zu: PSD of rank %zu refused", n, s, n / 2);
            with_lambda_min(&g, n, 0.125);
            if (!check(n)) fail_msg("n=%zu seed %zu: lambda_min = -delta/8 refused", n, s);
        }
        memset(P, 0, sizeof P);
        assert_true(check(n)); /* P = 0: tr 0, delta = REAL_MIN */
    }
}

static void test_indefinite_refused(void **state)
{
    test_rng_t g;
    size_t k, s;
    (void)state;
    test_rng_seed(&g, 0x5eed0002u);
    for (k = 0; k < cap(); ++k) {
        const size_t n = sizes[k];
        if (n == 1) continue; /* the one eigenvalue is the trace: test_negative_diagonal_... */
        for (s = 0; s < SEEDS; ++s) {
            with_lambda_min(&g, n, 2.0);
            if (check(n)) fail_msg("n=%zu seed %zu: lambda_min = -2 delta accepted", n, s);
        }
    }
}

static void test_negative_diagonal_and_trace(void **state)
{
    size_t k, i;
    (void)state;
    for (k = 0; k < cap(); ++k) {
        const size_t n = sizes[k];
        identity(n);
        P[(n - 1) * n + n - 1] = DKF_R(-0.5); /* the last pivot */
        assert_false(check(n));
        for (i = 0; i < n; ++i) P[i * n + i] = DKF_R(-1.0); /* tr < 0: delta < 0 */
        assert_false(check(n));
        P[0] = DKF_R(-1e-30); /* alone on the diagonal, tr < 0 */
        for (i = 1; i < n; ++i) P[i * n + i] = DKF_R(0.0);
        assert_false(check(n));
    }
}

static void test_lower_triangle_read(void **state)
{
    test_rng_t g;
    size_t k, i, j;
    (void)state;
    test_rng_seed(&g, 0x5eed0003u);
    for (k = 0; k < cap(); ++k) {
        const size_t n = sizes[k];
        if (n < 2) continue;
        /* PSD lower triangle, huge upper: still accepted */
        with_zeros(&g, n, 1);
        for (i = 0; i < n; ++i)
            for (j = i + 1; j < n; ++j) P[i * n + j] = DKF_R(1e3);
        if (!check(n)) fail_msg("n=%zu: the upper triangle was read (PSD refused)", n);
        /* indefinite lower triangle (P(1,0) = 2 max diag), identity's upper */
        identity(n);
        P[1 * n + 0] = DKF_R(2.0);
        if (check(n)) fail_msg("n=%zu: the upper triangle was read (indefinite accepted)", n);
    }
}

/* Whether test_nonfinite_refused tries position (i, j), j <= i. */
static int column_tried(size_t n, size_t i, size_t j)
{
    return n <= 17 || i == j || j < 2 || j == n / 2 || j + 2 >= n;
}

/* Sets P(i,k) and P(k,i) to v; returns the old value. */
static dkf_real_t put_sym(size_t n, size_t i, size_t k, dkf_real_t v)
{
    const dkf_real_t old = P[i * n + k];
    P[i * n + k] = v;
    P[k * n + i] = v;
    return old;
}

static void test_nonfinite_refused(void **state)
{
    const dkf_real_t bad[3] = {(dkf_real_t)NAN, (dkf_real_t)INFINITY, -(dkf_real_t)INFINITY};
    test_rng_t g;
    size_t k, i, j, b, base;
    (void)state;
    test_rng_seed(&g, 0x5eed0004u);
    for (k = 0; k < cap(); ++k) {
        const size_t n = sizes[k];
        for (base = 0; base < 2; ++base) {
            if (base == 0) { /* PSD, one zero eigenvalue */
                with_zeros(&g, n, 1);
            } else { /* I */
                identity(n);
            }
            assert_true(check(n));
            for (i = 0; i < n; ++i)
                for (j = 0; j <= i; ++j)
                    for (b = 0; b < 3 && column_tried(n, i, j); ++b) {
                        const dkf_real_t old = put_sym(n, i, j, bad[b]);
                        if (check(n))
                            fail_msg("n=%zu P(%zu,%zu) = %g accepted (%s)", n, i, j,
                                     (double)bad[b], base == 0 ? "PSD" : "I");
                        (void)put_sym(n, i, j, old);
                    }
        }
    }
}

/* The verdict does not depend on P's scale: P times 2^e, exact for every
 * entry (the exponents keep the entries of 1e-10 .. 67 normal), must be
 * accepted (lambda_min = 0, or -delta/8) or refused (-2 delta) as P is.
 * The exponents take the shifted trace inside and outside the window
 * where the check runs unscaled (2^+-32 in float, 2^+-256 in double) and
 * to where a pivot pair's a c and b^2 of the unscaled P would overflow or
 * underflow: a check without its scale refuses the large PSD ones. */
static void test_scale_invariant(void **state)
{
#if DKF_USE_FLOAT
    static const int ex[] = {-90, -60, -34, -30, 30, 34, 60, 110};
#else
    static const int ex[] = {-900, -600, -258, -250, 250, 258, 600, 1000};
#endif
    static const double a_of[] = {0.0, 0.125, 2.0}; /* lambda_min = -a delta */
    test_rng_t g;
    size_t k, s, q, x, i;
    (void)state;
    test_rng_seed(&g, 0x5eed0006u);
    for (k = 0; k < cap(); ++k) {
        const size_t n = sizes[k];
        for (s = 0; s < 2; ++s)
            for (q = 0; q < sizeof a_of / sizeof a_of[0]; ++q) {
                const int want = a_of[q] < 1.0;
                if (n == 1 && !want) continue; /* as in test_indefinite_refused */
                if (a_of[q] == 0.0) {
                    with_zeros(&g, n, 1);
                } else {
                    with_lambda_min(&g, n, a_of[q]);
                }
                memcpy(P0, P, n * n * sizeof *P);
                for (x = 0; x < sizeof ex / sizeof ex[0]; ++x) {
                    const dkf_real_t f = (dkf_real_t)ldexp(1.0, ex[x]);
                    memcpy(P, P0, n * n * sizeof *P);
                    for (i = 0; i < n * n; ++i) P[i] *= f;
                    if (check(n) != want)
                        fail_msg("n=%zu seed %zu: lambda_min = -(%g delta), times 2^%d, %s", n, s,
                                 a_of[q], ex[x], want ? "refused" : "accepted");
                }
            }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_psd_singular_accepted),
        cmocka_unit_test(test_indefinite_refused),
        cmocka_unit_test(test_negative_diagonal_and_trace),
        cmocka_unit_test(test_lower_triangle_read),
        cmocka_unit_test(test_nonfinite_refused),
        cmocka_unit_test(test_scale_invariant),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
