/*
 * bench/bench_kf_ref.c - the independent reference the KF benchmarks'
 * checksums are judged against (smoke.py, run_bench.sh): the textbook
 * Kalman step in long double with plain loops, written neither from
 * src/kf.c nor from Eigen, and compiled with the baseline flags of the
 * build (never -march), so a peer built with other flags cannot drag it
 * along when that peer goes wrong.
 *
 *   predict  x = F x,  P = F P F^T + Q;
 *   update   S = H P H^T + R,  K^T = S^{-1} (H P) (Gauss-Jordan, partial
 *            pivoting),  x += K (y - H x),
 *            P = (I - K H) P (I - K H)^T + K R K^T   (Joseph form).
 *
 * One form only: the cases are well conditioned (bench_common.h), so the
 * Joseph and the short form P - K H P differ by a few units of roundoff,
 * far below the checksum tolerance; the reference does not need to follow
 * the build's DKF_JOSEPH. With BENCH_USE_FLOAT the model is rounded to
 * float first, as the float implementations see it, and the computation
 * stays in long double: the float builds are judged against the exact
 * answer to the very problem they were given.
 *
 * Output: the line of bench_common.h with impl "reference" (its time is
 * printed like any other, and means nothing: it is not a peer).
 */
#include "bench_common.h"

#if BENCH_USE_FLOAT
#define BENCH_TYPE "float"
#define BENCH_ROUND(v) ((long double)(float)(v))
#else
#define BENCH_TYPE "double"
#define BENCH_ROUND(v) ((long double)(v))
#endif

typedef long double ref_t;

/* The model of the current case, row-major, in long double. */
static struct {
    int n, m;
    ref_t F[BENCH_NMAX * BENCH_NMAX];
    ref_t Q[BENCH_NMAX * BENCH_NMAX];
    ref_t H[BENCH_MMAX * BENCH_NMAX];
    ref_t R[BENCH_MMAX * BENCH_MMAX];
    ref_t x0[BENCH_NMAX];
    ref_t P0[BENCH_NMAX * BENCH_NMAX];
    ref_t Y[BENCH_NMEAS * BENCH_MMAX];
} ref;

static void ref_load(ref_t *dst, const double *src, int count)
{
    int i;
    for (i = 0; i < count; ++i) dst[i] = BENCH_ROUND(src[i]);
}

static void prepare(int c, const bench_model_t *md)
{
    int n = md->n, m = md->m;
    (void)c;
    ref.n = n;
    ref.m = m;
    ref_load(ref.F, md->F, n * n);
    ref_load(ref.Q, md->Q, n * n);
    ref_load(ref.H, md->H, m * n);
    ref_load(ref.R, md->R, m * m);
    ref_load(ref.x0, md->x0, n);
    ref_load(ref.P0, md->P0, n * n);
    ref_load(ref.Y, md->Y, BENCH_NMEAS * m);
}

/* C (r x c) = op(A) op(B), op = transpose where ta / tb is set; A is
 * stored r x k (or k x r if ta), B k x c (or c x k if tb). C may not alias
 * A or B. */
static void ref_mul(ref_t *C, const ref_t *A, int ta, const ref_t *B, int tb, int r, int k, int c)
{
    int i, j, l;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) {
            ref_t s = 0.0L;
            for (l = 0; l < k; ++l)
                s += (ta ? A[l * r + i] : A[i * k + l]) * (tb ? B[j * k + l] : B[l * c + j]);
            C[i * c + j] = s;
        }
}

/* Solves S X = B in place (S m x m, B m x c), Gauss-Jordan with partial
 * pivoting on copies. Returns 0 if S is singular to long double. */
static int ref_solve(ref_t *B, const ref_t *S, int m, int c)
{
    ref_t A[BENCH_MMAX * BENCH_MMAX];
    int i, j, l;
    memcpy(A, S, sizeof(ref_t) * (size_t)(m * m));
    for (i = 0; i < m; ++i) {
        int piv = i;
        for (j = i + 1; j < m; ++j)
            if (fabsl(A[j * m + i]) > fabsl(A[piv * m + i])) piv = j;
        if (A[piv * m + i] == 0.0L) return 0;
        if (piv != i) {
            for (l = 0; l < m; ++l) {
                ref_t t = A[i * m + l];
                A[i * m + l] = A[piv * m + l];
                A[piv * m + l] = t;
            }
            for (l = 0; l < c; ++l) {
                ref_t t = B[i * c + l];
                B[i * c + l] = B[piv * c + l];
                B[piv * c + l] = t;
            }
        }
        for (j = 0; j < m; ++j) {
            ref_t f;
            if (j == i) continue;
            f = A[j * m + i] / A[i * m + i];
            for (l = 0; l < m; ++l) A[j * m + l] -= f * A[i * m + l];
            for (l = 0; l < c; ++l) B[j * c + l] -= f * B[i * c + l];
        }
    }
    for (i = 0; i < m; ++i)
        for (l = 0; l < c; ++l) B[i * c + l] /= A[i * m + i];
    return 1;
}

static double run(long steps)
{
    const int n = ref.n, m = ref.m;
    ref_t x[BENCH_NMAX], t[BENCH_NMAX], nu[BENCH_MMAX];
    ref_t P[BENCH_NMAX * BENCH_NMAX], T[BENCH_NMAX * BENCH_NMAX], A[BENCH_NMAX * BENCH_NMAX];
    ref_t HP[BENCH_MMAX * BENCH_NMAX], Kt[BENCH_MMAX * BENCH_NMAX];
    ref_t S[BENCH_MMAX * BENCH_MMAX], RKt[BENCH_MMAX * BENCH_NMAX];
    ref_t sum = 0.0L;
    long k;
    int i, j;

    memcpy(x, ref.x0, sizeof(ref_t) * (size_t)n);
    memcpy(P, ref.P0, sizeof(ref_t) * (size_t)(n * n));
    for (k = 0; k < steps; ++k) {
        const ref_t *y = ref.Y + (k % BENCH_NMEAS) * m;
        /* predict */
        ref_mul(t, ref.F, 0, x, 0, n, n, 1);
        memcpy(x, t, sizeof(ref_t) * (size_t)n);
        ref_mul(T, ref.F, 0, P, 0, n, n, n);
        ref_mul(P, T, 0, ref.F, 1, n, n, n);
        for (i = 0; i < n * n; ++i) P[i] += ref.Q[i];
        /* update: S = H P H^T + R, K^T = S^{-1} H P */
        ref_mul(HP, ref.H, 0, P, 0, m, n, n);
        ref_mul(S, HP, 0, ref.H, 1, m, n, m);
        for (i = 0; i < m * m; ++i) S[i] += ref.R[i];
        memcpy(Kt, HP, sizeof(ref_t) * (size_t)(m * n));
        if (!ref_solve(Kt, S, m, n)) return NAN;
        ref_mul(nu, ref.H, 0, x, 0, m, n, 1);
        for (i = 0; i < m; ++i) nu[i] = y[i] - nu[i];
        for (i = 0; i < n; ++i)
            for (j = 0; j < m; ++j) x[i] += Kt[j * n + i] * nu[j];
        /* Joseph: A = I - K H, P = A P A^T + K R K^T */
        ref_mul(A, Kt, 1, ref.H, 0, n, m, n);
        for (i = 0; i < n * n; ++i) A[i] = -A[i];
        for (i = 0; i < n; ++i) A[i * n + i] += 1.0L;
        ref_mul(T, A, 0, P, 0, n, n, n);
        ref_mul(P, T, 0, A, 1, n, n, n);
        ref_mul(RKt, ref.R, 0, Kt, 0, m, m, n);
        ref_mul(T, Kt, 1, RKt, 0, n, m, n);
        for (i = 0; i < n * n; ++i) P[i] += T[i];
    }
    for (i = 0; i < n; ++i) sum += x[i] + P[i * n + i];
    return (double)sum;
}

int main(int argc, char **argv)
{
    return bench_main(argc, argv, "reference", BENCH_TYPE, prepare, run);
}
