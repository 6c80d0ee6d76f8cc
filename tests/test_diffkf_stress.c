/*
 * The Difference KF (dkf/diffkf.h) where the differenced measurement z_k
 * pins the state, against 60-digit references (tests/vectors/stress/
 * diffkf.json, written by tools/make_stress_vectors.py from Theorem 1 as
 * docs/design/diffkf.md states it, (8)-(20) with the corrected lag of C_k, not
 * from src/diffkf.c; every input float32-exact): p = n, P_{1|0} eigenvalues
 * in [1e6, 1e8], Q, R, Rd in [1e-4, 1e-3], 5 steps from the prior
 * (dkf_diffkf_start with F0 = Q0 = NULL). The first step's P_{1|1} lies
 * rho = 3e9..6e9 below P_{1|0}; the later steps (rho ~ 2) check the
 * correlated-noise carry (C_k, W_{k-1}, L_{k-1}^{-1} dz_{k-1}) at
 * moderate conditioning.
 *
 * Bounds, per case (kappa = the largest cond(M_k), rho the largest
 * max|P_{k|k-1}| / max|P_{k|k}|, both from the vector). Double, external:
 * L = M P M^T + ... has cond(L) <~ rho kappa^2, and the gains K = J L^-1,
 * W = (F J + S) L^-1 carry cond(L) eps; the Joseph-type congruences of
 * docs/design/diffkf.md pass it to P_{k|k}, P_{k+1|k} without subtracting from
 * P_{k|k-1} (the short form P - K J^T adds rho eps more, which the bound
 * also covers, so only the regression bound tells the forms apart):
 * 10 (n + p) rho kappa^2 eps, relative to each reference's max|.|. Float:
 * that bound exceeds 1 (vacuous); the promise is every committed P PSD, or
 * the step refused (a DKF_ERR_NOT_SPD with the filter bit-identical ends
 * the case). Regression bounds: 4x the worst observed (printed by the
 * test). Short form (DKF_JOSEPH=0): the PSD property (or a refusal) and
 * the external bound.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/diffkf.h"
#include "dkf_test.h"

#define NX 4 /* largest n = p in the vectors */
#define MX 4 /* largest m */

/* worst relative errors over a case: xf, Pf, xn, Pn */
#define NOUT 4
/* worst observed, [case][xf Pf xn Pn] (float n4_m4: every step OK and
 * PSD, but P_{1|1} 8x off: rho cond^2 eps = 5e5, beyond float) */
#if DKF_USE_FLOAT
static const double seen[2][NOUT] = {{1.77e-4, 3.55e-4, 1.1e-4, 2.65e-4},
                                     {0.19, 7.9, 0.21, 10.4}};
#else
static const double seen[2][NOUT] = {{1.54e-15, 7.4e-16, 1.25e-15, 4.9e-16},
                                     {2.24e-13, 1.39e-13, 1.5e-13, 1.39e-13}};
#endif

typedef struct {
    DKF_DIFFKF_DECLARE(, f, NX, MX, NX);
} dkf_box_t;

/* One case: every step against the reference, then the bounds. */
static void diffkf_case(const test_stress_case_t *sc, size_t c)
{
    static const char *const what[NOUT] = {"xf", "Pf", "xn", "Pn"};
    static dkf_box_t b;
    static test_ui_step_t s;
    static dkf_real_t snap[DKF_DIFFKF_STATE_LEN(NX, MX, NX)];
    const size_t n = sc->n, m = sc->m, p = sc->p;
    const size_t len = DKF_DIFFKF_STATE_LEN(n, m, p);
    double w[NOUT] = {0, 0, 0, 0}, rk2 = 0, ext;
    size_t j;
    assert_true(m > 0 && p > 0); /* the case gives "m" and "p" */
    assert_int_equal(dkf_diffkf_init(&b.f, n, m, p, b.f_storage, DKF_DIFFKF_STORAGE_LEN(n, m, p),
                                     &sc->mx0, &sc->mP0),
                     DKF_OK);
    test_load_ui_step(&s, test_json_get(sc->node, "meas1"), 0);
    assert_int_equal(dkf_diffkf_start(&b.f, NULL, NULL, &s.meas, &s.ym), DKF_OK);
    for (j = 0; j < json_array_size(sc->steps); ++j) {
        const json_t *st = json_array_get(sc->steps, j);
        const test_out_t out[NOUT] = {{"xf", b.f.xf.data, n}, {"Pf", b.f.Pf.data, n * n},
                                      {"xn", b.f.xn.data, n}, {"Pn", b.f.Pn.data, n * n}};
        const double k = json_number_value(test_json_get(st, "cond_M"));
        const double rho = json_number_value(test_json_get(st, "rho"));
        dkf_status_t rc;
        if (rho * k * k > rk2) rk2 = rho * k * k;
        test_load_ui_step(&s, st, 1);
        memcpy(snap, b.f_storage, len * sizeof *snap);
        rc = dkf_diffkf_step(&b.f, &s.dyn, &s.meas, &s.ym);
        if (rc == DKF_ERR_NOT_SPD && (DKF_USE_FLOAT || !DKF_JOSEPH)) {
            /* allowed where the bound exceeds 1: the filter unchanged */
            print_message("%s step %zu: refused (NOT_SPD)\n", sc->name, j);
            assert_memory_equal(snap, b.f_storage, len * sizeof *snap);
            break;
        }
        assert_int_equal(rc, DKF_OK);
        test_note_rel_errs(w, st, out, NOUT);
        assert_true(test_psd_within(b.f.Pf.data, n, 4.0 * NX * TEST_EPS));
        assert_true(test_psd_within(b.f.Pn.data, n, 4.0 * NX * TEST_EPS));
    }
    ext = 10.0 * (double)(n + p) * rk2 * TEST_EPS;
    test_stress_verdict(sc->name, j, what, w, NOUT, rk2, ext,
                        DKF_JOSEPH || DKF_USE_FLOAT ? seen[c] : NULL);
}

static void test_diffkf_pinned(void **state)
{
    static const char *const names[] = {"diffkf_n3_m4", "diffkf_n4_m4"};
    (void)state;
    test_stress_cases("stress/diffkf.json", names, 2, diffkf_case);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_diffkf_pinned),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
