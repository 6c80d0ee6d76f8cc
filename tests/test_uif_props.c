/*
 * Unknown-input filters (dkf/uif.h): properties beyond the golden vectors.
 *  - the storage macro is exact;
 *  - NRTSF-DF equals RTSF when H_k has full column rank (random
 *    time-varying models);
 *  - NRTSF-DF with a rank r_k that changes every step (3, 2, 1, 0, ...)
 *    equals an independent double-precision implementation of the paper's
 *    equations (27)-(29) built on the APPENDIX decomposition (a pivoted
 *    minor, T^+ = T^T (T T^T)^-1), so the SVD route's invariance is tested
 *    too;
 *  - unbiasedness: zero noise and a large deterministic input leave state
 *    errors at rounding level (RTSF, NRTSF-DF with null(H) in null(G),
 *    NRTSF with rank-deficient G), and the estimable part of d exact;
 *  - the bias flag: raised on the paper's example, not when
 *    G (I - T^+T) = 0; the bias it warns about is real;
 *  - non-estimable components reported (paper d_1 under NRTSF-DF, d_3
 *    under NRTSF) and returned as exact zeros;
 *  - failure atomicity for NaN, rank failures, non-SPD R~, bad sequence.
 * Random models use dyadic entries (multiples of 1/8) so that H = Hbar T is
 * exactly representable, and exactly of rank r, in float as well as double.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/uif.h"
#include "dkf_test.h"
#include "uif_paper.h"

#define MAXN 6
#define MAXP 4
#define MAXM 5
#define CAP 64
#define STEPS 40

typedef struct {
    DKF_UIF_DECLARE(, f, MAXN, MAXM, MAXP);
} box_t;

/* ---- double-precision helpers (independent of the library) ------------ */

static void dmul(double *C, const double *A, const double *B, size_t r, size_t k, size_t c)
{
    test_ref_mul(C, A, B, r, k, c);
}

static double dyadic(test_rng_t *r, double scale)
{
    return floor(8.0 * scale * test_rng_normal(r) + 0.5) / 8.0;
}

static void rand_dyadic(test_rng_t *r, double *A, size_t rows, size_t cols, double scale)
{
    size_t i;
    for (i = 0; i < rows * cols; ++i) A[i] = dyadic(r, scale);
}

/* 1 if the Gram matrix of the k vectors of length len (stride: element
 * (v, i) at X[v * sv + i * si]) is well conditioned: Gaussian elimination
 * pivots all above 0.3 times the largest diagonal. Keeps random factors
 * away from (near) rank loss, so cond(H) stays moderate. */
static int gram_ok(const double *X, size_t k, size_t len, size_t sv, size_t si)
{
    double Gm[CAP], dmax = 0.0;
    size_t a, c, i;
    for (a = 0; a < k; ++a)
        for (c = 0; c < k; ++c) {
            double acc = 0.0;
            for (i = 0; i < len; ++i) acc += X[a * sv + i * si] * X[c * sv + i * si];
            Gm[a * k + c] = acc;
        }
    for (a = 0; a < k; ++a) dmax = fmax(dmax, Gm[a * k + a]);
    for (c = 0; c < k; ++c) { /* Cholesky-like elimination, SPD Gram */
        if (!(Gm[c * k + c] > 0.3 * dmax)) return 0;
        for (a = c + 1; a < k; ++a) {
            const double f = Gm[a * k + c] / Gm[c * k + c];
            for (i = c; i < k; ++i) Gm[a * k + i] -= f * Gm[c * k + i];
        }
    }
    return 1;
}

/* A rows x cols dyadic matrix of rank exactly `rank` (a product of dyadic
 * factors, both well conditioned; small integers over 64, exact in
 * float). If T is given it receives the right factor (rank x cols). */
static void rand_rank(test_rng_t *r, double *A, double *T, size_t rows, size_t cols, size_t rank,
                      double scale)
{
    double L[CAP], R[CAP];
    size_t i;
    if (rank == 0) {
        for (i = 0; i < rows * cols; ++i) A[i] = 0.0;
        return;
    }
    do {
        rand_dyadic(r, L, rows, rank, scale);
        rand_dyadic(r, R, rank, cols, 1.0);
    } while (!gram_ok(L, rank, rows, 1, rank) || !gram_ok(R, rank, cols, cols, 1));
    dmul(A, L, R, rows, rank, cols);
    if (T != NULL) memcpy(T, R, rank * cols * sizeof *R);
}

/* ---- a time-varying model in double, and its library views ------------ */

typedef struct {
    size_t n, p, m;
    double A[CAP], G[CAP], Q[CAP], C[CAP], H[CAP], R[CAP];
    double Tlast[CAP]; /* right factor of the previous H (rank rlast) */
    size_t rlast;
    dkf_real_t rA[CAP], rG[CAP], rQ[CAP], rC[CAP], rH[CAP], rR[CAP];
    dkf_mat_t mA, mG, mQ, mC, mH, mR;
    dkf_uif_dyn_t dyn;
    dkf_ui_meas_t meas;
} model_t;

/* Converts the double model to the library type and wires the views. */
static void model_views(model_t *s, int with_h)
{
    const size_t n = s->n, p = s->p, m = s->m;
    test_to_real(s->rA, s->A, n * n);
    test_to_real(s->rG, s->G, n * p);
    test_to_real(s->rQ, s->Q, n * n);
    test_to_real(s->rC, s->C, m * n);
    test_to_real(s->rH, s->H, m * p);
    test_to_real(s->rR, s->R, m * m);
    s->mA = test_view(n, n, s->rA);
    s->mG = test_view(n, p, s->rG);
    s->mQ = test_view(n, n, s->rQ);
    s->mC = test_view(m, n, s->rC);
    s->mH = test_view(m, p, s->rH);
    s->mR = test_view(m, m, s->rR);
    s->dyn.F = &s->mA;
    s->dyn.G = &s->mG;
    s->dyn.Q = &s->mQ;
    s->meas.H = &s->mC;
    s->meas.D = with_h ? &s->mH : NULL;
    s->meas.R = &s->mR;
}

/* One step's model: random A (spectral radius ~0.6), C, Q, R; the scales
 * (|G| |C| / |H| ~ 1/8) keep the input observable enough that the
 * covariances stay O(1) and cond(R~) moderate, so rounding, not the model,
 * sets the error levels the tests bound; H_k of rank
 * rh (m x p); G_{k-1} of rank rg, or (g_in_row_h) G_{k-1} = G1 T_{k-1}
 * with T_{k-1} the right factor of the previous call's H, so that
 * null(H_{k-1}) is in null(G_{k-1}). Set s->rlast = 0 before the first
 * call. */
static void rand_model(test_rng_t *r, model_t *s, size_t n, size_t p, size_t m, size_t rh,
                       size_t rg, int g_in_row_h)
{
    double G1[CAP];
    size_t i;
    s->n = n, s->p = p, s->m = m;
    rand_dyadic(r, s->A, n, n, 0.6 / sqrt((double)n));
    rand_dyadic(r, s->C, m, n, 0.5);
    test_rand_spd(r, s->Q, n, 10.0, 1e-2);
    test_rand_spd(r, s->R, m, 10.0, 1e-1);
    if (g_in_row_h) {
        for (i = 0; i < n * p; ++i) s->G[i] = 0.0;
        if (s->rlast > 0) {
            rand_dyadic(r, G1, n, s->rlast, 0.25);
            dmul(s->G, G1, s->Tlast, n, s->rlast, p);
        }
    } else {
        rand_rank(r, s->G, NULL, n, p, rg, 0.25);
    }
    rand_rank(r, s->H, s->Tlast, m, p, rh, 1.0);
    s->rlast = rh;
}

static void init_filter(box_t *b, dkf_uif_kind_t kind, size_t n, size_t p, size_t m,
                        const double *x0, double p0)
{
    dkf_real_t xs[MAXN], Ps[MAXN * MAXN];
    dkf_mat_t X, P;
    size_t i;
    test_to_real(xs, x0, n);
    test_fill(Ps, n * n, DKF_R(0.0));
    for (i = 0; i < n; ++i) Ps[i * n + i] = (dkf_real_t)p0;
    X = test_view(n, 1, xs);
    P = test_view(n, n, Ps);
    assert_int_equal(dkf_uif_init(&b->f, kind, n, m, p, b->f_storage,
                                  DKF_UIF_STORAGE_LEN(MAXN, MAXM, MAXP), &X, &P),
                     DKF_OK);
}

static dkf_status_t step_with(box_t *b, model_t *s, const double *y, int first)
{
    dkf_real_t ys[MAXM];
    dkf_mat_t Y;
    test_to_real(ys, y, s->m);
    Y = test_view(s->m, 1, ys);
    return dkf_uif_step(&b->f, first ? NULL : &s->dyn, &s->meas, &Y);
}

/* ---- storage ------------------------------------------------------------ */

/* init accepts DKF_UIF_STORAGE_LEN reals and refuses one less, for every
 * kind and several shapes (an under-count would overrun the caller's
 * array, an over-count wastes RAM). */
static void test_uif_storage_macro_is_exact(void **state)
{
    static dkf_real_t st[DKF_UIF_STORAGE_LEN(MAXN, MAXM, MAXP)];
    static const size_t dims[][3] = {{5, 3, 5}, {1, 1, 1}, {6, 2, 3}, {2, 4, 5}, {6, 4, 4}, {3, 1, 5}};
    dkf_real_t x[MAXN] = {0}, P[MAXN * MAXN];
    dkf_uif_t f;
    size_t d, i, kind;
    (void)state;
    for (d = 0; d < sizeof dims / sizeof dims[0]; ++d)
        for (kind = 0; kind < 3; ++kind) {
            const size_t n = dims[d][0], p = dims[d][1], m = dims[d][2];
            const size_t len = DKF_UIF_STORAGE_LEN(n, m, p);
            dkf_mat_t X = test_view(n, 1, x), P0 = test_view(n, n, P);
            assert_true(len <= sizeof st / sizeof st[0]);
            test_fill(P, n * n, DKF_R(0.0));
            for (i = 0; i < n; ++i) P[i * n + i] = 1;
            assert_int_equal(dkf_uif_init(&f, (dkf_uif_kind_t)kind, n, m, p, st, len - 1, &X, &P0),
                             DKF_ERR_CAPACITY);
            assert_int_equal(dkf_uif_init(&f, (dkf_uif_kind_t)kind, n, m, p, st, len, &X, &P0),
                             DKF_OK);
        }
}

/* ---- NRTSF-DF == RTSF for full-rank H ----------------------------------- */

/* Tolerance: the two filters compute the same quantities through B = H
 * and through B = Hbar = U S with d = V dbar; the difference is rounding
 * amplified by cond(H^T R~^-1 H) (here < 1e3): 1e4 * eps relative
 * (2e-12 double, 1.2e-3 float); measured values are printed. */
#define SAME_REL (1e4 * TEST_EPS)

static void assert_same_filter(const dkf_uif_t *a, const dkf_uif_t *b)
{
    double e[CAP];
    const dkf_mat_t *pa[] = {&a->x, &a->Px, &a->d, &a->Pd, &a->Pxd, &a->K, &a->L, &a->M, &a->proj};
    const dkf_mat_t *pb[] = {&b->x, &b->Px, &b->d, &b->Pd, &b->Pxd, &b->K, &b->L, &b->M, &b->proj};
    static const char *names[] = {"x", "Px", "d", "Pd", "Pxd", "K", "L", "M", "proj"};
    size_t i;
    for (i = 0; i < sizeof pa / sizeof pa[0]; ++i) {
        const size_t len = pa[i]->rows * pa[i]->cols;
        test_to_double(e, pb[i]->data, len);
        test_assert_close(names[i], pa[i]->data, e, len, SAME_REL);
    }
    assert_int_equal(a->rank, b->rank);
}

static void test_uif_nrtsf_df_equals_rtsf_full_rank(void **state)
{
    static box_t a, b;
    /* (m = p would leave no measurement for the state: P_{k|k-1} then
     * grows without bound, a valid but degenerate case not used here) */
    static const size_t dims[][3] = {{4, 2, 3}, {6, 3, 5}, {5, 4, 5}, {3, 1, 2}};
    test_rng_t rng;
    model_t s;
    double x0[MAXN] = {0}, y[MAXM];
    size_t d, k, i;
    (void)state;
    test_rng_seed(&rng, 4004);
    test_reset_worst_rel();
    for (d = 0; d < sizeof dims / sizeof dims[0]; ++d) {
        const size_t n = dims[d][0], p = dims[d][1], m = dims[d][2];
        init_filter(&a, DKF_UIF_RTSF, n, p, m, x0, 1.0);
        init_filter(&b, DKF_UIF_NRTSF_DF, n, p, m, x0, 1.0);
        for (k = 0; k < STEPS; ++k) {
            rand_model(&rng, &s, n, p, m, p, p, 0);
            model_views(&s, 1);
            for (i = 0; i < m; ++i) y[i] = test_rng_normal(&rng);
            assert_int_equal(step_with(&a, &s, y, k == 0), DKF_OK);
            assert_int_equal(step_with(&b, &s, y, k == 0), DKF_OK);
            assert_same_filter(&b.f, &a.f);
            assert_int_equal(b.f.rank, p);
            assert_int_equal(b.f.bias_risk, 0);
            for (i = 0; i < p; ++i) assert_int_equal(b.f.estimable[i], DKF_UIF_EST_FULL);
        }
    }
    print_message("NRTSF-DF vs RTSF, 4 shapes x %d steps: worst relative difference %.3e\n",
                  STEPS, test_worst_rel());
}

/* ---- independent reference with the appendix decomposition ------------- */

typedef struct {
    double x[MAXN], Px[CAP], d[MAXP], Pd[CAP], Pxd[CAP];
} ref_t;

/* The paper's appendix: a nonsingular rank x rank minor H[I, J] found by
 * complete pivoting, Hbar = H[:, J], T = H[I, J]^-1 H[I, :]. */
static void appendix_frd(double *Hbar, double *T, const double *H, size_t m, size_t p, size_t r)
{
    double W[CAP], Mi[CAP], Min[CAP], HI[CAP];
    size_t I[MAXM], J[MAXP], t, i, j;
    memcpy(W, H, m * p * sizeof *W);
    for (t = 0; t < r; ++t) {
        size_t bi = 0, bj = 0;
        double best = -1.0;
        for (i = 0; i < m; ++i)
            for (j = 0; j < p; ++j)
                if (fabs(W[i * p + j]) > best) best = fabs(W[i * p + j]), bi = i, bj = j;
        assert_true(best > 0.0);
        I[t] = bi, J[t] = bj;
        for (i = 0; i < m; ++i) /* eliminate column bj with row bi */
            if (i != bi) {
                const double f = W[i * p + bj] / W[bi * p + bj];
                for (j = 0; j < p; ++j) W[i * p + j] -= f * W[bi * p + j];
            }
        for (j = 0; j < p; ++j) W[bi * p + j] = 0.0;
    }
    for (i = 0; i < m; ++i)
        for (t = 0; t < r; ++t) Hbar[i * r + t] = H[i * p + J[t]];
    for (t = 0; t < r; ++t)
        for (j = 0; j < r; ++j) Min[t * r + j] = H[I[t] * p + J[j]];
    for (t = 0; t < r; ++t)
        for (j = 0; j < p; ++j) HI[t * p + j] = H[I[t] * p + j];
    test_ref_inverse_double(Mi, Min, r);
    dmul(T, Mi, HI, r, r, p);
}

/* One NRTSF-DF step, (27)-(29) literally, in double. */
static void ref_df_step(ref_t *f, const model_t *s, const double *y, size_t r, int first)
{
    const size_t n = s->n, p = s->p, m = s->m;
    double xp[MAXN], Pp[CAP], t1[CAP], t2[CAP], t3[CAP], Rt[CAP], Rti[CAP], K[CAP], yt[MAXM];
    double Hbar[CAP], T[CAP], Tt[CAP], Tp[CAP], Pdb[CAP], Mb[CAP], db[MAXP], e[MAXM];
    size_t i;
    if (first) {
        memcpy(xp, f->x, n * sizeof *xp);
        memcpy(Pp, f->Px, n * n * sizeof *Pp);
    } else { /* [A G] [Px Pxd; Pxd^T Pd] [A G]^T + Q */
        double AG[CAP * 2], J[4 * CAP], JA[4 * CAP], AGt[4 * CAP], xd[MAXN + MAXP];
        const size_t q = n + p;
        size_t j;
        for (i = 0; i < n; ++i)
            for (j = 0; j < q; ++j) AG[i * q + j] = j < n ? s->A[i * n + j] : s->G[i * p + j - n];
        for (i = 0; i < q; ++i)
            for (j = 0; j < q; ++j)
                J[i * q + j] = i < n ? (j < n ? f->Px[i * n + j] : f->Pxd[i * p + j - n])
                                     : (j < n ? f->Pxd[j * p + i - n] : f->Pd[(i - n) * p + j - n]);
        for (i = 0; i < q; ++i) xd[i] = i < n ? f->x[i] : f->d[i - n];
        dmul(xp, AG, xd, n, q, 1);
        dmul(JA, AG, J, n, q, q);
        test_ref_transpose(AGt, AG, n, q);
        dmul(Pp, JA, AGt, n, q, n);
        for (i = 0; i < n * n; ++i) Pp[i] += s->Q[i];
    }
    dmul(t1, s->C, Pp, m, n, n);
    test_ref_transpose(t2, s->C, m, n);
    dmul(Rt, t1, t2, m, n, m);
    for (i = 0; i < m * m; ++i) Rt[i] += s->R[i];
    test_ref_inverse_double(Rti, Rt, m);
    dmul(t3, Pp, t2, n, n, m);
    dmul(K, t3, Rti, n, m, m);
    dmul(e, s->C, xp, m, n, 1);
    for (i = 0; i < m; ++i) yt[i] = y[i] - e[i];
    memset(f->d, 0, sizeof f->d);
    memset(f->Pd, 0, sizeof f->Pd);
    memset(f->Pxd, 0, sizeof f->Pxd);
    if (r == 0) {
        dmul(e, K, yt, n, m, 1);
        for (i = 0; i < n; ++i) f->x[i] = xp[i] + e[i];
        dmul(t1, K, Rt, n, m, m);
        test_ref_transpose(t2, K, n, m);
        dmul(t3, t1, t2, n, m, n);
        for (i = 0; i < n * n; ++i) f->Px[i] = Pp[i] - t3[i];
        return;
    }
    appendix_frd(Hbar, T, s->H, m, p, r);
    { /* Pdbar = (Hbar^T R~^-1 Hbar)^-1, Mbar = Pdbar Hbar^T R~^-1 (28) */
        double Hbt[CAP], HR[CAP], S[CAP];
        test_ref_transpose(Hbt, Hbar, m, r);
        dmul(HR, Hbt, Rti, r, m, m);
        dmul(S, HR, Hbar, r, m, r);
        test_ref_inverse_double(Pdb, S, r);
        dmul(Mb, Pdb, HR, r, r, m);
        dmul(db, Mb, yt, r, m, 1);
        /* x = xp + K (y~ - Hbar dbar) */
        dmul(e, Hbar, db, m, r, 1);
        for (i = 0; i < m; ++i) e[i] = yt[i] - e[i];
        dmul(t1, K, e, n, m, 1);
        for (i = 0; i < n; ++i) f->x[i] = xp[i] + t1[i];
        /* Px = Pp - K (R~ - Hbar Pdbar Hbar^T) K^T */
        dmul(t1, Hbar, Pdb, m, r, r);
        dmul(t2, t1, Hbt, m, r, m);
        for (i = 0; i < m * m; ++i) t2[i] = Rt[i] - t2[i];
        dmul(t1, K, t2, n, m, m);
        test_ref_transpose(t2, K, n, m);
        dmul(t3, t1, t2, n, m, n);
        for (i = 0; i < n * n; ++i) f->Px[i] = Pp[i] - t3[i];
        /* T^+ = T^T (T T^T)^-1; d = T^+ dbar, Pd = T^+ Pdbar T^+T,
         * Pxd = -K Hbar Pdbar T^+T */
        test_ref_transpose(Tt, T, r, p);
        dmul(t1, T, Tt, r, p, r);
        test_ref_inverse_double(t2, t1, r);
        dmul(Tp, Tt, t2, p, r, r);
        dmul(f->d, Tp, db, p, r, 1);
        dmul(t1, Tp, Pdb, p, r, r);
        test_ref_transpose(t2, Tp, p, r);
        dmul(f->Pd, t1, t2, p, r, p);
        dmul(t1, K, Hbar, n, m, r);
        dmul(t3, t1, Pdb, n, r, r);
        dmul(f->Pxd, t3, t2, n, r, p);
        for (i = 0; i < n * p; ++i) f->Pxd[i] = -f->Pxd[i];
    }
}

/* NRTSF-DF with H_k of rank 3, 2, 1, 0, 2, 3, 1, ... (p = 3) against the
 * reference. Tolerance: both are backward stable evaluations of the same
 * formulas with different decompositions; cond(Hbar^T R~^-1 Hbar) stays
 * below ~1e3, so 1e4 * eps relative per field (double 2.2e-12, float
 * 1.2e-3 with rounding of the model to float included). */
static void test_uif_nrtsf_df_rank_changes_match_reference(void **state)
{
    static box_t b;
    static const size_t ranks[] = {3, 2, 1, 0, 2, 3, 1, 2, 0, 3};
    const size_t n = 5, p = 3, m = 4;
    test_rng_t rng;
    model_t s;
    ref_t ref;
    double x0[MAXN] = {0.5, -1, 0, 2, 1}, y[MAXM], e[CAP];
    size_t k, i, seen[4] = {0, 0, 0, 0};
    (void)state;
    test_rng_seed(&rng, 77);
    test_reset_worst_rel();
    memset(&ref, 0, sizeof ref);
    memcpy(ref.x, x0, n * sizeof *x0);
    for (i = 0; i < n; ++i) ref.Px[i * n + i] = 0.5;
    init_filter(&b, DKF_UIF_NRTSF_DF, n, p, m, x0, 0.5);
    for (k = 0; k < STEPS; ++k) {
        const size_t r = ranks[k % (sizeof ranks / sizeof ranks[0])];
        rand_model(&rng, &s, n, p, m, r, p, 0);
        model_views(&s, 1);
        for (i = 0; i < m; ++i) y[i] = 3.0 * test_rng_normal(&rng);
        assert_int_equal(step_with(&b, &s, y, k == 0), DKF_OK);
        ref_df_step(&ref, &s, y, r, k == 0);
        assert_int_equal(b.f.rank, r);
        ++seen[r];
        test_assert_close("x", b.f.x.data, ref.x, n, 1e4 * TEST_EPS);
        test_assert_close("Px", b.f.Px.data, ref.Px, n * n, 1e4 * TEST_EPS);
        test_assert_close("d", b.f.d.data, ref.d, p, 1e4 * TEST_EPS);
        test_assert_close("Pd", b.f.Pd.data, ref.Pd, p * p, 1e4 * TEST_EPS);
        test_assert_close("Pxd", b.f.Pxd.data, ref.Pxd, n * p, 1e4 * TEST_EPS);
        /* the projector is T^+ T of the reference decomposition too */
        if (r == 0) {
            for (i = 0; i < p * p; ++i) e[i] = 0.0;
        } else {
            double Hbar[CAP], T[CAP], Tt[CAP], t1[CAP], t2[CAP], Tp[CAP];
            appendix_frd(Hbar, T, s.H, m, p, r);
            test_ref_transpose(Tt, T, r, p);
            dmul(t1, T, Tt, r, p, r);
            test_ref_inverse_double(t2, t1, r);
            dmul(Tp, Tt, t2, p, r, r);
            dmul(e, Tp, T, p, r, p);
        }
        test_assert_close("proj", b.f.proj.data, e, p * p, 1e4 * TEST_EPS);
    }
    for (i = 0; i <= 3; ++i) assert_true(seen[i] > 0);
    print_message("NRTSF-DF with r_k in {0..3} vs appendix reference, %d steps: worst %.3e\n",
                  STEPS, test_worst_rel());
}

/* ---- unbiasedness --------------------------------------------------------- */

/* A large deterministic input: amplitude 1e3, a sine, a square wave and a
 * ramp, different per component. */
static double input_at(size_t k, size_t i)
{
    const double t = (double)k;
    switch (i % 3) {
    case 0: return 1e3 * sin(2.0 * 3.141592653589793 * t / 17.0 + (double)i);
    case 1: return ((k / 7) % 2 == 0 ? 1e3 : -8e2);
    default: return 40.0 * t - 5e2;
    }
}

/* Runs `kind` on a zero-noise simulation of random time-varying models
 * (x_0 known exactly) and returns the worst state error relative to
 * max(1, max|x|) and the worst error of the estimable input part
 * (d_hat - proj d) relative to the input amplitude. */
static void zero_noise_run(dkf_uif_kind_t kind, size_t n, size_t p, size_t m, size_t rh, size_t rg,
                           int g_in_row_h, uint64_t seed, double *xerr, double *derr)
{
    static box_t b;
    test_rng_t rng;
    model_t s;
    double x[MAXN], xn[MAXN], dprev[MAXP], d[MAXP], y[MAXM], t[MAXM], xmax = 1.0;
    double x0[MAXN] = {3, -1, 2, 0.5, -2, 1};
    size_t k, i, j;
    const int df = kind != DKF_UIF_NRTSF;
    test_rng_seed(&rng, seed);
    s.rlast = 0;
    memcpy(x, x0, n * sizeof *x);
    init_filter(&b, kind, n, p, m, x0, 1.0);
    *xerr = *derr = 0.0;
    for (i = 0; i < p; ++i) dprev[i] = input_at(0, i);
    for (k = 0; k < STEPS; ++k) {
        rand_model(&rng, &s, n, p, m, df ? rh : 0, rg, g_in_row_h);
        if (!df) memset(s.H, 0, sizeof s.H);
        model_views(&s, df);
        for (i = 0; i < p; ++i) d[i] = input_at(k + 1, i);
        if (k > 0 || !df) { /* x_k = A x_{k-1} + G d_{k-1} (s holds A_{k-1}, G_{k-1}) */
            double Gd[MAXN];
            dmul(xn, s.A, x, n, n, 1);
            dmul(Gd, s.G, dprev, n, p, 1);
            for (i = 0; i < n; ++i) x[i] = xn[i] + Gd[i];
        }
        dmul(y, s.C, x, m, n, 1);
        if (df) {
            dmul(t, s.H, d, m, p, 1);
            for (i = 0; i < m; ++i) y[i] += t[i];
        }
        assert_int_equal(step_with(&b, &s, y, df && k == 0), DKF_OK);
        for (i = 0; i < n; ++i)
            if (fabs(x[i]) > xmax) xmax = fabs(x[i]);
        for (i = 0; i < n; ++i) {
            const double er = fabs((double)b.f.x.data[i] - x[i]) / xmax;
            if (er > *xerr) *xerr = er;
        }
        /* the estimable part of the input the filter estimated: d_k (DF)
         * or d_{k-1} (NRTSF) */
        for (i = 0; i < p; ++i) {
            const double *dd = df ? d : dprev;
            double pd = 0.0, er;
            for (j = 0; j < p; ++j) pd += (double)b.f.proj.data[i * p + j] * dd[j];
            er = fabs((double)b.f.d.data[i] - pd) / 1e3;
            if (er > *derr) *derr = er;
        }
        assert_int_equal(b.f.bias_risk, 0);
        memcpy(dprev, d, p * sizeof *d);
    }
}

/* Tolerances: the inputs are 1e3, the states up to ~1e4, and every error
 * is rounding of O(m) Cholesky solves and products amplified by the
 * conditioning of the weighted least squares (< 1e3 here), without growth
 * (the error dynamics are contractive): 1e4 * eps relative (2.2e-12
 * double, 1.2e-3 float); the derivation (docs/design/derivation-seed003-004.md) measured <= 7e-14 in double. */
static void test_uif_unbiased_zero_noise(void **state)
{
    static const struct {
        const char *name, *dwhat;
        dkf_uif_kind_t kind;
        size_t n, p, m, rh, rg; /* zero_noise_run's */
        int g_in_row_h;
        uint64_t seed;
    } runs[] = {
        /* RTSF, full-rank H */
        {"RTSF", "input", DKF_UIF_RTSF, 4, 2, 5, 2, 2, 0, 11},
        /* NRTSF-DF, rank H = 2 < p = 3 and G = G1 T (null(H) in null(G)): the
         * input has a component in null(H), which the filter cannot see and
         * does not need */
        {"NRTSF-DF", "input (estimable)", DKF_UIF_NRTSF_DF, 5, 3, 5, 2, 0, 1, 12},
        /* NRTSF-DF, rank H = 1 of p = 2 */
        {"NRTSF-DF r1", "input (estimable)", DKF_UIF_NRTSF_DF, 6, 2, 5, 1, 0, 1, 13},
        /* NRTSF, rank G = 2 < p = 3 */
        {"NRTSF", "input (estimable)", DKF_UIF_NRTSF, 5, 3, 5, 0, 2, 0, 14},
        /* NRTSF, full-rank G */
        {"NRTSF r=m", "input", DKF_UIF_NRTSF, 6, 2, 5, 0, 2, 0, 15},
    };
    double xe, de;
    const double tol = 1e4 * TEST_EPS;
    size_t c;
    (void)state;
    for (c = 0; c < sizeof runs / sizeof runs[0]; ++c) {
        zero_noise_run(runs[c].kind, runs[c].n, runs[c].p, runs[c].m, runs[c].rh, runs[c].rg,
                       runs[c].g_in_row_h, runs[c].seed, &xe, &de);
        print_message("%-11s zero noise: state %.2e, %s %.2e\n", runs[c].name, xe, runs[c].dwhat,
                      de);
        assert_true(xe <= tol && de <= tol);
    }
}

/* ---- the paper's example (uif_paper.h): estimability and the bias flag -- */

static void paper_model(model_t *s, int with_h)
{
    size_t i;
    s->n = 5, s->p = 3, s->m = 5;
    memcpy(s->A, PA, sizeof PA);
    memcpy(s->G, PG, sizeof PG);
    memcpy(s->H, PH, sizeof PH);
    memcpy(s->R, PR, sizeof PR);
    for (i = 0; i < 25; ++i) s->Q[i] = 1e-2 * PR[i]; /* derivation §5: Q = 1e-4 x R's pattern */
    memset(s->C, 0, sizeof s->C);
    for (i = 0; i < 5; ++i) s->C[i * 5 + i] = 1.0;
    if (!with_h) memset(s->H, 0, sizeof s->H);
    model_views(s, 1);
    if (!with_h) s->meas.D = NULL;
}

/* Zero noise, the paper's system; d1 = d1amp sin, d2 steps, d3 square
 * wave. Returns the worst |x_hat - x| over steps 1.. . */
static double paper_zero_noise(box_t *b, dkf_uif_kind_t kind, double d1amp)
{
    model_t s;
    double x[5] = {0}, xn[5], d[3], dprev[3] = {0}, y[5], worst = 0.0, x0[5] = {0};
    size_t k, i;
    const int df = kind != DKF_UIF_NRTSF;
    paper_model(&s, df);
    init_filter(b, kind, 5, 3, 5, x0, 0.1);
    for (k = 0; k < STEPS; ++k) {
        d[0] = d1amp * sin(2.0 * 3.141592653589793 * (double)k / 40.0);
        d[1] = (k >= 10 && k < 30) ? 2.0 : -1.0;
        d[2] = ((k / 15) % 2 == 0) ? 1.5 : -1.5;
        if (k > 0 || !df) {
            double Gd[5];
            dmul(xn, s.A, x, 5, 5, 1);
            dmul(Gd, s.G, dprev, 5, 3, 1);
            for (i = 0; i < 5; ++i) x[i] = xn[i] + Gd[i];
        }
        for (i = 0; i < 5; ++i) y[i] = x[i]; /* C = I */
        if (df) {
            double Hd[5];
            dmul(Hd, s.H, d, 5, 3, 1);
            for (i = 0; i < 5; ++i) y[i] += Hd[i];
        }
        assert_int_equal(step_with(b, &s, y, df && k == 0), DKF_OK);
        for (i = 0; i < 5 && k > 0; ++i) worst = fmax(worst, fabs((double)b->f.x.data[i] - x[i]));
        memcpy(dprev, d, sizeof d);
    }
    return worst;
}

/* NRTSF-DF on the paper's example: rank 2, d_1 not estimable (returned as
 * exactly 0 with zero variance), and the flag raised at every step with a
 * time update, because G e_1 = e_1 != 0. With d_1 != 0 the bias is real
 * (derivation §8: up to ~2 in x_1); with d_1 = 0 the same run is exact, and the
 * flag (which cannot know d) is still raised. */
static void test_uif_bias_flag_paper_example(void **state)
{
    static box_t b;
    double biased, clean;
    size_t i;
    (void)state;
    biased = paper_zero_noise(&b, DKF_UIF_NRTSF_DF, 1.0);
    assert_int_equal(b.f.rank, 2);
    assert_int_equal(b.f.bias_risk, 1);
    assert_int_equal(b.f.bias_steps, STEPS - 1);
    assert_int_equal(b.f.estimable[0], DKF_UIF_EST_NONE);
    assert_int_equal(b.f.estimable[1], DKF_UIF_EST_FULL);
    assert_int_equal(b.f.estimable[2], DKF_UIF_EST_FULL);
    assert_true(b.f.d.data[0] == DKF_R(0.0));
    for (i = 0; i < 3; ++i) {
        assert_true(b.f.Pd.data[i] == DKF_R(0.0));
        assert_true(b.f.Pd.data[i * 3] == DKF_R(0.0));
    }
    for (i = 0; i < 5; ++i) assert_true(b.f.M.data[i] == DKF_R(0.0));
    for (i = 0; i < 5; ++i) assert_true(b.f.Pxd.data[i * 3] == DKF_R(0.0));
    clean = paper_zero_noise(&b, DKF_UIF_NRTSF_DF, 0.0);
    assert_int_equal(b.f.bias_steps, STEPS - 1);
    print_message("paper NRTSF-DF zero noise: max|x_hat - x| = %.3g with d1 = sin, %.3g with d1 = 0\n",
                  biased, clean);
    assert_true(biased > 0.1);
    assert_true(clean <= 1e4 * TEST_EPS * 10.0); /* x up to ~10 */
}

/* No flag when G (I - T^+T) = 0: full-rank H (RTSF and NRTSF-DF on the
 * paper system with H[3][0] = 1), and NRTSF on the paper example, which is
 * unbiased for every d; NRTSF reports d_3 (null(G)) as not estimable. */
static void test_uif_bias_flag_not_raised(void **state)
{
    static box_t b;
    model_t s;
    double worst;
    size_t k;
    double y[5] = {0.1, -0.2, 0.3, 0.0, 0.05}, x0[5] = {0};
    (void)state;
    paper_model(&s, 1);
    s.H[3 * 3 + 0] = 1.0;
    model_views(&s, 1);
    init_filter(&b, DKF_UIF_NRTSF_DF, 5, 3, 5, x0, 0.1);
    for (k = 0; k < 10; ++k) {
        assert_int_equal(step_with(&b, &s, y, k == 0), DKF_OK);
        assert_int_equal(b.f.rank, 3);
        assert_int_equal(b.f.bias_risk, 0);
    }
    assert_int_equal(b.f.bias_steps, 0);
    worst = paper_zero_noise(&b, DKF_UIF_NRTSF, 1.0);
    print_message("paper NRTSF zero noise (d3 unseen): max|x_hat - x| = %.3g\n", worst);
    assert_true(worst <= 1e4 * TEST_EPS * 10.0);
    assert_int_equal(b.f.bias_steps, 0);
    assert_int_equal(b.f.rank, 2);
    assert_int_equal(b.f.estimable[0], DKF_UIF_EST_FULL);
    assert_int_equal(b.f.estimable[1], DKF_UIF_EST_FULL);
    assert_int_equal(b.f.estimable[2], DKF_UIF_EST_NONE);
    assert_true(b.f.d.data[2] == DKF_R(0.0));
}

/* A generic rank-deficient H has no component that is estimable on its
 * own: every component is PARTIAL, and proj is a rank-r projector. */
static void test_uif_partial_estimability(void **state)
{
    static box_t b;
    test_rng_t rng;
    model_t s;
    double y[MAXM] = {1, 2, 3, 4}, x0[MAXN] = {0}, tr = 0.0;
    size_t i;
    (void)state;
    test_rng_seed(&rng, 5);
    rand_model(&rng, &s, 4, 3, 4, 2, 3, 0);
    model_views(&s, 1);
    init_filter(&b, DKF_UIF_NRTSF_DF, 4, 3, 4, x0, 1.0);
    assert_int_equal(step_with(&b, &s, y, 1), DKF_OK);
    assert_int_equal(b.f.rank, 2);
    for (i = 0; i < 3; ++i) {
        assert_int_equal(b.f.estimable[i], DKF_UIF_EST_PARTIAL);
        tr += (double)b.f.proj.data[i * 3 + i];
    }
    assert_true(fabs(tr - 2.0) <= 100 * TEST_EPS);
}

/* ---- failure atomicity and statuses -------------------------------------- */

typedef struct {
    dkf_real_t out[DKF__UIF_OUT_LEN(MAXN, MAXM, MAXP)];
    size_t len, k, rank, bias_steps;
    int bias_risk;
    unsigned char est[DKF_MAX_DIM];
} snap_t;

static void snap_take(snap_t *s, const dkf_uif_t *f)
{
    s->len = (size_t)(f->priv.mem - f->x.data);
    assert_true(s->len <= sizeof s->out / sizeof s->out[0]);
    memcpy(s->out, f->x.data, s->len * sizeof(dkf_real_t));
    s->k = f->k, s->rank = f->rank, s->bias_steps = f->bias_steps, s->bias_risk = f->bias_risk;
    memcpy(s->est, f->estimable, sizeof s->est);
}

static void snap_check(const snap_t *s, const dkf_uif_t *f)
{
    assert_memory_equal(s->out, f->x.data, s->len * sizeof(dkf_real_t));
    assert_int_equal(s->k, f->k);
    assert_int_equal(s->rank, f->rank);
    assert_int_equal(s->bias_steps, f->bias_steps);
    assert_int_equal(s->bias_risk, f->bias_risk);
    assert_memory_equal(s->est, f->estimable, sizeof s->est);
}

/* Every refused step leaves the filter bit-identical, and the filter then
 * continues exactly as if the bad call had never happened. */
static void test_uif_failure_atomicity(void **state)
{
    static box_t b, ctl;
    static snap_t snap, snap2;
    model_t s, bad;
    double y[5] = {0.3, -0.1, 0.2, 0.4, -0.3}, x0[5] = {0};
    dkf_real_t ys[5], Cb[25];
    dkf_mat_t Y, Yshort, mCb;
    dkf_ui_meas_t meas;
    size_t k, i;
    (void)state;
    test_to_real(ys, y, 5);
    Y = test_view(5, 1, ys);
    Yshort = test_view(4, 1, ys);
    paper_model(&s, 1);
    for (k = 0; k < 2; ++k) {
        const dkf_uif_kind_t kind = k == 0 ? DKF_UIF_NRTSF_DF : DKF_UIF_NRTSF;
        const int df = kind == DKF_UIF_NRTSF_DF;
        paper_model(&s, df);
        init_filter(&b, kind, 5, 3, 5, x0, 0.1);
        init_filter(&ctl, kind, 5, 3, 5, x0, 0.1);
        if (df) {
            assert_int_equal(dkf_uif_step(&b.f, NULL, &s.meas, &Y), DKF_OK);
            assert_int_equal(dkf_uif_step(&ctl.f, NULL, &s.meas, &Y), DKF_OK);
        }
        for (i = 0; i < 3; ++i) {
            assert_int_equal(dkf_uif_step(&b.f, &s.dyn, &s.meas, &Y), DKF_OK);
            assert_int_equal(dkf_uif_step(&ctl.f, &s.dyn, &s.meas, &Y), DKF_OK);
        }
        snap_take(&snap, &b.f);
        /* NaN in y, in A, in R */
        ys[2] = (dkf_real_t)NAN;
        assert_int_equal(dkf_uif_step(&b.f, &s.dyn, &s.meas, &Y), DKF_ERR_NONFINITE);
        snap_check(&snap, &b.f);
        ys[2] = (dkf_real_t)y[2];
        bad = s;
        model_views(&bad, df);
        bad.rA[7] = (dkf_real_t)INFINITY;
        assert_int_equal(dkf_uif_step(&b.f, &bad.dyn, &bad.meas, &Y), DKF_ERR_NONFINITE);
        snap_check(&snap, &b.f);
        /* overflow inside the step: A so large that P_{k|k-1} is infinite */
        model_views(&bad, df);
        for (i = 0; i < 25; ++i) bad.rA[i] = (dkf_real_t)(DKF_REAL_MAX / 4);
        assert_int_equal(dkf_uif_step(&b.f, &bad.dyn, &bad.meas, &Y), DKF_ERR_NONFINITE);
        snap_check(&snap, &b.f);
        /* R~ not SPD: R = -1 I */
        model_views(&bad, df);
        test_fill(bad.rR, 25, DKF_R(0.0));
        for (i = 0; i < 5; ++i) bad.rR[i * 6] = DKF_R(-1.0);
        assert_int_equal(dkf_uif_step(&b.f, &bad.dyn, &bad.meas, &Y), DKF_ERR_NOT_SPD);
        snap_check(&snap, &b.f);
        /* rank: NRTSF with C blind to x_1, so rank(C Gbar) = 1 < rank G = 2
         * (for NRTSF-DF the analogue is RTSF's rank test, in the vector
         * test) */
        if (!df) {
            model_views(&bad, df);
            memcpy(Cb, bad.rC, sizeof Cb);
            Cb[0] = DKF_R(0.0);
            mCb = test_view(5, 5, Cb);
            meas = bad.meas;
            meas.H = &mCb;
            assert_int_equal(dkf_uif_step(&b.f, &bad.dyn, &meas, &Y), DKF_ERR_RANK);
            snap_check(&snap, &b.f);
        }
        /* sequence and argument errors */
        assert_int_equal(dkf_uif_step(&b.f, NULL, &s.meas, &Y), DKF_ERR_STATE);
        snap_check(&snap, &b.f);
        assert_int_equal(dkf_uif_step(&b.f, &s.dyn, &s.meas, &Yshort), DKF_ERR_DIM);
        snap_check(&snap, &b.f);
        meas = s.meas;
        meas.D = df ? NULL : &s.mH;
        assert_int_equal(dkf_uif_step(&b.f, &s.dyn, &meas, &Y), df ? DKF_ERR_NULL : DKF_ERR_ARG);
        snap_check(&snap, &b.f);
        /* the failures changed nothing: both filters agree bit for bit */
        assert_int_equal(dkf_uif_step(&b.f, &s.dyn, &s.meas, &Y), DKF_OK);
        assert_int_equal(dkf_uif_step(&ctl.f, &s.dyn, &s.meas, &Y), DKF_OK);
        snap_take(&snap, &b.f);
        snap_take(&snap2, &ctl.f);
        assert_memory_equal(snap.out, snap2.out, snap.len * sizeof(dkf_real_t));
    }
}

/* A first feedthrough step must not have dynamics; init refuses bad
 * arguments. */
static void test_uif_init_and_sequence_errors(void **state)
{
    static box_t b;
    static dkf_real_t st[DKF_UIF_STORAGE_LEN(MAXN, MAXM, MAXP)];
    model_t s;
    dkf_real_t xs[5] = {0}, Ps[25] = {0}, ys[5] = {0};
    dkf_mat_t X = test_view(5, 1, xs), P = test_view(5, 5, Ps), Y = test_view(5, 1, ys);
    dkf_uif_t f;
    const size_t len = DKF_UIF_STORAGE_LEN(MAXN, MAXM, MAXP);
    (void)state;
    memset(&f, 0, sizeof f);
    paper_model(&s, 1);
    assert_int_equal(dkf_uif_init(&f, DKF_UIF_NRTSF_DF, 5, 5, 3, st, len, &X, &P), DKF_ERR_NOT_SPD);
    for (size_t i = 0; i < 5; ++i) Ps[i * 6] = 1;
    assert_int_equal(dkf_uif_init(&f, (dkf_uif_kind_t)7, 5, 5, 3, st, len, &X, &P), DKF_ERR_ARG);
    assert_int_equal(dkf_uif_init(&f, DKF_UIF_RTSF, 5, 3, 4, st, len, &X, &P), DKF_ERR_RANK);
    assert_int_equal(dkf_uif_init(&f, DKF_UIF_NRTSF_DF, 0, 5, 3, st, len, &X, &P),
                     DKF_ERR_CAPACITY);
    assert_int_equal(dkf_uif_init(&f, DKF_UIF_NRTSF_DF, 4, 5, 3, st, len, &X, &P), DKF_ERR_DIM);
    assert_int_equal(dkf_uif_init(&b.f, DKF_UIF_RTSF, 5, 5, 3, b.f_storage, len, &X, &P), DKF_OK);
    s.H[3 * 3] = 1.0;
    model_views(&s, 1);
    assert_int_equal(dkf_uif_step(&b.f, &s.dyn, &s.meas, &Y), DKF_ERR_STATE);
    assert_int_equal(b.f.k, 0);
    assert_int_equal(dkf_uif_step(&b.f, NULL, &s.meas, &Y), DKF_OK);
    assert_int_equal(b.f.k, 1);
    f.priv.ready = 0;
    assert_int_equal(dkf_uif_step(&f, NULL, &s.meas, &Y), DKF_ERR_STATE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_uif_storage_macro_is_exact),
        cmocka_unit_test(test_uif_nrtsf_df_equals_rtsf_full_rank),
        cmocka_unit_test(test_uif_nrtsf_df_rank_changes_match_reference),
        cmocka_unit_test(test_uif_unbiased_zero_noise),
        cmocka_unit_test(test_uif_bias_flag_paper_example),
        cmocka_unit_test(test_uif_bias_flag_not_raised),
        cmocka_unit_test(test_uif_partial_estimability),
        cmocka_unit_test(test_uif_failure_atomicity),
        cmocka_unit_test(test_uif_init_and_sequence_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
