/*
 * bench/bench_common.h - what the dkf and the Eigen KF benchmarks share, so
 * that both run the same models on the same data and are timed the same way:
 *
 *  - a fixed-seed PRNG (splitmix64) and the model generator, in double;
 *    each implementation converts the doubles to its own real type once,
 *    outside the timed region;
 *  - the driver: calibration, repeats, median, checksum, output line.
 *
 * Header-only, valid C99 and C++ (every function is static inline), so the
 * C benchmark and the C++ benchmark compile the very same code.
 *
 * Output of one benchmark case, one line, whitespace separated:
 *   impl type n m ns_per_step steps_per_repeat repeats checksum
 * (run_bench.sh and callgrind.sh parse it).
 */
#ifndef DKF_BENCH_COMMON_H
#define DKF_BENCH_COMMON_H

#ifndef __cplusplus
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 199309L /* clock_gettime under -std=c99 */
#endif
#endif

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ---- the benchmark cases ----------------------------------------------- */

#define BENCH_NCASES 3
#define BENCH_NMAX 12
#define BENCH_MMAX 6
/* Measurements are cycled: step k uses Y[k mod BENCH_NMEAS]. 256 keeps
 * them in L1 (256 * 6 doubles = 12 KiB) so the benchmark times the filter,
 * not memory. */
#define BENCH_NMEAS 256
/* Steps of the checksum run (from init, identical for every
 * implementation, independent of the timed step counts). */
#define BENCH_CHECK_STEPS 1000L

static const int bench_case_n[BENCH_NCASES] = {4, 8, 12};
static const int bench_case_m[BENCH_NCASES] = {2, 4, 6};

/* One model, row-major doubles (element (i,j) of an r x c at [i*c + j]). */
typedef struct {
    int n, m;
    double F[BENCH_NMAX * BENCH_NMAX];
    double Q[BENCH_NMAX * BENCH_NMAX];
    double H[BENCH_MMAX * BENCH_NMAX];
    double R[BENCH_MMAX * BENCH_MMAX];
    double x0[BENCH_NMAX];
    double P0[BENCH_NMAX * BENCH_NMAX];
    double Y[BENCH_NMEAS * BENCH_MMAX]; /* measurement k at Y[k*m] */
} bench_model_t;

/* ---- PRNG: splitmix64, then Box-Muller ----------------------------------- */

typedef struct {
    uint64_t s;
} bench_rng_t;

static inline uint64_t bench_rng_next(bench_rng_t *r)
{
    uint64_t z = (r->s += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

/* Uniform in (0, 1): the top 53 bits, offset by half a step so log() in
 * Box-Muller never sees 0. */
static inline double bench_rng_uniform(bench_rng_t *r)
{
    return ((double)(bench_rng_next(r) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

static inline double bench_rng_normal(bench_rng_t *r)
{
    const double two_pi = 6.283185307179586476925286766559;
    double u1 = bench_rng_uniform(r);
    double u2 = bench_rng_uniform(r);
    return sqrt(-2.0 * log(u1)) * cos(two_pi * u2);
}

static inline void bench_rand_gauss(bench_rng_t *r, double *A, int count)
{
    int i;
    for (i = 0; i < count; ++i) A[i] = bench_rng_normal(r);
}

/* C = A B^T for row-major A (r x k) and B (c x k). */
static inline void bench_mul_abt(double *C, const double *A, const double *B, int r, int k,
                                 int c)
{
    int i, j, l;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) {
            double s = 0.0;
            for (l = 0; l < k; ++l) s += A[i * k + l] * B[j * k + l];
            C[i * c + j] = s;
        }
}

/* Random orthogonal n x n: modified Gram-Schmidt, applied twice, on the
 * rows of a Gaussian matrix. */
static inline void bench_rand_orthogonal(bench_rng_t *r, double *Qm, int n)
{
    int pass, i, j, l;
    bench_rand_gauss(r, Qm, n * n);
    for (pass = 0; pass < 2; ++pass)
        for (i = 0; i < n; ++i) {
            double nrm = 0.0;
            for (j = 0; j < i; ++j) {
                double d = 0.0;
                for (l = 0; l < n; ++l) d += Qm[i * n + l] * Qm[j * n + l];
                for (l = 0; l < n; ++l) Qm[i * n + l] -= d * Qm[j * n + l];
            }
            for (l = 0; l < n; ++l) nrm += Qm[i * n + l] * Qm[i * n + l];
            nrm = sqrt(nrm);
            for (l = 0; l < n; ++l) Qm[i * n + l] /= nrm;
        }
}

/* SPD A = B B^T / k + shift I with B Gaussian (n x n): well conditioned for
 * shift of order 1, exactly symmetric (each (i,j) and (j,i) is the same
 * sum in the same order). */
static inline void bench_rand_spd(bench_rng_t *r, double *A, int n, double scale, double shift)
{
    double B[BENCH_NMAX * BENCH_NMAX];
    int i;
    bench_rand_gauss(r, B, n * n);
    bench_mul_abt(A, B, B, n, n, n);
    for (i = 0; i < n * n; ++i) A[i] *= scale / (double)n;
    for (i = 0; i < n; ++i) A[i * n + i] += shift;
}

/* The model of case `c`: seed depends on the case only.
 *   F = 0.98 * (random orthogonal): near-orthogonal, strictly stable, so
 *       the true state stays bounded and P converges for any (H, R, Q);
 *   Q = SPD of size ~0.01, R = SPD of size ~0.1, H Gaussian / sqrt(n);
 *   x0 = 0, P0 = I;
 *   Y: H x_true + w along a simulated trajectory x_true' = F x_true + v,
 *      v ~ N(0, 0.01 I) approximately, w ~ N(0, 0.1 I) approximately. */
static inline void bench_make_model(bench_model_t *md, int c)
{
    bench_rng_t rng;
    double xt[BENCH_NMAX], xn[BENCH_NMAX];
    int n = bench_case_n[c], m = bench_case_m[c];
    int i, j, k;

    memset(md, 0, sizeof *md);
    md->n = n;
    md->m = m;
    rng.s = UINT64_C(0xD1CEB00C) + (uint64_t)c * UINT64_C(1000003);

    bench_rand_orthogonal(&rng, md->F, n);
    for (i = 0; i < n * n; ++i) md->F[i] *= 0.98;
    bench_rand_spd(&rng, md->Q, n, 0.005, 0.005);
    bench_rand_gauss(&rng, md->H, m * n);
    for (i = 0; i < m * n; ++i) md->H[i] /= sqrt((double)n);
    bench_rand_spd(&rng, md->R, m, 0.05, 0.05);
    for (i = 0; i < n; ++i) md->P0[i * n + i] = 1.0;

    for (i = 0; i < n; ++i) xt[i] = bench_rng_normal(&rng);
    for (k = 0; k < BENCH_NMEAS; ++k) {
        for (i = 0; i < n; ++i) {
            double s = 0.0;
            for (j = 0; j < n; ++j) s += md->F[i * n + j] * xt[j];
            xn[i] = s + 0.1 * bench_rng_normal(&rng);
        }
        memcpy(xt, xn, sizeof xt);
        for (i = 0; i < m; ++i) {
            double s = 0.0;
            for (j = 0; j < n; ++j) s += md->H[i * n + j] * xt[j];
            md->Y[k * m + i] = s + 0.3 * bench_rng_normal(&rng);
        }
    }
}

/* ---- timing and statistics ----------------------------------------------- */

static inline double bench_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static inline int bench_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static inline double bench_median(double *v, int count)
{
    qsort(v, (size_t)count, sizeof *v, bench_cmp_double);
    return (count % 2) ? v[count / 2] : 0.5 * (v[count / 2 - 1] + v[count / 2]);
}

/* ---- the driver ------------------------------------------------------------ */

/* An implementation provides:
 *   prepare(c, md): converts model md (case c) to its own storage, untimed;
 *   run(steps):     init from (x0, P0), `steps` predict+update steps,
 *                   returns sum(x) + trace(P) at the end as a double;
 *                   returns NAN if a step failed. */
typedef void (*bench_prepare_fn)(int c, const bench_model_t *md);
typedef double (*bench_run_fn)(long steps);

/* Defeats dead-code elimination of timed runs across translation units. */
static volatile double bench_sink;

#define BENCH_REPEATS_MAX 1001

static inline void bench_usage(const char *prog)
{
    fprintf(stderr,
            "usage: %s [--case N] [--repeats R] [--target-ms T] [--steps S]\n"
            "  --case N       only case N (0: n=4 m=2, 1: n=8 m=4, 2: n=12 m=6)\n"
            "  --repeats R    timed repeats per case (median reported), default 31\n"
            "  --target-ms T  calibrate steps per repeat to about T ms, default 20\n"
            "  --steps S      fixed steps per repeat, no calibration (S may be 0:\n"
            "                 callgrind.sh subtracts such a run to cancel setup)\n",
            prog);
}

/* BENCH_PERTURB=<prefix>: every implementation whose name starts with it
 * (e.g. "eigen-O2", "eigen", "dkf") gets R(0,0) doubled, so it computes a
 * wrong answer on purpose. smoke.py's own tests use it to check their
 * verdicts: a wrong peer is reported and excluded, a wrong dkf fails. */
static inline void bench_perturb(bench_model_t *md, const char *impl)
{
    const char *p = getenv("BENCH_PERTURB");
    if (p == NULL || *p == '\0' || strncmp(impl, p, strlen(p)) != 0) return;
    md->R[0] *= 2.0;
    fprintf(stderr, "%s: BENCH_PERTURB: R(0,0) doubled, a wrong answer on purpose\n", impl);
}

/* Runs the cases and prints one line per case; returns the exit status. */
/* Steps per repeat for about target_ms: double until one run takes >= 1/8
 * of the target (also warms caches and the branch predictor), then scale
 * to the target; the first runs are often slow (frequency ramp, page
 * faults), so the scaled count is timed once more and rescaled. */
static inline long bench_calibrate(bench_run_fn run, double target_ms)
{
    long steps = 16;
    double t, t0;
    for (;;) {
        t0 = bench_now_ns();
        bench_sink = run(steps);
        t = bench_now_ns() - t0;
        if (t >= target_ms * 1e6 / 8.0 || steps > (1L << 28)) break;
        steps *= 2;
    }
    steps = (long)((double)steps * (target_ms * 1e6) / t) + 1;
    t0 = bench_now_ns();
    bench_sink = run(steps);
    t = bench_now_ns() - t0;
    return (long)((double)steps * (target_ms * 1e6) / t) + 1;
}

/* A benchmark of named filters on one model (bench_uif, bench_nerts): the
 * options --filter NAME (default every one, back to back), --repeats R,
 * --target-ms T, --steps S; per filter a checksum run of check_steps
 * (NaN: the filter failed, exit 1), then the timed repeats, one output
 * line "<prefix>-<name> type n m ns steps repeats checksum". */
typedef struct {
    const char *name;
    bench_run_fn run;
} bench_filter_t;

static inline int bench_filters_main(int argc, char **argv, const char *prefix, const char *type,
                                     int n, int m, const bench_filter_t *filters, int count,
                                     long check_steps)
{
    static double per_step[BENCH_REPEATS_MAX];
    const char *only = NULL;
    int repeats = 31, i, f;
    double target_ms = 20.0;
    long fixed_steps = -1;
    for (i = 1; i < argc; ++i) {
        const char *a = argv[i];
        const char *v = (i + 1 < argc) ? argv[i + 1] : NULL;
        if (v != NULL && strcmp(a, "--filter") == 0) only = v;
        else if (v != NULL && strcmp(a, "--repeats") == 0) repeats = atoi(v);
        else if (v != NULL && strcmp(a, "--target-ms") == 0) target_ms = atof(v);
        else if (v != NULL && strcmp(a, "--steps") == 0) fixed_steps = atol(v);
        else {
            fprintf(stderr, "usage: %s [--filter NAME] [--repeats R] [--target-ms T] "
                            "[--steps S]\n  NAME:",
                    argv[0]);
            for (f = 0; f < count; ++f) fprintf(stderr, " %s", filters[f].name);
            fprintf(stderr, "\n");
            return 2;
        }
        ++i;
    }
    if (repeats < 1 || repeats > BENCH_REPEATS_MAX || !(target_ms > 0.0)) return 2;
    for (f = 0; only != NULL && f < count && strcmp(only, filters[f].name) != 0; ++f) {
    }
    if (f == count) {
        fprintf(stderr, "%s: --filter %s: unknown\n", argv[0], only);
        return 2;
    }
    for (f = 0; f < count; ++f) {
        double checksum, ns;
        long steps;
        if (only != NULL && strcmp(only, filters[f].name) != 0) continue;
        checksum = filters[f].run(check_steps);
        if (!(checksum == checksum)) {
            fprintf(stderr, "%s-%s: a filter step failed\n", prefix, filters[f].name);
            return 1;
        }
        steps = fixed_steps >= 0 ? fixed_steps : bench_calibrate(filters[f].run, target_ms);
        for (i = 0; i < repeats; ++i) {
            double t0 = bench_now_ns();
            bench_sink = filters[f].run(steps);
            per_step[i] = (bench_now_ns() - t0) / (double)(steps > 0 ? steps : 1);
        }
        ns = bench_median(per_step, repeats);
        printf("%s-%s %s %d %d %.2f %ld %d %.17g\n", prefix, filters[f].name, type, n, m, ns,
               steps, repeats, checksum);
        fflush(stdout);
    }
    return 0;
}

static inline int bench_main(int argc, char **argv, const char *impl, const char *type,
                             bench_prepare_fn prepare, bench_run_fn run)
{
    static bench_model_t md;
    static double per_step[BENCH_REPEATS_MAX];
    int only = -1, repeats = 31, c, i;
    double target_ms = 20.0;
    long fixed_steps = -1;

    for (i = 1; i < argc; ++i) {
        const char *a = argv[i];
        const char *v = (i + 1 < argc) ? argv[i + 1] : NULL;
        if (v != NULL && strcmp(a, "--case") == 0) only = atoi(v);
        else if (v != NULL && strcmp(a, "--repeats") == 0) repeats = atoi(v);
        else if (v != NULL && strcmp(a, "--target-ms") == 0) target_ms = atof(v);
        else if (v != NULL && strcmp(a, "--steps") == 0) fixed_steps = atol(v);
        else {
            bench_usage(argv[0]);
            return 2;
        }
        ++i;
    }
    if (only < -1 || only >= BENCH_NCASES || repeats < 1 || repeats > BENCH_REPEATS_MAX ||
        !(target_ms > 0.0)) {
        bench_usage(argv[0]);
        return 2;
    }

    for (c = 0; c < BENCH_NCASES; ++c) {
        long steps;
        double checksum, ns;
        if (only >= 0 && c != only) continue;
        bench_make_model(&md, c);
        bench_perturb(&md, impl);
        prepare(c, &md);

        checksum = run(BENCH_CHECK_STEPS);
        if (!(checksum == checksum)) {
            fprintf(stderr, "%s: case %d: a filter step failed\n", impl, c);
            return 1;
        }

        steps = fixed_steps >= 0 ? fixed_steps : bench_calibrate(run, target_ms);

        for (i = 0; i < repeats; ++i) {
            double t0 = bench_now_ns();
            bench_sink = run(steps);
            per_step[i] = (bench_now_ns() - t0) / (double)(steps > 0 ? steps : 1);
        }
        ns = bench_median(per_step, repeats);
        printf("%s %s %d %d %.2f %ld %d %.17g\n", impl, type, md.n, md.m, ns, steps, repeats,
               checksum);
        fflush(stdout);
    }
    return 0;
}

#endif /* DKF_BENCH_COMMON_H */
