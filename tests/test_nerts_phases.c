/*
 * The phase API of dkf/nerts.h as Algorithm 3's nodes use it, against
 * df_dnertsif.json (tests/vectors/infofusion/): for every case, node and
 * step, predict + local must give the node's stored local statistics
 * (x_pred ... i, I), and commit_info with the file's consensus (Y, y)
 * must give its x, Px and the local d, Pd, Pxd. The consensus itself is
 * dkf/dfnerts.h's; here it is data, so this checks the single-node side of
 * the distributed filter on its own, including p = 0 (the DF-CKF case:
 * Rbar = R_tilde - Pxz^T P_pred^{-1} Pxz without elimination).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/nerts.h"
#include "dkf_test.h"
#include "nerts_fixture.h"

#define CAP 64

/* The file's rule (rtol 1e-8, atol 1e-10 of max(1, max|exp|)), checked
 * as max|got - exp| <= 1e-8 max(1, max|exp|); measured worst printed.
 * Float: 1e-3, as test_nerts_vectors (the same radar conditioning);
 * measured worst 2.3e-5. */
#if DKF_USE_FLOAT
#define VEC_REL 1e-3
#else
#define VEC_REL 1e-8
#endif

static dkf_real_t storage[DKF_NERTS_STORAGE_LEN(4, 3, 1)];

static void cmp(const char *tag, size_t node, size_t k, const json_t *exp, const char *key,
                const dkf_mat_t *v)
{
    static double ref[CAP];
    char what[128];
    size_t cnt = test_json_array(test_json_get(exp, key), ref, CAP, NULL, NULL);
    assert_int_equal(cnt, v->rows * v->cols);
    snprintf(what, sizeof what, "%s node %zu k=%zu %s", tag, node, k, key);
    if (cnt > 0) test_assert_close(what, v->data, ref, cnt, VEC_REL);
}

static dkf_mat_t *opt(dkf_mat_t *m)
{
    return m->rows * m->cols > 0 ? m : NULL;
}

static void run_node(const char *tag, const json_t *c, size_t j)
{
    static dkf_real_t x0[CAP], P0[CAP], d0[CAP], Pd0[CAP], Pxd0[CAP], Qb[CAP], Rb[CAP], zb[CAP],
        Yb[CAP], yb[CAP];
    static double sxy[2];
    const json_t *nm = json_array_get(test_json_get(c, "node_models"), j);
    const json_t *in = json_array_get(test_json_get(c, "init_per_node"), j);
    const json_t *steps = test_json_get(c, "steps");
    const char *fam = json_string_value(test_json_get(nm, "family"));
    radar_t rc;
    dkf_nl_model_t md;
    dkf_nerts_t f;
    dkf_mat_t mx, mP, mdd, mPd, mPxd, Q, R, z, Y, y;
    size_t s;
    memset(&rc, 0, sizeof rc);
    test_json_array(test_json_get(nm, "sensor_xy"), sxy, 2, NULL, NULL);
    rc.sx = sxy[0];
    rc.sy = sxy[1];
    rc.with_omega = strcmp(fam, "s1_radar") == 0;
    if (!rc.with_omega) {
        assert_string_equal(fam, "s1_ckf");
        rc.omega_fixed = json_number_value(test_json_get(nm, "omega_fixed"));
    }
    md = radar_model(&rc, 1);
    test_json_mat(test_json_get(nm, "Q"), Qb, CAP, &Q);
    test_json_mat(test_json_get(nm, "R"), Rb, CAP, &R);
    test_json_mat(test_json_get(in, "x0"), x0, CAP, &mx);
    test_json_mat(test_json_get(in, "Px0"), P0, CAP, &mP);
    test_json_mat(test_json_get(in, "d0"), d0, CAP, &mdd);
    test_json_mat(test_json_get(in, "Pd0"), Pd0, CAP, &mPd);
    test_json_mat(test_json_get(in, "Pxd0"), Pxd0, CAP, &mPxd);
    assert_int_equal(dkf_nerts_init(&f, DKF_NERTS_DNERTSIF, 4, md.m, md.p, storage,
                                    DKF_NERTS_STORAGE_LEN(4, md.m, md.p), &mx, &mP, opt(&mdd),
                                    opt(&mPd), md.p > 0 ? &mPxd : NULL),
                     DKF_OK);
    for (s = 0; s < json_array_size(steps); ++s) {
        const json_t *st = json_array_get(steps, s);
        const json_t *e = json_array_get(test_json_get(st, "expected_per_node"), j);
        const size_t k = test_json_size(st, "k");
        test_json_mat(json_array_get(test_json_get(st, "z"), j), zb, CAP, &z);
        assert_int_equal(dkf_nerts_predict(&f, &md, NULL, &Q), DKF_OK);
        assert_int_equal(dkf_nerts_local(&f, &md, NULL, &R, &z), DKF_OK);
        cmp(tag, j, k, e, "x_pred", &f.x_pred);
        cmp(tag, j, k, e, "P_pred", &f.P_pred);
        cmp(tag, j, k, e, "Y_pred", &f.Y_pred);
        cmp(tag, j, k, e, "y_pred", &f.y_pred);
        cmp(tag, j, k, e, "z_hat", &f.z_hat);
        cmp(tag, j, k, e, "R_tilde", &f.R_tilde);
        cmp(tag, j, k, e, "nu", &f.nu);
        if (md.p > 0) cmp(tag, j, k, e, "M", &f.M);
        cmp(tag, j, k, e, "Rbar_inv", &f.Rbar_inv);
        cmp(tag, j, k, e, "i", &f.i);
        cmp(tag, j, k, e, "I", &f.I);
        test_json_mat(test_json_get(e, "Y"), Yb, CAP, &Y);
        test_json_mat(test_json_get(e, "y"), yb, CAP, &y);
        assert_int_equal(dkf_nerts_commit_info(&f, &Y, &y), DKF_OK);
        assert_int_equal(f.k, k);
        cmp(tag, j, k, e, "x", &f.x);
        cmp(tag, j, k, e, "Px", &f.Px);
        cmp(tag, j, k, e, "d", &f.d);
        cmp(tag, j, k, e, "Pd", &f.Pd);
        cmp(tag, j, k, e, "Pxd", &f.Pxd);
    }
}

static void test_df_nodes_local_and_commit(void **state)
{
    json_t *root = test_load_vector("infofusion/df_dnertsif.json");
    const json_t *cases = test_json_get(root, "cases");
    size_t i, j, nodes = 0;
    (void)state;
    test_reset_worst_rel();
    for (i = 0; i < json_array_size(cases); ++i) {
        const json_t *c = json_array_get(cases, i);
        const size_t N = json_array_size(test_json_get(c, "node_models"));
        for (j = 0; j < N; ++j) run_node(json_string_value(test_json_get(c, "name")), c, j);
        nodes += N;
    }
    print_message("df_dnertsif.json: %zu cases, %zu nodes, worst rel err %.2e (tol %.0e)\n",
                  json_array_size(cases), nodes, test_worst_rel(), VEC_REL);
    assert_true(json_array_size(cases) >= 5);
#if !DKF_USE_FLOAT
    test_assert_below("df nodes worst", test_worst_rel(), 1e-12);
#endif
    json_decref(root);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_df_nodes_local_and_commit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
