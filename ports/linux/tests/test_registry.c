/*
 * The runner registry (registry.h) and the host utility file (util.h):
 * every --filter name is found once, every family has its operations, the
 * option/layout name lists dkf-run prints, a run driven through the
 * operations alone (kf on ex1, rtsf on the seed-004 vector), the dkf
 * family's node role against its whole-scenario run, the JSON
 * placement of "local[i]" estimators, and the FNV-1a hash against values
 * computed independently (Python, the FNV-1a definition over the bytes
 * most significant first).
 */
#define _POSIX_C_SOURCE 200809L /* mkstemp */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "record_doc.h"
#include "registry.h"
#include "util.h"

static void test_every_filter_found_once(void **state)
{
    size_t i, j, i2, j2, count = 0;
    (void)state;
    for (i = 0; dkf_registry[i] != NULL; ++i)
        for (j = 0; j < dkf_registry[i]->nfilters; ++j) {
            const dkf_filter_t *f = &dkf_registry[i]->filters[j];
            assert_ptr_equal(dkf_registry_find(f->name), f);
            assert_ptr_equal(f->family, dkf_registry[i]);
            for (i2 = 0; dkf_registry[i2] != NULL; ++i2)
                for (j2 = 0; j2 < dkf_registry[i2]->nfilters; ++j2)
                    if (i2 != i || j2 != j)
                        assert_string_not_equal(dkf_registry[i2]->filters[j2].name, f->name);
            ++count;
        }
    /* kf info dkf askf otskf rtsf nrtsf_df nrtsf tw1 tw2 tw3 nertsf nertsif dnertsf dnertsif
     * cf_dnertsf df_dnertsif df_ckf df_dnertsif_joint local_kf fusion_scalar fusion_matrix
     * fusion_steady fusion_selftune central_kf */
    assert_int_equal(count, 25);
    assert_null(dkf_registry_find("ukf"));
}

static void test_every_family_complete(void **state)
{
    size_t i;
    (void)state;
    for (i = 0; dkf_registry[i] != NULL; ++i) {
        const dkf_family_t *fam = dkf_registry[i];
        assert_non_null(fam->name);
        assert_true(fam->nfilters >= 1);
        assert_true(fam->layouts != 0);
        assert_non_null(fam->check);
        assert_non_null(fam->create);
        assert_non_null(fam->step);
        assert_non_null(fam->record);
        assert_non_null(fam->summary);
        assert_non_null(fam->destroy);
    }
}

static void test_names_lists(void **state)
{
    char out[128];
    (void)state;
    assert_string_equal(dkf_registry_names(out, sizeof out, "d00", -1),
                        "askf and otskf");
    assert_string_equal(dkf_registry_names(out, sizeof out, "eta", -1), "tw3");
    assert_string_equal(dkf_registry_names(out, sizeof out, "metrics-only", -1),
                        "tw1, tw2, tw3");
    assert_string_equal(dkf_registry_names(out, sizeof out, NULL, DKF_SCN_LAYOUT_STEPS),
                        "rtsf, nrtsf_df, nrtsf");
    assert_string_equal(dkf_registry_names(out, sizeof out, NULL, DKF_SCN_LAYOUT_NETWORK),
                        "tw1, tw2, tw3");
    assert_string_equal(dkf_registry_names(out, sizeof out, NULL, DKF_SCN_LAYOUT_CASES),
                        "kf, info, dkf, askf, otskf");
    assert_string_equal(dkf_registry_names(out, sizeof out, NULL, DKF_SCN_LAYOUT_NLCASES),
                        "nertsf, nertsif, dnertsf, dnertsif, cf_dnertsf, df_dnertsif, df_ckf, "
                        "df_dnertsif_joint");
    assert_string_equal(dkf_registry_names(out, sizeof out, NULL, DKF_SCN_LAYOUT_WFCASES),
                        "local_kf, fusion_scalar, fusion_matrix, fusion_steady, fusion_selftune, central_kf");
}

/* The families' options through the registry alone: which filters take
 * them, their labels, the defaults and a value refused by the family. */
static void test_family_options(void **state)
{
    const dkf_filter_t *tw3 = dkf_registry_find("tw3"), *kf = dkf_registry_find("kf");
    char out[64], err[256];
    void *area;
    int oom;
    (void)state;
    assert_true(dkf_registry_takes(tw3, "eta"));
    assert_false(dkf_registry_takes(dkf_registry_find("tw2"), "eta"));
    assert_false(dkf_registry_takes(kf, "d00"));
    assert_true(dkf_registry_takes(dkf_registry_find("otskf"), "Pd00-scale"));
    assert_null(dkf_registry_opt(NULL, "no-such-option"));
    assert_string_equal(dkf_registry_opt_label(out, sizeof out, "Pd00-scale"),
                        "--d00/--Pd00-scale");
    assert_string_equal(dkf_registry_opt_label(out, sizeof out, "eta"), "--eta");
    assert_null(dkf_registry_opts_new(dkf_registry_find("rtsf"), &oom)); /* uif: none */
    assert_int_equal(oom, 0);
    area = dkf_registry_opts_new(tw3, &oom);
    assert_non_null(area);
    assert_int_equal(dkf_registry_opt_set(tw3, area, "eta", "x", err, sizeof err), DKF_EXIT_USAGE);
    assert_string_equal(err, "--eta x: expected an integer >= 0 (at most 1000000)");
    assert_int_equal(dkf_registry_opt_set(tw3, area, "eta", "3", err, sizeof err), DKF_EXIT_OK);
    assert_int_equal(dkf_registry_opt_set(tw3, area, "d00", "1", err, sizeof err),
                     DKF_EXIT_USAGE);
    assert_string_equal(err, "--d00: not an option of filter tw3");
    free(area);
}

/* Loads path, runs filter `name` through the registry's operations only
 * (recording), returns the output document (record_doc.h). */
static json_t *run(const char *path, const char *name, dkf_scenario_t **sp,
                   const dkf_filter_t **fp, dkf_runner_t **rp)
{
    char err[DKF_SCN_ERR_LEN];
    const dkf_filter_t *f = dkf_registry_find(name);
    dkf_scenario_t *s = dkf_scenario_load(path, NULL, err, sizeof err);
    dkf_run_opts_t o;
    dkf_runner_t *r;
    json_t *doc;
    int rc = -1;
    if (s == NULL) fail_msg("%s", err);
    assert_non_null(f);
    memset(&o, 0, sizeof o);
    o.record = 1;
    if (f->family->check(f, &o, s, err, sizeof err) != DKF_EXIT_OK) fail_msg("%s", err);
    r = f->family->create(f, &o, s, err, sizeof err, &rc);
    if (r == NULL) fail_msg("%s", err);
    assert_int_equal(rc, DKF_EXIT_OK);
    doc = record_doc(f, r, s);
    *sp = s;
    *fp = f;
    *rp = r;
    return doc;
}

static void test_kf_through_the_operations(void **state)
{
    dkf_scenario_t *s;
    const dkf_filter_t *f;
    dkf_runner_t *r;
    json_t *doc = run(DKF_VECTOR_DIR "/diffkf/ex1_single.json", "kf", &s, &f, &r);
    const char *name = NULL;
    const double *sf = NULL, *sp = NULL;
    json_t *xf = json_object_get(json_object_get(json_object_get(doc, "outputs"), "KF"), "xf");
    size_t k, finite = 0;
    (void)state;
    assert_int_equal(json_array_size(xf), s->steps);
    assert_int_equal(f->family->errors(r, 0, &name, &sf, &sp), 1);
    assert_string_equal(name, "KF");
    for (k = 0; k < s->steps; ++k) finite += isfinite(sf[k]) && sf[k] >= 0 && sp[k] >= 0;
    assert_true(finite > 0); /* ex1 has truth */
    assert_int_equal(f->family->errors(r, 1, &name, &sf, &sp), 0);
    f->family->destroy(r);
    json_decref(doc);
    dkf_scenario_free(s);
}

/* The node role (what dkf-node runs) on ex1's single sensor gives, step for
 * step and bit for bit, the DKF that dkf-run's dkf runner records: the
 * two go through different code (est_diffkf_node.c's per-sensor model
 * loading and start/step vs est_diffkf.c's stacked run) over one file. A
 * restart on a bad measurement is refused with a message, and only the dkf
 * family has a node role (so dkf-node refuses every other --filter). */
static void test_dkf_node_role(void **state)
{
    dkf_scenario_t *s;
    const dkf_filter_t *f;
    dkf_runner_t *r;
    json_t *doc = run(DKF_VECTOR_DIR "/diffkf/ex1_single.json", "dkf", &s, &f, &r);
    json_t *out = json_object_get(json_object_get(doc, "outputs"), "DKF");
    const dkf_node_ops_t *ops = f->family->node;
    char err[DKF_SCN_ERR_LEN];
    dkf_node_filter_t *nf;
    dkf_node_estimate_t msg;
    size_t i, k, nroles = 0;
    (void)state;
    assert_non_null(ops);
    for (i = 0; dkf_registry[i] != NULL; ++i) nroles += dkf_registry[i]->node != NULL;
    assert_int_equal(nroles, 2); /* dkf and wfusion */
    assert_int_equal(ops->same_step, 0);
    nf = ops->create(f, s, 0, err, sizeof err);
    if (nf == NULL) fail_msg("%s", err);
    if (ops->start(nf, 1, dkf_scn_y(s, 0, 1), err, sizeof err) != DKF_EXIT_OK) fail_msg("%s", err);
    for (k = 1; k <= s->steps; ++k) {
        json_t *xf = json_array_get(json_object_get(out, "xf"), k - 1);
        if (ops->step(nf, (long)k, dkf_scn_y(s, 0, (long)k + 1), err, sizeof err) != DKF_EXIT_OK)
            fail_msg("%s", err);
        assert_int_equal(ops->payload(nf, &msg), 0);
        assert_int_equal(msg.k, k);
        for (i = 0; i < s->n; ++i)
            assert_true((double)msg.xf[i] == json_real_value(json_array_get(xf, i)));
    }
    /* a restart on a non-finite measurement is refused naming the call */
    {
        double ybad[DKF_MAX_DIM];
        memcpy(ybad, dkf_scn_y(s, 0, 3), s->sensors[0].m * sizeof *ybad);
        ybad[0] = NAN;
        assert_int_equal(ops->start(nf, 3, ybad, err, sizeof err), DKF_EXIT_RUN);
        assert_non_null(strstr(err, "node 0: step k=3: dkf_diffkf_start failed"));
    }
    ops->destroy(nf);
    f->family->destroy(r);
    json_decref(doc);
    dkf_scenario_free(s);
}

static void test_rtsf_through_the_operations(void **state)
{
    dkf_scenario_t *s;
    const dkf_filter_t *f;
    dkf_runner_t *r;
    json_t *doc = run(DKF_VECTOR_DIR "/uif/s004_rtsf.json", "rtsf", &s, &f, &r);
    json_t *x = json_object_get(json_object_get(json_object_get(doc, "outputs"), "RTSF"), "x");
    (void)state;
    assert_int_equal(json_array_size(x), s->steps);
    assert_null(f->family->errors); /* one run per steps-layout file */
    f->family->destroy(r);
    json_decref(doc);
    dkf_scenario_free(s);
}

static void test_json_place(void **state)
{
    json_t *outs = json_object();
    (void)state;
    dkf_json_place(outs, "local[0]", json_integer(10));
    dkf_json_place(outs, "local[1]", json_integer(11));
    dkf_json_place(outs, "central", json_integer(2));
    assert_int_equal(json_array_size(json_object_get(outs, "local")), 2);
    assert_int_equal(json_integer_value(json_array_get(json_object_get(outs, "local"), 1)), 11);
    assert_int_equal(json_integer_value(json_object_get(outs, "central")), 2);
    assert_int_equal(json_object_size(outs), 2);
    json_decref(outs);
}

static void test_fnv1a(void **state)
{
    const double v = 1.5;
    (void)state;
    /* FNV-1a 64 of 8 zero bytes, of bytes 01..08, of the bytes of 1.5 (0x3ff8000000000000) */
    assert_true(dkf_fnv1a_u64(DKF_FNV1A_OFFSET, 0) == 0xa8c7f832281a39c5ull);
    assert_true(dkf_fnv1a_u64(DKF_FNV1A_OFFSET, 0x0102030405060708ull) == 0x7eb5108b368a78edull);
    assert_true(dkf_fnv1a_doubles(DKF_FNV1A_OFFSET, &v, 1) == 0xd2227d9462d46a12ull);
}

/* The wfusion family's node role (one sensor's local KF, what `dkf-node
 * --filter local_kf` runs) on the seed-002 vector: y_i(k) completes step k
 * (same_step), and every payload's xf is, bit for bit, the x_local that
 * dkf-run's local_kf records for that sensor (the registry's in-process
 * run of all sensors through dkf_wfusion_step); xp = Phi x_i(k-1|k-1). */
static void test_wfusion_node_role(void **state)
{
    dkf_scenario_t *s;
    const dkf_filter_t *f;
    dkf_runner_t *r;
    json_t *doc = run(DKF_VECTOR_DIR "/infofusion/s2_weighted_fusion.json", "local_kf", &s, &f, &r);
    const json_t *xl = json_object_get(json_object_get(json_object_get(doc, "outputs"),
                                                       "LOCAL_KF"),
                                       "x_local");
    const dkf_node_ops_t *ops = f->family->node;
    const dkf_scn_mat_t *F = dkf_scn_model(s, "F");
    char err[DKF_SCN_ERR_LEN];
    dkf_node_estimate_t msg;
    double prev[DKF_MAX_DIM];
    size_t id, k, i, j;
    (void)state;
    assert_non_null(ops);
    assert_int_equal(ops->same_step, 1);
    assert_int_equal(json_array_size(xl), s->steps);
    for (id = 0; id < s->nsensors; ++id) {
        dkf_node_filter_t *nf = ops->create(f, s, id, err, sizeof err);
        if (nf == NULL) fail_msg("%s", err);
        for (i = 0; i < s->n; ++i) prev[i] = dkf_scn_at(dkf_scn_init(s, "x00"), 0)[i];
        for (k = 1; k <= s->steps; ++k) {
            const json_t *x = json_array_get(json_array_get(xl, k - 1), id);
            const int rc = k == 1 ? ops->start(nf, 1, dkf_scn_y(s, id, 1), err, sizeof err)
                                  : ops->step(nf, (long)k, dkf_scn_y(s, id, (long)k), err,
                                              sizeof err);
            if (rc != DKF_EXIT_OK) fail_msg("%s", err);
            assert_int_equal(ops->payload(nf, &msg), 0);
            assert_int_equal(msg.k, k);
            assert_int_equal(msg.n, s->n);
            for (i = 0; i < s->n; ++i) {
                double xp = 0;
                assert_true((double)msg.xf[i] == json_real_value(json_array_get(x, i)));
                for (j = 0; j < s->n; ++j) xp += F->data[i * s->n + j] * prev[j];
                /* xp: F x(k-1|k-1) (in double here: to rounding) */
                assert_true(fabs((double)msg.xp[i] - xp) <= 1e-4 * (1 + fabs(xp)));
            }
            for (i = 0; i < s->n; ++i) prev[i] = (double)msg.xf[i];
        }
        ops->destroy(nf);
    }
    f->family->destroy(r);
    json_decref(doc);
    dkf_scenario_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_filter_found_once),
        cmocka_unit_test(test_every_family_complete),
        cmocka_unit_test(test_names_lists),
        cmocka_unit_test(test_family_options),
        cmocka_unit_test(test_kf_through_the_operations),
        cmocka_unit_test(test_rtsf_through_the_operations),
        cmocka_unit_test(test_dkf_node_role),
        cmocka_unit_test(test_wfusion_node_role),
        cmocka_unit_test(test_json_place),
        cmocka_unit_test(test_fnv1a),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
