/*
 * kf_paths_dump OUT fixed|generic - one fixed, deterministic sequence of
 * dkf_kf_init / dkf_kf_predict / dkf_kf_update calls over sizes in the
 * default DKF_KF_FIXED_SIZES and not in it; after every call it appends
 * to OUT the status and the raw bytes of x, P, nu, S and nis (the m rows
 * of the last update). Then the same for Difference-KF steps
 * (dkf_diffkf_step) at the size of the default DKF_DIFFKF_FIXED_SIZES,
 * (4, 2, 2), and at (5, 3, 2): a constant model (the memo hits), a
 * time-varying one (it misses every step) and faults; after every call
 * xf, Pf, xn, Pn, dz, J, L, K and k. Built twice (tests/CMakeLists.txt),
 * against dkf and against dkf_kf_generic (every size on the generic step,
 * no vector extension, no loop peeling); ctest requires the two files to
 * be equal byte for byte (kf_paths_identical): no tolerance, the claim
 * under test is bit identity.
 *
 * Plain exit codes, no cmocka: the program must link exactly one dkf
 * library, and dkf_test_support (cmocka's harness here) links dkf itself,
 * so the generic build would carry both and the linker would silently
 * pick one. Its assertion is the byte comparison; the checks below only
 * make sure there is something to compare: every normal call returns
 * DKF_OK and changes the state, every injected fault returns its status
 * and leaves the state bit-identical, and the build is the one asked for
 * (argv[2] against the DKF_KF_FIXED_SIZES this file was compiled with,
 * which only dkf_kf_generic's usage requirements make empty).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "dkf/diffkf.h"
#include "dkf/kf.h"

#define NMAX 16
#define MMAX 8
#define STEPS 30

/* Faults, one per kind and filter, at these steps (m alternates, so the
 * update faults of the alternating filter hit both of its sizes). */
#define K_INF_F 5
#define K_NAN_Y 8
#define K_NAN_H 13
#define K_NEG_R 20

/* n, m_max, and the m of odd-numbered updates (m_max on even ones) */
static const struct {
    size_t n, m_max, m_odd;
} cases[] = {
    {4, 2, 2}, {6, 3, 3}, {8, 4, 4}, {12, 6, 6}, /* the default fixed sizes */
    {4, 1, 1}, {5, 2, 2}, {3, 3, 3}, {1, 1, 1}, {16, 5, 5},
    {8, 4, 2}, /* one filter switching between fixed (8, 4) and generic (8, 2) */
};

#define COUNT_SIZE(N, M) +1
static const int n_fixed_sizes = 0 DKF_KF_FIXED_SIZES(COUNT_SIZE);

static dkf_real_t kf_storage[DKF_KF_STORAGE_LEN(NMAX, MMAX)];
static dkf_kf_t kf;
static FILE *out;
static int failures;
static uint64_t rng = 20240611u;

/* splitmix64, uniform in [-1, 1); computed in double, rounded once */
static double uni(void)
{
    uint64_t z = (rng += 0x9E3779B97F4A7C15u);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9u;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBu;
    z ^= z >> 31;
    return (double)(z >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

/* a uniform index in [0, len) */
static size_t pick(size_t len)
{
    return (size_t)((uni() + 1.0) * 0.5 * (double)len) % len;
}

/* A = diag I + scale U(-1, 1), r x c */
static void rand_mat(dkf_real_t *A, size_t r, size_t c, double diag, double scale)
{
    size_t i;
    for (i = 0; i < r * c; ++i) A[i] = (dkf_real_t)((i / c == i % c ? diag : 0.0) + scale * uni());
}

/* A = B B^T / n + ridge I, B n x n uniform: SPD with eigenvalues >= ridge,
 * exactly symmetric (same products, same order for (i, j) and (j, i)) */
static void rand_spd(dkf_real_t *A, size_t n, double ridge)
{
    double B[NMAX * NMAX];
    size_t i, j, k;
    for (i = 0; i < n * n; ++i) B[i] = uni();
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) {
            double s = i == j ? ridge : 0.0;
            for (k = 0; k < n; ++k) s += B[i * n + k] * B[j * n + k] / (double)n;
            A[i * n + j] = (dkf_real_t)s;
        }
}

/* The filter's public state as bytes: the sizes of nu and S, x, P, the
 * m rows of nu and S, nis. */
typedef struct {
    unsigned char b[3 * sizeof(size_t) + (NMAX + NMAX * NMAX + MMAX + MMAX * MMAX + 1) * sizeof(dkf_real_t)];
    size_t len;
} state_t;

static void put(state_t *s, const void *p, size_t bytes)
{
    if (bytes == 0) return; /* before the first init, p is NULL */
    memcpy(s->b + s->len, p, bytes);
    s->len += bytes;
}

static void state_of(state_t *s)
{
    const size_t r = sizeof(dkf_real_t);
    s->len = 0;
    put(s, &kf.nu.rows, sizeof kf.nu.rows);
    put(s, &kf.S.rows, sizeof kf.S.rows);
    put(s, &kf.S.cols, sizeof kf.S.cols);
    put(s, kf.x.data, kf.n * r);
    put(s, kf.P.data, kf.n * kf.n * r);
    put(s, kf.nu.data, kf.nu.rows * r);
    put(s, kf.S.data, kf.S.rows * kf.S.cols * r);
    put(s, &kf.nis, r);
}

/* Records one call (case id, step, op, status, the state that state_fn
 * reads: the Kalman filter's or the DKF's) and checks it: DKF_OK must
 * change the state, an error must leave it bit-identical. */
static void record(void (*state_fn)(state_t *), int id, int k, const char *op, dkf_status_t st,
                   dkf_status_t want, const state_t *before)
{
    const int head[4] = {id, k, op[0], (int)st};
    state_t after;
    state_fn(&after);
    fwrite(head, sizeof head, 1, out);
    fwrite(after.b, 1, after.len, out);
    if (st != want) {
        fprintf(stderr, "case %d step %d %s: status %d, expected %d\n", id, k, op, (int)st,
                (int)want);
        ++failures;
    } else if ((st == DKF_OK) == (before->len == after.len && !memcmp(before->b, after.b, after.len))) {
        fprintf(stderr, "case %d step %d %s: state %s\n", id, k, op,
                st == DKF_OK ? "unchanged by a successful call" : "changed by a failed call");
        ++failures;
    }
}

static void run_case(size_t c)
{
    const size_t n = cases[c].n;
    dkf_real_t x0[NMAX], P0[NMAX * NMAX], F[NMAX * NMAX], Q[NMAX * NMAX], u[NMAX];
    dkf_real_t H[MMAX * NMAX], R[MMAX * MMAX], y[MMAX];
    dkf_mat_t x0m = DKF_MAT(n, 1, x0), P0m = DKF_MAT(n, n, P0);
    dkf_mat_t Fm = DKF_MAT(n, n, F), Qm = DKF_MAT(n, n, Q), um = DKF_MAT(n, 1, u);
    state_t before;
    int k;
    rand_mat(x0, n, 1, 0.0, 1.0);
    rand_spd(P0, n, 0.5);
    state_of(&before);
    record(state_of, (int)c, -1, "init",
           dkf_kf_init(&kf, n, cases[c].m_max, kf_storage,
                       DKF_KF_STORAGE_LEN(n, cases[c].m_max), &x0m, &P0m),
           DKF_OK, &before);
    for (k = 0; k < STEPS; ++k) {
        const size_t m = k % 2 ? cases[c].m_odd : cases[c].m_max;
        dkf_mat_t Hm = DKF_MAT(m, n, H), Rm = DKF_MAT(m, m, R), ym = DKF_MAT(m, 1, y);
        dkf_status_t want = DKF_OK;
        size_t i;
        /* F: 0.9 I + entries 0.3/sqrt(n) U(-1, 1), spectral norm ~0.35:
         * P stays O(1) (max |P_ij| < 2 in every case) */
        rand_mat(F, n, n, 0.9, 0.3 / sqrt((double)n));
        rand_spd(Q, n, 0.01);
        rand_mat(u, n, 1, 0.0, 0.1);
        if (k == K_INF_F) {
            F[pick(n * n)] = INFINITY;
            want = DKF_ERR_NONFINITE;
        }
        state_of(&before);
        record(state_of, (int)c, k, "predict",
               dkf_kf_predict(&kf, &(dkf_kf_dyn_t){&Fm, &Qm}, k % 3 ? NULL : &um), want, &before);

        rand_mat(H, m, n, 0.0, 1.0);
        rand_spd(R, m, 0.1);
        rand_mat(y, m, 1, 0.0, 2.0);
        want = DKF_OK;
        if (k == K_NAN_Y) {
            y[m - 1] = NAN;
            want = DKF_ERR_NONFINITE;
        }
        if (k == K_NAN_H) {
            H[pick(m * n)] = NAN;
            want = DKF_ERR_NONFINITE;
        }
        if (k == K_NEG_R) {
            /* H P H^T <= n |P| I, a few hundred at most: -1e6 I makes S
             * negative definite (and a surprise fails the status check) */
            for (i = 0; i < m * m; ++i) R[i] = i % (m + 1) ? DKF_R(0.0) : -DKF_R(1e6);
            want = DKF_ERR_NOT_SPD;
        }
        state_of(&before);
        record(state_of, (int)c, k, "update", dkf_kf_update(&kf, &(dkf_kf_meas_t){&Hm, &Rm}, &ym),
               want, &before);
    }
}

/* ---- the Difference KF ---------------------------------------------------- */

#define DN 5
#define DM 3
#define DP 2
#define DSTEPS 30
/* faults: y_{k+1} NaN; F_k Inf (in the varying phase); Q_k = -1e6 I */
#define D_NAN_Y 6
#define D_INF_F 14
#define D_NEG_Q 24

static const struct {
    size_t n, m, p;
} dcases[] = {{4, 2, 2}, {5, 3, 2}};

static dkf_real_t d_storage[DKF_DIFFKF_STORAGE_LEN(DN, DM, DP)];
static dkf_diffkf_t df;

static void dkf_state_of(state_t *s)
{
    const size_t r = sizeof(dkf_real_t), n = df.n, pk = df.pk;
    s->len = 0;
    put(s, &df.k, sizeof df.k);
    put(s, &df.pk, sizeof df.pk);
    put(s, df.xf.data, n * r);
    put(s, df.Pf.data, n * n * r);
    put(s, df.xn.data, n * r);
    put(s, df.Pn.data, n * n * r);
    put(s, df.dz.data, pk * r);
    put(s, df.J.data, n * pk * r);
    put(s, df.L.data, pk * pk * r);
    put(s, df.K.data, n * pk * r);
}

/* A model with B and D well conditioned (diagonal 1 plus 0.3 U(-1, 1)). */
static void dkf_model(dkf_real_t *F, dkf_real_t *Q, dkf_real_t *B, dkf_real_t *Rd, size_t n,
                      size_t p)
{
    rand_mat(F, n, n, 0.9, 0.3 / sqrt((double)n));
    rand_spd(Q, n, 0.01);
    rand_mat(B, p, p, 1.0, 0.3);
    rand_spd(Rd, p, 0.05);
}

static void run_dkf_case(size_t c)
{
    const size_t n = dcases[c].n, m = dcases[c].m, p = dcases[c].p;
    dkf_real_t x0[DN], P0[DN * DN], F[DN * DN], Q[DN * DN], B[DP * DP], Rd[DP * DP];
    dkf_real_t H[DM * DN], D[DM * DP], R[DM * DM], y[DM];
    dkf_mat_t x0m = DKF_MAT(n, 1, x0), P0m = DKF_MAT(n, n, P0);
    dkf_mat_t Fm = DKF_MAT(n, n, F), Qm = DKF_MAT(n, n, Q), Bm = DKF_MAT(p, p, B);
    dkf_mat_t Rdm = DKF_MAT(p, p, Rd), Hm = DKF_MAT(m, n, H), Dm = DKF_MAT(m, p, D);
    dkf_mat_t Rm = DKF_MAT(m, m, R), ym = DKF_MAT(m, 1, y);
    const dkf_ui_dyn_t dyn = {&Fm, &Qm, &Bm, &Rdm};
    const dkf_ui_meas_t meas = {&Hm, &Dm, &Rm};
    state_t before;
    int k;
    size_t i;
    rand_mat(x0, n, 1, 0.0, 1.0);
    rand_spd(P0, n, 0.5);
    dkf_model(F, Q, B, Rd, n, p);
    rand_mat(H, m, n, 0.0, 1.0);
    rand_mat(D, m, p, 1.0, 0.3);
    rand_spd(R, m, 0.1);
    rand_mat(y, m, 1, 0.0, 2.0);
    if (dkf_diffkf_init(&df, n, m, p, d_storage, DKF_DIFFKF_STORAGE_LEN(n, m, p), &x0m, &P0m) !=
            DKF_OK ||
        dkf_diffkf_start(&df, &Fm, &Qm, &meas, &ym) != DKF_OK) {
        fprintf(stderr, "diffkf case %d: init or start failed\n", (int)c);
        ++failures;
        return;
    }
    for (k = 0; k < DSTEPS; ++k) {
        dkf_status_t want = DKF_OK;
        const int varying = k >= 10 && k < 20; /* steps 10-19: a new model every step */
        dkf_real_t keep = DKF_R(0.0);
        if (varying) dkf_model(F, Q, B, Rd, n, p);
        rand_mat(y, m, 1, 0.0, 2.0);
        if (k == D_NAN_Y) {
            y[m - 1] = NAN;
            want = DKF_ERR_NONFINITE;
        }
        if (k == D_INF_F) {
            keep = F[1];
            F[1] = INFINITY;
            want = DKF_ERR_NONFINITE;
        }
        if (k == D_NEG_Q) {
            for (i = 0; i < n * n; ++i) Q[i] = i % (n + 1) ? DKF_R(0.0) : -DKF_R(1e6);
            want = DKF_ERR_NOT_SPD;
        }
        dkf_state_of(&before);
        record(dkf_state_of, 100 + (int)c, k, "diffkf step", dkf_diffkf_step(&df, &dyn, &meas, &ym),
               want, &before);
        if (k == D_INF_F) F[1] = keep;
        if (k == D_NEG_Q) rand_spd(Q, n, 0.01);
    }
}

int main(int argc, char **argv)
{
    size_t c;
    if (argc != 3 || (strcmp(argv[2], "fixed") && strcmp(argv[2], "generic"))) {
        fprintf(stderr, "usage: kf_paths_dump OUT fixed|generic\n");
        return 2;
    }
    /* a generic dump from a build with fixed sizes (or the reverse) would
     * compare two runs of the same code */
    printf("kf_paths_dump: %s build, %d fixed sizes, DKF_SIMD %d, %s\n", argv[2], n_fixed_sizes,
           DKF_SIMD, sizeof(dkf_real_t) == sizeof(float) ? "float" : "double");
    if ((n_fixed_sizes == 0) != !strcmp(argv[2], "generic")) {
        fprintf(stderr, "kf_paths_dump: built with %d fixed sizes, not a %s build\n", n_fixed_sizes,
                argv[2]);
        return 1;
    }
    out = fopen(argv[1], "wb");
    if (out == NULL) {
        perror(argv[1]);
        return 1;
    }
    for (c = 0; c < sizeof cases / sizeof cases[0]; ++c) run_case(c);
    for (c = 0; c < sizeof dcases / sizeof dcases[0]; ++c) run_dkf_case(c);
    if (fclose(out) != 0) {
        perror(argv[1]);
        return 1;
    }
    printf("kf_paths_dump: %d Kalman and %d DKF cases, %d check failures\n",
           (int)(sizeof cases / sizeof cases[0]), (int)(sizeof dcases / sizeof dcases[0]),
           failures);
    return failures != 0;
}
