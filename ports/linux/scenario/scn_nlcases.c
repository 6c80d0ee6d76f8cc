/*
 * scn_nlcases.c - the nonlinear cases layout (the seed-001 vector files
 * nertsif.json, dnertsif_single.json, df_dnertsif.json, and expression
 * scenarios written like them; docs/reference/scenario-format.md, "Nonlinear
 * cases"). One case:
 *
 *   single node:  model {family ... | expr ...; Q, R},
 *                 init {x0, Px0, d0, Pd0, Pxd0},
 *                 steps [{k, z: [m]}], optional x_true / d_true (x_k, d_k
 *                 for k = 1..N) or truth {X, omega} (k = 0..N)
 *   network:      node_models [N models], init_per_node [N inits],
 *                 W (N x N, or W_sparse triplets), optional edges (else
 *                 the links of W's nonzero entries), Tp, scale,
 *                 steps [{k, z: [N lists]}], optional truth
 *
 * The models are built here (nlm.h); p = 0 (d0 = []) is a model without
 * unknown input (DF-CKF). Steps must be k = 1..N in order. What runs on a
 * case is the registry's business (families/nerts_run.c reads this layout).
 */
#include "scn_parse.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nlm.h"

/* The keys of the layout's objects (`held_out`, `node_sensor_index_in_paper`,
 * the expected values and truth's noises: the vectors' own). */
static const char *const case_keys[] = {"model", "node_models", "init", "init_per_node", "W",
                                        "W_sparse", "edges", "Tp", "scale", "steps", "truth",
                                        "x_true", "d_true", "held_out",
                                        "node_sensor_index_in_paper", NULL};
static const char *const init_keys[] = {"x0", "Px0", "d0", "Pd0", "Pxd0", NULL};
static const char *const step_keys[] = {"k", "z", "expected", "expected_per_node", NULL};
static const char *const truth_keys[] = {"X", "omega", "W_process", "V_meas", NULL};
/* steps[j].z: the model's g values (single node) or one such list per node. */
static const dkf_scn_case_steps_t one_node = {"k", "z", step_keys, NULL, "the model's g"};
static const dkf_scn_case_steps_t per_node = {"k", "z", step_keys, "node, as node_models",
                                              "the g of node_models"};

/* v must be a list; 1 if it is an empty one (or a list of empty lists). */
static int is_empty_list(const json_t *v)
{
    size_t i;
    if (!json_is_array(v)) return 0;
    for (i = 0; i < json_array_size(v); ++i)
        if (!json_is_array(json_array_get(v, i)) || json_array_size(json_array_get(v, i)) != 0)
            return 0;
    return 1;
}

/* init[key] of node `node` into its mats as `as`, of shape r x cc (cc = 1:
 * a vector; cov: a covariance, symmetric); p = 0 entries must be empty lists
 * and are not stored. */
static int init_entry(dkf_scn_ctx_t *c, dkf_scn_mats_t *set, const json_t *init,
                      const char *ipath, const char *key, const char *as, size_t r, size_t cc,
                      int cov)
{
    const json_t *v = json_object_get(init, key);
    const dkf_scn_mat_t *m;
    char p[DKF_SCN_PATH_LEN];
    dkf_scn_subkey(p, ipath, key);
    if (v == NULL) return dkf_scn_fail(c, p, "missing key");
    if (r == 0 || cc == 0) {
        if (is_empty_list(v)) return 0;
        return dkf_scn_fail(c, p, "expected an empty list (d0 = [], no unknown input)");
    }
    if (dkf_scn_parse_init_entry(c, set, as, v, p) != 0) return -1;
    m = dkf_scn_mats_find(set, as);
    if (m == NULL || m->count != 0) return dkf_scn_fail(c, p, "expected a vector or a matrix");
    if (dkf_scn_require_shape(c, m, p, r, cc) != 0) return -1;
    if (!cov) return 0;
    return dkf_scn_check_symmetric(c, p, m->data, r) != 0 ||
                   dkf_scn_check_definite(c, p, m->data, r, 0,
                                          "an initial covariance must be symmetric PSD") != 0
               ? -1
               : 0;
}

/* Node i's init object: n from x0, p from d0 (the first node fixes them). */
static int node_init(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t i, const json_t *init,
                     const char *ipath)
{
    const json_t *x0 = json_object_get(init, "x0"), *d0 = json_object_get(init, "d0");
    char p[DKF_SCN_PATH_LEN];
    size_t n, pp, k;
    if (!json_is_object(init))
        return dkf_scn_fail(c, ipath, "expected {x0, Px0, d0, Pd0, Pxd0}, got %s",
                            dkf_scn_json_kind(init));
    if (dkf_scn_check_keys(c, init, ipath, init_keys, NULL) != 0) return -1;
    dkf_scn_subkey(p, ipath, "x0");
    if (!json_is_array(x0) || json_array_size(x0) == 0 || json_array_size(x0) > DKF_MAX_DIM)
        return dkf_scn_fail(c, p, "expected a list of 1..%d numbers (the initial state)",
                            DKF_MAX_DIM);
    dkf_scn_subkey(p, ipath, "d0");
    if (!json_is_array(d0) || json_array_size(d0) > DKF_MAX_DIM)
        return dkf_scn_fail(c, p, "expected a list of at most %d numbers (the initial input "
                            "estimate; [] for no unknown input)", DKF_MAX_DIM);
    n = json_array_size(x0);
    pp = json_array_size(d0);
    if (n + pp > DKF_MAX_DIM)
        return dkf_scn_fail(c, p, "%zu values beside x0's %zu: the core's filters agree on "
                            "[x; d], at most %d values", pp, n, DKF_MAX_DIM);
    if (i == 0) {
        s->n = n;
        s->nl->p = pp;
    } else if (n != s->n || pp != s->nl->p) {
        return dkf_scn_fail(c, ipath, "x0 of %zu and d0 of %zu values; node 0 has %zu and %zu "
                            "(n and p are common to every node; m, g and R may differ)",
                            n, pp, s->n, s->nl->p);
    }
    /* node 0's is also the file's init (dkf_scn_init, dkf_scn_P00_central:
     * the centralised filter's prior) */
    for (k = 0; k < (i == 0 ? 2u : 1u); ++k) {
        dkf_scn_mats_t *set = k == 0 ? &s->sensors[i].mats : &s->init;
        if (init_entry(c, set, init, ipath, "x0", "x00", n, 1, 0) != 0) return -1;
        if (init_entry(c, set, init, ipath, "Px0", "P00", n, n, 1) != 0) return -1;
        if (init_entry(c, set, init, ipath, "d0", "d00", pp, 1, 0) != 0) return -1;
        if (init_entry(c, set, init, ipath, "Pd0", "Pd00", pp, pp, 1) != 0) return -1;
        if (init_entry(c, set, init, ipath, "Pxd0", "Pxd00", pp == 0 ? 0 : n, pp, 0) != 0)
            return -1;
    }
    return 0;
}

static int node_model(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t i, const json_t *mj,
                      const char *mpath)
{
    const dkf_scn_mat_t *x0 = dkf_scn_mats_find(&s->sensors[i].mats, "x00");
    const dkf_scn_mat_t *d0 = dkf_scn_mats_find(&s->sensors[i].mats, "d00");
    dkf_nlm_t *m = dkf_nlm_load(mj, c->file, mpath, s->n, s->nl->p, x0->data,
                                d0 != NULL ? d0->data : NULL, c->err, c->errlen);
    if (m == NULL) return -1;
    s->nl->models[i] = m;
    s->sensors[i].m = m->m;
    return 0;
}

/* x_true / d_true (k = 1..N) or truth {X, omega} (k = 0..N); optional. */
static int nl_truth(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj, const char *cpath)
{
    const json_t *tr = json_object_get(cj, "truth"), *xt = json_object_get(cj, "x_true"),
                 *dt = json_object_get(cj, "d_true"), *dj = NULL;
    char p[DKF_SCN_PATH_LEN];
    long k0 = 1;
    if (tr != NULL && json_is_object(tr)) {
        dkf_scn_subkey(p, cpath, "truth");
        if (dkf_scn_check_keys(c, tr, p, truth_keys, NULL) != 0) return -1;
        xt = json_object_get(tr, "X");
        dj = json_object_get(tr, "omega");
        k0 = 0;
        dkf_scn_subkey(p, cpath, "truth.X");
    } else {
        dj = dt;
        dkf_scn_subkey(p, cpath, "x_true");
    }
    if (xt != NULL && dkf_scn_cases_truth(c, xt, p, s->n, "the length of x0", k0, &s->ntruth,
                                          &s->truth_k, &s->truth_x) != 0)
        return -1;
    if (dj != NULL && s->nl->p > 0) {
        dkf_scn_subkey(p, cpath, k0 == 0 ? "truth.omega" : "d_true");
        if (dkf_scn_cases_truth(c, dj, p, s->nl->p, "the length of d0", k0, &s->ntruth_u,
                                &s->truth_u_k, &s->truth_u) != 0)
            return -1;
        s->m_u = s->nl->p;
        snprintf(s->truth_u_key, sizeof s->truth_u_key, "%s", k0 == 0 ? "omega" : "d");
    }
    return 0;
}

/* W (dense N x N or W_sparse), optional edges, Tp, scale of a network case. */
static int consensus(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj, const char *cpath)
{
    dkf_scn_network_t *net;
    const json_t *edges = json_object_get(cj, "edges"), *tp = json_object_get(cj, "Tp"),
                 *sc = json_object_get(cj, "scale");
    char p[DKF_SCN_PATH_LEN];
    if ((net = s->net = dkf_scn_calloc(c, 1, sizeof *net)) == NULL) return -1;
    net->N = s->nsensors;
    net->eta = -1;
    if (edges != NULL) {
        dkf_scn_subkey(p, cpath, "edges");
        if (dkf_scn_parse_edges(c, net, edges, p, "node_models") != 0) return -1;
    }
    if (dkf_scn_parse_weights(c, net->N, cj, cpath, "W", &net->W_key, &net->nW, &net->W_rc,
                              &net->W_v) != 0)
        return -1;
    if (net->W_key == NULL) {
        dkf_scn_subkey(p, cpath, "W");
        return dkf_scn_fail(c, p, "missing key (the %zu x %zu consensus weights)", net->N,
                            net->N);
    }
    if (edges == NULL) {
        /* the graph of W: a link i - j for every W_ij != 0 with i < j (an
         * entry below the diagonal without its mirror is then off the graph,
         * which binding the weights refuses) */
        size_t t, e = 0;
        if ((net->edges = dkf_scn_calloc(c, 2 * net->nW, sizeof *net->edges)) == NULL) return -1;
        for (t = 0; t < net->nW; ++t) {
            if (net->W_rc[2 * t] >= net->W_rc[2 * t + 1]) continue;
            net->edges[2 * e] = net->W_rc[2 * t];
            net->edges[2 * e + 1] = net->W_rc[2 * t + 1];
            ++e;
        }
        net->E = e;
    }
    dkf_scn_subkey(p, cpath, "Tp");
    if (tp == NULL) return dkf_scn_fail(c, p, "missing key (consensus iterations per step)");
    if (dkf_scn_get_integer(c, tp, p, 1.0, (double)DKF_SCN_MAX_TP, &net->eta) != 0) return -1;
    s->nl->scale = 1.0;
    if (sc != NULL) {
        dkf_scn_subkey(p, cpath, "scale");
        if (!json_is_number(sc) || !isfinite(json_number_value(sc)) || json_number_value(sc) <= 0)
            return dkf_scn_fail(c, p, "expected a finite number > 0 (1: the paper's Algorithm 3, "
                                "N: the N-scaled variant)");
        s->nl->scale = json_number_value(sc);
        s->nl->has_scale = 1;
    }
    return 0;
}

int dkf_scn_load_nlcases(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *cj,
                         const char *cpath)
{
    const json_t *steps, *models, *inits;
    const int network = json_object_get(cj, "node_models") != NULL;
    char pm[DKF_SCN_PATH_LEN], pi[DKF_SCN_PATH_LEN];
    size_t i, N;

    s->layout = DKF_SCN_LAYOUT_NLCASES;
    if (dkf_scn_check_keys(c, cj, cpath, case_keys, NULL) != 0) return -1;
    if ((s->nl = dkf_scn_calloc(c, 1, sizeof *s->nl)) == NULL) return -1;
    s->nl->network = network;
    s->nl->scale = 1.0;
    s->multi = network;
    if (network && json_object_get(cj, "model") != NULL)
        return dkf_scn_fail(c, cpath, "both model and node_models: a case has one of them");
    models = json_object_get(cj, network ? "node_models" : "model");
    inits = json_object_get(cj, network ? "init_per_node" : "init");
    dkf_scn_subkey(pm, cpath, network ? "node_models" : "model");
    dkf_scn_subkey(pi, cpath, network ? "init_per_node" : "init");
    if (inits == NULL) return dkf_scn_fail(c, pi, "missing key");
    N = 1;
    if (network) {
        if (dkf_scn_list_len(c, models, pm, "node models", "nodes", DKF_SCN_MAX_SENSORS, &N) !=
            0)
            return -1;
        if (!json_is_array(inits) || json_array_size(inits) != N)
            return dkf_scn_fail(c, pi, "expected a list of %zu initial estimates (one per "
                                "node), got %s", N, dkf_scn_json_kind(inits));
    }
    s->nsensors = N;
    if ((s->sensors = dkf_scn_calloc(c, N, sizeof *s->sensors)) == NULL) return -1;
    if ((s->nl->models = dkf_scn_calloc(c, N, sizeof *s->nl->models)) == NULL) return -1;

    if ((steps = dkf_scn_cases_steps(c, s, cj, cpath)) == NULL) return -1;
    for (i = 0; i < N; ++i) {
        char ip[DKF_SCN_PATH_LEN], mp[DKF_SCN_PATH_LEN];
        if (network) {
            dkf_scn_subidx(ip, pi, i);
            dkf_scn_subidx(mp, pm, i);
        } else {
            dkf_scn_pathf(ip, "%s", pi);
            dkf_scn_pathf(mp, "%s", pm);
        }
        if (node_init(c, s, i, network ? json_array_get(inits, i) : inits, ip) != 0) return -1;
        if (node_model(c, s, i, network ? json_array_get(models, i) : models, mp) != 0)
            return -1;
    }
    if (network && consensus(c, s, cj, cpath) != 0) return -1;
    if (dkf_scn_cases_measurements(c, s, steps, cpath, network ? &per_node : &one_node) != 0)
        return -1;
    if (dkf_scn_alloc_runs(c, s, 1) != 0) return -1;
    dkf_scn_adopt_y(s, 0);
    if (nl_truth(c, s, cj, cpath) != 0) return -1;
    dkf_scn_adopt_truth(s, 0);
    dkf_scn_select_run(s, 0);
    return 0;
}
