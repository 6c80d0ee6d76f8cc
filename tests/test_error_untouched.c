/*
 * Every public function of the core that takes a filter object, called
 * with bad input of each kind, returns an error and leaves the object
 * bit-identical: the struct and the state part of its storage (the first
 * *_STATE_LEN reals; the rest is scratch any call may overwrite). Kinds:
 * a NULL data pointer, one row or column too many, a zero dimension, NaN,
 * +Inf and -Inf at every element of every input matrix, and the
 * module-specific ones (non-SPD, singular, rank, overflow of finite
 * inputs, out-of-sequence calls). Each module is put in a state after a
 * few successful calls first, so that the caches and carries are live.
 * A "huge" variant (one input scaled by 2 sqrt(REAL_MAX)) may fail or
 * not; if it fails it must leave the object untouched too. A composite
 * call (restart, rejoin, a local step over a pending one, a network step,
 * a central step) is refused at each of its checks in turn, in every
 * state its object can be in (fresh, pending, after a commit), with a
 * pending step counted as state.
 * test_exact_storage runs one table over every module: each init refuses
 * one real less than its *_STORAGE_LEN, untouched, and accepts exactly it;
 * test_init_over_live re-initialises each over its live object with a
 * prior refused at the last check. test_every_object_call_refused, last,
 * requires a checked refusal of every public function that takes a
 * filter object (untouched_api.h, written from the headers by
 * tests/untouched_api.cmake), bar a commented list of exemptions.
 * test_priv_last: every object struct ends with its private member priv.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/askf.h"
#include "dkf/diffkf.h"
#include "dkf/diffkf_fusion.h"
#include "dkf/info.h"
#include "dkf/kf.h"
#include "dkf/dfnerts.h"
#include "dkf/nerts.h"
#include "dkf/otskf.h"
#include "dkf/tw.h"
#include "dkf/selftune.h"
#include "dkf/uif.h"
#include "dkf/wfusion.h"
#include "dfnerts_fixture.h"
#include "dkf_test.h"
#include "nerts_fixture.h"

/* ---- which public calls were refused under a check ------------------------ */

/* A check is armed from the snapshot of the object (snap_take) to its
 * comparison (check_failed); every call of a public function that takes
 * a filter object goes through untouched_note (untouched_api.h, written
 * from the headers, makes each such name a macro that calls it), and one
 * that fails while a check is armed is recorded as exercised.
 * test_every_object_call_refused requires every function to be. */
static int check_armed;
static const char *refused_calls[256];
static size_t n_refused_calls;

static int call_refused(const char *name)
{
    size_t i;
    for (i = 0; i < n_refused_calls; ++i)
        if (strcmp(refused_calls[i], name) == 0) return 1;
    return 0;
}

static dkf_status_t untouched_note(const char *name, dkf_status_t st)
{
    if (check_armed && st != DKF_OK && !call_refused(name)) {
        assert_true(n_refused_calls < sizeof refused_calls / sizeof refused_calls[0]);
        refused_calls[n_refused_calls++] = name;
    }
    return st;
}

#include "untouched_api.h"

/* ---- snapshots ------------------------------------------------------------ */

/* "any error": the call must fail, the status is not pinned */
#define ANY_ERR ((dkf_status_t)1)
#define SNAP_CAP (1u << 20)

typedef struct {
    const void *p[24];
    size_t len[24];
    size_t n;
} regions_t;

static unsigned char snap_bytes[SNAP_CAP];

static void reg_clear(regions_t *g) { g->n = 0; }
static void reg_add(regions_t *g, const void *p, size_t len)
{
    assert_true(g->n < 24);
    g->p[g->n] = p;
    g->len[g->n] = len;
    g->n++;
}

static void snap_take(const regions_t *g)
{
    size_t i, off = 0;
    check_armed = 1;
    for (i = 0; i < g->n; ++i) {
        assert_true(off + g->len[i] <= SNAP_CAP);
        memcpy(snap_bytes + off, g->p[i], g->len[i]);
        off += g->len[i];
    }
}

static int snap_same(const regions_t *g)
{
    size_t i, off = 0;
    for (i = 0; i < g->n; ++i) {
        if (memcmp(snap_bytes + off, g->p[i], g->len[i]) != 0) return 0;
        off += g->len[i];
    }
    return 1;
}

/* Puts the snapshot back (after a call that was allowed to succeed). */
static void snap_restore(const regions_t *g)
{
    size_t i, off = 0;
    for (i = 0; i < g->n; ++i) {
        memcpy((void *)(uintptr_t)g->p[i], snap_bytes + off, g->len[i]);
        off += g->len[i];
    }
}

static size_t n_checked; /* failing calls checked, for the log */

static void check_failed(const regions_t *g, dkf_status_t want, dkf_status_t got,
                         const char *what, size_t e)
{
    check_armed = 0;
    ++n_checked;
    if (got == DKF_OK || (want != ANY_ERR && got != want)) {
        print_error("%s (element %zu): status %d (%s), want %d\n", what, e, (int)got,
                    dkf_status_str(got), (int)want);
        fail();
    }
    if (!snap_same(g)) {
        print_error("%s (element %zu): the failed call (%s) changed the object\n", what, e,
                    dkf_status_str(got));
        fail();
    }
}

#define EXPECT_UNTOUCHED(g, want, call, what) \
    do { \
        snap_take(g); \
        check_failed((g), (want), (call), (what), 0); \
    } while (0)

/* ---- corrupting one input view ---------------------------------------------- */

typedef enum { K_NULL, K_ROWS, K_COLS, K_ZERO, K_NAN, K_PINF, K_NINF, K_HUGE, K_COUNT } kind_t;

static const char *const kind_name[K_COUNT] = {"NULL data", "rows + 1", "cols + 1", "0 rows",
                                               "NaN",       "+Inf",     "-Inf",     "huge"};

static size_t variants(const dkf_mat_t *v, kind_t k)
{
    return k == K_NAN || k == K_PINF || k == K_NINF ? v->rows * v->cols : 1;
}

static dkf_status_t kind_status(kind_t k)
{
    switch (k) {
    case K_NULL: return DKF_ERR_NULL;
    case K_ZERO: return DKF_ERR_CAPACITY;
    case K_NAN:
    case K_PINF:
    case K_NINF: return DKF_ERR_NONFINITE;
    default: return ANY_ERR;
    }
}

/* 2 sqrt(REAL_MAX): any product of two such entries overflows. */
static dkf_real_t huge_value(void) { return DKF_R(2.0) * DKF_SQRT(DKF_REAL_MAX); }

typedef struct {
    dkf_mat_t v;
    dkf_real_t saved[64];
} undo_t;

/* Every view's data must have room for (rows + 1) (cols + 1) reals. */
static void corrupt(dkf_mat_t *v, kind_t k, size_t e, undo_t *u)
{
    size_t i;
    u->v = *v;
    assert_true(v->rows * v->cols <= 64);
    memcpy(u->saved, v->data, v->rows * v->cols * sizeof(dkf_real_t));
    switch (k) {
    case K_NULL: v->data = NULL; break;
    case K_ROWS: v->rows += 1; break;
    case K_COLS: v->cols += 1; break;
    case K_ZERO: v->rows = 0; break;
    case K_NAN: v->data[e] = (dkf_real_t)NAN; break;
    case K_PINF: v->data[e] = (dkf_real_t)INFINITY; break;
    case K_NINF: v->data[e] = -(dkf_real_t)INFINITY; break;
    case K_HUGE:
        for (i = 0; i < v->rows * v->cols; ++i) v->data[i] *= huge_value();
        break;
    default: break;
    }
}

static void uncorrupt(dkf_mat_t *v, const undo_t *u)
{
    *v = u->v;
    memcpy(v->data, u->saved, v->rows * v->cols * sizeof(dkf_real_t));
}

typedef dkf_status_t (*call_fn)(void *ctx);

/* Every kind at every element of every view in views[] (which the call
 * reads through pointers), with the object described by g. */
static void sweep(const char *what, call_fn call, void *ctx, dkf_mat_t *const views[],
                  const char *const names[], size_t nv, const regions_t *g)
{
    char label[256]; /* what (up to 160) + a view and a kind name */
    size_t j, e;
    int k;
    for (j = 0; j < nv; ++j)
        for (k = 0; k < K_COUNT; ++k)
            for (e = 0; e < variants(views[j], (kind_t)k); ++e) {
                undo_t u;
                dkf_status_t st;
                snprintf(label, sizeof label, "%s: %s %s", what, names[j], kind_name[k]);
                corrupt(views[j], (kind_t)k, e, &u);
                snap_take(g);
                st = call(ctx);
                if (k == K_HUGE) {
                    check_armed = 0;
                    if (st != DKF_OK && !snap_same(g)) {
                        print_error("%s: the failed call (%s) changed the object\n", label,
                                    dkf_status_str(st));
                        fail();
                    }
                    snap_restore(g);
                } else {
                    check_failed(g, kind_status((kind_t)k), st, label, e);
                }
                uncorrupt(views[j], &u);
            }
}

/* A matrix with room for one more row and column. */
typedef struct {
    dkf_real_t d[64];
    dkf_mat_t v;
} mbuf_t;

static dkf_mat_t *mset(mbuf_t *b, size_t r, size_t c, const double *vals)
{
    size_t i;
    memset(b->d, 0, sizeof b->d);
    for (i = 0; i < r * c; ++i) b->d[i] = (dkf_real_t)vals[i];
    b->v.rows = r;
    b->v.cols = c;
    b->v.data = b->d;
    return &b->v;
}

static dkf_mat_t *meye(mbuf_t *b, size_t n, double s)
{
    double v[64] = {0};
    size_t i;
    for (i = 0; i < n; ++i) v[i * n + i] = s;
    return mset(b, n, n, v);
}

/* ---- the shared model (n = 3 states) ----------------------------------------- */

static const double F3[9] = {1.0, 0.1, 0.0, 0.0, 1.0, 0.1, 0.0, 0.0, 0.9};
static const double Q3[9] = {0.02, 0.001, 0.0, 0.001, 0.02, 0.0, 0.0, 0.0, 0.03};
static const double P3[9] = {1.0, 0.2, 0.0, 0.2, 1.5, 0.1, 0.0, 0.1, 0.8};
static const double x3[3] = {0.5, -1.0, 2.0};

/* ---- KF ------------------------------------------------------------------------ */

typedef struct {
    dkf_kf_t kf;
    dkf_real_t st[DKF_KF_STORAGE_LEN(3, 2)];
    mbuf_t F, Q, u, H, R, y;
    regions_t g;
} kf_ctx_t;

static dkf_status_t kf_predict_call(void *c)
{
    kf_ctx_t *k = c;
    return dkf_kf_predict(&k->kf, &(dkf_kf_dyn_t){&k->F.v, &k->Q.v}, &k->u.v);
}

static dkf_status_t kf_update_call(void *c)
{
    kf_ctx_t *k = c;
    return dkf_kf_update(&k->kf, &(dkf_kf_meas_t){&k->H.v, &k->R.v}, &k->y.v);
}

static void test_kf(void **state)
{
    static kf_ctx_t k;
    static const double H[6] = {1.0, 0.0, 0.5, 0.0, 1.0, 0.0};
    static const double R[4] = {0.1, 0.01, 0.01, 0.2};
    static const double y[2] = {0.3, -0.7}, u[3] = {0.1, 0.0, -0.1};
    static const char *const pn[] = {"F", "Q", "u"}, *const un[] = {"H", "R", "y"};
    mbuf_t x0, P0, H3;
    dkf_mat_t *pv[3], *uv[3];
    dkf_kf_t blank;
    (void)state;
    mset(&x0, 3, 1, x3);
    mset(&P0, 3, 3, P3);
    assert_int_equal(dkf_kf_init(&k.kf, 3, 2, k.st, DKF_KF_STORAGE_LEN(3, 2), &x0.v, &P0.v),
                     DKF_OK);
    assert_true(k.kf.priv.work == k.st + DKF_KF_STATE_LEN(3, 2));
    pv[0] = mset(&k.F, 3, 3, F3), pv[1] = mset(&k.Q, 3, 3, Q3), pv[2] = mset(&k.u, 3, 1, u);
    uv[0] = mset(&k.H, 2, 3, H), uv[1] = mset(&k.R, 2, 2, R), uv[2] = mset(&k.y, 2, 1, y);
    assert_int_equal(kf_predict_call(&k), DKF_OK);
    assert_int_equal(kf_update_call(&k), DKF_OK);
    reg_clear(&k.g);
    reg_add(&k.g, &k.kf, sizeof k.kf);
    reg_add(&k.g, k.st, DKF_KF_STATE_LEN(3, 2) * sizeof(dkf_real_t));
    sweep("kf_predict", kf_predict_call, &k, pv, pn, 3, &k.g);
    sweep("kf_update", kf_update_call, &k, uv, un, 3, &k.g);
    /* R = -I: S not SPD; m = 3 > m_max; finite F whose F P F^T overflows */
    meye(&k.R, 2, -1.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, kf_update_call(&k), "kf_update: R = -I");
    mset(&k.R, 2, 2, R);
    mset(&H3, 3, 3, F3);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_CAPACITY, dkf_kf_update(&k.kf, &(dkf_kf_meas_t){&H3.v, &k.R.v}, &k.y.v),
                     "kf_update: m > m_max");
    meye(&k.F, 3, (double)huge_value());
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, kf_predict_call(&k), "kf_predict: F P F^T overflows");
    mset(&k.F, 3, 3, F3);
    /* out of sequence: a filter that was never initialised */
    memset(&blank, 0, sizeof blank);
    reg_clear(&k.g);
    reg_add(&k.g, &blank, sizeof blank);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_kf_predict(&blank, &(dkf_kf_dyn_t){&k.F.v, &k.Q.v}, NULL),
                     "kf_predict before init");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_kf_update(&blank, &(dkf_kf_meas_t){&k.H.v, &k.R.v}, &k.y.v),
                     "kf_update before init");
    /* a failed init never writes *kf */
    reg_clear(&k.g);
    reg_add(&k.g, &k.kf, sizeof k.kf);
    meye(&P0, 3, -1.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD,
                     dkf_kf_init(&k.kf, 3, 2, k.st, DKF_KF_STORAGE_LEN(3, 2), &x0.v, &P0.v),
                     "kf_init: P0 = -I");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_CAPACITY,
                     dkf_kf_init(&k.kf, 3, 2, k.st, DKF_KF_STORAGE_LEN(3, 2) - 1, &x0.v, &P0.v),
                     "kf_init: storage");
}

/* ---- information filter --------------------------------------------------------- */

typedef struct {
    dkf_info_t f;
    dkf_real_t st[DKF_INFO_STORAGE_LEN(3)];
    mbuf_t F, Q, i[2], I[2];
    regions_t g;
} info_ctx_t;

static dkf_status_t info_predict_call(void *c)
{
    info_ctx_t *k = c;
    return dkf_info_predict(&k->f, &(dkf_kf_dyn_t){&k->F.v, &k->Q.v});
}

static dkf_status_t info_fuse_call(void *c)
{
    info_ctx_t *k = c;
    const dkf_mat_t iv[2] = {k->i[0].v, k->i[1].v}, Iv[2] = {k->I[0].v, k->I[1].v};
    return dkf_info_fuse(&k->f, iv, Iv, 2);
}

typedef struct {
    mbuf_t i, I, C, R, z;
    dkf_real_t work[DKF_INFO_CONTRIB_WORK(4, 3)];
} contrib_ctx_t;

static dkf_status_t contrib_call(void *c)
{
    contrib_ctx_t *k = c;
    return dkf_info_contribution(&k->i.v, &k->I.v, &(dkf_kf_meas_t){&k->C.v, &k->R.v}, &k->z.v, k->work);
}

static void test_info(void **state)
{
    static info_ctx_t k;
    static contrib_ctx_t c;
    static const double C[6] = {1.0, 0.0, 0.5, 0.0, 1.0, 0.0};
    static const double R[4] = {0.1, 0.01, 0.01, 0.2}, z[2] = {0.3, -0.7};
    static const double i0[3] = {0.1, 0.2, 0.3}, I0[9] = {2.0, 0.1, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0, 0.5};
    static const char *const pn[] = {"F", "Q"}, *const fn[] = {"i0", "i1", "I0", "I1"},
                             *const cn[] = {"C", "R", "z"};
    dkf_mat_t *pv[2], *fv[4], *cv[3];
    mbuf_t x0, P0;
    regions_t out;
    double big;
    (void)state;
    mset(&x0, 3, 1, x3);
    mset(&P0, 3, 3, P3);
    assert_int_equal(dkf_info_init(&k.f, 3, k.st, DKF_INFO_STORAGE_LEN(3), &x0.v, &P0.v), DKF_OK);
    assert_true(k.f.priv.work == k.st + DKF_INFO_STATE_LEN(3));
    pv[0] = mset(&k.F, 3, 3, F3), pv[1] = mset(&k.Q, 3, 3, Q3);
    fv[0] = mset(&k.i[0], 3, 1, i0), fv[1] = mset(&k.i[1], 3, 1, i0);
    fv[2] = mset(&k.I[0], 3, 3, I0), fv[3] = mset(&k.I[1], 3, 3, I0);
    assert_int_equal(info_predict_call(&k), DKF_OK);
    assert_int_equal(info_fuse_call(&k), DKF_OK);
    reg_clear(&k.g);
    reg_add(&k.g, &k.f, sizeof k.f);
    reg_add(&k.g, k.st, DKF_INFO_STATE_LEN(3) * sizeof(dkf_real_t));
    sweep("info_predict", info_predict_call, &k, pv, pn, 2, &k.g);
    sweep("info_fuse", info_fuse_call, &k, fv, fn, 4, &k.g);
    meye(&k.Q, 3, -10.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, info_predict_call(&k), "info_predict: Q = -10 I");
    mset(&k.Q, 3, 3, Q3);
    /* finite inputs whose products overflow: NONFINITE, not NOT_SPD */
    big = (double)huge_value();
    meye(&k.F, 3, big);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, info_predict_call(&k),
                     "info_predict: F P F^T overflows");
    mset(&k.F, 3, 3, F3);
    meye(&k.I[0], 3, (double)DKF_REAL_MAX);
    meye(&k.I[1], 3, (double)DKF_REAL_MAX);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, info_fuse_call(&k), "info_fuse: the sum overflows");
    meye(&k.I[0], 3, -10.0);
    mset(&k.I[1], 3, 3, I0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, info_fuse_call(&k), "info_fuse: Y not SPD");
    mset(&k.I[0], 3, 3, I0);
    /* the contribution: its outputs are untouched on failure */
    mset(&c.i, 3, 1, i0);
    mset(&c.I, 3, 3, I0);
    cv[0] = mset(&c.C, 2, 3, C), cv[1] = mset(&c.R, 2, 2, R), cv[2] = mset(&c.z, 2, 1, z);
    reg_clear(&out);
    reg_add(&out, c.i.d, sizeof c.i.d);
    reg_add(&out, c.I.d, sizeof c.I.d);
    sweep("info_contribution", contrib_call, &c, cv, cn, 3, &out);
    meye(&c.R, 2, -1.0);
    EXPECT_UNTOUCHED(&out, DKF_ERR_NOT_SPD, contrib_call(&c), "info_contribution: R = -I");
    mset(&c.R, 2, 2, R);
    {
        const double Cb[6] = {big, 0.0, 0.0, 0.0, 1.0, 0.0};
        mset(&c.C, 2, 3, Cb);
        EXPECT_UNTOUCHED(&out, DKF_ERR_NONFINITE, contrib_call(&c),
                         "info_contribution: C^T R^-1 C overflows");
        mset(&c.C, 2, 3, C);
    }
    {
        const double zb[2] = {(double)DKF_REAL_MAX, (double)DKF_REAL_MAX};
        mset(&c.z, 2, 1, zb);
        EXPECT_UNTOUCHED(&out, DKF_ERR_NONFINITE, contrib_call(&c),
                         "info_contribution: C^T R^-1 z overflows");
        mset(&c.z, 2, 1, z);
    }
}

/* ---- ASKF and OTSKF ---------------------------------------------------------------- */

typedef struct {
    dkf_askf_t a;
    dkf_otskf_t o;
    dkf_real_t ast[DKF_ASKF_STORAGE_LEN(3, 2, 2)];
    dkf_real_t ost[DKF_OTSKF_STORAGE_LEN(3, 2, 2)];
    mbuf_t F, Q, B, Rd, H, A, R, y;
    dkf_ui_dyn_t dyn;
    dkf_ui_meas_t meas;
    regions_t ga, go;
} ui_ctx_t;

static dkf_status_t askf_predict_call(void *c)
{
    ui_ctx_t *k = c;
    return dkf_askf_predict(&k->a, &k->dyn);
}
static dkf_status_t askf_update_call(void *c)
{
    ui_ctx_t *k = c;
    return dkf_askf_update(&k->a, &k->meas, &k->y.v);
}
static dkf_status_t otskf_predict_call(void *c)
{
    ui_ctx_t *k = c;
    return dkf_otskf_predict(&k->o, &k->dyn);
}
static dkf_status_t otskf_update_call(void *c)
{
    ui_ctx_t *k = c;
    return dkf_otskf_update(&k->o, &k->meas, &k->y.v);
}

static const double B2[4] = {0.9, 0.1, 0.0, 0.8}, Rd2[4] = {0.05, 0.0, 0.0, 0.05};
static const double H23[6] = {1.0, 0.0, 0.5, 0.0, 1.0, 0.0};
static const double A22[4] = {1.0, 0.2, 0.0, 1.0}, R22[4] = {0.1, 0.01, 0.01, 0.2};
static const double y2[2] = {0.3, -0.7};

static void ui_model(ui_ctx_t *k, dkf_mat_t *dv[4], dkf_mat_t *mv[4])
{
    dv[0] = mset(&k->F, 3, 3, F3), dv[1] = mset(&k->Q, 3, 3, Q3);
    dv[2] = mset(&k->B, 2, 2, B2), dv[3] = mset(&k->Rd, 2, 2, Rd2);
    mv[0] = mset(&k->H, 2, 3, H23), mv[1] = mset(&k->A, 2, 2, A22);
    mv[2] = mset(&k->R, 2, 2, R22), mv[3] = mset(&k->y, 2, 1, y2);
    k->dyn.F = &k->F.v, k->dyn.Q = &k->Q.v, k->dyn.B = &k->B.v, k->dyn.Rd = &k->Rd.v;
    k->meas.H = &k->H.v, k->meas.D = &k->A.v, k->meas.R = &k->R.v;
}

static void test_askf_otskf(void **state)
{
    static ui_ctx_t k;
    static const char *const dn[] = {"F", "Q", "B", "Rd"}, *const mn[] = {"H", "A", "R", "y"};
    static const double d0[2] = {0.1, -0.2}, Pd0[4] = {1.0, 0.0, 0.0, 1.0};
    static const double Asing[4] = {1.0, 2.0, 2.0, 4.0};
    dkf_mat_t *dv[4], *mv[4];
    mbuf_t x0, P0, md0, mPd0;
    (void)state;
    ui_model(&k, dv, mv);
    mset(&x0, 3, 1, x3), mset(&P0, 3, 3, P3), mset(&md0, 2, 1, d0), mset(&mPd0, 2, 2, Pd0);
    assert_int_equal(dkf_askf_init(&k.a, 3, 2, 2, k.ast, DKF_ASKF_STORAGE_LEN(3, 2, 2), &x0.v,
                                   &P0.v, &md0.v, &mPd0.v, NULL),
                     DKF_OK);
    assert_true(k.a.kf.priv.work == k.ast + DKF_ASKF_STATE_LEN(3, 2, 2));
    assert_int_equal(dkf_otskf_init(&k.o, 3, 2, 2, k.ost, DKF_OTSKF_STORAGE_LEN(3, 2, 2), &x0.v,
                                    &P0.v, &md0.v, &mPd0.v),
                     DKF_OK);
    assert_int_equal(askf_predict_call(&k), DKF_OK);
    assert_int_equal(askf_update_call(&k), DKF_OK);
    assert_int_equal(otskf_predict_call(&k), DKF_OK);
    assert_int_equal(otskf_update_call(&k), DKF_OK);
    reg_clear(&k.ga);
    reg_add(&k.ga, &k.a, sizeof k.a);
    reg_add(&k.ga, k.ast, DKF_ASKF_STATE_LEN(3, 2, 2) * sizeof(dkf_real_t));
    reg_clear(&k.go);
    reg_add(&k.go, &k.o, sizeof k.o);
    reg_add(&k.go, k.ost, DKF_OTSKF_STATE_LEN(3, 2) * sizeof(dkf_real_t));
    sweep("askf_predict", askf_predict_call, &k, dv, dn, 4, &k.ga);
    sweep("askf_update", askf_update_call, &k, mv, mn, 4, &k.ga);
    sweep("otskf_predict", otskf_predict_call, &k, dv, dn, 4, &k.go);
    sweep("otskf_update", otskf_update_call, &k, mv, mn, 4, &k.go);
    meye(&k.R, 2, -1.0);
    EXPECT_UNTOUCHED(&k.ga, DKF_ERR_NOT_SPD, askf_update_call(&k), "askf_update: R = -I");
    EXPECT_UNTOUCHED(&k.go, DKF_ERR_NOT_SPD, otskf_update_call(&k), "otskf_update: R = -I");
    mset(&k.R, 2, 2, R22);
    meye(&k.B, 2, 0.0);
    EXPECT_UNTOUCHED(&k.go, DKF_ERR_SINGULAR, otskf_predict_call(&k), "otskf_predict: B = 0");
    mset(&k.B, 2, 2, B2);
    /* A of rank 1 < p = 2: the OTSKF's model needs full column rank */
    mset(&k.A, 2, 2, Asing);
    EXPECT_UNTOUCHED(&k.go, DKF_ERR_RANK, otskf_update_call(&k), "otskf_update: rank A = 1");
    mset(&k.A, 2, 2, A22);
    meye(&k.F, 3, (double)huge_value());
    EXPECT_UNTOUCHED(&k.ga, DKF_ERR_NONFINITE, askf_predict_call(&k), "askf_predict: overflow");
    EXPECT_UNTOUCHED(&k.go, DKF_ERR_NONFINITE, otskf_predict_call(&k), "otskf_predict: overflow");
    mset(&k.F, 3, 3, F3);
    /* the queries: a misshaped covariance output, a filter never
     * initialised; the outputs untouched too */
    {
        static mbuf_t Pb;
        static dkf_mat_t xv;
        dkf_askf_t blank;
        regions_t gq = k.ga;
        meye(&Pb, 3, 7.0);
        Pb.v.rows = 2;
        memset(&xv, 0, sizeof xv);
        reg_add(&gq, &Pb, sizeof Pb);
        reg_add(&gq, &xv, sizeof xv);
        EXPECT_UNTOUCHED(&gq, DKF_ERR_DIM, dkf_askf_state(&k.a, &xv, &Pb.v),
                         "askf_state: Px 2 x 3");
        EXPECT_UNTOUCHED(&gq, DKF_ERR_DIM, dkf_askf_input(&k.a, &xv, &Pb.v),
                         "askf_input: Pd 2 x 3");
        memset(&blank, 0, sizeof blank);
        reg_add(&gq, &blank, sizeof blank);
        EXPECT_UNTOUCHED(&gq, DKF_ERR_STATE, dkf_askf_state(&blank, &xv, NULL),
                         "askf_state: blank");
        EXPECT_UNTOUCHED(&gq, DKF_ERR_STATE, dkf_askf_input(&blank, &xv, NULL),
                         "askf_input: blank");
    }
}

/* ---- Difference KF ------------------------------------------------------------------- */

#define DN 3
#define DM 3
#define DP 2

typedef struct {
    dkf_diffkf_t f;
    dkf_real_t st[DKF_DIFFKF_STORAGE_LEN(DN, DM, DP)];
    mbuf_t F, Q, B, Rd, H, A, R, y, z;
    dkf_ui_dyn_t dyn;
    dkf_ui_meas_t meas;
    unsigned char rows[DP];
    regions_t g;
} dkf_ctx_t;

static dkf_status_t dkf_start_call(void *c)
{
    dkf_ctx_t *k = c;
    return dkf_diffkf_start(&k->f, &k->F.v, &k->Q.v, &k->meas, &k->y.v);
}
static dkf_status_t dkf_step_call(void *c)
{
    dkf_ctx_t *k = c;
    return dkf_diffkf_step(&k->f, &k->dyn, &k->meas, &k->y.v);
}
static dkf_status_t dkf_gain_call(void *c)
{
    dkf_ctx_t *k = c;
    return dkf_diffkf_gain_masked(&k->f, &k->dyn, &k->meas, k->rows);
}
static dkf_status_t dkf_gain_all_call(void *c)
{
    dkf_ctx_t *k = c;
    return dkf_diffkf_gain(&k->f, &k->dyn, &k->meas);
}
static dkf_status_t dkf_update_call(void *c)
{
    dkf_ctx_t *k = c;
    return dkf_diffkf_update_z(&k->f, &k->z.v, &k->y.v);
}

static const double DH[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.3, 0.0, 1.0};
static const double DA[6] = {1.0, 0.0, 0.0, 1.0, 0.5, 0.5};
static const double DR[9] = {0.1, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.1};
static const double Dy[3] = {0.2, -0.1, 0.4};

static void dkf_model(dkf_ctx_t *k, dkf_mat_t *v[8])
{
    static const double z[2] = {0.1, 0.2};
    v[0] = mset(&k->F, DN, DN, F3), v[1] = mset(&k->Q, DN, DN, Q3);
    v[2] = mset(&k->B, DP, DP, B2), v[3] = mset(&k->Rd, DP, DP, Rd2);
    v[4] = mset(&k->H, DM, DN, DH), v[5] = mset(&k->A, DM, DP, DA);
    v[6] = mset(&k->R, DM, DM, DR), v[7] = mset(&k->y, DM, 1, Dy);
    mset(&k->z, DP, 1, z);
    k->dyn.F = &k->F.v, k->dyn.Q = &k->Q.v, k->dyn.B = &k->B.v, k->dyn.Rd = &k->Rd.v;
    k->meas.H = &k->H.v, k->meas.D = &k->A.v, k->meas.R = &k->R.v;
    k->rows[0] = k->rows[1] = 1;
}

static void dkf_regions(dkf_ctx_t *k, int with_pending)
{
    reg_clear(&k->g);
    reg_add(&k->g, &k->f, sizeof k->f);
    reg_add(&k->g, k->st,
            (DKF_DIFFKF_STATE_LEN(DN, DM, DP) + (with_pending ? DKF_DIFFKF_PENDING_LEN(DN, DM, DP) : 0)) *
                sizeof(dkf_real_t));
}

/* The model-specific failures of a step (and of a gain): A of rank 1,
 * B singular, L not SPD (R = -10 I makes Ru negative definite). Each
 * with a model the caches have not seen: a miss computes new entries. */
static void dkf_model_failures(dkf_ctx_t *k, call_fn call, const char *what)
{
    static const double Arank1[6] = {1.0, 2.0, 0.0, 0.0, 1.0, 2.0};
    char label[120];
    mset(&k->A, DM, DP, Arank1);
    snprintf(label, sizeof label, "%s: rank A = 1", what);
    EXPECT_UNTOUCHED(&k->g, DKF_ERR_RANK, call(k), label);
    mset(&k->A, DM, DP, DA);
    meye(&k->B, DP, 0.0);
    snprintf(label, sizeof label, "%s: B = 0", what);
    EXPECT_UNTOUCHED(&k->g, DKF_ERR_SINGULAR, call(k), label);
    mset(&k->B, DP, DP, B2);
    meye(&k->R, DM, -10.0);
    snprintf(label, sizeof label, "%s: L not SPD", what);
    EXPECT_UNTOUCHED(&k->g, DKF_ERR_NOT_SPD, call(k), label);
    mset(&k->R, DM, DM, DR);
    meye(&k->F, DN, (double)huge_value());
    snprintf(label, sizeof label, "%s: F P F^T overflows", what);
    EXPECT_UNTOUCHED(&k->g, DKF_ERR_NONFINITE, call(k), label);
    mset(&k->F, DN, DN, F3);
}

/* Before the start (the filter k->f initialised, not started): the
 * queries and settings that refuse, their outputs untouched too, and
 * the same calls on a filter never initialised. */
static void dkf_query_refusals(dkf_ctx_t *k)
{
    static dkf_diffkf_msg_t msg;
    static dkf_mat_t M, K, zc;
    dkf_diffkf_t blank;
    regions_t gq = k->g;
    memset(&msg, 0x5a, sizeof msg);
    reg_add(&gq, &msg, sizeof msg);
    reg_add(&gq, &M, sizeof M);
    reg_add(&gq, &K, sizeof K);
    reg_add(&gq, &zc, sizeof zc);
    EXPECT_UNTOUCHED(&gq, DKF_ERR_STATE, dkf_diffkf_msg_fill(&msg, 0, &k->f),
                     "diffkf_msg_fill before the first step");
    EXPECT_UNTOUCHED(&gq, DKF_ERR_STATE, dkf_diffkf_pending(&k->f, &M, &K, &zc),
                     "diffkf_pending: no gain pending");
    EXPECT_UNTOUCHED(&gq, DKF_ERR_ARG, dkf_diffkf_set_steady(&k->f, DKF_R(1.0)),
                     "diffkf_set_steady: tol = 1");
    EXPECT_UNTOUCHED(&gq, DKF_ERR_ARG, dkf_diffkf_set_steady(&k->f, DKF_R(-0.5)),
                     "diffkf_set_steady: tol < 0");
    EXPECT_UNTOUCHED(&gq, DKF_ERR_ARG, dkf_diffkf_set_steady(&k->f, (dkf_real_t)NAN),
                     "diffkf_set_steady: tol NaN");
    memset(&blank, 0, sizeof blank);
    reg_add(&gq, &blank, sizeof blank);
    EXPECT_UNTOUCHED(&gq, DKF_ERR_STATE, dkf_diffkf_set_steady(&blank, DKF_R(0.0)),
                     "diffkf_set_steady: blank");
    EXPECT_UNTOUCHED(&gq, DKF_ERR_STATE, dkf_diffkf_set_time(&blank, 3), "diffkf_set_time: blank");
    EXPECT_UNTOUCHED(&gq, DKF_ERR_STATE, dkf_diffkf_msg_fill(&msg, 0, &blank),
                     "diffkf_msg_fill: blank");
    EXPECT_UNTOUCHED(&gq, DKF_ERR_NULL, dkf_diffkf_set_time(NULL, 3), "diffkf_set_time: NULL");
}

/* A checkpoint of len reals at ck (valid): save into a short buffer, and
 * the check of corrupted copies (tag, n, k digit, flags, NaN, short),
 * each refused with the filter and the buffer untouched. */
static void dkf_checkpoint_refusals(dkf_ctx_t *k, dkf_real_t *ck, size_t len)
{
    static const size_t at[] = {0, 2, 4, 10};
    static const dkf_status_t want[] = {DKF_ERR_ARG, DKF_ERR_DIM, DKF_ERR_ARG, DKF_ERR_ARG};
    regions_t gq = k->g;
    size_t i;
    reg_add(&gq, ck, len * sizeof *ck);
    EXPECT_UNTOUCHED(&gq, DKF_ERR_CAPACITY, dkf_diffkf_save(&k->f, ck, len - 1),
                     "diffkf_save: short");
    EXPECT_UNTOUCHED(&gq, DKF_ERR_CAPACITY, dkf_diffkf_checkpoint_check(&k->f, ck, len - 1),
                     "diffkf_checkpoint_check: short");
    for (i = 0; i < sizeof at / sizeof at[0]; ++i) {
        const dkf_real_t keep = ck[at[i]];
        ck[at[i]] = DKF_R(0.5);
        check_failed(&gq, want[i], (snap_take(&gq), dkf_diffkf_checkpoint_check(&k->f, ck, len)),
                     "diffkf_checkpoint_check: a header field", at[i]);
        ck[at[i]] = keep;
    }
    ck[len - 1] = (dkf_real_t)INFINITY;
    EXPECT_UNTOUCHED(&gq, DKF_ERR_NONFINITE, dkf_diffkf_checkpoint_check(&k->f, ck, len),
                     "diffkf_checkpoint_check: Inf");
    ck[len - 1] = DKF_R(0.0);
}

static void test_diffkf(void **state)
{
    static dkf_ctx_t k;
    static dkf_real_t ck[DKF_DIFFKF_STORAGE_LEN(DN, DM, DP)];
    static const char *const names[] = {"F", "Q", "B", "Rd", "H", "A", "R", "y"};
    static const char *const un[] = {"z", "y"};
    dkf_mat_t *v[8], *uv[2];
    mbuf_t x0, P0;
    size_t len;
    (void)state;
    dkf_model(&k, v);
    mset(&x0, DN, 1, x3), mset(&P0, DN, DN, P3);
    assert_int_equal(dkf_diffkf_init(&k.f, DN, DM, DP, k.st, DKF_DIFFKF_STORAGE_LEN(DN, DM, DP),
                                     &x0.v, &P0.v),
                     DKF_OK);
    dkf_regions(&k, 0);
    dkf_query_refusals(&k);
    /* before start: step, gain and update are out of sequence */
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_step_call(&k), "diffkf_step before start");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_gain_call(&k), "diffkf_gain before start");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_update_call(&k), "diffkf_update_z before gain");
    /* start: F0, Q0, H, A, R, y1 (B, Rd are not inputs of start) */
    {
        dkf_mat_t *sv[6] = {v[0], v[1], v[4], v[5], v[6], v[7]};
        static const char *const sn[] = {"F0", "Q0", "H", "A", "R", "y1"};
        static const double Arank1[6] = {1.0, 2.0, 0.0, 0.0, 1.0, 2.0};
        sweep("diffkf_start", dkf_start_call, &k, sv, sn, 6, &k.g);
        mset(&k.A, DM, DP, Arank1);
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_RANK, dkf_start_call(&k), "diffkf_start: rank A = 1");
        mset(&k.A, DM, DP, DA);
        meye(&k.F, DN, (double)huge_value());
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, dkf_start_call(&k), "diffkf_start: overflow");
        mset(&k.F, DN, DN, F3);
    }
    assert_int_equal(dkf_start_call(&k), DKF_OK);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_start_call(&k), "diffkf_start twice");
    assert_int_equal(dkf_step_call(&k), DKF_OK);
    assert_int_equal(dkf_step_call(&k), DKF_OK); /* caches and memo live now */
    sweep("diffkf_step", dkf_step_call, &k, v, names, 8, &k.g);
    dkf_model_failures(&k, dkf_step_call, "diffkf_step");
    sweep("diffkf_gain_masked", dkf_gain_call, &k, v, names, 7, &k.g);
    dkf_model_failures(&k, dkf_gain_call, "diffkf_gain_masked");
    sweep("diffkf_gain", dkf_gain_all_call, &k, v, names, 7, &k.g);
    dkf_model_failures(&k, dkf_gain_all_call, "diffkf_gain");
    /* a pending gain: update_z's failures leave it (and everything) as it
     * was; a step is refused and leaves it too */
    k.rows[1] = 0;
    assert_int_equal(dkf_gain_call(&k), DKF_OK);
    k.z.v.rows = 1;
    dkf_regions(&k, 1);
    {
        /* the pending gain lies where DKF_DIFFKF_PENDING_LEN says */
        dkf_mat_t M, K, zc;
        const dkf_real_t *lo = k.st + DKF_DIFFKF_STATE_LEN(DN, DM, DP),
                         *hi = lo + DKF_DIFFKF_PENDING_LEN(DN, DM, DP);
        assert_int_equal(dkf_diffkf_pending(&k.f, &M, &K, &zc), DKF_OK);
        assert_true(M.data >= lo && M.data + M.rows * M.cols <= hi);
        assert_true(K.data >= lo && K.data + K.rows * K.cols <= hi);
        assert_true(zc.data >= lo && zc.data + zc.rows <= hi);
    }
    uv[0] = &k.z.v, uv[1] = &k.y.v;
    sweep("diffkf_update_z", dkf_update_call, &k, uv, un, 2, &k.g);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_step_call(&k), "diffkf_step while a gain is pending");
    meye(&k.B, DP, 0.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_step_call(&k),
                     "diffkf_step (singular B) while a gain is pending");
    mset(&k.B, DP, DP, B2);
    /* a failed gain cancels the pending one, as documented: pending = 0,
     * pk = z.rows, and nothing else */
    {
        dkf_diffkf_t expect = k.f;
        regions_t gs;
        expect.pending = 0;
        expect.pk = expect.z.rows;
        reg_clear(&gs);
        reg_add(&gs, k.st, DKF_DIFFKF_STATE_LEN(DN, DM, DP) * sizeof(dkf_real_t));
        meye(&k.B, DP, 0.0);
        EXPECT_UNTOUCHED(&gs, DKF_ERR_SINGULAR, dkf_gain_call(&k),
                         "diffkf_gain_masked (B = 0) with a gain pending");
        mset(&k.B, DP, DP, B2);
        assert_memory_equal(&expect, &k.f, sizeof expect);
        /* likewise a gain refused for its shapes (before any computation):
         * never a pending gain with the last step's pk (found by
         * fuzz_core_diffkf) */
        assert_int_equal(dkf_gain_call(&k), DKF_OK);
        k.F.v.rows = DN + 1;
        EXPECT_UNTOUCHED(&gs, DKF_ERR_DIM, dkf_gain_call(&k),
                         "diffkf_gain_masked (F misshaped) with a gain pending");
        k.F.v.rows = DN;
        assert_memory_equal(&expect, &k.f, sizeof expect);
        dkf_regions(&k, 0);
    }
    assert_int_equal(dkf_update_call(&k), DKF_ERR_STATE);
    /* checkpoints: a corrupted one is refused, the filter untouched */
    len = dkf_diffkf_checkpoint_len(&k.f);
    assert_int_equal(dkf_diffkf_save(&k.f, ck, len), DKF_OK);
    ck[len - 1] = (dkf_real_t)NAN;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, dkf_diffkf_restore(&k.f, ck, len),
                     "diffkf_restore: NaN");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_CAPACITY, dkf_diffkf_restore(&k.f, ck, len - 1),
                     "diffkf_restore: short");
    ck[len - 1] = DKF_R(0.0);
    ck[1] += DKF_R(1.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_DIM, dkf_diffkf_restore(&k.f, ck, len), "diffkf_restore: n");
    ck[1] -= DKF_R(1.0);
    dkf_checkpoint_refusals(&k, ck, len);
}

/* ---- Difference-KF fusion centre ------------------------------------------------------ */

#define FN 3
#define FL 2

typedef struct {
    dkf_diffkf_fc_t fc;
    dkf_diffkf_fc_node_t nodes[FL];
    dkf_real_t st[DKF_DIFFKF_FC_STORAGE_MAX(FN, FL, 3, 2)];
    mbuf_t F, Q, B[FL], Rd[FL], H[FL], A[FL], R[FL], P;
    dkf_diffkf_sensor_t s[FL];
    dkf_diffkf_msg_t msgs[FL];
    unsigned char present[FL];
    dkf_diffkf_fc_fault_t fault;
    size_t node, k_start;
    dkf_real_t ck[4096];
    size_t ck_len;
    regions_t g;
} fc_ctx_t;

static const size_t FM[FL] = {3, 2}, FP[FL] = {2, 1};

static dkf_status_t fc_start_call(void *c)
{
    fc_ctx_t *k = c;
    return dkf_diffkf_fc_start(&k->fc, &k->F.v, &k->Q.v, k->s, &k->fault);
}
static dkf_status_t fc_step_call(void *c)
{
    fc_ctx_t *k = c;
    return dkf_diffkf_fc_step(&k->fc, &k->F.v, &k->Q.v, k->s, k->msgs, &k->fault);
}
static dkf_status_t fc_partial_call(void *c)
{
    fc_ctx_t *k = c;
    unsigned char contributed[FL];
    return dkf_diffkf_fc_step_partial(&k->fc, &k->F.v, &k->Q.v, k->s, k->msgs, k->present,
                                      contributed, &k->fault);
}
static dkf_status_t fc_restart_call(void *c)
{
    fc_ctx_t *k = c;
    return dkf_diffkf_fc_restart_node(&k->fc, k->node, k->k_start, &k->P.v, &k->s[k->node],
                                      &k->fault);
}

static void fc_model(fc_ctx_t *k)
{
    static const double H1[6] = {0.0, 1.0, 0.0, 0.0, 0.0, 1.0}, A1[2] = {1.0, 0.5};
    static const double R1[4] = {0.2, 0.0, 0.0, 0.2}, B1[1] = {0.8}, Rd1[1] = {0.05};
    size_t i;
    mset(&k->F, FN, FN, F3), mset(&k->Q, FN, FN, Q3), mset(&k->P, FN, FN, P3);
    mset(&k->H[0], 3, FN, DH), mset(&k->A[0], 3, 2, DA), mset(&k->R[0], 3, 3, DR);
    mset(&k->B[0], 2, 2, B2), mset(&k->Rd[0], 2, 2, Rd2);
    mset(&k->H[1], 2, FN, H1), mset(&k->A[1], 2, 1, A1), mset(&k->R[1], 2, 2, R1);
    mset(&k->B[1], 1, 1, B1), mset(&k->Rd[1], 1, 1, Rd1);
    for (i = 0; i < FL; ++i) {
        k->s[i].B = &k->B[i].v, k->s[i].Rd = &k->Rd[i].v;
        k->s[i].meas.H = &k->H[i].v, k->s[i].meas.D = &k->A[i].v, k->s[i].meas.R = &k->R[i].v;
        k->present[i] = 1;
    }
}

/* Node messages of the FC's next step: x_{k|k-1} = x3 + k/10, x_{k|k} a
 * little off it (any finite pair is a valid message). */
static void fc_msgs(fc_ctx_t *k)
{
    size_t i, j;
    for (i = 0; i < FL; ++i) {
        memset(&k->msgs[i], 0, sizeof k->msgs[i]);
        k->msgs[i].node = (uint16_t)i;
        k->msgs[i].k = (uint32_t)(k->fc.k + 1);
        k->msgs[i].n = FN;
        for (j = 0; j < FN; ++j) {
            k->msgs[i].xp[j] = (dkf_real_t)(x3[j] + 0.1 * (double)k->fc.k);
            k->msgs[i].xf[j] = k->msgs[i].xp[j] + (dkf_real_t)(0.05 * (double)(i + j + 1));
        }
    }
}

static void fc_regions(fc_ctx_t *k)
{
    reg_clear(&k->g);
    reg_add(&k->g, &k->fc, sizeof k->fc);
    reg_add(&k->g, k->nodes, sizeof k->nodes);
    reg_add(&k->g, k->st, dkf_diffkf_fc_state_len(FN, FL, FM, FP) * sizeof(dkf_real_t));
}

/* The model views of a start or step: F, Q, then each sensor's B, Rd, H,
 * A, R (Rd is no input of start: nv leaves it out there). */
static size_t fc_views(fc_ctx_t *k, dkf_mat_t *v[], const char *names[], int with_rd)
{
    static const char *const sn[FL][5] = {{"B0", "Rd0", "H0", "A0", "R0"},
                                          {"B1", "Rd1", "H1", "A1", "R1"}};
    size_t i, nv = 0;
    v[nv] = &k->F.v, names[nv++] = "F";
    v[nv] = &k->Q.v, names[nv++] = "Q";
    for (i = 0; i < FL; ++i) {
        v[nv] = &k->B[i].v, names[nv++] = sn[i][0];
        if (with_rd) v[nv] = &k->Rd[i].v, names[nv++] = sn[i][1];
        v[nv] = &k->H[i].v, names[nv++] = sn[i][2];
        v[nv] = &k->A[i].v, names[nv++] = sn[i][3];
        v[nv] = &k->R[i].v, names[nv++] = sn[i][4];
    }
    return nv;
}

/* Rank, singularity and definiteness faults of sensor i's model, each a
 * model the caches have not seen. */
static void fc_model_failures(fc_ctx_t *k, call_fn call, const char *what, int with_spd)
{
    static const double Arank1[6] = {1.0, 2.0, 0.0, 0.0, 1.0, 2.0}, A0[2] = {0.0, 0.0};
    char label[120];
    size_t i;
    for (i = 0; i < FL; ++i) {
        const mbuf_t Asv = k->A[i];
        if (i == 0)
            mset(&k->A[0], 3, 2, Arank1);
        else
            mset(&k->A[1], 2, 1, A0);
        snprintf(label, sizeof label, "%s: rank A%zu deficient", what, i);
        EXPECT_UNTOUCHED(&k->g, DKF_ERR_RANK, call(k), label);
        k->A[i] = Asv, k->A[i].v.data = k->A[i].d;
        meye(&k->B[i], FP[i], 0.0);
        snprintf(label, sizeof label, "%s: B%zu = 0", what, i);
        EXPECT_UNTOUCHED(&k->g, DKF_ERR_SINGULAR, call(k), label);
        if (i == 0)
            mset(&k->B[0], 2, 2, B2);
        else
            meye(&k->B[1], 1, 0.8);
        if (with_spd) {
            const mbuf_t Rsv = k->R[i];
            meye(&k->R[i], FM[i], -10.0);
            snprintf(label, sizeof label, "%s: R%zu = -10 I (L not SPD)", what, i);
            EXPECT_UNTOUCHED(&k->g, DKF_ERR_NOT_SPD, call(k), label);
            k->R[i] = Rsv, k->R[i].v.data = k->R[i].d;
        }
    }
    meye(&k->F, FN, (double)huge_value());
    snprintf(label, sizeof label, "%s: F P F^T overflows", what);
    EXPECT_UNTOUCHED(&k->g, ANY_ERR, call(k), label);
    mset(&k->F, FN, FN, F3);
}

/* The message faults, in each node's message: node, step, n, NaN/Inf. */
static void fc_msg_failures(fc_ctx_t *k, call_fn call, const char *what)
{
    char label[120];
    size_t i, j;
    for (i = 0; i < FL; ++i) {
        const dkf_diffkf_msg_t ok = k->msgs[i];
        snprintf(label, sizeof label, "%s: msg %zu node", what, i);
        k->msgs[i].node = (uint16_t)(FL - 1 - i);
        EXPECT_UNTOUCHED(&k->g, DKF_ERR_ARG, call(k), label);
        k->msgs[i] = ok;
        snprintf(label, sizeof label, "%s: msg %zu out of sequence", what, i);
        k->msgs[i].k += 1;
        EXPECT_UNTOUCHED(&k->g, DKF_ERR_STATE, call(k), label);
        k->msgs[i].k -= 2;
        EXPECT_UNTOUCHED(&k->g, DKF_ERR_STATE, call(k), label);
        k->msgs[i] = ok;
        snprintf(label, sizeof label, "%s: msg %zu n", what, i);
        k->msgs[i].n = FN + 1;
        EXPECT_UNTOUCHED(&k->g, DKF_ERR_DIM, call(k), label);
        k->msgs[i] = ok;
        for (j = 0; j < FN; ++j) {
            snprintf(label, sizeof label, "%s: msg %zu NaN/Inf", what, i);
            k->msgs[i].xf[j] = (dkf_real_t)NAN;
            EXPECT_UNTOUCHED(&k->g, DKF_ERR_NONFINITE, call(k), label);
            k->msgs[i] = ok;
            k->msgs[i].xp[j] = -(dkf_real_t)INFINITY;
            EXPECT_UNTOUCHED(&k->g, DKF_ERR_NONFINITE, call(k), label);
            k->msgs[i] = ok;
        }
    }
}

/* A failure after the central gain has committed new cache entries (the
 * bug this guards against: the rollback restored the central struct but
 * not its caches). Node messages of size 0.9 s, s = REAL_MAX / 2^e (the
 * first e that succeeds), drive the fused estimate near REAL_MAX; then a
 * step with ordinary messages and F = 2^q F3 (a model no cache has seen)
 * passes every gain and overflows in the central update (F x_{k|k-1}).
 * Each failed call must leave the FC untouched; returns the number of
 * failures in the central filter's update (fault node NO_NODE). The FC
 * is put back as it was before. */
static size_t fc_overflow_failures(fc_ctx_t *k, call_fn call, const char *what)
{
    static unsigned char base[SNAP_CAP];
    char label[120];
    size_t i, j, e, q, central = 0;
    dkf_real_t s = DKF_REAL_MAX;
    dkf_status_t st = DKF_ERR_ARG;
    snap_take(&k->g);
    memcpy(base, snap_bytes, sizeof base);
    for (e = 0; e < 12 && st != DKF_OK; ++e, s /= DKF_R(2.0)) {
        fc_msgs(k);
        for (i = 0; i < FL; ++i)
            for (j = 0; j < FN; ++j) k->msgs[i].xp[j] = k->msgs[i].xf[j] = s * DKF_R(0.9);
        snprintf(label, sizeof label, "%s: messages of size REAL_MAX / 2^%zu", what, e);
        snap_take(&k->g);
        st = call(k);
        if (st != DKF_OK) check_failed(&k->g, ANY_ERR, st, label, e);
    }
    assert_int_equal(st, DKF_OK);
    for (q = 0; q < 12; ++q) {
        fc_msgs(k);
        mset(&k->F, FN, FN, F3);
        for (i = 0; i < FN * FN; ++i) k->F.d[i] *= (dkf_real_t)(1u << q);
        snprintf(label, sizeof label, "%s: fused x near REAL_MAX, F = 2^%zu F3", what, q);
        snap_take(&k->g);
        st = call(k);
        if (st != DKF_OK) {
            check_failed(&k->g, ANY_ERR, st, label, q);
            central += k->fault.node == DKF_DIFFKF_FC_NO_NODE;
        }
        snap_restore(&k->g);
    }
    memcpy(snap_bytes, base, sizeof base);
    snap_restore(&k->g);
    mset(&k->F, FN, FN, F3);
    fc_msgs(k);
    return central;
}

static void test_diffkf_fc(void **state)
{
    static fc_ctx_t k;
    dkf_mat_t *v[2 + 5 * FL];
    const char *names[2 + 5 * FL];
    mbuf_t x0;
    size_t nv, len;
    (void)state;
    fc_model(&k);
    mset(&x0, FN, 1, x3);
    assert_true(dkf_diffkf_fc_storage_len(FN, FL, FM, FP) <= sizeof k.st / sizeof k.st[0]);
    assert_int_equal(dkf_diffkf_fc_init(&k.fc, k.nodes, FL, FN, FM, FP, k.st,
                                        dkf_diffkf_fc_storage_len(FN, FL, FM, FP), &x0.v, &k.P.v,
                                        NULL, &k.fault),
                     DKF_OK);
    fc_regions(&k);
    fc_msgs(&k);
    /* out of sequence before the start */
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, fc_step_call(&k), "fc_step before start");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, fc_partial_call(&k), "fc_step_partial before start");
    k.node = 0, k.k_start = 1;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, fc_restart_call(&k), "fc_restart_node before start");
    nv = fc_views(&k, v, names, 0);
    sweep("fc_start", fc_start_call, &k, v, names, nv, &k.g);
    fc_model_failures(&k, fc_start_call, "fc_start", 0);
    assert_int_equal(fc_start_call(&k), DKF_OK);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, fc_start_call(&k), "fc_start twice");
    fc_msgs(&k);
    assert_int_equal(fc_step_call(&k), DKF_OK);
    fc_msgs(&k);
    assert_int_equal(fc_step_call(&k), DKF_OK); /* caches, memo, carries live */
    fc_msgs(&k);

    nv = fc_views(&k, v, names, 1);
    sweep("fc_step", fc_step_call, &k, v, names, nv, &k.g);
    fc_model_failures(&k, fc_step_call, "fc_step", 1);
    fc_msg_failures(&k, fc_step_call, "fc_step");
    assert_true(fc_overflow_failures(&k, fc_step_call, "fc_step") > 0);

    /* degraded: node 1 absent (its message is not checked), node 0 present */
    k.present[1] = 0;
    sweep("fc_step_partial", fc_partial_call, &k, v, names, nv, &k.g);
    fc_model_failures(&k, fc_partial_call, "fc_step_partial", 1);
    assert_true(fc_overflow_failures(&k, fc_partial_call, "fc_step_partial") > 0);
    assert_int_equal(fc_partial_call(&k), DKF_OK); /* node 1 out of sync now */
    fc_msgs(&k);
    k.present[1] = 1;
    fc_msg_failures(&k, fc_partial_call, "fc_step_partial");
    sweep("fc_step_partial (node 1 out of sync)", fc_partial_call, &k, v, names, nv, &k.g);
    assert_true(fc_overflow_failures(&k, fc_partial_call, "fc_step_partial (out of sync)") > 0);

    /* restart of a node: prior, model, node index, sequence */
    {
        dkf_mat_t *rv[4];
        static const char *const rn[] = {"P_prior", "H", "A", "R"};
        static const double Pbad[9] = {1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0};
        k.node = 0, k.k_start = k.fc.k + 1;
        rv[0] = &k.P.v, rv[1] = &k.H[0].v, rv[2] = &k.A[0].v, rv[3] = &k.R[0].v;
        sweep("fc_restart_node", fc_restart_call, &k, rv, rn, 4, &k.g);
        mset(&k.P, FN, FN, Pbad);
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, fc_restart_call(&k), "fc_restart_node: P not SPD");
        mset(&k.P, FN, FN, P3);
        {
            static const double Arank1[6] = {1.0, 2.0, 0.0, 0.0, 1.0, 2.0};
            mset(&k.A[0], 3, 2, Arank1);
            EXPECT_UNTOUCHED(&k.g, DKF_ERR_RANK, fc_restart_call(&k), "fc_restart_node: rank A");
            mset(&k.A[0], 3, 2, DA);
        }
        k.node = FL;
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_ARG, fc_restart_call(&k), "fc_restart_node: node >= l");
        k.node = 1, k.k_start = k.fc.k + 2;
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, fc_restart_call(&k), "fc_restart_node: k_start");
        k.k_start = k.fc.k;
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, fc_restart_call(&k), "fc_restart_node: k_start");
    }

    /* checkpoints: a corrupted one is refused, the FC untouched */
    len = dkf_diffkf_fc_checkpoint_len(&k.fc);
    assert_true(len > 0 && len <= sizeof k.ck / sizeof k.ck[0]);
    assert_int_equal(dkf_diffkf_fc_save(&k.fc, k.ck, len), DKF_OK);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_CAPACITY, dkf_diffkf_fc_restore(&k.fc, k.ck, len - 1),
                     "fc_restore: short");
    k.ck[len - 1] = (dkf_real_t)NAN;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, dkf_diffkf_fc_restore(&k.fc, k.ck, len),
                     "fc_restore: NaN");
    k.ck[len - 1] = DKF_R(0.0);
    k.ck[1] += DKF_R(1.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_DIM, dkf_diffkf_fc_restore(&k.fc, k.ck, len), "fc_restore: n");
    k.ck[1] -= DKF_R(1.0);
    k.ck[0] += DKF_R(1.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_ARG, dkf_diffkf_fc_restore(&k.fc, k.ck, len), "fc_restore: tag");
    k.ck[0] -= DKF_R(1.0);
    k.ck[9] = DKF_R(2.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_ARG, dkf_diffkf_fc_restore(&k.fc, k.ck, len),
                     "fc_restore: start flag");
    k.ck[9] = DKF_R(1.0);
    {
        regions_t gq = k.g;
        reg_add(&gq, k.ck, len * sizeof k.ck[0]);
        EXPECT_UNTOUCHED(&gq, DKF_ERR_CAPACITY, dkf_diffkf_fc_save(&k.fc, k.ck, len - 1),
                         "fc_save: short");
        EXPECT_UNTOUCHED(&gq, DKF_ERR_ARG, dkf_diffkf_fc_set_steady(&k.fc, DKF_R(1.5)),
                         "fc_set_steady: tol > 1");
        EXPECT_UNTOUCHED(&gq, DKF_ERR_ARG, dkf_diffkf_fc_set_steady(&k.fc, (dkf_real_t)NAN),
                         "fc_set_steady: tol NaN");
    }
    /* the intact checkpoint restores, and a failed step after it is
     * untouched too (the central caches were reset by the restore) */
    assert_int_equal(dkf_diffkf_fc_restore(&k.fc, k.ck, len), DKF_OK);
    fc_msgs(&k);
    assert_true(fc_overflow_failures(&k, fc_step_call, "fc_step after restore") > 0);
}

/* ---- UIF ---------------------------------------------------------------------------------- */

typedef struct {
    dkf_uif_t f;
    dkf_real_t st[DKF_UIF_STORAGE_LEN(3, 2, 2)];
    mbuf_t A, G, Q, C, H, R, y;
    dkf_uif_dyn_t dyn;
    dkf_ui_meas_t meas;
    int with_dyn;
    regions_t g;
} uif_ctx_t;

static dkf_status_t uif_step_call(void *c)
{
    uif_ctx_t *k = c;
    return dkf_uif_step(&k->f, k->with_dyn ? &k->dyn : NULL, &k->meas, &k->y.v);
}

static void uif_case(dkf_uif_kind_t kind, size_t p, const double *Hv, const char *what)
{
    static uif_ctx_t k;
    static const double G[6] = {1.0, 0.0, 0.0, 1.0, 0.5, 0.0};
    static const double C[6] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0};
    static const double R[4] = {0.1, 0.0, 0.0, 0.1}, y[2] = {0.3, -0.2};
    static const char *const names[] = {"A", "G", "Q", "C", "R", "y", "H"};
    char label[120];
    dkf_mat_t *v[7];
    mbuf_t x0, P0;
    const size_t m = 2;
    size_t nv;
    v[0] = mset(&k.A, 3, 3, F3), v[1] = mset(&k.G, 3, p, G), v[2] = mset(&k.Q, 3, 3, Q3);
    v[3] = mset(&k.C, m, 3, C), v[4] = mset(&k.R, m, m, R), v[5] = mset(&k.y, m, 1, y);
    v[6] = Hv != NULL ? mset(&k.H, m, p, Hv) : NULL;
    nv = Hv != NULL ? 7 : 6;
    k.dyn.F = &k.A.v, k.dyn.G = &k.G.v, k.dyn.Q = &k.Q.v;
    k.meas.H = &k.C.v, k.meas.D = Hv != NULL ? &k.H.v : NULL, k.meas.R = &k.R.v;
    mset(&x0, 3, 1, x3), mset(&P0, 3, 3, P3);
    assert_int_equal(dkf_uif_init(&k.f, kind, 3, m, p, k.st, DKF_UIF_STORAGE_LEN(3, m, p), &x0.v,
                                  &P0.v),
                     DKF_OK);
    reg_clear(&k.g);
    reg_add(&k.g, &k.f, sizeof k.f);
    reg_add(&k.g, k.st, DKF_UIF_STATE_LEN(3, m, p) * sizeof(dkf_real_t));
    k.with_dyn = kind == DKF_UIF_NRTSF;
    assert_int_equal(uif_step_call(&k), DKF_OK);
    k.with_dyn = 1;
    assert_int_equal(uif_step_call(&k), DKF_OK); /* the cache is live */
    snprintf(label, sizeof label, "uif_step %s", what);
    sweep(label, uif_step_call, &k, v, names, nv, &k.g);
    /* out of sequence: no dynamics after the first step */
    k.with_dyn = 0;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, uif_step_call(&k), "uif_step: dyn NULL");
    k.with_dyn = 1;
    meye(&k.R, m, -10.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, uif_step_call(&k), "uif_step: R = -10 I");
    mset(&k.R, m, m, R);
    meye(&k.A, 3, (double)huge_value());
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, uif_step_call(&k), "uif_step: overflow");
    mset(&k.A, 3, 3, F3);
    if (kind == DKF_UIF_RTSF) {
        /* a new H of rank 1 < p: decided after a new decomposition (a
         * cache miss), refused with the cache as it was */
        static const double Hr[4] = {1.0, 2.0, 2.0, 4.0};
        mset(&k.H, m, p, Hr);
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_RANK, uif_step_call(&k), "uif_step RTSF: rank H = 1");
        mset(&k.H, m, p, Hv);
    }
    if (kind == DKF_UIF_NRTSF) {
        /* C G loses the rank of a new G: G's columns in null(C) */
        static const double Gn[6] = {0.0, 0.0, 0.0, 0.0, 1.0, 0.5};
        mset(&k.G, 3, p, Gn);
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_RANK, uif_step_call(&k), "uif_step NRTSF: rank C G");
        mset(&k.G, 3, p, G);
        k.meas.D = &k.C.v;
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_ARG, uif_step_call(&k), "uif_step NRTSF: H given");
        k.meas.D = NULL;
    }
}

static void test_uif(void **state)
{
    static const double Hfull[4] = {1.0, 0.0, 0.2, 1.0};
    static const double Hdef[4] = {1.0, 1.0, 0.0, 0.0}; /* rank 1 < p = 2 */
    (void)state;
    uif_case(DKF_UIF_RTSF, 2, Hfull, "RTSF");
    uif_case(DKF_UIF_NRTSF_DF, 2, Hdef, "NRTSF-DF");
    uif_case(DKF_UIF_NRTSF, 2, NULL, "NRTSF");
}

/* ---- Talebi-Werner nodes and networks ------------------------------------------------------- */

#define TN 3
#define TP 1
#define TPK DKF_TW_PKT_LEN(TN)
#define TNODES 4

typedef struct {
    dkf_tw_node_t nd;
    dkf_real_t st[DKF_TW_NODE_STORAGE_LEN(TN, 2, TP)];
    mbuf_t A, B, Sv, H, Sw, y;
    dkf_uif_dyn_t md;
    dkf_kf_meas_t sn;
    dkf_real_t info[TPK + 1], pkt[TPK];
    regions_t g;
} tw_ctx_t;

static dkf_status_t tw_local_call(void *c)
{
    tw_ctx_t *k = c;
    return dkf_tw_node_local(&k->nd, &k->md, k->info, NULL);
}
static dkf_status_t tw_packet_call(void *c)
{
    tw_ctx_t *k = c;
    return dkf_tw_meas_packet(k->pkt, &k->nd, &k->sn, &k->y.v, DKF_R(1.0));
}
static dkf_status_t tw_central_call(void *c)
{
    tw_ctx_t *k = c;
    return dkf_tw_central_step(&k->nd, &k->md, &k->sn, &k->y.v, 1);
}

static const double TB[3] = {0.0, 0.0, 1.0};
static const double TH[6] = {1.0, 0.0, 0.0, 0.0, 1.0, 1.0};
static const double TSw[4] = {0.1, 0.0, 0.0, 0.1}, Ty[2] = {0.4, 0.1};

static void tw_regions(tw_ctx_t *k)
{
    reg_clear(&k->g);
    reg_add(&k->g, &k->nd, sizeof k->nd);
    reg_add(&k->g, k->st, DKF_TW_NODE_STATE_LEN(TN, TP) * sizeof(dkf_real_t));
}

static void test_tw_node(void **state)
{
    static tw_ctx_t k;
    static const char *const mn[] = {"A", "B", "Sv"}, *const sn[] = {"H", "Sw", "y"};
    static const char *const inn[] = {"info"};
    dkf_mat_t *mv[3], *sv[3], infov;
    dkf_real_t xs[TN], Pp[TPK - TN];
    mbuf_t x0, P0;
    size_t i;
    (void)state;
    mv[0] = mset(&k.A, TN, TN, F3), mv[1] = mset(&k.B, TN, TP, TB), mv[2] = mset(&k.Sv, TN, TN, Q3);
    sv[0] = mset(&k.H, 2, TN, TH), sv[1] = mset(&k.Sw, 2, 2, TSw), sv[2] = mset(&k.y, 2, 1, Ty);
    k.md.F = &k.A.v, k.md.G = &k.B.v, k.md.Q = &k.Sv.v;
    k.sn.H = &k.H.v, k.sn.R = &k.Sw.v;
    mset(&x0, TN, 1, x3), mset(&P0, TN, TN, P3);
    assert_int_equal(dkf_tw_node_init(&k.nd, TN, 2, TP, k.st, DKF_TW_NODE_STORAGE_LEN(TN, 2, TP),
                                      &x0.v, &P0.v),
                     DKF_OK);
    assert_true(k.nd.priv.mem == k.st + DKF_TW_NODE_STATE_LEN(TN, TP));
    assert_int_equal(tw_central_call(&k), DKF_OK);
    tw_regions(&k);
    sweep("tw_central_step", tw_central_call, &k, sv, sn, 3, &k.g);
    sweep("tw_central_step (model)", tw_central_call, &k, mv, mn, 3, &k.g);
    /* the info packet of the sensor, and the local step on it */
    assert_int_equal(tw_packet_call(&k), DKF_OK);
    {
        regions_t gp = k.g;
        reg_add(&gp, k.pkt, sizeof k.pkt);
        sweep("tw_meas_packet", tw_packet_call, &k, sv, sn, 3, &gp);
        meye(&k.Sw, 2, -1.0);
        EXPECT_UNTOUCHED(&gp, DKF_ERR_NOT_SPD, tw_packet_call(&k), "tw_meas_packet: Sw = -I");
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, tw_central_call(&k), "tw_central_step: Sw = -I");
        mset(&k.Sw, 2, 2, TSw);
    }
    memcpy(k.info, k.pkt, sizeof k.pkt);
    sweep("tw_node_local", tw_local_call, &k, mv, mn, 3, &k.g);
    infov = test_view(1, TPK, k.info);
    {
        dkf_mat_t *iv[1] = {&infov};
        /* only the value kinds apply to a raw packet */
        int kk;
        for (kk = K_NAN; kk <= K_NINF; ++kk)
            for (i = 0; i < TPK; ++i) {
                undo_t u;
                corrupt(&infov, (kind_t)kk, i, &u);
                EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, tw_local_call(&k), "tw_node_local: info");
                uncorrupt(&infov, &u);
            }
        (void)iv;
        (void)inn;
    }
    meye(&k.Sv, TN, -10.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, tw_local_call(&k), "tw_node_local: Phi- not SPD");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, tw_central_call(&k), "tw_central_step: Phi- not SPD");
    mset(&k.Sv, TN, TN, Q3);
    {
        /* no information on z: S = 0, rank(H B) = 0 < m */
        static const double Hz[6] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0};
        dkf_real_t saved[TPK];
        memcpy(saved, k.info, sizeof saved);
        mset(&k.H, 2, TN, Hz);
        assert_int_equal(tw_packet_call(&k), DKF_OK);
        memcpy(k.info, k.pkt, sizeof k.pkt);
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_RANK, tw_local_call(&k), "tw_node_local: rank H B = 0");
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_RANK, tw_central_call(&k), "tw_central_step: rank H B = 0");
        mset(&k.H, 2, TN, TH);
        memcpy(k.info, saved, sizeof saved);
    }
    /* commit without a pending step; with a pending step, a bad commit */
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_tw_node_commit(&k.nd, NULL, NULL),
                     "tw_node_commit: nothing pending");
    assert_int_equal(tw_local_call(&k), DKF_OK);
    tw_regions(&k);
    reg_add(&k.g, k.nd.priv.mem,
            (DKF_TW_NODE_STATE_LEN(TN, TP) - TN - TN * TN) * sizeof(dkf_real_t));
    for (i = 0; i < TN; ++i) xs[i] = DKF_R(0.0);
    for (i = 0; i < TPK - TN; ++i) Pp[i] = DKF_R(0.0);
    Pp[0] = DKF_R(-1.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, dkf_tw_node_commit(&k.nd, xs, Pp),
                     "tw_node_commit: P not SPD");
    xs[1] = (dkf_real_t)NAN;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, dkf_tw_node_commit(&k.nd, xs, NULL),
                     "tw_node_commit: x NaN");
    assert_int_equal(dkf_tw_node_commit(&k.nd, NULL, NULL), DKF_OK);
    /* with a step pending, a failed local step or central step leaves it
     * pending, whichever check fails: every refusal above again */
    assert_int_equal(tw_local_call(&k), DKF_OK);
    tw_regions(&k);
    reg_add(&k.g, k.nd.priv.mem,
            (DKF_TW_NODE_STATE_LEN(TN, TP) - TN - TN * TN) * sizeof(dkf_real_t));
    sweep("tw_node_local (pending)", tw_local_call, &k, mv, mn, 3, &k.g);
    sweep("tw_central_step (pending)", tw_central_call, &k, sv, sn, 3, &k.g);
    sweep("tw_central_step (model, pending)", tw_central_call, &k, mv, mn, 3, &k.g);
    meye(&k.Sv, TN, -10.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, tw_local_call(&k), "tw_node_local (pending): Phi-");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, tw_central_call(&k), "tw_central_step (pending): Phi-");
    mset(&k.Sv, TN, TN, Q3);
    k.info[1] = (dkf_real_t)NAN;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, tw_local_call(&k), "tw_node_local (pending): info");
    memcpy(k.info, k.pkt, sizeof k.pkt);
    {
        /* no information on z: rank(H B) = 0 */
        static const double Hz[6] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0};
        mset(&k.H, 2, TN, Hz);
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_RANK, tw_central_call(&k),
                         "tw_central_step (pending): rank H B = 0");
        mset(&k.H, 2, TN, TH);
    }
    assert_int_equal(k.nd.pending, 1);
    assert_int_equal(dkf_tw_node_commit(&k.nd, NULL, NULL), DKF_OK);
}

/* A path 0-1-2-3: nodes 0, 1 observe z, nodes 2, 3 do not, so the local
 * steps of nodes 2 and 3 fail (rank) after those of 0 and 1 succeeded:
 * the failed net step must leave every node as it was, none pending. */
static void test_tw_net(void **state)
{
    static dkf_tw_node_t nodes[TNODES];
    static dkf_real_t st[DKF_TW_NET_STORAGE_LEN(TNODES, TN, 2, TP)];
    static const size_t edges[] = {0, 1, 1, 2, 2, 3};
    static size_t start[TNODES + 1], nbr[DKF_GRAPH_NNZ(TNODES, 3)];
    static const double Hz[6] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0};
    dkf_real_t alpha[DKF_GRAPH_NNZ(TNODES, 3)], W[DKF_GRAPH_NNZ(TNODES, 3)];
    mbuf_t A, B, Sv, H, H0, Sw, y, x0, P0;
    dkf_kf_meas_t sens[TNODES];
    dkf_mat_t ys[TNODES];
    dkf_uif_dyn_t md;
    dkf_graph_t g;
    dkf_tw_net_t net;
    regions_t rg;
    size_t l;
    const size_t node_len = DKF_TW_NODE_STORAGE_LEN(TN, 2, TP);
    (void)state;
    assert_int_equal(dkf_graph_from_edges(&g, start, nbr, DKF_GRAPH_NNZ(TNODES, 3), TNODES, edges, 3),
                     DKF_OK);
    assert_int_equal(dkf_graph_weights_uniform(alpha, &g), DKF_OK);
    assert_int_equal(dkf_graph_weights_metropolis(W, &g), DKF_OK);
    mset(&A, TN, TN, F3), mset(&B, TN, TP, TB), mset(&Sv, TN, TN, Q3);
    mset(&H, 2, TN, TH), mset(&H0, 2, TN, Hz), mset(&Sw, 2, 2, TSw), mset(&y, 2, 1, Ty);
    mset(&x0, TN, 1, x3), mset(&P0, TN, TN, P3);
    md.F = &A.v, md.G = &B.v, md.Q = &Sv.v;
    for (l = 0; l < TNODES; ++l) {
        sens[l].H = &H.v;
        sens[l].R = &Sw.v;
        ys[l] = y.v;
    }
    assert_int_equal(dkf_tw_net_init(&net, &g, nodes, TN, 2, TP, st, sizeof st / sizeof st[0],
                                     &x0.v, &P0.v),
                     DKF_OK);
    assert_int_equal(dkf_tw_net_diffusion_step(&net, alpha, &md, sens, ys), DKF_OK);
    reg_clear(&rg);
    reg_add(&rg, &net, sizeof net);
    reg_add(&rg, nodes, sizeof nodes);
    for (l = 0; l < TNODES; ++l)
        reg_add(&rg, st + l * node_len, DKF_TW_NODE_STATE_LEN(TN, TP) * sizeof(dkf_real_t));
    sens[2].H = sens[3].H = &H0.v;
    EXPECT_UNTOUCHED(&rg, DKF_ERR_RANK, dkf_tw_net_diffusion_step(&net, alpha, &md, sens, ys),
                     "tw_net_diffusion_step: nodes 2, 3 without information on z");
    EXPECT_UNTOUCHED(&rg, DKF_ERR_RANK, dkf_tw_net_consensus_step(&net, W, 0, &md, sens, ys),
                     "tw_net_consensus_step: nodes 2, 3 without information on z");
    sens[2].H = sens[3].H = &H.v;
    EXPECT_UNTOUCHED(&rg, DKF_ERR_WEIGHTS, dkf_tw_net_consensus_step(&net, alpha, 2, &md, sens, ys),
                     "tw_net_consensus_step: alpha is not doubly stochastic");
    Sw.d[0] = DKF_R(-1.0);
    EXPECT_UNTOUCHED(&rg, DKF_ERR_NOT_SPD, dkf_tw_net_diffusion_step(&net, alpha, &md, sens, ys),
                     "tw_net_diffusion_step: Sw not SPD");
    Sw.d[0] = (dkf_real_t)TSw[0];
    A.d[4] = (dkf_real_t)NAN;
    EXPECT_UNTOUCHED(&rg, DKF_ERR_NONFINITE, dkf_tw_net_consensus_step(&net, W, 2, &md, sens, ys),
                     "tw_net_consensus_step: A NaN");
    A.d[4] = (dkf_real_t)F3[4];
    assert_int_equal(dkf_tw_net_consensus_step(&net, W, 2, &md, sens, ys), DKF_OK);
    /* a node with a step of its own pending: both steps refuse to run (a
     * failure could not give that step back) */
    assert_int_equal(dkf_tw_meas_packet(net.priv.mix, &nodes[1], &sens[1], &ys[1], DKF_R(1.0)),
                     DKF_OK);
    assert_int_equal(dkf_tw_node_local(&nodes[1], &md, net.priv.mix, NULL), DKF_OK);
    reg_add(&rg, st + node_len + DKF_TW_NODE_STATE_LEN(TN, TP),
            (DKF_TW_NODE_STATE_LEN(TN, TP) - TN - TN * TN) * sizeof(dkf_real_t));
    EXPECT_UNTOUCHED(&rg, DKF_ERR_STATE, dkf_tw_net_diffusion_step(&net, alpha, &md, sens, ys),
                     "tw_net_diffusion_step: node 1 pending");
    EXPECT_UNTOUCHED(&rg, DKF_ERR_STATE, dkf_tw_net_consensus_step(&net, W, 2, &md, sens, ys),
                     "tw_net_consensus_step: node 1 pending");
    assert_int_equal(dkf_tw_node_commit(&nodes[1], NULL, NULL), DKF_OK);
    assert_int_equal(dkf_tw_net_diffusion_step(&net, alpha, &md, sens, ys), DKF_OK);
}

/* ---- nerts (seed 001's single-node filters) --------------------------------------------------- */

#define NN 3
#define NM 3
#define NP 1

typedef struct {
    dkf_nerts_t f;
    dkf_real_t st[DKF_NERTS_STORAGE_LEN(NN, NM, NP)];
    lxs_t c;
    dkf_nl_model_t md;
    mbuf_t Q, R, z, Y, y;
    regions_t g;
} nerts_ctx_t;

static dkf_status_t nerts_predict_call(void *c)
{
    nerts_ctx_t *k = c;
    return dkf_nerts_predict(&k->f, &k->md, NULL, &k->Q.v);
}
static dkf_status_t nerts_local_call(void *c)
{
    nerts_ctx_t *k = c;
    return dkf_nerts_local(&k->f, &k->md, NULL, &k->R.v, &k->z.v);
}
static dkf_status_t nerts_step_call(void *c)
{
    nerts_ctx_t *k = c;
    return dkf_nerts_step(&k->f, &k->md, NULL, &k->Q.v, NULL, &k->R.v, &k->z.v);
}
static dkf_status_t nerts_commit_call(void *c)
{
    nerts_ctx_t *k = c;
    return dkf_nerts_commit_info(&k->f, &k->Y.v, &k->y.v);
}

/* nertsif.json's lin_x_sin_d model in c (n = NN, m = NM, p = NP) */
static dkf_nl_model_t lxs_fill(lxs_t *c, int jacobians)
{
    static const double A[9] = {1, 0.1, 0, 0, 0.95, 0.1, 0, 0, 0.9}, b[3] = {0, 0.1, 0.05};
    static const double C[9] = {1, 0, 0, 0, 0, 1, 1, 1, 0}, H[3] = {0, 0.5, 1};
    memset(c, 0, sizeof *c);
    c->n = NN, c->m = NM, c->p = NP;
    memcpy(c->A, A, sizeof A);
    memcpy(c->B, b, sizeof b);
    memcpy(c->C, C, sizeof C);
    memcpy(c->H, H, sizeof H);
    return lxs_model(c, jacobians);
}

static void nerts_model(nerts_ctx_t *k, int jacobians)
{
    k->md = lxs_fill(&k->c, jacobians);
}

/* Every way a phase can fail, with the filter live (two steps done). */
static void nerts_case(dkf_nerts_kind_t kind, int jacobians, const char *what)
{
    static nerts_ctx_t k;
    static const double R3[9] = {0.02, 0.005, 0, 0.005, 0.03, 0, 0, 0, 0.01};
    static const double z3[3] = {0.1, 0.6, 0.5}, Pd[1] = {0.25}, d0[1] = {0.1};
    static const double Pxd0[3] = {0.01, -0.02, 0.0};
    static const char *const qname[] = {"Q"}, *const rz[] = {"R", "z"},
                             *const qrz[] = {"Q", "R", "z"}, *const yy[] = {"Y", "y"};
    const int info = kind == DKF_NERTS_NERTSIF || kind == DKF_NERTS_DNERTSIF;
    char label[160];
    dkf_mat_t *v[3];
    mbuf_t x0, P0, dd, PPd, PPxd;
    dkf_nl_model_t other;
    nerts_model(&k, jacobians);
    mset(&k.Q, NN, NN, Q3), mset(&k.R, NM, NM, R3), mset(&k.z, NM, 1, z3);
    mset(&x0, NN, 1, x3), mset(&P0, NN, NN, P3), mset(&dd, NP, 1, d0), mset(&PPd, NP, NP, Pd);
    mset(&PPxd, NN, NP, Pxd0);
    assert_int_equal(dkf_nerts_init(&k.f, kind, NN, NM, NP, k.st, DKF_NERTS_STORAGE_LEN(NN, NM, NP),
                                    &x0.v, &P0.v, &dd.v, &PPd.v, &PPxd.v),
                     DKF_OK);
    reg_clear(&k.g);
    reg_add(&k.g, &k.f, sizeof k.f);
    reg_add(&k.g, k.st, DKF_NERTS_STATE_LEN(NN, NM, NP) * sizeof(dkf_real_t));
    assert_int_equal(nerts_step_call(&k), DKF_OK);
    assert_int_equal(nerts_step_call(&k), DKF_OK);
    /* every kind of bad matrix in every input of every phase */
    v[0] = &k.Q.v;
    snprintf(label, sizeof label, "nerts_predict %s", what);
    sweep(label, nerts_predict_call, &k, v, qname, 1, &k.g);
    v[0] = &k.Q.v, v[1] = &k.R.v, v[2] = &k.z.v;
    snprintf(label, sizeof label, "nerts_step %s", what);
    sweep(label, nerts_step_call, &k, v, qrz, 3, &k.g);
    /* out of sequence */
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, nerts_local_call(&k), "nerts_local before predict");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_nerts_update(&k.f), "nerts_update before local");
    assert_int_equal(nerts_predict_call(&k), DKF_OK);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_nerts_update(&k.f), "nerts_update after predict");
    v[0] = &k.R.v, v[1] = &k.z.v;
    snprintf(label, sizeof label, "nerts_local %s", what);
    sweep(label, nerts_local_call, &k, v, rz, 2, &k.g);
    /* the model */
    other = k.md;
    other.m = 2;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_DIM, dkf_nerts_local(&k.f, &other, NULL, &k.R.v, &k.z.v),
                     "nerts_local: model m = 2");
    other = k.md;
    other.h = NULL;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NULL, dkf_nerts_local(&k.f, &other, NULL, &k.R.v, &k.z.v),
                     "nerts_local: h NULL");
    k.c.fail_h = 1;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_MODEL, nerts_local_call(&k), "nerts_local: h fails");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_MODEL, nerts_step_call(&k), "nerts_step: h fails");
    k.c.fail_h = 0;
    k.c.nan_h = 1;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, nerts_local_call(&k), "nerts_local: h gives NaN");
    k.c.nan_h = 0;
    k.c.fail_f = 1;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_MODEL, nerts_predict_call(&k), "nerts_predict: f fails");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_MODEL, nerts_step_call(&k), "nerts_step: f fails");
    k.c.fail_f = 0;
    meye(&k.R, NM, -0.01);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, nerts_local_call(&k), "nerts_local: R = -0.01 I");
    mset(&k.R, NM, NM, R3);
    meye(&k.Q, NN, -10.0);
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, nerts_step_call(&k), "nerts_step: Q = -10 I");
    mset(&k.Q, NN, NN, Q3);
    /* rank Hd = 0 < p */
    k.c.H[0] = k.c.H[1] = k.c.H[2] = 0;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_RANK, nerts_local_call(&k), "nerts_local: Hd = 0");
    nerts_model(&k, jacobians);
    /* the commits */
    assert_int_equal(nerts_local_call(&k), DKF_OK);
    if (info) {
        static const double Yd[9] = {20, 1, 0, 1, 30, 2, 0, 2, 25}, yd[3] = {1, -2, 0.5};
        static const char *const ynames[] = {"Y", "y"};
        mset(&k.Y, NN, NN, Yd), mset(&k.y, NN, 1, yd);
        v[0] = &k.Y.v, v[1] = &k.y.v;
        snprintf(label, sizeof label, "nerts_commit_info %s", what);
        sweep(label, nerts_commit_call, &k, v, ynames, 2, &k.g);
        meye(&k.Y, NN, -1.0);
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, nerts_commit_call(&k), "nerts_commit_info: Y = -I");
        /* a consensus Px far below the local Pxd: the joint covariance
         * [[Px, Pxd], [Pxd^T, Pd]] is indefinite (note section 4 item 6) */
        meye(&k.Y, NN, 1e8);
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, nerts_commit_call(&k),
                         "nerts_commit_info: joint covariance indefinite");
        (void)yy;
    } else {
        meye(&k.Y, NN, 1.0), mset(&k.y, NN, 1, x3);
        EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, nerts_commit_call(&k),
                         "nerts_commit_info on a covariance kind");
        (void)yy;
    }
    assert_int_equal(dkf_nerts_update(&k.f), DKF_OK);
}

/* p = 2 with Hd's columns parallel (rank 1): Hd^T R_tilde^{-1} Hd is
 * singular only up to rounding, so a Cholesky of it may pass; the rank is
 * decided on the whitened Hd by singular values. */
static void nerts_rank_p2(dkf_nerts_kind_t kind)
{
    static dkf_nerts_t f;
    static dkf_real_t st[DKF_NERTS_STORAGE_LEN(3, 4, 2)];
    static lxs_t c;
    static const double A[9] = {1, 0.1, 0, 0, 0.95, 0.1, 0, 0, 0.9};
    static const double B[6] = {0, 0.1, 0.1, 0, 0.05, 0.05}, C[12] = {1, 0, 0, 0, 0, 1, 1, 1, 0, 0, 1, 1};
    static const double Hpar[8] = {0.3, 0.21, 0.5, 0.35, 1.0, 0.7, 0.1, 0.07}; /* col 2 = 0.7 col 1 */
    static const double R4[16] = {0.02, 0, 0, 0, 0, 0.03, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 0.02};
    static const double z4[4] = {0.1, 0.2, -0.1, 0.3}, zero[6] = {0}, I2[4] = {1, 0, 0, 1};
    mbuf_t x0, P0, d0, Pd0, Pxd0, Q, R, z;
    regions_t g;
    dkf_nl_model_t md;
    memset(&c, 0, sizeof c);
    c.n = 3, c.m = 4, c.p = 2;
    memcpy(c.A, A, sizeof A), memcpy(c.B, B, sizeof B), memcpy(c.C, C, sizeof C);
    memcpy(c.H, Hpar, sizeof Hpar);
    md = lxs_model(&c, 1);
    mset(&x0, 3, 1, x3), mset(&P0, 3, 3, P3), mset(&d0, 2, 1, zero), mset(&Pd0, 2, 2, I2);
    mset(&Pxd0, 3, 2, zero), mset(&Q, 3, 3, Q3), mset(&R, 4, 4, R4), mset(&z, 4, 1, z4);
    assert_int_equal(dkf_nerts_init(&f, kind, 3, 4, 2, st, DKF_NERTS_STORAGE_LEN(3, 4, 2), &x0.v,
                                    &P0.v, &d0.v, &Pd0.v, &Pxd0.v),
                     DKF_OK);
    reg_clear(&g);
    reg_add(&g, &f, sizeof f);
    reg_add(&g, st, DKF_NERTS_STATE_LEN(3, 4, 2) * sizeof(dkf_real_t));
    EXPECT_UNTOUCHED(&g, DKF_ERR_RANK, dkf_nerts_step(&f, &md, NULL, &Q.v, NULL, &R.v, &z.v),
                     "nerts_step p = 2: Hd of rank 1");
    /* rank 2 in exact arithmetic, but sigma_2 / sigma_1 ~ 1e-10: G's
     * rounding (~ eps G) swamps its smallest eigenvalue */
    {
        static const double pert[4] = {3e-8, 1e-8, 1e-9, 1e-11};
        char what[96];
        size_t i;
        for (i = 0; i < 4; ++i) {
            c.H[7] = 0.07 + pert[i];
            snprintf(what, sizeof what, "nerts_step p = 2: Hd of rank 2, sigma ratio ~ %.0e", pert[i]);
            EXPECT_UNTOUCHED(&g, DKF_ERR_RANK,
                             dkf_nerts_step(&f, &md, NULL, &Q.v, NULL, &R.v, &z.v), what);
        }
    }
    c.H[7] = 0.25; /* well conditioned again */
    assert_int_equal(dkf_nerts_step(&f, &md, NULL, &Q.v, NULL, &R.v, &z.v), DKF_OK);
}

static void test_nerts(void **state)
{
    static const char *const names[] = {"NERTSF", "NERTSIF", "DNERTSF", "DNERTSIF"};
    char what[64];
    int kind, jac;
    (void)state;
    for (kind = 0; kind < 4; ++kind)
        for (jac = 0; jac < 2; ++jac) {
            snprintf(what, sizeof what, "%s %s", names[kind], jac ? "analytic" : "differences");
            nerts_case((dkf_nerts_kind_t)kind, jac, what);
        }
    for (kind = 0; kind < 4; ++kind) nerts_rank_p2((dkf_nerts_kind_t)kind);
}

/* ---- dfnerts (seed 001's consensus network) ---------------------------------------------------- */

typedef struct {
    dkf_dfnerts_node_t nd;
    dkf_real_t st[DKF_DFNERTS_NODE_STORAGE_LEN(NN, NM, NP)];
    lxs_t c;
    dkf_nl_model_t md;
    mbuf_t Q, R, z;
    regions_t g;
} dfn_ctx_t;

static dkf_status_t dfn_local_call(void *c)
{
    dfn_ctx_t *k = c;
    return dkf_dfnerts_node_local(&k->nd, &k->md, NULL, &k->Q.v, NULL, &k->R.v, &k->z.v,
                                  DKF_R(1.0), NULL);
}

/* One node alone (its graph row is itself, weight 1, s = 1: the node's
 * own DNERTSIF / NERTSIF step): local, one round of its own packet, commit. */
static dkf_status_t dfn_step(dfn_ctx_t *k)
{
    static dkf_real_t own[DKF_DFNERTS_PKT_MAX(NN, NP)];
    const dkf_real_t *in[1] = {own};
    const dkf_real_t one = DKF_R(1.0);
    dkf_status_t st = dfn_local_call(k);
    if (st != DKF_OK) return st;
    memcpy(own, k->nd.pkt, k->nd.pkt_len * sizeof(dkf_real_t));
    st = dkf_dfnerts_node_mix(&k->nd, in, &one, 1, NULL);
    return st != DKF_OK ? st : dkf_dfnerts_node_commit(&k->nd);
}

/* nertsif.json's lin_x_sin_d model with its Q, R and a measurement z. */
static void dfn_fixture(dfn_ctx_t *k)
{
    static const double R3[9] = {0.02, 0.005, 0, 0.005, 0.03, 0, 0, 0, 0.01};
    static const double z3[3] = {0.1, 0.6, 0.5};
    k->md = lxs_fill(&k->c, 1);
    mset(&k->Q, NN, NN, Q3), mset(&k->R, NM, NM, R3), mset(&k->z, NM, 1, z3);
}

static dkf_status_t dfn_init(dfn_ctx_t *k, dkf_nerts_kind_t kind, dkf_dfnerts_variant_t variant)
{
    static const double Pd[1] = {0.25}, d0[1] = {0.1}, Pxd0[3] = {0.01, -0.02, 0.0};
    mbuf_t x0, P0, dd, PPd, PPxd;
    mset(&x0, NN, 1, x3), mset(&P0, NN, NN, P3), mset(&dd, NP, 1, d0), mset(&PPd, NP, NP, Pd);
    mset(&PPxd, NN, NP, Pxd0);
    return dkf_dfnerts_node_init(&k->nd, kind, variant, NN, NM, NP, k->st,
                                 DKF_DFNERTS_NODE_STORAGE_LEN(NN, NM, NP), &x0.v, &P0.v, &dd.v,
                                 &PPd.v, &PPxd.v);
}

static void dfnerts_case(dkf_nerts_kind_t kind, dkf_dfnerts_variant_t variant, const char *what)
{
    static dfn_ctx_t k;
    static const char *const qrz[] = {"Q", "R", "z"};
    static dkf_real_t bad[DKF_DFNERTS_PKT_MAX(NN, NP)];
    const dkf_real_t *in[1] = {bad};
    const dkf_real_t one = DKF_R(1.0);
    char label[160];
    dkf_mat_t *v[3];
    size_t e, q;
    dfn_fixture(&k);
    assert_int_equal(dfn_init(&k, kind, variant), DKF_OK);
    reg_clear(&k.g);
    reg_add(&k.g, &k.nd, sizeof k.nd);
    reg_add(&k.g, k.st, DKF_DFNERTS_NODE_STATE_LEN(NN, NM, NP) * sizeof(dkf_real_t));
    assert_int_equal(dfn_step(&k), DKF_OK);
    assert_int_equal(dfn_step(&k), DKF_OK);
    v[0] = &k.Q.v, v[1] = &k.R.v, v[2] = &k.z.v;
    snprintf(label, sizeof label, "dfnerts_node_local %s", what);
    sweep(label, dfn_local_call, &k, v, qrz, 3, &k.g);
    k.c.fail_h = 1;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_MODEL, dfn_local_call(&k), "dfnerts_node_local: h fails");
    k.c.fail_h = 0;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_dfnerts_node_mix(&k.nd, in, &one, 1, NULL),
                     "dfnerts_node_mix: nothing pending");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_dfnerts_node_commit(&k.nd),
                     "dfnerts_node_commit: nothing pending");
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_dfnerts_node_cancel(&k.nd),
                     "dfnerts_node_cancel: nothing pending");
    /* pending from here: the pending packet is state too */
    assert_int_equal(dfn_local_call(&k), DKF_OK);
    reg_add(&k.g, k.nd.pkt, k.nd.pkt_len * sizeof(dkf_real_t));
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_STATE, dkf_dfnerts_node_commit(&k.nd),
                     "dfnerts_node_commit: before the first round");
    memcpy(bad, k.nd.pkt, k.nd.pkt_len * sizeof(dkf_real_t));
    bad[1] = (dkf_real_t)NAN;
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NONFINITE, dkf_dfnerts_node_mix(&k.nd, in, &one, 1, NULL),
                     "dfnerts_node_mix: NaN in a packet");
    /* an agreed Y of -1e6 I: not SPD at commit */
    q = variant == DKF_DFNERTS_JOINT ? NN + NP : NN;
    for (e = 0; e < k.nd.pkt_len; ++e) bad[e] = DKF_R(0.0);
    for (e = 0; e < q; ++e) bad[q + e * q - e * (e - 1) / 2] = DKF_R(-1e6);
    assert_int_equal(dkf_dfnerts_node_mix(&k.nd, in, &one, 1, NULL), DKF_OK);
    reg_clear(&k.g);
    reg_add(&k.g, &k.nd, sizeof k.nd);
    reg_add(&k.g, k.st, DKF_DFNERTS_NODE_STATE_LEN(NN, NM, NP) * sizeof(dkf_real_t));
    reg_add(&k.g, k.nd.pkt, k.nd.pkt_len * sizeof(dkf_real_t));
    EXPECT_UNTOUCHED(&k.g, DKF_ERR_NOT_SPD, dkf_dfnerts_node_commit(&k.nd),
                     "dfnerts_node_commit: agreed Y not SPD");
    assert_int_equal(dkf_dfnerts_node_cancel(&k.nd), DKF_OK);
    assert_int_equal(dfn_step(&k), DKF_OK);
}

/* A case for both variants of both information kinds. */
static void dfn_every_case(void (*run)(dkf_nerts_kind_t, dkf_dfnerts_variant_t, const char *))
{
    run(DKF_NERTS_DNERTSIF, DKF_DFNERTS_PAPER, "DNERTSIF PAPER");
    run(DKF_NERTS_DNERTSIF, DKF_DFNERTS_JOINT, "DNERTSIF JOINT");
    run(DKF_NERTS_NERTSIF, DKF_DFNERTS_PAPER, "NERTSIF PAPER");
    run(DKF_NERTS_NERTSIF, DKF_DFNERTS_JOINT, "NERTSIF JOINT");
}

static void test_dfnerts(void **state)
{
    (void)state;
    dfn_every_case(dfnerts_case);
}

/* ---- dfnerts restart and rejoin: every refusal, in every state ------------------------------- */

/* A restart or rejoin composes a drop of the pending step with a new
 * prior: every refusal of the prior (or of the packet it comes from) must
 * come before the drop. */
typedef struct {
    dfn_ctx_t n;
    mbuf_t x0, P0, d0, Pd0, Pxd0;
    dkf_real_t pkt[DKF_DFNERTS_PKT_MAX(NN, NP)];
} rj_ctx_t;

/* The node's regions: the struct, the filter's state and, while a step is
 * pending, the pending step (packet, contribution and the snapshot a
 * cancel restores). */
static void rj_regions(rj_ctx_t *k)
{
    reg_clear(&k->n.g);
    reg_add(&k->n.g, &k->n.nd, sizeof k->n.nd);
    reg_add(&k->n.g, k->n.st, DKF_DFNERTS_NODE_STATE_LEN(NN, NM, NP) * sizeof(dkf_real_t));
    if (k->n.nd.pending)
        reg_add(&k->n.g, k->n.st + DKF_DFNERTS_NODE_PENDING_AT(NN, NM, NP),
                DKF_DFNERTS_NODE_PENDING_LEN(NN, NM, NP) * sizeof(dkf_real_t));
}

static dkf_status_t rj_restart_call(void *c)
{
    rj_ctx_t *k = c;
    return dkf_dfnerts_node_restart(&k->n.nd, 7, &k->x0.v, &k->P0.v, &k->d0.v, &k->Pd0.v,
                                    &k->Pxd0.v);
}

static dkf_status_t rj_rejoin_call(void *c)
{
    rj_ctx_t *k = c;
    return dkf_dfnerts_node_rejoin(&k->n.nd, 7, k->pkt, &k->d0.v, &k->Pd0.v);
}

/* A valid prior and packet: y = (1, .., q), Y = 10 I (q = the agreed size). */
static void rj_valid(rj_ctx_t *k)
{
    static const double Pd[1] = {0.25}, d0[1] = {0.1}, Pxd0[3] = {0.01, -0.02, 0.0};
    const size_t q = k->n.nd.q;
    size_t e;
    mset(&k->x0, NN, 1, x3), mset(&k->P0, NN, NN, P3), mset(&k->d0, NP, 1, d0);
    mset(&k->Pd0, NP, NP, Pd), mset(&k->Pxd0, NN, NP, Pxd0);
    for (e = 0; e < k->n.nd.pkt_len; ++e) k->pkt[e] = DKF_R(0.0);
    for (e = 0; e < q; ++e) {
        k->pkt[e] = (dkf_real_t)(e + 1);
        k->pkt[q + e * q - e * (e - 1) / 2] = DKF_R(10.0);
    }
}

/* One refusal in the node's state `state`: the call fails with `want`
 * and leaves the node untouched; the prior and packet are valid again
 * afterwards. */
static void rj_expect(rj_ctx_t *k, dkf_status_t want, call_fn call, const char *state,
                      const char *what)
{
    char label[160];
    snprintf(label, sizeof label, "%s (%s): %s",
             call == rj_restart_call ? "dfnerts_node_restart" : "dfnerts_node_rejoin", state, what);
    EXPECT_UNTOUCHED(&k->n.g, want, call(k), label);
    rj_valid(k);
}

/* Every refusal of restart and rejoin in the node's current state, in
 * the order of their checks. */
static void rj_refusals(rj_ctx_t *k, const char *state)
{
    static const char *const pn[] = {"x0", "P0", "d0", "Pd0", "Pxd0"}, *const dn[] = {"d0", "Pd0"};
    char label[160];
    dkf_mat_t *v[5];
    size_t e;
    rj_valid(k);
    rj_regions(k);
    v[0] = &k->x0.v, v[1] = &k->P0.v, v[2] = &k->d0.v, v[3] = &k->Pd0.v, v[4] = &k->Pxd0.v;
    snprintf(label, sizeof label, "dfnerts_node_restart (%s)", state);
    sweep(label, rj_restart_call, k, v, pn, 5, &k->n.g);
    /* priors that are finite but refused: P0, Pd0 and the joint covariance */
    meye(&k->P0, NN, -1.0);
    rj_expect(k, DKF_ERR_NOT_SPD, rj_restart_call, state, "P0 = -I");
    meye(&k->Pd0, NP, -1.0);
    rj_expect(k, DKF_ERR_NOT_SPD, rj_restart_call, state, "Pd0 = -1");
    for (e = 0; e < NN; ++e) k->Pxd0.d[e] = DKF_R(10.0);
    rj_expect(k, DKF_ERR_NOT_SPD, rj_restart_call, state, "joint covariance indefinite");
    /* rejoin: the packet, then (PAPER) the caller's input prior */
    snprintf(label, sizeof label, "dfnerts_node_rejoin (%s): packet NULL", state);
    EXPECT_UNTOUCHED(&k->n.g, DKF_ERR_NULL,
                     dkf_dfnerts_node_rejoin(&k->n.nd, 7, NULL, &k->d0.v, &k->Pd0.v), label);
    for (e = 0; e < k->n.nd.pkt_len; ++e) {
        k->pkt[e] = (dkf_real_t)NAN;
        rj_expect(k, DKF_ERR_NONFINITE, rj_rejoin_call, state, "NaN in the packet");
    }
    for (e = 0; e < k->n.nd.q; ++e)
        k->pkt[k->n.nd.q + e * k->n.nd.q - e * (e - 1) / 2] = DKF_R(-10.0);
    rj_expect(k, DKF_ERR_NOT_SPD, rj_rejoin_call, state, "packet Y = -10 I");
    if (k->n.nd.variant != DKF_DFNERTS_PAPER) return; /* JOINT ignores d0, Pd0 */
    snprintf(label, sizeof label, "dfnerts_node_rejoin (%s): d0 NULL", state);
    EXPECT_UNTOUCHED(&k->n.g, DKF_ERR_NULL,
                     dkf_dfnerts_node_rejoin(&k->n.nd, 7, k->pkt, NULL, &k->Pd0.v), label);
    v[0] = &k->d0.v, v[1] = &k->Pd0.v;
    snprintf(label, sizeof label, "dfnerts_node_rejoin (%s)", state);
    sweep(label, rj_rejoin_call, k, v, dn, 2, &k->n.g);
    meye(&k->Pd0, NP, -1.0);
    rj_expect(k, DKF_ERR_NOT_SPD, rj_rejoin_call, state, "Pd0 = -1");
}

/* Restart and rejoin refused in every state: fresh, after commits,
 * pending after local, pending after a round. Then both succeed. */
static void rj_case(dkf_nerts_kind_t kind, dkf_dfnerts_variant_t variant, const char *what)
{
    static rj_ctx_t k;
    const dkf_real_t *in[1];
    const dkf_real_t one = DKF_R(1.0);
    char label[160];
    dfn_fixture(&k.n);
    assert_int_equal(dfn_init(&k.n, kind, variant), DKF_OK);
    snprintf(label, sizeof label, "%s, fresh", what);
    rj_refusals(&k, label);
    assert_int_equal(dfn_step(&k.n), DKF_OK);
    assert_int_equal(dfn_step(&k.n), DKF_OK);
    snprintf(label, sizeof label, "%s, after commits", what);
    rj_refusals(&k, label);
    assert_int_equal(dfn_local_call(&k.n), DKF_OK);
    snprintf(label, sizeof label, "%s, pending", what);
    rj_refusals(&k, label);
    in[0] = k.n.nd.pkt;
    assert_int_equal(dkf_dfnerts_node_mix(&k.n.nd, in, &one, 1, NULL), DKF_OK);
    snprintf(label, sizeof label, "%s, pending after a round", what);
    rj_refusals(&k, label);
    /* the node still completes its step, then takes a valid prior */
    assert_int_equal(dkf_dfnerts_node_commit(&k.n.nd), DKF_OK);
    rj_valid(&k);
    assert_int_equal(rj_rejoin_call(&k), DKF_OK);
    assert_int_equal(k.n.nd.f.k, 7);
    assert_int_equal(rj_restart_call(&k), DKF_OK);
    assert_int_equal(dfn_step(&k.n), DKF_OK);
}

static void test_dfnerts_restart_rejoin(void **state)
{
    (void)state;
    dfn_every_case(rj_case);
}

/* The review's case exactly: PAPER, p = 1, a step pending after local and
 * a round, a rejoin whose packet is fine but whose Pd0 = [[-1]] is
 * refused: DKF_ERR_NOT_SPD and the node bit-identical. */
static void test_dfnerts_rejoin_refused_pd0(void **state)
{
    static rj_ctx_t k;
    const dkf_real_t *in[1];
    const dkf_real_t one = DKF_R(1.0);
    (void)state;
    dfn_fixture(&k.n);
    assert_int_equal(dfn_init(&k.n, DKF_NERTS_DNERTSIF, DKF_DFNERTS_PAPER), DKF_OK);
    assert_int_equal(dfn_step(&k.n), DKF_OK);
    assert_int_equal(dfn_local_call(&k.n), DKF_OK);
    in[0] = k.n.nd.pkt;
    assert_int_equal(dkf_dfnerts_node_mix(&k.n.nd, in, &one, 1, NULL), DKF_OK);
    rj_valid(&k);
    memcpy(k.pkt, k.n.nd.pkt, k.n.nd.pkt_len * sizeof(dkf_real_t));
    meye(&k.Pd0, NP, -1.0);
    rj_regions(&k);
    assert_int_equal(k.n.nd.pending, 1);
    EXPECT_UNTOUCHED(&k.n.g, DKF_ERR_NOT_SPD, rj_rejoin_call(&k), "rejoin: Pd0 = [[-1]], pending");
    EXPECT_UNTOUCHED(&k.n.g, DKF_ERR_NOT_SPD, rj_restart_call(&k),
                     "restart: Pd0 = [[-1]], pending");
    assert_int_equal(dkf_dfnerts_node_commit(&k.n.nd), DKF_OK);
}

/* ---- dfnerts network ---------------------------------------------------------------------- */

/* dfnerts_fixture.h's four sensors on the complete graph, Metropolis W. */
#define DNN DFN_NODES

typedef struct {
    dkf_dfnerts_net_t net;
    dkf_dfnerts_node_t nodes[DNN];
    dkf_real_t st[DKF_DFNERTS_NET_STORAGE_LEN(DNN, DFN_N, DFN_M, 1)];
    lxs_t c[DNN];
    dkf_nl_model_t md[DNN];
    mbuf_t Qb[DNN], Rb[DNN], zb[DNN];
    dkf_mat_t Q[DNN], R[DNN], z[DNN];
    size_t start[DNN + 1], nbr[DKF_GRAPH_NNZ(DNN, 6)];
    dkf_graph_t g;
    dkf_real_t W[DKF_GRAPH_NNZ(DNN, 6)];
    size_t Tp;
    dkf_real_t scale;
    regions_t g_all;
} dnet_ctx_t;

static dkf_status_t dnet_step_call(void *c)
{
    dnet_ctx_t *k = c;
    return dkf_dfnerts_net_step(&k->net, k->md, NULL, k->Q, NULL, k->R, k->z, k->W, k->Tp,
                                k->scale);
}

static void dnet_make(dnet_ctx_t *k, dkf_dfnerts_variant_t variant)
{
    static const size_t edges[12] = {0, 1, 0, 2, 0, 3, 1, 2, 1, 3, 2, 3};
    static const double x0[DFN_N] = {0}, P0[DFN_N * DFN_N] = {1, 0, 0, 1}, d0[1] = {0},
                        Pd0[1] = {1}, Pxd0[DFN_N] = {0};
    static mbuf_t bx, bP, bd, bPd, bPxd;
    dkf_mat_t x[DNN], P[DNN], d[DNN], Pd[DNN], Pxd[DNN];
    size_t l;
    assert_int_equal(dkf_graph_from_edges(&k->g, k->start, k->nbr, DKF_GRAPH_NNZ(DNN, 6), DNN,
                                          edges, 6),
                     DKF_OK);
    assert_int_equal(dkf_graph_weights_metropolis(k->W, &k->g), DKF_OK);
    mset(&bx, DFN_N, 1, x0), mset(&bP, DFN_N, DFN_N, P0), mset(&bd, 1, 1, d0);
    mset(&bPd, 1, 1, Pd0), mset(&bPxd, DFN_N, 1, Pxd0);
    for (l = 0; l < DNN; ++l) {
        const double R[4] = {dfn_R[l][0], 0, 0, dfn_R[l][1]}, z[2] = {0.3 * (double)l, -0.2};
        lxs_t *c = &k->c[l];
        memset(c, 0, sizeof *c);
        c->n = DFN_N, c->m = DFN_M, c->p = 1, c->linear = 1;
        memcpy(c->A, dfn_F, sizeof dfn_F);
        memcpy(c->B, dfn_G, sizeof dfn_G);
        memcpy(c->C, dfn_H[l], sizeof dfn_H[l]);
        memcpy(c->H, dfn_D[l], sizeof dfn_D[l]);
        k->md[l] = lxs_model(c, 1);
        k->Q[l] = *mset(&k->Qb[l], DFN_N, DFN_N, dfn_Q);
        k->R[l] = *mset(&k->Rb[l], DFN_M, DFN_M, R);
        k->z[l] = *mset(&k->zb[l], DFN_M, 1, z);
        x[l] = bx.v, P[l] = bP.v, d[l] = bd.v, Pd[l] = bPd.v, Pxd[l] = bPxd.v;
    }
    {
        static const size_t m[DNN] = {DFN_M, DFN_M, DFN_M, DFN_M};
        assert_int_equal(dkf_dfnerts_net_init(&k->net, &k->g, k->nodes, DKF_NERTS_DNERTSIF,
                                              variant, DFN_N, m, 1, k->st,
                                              sizeof k->st / sizeof k->st[0], x, P, d, Pd, Pxd),
                         DKF_OK);
    }
    k->Tp = 3;
    k->scale = DKF_R(1.0) * (dkf_real_t)DNN;
    reg_clear(&k->g_all);
    reg_add(&k->g_all, &k->net, sizeof k->net);
    reg_add(&k->g_all, k->nodes, sizeof k->nodes);
    for (l = 0; l < DNN; ++l)
        reg_add(&k->g_all, k->st + l * DKF_DFNERTS_NODE_STORAGE_LEN(DFN_N, DFN_M, 1),
                DKF_DFNERTS_NODE_STATE_LEN(DFN_N, DFN_M, 1) * sizeof(dkf_real_t));
}

/* The network step's checks in order: a node pending, the arguments, each
 * node's local step (the first node, the last after the others ran
 * theirs), and (PAPER) the commit that the mixed joint covariance fails
 * at, with an odd and an even T_p. */
static void test_dfnerts_net(void **state)
{
    static dnet_ctx_t k;
    static const char *const qn[] = {"Q0", "R0", "z0"}, *const rn[] = {"R3", "z3"};
    dkf_mat_t *v[3];
    dkf_real_t Wbad[DKF_GRAPH_NNZ(DNN, 6)];
    (void)state;
    dnet_make(&k, DKF_DFNERTS_PAPER);
    k.Tp = 3;
    EXPECT_UNTOUCHED(&k.g_all, DKF_ERR_NOT_SPD, dnet_step_call(&k),
                     "dfnerts_net_step (PAPER): mixed covariance indefinite, T_p = 3");
    k.Tp = 2;
    EXPECT_UNTOUCHED(&k.g_all, DKF_ERR_NOT_SPD, dnet_step_call(&k),
                     "dfnerts_net_step (PAPER): mixed covariance indefinite, T_p = 2");
    dnet_make(&k, DKF_DFNERTS_JOINT);
    assert_int_equal(dnet_step_call(&k), DKF_OK);
    k.Tp = 0;
    EXPECT_UNTOUCHED(&k.g_all, DKF_ERR_ARG, dnet_step_call(&k), "dfnerts_net_step: T_p = 0");
    k.Tp = 3;
    k.scale = DKF_R(0.0);
    EXPECT_UNTOUCHED(&k.g_all, DKF_ERR_ARG, dnet_step_call(&k), "dfnerts_net_step: s = 0");
    k.scale = (dkf_real_t)DNN;
    memcpy(Wbad, k.W, sizeof Wbad);
    k.W[0] += DKF_R(0.25);
    EXPECT_UNTOUCHED(&k.g_all, DKF_ERR_WEIGHTS, dnet_step_call(&k), "dfnerts_net_step: W");
    memcpy(k.W, Wbad, sizeof Wbad);
    v[0] = &k.Q[0], v[1] = &k.R[0], v[2] = &k.z[0];
    sweep("dfnerts_net_step (node 0)", dnet_step_call, &k, v, qn, 3, &k.g_all);
    v[0] = &k.R[DNN - 1], v[1] = &k.z[DNN - 1];
    sweep("dfnerts_net_step (the last node)", dnet_step_call, &k, v, rn, 2, &k.g_all);
    k.c[2].fail_h = 1;
    EXPECT_UNTOUCHED(&k.g_all, DKF_ERR_MODEL, dnet_step_call(&k), "dfnerts_net_step: h fails at 2");
    k.c[2].fail_h = 0;
    assert_int_equal(dkf_dfnerts_node_local(&k.nodes[1], &k.md[1], NULL, &k.Q[1], NULL, &k.R[1],
                                            &k.z[1], k.scale, NULL),
                     DKF_OK);
    {
        regions_t gp = k.g_all;
        reg_add(&gp, k.st + DKF_DFNERTS_NODE_STORAGE_LEN(DFN_N, DFN_M, 1) +
                         DKF_DFNERTS_NODE_PENDING_AT(DFN_N, DFN_M, 1),
                DKF_DFNERTS_NODE_PENDING_LEN(DFN_N, DFN_M, 1) * sizeof(dkf_real_t));
        EXPECT_UNTOUCHED(&gp, DKF_ERR_STATE, dnet_step_call(&k),
                         "dfnerts_net_step: node 1 pending");
    }
    assert_int_equal(dkf_dfnerts_node_cancel(&k.nodes[1]), DKF_OK);
    assert_int_equal(dnet_step_call(&k), DKF_OK);
}

/* ---- weighted fusion ------------------------------------------------------------------------ */

#define WN 2
#define WL 2

typedef struct {
    dkf_wfusion_t fu;
    dkf_wfusion_local_t nodes[WL];
    dkf_real_t st[DKF_WFUSION_STORAGE_LEN(WN, WL, 1)];
    dkf_wfusion_local_t loc;
    dkf_real_t lst[DKF_WFUSION_LOCAL_STORAGE_LEN(WN, 1)];
    mbuf_t F, Q, H[WL], R[WL], y[WL];
    dkf_kf_dyn_t dyn;
    dkf_kf_meas_t meas[WL];
    dkf_mat_t ys[WL];
    const dkf_mat_t *xs[WL];
    dkf_real_t ck[512];
    regions_t gl, gf;
} wf_ctx_t;

static dkf_status_t wf_local_step_call(void *c)
{
    wf_ctx_t *k = c;
    return dkf_wfusion_local_step(&k->loc, &k->dyn, &k->meas[0], &k->y[0].v);
}
static dkf_status_t wf_local_steady_call(void *c)
{
    wf_ctx_t *k = c;
    return dkf_wfusion_local_steady(&k->loc, &k->dyn, &k->meas[0]);
}
static dkf_status_t wf_step_call(void *c)
{
    wf_ctx_t *k = c;
    k->ys[0] = k->y[0].v, k->ys[1] = k->y[1].v;
    return dkf_wfusion_step(&k->fu, &k->dyn, k->meas, k->ys);
}
static dkf_status_t wf_steady_call(void *c)
{
    wf_ctx_t *k = c;
    return dkf_wfusion_steady(&k->fu, &k->dyn, k->meas);
}

static void wf_model(wf_ctx_t *k)
{
    static const double F[4] = {1.0, 0.1, 0.0, 0.9}, Q[4] = {0.01, 0.0, 0.0, 0.02};
    static const double H[WL][2] = {{1.0, 0.0}, {1.0, 1.0}}, R[1] = {0.1}, y[WL] = {0.3, -0.2};
    size_t i;
    mset(&k->F, WN, WN, F), mset(&k->Q, WN, WN, Q);
    k->dyn.F = &k->F.v, k->dyn.Q = &k->Q.v;
    for (i = 0; i < WL; ++i) {
        mset(&k->H[i], 1, WN, H[i]), mset(&k->R[i], 1, 1, R), mset(&k->y[i], 1, 1, &y[i]);
        k->meas[i].H = &k->H[i].v, k->meas[i].R = &k->R[i].v;
    }
}

/* The local filter and the fusion: every input of their steps and
 * steady-state switches, an indefinite R, a model with no stabilising
 * solution, the fusions without a sensor or with a NaN estimate, the
 * checkpoints; a filter never initialised. */
static void test_wfusion(void **state)
{
    static wf_ctx_t k;
    static const char *const ln[] = {"F", "Q", "H", "R", "y"}, *const fn[] = {"F", "Q", "H0", "R1"};
    static const size_t m[WL] = {1, 1};
    static const double Hs[WN] = {1.0, 0.0};
    dkf_mat_t *v[5];
    mbuf_t x0, P0, bHs;
    mbuf_t xbad;
    dkf_wfusion_local_t blank;
    size_t len, i;
    (void)state;
    wf_model(&k);
    mset(&x0, WN, 1, x3), mset(&P0, WN, WN, P3), mset(&bHs, 1, WN, Hs);
    P0.d[1] = P0.d[2] = DKF_R(0.2); /* P3's leading 2 x 2 block, symmetric */
    P0.d[3] = DKF_R(1.5);
    assert_int_equal(dkf_wfusion_local_init(&k.loc, WN, 1, k.lst,
                                            DKF_WFUSION_LOCAL_STORAGE_LEN(WN, 1), &x0.v, &P0.v),
                     DKF_OK);
    assert_int_equal(dkf_wfusion_init(&k.fu, WN, WL, m, k.nodes, k.st,
                                      sizeof k.st / sizeof k.st[0], &bHs.v, &x0.v, &P0.v),
                     DKF_OK);
    assert_int_equal(wf_local_step_call(&k), DKF_OK);
    assert_int_equal(wf_step_call(&k), DKF_OK);
    reg_clear(&k.gl);
    reg_add(&k.gl, &k.loc, sizeof k.loc);
    reg_add(&k.gl, k.lst, DKF_WFUSION_LOCAL_STATE_LEN(WN, 1) * sizeof(dkf_real_t));
    reg_clear(&k.gf);
    reg_add(&k.gf, &k.fu, sizeof k.fu);
    reg_add(&k.gf, k.nodes, sizeof k.nodes);
    for (i = 0; i < WL; ++i)
        reg_add(&k.gf, k.st + i * DKF_WFUSION_LOCAL_STORAGE_LEN(WN, 1),
                DKF_WFUSION_LOCAL_STATE_LEN(WN, 1) * sizeof(dkf_real_t));
    reg_add(&k.gf, k.fu.Pj.data,
            (WN * WL * WN * WL + WN + WL * WL + WL + WN * WN * WL + WN + WN * WN) *
                sizeof(dkf_real_t));
    v[0] = &k.F.v, v[1] = &k.Q.v, v[2] = &k.H[0].v, v[3] = &k.R[0].v, v[4] = &k.y[0].v;
    sweep("wfusion_local_step", wf_local_step_call, &k, v, ln, 5, &k.gl);
    sweep("wfusion_local_steady", wf_local_steady_call, &k, v, ln, 4, &k.gl);
    sweep("wfusion_step", wf_step_call, &k, v, ln, 5, &k.gf);
    v[2] = &k.H[0].v, v[3] = &k.R[1].v;
    sweep("wfusion_steady", wf_steady_call, &k, v, fn, 4, &k.gf);
    meye(&k.R[0], 1, -1.0);
    EXPECT_UNTOUCHED(&k.gl, DKF_ERR_NOT_SPD, wf_local_step_call(&k), "wfusion_local_step: R = -1");
    EXPECT_UNTOUCHED(&k.gf, DKF_ERR_NOT_SPD, wf_step_call(&k), "wfusion_step: R0 = -1");
    meye(&k.R[0], 1, 0.1);
    /* F = 2 I seen by no sensor: no stabilising solution */
    meye(&k.F, WN, 2.0);
    meye(&k.H[0], 1, 0.0), k.H[0].v.cols = WN;
    meye(&k.H[1], 1, 0.0), k.H[1].v.cols = WN;
    EXPECT_UNTOUCHED(&k.gl, ANY_ERR, wf_local_steady_call(&k),
                     "wfusion_local_steady: undetectable");
    EXPECT_UNTOUCHED(&k.gf, ANY_ERR, wf_steady_call(&k), "wfusion_steady: undetectable");
    wf_model(&k);
    /* the fusions: no sensor, a NaN estimate */
    {
        regions_t gr = k.gf;
        const dkf_mat_t *none[WL] = {NULL, NULL};
        reg_add(&gr, &xbad, sizeof xbad);
        mset(&xbad, WN, 1, x3);
        xbad.d[1] = (dkf_real_t)NAN;
        k.xs[0] = &x0.v, k.xs[1] = &xbad.v;
        EXPECT_UNTOUCHED(&gr, DKF_ERR_ARG, dkf_wfusion_fuse_scalar(&k.fu, none),
                         "wfusion_fuse_scalar: no sensor");
        EXPECT_UNTOUCHED(&gr, DKF_ERR_ARG, dkf_wfusion_fuse_matrix(&k.fu, none),
                         "wfusion_fuse_matrix: no sensor");
        EXPECT_UNTOUCHED(&gr, DKF_ERR_NONFINITE, dkf_wfusion_fuse_scalar(&k.fu, k.xs),
                         "wfusion_fuse_scalar: NaN estimate");
        EXPECT_UNTOUCHED(&gr, DKF_ERR_NONFINITE, dkf_wfusion_fuse_matrix(&k.fu, k.xs),
                         "wfusion_fuse_matrix: NaN estimate");
    }
    /* checkpoints */
    len = dkf_wfusion_checkpoint_len(&k.fu);
    assert_true(len > 0 && len <= sizeof k.ck / sizeof k.ck[0]);
    assert_int_equal(dkf_wfusion_save(&k.fu, k.ck, len), DKF_OK);
    {
        regions_t gr = k.gf;
        reg_add(&gr, k.ck, len * sizeof k.ck[0]);
        EXPECT_UNTOUCHED(&gr, DKF_ERR_CAPACITY, dkf_wfusion_save(&k.fu, k.ck, len - 1),
                         "wfusion_save: short");
        EXPECT_UNTOUCHED(&gr, DKF_ERR_CAPACITY, dkf_wfusion_restore(&k.fu, k.ck, len - 1),
                         "wfusion_restore: short");
        k.ck[0] += DKF_R(1.0);
        EXPECT_UNTOUCHED(&gr, DKF_ERR_ARG, dkf_wfusion_restore(&k.fu, k.ck, len),
                         "wfusion_restore: tag");
        k.ck[0] -= DKF_R(1.0);
        k.ck[len - 1] = (dkf_real_t)NAN;
        EXPECT_UNTOUCHED(&gr, DKF_ERR_NONFINITE, dkf_wfusion_restore(&k.fu, k.ck, len),
                         "wfusion_restore: NaN");
    }
    memset(&blank, 0, sizeof blank);
    reg_clear(&k.gl);
    reg_add(&k.gl, &blank, sizeof blank);
    EXPECT_UNTOUCHED(&k.gl, DKF_ERR_STATE,
                     dkf_wfusion_local_step(&blank, &k.dyn, &k.meas[0], &k.y[0].v),
                     "wfusion_local_step: blank");
}

/* ---- self-tuning identifier ------------------------------------------------------------------ */

/* The seed's example orders (na = 2, np = 2, nc = 1, K = 5, L = 2): a NaN
 * measurement after the warm-up, the queries with short or misshaped
 * outputs, another estimate's orders, a negative variance; an identifier
 * never initialised. */
static void test_selftune(void **state)
{
    static const dkf_real_t p2[2] = {DKF_R(-0.7), DKF_R(0.5)}, sv[2] = {DKF_R(0.1), DKF_R(0.2)};
    static dkf_selftune_t id, blank;
    static dkf_real_t st[DKF_SELFTUNE_STORAGE_LEN(2, 2, 1, 5)], r[8];
    static dkf_selftune_est_t est, other;
    static mbuf_t F, Q;
    dkf_selftune_cfg_t c;
    dkf_real_t y[2];
    size_t t, n = 0;
    regions_t g;
    (void)state;
    assert_int_equal(dkf_selftune_config_default(&c), DKF_OK);
    c.np = 2, c.p = p2, c.L = 2, c.sigma_v2 = sv, c.sigma_xi2 = DKF_R(0.3), c.t_min = 8;
    assert_int_equal(dkf_selftune_init(&id, &c, st, sizeof st / sizeof st[0]), DKF_OK);
    for (t = 0; t < 20; ++t) {
        y[0] = (dkf_real_t)sin(0.7 * (double)t), y[1] = (dkf_real_t)cos(0.3 * (double)t);
        assert_int_equal(dkf_selftune_update(&id, y), DKF_OK);
    }
    assert_int_equal(dkf_selftune_estimate(&id, &est), DKF_OK);
    assert_int_equal(dkf_selftune_model_dim(&id, &n), DKF_OK);
    reg_clear(&g);
    reg_add(&g, &id, sizeof id);
    reg_add(&g, st, sizeof st);
    reg_add(&g, r, sizeof r);
    reg_add(&g, &F, sizeof F);
    reg_add(&g, &Q, sizeof Q);
    y[1] = (dkf_real_t)NAN;
    EXPECT_UNTOUCHED(&g, DKF_ERR_NONFINITE, dkf_selftune_update(&id, y), "selftune_update: NaN");
    EXPECT_UNTOUCHED(&g, DKF_ERR_CAPACITY, dkf_selftune_autocov(&id, r, 5),
                     "selftune_autocov: len = K");
    EXPECT_UNTOUCHED(&g, DKF_ERR_CAPACITY, dkf_selftune_noise_autocov(&id, r, 5),
                     "selftune_noise_autocov: len = K");
    meye(&F, n, 0.0), meye(&Q, n, 0.0);
    F.v.rows = n + 1;
    EXPECT_UNTOUCHED(&g, DKF_ERR_DIM, dkf_selftune_model(&id, &est, &F.v, &Q.v),
                     "selftune_model: F (n + 1) x n");
    F.v.rows = n;
    other = est;
    other.nc = 0;
    EXPECT_UNTOUCHED(&g, DKF_ERR_ARG, dkf_selftune_model(&id, &other, &F.v, &Q.v),
                     "selftune_model: another estimate's orders");
    other = est;
    other.sigma_w2 = DKF_R(-1.0);
    EXPECT_UNTOUCHED(&g, DKF_ERR_ARG, dkf_selftune_model(&id, &other, &F.v, &Q.v),
                     "selftune_model: sigma_w^2 < 0");
    memset(&blank, 0, sizeof blank);
    memset(&other, 0x5a, sizeof other);
    reg_add(&g, &blank, sizeof blank);
    reg_add(&g, &other, sizeof other);
    y[1] = DKF_R(0.0);
    EXPECT_UNTOUCHED(&g, DKF_ERR_STATE, dkf_selftune_update(&blank, y), "selftune_update: blank");
    EXPECT_UNTOUCHED(&g, DKF_ERR_STATE, dkf_selftune_estimate(&blank, &other),
                     "selftune_estimate: blank");
    EXPECT_UNTOUCHED(&g, DKF_ERR_STATE, dkf_selftune_model_dim(&blank, &n),
                     "selftune_model_dim: blank");
}

/* ---- exact storage, every module ------------------------------------------------------------ */

/* For every module and several shapes: init refuses storage_len one less
 * than the module's *_STORAGE_LEN (DKF_ERR_CAPACITY, the object
 * untouched) and accepts exactly *_STORAGE_LEN without writing past it.
 * A macro that under-counts would let a filter overrun the caller's array
 * (the layout needs more than the macro says: the first check fails); one
 * that over-counts wastes RAM (init accepts less: the first check fails). */

typedef struct {
    size_t n, m, p, l; /* l: sensors or nodes (fusion centre, network) */
} dims_t;

#define XS_SHAPES 6
#define XS_CAP 60000
#define XS_NODES 4

typedef struct {
    const char *name;
    size_t (*len)(dims_t d);
    dkf_status_t (*init)(dims_t d, dkf_real_t *st, size_t len);
    dims_t shape[XS_SHAPES];
    /* the state parts of xs_st (each node's, for a network) into g */
    void (*state)(dims_t d, regions_t *g);
} xs_module_t;

/* the object under test (one of), with room for its node arrays */
static union {
    dkf_kf_t kf;
    dkf_info_t info;
    dkf_askf_t askf;
    dkf_otskf_t otskf;
    dkf_diffkf_t diffkf;
    struct {
        dkf_diffkf_fc_t fc;
        dkf_diffkf_fc_node_t nodes[XS_NODES];
    } fc;
    dkf_uif_t uif;
    dkf_nerts_t nerts;
    dkf_dfnerts_node_t dfn_node;
    struct {
        dkf_dfnerts_net_t net;
        dkf_dfnerts_node_t nodes[XS_NODES];
    } dfn_net;
    dkf_tw_node_t tw_node;
    struct {
        dkf_tw_net_t net;
        dkf_tw_node_t nodes[XS_NODES];
    } tw_net;
    dkf_wfusion_local_t wf_local;
    struct {
        dkf_wfusion_t fu;
        dkf_wfusion_local_t nodes[XS_NODES];
    } wf;
    dkf_selftune_t selftune;
} xs_obj;
static dkf_real_t xs_st[XS_CAP + 1];
static dkf_real_t xs_x0[DKF_MAX_DIM], xs_P0[3][DKF_MAX_DIM * DKF_MAX_DIM];
/* 1: the covariance priors are refused (test_init_over_live) */
static int xs_refuse;

/* x0 = 0 (n), P0 = I (n x n): a prior every init accepts; the input
 * prior d0 = 0, Pd0 = I (p x p) of askf and otskf likewise (buffer 1).
 * With xs_refuse, x0 = 0.25 and P0 = diag(1, .., 1, -1): refused by the
 * last pivot of its factorisation, after every other check. */
static dkf_mat_t xs_x(size_t n)
{
    static dkf_real_t x1[DKF_MAX_DIM];
    size_t i;
    if (!xs_refuse) return test_view(n, 1, xs_x0);
    for (i = 0; i < n; ++i) x1[i] = DKF_R(0.25); /* unlike the live object's */
    return test_view(n, 1, x1);
}
static dkf_mat_t xs_eye_in(size_t b, size_t n)
{
    size_t i;
    memset(xs_P0[b], 0, sizeof xs_P0[b]);
    for (i = 0; i < n; ++i) xs_P0[b][i * n + i] = DKF_R(1.0);
    if (xs_refuse && n > 0) xs_P0[b][n * n - 1] = DKF_R(-1.0);
    return test_view(n, n, xs_P0[b]);
}
static dkf_mat_t xs_eye(size_t n) { return xs_eye_in(0, n); }

static size_t kf_len(dims_t d) { return DKF_KF_STORAGE_LEN(d.n, d.m); }
static dkf_status_t kf_init(dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n);
    return dkf_kf_init(&xs_obj.kf, d.n, d.m, st, len, &x, &P);
}

static size_t info_len(dims_t d) { return DKF_INFO_STORAGE_LEN(d.n); }
static dkf_status_t info_init(dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n);
    return dkf_info_init(&xs_obj.info, d.n, st, len, &x, &P);
}

static size_t askf_len(dims_t d) { return DKF_ASKF_STORAGE_LEN(d.n, d.m, d.p); }
static dkf_status_t askf_init(dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n), dd = xs_x(d.p), Pd = xs_eye_in(1, d.p);
    return dkf_askf_init(&xs_obj.askf, d.n, d.m, d.p, st, len, &x, &P, &dd, &Pd, NULL);
}

static size_t otskf_len(dims_t d) { return DKF_OTSKF_STORAGE_LEN(d.n, d.m, d.p); }
static dkf_status_t otskf_init(dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n), dd = xs_x(d.p), Pd = xs_eye_in(1, d.p);
    return dkf_otskf_init(&xs_obj.otskf, d.n, d.m, d.p, st, len, &x, &P, &dd, &Pd);
}

static size_t diffkf_len(dims_t d) { return DKF_DIFFKF_STORAGE_LEN(d.n, d.m, d.p); }
static dkf_status_t diffkf_init(dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n);
    return dkf_diffkf_init(&xs_obj.diffkf, d.n, d.m, d.p, st, len, &x, &P);
}

/* l sensors of dimensions (m, p); the runtime size must equal the macro */
static size_t fc_len(dims_t d)
{
    size_t m[XS_NODES], p[XS_NODES], i;
    for (i = 0; i < d.l; ++i) m[i] = d.m, p[i] = d.p;
    assert_int_equal(dkf_diffkf_fc_storage_len(d.n, d.l, m, p),
                     DKF_DIFFKF_FC_STORAGE_LEN(d.n, d.l, d.m, d.p));
    return DKF_DIFFKF_FC_STORAGE_LEN(d.n, d.l, d.m, d.p);
}
static dkf_status_t fc_init(dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n);
    size_t m[XS_NODES], p[XS_NODES], i;
    for (i = 0; i < d.l; ++i) m[i] = d.m, p[i] = d.p;
    return dkf_diffkf_fc_init(&xs_obj.fc.fc, xs_obj.fc.nodes, d.l, d.n, m, p, st, len, &x, &P,
                              NULL, NULL);
}

static size_t uif_len(dims_t d) { return DKF_UIF_STORAGE_LEN(d.n, d.m, d.p); }
static dkf_status_t uif_init(dkf_uif_kind_t kind, dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n);
    return dkf_uif_init(&xs_obj.uif, kind, d.n, d.m, d.p, st, len, &x, &P);
}
static dkf_status_t rtsf_init(dims_t d, dkf_real_t *st, size_t len)
{
    return uif_init(DKF_UIF_RTSF, d, st, len);
}
static dkf_status_t nrtsf_df_init(dims_t d, dkf_real_t *st, size_t len)
{
    return uif_init(DKF_UIF_NRTSF_DF, d, st, len);
}
static dkf_status_t nrtsf_init(dims_t d, dkf_real_t *st, size_t len)
{
    return uif_init(DKF_UIF_NRTSF, d, st, len);
}

static size_t nerts_len(dims_t d) { return DKF_NERTS_STORAGE_LEN(d.n, d.m, d.p); }
static dkf_status_t nerts_init_kind(dkf_nerts_kind_t kind, dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n), dd = xs_x(d.p), Pd = xs_eye_in(1, d.p);
    dkf_mat_t Pxd = test_view(d.n, d.p, xs_x0); /* zeros */
    const int p = d.p > 0;
    return dkf_nerts_init(&xs_obj.nerts, kind, d.n, d.m, d.p, st, len, &x, &P, p ? &dd : NULL,
                          p ? &Pd : NULL, p ? &Pxd : NULL);
}
static dkf_status_t nertsf_init(dims_t d, dkf_real_t *st, size_t len)
{
    return nerts_init_kind(DKF_NERTS_NERTSF, d, st, len);
}
static dkf_status_t dnertsif_init(dims_t d, dkf_real_t *st, size_t len)
{
    return nerts_init_kind(DKF_NERTS_DNERTSIF, d, st, len);
}

static size_t dfn_node_len(dims_t d) { return DKF_DFNERTS_NODE_STORAGE_LEN(d.n, d.m, d.p); }
static dkf_status_t dfn_node_init(dkf_dfnerts_variant_t v, dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n), dd = xs_x(d.p), Pd = xs_eye_in(1, d.p);
    dkf_mat_t Pxd = test_view(d.n, d.p, xs_x0); /* zeros */
    const int p = d.p > 0;
    return dkf_dfnerts_node_init(&xs_obj.dfn_node, DKF_NERTS_DNERTSIF, v, d.n, d.m, d.p, st, len,
                                 &x, &P, p ? &dd : NULL, p ? &Pd : NULL, p ? &Pxd : NULL);
}
static dkf_status_t dfn_paper_init(dims_t d, dkf_real_t *st, size_t len)
{
    return dfn_node_init(DKF_DFNERTS_PAPER, d, st, len);
}
static dkf_status_t dfn_joint_init(dims_t d, dkf_real_t *st, size_t len)
{
    return dfn_node_init(DKF_DFNERTS_JOINT, d, st, len);
}

/* l nodes on a path, every node the same prior; node e measures m + e % 2
 * values (mixed sensors: the runtime length, below the macro's for
 * m_max = m + 1, which is exact when every node has m + 1) */
static void dfn_net_m(dims_t d, size_t m[])
{
    size_t e;
    for (e = 0; e < d.l; ++e) m[e] = d.m + e % 2;
}
static size_t dfn_net_len(dims_t d)
{
    size_t m[XS_NODES], e;
    for (e = 0; e < d.l; ++e) m[e] = d.m + 1;
    assert_int_equal(dkf_dfnerts_net_storage_len(d.l, d.n, m, d.p),
                     DKF_DFNERTS_NET_STORAGE_LEN(d.l, d.n, d.m + 1, d.p));
    dfn_net_m(d, m);
    assert_true(dkf_dfnerts_net_storage_len(d.l, d.n, m, d.p) <=
                DKF_DFNERTS_NET_STORAGE_LEN(d.l, d.n, d.m + 1, d.p));
    return dkf_dfnerts_net_storage_len(d.l, d.n, m, d.p);
}
static dkf_status_t dfn_net_init(dims_t d, dkf_real_t *st, size_t len)
{
    static size_t start[XS_NODES + 1], nbr[DKF_GRAPH_NNZ(XS_NODES, XS_NODES - 1)], m[XS_NODES];
    static dkf_graph_t g;
    static dkf_mat_t x[XS_NODES], P[XS_NODES], dd[XS_NODES], Pd[XS_NODES], Pxd[XS_NODES];
    size_t edges[2 * XS_NODES] = {0}, e;
    const int p = d.p > 0;
    for (e = 0; e + 1 < d.l; ++e) edges[2 * e] = e, edges[2 * e + 1] = e + 1;
    assert_int_equal(dkf_graph_from_edges(&g, start, nbr, DKF_GRAPH_NNZ(XS_NODES, XS_NODES - 1),
                                          d.l, edges, d.l - 1),
                     DKF_OK);
    {
        /* with xs_refuse, only the last node's P0 is refused */
        const int refuse = xs_refuse;
        for (e = 0; e < d.l; ++e) {
            x[e] = xs_x(d.n), dd[e] = xs_x(d.p);
            Pxd[e] = test_view(d.n, d.p, xs_x0);
        }
        xs_refuse = 0;
        for (e = 0; e < d.l; ++e) P[e] = xs_eye(d.n), Pd[e] = xs_eye_in(1, d.p);
        xs_refuse = refuse;
        P[d.l - 1] = xs_eye_in(2, d.n);
    }
    dfn_net_m(d, m);
    return dkf_dfnerts_net_init(&xs_obj.dfn_net.net, &g, xs_obj.dfn_net.nodes, DKF_NERTS_DNERTSIF,
                                DKF_DFNERTS_JOINT, d.n, m, d.p, st, len, x, P, p ? dd : NULL,
                                p ? Pd : NULL, p ? Pxd : NULL);
}

static size_t tw_node_len(dims_t d) { return DKF_TW_NODE_STORAGE_LEN(d.n, d.m, d.p); }
static dkf_status_t tw_node_init(dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n);
    return dkf_tw_node_init(&xs_obj.tw_node, d.n, d.m, d.p, st, len, &x, &P);
}

/* l nodes on a path */
static size_t tw_net_len(dims_t d) { return DKF_TW_NET_STORAGE_LEN(d.l, d.n, d.m, d.p); }
static dkf_status_t tw_net_init(dims_t d, dkf_real_t *st, size_t len)
{
    static size_t start[XS_NODES + 1], nbr[DKF_GRAPH_NNZ(XS_NODES, XS_NODES - 1)];
    static dkf_graph_t g;
    size_t edges[2 * XS_NODES], e;
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n);
    for (e = 0; e + 1 < d.l; ++e) edges[2 * e] = e, edges[2 * e + 1] = e + 1;
    assert_int_equal(dkf_graph_from_edges(&g, start, nbr, DKF_GRAPH_NNZ(XS_NODES, XS_NODES - 1),
                                          d.l, edges, d.l - 1),
                     DKF_OK);
    return dkf_tw_net_init(&xs_obj.tw_net.net, &g, xs_obj.tw_net.nodes, d.n, d.m, d.p, st, len, &x,
                           &P);
}

static size_t wf_local_len(dims_t d) { return DKF_WFUSION_LOCAL_STORAGE_LEN(d.n, d.m); }
static dkf_status_t wf_local_init(dims_t d, dkf_real_t *st, size_t len)
{
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n);
    return dkf_wfusion_local_init(&xs_obj.wf_local, d.n, d.m, st, len, &x, &P);
}

/* l equal sensors: the macro is exact for them (and the function agrees) */
static size_t wf_len(dims_t d)
{
    const size_t m[XS_NODES] = {d.m, d.m, d.m, d.m};
    assert_int_equal(dkf_wfusion_storage_len(d.n, d.l, m), DKF_WFUSION_STORAGE_LEN(d.n, d.l, d.m));
    return DKF_WFUSION_STORAGE_LEN(d.n, d.l, d.m);
}
static dkf_status_t wf_init(dims_t d, dkf_real_t *st, size_t len)
{
    const size_t m[XS_NODES] = {d.m, d.m, d.m, d.m};
    dkf_mat_t x = xs_x(d.n), P = xs_eye(d.n), Hs = test_view(1, d.n, xs_P0[1]);
    memset(xs_P0[1], 0, sizeof xs_P0[1]);
    xs_P0[1][0] = DKF_R(1.0);
    return dkf_wfusion_init(&xs_obj.wf.fu, d.n, d.l, m, xs_obj.wf.nodes, st, len, &Hs, &x, &P);
}

/* selftune: dims (n, m, p, l) = (na, np, nc, K), the example's noise (L = 2) */
static size_t selftune_len(dims_t d) { return DKF_SELFTUNE_STORAGE_LEN(d.n, d.m, d.p, d.l); }
static dkf_status_t selftune_init(dims_t d, dkf_real_t *st, size_t len)
{
    static const dkf_real_t p[4] = {DKF_R(-0.5), DKF_R(0.1), DKF_R(0.0), DKF_R(0.0)},
                            sv[2] = {DKF_R(0.1), DKF_R(0.2)};
    dkf_selftune_cfg_t c;
    assert_int_equal(dkf_selftune_config_default(&c), DKF_OK);
    c.na = d.n;
    c.np = d.m;
    c.nc = d.p;
    c.lags = d.l;
    c.p = p;
    if (xs_refuse) c.sigma_xi2 = DKF_R(-1.0); /* refused by init's checks */
    else
        c.sigma_xi2 = DKF_R(0.3);
    c.L = 2;
    c.sigma_v2 = sv;
    return dkf_selftune_init(&xs_obj.selftune, &c, st, len);
}

/* The state parts of xs_st: one region from the start, or one per node
 * of a network at node l's storage. */
static void xs_state_at(regions_t *g, size_t off, size_t len)
{
    reg_add(g, xs_st + off, len * sizeof(dkf_real_t));
}
static void kf_state(dims_t d, regions_t *g) { xs_state_at(g, 0, DKF_KF_STATE_LEN(d.n, d.m)); }
static void info_state(dims_t d, regions_t *g) { xs_state_at(g, 0, DKF_INFO_STATE_LEN(d.n)); }
static void askf_state(dims_t d, regions_t *g)
{
    xs_state_at(g, 0, DKF_ASKF_STATE_LEN(d.n, d.m, d.p));
}
static void otskf_state(dims_t d, regions_t *g)
{
    xs_state_at(g, 0, DKF_OTSKF_STATE_LEN(d.n, d.p));
}
static void diffkf_state(dims_t d, regions_t *g)
{
    xs_state_at(g, 0, DKF_DIFFKF_STATE_LEN(d.n, d.m, d.p));
}
static void fc_state(dims_t d, regions_t *g)
{
    size_t m[XS_NODES], p[XS_NODES], i;
    for (i = 0; i < d.l; ++i) m[i] = d.m, p[i] = d.p;
    xs_state_at(g, 0, dkf_diffkf_fc_state_len(d.n, d.l, m, p));
}
static void uif_state(dims_t d, regions_t *g)
{
    xs_state_at(g, 0, DKF_UIF_STATE_LEN(d.n, d.m, d.p));
}
static void nerts_state(dims_t d, regions_t *g)
{
    xs_state_at(g, 0, DKF_NERTS_STATE_LEN(d.n, d.m, d.p));
}
static void dfn_node_state(dims_t d, regions_t *g)
{
    xs_state_at(g, 0, DKF_DFNERTS_NODE_STATE_LEN(d.n, d.m, d.p));
}
static void dfn_net_state(dims_t d, regions_t *g)
{
    size_t l;
    for (l = 0; l < d.l; ++l)
        xs_state_at(g, l * DKF_DFNERTS_NODE_STORAGE_LEN(d.n, d.m, d.p),
                    DKF_DFNERTS_NODE_STATE_LEN(d.n, d.m, d.p));
}
static void tw_node_state(dims_t d, regions_t *g)
{
    xs_state_at(g, 0, DKF_TW_NODE_STATE_LEN(d.n, d.p));
}
static void tw_net_state(dims_t d, regions_t *g)
{
    size_t l;
    for (l = 0; l < d.l; ++l)
        xs_state_at(g, l * DKF_TW_NODE_STORAGE_LEN(d.n, d.m, d.p), DKF_TW_NODE_STATE_LEN(d.n, d.p));
}
static void wf_local_state(dims_t d, regions_t *g)
{
    xs_state_at(g, 0, DKF_WFUSION_LOCAL_STATE_LEN(d.n, d.m));
}
/* each local filter's state, then the fusion's: P_ij, Hs and the last
 * fusions' results (wfusion.c's layout) */
static void wf_state(dims_t d, regions_t *g)
{
    const size_t N = d.n * d.l, own = d.l * DKF_WFUSION_LOCAL_STORAGE_LEN(d.n, d.m);
    size_t i;
    for (i = 0; i < d.l; ++i)
        xs_state_at(g, i * DKF_WFUSION_LOCAL_STORAGE_LEN(d.n, d.m),
                    DKF_WFUSION_LOCAL_STATE_LEN(d.n, d.m));
    xs_state_at(g, own, N * N + d.n + d.l * d.l + d.l + d.n * N + d.n + d.n * d.n);
}
static void selftune_state(dims_t d, regions_t *g)
{
    xs_state_at(g, 0, DKF_SELFTUNE_STATE_LEN(d.n, d.m, d.p, d.l));
}

static const xs_module_t xs_modules[] = {
    {"kf", kf_len, kf_init, {{1, 1, 0, 0}, {4, 2, 0, 0}, {2, 6, 0, 0}, {6, 6, 0, 0}, {7, 1, 0, 0}},
     kf_state},
    {"info", info_len, info_init, {{1, 0, 0, 0}, {3, 0, 0, 0}, {8, 0, 0, 0}}, info_state},
    {"askf", askf_len, askf_init, {{1, 1, 1, 0}, {4, 2, 2, 0}, {3, 5, 1, 0}, {6, 3, 4, 0}},
     askf_state},
    {"otskf", otskf_len, otskf_init,
     {{1, 1, 1, 0}, {4, 2, 2, 0}, {2, 5, 4, 0}, {6, 3, 2, 0}, {3, 1, 6, 0}}, otskf_state},
    {"diffkf", diffkf_len, diffkf_init,
     {{1, 1, 1, 0}, {4, 2, 2, 0}, {6, 3, 2, 0}, {3, 5, 4, 0}, {6, 6, 6, 0}}, diffkf_state},
    {"diffkf_fc", fc_len, fc_init,
     {{1, 1, 1, 1}, {4, 2, 2, 3}, {3, 3, 1, 4}, {6, 2, 1, 2}, {2, 4, 2, 2}}, fc_state},
    {"uif RTSF", uif_len, rtsf_init, {{1, 1, 1, 0}, {4, 3, 2, 0}, {2, 5, 4, 0}, {6, 2, 2, 0}},
     uif_state},
    {"uif NRTSF-DF", uif_len, nrtsf_df_init,
     {{1, 1, 1, 0}, {4, 2, 3, 0}, {2, 5, 4, 0}, {6, 3, 1, 0}}, uif_state},
    {"uif NRTSF", uif_len, nrtsf_init, {{1, 1, 1, 0}, {4, 2, 3, 0}, {3, 5, 2, 0}, {6, 1, 4, 0}},
     uif_state},
    {"nerts NERTSF", nerts_len, nertsf_init,
     {{1, 1, 0, 0}, {3, 3, 1, 0}, {4, 3, 1, 0}, {2, 6, 4, 0}, {6, 2, 2, 0}, {4, 36, 1, 0}},
      nerts_state},
    {"nerts DNERTSIF", nerts_len, dnertsif_init,
     {{1, 1, 1, 0}, {4, 2, 0, 0}, {4, 3, 1, 0}, {5, 4, 3, 0}, {4, 36, 1, 0}}, nerts_state},
    {"dfnerts node PAPER", dfn_node_len, dfn_paper_init,
     {{1, 1, 1, 0}, {4, 2, 0, 0}, {4, 3, 1, 0}, {5, 4, 3, 0}, {4, 36, 1, 0}}, dfn_node_state},
    {"dfnerts node JOINT", dfn_node_len, dfn_joint_init,
     {{1, 1, 1, 0}, {4, 2, 0, 0}, {4, 3, 1, 0}, {5, 4, 3, 0}, {3, 5, 2, 0}}, dfn_node_state},
    {"dfnerts net", dfn_net_len, dfn_net_init,
     {{1, 1, 1, 1}, {4, 3, 1, 4}, {4, 2, 0, 3}, {2, 3, 2, 2}}, dfn_net_state},
    {"tw_node", tw_node_len, tw_node_init, {{1, 1, 1, 0}, {4, 2, 2, 0}, {6, 3, 5, 0}, {5, 5, 1, 0}},
     tw_node_state},
    {"tw_net", tw_net_len, tw_net_init, {{1, 1, 1, 1}, {4, 2, 2, 3}, {3, 5, 1, 4}, {2, 1, 2, 2}},
     tw_net_state},
    {"wfusion local", wf_local_len, wf_local_init,
     {{1, 1, 0, 0}, {4, 1, 0, 0}, {4, 3, 0, 0}, {6, 2, 0, 0}, {2, 7, 0, 0}}, wf_local_state},
    {"wfusion", wf_len, wf_init,
     {{1, 1, 0, 1}, {4, 1, 0, 4}, {3, 2, 0, 4}, {2, 3, 0, 3}, {6, 4, 0, 2}}, wf_state},
    {"selftune", selftune_len, selftune_init,
     {{1, 0, 0, 1}, {2, 2, 1, 5}, {4, 4, 1, 32}, {3, 1, 0, 7}, {2, 0, 1, 3}}, selftune_state},
};

/* check(md, d, len) for every module md and each of its shapes d
 * (len = its storage length); the count of shapes. */
static size_t xs_each_shape(void (*check)(const xs_module_t *md, dims_t d, size_t len))
{
    size_t i, s, checked = 0;
    for (i = 0; i < sizeof xs_modules / sizeof xs_modules[0]; ++i) {
        const xs_module_t *md = &xs_modules[i];
        for (s = 0; s < XS_SHAPES && md->shape[s].n != 0; ++s) {
            const size_t len = md->len(md->shape[s]);
            assert_true(len > 0 && len <= XS_CAP);
            check(md, md->shape[s], len);
            ++checked;
        }
    }
    return checked;
}

static void exact_storage(const xs_module_t *md, dims_t d, size_t len)
{
    static unsigned char before[sizeof xs_obj];
    const dkf_real_t sentinel = DKF_R(1234.5);
    dkf_status_t st;
    memset(&xs_obj, 0x5a, sizeof xs_obj);
    memcpy(before, &xs_obj, sizeof xs_obj);
    st = md->init(d, xs_st, len - 1);
    if (st != DKF_ERR_CAPACITY || memcmp(before, &xs_obj, sizeof xs_obj) != 0) {
        print_error("%s (%zu, %zu, %zu, %zu): storage_len %zu - 1: status %s%s\n", md->name, d.n,
                    d.m, d.p, d.l, len, dkf_status_str(st),
                    st == DKF_ERR_CAPACITY ? ", the object changed" : "");
        fail();
    }
    xs_st[len] = sentinel;
    st = md->init(d, xs_st, len);
    if (st != DKF_OK || xs_st[len] != sentinel) {
        print_error("%s (%zu, %zu, %zu, %zu): storage_len %zu: status %s%s\n", md->name, d.n,
                    d.m, d.p, d.l, len, dkf_status_str(st),
                    st == DKF_OK ? ", wrote past the storage" : "");
        fail();
    }
}

static void test_exact_storage(void **state)
{
    (void)state;
    print_message("exact storage: %zu shapes checked\n", xs_each_shape(exact_storage));
}

/* What the caller must not touch is in one member `priv` at the end of
 * each object struct (docs/layout.md, the module contract; decisions.md
 * item 45): nothing follows it. */
#define PRIV_LAST(T) assert_int_equal(offsetof(T, priv) + sizeof(((T *)0)->priv), sizeof(T))
static void test_priv_last(void **state)
{
    (void)state;
    PRIV_LAST(dkf_kf_t);
    PRIV_LAST(dkf_info_t);
    PRIV_LAST(dkf_askf_t);
    PRIV_LAST(dkf_otskf_t);
    PRIV_LAST(dkf_uif_t);
    PRIV_LAST(dkf_nerts_t);
    PRIV_LAST(dkf_dfnerts_node_t);
    PRIV_LAST(dkf_dfnerts_net_t);
    PRIV_LAST(dkf_diffkf_t);
    PRIV_LAST(dkf_diffkf_fc_node_t);
    PRIV_LAST(dkf_diffkf_fc_t);
    PRIV_LAST(dkf_tw_node_t);
    PRIV_LAST(dkf_tw_net_t);
    PRIV_LAST(dkf_wfusion_local_t);
    PRIV_LAST(dkf_wfusion_t);
    PRIV_LAST(dkf_selftune_t);
}
#undef PRIV_LAST

/* An init over a live object (the same object and storage, initialised)
 * whose prior is refused at its last check (P0 = diag(1, .., 1, -1), the
 * last network node's only) leaves the object and the state parts of its
 * storage bit-identical. */
static void init_over_live(const xs_module_t *md, dims_t d, size_t len)
{
    regions_t g;
    char label[160];
    dkf_status_t st;
    xs_refuse = 0;
    assert_int_equal(md->init(d, xs_st, len), DKF_OK);
    reg_clear(&g);
    reg_add(&g, &xs_obj, sizeof xs_obj);
    md->state(d, &g);
    snap_take(&g);
    xs_refuse = 1;
    st = md->init(d, xs_st, len);
    xs_refuse = 0;
    snprintf(label, sizeof label, "%s (%zu, %zu, %zu, %zu): init over a live object", md->name, d.n,
             d.m, d.p, d.l);
    check_failed(&g, ANY_ERR, st, label, 0);
}

static void test_init_over_live(void **state)
{
    (void)state;
    print_message("init over a live object: %zu shapes checked\n", xs_each_shape(init_over_live));
}

/* Every DKF_*_DECLARE gives an array of exactly *_STORAGE_LEN reals that
 * init accepts; the fusion centre's, one for sensors up to (mx, px), also
 * serves smaller ones (here (3, 2) and (2, 1)). */
DKF_KF_DECLARE(static, dk_kf, 4, 2);
DKF_INFO_DECLARE(static, dk_info, 3);
DKF_ASKF_DECLARE(static, dk_askf, 3, 2, 1);
DKF_OTSKF_DECLARE(static, dk_otskf, 3, 2, 1);
DKF_DIFFKF_DECLARE(static, dk_diffkf, 3, 2, 1);
DKF_DIFFKF_FC_DECLARE(static, dk_fc, 3, 2, 3, 2);
DKF_UIF_DECLARE(static, dk_uif, 3, 2, 1);
DKF_TW_NODE_DECLARE(static, dk_tw_node, 3, 2, 1);
DKF_NERTS_DECLARE(static, dk_nerts, 4, 3, 1);
DKF_DFNERTS_NODE_DECLARE(static, dk_dfn_node, 4, 3, 1);
DKF_DFNERTS_NET_DECLARE(static, dk_dfn_net, 2, 4, 3, 1);
DKF_TW_NET_DECLARE(static, dk_tw_net, 2, 3, 2, 1);
DKF_WFUSION_LOCAL_DECLARE(static, dk_wfl, 4, 2);
DKF_WFUSION_DECLARE(static, dk_wf, 3, 2, 2);
DKF_SELFTUNE_DECLARE(static, dk_selftune, 2, 2, 1, 5);

#define ARRAY_LEN(a) (sizeof(a) / sizeof((a)[0]))

static void test_declare_macros(void **state)
{
    static const size_t fm[2] = {3, 2}, fp[2] = {2, 1};
    dkf_mat_t x = xs_x(3), P = xs_eye(3), d = xs_x(1), Pd = xs_eye_in(1, 1);
    (void)state;
    assert_int_equal(ARRAY_LEN(dk_kf_storage), DKF_KF_STORAGE_LEN(4, 2));
    assert_int_equal(ARRAY_LEN(dk_info_storage), DKF_INFO_STORAGE_LEN(3));
    assert_int_equal(ARRAY_LEN(dk_askf_storage), DKF_ASKF_STORAGE_LEN(3, 2, 1));
    assert_int_equal(ARRAY_LEN(dk_otskf_storage), DKF_OTSKF_STORAGE_LEN(3, 2, 1));
    assert_int_equal(ARRAY_LEN(dk_diffkf_storage), DKF_DIFFKF_STORAGE_LEN(3, 2, 1));
    assert_int_equal(ARRAY_LEN(dk_fc_storage), DKF_DIFFKF_FC_STORAGE_LEN(3, 2, 3, 2));
    assert_int_equal(ARRAY_LEN(dk_fc_nodes), 2);
    assert_true(dkf_diffkf_fc_storage_len(3, 2, fm, fp) <= ARRAY_LEN(dk_fc_storage));
    assert_int_equal(dkf_info_init(&dk_info, 3, dk_info_storage, ARRAY_LEN(dk_info_storage), &x, &P),
                     DKF_OK);
    assert_int_equal(dkf_askf_init(&dk_askf, 3, 2, 1, dk_askf_storage, ARRAY_LEN(dk_askf_storage),
                                   &x, &P, &d, &Pd, NULL),
                     DKF_OK);
    assert_int_equal(dkf_otskf_init(&dk_otskf, 3, 2, 1, dk_otskf_storage,
                                    ARRAY_LEN(dk_otskf_storage), &x, &P, &d, &Pd),
                     DKF_OK);
    assert_int_equal(dkf_diffkf_init(&dk_diffkf, 3, 2, 1, dk_diffkf_storage,
                                     ARRAY_LEN(dk_diffkf_storage), &x, &P),
                     DKF_OK);
    assert_int_equal(dkf_diffkf_fc_init(&dk_fc, dk_fc_nodes, 2, 3, fm, fp, dk_fc_storage,
                                        ARRAY_LEN(dk_fc_storage), &x, &P, NULL, NULL),
                     DKF_OK);
    assert_int_equal(ARRAY_LEN(dk_uif_storage), DKF_UIF_STORAGE_LEN(3, 2, 1));
    assert_int_equal(dkf_uif_init(&dk_uif, DKF_UIF_RTSF, 3, 2, 1, dk_uif_storage,
                                  ARRAY_LEN(dk_uif_storage), &x, &P),
                     DKF_OK);
    assert_int_equal(ARRAY_LEN(dk_selftune_storage), DKF_SELFTUNE_STORAGE_LEN(2, 2, 1, 5));
    {
        static const dkf_real_t p2[2] = {DKF_R(-0.7), DKF_R(0.5)}, sv1[1] = {DKF_R(0.1)};
        dkf_selftune_cfg_t c;
        assert_int_equal(dkf_selftune_config_default(&c), DKF_OK);
        c.np = 2, c.p = p2, c.L = 1, c.sigma_v2 = sv1;
        assert_int_equal(dkf_selftune_init(&dk_selftune, &c, dk_selftune_storage,
                                           ARRAY_LEN(dk_selftune_storage)),
                         DKF_OK);
    }
    assert_int_equal(ARRAY_LEN(dk_nerts_storage), DKF_NERTS_STORAGE_LEN(4, 3, 1));
    {
        static dkf_real_t I4[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        dkf_mat_t x4 = xs_x(4), P4 = test_view(4, 4, I4), Pxd = test_view(4, 1, xs_x0);
        assert_int_equal(dkf_nerts_init(&dk_nerts, DKF_NERTS_DNERTSIF, 4, 3, 1, dk_nerts_storage,
                                        ARRAY_LEN(dk_nerts_storage), &x4, &P4, &d, &Pd, &Pxd),
                         DKF_OK);
    }
    assert_int_equal(ARRAY_LEN(dk_dfn_node_storage), DKF_DFNERTS_NODE_STORAGE_LEN(4, 3, 1));
    assert_int_equal(ARRAY_LEN(dk_dfn_net_storage), DKF_DFNERTS_NET_STORAGE_LEN(2, 4, 3, 1));
    assert_int_equal(ARRAY_LEN(dk_dfn_net_nodes), 2);
    {
        static dkf_real_t I4[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        static size_t start[3], nbr[DKF_GRAPH_NNZ(2, 1)];
        static const size_t edge[2] = {0, 1}, dfn_m[2] = {3, 2}; /* m_max 3 serves m = 2 */
        static dkf_graph_t g;
        dkf_mat_t x4[2], P4[2], dv[2], Pdv[2], Pxd[2];
        size_t l;
        for (l = 0; l < 2; ++l) {
            x4[l] = xs_x(4), P4[l] = test_view(4, 4, I4), Pxd[l] = test_view(4, 1, xs_x0);
            dv[l] = d, Pdv[l] = Pd;
        }
        assert_int_equal(dkf_dfnerts_node_init(&dk_dfn_node, DKF_NERTS_DNERTSIF, DKF_DFNERTS_JOINT,
                                               4, 3, 1, dk_dfn_node_storage,
                                               ARRAY_LEN(dk_dfn_node_storage), &x4[0], &P4[0], &d,
                                               &Pd, &Pxd[0]),
                         DKF_OK);
        assert_int_equal(dkf_graph_from_edges(&g, start, nbr, DKF_GRAPH_NNZ(2, 1), 2, edge, 1),
                         DKF_OK);
        assert_int_equal(dkf_dfnerts_net_init(&dk_dfn_net, &g, dk_dfn_net_nodes,
                                              DKF_NERTS_DNERTSIF, DKF_DFNERTS_PAPER, 4, dfn_m, 1,
                                              dk_dfn_net_storage, ARRAY_LEN(dk_dfn_net_storage),
                                              x4, P4, dv, Pdv, Pxd),
                         DKF_OK);
    }
    assert_int_equal(ARRAY_LEN(dk_tw_node_storage), DKF_TW_NODE_STORAGE_LEN(3, 2, 1));
    assert_int_equal(dkf_tw_node_init(&dk_tw_node, 3, 2, 1, dk_tw_node_storage,
                                      ARRAY_LEN(dk_tw_node_storage), &x, &P),
                     DKF_OK);
    assert_int_equal(ARRAY_LEN(dk_tw_net_storage), DKF_TW_NET_STORAGE_LEN(2, 3, 2, 1));
    assert_int_equal(ARRAY_LEN(dk_tw_net_nodes), 2);
    {
        static size_t start[3], nbr[DKF_GRAPH_NNZ(2, 1)];
        static const size_t edge[2] = {0, 1};
        static dkf_graph_t g;
        assert_int_equal(dkf_graph_from_edges(&g, start, nbr, DKF_GRAPH_NNZ(2, 1), 2, edge, 1),
                         DKF_OK);
        assert_int_equal(dkf_tw_net_init(&dk_tw_net, &g, dk_tw_net_nodes, 3, 2, 1, dk_tw_net_storage,
                                         ARRAY_LEN(dk_tw_net_storage), &x, &P),
                         DKF_OK);
    }
    assert_int_equal(ARRAY_LEN(dk_wf_storage), DKF_WFUSION_STORAGE_LEN(3, 2, 2));
    assert_int_equal(ARRAY_LEN(dk_wf_nodes), 2);
    {
        const size_t wm[2] = {2, 1}; /* one smaller sensor: the macro is a bound */
        dkf_mat_t Hs = test_view(1, 3, xs_x0);
        assert_int_equal(dkf_wfusion_init(&dk_wf, 3, 2, wm, dk_wf_nodes, dk_wf_storage,
                                          ARRAY_LEN(dk_wf_storage), &Hs, &x, &P),
                         DKF_OK);
    }
    x = xs_x(4), P = xs_eye(4);
    assert_int_equal(ARRAY_LEN(dk_wfl_storage), DKF_WFUSION_LOCAL_STORAGE_LEN(4, 2));
    assert_int_equal(dkf_wfusion_local_init(&dk_wfl, 4, 2, dk_wfl_storage,
                                            ARRAY_LEN(dk_wfl_storage), &x, &P),
                     DKF_OK);
    assert_int_equal(dkf_kf_init(&dk_kf, 4, 2, dk_kf_storage, ARRAY_LEN(dk_kf_storage), &x, &P),
                     DKF_OK);
}

/* ---- the sweep's coverage ------------------------------------------------------------------ */

/* Functions that take a filter object but need no refusal here, each with
 * its reason. Functions that take no object (dkf_status_str, the matrix
 * kernels of dkf/mat.h and dkf/mat_riccati.h, tested for untouched
 * outputs by test_mat_*, dkf/graph.h, dkf/nl_model.h, the stacking and
 * storage-size helpers) are not on untouched_api.h's list at all. */
static const char *const untouched_exempt[] = {
    /* checkpoint sizes: return size_t, 0 for a NULL or uninitialised
     * object; they cannot fail and write nothing */
    "dkf_diffkf_checkpoint_len",
    "dkf_diffkf_fc_checkpoint_len",
    "dkf_wfusion_checkpoint_len",
};

/* Every public function that takes a filter object was refused at least
 * once under a check (every test above ran first), unless exempt; and
 * every exemption names such a function. */
static void test_every_object_call_refused(void **state)
{
#define DKF_UNTOUCHED_API(name, returns_status) #name,
    static const char *const api[] = {DKF_UNTOUCHED_API_LIST};
#undef DKF_UNTOUCHED_API
    size_t i, j, missing = 0;
    (void)state;
    for (i = 0; i < sizeof api / sizeof api[0]; ++i) {
        int exempt = 0;
        for (j = 0; j < sizeof untouched_exempt / sizeof untouched_exempt[0]; ++j)
            exempt |= strcmp(api[i], untouched_exempt[j]) == 0;
        if (!exempt && !call_refused(api[i])) {
            print_error("%s: no refusal of it is checked by this sweep\n", api[i]);
            ++missing;
        }
    }
    for (j = 0; j < sizeof untouched_exempt / sizeof untouched_exempt[0]; ++j) {
        int listed = 0;
        for (i = 0; i < sizeof api / sizeof api[0]; ++i)
            listed |= strcmp(api[i], untouched_exempt[j]) == 0;
        if (!listed) {
            print_error("exemption %s: not a public function that takes a filter object\n",
                        untouched_exempt[j]);
            ++missing;
        }
    }
    print_message("%zu public calls that take a filter object, %zu refused under a check\n",
                  sizeof api / sizeof api[0], n_refused_calls);
    assert_int_equal(missing, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kf),          cmocka_unit_test(test_info),
        cmocka_unit_test(test_askf_otskf),  cmocka_unit_test(test_diffkf),
        cmocka_unit_test(test_diffkf_fc),
        cmocka_unit_test(test_uif),         cmocka_unit_test(test_tw_node),
        cmocka_unit_test(test_tw_net),
        cmocka_unit_test(test_nerts),
        cmocka_unit_test(test_dfnerts),
        cmocka_unit_test(test_dfnerts_rejoin_refused_pd0),
        cmocka_unit_test(test_dfnerts_restart_rejoin),
        cmocka_unit_test(test_dfnerts_net),
        cmocka_unit_test(test_wfusion),
        cmocka_unit_test(test_selftune),
        cmocka_unit_test(test_exact_storage),
        cmocka_unit_test(test_priv_last),
        cmocka_unit_test(test_init_over_live),
        cmocka_unit_test(test_declare_macros),
        cmocka_unit_test(test_every_object_call_refused), /* last: it reads what ran */
    };
    const int failed = cmocka_run_group_tests(tests, NULL, NULL);
    print_message("%zu failing calls checked\n", n_checked);
    return failed;
}
