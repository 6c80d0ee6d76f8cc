/*
 * Unknown-input filters (dkf/uif.h) against the seed-004 golden vectors:
 * RTSF, NRTSF-DF and NRTSF, every stored field at every step, and the
 * RTSF refusal of the paper's rank-deficient H.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/uif.h"
#include "dkf_test.h"

#define NX 5
#define NP 3
#define NM 5
#define CAP 64

/* Vector tolerance (README rule: max|got - exp| <= rel * max(1, max|exp|)
 * per field and step). Double: the README's 1e-9; the float64 oracle
 * reached 1.6e-15 and so should we (the filters are stable, errors do not
 * grow over the 50 steps). Float: the README's 1e-3. Justification: one
 * step costs a few Cholesky solves with cond(R~) <= ~20 and
 * cond(Hbar^T R~^-1 Hbar) ~ 1e2 (R ~ 1e-2 against P ~ 1e-2..1), i.e.
 * ~1e2 * p * FLT_EPSILON ~ 6e-5 relative, and the README measured that
 * merely rounding the inputs to float32 moves the outputs by 5.6e-6. */
#if DKF_USE_FLOAT
#define VEC_REL 1e-3
#else
#define VEC_REL 1e-9
#endif

typedef struct {
    DKF_UIF_DECLARE(, f, NX, NM, NP);
} box_t;

typedef struct {
    dkf_real_t A[CAP], G[CAP], Q[CAP], C[CAP], H[CAP], R[CAP], y[CAP];
    dkf_mat_t mA, mG, mQ, mC, mH, mR, my;
    dkf_uif_dyn_t dyn;
    dkf_ui_meas_t meas;
} model_t;

/* A model matrix of step `st`: its per-step input `key` (time-varying
 * files) or else the constant model's `mkey`. */
static const json_t *model_at(const json_t *root, const json_t *st, const char *key,
                              const char *mkey)
{
    const json_t *v = json_object_get(test_json_get(st, "inputs"), key);
    return v != NULL ? v : test_json_get(test_json_get(root, "model"), mkey);
}

static void load_step(model_t *s, const json_t *root, const json_t *st, dkf_uif_kind_t kind)
{
    test_json_mat(model_at(root, st, "F_prev", "F"), s->A, CAP, &s->mA);
    test_json_mat(model_at(root, st, "G_prev", "G"), s->G, CAP, &s->mG);
    test_json_mat(model_at(root, st, "Q_prev", "Q"), s->Q, CAP, &s->mQ);
    test_json_mat(model_at(root, st, "H", "H"), s->C, CAP, &s->mC);
    test_json_mat(model_at(root, st, "R", "R"), s->R, CAP, &s->mR);
    test_json_mat(test_json_get(test_json_get(st, "inputs"), "y"), s->y, CAP, &s->my);
    s->dyn.F = &s->mA;
    s->dyn.G = &s->mG;
    s->dyn.Q = &s->mQ;
    s->meas.H = &s->mC;
    s->meas.R = &s->mR;
    s->meas.D = NULL;
    if (kind != DKF_UIF_NRTSF) {
        test_json_mat(model_at(root, st, "D", "D"), s->H, CAP, &s->mH);
        s->meas.D = &s->mH;
    }
}

static void compare(const char *what, const dkf_mat_t *got, const json_t *exp, const char *key)
{
    double e[CAP];
    size_t cnt = test_json_array(test_json_get(exp, key), e, CAP, NULL, NULL);
    assert_int_equal(cnt, got->rows * got->cols);
    test_assert_close(what, got->data, e, cnt, VEC_REL);
}

static void init_from(box_t *b, const json_t *root, dkf_uif_kind_t kind)
{
    const json_t *init = test_json_get(root, "init");
    const json_t *dims = test_json_get(root, "dims");
    dkf_real_t xs[CAP], Ps[CAP];
    dkf_mat_t x0, P0;
    test_json_mat(test_json_get(init, "x0"), xs, CAP, &x0);
    test_json_mat(test_json_get(init, "P0"), Ps, CAP, &P0);
    assert_int_equal(json_integer_value(test_json_get(dims, "n")), NX);
    assert_int_equal(json_integer_value(test_json_get(dims, "m")), NP);
    assert_int_equal(json_integer_value(test_json_get(dims, "p")), NM);
    assert_int_equal(dkf_uif_init(&b->f, kind, NX, NM, NP, b->f_storage,
                                  DKF_UIF_STORAGE_LEN(NX, NM, NP), &x0, &P0),
                     DKF_OK);
}

/* Runs the whole file through one filter (its own state, not re-seeded
 * from the expected values) and compares every stored field. */
static void run_vector(const char *file, dkf_uif_kind_t kind, dkf_uif_kind_t file_kind)
{
    static box_t b;
    static model_t s;
    json_t *root = test_load_vector(file);
    const json_t *steps = test_json_get(root, "steps");
    size_t j;
    test_reset_worst_rel();
    init_from(&b, root, kind);
    assert_true(json_array_size(steps) > 0);
    for (j = 0; j < json_array_size(steps); ++j) {
        const json_t *st = json_array_get(steps, j);
        const json_t *exp = test_json_get(st, "expected");
        const int first_df = kind != DKF_UIF_NRTSF && j == 0;
        load_step(&s, root, st, kind);
        assert_int_equal(dkf_uif_step(&b.f, first_df ? NULL : &s.dyn, &s.meas, &s.my), DKF_OK);
        compare("x_pred", &b.f.x_pred, exp, "x_pred");
        compare("P_pred", &b.f.P_pred, exp, "P_pred");
        compare("Rtilde", &b.f.Rtilde, exp, "Rtilde");
        compare("d", &b.f.d, exp, "d");
        compare("Pd", &b.f.Pd, exp, "Pd");
        compare("x", &b.f.x, exp, "x");
        compare("Px", &b.f.Px, exp, "Px");
        compare("K", &b.f.K, exp, "K");
        compare("L", &b.f.L, exp, "L");
        if (kind == DKF_UIF_NRTSF)
            compare("Pxd_extra", &b.f.Pxd, exp, "Pxd_extra");
        else
            compare("Pxd", &b.f.Pxd, exp, "Pxd");
        if (file_kind == DKF_UIF_RTSF) { /* full-rank H: proj = I */
            double eye[NP * NP] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
            compare("M", &b.f.M, exp, "M");
            assert_int_equal(b.f.rank, NP);
            test_assert_close("proj", b.f.proj.data, eye, NP * NP, VEC_REL);
        } else {
            assert_int_equal(b.f.rank, json_integer_value(test_json_get(exp, "rank")));
            compare("proj", &b.f.proj, exp, "proj");
        }
    }
    print_message("%s: %zu steps, worst relative error %.3e (tolerance %.0e)\n", file,
                  json_array_size(steps), test_worst_rel(), VEC_REL);
    json_decref(root);
}

static void test_uif_rtsf_vector(void **state)
{
    (void)state;
    run_vector("uif/s004_rtsf.json", DKF_UIF_RTSF, DKF_UIF_RTSF);
}

/* The RTSF file's system has full-rank H, so NRTSF-DF must reproduce the
 * same numbers (paper: "if H_k is of full column rank ... RTSF is
 * obtained"); its `M` field is the invariant T^+ Mbar. */
static void test_uif_nrtsf_df_on_rtsf_vector(void **state)
{
    (void)state;
    run_vector("uif/s004_rtsf.json", DKF_UIF_NRTSF_DF, DKF_UIF_RTSF);
}

static void test_uif_nrtsf_df_vector(void **state)
{
    (void)state;
    run_vector("uif/s004_nrtsf_df.json", DKF_UIF_NRTSF_DF, DKF_UIF_NRTSF_DF);
}

static void test_uif_nrtsf_vector(void **state)
{
    (void)state;
    run_vector("uif/s004_nrtsf.json", DKF_UIF_NRTSF, DKF_UIF_NRTSF);
}

/* A copy of everything a failed step must leave alone: the output block
 * (x, Px, d, Pd, Pxd and the last step's intermediates) and the scalars. */
typedef struct {
    dkf_real_t out[DKF__UIF_OUT_LEN(NX, NM, NP)];
    size_t k, rank, bias_steps;
    int bias_risk;
    unsigned char est[DKF_MAX_DIM];
} snap_t;

static void snap_take(snap_t *s, const dkf_uif_t *f)
{
    assert_int_equal((size_t)(f->priv.mem - f->x.data), DKF__UIF_OUT_LEN(NX, NM, NP));
    memcpy(s->out, f->x.data, sizeof s->out);
    s->k = f->k;
    s->rank = f->rank;
    s->bias_steps = f->bias_steps;
    s->bias_risk = f->bias_risk;
    memcpy(s->est, f->estimable, sizeof s->est);
}

static void snap_check(const snap_t *s, const dkf_uif_t *f)
{
    assert_memory_equal(s->out, f->x.data, sizeof s->out);
    assert_int_equal(s->k, f->k);
    assert_int_equal(s->rank, f->rank);
    assert_int_equal(s->bias_steps, f->bias_steps);
    assert_int_equal(s->bias_risk, f->bias_risk);
    assert_memory_equal(s->est, f->estimable, sizeof s->est);
}

/* expect_error_case: RTSF on the paper's original H (rank 2 < m = 3) must be
 * refused with DKF_ERR_RANK, at the first step and at a later one, leaving
 * the filter bit-identical; NRTSF-DF accepts the same H. */
static void test_uif_rtsf_refuses_rank_deficient_h(void **state)
{
    static box_t b, c;
    static model_t s;
    static snap_t snap;
    json_t *root = test_load_vector("uif/s004_rtsf.json");
    const json_t *bad = test_json_get(test_json_get(root, "expect_error_case"), "H");
    const json_t *st0 = json_array_get(test_json_get(root, "steps"), 0);
    const json_t *st1 = json_array_get(test_json_get(root, "steps"), 1);
    dkf_real_t Hb[CAP];
    dkf_mat_t mHb;
    dkf_ui_meas_t meas;
    (void)state;
    test_json_mat(bad, Hb, CAP, &mHb);
    init_from(&b, root, DKF_UIF_RTSF);
    load_step(&s, root, st0, DKF_UIF_RTSF);
    meas = s.meas;
    meas.D = &mHb;
    snap_take(&snap, &b.f);
    assert_int_equal(dkf_uif_step(&b.f, NULL, &meas, &s.my), DKF_ERR_RANK);
    snap_check(&snap, &b.f);
    /* a good first step, then the bad H at step 1 */
    assert_int_equal(dkf_uif_step(&b.f, NULL, &s.meas, &s.my), DKF_OK);
    load_step(&s, root, st1, DKF_UIF_RTSF);
    meas = s.meas;
    meas.D = &mHb;
    snap_take(&snap, &b.f);
    assert_int_equal(dkf_uif_step(&b.f, &s.dyn, &meas, &s.my), DKF_ERR_RANK);
    snap_check(&snap, &b.f);
    /* and the filter still runs on with a good H */
    assert_int_equal(dkf_uif_step(&b.f, &s.dyn, &s.meas, &s.my), DKF_OK);
    /* NRTSF-DF handles the rank-2 H: rank 2, d_1 not estimable */
    init_from(&c, root, DKF_UIF_NRTSF_DF);
    load_step(&s, root, st0, DKF_UIF_NRTSF_DF);
    assert_int_equal(dkf_uif_step(&c.f, NULL, &meas, &s.my), DKF_OK);
    assert_int_equal(c.f.rank, 2);
    assert_int_equal(c.f.estimable[0], DKF_UIF_EST_NONE);
    assert_int_equal(c.f.estimable[1], DKF_UIF_EST_FULL);
    assert_int_equal(c.f.estimable[2], DKF_UIF_EST_FULL);
    json_decref(root);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_uif_rtsf_vector),
        cmocka_unit_test(test_uif_nrtsf_df_on_rtsf_vector),
        cmocka_unit_test(test_uif_nrtsf_df_vector),
        cmocka_unit_test(test_uif_nrtsf_vector),
        cmocka_unit_test(test_uif_rtsf_refuses_rank_deficient_h),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
