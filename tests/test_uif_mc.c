/*
 * Unknown-input filters (dkf/uif.h): Monte-Carlo consistency on the seed-004
 * example system (docs/design/derivation-seed003-004.md §7). For an unbiased configuration the normalised
 * estimation error squared at a fixed step, averaged over R independent
 * runs, is chi-square(dof * R) / R when the reported covariance is right;
 * we require it inside the two-sided 99.9 % band. The biased NRTSF-DF
 * configuration (d_1 != 0, flagged) must fall far outside it.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/uif.h"
#include "dkf_test.h"
#include "uif_paper.h"

#define N 5
#define P 3
#define M 5
#define RUNS 1000
#define STEPS 40

typedef struct {
    DKF_UIF_DECLARE(, f, N, M, P);
} box_t;

/* the system of uif_paper.h; P0 = 0.1 I */
#define P0_DIAG 0.1

/* Two-sided 99.9 % band of chi2(nu) / R (Wilson-Hilferty, accurate to a
 * fraction of a percent for nu >= 100). */
static void chi2_band(double nu, double runs, double *lo, double *hi)
{
    const double z = 3.2905, c = 2.0 / (9.0 * nu);
    *lo = nu * pow(1.0 - c - z * sqrt(c), 3.0) / runs;
    *hi = nu * pow(1.0 - c + z * sqrt(c), 3.0) / runs;
}

/* The derivation's §7 input: d1 = d1amp sin(2 pi k / 40), d2 steps, d3 square. */
static void input_at(size_t k, double d1amp, double *d)
{
    d[0] = d1amp * sin(2.0 * 3.141592653589793 * (double)k / 40.0);
    d[1] = (k >= 10 && k < 60) ? 2.0 : ((k >= 60 && k < 80) ? -1.0 : 0.0);
    d[2] = ((k / 15) % 2 == 0) ? 1.5 : -1.5;
}

typedef struct {
    double x_nees;   /* mean over runs at the last step, state */
    double d_nees;   /* same, estimable input components */
    double j_nees;   /* joint [x; d] (RTSF only, checks Pxd) */
    double x_avg;    /* state NEES averaged over runs and steps 10.. (info) */
    size_t d_dof;
} mc_t;

/* R runs of `kind` on the paper system (H modified by `h30`: H[3][0]). */
static void monte_carlo(dkf_uif_kind_t kind, double h30, double d1amp, mc_t *out)
{
    static box_t b;
    const int df = kind != DKF_UIF_NRTSF;
    double Q[25], LQ[25], LR[25], P0[25] = {0};
    dkf_real_t rA[25], rG[15], rQ[25], rC[25], rH[15], rR[25], x0r[5] = {0}, P0r[25], yr[5];
    dkf_mat_t mA, mG, mQ, mC, mH, mR, mx0, mP0, my;
    dkf_uif_dyn_t dyn;
    dkf_ui_meas_t meas;
    test_rng_t rng;
    size_t run, k, i, j, est[P], ne = 0, avg_n = 0;
    double H[15], C[25] = {0};
    memset(out, 0, sizeof *out);
    for (i = 0; i < 25; ++i) Q[i] = 1e-2 * PR[i];
    for (i = 0; i < 5; ++i) C[i * 5 + i] = 1.0, P0[i * 5 + i] = P0_DIAG;
    memcpy(H, PH, sizeof H);
    H[3 * 3 + 0] = h30;
    if (!df) memset(H, 0, sizeof H);
    test_dchol(LQ, Q, 5);
    test_dchol(LR, PR, 5);
    test_to_real(rA, PA, 25), test_to_real(rG, PG, 15), test_to_real(rQ, Q, 25);
    test_to_real(rC, C, 25), test_to_real(rH, H, 15), test_to_real(rR, PR, 25);
    test_to_real(P0r, P0, 25);
    mA = test_view(5, 5, rA), mG = test_view(5, 3, rG), mQ = test_view(5, 5, rQ);
    mC = test_view(5, 5, rC), mH = test_view(5, 3, rH), mR = test_view(5, 5, rR);
    mx0 = test_view(5, 1, x0r), mP0 = test_view(5, 5, P0r), my = test_view(5, 1, yr);
    dyn.F = &mA, dyn.G = &mG, dyn.Q = &mQ;
    meas.H = &mC, meas.D = df ? &mH : NULL, meas.R = &mR;
    test_rng_seed(&rng, 2021 + (uint64_t)kind * 7 + (uint64_t)(d1amp * 3));

    for (run = 0; run < RUNS; ++run) {
        double x[5], d[3], dprev[3], w[5], v[5], sd = sqrt(P0_DIAG);
        for (i = 0; i < 5; ++i) x[i] = sd * test_rng_normal(&rng);
        assert_int_equal(dkf_uif_init(&b.f, kind, N, M, P, b.f_storage,
                                      DKF_UIF_STORAGE_LEN(N, M, P), &mx0, &mP0),
                         DKF_OK);
        input_at(0, d1amp, dprev);
        for (k = 0; k < STEPS; ++k) {
            /* DF: step k is time k. NRTSF: step k is time k + 1. */
            const size_t t = df ? k : k + 1;
            input_at(t, d1amp, d);
            if (t > 0) { /* x_t = A x + G d_{t-1} + w */
                double xn[5];
                test_draw(&rng, w, LQ, 5);
                for (i = 0; i < 5; ++i) {
                    xn[i] = w[i];
                    for (j = 0; j < 5; ++j) xn[i] += PA[i * 5 + j] * x[j];
                    for (j = 0; j < 3; ++j) xn[i] += PG[i * 3 + j] * dprev[j];
                }
                memcpy(x, xn, sizeof x);
            }
            test_draw(&rng, v, LR, 5);
            for (i = 0; i < 5; ++i) {
                double yi = x[i] + v[i]; /* C = I */
                for (j = 0; j < 3; ++j) yi += H[i * 3 + j] * d[j];
                yr[i] = (dkf_real_t)yi;
            }
            assert_int_equal(dkf_uif_step(&b.f, (df && k == 0) ? NULL : &dyn, &meas, &my),
                             DKF_OK);
            {
                double ex[5], Px[25];
                for (i = 0; i < 5; ++i) ex[i] = x[i] - (double)b.f.x.data[i];
                test_to_double(Px, b.f.Px.data, 25);
                if (k >= 10) {
                    out->x_avg += test_nees(ex, Px, 5);
                    ++avg_n;
                }
                if (k == STEPS - 1) {
                    /* input: the estimable components (estimable == FULL),
                     * d_t (DF) or d_{t-1} (NRTSF) */
                    const double *dd = df ? d : dprev;
                    double ed[3], Pd[9], ej[8], Pj[64];
                    ne = 0;
                    for (i = 0; i < 3; ++i)
                        if (b.f.estimable[i] == DKF_UIF_EST_FULL) est[ne++] = i;
                    for (i = 0; i < ne; ++i) {
                        ed[i] = dd[est[i]] - (double)b.f.d.data[est[i]];
                        for (j = 0; j < ne; ++j) Pd[i * ne + j] = (double)b.f.Pd.data[est[i] * 3 + est[j]];
                    }
                    out->x_nees += test_nees(ex, Px, 5) / RUNS;
                    out->d_nees += test_nees(ed, Pd, ne) / RUNS;
                    out->d_dof = ne;
                    if (kind == DKF_UIF_RTSF) { /* joint [x; d] with Pxd */
                        for (i = 0; i < 8; ++i) ej[i] = i < 5 ? ex[i] : dd[i - 5] - (double)b.f.d.data[i - 5];
                        for (i = 0; i < 8; ++i)
                            for (j = 0; j < 8; ++j)
                                Pj[i * 8 + j] = (double)(i < 5 ? (j < 5 ? b.f.Px.data[i * 5 + j] : b.f.Pxd.data[i * 3 + j - 5])
                                                               : (j < 5 ? b.f.Pxd.data[j * 3 + i - 5] : b.f.Pd.data[(i - 5) * 3 + j - 5]));
                        out->j_nees += test_nees(ej, Pj, 8) / RUNS;
                    }
                }
            }
            memcpy(dprev, d, sizeof d);
        }
    }
    out->x_avg /= (double)avg_n;
}

static void check_band(const char *what, double value, double dof)
{
    double lo, hi;
    chi2_band(dof * RUNS, RUNS, &lo, &hi);
    print_message("%-28s NEES %.3f  (dof %g, 99.9%% band [%.3f, %.3f])\n", what, value, dof, lo,
                  hi);
    assert_true(value >= lo && value <= hi);
}

/* The unbiased configurations: the state NEES, the NEES of the d_dof
 * estimable input components and, for RTSF, the joint [x; d] NEES (which
 * checks the cross-covariance Pxd), each inside its band. */
typedef struct {
    const char *name, *d_what;
    dkf_uif_kind_t kind;
    double h30, d1amp; /* monte_carlo's */
    size_t d_dof;
} unbiased_t;

static const unbiased_t unbiased[] = {
    /* RTSF on the paper system with H[3][0] = 1 */
    {"RTSF", "RTSF d", DKF_UIF_RTSF, 1.0, 1.0, 3},
    /* NRTSF-DF on the paper's rank-2 H with d_1 = 0 (derivation §7) */
    {"NRTSF-DF (d1 = 0)", "NRTSF-DF (d1 = 0) d2, d3", DKF_UIF_NRTSF_DF, 0.0, 0.0, 2},
    /* NRTSF on the paper system with H = 0 (unbiased for every d) */
    {"NRTSF", "NRTSF d1, d2 (delayed)", DKF_UIF_NRTSF, 0.0, 1.0, 2},
};

static void check_unbiased(const unbiased_t *c)
{
    char what[64];
    mc_t r;
    monte_carlo(c->kind, c->h30, c->d1amp, &r);
    assert_int_equal(r.d_dof, c->d_dof);
    snprintf(what, sizeof what, "%s x", c->name);
    check_band(what, r.x_nees, 5);
    check_band(c->d_what, r.d_nees, (double)c->d_dof);
    if (c->kind == DKF_UIF_RTSF) check_band("RTSF [x; d]", r.j_nees, 8);
    print_message("%s x NEES/n averaged over steps 10..%d: %.3f\n", c->name, STEPS - 1,
                  r.x_avg / 5);
}

static void test_uif_mc_rtsf(void **state)
{
    (void)state;
    check_unbiased(&unbiased[0]);
}

static void test_uif_mc_nrtsf_df_unbiased(void **state)
{
    (void)state;
    check_unbiased(&unbiased[1]);
}

static void test_uif_mc_nrtsf(void **state)
{
    (void)state;
    check_unbiased(&unbiased[2]);
}

/* The paper's own NRTSF-DF example, d_1 = sin: flagged, and indeed
 * inconsistent (derivation §8: NEES_x / n = 17.6). */
static void test_uif_mc_nrtsf_df_biased(void **state)
{
    mc_t r;
    double lo, hi;
    (void)state;
    monte_carlo(DKF_UIF_NRTSF_DF, 0.0, 1.0, &r);
    chi2_band(5.0 * RUNS, RUNS, &lo, &hi);
    print_message("NRTSF-DF (d1 = sin) x NEES %.2f at the last step, %.2f/n averaged: outside [%.3f, %.3f]\n",
                  r.x_nees, r.x_avg / 5, lo, hi);
    assert_true(r.x_nees > 2.0 * hi);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_uif_mc_rtsf),
        cmocka_unit_test(test_uif_mc_nrtsf_df_unbiased),
        cmocka_unit_test(test_uif_mc_nrtsf),
        cmocka_unit_test(test_uif_mc_nrtsf_df_biased),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
