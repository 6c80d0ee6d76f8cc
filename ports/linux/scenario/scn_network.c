/*
 * scn_network.c - the network form of the steps layout (seed-003 files):
 * graph.edges, the weights alpha_diffusion[_sparse] / W_consensus[_sparse]
 * and eta, checked for shape and index range (dkf/graph.h checks the rest
 * when a runner binds them).
 */
#include "scn_parse.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dkf/tw.h" /* DKF_TW_MAX_ETA: the bound on eta */

int dkf_scn_parse_weights(dkf_scn_ctx_t *c, size_t N, const json_t *obj, const char *base,
                          const char *key, const char **which, size_t *count, size_t **rc,
                          double **v)
{
    char skey[64], p[DKF_SCN_PATH_LEN], pk[DKF_SCN_PATH_LEN], psk[DKF_SCN_PATH_LEN];
    const json_t *dense = json_object_get(obj, key), *sparse;
    size_t i, j, n = 0;
    snprintf(skey, sizeof skey, "%s_sparse", key);
    sparse = json_object_get(obj, skey);
    dkf_scn_subkey(pk, base, key);
    dkf_scn_subkey(psk, base, skey);
    *which = NULL;
    *count = 0;
    if (dense == NULL && sparse == NULL) return 0;
    if (dense != NULL && sparse != NULL)
        return dkf_scn_fail(c, psk, "not allowed together with %s", key);
    if (dense != NULL) {
        double *M;
        size_t r, cc;
        if (dkf_scn_parse_matrix(c, dense, pk, &r, &cc, &M) != 0) return -1;
        if (r != N || cc != N) {
            free(M);
            return dkf_scn_shape_error(c, pk, N, N, r, cc);
        }
        for (i = 0; i < N * N; ++i) n += M[i] != 0.0;
        *rc = dkf_scn_calloc(c, 2 * n, sizeof **rc);
        *v = dkf_scn_calloc(c, n, sizeof **v);
        if (*rc == NULL || *v == NULL) {
            free(M);
            return -1;
        }
        n = 0;
        for (i = 0; i < N; ++i)
            for (j = 0; j < N; ++j)
                if (M[i * N + j] != 0.0) {
                    (*rc)[2 * n] = i;
                    (*rc)[2 * n + 1] = j;
                    (*v)[n++] = M[i * N + j];
                }
        free(M);
        *which = key;
        *count = n;
        return 0;
    }
    if (!json_is_array(sparse) || json_array_size(sparse) == 0)
        return dkf_scn_fail(c, psk, "expected a non-empty list of [i, j, value] triplets, got %s",
                            dkf_scn_json_kind(sparse));
    n = json_array_size(sparse);
    *rc = dkf_scn_calloc(c, 2 * n, sizeof **rc);
    *v = dkf_scn_calloc(c, n, sizeof **v);
    if (*rc == NULL || *v == NULL) return -1;
    for (i = 0; i < n; ++i) {
        const json_t *t = json_array_get(sparse, i);
        long a, b;
        dkf_scn_subidx(p, psk, i);
        if (!json_is_array(t) || json_array_size(t) != 3)
            return dkf_scn_fail(c, p, "expected a triplet [i, j, value], got %s",
                                dkf_scn_json_kind(t));
        if (dkf_scn_get_integer(c, json_array_get(t, 0), p, -DKF_SCN_MAX_TIME, DKF_SCN_MAX_TIME,
                                &a) != 0)
            return -1;
        if (dkf_scn_get_integer(c, json_array_get(t, 1), p, -DKF_SCN_MAX_TIME, DKF_SCN_MAX_TIME,
                                &b) != 0)
            return -1;
        if (a < 0 || b < 0 || (size_t)a >= N || (size_t)b >= N)
            return dkf_scn_fail(c, p, "node index out of range 0..%zu", N - 1);
        if (!json_is_number(json_array_get(t, 2)))
            return dkf_scn_fail(c, p, "expected a number as the value, got %s",
                                dkf_scn_json_kind(json_array_get(t, 2)));
        (*rc)[2 * i] = (size_t)a;
        (*rc)[2 * i + 1] = (size_t)b;
        (*v)[i] = json_number_value(json_array_get(t, 2));
    }
    *which = strcmp(key, "W_consensus") == 0       ? "W_consensus_sparse"
             : strcmp(key, "alpha_diffusion") == 0 ? "alpha_diffusion_sparse"
                                                   : "W_sparse";
    *count = n;
    return 0;
}

int dkf_scn_parse_edges(dkf_scn_ctx_t *c, dkf_scn_network_t *net, const json_t *edges,
                        const char *path, const char *who)
{
    const size_t N = net->N;
    size_t e;
    char p[DKF_SCN_PATH_LEN];
    if (!json_is_array(edges))
        return dkf_scn_fail(c, path, "expected a list of [i, j] pairs, got %s",
                            dkf_scn_json_kind(edges));
    net->E = json_array_size(edges);
    if (net->E > N * (N - 1) / 2)
        return dkf_scn_fail(c, path,
                            "%zu edges, more than a simple graph on %zu nodes has",
                            net->E, N);
    if ((net->edges = dkf_scn_calloc(c, 2 * net->E, sizeof *net->edges)) == NULL) return -1;
    for (e = 0; e < net->E; ++e) {
        const json_t *pr = json_array_get(edges, e);
        size_t i;
        dkf_scn_subidx(p, path, e);
        if (!json_is_array(pr) || json_array_size(pr) != 2)
            return dkf_scn_fail(c, p, "expected a pair [i, j], got %s", dkf_scn_json_kind(pr));
        for (i = 0; i < 2; ++i) {
            long v;
            if (dkf_scn_get_integer(c, json_array_get(pr, i), p, -DKF_SCN_MAX_TIME,
                                    DKF_SCN_MAX_TIME, &v)
                != 0)
                return -1;
            if (v < 0 || (size_t)v >= N)
                return dkf_scn_fail(c, p,
                                    "node index %ld out of range 0..%zu (%s has %zu nodes)", v,
                                    N - 1, who, N);
            net->edges[2 * e + i] = (size_t)v;
        }
    }
    return 0;
}

/* graph.edges, the weights, eta (seed 003). */
int dkf_scn_load_network(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *root)
{
    const json_t *graph = json_object_get(root, "graph"), *edges, *eta;
    dkf_scn_network_t *net;
    size_t N = s->nsensors;
    if ((net = s->net = dkf_scn_calloc(c, 1, sizeof *net)) == NULL) return -1;
    net->N = N;
    net->eta = -1;
    if (!json_is_object(graph))
        return dkf_scn_fail(c, "graph", "expected an object, got %s", dkf_scn_json_kind(graph));
    edges = json_object_get(graph, "edges");
    if (edges == NULL) return dkf_scn_fail(c, "graph.edges", "missing key");
    if (dkf_scn_parse_edges(c, net, edges, "graph.edges", "model.H") != 0) return -1;
    if (dkf_scn_parse_weights(c, N, root, "", "W_consensus", &net->W_key, &net->nW, &net->W_rc,
                              &net->W_v) != 0)
        return -1;
    if (dkf_scn_parse_weights(c, N, root, "", "alpha_diffusion", &net->alpha_key, &net->nalpha,
                              &net->alpha_rc, &net->alpha_v) != 0)
        return -1;
    eta = json_object_get(root, "eta");
    if (eta != NULL) {
        if (dkf_scn_get_integer(c, eta, "eta", 0.0, (double)DKF_TW_MAX_ETA, &net->eta) != 0)
            return -1;
    }
    return 0;
}
