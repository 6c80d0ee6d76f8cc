/*
 * Seed 002's self-tuning fusion end to end (dkf/selftune.h feeding
 * dkf/wfusion.h): on the paper's example (5 sensors, A, C, sigma_w^2
 * unknown, P, sigma_xi^2, sigma_vi^2 known), at every step the identifier
 * takes the five measurements, its accepted estimate becomes the model
 * {F, Q} of the local filters and of the cross covariances, and the
 * scalar weights fuse the signal. Beside it the optimal fusion on the true
 * model, from the same data. Checked, on fixed-seed realisations:
 *   - the gap |s0_selftune - s0_optimal| shrinks: its RMS over
 *     t in [3000, 4000] is below 0.05 and below a fifth of its RMS over
 *     t in [50, 500] (the derivation's (docs/design/derivation-seed001-002.md) single 40 000-step run:
 *     0.65 for t < 500, 0.009 over 2000-4000);
 *   - the self-tuning fused error's MSE over t in [1000, 4000] is within
 *     5 % of the optimal one's (the derivation: 0.50081 vs 0.50037);
 *   - the self-tuning weights approach the optimal weights (max gap at
 *     t = 4000 below 0.005).
 * Measured (double, x86-64; seeds 2003-2005): gap RMS 0.11-0.14 early,
 * 0.0082-0.0123 late; MSE 0.48669 / 0.48704, 0.51675 / 0.51820,
 * 0.51160 / 0.51243 (within 0.3 %); weight gap 2-3e-4. The bounds leave
 * 4x to 16x: they are for other seeds' and compilers' luck, not for a
 * wrong model (the frozen control misses every one by 10x or more).
 * A negative control: the same fusion held at the identifier's initial
 * guesses (a = 0, c = 0, sigma_w^2 = 1) never closes the gap.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/selftune.h"
#include "dkf/wfusion.h"
#include "dkf_test.h"

#define NX 4
#define NL 5
#define T_END 4000

DKF_WFUSION_DECLARE(static, opt, NX, NL, 1);
DKF_WFUSION_DECLARE(static, st, NX, NL, 1);
DKF_SELFTUNE_DECLARE(static, id, 2, 2, 1, 5);

static const double a_true[2] = {-1.5, 0.56}, c_true = 0.4, sw2 = 0.8, sxi2 = 0.3;
static const double p_known[2] = {-0.7, 0.5}, sv2[NL] = {0.1, 0.2, 0.3, 0.4, 0.5};

static dkf_real_t F[NX * NX], Q[NX * NX], Fs[NX * NX], Qs[NX * NX], H[NX] = {1, 0, 1, 0},
    Hs[NX] = {1, 0, 0, 0}, R[NL], x0[NX], P0[NX * NX], yb[NL];
static dkf_mat_t mF, mQ, mFs, mQs, mH, mHs, mR[NL], mx0, mP0, my[NL];
static dkf_kf_dyn_t dyn_true, dyn_st;
static dkf_kf_meas_t meas[NL];

static void setup_model(void)
{
    const double f[NX * NX] = {1.5, 1, 0, 0, -.56, 0, 0, 0, 0, 0, .7, 1, 0, 0, -.5, 0};
    const double g[NX * 2] = {1, 0, .4, 0, 0, 1, 0, 0};
    size_t a, b, i;
    for (a = 0; a < NX; ++a)
        for (b = 0; b < NX; ++b) {
            F[a * NX + b] = (dkf_real_t)f[a * NX + b];
            Q[a * NX + b] = (dkf_real_t)(g[a * 2] * sw2 * g[b * 2] + g[a * 2 + 1] * sxi2 * g[b * 2 + 1]);
        }
    /* P0: a broad prior (the filters forget it within a few steps) */
    memset(P0, 0, sizeof P0);
    for (a = 0; a < NX; ++a) P0[a * NX + a] = 10, x0[a] = 0;
    mF = test_view(NX, NX, F), mQ = test_view(NX, NX, Q);
    mFs = test_view(NX, NX, Fs), mQs = test_view(NX, NX, Qs);
    mH = test_view(1, NX, H), mHs = test_view(1, NX, Hs);
    mx0 = test_view(NX, 1, x0), mP0 = test_view(NX, NX, P0);
    dyn_true.F = &mF, dyn_true.Q = &mQ;
    dyn_st.F = &mFs, dyn_st.Q = &mQs;
    for (i = 0; i < NL; ++i) {
        R[i] = (dkf_real_t)sv2[i];
        mR[i] = test_view(1, 1, &R[i]);
        my[i] = test_view(1, 1, &yb[i]);
        meas[i].H = &mH;
        meas[i].R = &mR[i];
    }
}

typedef struct {
    double gap_early, gap_late, mse_opt, mse_st, wgap_end;
} result_t;

/* One realisation: the example's signal, coloured noise and sensors
 * simulated in double with test_rng; freeze = 1 keeps the identifier's
 * initial guesses as the model (the negative control). */
static result_t run(uint64_t seed, int freeze)
{
    const size_t m[NL] = {1, 1, 1, 1, 1};
    dkf_selftune_cfg_t cfg;
    dkf_selftune_est_t est;
    dkf_real_t pk[2], svk[NL];
    test_rng_t rng;
    double s[3] = {0, 0, 0}, w[2] = {0, 0}, eta[3] = {0, 0, 0}, xi_prev = 0;
    double ge = 0, gl = 0, mo = 0, ms = 0;
    size_t ne = 0, nlate = 0, nm = 0, t, i;
    result_t r;
    test_rng_seed(&rng, seed);
    assert_int_equal(dkf_selftune_config_default(&cfg), DKF_OK);
    for (i = 0; i < 2; ++i) pk[i] = (dkf_real_t)p_known[i];
    for (i = 0; i < NL; ++i) svk[i] = (dkf_real_t)sv2[i];
    cfg.np = 2;
    cfg.p = pk;
    cfg.sigma_xi2 = (dkf_real_t)sxi2;
    cfg.L = NL;
    cfg.sigma_v2 = svk;
    assert_int_equal(dkf_selftune_init(&id, &cfg, id_storage, sizeof id_storage / sizeof id_storage[0]),
                     DKF_OK);
    assert_int_equal(dkf_wfusion_init(&opt, NX, NL, m, opt_nodes, opt_storage,
                                      sizeof opt_storage / sizeof opt_storage[0], &mHs, &mx0, &mP0),
                     DKF_OK);
    assert_int_equal(dkf_wfusion_init(&st, NX, NL, m, st_nodes, st_storage,
                                      sizeof st_storage / sizeof st_storage[0], &mHs, &mx0, &mP0),
                     DKF_OK);
    for (t = 1; t <= T_END; ++t) {
        /* A s(t) = C w(t-1): s(t) = 1.5 s(t-1) - 0.56 s(t-2) + w(t-1) + 0.4 w(t-2);
         * P eta(t) = xi(t-1) */
        const double wn = sqrt(sw2) * test_rng_normal(&rng), xin = sqrt(sxi2) * test_rng_normal(&rng);
        double st_now, eta_now, gap, e_opt, e_st;
        st_now = -a_true[0] * s[0] - a_true[1] * s[1] + w[0] + c_true * w[1];
        eta_now = -p_known[0] * eta[0] - p_known[1] * eta[1] + xi_prev;
        s[1] = s[0], s[0] = st_now;
        eta[1] = eta[0], eta[0] = eta_now;
        w[1] = w[0], w[0] = wn;
        xi_prev = xin;
        for (i = 0; i < NL; ++i)
            yb[i] = (dkf_real_t)(st_now + eta_now + sqrt(sv2[i]) * test_rng_normal(&rng));
        /* the identifier, then the model it has accepted (its guesses
         * before t_min) */
        assert_int_equal(dkf_selftune_update(&id, yb), DKF_OK);
        assert_int_equal(dkf_selftune_estimate(&id, &est), DKF_OK);
        if (freeze) est.t_accepted = 0, est.a[0] = est.a[1] = 0, est.c1 = 0, est.sigma_w2 = 1;
        assert_int_equal(dkf_selftune_model(&id, &est, &mFs, &mQs), DKF_OK);
        assert_int_equal(dkf_wfusion_step(&opt, &dyn_true, meas, my), DKF_OK);
        assert_int_equal(dkf_wfusion_step(&st, &dyn_st, meas, my), DKF_OK);
        assert_int_equal(dkf_wfusion_fuse_scalar(&opt, NULL), DKF_OK);
        assert_int_equal(dkf_wfusion_fuse_scalar(&st, NULL), DKF_OK);
        gap = (double)(st.s0 - opt.s0);
        e_opt = (double)opt.s0 - st_now;
        e_st = (double)st.s0 - st_now;
        if (t >= 50 && t <= 500) ge += gap * gap, ++ne;
        if (t >= 3000) gl += gap * gap, ++nlate;
        if (t >= 1000) mo += e_opt * e_opt, ms += e_st * e_st, ++nm;
    }
    r.gap_early = sqrt(ge / (double)ne);
    r.gap_late = sqrt(gl / (double)nlate);
    r.mse_opt = mo / (double)nm;
    r.mse_st = ms / (double)nm;
    r.wgap_end = 0;
    for (i = 0; i < NL; ++i) r.wgap_end = fmax(r.wgap_end, fabs((double)(st.w.data[i] - opt.w.data[i])));
    return r;
}

static void test_selftuning_converges(void **state)
{
    static const uint64_t seeds[3] = {2003, 2004, 2005};
    size_t k;
    (void)state;
    setup_model();
    for (k = 0; k < 3; ++k) {
        const result_t r = run(seeds[k], 0);
        printf("# seed %llu: gap RMS t 50-500 %.4f, 3000-4000 %.4f; MSE 1000-4000 optimal %.5f "
               "self-tuning %.5f; max |w_st - w_opt| at t = %d: %.4f\n",
               (unsigned long long)seeds[k], r.gap_early, r.gap_late, r.mse_opt, r.mse_st, T_END,
               r.wgap_end);
        assert_true(r.gap_late < 0.05);
        assert_true(r.gap_late < r.gap_early / 5);
        assert_true(fabs(r.mse_st - r.mse_opt) < 0.05 * r.mse_opt);
        assert_true(r.wgap_end < 0.005);
    }
}

static void test_frozen_guess_does_not_converge(void **state)
{
    result_t r;
    (void)state;
    setup_model();
    r = run(2003, 1);
    printf("# frozen guesses: gap RMS 3000-4000 %.4f, MSE optimal %.5f frozen %.5f\n", r.gap_late,
           r.mse_opt, r.mse_st);
    assert_true(r.gap_late > 0.1);
    assert_true(r.mse_st > 1.1 * r.mse_opt);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_selftuning_converges),
        cmocka_unit_test(test_frozen_guess_does_not_converge),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
