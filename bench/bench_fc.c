/*
 * bench/bench_fc.c - cost of one Difference-KF fusion-centre step
 * (dkf_diffkf_fc_step, dkf/diffkf_fusion.h) against the number of nodes N,
 * in ONE run (docs/results/bench.md).
 *
 * Model (time-invariant, so the core's pinv / inverse / model-block caches
 * hit after the first step, as in a deployed centre): n = 4, a damped
 * constant-velocity pair F; node i has m_i = 2 + (i mod 2) measurements and
 * p_i = 2 unknown inputs (B^i = 0.9 I, Rd^i = 0.05 I), H^i, D^i fixed
 * pseudo-random (seed 1400 + i; D^i of full column rank), R^i diagonal. The
 * nodes run their own Difference KF on simulated data (seed 14); only the
 * fusion-centre call is timed (clock_gettime around each call).
 *
 * The stacked model has sum m_i = 2.5 N rows and sum p_i = 2 N inputs, so
 * DKF_MAX_DIM limits N: with the default 48 only N <= 19 fits
 * (bench/run_bench.sh builds this program a second time with
 * DKF_MAX_DIM = 1024 for the large N); an N that does not fit is reported
 * as a comment line "# fc-step N=..: skipped (...)".
 *
 * Output, one line per N:
 *   fc-step type n N steady_ns first_ns start_ns storage_bytes calls repeats checksum
 * steady_ns is the median, over every call but the first of every repeat,
 * of the time of one fc_step: the cost of a step of a deployed centre.
 * first_ns is the median over repeats of the first call after fc_start,
 * which computes the model-only block (docs/design/diffkf-fusion.md §9; a
 * time-varying model pays it every step); start_ns the median of
 * dkf_diffkf_fc_init + dkf_diffkf_fc_start; storage_bytes the centre's
 * storage (dkf_diffkf_fc_storage_len reals). checksum = sum(central x_{k|k}) + trace(central P_{k|k}) after the last
 * step (the same whatever the speed: a change of the numbers shows here).
 * Options: --N a,b,c (default 2,12,50,100,200), --repeats R (default 3),
 * --steps S (calls per repeat; default 40000 / N^2 + 20).
 */
#include "bench_common.h"

#include "dkf/diffkf_fusion.h"

#if DKF_USE_FLOAT
#define BENCH_TYPE "float"
#else
#define BENCH_TYPE "double"
#endif

#define NX 4
#define NP 2
#define NMAX_M 3
/* the largest N this build's DKF_MAX_DIM allows (sum m_i <= 2.5 N + 1), at most 400 */
#define NCAP_RAW ((2 * DKF_MAX_DIM - 2) / 5)
#define NCAP (NCAP_RAW < 400 ? NCAP_RAW : 400)

static dkf_real_t storage[DKF_DIFFKF_FC_STORAGE_LEN(NX, NCAP, NMAX_M, NP)];
static dkf_diffkf_fc_node_t fc_nodes[NCAP];
static dkf_diffkf_fc_t fc;
static dkf_real_t node_store[NCAP][DKF_DIFFKF_STORAGE_LEN(NX, NMAX_M, NP)];
static dkf_diffkf_t node[NCAP];
static dkf_diffkf_msg_t msgs[NCAP];
static dkf_diffkf_sensor_t sensors[NCAP];
static size_t mi[NCAP], pi[NCAP];
/* per-call times: one repeat's, and every repeat's calls after the first */
#define STEPS_MAX 20000L
static double call_ns[STEPS_MAX], steady_ns[64 * STEPS_MAX];

static dkf_real_t F[NX * NX], Q[NX * NX], x0[NX], P0[NX * NX], B[NP * NP], Rd[NP * NP];
static dkf_real_t H[NCAP][NMAX_M * NX], D[NCAP][NMAX_M * NP], R[NCAP][NMAX_M * NMAX_M];
static dkf_real_t y[NCAP][NMAX_M];
static dkf_mat_t mF, mQ, mx0, mP0, mB, mRd, mH[NCAP], mD[NCAP], mR[NCAP], my[NCAP];
static double xs[NX], ds[NCAP][NP];

static void model(size_t N)
{
    size_t i, j;
    const double dt = 0.1;
    memset(F, 0, sizeof F);
    memset(Q, 0, sizeof Q);
    memset(P0, 0, sizeof P0);
    F[0] = (dkf_real_t)1.0, F[1] = (dkf_real_t)dt, F[5] = (dkf_real_t)0.98;
    F[10] = (dkf_real_t)1.0, F[11] = (dkf_real_t)dt, F[15] = (dkf_real_t)0.98;
    for (i = 0; i < NX; ++i) {
        Q[i * NX + i] = (dkf_real_t)(i % 2 ? 0.02 : 0.01);
        P0[i * NX + i] = (dkf_real_t)1.0;
        x0[i] = (dkf_real_t)0.0;
    }
    memset(B, 0, sizeof B);
    memset(Rd, 0, sizeof Rd);
    for (i = 0; i < NP; ++i) {
        B[i * NP + i] = (dkf_real_t)0.9;
        Rd[i * NP + i] = (dkf_real_t)0.05;
    }
    mF = (dkf_mat_t)DKF_MAT(NX, NX, F);
    mQ = (dkf_mat_t)DKF_MAT(NX, NX, Q);
    mx0 = (dkf_mat_t)DKF_MAT(NX, 1, x0);
    mP0 = (dkf_mat_t)DKF_MAT(NX, NX, P0);
    mB = (dkf_mat_t)DKF_MAT(NP, NP, B);
    mRd = (dkf_mat_t)DKF_MAT(NP, NP, Rd);
    for (i = 0; i < N; ++i) {
        bench_rng_t r;
        double h[NMAX_M * NX], d[NMAX_M * NP];
        r.s = 1400u + (uint64_t)i;
        mi[i] = 2 + i % 2;
        pi[i] = NP;
        bench_rand_gauss(&r, h, (int)(mi[i] * NX));
        bench_rand_gauss(&r, d, (int)(mi[i] * NP));
        d[0] += 2.0, d[NP + 1] += 2.0; /* full column rank, well conditioned */
        for (j = 0; j < mi[i] * NX; ++j) H[i][j] = (dkf_real_t)h[j];
        for (j = 0; j < mi[i] * NP; ++j) D[i][j] = (dkf_real_t)d[j];
        memset(R[i], 0, sizeof R[i]);
        for (j = 0; j < mi[i]; ++j) R[i][j * mi[i] + j] = (dkf_real_t)(0.1 + 0.05 * (double)j);
        mH[i] = (dkf_mat_t)DKF_MAT(mi[i], NX, H[i]);
        mD[i] = (dkf_mat_t)DKF_MAT(mi[i], NP, D[i]);
        mR[i] = (dkf_mat_t)DKF_MAT(mi[i], mi[i], R[i]);
        my[i] = (dkf_mat_t)DKF_MAT(mi[i], 1, y[i]);
        sensors[i].B = &mB;
        sensors[i].Rd = &mRd;
        sensors[i].meas.H = &mH[i];
        sensors[i].meas.D = &mD[i];
        sensors[i].meas.R = &mR[i];
    }
}

/* x_{k+1} = F x_k + v, d^i_{k+1} = B d^i + wd, then y^i at the new time */
static void simulate(bench_rng_t *r, size_t N, int advance)
{
    size_t i, j, l;
    if (advance) {
        double xn[NX];
        for (i = 0; i < NX; ++i) {
            xn[i] = 0.0;
            for (j = 0; j < NX; ++j) xn[i] += (double)F[i * NX + j] * xs[j];
            xn[i] += sqrt((double)Q[i * NX + i]) * bench_rng_normal(r);
        }
        memcpy(xs, xn, sizeof xs);
        for (i = 0; i < N; ++i)
            for (j = 0; j < NP; ++j) ds[i][j] = 0.9 * ds[i][j] + sqrt(0.05) * bench_rng_normal(r);
    }
    for (i = 0; i < N; ++i)
        for (j = 0; j < mi[i]; ++j) {
            double v = sqrt((double)R[i][j * mi[i] + j]) * bench_rng_normal(r);
            for (l = 0; l < NX; ++l) v += (double)H[i][j * NX + l] * xs[l];
            for (l = 0; l < NP; ++l) v += (double)D[i][j * NP + l] * ds[i][l];
            y[i][j] = (dkf_real_t)v;
        }
}

static int fail(const char *what, size_t N, dkf_status_t st)
{
    printf("# fc-step N=%zu: %s failed (%s)\n", N, what, dkf_status_str(st));
    return 1;
}

/* One repeat: set-up (untimed), then `steps` fusion-centre steps; the
 * time of each call to dkf_diffkf_fc_step into ns[0..steps-1]. */
static double steady_tol; /* --steady: dkf_diffkf_fc_set_steady's tolerance (0 = off) */
static long settled_k;    /* the first step whose central gain was reused (-1: none) */

static int run(size_t N, long steps, double *ns, double *start_ns, double *checksum)
{
    const size_t len = dkf_diffkf_fc_storage_len(NX, N, mi, pi);
    dkf_ui_dyn_t dyn;
    dkf_diffkf_fc_fault_t fault;
    dkf_status_t st;
    bench_rng_t r;
    size_t i;
    long k;
    double cs = 0.0;
    r.s = 14;
    settled_k = -1;
    memset(xs, 0, sizeof xs);
    memset(ds, 0, sizeof ds);
    dyn.F = &mF, dyn.Q = &mQ, dyn.B = &mB, dyn.Rd = &mRd;
    *start_ns = bench_now_ns();
    st = dkf_diffkf_fc_init(&fc, fc_nodes, N, NX, mi, pi, storage, len, &mx0, &mP0, NULL, &fault);
    if (st == DKF_OK) st = dkf_diffkf_fc_set_steady(&fc, (dkf_real_t)steady_tol);
    if (st != DKF_OK) return fail("fc_init", N, st);
    st = dkf_diffkf_fc_start(&fc, &mF, &mQ, sensors, &fault);
    if (st != DKF_OK) return fail("fc_start", N, st);
    *start_ns = bench_now_ns() - *start_ns;
    simulate(&r, N, 1);
    for (i = 0; i < N; ++i) {
        st = dkf_diffkf_init(&node[i], NX, mi[i], pi[i], node_store[i], sizeof node_store[i] /
                             sizeof node_store[i][0], &mx0, &mP0);
        if (st == DKF_OK) st = dkf_diffkf_start(&node[i], &mF, &mQ, &sensors[i].meas, &my[i]);
        if (st != DKF_OK) return fail("node start", N, st);
    }
    for (k = 0; k < steps; ++k) {
        double t0;
        simulate(&r, N, 1);
        for (i = 0; i < N; ++i) {
            st = dkf_diffkf_step(&node[i], &dyn, &sensors[i].meas, &my[i]);
            if (st == DKF_OK) st = dkf_diffkf_msg_fill(&msgs[i], (uint16_t)i, &node[i]);
            if (st != DKF_OK) return fail("node step", N, st);
        }
        t0 = bench_now_ns();
        st = dkf_diffkf_fc_step(&fc, &mF, &mQ, sensors, msgs, &fault);
        ns[k] = bench_now_ns() - t0;
        if (st != DKF_OK) return fail("fc_step", N, st);
        if (settled_k < 0 && fc.central.steady) settled_k = k;
    }
    for (i = 0; i < NX; ++i) cs += (double)fc.central.xf.data[i] + (double)fc.central.Pf.data[i * NX + i];
    *checksum = cs;
    return 0;
}

int main(int argc, char **argv)
{
    size_t Ns[16] = {2, 12, 50, 100, 200}, nN = 5, a;
    int repeats = 3, ai;
    long steps_opt = 0;
    for (ai = 1; ai < argc; ++ai) {
        if (strcmp(argv[ai], "--N") == 0 && ai + 1 < argc) {
            char *s = argv[++ai];
            nN = 0;
            while (*s && nN < 16) {
                Ns[nN++] = (size_t)strtoul(s, &s, 10);
                if (*s == ',') ++s;
            }
        } else if (strcmp(argv[ai], "--repeats") == 0 && ai + 1 < argc) {
            repeats = atoi(argv[++ai]);
        } else if (strcmp(argv[ai], "--steps") == 0 && ai + 1 < argc) {
            steps_opt = atol(argv[++ai]);
        } else if (strcmp(argv[ai], "--steady") == 0 && ai + 1 < argc) {
            steady_tol = atof(argv[++ai]);
        } else if (strcmp(argv[ai], "--target-ms") == 0 && ai + 1 < argc) {
            ++ai; /* accepted for run_bench.sh's common arguments; unused */
        } else {
            fprintf(stderr, "usage: %s [--N a,b,c] [--repeats R] [--steps S] [--steady TOL]\n", argv[0]);
            return 2;
        }
    }
    if (repeats < 1) repeats = 1;
    for (a = 0; a < nN; ++a) {
        const size_t N = Ns[a];
        long steps = steps_opt > 0 ? steps_opt : (long)(40000 / (N * N) + 20);
        double first[64], start[64], cs = 0.0;
        size_t nt = 0;
        int rp;
        if (steps < 2) steps = 2;
        if (steps > STEPS_MAX) steps = STEPS_MAX;
        if (N < 1 || N > NCAP) {
            printf("# fc-step N=%zu: skipped (DKF_MAX_DIM = %d fits N <= %d)\n", N, DKF_MAX_DIM,
                   (int)NCAP);
            continue;
        }
        model(N);
        for (rp = 0; rp < repeats && rp < 64; ++rp) {
            if (run(N, steps, call_ns, &start[rp], &cs) != 0) return 1;
            first[rp] = call_ns[0];
            if (steady_tol > 0.0) { /* the steps that reused the gain */
                const long from = settled_k < 0 ? steps : settled_k;
                memcpy(steady_ns + nt, call_ns + from, (size_t)(steps - from) * sizeof *call_ns);
                nt += (size_t)(steps - from);
                continue;
            }
            memcpy(steady_ns + nt, call_ns + 1, (size_t)(steps - 1) * sizeof *call_ns);
            nt += (size_t)(steps - 1);
        }
        if (steady_tol > 0.0) {
            printf("fc-steady %s %d %zu %.3g %ld %.1f %zu %ld %d %.17g\n", BENCH_TYPE, NX, N,
                   steady_tol, settled_k, nt > 0 ? bench_median(steady_ns, (int)nt) : -1.0, nt,
                   steps, rp, cs);
            fflush(stdout);
            continue;
        }
        printf("fc-step %s %d %zu %.1f %.1f %.1f %zu %ld %d %.17g\n", BENCH_TYPE, NX, N,
               bench_median(steady_ns, (int)nt), bench_median(first, rp), bench_median(start, rp),
               dkf_diffkf_fc_storage_len(NX, N, mi, pi) * sizeof(dkf_real_t), steps, rp, cs);
        fflush(stdout);
    }
    return 0;
}
