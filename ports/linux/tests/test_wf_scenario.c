/*
 * test_wf_scenario.c - the weighted-fusion cases layout (scn_wfcases.c)
 * and its model in dkf_real_t (wf_model.c) on the seed-002 vector: every
 * accessor returns the file's values (Q = Gamma Qe Gamma^T recomputed here
 * in long double), different measurement dimensions per sensor, an
 * optional x_true and expected, and the refusals with their key paths.
 */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <jansson.h>

#include "scenario.h"
#include "wf_model.h"

#define VEC DKF_VECTOR_DIR "/infofusion/s2_weighted_fusion.json"

static json_t *vector_case(void)
{
    json_error_t je;
    json_t *root = json_load_file(VEC, 0, &je);
    assert_non_null(root);
    return root;
}

static dkf_scenario_t *load_doc(json_t *root, char *err)
{
    char *txt = json_dumps(root, JSON_COMPACT);
    dkf_scenario_t *s;
    assert_non_null(txt);
    s = dkf_scenario_load_buffer(txt, strlen(txt), "wf.json", NULL, err, DKF_SCN_ERR_LEN);
    free(txt);
    return s;
}

static double jnum(const json_t *j, size_t i, size_t k)
{
    return json_number_value(json_array_get(json_array_get(j, i), k));
}

static void test_vector_mapping(void **state)
{
    char err[DKF_SCN_ERR_LEN];
    json_t *root = vector_case();
    const json_t *cj = json_array_get(json_object_get(root, "cases"), 0);
    const json_t *Phi = json_object_get(cj, "Phi"), *G = json_object_get(cj, "Gamma"),
                 *Qe = json_object_get(cj, "Qe");
    dkf_scenario_t *s = dkf_scenario_load(VEC, NULL, err, sizeof err);
    const dkf_scn_mat_t *F, *Q, *Hs, *H, *R;
    size_t i, j, a, b;
    (void)state;
    assert_non_null(s);
    assert_int_equal(s->layout, DKF_SCN_LAYOUT_WFCASES);
    assert_string_equal(s->case_name, "seed002_5_sensors");
    assert_int_equal(s->n, 4);
    assert_int_equal(s->nsensors, 5);
    assert_int_equal(s->steps, 30);
    F = dkf_scn_model(s, "F");
    Q = dkf_scn_model(s, "Q");
    Hs = dkf_scn_model(s, "Hs");
    assert_non_null(F);
    assert_non_null(Q);
    assert_non_null(Hs);
    assert_int_equal(Hs->rows, 1);
    assert_int_equal(Hs->cols, 4);
    for (i = 0; i < 4; ++i)
        for (j = 0; j < 4; ++j) {
            long double q = 0.0L;
            for (a = 0; a < 2; ++a)
                for (b = 0; b < 2; ++b)
                    q += (long double)jnum(G, i, a) * jnum(Qe, a, b) * jnum(G, j, b);
            assert_true(F->data[i * 4 + j] == jnum(Phi, i, j));
            /* a sum of 4 products in double: within 4 eps of the scale */
            assert_true(fabsl((long double)Q->data[i * 4 + j] - q) <= 4 * DBL_EPSILON * 10.0);
            assert_true(Q->data[i * 4 + j] == Q->data[j * 4 + i]);
        }
    for (i = 0; i < 5; ++i) {
        H = dkf_scn_sensor_model(s, i, "H");
        R = dkf_scn_sensor_model(s, i, "R");
        assert_int_equal(H->rows, 1);
        assert_int_equal(H->cols, 4);
        assert_int_equal(R->rows, 1);
        assert_true(R->data[0] ==
                    jnum(json_array_get(json_object_get(cj, "R"), i), 0, 0));
        assert_true(H->data[3] ==
                    jnum(json_array_get(json_object_get(cj, "H"), i), 0, 3));
    }
    /* y_i(t) = steps[t-1].y[i] for t = 1..30, nothing at 0 or 31 */
    assert_null(dkf_scn_y(s, 0, 0));
    assert_null(dkf_scn_y(s, 0, 31));
    assert_true(dkf_scn_y(s, 2, 1)[0] ==
                jnum(json_object_get(json_array_get(json_object_get(cj, "steps"), 0), "y"), 2,
                     0));
    assert_true(dkf_scn_y(s, 4, 30)[0] ==
                jnum(json_object_get(json_array_get(json_object_get(cj, "steps"), 29), "y"), 4,
                     0));
    /* truth k = 0..30 from x_true */
    assert_true(dkf_scn_truth(s, 0)[1] == jnum(json_object_get(cj, "x_true"), 0, 1));
    assert_true(dkf_scn_truth(s, 30)[3] == jnum(json_object_get(cj, "x_true"), 30, 3));
    assert_null(dkf_scn_truth(s, 31));
    assert_true(dkf_scn_init(s, "x00")->rows == 4);
    assert_true(dkf_scn_init(s, "P00")->data[5] == jnum(json_object_get(cj, "P0"), 1, 1));
    dkf_scenario_free(s);
    json_decref(root);
}

/* A generated scenario: steps of {t, y} only, no x_true; sensor 1 with two
 * rows (m = 2): the model's views follow every sensor's m. */
static void test_generated_mixed_m(void **state)
{
    char err[DKF_SCN_ERR_LEN];
    json_t *root = vector_case();
    json_t *cj = json_array_get(json_object_get(root, "cases"), 0);
    json_t *steps = json_object_get(cj, "steps");
    dkf_wf_model_t mdl;
    dkf_scenario_t *s;
    size_t j;
    (void)state;
    json_object_del(cj, "x_true");
    json_object_del(cj, "steady_state");
    json_array_set_new(json_object_get(cj, "H"), 1,
                       json_pack("[[f,f,f,f],[f,f,f,f]]", 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
                                 0.0));
    json_array_set_new(json_object_get(cj, "R"), 1, json_pack("[[f,f],[f,f]]", 2.0, 0.5, 0.5,
                                                              1.0));
    for (j = 0; j < json_array_size(steps); ++j) {
        json_t *st = json_array_get(steps, j);
        json_object_del(st, "expected");
        json_array_set_new(json_object_get(st, "y"), 1, json_pack("[f,f]", (double)j, -1.0));
    }
    s = load_doc(root, err);
    if (s == NULL) fail_msg("%s", err);
    assert_int_equal(s->sensors[1].m, 2);
    assert_int_equal(s->ntruth, 0);
    assert_int_equal(dkf_wf_model_load(s, &mdl, err, sizeof err), 0);
    assert_int_equal(mdl.l, 5);
    assert_int_equal(mdl.m[1], 2);
    assert_int_equal(mdl.m_max, 2);
    assert_int_equal(mdl.R[1].rows, 2);
    assert_true(mdl.R[1].data[1] == (dkf_real_t)0.5);
    assert_true(mdl.meas[1].H == &mdl.H[1]);
    assert_true(mdl.dyn.Q == &mdl.Q);
    assert_int_equal(dkf_wf_model_y(&mdl, s, 7), 0);
    assert_true(mdl.y[1].data[0] == (dkf_real_t)6.0);
    assert_true(mdl.y[1].data[1] == (dkf_real_t)-1.0);
    assert_int_equal(dkf_wf_model_y(&mdl, s, 31), -1);
    dkf_wf_model_free(&mdl);
    dkf_scenario_free(s);
    json_decref(root);
}

/* One edit of the vector's case and the message it must give. */
typedef void (*edit_fn)(json_t *cj);
static void expect_refused(edit_fn edit, const char *msg)
{
    char err[DKF_SCN_ERR_LEN];
    json_t *root = vector_case();
    dkf_scenario_t *s;
    edit(json_array_get(json_object_get(root, "cases"), 0));
    s = load_doc(root, err);
    if (s != NULL) fail_msg("accepted; expected '%s'", msg);
    if (strstr(err, msg) == NULL) fail_msg("got '%s', expected '%s'", err, msg);
    json_decref(root);
}

static void e_H_shape(json_t *cj)
{
    json_array_set_new(json_object_get(cj, "H"), 2, json_pack("[[f,f,f]]", 1.0, 0.0, 0.0));
}
static void e_R_not_pd(json_t *cj)
{
    json_array_set_new(json_object_get(cj, "R"), 3, json_pack("[[f]]", -0.5));
}
static void e_R_count(json_t *cj)
{
    json_array_remove(json_object_get(cj, "R"), 4);
}
static void e_y_missing(json_t *cj)
{
    json_object_del(json_array_get(json_object_get(cj, "steps"), 4), "y");
}
static void e_y_count(json_t *cj)
{
    json_array_remove(json_object_get(json_array_get(json_object_get(cj, "steps"), 2), "y"), 0);
}
static void e_t(json_t *cj)
{
    json_object_set_new(json_array_get(json_object_get(cj, "steps"), 3), "t", json_integer(7));
}
static void e_truth_len(json_t *cj)
{
    json_array_remove(json_object_get(cj, "x_true"), 30);
}
static void e_Qe_shape(json_t *cj)
{
    json_object_set_new(cj, "Qe", json_pack("[[f]]", 1.0));
}
static void e_Hs_shape(json_t *cj)
{
    json_object_set_new(cj, "H_signal", json_pack("[[f,f]]", 1.0, 0.0));
}
static void e_Phi_square(json_t *cj)
{
    json_array_remove(json_object_get(cj, "Phi"), 3);
}
static void e_x0_len(json_t *cj)
{
    json_array_remove(json_object_get(cj, "x_hat0"), 0);
}

static void test_refusals(void **state)
{
    (void)state;
    expect_refused(e_H_shape, "wf.json: cases[0].H[2]: expected 1x4 matrix, got 1x3");
    expect_refused(e_R_not_pd, "wf.json: cases[0].R[3]: not positive definite");
    expect_refused(e_R_count, "wf.json: cases[0].R: expected a list of 5 matrices (one per "
                              "H_i), got 4");
    expect_refused(e_y_missing, "wf.json: cases[0].steps[4].y: missing key");
    expect_refused(e_y_count, "wf.json: cases[0].steps[2].y: expected a list of 5 "
                              "measurements (one per sensor, as H), got 4");
    expect_refused(e_t, "wf.json: cases[0].steps[3].t: expected 4 (steps list t = 1..N), got 7");
    expect_refused(e_truth_len, "wf.json: cases[0].x_true: expected 31 states");
    expect_refused(e_Qe_shape, "wf.json: cases[0].Qe: expected 2x2 matrix, got 1x1");
    expect_refused(e_Hs_shape, "wf.json: cases[0].H_signal: expected 1x4 matrix, got 1x2");
    expect_refused(e_Phi_square, "wf.json: cases[0].Phi: expected a square matrix");
    expect_refused(e_x0_len, "wf.json: cases[0].x_hat0: expected a vector of 4 values");
}

/* dkf_wf_model_load refuses a scenario of another layout. */
static void test_model_other_layout(void **state)
{
    char err[DKF_SCN_ERR_LEN];
    dkf_wf_model_t mdl;
    dkf_scenario_t *s =
        dkf_scenario_load(DKF_VECTOR_DIR "/diffkf/ex1_single.json", NULL, err, sizeof err);
    (void)state;
    assert_non_null(s);
    assert_int_equal(dkf_wf_model_load(s, &mdl, err, sizeof err), -1);
    assert_non_null(strstr(err, "not a weighted-fusion case"));
    assert_null(mdl.data);
    dkf_scenario_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vector_mapping),
        cmocka_unit_test(test_generated_mixed_m),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_model_other_layout),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
