/*
 * bench/bench_kf.c - time of one dkf Kalman step (dkf_kf_predict then
 * dkf_kf_update) for (n, m) = (4,2), (8,4), (12,6), through the public API
 * exactly as an application calls it.
 *
 * The real type is the library's (DKF_REAL at configure time): build one
 * bench directory per type (run_bench.sh does). bench_common.h has the
 * models, the data and the timing method, shared with bench_kf_eigen.cpp.
 */
#include "bench_common.h"

#include "dkf/kf.h"

#if DKF_USE_FLOAT
#define BENCH_TYPE "float"
#else
#define BENCH_TYPE "double"
#endif

/* The model of the current case in the library's real type. */
static struct {
    size_t n, m;
    dkf_real_t F[BENCH_NMAX * BENCH_NMAX];
    dkf_real_t Q[BENCH_NMAX * BENCH_NMAX];
    dkf_real_t H[BENCH_MMAX * BENCH_NMAX];
    dkf_real_t R[BENCH_MMAX * BENCH_MMAX];
    dkf_real_t x0[BENCH_NMAX];
    dkf_real_t P0[BENCH_NMAX * BENCH_NMAX];
    dkf_real_t Y[BENCH_NMEAS * BENCH_MMAX];
} cur;

static dkf_real_t kf_storage[DKF_KF_STORAGE_LEN(BENCH_NMAX, BENCH_MMAX)];

static void to_real(dkf_real_t *dst, const double *src, int count)
{
    int i;
    for (i = 0; i < count; ++i) dst[i] = (dkf_real_t)src[i];
}

static void prepare(int c, const bench_model_t *md)
{
    int n = md->n, m = md->m;
    (void)c;
    cur.n = (size_t)n;
    cur.m = (size_t)m;
    to_real(cur.F, md->F, n * n);
    to_real(cur.Q, md->Q, n * n);
    to_real(cur.H, md->H, m * n);
    to_real(cur.R, md->R, m * m);
    to_real(cur.x0, md->x0, n);
    to_real(cur.P0, md->P0, n * n);
    to_real(cur.Y, md->Y, BENCH_NMEAS * m);
}

static double run(long steps)
{
    const size_t n = cur.n, m = cur.m;
    dkf_kf_t kf;
    dkf_mat_t F = DKF_MAT(n, n, cur.F), Q = DKF_MAT(n, n, cur.Q);
    dkf_mat_t H = DKF_MAT(m, n, cur.H), R = DKF_MAT(m, m, cur.R);
    dkf_mat_t x0 = DKF_MAT(n, 1, cur.x0), P0 = DKF_MAT(n, n, cur.P0);
    dkf_mat_t y = DKF_MAT(m, 1, cur.Y);
    /* the model structs, made once as a user's firmware does (not per step) */
    const dkf_kf_dyn_t dyn = {&F, &Q};
    const dkf_kf_meas_t meas = {&H, &R};
    double sum = 0.0;
    long k;
    size_t i;

    if (dkf_kf_init(&kf, n, m, kf_storage, sizeof kf_storage / sizeof kf_storage[0], &x0, &P0) !=
        DKF_OK)
        return NAN;
    for (k = 0; k < steps; ++k) {
        y.data = cur.Y + (size_t)(k % BENCH_NMEAS) * m;
        if (dkf_kf_predict(&kf, &dyn, NULL) != DKF_OK) return NAN;
        if (dkf_kf_update(&kf, &meas, &y) != DKF_OK) return NAN;
    }
    for (i = 0; i < n; ++i) sum += (double)kf.x.data[i] + (double)DKF_AT(&kf.P, i, i);
    return sum;
}

int main(int argc, char **argv)
{
    return bench_main(argc, argv, "dkf", BENCH_TYPE, prepare, run);
}
