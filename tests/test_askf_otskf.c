/*
 * ASKF (dkf/askf.h) and OTSKF (dkf/otskf.h), the baselines of seed 000:
 * golden vectors of Example 1, OTSKF == ASKF on random fully time-varying
 * models (with missing and repeated measurements), failure atomicity.
 */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/askf.h"
#include "dkf/otskf.h"
#include "dkf_test.h"

#define NMAX 6
#define MMAX 5
#define PMAX 3
#define CAP ((NMAX + PMAX) * (NMAX + PMAX))

/* Golden-vector tolerance, relative to max(1, max|expected|) per array.
 * Double: the vectors' tolerance 1e-9 (the vectors equal a batch LMMSE to 1.6e-11;
 * both filters are contractions, so rounding does not accumulate; we see
 * ~1e-14). Float: one step loses about (n + p) cond(S) eps with n + p = 6
 * and cond(S) <= 10 (S = H P H^T + R, R = I), i.e. ~60 eps ~ 7e-6, and the
 * stable closed loop forgets old errors; x reaches ~300, so the absolute
 * error of x is eps * 300 per rounding and the ratio to max(1, |x|) stays
 * O(eps). 1e-5 ~ 84 eps (we observe 3e-7 for the ASKF, 1e-6 = 8 eps
 * for the OTSKF, whose U, V blend adds a few roundings). */
#if DKF_USE_FLOAT
#define VEC_REL 1e-5
#else
#define VEC_REL 1e-9
#endif

/* OTSKF against ASKF on random models: the same estimator computed by two
 * different factorisations, so the difference is rounding only. Double:
 * the vectors' tolerance 1e-9. Float: the random models have cond(Sx), cond(P^d) up
 * to ~1e2 (SPD factors of condition 10, B with singular values in
 * [0.5, 1.2], F in [0.5, 1.05]), n + p <= 9; one step's relative error is
 * then up to ~ (n + p) cond eps ~ 1e3 eps, and a stable filter forgets
 * older errors instead of accumulating them: 1e-4 ~ 840 eps (we observe
 * ~40 eps, printed). */
#if DKF_USE_FLOAT
#define EQ_REL 1e-4
#else
#define EQ_REL 1e-9
#endif

typedef struct {
    DKF_ASKF_DECLARE(, a, NMAX, MMAX, PMAX);
} askf_box_t;

typedef struct {
    DKF_OTSKF_DECLARE(, o, NMAX, MMAX, PMAX);
} otskf_box_t;

static void compare(const char *what, const dkf_real_t *got, size_t cnt_got, const json_t *out,
                    const char *key, size_t j)
{
    double e[CAP];
    size_t cnt = test_json_array(json_array_get(test_json_get(out, key), j), e, CAP, NULL, NULL);
    assert_int_equal(cnt, cnt_got);
    test_assert_close(what, got, e, cnt, VEC_REL);
}

typedef struct {
    test_run_vector_t v; /* root, model, init, yv, N, out */
    dkf_real_t x0[NMAX], P0[CAP], d0[PMAX], Pd0[CAP];
    dkf_mat_t mx0, mP0, md0, mPd0;
} ex1_t;

/* ex1_single.json's run of `filter` and its prior. */
static void ex1_load(ex1_t *e, const char *filter)
{
    const json_t *init;
    test_load_run_vector(&e->v, "diffkf/ex1_single.json", filter);
    init = e->v.init;
    assert_true(e->v.N == 50);
    test_json_mat(test_json_get(init, "x00"), e->x0, NMAX, &e->mx0);
    test_json_mat(test_json_get(init, "P00"), e->P0, CAP, &e->mP0);
    test_json_mat(test_json_get(init, "d00"), e->d0, PMAX, &e->md0);
    test_json_mat(test_json_get(init, "Pd00"), e->Pd0, CAP, &e->mPd0);
}

/* seed 000 Example 1, ASKF with d00 = (5,5): step k predicts with the
 * dynamics at k-1 and updates with y_k, from (x_{0|0}, P_{0|0}). */
static void test_askf_matches_ex1_vector(void **state)
{
    static askf_box_t b;
    static test_ui_step_t md;
    ex1_t e;
    const json_t *out;
    dkf_real_t Px[CAP];
    dkf_mat_t x, mPx;
    size_t j, n, m, p, N;
    (void)state;
    ex1_load(&e, "ASKF");
    out = e.v.out;
    test_reset_worst_rel();
    test_ui_model_at(&md, e.v.model, e.v.model, 0);
    n = md.Fm.rows, m = md.Hm.rows, p = md.Bm.rows, N = n + p;
    mPx = test_view(n, n, Px);
    assert_int_equal(dkf_askf_init(&b.a, n, m, p, b.a_storage, DKF_ASKF_STORAGE_LEN(NMAX, MMAX, PMAX),
                                   &e.mx0, &e.mP0, &e.md0, &e.mPd0, NULL),
                     DKF_OK);
    for (j = 0; j < e.v.N; ++j) {
        const size_t k = j + 1;
        test_ui_model_at(&md, e.v.model, e.v.model, k - 1);
        assert_int_equal(dkf_askf_predict(&b.a, &md.dyn), DKF_OK);
        assert_int_equal(dkf_askf_state(&b.a, &x, &mPx), DKF_OK);
        compare("ASKF Xp", b.a.kf.x.data, N, out, "Xp", j);
        compare("ASKF PXp", b.a.kf.P.data, N * N, out, "PXp", j);
        compare("ASKF xp", x.data, n, out, "xp", j);
        compare("ASKF Pp", Px, n * n, out, "Pp", j);
        test_ui_model_at(&md, e.v.model, e.v.model, k);
        test_json_mat(json_array_get(e.v.yv, j), md.y, MMAX, &md.ym); /* y_k */
        assert_int_equal(dkf_askf_update(&b.a, &md.meas, &md.ym), DKF_OK);
        assert_int_equal(dkf_askf_state(&b.a, &x, &mPx), DKF_OK);
        compare("ASKF Xf", b.a.kf.x.data, N, out, "Xf", j);
        compare("ASKF PXf", b.a.kf.P.data, N * N, out, "PXf", j);
        compare("ASKF xf", x.data, n, out, "xf", j);
        compare("ASKF Pf", Px, n * n, out, "Pf", j);
    }
    print_message("ASKF ex1: worst relative error %.3e\n", test_worst_rel());
    json_decref(e.v.root);
}

/* The same with the OTSKF, every intermediate of docs/design/derivation-seed000.md §5 included. */
static void test_otskf_matches_ex1_vector(void **state)
{
    static otskf_box_t b;
    static test_ui_step_t md;
    ex1_t e;
    const json_t *out;
    size_t j, n, m, p;
    (void)state;
    ex1_load(&e, "OTSKF");
    out = e.v.out;
    test_reset_worst_rel();
    test_ui_model_at(&md, e.v.model, e.v.model, 0);
    n = md.Fm.rows, m = md.Hm.rows, p = md.Bm.rows;
    assert_int_equal(dkf_otskf_init(&b.o, n, m, p, b.o_storage,
                                    DKF_OTSKF_STORAGE_LEN(NMAX, MMAX, PMAX), &e.mx0, &e.mP0,
                                    &e.md0, &e.mPd0),
                     DKF_OK);
    for (j = 0; j < e.v.N; ++j) {
        const size_t k = j + 1;
        test_ui_model_at(&md, e.v.model, e.v.model, k - 1);
        assert_int_equal(dkf_otskf_predict(&b.o, &md.dyn), DKF_OK);
        compare("OTSKF xtp", b.o.xt.data, n, out, "xtp", j);
        compare("OTSKF Pxp", b.o.Px.data, n * n, out, "Pxp", j);
        compare("OTSKF dp", b.o.d.data, p, out, "dp", j);
        compare("OTSKF Pdp", b.o.Pd.data, p * p, out, "Pdp", j);
        compare("OTSKF U", b.o.U.data, n * p, out, "U", j);
        compare("OTSKF xp", b.o.x.data, n, out, "xp", j);
        compare("OTSKF Pp", b.o.P.data, n * n, out, "Pp", j);
        test_ui_model_at(&md, e.v.model, e.v.model, k);
        test_json_mat(json_array_get(e.v.yv, j), md.y, MMAX, &md.ym); /* y_k */
        assert_int_equal(dkf_otskf_update(&b.o, &md.meas, &md.ym), DKF_OK);
        compare("OTSKF xtf", b.o.xt.data, n, out, "xtf", j);
        compare("OTSKF Pxf", b.o.Px.data, n * n, out, "Pxf", j);
        compare("OTSKF df", b.o.d.data, p, out, "df", j);
        compare("OTSKF Pdf", b.o.Pd.data, p * p, out, "Pdf", j);
        compare("OTSKF V", b.o.V.data, n * p, out, "V", j);
        compare("OTSKF xf", b.o.x.data, n, out, "xf", j);
        compare("OTSKF Pf", b.o.P.data, n * n, out, "Pf", j);
    }
    print_message("OTSKF ex1: worst relative error %.3e\n", test_worst_rel());
    json_decref(e.v.root);
}

/* ---- random fully time-varying models ----------------------------------- */

static double uniform(test_rng_t *r, double lo, double hi)
{
    return lo + (hi - lo) * test_rng_uniform(r);
}

/* A fresh random model of dimensions (n, m, p): every matrix changes at
 * every call. F and B have singular values in [0.5, 1.05] and [0.5, 1.2]
 * (B nonsingular, d mildly unstable at times), A full column rank. */
static void random_model(test_rng_t *r, test_ui_step_t *s, size_t n, size_t m, size_t p)
{
    double t[CAP], sv[NMAX];
    size_t i;
    for (i = 0; i < n; ++i) sv[i] = uniform(r, 0.5, 1.05);
    test_mat_with_singular_values(r, t, n, n, sv);
    test_to_real(s->F, t, n * n);
    test_rand_spd(r, t, n, 10.0, uniform(r, 0.1, 1.0));
    test_to_real(s->Q, t, n * n);
    for (i = 0; i < p; ++i) sv[i] = uniform(r, 0.5, 1.2);
    test_mat_with_singular_values(r, t, p, p, sv);
    test_to_real(s->B, t, p * p);
    test_rand_spd(r, t, p, 10.0, uniform(r, 0.1, 1.0));
    test_to_real(s->Rd, t, p * p);
    test_rand_gauss(r, t, m, n);
    test_to_real(s->H, t, m * n);
    for (i = 0; i < p; ++i) sv[i] = uniform(r, 0.5, 2.0);
    test_mat_with_singular_values(r, t, m, p, sv);
    test_to_real(s->A, t, m * p);
    test_rand_spd(r, t, m, 10.0, uniform(r, 0.2, 2.0));
    test_to_real(s->R, t, m * m);
    /* both filters are linear in y: any data exercise them alike */
    test_rand_gauss(r, t, m, 1);
    for (i = 0; i < m; ++i) t[i] *= 5.0;
    test_to_real(s->y, t, m);
    s->Fm = test_view(n, n, s->F);
    s->Qm = test_view(n, n, s->Q);
    s->Bm = test_view(p, p, s->B);
    s->Rdm = test_view(p, p, s->Rd);
    s->Hm = test_view(m, n, s->H);
    s->Am = test_view(m, p, s->A);
    s->Rm = test_view(m, m, s->R);
    s->ym = test_view(m, 1, s->y);
    test_ui_bind(s);
}

/* Asserts the OTSKF's x, P, d, P^d equal the ASKF's blocks. */
static void compare_otskf_askf(const char *what, const dkf_otskf_t *o, const dkf_askf_t *a)
{
    const size_t n = o->n, p = o->p;
    double ax[NMAX], aP[NMAX * NMAX], ad[PMAX], aPd[PMAX * PMAX];
    dkf_real_t Px[NMAX * NMAX], Pd[PMAX * PMAX];
    dkf_mat_t x, d, mPx = test_view(n, n, Px), mPd = test_view(p, p, Pd);
    char buf[64];
    assert_int_equal(dkf_askf_state(a, &x, &mPx), DKF_OK);
    assert_int_equal(dkf_askf_input(a, &d, &mPd), DKF_OK);
    test_to_double(ax, x.data, n);
    test_to_double(aP, Px, n * n);
    test_to_double(ad, d.data, p);
    test_to_double(aPd, Pd, p * p);
    snprintf(buf, sizeof buf, "%s x", what);
    test_assert_close(buf, o->x.data, ax, n, EQ_REL);
    snprintf(buf, sizeof buf, "%s P", what);
    test_assert_close(buf, o->P.data, aP, n * n, EQ_REL);
    snprintf(buf, sizeof buf, "%s d", what);
    test_assert_close(buf, o->d.data, ad, p, EQ_REL);
    snprintf(buf, sizeof buf, "%s Pd", what);
    test_assert_close(buf, o->Pd.data, aPd, p * p, EQ_REL);
}

/* OTSKF == ASKF on random models where every matrix changes at every
 * step, dimensions including n < p, p = m and scalars. Every 7th time has
 * no measurement (predict twice in a row) and every 5th has a second,
 * independent measurement at the same time (update twice): both exercise
 * the blending matrix of the last call. */
static void test_otskf_equals_askf_random(void **state)
{
    static const size_t dims[][3] = {{4, 2, 2}, {5, 3, 2}, {3, 4, 1}, {6, 5, 3},
                                     {2, 3, 3}, {1, 1, 1}, {4, 5, 2}};
    static askf_box_t ab;
    static otskf_box_t ob;
    static test_ui_step_t md;
    test_rng_t r;
    size_t c, k;
    (void)state;
    test_rng_seed(&r, 0x0A5CF0u);
    test_reset_worst_rel();
    for (c = 0; c < sizeof dims / sizeof dims[0]; ++c) {
        const size_t n = dims[c][0], m = dims[c][1], p = dims[c][2];
        double t[CAP];
        dkf_real_t x0[NMAX], P0[CAP], d0[PMAX], Pd0[CAP];
        dkf_mat_t mx0 = test_view(n, 1, x0), mP0 = test_view(n, n, P0),
                  md0 = test_view(p, 1, d0), mPd0 = test_view(p, p, Pd0);
        test_rand_gauss(&r, t, n, 1);
        test_to_real(x0, t, n);
        test_rand_spd(&r, t, n, 10.0, 2.0);
        test_to_real(P0, t, n * n);
        test_rand_gauss(&r, t, p, 1);
        test_to_real(d0, t, p);
        test_rand_spd(&r, t, p, 10.0, 2.0);
        test_to_real(Pd0, t, p * p);
        assert_int_equal(dkf_askf_init(&ab.a, n, m, p, ab.a_storage,
                                       DKF_ASKF_STORAGE_LEN(NMAX, MMAX, PMAX), &mx0, &mP0, &md0,
                                       &mPd0, NULL),
                         DKF_OK);
        assert_int_equal(dkf_otskf_init(&ob.o, n, m, p, ob.o_storage,
                                        DKF_OTSKF_STORAGE_LEN(NMAX, MMAX, PMAX), &mx0, &mP0,
                                        &md0, &mPd0),
                         DKF_OK);
        compare_otskf_askf("init", &ob.o, &ab.a);
        for (k = 1; k <= 40; ++k) {
            random_model(&r, &md, n, m, p);
            assert_int_equal(dkf_askf_predict(&ab.a, &md.dyn), DKF_OK);
            assert_int_equal(dkf_otskf_predict(&ob.o, &md.dyn), DKF_OK);
            compare_otskf_askf("predict", &ob.o, &ab.a);
            if (k % 7 == 3) continue; /* no measurement at k */
            assert_int_equal(dkf_askf_update(&ab.a, &md.meas, &md.ym), DKF_OK);
            assert_int_equal(dkf_otskf_update(&ob.o, &md.meas, &md.ym), DKF_OK);
            compare_otskf_askf("update", &ob.o, &ab.a);
            if (k % 5 == 2) {
                random_model(&r, &md, n, m, p); /* a second sensor at k */
                assert_int_equal(dkf_askf_update(&ab.a, &md.meas, &md.ym), DKF_OK);
                assert_int_equal(dkf_otskf_update(&ob.o, &md.meas, &md.ym), DKF_OK);
                compare_otskf_askf("second update", &ob.o, &ab.a);
            }
        }
    }
    print_message("OTSKF vs ASKF: worst relative difference %.3e\n", test_worst_rel());
}

/* ---- failure atomicity --------------------------------------------------- */

/* A small fixed model (n, m, p) = (3, 2, 2) for the failure tests. */
static void fixed_model(test_ui_step_t *s)
{
    static const dkf_real_t F[] = {DKF_R(1.0), DKF_R(0.5), DKF_R(0.0), DKF_R(0.0), DKF_R(1.0),
                                   DKF_R(0.2), DKF_R(0.1), DKF_R(0.0), DKF_R(0.9)};
    static const dkf_real_t Q[] = {DKF_R(0.5), DKF_R(0.1), DKF_R(0.0), DKF_R(0.1), DKF_R(0.4),
                                   DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(0.3)};
    static const dkf_real_t B[] = {DKF_R(0.9), DKF_R(0.1), DKF_R(0.0), DKF_R(0.8)};
    static const dkf_real_t Rd[] = {DKF_R(1.0), DKF_R(0.2), DKF_R(0.2), DKF_R(0.5)};
    static const dkf_real_t H[] = {DKF_R(1.0), DKF_R(0.0), DKF_R(0.5),
                                   DKF_R(0.0), DKF_R(1.0), DKF_R(-0.3)};
    static const dkf_real_t A[] = {DKF_R(1.0), DKF_R(0.3), DKF_R(-0.2), DKF_R(1.0)};
    static const dkf_real_t R[] = {DKF_R(1.0), DKF_R(0.1), DKF_R(0.1), DKF_R(2.0)};
    static const dkf_real_t y[] = {DKF_R(3.0), DKF_R(-1.5)};
    memcpy(s->F, F, sizeof F);
    memcpy(s->Q, Q, sizeof Q);
    memcpy(s->B, B, sizeof B);
    memcpy(s->Rd, Rd, sizeof Rd);
    memcpy(s->H, H, sizeof H);
    memcpy(s->A, A, sizeof A);
    memcpy(s->R, R, sizeof R);
    memcpy(s->y, y, sizeof y);
    s->Fm = test_view(3, 3, s->F);
    s->Qm = test_view(3, 3, s->Q);
    s->Bm = test_view(2, 2, s->B);
    s->Rdm = test_view(2, 2, s->Rd);
    s->Hm = test_view(2, 3, s->H);
    s->Am = test_view(2, 2, s->A);
    s->Rm = test_view(2, 2, s->R);
    s->ym = test_view(2, 1, s->y);
    test_ui_bind(s);
}

static dkf_real_t bad_value(int kind)
{
    return kind == 0 ? (dkf_real_t)NAN : (dkf_real_t)INFINITY;
}

/* A square root of the largest real: its square overflows. */
#define HUGE_ENTRY (DKF_R(4.0) * DKF_SQRT(DKF_REAL_MAX))

typedef enum { CALL_PREDICT, CALL_UPDATE } call_t;

/* One failing call: the model `md` was corrupted by the caller. */
typedef struct {
    const char *what;
    call_t call;
    dkf_status_t st;
} failure_t;

/* Corrupts a copy of the fixed model for failure case i; returns 0 when
 * there are no more cases. `askf` selects the ASKF's list. */
static int make_failure(size_t i, int askf, test_ui_step_t *md, failure_t *fl)
{
    fixed_model(md);
    switch (i) {
    case 0: md->F[4] = bad_value(0), *fl = (failure_t){"NaN in F", CALL_PREDICT, DKF_ERR_NONFINITE}; break;
    case 1: md->Q[0] = bad_value(1), *fl = (failure_t){"Inf in Q", CALL_PREDICT, DKF_ERR_NONFINITE}; break;
    case 2: md->B[3] = bad_value(0), *fl = (failure_t){"NaN in B", CALL_PREDICT, DKF_ERR_NONFINITE}; break;
    case 3: md->Rd[1] = bad_value(0), *fl = (failure_t){"NaN in Rd", CALL_PREDICT, DKF_ERR_NONFINITE}; break;
    case 4:
        md->Bm = test_view(1, 4, md->B);
        *fl = (failure_t){"B 1 x 4", CALL_PREDICT, DKF_ERR_DIM};
        break;
    case 5:
        md->Fm = test_view(3, 2, md->F);
        *fl = (failure_t){"F 3 x 2", CALL_PREDICT, DKF_ERR_DIM};
        break;
    case 6:
        md->dyn.Rd = NULL;
        *fl = (failure_t){"Rd NULL", CALL_PREDICT, DKF_ERR_NULL};
        break;
    case 7:
        /* overflow found only after the products: F P F^T = Inf */
        md->F[0] = HUGE_ENTRY;
        *fl = (failure_t){"F P F^T overflows", CALL_PREDICT, DKF_ERR_NONFINITE};
        break;
    case 8: md->y[1] = bad_value(0), *fl = (failure_t){"NaN in y", CALL_UPDATE, DKF_ERR_NONFINITE}; break;
    case 9: md->H[2] = bad_value(1), *fl = (failure_t){"Inf in H", CALL_UPDATE, DKF_ERR_NONFINITE}; break;
    case 10: md->A[0] = bad_value(0), *fl = (failure_t){"NaN in A", CALL_UPDATE, DKF_ERR_NONFINITE}; break;
    case 11:
        md->R[0] = md->R[3] = DKF_R(-1000.0);
        *fl = (failure_t){"R = -1000 I: innovation covariance not SPD", CALL_UPDATE,
                          DKF_ERR_NOT_SPD};
        break;
    case 12:
        md->ym = test_view(3, 1, md->y);
        *fl = (failure_t){"y 3 x 1", CALL_UPDATE, DKF_ERR_DIM};
        break;
    case 13:
        md->Am = test_view(2, 1, md->A);
        *fl = (failure_t){"A 2 x 1", CALL_UPDATE, DKF_ERR_DIM};
        break;
    case 14:
        md->Hm = test_view(2, 2, md->H);
        *fl = (failure_t){"H 2 x 2", CALL_UPDATE, DKF_ERR_DIM};
        break;
    case 15:
        md->meas.R = NULL;
        *fl = (failure_t){"R NULL", CALL_UPDATE, DKF_ERR_NULL};
        break;
    case 16:
        /* singular B: the OTSKF needs B^{-1} (Ubar = F V B^{-1}); the ASKF
         * does not, so for it this is not a failure (tested separately) */
        if (askf) return make_failure(17, askf, md, fl);
        md->B[0] = DKF_R(0.9), md->B[1] = DKF_R(0.3), md->B[2] = DKF_R(0.3), md->B[3] = DKF_R(0.1);
        *fl = (failure_t){"singular B", CALL_PREDICT, DKF_ERR_SINGULAR};
        break;
    case 17:
        /* P^d_{k|k-1} = B P^d B^T + Rd is not SPD; the ASKF's KF does not
         * test Q^a's definiteness, so this is OTSKF only */
        if (askf) return 0;
        md->Rd[0] = md->Rd[3] = DKF_R(-1000.0);
        *fl = (failure_t){"Rd = -1000 I: P^d_{k|k-1} not SPD", CALL_PREDICT, DKF_ERR_NOT_SPD};
        break;
    default: return 0;
    }
    return 1;
}

/* For each failure: a filter that has run a few steps fails the call with
 * the expected status, its state (and struct) stay bit-identical, and its
 * next valid steps agree bit for bit with a twin that never failed. */
static void test_otskf_failure_atomicity(void **state)
{
    static otskf_box_t fb, tb;
    static test_ui_step_t good, md;
    static dkf_real_t snap[DKF_OTSKF_STATE_LEN(NMAX, PMAX)], snapA[2 * 2];
    dkf_real_t x0[3] = {DKF_R(1.0), DKF_R(-2.0), DKF_R(0.5)}, d0[2] = {DKF_R(0.3), DKF_R(-0.1)};
    dkf_real_t P0[9] = {DKF_R(2.0), DKF_R(0.3), DKF_R(0.0), DKF_R(0.3), DKF_R(1.0),
                        DKF_R(0.1), DKF_R(0.0), DKF_R(0.1), DKF_R(0.5)};
    dkf_real_t Pd0[4] = {DKF_R(1.0), DKF_R(0.2), DKF_R(0.2), DKF_R(1.0)};
    dkf_mat_t mx0 = test_view(3, 1, x0), mP0 = test_view(3, 3, P0), md0 = test_view(2, 1, d0),
              mPd0 = test_view(2, 2, Pd0);
    const size_t len = DKF_OTSKF_STORAGE_LEN(3, 2, 2), slen = DKF_OTSKF_STATE_LEN(3, 2);
    dkf_otskf_t before;
    failure_t fl;
    size_t i, phase;
    (void)state;
    fixed_model(&good);
    for (i = 0; make_failure(i, 0, &md, &fl); ++i)
        for (phase = 0; phase < 2; ++phase) {
            /* phase 0: the failing call follows an update; 1: a predict */
            assert_int_equal(dkf_otskf_init(&fb.o, 3, 2, 2, fb.o_storage, len, &mx0, &mP0, &md0,
                                            &mPd0),
                             DKF_OK);
            assert_int_equal(dkf_otskf_init(&tb.o, 3, 2, 2, tb.o_storage, len, &mx0, &mP0, &md0,
                                            &mPd0),
                             DKF_OK);
            assert_int_equal(dkf_otskf_predict(&fb.o, &good.dyn), DKF_OK);
            assert_int_equal(dkf_otskf_update(&fb.o, &good.meas, &good.ym), DKF_OK);
            assert_int_equal(dkf_otskf_predict(&tb.o, &good.dyn), DKF_OK);
            assert_int_equal(dkf_otskf_update(&tb.o, &good.meas, &good.ym), DKF_OK);
            if (phase == 1) {
                assert_int_equal(dkf_otskf_predict(&fb.o, &good.dyn), DKF_OK);
                assert_int_equal(dkf_otskf_predict(&tb.o, &good.dyn), DKF_OK);
            }
            memcpy(&before, &fb.o, sizeof before);
            memcpy(snap, fb.o_storage, slen * sizeof(dkf_real_t));
            memcpy(snapA, fb.o.priv.D_ok, sizeof snapA);
            if (fl.call == CALL_PREDICT)
                assert_int_equal(dkf_otskf_predict(&fb.o, &md.dyn), fl.st);
            else
                assert_int_equal(dkf_otskf_update(&fb.o, &md.meas, &md.ym), fl.st);
            if (memcmp(snap, fb.o_storage, slen * sizeof(dkf_real_t)) != 0 ||
                memcmp(snapA, fb.o.priv.D_ok, sizeof snapA) != 0 ||
                memcmp(&before, &fb.o, sizeof before) != 0) {
                print_error("OTSKF state changed by failing call: %s\n", fl.what);
                fail();
            }
            /* the failed filter continues exactly like its twin */
            assert_int_equal(dkf_otskf_update(&fb.o, &good.meas, &good.ym), DKF_OK);
            assert_int_equal(dkf_otskf_update(&tb.o, &good.meas, &good.ym), DKF_OK);
            assert_int_equal(dkf_otskf_predict(&fb.o, &good.dyn), DKF_OK);
            assert_int_equal(dkf_otskf_predict(&tb.o, &good.dyn), DKF_OK);
            assert_memory_equal(fb.o_storage, tb.o_storage, slen * sizeof(dkf_real_t));
        }
    assert_true(i == 18);
}

/* The rank check of A_k is remembered for A_k's bits (dkf/otskf.h): a
 * filter reusing one A agrees bit for bit with one that sees a fresh copy
 * of it each step (same bits, new address); a different, rank-deficient A
 * is still refused; an A that passes the check in a step that then fails
 * (R not SPD) is not remembered. */
static void test_otskf_rank_memo(void **state)
{
    static otskf_box_t fb, tb;
    static test_ui_step_t md, bad;
    dkf_real_t x0[3] = {DKF_R(1.0), DKF_R(-2.0), DKF_R(0.5)}, d0[2] = {DKF_R(0.3), DKF_R(-0.1)};
    dkf_real_t P0[9] = {DKF_R(2.0), DKF_R(0.3), DKF_R(0.0), DKF_R(0.3), DKF_R(1.0),
                        DKF_R(0.1), DKF_R(0.0), DKF_R(0.1), DKF_R(0.5)};
    dkf_real_t Pd0[4] = {DKF_R(1.0), DKF_R(0.2), DKF_R(0.2), DKF_R(1.0)}, Acopy[4];
    dkf_mat_t mx0 = test_view(3, 1, x0), mP0 = test_view(3, 3, P0), md0 = test_view(2, 1, d0),
              mPd0 = test_view(2, 2, Pd0), mAcopy = test_view(2, 2, Acopy);
    const size_t len = DKF_OTSKF_STORAGE_LEN(3, 2, 2);
    dkf_ui_meas_t fresh;
    int k;
    (void)state;
    fixed_model(&md);
    assert_int_equal(dkf_otskf_init(&fb.o, 3, 2, 2, fb.o_storage, len, &mx0, &mP0, &md0, &mPd0),
                     DKF_OK);
    assert_int_equal(dkf_otskf_init(&tb.o, 3, 2, 2, tb.o_storage, len, &mx0, &mP0, &md0, &mPd0),
                     DKF_OK);
    assert_int_equal(fb.o.priv.d_checked, 0);
    fresh = md.meas;
    fresh.D = &mAcopy;
    for (k = 0; k < 5; ++k) {
        assert_int_equal(dkf_otskf_predict(&fb.o, &md.dyn), DKF_OK);
        assert_int_equal(dkf_otskf_predict(&tb.o, &md.dyn), DKF_OK);
        assert_int_equal(dkf_otskf_update(&fb.o, &md.meas, &md.ym), DKF_OK);
        memcpy(Acopy, md.A, sizeof Acopy);
        tb.o.priv.d_checked = 0; /* the twin checks every step */
        assert_int_equal(dkf_otskf_update(&tb.o, &fresh, &md.ym), DKF_OK);
        assert_memory_equal(fb.o_storage, tb.o_storage,
                            DKF_OTSKF_STATE_LEN(3, 2) * sizeof(dkf_real_t));
    }
    assert_int_equal(fb.o.priv.d_checked, 1);
    assert_memory_equal(fb.o.priv.D_ok, md.A, 4 * sizeof(dkf_real_t));
    /* rank A = 1 (second column = 2 x first): refused although a full-rank A is remembered */
    fixed_model(&bad);
    bad.A[1] = DKF_R(2.0) * bad.A[0];
    bad.A[3] = DKF_R(2.0) * bad.A[2];
    assert_int_equal(dkf_otskf_update(&fb.o, &bad.meas, &bad.ym), DKF_ERR_RANK);
    /* a new full-rank A in an update that fails later (R = -I): not remembered */
    fixed_model(&bad);
    bad.A[1] = DKF_R(0.25);
    bad.R[0] = bad.R[3] = DKF_R(-1.0);
    bad.R[1] = bad.R[2] = DKF_R(0.0);
    assert_int_equal(dkf_otskf_update(&fb.o, &bad.meas, &bad.ym), DKF_ERR_NOT_SPD);
    assert_memory_equal(fb.o.priv.D_ok, md.A, 4 * sizeof(dkf_real_t));
}

static void test_askf_failure_atomicity(void **state)
{
    static askf_box_t fb, tb;
    static test_ui_step_t good, md;
    static dkf_real_t snap[DKF_ASKF_STORAGE_LEN(NMAX, MMAX, PMAX)];
    dkf_real_t x0[3] = {DKF_R(1.0), DKF_R(-2.0), DKF_R(0.5)}, d0[2] = {DKF_R(0.3), DKF_R(-0.1)};
    dkf_real_t P0[9] = {DKF_R(2.0), DKF_R(0.3), DKF_R(0.0), DKF_R(0.3), DKF_R(1.0),
                        DKF_R(0.1), DKF_R(0.0), DKF_R(0.1), DKF_R(0.5)};
    dkf_real_t Pd0[4] = {DKF_R(1.0), DKF_R(0.2), DKF_R(0.2), DKF_R(1.0)};
    dkf_real_t Pxd0[6] = {DKF_R(0.1), DKF_R(0.0), DKF_R(0.0), DKF_R(0.2), DKF_R(-0.1), DKF_R(0.0)};
    dkf_mat_t mx0 = test_view(3, 1, x0), mP0 = test_view(3, 3, P0), md0 = test_view(2, 1, d0),
              mPd0 = test_view(2, 2, Pd0), mPxd0 = test_view(3, 2, Pxd0);
    const size_t len = DKF_ASKF_STORAGE_LEN(3, 2, 2);
    /* the state: X, P^a, nu, S of the underlying KF (the start of storage) */
    const size_t slen = 5 + 25 + 2 + 4;
    dkf_askf_t before;
    failure_t fl;
    size_t i;
    (void)state;
    fixed_model(&good);
    for (i = 0; make_failure(i, 1, &md, &fl); ++i) {
        assert_int_equal(dkf_askf_init(&fb.a, 3, 2, 2, fb.a_storage, len, &mx0, &mP0, &md0,
                                       &mPd0, &mPxd0),
                         DKF_OK);
        assert_int_equal(dkf_askf_init(&tb.a, 3, 2, 2, tb.a_storage, len, &mx0, &mP0, &md0,
                                       &mPd0, &mPxd0),
                         DKF_OK);
        assert_int_equal(dkf_askf_predict(&fb.a, &good.dyn), DKF_OK);
        assert_int_equal(dkf_askf_update(&fb.a, &good.meas, &good.ym), DKF_OK);
        assert_int_equal(dkf_askf_predict(&tb.a, &good.dyn), DKF_OK);
        assert_int_equal(dkf_askf_update(&tb.a, &good.meas, &good.ym), DKF_OK);
        memcpy(&before, &fb.a, sizeof before);
        memcpy(snap, fb.a_storage, slen * sizeof(dkf_real_t));
        if (fl.call == CALL_PREDICT)
            assert_int_equal(dkf_askf_predict(&fb.a, &md.dyn), fl.st);
        else
            assert_int_equal(dkf_askf_update(&fb.a, &md.meas, &md.ym), fl.st);
        if (memcmp(snap, fb.a_storage, slen * sizeof(dkf_real_t)) != 0 ||
            memcmp(&before, &fb.a, sizeof before) != 0) {
            print_error("ASKF state changed by failing call: %s\n", fl.what);
            fail();
        }
        assert_int_equal(dkf_askf_predict(&fb.a, &good.dyn), DKF_OK);
        assert_int_equal(dkf_askf_predict(&tb.a, &good.dyn), DKF_OK);
        assert_int_equal(dkf_askf_update(&fb.a, &good.meas, &good.ym), DKF_OK);
        assert_int_equal(dkf_askf_update(&tb.a, &good.meas, &good.ym), DKF_OK);
        assert_memory_equal(fb.a_storage, tb.a_storage, slen * sizeof(dkf_real_t));
    }
    assert_true(i == 16);
    /* the ASKF never inverts B: a singular B is a valid model for it */
    fixed_model(&md);
    md.B[0] = DKF_R(0.9), md.B[1] = DKF_R(0.3), md.B[2] = DKF_R(0.3), md.B[3] = DKF_R(0.1);
    assert_int_equal(dkf_askf_predict(&fb.a, &md.dyn), DKF_OK);
}

/* Argument and init errors of both filters, with outputs untouched. */
static void test_init_and_argument_errors(void **state)
{
    static askf_box_t ab;
    static otskf_box_t ob;
    dkf_real_t x0[3] = {DKF_R(1.0), DKF_R(2.0), DKF_R(3.0)}, d0[2] = {DKF_R(0.0), DKF_R(1.0)};
    dkf_real_t P0[9] = {DKF_R(1.0), DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(1.0),
                        DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(1.0)};
    dkf_real_t Pbad[9] = {DKF_R(1.0), DKF_R(2.0), DKF_R(0.0), DKF_R(2.0), DKF_R(1.0),
                          DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(1.0)};
    dkf_real_t Pd0[4] = {DKF_R(1.0), DKF_R(0.0), DKF_R(0.0), DKF_R(1.0)};
    dkf_real_t Pdbad[4] = {DKF_R(1.0), DKF_R(0.0), DKF_R(0.0), DKF_R(-1.0)};
    dkf_real_t Pxdbad[6] = {DKF_R(2.0), DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(0.0)};
    dkf_real_t out[9];
    dkf_mat_t mx0 = test_view(3, 1, x0), mP0 = test_view(3, 3, P0), md0 = test_view(2, 1, d0),
              mPd0 = test_view(2, 2, Pd0), mPbad = test_view(3, 3, Pbad),
              mPdbad = test_view(2, 2, Pdbad), mPxdbad = test_view(3, 2, Pxdbad),
              mout = test_view(2, 2, out), v = test_view(1, 1, out);
    const size_t olen = DKF_OTSKF_STORAGE_LEN(3, 2, 2), alen = DKF_ASKF_STORAGE_LEN(3, 2, 2);
    dkf_otskf_t osent;
    dkf_askf_t asent;
    test_ui_step_t md;
    (void)state;
    fixed_model(&md);
    memset(&osent, 0x5a, sizeof osent);
    memset(&asent, 0x5a, sizeof asent);

    /* OTSKF: the storage macro is exact; bad priors; *f untouched */
    memcpy(&ob.o, &osent, sizeof osent);
    assert_int_equal(dkf_otskf_init(&ob.o, 3, 2, 2, ob.o_storage, olen - 1, &mx0, &mP0, &md0, &mPd0),
                     DKF_ERR_CAPACITY);
    assert_int_equal(dkf_otskf_init(&ob.o, 3, 2, 2, ob.o_storage, olen, &mx0, &mPbad, &md0, &mPd0),
                     DKF_ERR_NOT_SPD);
    assert_int_equal(dkf_otskf_init(&ob.o, 3, 2, 2, ob.o_storage, olen, &mx0, &mP0, &md0, &mPdbad),
                     DKF_ERR_NOT_SPD);
    assert_int_equal(dkf_otskf_init(&ob.o, 3, 2, 2, ob.o_storage, olen, &md0, &mP0, &md0, &mPd0),
                     DKF_ERR_DIM);
    assert_int_equal(dkf_otskf_init(&ob.o, 3, 2, 0, ob.o_storage, olen, &mx0, &mP0, &md0, &mPd0),
                     DKF_ERR_CAPACITY);
    assert_memory_equal(&ob.o, &osent, sizeof osent);
    assert_int_equal(dkf_otskf_init(&ob.o, 3, 2, 2, ob.o_storage, olen, &mx0, &mP0, &md0, &mPd0),
                     DKF_OK);
    /* before init */
    memset(&ob.o, 0, sizeof ob.o);
    assert_int_equal(dkf_otskf_predict(&ob.o, &md.dyn), DKF_ERR_STATE);
    assert_int_equal(dkf_otskf_update(&ob.o, &md.meas, &md.ym), DKF_ERR_STATE);

    /* ASKF: exact storage, P^a indefinite through Pxd0, n + p too large */
    memcpy(&ab.a, &asent, sizeof asent);
    assert_int_equal(dkf_askf_init(&ab.a, 3, 2, 2, ab.a_storage, alen - 1, &mx0, &mP0, &md0, &mPd0,
                                   NULL),
                     DKF_ERR_CAPACITY);
    assert_int_equal(dkf_askf_init(&ab.a, 3, 2, 2, ab.a_storage, alen, &mx0, &mP0, &md0, &mPd0,
                                   &mPxdbad),
                     DKF_ERR_NOT_SPD);
    assert_int_equal(dkf_askf_init(&ab.a, 3, 2, 2, ab.a_storage, alen, &mx0, &mP0, &md0, &mPd0,
                                   &mPd0),
                     DKF_ERR_DIM);
    assert_int_equal(dkf_askf_init(&ab.a, DKF_MAX_DIM, 2, 1, ab.a_storage, alen, &mx0, &mP0, &md0,
                                   &mPd0, NULL),
                     DKF_ERR_CAPACITY);
    assert_memory_equal(&ab.a, &asent, sizeof asent);
    memset(&ab.a, 0, sizeof ab.a);
    assert_int_equal(dkf_askf_predict(&ab.a, &md.dyn), DKF_ERR_STATE);
    assert_int_equal(dkf_askf_state(&ab.a, &v, NULL), DKF_ERR_STATE);
    assert_int_equal(dkf_askf_init(&ab.a, 3, 2, 2, ab.a_storage, alen, &mx0, &mP0, &md0, &mPd0,
                                   NULL),
                     DKF_OK);
    /* accessors: a wrong Px shape writes neither output */
    test_fill(out, 9, DKF_R(7.0));
    v = test_view(1, 1, out);
    assert_int_equal(dkf_askf_state(&ab.a, &v, &mout), DKF_ERR_DIM);
    assert_true(v.rows == 1 && v.data == out && out[0] == DKF_R(7.0));
    assert_int_equal(dkf_askf_input(&ab.a, &v, &mout), DKF_OK);
    assert_true(v.rows == 2 && v.data[1] == DKF_R(1.0) && out[0] == DKF_R(1.0) && out[1] == DKF_R(0.0));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_askf_matches_ex1_vector),
        cmocka_unit_test(test_otskf_matches_ex1_vector),
        cmocka_unit_test(test_otskf_equals_askf_random),
        cmocka_unit_test(test_otskf_failure_atomicity),
        cmocka_unit_test(test_otskf_rank_memo),
        cmocka_unit_test(test_askf_failure_atomicity),
        cmocka_unit_test(test_init_and_argument_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
