/*
 * ASKF, OTSKF (dkf/askf.h, dkf/otskf.h) and the information filter
 * (dkf/info.h) where the measurements pin the state, against 60-digit
 * references (tests/vectors/stress/aug.json, info.json;
 * tools/make_stress_vectors.py; every input float32-exact):
 *   aug   the KF on [x; d] with m = n + p (the ASKF exactly, the OTSKF
 *         algebraically), P0 in [1e4, 1e6], Pd0 = 1e4 I, R in [1e-4,
 *         1e-3], 5 steps: P+ ~ 1e-4, 1e8..1e10 below P;
 *   info  two sensors of n/2 rows (the KF on the stacked measurement),
 *         the same scales, 5 predict + fuse steps.
 * Every committed covariance must be PSD up to rounding; a step that would
 * commit one that is not must fail with the filter bit-identical.
 *
 * Bounds, per case (kappa = the largest cond([H A]) or cond(stacked C) of
 * its steps). Double, external: a gain carries cond(S) eps = kappa^2 eps,
 * and the Joseph forms (ASKF via dkf_kf, OTSKF's two updates) and the
 * information form (sums of Gram matrices, then a Cholesky inverse) pass
 * it to P+ without the O(eps |P| / |P+|) amplification of a subtraction
 * from P: 10 (N + m) kappa^2 eps, N the filter's state dimension. The
 * OTSKF's combined P = P^x + V P^d V^T adds the rounding of V = U - K^x S,
 * which is the same order. The OTSKF's bias filter, though, takes as its
 * noise Sx = H P^x_{k|k-1} H^T + R, which carries the state's prior
 * uncertainty: its products round at rho |P+| (rho = max|P_{k|k-1}| /
 * max|P_{k|k}|, from the vector) and its gain at cond(Sx) <~ rho kappa,
 * so the OTSKF's external bound is 10 (n + m) rho kappa eps (observed
 * 4e-8 on the first update, rho = 2e6: the two-stage decomposition's
 * price, which the ASKF does not pay). Float: the same formulas are the
 * promise, and every P PSD; a float OTSKF step may instead be refused
 * (DKF_ERR_NOT_SPD, filter unchanged), which ends that case for it.
 * Regression bounds: 4x the worst observed (printed
 * by the test). Short form (DKF_JOSEPH=0): P - K H P loses |P| eps / |P+|
 * ~ 1e-6..1e-2 relative; only the PSD property (or a refusal) is asserted.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/askf.h"
#include "dkf/info.h"
#include "dkf/diffkf.h"
#include "dkf/otskf.h"
#include "dkf/uif.h"
#include "dkf_test.h"

#define NM 6 /* largest n, m, n + p in the vectors */

/* Worst relative errors of one filter over a case: x, P, d, Pd. */
typedef struct {
    double e[4], kappa2, rho_kappa;
} errs_t;

static void note(errs_t *w, size_t i, double e)
{
    if (!(e <= w->e[i])) w->e[i] = e;
}

/* Compares (x, P, d, Pd) with step st's reference and checks P, Pd PSD. */
static void compare_aug(errs_t *w, const json_t *st, const dkf_real_t *x, const dkf_real_t *P,
                        const dkf_real_t *d, const dkf_real_t *Pd, size_t n, size_t p)
{
    double r[NM * NM];
    const double k = json_number_value(test_json_get(st, "cond_H"));
    const double rho = json_number_value(test_json_get(st, "rho"));
    if (k * k > w->kappa2) w->kappa2 = k * k;
    if (rho * k > w->rho_kappa) w->rho_kappa = rho * k;
    test_json_array(test_json_get(st, "x"), r, NM * NM, NULL, NULL);
    note(w, 0, test_rel_err(x, r, n));
    test_json_array(test_json_get(st, "P"), r, NM * NM, NULL, NULL);
    note(w, 1, test_rel_err(P, r, n * n));
    test_json_array(test_json_get(st, "d"), r, NM * NM, NULL, NULL);
    note(w, 2, test_rel_err(d, r, p));
    test_json_array(test_json_get(st, "Pd"), r, NM * NM, NULL, NULL);
    note(w, 3, test_rel_err(Pd, r, p * p));
    assert_true(test_psd_within(P, n, 4.0 * NM * TEST_EPS));
    assert_true(test_psd_within(Pd, p, 4.0 * NM * TEST_EPS));
}

/* ext_scale: kappa^2 (ASKF) or rho kappa (OTSKF; see the top). */
static void check_errs(const char *who, const errs_t *w, size_t N, size_t m, double ext_scale,
                       const double seen[4])
{
    static const char *what[] = {"x", "P", "d", "Pd"};
    const double ext = 10.0 * (double)(N + m) * ext_scale * TEST_EPS;
    size_t i;
    char msg[64];
    print_message("%s: worst rel error x %.3e P %.3e d %.3e Pd %.3e (cond^2 %.3g, bound %.3e)\n",
                  who, w->e[0], w->e[1], w->e[2], w->e[3], w->kappa2, ext);
    for (i = 0; i < 4; ++i) {
#if DKF_JOSEPH || DKF_USE_FLOAT
        snprintf(msg, sizeof msg, "%s %s external", who, what[i]);
        test_assert_below(msg, w->e[i], ext);
        snprintf(msg, sizeof msg, "%s %s regression", who, what[i]);
        test_assert_below(msg, w->e[i], 4 * seen[i]);
#else
        (void)msg, (void)what, (void)ext, (void)seen;
#endif
    }
}

typedef struct {
    DKF_ASKF_DECLARE(, askf, 3, 5, 2);
    DKF_OTSKF_DECLARE(, otskf, 3, 5, 2);
} aug_box_t;

/* worst observed, [case][filter][x P d Pd] (a float OTSKF is refused on
 * its first update in both cases: no numbers) */
#if DKF_USE_FLOAT
static const double seen_aug[2][2][4] = {{{3.6e-4, 1.9e-3, 3.4e-4, 2.2e-3}, {1, 1, 1, 1}},
                                         {{5.1e-3, 2.3e-1, 5.1e-3, 2.5e-1}, {1, 1, 1, 1}}};
#else
static const double seen_aug[2][2][4] = {{{1.03e-12, 6.9e-16, 8.9e-13, 4.5e-15},
                                          {5.5e-13, 4.1e-8, 7.9e-13, 4.7e-8}},
                                         {{2.6e-12, 7.0e-15, 2.6e-12, 4.6e-15},
                                          {3.7e-11, 8.8e-8, 7.7e-11, 8.7e-8}}};
#endif

/* One case through the ASKF and the OTSKF, then the bounds of each. */
static void aug_case(const test_stress_case_t *sc, size_t c)
{
    static aug_box_t b;
    const size_t n = sc->n, m = sc->m, p = sc->p;
    dkf_real_t ds[NM], Pds[NM * NM], Px[NM * NM], Pd[NM * NM];
    dkf_mat_t d0, Pd0, xv, dv, Pxv = test_view(n, n, Px), Pdv = test_view(p, p, Pd);
    errs_t wa = {{0, 0, 0, 0}, 0, 0}, wo = {{0, 0, 0, 0}, 0, 0};
    int ots_live = 1; /* 0 once a float OTSKF step was refused */
    size_t j;
    assert_true(m > 0 && p > 0); /* the case gives "m" and "p" */
    test_json_mat(test_json_get(sc->node, "d0"), ds, NM, &d0);
    test_json_mat(test_json_get(sc->node, "Pd0"), Pds, NM * NM, &Pd0);
    assert_int_equal(dkf_askf_init(&b.askf, n, m, p, b.askf_storage, DKF_ASKF_STORAGE_LEN(n, m, p),
                                   &sc->mx0, &sc->mP0, &d0, &Pd0, NULL),
                     DKF_OK);
    assert_int_equal(dkf_otskf_init(&b.otskf, n, m, p, b.otskf_storage,
                                    DKF_OTSKF_STORAGE_LEN(n, m, p), &sc->mx0, &sc->mP0, &d0,
                                    &Pd0),
                     DKF_OK);
    for (j = 0; j < json_array_size(sc->steps); ++j) {
        const json_t *st = json_array_get(sc->steps, j);
        static test_ui_step_t s;
        const int has_dyn = json_object_get(st, "F") != NULL;
        test_load_ui_step(&s, st, has_dyn);
        if (has_dyn) assert_int_equal(dkf_askf_predict(&b.askf, &s.dyn), DKF_OK);
        assert_int_equal(dkf_askf_update(&b.askf, &s.meas, &s.ym), DKF_OK);
        assert_int_equal(dkf_askf_state(&b.askf, &xv, &Pxv), DKF_OK);
        assert_int_equal(dkf_askf_input(&b.askf, &dv, &Pdv), DKF_OK);
        compare_aug(&wa, st, xv.data, Px, dv.data, Pd, n, p);
        if (ots_live) {
            static dkf_real_t snap[DKF_OTSKF_STATE_LEN(3, 2)];
            const size_t len = DKF_OTSKF_STATE_LEN(n, p);
            dkf_status_t sp = DKF_OK, su;
            memcpy(snap, b.otskf_storage, len * sizeof *snap);
            if (has_dyn) sp = dkf_otskf_predict(&b.otskf, &s.dyn);
            su = sp == DKF_OK ? dkf_otskf_update(&b.otskf, &s.meas, &s.ym) : sp;
            if (DKF_USE_FLOAT && su == DKF_ERR_NOT_SPD && sp == DKF_OK) {
                /* refused: the state is that after the predict, which
                 * succeeded; check the update left it alone by
                 * repeating it */
                memcpy(snap, b.otskf_storage, len * sizeof *snap);
                assert_int_equal(dkf_otskf_update(&b.otskf, &s.meas, &s.ym), su);
                assert_memory_equal(snap, b.otskf_storage, len * sizeof *snap);
            } else if (DKF_USE_FLOAT && su == DKF_ERR_NOT_SPD) {
                assert_memory_equal(snap, b.otskf_storage, len * sizeof *snap);
            }
            if (DKF_USE_FLOAT && su == DKF_ERR_NOT_SPD) {
                print_message("%s step %zu: float OTSKF refused (NOT_SPD)\n", sc->name, j);
                ots_live = 0;
            } else {
                assert_int_equal(su, DKF_OK);
                compare_aug(&wo, st, b.otskf.x.data, b.otskf.P.data, b.otskf.d.data,
                            b.otskf.Pd.data, n, p);
                assert_true(test_psd_within(b.otskf.Px.data, n, 4.0 * NM * TEST_EPS));
            }
        }
    }
    check_errs(c == 0 ? "ASKF n2p1" : "ASKF n3p2", &wa, n + p, m, wa.kappa2, seen_aug[c][0]);
    if (ots_live)
        check_errs(c == 0 ? "OTSKF n2p1" : "OTSKF n3p2", &wo, n, m, wo.rho_kappa,
                   seen_aug[c][1]);
}

static void test_askf_otskf_pinned(void **state)
{
    static const char *const names[] = {"aug_n2_p1", "aug_n3_p2"};
    (void)state;
    test_stress_cases("stress/aug.json", names, 2, aug_case);
}

/* ---- information filter -------------------------------------------------- */

typedef struct {
    DKF_INFO_DECLARE(, f, NM);
} info_box_t;

/* worst observed, [case][x P] */
#if DKF_USE_FLOAT
static const double seen_info[2][2] = {{5.9e-6, 5.1e-6}, {3.8e-4, 3.7e-4}};
#else
static const double seen_info[2][2] = {{1.2e-14, 2.2e-14}, {8.2e-13, 6.2e-13}};
#endif

/* One case: the two sensors fused every step, against the reference. */
static void info_case(const test_stress_case_t *sc, size_t c)
{
    static info_box_t b;
    const size_t n = sc->n;
    dkf_real_t F[NM * NM], Q[NM * NM];
    dkf_real_t C[NM * NM], R[NM * NM], z[NM], work[DKF_INFO_CONTRIB_WORK(NM, NM)];
    dkf_real_t iv[2][NM], Im[2][NM * NM];
    dkf_mat_t Fm, Qm, Cm, Rm, zm, ivm[2], Imm[2];
    double r[NM * NM], ex = 0, eP = 0, k2 = 0, ext;
    size_t j, s;
    assert_int_equal(
        dkf_info_init(&b.f, n, b.f_storage, DKF_INFO_STORAGE_LEN(n), &sc->mx0, &sc->mP0), DKF_OK);
    for (j = 0; j < json_array_size(sc->steps); ++j) {
        const json_t *st = json_array_get(sc->steps, j), *sens = test_json_get(st, "sensors");
        const double k = json_number_value(test_json_get(st, "cond_H"));
        if (k * k > k2) k2 = k * k;
        if (json_object_get(st, "F") != NULL) {
            test_json_mat(test_json_get(st, "F"), F, NM * NM, &Fm);
            test_json_mat(test_json_get(st, "Q"), Q, NM * NM, &Qm);
            assert_int_equal(dkf_info_predict(&b.f, &(dkf_kf_dyn_t){&Fm, &Qm}), DKF_OK);
        }
        for (s = 0; s < 2; ++s) {
            const json_t *se = json_array_get(sens, s);
            test_json_mat(test_json_get(se, "C"), C, NM * NM, &Cm);
            test_json_mat(test_json_get(se, "R"), R, NM * NM, &Rm);
            test_json_mat(test_json_get(se, "z"), z, NM, &zm);
            ivm[s] = test_view(n, 1, iv[s]);
            Imm[s] = test_view(n, n, Im[s]);
            assert_int_equal(dkf_info_contribution(&ivm[s], &Imm[s], &(dkf_kf_meas_t){&Cm, &Rm}, &zm, work),
                             DKF_OK);
            assert_true(test_psd_within(Im[s], n, 4.0 * NM * TEST_EPS));
        }
        assert_int_equal(dkf_info_fuse(&b.f, ivm, Imm, 2), DKF_OK);
        test_json_array(test_json_get(st, "x"), r, NM * NM, NULL, NULL);
        if (!(test_rel_err(b.f.x.data, r, n) <= ex)) ex = test_rel_err(b.f.x.data, r, n);
        test_json_array(test_json_get(st, "P"), r, NM * NM, NULL, NULL);
        if (!(test_rel_err(b.f.P.data, r, n * n) <= eP))
            eP = test_rel_err(b.f.P.data, r, n * n);
        assert_true(test_psd_within(b.f.P.data, n, 4.0 * NM * TEST_EPS));
    }
    ext = 10.0 * (double)(2 * n) * k2 * TEST_EPS;
    print_message("info n%zu: worst rel error x %.3e P %.3e (cond^2 %.3g, bound %.3e)\n", n,
                  ex, eP, k2, ext);
    test_assert_below("info x external", ex, ext);
    test_assert_below("info P external", eP, ext);
    test_assert_below("info x regression", ex, 4 * seen_info[c][0]);
    test_assert_below("info P regression", eP, 4 * seen_info[c][1]);
}

static void test_info_pinned(void **state)
{
    static const char *const names[] = {"info_n4", "info_n6"};
    (void)state;
    test_stress_cases("stress/info.json", names, 2, info_case);
}

/* ---- an indefinite covariance is refused, the filter untouched ----------- */

/* Inputs that make the new covariance indefinite while every factorisation
 * on the way succeeds (an indefinite Q or R is the caller's error, and the
 * step must say so rather than commit an indefinite P):
 *   OTSKF  predict with Q = diag(1, -3) from P^x = I: P^x = diag(2, -2);
 *   uif    NRTSF-DF, H = 0 (a Kalman step), C = [1 1], P = I, R = -1.5:
 *          R~ = 0.5 > 0, P+ = [[-1, -2], [-2, -1]];
 *   DKF    Q_1 = diag(1, -3) with H = [1 0] (which does not see Q's
 *          negative direction, so Ru and L stay SPD): P_{2|1} indefinite.
 * Each must return DKF_ERR_NOT_SPD with its estimates and covariances
 * bit-identical. (Before the checks all three returned OK.) */
static void test_indefinite_covariance_refused(void **state)
{
    DKF_OTSKF_DECLARE(static, ot, 2, 2, 1);
    DKF_UIF_DECLARE(static, uf, 2, 1, 1);
    DKF_DIFFKF_DECLARE(static, df, 2, 1, 1);
    static dkf_real_t snap[64];
    dkf_real_t x0d[2] = {1, 2}, Id[4] = {1, 0, 0, 1}, Qd[4] = {1, 0, 0, -3}, one[1] = {1};
    dkf_real_t Hd2[4] = {1, 0, 0, 1}, Ad2[2] = {1, 1}, Cd[2] = {1, 1}, Rneg[1] = {-1.5};
    dkf_real_t zero[1] = {0}, Hd[2] = {1, 0}, y2[2] = {0.5, 0.25}, y1[1] = {0.5};
    dkf_real_t Gd[2] = {0, 0};
    dkf_mat_t x0 = test_view(2, 1, x0d), I2 = test_view(2, 2, Id), Q = test_view(2, 2, Qd);
    dkf_mat_t I1 = test_view(1, 1, one), d0 = test_view(1, 1, one), H2 = test_view(2, 2, Hd2);
    dkf_mat_t A2 = test_view(2, 1, Ad2), Y2 = test_view(2, 1, y2), C = test_view(1, 2, Cd);
    dkf_mat_t Rn = test_view(1, 1, Rneg), Z1 = test_view(1, 1, zero), H = test_view(1, 2, Hd);
    dkf_mat_t Y1 = test_view(1, 1, y1), G = test_view(2, 1, Gd);
    (void)state;
    { /* OTSKF */
        dkf_ui_dyn_t dyn = {&I2, &Q, &I1, &I1};
        const size_t len = DKF_OTSKF_STATE_LEN(2, 1);
        (void)H2, (void)A2, (void)Y2;
        assert_int_equal(dkf_otskf_init(&ot, 2, 2, 1, ot_storage, DKF_OTSKF_STORAGE_LEN(2, 2, 1),
                                        &x0, &I2, &d0, &I1),
                         DKF_OK);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_otskf_predict(&ot, &dyn), ot_storage, len);
    }
    { /* uif, NRTSF-DF with H = 0: a Kalman step with R = -1.5 */
        dkf_ui_meas_t meas = {&C, &Z1, &Rn};
        const size_t len = DKF__UIF_OUT_LEN(2, 1, 1);
        assert_int_equal(dkf_uif_init(&uf, DKF_UIF_NRTSF_DF, 2, 1, 1, uf_storage,
                                      DKF_UIF_STORAGE_LEN(2, 1, 1), &x0, &I2),
                         DKF_OK);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NOT_SPD, dkf_uif_step(&uf, NULL, &meas, &Y1),
                             uf.x.data, len);
        (void)G;
    }
    { /* DKF: n = 2, m = p = 1, Q_1 indefinite */
        dkf_ui_meas_t meas = {&H, &I1, &I1};
        dkf_ui_dyn_t dyn = {&I2, &Q, &I1, &I1};
        double before[12];
        assert_int_equal(dkf_diffkf_init(&df, 2, 1, 1, df_storage,
                                         DKF_DIFFKF_STORAGE_LEN(2, 1, 1), &x0, &I2),
                         DKF_OK);
        assert_int_equal(dkf_diffkf_start(&df, &I2, &I2, &meas, &Y1), DKF_OK);
        test_to_double(before, df.xf.data, 2);
        test_to_double(before + 2, df.Pf.data, 4);
        test_to_double(before + 6, df.xn.data, 2);
        test_to_double(before + 8, df.Pn.data, 4);
        assert_int_equal(dkf_diffkf_step(&df, &dyn, &meas, &Y1), DKF_ERR_NOT_SPD);
        assert_true(test_max_abs_diff(df.xf.data, before, 2) == 0.0);
        assert_true(test_max_abs_diff(df.Pf.data, before + 2, 4) == 0.0);
        assert_true(test_max_abs_diff(df.xn.data, before + 6, 2) == 0.0);
        assert_true(test_max_abs_diff(df.Pn.data, before + 8, 4) == 0.0);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_askf_otskf_pinned),
        cmocka_unit_test(test_info_pinned),
        cmocka_unit_test(test_indefinite_covariance_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
