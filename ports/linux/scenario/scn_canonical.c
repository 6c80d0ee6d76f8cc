/*
 * scn_canonical.c - the canonical layout (the diffkf golden-vector files):
 * top-level model (or model.sensors), init, y (or runs), truth, k, N
 * (docs/reference/scenario-format.md, "Canonical layout").
 */
#include "scn_parse.h"

#include <stdio.h>
#include <string.h>

/* The keys of each object of the layout (docs/reference/scenario-format.md,
 * "Canonical layout"); a key of another object is suggested where it fits. */
static const char *const top_keys[] = {"model", "init", "y", "runs", "truth", "k", "N", NULL};
static const char *const model_keys[] = {"F", "Q", "H", "R", "D", "B", "Rd", "sensors", NULL};
static const char *const sensor_keys[] = {"H", "R", "D", "B", "Rd", NULL};
static const char *const init_keys[] = {"x00", "P00", "P00_local", "P00_central", "d00", "Pd00",
                                        NULL};
static const char *const run_keys[] = {"y", "truth", NULL};
static const char *const init_paths[] = {"init.x00", "init.P00", "init.P00_local",
                                         "init.P00_central", "init.d00", "init.Pd00", NULL};
static const char *const model_paths[] = {"model.F", "model.Q", "model.H", "model.R", "model.D",
                                          "model.B", "model.Rd", "model.sensors", NULL};

static int parse_mat_object(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const json_t *obj,
                            const char *path,
                            const char *skip)
{
    const char *key;
    json_t *val;
    char p[DKF_SCN_PATH_LEN];
    json_object_foreach((json_t *)obj, key, val) {
        if (skip != NULL && strcmp(key, skip) == 0) continue;
        dkf_scn_subkey(p, path, key);
        if (dkf_scn_parse_model_entry(c, set, key, val, p) != 0) return -1;
    }
    return 0;
}

/* The number of steps N: key `N`, else the list `k` (= [1..N]), else the
 * last time every sensor has a measurement for. */
static int canonical_steps(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *root)
{
    const json_t *jn = json_object_get(root, "N"), *jk = json_object_get(root, "k");
    long N = -1;
    size_t i;
    char p[DKF_SCN_PATH_LEN];
    if (jn != NULL) {
        if (dkf_scn_get_integer(c, jn, "N", 1.0, (double)DKF_SCN_MAX_STEPS, &N) != 0) return -1;
    }
    if (jk != NULL) {
        size_t len;
        if (!json_is_array(jk) || json_array_size(jk) == 0)
            return dkf_scn_fail(c, "k", "expected the list [1, 2, ..., N], got %s",
                                dkf_scn_json_kind(jk));
        len = json_array_size(jk);
        if (len > DKF_SCN_MAX_STEPS)
            return dkf_scn_fail(c, "k", "%zu steps, more than the %lu allowed", len,
                                DKF_SCN_MAX_STEPS);
        if (N >= 0 && (size_t)N != len)
            return dkf_scn_fail(c, "k", "has %zu entries but N = %ld", len, N);
        for (i = 0; i < len; ++i) {
            long v;
            dkf_scn_subidx(p, "k", i);
            if (dkf_scn_get_integer(c, json_array_get(jk, i), p, 0.0, DKF_SCN_MAX_TIME, &v) != 0)
                return -1;
            if (v != (long)i + 1)
                return dkf_scn_fail(c, p, "expected %zu (k lists 1..N), got %ld", i + 1, v);
        }
        N = (long)len;
    }
    if (N < 0) {
        for (i = 0; i < s->nsensors; ++i) {
            const dkf_scn_sensor_t *se = &s->sensors[i];
            long last = se->yk[se->ny - 1];
            if (N < 0 || last < N) N = last;
        }
        if (N < 1) return dkf_scn_fail(c, "y", "no measurement at k >= 1");
        if (N > (long)DKF_SCN_MAX_STEPS)
            return dkf_scn_fail(c, "y",
                                "measurements up to k = %ld: more than the %lu steps allowed "
                                "(give N)", N, DKF_SCN_MAX_STEPS);
    }
    s->steps = (size_t)N;
    return 0;
}

/* A sensor's y series; its dimension comes from its H (checked again later). */
static int parse_sensor_y(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t i, const json_t *yj,
                          const char *path)
{
    dkf_scn_sensor_t *se = &s->sensors[i];
    const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, i, "H");
    const json_t *v0;
    size_t dim;
    if (H != NULL) {
        dim = H->rows;
    } else {
        /* Let dkf_scn_validate() report the missing H; size y by its first value. */
        v0 = json_is_object(yj) ? json_object_get(yj, "values") : NULL;
        v0 = v0 != NULL ? json_array_get(v0, 0) : NULL;
        dim = v0 != NULL && json_is_array(v0) ? json_array_size(v0) : 1;
    }
    se->m = dim;
    se->ny = 0;
    se->yk = NULL;
    se->y = NULL;
    se->borrowed = 0;
    return dkf_scn_parse_series(c, yj, path, "values", dim, &se->ny, &se->yk, &se->y);
}

/* Every sensor's y series from yj (one object, or a list with one per sensor). */
static int parse_y_all(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *yj, const char *path)
{
    size_t i;
    char p[DKF_SCN_PATH_LEN];
    if (!s->multi) return parse_sensor_y(c, s, 0, yj, path);
    if (!json_is_array(yj) || json_array_size(yj) != s->nsensors)
        return dkf_scn_fail(c, path, "expected a list of %zu measurement series (one per "
                            "model.sensors entry), got %s", s->nsensors,
                            json_is_array(yj) ? "a list of another length" : dkf_scn_json_kind(yj));
    for (i = 0; i < s->nsensors; ++i) {
        dkf_scn_subidx(p, path, i);
        if (parse_sensor_y(c, s, i, json_array_get(yj, i), p) != 0) return -1;
    }
    return 0;
}

int dkf_scn_load_canonical(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *root)
{
    const json_t *model = json_object_get(root, "model"), *init = json_object_get(root, "init");
    const json_t *sensors, *yj, *runs;
    const char *key;
    json_t *val;
    size_t i, r, nruns = 1;
    char p[DKF_SCN_PATH_LEN];

    if (dkf_scn_check_keys(c, root, "", top_keys, NULL) != 0) return -1;
    if (model == NULL) return dkf_scn_fail(c, "model", "missing key");
    if (!json_is_object(model))
        return dkf_scn_fail(c, "model", "expected an object, got %s", dkf_scn_json_kind(model));
    if (init == NULL) return dkf_scn_fail(c, "init", "missing key");
    if (!json_is_object(init))
        return dkf_scn_fail(c, "init", "expected an object, got %s", dkf_scn_json_kind(init));
    yj = json_object_get(root, "y");
    runs = json_object_get(root, "runs");
    if (runs != NULL) {
        if (yj != NULL)
            return dkf_scn_fail(c, "y", "not allowed together with runs (give runs[i].y)");
        if (json_object_get(root, "truth") != NULL)
            return dkf_scn_fail(c, "truth", "not allowed together with runs (give runs[i].truth)");
        if (dkf_scn_list_len(c, runs, "runs", "{\"y\": ..., \"truth\": ...} objects", "runs",
                             DKF_SCN_MAX_RUNS, &nruns) != 0)
            return -1;
        s->has_runs = 1;
    } else if (yj == NULL) {
        return dkf_scn_fail(c, "y", "missing key");
    }

    if (dkf_scn_check_keys(c, model, "model", model_keys, init_paths) != 0 ||
        dkf_scn_check_keys(c, init, "init", init_keys, model_paths) != 0)
        return -1;
    sensors = json_object_get(model, "sensors");
    if (parse_mat_object(c, &s->model, model, "model", "sensors") != 0) return -1;
    if (sensors != NULL) {
        if (dkf_scn_list_len(c, sensors, "model.sensors", "sensor objects", "sensors",
                             DKF_SCN_MAX_SENSORS, &s->nsensors) != 0)
            return -1;
        s->multi = 1;
    } else {
        s->nsensors = 1;
    }
    if ((s->sensors = dkf_scn_calloc(c, s->nsensors, sizeof *s->sensors)) == NULL) return -1;
    for (i = 0; s->multi && i < s->nsensors; ++i) {
        const json_t *sj = json_array_get(sensors, i);
        dkf_scn_subidx(p, "model.sensors", i);
        if (!json_is_object(sj))
            return dkf_scn_fail(c, p, "expected an object, got %s", dkf_scn_json_kind(sj));
        if (dkf_scn_check_keys(c, sj, p, sensor_keys, model_paths) != 0) return -1;
        if (parse_mat_object(c, &s->sensors[i].mats, sj, p, NULL) != 0) return -1;
    }

    json_object_foreach((json_t *)init, key, val) {
        dkf_scn_subkey(p, "init", key);
        if (dkf_scn_parse_init_entry(c, &s->init, key, val, p) != 0) return -1;
    }

    if (dkf_scn_alloc_runs(c, s, nruns) != 0) return -1;
    for (r = 0; r < nruns; ++r) {
        const json_t *rj = runs != NULL ? json_array_get(runs, r) : root;
        char py[DKF_SCN_PATH_LEN];
        if (runs != NULL) {
            dkf_scn_subidx(p, "runs", r);
            if (!json_is_object(rj))
                return dkf_scn_fail(c, p, "expected an object, got %s", dkf_scn_json_kind(rj));
            if (dkf_scn_check_keys(c, rj, p, run_keys, NULL) != 0) return -1;
            dkf_scn_subkey(py, p, "y");
            if ((yj = json_object_get(rj, "y")) == NULL) return dkf_scn_fail(c, py, "missing key");
        } else {
            dkf_scn_pathf(py, "y");
        }
        if (parse_y_all(c, s, yj, py) != 0) return -1;
        dkf_scn_adopt_y(s, r);
    }
    dkf_scn_select_run(s, 0);

    if (canonical_steps(c, s, root) != 0) return -1;
    /* n comes from F; validate first so truth is sized right. */
    if (dkf_scn_validate(c, s, "model", s->multi ? "model.sensors[%zu]" : "model") != 0) return -1;
    for (r = 0; r < nruns; ++r) {
        const json_t *rj = runs != NULL ? json_array_get(runs, r) : root;
        if (runs != NULL)
            dkf_scn_pathf(p, "runs[%zu].truth", r);
        else
            dkf_scn_pathf(p, "truth");
        if (dkf_scn_parse_run_truth(c, s, r, json_object_get(rj, "truth"), p) != 0) return -1;
    }
    dkf_scn_select_run(s, 0);
    return 0;
}
