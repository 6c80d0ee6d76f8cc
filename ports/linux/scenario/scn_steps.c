/*
 * scn_steps.c - the steps layout (the seed-003/004 golden-vector files read
 * as they are): steps[] with k or n, inputs (y and time-varying matrices),
 * truth. Without a `graph` key one sensor (model F, G, Q, H, D, R); with
 * one the network form (model F, G, Q; per-node H, R, y; the graph and
 * weights: scn_network.c). docs/reference/scenario-format.md, "Steps layout"; the
 * vectors' own letters are renamed before (scn_letters.c).
 */
#include "scn_parse.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define STEPS_MAX_KEYS 32

/* The keys of the layout's objects (`expected`: the vectors'). A matrix
 * given per step is <M> (at k) or <M>_prev (at k - 1). */
static const char *const top_keys[] = {"init", "model", "steps", "graph", "W_consensus",
                                       "W_consensus_sparse", "alpha_diffusion",
                                       "alpha_diffusion_sparse", "eta", NULL};
static const char *const init_keys[] = {"x0", "P0", NULL};
static const char *const model_keys[] = {"F", "G", "Q", "H", "D", "R", NULL};
static const char *const step_keys[] = {"k", "n", "inputs", "truth", "expected", NULL};
static const char *const input_keys[] = {"y", "F", "G", "Q", "H", "D", "R", "F_prev", "G_prev",
                                         "Q_prev", "H_prev", "D_prev", "R_prev", NULL};
static const char *const truth_keys[] = {"x", "d", "d_prev", "z_prev", NULL};
static const char *const graph_keys[] = {"edges", "neighbours_incl_self", NULL};

/* Step j's absolute time: key `k` (seed 004) or `n` (seed 003). */
static int steps_time(dkf_scn_ctx_t *c, const json_t *st, size_t j, long *k)
{
    const json_t *jk = json_object_get(st, "k");
    const char *key = "k";
    char p[DKF_SCN_PATH_LEN], pk[DKF_SCN_PATH_LEN];
    dkf_scn_subidx(p, "steps", j);
    if (!json_is_object(st))
        return dkf_scn_fail(c, p, "expected an object, got %s", dkf_scn_json_kind(st));
    if (jk == NULL) {
        jk = json_object_get(st, "n");
        key = "n";
    }
    if (jk == NULL) return dkf_scn_fail(c, p, "missing key k (or n): the step's time");
    if (dkf_scn_check_keys(c, st, p, step_keys, NULL) != 0) return -1;
    dkf_scn_subkey(pk, p, "truth");
    if (dkf_scn_check_keys(c, json_object_get(st, "truth"), pk, truth_keys, NULL) != 0) return -1;
    dkf_scn_subkey(pk, p, key);
    return dkf_scn_get_integer(c, jk, pk, 0.0, DKF_SCN_MAX_TIME, k);
}

/* `inputs` of step j: an object with at least y. */
static int steps_inputs_of(dkf_scn_ctx_t *c, const json_t *st, size_t j, const json_t **in)
{
    char p[DKF_SCN_PATH_LEN];
    dkf_scn_pathf(p, "steps[%zu].inputs", j);
    *in = json_object_get(st, "inputs");
    if (*in == NULL) return dkf_scn_fail(c, p, "missing key");
    if (!json_is_object(*in))
        return dkf_scn_fail(c, p, "expected an object, got %s", dkf_scn_json_kind(*in));
    return dkf_scn_check_keys(c, *in, p, input_keys, NULL);
}

/* Per-step matrix `key` of the inputs (`<M>` at k, `<M>_prev` at k - 1)
 * into model <M>, per_k from k0. Steps that need it: all, or k >= 1. */
static int steps_matrix(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *steps, const char *key)
{
    size_t len = strlen(key), N = json_array_size(steps), j, first = N;
    dkf_scn_block_t b;
    int prev = len > 5 && strcmp(key + len - 5, "_prev") == 0;
    char name[64], p[DKF_SCN_PATH_LEN];
    dkf_scn_mat_t *m;
    snprintf(name, sizeof name, "%.*s", (int)(prev ? len - 5 : len), key);
    for (j = 0; j < N; ++j) {
        const json_t *v = json_object_get(json_object_get(json_array_get(steps, j), "inputs"), key);
        const long k = s->k_first + (long)j;
        dkf_scn_pathf(p, "steps[%zu].inputs.%s", j, key);
        if (prev && k == 0) {
            if (v != NULL)
                return dkf_scn_fail(c, p, "no dynamics lead to k = 0 (the first step has none)");
            continue;
        }
        if (v == NULL)
            return dkf_scn_fail(c, p, "missing key (another step has it, so every step%s needs it)",
                                prev ? " with k >= 1" : "");
        if (dkf_scn_nest_depth(v) > 2)
            return dkf_scn_fail(c, p,
                                "expected a matrix, got a list of matrices (only seed-003 H and R "
                                "are per node)");
        if (first == N) first = j;
    }
    if (dkf_scn_mats_find(&s->model, name) != NULL) {
        dkf_scn_pathf(p, "steps[%zu].inputs.%s", first, key);
        return dkf_scn_fail(c, p, "also given as model.%s or as another step input (give one)",
                            name);
    }
    dkf_scn_pathf(p, "steps[%zu].inputs.%s", first, key);
    if ((m = dkf_scn_mats_add(c, &s->model, name, p)) == NULL) return -1;
    for (j = first; j < N; ++j) {
        dkf_scn_pathf(p, "steps[%zu].inputs.%s", j, key);
        if (dkf_scn_stack_matrix(c, m, &b, j - first, N - first,
                                 json_object_get(json_object_get(json_array_get(steps, j),
                                                                 "inputs"), key),
                                 p) != 0)
            return -1;
    }
    m->count = N - first;
    m->k0 = (size_t)(s->k_first + (long)first - (prev ? 1 : 0));
    return dkf_scn_check_dims(c, m);
}

/* Seed 003's per-node H or R given per step: steps[j].inputs.<key> is a
 * list of one matrix per node, node l's <key> at the step's time (a per_k
 * list of sensor l from k_first). Shapes may not change between steps. */
static int steps_node_series(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *steps,
                             const char *key)
{
    size_t N = json_array_size(steps), L = s->nsensors, j, l;
    dkf_scn_block_t *b;
    char p[DKF_SCN_PATH_LEN], pl[DKF_SCN_PATH_LEN];
    int rc = -1;
    for (l = 0; l < L; ++l)
        if (dkf_scn_mats_find(&s->sensors[l].mats, key) != NULL) {
            dkf_scn_pathf(p, "steps[0].inputs.%s", key);
            return dkf_scn_fail(c, p, "also given as model.%s (give one)", key);
        }
    if ((b = dkf_scn_calloc(c, L, sizeof *b)) == NULL) return -1;
    for (l = 0; l < L; ++l) {
        dkf_scn_mat_t *m;
        dkf_scn_pathf(pl, "steps[0].inputs.%s[%zu]", key, l);
        if ((m = dkf_scn_mats_add(c, &s->sensors[l].mats, key, pl)) == NULL) goto done;
        m->count = N;
        m->k0 = (size_t)s->k_first;
    }
    for (j = 0; j < N; ++j) {
        const json_t *v = json_object_get(json_object_get(json_array_get(steps, j), "inputs"), key);
        dkf_scn_pathf(p, "steps[%zu].inputs.%s", j, key);
        if (v == NULL) {
            dkf_scn_fail(c, p, "missing key (another step has it, so every step needs it)");
            goto done;
        }
        if (!json_is_array(v) || dkf_scn_nest_depth(v) != 3 || json_array_size(v) != L) {
            dkf_scn_fail(c, p, "expected a list of %zu matrices (one per node), got %s", L,
                         json_is_array(v) ? "a list of another shape" : dkf_scn_json_kind(v));
            goto done;
        }
        for (l = 0; l < L; ++l) {
            dkf_scn_mat_t *m = &s->sensors[l].mats.items[s->sensors[l].mats.len - 1];
            dkf_scn_subidx(pl, p, l);
            if (dkf_scn_stack_matrix(c, m, &b[l], j, N, json_array_get(v, l), pl) != 0) goto done;
            if (j == 0 && dkf_scn_check_dims(c, m) != 0) goto done;
        }
    }
    rc = 0;
done:
    free(b);
    return rc;
}

/* Every per-step matrix input (the union of the steps' input keys but y). */
static int steps_matrices(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *steps)
{
    const char *keys[STEPS_MAX_KEYS];
    size_t nkeys = 0, j, i;
    for (j = 0; j < json_array_size(steps); ++j) {
        const json_t *in = json_object_get(json_array_get(steps, j), "inputs");
        const char *key;
        json_t *val;
        json_object_foreach((json_t *)in, key, val) {
            if (strcmp(key, "y") == 0 || json_is_string(val) || json_is_null(val)) continue;
            for (i = 0; i < nkeys && strcmp(keys[i], key) != 0; ++i) continue;
            if (i < nkeys) continue;
            if (nkeys == STEPS_MAX_KEYS) {
                char p[DKF_SCN_PATH_LEN];
                dkf_scn_pathf(p, "steps[%zu].inputs.%s", j, key);
                return dkf_scn_fail(c, p, "more than %d different per-step inputs", STEPS_MAX_KEYS);
            }
            keys[nkeys++] = key;
        }
    }
    for (i = 0; i < nkeys; ++i) {
        const int node_key = s->layout == DKF_SCN_LAYOUT_NETWORK &&
                             (strcmp(keys[i], "H") == 0 || strcmp(keys[i], "R") == 0);
        if ((node_key ? steps_node_series(c, s, steps, keys[i])
                      : steps_matrix(c, s, steps, keys[i])) != 0)
            return -1;
    }
    return 0;
}

/* A list of N same-shape matrices (model.H / model.R of seed 003): sensor
 * l's matrix `name`. */
static int steps_node_matrices(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *model,
                               const char *name)
{
    const json_t *v = json_object_get(model, name);
    size_t l;
    char p[DKF_SCN_PATH_LEN], pl[DKF_SCN_PATH_LEN];
    dkf_scn_subkey(p, "model", name);
    if (v == NULL) return dkf_scn_fail(c, p, "missing key (a list of one matrix per node)");
    if (!json_is_array(v) || dkf_scn_nest_depth(v) != 3 || json_array_size(v) != s->nsensors)
        return dkf_scn_fail(c, p, "expected a list of %zu matrices (one per node of graph), got %s",
                            s->nsensors,
                            json_is_array(v) ? "a list of another shape" : dkf_scn_json_kind(v));
    for (l = 0; l < s->nsensors; ++l) {
        dkf_scn_mat_t *m;
        dkf_scn_subidx(pl, p, l);
        if ((m = dkf_scn_mats_add(c, &s->sensors[l].mats, name, pl)) == NULL) return -1;
        if (dkf_scn_parse_matrix(c, json_array_get(v, l), pl, &m->rows, &m->cols, &m->data) != 0)
            return -1;
        if (dkf_scn_check_dims(c, m) != 0) return -1;
    }
    return 0;
}

/* The constant model: bare matrices (or const/per_k objects); seed 003's
 * per-node H, R go to the sensors. */
static int steps_model(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *model)
{
    const char *key;
    json_t *val;
    char p[DKF_SCN_PATH_LEN];
    json_object_foreach((json_t *)model, key, val) {
        if (s->layout == DKF_SCN_LAYOUT_NETWORK && (strcmp(key, "H") == 0 || strcmp(key, "R") == 0))
            continue;
        dkf_scn_subkey(p, "model", key);
        if (json_is_array(val) && dkf_scn_nest_depth(val) > 2)
            return dkf_scn_fail(c, p, "expected a matrix, got a list of matrices");
        if (dkf_scn_parse_model_entry(c, &s->model, key, val, p) != 0) return -1;
    }
    if (s->layout == DKF_SCN_LAYOUT_NETWORK) {
        /* per node, in model or (time varying) in every step's inputs */
        if (json_object_get(model, "H") != NULL && steps_node_matrices(c, s, model, "H") != 0)
            return -1;
        if (json_object_get(model, "R") != NULL && steps_node_matrices(c, s, model, "R") != 0)
            return -1;
    }
    return 0;
}

/* The length of sensor i's y: the rows of its H if given, else what the first step's y has (steps_validate then reports
 * the missing matrix); every step's y is checked against it. */
static size_t steps_y_dim(const dkf_scenario_t *s, size_t i, const json_t *y0)
{
    const int tw = s->layout == DKF_SCN_LAYOUT_NETWORK;
    const dkf_scn_mat_t *H = dkf_scn_sensor_model(s, i, "H");
    const json_t *yi = tw ? json_array_get(y0, i) : y0;
    if (H != NULL) return H->rows;
    return json_is_array(yi) && json_array_size(yi) > 0 ? json_array_size(yi) : 1;
}

/* y of every step into the sensors' series (seed 004: one vector; seed
 * 003: a list with one vector per node). */
static int steps_measurements(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *steps)
{
    size_t N = json_array_size(steps), j, i;
    const int tw = s->layout == DKF_SCN_LAYOUT_NETWORK;
    const json_t *y0 = json_object_get(json_object_get(json_array_get(steps, 0), "inputs"), "y");
    char p[DKF_SCN_PATH_LEN], pi[DKF_SCN_PATH_LEN];
    dkf_scn_block_t *yb = dkf_scn_calloc(c, s->nsensors, sizeof *yb);
    int rc = -1;
    if (yb == NULL) return -1;
    for (i = 0; i < s->nsensors; ++i) {
        dkf_scn_sensor_t *se = &s->sensors[i];
        se->m = steps_y_dim(s, i, y0);
        se->ny = N;
        se->yk = dkf_scn_calloc(c, N, sizeof *se->yk);
        if (se->yk == NULL || dkf_scn_block_alloc(c, &yb[i], N, se->m, "steps") != 0) goto done;
        se->y = yb[i].v;
    }
    for (j = 0; j < N; ++j) {
        const json_t *y = json_object_get(json_object_get(json_array_get(steps, j), "inputs"), "y");
        dkf_scn_pathf(p, "steps[%zu].inputs.y", j);
        if (y == NULL) {
            dkf_scn_fail(c, p, "missing key");
            goto done;
        }
        if (tw && (!json_is_array(y) || json_array_size(y) != s->nsensors ||
                   dkf_scn_nest_depth(y) != 2)) {
            dkf_scn_fail(c, p, "expected a list of %zu measurement vectors (one per node), got %s",
                         s->nsensors,
                         json_is_array(y) ? "a list of another shape" : dkf_scn_json_kind(y));
            goto done;
        }
        for (i = 0; i < s->nsensors; ++i) {
            if (tw)
                dkf_scn_subidx(pi, p, i);
            else
                dkf_scn_pathf(pi, "%s", p);
            if (dkf_scn_store_vector(c, tw ? json_array_get(y, i) : y, pi, &yb[i], j,
                                     "the rows of H") != 0)
                goto done;
            s->sensors[i].yk[j] = s->k_first + (long)j;
        }
    }
    rc = 0;
done:
    free(yb);
    return rc;
}

/* truth.x (n) and the true input truth.d / d_prev / z_prev (m), all or none. */
static int steps_truth(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *steps, size_t m)
{
    static const char *const ukeys[] = {"d", "d_prev", "z_prev"};
    const json_t *t0 = json_object_get(json_array_get(steps, 0), "truth");
    size_t N = json_array_size(steps), j, i;
    const char *ukey = NULL;
    dkf_scn_block_t tb[2] = {{NULL, 0, 0}, {NULL, 0, 0}};
    char p[DKF_SCN_PATH_LEN];
    if (!json_is_object(t0)) return 0;
    for (i = 0; i < 3 && ukey == NULL; ++i)
        if (json_object_get(t0, ukeys[i]) != NULL) ukey = ukeys[i];
    if (json_object_get(t0, "x") != NULL) {
        s->truth_k = dkf_scn_calloc(c, N, sizeof *s->truth_k);
        if (s->truth_k == NULL || dkf_scn_block_alloc(c, &tb[0], N, s->n, "steps[0].truth.x") != 0)
            return -1;
        s->truth_x = tb[0].v;
        s->ntruth = N;
    }
    if (ukey != NULL) {
        snprintf(s->truth_u_key, sizeof s->truth_u_key, "%s", ukey);
        s->truth_u_k = dkf_scn_calloc(c, N, sizeof *s->truth_u_k);
        if (s->truth_u_k == NULL || dkf_scn_block_alloc(c, &tb[1], N, m, "steps[0].truth") != 0)
            return -1;
        s->truth_u = tb[1].v;
        s->ntruth_u = N;
        s->m_u = m;
    }
    for (j = 0; j < N; ++j) {
        const json_t *t = json_object_get(json_array_get(steps, j), "truth");
        for (i = 0; i < 2; ++i) {
            const char *key = i == 0 ? "x" : ukey;
            long *kd = i == 0 ? s->truth_k : s->truth_u_k;
            size_t len;
            double *v;
            int rc;
            if (tb[i].v == NULL) continue;
            dkf_scn_pathf(p, "steps[%zu].truth.%s", j, key);
            if (json_object_get(t, key) == NULL)
                return dkf_scn_fail(c, p, "missing key (steps[0] has it, so every step needs it)");
            if (dkf_scn_parse_vector(c, json_object_get(t, key), p, &len, &v) != 0) return -1;
            rc = dkf_scn_store(c, p, &tb[i], j, v, len);
            free(v);
            if (rc != 0) return -1;
            kd[j] = s->k_first + (long)j;
        }
    }
    return 0;
}

/* Model matrix `name` must exist with shape r x cc (0: any) and cover
 * absolute times k = from..to; returns it through out. */
static int steps_require(dkf_scn_ctx_t *c, const dkf_scenario_t *s, size_t sensor, const char *name,
                         size_t r, size_t cc, long from, long to, const dkf_scn_mat_t **out)
{
    const dkf_scn_mat_t *m = dkf_scn_sensor_model(s, sensor, name);
    char p[DKF_SCN_PATH_LEN];
    long k;
    dkf_scn_subkey(p, "model", name);
    if (m == NULL) return dkf_scn_fail(c, p, "missing key");
    if ((r != 0 && m->rows != r) || (cc != 0 && m->cols != cc))
        return dkf_scn_shape_error(c, m->path, r != 0 ? r : m->rows, cc != 0 ? cc : m->cols,
                                   m->rows,
                                   m->cols);
    for (k = from; k <= to; ++k)
        if (dkf_scn_at(m, (size_t)k) == NULL)
            return dkf_scn_fail(c, m->path, "no value for k = %ld (steps k = %ld..%ld need %s_%ld)",
                                k,
                                s->k_first, s->k_first + (long)s->steps - 1, name, k);
    if (m->rows > DKF_MAX_DIM || m->cols > DKF_MAX_DIM)
        return dkf_scn_fail(c, m->path, "dimension %zu exceeds DKF_MAX_DIM = %d",
                            m->rows > m->cols ? m->rows : m->cols, DKF_MAX_DIM);
    if (out != NULL) *out = m;
    return 0;
}

/* Shapes and time coverage of a steps-layout model; sets n. Dynamics are
 * needed at k - 1 for every step k >= 1, the measurement model at every k. */
static int steps_validate(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t *m_out)
{
    const long klast = s->k_first + (long)s->steps - 1, kd0 = s->k_first > 0 ? s->k_first - 1 : 0;
    const long kd1 = klast - 1;
    const dkf_scn_mat_t *F, *G, *H;
    size_t n, m, p, l;
    const int tw = s->layout == DKF_SCN_LAYOUT_NETWORK;
    if (steps_require(c, s, 0, "F", 0, 0, kd0, kd1, &F) != 0) return -1;
    if (F->rows != F->cols)
        return dkf_scn_fail(c, F->path, "expected a square matrix, got %zux%zu", F->rows, F->cols);
    n = s->n = F->rows;
    if (steps_require(c, s, 0, "G", n, 0, kd0, kd1, &G) != 0) return -1;
    m = *m_out = G->cols;
    if (steps_require(c, s, 0, "Q", n, n, kd0, kd1, NULL) != 0) return -1;
    if (!tw) {
        if (steps_require(c, s, 0, "H", 0, n, s->k_first, klast, &H) != 0) return -1;
        p = H->rows;
        if (steps_require(c, s, 0, "R", p, p, s->k_first, klast, NULL) != 0) return -1;
        if (dkf_scn_model(s, "D") != NULL &&
            steps_require(c, s, 0, "D", p, m, s->k_first, klast, NULL) != 0)
            return -1;
        if (s->sensors[0].m != p)
            return dkf_scn_fail(c, "steps[0].inputs.y",
                                "expected a vector of %zu values (the rows of H), "
                                "got %zu", p, s->sensors[0].m);
        return 0;
    }
    for (l = 0; l < s->nsensors; ++l) {
        const dkf_scn_mat_t *Hl = dkf_scn_sensor_model(s, l, "H"), *Rl;
        if (Hl == NULL)
            return dkf_scn_fail(c, "model.H", "missing key (seed-003 files give one H per node, in "
                                "model or in every step's inputs)");
        if (Hl->cols != n) return dkf_scn_shape_error(c, Hl->path, Hl->rows, n, Hl->rows, Hl->cols);
        if (Hl->rows > DKF_MAX_DIM)
            return dkf_scn_fail(c, Hl->path, "dimension %zu exceeds DKF_MAX_DIM = %d", Hl->rows,
                                DKF_MAX_DIM);
        Rl = dkf_scn_sensor_model(s, l, "R");
        if (Rl == NULL)
            return dkf_scn_fail(c, "model.R", "missing key (one R per node, in model or in every "
                                "step's inputs)");
        if (Rl->rows != Hl->rows || Rl->cols != Hl->rows)
            return dkf_scn_shape_error(c, Rl->path, Hl->rows, Hl->rows, Rl->rows, Rl->cols);
        if (s->sensors[l].m != Hl->rows) {
            char p2[DKF_SCN_PATH_LEN];
            dkf_scn_pathf(p2, "steps[0].inputs.y[%zu]", l);
            return dkf_scn_fail(c, p2, "expected a vector of %zu values (the rows of "
                                "model.H[%zu]), got %zu", Hl->rows, l, s->sensors[l].m);
        }
    }
    return 0;
}

int dkf_scn_load_steps(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *root)
{
    const json_t *steps = json_object_get(root, "steps"), *model = json_object_get(root, "model");
    const json_t *init = json_object_get(root, "init"), *in;
    size_t j, N, m = 0;
    long k;
    s->layout = DKF_SCN_LAYOUT_STEPS;
    if (dkf_scn_check_keys(c, root, "", top_keys, NULL) != 0 ||
        dkf_scn_check_keys(c, init, "init", init_keys, NULL) != 0 ||
        dkf_scn_check_keys(c, model, "model", model_keys, NULL) != 0 ||
        dkf_scn_check_keys(c, json_object_get(root, "graph"), "graph", graph_keys, NULL) != 0)
        return -1;
    if (dkf_scn_list_len(c, steps, "steps", "step objects", "steps", DKF_SCN_MAX_STEPS, &N) != 0)
        return -1;
    s->steps = N;
    for (j = 0; j < N; ++j) {
        char p[DKF_SCN_PATH_LEN];
        if (steps_time(c, json_array_get(steps, j), j, &k) != 0) return -1;
        if (steps_inputs_of(c, json_array_get(steps, j), j, &in) != 0) return -1;
        if (j == 0) {
            if (k != 0 && k != 1)
                return dkf_scn_fail(c, "steps[0]", "the first step's time must be 0 or 1, got %ld",
                                    k);
            s->k_first = k;
        } else if (k != s->k_first + (long)j) {
            dkf_scn_pathf(p, "steps[%zu]", j);
            return dkf_scn_fail(c, p, "time %ld, expected %ld (steps are consecutive)", k,
                                s->k_first + (long)j);
        }
    }
    /* a time-varying file may give every matrix per step: no model, or null */
    if (json_is_null(model)) model = NULL;
    if (model != NULL && !json_is_object(model))
        return dkf_scn_fail(c, "model", "expected an object, got %s", dkf_scn_json_kind(model));
    if (init == NULL) return dkf_scn_fail(c, "init", "missing key");
    if (!json_is_object(init))
        return dkf_scn_fail(c, "init", "expected an object, got %s", dkf_scn_json_kind(init));
    if (json_object_get(root, "graph") != NULL) {
        const json_t *H = json_object_get(model, "H");
        const char *hkey = "model.H";
        s->layout = DKF_SCN_LAYOUT_NETWORK;
        s->multi = 1;
        if (H == NULL) {
            H = json_object_get(json_object_get(json_array_get(steps, 0), "inputs"), "H");
            hkey = "steps[0].inputs.H";
        }
        if (H == NULL)
            return dkf_scn_fail(c, "model.H", "missing key (seed-003 files give one H per node, in "
                                "model or in every step's inputs)");
        if (!json_is_array(H) || json_array_size(H) == 0)
            return dkf_scn_fail(c, hkey, "expected a list of matrices (one per node)");
        s->nsensors = json_array_size(H);
        if (s->nsensors > DKF_SCN_MAX_SENSORS)
            return dkf_scn_fail(c, hkey, "%zu nodes, more than the %lu allowed", s->nsensors,
                                DKF_SCN_MAX_SENSORS);
    } else {
        s->nsensors = 1;
    }
    if ((s->sensors = dkf_scn_calloc(c, s->nsensors, sizeof *s->sensors)) == NULL) return -1;
    if (steps_model(c, s, model) != 0) return -1;
    if (steps_matrices(c, s, steps) != 0) return -1;
    {
        const char *key;
        json_t *val;
        char p[DKF_SCN_PATH_LEN];
        json_object_foreach((json_t *)init, key, val) {
            const char *as = strcmp(key, "x0") == 0 ? "x00" : strcmp(key, "P0") == 0 ? "P00" : key;
            dkf_scn_subkey(p, "init", key);
            if (dkf_scn_parse_init_entry(c, &s->init, as, val, p) != 0) return -1;
        }
    }
    if (steps_measurements(c, s, steps) != 0) return -1;
    if (steps_validate(c, s, &m) != 0) return -1;
    if (dkf_scn_require_shape(c, dkf_scn_init(s, "x00"), "init.x0", s->n, 1) != 0) return -1;
    if (dkf_scn_require_shape(c, dkf_scn_init(s, "P00"), "init.P0", s->n, s->n) != 0) return -1;
    if (dkf_scn_require_single(c, dkf_scn_init(s, "P00"), "init.P0", s->n) != 0) return -1;
    if (dkf_scn_check_covariances(c, s) != 0) return -1;
    if (s->layout == DKF_SCN_LAYOUT_NETWORK && dkf_scn_load_network(c, s, root) != 0) return -1;
    if (dkf_scn_alloc_runs(c, s, 1) != 0) return -1;
    dkf_scn_adopt_y(s, 0);
    if (steps_truth(c, s, steps, m) != 0) return -1;
    dkf_scn_adopt_truth(s, 0);
    dkf_scn_select_run(s, 0);
    return 0;
}
