/*
 * Linear Kalman filter (dkf/kf.h): golden vector, an independent reference
 * implementation, failure atomicity, and Monte-Carlo consistency.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/kf.h"
#include "dkf_test.h"

#define NMAX 12
#define MMAX 6

/* Golden-vector tolerance, relative to max(1, max|expected|) per array.
 * Double: the vectors are exact to ~1e-15 and the KF is a contraction, so
 * rounding does not accumulate: 1e-9 is the vectors' tolerance (we see ~1e-13).
 * Float: each step loses O(n cond(S)) eps with n = 4, cond(S) ~ 10; errors
 * stay bounded because the filter forgets (the closed loop is stable), so
 * 1e-5 ~ 84 eps ~ 2 n cond eps; we observe 1.0e-7. */
#if DKF_USE_FLOAT
#define VEC_REL 1e-5
#else
#define VEC_REL 1e-9
#endif

typedef struct {
    DKF_KF_DECLARE(, kf, NMAX, MMAX);
} kf_box_t;

static void compare_step(const char *what, const dkf_real_t *got, const json_t *list, size_t j)
{
    double e[NMAX * NMAX];
    size_t cnt = test_json_array(json_array_get(list, j), e, NMAX * NMAX, NULL, NULL);
    test_assert_close(what, got, e, cnt, VEC_REL);
}

/* seed 000 Example 1, "KF" baseline: a plain KF on (F, Q, H, R) that
 * ignores the unknown input A d. Step k predicts with F_{k-1}, Q_{k-1}
 * and updates with y_k, from (x_{0|0}, P_{0|0}). */
static void test_kf_matches_ex1_vector(void **state)
{
    static kf_box_t b;
    test_run_vector_t v;
    size_t j;
    dkf_real_t xs[NMAX], Ps[NMAX * NMAX], Fs[NMAX * NMAX], Qs[NMAX * NMAX], Hs[NMAX * NMAX],
        Rs[NMAX * NMAX], ys[NMAX];
    dkf_mat_t x0, P0, F, Q, H, R, y;
    (void)state;
    test_load_run_vector(&v, "diffkf/ex1_single.json", "KF");
    test_reset_worst_rel();
    test_json_mat(test_json_get(v.init, "x00"), xs, NMAX, &x0);
    test_json_mat(test_json_get(v.init, "P00"), Ps, NMAX * NMAX, &P0);
    assert_int_equal(dkf_kf_init(&b.kf, x0.rows, MMAX, b.kf_storage,
                                 DKF_KF_STORAGE_LEN(NMAX, MMAX), &x0, &P0),
                     DKF_OK);
    assert_true(v.N == 50);
    for (j = 0; j < v.N; ++j) {
        size_t k = j + 1;
        test_json_mat(test_json_model_at(v.model, "F", k - 1), Fs, NMAX * NMAX, &F);
        test_json_mat(test_json_model_at(v.model, "Q", k - 1), Qs, NMAX * NMAX, &Q);
        test_json_mat(test_json_model_at(v.model, "H", k), Hs, NMAX * NMAX, &H);
        test_json_mat(test_json_model_at(v.model, "R", k), Rs, NMAX * NMAX, &R);
        /* y lists y_1..y_{N+1}; entry j is y_{j+1} */
        test_json_mat(json_array_get(v.yv, j), ys, NMAX, &y);
        assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){&F, &Q}, NULL), DKF_OK);
        compare_step("KF xp", b.kf.x.data, test_json_get(v.out, "xp"), j);
        compare_step("KF Pp", b.kf.P.data, test_json_get(v.out, "Pp"), j);
        assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &y), DKF_OK);
        compare_step("KF xf", b.kf.x.data, test_json_get(v.out, "xf"), j);
        compare_step("KF Pf", b.kf.P.data, test_json_get(v.out, "Pf"), j);
    }
    json_decref(v.root);
    print_message("worst relative error %.3e\n", test_worst_rel());
}

/* ---- an independent double-precision reference ------------------------ */

/* Textbook KF step in double: x = F x; P = F P F^T + Q; K = P H^T S^{-1};
 * x += K (y - H x); P -= K H P. */
static void ref_kf_step(double *x, double *P, const double *F, const double *Q, const double *H,
                        const double *R, const double *y, size_t n, size_t m)
{
    double t[NMAX * NMAX], Ft[NMAX * NMAX], Ht[NMAX * MMAX], PHt[NMAX * MMAX], S[MMAX * MMAX],
        Si[MMAX * MMAX], K[NMAX * MMAX], HP[MMAX * NMAX], KHP[NMAX * NMAX], hx[MMAX], xn[NMAX];
    size_t i;
    test_ref_mul(xn, F, x, n, n, 1);
    memcpy(x, xn, n * sizeof *x);
    test_ref_transpose(Ft, F, n, n);
    test_ref_mul(t, F, P, n, n, n);
    test_ref_mul(P, t, Ft, n, n, n);
    for (i = 0; i < n * n; ++i) P[i] += Q[i];
    test_ref_transpose(Ht, H, m, n);
    test_ref_mul(PHt, P, Ht, n, n, m);
    test_ref_mul(S, H, PHt, m, n, m);
    for (i = 0; i < m * m; ++i) S[i] += R[i];
    test_ref_inverse_double(Si, S, m);
    test_ref_mul(K, PHt, Si, n, m, m);
    test_ref_mul(hx, H, x, m, n, 1);
    for (i = 0; i < m; ++i) hx[i] = y[i] - hx[i];
    test_ref_mul(xn, K, hx, n, m, 1);
    for (i = 0; i < n; ++i) x[i] += xn[i];
    test_ref_mul(HP, H, P, m, n, n);
    test_ref_mul(KHP, K, HP, n, m, n);
    for (i = 0; i < n * n; ++i) P[i] -= KHP[i];
}

/* Random time-varying model, varying measurement dimension: the filter
 * must agree with the textbook recursion, for n = 4, 6, 8, 12 and m = 1..6
 * (so every fixed-size step of the default DKF_KF_FIXED_SIZES, and the
 * generic one, is checked against an independent computation). Tolerance:
 * both compute the same quantities in different orders; the differences
 * are rounding only, O(n^2 eps cond) per step with cond(S) < 1e2, and do
 * not accumulate (stable filter): 1e-10 in double, 2e-5 in float
 * (cond * n * eps / 4 at n = 12; observed 1.1e-16 and 6.6e-7 at n = 6). */
static void test_kf_matches_reference_time_varying(void **state)
{
    static kf_box_t b;
    static const size_t sizes[4] = {4, 6, 8, 12};
    double x[NMAX], P[NMAX * NMAX], F[NMAX * NMAX], Q[NMAX * NMAX], H[MMAX * NMAX],
        R[MMAX * MMAX], y[MMAX];
    dkf_real_t xr[NMAX], Pr[NMAX * NMAX], Fr[NMAX * NMAX], Qr[NMAX * NMAX], Hr[MMAX * NMAX],
        Rr[MMAX * MMAX], yr[MMAX];
    test_rng_t rng;
    size_t c, k, i;
    const double rel = DKF_USE_FLOAT ? 2e-5 : 1e-10;
    (void)state;
    test_reset_worst_rel();
    test_rng_seed(&rng, 11);
    for (c = 0; c < 4; ++c) {
        const size_t n = sizes[c];
        dkf_mat_t X0 = DKF_MAT(n, 1, xr), P0 = DKF_MAT(n, n, Pr), Fm = DKF_MAT(n, n, Fr),
                  Qm = DKF_MAT(n, n, Qr), Hm, Rm, Ym;
        test_rand_gauss(&rng, x, n, 1);
        test_rand_spd(&rng, P, n, 10.0, 1.0);
        test_to_real(xr, x, n);
        test_to_real(Pr, P, n * n);
        assert_int_equal(dkf_kf_init(&b.kf, n, MMAX, b.kf_storage,
                                     DKF_KF_STORAGE_LEN(NMAX, MMAX), &X0, &P0),
                         DKF_OK);
        for (k = 0; k < 40; ++k) {
            size_t m = 1 + k % MMAX;
            /* F = 0.95 * orthogonal: bounded, but rotating differently each step */
            test_rand_orthogonal(&rng, F, n);
            for (i = 0; i < n * n; ++i) F[i] *= 0.95;
            test_rand_spd(&rng, Q, n, 5.0, 0.1);
            test_rand_gauss(&rng, H, m, n);
            test_rand_spd(&rng, R, m, 3.0, 0.5);
            test_rand_gauss(&rng, y, m, 1);
            test_to_real(Fr, F, n * n);
            test_to_real(Qr, Q, n * n);
            test_to_real(Hr, H, m * n);
            test_to_real(Rr, R, m * m);
            test_to_real(yr, y, m);
            Hm = (dkf_mat_t)DKF_MAT(m, n, Hr);
            Rm = (dkf_mat_t)DKF_MAT(m, m, Rr);
            Ym = (dkf_mat_t)DKF_MAT(m, 1, yr);
            ref_kf_step(x, P, F, Q, H, R, y, n, m);
            assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){&Fm, &Qm}, NULL), DKF_OK);
            assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&Hm, &Rm}, &Ym), DKF_OK);
            test_assert_close("x vs reference", b.kf.x.data, x, n, rel);
            test_assert_close("P vs reference", b.kf.P.data, P, n * n, rel);
            assert_int_equal(b.kf.nu.rows, m);
        }
    }
    print_message("worst relative error %.3e\n", test_worst_rel());
}

/* The innovation, its covariance and the NIS are exposed and correct:
 * checked against a direct computation on a 2-state example. */
static void test_kf_exposes_innovation(void **state)
{
    static kf_box_t b;
    dkf_real_t x0d[2] = {1, 2}, P0d[4] = {2, 0.5, 0.5, 1}, Hd[2] = {1, 1}, Rd[1] = {0.5},
               yd[1] = {4};
    dkf_mat_t x0 = DKF_MAT(2, 1, x0d), P0 = DKF_MAT(2, 2, P0d), H = DKF_MAT(1, 2, Hd),
              R = DKF_MAT(1, 1, Rd), y = DKF_MAT(1, 1, yd);
    (void)state;
    assert_int_equal(
        dkf_kf_init(&b.kf, 2, MMAX, b.kf_storage, DKF_KF_STORAGE_LEN(NMAX, MMAX), &x0, &P0),
        DKF_OK);
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &y), DKF_OK);
    /* nu = 4 - 3 = 1; S = 2 + 1 + 2*0.5 + 0.5 = 4.5; NIS = 1/4.5 */
    assert_int_equal(b.kf.nu.rows, 1);
    assert_true(fabs((double)b.kf.nu.data[0] - 1.0) < 10 * TEST_EPS);
    assert_true(fabs((double)b.kf.S.data[0] - 4.5) < 10 * TEST_EPS);
    assert_true(fabs((double)b.kf.nis - 1.0 / 4.5) < 10 * TEST_EPS);
    /* x+ = x + P H^T / S * nu = (1 + 2.5/4.5, 2 + 1.5/4.5) */
    assert_true(fabs((double)b.kf.x.data[0] - (1.0 + 2.5 / 4.5)) < 10 * TEST_EPS);
    assert_true(fabs((double)b.kf.x.data[1] - (2.0 + 1.5 / 4.5)) < 10 * TEST_EPS);
}

/* ---- failure atomicity --------------------------------------------------- */

typedef struct {
    dkf_kf_t kf;
    dkf_real_t state[NMAX + NMAX * NMAX + MMAX + MMAX * MMAX];
} kf_snapshot_t;

/* x, P, nu, S are contiguous at the start of the storage. */
static void snapshot(kf_snapshot_t *s, const dkf_kf_t *kf)
{
    s->kf = *kf;
    memcpy(s->state, kf->x.data,
           (kf->n + kf->n * kf->n + kf->m_max + kf->m_max * kf->m_max) * sizeof(dkf_real_t));
}

static void assert_unchanged(const kf_snapshot_t *s, const dkf_kf_t *kf)
{
    assert_memory_equal(&s->kf, kf, sizeof *kf);
    assert_memory_equal(s->state, kf->x.data,
                        (kf->n + kf->n * kf->n + kf->m_max + kf->m_max * kf->m_max) *
                            sizeof(dkf_real_t));
}

static void test_kf_failed_steps_leave_state_bit_identical(void **state)
{
    static kf_box_t b;
    static kf_snapshot_t snap;
    dkf_real_t x0d[2] = {1, 2}, P0d[4] = {2, 0.5, 0.5, 1}, Fd[4] = {1, 1, 0, 1},
               Qd[4] = {0.1, 0, 0, 0.1}, Hd[2] = {1, 0}, Rd[1] = {0.5}, yd[1] = {1.5};
    dkf_real_t H2d[4] = {1, 0, 0, 1}, R2d[4] = {1, 0, 0, 1}, y2d[2] = {0, 0};
    dkf_real_t Rneg[1] = {-100}, bad[4];
    dkf_mat_t x0 = DKF_MAT(2, 1, x0d), P0 = DKF_MAT(2, 2, P0d), F = DKF_MAT(2, 2, Fd),
              Q = DKF_MAT(2, 2, Qd), H = DKF_MAT(1, 2, Hd), R = DKF_MAT(1, 1, Rd),
              y = DKF_MAT(1, 1, yd), H2 = DKF_MAT(2, 2, H2d), R2 = DKF_MAT(2, 2, R2d),
              y2 = DKF_MAT(2, 1, y2d), Rn = DKF_MAT(1, 1, Rneg), B;
    (void)state;
    /* a small filter: m_max = 1 so a 2-dim measurement exceeds capacity */
    assert_int_equal(dkf_kf_init(&b.kf, 2, 1, b.kf_storage, DKF_KF_STORAGE_LEN(2, 1), &x0, &P0),
                     DKF_OK);
    assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){&F, &Q}, NULL), DKF_OK);
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &y), DKF_OK);
    snapshot(&snap, &b.kf);

    /* non-finite measurement */
    yd[0] = (dkf_real_t)NAN;
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &y), DKF_ERR_NONFINITE);
    assert_unchanged(&snap, &b.kf);
    yd[0] = (dkf_real_t)INFINITY;
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &y), DKF_ERR_NONFINITE);
    assert_unchanged(&snap, &b.kf);
    yd[0] = 1.5;
    /* S = H P H^T + R not SPD */
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &Rn}, &y), DKF_ERR_NOT_SPD);
    assert_unchanged(&snap, &b.kf);
    /* measurement larger than the capacity */
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H2, &R2}, &y2), DKF_ERR_CAPACITY);
    assert_unchanged(&snap, &b.kf);
    /* dimension mismatch: y 2x1 for H 1x2 */
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &y2), DKF_ERR_DIM);
    assert_unchanged(&snap, &b.kf);
    /* non-finite and wrongly shaped model in the time update */
    memcpy(bad, Fd, sizeof bad);
    bad[1] = (dkf_real_t)NAN;
    B = (dkf_mat_t)DKF_MAT(2, 2, bad);
    assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){&B, &Q}, NULL), DKF_ERR_NONFINITE);
    assert_unchanged(&snap, &b.kf);
    assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){&F, &H}, NULL), DKF_ERR_DIM);
    assert_unchanged(&snap, &b.kf);
    /* overflow inside the step: F with huge entries makes P infinite */
    bad[0] = bad[3] = (dkf_real_t)(4.0 * sqrt((double)DKF_REAL_MAX));
    bad[1] = bad[2] = 0;
    assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){&B, &Q}, NULL), DKF_ERR_NONFINITE);
    assert_unchanged(&snap, &b.kf);
    /* NULL arguments */
    assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){NULL, &Q}, NULL), DKF_ERR_NULL);
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, NULL}, &y), DKF_ERR_NULL);
    assert_unchanged(&snap, &b.kf);
    /* and the filter still works afterwards */
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &y), DKF_OK);
}

/* Every entry of every model input, set to NaN, +Inf or -Inf in turn, must
 * give DKF_ERR_NONFINITE and leave the state bit-identical. The step scans
 * Q and R on the way in but finds a non-finite F, u, H or y through what it
 * does to the results (src/kf.c explains why that is exact), so this runs
 * on sizes of the fixed-size steps (4/2, 8/4) and of the generic one (3/2,
 * 5/1), from a regular P and from P = 0, the case where Inf * P(k,l) is
 * Inf * 0 = NaN rather than Inf. */
static void inject_each(kf_box_t *b, dkf_real_t *v, size_t len, int update, const dkf_mat_t *M1,
                        const dkf_mat_t *M2, const dkf_mat_t *M3)
{
    static const double bad[3] = {NAN, INFINITY, -INFINITY};
    static kf_snapshot_t snap;
    size_t i, t;
    snapshot(&snap, &b->kf);
    for (i = 0; i < len; ++i) {
        const dkf_real_t keep = v[i];
        for (t = 0; t < 3; ++t) {
            v[i] = (dkf_real_t)bad[t];
            assert_int_equal(update ? dkf_kf_update(&b->kf, &(dkf_kf_meas_t){M1, M2}, M3)
                                    : dkf_kf_predict(&b->kf, &(dkf_kf_dyn_t){M1, M2}, M3),
                             DKF_ERR_NONFINITE);
            assert_unchanged(&snap, &b->kf);
        }
        v[i] = keep;
    }
}

static void test_kf_nonfinite_inputs_anywhere(void **state)
{
    static const size_t sizes[4][2] = {{4, 2}, {8, 4}, {3, 2}, {5, 1}};
    static kf_box_t b;
    dkf_real_t x0d[NMAX], P0d[NMAX * NMAX], Fd[NMAX * NMAX], Qd[NMAX * NMAX], ud[NMAX],
        Hd[MMAX * NMAX], Rd[MMAX * MMAX], yd[MMAX], Zd[NMAX * NMAX];
    double tmp[NMAX * NMAX];
    test_rng_t rng;
    size_t c, zero, i;
    (void)state;
    test_rng_seed(&rng, 77);
    for (c = 0; c < 4; ++c) {
        const size_t n = sizes[c][0], m = sizes[c][1];
        dkf_mat_t x0 = DKF_MAT(n, 1, x0d), P0 = DKF_MAT(n, n, P0d), F = DKF_MAT(n, n, Fd),
                  Q = DKF_MAT(n, n, Qd), u = DKF_MAT(n, 1, ud), H = DKF_MAT(m, n, Hd),
                  R = DKF_MAT(m, m, Rd), y = DKF_MAT(m, 1, yd), Z = DKF_MAT(n, n, Zd);
        for (zero = 0; zero < 2; ++zero) {
            test_rand_gauss(&rng, tmp, n, 1);
            for (i = 0; i < n; ++i) x0d[i] = (dkf_real_t)tmp[i], ud[i] = (dkf_real_t)tmp[i];
            test_rand_spd(&rng, tmp, n, 10.0, 1.0);
            for (i = 0; i < n * n; ++i) P0d[i] = Qd[i] = (dkf_real_t)tmp[i], Zd[i] = 0;
            test_rand_gauss(&rng, tmp, n, n);
            for (i = 0; i < n * n; ++i) Fd[i] = (dkf_real_t)(0.5 * tmp[i]);
            test_rand_gauss(&rng, tmp, m, n);
            for (i = 0; i < m * n; ++i) Hd[i] = (dkf_real_t)tmp[i];
            test_rand_spd(&rng, tmp, m, 10.0, 1.0);
            for (i = 0; i < m * m; ++i) Rd[i] = (dkf_real_t)tmp[i];
            test_rand_gauss(&rng, tmp, m, 1);
            for (i = 0; i < m; ++i) yd[i] = (dkf_real_t)tmp[i];
            assert_int_equal(dkf_kf_init(&b.kf, n, MMAX, b.kf_storage,
                                         DKF_KF_STORAGE_LEN(NMAX, MMAX), &x0, &P0),
                             DKF_OK);
            if (zero) { /* F = 0, Q = 0: x = 0 and P = 0 exactly */
                assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){&Z, &Z}, NULL), DKF_OK);
                for (i = 0; i < n * n; ++i) assert_true(b.kf.P.data[i] == 0);
            }
            inject_each(&b, Fd, n * n, 0, &F, &Q, &u);
            inject_each(&b, Qd, n * n, 0, &F, &Q, &u);
            inject_each(&b, ud, n, 0, &F, &Q, &u);
            inject_each(&b, Hd, m * n, 1, &H, &R, &y);
            inject_each(&b, Rd, m * m, 1, &H, &R, &y);
            inject_each(&b, yd, m, 1, &H, &R, &y);
            /* the clean inputs still work */
            assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){&F, &Q}, &u), DKF_OK);
            assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &y), DKF_OK);
        }
    }
}

static void test_kf_init_errors(void **state)
{
    static kf_box_t b;
    static dkf_kf_t before;
    dkf_real_t x0d[2] = {0, 0}, Pind[4] = {1, 2, 2, 1}, Psemi[4] = {1, 1, 1, 1},
               Pok[4] = {1, 0, 0, 1};
    dkf_mat_t x0 = DKF_MAT(2, 1, x0d), Pi = DKF_MAT(2, 2, Pind), Ps = DKF_MAT(2, 2, Psemi),
              P = DKF_MAT(2, 2, Pok);
    dkf_mat_t H = DKF_MAT(1, 2, x0d), R = DKF_MAT(1, 1, x0d);
    (void)state;
    memset(&b.kf, 0, sizeof b.kf);
    before = b.kf;
    /* calling a step before init */
    assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &x0), DKF_ERR_STATE);
    assert_int_equal(dkf_kf_init(&b.kf, 2, 1, b.kf_storage, DKF_KF_STORAGE_LEN(2, 1) - 1, &x0,
                                 &P),
                     DKF_ERR_CAPACITY);
    assert_int_equal(dkf_kf_init(&b.kf, DKF_MAX_DIM + 1, 1, b.kf_storage, 1u << 30, &x0, &P),
                     DKF_ERR_CAPACITY);
    assert_int_equal(
        dkf_kf_init(&b.kf, 2, 1, b.kf_storage, DKF_KF_STORAGE_LEN(2, 1), &x0, &Pi),
        DKF_ERR_NOT_SPD);
    assert_int_equal(
        dkf_kf_init(&b.kf, 2, 1, b.kf_storage, DKF_KF_STORAGE_LEN(2, 1), &x0, &Ps),
        DKF_ERR_NOT_SPD);
    assert_int_equal(
        dkf_kf_init(&b.kf, 3, 1, b.kf_storage, DKF_KF_STORAGE_LEN(3, 1), &x0, &P),
        DKF_ERR_DIM);
    assert_memory_equal(&before, &b.kf, sizeof before);
}

/* ---- Monte-Carlo consistency ------------------------------------------- */

/* 300 runs (fixed seed) of a 4-state constant-velocity model with 2
 * position sensors, 60 steps each. For a consistent filter the NEES
 * e^T P^{-1} e at each step is chi-square with n = 4 degrees of freedom, so
 * its 300-run mean has mean 4 and standard deviation sqrt(2*4/300) = 0.163;
 * the mean over all 60 x 300 values has sd about 0.02 (correlated in time:
 * we allow 0.25). The NIS (m = 2) likewise. A filter with P scaled by 2 or
 * missing Q fails these bounds by a wide margin. */
static void test_kf_monte_carlo_nees(void **state)
{
    static kf_box_t b;
    const size_t n = 4, m = 2, runs = 300, steps = 60;
    const double q = 0.05, r = 0.5;
    double Fd[16] = {1, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1};
    double Qd[16] = {q / 3, q / 2, 0, 0, q / 2, q, 0, 0, 0, 0, q / 3, q / 2, 0, 0, q / 2, q};
    double Hd[8] = {1, 0, 0, 0, 0, 0, 1, 0};
    double Rd[4] = {r, 0, 0, r};
    double P0d[16] = {4, 0, 0, 0, 0, 1, 0, 0, 0, 0, 4, 0, 0, 0, 0, 1};
    double Lq[16] = {0}, xt[4], nees_sum = 0.0, nis_sum = 0.0;
    dkf_real_t Fr[16], Qr[16], Hr[8], Rr[4], P0r[16], x0r[4], yr[2];
    dkf_mat_t F = DKF_MAT(4, 4, Fr), Q = DKF_MAT(4, 4, Qr), H = DKF_MAT(2, 4, Hr),
              R = DKF_MAT(2, 2, Rr), P0 = DKF_MAT(4, 4, P0r), x0 = DKF_MAT(4, 1, x0r),
              y = DKF_MAT(2, 1, yr);
    test_rng_t rng;
    size_t run, k, i, j;
    (void)state;
    test_to_real(Fr, Fd, 16);
    test_to_real(Qr, Qd, 16);
    test_to_real(Hr, Hd, 8);
    test_to_real(Rr, Rd, 4);
    test_to_real(P0r, P0d, 16);
    /* Cholesky of Q (2x2 blocks) for sampling the process noise */
    Lq[0] = sqrt(q / 3);
    Lq[4] = (q / 2) / Lq[0];
    Lq[5] = sqrt(q - Lq[4] * Lq[4]);
    Lq[10] = Lq[0];
    Lq[14] = Lq[4];
    Lq[15] = Lq[5];
    test_rng_seed(&rng, 2026);
    for (run = 0; run < runs; ++run) {
        double w[4];
        /* truth x0 ~ N(0, P0); the filter starts at 0 */
        xt[0] = 2 * test_rng_normal(&rng);
        xt[1] = test_rng_normal(&rng);
        xt[2] = 2 * test_rng_normal(&rng);
        xt[3] = test_rng_normal(&rng);
        for (i = 0; i < 4; ++i) x0r[i] = 0;
        assert_int_equal(dkf_kf_init(&b.kf, n, MMAX, b.kf_storage, DKF_KF_STORAGE_LEN(NMAX, MMAX),
                                     &x0, &P0),
                         DKF_OK);
        for (k = 0; k < steps; ++k) {
            double xn[4], e[4], Pinv_e[4];
            double Pd[16], Pi[16];
            test_ref_mul(xn, Fd, xt, 4, 4, 1);
            test_rand_gauss(&rng, w, 4, 1);
            for (i = 0; i < 4; ++i) {
                double acc = 0;
                for (j = 0; j < 4; ++j) acc += Lq[i * 4 + j] * w[j];
                xt[i] = xn[i] + acc;
            }
            yr[0] = (dkf_real_t)(xt[0] + sqrt(r) * test_rng_normal(&rng));
            yr[1] = (dkf_real_t)(xt[2] + sqrt(r) * test_rng_normal(&rng));
            assert_int_equal(dkf_kf_predict(&b.kf, &(dkf_kf_dyn_t){&F, &Q}, NULL), DKF_OK);
            assert_int_equal(dkf_kf_update(&b.kf, &(dkf_kf_meas_t){&H, &R}, &y), DKF_OK);
            nis_sum += (double)b.kf.nis;
            for (i = 0; i < 4; ++i) e[i] = xt[i] - (double)b.kf.x.data[i];
            test_to_double(Pd, b.kf.P.data, 16);
            /* P^{-1} e by the 4x4 Gauss-Jordan of the reference (MMAX = 4) */
            test_ref_inverse_double(Pi, Pd, 4);
            test_ref_mul(Pinv_e, Pi, e, 4, 4, 1);
            for (i = 0; i < 4; ++i) nees_sum += e[i] * Pinv_e[i];
        }
    }
    {
        double nees = nees_sum / (double)(runs * steps), nis = nis_sum / (double)(runs * steps);
        print_message("mean NEES %.3f (expect %zu), mean NIS %.3f (expect %zu)\n", nees, n, nis,
                      m);
        assert_true(fabs(nees - (double)n) < 0.25);
        assert_true(fabs(nis - (double)m) < 0.15);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kf_matches_ex1_vector),
        cmocka_unit_test(test_kf_matches_reference_time_varying),
        cmocka_unit_test(test_kf_exposes_innovation),
        cmocka_unit_test(test_kf_failed_steps_leave_state_bit_identical),
        cmocka_unit_test(test_kf_nonfinite_inputs_anywhere),
        cmocka_unit_test(test_kf_init_errors),
        cmocka_unit_test(test_kf_monte_carlo_nees),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
