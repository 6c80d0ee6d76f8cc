/*
 * Distributed Difference KF (dkf/diffkf_fusion.h): the fusion centre (FC)
 * against golden/own vectors and against the centralized Difference KF run
 * in-library on the stacked data; stacking helpers; node messages; set-up
 * and per-step rank conditions; message validation; failure atomicity.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/diffkf_fusion.h"
#include "dkf_test.h"

#define NX 6   /* largest state dimension of the vector files */
#define NL 4   /* most sensors */
#define NY 4   /* largest m_i */
#define NP 2   /* largest p_i */
#define MS (NL * NY)
#define PS (NL * NP)
#define CAP (NX * NX)
#define FC_LEN DKF_DIFFKF_FC_STORAGE_MAX(NX, NL, NY, NP)
#define LOC_LEN DKF_DIFFKF_STORAGE_LEN(NX, NY, NP)
#define CEN_LEN DKF_DIFFKF_STORAGE_LEN(NX, MS, PS)

/*
 * Tolerances, all max|a - b| / max(1, max|b|) per array.
 *
 * VEC_REL (against the numpy vectors, which equal a batch LMMSE to <= 6e-14
 * for our scenarios and 1.6e-11 for ex3): double 1e-9, the vectors' tolerance
 * (measured ~1e-13). Float: the local filters alone are within ~1e-5 of
 * the vectors (test_diffkf.c justifies 1e-4: cond(L) ~ 30, |x| ~ 300); the
 * recovery adds |dz error| ~ eps |x_{k|k}| / sigma_min(K^i) (xf - xp is a
 * difference of O(|x|) numbers; sigma_min(K) >= 0.045 in our files, 0.16 in
 * ex3), i.e. <= 1.2e-7 * 300 / 0.16 ~ 2e-4 absolute on z^i, and the central
 * filter turns that into |K_c| 2e-4 on x. So 1e-3 = ~8000 FLT_EPSILON: the
 * chain is stable (no growth over 50 steps), measured below.
 *
 * FUSED_REL (fused vs the in-library centralized DKF on the stacked y, same
 * arithmetic otherwise): the only difference is the recovery rounding just
 * described. Double: 1e-9 (the vectors' tolerance; measured ~1e-13). Float: the
 * same 1e-3 argument (the reference is itself a float filter).
 */
#if DKF_USE_FLOAT
#define VEC_REL 1e-3
#define FUSED_REL 1e-3
#else
#define VEC_REL 1e-9
#define FUSED_REL 1e-9
#endif

typedef struct {
    double vec, fused, zloc, carry;
} stats_t;

static double rel_err(const dkf_real_t *got, const double *exp, size_t n)
{
    double scale = 1.0, err = 0.0;
    size_t i;
    for (i = 0; i < n; ++i) {
        if (fabs(exp[i]) > scale) scale = fabs(exp[i]);
        if (fabs((double)got[i] - exp[i]) > err) err = fabs((double)got[i] - exp[i]);
    }
    return err / scale;
}

static void close_to(double *worst, const char *what, const dkf_real_t *got, const double *exp,
                     size_t n, double tol)
{
    const double e = rel_err(got, exp, n);
    if (e > *worst) *worst = e;
    if (!(e <= tol)) fail_msg("%s: relative error %.3e > %.1e", what, e, tol);
}

static void close_real(double *worst, const char *what, const dkf_real_t *got,
                       const dkf_real_t *exp, size_t n, double tol)
{
    double e[MS * MS];
    test_to_double(e, exp, n);
    close_to(worst, what, got, e, n, tol);
}

/* got against the JSON array node (a vector or matrix). */
static void close_json(double *worst, const char *what, const dkf_real_t *got, size_t n,
                       const json_t *node, double tol)
{
    double e[MS * MS];
    const size_t cnt = test_json_array(node, e, MS * MS, NULL, NULL);
    assert_int_equal(cnt, n);
    close_to(worst, what, got, e, n, tol);
}

static const json_t *at(const json_t *obj, const char *key, size_t j)
{
    return json_array_get(test_json_get(obj, key), j);
}

/* ---- models ---------------------------------------------------------------- */

typedef struct {
    dkf_real_t H[CAP], A[CAP], R[CAP], B[CAP], Rd[CAP];
    dkf_mat_t mH, mA, mR, mB, mRd;
} sens_buf_t;

typedef struct {
    dkf_real_t F[CAP], Q[CAP];
    dkf_mat_t mF, mQ;
    sens_buf_t s[NL];
    dkf_diffkf_sensor_t sensors[NL]; /* B, Rd at k; meas at k + 1 */
    dkf_ui_dyn_t dyn[NL];
} step_model_t;

/* F_k, Q_k, (B^i_k, Rd^i_k) and (H, A, R)^i at kmeas. */
static void load_step(step_model_t *sm, const json_t *model, size_t l, size_t k, size_t kmeas)
{
    const json_t *sens = test_json_get(model, "sensors");
    size_t i;
    test_json_mat(test_json_model_at(model, "F", k), sm->F, CAP, &sm->mF);
    test_json_mat(test_json_model_at(model, "Q", k), sm->Q, CAP, &sm->mQ);
    for (i = 0; i < l; ++i) {
        const json_t *s = json_array_get(sens, i);
        sens_buf_t *b = &sm->s[i];
        test_json_mat(test_json_model_at(s, "H", kmeas), b->H, CAP, &b->mH);
        test_json_mat(test_json_model_at(s, "D", kmeas), b->A, CAP, &b->mA);
        test_json_mat(test_json_model_at(s, "R", kmeas), b->R, CAP, &b->mR);
        test_json_mat(test_json_model_at(s, "B", k), b->B, CAP, &b->mB);
        test_json_mat(test_json_model_at(s, "Rd", k), b->Rd, CAP, &b->mRd);
        sm->sensors[i].B = &b->mB;
        sm->sensors[i].Rd = &b->mRd;
        sm->sensors[i].meas.H = &b->mH;
        sm->sensors[i].meas.D = &b->mA;
        sm->sensors[i].meas.R = &b->mR;
        sm->dyn[i].F = &sm->mF;
        sm->dyn[i].Q = &sm->mQ;
        sm->dyn[i].B = &b->mB;
        sm->dyn[i].Rd = &b->mRd;
    }
}

/* The stacked model of a step_model_t, for the in-library centralized DKF. */
typedef struct {
    dkf_real_t H[MS * NX], A[MS * PS], R[MS * MS], B[PS * PS], Rd[PS * PS], y[MS];
    dkf_mat_t mH, mA, mR, mB, mRd, my;
    dkf_ui_dyn_t dyn;
    dkf_ui_meas_t meas;
} stacked_t;

static void stack(stacked_t *st, step_model_t *sm, size_t l, size_t n, size_t ms, size_t ps)
{
    const dkf_ui_meas_t *meas[NL];
    const dkf_mat_t *Bi[NL], *Rdi[NL];
    size_t i;
    for (i = 0; i < l; ++i) {
        meas[i] = &sm->sensors[i].meas;
        Bi[i] = sm->sensors[i].B;
        Rdi[i] = sm->sensors[i].Rd;
    }
    st->mH = test_view(ms, n, st->H);
    st->mA = test_view(ms, ps, st->A);
    st->mR = test_view(ms, ms, st->R);
    st->mB = test_view(ps, ps, st->B);
    st->mRd = test_view(ps, ps, st->Rd);
    assert_int_equal(dkf_diffkf_stack_meas(&st->mH, &st->mA, &st->mR, meas, l), DKF_OK);
    assert_int_equal(dkf_diffkf_stack_input(&st->mB, &st->mRd, Bi, Rdi, l), DKF_OK);
    st->dyn.F = &sm->mF;
    st->dyn.Q = &sm->mQ;
    st->dyn.B = &st->mB;
    st->dyn.Rd = &st->mRd;
    st->meas.H = &st->mH;
    st->meas.D = &st->mA;
    st->meas.R = &st->mR;
}

/* ---- one scenario file, end to end ------------------------------------------ */

typedef struct {
    dkf_diffkf_fc_t fc;
    dkf_diffkf_fc_node_t nodes[NL];
    dkf_real_t store[FC_LEN];
    dkf_diffkf_t loc[NL];
    dkf_real_t loc_store[NL][LOC_LEN];
    dkf_diffkf_t cen; /* centralized DKF on the stacked y (reference) */
    dkf_real_t cen_store[CEN_LEN];
    dkf_diffkf_msg_t msgs[NL];
    step_model_t sm;
    stacked_t st;
    dkf_real_t ys[NL][NY];
} world_t;

typedef struct {
    json_t *root;
    const json_t *model, *out;
    size_t n, l, N, m[NL], p[NL], ms, ps;
} scen_t;

static void open_scen(scen_t *sc, const char *file)
{
    const json_t *dims;
    size_t i;
    memset(sc, 0, sizeof *sc);
    sc->root = test_load_vector(file);
    sc->model = test_json_get(sc->root, "model");
    sc->out = test_json_get(sc->root, "outputs");
    dims = test_json_get(sc->root, "dims");
    sc->n = test_json_size(dims, "m");
    sc->l = json_array_size(test_json_get(dims, "p_i"));
    sc->N = json_array_size(test_json_get(sc->root, "k"));
    assert_true(sc->n <= NX && sc->l <= NL);
    for (i = 0; i < sc->l; ++i) {
        sc->m[i] = (size_t)json_integer_value(at(dims, "n_i", i));
        sc->p[i] = (size_t)json_integer_value(at(dims, "p_i", i));
        assert_true(sc->m[i] <= NY && sc->p[i] <= NP);
        sc->ms += sc->m[i];
        sc->ps += sc->p[i];
    }
}

/* y^i_k into w->ys[i], and the stacked y into w->st.y. */
static void load_y(world_t *w, const scen_t *sc, size_t k)
{
    size_t i, off = 0;
    for (i = 0; i < sc->l; ++i) {
        dkf_mat_t y;
        test_json_mat(json_array_get(test_json_get(json_array_get(test_json_get(sc->root, "y"), i),
                                                   "values"),
                                     k - 1),
                      w->ys[i], NY, &y);
        assert_int_equal(y.rows, sc->m[i]);
        memcpy(w->st.y + off, w->ys[i], sc->m[i] * sizeof(dkf_real_t));
        off += sc->m[i];
    }
    w->st.my = test_view(sc->ms, 1, w->st.y);
}

/* Init + start of the local nodes, the FC and the reference central DKF. */
static void start_world(world_t *w, const scen_t *sc)
{
    const json_t *init = test_json_get(sc->root, "init");
    dkf_real_t x0s[NX], P0s[CAP], Pls[NL][CAP];
    const dkf_mat_t *P0l[NL];
    dkf_mat_t x0, P0, Pl[NL];
    dkf_diffkf_fc_fault_t fault;
    size_t i;
    test_json_mat(test_json_get(init, "x00"), x0s, NX, &x0);
    test_json_mat(test_json_get(init, "P00_central"), P0s, CAP, &P0);
    assert_true(FC_LEN >= dkf_diffkf_fc_storage_len(sc->n, sc->l, sc->m, sc->p));
    for (i = 0; i < sc->l; ++i) {
        test_json_mat(at(init, "P00_local", i), Pls[i], CAP, &Pl[i]);
        P0l[i] = &Pl[i];
        assert_int_equal(dkf_diffkf_init(&w->loc[i], sc->n, sc->m[i], sc->p[i], w->loc_store[i],
                                         LOC_LEN, &x0, &Pl[i]),
                         DKF_OK);
    }
    assert_int_equal(dkf_diffkf_fc_init(&w->fc, w->nodes, sc->l, sc->n, sc->m, sc->p, w->store,
                                        FC_LEN, &x0, &P0, P0l, &fault),
                     DKF_OK);
    assert_int_equal(fault.which, DKF_DIFFKF_FC_NO_FAULT);
    assert_int_equal(dkf_diffkf_init(&w->cen, sc->n, sc->ms, sc->ps, w->cen_store, CEN_LEN, &x0,
                                     &P0),
                     DKF_OK);
    /* start: F_0, Q_0, the models at 1 (B at 1 for the FC's set-up check), y_1 */
    load_step(&w->sm, sc->model, sc->l, 1, 1);
    test_json_mat(test_json_model_at(sc->model, "F", 0), w->sm.F, CAP, &w->sm.mF);
    test_json_mat(test_json_model_at(sc->model, "Q", 0), w->sm.Q, CAP, &w->sm.mQ);
    load_y(w, sc, 1);
    stack(&w->st, &w->sm, sc->l, sc->n, sc->ms, sc->ps);
    for (i = 0; i < sc->l; ++i) {
        dkf_mat_t y = test_view(sc->m[i], 1, w->ys[i]);
        assert_int_equal(dkf_diffkf_start(&w->loc[i], &w->sm.mF, &w->sm.mQ,
                                          &w->sm.sensors[i].meas, &y),
                         DKF_OK);
        assert_int_equal(dkf_diffkf_msg_fill(&w->msgs[i], (uint16_t)i, &w->loc[i]), DKF_ERR_STATE);
    }
    assert_int_equal(dkf_diffkf_fc_start(&w->fc, &w->sm.mF, &w->sm.mQ, w->sm.sensors, &fault),
                     DKF_OK);
    assert_int_equal(dkf_diffkf_start(&w->cen, &w->sm.mF, &w->sm.mQ, &w->st.meas, &w->st.my),
                     DKF_OK);
}

/* Local steps k (consuming y_{k+1}) and their messages; the model of step
 * k is loaded into w->sm and w->st. */
static void nodes_step(world_t *w, const scen_t *sc, size_t k)
{
    size_t i;
    load_step(&w->sm, sc->model, sc->l, k, k + 1);
    stack(&w->st, &w->sm, sc->l, sc->n, sc->ms, sc->ps);
    load_y(w, sc, k + 1);
    for (i = 0; i < sc->l; ++i) {
        dkf_mat_t y = test_view(sc->m[i], 1, w->ys[i]);
        assert_int_equal(dkf_diffkf_step(&w->loc[i], &w->sm.dyn[i], &w->sm.sensors[i].meas, &y),
                         DKF_OK);
        assert_int_equal(dkf_diffkf_msg_fill(&w->msgs[i], (uint16_t)i, &w->loc[i]), DKF_OK);
    }
}

static void fc_step_ok(world_t *w)
{
    dkf_diffkf_fc_fault_t fault;
    assert_int_equal(dkf_diffkf_fc_step(&w->fc, &w->sm.mF, &w->sm.mQ, w->sm.sensors, w->msgs,
                                        &fault),
                     DKF_OK);
    assert_int_equal(fault.which, DKF_DIFFKF_FC_NO_FAULT);
}

static void run_scenario(const char *file)
{
    static world_t w;
    scen_t sc;
    stats_t s = {0, 0, 0, 0};
    size_t j, i;
    open_scen(&sc, file);
    start_world(&w, &sc);
    for (j = 0; j < sc.N; ++j) {
        const size_t k = j + 1, n = sc.n;
        const dkf_diffkf_t *c = &w.fc.central;
        const json_t *fused = test_json_get(sc.out, "fused"), *cen = test_json_get(sc.out, "central");
        /* the prediction x_{k|k-1} the step starts from */
        close_json(&s.vec, "fused xp", c->xn.data, n, at(fused, "xp", j), VEC_REL);
        close_json(&s.vec, "fused Pp", c->Pn.data, n * n, at(fused, "Pp", j), VEC_REL);
        close_json(&s.vec, "central xp", c->xn.data, n, at(cen, "xp", j), VEC_REL);
        close_real(&s.fused, "fused vs CDKF xp", c->xn.data, w.cen.xn.data, n, FUSED_REL);

        nodes_step(&w, &sc, k);
        for (i = 0; i < sc.l; ++i) {
            const json_t *msg = json_array_get(json_array_get(test_json_get(sc.out, "messages"), j), i);
            assert_int_equal(w.msgs[i].k, k);
            assert_int_equal(w.msgs[i].node, i);
            assert_int_equal(w.msgs[i].n, n);
            close_json(&s.vec, "msg xf", w.msgs[i].xf, n, test_json_get(msg, "xf"), VEC_REL);
            close_json(&s.vec, "msg xp", w.msgs[i].xp, n, test_json_get(msg, "xp"), VEC_REL);
        }
        fc_step_ok(&w);
        assert_int_equal(w.fc.k, k);
        assert_int_equal(dkf_diffkf_step(&w.cen, &w.st.dyn, &w.st.meas, &w.st.my), DKF_OK);

        for (i = 0; i < sc.l; ++i) {
            const json_t *rec = json_array_get(json_array_get(test_json_get(sc.out, "fc_recovered"), j), i);
            const dkf_diffkf_fc_node_t *nd = &w.nodes[i];
            close_json(&s.vec, "recovered dz", nd->dz.data, sc.p[i], test_json_get(rec, "dz"), VEC_REL);
            close_json(&s.vec, "recovered z", nd->z.data, sc.p[i], test_json_get(rec, "z"), VEC_REL);
            close_json(&s.vec, "replica K", nd->rep.K.data, n * sc.p[i], test_json_get(rec, "K"),
                       VEC_REL);
            /* the recovered datum is the node's own z^i_k and dz^i_k */
            close_real(&s.zloc, "recovered z vs node z", nd->z.data, w.loc[i].z.data, sc.p[i],
                       FUSED_REL);
            close_real(&s.zloc, "recovered dz vs node dz", nd->dz.data, w.loc[i].dz.data, sc.p[i],
                       FUSED_REL);
            /* what the replica carries into step k+1 is the recovered dz */
            close_real(&s.carry, "replica dz", nd->rep.dz.data, nd->dz.data, sc.p[i], FUSED_REL);
        }
        close_json(&s.vec, "fused xf", c->xf.data, n, at(fused, "xf", j), VEC_REL);
        close_json(&s.vec, "fused Pf", c->Pf.data, n * n, at(fused, "Pf", j), VEC_REL);
        close_json(&s.vec, "central xf", c->xf.data, n, at(cen, "xf", j), VEC_REL);
        close_json(&s.vec, "central Pf", c->Pf.data, n * n, at(cen, "Pf", j), VEC_REL);
        close_json(&s.vec, "central z", c->z.data, sc.ps, at(cen, "z", j), VEC_REL);
        close_json(&s.vec, "central dz", c->dz.data, sc.ps, at(cen, "dz", j), VEC_REL);
        close_json(&s.vec, "central K", c->K.data, n * sc.ps, at(cen, "K", j), VEC_REL);
        close_real(&s.fused, "fused vs CDKF xf", c->xf.data, w.cen.xf.data, n, FUSED_REL);
        close_real(&s.fused, "fused vs CDKF Pf", c->Pf.data, w.cen.Pf.data, n * n, FUSED_REL);
        close_real(&s.fused, "fused vs CDKF xp", c->xn.data, w.cen.xn.data, n, FUSED_REL);
        close_real(&s.fused, "fused vs CDKF Pp", c->Pn.data, w.cen.Pn.data, n * n, FUSED_REL);
        close_real(&s.fused, "fused vs CDKF z", c->z.data, w.cen.z.data, sc.ps, FUSED_REL);
    }
    print_message("%s: N=%zu l=%zu | vs vectors %.3e | fused vs centralized DKF %.3e | "
                  "recovered vs node z/dz %.3e | replica carry vs recovered dz %.3e\n",
                  file, sc.N, sc.l, s.vec, s.fused, s.zloc, s.carry);
    json_decref(sc.root);
}

/* The vector scenarios, one test each (FC_VECTOR_TEST in main):
 *  - diffkf/ex3_multi.json: the paper's Example 3;
 *  - own scenarios (tools/make_diffkf_vectors.py): tv3_multi.json, 3 sensors,
 *    n=5, (m,p) = (3,2),(2,2),(4,1); tv4_multi.json, 4 sensors, n=3,
 *    (1,1),(2,1),(3,2),(2,2), time-varying F and Q; both with time-varying
 *    H and A, B != I, local priors != central;
 *  - cond6_multi.json: the paper's condition for its (30)-(36) holds here
 *    (every H^i and the stacked H, 5 x 6, of full row rank;
 *    docs/design/diffkf-fusion.md §10): the general centre is exact there
 *    too, so no second centre is chosen for it. 3 sensors, n = 6, (m,p) =
 *    (2,1),(2,2),(1,1), time-varying F, Q, H, A and B. */
static void test_fc_vector(void **state)
{
    run_scenario((const char *)*state);
}
#define FC_VECTOR_TEST(name, file) {#name, test_fc_vector, NULL, NULL, (void *)(file)}

/* ---- stacking helpers -------------------------------------------------------- */

static void test_stack_helpers(void **state)
{
    /* sensor 0: m=2, p=1; sensor 1: m=1, p=1; n = 2 */
    dkf_real_t H0[] = {1, 2, 3, 4}, A0[] = {5, 6}, R0[] = {7, 8, 8, 9};
    dkf_real_t H1[] = {10, 11}, A1[] = {12}, R1[] = {13};
    dkf_real_t B0[] = {14}, B1[] = {15}, Rd0[] = {16}, Rd1[] = {17};
    dkf_mat_t mH0 = DKF_MAT(2, 2, H0), mA0 = DKF_MAT(2, 1, A0), mR0 = DKF_MAT(2, 2, R0);
    dkf_mat_t mH1 = DKF_MAT(1, 2, H1), mA1 = DKF_MAT(1, 1, A1), mR1 = DKF_MAT(1, 1, R1);
    dkf_mat_t mB0 = DKF_MAT(1, 1, B0), mB1 = DKF_MAT(1, 1, B1);
    dkf_mat_t mRd0 = DKF_MAT(1, 1, Rd0), mRd1 = DKF_MAT(1, 1, Rd1);
    dkf_ui_meas_t s0 = {&mH0, &mA0, &mR0}, s1 = {&mH1, &mA1, &mR1};
    const dkf_ui_meas_t *meas[2] = {&s0, &s1};
    const dkf_mat_t *Bi[2] = {&mB0, &mB1}, *Rdi[2] = {&mRd0, &mRd1};
    dkf_real_t H[6], A[6], R[9], B[4], Rd[4], snap[9];
    dkf_mat_t mH = DKF_MAT(3, 2, H), mA = DKF_MAT(3, 2, A), mR = DKF_MAT(3, 3, R);
    dkf_mat_t mB = DKF_MAT(2, 2, B), mRd = DKF_MAT(2, 2, Rd), bad = DKF_MAT(3, 3, R);
    const double eH[] = {1, 2, 3, 4, 10, 11}, eA[] = {5, 0, 6, 0, 0, 12};
    const double eR[] = {7, 8, 0, 8, 9, 0, 0, 0, 13}, eB[] = {14, 0, 0, 15}, eRd[] = {16, 0, 0, 17};
    double w = 0;
    (void)state;
    test_fill(A, 6, DKF_R(-1.0));
    test_fill(R, 9, DKF_R(-1.0));
    assert_int_equal(dkf_diffkf_stack_meas(&mH, &mA, &mR, meas, 2), DKF_OK);
    assert_int_equal(dkf_diffkf_stack_input(&mB, &mRd, Bi, Rdi, 2), DKF_OK);
    close_to(&w, "H", H, eH, 6, 0.0);
    close_to(&w, "A", A, eA, 6, 0.0);
    close_to(&w, "R", R, eR, 9, 0.0);
    close_to(&w, "B", B, eB, 4, 0.0);
    close_to(&w, "Rd", Rd, eRd, 4, 0.0);
    /* wrong output shape (A must be 3 x 2): nothing written */
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_diffkf_stack_meas(&mH, &bad, &mR, meas, 2), R, 9);
    /* inconsistent inputs: H^1 with 3 columns */
    mH1.cols = 3;
    mH1.rows = 1;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_diffkf_stack_meas(&mH, &mA, &mR, meas, 2), H, 6);
    /* B^i / Rd^i of different sizes */
    mRd1.rows = 2;
    mRd1.cols = 2;
    TEST_FAILS_UNTOUCHED(snap, DKF_ERR_DIM, dkf_diffkf_stack_input(&mB, &mRd, Bi, Rdi, 2), B, 4);
    /* an output aliasing an input */
    mRd1.rows = mRd1.cols = 1;
    {
        dkf_real_t big[4] = {0, 0, 0, 15};
        dkf_mat_t in1 = DKF_MAT(1, 1, big + 3), alias = DKF_MAT(2, 2, big);
        const dkf_mat_t *Ba[2] = {&mB0, &in1};
        assert_int_equal(dkf_diffkf_stack_input(&alias, NULL, Ba, NULL, 2),
                         DKF_DEBUG_CHECKS ? DKF_ERR_ALIAS : DKF_OK);
    }
}

/* ---- a small hand-built model for the condition tests ----------------------- */

/* n = 4 (constant velocity in 2-D, as ex3), sensors of (m, p) given; H^i
 * random, A^i = [I; random], B^i = 0.9 I, R^i = Rd^i = I; data random
 * (the filters do not care where y comes from). */
#define HN 4
#define HL 3
#define HM 3
#define HP 2
#define H_FC_LEN DKF_DIFFKF_FC_STORAGE_MAX(HN, HL, HM, HP)
#define H_LOC_LEN DKF_DIFFKF_STORAGE_LEN(HN, HM, HP)

typedef struct {
    size_t l, m[HL], p[HL];
    dkf_real_t F[16], Q[16], x0[4], P0[16];
    dkf_real_t H[HL][HM * HN], A[HL][HM * HP], R[HL][HM * HM], B[HL][HP * HP], Rd[HL][HP * HP];
    dkf_mat_t mF, mQ, mx0, mP0, mH[HL], mA[HL], mR[HL], mB[HL], mRd[HL];
    dkf_diffkf_sensor_t sens[HL];
    dkf_ui_dyn_t dyn[HL];
} hmodel_t;

static void hmodel(hmodel_t *h, size_t l, const size_t *m, const size_t *p, uint64_t seed)
{
    test_rng_t rng;
    double tmp[HM * HN];
    size_t i, r, c;
    const dkf_real_t F[16] = {1, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1};
    const dkf_real_t Q[16] = {5, 0, 0, 0, 0, DKF_R(0.1), 0, 0, 0, 0, 5, 0, 0, 0, 0, DKF_R(0.1)};
    memset(h, 0, sizeof *h);
    test_rng_seed(&rng, seed);
    h->l = l;
    memcpy(h->F, F, sizeof F);
    memcpy(h->Q, Q, sizeof Q);
    for (i = 0; i < 4; ++i) h->x0[i] = DKF_R(10.0) * (dkf_real_t)i, h->P0[i * 5] = 1;
    h->mF = test_view(4, 4, h->F);
    h->mQ = test_view(4, 4, h->Q);
    h->mx0 = test_view(4, 1, h->x0);
    h->mP0 = test_view(4, 4, h->P0);
    for (i = 0; i < l; ++i) {
        h->m[i] = m[i];
        h->p[i] = p[i];
        test_rand_gauss(&rng, tmp, m[i], HN);
        test_to_real(h->H[i], tmp, m[i] * HN);
        test_rand_gauss(&rng, tmp, m[i], p[i]);
        test_to_real(h->A[i], tmp, m[i] * p[i]);
        for (r = 0; r < p[i]; ++r)
            for (c = 0; c < p[i]; ++c) h->A[i][r * p[i] + c] = r == c ? 1 : 0;
        for (r = 0; r < m[i]; ++r) h->R[i][r * m[i] + r] = 1;
        for (r = 0; r < p[i]; ++r) h->B[i][r * p[i] + r] = DKF_R(0.9), h->Rd[i][r * p[i] + r] = 1;
        h->mH[i] = test_view(m[i], HN, h->H[i]);
        h->mA[i] = test_view(m[i], p[i], h->A[i]);
        h->mR[i] = test_view(m[i], m[i], h->R[i]);
        h->mB[i] = test_view(p[i], p[i], h->B[i]);
        h->mRd[i] = test_view(p[i], p[i], h->Rd[i]);
        h->sens[i].B = &h->mB[i];
        h->sens[i].Rd = &h->mRd[i];
        h->sens[i].meas.H = &h->mH[i];
        h->sens[i].meas.D = &h->mA[i];
        h->sens[i].meas.R = &h->mR[i];
        h->dyn[i].F = &h->mF;
        h->dyn[i].Q = &h->mQ;
        h->dyn[i].B = &h->mB[i];
        h->dyn[i].Rd = &h->mRd[i];
    }
}

typedef struct {
    hmodel_t h;
    dkf_diffkf_fc_t fc;
    dkf_diffkf_fc_node_t nodes[HL];
    dkf_real_t store[H_FC_LEN];
    dkf_diffkf_t loc[HL];
    dkf_real_t loc_store[HL][H_LOC_LEN];
    dkf_diffkf_msg_t msgs[HL];
    test_rng_t rng;
} hworld_t;

/* Node i's measurement, m_i N(0, 1) draws from w's rng, in y; its view. */
static dkf_mat_t h_draw_y(hworld_t *w, size_t i, dkf_real_t *y)
{
    double tmp[HM];
    test_rand_gauss(&w->rng, tmp, w->h.m[i], 1);
    test_to_real(y, tmp, w->h.m[i]);
    return test_view(w->h.m[i], 1, y);
}

static void h_start(hworld_t *w)
{
    dkf_diffkf_fc_fault_t fault;
    dkf_real_t y[HM];
    size_t i;
    for (i = 0; i < w->h.l; ++i) {
        dkf_mat_t my = h_draw_y(w, i, y);
        assert_int_equal(dkf_diffkf_init(&w->loc[i], HN, w->h.m[i], w->h.p[i], w->loc_store[i],
                                         H_LOC_LEN, &w->h.mx0, &w->h.mP0),
                         DKF_OK);
        assert_int_equal(dkf_diffkf_start(&w->loc[i], &w->h.mF, &w->h.mQ, &w->h.sens[i].meas, &my),
                         DKF_OK);
    }
    assert_int_equal(dkf_diffkf_fc_init(&w->fc, w->nodes, w->h.l, HN, w->h.m, w->h.p, w->store,
                                        H_FC_LEN, &w->h.mx0, &w->h.mP0, NULL, &fault),
                     DKF_OK);
    assert_int_equal(dkf_diffkf_fc_start(&w->fc, &w->h.mF, &w->h.mQ, w->h.sens, &fault), DKF_OK);
}

/* w on hmodel(l, m, p, model_seed), its rng seeded with rng_seed, started. */
static void h_world(hworld_t *w, size_t l, const size_t *m, const size_t *p, uint64_t model_seed,
                    uint64_t rng_seed)
{
    hmodel(&w->h, l, m, p, model_seed);
    test_rng_seed(&w->rng, rng_seed);
    h_start(w);
}

/* Every node steps on fresh random data and writes its message. */
static void h_nodes_step(hworld_t *w)
{
    dkf_real_t y[HM];
    size_t i;
    for (i = 0; i < w->h.l; ++i) {
        dkf_mat_t my = h_draw_y(w, i, y);
        assert_int_equal(dkf_diffkf_step(&w->loc[i], &w->h.dyn[i], &w->h.sens[i].meas, &my),
                         DKF_OK);
        assert_int_equal(dkf_diffkf_msg_fill(&w->msgs[i], (uint16_t)i, &w->loc[i]), DKF_OK);
    }
}

static dkf_status_t h_fc_step(hworld_t *w, dkf_diffkf_fc_fault_t *fault)
{
    return dkf_diffkf_fc_step(&w->fc, &w->h.mF, &w->h.mQ, w->h.sens, w->msgs, fault);
}

/* What "the FC state" is: the FC and node structs, every replica's storage
 * (restored in full), the central filter's committed estimates and carry
 * (its struct, its output views), and the recovered z/dz. */
typedef struct {
    dkf_diffkf_fc_t fc;
    dkf_diffkf_fc_node_t nodes[HL];
    dkf_real_t store[H_FC_LEN];
} fc_snap_t;

static void snap_take(fc_snap_t *s, const hworld_t *w)
{
    s->fc = w->fc;
    memcpy(s->nodes, w->nodes, sizeof w->nodes);
    memcpy(s->store, w->store, sizeof w->store);
}

static void assert_view_same(const dkf_mat_t *v, const fc_snap_t *s, const hworld_t *w)
{
    const size_t off = (size_t)(v->data - w->store);
    assert_memory_equal(v->data, s->store + off, v->rows * v->cols * sizeof(dkf_real_t));
}

static void assert_state_same(const fc_snap_t *s, const hworld_t *w)
{
    const dkf_diffkf_t *c = &w->fc.central;
    size_t i;
    assert_memory_equal(&s->fc, &w->fc, sizeof w->fc);
    assert_memory_equal(s->nodes, w->nodes, sizeof w->nodes);
    for (i = 0; i < w->h.l; ++i) {
        const size_t off = (size_t)(w->nodes[i].priv.store - w->store);
        assert_memory_equal(w->nodes[i].priv.store, s->store + off,
                            w->nodes[i].priv.store_len * sizeof(dkf_real_t));
        assert_view_same(&w->nodes[i].z, s, w);
        assert_view_same(&w->nodes[i].dz, s, w);
    }
    assert_view_same(&c->xf, s, w);
    assert_view_same(&c->Pf, s, w);
    assert_view_same(&c->xn, s, w);
    assert_view_same(&c->Pn, s, w);
    assert_view_same(&c->z, s, w);
    assert_view_same(&c->dz, s, w);
    assert_view_same(&c->J, s, w);
    assert_view_same(&c->L, s, w);
    assert_view_same(&c->K, s, w);
    assert_view_same(&c->xp, s, w);
}

/* ---- set-up conditions -------------------------------------------------------- */

static dkf_status_t try_init(hworld_t *w, size_t l, const size_t *m, const size_t *p, size_t len,
                             const dkf_mat_t *const P0l[], dkf_diffkf_fc_fault_t *fault)
{
    return dkf_diffkf_fc_init(&w->fc, w->nodes, l, HN, m, p, w->store, len, &w->h.mx0, &w->h.mP0,
                              P0l, fault);
}

static void expect_fault(const dkf_diffkf_fc_fault_t *f, dkf_diffkf_fc_cond_t which, size_t node)
{
    assert_int_equal(f->which, which);
    assert_int_equal(f->node, node);
}

static void test_fc_setup_conditions(void **state)
{
    static hworld_t w;
    static dkf_diffkf_fc_t fc_snap;
    static dkf_diffkf_fc_node_t nodes_snap[HL];
    const size_t m[3] = {3, 2, 2}, p[3] = {2, 1, 2};
    size_t mm[3], pp[3];
    dkf_diffkf_fc_fault_t f;
    dkf_real_t bad[16] = {1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    dkf_mat_t mbad = DKF_MAT(4, 4, bad);
    const dkf_mat_t *P0l[3] = {NULL, &mbad, NULL};
    (void)state;
    hmodel(&w.h, 3, m, p, 11);
    memset(&w.fc, 0x5a, sizeof w.fc);
    memset(w.nodes, 0x5a, sizeof w.nodes);
    fc_snap = w.fc;
    memcpy(nodes_snap, w.nodes, sizeof w.nodes);

    /* p_i > n: z^i (p_i numbers) cannot be rebuilt from n-vectors */
    memcpy(mm, m, sizeof mm);
    memcpy(pp, p, sizeof pp);
    mm[2] = 6;
    pp[2] = 5;
    assert_int_equal(try_init(&w, 3, mm, pp, H_FC_LEN, NULL, &f), DKF_ERR_RANK);
    expect_fault(&f, DKF_DIFFKF_FC_INPUT_DIM, 2);
    /* p_i > m_i: A^i cannot have full column rank */
    memcpy(mm, m, sizeof mm);
    memcpy(pp, p, sizeof pp);
    pp[1] = 3;
    assert_int_equal(try_init(&w, 3, mm, pp, H_FC_LEN, NULL, &f), DKF_ERR_RANK);
    expect_fault(&f, DKF_DIFFKF_FC_INPUT_MEAS, 1);
    /* stacked dimensions above DKF_MAX_DIM */
    mm[0] = mm[1] = mm[2] = DKF_MAX_DIM / 2 + 1;
    pp[0] = pp[1] = pp[2] = 1;
    assert_int_equal(try_init(&w, 3, mm, pp, H_FC_LEN, NULL, &f), DKF_ERR_CAPACITY);
    expect_fault(&f, DKF_DIFFKF_FC_STACK_CAPACITY, DKF_DIFFKF_FC_NO_NODE);
    /* storage one real short */
    assert_int_equal(try_init(&w, 3, m, p, dkf_diffkf_fc_storage_len(HN, 3, m, p) - 1, NULL, &f),
                     DKF_ERR_CAPACITY);
    expect_fault(&f, DKF_DIFFKF_FC_STORAGE, DKF_DIFFKF_FC_NO_NODE);
    /* node 1's prior covariance is not SPD */
    assert_int_equal(try_init(&w, 3, m, p, H_FC_LEN, P0l, &f), DKF_ERR_NOT_SPD);
    expect_fault(&f, DKF_DIFFKF_FC_PRIOR, 1);
    /* no failed init touched the FC or the node array */
    assert_memory_equal(&fc_snap, &w.fc, sizeof w.fc);
    assert_memory_equal(nodes_snap, w.nodes, sizeof w.nodes);

    /* start: A^1_1 of rank 1 < p_1 = 1? use sensor 2 (p = 2): columns equal */
    assert_int_equal(try_init(&w, 3, m, p, H_FC_LEN, NULL, &f), DKF_OK);
    {
        static fc_snap_t s;
        dkf_real_t keep[HM * HP];
        size_t r;
        memcpy(keep, w.h.A[2], sizeof keep);
        for (r = 0; r < m[2]; ++r) w.h.A[2][r * 2 + 1] = w.h.A[2][r * 2];
        snap_take(&s, &w);
        assert_int_equal(dkf_diffkf_fc_start(&w.fc, &w.h.mF, &w.h.mQ, w.h.sens, &f), DKF_ERR_RANK);
        expect_fault(&f, DKF_DIFFKF_FC_D_RANK, 2);
        assert_state_same(&s, &w);
        memcpy(w.h.A[2], keep, sizeof keep);
        /* B^0_1 singular */
        w.h.B[0][3] = 0;
        assert_int_equal(dkf_diffkf_fc_start(&w.fc, &w.h.mF, &w.h.mQ, w.h.sens, &f),
                         DKF_ERR_SINGULAR);
        expect_fault(&f, DKF_DIFFKF_FC_B_SINGULAR, 0);
        assert_state_same(&s, &w);
        w.h.B[0][3] = DKF_R(0.9);
        /* a misshaped model matrix names its node */
        w.h.mR[1].rows = 1;
        assert_int_equal(dkf_diffkf_fc_start(&w.fc, &w.h.mF, &w.h.mQ, w.h.sens, &f), DKF_ERR_DIM);
        expect_fault(&f, DKF_DIFFKF_FC_MODEL, 1);
        w.h.mR[1].rows = 2;
        /* a step before start is out of sequence */
        assert_int_equal(dkf_diffkf_fc_step(&w.fc, &w.h.mF, &w.h.mQ, w.h.sens, w.msgs, &f),
                         DKF_ERR_STATE);
        expect_fault(&f, DKF_DIFFKF_FC_SEQUENCE, DKF_DIFFKF_FC_NO_NODE);
        assert_int_equal(dkf_diffkf_fc_start(&w.fc, &w.h.mF, &w.h.mQ, w.h.sens, &f), DKF_OK);
        assert_int_equal(dkf_diffkf_fc_start(&w.fc, &w.h.mF, &w.h.mQ, w.h.sens, &f), DKF_ERR_STATE);
        expect_fault(&f, DKF_DIFFKF_FC_SEQUENCE, DKF_DIFFKF_FC_NO_NODE);
    }
}

/* ---- per-step conditions and atomicity ---------------------------------------- */

/* A twin FC that never sees the failures: after every failed call on w the
 * correct call must give bit-identical results on both. */
static void assert_twins_equal(const hworld_t *a, const hworld_t *b)
{
    const dkf_diffkf_t *x = &a->fc.central, *y = &b->fc.central;
    assert_memory_equal(x->xf.data, y->xf.data, a->fc.n * sizeof(dkf_real_t));
    assert_memory_equal(x->Pf.data, y->Pf.data, a->fc.n * a->fc.n * sizeof(dkf_real_t));
    assert_memory_equal(x->xn.data, y->xn.data, a->fc.n * sizeof(dkf_real_t));
    assert_memory_equal(x->Pn.data, y->Pn.data, a->fc.n * a->fc.n * sizeof(dkf_real_t));
    assert_memory_equal(x->z.data, y->z.data, a->fc.ps * sizeof(dkf_real_t));
}

static void test_fc_message_validation_and_atomicity(void **state)
{
    static hworld_t w, twin;
    static fc_snap_t s;
    const size_t m[3] = {3, 2, 2}, p[3] = {2, 1, 2};
    dkf_diffkf_fc_fault_t f;
    dkf_diffkf_msg_t keep;
    size_t k;
    (void)state;
    h_world(&w, 3, m, p, 21, 5);
    /* the twin is built the same way (its views point into its own storage) */
    h_world(&twin, 3, m, p, 21, 5);
    for (k = 1; k <= 6; ++k) {
        h_nodes_step(&w);
        h_nodes_step(&twin);
        if (k == 4) {
            snap_take(&s, &w);
            /* wrong node id, wrong step (replay and skip), wrong n, NaN, Inf */
            keep = w.msgs[1];
            w.msgs[1].node = 2;
            assert_int_equal(h_fc_step(&w, &f), DKF_ERR_ARG);
            expect_fault(&f, DKF_DIFFKF_FC_MSG_NODE, 1);
            w.msgs[1] = keep;
            w.msgs[2].k = (uint32_t)(k - 1);
            assert_int_equal(h_fc_step(&w, &f), DKF_ERR_STATE);
            expect_fault(&f, DKF_DIFFKF_FC_MSG_STEP, 2);
            w.msgs[2].k = (uint32_t)(k + 1);
            assert_int_equal(h_fc_step(&w, &f), DKF_ERR_STATE);
            expect_fault(&f, DKF_DIFFKF_FC_MSG_STEP, 2);
            w.msgs[2].k = (uint32_t)k;
            w.msgs[0].n = HN - 1;
            assert_int_equal(h_fc_step(&w, &f), DKF_ERR_DIM);
            expect_fault(&f, DKF_DIFFKF_FC_MSG_DIM, 0);
            w.msgs[0].n = HN;
            keep = w.msgs[2];
            w.msgs[2].xp[3] = (dkf_real_t)NAN;
            assert_int_equal(h_fc_step(&w, &f), DKF_ERR_NONFINITE);
            expect_fault(&f, DKF_DIFFKF_FC_MSG_NONFINITE, 2);
            w.msgs[2] = keep;
            w.msgs[2].xf[0] = (dkf_real_t)INFINITY;
            assert_int_equal(h_fc_step(&w, &f), DKF_ERR_NONFINITE);
            expect_fault(&f, DKF_DIFFKF_FC_MSG_NONFINITE, 2);
            w.msgs[2] = keep;
            /* message failures are found before anything is computed: the
             * whole storage is untouched */
            assert_memory_equal(s.store, w.store, sizeof w.store);
            assert_state_same(&s, &w);

            /* model failures in the middle of a step: replica 0's gain has
             * run when replica 1's A_{k+1} (rank) or B_k (singular) fails */
            {
                dkf_real_t a0 = w.h.A[1][1];
                w.h.A[1][1] = 0;
                w.h.A[1][0] = 0; /* A^1 (2 x 1) = 0 */
                assert_int_equal(h_fc_step(&w, &f), DKF_ERR_RANK);
                expect_fault(&f, DKF_DIFFKF_FC_D_RANK, 1);
                assert_state_same(&s, &w);
                w.h.A[1][0] = 1;
                w.h.A[1][1] = a0;
                w.h.B[2][0] = 0;
                w.h.B[2][1] = 0; /* B^2 first row 0 */
                assert_int_equal(h_fc_step(&w, &f), DKF_ERR_SINGULAR);
                expect_fault(&f, DKF_DIFFKF_FC_B_SINGULAR, 2);
                assert_state_same(&s, &w);
                w.h.B[2][0] = DKF_R(0.9);
                /* overflow in the recovery of node 2 (finite but huge x) */
                keep = w.msgs[2];
                w.msgs[2].xf[0] = DKF_REAL_MAX;
                w.msgs[2].xp[0] = -DKF_REAL_MAX;
                assert_int_equal(h_fc_step(&w, &f), DKF_ERR_NONFINITE);
                expect_fault(&f, DKF_DIFFKF_FC_NONFINITE, 2);
                assert_state_same(&s, &w);
                w.msgs[2] = keep;
            }
        }
        assert_int_equal(h_fc_step(&w, &f), DKF_OK);
        assert_int_equal(h_fc_step(&twin, &f), DKF_OK);
        assert_twins_equal(&w, &twin);
    }
}

/* rank K^i_k < p_i at step 4: from k = 4 on, sensor 1 sees nothing (H^1 = 0)
 * and its noise vanishes (R^1 = 0), so M^1 = 0 and C^1 = 0, hence J^1 = 0:
 * its innovation never reaches x^1 and cannot be recovered. The node's own
 * filter runs on (L^1 = B^{-1} Rd B^{-T} > 0). */
static void test_fc_step_rank_failure(void **state)
{
    static hworld_t w;
    static fc_snap_t s;
    const size_t m[2] = {2, 2}, p[2] = {2, 2};
    dkf_diffkf_fc_fault_t f;
    size_t k;
    (void)state;
    h_world(&w, 2, m, p, 31, 9);
    for (k = 1; k <= 4; ++k) {
        if (k == 3) {
            /* the model at k + 1 = 4 (used by step 3) and from then on */
            memset(w.h.H[1], 0, sizeof w.h.H[1]);
            memset(w.h.R[1], 0, sizeof w.h.R[1]);
        }
        h_nodes_step(&w);
        if (k < 4) {
            assert_int_equal(h_fc_step(&w, &f), DKF_OK);
            continue;
        }
        snap_take(&s, &w);
        assert_int_equal(h_fc_step(&w, &f), DKF_ERR_RANK);
        expect_fault(&f, DKF_DIFFKF_FC_K_RANK, 1);
        assert_state_same(&s, &w);
        /* the local filter itself is fine: its K is 0 */
        assert_true(test_max_abs_diff(w.loc[1].K.data, (const double[8]){0}, 8) == 0.0);
    }
}

static void test_msg_fill_checks(void **state)
{
    static hworld_t w;
    const size_t m[1] = {2}, p[1] = {2};
    dkf_diffkf_msg_t msg;
    (void)state;
    hmodel(&w.h, 1, m, p, 41);
    test_rng_seed(&w.rng, 3);
    assert_int_equal(dkf_diffkf_msg_fill(&msg, 0, &w.loc[0]), DKF_ERR_STATE); /* zeroed struct */
    h_start(&w);
    assert_int_equal(dkf_diffkf_msg_fill(&msg, 0, &w.loc[0]), DKF_ERR_STATE); /* before a step */
    {
        dkf_real_t xp_before[HN];
        memcpy(xp_before, w.loc[0].xn.data, sizeof xp_before);
        h_nodes_step(&w);
        assert_int_equal(w.msgs[0].k, 1);
        /* x_{k|k-1} is the prediction the step started from, bit for bit */
        assert_memory_equal(w.msgs[0].xp, xp_before, sizeof xp_before);
        assert_memory_equal(w.msgs[0].xf, w.loc[0].xf.data, sizeof xp_before);
    }
}

/* ---- degraded steps: absent messages, restarts, checkpoints ------------------ */

/* The model of step k (F_k, Q_k, sensors at k+1) and the stacked model,
 * without stepping the nodes (for replays). */
static void load_model(world_t *w, const scen_t *sc, size_t k)
{
    load_step(&w->sm, sc->model, sc->l, k, k + 1);
    stack(&w->st, &w->sm, sc->l, sc->n, sc->ms, sc->ps);
}

/* The reference: the centralized DKF run directly on the stacked data
 * (each node's own z^i_k, computed from its y), given exactly the rows the
 * FC says entered its step. Independent of the recovery. */
static void ref_masked_step(world_t *w, const scen_t *sc, const unsigned char *contributed)
{
    unsigned char rows[PS] = {0};
    dkf_real_t zk[PS] = {0};
    dkf_mat_t zv;
    size_t i, j, off = 0, pk = 0;
    for (i = 0; i < sc->l; ++i)
        for (j = 0; j < sc->p[i]; ++j, ++off) {
            rows[off] = contributed[i];
            if (contributed[i]) zk[pk++] = w->loc[i].z.data[j];
        }
    assert_int_equal(dkf_diffkf_gain_masked(&w->cen, &w->st.dyn, &w->st.meas, rows), DKF_OK);
    zv = test_view(pk, 1, zk);
    assert_int_equal(dkf_diffkf_update_z(&w->cen, pk > 0 ? &zv : NULL, NULL), DKF_OK);
}

static void fused_vs_ref(world_t *w, size_t n, double *worst)
{
    const dkf_diffkf_t *c = &w->fc.central;
    close_real(worst, "degraded fused xf", c->xf.data, w->cen.xf.data, n, FUSED_REL);
    close_real(worst, "degraded fused Pf", c->Pf.data, w->cen.Pf.data, n * n, FUSED_REL);
    close_real(worst, "degraded fused xp", c->xn.data, w->cen.xn.data, n, FUSED_REL);
    close_real(worst, "degraded fused Pp", c->Pn.data, w->cen.Pn.data, n * n, FUSED_REL);
    assert_int_equal(c->pk, w->cen.pk);
}

/* Restarts node j's local filter at k (dkf_diffkf_init with its P00_local
 * prior and an arbitrary x, start at k with F0 = Q0 = NULL, absolute
 * time), and the FC's replica likewise. */
static void restart_node(world_t *w, const scen_t *sc, size_t j, size_t k)
{
    const json_t *init = test_json_get(sc->root, "init");
    dkf_real_t Pl[CAP], xa[NX];
    dkf_mat_t mPl, xv;
    dkf_diffkf_fc_fault_t fault;
    size_t i;
    test_json_mat(at(init, "P00_local", j), Pl, CAP, &mPl);
    for (i = 0; i < sc->n; ++i) xa[i] = (dkf_real_t)(17.0 * (double)i - 3.0); /* any x */
    xv = test_view(sc->n, 1, xa);
    load_step(&w->sm, sc->model, sc->l, k, k); /* the sensors' models at k */
    load_y(w, sc, k);
    {
        dkf_mat_t y = test_view(sc->m[j], 1, w->ys[j]);
        assert_int_equal(dkf_diffkf_init(&w->loc[j], sc->n, sc->m[j], sc->p[j], w->loc_store[j],
                                         LOC_LEN, &xv, &mPl),
                         DKF_OK);
        assert_int_equal(dkf_diffkf_start(&w->loc[j], NULL, NULL, &w->sm.sensors[j].meas, &y),
                         DKF_OK);
        assert_int_equal(dkf_diffkf_set_time(&w->loc[j], k - 1), DKF_OK);
    }
    assert_int_equal(dkf_diffkf_fc_restart_node(&w->fc, j, k, &mPl, &w->sm.sensors[j], &fault),
                     DKF_OK);
    assert_int_equal(fault.which, DKF_DIFFKF_FC_NO_FAULT);
    assert_int_equal(w->nodes[j].sync, 1);
}

/* One scenario with messages absent at random (each with probability
 * 0.3; step 5 loses every message, step 6 none), optionally with node
 * `rj` absent for steps ra..rb and restarted at rb + 1 (ra = 1: a late
 * node). Every step: fused = the centralized DKF on the stacked data with
 * the FC's contributed masks, and contributed follows the sync rule. */
static double run_degraded(const char *file, uint64_t seed, size_t rj, size_t ra, size_t rb)
{
    static world_t w;
    scen_t sc;
    test_rng_t rng;
    unsigned char present[NL], contributed[NL], prev[NL];
    double worst = 0;
    size_t j, i, lost = 0, masked = 0;
    open_scen(&sc, file);
    start_world(&w, &sc);
    test_rng_seed(&rng, seed);
    memset(prev, 1, sizeof prev);
    for (j = 0; j < sc.N; ++j) {
        const size_t k = j + 1;
        dkf_diffkf_fc_fault_t fault;
        if (rb > 0 && k == rb + 1) restart_node(&w, &sc, rj, k);
        nodes_step(&w, &sc, k);
        for (i = 0; i < sc.l; ++i) {
            present[i] = (unsigned char)(k == 6 || (k != 5 && test_rng_uniform(&rng) >= 0.3));
            if (rb > 0 && i == rj && k >= ra && k <= rb) present[i] = 0;
            if (rb > 0 && i == rj && k == rb + 1) present[i] = 1; /* its first message */
            if (!present[i]) {
                /* an absent message is ignored, whatever it holds */
                w.msgs[i].xf[0] = (dkf_real_t)NAN;
                w.msgs[i].k = 12345;
                ++lost;
            }
        }
        memset(contributed, 0x77, sizeof contributed);
        assert_int_equal(dkf_diffkf_fc_step_partial(&w.fc, &w.sm.mF, &w.sm.mQ, w.sm.sensors,
                                                    w.msgs, present, contributed, &fault),
                         DKF_OK);
        assert_int_equal(w.fc.k, k);
        for (i = 0; i < sc.l; ++i) {
            const int restarted = rb > 0 && i == rj && k == rb + 1;
            assert_int_equal(contributed[i], present[i] && (prev[i] || restarted));
            assert_int_equal(w.nodes[i].sync, present[i]);
            masked += !contributed[i];
            prev[i] = present[i];
        }
        ref_masked_step(&w, &sc, contributed);
        fused_vs_ref(&w, sc.n, &worst);
    }
    print_message("%s seed %llu: %zu messages lost, %zu node-steps masked, fused vs "
                  "centralized DKF given the data received %.3e\n",
                  file, (unsigned long long)seed, lost, masked, worst);
    assert_true(masked > lost); /* the sync rule masked more than the losses */
    json_decref(sc.root);
    return worst;
}

static void test_fc_partial_random_absent(void **state)
{
    (void)state;
    run_degraded("diffkf/ex3_multi.json", 31, 0, 0, 0);
    run_degraded("diffkf/tv3_multi.json", 32, 0, 0, 0);
    run_degraded("diffkf/tv4_multi.json", 33, 0, 0, 0);
    run_degraded("diffkf/tv4_multi.json", 34, 0, 0, 0);
}

/* A node absent for steps a..b then restarted at b+1 with its P00_local
 * prior; a node that starts late (a = 1). */
static void test_fc_restart_and_late_node(void **state)
{
    (void)state;
    run_degraded("diffkf/ex3_multi.json", 41, 1, 7, 12);
    run_degraded("diffkf/tv3_multi.json", 42, 2, 4, 9);
    run_degraded("diffkf/tv3_multi.json", 43, 0, 1, 6); /* late */
    run_degraded("diffkf/tv4_multi.json", 44, 3, 1, 3); /* late */
}

/* Every node present: step_partial (with contributed) is bit-identical to
 * dkf_diffkf_fc_step, step by step, and contributes every node. */
static void test_fc_partial_all_present_bit_identical(void **state)
{
    static world_t a, b;
    scen_t sc;
    const unsigned char all[NL] = {1, 1, 1, 1};
    unsigned char contributed[NL];
    size_t j, i;
    (void)state;
    open_scen(&sc, "diffkf/tv3_multi.json");
    start_world(&a, &sc);
    start_world(&b, &sc);
    for (j = 0; j < sc.N; ++j) {
        dkf_diffkf_fc_fault_t fault;
        nodes_step(&a, &sc, j + 1);
        nodes_step(&b, &sc, j + 1);
        fc_step_ok(&a);
        assert_int_equal(dkf_diffkf_fc_step_partial(&b.fc, &b.sm.mF, &b.sm.mQ, b.sm.sensors,
                                                    b.msgs, j % 2 ? all : NULL, contributed,
                                                    &fault),
                         DKF_OK);
        for (i = 0; i < sc.l; ++i) assert_int_equal(contributed[i], 1);
        assert_memory_equal(a.fc.central.xf.data, b.fc.central.xf.data, sc.n * sizeof(dkf_real_t));
        assert_memory_equal(a.fc.central.Pf.data, b.fc.central.Pf.data,
                            sc.n * sc.n * sizeof(dkf_real_t));
        assert_memory_equal(a.fc.central.xn.data, b.fc.central.xn.data, sc.n * sizeof(dkf_real_t));
        assert_memory_equal(a.fc.central.Pn.data, b.fc.central.Pn.data,
                            sc.n * sc.n * sizeof(dkf_real_t));
        assert_memory_equal(a.fc.central.z.data, b.fc.central.z.data, sc.ps * sizeof(dkf_real_t));
    }
    json_decref(sc.root);
}

/* Checkpoints: a round trip restores the FC bit for bit; a rollback and a
 * replay with the payload that was missing turns a degraded history into
 * the full-data one (the vectors, <= VEC_REL, and bit-identical to an FC
 * that never missed it). */
static void run_rollback(const char *file, size_t k0, size_t node)
{
    static world_t w, full;
    static dkf_real_t ck[FC_LEN], ck2[FC_LEN];
    static dkf_diffkf_msg_t saved[64][NL];
    scen_t sc;
    stats_t s = {0, 0, 0, 0};
    unsigned char present[NL];
    size_t j, i, len;
    dkf_diffkf_fc_fault_t fault;
    open_scen(&sc, file);
    assert_true(sc.N < 64 && k0 + 4 <= sc.N);
    start_world(&w, &sc);
    start_world(&full, &sc);
    len = dkf_diffkf_fc_checkpoint_len(&w.fc);
    assert_true(len > 0 && len <= FC_LEN);
    for (j = 0; j < sc.N; ++j) {
        const size_t k = j + 1;
        nodes_step(&full, &sc, k);
        fc_step_ok(&full);
        nodes_step(&w, &sc, k);
        memcpy(saved[k], w.msgs, sizeof w.msgs);
        if (k == k0) assert_int_equal(dkf_diffkf_fc_save(&w.fc, ck, len), DKF_OK);
        for (i = 0; i < sc.l; ++i) present[i] = (unsigned char)(k != k0 || i != node);
        assert_int_equal(dkf_diffkf_fc_step_partial(&w.fc, &w.sm.mF, &w.sm.mQ, w.sm.sensors,
                                                    w.msgs, present, NULL, &fault),
                         DKF_OK);
        if (k == k0 + 3) {
            /* degraded so far: not the full-data estimate */
            {
                double e[CAP];
                test_to_double(e, full.fc.central.Pf.data, sc.n * sc.n);
                assert_true(rel_err(w.fc.central.Pf.data, e, sc.n * sc.n) > 1e-6);
            }
            /* round trip: save now, restore, same bits */
            assert_int_equal(dkf_diffkf_fc_save(&w.fc, ck2, len), DKF_OK);
            assert_int_equal(dkf_diffkf_fc_restore(&w.fc, ck2, len), DKF_OK);
            assert_int_equal(w.fc.k, k);
            /* the missing payload arrives: roll back to before k0, replay */
            assert_int_equal(dkf_diffkf_fc_restore(&w.fc, ck, len), DKF_OK);
            assert_int_equal(w.fc.k, k0 - 1);
            for (i = k0; i <= k; ++i) {
                dkf_diffkf_fc_fault_t f2;
                load_model(&w, &sc, i);
                assert_int_equal(dkf_diffkf_fc_step_partial(&w.fc, &w.sm.mF, &w.sm.mQ,
                                                            w.sm.sensors, saved[i], NULL, NULL,
                                                            &f2),
                                 DKF_OK);
            }
        }
        if (k >= k0 + 3) {
            const json_t *fused = test_json_get(sc.out, "fused");
            const dkf_diffkf_t *c = &w.fc.central;
            close_json(&s.vec, "replayed xf", c->xf.data, sc.n, at(fused, "xf", j), VEC_REL);
            close_json(&s.vec, "replayed Pf", c->Pf.data, sc.n * sc.n, at(fused, "Pf", j), VEC_REL);
            assert_memory_equal(c->xf.data, full.fc.central.xf.data, sc.n * sizeof(dkf_real_t));
            assert_memory_equal(c->Pn.data, full.fc.central.Pn.data,
                                sc.n * sc.n * sizeof(dkf_real_t));
        }
    }
    print_message("%s: checkpoint %zu reals; rollback to %zu, replay with node %zu's message: "
                  "vs vectors %.3e (bit-identical to the full-data FC)\n",
                  file, len, k0 - 1, node, s.vec);
    json_decref(sc.root);
}

static void test_fc_checkpoint_rollback_replay(void **state)
{
    (void)state;
    run_rollback("diffkf/ex3_multi.json", 10, 1);
    run_rollback("diffkf/tv3_multi.json", 5, 1);
    run_rollback("diffkf/tv4_multi.json", 7, 2);
}

/* Failure atomicity of the new calls (the FC, node array, replica storage
 * and central views bit-identical; contributed untouched), and a twin
 * that never saw the failures steps identically afterwards. */
static void test_fc_degraded_atomicity(void **state)
{
    static hworld_t w, twin;
    static fc_snap_t s;
    static dkf_real_t ck[H_FC_LEN], bad[H_FC_LEN];
    const size_t m[3] = {3, 2, 2}, p[3] = {2, 1, 2};
    const unsigned char present[3] = {1, 0, 1};
    unsigned char contributed[3] = {9, 9, 9};
    dkf_real_t Pn[16] = {1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    dkf_mat_t mPn = DKF_MAT(4, 4, Pn);
    dkf_diffkf_fc_fault_t f;
    dkf_diffkf_msg_t keep;
    size_t len, r;
    (void)state;
    h_world(&w, 3, m, p, 61, 6);
    h_world(&twin, 3, m, p, 61, 6);
    h_nodes_step(&w);
    h_nodes_step(&twin);

    /* a present node's bad message: refused, nothing changed */
    keep = w.msgs[2];
    w.msgs[2].xp[1] = (dkf_real_t)INFINITY;
    snap_take(&s, &w);
    assert_int_equal(dkf_diffkf_fc_step_partial(&w.fc, &w.h.mF, &w.h.mQ, w.h.sens, w.msgs, present,
                                                contributed, &f),
                     DKF_ERR_NONFINITE);
    expect_fault(&f, DKF_DIFFKF_FC_MSG_NONFINITE, 2);
    assert_state_same(&s, &w);
    assert_int_equal(contributed[0], 9);
    w.msgs[2] = keep;
    /* an absent node's garbage is ignored */
    w.msgs[1].node = 7;
    assert_int_equal(dkf_diffkf_fc_step_partial(&w.fc, &w.h.mF, &w.h.mQ, w.h.sens, w.msgs, present,
                                                contributed, &f),
                     DKF_OK);
    assert_int_equal(dkf_diffkf_fc_step_partial(&twin.fc, &twin.h.mF, &twin.h.mQ, twin.h.sens,
                                                twin.msgs, present, NULL, &f),
                     DKF_OK);
    assert_twins_equal(&w, &twin);
    assert_int_equal(contributed[0], 1);
    assert_int_equal(contributed[1], 0);
    assert_int_equal(w.nodes[1].sync, 0);

    /* restart: wrong time, node, prior, rank; each refused untouched */
    snap_take(&s, &w);
    assert_int_equal(dkf_diffkf_fc_restart_node(&w.fc, 1, w.fc.k + 2, &w.h.mP0, &w.h.sens[1], &f),
                     DKF_ERR_STATE);
    expect_fault(&f, DKF_DIFFKF_FC_SEQUENCE, 1);
    assert_int_equal(dkf_diffkf_fc_restart_node(&w.fc, 3, w.fc.k + 1, &w.h.mP0, &w.h.sens[1], &f),
                     DKF_ERR_ARG);
    assert_int_equal(dkf_diffkf_fc_restart_node(&w.fc, 1, w.fc.k + 1, &mPn, &w.h.sens[1], &f),
                     DKF_ERR_NOT_SPD);
    expect_fault(&f, DKF_DIFFKF_FC_PRIOR, 1);
    for (r = 0; r < m[2]; ++r) w.h.A[2][r * 2 + 1] = w.h.A[2][r * 2];
    assert_int_equal(dkf_diffkf_fc_restart_node(&w.fc, 2, w.fc.k + 1, &w.h.mP0, &w.h.sens[2], &f),
                     DKF_ERR_RANK);
    expect_fault(&f, DKF_DIFFKF_FC_D_RANK, 2);
    assert_state_same(&s, &w);
    memcpy(w.h.A[2], twin.h.A[2], sizeof w.h.A[2]);

    /* restore: short, tag, dimension, non-finite: refused untouched */
    len = dkf_diffkf_fc_checkpoint_len(&w.fc);
    assert_int_equal(dkf_diffkf_fc_save(&w.fc, ck, len - 1), DKF_ERR_CAPACITY);
    assert_int_equal(dkf_diffkf_fc_save(&w.fc, ck, len), DKF_OK);
    snap_take(&s, &w);
    assert_int_equal(dkf_diffkf_fc_restore(&w.fc, ck, len - 1), DKF_ERR_CAPACITY);
    memcpy(bad, ck, len * sizeof(dkf_real_t));
    bad[0] = 1;
    assert_int_equal(dkf_diffkf_fc_restore(&w.fc, bad, len), DKF_ERR_ARG);
    memcpy(bad, ck, len * sizeof(dkf_real_t));
    bad[2] = 2;
    assert_int_equal(dkf_diffkf_fc_restore(&w.fc, bad, len), DKF_ERR_DIM);
    memcpy(bad, ck, len * sizeof(dkf_real_t));
    bad[len - 3] = (dkf_real_t)NAN;
    assert_int_equal(dkf_diffkf_fc_restore(&w.fc, bad, len), DKF_ERR_NONFINITE);
    memcpy(bad, ck, len * sizeof(dkf_real_t));
    bad[len / 2] = (dkf_real_t)NAN; /* inside a replica's state */
    assert_int_equal(dkf_diffkf_fc_restore(&w.fc, bad, len), DKF_ERR_NONFINITE);
    assert_state_same(&s, &w);

    /* the failures changed nothing: both step on identically */
    h_nodes_step(&w);
    h_nodes_step(&twin);
    assert_int_equal(h_fc_step(&w, &f), DKF_OK);
    assert_int_equal(h_fc_step(&twin, &f), DKF_OK);
    assert_twins_equal(&w, &twin);
    /* node 1 was out of sync: masked now, back at the next step */
    assert_int_equal(w.fc.central.pk, p[0] + p[2]);
    h_nodes_step(&w);
    assert_int_equal(h_fc_step(&w, &f), DKF_OK);
    assert_int_equal(w.fc.central.pk, p[0] + p[1] + p[2]);
}

/* Every condition has its own text, none of them the fallback; a value
 * past the enum gets the fallback (one table for every host program). */
/* ---- the steady gain (dkf_diffkf_set_steady, docs/design/diffkf-fusion.md §11) ---------
 *
 * STEADY_TOL, the setting: the relative change per step of P_{k+1|k}, W and
 * Vt at which the gain settles. The recursion converges geometrically and
 * then moves only by rounding (measured on bench_fc's model, double: P by
 * 7e-17 to 4e-16 relative per step, the carry by up to 1.3e-15), so 1e-12 (~5000 eps) in double and
 * 1e-5 (~80 eps) in float settle it some steps before the rounding floor.
 * Steady against recomputed, max|a - b| / max(1, max|b|) over every step
 * and estimate: the external bound is FUSED_REL (the claim that the centre
 * equals the central DKF, which the steady centre must keep); STEADY_REG a
 * regression bound. Measured (x86-64): double 4.9e-12 (one filter) and
 * 1.9e-11 (centre), so 1e-10; float 4.0e-5 and 1.4e-4, so 5e-4. The gain
 * settles while the recursion still moves by up to tol per step, and its
 * remaining path to the fixed point is about tol / (1 - rate) (rate 0.8
 * to 0.95 per step here), which the closed loop passes on to x. */
#if DKF_USE_FLOAT
#define STEADY_TOL 1e-5
#define STEADY_REG 5e-4
#else
#define STEADY_TOL 1e-12
#define STEADY_REG 1e-10
#endif

static void steady_close(double *worst, const dkf_diffkf_t *a, const dkf_diffkf_t *b)
{
    const size_t n = a->n;
    const double tol = STEADY_REG < FUSED_REL ? STEADY_REG : FUSED_REL;
    close_real(worst, "xf", a->xf.data, b->xf.data, n, tol);
    close_real(worst, "Pf", a->Pf.data, b->Pf.data, n * n, tol);
    close_real(worst, "xn", a->xn.data, b->xn.data, n, tol);
    close_real(worst, "Pn", a->Pn.data, b->Pn.data, n * n, tol);
}

static void test_steady_args(void **state)
{
    static hworld_t w;
    static dkf_real_t st[H_LOC_LEN];
    const size_t m[2] = {3, 2}, p[2] = {2, 1};
    const dkf_real_t bad[4] = {DKF_R(-1e-12), DKF_R(1.0), (dkf_real_t)NAN, (dkf_real_t)INFINITY};
    dkf_diffkf_t f;
    size_t i;
    (void)state;
    memset(&f, 0, sizeof f);
    assert_int_equal(dkf_diffkf_set_steady(NULL, DKF_R(1e-5)), DKF_ERR_NULL);
    assert_int_equal(dkf_diffkf_set_steady(&f, DKF_R(1e-5)), DKF_ERR_STATE);
    assert_int_equal(dkf_diffkf_fc_set_steady(NULL, DKF_R(1e-5)), DKF_ERR_NULL);
    memset(&w.fc, 0, sizeof w.fc);
    assert_int_equal(dkf_diffkf_fc_set_steady(&w.fc, DKF_R(1e-5)), DKF_ERR_STATE);
    hmodel(&w.h, 2, m, p, 61);
    assert_int_equal(dkf_diffkf_init(&f, HN, 3, 2, st, H_LOC_LEN, &w.h.mx0, &w.h.mP0), DKF_OK);
    test_rng_seed(&w.rng, 63);
    h_start(&w);
    assert_true(f.priv.steady_tol == 0); /* off after init */
    assert_int_equal(dkf_diffkf_set_steady(&f, DKF_R(1e-5)), DKF_OK);
    assert_int_equal(dkf_diffkf_fc_set_steady(&w.fc, DKF_R(1e-5)), DKF_OK);
    for (i = 0; i < 4; ++i) {
        assert_int_equal(dkf_diffkf_set_steady(&f, bad[i]), DKF_ERR_ARG);
        assert_int_equal(dkf_diffkf_fc_set_steady(&w.fc, bad[i]), DKF_ERR_ARG);
        assert_true(f.priv.steady_tol == DKF_R(1e-5));
        assert_true(w.fc.central.priv.steady_tol == DKF_R(1e-5));
        assert_true(w.fc.nodes[1].rep.priv.steady_tol == DKF_R(1e-5));
    }
    assert_int_equal(dkf_diffkf_set_steady(&f, 0), DKF_OK);
    assert_true(f.priv.steady_tol == 0);
}

/* One Difference KF with the steady gain (a) against one that computes
 * every gain (b), on the same data: a settles, stays within the bounds,
 * and computes its gain afresh after each event that invalidates the
 * settled one (P_{k+1|k} written by the caller, a model change, a masked
 * row, a restore), settling again afterwards. A refused step on a settled
 * filter changes nothing, the next step still reuses the gain. */
static void test_steady_diffkf(void **state)
{
    static hmodel_t h;
    static dkf_real_t sa[H_LOC_LEN], sb[H_LOC_LEN], ck[H_LOC_LEN], snap[H_LOC_LEN];
    const size_t m[1] = {3}, p[1] = {2}, K = 680;
    const size_t events[4] = {200, 320, 440, 560};
    const unsigned char rows[2] = {1, 0};
    dkf_diffkf_t a, b, keep;
    dkf_real_t y[HM];
    dkf_mat_t my = DKF_MAT(3, 1, y), zk;
    test_rng_t rng;
    double tmp[HM], worst = 0;
    size_t k, e = 0, settled = 0, reused = 0;
    (void)state;
    hmodel(&h, 1, m, p, 41);
    h.F[0] = h.F[10] = DKF_R(0.8); /* damped: one sensor cannot pin the state */
    h.F[5] = h.F[15] = DKF_R(0.5);
    test_rng_seed(&rng, 43);
    test_rand_gauss(&rng, tmp, 3, 1);
    test_to_real(y, tmp, 3);
    assert_int_equal(dkf_diffkf_init(&a, HN, 3, 2, sa, H_LOC_LEN, &h.mx0, &h.mP0), DKF_OK);
    assert_int_equal(dkf_diffkf_init(&b, HN, 3, 2, sb, H_LOC_LEN, &h.mx0, &h.mP0), DKF_OK);
    assert_int_equal(dkf_diffkf_start(&a, &h.mF, &h.mQ, &h.sens[0].meas, &my), DKF_OK);
    assert_int_equal(dkf_diffkf_start(&b, &h.mF, &h.mQ, &h.sens[0].meas, &my), DKF_OK);
    assert_int_equal(dkf_diffkf_set_steady(&a, (dkf_real_t)STEADY_TOL), DKF_OK);
    for (k = 1; k <= K; ++k) {
        const int event = e < 4 && k == events[e];
        test_rand_gauss(&rng, tmp, 3, 1);
        test_to_real(y, tmp, 3);
        if (k == 150) { /* settled by now: a refused step changes nothing */
            assert_true(a.steady);
            keep = a;
            memcpy(snap, sa, sizeof sa);
            h.mH[0].cols = 3;
            assert_int_equal(dkf_diffkf_step(&a, &h.dyn[0], &h.sens[0].meas, &my), DKF_ERR_DIM);
            h.mH[0].cols = HN;
            assert_memory_equal(&keep, &a, sizeof a);
            assert_memory_equal(snap, sa,
                                (DKF_DIFFKF_STATE_LEN(HN, 3, 2) + DKF_DIFFKF_PENDING_LEN(HN, 3, 2)) *
                                    sizeof(dkf_real_t));
        }
        if (event && e == 0) { /* the caller writes P_{k|k-1} */
            a.Pn.data[0] += 1;
            b.Pn.data[0] += 1;
        } else if (event && e == 1) { /* a model change */
            h.Q[0] *= 2;
        } else if (event && e == 3) { /* a restore (of the state it has) */
            assert_int_equal(dkf_diffkf_save(&a, ck, H_LOC_LEN), DKF_OK);
            assert_int_equal(dkf_diffkf_restore(&a, ck, H_LOC_LEN), DKF_OK);
        }
        if (event && e == 2) { /* a step with a masked row, in two phases */
            dkf_diffkf_t *const fs[2] = {&a, &b};
            size_t j;
            for (j = 0; j < 2; ++j) {
                dkf_mat_t M, Kp, zc;
                dkf_real_t z1[1];
                assert_int_equal(dkf_diffkf_gain_masked(fs[j], &h.dyn[0], &h.sens[0].meas, rows),
                                 DKF_OK);
                assert_int_equal(dkf_diffkf_pending(fs[j], &M, &Kp, &zc), DKF_OK);
                z1[0] = zc.data[0] + DKF_R(0.5); /* any datum */
                zk = (dkf_mat_t)DKF_MAT(1, 1, z1);
                assert_int_equal(dkf_diffkf_update_z(fs[j], &zk, &my), DKF_OK);
            }
        } else {
            assert_int_equal(dkf_diffkf_step(&a, &h.dyn[0], &h.sens[0].meas, &my), DKF_OK);
            assert_int_equal(dkf_diffkf_step(&b, &h.dyn[0], &h.sens[0].meas, &my), DKF_OK);
        }
        if (event) { /* the gain was computed afresh */
            assert_false(a.steady);
            e += 1;
        } else if (k + 1 == (e < 4 ? events[e] : K + 1)) {
            assert_true(a.steady); /* settled again before each event and at the end */
        }
        if (a.steady && settled == 0) settled = k;
        reused += a.steady ? 1u : 0u;
        steady_close(&worst, &a, &b);
    }
    assert_true(settled > 0 && settled < 150);
    print_message("steady DKF: settled at k = %zu, %zu of %zu steps reused the gain, "
                  "max rel diff %.3e\n",
                  settled, reused, K, worst);
}

/* The fusion centre with the steady gain (a) against one without (b), on
 * the same messages: within the bounds every step; an absent node, then a
 * model change whose first call fails after the model was restacked (the
 * centre's hint that the stacked model is the memo's must not survive it)
 * each make the central filter compute its gain afresh, and it settles
 * again. */
static void test_steady_fc(void **state)
{
    static hworld_t a, b;
    const size_t m[3] = {3, 2, 3}, p[3] = {2, 1, 2}, K = 480;
    const unsigned char absent1[3] = {1, 0, 1};
    dkf_diffkf_fc_fault_t f;
    dkf_diffkf_msg_t keep;
    double worst = 0;
    size_t k, settled = 0, reused = 0;
    (void)state;
    h_world(&a, 3, m, p, 51, 53);
    h_world(&b, 3, m, p, 51, 53);
    assert_int_equal(dkf_diffkf_fc_set_steady(&a.fc, (dkf_real_t)STEADY_TOL), DKF_OK);
    for (k = 1; k <= K; ++k) {
        if (k == 340) { /* node 0's R from step 340's model (time 341) on */
            a.h.R[0][0] *= 2;
            b.h.R[0][0] *= 2;
        }
        h_nodes_step(&a);
        h_nodes_step(&b);
        if (k == 200) {
            assert_int_equal(dkf_diffkf_fc_step_partial(&a.fc, &a.h.mF, &a.h.mQ, a.h.sens, a.msgs,
                                                        absent1, NULL, &f),
                             DKF_OK);
            assert_int_equal(dkf_diffkf_fc_step_partial(&b.fc, &b.h.mF, &b.h.mQ, b.h.sens, b.msgs,
                                                        absent1, NULL, &f),
                             DKF_OK);
            assert_false(a.fc.central.steady);
        } else {
            if (k == 340) { /* fails in node 2's recovery, after the restacking */
                keep = a.msgs[2];
                a.msgs[2].xf[0] = DKF_REAL_MAX;
                a.msgs[2].xp[0] = -DKF_REAL_MAX;
                assert_int_equal(h_fc_step(&a, &f), DKF_ERR_NONFINITE);
                expect_fault(&f, DKF_DIFFKF_FC_NONFINITE, 2);
                a.msgs[2] = keep;
            }
            assert_int_equal(h_fc_step(&a, &f), DKF_OK);
            assert_int_equal(h_fc_step(&b, &f), DKF_OK);
            if (k == 340) assert_false(a.fc.central.steady);
            if (k == 199 || k == 339 || k == K) assert_true(a.fc.central.steady);
        }
        if (a.fc.central.steady && settled == 0) settled = k;
        reused += a.fc.central.steady ? 1u : 0u;
        steady_close(&worst, &a.fc.central, &b.fc.central);
    }
    assert_true(settled > 0 && settled < 199);
    print_message("steady FC: settled at k = %zu, %zu of %zu steps reused the gain, "
                  "max rel diff %.3e\n",
                  settled, reused, K, worst);
}

static void test_cond_str(void **state)
{
    const char *seen[DKF_DIFFKF_FC_SEQUENCE + 1];
    int c, j;
    (void)state;
    for (c = DKF_DIFFKF_FC_NO_FAULT; c <= DKF_DIFFKF_FC_SEQUENCE; ++c) {
        seen[c] = dkf_diffkf_fc_cond_str((dkf_diffkf_fc_cond_t)c);
        assert_non_null(seen[c]);
        assert_string_not_equal(seen[c], "unknown condition");
        for (j = 0; j < c; ++j) assert_string_not_equal(seen[j], seen[c]);
    }
    assert_string_equal(dkf_diffkf_fc_cond_str(DKF_DIFFKF_FC_D_RANK), "D rank");
    assert_string_equal(dkf_diffkf_fc_cond_str((dkf_diffkf_fc_cond_t)(DKF_DIFFKF_FC_SEQUENCE + 1)),
                        "unknown condition");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cond_str),
        cmocka_unit_test(test_stack_helpers),
        cmocka_unit_test(test_msg_fill_checks),
        FC_VECTOR_TEST(test_fc_ex3_vector, "diffkf/ex3_multi.json"),
        FC_VECTOR_TEST(test_fc_tv3_vector, "diffkf/tv3_multi.json"),
        FC_VECTOR_TEST(test_fc_tv4_vector, "diffkf/tv4_multi.json"),
        FC_VECTOR_TEST(test_fc_cond6_vector, "diffkf/cond6_multi.json"),
        cmocka_unit_test(test_fc_setup_conditions),
        cmocka_unit_test(test_fc_message_validation_and_atomicity),
        cmocka_unit_test(test_fc_step_rank_failure),
        cmocka_unit_test(test_fc_partial_all_present_bit_identical),
        cmocka_unit_test(test_fc_partial_random_absent),
        cmocka_unit_test(test_fc_restart_and_late_node),
        cmocka_unit_test(test_fc_checkpoint_rollback_replay),
        cmocka_unit_test(test_fc_degraded_atomicity),
        cmocka_unit_test(test_steady_args),
        cmocka_unit_test(test_steady_diffkf),
        cmocka_unit_test(test_steady_fc),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
