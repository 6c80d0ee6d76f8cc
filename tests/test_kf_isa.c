/*
 * The two instances of the Kalman step (src/kf_step.h): the baseline one
 * (kf.c; x86-64: SSE2) and, on x86-64 under GCC in double, the AVX one
 * (kf_avx.c, 32-byte vectors, no FMA), which dkf_kf_predict and
 * dkf_kf_update take when the CPU has AVX. The claim is bit identity:
 * every lane does the baseline's IEEE operations in its order.
 *
 * Two filters get the same init and the same sequence of calls, one
 * through dkf__kf_predict_isa / dkf__kf_update_isa with avx = 0, the other
 * with avx = 1; after every call the statuses must be equal and the state
 * (x, P, nu, S: DKF_KF_STATE_LEN) and the NIS equal byte for byte
 * (memcmp, no tolerance). The scratch is not compared: the PSD check's
 * lower triangle is scratch whose extent follows the vector width. Sizes: the default DKF_KF_FIXED_SIZES (4, 2), (6, 3),
 * (8, 4), (12, 6), whose steps are compiled for their size, and run-time
 * sizes around them (1 .. 33, m up to 9, one filter alternating between a
 * fixed and a run-time m). Faults at fixed steps (a NaN measurement, an
 * indefinite R, an Inf in F, an indefinite Q) must return the same error
 * from both (test_error_untouched checks that a failed step changes
 * nothing).
 * Skipped (and says so) where the build has no AVX instance (float,
 * Clang, other targets, DKF_SIMD 0) or the CPU has no AVX: there both
 * calls take the baseline step. Mutation checked by hand (2026-12-05):
 * kf_avx.c with target("avx,fma") and fp-contract=fast (340 fused
 * multiply-adds in its object) fails at the first predict.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "dkf_test.h"
#include "kf_step.h"

#define NMAX 33
#define MMAX 9
#define STEPS 30
#define LEN DKF_KF_STORAGE_LEN(NMAX, MMAX)

static const struct {
    size_t n, m_max, m_odd;
} cases[] = {
    {4, 2, 2}, {6, 3, 3}, {8, 4, 4}, {12, 6, 6}, {8, 4, 2}, {1, 1, 1}, {3, 3, 3},
    {5, 2, 1}, {7, 5, 5},  {16, 5, 5}, {24, 7, 7}, {33, 9, 9},
};

static dkf_real_t sa[LEN], sb[LEN];
static dkf_real_t F[NMAX * NMAX], Q[NMAX * NMAX], H[MMAX * NMAX], R[MMAX * MMAX], y[MMAX];
static dkf_real_t u[NMAX];
static double d[NMAX * NMAX];

static void same(const dkf_kf_t *a, const dkf_kf_t *b, size_t len, dkf_status_t ea,
                 dkf_status_t eb, size_t n, size_t k, const char *what)
{
    if (ea != eb) fail_msg("n=%zu step %zu %s: status %d (baseline) != %d (AVX)", n, k, what, ea, eb);
    if (memcmp(sa, sb, len * sizeof *sa) != 0)
        fail_msg("n=%zu step %zu %s: state differs between the instances", n, k, what);
    if (memcmp(&a->nis, &b->nis, sizeof a->nis) != 0)
        fail_msg("n=%zu step %zu %s: NIS differs", n, k, what);
}

static void run_case(test_rng_t *g, size_t n, size_t m_max, size_t m_odd)
{
    const size_t len = DKF_KF_STATE_LEN(n, m_max);
    dkf_kf_t a, b;
    dkf_mat_t x0, P0;
    dkf_real_t x0d[NMAX], P0d[NMAX * NMAX];
    size_t k, i;
    for (i = 0; i < n; ++i) x0d[i] = (dkf_real_t)test_rng_normal(g);
    test_rand_spd(g, d, n, 1e2, 1.0);
    test_to_real(P0d, d, n * n);
    x0 = test_view(n, 1, x0d);
    P0 = test_view(n, n, P0d);
    memset(sa, 0, sizeof sa);
    memset(sb, 0, sizeof sb);
    assert_int_equal(dkf_kf_init(&a, n, m_max, sa, LEN, &x0, &P0), DKF_OK);
    assert_int_equal(dkf_kf_init(&b, n, m_max, sb, LEN, &x0, &P0), DKF_OK);
    for (k = 0; k < STEPS; ++k) {
        const size_t m = k % 2 ? m_odd : m_max;
        dkf_status_t ea, eb;
        test_rand_orthogonal(g, d, n); /* F = 0.97 Q_orth: stable */
        for (i = 0; i < n * n; ++i) F[i] = (dkf_real_t)(0.97 * d[i]);
        test_rand_spd(g, d, n, 1e3, 0.01);
        test_to_real(Q, d, n * n);
        test_rand_gauss(g, d, m, n);
        test_to_real(H, d, m * n);
        test_rand_spd(g, d, m, 1e2, 0.1);
        test_to_real(R, d, m * m);
        for (i = 0; i < m; ++i) y[i] = (dkf_real_t)test_rng_normal(g);
        for (i = 0; i < n; ++i) u[i] = (dkf_real_t)(0.1 * test_rng_normal(g));
        if (k == 19) F[n * n - 1] = (dkf_real_t)INFINITY;
        if (k == 23) Q[0] = -Q[0] - DKF_R(1.0);
        ea = dkf__kf_predict_isa(0, &a, F, Q, k % 3 ? u : NULL);
        eb = dkf__kf_predict_isa(1, &b, F, Q, k % 3 ? u : NULL);
        same(&a, &b, len, ea, eb, n, k, "predict");
        if (k == 19 || k == 23) assert_int_not_equal(ea, DKF_OK);
        if (k == 7) y[m - 1] = (dkf_real_t)NAN;
        if (k == 13) R[0] = -R[0] - DKF_R(10.0);
        ea = dkf__kf_update_isa(0, &a, H, R, y, m);
        eb = dkf__kf_update_isa(1, &b, H, R, y, m);
        same(&a, &b, len, ea, eb, n, k, "update");
        if (k == 7) assert_int_equal(ea, DKF_ERR_NONFINITE);
    }
}

static void test_instances_bit_identical(void **state)
{
    test_rng_t g;
    size_t c;
    (void)state;
    if (!DKF__KF_AVX || !dkf__isa_avx()) {
        print_message("no AVX instance in this build or no AVX on this CPU: nothing to compare\n");
        skip();
    }
    test_rng_seed(&g, 0xa11ce5u);
    for (c = 0; c < sizeof cases / sizeof cases[0]; ++c)
        if (cases[c].n <= DKF_MAX_DIM && cases[c].m_max <= DKF_MAX_DIM)
            run_case(&g, cases[c].n, cases[c].m_max, cases[c].m_odd);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_instances_bit_identical),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
