/*
 * bench/bench_uif.c - per-step cost of the three unknown-input filters on
 * seed 000 Example 1, in ONE run: the Difference KF (dkf_diffkf_step), the
 * augmented-state KF (dkf_askf_predict + _update) and the optimal two-stage
 * KF (dkf_otskf_predict + _update). The paper reports 9.27 s : 16.16 s :
 * 11.68 s for DKF : ASKF : OTSKF, i.e. 1 : 1.74 : 1.26.
 *
 * Model: tests/vectors/diffkf/ex1_single.json `model` (library notation:
 * state n = 4, measurement m = 2, unknown input p = 2), constant:
 *   F = [1 1 0 0; 0 1 0 0; 0 0 1 1; 0 0 0 1], Q = diag(1, .1, 1, .1),
 *   H = [1 0 0 0; 0 0 1 0], D = I2, R = I2, B = 0.9 I2, Rd = I2;
 * priors of `init`: x00 = (50, 1, 50, 1), P00 = diag(1, .1, 1, .1),
 * d00 = (5, 5), Pd00 = I2 (ASKF, OTSKF; the DKF needs no d prior).
 * Data: one trajectory of that model simulated in double with
 * bench_common.h's splitmix64 generator (fixed seed), BENCH_NMEAS
 * measurements cycled (step k uses y[k mod BENCH_NMEAS]; the jump at the
 * wrap is just a large innovation: the cost of a step does not depend on
 * the data).
 *
 * Output, one line per filter (same columns as the KF benchmark):
 *   impl type n m ns_per_step steps_per_repeat repeats checksum
 * with impl uif-dkf, uif-askf, uif-otskf; checksum = sum(x) + trace(P_x)
 * after BENCH_CHECK_STEPS steps (the filters estimate different things
 * from the same data; it is printed, not compared).
 *
 * Options: --filter NAME (dkf, askf or otskf; default all three, back to
 * back), --repeats R, --target-ms T, --steps S (as bench_kf;
 * callgrind.sh uses --filter with --steps S and --steps 0).
 */
#include "bench_common.h"

#include "dkf/askf.h"
#include "dkf/diffkf.h"
#include "dkf/otskf.h"

#if DKF_USE_FLOAT
#define BENCH_TYPE "float"
#else
#define BENCH_TYPE "double"
#endif

#define UN 4
#define UM 2
#define UP 2

static dkf_real_t mF[UN * UN], mQ[UN * UN], mH[UM * UN], mD[UM * UP], mR[UM * UM], mB[UP * UP],
    mRd[UP * UP], mx0[UN], mP0[UN * UN], md0[UP], mPd0[UP * UP];
static dkf_real_t mY[BENCH_NMEAS * UM];

static dkf_mat_t vF = DKF_MAT(UN, UN, mF), vQ = DKF_MAT(UN, UN, mQ), vH = DKF_MAT(UM, UN, mH),
                 vD = DKF_MAT(UM, UP, mD), vR = DKF_MAT(UM, UM, mR), vB = DKF_MAT(UP, UP, mB),
                 vRd = DKF_MAT(UP, UP, mRd), vx0 = DKF_MAT(UN, 1, mx0),
                 vP0 = DKF_MAT(UN, UN, mP0), vd0 = DKF_MAT(UP, 1, md0),
                 vPd0 = DKF_MAT(UP, UP, mPd0);
static dkf_ui_dyn_t dyn;
static dkf_ui_meas_t meas;

static void make_model(void)
{
    static const double F[UN * UN] = {1, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1};
    static const double Qd[UN] = {1.0, 0.1, 1.0, 0.1};
    static const double H[UM * UN] = {1, 0, 0, 0, 0, 0, 1, 0};
    static const double x0[UN] = {50.0, 1.0, 50.0, 1.0};
    static const double d0[UP] = {5.0, 5.0};
    const double b = 0.9;
    bench_rng_t rng;
    double xt[UN], xn[UN], dt[UP];
    int i, j, k;

    for (i = 0; i < UN * UN; ++i) mF[i] = (dkf_real_t)F[i];
    for (i = 0; i < UM * UN; ++i) mH[i] = (dkf_real_t)H[i];
    for (i = 0; i < UN; ++i) {
        mQ[i * UN + i] = (dkf_real_t)Qd[i];
        mP0[i * UN + i] = (dkf_real_t)Qd[i]; /* P00 = diag(1, .1, 1, .1) = Q */
        mx0[i] = (dkf_real_t)x0[i];
    }
    for (i = 0; i < UM; ++i) {
        mD[i * UP + i] = 1;
        mR[i * UM + i] = 1;
    }
    for (i = 0; i < UP; ++i) {
        mB[i * UP + i] = (dkf_real_t)b;
        mRd[i * UP + i] = 1;
        mPd0[i * UP + i] = 1;
        md0[i] = (dkf_real_t)d0[i];
    }
    dyn.F = &vF, dyn.Q = &vQ, dyn.B = &vB, dyn.Rd = &vRd;
    meas.H = &vH, meas.D = &vD, meas.R = &vR;

    /* x_{k+1} = F x_k + v, d_{k+1} = B d_k + wd, y_k = H x_k + D d_k + w */
    rng.s = UINT64_C(0x5EED000E1);
    for (i = 0; i < UN; ++i) xt[i] = x0[i];
    for (i = 0; i < UP; ++i) dt[i] = d0[i];
    for (k = 0; k < BENCH_NMEAS; ++k) {
        for (i = 0; i < UN; ++i) {
            double s = 0.0;
            for (j = 0; j < UN; ++j) s += F[i * UN + j] * xt[j];
            xn[i] = s + sqrt(Qd[i]) * bench_rng_normal(&rng);
        }
        memcpy(xt, xn, sizeof xt);
        for (i = 0; i < UP; ++i) dt[i] = b * dt[i] + bench_rng_normal(&rng);
        for (i = 0; i < UM; ++i) {
            double s = dt[i] + bench_rng_normal(&rng);
            for (j = 0; j < UN; ++j) s += H[i * UN + j] * xt[j];
            mY[k * UM + i] = (dkf_real_t)s;
        }
    }
}

static double trace_plus_sum(const dkf_real_t *x, const dkf_real_t *P)
{
    double s = 0.0;
    int i;
    for (i = 0; i < UN; ++i) s += (double)x[i] + (double)P[i * UN + i];
    return s;
}

/* Each run: init from the priors, then `steps` time steps. */

static double run_dkf(long steps)
{
    DKF_DIFFKF_DECLARE(static, f, UN, UM, UP);
    dkf_mat_t y = DKF_MAT(UM, 1, mY);
    long k;
    if (dkf_diffkf_init(&f, UN, UM, UP, f_storage, DKF_DIFFKF_STORAGE_LEN(UN, UM, UP), &vx0,
                        &vP0) != DKF_OK)
        return NAN;
    if (dkf_diffkf_start(&f, &vF, &vQ, &meas, &y) != DKF_OK) return NAN;
    for (k = 1; k <= steps; ++k) {
        y.data = mY + (size_t)(k % BENCH_NMEAS) * UM;
        if (dkf_diffkf_step(&f, &dyn, &meas, &y) != DKF_OK) return NAN;
    }
    return trace_plus_sum(f.xf.data, f.Pf.data);
}

static double run_askf(long steps)
{
    DKF_ASKF_DECLARE(static, f, UN, UM, UP);
    static dkf_real_t Px[UN * UN];
    dkf_mat_t y = DKF_MAT(UM, 1, mY), x, P = DKF_MAT(UN, UN, Px);
    long k;
    if (dkf_askf_init(&f, UN, UM, UP, f_storage, DKF_ASKF_STORAGE_LEN(UN, UM, UP), &vx0, &vP0,
                      &vd0, &vPd0, NULL) != DKF_OK)
        return NAN;
    for (k = 1; k <= steps; ++k) {
        y.data = mY + (size_t)(k % BENCH_NMEAS) * UM;
        if (dkf_askf_predict(&f, &dyn) != DKF_OK) return NAN;
        if (dkf_askf_update(&f, &meas, &y) != DKF_OK) return NAN;
    }
    if (dkf_askf_state(&f, &x, &P) != DKF_OK) return NAN;
    return trace_plus_sum(x.data, Px);
}

static double run_otskf(long steps)
{
    DKF_OTSKF_DECLARE(static, f, UN, UM, UP);
    dkf_mat_t y = DKF_MAT(UM, 1, mY);
    long k;
    if (dkf_otskf_init(&f, UN, UM, UP, f_storage, DKF_OTSKF_STORAGE_LEN(UN, UM, UP), &vx0, &vP0,
                       &vd0, &vPd0) != DKF_OK)
        return NAN;
    for (k = 1; k <= steps; ++k) {
        y.data = mY + (size_t)(k % BENCH_NMEAS) * UM;
        if (dkf_otskf_predict(&f, &dyn) != DKF_OK) return NAN;
        if (dkf_otskf_update(&f, &meas, &y) != DKF_OK) return NAN;
    }
    return trace_plus_sum(f.x.data, f.P.data);
}

static const bench_filter_t filters[3] = {
    {"dkf", run_dkf}, {"askf", run_askf}, {"otskf", run_otskf}};

int main(int argc, char **argv)
{
    make_model();
    return bench_filters_main(argc, argv, "uif", BENCH_TYPE, UN, UM, filters, 3, BENCH_CHECK_STEPS);
}
