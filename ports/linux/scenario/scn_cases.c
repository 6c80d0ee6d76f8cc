/*
 * scn_cases.c - the cases layout (the infofusion golden-vector file):
 * cases[c] with x0, P0, Q, H[j] (the vector's C[j]), R[j] and steps[]
 * carrying k, F, z[j] (docs/reference/scenario-format.md, "Cases layout").
 */
#include "scn_parse.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The keys of the layout's objects (`expected`, `held_out`: the vector's). */
static const char *const top_keys[] = {"cases", NULL};
static const char *const case_keys[] = {"x0", "P0", "Q", "H", "R", "steps", "truth", "held_out",
                                        NULL};
static const char *const step_keys[] = {"k", "F", "Q", "z", "expected", NULL};
/* steps[j].z: one vector per sensor, of H[i]'s rows. */
static const dkf_scn_case_steps_t measured = {"k", "z", step_keys, "sensor, as H",
                                              "the rows of H"};

static int select_case(dkf_scn_ctx_t *c, const json_t *cases, const char *sel, size_t *idx)
{
    size_t i, n = json_array_size(cases);
    char *end;
    unsigned long v;
    if (n == 0) return dkf_scn_fail(c, "cases", "expected a non-empty list of cases");
    if (sel == NULL) {
        *idx = 0;
        return 0;
    }
    for (i = 0; i < n; ++i) {
        const json_t *name = json_object_get(json_array_get(cases, i), "name");
        if (json_is_string(name) && strcmp(json_string_value(name), sel) == 0) {
            *idx = i;
            return 0;
        }
    }
    errno = 0;
    v = strtoul(sel, &end, 10);
    if (sel[0] >= '0' && sel[0] <= '9' && *end == '\0' && errno == 0) {
        if (v >= n)
            return dkf_scn_fail(c, "cases", "case index %lu out of range (file has %zu)", v, n);
        *idx = (size_t)v;
        return 0;
    }
    return dkf_scn_fail(c, "cases", "no case named '%s' (use a name or an index 0..%zu)", sel,
                        n - 1);
}

/* Model matrix `name` from every step (per_k: step k gives entry k-1, the
 * matrix that propagates k-1 -> k) or from the case itself. */
static int cases_model(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj, const json_t *steps,
                       const char *cpath, const char *name)
{
    const json_t *first = json_object_get(json_array_get(steps, 0), name);
    dkf_scn_mat_t *m;
    size_t j, N = json_array_size(steps);
    dkf_scn_block_t b;
    char p[DKF_SCN_PATH_LEN], sp[DKF_SCN_PATH_LEN];
    if (first == NULL) {
        const json_t *v = json_object_get(cj, name);
        dkf_scn_subkey(p, cpath, name);
        if (v == NULL)
            return dkf_scn_fail(c, p, "missing key (give it in the case or in every step)");
        if ((m = dkf_scn_mats_add(c, &s->model, name, p)) == NULL) return -1;
        if (dkf_scn_parse_matrix(c, v, p, &m->rows, &m->cols, &m->data) != 0) return -1;
        return dkf_scn_check_dims(c, m);
    }
    dkf_scn_pathf(p, "%s.steps[].%s", cpath, name);
    if ((m = dkf_scn_mats_add(c, &s->model, name, p)) == NULL) return -1;
    for (j = 0; j < N; ++j) {
        const json_t *v = json_object_get(json_array_get(steps, j), name);
        dkf_scn_pathf(sp, "%s.steps[%zu].%s", cpath, j, name);
        if (v == NULL)
            return dkf_scn_fail(c, sp, "missing key (step 0 has it, so every step needs it)");
        if (dkf_scn_stack_matrix(c, m, &b, j, N, v, sp) != 0) return -1;
    }
    m->count = N;
    return 0;
}

/* Sensor j's matrix from the case list `list` (C or R), renamed to `as`. */
static int cases_sensor_mat(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *list,
                            const char *lpath,
                            size_t j, const char *as)
{
    dkf_scn_mat_t *m;
    char p[DKF_SCN_PATH_LEN];
    dkf_scn_subidx(p, lpath, j);
    if ((m = dkf_scn_mats_add(c, &s->sensors[j].mats, as, p)) == NULL) return -1;
    if (dkf_scn_parse_matrix(c, json_array_get(list, j), p, &m->rows, &m->cols, &m->data) != 0)
        return -1;
    return dkf_scn_check_dims(c, m);
}

static int cases_init(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj, const char *cpath,
                      const char *key, const char *as)
{
    const json_t *v = json_object_get(cj, key);
    char p[DKF_SCN_PATH_LEN];
    dkf_scn_subkey(p, cpath, key);
    if (v == NULL) return dkf_scn_fail(c, p, "missing key");
    return dkf_scn_parse_init_entry(c, &s->init, as, v, p);
}

/* Every sensor's y series of N steps (sensor i's m set), blocks y[i]. */
static int cases_alloc_y(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t N, dkf_scn_block_t *y,
                         const char *cpath)
{
    size_t i;
    for (i = 0; i < s->nsensors; ++i) {
        dkf_scn_sensor_t *se = &s->sensors[i];
        se->ny = N;
        se->yk = dkf_scn_calloc(c, N, sizeof *se->yk);
        if (se->yk == NULL || dkf_scn_block_alloc(c, &y[i], N, se->m, cpath) != 0) return -1;
        se->y = y[i].v;
    }
    return 0;
}

/* steps[j] (of the case at cpath): an object of how's keys whose time key
 * is j + 1; its data key's value is returned (its key path in pd), NULL
 * after the message. */
static const json_t *cases_step(dkf_scn_ctx_t *c, const json_t *steps, size_t j,
                                const char *cpath, const dkf_scn_case_steps_t *how, char *pd)
{
    const json_t *st = json_array_get(steps, j), *d;
    char p[DKF_SCN_PATH_LEN];
    long k;
    dkf_scn_pathf(p, "%s.steps[%zu]", cpath, j);
    if (!json_is_object(st)) {
        dkf_scn_fail(c, p, "expected an object {%s, %s}, got %s", how->tkey, how->dkey,
                     dkf_scn_json_kind(st));
        return NULL;
    }
    if (dkf_scn_check_keys(c, st, p, how->known, NULL) != 0) return NULL;
    dkf_scn_subkey(pd, p, how->tkey);
    if (json_object_get(st, how->tkey) == NULL) {
        dkf_scn_fail(c, pd, "missing key");
        return NULL;
    }
    if (dkf_scn_get_integer(c, json_object_get(st, how->tkey), pd, 0.0, DKF_SCN_MAX_TIME, &k) !=
        0)
        return NULL;
    if (k != (long)j + 1) {
        dkf_scn_fail(c, pd, "expected %zu (steps list %s = 1..N), got %ld", j + 1, how->tkey, k);
        return NULL;
    }
    d = json_object_get(st, how->dkey);
    dkf_scn_subkey(pd, p, how->dkey);
    if (d == NULL) dkf_scn_fail(c, pd, "missing key");
    return d;
}

const json_t *dkf_scn_cases_steps(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj,
                                  const char *cpath)
{
    const json_t *steps = json_object_get(cj, "steps");
    char p[DKF_SCN_PATH_LEN];
    dkf_scn_subkey(p, cpath, "steps");
    if (dkf_scn_list_len(c, steps, p, "steps", "steps", DKF_SCN_MAX_STEPS, &s->steps) != 0)
        return NULL;
    return steps;
}

int dkf_scn_cases_measurements(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *steps,
                               const char *cpath, const dkf_scn_case_steps_t *how)
{
    size_t j, i, N = json_array_size(steps);
    char pd[DKF_SCN_PATH_LEN], pdi[DKF_SCN_PATH_LEN], len_of[DKF_SCN_PATH_LEN];
    dkf_scn_block_t *y = dkf_scn_calloc(c, s->nsensors, sizeof *y);
    int rc = -1;
    if (y == NULL) return -1;
    if (cases_alloc_y(c, s, N, y, cpath) != 0) goto done;
    for (j = 0; j < N; ++j) {
        const json_t *d = cases_step(c, steps, j, cpath, how, pd);
        if (d == NULL) goto done;
        if (how->per != NULL && (!json_is_array(d) || json_array_size(d) != s->nsensors)) {
            if (json_is_array(d))
                dkf_scn_fail(c, pd, "expected a list of %zu measurements (one per %s), got %zu",
                             s->nsensors, how->per, json_array_size(d));
            else
                dkf_scn_fail(c, pd, "expected a list of %zu measurements (one per %s), got %s",
                             s->nsensors, how->per, dkf_scn_json_kind(d));
            goto done;
        }
        for (i = 0; i < s->nsensors; ++i) {
            if (how->per != NULL) {
                dkf_scn_subidx(pdi, pd, i);
                dkf_scn_subidx(len_of, how->len_of, i);
            } else {
                dkf_scn_pathf(pdi, "%s", pd);
                dkf_scn_pathf(len_of, "%s", how->len_of);
            }
            if (dkf_scn_store_vector(c, how->per != NULL ? json_array_get(d, i) : d, pdi, &y[i], j,
                                     len_of) != 0)
                goto done;
            s->sensors[i].yk[j] = (long)j + 1;
        }
    }
    rc = 0;
done:
    free(y);
    return rc;
}

int dkf_scn_cases_truth(dkf_scn_ctx_t *c, const json_t *list, const char *path, size_t dim,
                        const char *len_of, long k0, size_t *count, long **kout, double **vout)
{
    size_t j, N;
    dkf_scn_block_t b = {NULL, 0, 0};
    char p[DKF_SCN_PATH_LEN];
    if (dkf_scn_list_len(c, list, path, "vectors", "entries", DKF_SCN_MAX_TIMES, &N) != 0)
        return -1;
    if ((*kout = dkf_scn_calloc(c, N, sizeof **kout)) == NULL) return -1;
    if (dkf_scn_block_alloc(c, &b, N, dim, path) != 0) return -1;
    *vout = b.v;
    for (j = 0; j < N; ++j) {
        const json_t *e = json_array_get(list, j);
        double one;
        dkf_scn_subidx(p, path, j);
        if (json_is_number(e) && dim == 1) {
            one = json_number_value(e);
            if (dkf_scn_store(c, p, &b, j, &one, 1) != 0) return -1;
        } else if (dkf_scn_store_vector(c, e, p, &b, j, len_of) != 0) {
            return -1;
        }
        (*kout)[j] = k0 + (long)j;
    }
    *count = N;
    return 0;
}

int dkf_scn_load_cases(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *root, const char *sel)
{
    const json_t *cases = json_object_get(root, "cases"), *cj, *steps, *C, *R, *name;
    size_t i;
    char cpath[DKF_SCN_PATH_LEN], p[DKF_SCN_PATH_LEN], pr[DKF_SCN_PATH_LEN];

    if (dkf_scn_check_keys(c, root, "", top_keys, NULL) != 0) return -1;
    if (!json_is_array(cases))
        return dkf_scn_fail(c, "cases", "expected a list, got %s", dkf_scn_json_kind(cases));
    if (select_case(c, cases, sel, &s->case_index) != 0) return -1;
    dkf_scn_subidx(cpath, "cases", s->case_index);
    cj = json_array_get(cases, s->case_index);
    if (!json_is_object(cj))
        return dkf_scn_fail(c, cpath, "expected an object, got %s", dkf_scn_json_kind(cj));
    name = json_object_get(cj, "name");
    s->case_name = dkf_scn_dupstr(json_is_string(name) ? json_string_value(name) : "");
    if (json_object_get(cj, "model") != NULL || json_object_get(cj, "node_models") != NULL)
        return dkf_scn_load_nlcases(c, s, cj, cpath);
    if (dkf_scn_is_wfcase(cj)) return dkf_scn_load_wfcases(c, s, cj, cpath);
    s->layout = DKF_SCN_LAYOUT_CASES;
    if (dkf_scn_check_keys(c, cj, cpath, case_keys, NULL) != 0) return -1;
    s->multi = 1;

    if ((steps = dkf_scn_cases_steps(c, s, cj, cpath)) == NULL) return -1;
    dkf_scn_subkey(p, cpath, "steps");
    if (!json_is_object(json_array_get(steps, 0)))
        return dkf_scn_fail(c, p, "expected a list of step objects");
    if (cases_model(c, s, cj, steps, cpath, "F") != 0) return -1;
    if (cases_model(c, s, cj, steps, cpath, "Q") != 0) return -1;

    C = json_object_get(cj, "H");
    R = json_object_get(cj, "R");
    dkf_scn_subkey(p, cpath, "H");
    dkf_scn_subkey(pr, cpath, "R");
    if (C == NULL) return dkf_scn_fail(c, p, "missing key");
    if (R == NULL) return dkf_scn_fail(c, pr, "missing key");
    if (dkf_scn_list_len(c, C, p, "sensor matrices", "sensors", DKF_SCN_MAX_SENSORS,
                         &s->nsensors) != 0)
        return -1;
    if (!json_is_array(R) || json_array_size(R) != s->nsensors)
        return dkf_scn_fail(c, pr, "expected a list of %zu matrices (one per H), got %s",
                            s->nsensors,
                            dkf_scn_json_kind(R));
    if ((s->sensors = dkf_scn_calloc(c, s->nsensors, sizeof *s->sensors)) == NULL) return -1;
    for (i = 0; i < s->nsensors; ++i) {
        if (cases_sensor_mat(c, s, C, p, i, "H") != 0) return -1;
        if (cases_sensor_mat(c, s, R, pr, i, "R") != 0) return -1;
    }
    if (cases_init(c, s, cj, cpath, "x0", "x00") != 0) return -1;
    if (cases_init(c, s, cj, cpath, "P0", "P00") != 0) return -1;
    for (i = 0; i < s->nsensors; ++i) s->sensors[i].m = dkf_scn_sensor_model(s, i, "H")->rows;
    if (dkf_scn_cases_measurements(c, s, steps, cpath, &measured) != 0) return -1;
    if (dkf_scn_alloc_runs(c, s, 1) != 0) return -1;
    dkf_scn_adopt_y(s, 0);
    dkf_scn_pathf(p, "%s.H[%%zu]", cpath);
    if (dkf_scn_validate(c, s, cpath, p) != 0) return -1;
    dkf_scn_subkey(p, cpath, "truth");
    if (dkf_scn_parse_run_truth(c, s, 0, json_object_get(cj, "truth"), p) != 0) return -1;
    dkf_scn_select_run(s, 0);
    return 0;
}
