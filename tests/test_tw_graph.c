/*
 * Graphs, weights and mixing (dkf/graph.h): the builders reproduce the
 * seed-003 vector files' neighbourhoods and weights, bad graphs and
 * weights are refused with specific statuses and untouched outputs, and
 * the ACF is the power W^eta of eq. (30) and the literal iteration (29).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "tw_fixture.h"

static tw_case_t C;

/* Library weights vs the file's (exact values rounded to the real type):
 * an off-diagonal 1/(1+d) is correctly rounded (<= eps/2 apart); the
 * diagonal 1 - sum of up to 15 others (max degree of the 200-node graph)
 * accumulates <= 16 roundings of size <= eps. 64 eps covers both. */
#define W_TOL (64.0 * TEST_EPS)

static void test_graph_builders_match_vectors(void **state)
{
    static dkf_real_t w[TW_NNZ];
    static size_t work[TW_NMAX];
    static const char *files[] = {"uif/s003_6node.json", "uif/s003_200node_alg23.json"};
    size_t f, e;
    (void)state;
    for (f = 0; f < 2; ++f) {
        json_t *root = test_load_vector(files[f]);
        double worst = 0.0;
        tw_load(&C, root); /* asserts from_edges == neighbours_incl_self */
        assert_int_equal(C.g.nnz, DKF_GRAPH_NNZ(C.N, C.E));
        assert_int_equal(dkf_graph_connected(&C.g, work), DKF_OK);
        /* the library's Metropolis and uniform weights are the file's */
        assert_int_equal(dkf_graph_weights_metropolis(w, &C.g), DKF_OK);
        for (e = 0; e < C.g.nnz; ++e) {
            const double d = fabs((double)w[e] - (double)C.W[e]);
            assert_true(d <= W_TOL);
            if (d > worst) worst = d;
        }
        assert_int_equal(dkf_graph_weights_uniform(w, &C.g), DKF_OK);
        for (e = 0; e < C.g.nnz; ++e) assert_true(fabs((double)w[e] - (double)C.alpha[e]) <= W_TOL);
        assert_int_equal(dkf_graph_check_doubly_stochastic(&C.g, C.W), DKF_OK);
        assert_int_equal(dkf_graph_check_row_stochastic(&C.g, C.alpha), DKF_OK);
        /* the graphs are irregular: uniform alpha is row- but not column-
         * stochastic, so consensus must refuse it */
        assert_int_equal(dkf_graph_check_doubly_stochastic(&C.g, C.alpha), DKF_ERR_WEIGHTS);
        assert_int_equal(dkf_graph_weights_max_degree(w, &C.g), DKF_OK);
        assert_int_equal(dkf_graph_check_doubly_stochastic(&C.g, w), DKF_OK);
        print_message("%s: N = %zu, E = %zu, Metropolis vs file max diff %.2e\n", files[f], C.N,
                      C.E, worst);
        json_decref(root);
    }
}

/* Untouched-output checks use sentinels in start/nbr. */
static void test_graph_from_edges_rejects(void **state)
{
    size_t start[5], nbr[16], snap_s[5], snap_n[16];
    dkf_graph_t g = {0, 0, NULL, NULL}, gsnap;
    static const size_t out_of_range[] = {0, 1, 1, 4};
    static const size_t loop[] = {0, 1, 2, 2};
    static const size_t dup[] = {0, 1, 1, 2, 1, 0};
    static const size_t ok[] = {0, 1, 1, 2, 2, 3};
    (void)state;
    memset(start, 0xA5, sizeof start);
    memset(nbr, 0xA5, sizeof nbr);
    memcpy(snap_s, start, sizeof start);
    memcpy(snap_n, nbr, sizeof nbr);
    gsnap = g;
    assert_int_equal(dkf_graph_from_edges(&g, start, nbr, 16, 4, out_of_range, 2), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_from_edges(&g, start, nbr, 16, 4, loop, 2), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_from_edges(&g, start, nbr, 16, 4, dup, 3), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_from_edges(&g, start, nbr, 9, 4, ok, 3), DKF_ERR_CAPACITY);
    assert_int_equal(dkf_graph_from_edges(&g, start, nbr, 16, 0, ok, 0), DKF_ERR_CAPACITY);
    assert_memory_equal(start, snap_s, sizeof start);
    assert_memory_equal(nbr, snap_n, sizeof nbr);
    assert_memory_equal(&g, &gsnap, sizeof g);
    /* exactly N + 2E entries are enough */
    assert_int_equal(dkf_graph_from_edges(&g, start, nbr, 10, 4, ok, 3), DKF_OK);
    assert_int_equal(g.nnz, 10);
    {
        static const size_t want_start[] = {0, 2, 5, 8, 10};
        static const size_t want_nbr[] = {0, 1, 0, 1, 2, 1, 2, 3, 2, 3};
        assert_memory_equal(start, want_start, sizeof want_start);
        assert_memory_equal(nbr, want_nbr, sizeof want_nbr);
    }
}

static void test_graph_init_rejects(void **state)
{
    /* path 0-1-2 as valid lists, then one defect at a time */
    static const size_t st[] = {0, 2, 5, 7};
    static const size_t good[] = {0, 1, 0, 1, 2, 1, 2};
    static const size_t st_asym[] = {0, 2, 5, 6};
    static const size_t asym[] = {0, 1, 0, 1, 2, 2}; /* 2 in N_1, 1 not in N_2 */
    static const size_t st_noself[] = {0, 1, 4, 6};
    static const size_t noself[] = {1, 0, 1, 2, 1, 2}; /* N_0 = {1} */
    static const size_t unsorted[] = {1, 0, 0, 1, 2, 1, 2};
    static const size_t range[] = {0, 1, 0, 1, 7, 1, 2};
    static const size_t st_bad0[] = {1, 2, 5, 7};
    static const size_t st_empty[] = {0, 0, 5, 7};
    static const size_t st2[] = {0, 1, 2}; /* two isolated nodes */
    static const size_t iso[] = {0, 1};
    size_t work[3];
    dkf_graph_t g, snap;
    (void)state;
    memset(&g, 0x5A, sizeof g);
    snap = g;
    assert_int_equal(dkf_graph_init(&g, 3, st_asym, asym), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_init(&g, 3, st_noself, noself), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_init(&g, 3, st, unsorted), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_init(&g, 3, st, range), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_init(&g, 3, st_bad0, good), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_init(&g, 3, st_empty, good), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_init(&g, 0, st, good), DKF_ERR_CAPACITY);
    assert_int_equal(dkf_graph_init(&g, 3, NULL, good), DKF_ERR_NULL);
    assert_memory_equal(&g, &snap, sizeof g);
    assert_int_equal(dkf_graph_init(&g, 3, st, good), DKF_OK);
    assert_int_equal(dkf_graph_connected(&g, work), DKF_OK);
    /* a graph that is valid but disconnected */
    assert_int_equal(dkf_graph_init(&g, 2, st2, iso), DKF_OK);
    assert_int_equal(dkf_graph_connected(&g, work), DKF_ERR_GRAPH);
    {
        size_t pos;
        assert_int_equal(dkf_graph_init(&g, 3, st, good), DKF_OK);
        assert_int_equal(dkf_graph_find(&pos, &g, 1, 2), DKF_OK);
        assert_int_equal(pos, 4);
        assert_int_equal(dkf_graph_find(&pos, &g, 0, 2), DKF_ERR_GRAPH);
        assert_int_equal(dkf_graph_find(&pos, &g, 3, 0), DKF_ERR_ARG);
    }
}

static void test_graph_weights_rejected(void **state)
{
    static const size_t st[] = {0, 2, 5, 7};
    static const size_t nb[] = {0, 1, 0, 1, 2, 1, 2};
    dkf_graph_t g;
    dkf_real_t w[7], bad[7], snap[7];
    const size_t ti[] = {0, 0, 2}, tj[] = {0, 2, 2};
    const size_t di[] = {0, 0}, dj[] = {1, 1};
    const dkf_real_t tv[] = {DKF_R(0.5), DKF_R(0.5), DKF_R(1.0)};
    (void)state;
    assert_int_equal(dkf_graph_init(&g, 3, st, nb), DKF_OK);
    assert_int_equal(dkf_graph_weights_metropolis(w, &g), DKF_OK);
    /* path degrees 1, 2, 1: w01 = w12 = 1/3, w00 = w22 = 2/3, w11 = 1/3 */
    assert_true(fabs((double)w[0] - 2.0 / 3.0) <= 4 * TEST_EPS);
    assert_true(fabs((double)w[3] - 1.0 / 3.0) <= 4 * TEST_EPS);
    assert_int_equal(dkf_graph_check_doubly_stochastic(&g, w), DKF_OK);
    /* a negative weight with correct sums */
    memcpy(bad, w, sizeof w);
    bad[0] += DKF_R(1.0), bad[1] -= DKF_R(1.0), bad[2] -= DKF_R(1.0), bad[3] += DKF_R(1.0);
    assert_int_equal(dkf_graph_check_row_stochastic(&g, bad), DKF_ERR_WEIGHTS);
    assert_int_equal(dkf_graph_check_doubly_stochastic(&g, bad), DKF_ERR_WEIGHTS);
    /* a row sum off by 1e-3 */
    memcpy(bad, w, sizeof w);
    bad[6] += DKF_R(1e-3);
    assert_int_equal(dkf_graph_check_row_stochastic(&g, bad), DKF_ERR_WEIGHTS);
    /* rows fine, a column not: move weight within row 1 */
    memcpy(bad, w, sizeof w);
    bad[2] += DKF_R(0.1), bad[4] -= DKF_R(0.1);
    assert_int_equal(dkf_graph_check_row_stochastic(&g, bad), DKF_OK);
    assert_int_equal(dkf_graph_check_doubly_stochastic(&g, bad), DKF_ERR_WEIGHTS);
    /* NaN */
    memcpy(bad, w, sizeof w);
    bad[3] = (dkf_real_t)NAN;
    assert_int_equal(dkf_graph_check_row_stochastic(&g, bad), DKF_ERR_NONFINITE);
    /* triplets: (0, 2) is not a link; a repeated entry; both leave w alone */
    memcpy(snap, w, sizeof w);
    assert_int_equal(dkf_graph_weights_from_triplets(w, &g, ti, tj, tv, 3), DKF_ERR_GRAPH);
    assert_int_equal(dkf_graph_weights_from_triplets(w, &g, di, dj, tv, 2), DKF_ERR_WEIGHTS);
    assert_memory_equal(w, snap, sizeof w);
}

static void test_graph_mix_and_acf(void **state)
{
    static dkf_real_t F[TW_NMAX * 3], work[TW_NMAX * 3], lit[TW_NMAX * 3], nxt[TW_NMAX * 3];
    double Wd[36], Wp[36], T[36], ref[18], avg[3] = {0, 0, 0};
    json_t *root = test_load_vector("uif/s003_6node.json");
    size_t i, j, e, it;
    const size_t eta = 10;
    test_rng_t r;
    (void)state;
    tw_load(&C, root);
    test_rng_seed(&r, 3003);
    for (i = 0; i < C.N * 3; ++i) F[i] = (dkf_real_t)test_rng_normal(&r);
    memcpy(lit, F, sizeof F);
    /* reference W^eta F in double from the dense W */
    memset(Wd, 0, sizeof Wd);
    for (i = 0; i < C.N; ++i)
        for (e = C.start[i]; e < C.start[i + 1]; ++e) Wd[i * 6 + C.nbr[e]] = (double)C.W[e];
    memcpy(Wp, Wd, sizeof Wd);
    for (it = 1; it < eta; ++it) {
        test_ref_mul(T, Wp, Wd, 6, 6, 6);
        memcpy(Wp, T, sizeof T);
    }
    {
        double Fd[18];
        test_to_double(Fd, F, 18);
        test_ref_mul(ref, Wp, Fd, 6, 6, 3);
        for (i = 0; i < 6; ++i)
            for (j = 0; j < 3; ++j) avg[j] += Fd[i * 3 + j] / 6.0;
    }
    assert_int_equal(dkf_graph_acf(F, 3, &C.g, C.W, eta, work), DKF_OK);
    /* (30): eta products of a doubly stochastic W, |entries| <= 1: a few
     * eps per iteration */
    test_assert_close("ACF vs W^eta", F, ref, 18, 16.0 * (double)eta * TEST_EPS);
    /* literal (29): F_i <- F_i + sum_{j in N_i \ i} w_ij (F_j - F_i) */
    for (it = 0; it < eta; ++it) {
        for (i = 0; i < C.N; ++i)
            for (j = 0; j < 3; ++j) {
                dkf_real_t v = lit[i * 3 + j];
                for (e = C.start[i]; e < C.start[i + 1]; ++e)
                    if (C.nbr[e] != i) v += C.W[e] * (lit[C.nbr[e] * 3 + j] - lit[i * 3 + j]);
                nxt[i * 3 + j] = v;
            }
        memcpy(lit, nxt, sizeof nxt);
    }
    test_to_double(ref, lit, 18);
    test_assert_close("ACF (29) vs (30)", F, ref, 18, 16.0 * (double)eta * TEST_EPS);
    /* Remark 1: many iterations reach the network average everywhere
     * (|lambda_2| = 0.75: 0.75^150 ~ 2e-19) */
    assert_int_equal(dkf_graph_acf(F, 3, &C.g, C.W, 150, work), DKF_OK);
    for (i = 0; i < C.N; ++i) test_assert_close("ACF limit", F + 3 * i, avg, 3, 64.0 * TEST_EPS);

    /* one node's mix over caller buffers = its row of the whole-graph mix */
    {
        const dkf_real_t *in[6];
        dkf_real_t out[3], all[18], snap[3];
        const size_t node = 4;
        for (e = C.start[node]; e < C.start[node + 1]; ++e) in[e - C.start[node]] = lit + 3 * C.nbr[e];
        assert_int_equal(dkf_graph_mix(out, 3, in, C.W + C.start[node], C.start[node + 1] - C.start[node]),
                         DKF_OK);
        assert_int_equal(dkf_graph_mix_all(all, lit, 3, 3, &C.g, C.W), DKF_OK);
        assert_memory_equal(out, all + 3 * node, sizeof out);
        /* aliasing and non-finite inputs are refused, out untouched */
        assert_int_equal(dkf_graph_mix(lit + 3 * C.nbr[C.start[node]], 3, in, C.W, 2), DKF_ERR_ALIAS);
        memcpy(snap, out, sizeof out);
        lit[3 * C.nbr[C.start[node]] + 1] = (dkf_real_t)NAN;
        assert_int_equal(dkf_graph_mix(out, 3, in, C.W + C.start[node], 2), DKF_ERR_NONFINITE);
        assert_memory_equal(out, snap, sizeof out);
        assert_int_equal(dkf_graph_mix_all(all, lit, 3, 3, &C.g, C.W), DKF_ERR_NONFINITE);
    }
    json_decref(root);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_graph_builders_match_vectors),
        cmocka_unit_test(test_graph_from_edges_rejects),
        cmocka_unit_test(test_graph_init_rejects),
        cmocka_unit_test(test_graph_weights_rejected),
        cmocka_unit_test(test_graph_mix_and_acf),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
