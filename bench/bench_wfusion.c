/*
 * bench/bench_wfusion.c - cost of seed 002's weighted fusion against the
 * number of sensors L (dkf/wfusion.h), in ONE run:
 *
 *   wfusion-cross    dkf_wfusion_step without measurements: L local gain
 *                    recursions (Riccati steps, O(L n^3)) and the
 *                    L (L - 1) / 2 cross covariances P_ij (O(L^2 n^3))
 *   wfusion-scalar   dkf_wfusion_fuse_scalar: P_S (L x L) from the P_ij,
 *                    its Cholesky, the weights (O(L^2 n^2 + L^3))
 *   wfusion-matrix   dkf_wfusion_fuse_matrix: the joint covariance's
 *                    Cholesky (n L x n L: O(n^3 L^3 / 3)), the weights
 *
 * Model: seed 002's example (n = 4: F, Gamma Qe Gamma^T, H = (1 0 1 0),
 * Hs = (1 0 0 0)); sensor i has R_i = 0.1 + 0.1 (i mod 5) (the example's
 * five repeated). Every fusion runs after 20 steps from a common prior, so
 * the joint covariance is non-singular in exact arithmetic. Its condition
 * number grows with L (the local errors share the process noise): where
 * a Cholesky pivot falls below 64 N eps max diag (float at L = 20, 50) the
 * matrix fusion takes the KKT pseudo-inverse path (an SVD, much slower)
 * and may report the weights not unique at that precision; a comment
 * line "# wfusion L=.. matrix: ..." says so.
 *
 * The joint covariance is n L x n L and the KKT system n (L + 1): with
 * the default DKF_MAX_DIM = 48 only L <= 11 fits. bench/run_bench.sh
 * builds this program a second time with DKF_MAX_DIM = 256 for
 * L = 20 and 50; a size that does not fit is reported as "skipped".
 *
 * Output, one line per (op, L):
 *   wfusion-<op> type n L ns_per_call calls repeats checksum
 * checksum = s0 + PS0 + sum(x0) + trace(P0) after the 20 steps (the same
 * for every op of one L). Options: --L a,b,c (default 2,5,20,50),
 * --repeats R, --target-ms T, --steps S (calls per repeat, no calibration).
 */
#include "bench_common.h"

#include "dkf/wfusion.h"

#if DKF_USE_FLOAT
#define BENCH_TYPE "float"
#else
#define BENCH_TYPE "double"
#endif

#define NX 4
/* the largest L this build's DKF_MAX_DIM allows (n L + n <= DKF_MAX_DIM), at most 50 */
#define LCAP (DKF_MAX_DIM / NX - 1 < 50 ? DKF_MAX_DIM / NX - 1 : 50)

static dkf_real_t storage[DKF_WFUSION_STORAGE_LEN(NX, LCAP, 1)];
static dkf_wfusion_local_t nodes[LCAP];
static dkf_wfusion_t fu;

static dkf_real_t F[NX * NX], Q[NX * NX], Hs[NX], H[NX], R[LCAP], x0[NX], P0[NX * NX],
    yb[LCAP];
static dkf_mat_t mF, mQ, mHs, mH, mR[LCAP], mx0, mP0, my[LCAP];
static dkf_kf_dyn_t dyn;
static dkf_kf_meas_t meas[LCAP];
static size_t L;

static void model(void)
{
    static const double f[NX * NX] = {1.5, 1, 0, 0, -.56, 0, 0, 0, 0, 0, .7, 1, 0, 0, -.5, 0};
    static const double g[NX * 2] = {1, 0, .4, 0, 0, 1, 0, 0}, qe[2] = {0.8, 0.3};
    int a, b, k;
    for (a = 0; a < NX * NX; ++a) F[a] = (dkf_real_t)f[a];
    for (a = 0; a < NX; ++a)
        for (b = 0; b < NX; ++b) {
            double v = 0;
            for (k = 0; k < 2; ++k) v += g[a * 2 + k] * qe[k] * g[b * 2 + k];
            Q[a * NX + b] = (dkf_real_t)v;
        }
    for (a = 0; a < NX; ++a) {
        Hs[a] = a == 0 ? DKF_R(1.0) : DKF_R(0.0);
        H[a] = (a == 0 || a == 2) ? DKF_R(1.0) : DKF_R(0.0);
        x0[a] = DKF_R(0.0);
    }
    /* P0: a diagonal prior comparable to the stationary covariance */
    for (a = 0; a < NX * NX; ++a) P0[a] = (a % (NX + 1) == 0) ? DKF_R(5.0) : DKF_R(0.0);
    dkf_mat_init(&mF, NX, NX, F);
    dkf_mat_init(&mQ, NX, NX, Q);
    dkf_mat_init(&mHs, 1, NX, Hs);
    dkf_mat_init(&mH, 1, NX, H);
    dkf_mat_init(&mx0, NX, 1, x0);
    dkf_mat_init(&mP0, NX, NX, P0);
    dyn.F = &mF;
    dyn.Q = &mQ;
}

/* init for L sensors and 20 steps on simulated data; the checksum. */
static double prepare(size_t l)
{
    size_t m[LCAP], i, t;
    bench_rng_t rng = {0x5eed002u};
    double xt[NX] = {0, 0, 0, 0}, xn[NX];
    L = l;
    for (i = 0; i < L; ++i) {
        m[i] = 1;
        R[i] = (dkf_real_t)(0.1 + 0.1 * (double)(i % 5));
        dkf_mat_init(&mR[i], 1, 1, &R[i]);
        dkf_mat_init(&my[i], 1, 1, &yb[i]);
        meas[i].H = &mH;
        meas[i].R = &mR[i];
    }
    if (dkf_wfusion_init(&fu, NX, L, m, nodes, storage, sizeof storage / sizeof storage[0], &mHs,
                         &mx0, &mP0) != DKF_OK)
        return NAN;
    for (t = 0; t < 20; ++t) {
        const double w = bench_rng_normal(&rng) * 0.894427191, xi = bench_rng_normal(&rng) * 0.547722558;
        int a, b;
        for (a = 0; a < NX; ++a) {
            xn[a] = 0;
            for (b = 0; b < NX; ++b) xn[a] += (double)F[a * NX + b] * xt[b];
        }
        xn[0] += w, xn[1] += 0.4 * w, xn[2] += xi;
        for (a = 0; a < NX; ++a) xt[a] = xn[a];
        for (i = 0; i < L; ++i)
            yb[i] = (dkf_real_t)(xt[0] + xt[2] + sqrt((double)R[i]) * bench_rng_normal(&rng));
        if (dkf_wfusion_step(&fu, &dyn, meas, my) != DKF_OK) return NAN;
    }
    if (dkf_wfusion_fuse_scalar(&fu, NULL) != DKF_OK || dkf_wfusion_fuse_matrix(&fu, NULL) != DKF_OK)
        return NAN;
    {
        double c = (double)fu.s0 + (double)fu.PS0;
        int a;
        for (a = 0; a < NX; ++a) c += (double)fu.xf.data[a] + (double)fu.Pf.data[a * NX + a];
        return c;
    }
}

static double run_cross(long calls)
{
    long k;
    for (k = 0; k < calls; ++k)
        if (dkf_wfusion_step(&fu, &dyn, meas, NULL) != DKF_OK) return NAN;
    return (double)fu.Pj.data[0];
}
static double run_scalar(long calls)
{
    long k;
    for (k = 0; k < calls; ++k)
        if (dkf_wfusion_fuse_scalar(&fu, NULL) != DKF_OK) return NAN;
    return (double)fu.PS0;
}
static double run_matrix(long calls)
{
    long k;
    for (k = 0; k < calls; ++k)
        if (dkf_wfusion_fuse_matrix(&fu, NULL) != DKF_OK) return NAN;
    return (double)fu.Pf.data[0];
}

int main(int argc, char **argv)
{
    static const char *const names[3] = {"cross", "scalar", "matrix"};
    static const bench_run_fn runs[3] = {run_cross, run_scalar, run_matrix};
    static double per[BENCH_REPEATS_MAX];
    size_t ls[8] = {2, 5, 20, 50}, nl = 4, j;
    int repeats = 31, i, op;
    double target_ms = 20.0;
    long fixed = -1;
    for (i = 1; i < argc; ++i) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (v != NULL && strcmp(a, "--L") == 0) {
            char *e = (char *)v;
            for (nl = 0; nl < 8 && *e != '\0';) {
                long x = strtol(e, &e, 10);
                if (x < 1 || x > 1000) return 2;
                ls[nl++] = (size_t)x;
                if (*e == ',') ++e;
                else if (*e != '\0') return 2;
            }
        } else if (v != NULL && strcmp(a, "--repeats") == 0) {
            repeats = atoi(v);
        } else if (v != NULL && strcmp(a, "--target-ms") == 0) {
            target_ms = atof(v);
        } else if (v != NULL && strcmp(a, "--steps") == 0) {
            fixed = atol(v);
        } else {
            fprintf(stderr, "usage: %s [--L 2,5,20,50] [--repeats R] [--target-ms T] [--steps S]\n",
                    argv[0]);
            return 2;
        }
        ++i;
    }
    if (repeats < 1 || repeats > BENCH_REPEATS_MAX || !(target_ms > 0.0)) return 2;
    model();
    for (j = 0; j < nl; ++j) {
        double checksum;
        if (ls[j] > LCAP) {
            printf("# wfusion L=%zu skipped: n L + n = %zu > DKF_MAX_DIM = %d (build with "
                   "-DDKF_MAX_DIM=256: bench/run_bench.sh does)\n",
                   ls[j], NX * ls[j] + NX, DKF_MAX_DIM);
            continue;
        }
        for (op = 0; op < 3; ++op) {
            long calls;
            double ns, one;
            checksum = prepare(ls[j]);
            one = runs[op](1);
            if (!(checksum == checksum) || !(one == one)) {
                fprintf(stderr, "wfusion-%s L=%zu: a call failed\n", names[op], ls[j]);
                return 1;
            }
            calls = fixed >= 0 ? fixed : bench_calibrate(runs[op], target_ms);
            for (i = 0; i < repeats; ++i) {
                double t0 = bench_now_ns();
                bench_sink = runs[op](calls);
                per[i] = (bench_now_ns() - t0) / (double)(calls > 0 ? calls : 1);
            }
            ns = bench_median(per, repeats);
            printf("wfusion-%s %s %d %zu %.2f %ld %d %.17g\n", names[op], BENCH_TYPE, NX, ls[j], ns,
                   calls, repeats, checksum);
            if (op == 2 && !fu.A_unique)
                printf("# wfusion L=%zu matrix: the weights are not unique at this precision "
                       "(the joint covariance is numerically singular: the KKT path)\n", ls[j]);
            fflush(stdout);
        }
    }
    return 0;
}
