/*
 * Shared fixture of the Talebi-Werner tests (test_tw_*.c): loads a seed-003
 * vector file (tests/vectors/uif/s003_*.json) into library types. Include
 * after <cmocka.h>. Everything is static inline so each test uses what it
 * needs without unused-function warnings.
 */
#ifndef TW_FIXTURE_H
#define TW_FIXTURE_H

#include <math.h>
#include <string.h>

#include "dkf/graph.h"
#include "dkf/tw.h"
#include "dkf_test.h"

#define TW_NMAX 200                      /* nodes */
#define TW_EMAX 732                      /* undirected edges */
#define TW_NNZ DKF_GRAPH_NNZ(TW_NMAX, TW_EMAX)
#define TW_STEPS 30
#define TW_N 4 /* state */
#define TW_P 2 /* unknown input */
#define TW_M 2 /* measurement per node */
#define TW_PKT DKF_TW_PKT_LEN(TW_N)

typedef struct {
    size_t N, E, steps, eta;
    size_t edges[2 * TW_EMAX];
    size_t start[TW_NMAX + 1], nbr[TW_NNZ];
    dkf_graph_t g;
    dkf_real_t W[TW_NNZ], alpha[TW_NNZ]; /* from the file (zero if absent) */
    int has_weights;
    dkf_real_t A[TW_N * TW_N], B[TW_N * TW_P], Sv[TW_N * TW_N], x0[TW_N], P0[TW_N * TW_N];
    dkf_mat_t mA, mB, mSv, mx0, mP0;
    dkf_uif_dyn_t model;
    dkf_real_t H[TW_NMAX][TW_M * TW_N], Sw[TW_NMAX][TW_M * TW_M];
    dkf_real_t y[TW_STEPS][TW_NMAX][TW_M];
    dkf_mat_t mH[TW_NMAX], mSw[TW_NMAX], my[TW_NMAX];
    dkf_kf_meas_t sens[TW_NMAX]; /* node l's model; its y is my[l] */
    /* truth (plots/metrics only) */
    double xtrue[TW_STEPS][TW_N], zprev[TW_STEPS][TW_P];
    const json_t *steps_json;
} tw_case_t;

static inline void tw_flat_real(const json_t *node, dkf_real_t *out, size_t expect)
{
    static double tmp[TW_NNZ * 3];
    assert_int_equal(test_json_flatten(node, tmp, sizeof tmp / sizeof tmp[0]), expect);
    test_to_real(out, tmp, expect);
}

/* Scatters dense rows [N][N] or triplets [[i, j, v], ...] into w. */
static inline void tw_weights(tw_case_t *c, dkf_real_t *w, const json_t *dense, const json_t *sparse)
{
    static size_t ti[TW_NNZ], tj[TW_NNZ];
    static dkf_real_t tv[TW_NNZ];
    size_t cnt = 0, i, j;
    if (dense != NULL) {
        for (i = 0; i < c->N; ++i)
            for (j = 0; j < c->N; ++j) {
                const double v = json_number_value(json_array_get(json_array_get(dense, i), j));
                if (v == 0.0) continue;
                assert_true(cnt < TW_NNZ);
                ti[cnt] = i, tj[cnt] = j, tv[cnt] = (dkf_real_t)v, ++cnt;
            }
    } else {
        for (i = 0; i < json_array_size(sparse); ++i) {
            const json_t *t = json_array_get(sparse, i);
            assert_true(cnt < TW_NNZ);
            ti[cnt] = (size_t)json_integer_value(json_array_get(t, 0));
            tj[cnt] = (size_t)json_integer_value(json_array_get(t, 1));
            tv[cnt] = (dkf_real_t)json_number_value(json_array_get(t, 2));
            ++cnt;
        }
    }
    assert_int_equal(dkf_graph_weights_from_triplets(w, &c->g, ti, tj, tv, cnt), DKF_OK);
}

static inline void tw_load(tw_case_t *c, const json_t *root)
{
    const json_t *dims = test_json_get(root, "dims"), *graph = test_json_get(root, "graph");
    const json_t *edges = test_json_get(graph, "edges"), *model = test_json_get(root, "model");
    const json_t *steps = test_json_get(root, "steps"), *nis = test_json_get(graph, "neighbours_incl_self");
    size_t e, l, k, i;
    memset(c, 0, sizeof *c);
    c->N = test_json_size(dims, "N");
    c->steps = json_array_size(steps);
    c->eta = test_json_size(root, "eta");
    assert_true(c->N <= TW_NMAX && c->steps <= TW_STEPS);
    assert_int_equal(json_integer_value(test_json_get(dims, "n")), TW_N);
    assert_int_equal(json_integer_value(test_json_get(dims, "m")), TW_P); /* the file's m: inputs */
    assert_false(json_is_true(test_json_get(root, "time_varying")));
    c->E = json_array_size(edges);
    assert_true(c->E <= TW_EMAX);
    for (e = 0; e < c->E; ++e) {
        c->edges[2 * e] = (size_t)json_integer_value(json_array_get(json_array_get(edges, e), 0));
        c->edges[2 * e + 1] = (size_t)json_integer_value(json_array_get(json_array_get(edges, e), 1));
    }
    assert_int_equal(dkf_graph_from_edges(&c->g, c->start, c->nbr, TW_NNZ, c->N, c->edges, c->E),
                     DKF_OK);
    /* the file's neighbourhoods are the lists the library built */
    for (l = 0; l < c->N; ++l) {
        const json_t *row = json_array_get(nis, l);
        assert_int_equal(json_array_size(row), c->start[l + 1] - c->start[l]);
        for (i = 0; i < json_array_size(row); ++i)
            assert_int_equal(json_integer_value(json_array_get(row, i)), c->nbr[c->start[l] + i]);
    }
    if (json_object_get(root, "W_consensus") != NULL) {
        tw_weights(c, c->W, json_object_get(root, "W_consensus"), NULL);
        tw_weights(c, c->alpha, json_object_get(root, "alpha_diffusion"), NULL);
        c->has_weights = 1;
    } else if (json_object_get(root, "W_consensus_sparse") != NULL) {
        tw_weights(c, c->W, NULL, json_object_get(root, "W_consensus_sparse"));
        tw_weights(c, c->alpha, NULL, json_object_get(root, "alpha_diffusion_sparse"));
        c->has_weights = 1;
    }
    tw_flat_real(test_json_get(model, "F"), c->A, TW_N * TW_N);
    tw_flat_real(test_json_get(model, "G"), c->B, TW_N * TW_P);
    tw_flat_real(test_json_get(model, "Q"), c->Sv, TW_N * TW_N);
    tw_flat_real(test_json_get(test_json_get(root, "init"), "x0"), c->x0, TW_N);
    tw_flat_real(test_json_get(test_json_get(root, "init"), "P0"), c->P0, TW_N * TW_N);
    c->mA = test_view(TW_N, TW_N, c->A);
    c->mB = test_view(TW_N, TW_P, c->B);
    c->mSv = test_view(TW_N, TW_N, c->Sv);
    c->mx0 = test_view(TW_N, 1, c->x0);
    c->mP0 = test_view(TW_N, TW_N, c->P0);
    c->model.F = &c->mA;
    c->model.G = &c->mB;
    c->model.Q = &c->mSv;
    for (l = 0; l < c->N; ++l) {
        tw_flat_real(json_array_get(test_json_get(model, "H"), l), c->H[l], TW_M * TW_N);
        tw_flat_real(json_array_get(test_json_get(model, "R"), l), c->Sw[l], TW_M * TW_M);
        c->mH[l] = test_view(TW_M, TW_N, c->H[l]);
        c->mSw[l] = test_view(TW_M, TW_M, c->Sw[l]);
    }
    for (k = 0; k < c->steps; ++k) {
        const json_t *st = json_array_get(steps, k), *ys = test_json_get(test_json_get(st, "inputs"), "y");
        const json_t *truth = test_json_get(st, "truth");
        assert_int_equal(json_integer_value(test_json_get(st, "n")), k + 1);
        for (l = 0; l < c->N; ++l) tw_flat_real(json_array_get(ys, l), c->y[k][l], TW_M);
        assert_int_equal(test_json_flatten(test_json_get(truth, "x"), c->xtrue[k], TW_N), TW_N);
        assert_int_equal(test_json_flatten(test_json_get(truth, "z_prev"), c->zprev[k], TW_P), TW_P);
    }
    c->steps_json = steps;
}

/* Points the sensors at step k's measurements (k = 0 is time n = 1). */
static inline void tw_sensors_at(tw_case_t *c, size_t k)
{
    size_t l;
    for (l = 0; l < c->N; ++l) {
        c->my[l] = test_view(TW_M, 1, c->y[k][l]);
        c->sens[l].H = &c->mH[l];
        c->sens[l].R = &c->mSw[l];
    }
}

/* The centralized filter (Algorithm 1) in nd, on storage of len reals,
 * from c's prior. */
static inline void tw_central_init(const tw_case_t *c, dkf_tw_node_t *nd, dkf_real_t *storage,
                                   size_t len)
{
    assert_int_equal(dkf_tw_node_init(nd, TW_N, TW_M, TW_P, storage, len, &c->mx0, &c->mP0),
                     DKF_OK);
}

/* Step k of the centralized filter nd on every node's data of c. */
static inline void tw_central_step(tw_case_t *c, dkf_tw_node_t *nd, size_t k)
{
    tw_sensors_at(c, k);
    assert_int_equal(dkf_tw_central_step(nd, &c->model, c->sens, c->my, c->N), DKF_OK);
}

#endif /* TW_FIXTURE_H */
