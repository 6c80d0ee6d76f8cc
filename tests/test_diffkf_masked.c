/*
 * The row-masked Difference KF (dkf_diffkf_gain_masked): the optimal
 * estimate given the rows of z received, checked against an independent
 * double-precision batch LMMSE (Gaussian conditioning on the stacked
 * received z's, every quantity written as an affine map of the primitive
 * noises, as in docs/design/derivation-seed000.md §7); all-ones masks bit-identical to the
 * unmasked filter; pure prediction steps (pk = 0); masks changing every
 * step; update_z shape checks; single-filter checkpoints.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/diffkf.h"
#include "dkf_test.h"

#define NX 5  /* largest n */
#define NY 6  /* largest m */
#define NP 4  /* largest p */
#define NS 10 /* steps */
#define NT (NS + 2)
/* primitives: x0, d1, v_0..v_NS, wd_1..wd_NS, w_1..w_{NS+1} */
#define ND (NX + NP + (NS + 1) * NX + NS * NP + (NS + 1) * NY)
#define ST_LEN DKF_DIFFKF_STORAGE_LEN(NX, NY, NP)

/*
 * Tolerance, max|a - b| / max(1, max|b|) per array. Double: 1e-9 (the
 * project's bound; the batch and the recursion agree to ~2e-12, measured
 * below: the batch itself conditions on up to 40 correlated rows). Float:
 * the filter runs in float against the double batch, so the error is the
 * float filter's own rounding, O(eps cond(L)) per step on random models
 * whose L reach cond ~1e2-1e3, forgotten at the filter's rate; measured
 * 2.8e-4 (~2300 FLT_EPSILON) over the five models; 1e-3 (~8400
 * FLT_EPSILON) still catches any wrong term: the negative control's error
 * is 0.8.
 */
#if DKF_USE_FLOAT
#define TOL 1e-3
#else
#define TOL 1e-9
#endif

/* ---- double-precision helpers (independent of the library) ----------------- */

/* Inverse of the n x n A (Gauss-Jordan, partial pivoting). */
static void dinv(double *Ai, const double *A, size_t n)
{
    double M[NY * 2 * NY];
    size_t i, j, r;
    for (i = 0; i < n; ++i)
        for (j = 0; j < 2 * n; ++j) M[i * 2 * n + j] = j < n ? A[i * n + j] : (j - n == i);
    for (i = 0; i < n; ++i) {
        size_t piv = i;
        for (r = i + 1; r < n; ++r)
            if (fabs(M[r * 2 * n + i]) > fabs(M[piv * 2 * n + i])) piv = r;
        for (j = 0; j < 2 * n; ++j) {
            const double t = M[i * 2 * n + j];
            M[i * 2 * n + j] = M[piv * 2 * n + j];
            M[piv * 2 * n + j] = t;
        }
        for (j = 2 * n; j-- > i;) M[i * 2 * n + j] /= M[i * 2 * n + i];
        for (r = 0; r < n; ++r)
            if (r != i)
                for (j = 2 * n; j-- > i;) M[r * 2 * n + j] -= M[r * 2 * n + i] * M[i * 2 * n + j];
    }
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) Ai[i * n + j] = M[i * 2 * n + n + j];
}

/* A^+ = (A^T A)^{-1} A^T for A m x p of full column rank. */
static void dpinv(double *Ap, const double *A, size_t m, size_t p)
{
    double At[NP * NY], AtA[NP * NP], Inv[NP * NP];
    test_ref_transpose(At, A, m, p);
    test_ref_mul(AtA, At, A, p, m, p);
    dinv(Inv, AtA, p);
    test_ref_mul(Ap, Inv, At, p, p, m);
}

/* ---- the random model and its affine maps ----------------------------------- */

typedef struct {
    size_t n, m, p;
    /* model, double: F_k, Q_k (k = 0..NS); H, A, R at k = 1..NS+1; B, Rd at k = 1..NS */
    double F[NT][NX * NX], Q[NT][NX * NX], H[NT][NY * NX], A[NT][NY * NP], R[NT][NY * NY],
        B[NT][NP * NP], Rd[NT][NP * NP], x00[NX], P00[NX * NX];
    /* every x_k (k = 0..NS+1) and z_k (k = 1..NS) as mean + T eps, eps ~ N(0, I_D) */
    double Tx[NT][NX][ND], mx[NT][NX], Tz[NT][NP][ND], mz[NT][NP];
    double z[NT][NP]; /* one realisation */
    unsigned char mask[NT][NP];
    /* the same model in the library type */
    dkf_real_t rF[NT][NX * NX], rQ[NT][NX * NX], rH[NT][NY * NX], rA[NT][NY * NP],
        rR[NT][NY * NY], rB[NT][NP * NP], rRd[NT][NP * NP];
    dkf_mat_t mF[NT], mQ[NT], mH[NT], mA[NT], mR[NT], mB[NT], mRd[NT];
    dkf_ui_dyn_t dyn[NT];
    dkf_ui_meas_t meas[NT];
} world_t;

/* Row block dst (r x ND) = M (r x c) src (c x ND). */
static void map_mul(double *dst, const double *M, const double *src, size_t r, size_t c)
{
    test_ref_mul(dst, M, src, r, c, ND);
}

/* dst (r x ND) += Lc (r x r) on the primitive columns [col, col + r). */
static void map_noise(double *dst, const double *Lc, size_t r, size_t col)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = 0; j < r; ++j) dst[i * ND + col + j] += Lc[i * r + j];
}

static void spd(test_rng_t *rng, double *A, size_t n, double scale)
{
    test_rand_spd(rng, A, n, 10.0, scale);
}

/* Lc = chol(A) for the SPD n x n A: every pivot positive. */
static void chol_of(double *Lc, const double *A, size_t n)
{
    size_t i;
    test_dchol(Lc, A, n);
    for (i = 0; i < n; ++i) assert_true(Lc[i * n + i] > 0);
}

static void build_world(world_t *w, uint64_t seed, size_t n, size_t m, size_t p)
{
    static double Td[NT][NP][ND], Ty[NT][NY][ND];
    double my[NT][NY], md[NT][NP], Lc[NY * NY], G[NP * NY], Bi[NP * NP], Ap[NP * NY], Ap1[NP * NY];
    double eps[ND], tmp[NY * ND], tmp2[NY * ND];
    test_rng_t rng;
    size_t k, i, j, col;
    const size_t cx0 = 0, cd1 = NX, cv = NX + NP, cwd = cv + (NS + 1) * NX,
                 cw = cwd + NS * NP;
    memset(w, 0, sizeof *w);
    memset(Td, 0, sizeof Td);
    memset(Ty, 0, sizeof Ty);
    memset(md, 0, sizeof md);
    w->n = n, w->m = m, w->p = p;
    test_rng_seed(&rng, seed);
    for (i = 0; i < n; ++i) w->x00[i] = 3 * test_rng_normal(&rng);
    spd(&rng, w->P00, n, 2.0);
    for (k = 0; k < NT; ++k) {
        double O[NX * NX];
        test_rand_orthogonal(&rng, O, n);
        test_rand_gauss(&rng, w->F[k], n, n);
        for (i = 0; i < n * n; ++i) w->F[k][i] = 0.95 * O[i] + 0.1 * w->F[k][i];
        spd(&rng, w->Q[k], n, 0.3);
        test_rand_gauss(&rng, w->H[k], m, n);
        test_rand_gauss(&rng, w->A[k], m, p);
        spd(&rng, w->R[k], m, 0.5);
        test_rand_gauss(&rng, w->B[k], p, p);
        for (i = 0; i < p * p; ++i) w->B[k][i] = 0.2 * w->B[k][i] + (i % (p + 1) == 0 ? 0.9 : 0.0);
        spd(&rng, w->Rd[k], p, 1.0);
    }
    /* x_0 = x00 + chol(P00) eps_x0;  x_{k+1} = F_k x_k + chol(Q_k) eps_vk */
    memcpy(w->mx[0], w->x00, n * sizeof(double));
    chol_of(Lc, w->P00, n);
    map_noise(&w->Tx[0][0][0], Lc, n, cx0);
    for (k = 0; k <= NS; ++k) {
        map_mul(&w->Tx[k + 1][0][0], w->F[k], &w->Tx[k][0][0], n, n);
        chol_of(Lc, w->Q[k], n);
        map_noise(&w->Tx[k + 1][0][0], Lc, n, cv + k * NX);
        for (i = 0; i < n; ++i) {
            double s = 0;
            for (j = 0; j < n; ++j) s += w->F[k][i * n + j] * w->mx[k][j];
            w->mx[k + 1][i] = s;
        }
    }
    /* d_1 = eps_d1 (any law: z does not depend on d_1);
     * d_{k+1} = B_k d_k + chol(Rd_k) eps_wdk */
    for (i = 0; i < p; ++i) Td[1][i][cd1 + i] = 1.0;
    for (k = 1; k <= NS; ++k) {
        map_mul(&Td[k + 1][0][0], w->B[k], &Td[k][0][0], p, p);
        chol_of(Lc, w->Rd[k], p);
        map_noise(&Td[k + 1][0][0], Lc, p, cwd + (k - 1) * NP);
    }
    /* y_k = H_k x_k + A_k d_k + chol(R_k) eps_wk, k = 1..NS+1 */
    for (k = 1; k <= NS + 1; ++k) {
        map_mul(tmp, w->H[k], &w->Tx[k][0][0], m, n);
        map_mul(tmp2, w->A[k], &Td[k][0][0], m, p);
        for (i = 0; i < m * ND; ++i) (&Ty[k][0][0])[i] = tmp[i] + tmp2[i];
        chol_of(Lc, w->R[k], m);
        map_noise(&Ty[k][0][0], Lc, m, cw + (k - 1) * NY);
        for (i = 0; i < m; ++i) {
            double s = 0;
            for (j = 0; j < n; ++j) s += w->H[k][i * n + j] * w->mx[k][j];
            my[k][i] = s; /* E d_k = 0 */
        }
    }
    /* z_k = B_k^{-1} A_{k+1}^+ y_{k+1} - A_k^+ y_k                       (8) */
    for (k = 1; k <= NS; ++k) {
        dinv(Bi, w->B[k], p);
        dpinv(Ap1, w->A[k + 1], m, p);
        dpinv(Ap, w->A[k], m, p);
        test_ref_mul(G, Bi, Ap1, p, p, m);
        map_mul(tmp, G, &Ty[k + 1][0][0], p, m);
        map_mul(tmp2, Ap, &Ty[k][0][0], p, m);
        for (i = 0; i < p * ND; ++i) (&w->Tz[k][0][0])[i] = tmp[i] - tmp2[i];
        for (i = 0; i < p; ++i) {
            double s = 0;
            for (j = 0; j < m; ++j) s += G[i * m + j] * my[k + 1][j] - Ap[i * m + j] * my[k][j];
            w->mz[k][i] = s;
        }
    }
    (void)md;
    /* one realisation */
    for (col = 0; col < ND; ++col) eps[col] = test_rng_normal(&rng);
    for (k = 1; k <= NS; ++k)
        for (i = 0; i < p; ++i) {
            double s = w->mz[k][i];
            for (col = 0; col < ND; ++col) s += w->Tz[k][i][col] * eps[col];
            w->z[k][i] = s;
        }
    /* the library-type model */
    for (k = 0; k < NT; ++k) {
        test_to_real(w->rF[k], w->F[k], n * n);
        test_to_real(w->rQ[k], w->Q[k], n * n);
        test_to_real(w->rH[k], w->H[k], m * n);
        test_to_real(w->rA[k], w->A[k], m * p);
        test_to_real(w->rR[k], w->R[k], m * m);
        test_to_real(w->rB[k], w->B[k], p * p);
        test_to_real(w->rRd[k], w->Rd[k], p * p);
        w->mF[k] = test_view(n, n, w->rF[k]);
        w->mQ[k] = test_view(n, n, w->rQ[k]);
        w->mH[k] = test_view(m, n, w->rH[k]);
        w->mA[k] = test_view(m, p, w->rA[k]);
        w->mR[k] = test_view(m, m, w->rR[k]);
        w->mB[k] = test_view(p, p, w->rB[k]);
        w->mRd[k] = test_view(p, p, w->rRd[k]);
        w->dyn[k].F = &w->mF[k];
        w->dyn[k].Q = &w->mQ[k];
        w->dyn[k].B = &w->mB[k];
        w->dyn[k].Rd = &w->mRd[k];
        w->meas[k].H = &w->mH[k];
        w->meas[k].D = &w->mA[k];
        w->meas[k].R = &w->mR[k];
    }
}

/* Masks: step 3 and 4 keep nothing (two pure predictions in a row), step 6
 * keeps everything, every other step keeps each row with probability 0.6;
 * so the selection changes at nearly every step. */
static void make_masks(world_t *w, uint64_t seed)
{
    test_rng_t rng;
    size_t k, i;
    test_rng_seed(&rng, seed);
    for (k = 1; k <= NS; ++k)
        for (i = 0; i < w->p; ++i)
            w->mask[k][i] = (unsigned char)(k == 3 || k == 4 ? 0
                                            : k == 6     ? 1
                                                         : test_rng_uniform(&rng) < 0.6);
}

/* ---- the batch estimator ------------------------------------------------------ */

/* Mean and covariance of x_t given the rows of z_1..z_kz that the masks
 * keep: x = mx + Cxz Czz^{-1} (zr - mzr), P = Cxx - Cxz Czz^{-1} Czx. */
static void batch(const world_t *w, size_t t, size_t kz, double *x, double *P)
{
    static double Zr[NS * NP][ND], Czz[NS * NP * NS * NP], Lzz[NS * NP * NS * NP],
        Czx[NS * NP * NX];
    double dz[NS * NP], v[NS * NP];
    const size_t n = w->n;
    size_t r = 0, k, i, j, l;
    for (k = 1; k <= kz; ++k)
        for (i = 0; i < w->p; ++i)
            if (w->mask[k][i]) {
                memcpy(Zr[r], w->Tz[k][i], sizeof Zr[r]);
                dz[r] = w->z[k][i] - w->mz[k][i];
                ++r;
            }
    for (i = 0; i < n; ++i) {
        x[i] = w->mx[t][i];
        for (j = 0; j < n; ++j) {
            double s = 0;
            for (l = 0; l < ND; ++l) s += w->Tx[t][i][l] * w->Tx[t][j][l];
            P[i * n + j] = s;
        }
    }
    if (r == 0) return;
    for (i = 0; i < r; ++i) {
        for (j = 0; j < r; ++j) {
            double s = 0;
            for (l = 0; l < ND; ++l) s += Zr[i][l] * Zr[j][l];
            Czz[i * r + j] = s;
        }
        for (j = 0; j < n; ++j) {
            double s = 0;
            for (l = 0; l < ND; ++l) s += Zr[i][l] * w->Tx[t][j][l];
            Czx[i * n + j] = s;
        }
    }
    chol_of(Lzz, Czz, r);
    memcpy(v, dz, r * sizeof(double));
    test_dchol_solve(Lzz, v, r, 1);
    for (i = 0; i < n; ++i)
        for (j = 0; j < r; ++j) x[i] += Czx[j * n + i] * v[j];
    {
        static double X[NS * NP * NX];
        memcpy(X, Czx, r * n * sizeof(double));
        test_dchol_solve(Lzz, X, r, n); /* Czz^{-1} Czx */
        for (i = 0; i < n; ++i)
            for (j = 0; j < n; ++j) {
                double s = 0;
                for (l = 0; l < r; ++l) s += Czx[l * n + i] * X[l * n + j];
                P[i * n + j] -= s;
            }
    }
}

/* ---- the filter under test ----------------------------------------------------- */

static void start_filter(dkf_diffkf_t *f, dkf_real_t *st, const world_t *w)
{
    dkf_real_t x0[NX], P0[NX * NX];
    dkf_mat_t X0, P0v;
    test_to_real(x0, w->x00, w->n);
    test_to_real(P0, w->P00, w->n * w->n);
    X0 = test_view(w->n, 1, x0);
    P0v = test_view(w->n, w->n, P0);
    assert_int_equal(dkf_diffkf_init(f, w->n, w->m, w->p, st, ST_LEN, &X0, &P0v), DKF_OK);
    assert_int_equal(dkf_diffkf_start(f, &w->mF[0], &w->mQ[0], &w->meas[1], NULL), DKF_OK);
}

/* Masked step k: gain with the step's mask, then the kept rows of z_k. */
static void masked_step(dkf_diffkf_t *f, const world_t *w, size_t k)
{
    dkf_real_t zk[NP];
    dkf_mat_t zv;
    size_t i, pk = 0;
    assert_int_equal(dkf_diffkf_gain_masked(f, &w->dyn[k], &w->meas[k + 1], w->mask[k]), DKF_OK);
    for (i = 0; i < w->p; ++i)
        if (w->mask[k][i]) zk[pk++] = (dkf_real_t)w->z[k][i];
    assert_int_equal(f->pk, pk);
    zv = test_view(pk, 1, zk);
    assert_int_equal(dkf_diffkf_update_z(f, pk > 0 ? &zv : NULL, NULL), DKF_OK);
    assert_int_equal(f->z.rows, pk);
    assert_int_equal(f->K.cols, pk);
}

static double run_vs_batch(uint64_t seed, size_t n, size_t m, size_t p)
{
    static world_t w;
    static dkf_real_t st[ST_LEN];
    dkf_diffkf_t f;
    double x[NX], P[NX * NX];
    size_t k;
    build_world(&w, seed, n, m, p);
    make_masks(&w, seed + 1);
    start_filter(&f, st, &w);
    test_reset_worst_rel();
    batch(&w, 1, 0, x, P);
    test_assert_close("x_{1|0}", f.xn.data, x, n, TOL);
    for (k = 1; k <= NS; ++k) {
        masked_step(&f, &w, k);
        batch(&w, k, k, x, P);
        test_assert_close("x_{k|k}", f.xf.data, x, n, TOL);
        test_assert_close("P_{k|k}", f.Pf.data, P, n * n, TOL);
        batch(&w, k + 1, k, x, P);
        test_assert_close("x_{k+1|k}", f.xn.data, x, n, TOL);
        test_assert_close("P_{k+1|k}", f.Pn.data, P, n * n, TOL);
    }
    return test_worst_rel();
}

/* The masked recursion is the exact LMMSE given the rows received, on
 * random time-varying models with random masks (including pk = 0 steps and
 * an all-rows step after them). */
static void test_masked_matches_batch(void **state)
{
    static const size_t dims[][3] = {{3, 3, 2}, {4, 5, 3}, {2, 4, 4}, {5, 6, 4}, {3, 4, 1}};
    double worst = 0;
    size_t d;
    (void)state;
    for (d = 0; d < sizeof dims / sizeof dims[0]; ++d) {
        const double e = run_vs_batch(9100 + 7 * d, dims[d][0], dims[d][1], dims[d][2]);
        if (e > worst) worst = e;
    }
    print_message("masked DKF vs batch LMMSE: worst relative error %.3e\n", worst);
}

/* Negative control: the batch check is sensitive to the correlation
 * carry. Conditioning on the received rows of a z whose masks the filter
 * does not know (it runs unmasked on zeros for the lost rows) is far off. */
static void test_batch_detects_wrong_selection(void **state)
{
    static world_t w;
    static dkf_real_t st[ST_LEN];
    dkf_diffkf_t f;
    double x[NX], P[NX * NX], err = 0, scale = 1;
    size_t k, i;
    (void)state;
    build_world(&w, 9200, 4, 5, 3);
    make_masks(&w, 9201);
    start_filter(&f, st, &w);
    for (k = 1; k <= NS; ++k) {
        /* wrong: drop the rows (measurements) but keep their full-row gain */
        dkf_real_t zk[NP];
        dkf_mat_t zv = test_view(w.p, 1, zk);
        dkf_mat_t M, K, zc;
        assert_int_equal(dkf_diffkf_gain(&f, &w.dyn[k], &w.meas[k + 1]), DKF_OK);
        assert_int_equal(dkf_diffkf_pending(&f, &M, &K, &zc), DKF_OK);
        for (i = 0; i < w.p; ++i) {
            /* a lost row replaced by its prediction: dz = 0 on that row */
            double pred = zc.data[i];
            size_t j;
            for (j = 0; j < w.n; ++j) pred += M.data[i * w.n + j] * f.xn.data[j];
            zk[i] = w.mask[k][i] ? (dkf_real_t)w.z[k][i] : (dkf_real_t)pred;
        }
        assert_int_equal(dkf_diffkf_update_z(&f, &zv, NULL), DKF_OK);
    }
    batch(&w, NS, NS, x, P);
    for (i = 0; i < w.n * w.n; ++i) {
        if (fabs(P[i]) > scale) scale = fabs(P[i]);
        if (fabs((double)f.Pf.data[i] - P[i]) > err) err = fabs((double)f.Pf.data[i] - P[i]);
    }
    print_message("negative control (lost rows predicted, full gain): P error %.3e\n",
                  err / scale);
    assert_true(err / scale > 1e-2);
}

/* All-rows masks (explicit flags and NULL) are bit-identical to the
 * unmasked two-phase step, also after masked steps (a full step that
 * follows a partial one). */
static void test_all_ones_bit_identical(void **state)
{
    static world_t w;
    static dkf_real_t s1[ST_LEN], s2[ST_LEN], s3[ST_LEN];
    const unsigned char ones[NP] = {1, 1, 1, 1}, odd[NP] = {0, 1, 0, 1};
    dkf_diffkf_t a, b, c;
    size_t k;
    (void)state;
    build_world(&w, 9300, 4, 5, 4);
    start_filter(&a, s1, &w);
    start_filter(&b, s2, &w);
    start_filter(&c, s3, &w);
    for (k = 1; k <= NS; ++k) {
        dkf_real_t zk[NP], zs[NP];
        dkf_mat_t zv = test_view(w.p, 1, zk), zsv;
        const unsigned char *rows = k == 4 ? odd : ones;
        size_t i, pk = 0;
        for (i = 0; i < w.p; ++i) {
            zk[i] = (dkf_real_t)w.z[k][i];
            if (rows[i]) zs[pk++] = zk[i];
        }
        zsv = test_view(pk, 1, zs);
        if (k == 4) {
            assert_int_equal(dkf_diffkf_gain_masked(&a, &w.dyn[k], &w.meas[k + 1], odd), DKF_OK);
            assert_int_equal(dkf_diffkf_gain_masked(&b, &w.dyn[k], &w.meas[k + 1], odd), DKF_OK);
            assert_int_equal(dkf_diffkf_gain_masked(&c, &w.dyn[k], &w.meas[k + 1], odd), DKF_OK);
            assert_int_equal(dkf_diffkf_update_z(&a, &zsv, NULL), DKF_OK);
            assert_int_equal(dkf_diffkf_update_z(&b, &zsv, NULL), DKF_OK);
            assert_int_equal(dkf_diffkf_update_z(&c, &zsv, NULL), DKF_OK);
            continue;
        }
        assert_int_equal(dkf_diffkf_gain(&a, &w.dyn[k], &w.meas[k + 1]), DKF_OK);
        assert_int_equal(dkf_diffkf_gain_masked(&b, &w.dyn[k], &w.meas[k + 1], ones), DKF_OK);
        assert_int_equal(dkf_diffkf_gain_masked(&c, &w.dyn[k], &w.meas[k + 1], NULL), DKF_OK);
        assert_int_equal(b.pk, w.p);
        assert_int_equal(dkf_diffkf_update_z(&a, &zv, NULL), DKF_OK);
        assert_int_equal(dkf_diffkf_update_z(&b, &zv, NULL), DKF_OK);
        assert_int_equal(dkf_diffkf_update_z(&c, &zv, NULL), DKF_OK);
        assert_memory_equal(a.xf.data, b.xf.data, w.n * sizeof(dkf_real_t));
        assert_memory_equal(a.Pf.data, b.Pf.data, w.n * w.n * sizeof(dkf_real_t));
        assert_memory_equal(a.xn.data, b.xn.data, w.n * sizeof(dkf_real_t));
        assert_memory_equal(a.Pn.data, b.Pn.data, w.n * w.n * sizeof(dkf_real_t));
        assert_memory_equal(a.K.data, b.K.data, w.n * w.p * sizeof(dkf_real_t));
        assert_memory_equal(a.L.data, b.L.data, w.p * w.p * sizeof(dkf_real_t));
        assert_memory_equal(a.dz.data, b.dz.data, w.p * sizeof(dkf_real_t));
        assert_memory_equal(c.xf.data, b.xf.data, w.n * sizeof(dkf_real_t));
        assert_memory_equal(c.Pn.data, b.Pn.data, w.n * w.n * sizeof(dkf_real_t));
    }
}

/* pk = 0: x_{k|k} = x_{k|k-1} and P_{k|k} = P_{k|k-1} exactly, the
 * prediction is F x, F P F^T + Q, the views are empty, z may be NULL or
 * 0 x 1 (anything else is refused with the filter untouched). */
static void test_pure_prediction_step(void **state)
{
    static world_t w;
    static dkf_real_t st[ST_LEN], snap[ST_LEN];
    const unsigned char none[NP] = {0, 0, 0, 0};
    dkf_real_t xp0[NX], Pp0[NX * NX], one[1] = {1};
    double Fx[NX], FP[NX * NX], FPF[NX * NX], Pd[NX * NX], xd[NX];
    dkf_diffkf_t f;
    dkf_mat_t bad = test_view(1, 1, one), empty = {0, 1, NULL};
    size_t k, i;
    (void)state;
    build_world(&w, 9400, 3, 4, 2);
    make_masks(&w, 9401);
    start_filter(&f, st, &w);
    masked_step(&f, &w, 1);
    masked_step(&f, &w, 2);
    for (k = 3; k <= 4; ++k) {
        const size_t n = w.n;
        memcpy(xp0, f.xn.data, sizeof xp0);
        memcpy(Pp0, f.Pn.data, sizeof Pp0);
        assert_int_equal(dkf_diffkf_gain_masked(&f, &w.dyn[k], &w.meas[k + 1], none), DKF_OK);
        assert_int_equal(f.pk, 0);
        TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_diffkf_update_z(&f, &bad, NULL), st, ST_LEN);
        assert_int_equal(dkf_diffkf_update_z(&f, k == 3 ? NULL : &empty, NULL), DKF_OK);
        assert_int_equal(f.z.rows, 0);
        assert_int_equal(f.J.cols, 0);
        assert_int_equal(f.L.rows, 0);
        assert_memory_equal(f.xf.data, xp0, n * sizeof(dkf_real_t));
        assert_memory_equal(f.Pf.data, Pp0, n * n * sizeof(dkf_real_t));
        test_to_double(xd, xp0, n);
        test_to_double(Pd, Pp0, n * n);
        test_ref_mul(Fx, w.F[k], xd, n, n, 1);
        test_ref_mul(FP, w.F[k], Pd, n, n, n);
        for (i = 0; i < n * n; ++i) Pd[i] = 0;
        {
            double Ft[NX * NX];
            size_t a, b;
            for (a = 0; a < n; ++a)
                for (b = 0; b < n; ++b) Ft[a * n + b] = w.F[k][b * n + a];
            test_ref_mul(FPF, FP, Ft, n, n, n);
        }
        for (i = 0; i < n * n; ++i) FPF[i] += w.Q[k][i];
        /* rounding of one n-term product: a few eps relative */
        test_assert_close("F x", f.xn.data, Fx, n, 100 * TEST_EPS);
        test_assert_close("F P F^T + Q", f.Pn.data, FPF, n * n, 100 * TEST_EPS);
    }
    /* the step after: no previous innovation, still the exact LMMSE */
    masked_step(&f, &w, 5);
    {
        double x[NX], P[NX * NX];
        batch(&w, 5, 5, x, P);
        test_assert_close("x_{5|5} after two empty steps", f.xf.data, x, w.n, TOL);
        test_assert_close("P_{5|5} after two empty steps", f.Pf.data, P, w.n * w.n, TOL);
    }
}

/* update_z refuses a z of the unmasked size after a masked gain (and
 * leaves the filter untouched); a failed gain cancels the pending one and
 * pk describes the last completed step again. */
static void test_masked_shape_and_failure(void **state)
{
    static world_t w;
    static dkf_real_t st[ST_LEN], snap[ST_LEN];
    const unsigned char rows[NP] = {1, 0, 1, 0};
    dkf_real_t zk[NP] = {1, 2, 3, 4}, nan_z[2];
    dkf_diffkf_t f;
    dkf_mat_t full, part, F_bad;
    dkf_real_t Fb[NX * NX];
    dkf_ui_dyn_t dyn;
    (void)state;
    build_world(&w, 9500, 3, 4, 4);
    start_filter(&f, st, &w);
    full = test_view(4, 1, zk);
    part = test_view(2, 1, nan_z);
    assert_int_equal(dkf_diffkf_gain_masked(&f, &w.dyn[1], &w.meas[2], rows), DKF_OK);
    assert_int_equal(f.pk, 2);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_diffkf_update_z(&f, &full, NULL), st, ST_LEN);
    nan_z[0] = 0;
    nan_z[1] = (dkf_real_t)NAN;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_diffkf_update_z(&f, &part, NULL), st,
                         ST_LEN);
    /* a non-finite F fails the gain: nothing pending, pk back to the views */
    memcpy(Fb, w.rF[1], sizeof Fb);
    Fb[0] = (dkf_real_t)INFINITY;
    F_bad = test_view(w.n, w.n, Fb);
    dyn = w.dyn[1];
    dyn.F = &F_bad;
    assert_int_equal(dkf_diffkf_gain_masked(&f, &dyn, &w.meas[2], rows), DKF_ERR_NONFINITE);
    assert_int_equal(f.pending, 0);
    assert_int_equal(f.pk, f.z.rows);
    assert_int_equal(dkf_diffkf_update_z(&f, &part, NULL), DKF_ERR_STATE);
}

/* Checkpoint round trip: save at k = 4, run on, restore, replay: every
 * later step is bit-identical; a checkpoint restores into a second filter
 * bound to other storage; corrupted checkpoints are refused untouched. */
static void test_checkpoint_round_trip(void **state)
{
    static world_t w;
    static dkf_real_t st[ST_LEN], st2[ST_LEN], snap[ST_LEN];
    static dkf_real_t ck[ST_LEN], bad[ST_LEN];
    static dkf_real_t ref[NS + 1][2][NX * NX];
    dkf_diffkf_t f, g;
    size_t k, len;
    (void)state;
    build_world(&w, 9600, 4, 5, 3);
    make_masks(&w, 9601);
    start_filter(&f, st, &w);
    start_filter(&g, st2, &w);
    len = dkf_diffkf_checkpoint_len(&f);
    assert_true(len > 0 && len <= ST_LEN);
    assert_int_equal(dkf_diffkf_save(&f, ck, len - 1), DKF_ERR_CAPACITY);
    for (k = 1; k <= NS; ++k) {
        if (k == 4) assert_int_equal(dkf_diffkf_save(&f, ck, len), DKF_OK);
        masked_step(&f, &w, k);
        memcpy(ref[k][0], f.xf.data, w.n * sizeof(dkf_real_t));
        memcpy(ref[k][1], f.Pn.data, w.n * w.n * sizeof(dkf_real_t));
    }
    /* corrupted copies: tag, dimension, non-finite state, short */
    memcpy(bad, ck, len * sizeof(dkf_real_t));
    bad[0] += 1;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_ARG, dkf_diffkf_restore(&f, bad, len), st, ST_LEN);
    memcpy(bad, ck, len * sizeof(dkf_real_t));
    bad[1] += 1;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_diffkf_restore(&f, bad, len), st, ST_LEN);
    memcpy(bad, ck, len * sizeof(dkf_real_t));
    bad[len - 1] = (dkf_real_t)NAN;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_NONFINITE, dkf_diffkf_restore(&f, bad, len), st, ST_LEN);
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_CAPACITY, dkf_diffkf_restore(&f, ck, len - 1), st, ST_LEN);
    /* restore and replay, in the same filter and in another */
    assert_int_equal(dkf_diffkf_restore(&f, ck, len), DKF_OK);
    assert_int_equal(dkf_diffkf_restore(&g, ck, len), DKF_OK);
    assert_int_equal(f.k, 3);
    assert_int_equal(g.k, 3);
    for (k = 4; k <= NS; ++k) {
        masked_step(&f, &w, k);
        masked_step(&g, &w, k);
        assert_memory_equal(f.xf.data, ref[k][0], w.n * sizeof(dkf_real_t));
        assert_memory_equal(f.Pn.data, ref[k][1], w.n * w.n * sizeof(dkf_real_t));
        assert_memory_equal(g.xf.data, ref[k][0], w.n * sizeof(dkf_real_t));
        assert_memory_equal(g.Pn.data, ref[k][1], w.n * w.n * sizeof(dkf_real_t));
    }
    /* set_time: absolute times for a late start */
    assert_int_equal(dkf_diffkf_set_time(&g, 41), DKF_OK);
    assert_int_equal(dkf_diffkf_save(&g, ck, len), DKF_OK);
    assert_int_equal(dkf_diffkf_restore(&f, ck, len), DKF_OK);
    assert_int_equal(f.k, 41);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_masked_matches_batch),
        cmocka_unit_test(test_batch_detects_wrong_selection),
        cmocka_unit_test(test_all_ones_bit_identical),
        cmocka_unit_test(test_pure_prediction_step),
        cmocka_unit_test(test_masked_shape_and_failure),
        cmocka_unit_test(test_checkpoint_round_trip),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
