/*
 * Difference KF (dkf/diffkf.h): seed-000 golden vectors, invariance to the
 * unknown input's initial value, failure atomicity.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/diffkf.h"
#include "dkf_test.h"

#define NX 6
#define NY 6
#define NP 6
#define CAP (NX * NX)

/* Vector tolerance, relative to max(1, max|expected|) per array. Double:
 * the vectors' tolerance 1e-9 (the vectors are within 1.6e-11 of a batch LMMSE; we
 * measure ~1e-13). Float: the DKF's L_k is a sum of four covariances and
 * differences of nearly equal terms (M P M^T against Ru), cond(L) ~ 30,
 * and x reaches 300, so a step costs ~cond * p * eps relative; stable
 * filter, no growth: 1e-4 (observed below 1e-5). */
#if DKF_USE_FLOAT
#define VEC_REL 1e-4
#else
#define VEC_REL 1e-9
#endif

typedef struct {
    DKF_DIFFKF_DECLARE(, f, NX, NY, NP);
} dkf_box_t;

static void compare(const char *what, const dkf_mat_t *got, const json_t *out, const char *key,
                    size_t j)
{
    double e[CAP];
    size_t cnt = test_json_array(json_array_get(test_json_get(out, key), j), e, CAP, NULL, NULL);
    assert_int_equal(cnt, got->rows * got->cols);
    test_assert_close(what, got->data, e, cnt, VEC_REL);
}

/* Runs the DKF over one sensor of a vector file, comparing every output
 * with out (the DKF entry of that sensor), and returns nothing. */
static void run_against(dkf_box_t *b, const json_t *root, const json_t *dynamics,
                        const json_t *sensor, const json_t *yvals, const json_t *P00,
                        const json_t *out)
{
    static test_ui_step_t mk, mk1;
    dkf_real_t xs[NX], Ps[CAP], ys[NY];
    dkf_mat_t x0, P0, y;
    size_t N = json_array_size(test_json_get(root, "k")), j;
    test_json_mat(test_json_get(test_json_get(root, "init"), "x00"), xs, NX, &x0);
    test_json_mat(P00, Ps, CAP, &P0);
    test_ui_model_at(&mk1, dynamics, sensor, 1);
    test_ui_model_at(&mk, dynamics, sensor, 0);
    assert_int_equal(dkf_diffkf_init(&b->f, x0.rows, mk1.Hm.rows, mk1.Am.cols, b->f_storage,
                                     DKF_DIFFKF_STORAGE_LEN(NX, NY, NP), &x0, &P0),
                     DKF_OK);
    test_json_mat(json_array_get(yvals, 0), ys, NY, &y); /* y_1 */
    assert_int_equal(dkf_diffkf_start(&b->f, &mk.Fm, &mk.Qm, &mk1.meas, &y), DKF_OK);
    for (j = 0; j < N; ++j) {
        const size_t k = j + 1;
        compare("DKF xp", &b->f.xn, out, "xp", j);
        compare("DKF Pp", &b->f.Pn, out, "Pp", j);
        test_ui_model_at(&mk, dynamics, sensor, k);
        test_ui_model_at(&mk1, dynamics, sensor, k + 1);
        test_json_mat(json_array_get(yvals, k), ys, NY, &y); /* y_{k+1} */
        assert_int_equal(dkf_diffkf_step(&b->f, &mk.dyn, &mk1.meas, &y), DKF_OK);
        assert_int_equal(b->f.k, k);
        compare("DKF z", &b->f.z, out, "z", j);
        compare("DKF dz", &b->f.dz, out, "dz", j);
        compare("DKF J", &b->f.J, out, "J", j);
        compare("DKF L", &b->f.L, out, "L", j);
        compare("DKF K", &b->f.K, out, "K", j);
        compare("DKF xf", &b->f.xf, out, "xf", j);
        compare("DKF Pf", &b->f.Pf, out, "Pf", j);
        /* One name, one meaning: the struct's xp after step k is x_{k|k-1},
         * the vector's (and dkf-run's) xp at the same k. */
        compare("DKF xp after the step", &b->f.xp, out, "xp", j);
    }
}

static void test_diffkf_matches_ex1_vector(void **state)
{
    static dkf_box_t b;
    test_run_vector_t v;
    (void)state;
    test_load_run_vector(&v, "diffkf/ex1_single.json", "DKF");
    test_reset_worst_rel();
    run_against(&b, v.root, v.model, v.model, v.yv, test_json_get(v.init, "P00"), v.out);
    print_message("worst relative error %.3e\n", test_worst_rel());
    json_decref(v.root);
}

/* ex3: each sensor's local DKF (outputs.local[i]). */
static void test_diffkf_matches_ex3_local_vectors(void **state)
{
    static dkf_box_t b;
    json_t *root = test_load_vector("diffkf/ex3_multi.json");
    const json_t *model = test_json_get(root, "model");
    const json_t *sensors = test_json_get(model, "sensors");
    const json_t *locals = test_json_get(test_json_get(root, "outputs"), "local");
    const json_t *P00 = test_json_get(test_json_get(root, "init"), "P00_local");
    size_t i;
    (void)state;
    test_reset_worst_rel();
    for (i = 0; i < json_array_size(sensors); ++i)
        run_against(&b, root, model, json_array_get(sensors, i),
                    test_json_get(json_array_get(test_json_get(root, "y"), i), "values"),
                    json_array_get(P00, i), json_array_get(locals, i));
    print_message("worst relative error %.3e\n", test_worst_rel());
    json_decref(root);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_diffkf_matches_ex1_vector),
        cmocka_unit_test(test_diffkf_matches_ex3_local_vectors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
