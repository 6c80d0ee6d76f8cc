/*
 * Properties of the Talebi-Werner filters (dkf/tw.h) beyond the vectors:
 * Algorithm 2 on a complete graph is Algorithm 1; Algorithm 3 approaches
 * Algorithm 1 monotonically as the consensus iterations grow; the
 * node-level API over caller-owned neighbour buffers is bit-identical to
 * the whole-graph simulation; failures are atomic and specific; the
 * storage macros are exact.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "tw_fixture.h"

#define NODE_LEN DKF_TW_NODE_STORAGE_LEN(TW_N, TW_M, TW_P)

static tw_case_t C;
static dkf_tw_node_t nodes[TW_NMAX], nodes2[TW_NMAX];
static dkf_real_t storage[DKF_TW_NET_STORAGE_LEN(TW_NMAX, TW_N, TW_M, TW_P)];
static dkf_real_t storage2[DKF_TW_NET_STORAGE_LEN(TW_NMAX, TW_N, TW_M, TW_P)];
static dkf_tw_node_t central;
static dkf_real_t central_storage[NODE_LEN];
/* Algorithm 1's trajectory: x, P, z per step */
static double ref_x[TW_STEPS][TW_N], ref_P[TW_STEPS][TW_N * TW_N], ref_z[TW_STEPS][TW_P];

static void load(const char *file)
{
    json_t *root = test_load_vector(file);
    tw_load(&C, root);
    json_decref(root);
}

static void run_central(void)
{
    size_t k;
    tw_central_init(&C, &central, central_storage, NODE_LEN);
    for (k = 0; k < C.steps; ++k) {
        tw_central_step(&C, &central, k);
        test_to_double(ref_x[k], central.x.data, TW_N);
        test_to_double(ref_P[k], central.P.data, TW_N * TW_N);
        test_to_double(ref_z[k], central.d.data, TW_P);
    }
}

/* max over steps and nodes of the relative gap (x, z) to Algorithm 1. */
typedef struct {
    double x, z, P;
} gap_t;

static void gap_update(gap_t *gp, const dkf_tw_node_t *nd, size_t k)
{
    const double sx = fmax(1.0, test_max_abs(ref_x[k], TW_N));
    const double sz = fmax(1.0, test_max_abs(ref_z[k], TW_P));
    const double sP = fmax(1.0, test_max_abs(ref_P[k], TW_N * TW_N));
    gp->x = fmax(gp->x, test_max_abs_diff(nd->x.data, ref_x[k], TW_N) / sx);
    gp->z = fmax(gp->z, test_max_abs_diff(nd->d.data, ref_z[k], TW_P) / sz);
    gp->P = fmax(gp->P, test_max_abs_diff(nd->P.data, ref_P[k], TW_N * TW_N) / sP);
}

/* Runs Algorithm 2 (W == NULL, alpha) or 3 (W, eta) on graph g over all
 * steps of C and returns the gap to Algorithm 1. */
static gap_t run_net(const dkf_graph_t *g, const dkf_real_t *alpha, const dkf_real_t *W, size_t eta)
{
    static dkf_tw_net_t net;
    gap_t gp = {0.0, 0.0, 0.0};
    size_t k, l;
    assert_int_equal(dkf_tw_net_init(&net, g, nodes, TW_N, TW_M, TW_P, storage,
                                     DKF_TW_NET_STORAGE_LEN(g->N, TW_N, TW_M, TW_P), &C.mx0, &C.mP0),
                     DKF_OK);
    for (k = 0; k < C.steps; ++k) {
        tw_sensors_at(&C, k);
        if (W == NULL)
            assert_int_equal(dkf_tw_net_diffusion_step(&net, alpha, &C.model, C.sens, C.my), DKF_OK);
        else
            assert_int_equal(dkf_tw_net_consensus_step(&net, W, eta, &C.model, C.sens, C.my), DKF_OK);
        for (l = 0; l < g->N; ++l) gap_update(&gp, &nodes[l], k);
    }
    return gp;
}

/* Complete graph on C.N nodes, built directly as adjacency lists. */
static size_t kn_start[TW_NMAX + 1], kn_nbr[TW_NMAX * TW_NMAX];
static dkf_real_t kn_alpha[TW_NMAX * TW_NMAX];

static void complete_graph(dkf_graph_t *g, size_t N)
{
    size_t i, j;
    for (i = 0; i <= N; ++i) kn_start[i] = i * N;
    for (i = 0; i < N; ++i)
        for (j = 0; j < N; ++j) kn_nbr[i * N + j] = j;
    assert_int_equal(dkf_graph_init(g, N, kn_start, kn_nbr), DKF_OK);
}

/* Alg 2 on K_N: every node's Q_l and s_l are the network sums, in the
 * same order as the central sum (bit-identical), so psi_k = Alg 1's x for
 * every k and x_l = sum_k alpha_lk psi_k differs from it only by the
 * rounding of a weighted mean of N equal vectors: <= N eps relative per
 * step, and the filter contracts it (the loop gain (I - L Q) A is stable),
 * so a bound of 4 N eps over all steps holds with margin (measured
 * values printed). P and z are local and equal exactly. Non-uniform
 * row-stochastic alpha (Metropolis on K_N is 1/N as well, so a skewed
 * alpha is tested too) gives the same. */
static void test_tw_alg2_complete_graph_is_alg1(void **state)
{
    static const char *files[] = {"uif/s003_6node.json", "uif/s003_200node_alg1.json"};
    size_t f, i, e;
    (void)state;
    for (f = 0; f < 2; ++f) {
        dkf_graph_t g;
        gap_t gp;
        double tol;
        load(files[f]);
        run_central();
        complete_graph(&g, C.N);
        tol = 4.0 * (double)C.N * TEST_EPS;
        assert_int_equal(dkf_graph_weights_uniform(kn_alpha, &g), DKF_OK);
        gp = run_net(&g, kn_alpha, NULL, 0);
        print_message("%s, K_%zu, uniform alpha: max rel gap x %.2e z %.2e P %.2e (tol %.1e)\n",
                      files[f], C.N, gp.x, gp.z, gp.P, tol);
        assert_true(gp.x <= tol && gp.z <= tol && gp.P <= tol);
        /* skewed weights: alpha_l,l = 1/2, the rest shared */
        for (i = 0; i < C.N; ++i)
            for (e = kn_start[i]; e < kn_start[i + 1]; ++e)
                kn_alpha[e] = kn_nbr[e] == i ? DKF_R(0.5) : DKF_R(0.5) / (dkf_real_t)(C.N - 1);
        gp = run_net(&g, kn_alpha, NULL, 0);
        print_message("%s, K_%zu, skewed alpha: max rel gap x %.2e z %.2e P %.2e\n", files[f], C.N,
                      gp.x, gp.z, gp.P);
        assert_true(gp.x <= tol && gp.z <= tol && gp.P <= tol);
    }
}

/* Alg 3 -> Alg 1 as eta grows: W^eta -> 1 1^T / N at rate |lambda_2|^eta
 * (0.75 on the 6-node graph, 0.995 on the 200-node RGG), and with it
 * Upsilon_l -> Q, varphi_l -> s and the averaged estimates. The gap
 * (max over steps, nodes, relative) must decrease strictly along each
 * sweep until it reaches the rounding floor (1e3 eps), where it is only
 * required to stay below that floor. */
static void sweep(const char *file, const size_t *etas, size_t count, int library_W)
{
    double prev = HUGE_VAL;
    const double floor_ = 1e3 * TEST_EPS;
    size_t i;
    load(file);
    if (library_W) assert_int_equal(dkf_graph_weights_metropolis(C.W, &C.g), DKF_OK);
    run_central();
    print_message("%s: Alg 3 gap to Alg 1 vs eta (%zu steps, max over nodes and steps)\n", file,
                  C.steps);
    for (i = 0; i < count; ++i) {
        const gap_t gp = run_net(&C.g, NULL, C.W, etas[i]);
        print_message("  eta %5zu: x %.3e  z %.3e  P %.3e\n", etas[i], gp.x, gp.z, gp.P);
        if (prev > floor_)
            assert_true(gp.x < prev);
        else
            assert_true(gp.x <= floor_);
        prev = gp.x;
    }
}

static void test_tw_alg3_approaches_alg1(void **state)
{
    static const size_t small[] = {1, 2, 4, 8, 16, 32, 64, 128, 256};
    static const size_t big[] = {1, 3, 10, 30, 100, 300, 1000};
    (void)state;
    sweep("uif/s003_6node.json", small, sizeof small / sizeof small[0], 0);
    /* the 200-node file carries no weights: the library's Metropolis W
     * (equal to the alg23 file's, test_tw_graph) */
    sweep("uif/s003_200node_alg1.json", big, sizeof big / sizeof big[0], 1);
}

/* The node-level API over caller-owned neighbour buffers (what separate
 * node processes do) gives bit-for-bit the whole-graph simulation. */
static void test_tw_node_api_matches_simulation(void **state)
{
    static dkf_real_t pkt[TW_NMAX][TW_PKT], info[TW_NMAX][TW_PKT], est[TW_NMAX][TW_PKT];
    static dkf_real_t nxt[TW_NMAX][TW_PKT], xmix[TW_NMAX][TW_N];
    static dkf_tw_net_t net;
    const dkf_real_t *in[TW_NMAX];
    size_t alg, k, l, e, it;
    (void)state;
    load("uif/s003_6node.json");
    for (alg = 2; alg <= 3; ++alg) {
        assert_int_equal(dkf_tw_net_init(&net, &C.g, nodes, TW_N, TW_M, TW_P, storage,
                                         DKF_TW_NET_STORAGE_LEN(C.N, TW_N, TW_M, TW_P), &C.mx0,
                                         &C.mP0),
                         DKF_OK);
        for (l = 0; l < C.N; ++l)
            assert_int_equal(dkf_tw_node_init(&nodes2[l], TW_N, TW_M, TW_P, storage2 + l * NODE_LEN,
                                              NODE_LEN, &C.mx0, &C.mP0),
                             DKF_OK);
        for (k = 0; k < C.steps; ++k) {
            tw_sensors_at(&C, k);
            /* every node: its own info packet, the one it broadcasts */
            for (l = 0; l < C.N; ++l)
                assert_int_equal(dkf_tw_meas_packet(pkt[l], &nodes2[l], &C.sens[l], &C.my[l],
                                                    alg == 2 ? DKF_R(1.0) : (dkf_real_t)C.N),
                                 DKF_OK);
            if (alg == 2) {
                assert_int_equal(dkf_tw_net_diffusion_step(&net, C.alpha, &C.model, C.sens, C.my), DKF_OK);
                for (l = 0; l < C.N; ++l) { /* sum of the received packets */
                    for (e = C.start[l]; e < C.start[l + 1]; ++e) in[e - C.start[l]] = pkt[C.nbr[e]];
                    assert_int_equal(dkf_graph_mix(info[l], TW_PKT, in, NULL, C.start[l + 1] - C.start[l]),
                                     DKF_OK);
                }
                for (l = 0; l < C.N; ++l)
                    assert_int_equal(dkf_tw_node_local(&nodes2[l], &C.model, info[l], est[l]), DKF_OK);
                for (l = 0; l < C.N; ++l) { /* psi_k received from N_l */
                    for (e = C.start[l]; e < C.start[l + 1]; ++e) in[e - C.start[l]] = est[C.nbr[e]];
                    assert_int_equal(dkf_graph_mix(xmix[l], TW_N, in, C.alpha + C.start[l],
                                                   C.start[l + 1] - C.start[l]),
                                     DKF_OK);
                }
                for (l = 0; l < C.N; ++l)
                    assert_int_equal(dkf_tw_node_commit(&nodes2[l], xmix[l], NULL), DKF_OK);
            } else {
                assert_int_equal(dkf_tw_net_consensus_step(&net, C.W, C.eta, &C.model, C.sens, C.my), DKF_OK);
                for (it = 0; it < 2 * C.eta; ++it) {
                    if (it == C.eta) /* info consensus done: local steps */
                        for (l = 0; l < C.N; ++l) {
                            assert_int_equal(dkf_tw_node_local(&nodes2[l], &C.model, pkt[l], est[l]),
                                             DKF_OK);
                            memcpy(pkt[l], est[l], sizeof pkt[l]);
                        }
                    for (l = 0; l < C.N; ++l) {
                        for (e = C.start[l]; e < C.start[l + 1]; ++e) in[e - C.start[l]] = pkt[C.nbr[e]];
                        assert_int_equal(dkf_graph_mix(nxt[l], TW_PKT, in, C.W + C.start[l],
                                                       C.start[l + 1] - C.start[l]),
                                         DKF_OK);
                    }
                    memcpy(pkt, nxt, sizeof pkt);
                }
                for (l = 0; l < C.N; ++l)
                    assert_int_equal(dkf_tw_node_commit(&nodes2[l], pkt[l], pkt[l] + TW_N), DKF_OK);
            }
            for (l = 0; l < C.N; ++l) {
                assert_memory_equal(nodes2[l].x.data, nodes[l].x.data, TW_N * sizeof(dkf_real_t));
                assert_memory_equal(nodes2[l].P.data, nodes[l].P.data, TW_N * TW_N * sizeof(dkf_real_t));
                assert_memory_equal(nodes2[l].d.data, nodes[l].d.data, TW_P * sizeof(dkf_real_t));
                assert_int_equal(nodes2[l].k, k + 1);
            }
        }
    }
}

/* A copy of everything a step may change in the nodes' caller-visible
 * state: x, P, z, k and the views of the last step. */
typedef struct {
    dkf_real_t v[TW_NMAX][TW_N + 5 * TW_N * TW_N + TW_P * TW_P + TW_N * TW_P + 4 * TW_N + TW_P];
    size_t k[TW_NMAX];
} snap_t;

static void take(snap_t *s, const dkf_tw_node_t *nd, size_t N)
{
    size_t l;
    for (l = 0; l < N; ++l) {
        const dkf_mat_t *v[] = {&nd[l].x,   &nd[l].P,        &nd[l].d,        &nd[l].phi,
                                &nd[l].Phi, &nd[l].I,        &nd[l].i,        &nd[l].phi_post,
                                &nd[l].Phi_post, &nd[l].S,   &nd[l].Gpost,        &nd[l].psi,
                                &nd[l].Ploc};
        size_t i, used = 0;
        for (i = 0; i < sizeof v / sizeof v[0]; ++i) {
            memcpy(s->v[l] + used, v[i]->data, v[i]->rows * v[i]->cols * sizeof(dkf_real_t));
            used += v[i]->rows * v[i]->cols;
        }
        assert_int_equal(used, sizeof s->v[l] / sizeof(dkf_real_t));
        s->k[l] = nd[l].k;
    }
}

static void assert_unchanged(const snap_t *before, const dkf_tw_node_t *nd, size_t N)
{
    static snap_t now;
    take(&now, nd, N);
    assert_memory_equal(now.v, before->v, N * sizeof before->v[0]);
    assert_memory_equal(now.k, before->k, N * sizeof before->k[0]);
}

static void test_tw_failures_are_atomic(void **state)
{
    static dkf_tw_net_t net;
    static snap_t s;
    static dkf_real_t Hrank1[TW_NMAX][TW_N], Sbad[TW_M * TW_M];
    static dkf_mat_t mH1[TW_NMAX];
    static dkf_real_t neg[TW_NNZ];
    dkf_real_t pkt[TW_PKT], snap_pkt[TW_PKT], info[TW_PKT];
    size_t l, e;
    (void)state;
    load("uif/s003_6node.json");
    assert_int_equal(dkf_tw_net_init(&net, &C.g, nodes, TW_N, TW_M, TW_P, storage,
                                     DKF_TW_NET_STORAGE_LEN(C.N, TW_N, TW_M, TW_P), &C.mx0, &C.mP0),
                     DKF_OK);
    /* two good steps so the state is not the initial one */
    for (l = 0; l < 2; ++l) {
        tw_sensors_at(&C, l);
        assert_int_equal(dkf_tw_net_consensus_step(&net, C.W, C.eta, &C.model, C.sens, C.my), DKF_OK);
    }
    tw_sensors_at(&C, 2);
    take(&s, nodes, C.N);

    /* Alg 2: the neighbourhood of node 0 = {0, 1, 5} only measures x1
     * (H = [1 0 0 0]), so H_{N_0} G = [0.5 0] has rank 1 < p: S_0 is
     * singular. Other nodes are fine; no node may change. */
    for (l = 0; l < C.N; ++l) {
        memset(Hrank1[l], 0, sizeof Hrank1[l]);
        Hrank1[l][0] = DKF_R(1.0);
        mH1[l] = test_view(1, TW_N, Hrank1[l]);
    }
    {
        static dkf_mat_t Sw1[TW_NMAX], y1[TW_NMAX];
        static dkf_real_t sw1[TW_NMAX], yv[TW_NMAX];
        static dkf_kf_meas_t sens[TW_NMAX];
        static dkf_mat_t ys[TW_NMAX];
        for (l = 0; l < C.N; ++l) {
            sw1[l] = C.Sw[l][0];
            yv[l] = C.y[2][l][0];
            Sw1[l] = test_view(1, 1, &sw1[l]);
            y1[l] = test_view(1, 1, &yv[l]);
            sens[l] = C.sens[l];
            ys[l] = C.my[l];
            if (l == 0 || l == 1 || l == 5) sens[l].H = &mH1[l], sens[l].R = &Sw1[l], ys[l] = y1[l];
        }
        assert_int_equal(dkf_tw_net_diffusion_step(&net, C.alpha, &C.model, sens, ys), DKF_ERR_RANK);
        assert_unchanged(&s, nodes, C.N);
        /* Alg 1 on the same rank-1 data everywhere */
        for (l = 0; l < C.N; ++l) sens[l].H = &mH1[l], sens[l].R = &Sw1[l];
        assert_int_equal(dkf_tw_net_consensus_step(&net, C.W, C.eta, &C.model, sens, y1), DKF_ERR_RANK);
        assert_unchanged(&s, nodes, C.N);
        take(&s, &nodes[3], 1);
        assert_int_equal(dkf_tw_central_step(&nodes[3], &C.model, sens, y1, C.N), DKF_ERR_RANK);
        assert_unchanged(&s, &nodes[3], 1);
        take(&s, nodes, C.N);
    }

    /* a Sw that is not SPD at node 4; a NaN in node 2's y */
    Sbad[0] = DKF_R(1.0), Sbad[1] = DKF_R(2.0), Sbad[2] = DKF_R(2.0), Sbad[3] = DKF_R(1.0);
    {
        dkf_mat_t mS = test_view(TW_M, TW_M, Sbad);
        const dkf_mat_t *save = C.sens[4].R;
        C.sens[4].R = &mS;
        assert_int_equal(dkf_tw_net_consensus_step(&net, C.W, C.eta, &C.model, C.sens, C.my), DKF_ERR_NOT_SPD);
        assert_int_equal(dkf_tw_net_diffusion_step(&net, C.alpha, &C.model, C.sens, C.my), DKF_ERR_NOT_SPD);
        assert_unchanged(&s, nodes, C.N);
        /* the packet a failing call would have written stays as it was */
        test_fill(pkt, TW_PKT, DKF_R(-7.0));
        memcpy(snap_pkt, pkt, sizeof pkt);
        assert_int_equal(dkf_tw_meas_packet(pkt, &nodes[4], &C.sens[4], &C.my[4], DKF_R(1.0)), DKF_ERR_NOT_SPD);
        assert_memory_equal(pkt, snap_pkt, sizeof pkt);
        C.sens[4].R = save;
    }
    C.y[2][2][1] = (dkf_real_t)NAN;
    assert_int_equal(dkf_tw_net_consensus_step(&net, C.W, C.eta, &C.model, C.sens, C.my), DKF_ERR_NONFINITE);
    assert_unchanged(&s, nodes, C.N);
    C.y[2][2][1] = DKF_R(0.0);

    /* an eta above DKF_TW_MAX_ETA (e.g. read from a file) is refused before
     * any iteration, not run for hours */
    assert_int_equal(dkf_tw_net_consensus_step(&net, C.W, (size_t)DKF_TW_MAX_ETA + 1, &C.model,
                                               C.sens, C.my), DKF_ERR_ARG);
    assert_unchanged(&s, nodes, C.N);

    /* weights: uniform alpha is not doubly stochastic on this irregular
     * graph; a negative alpha with unit row sums */
    assert_int_equal(dkf_tw_net_consensus_step(&net, C.alpha, C.eta, &C.model, C.sens, C.my), DKF_ERR_WEIGHTS);
    memcpy(neg, C.alpha, sizeof neg);
    for (e = C.start[0]; e < C.start[1]; ++e)
        neg[e] = C.nbr[e] == 0 ? DKF_R(2.0) : DKF_R(-0.5);
    assert_int_equal(dkf_tw_net_diffusion_step(&net, neg, &C.model, C.sens, C.my), DKF_ERR_WEIGHTS);
    assert_unchanged(&s, nodes, C.N);

    /* node level: Psi = Phi-^{-1} + Q indefinite for a hostile info packet */
    take(&s, &nodes[1], 1);
    memset(info, 0, sizeof info);
    info[TW_N] = DKF_R(-1e6); /* packed Q(0, 0) */
    assert_int_equal(dkf_tw_node_local(&nodes[1], &C.model, info, NULL), DKF_ERR_NOT_SPD);
    assert_unchanged(&s, &nodes[1], 1);
    /* a failed local step cancels the pending one: commit is out of sequence */
    assert_int_equal(dkf_tw_node_commit(&nodes[1], NULL, NULL), DKF_ERR_STATE);
    /* a good local step, then a commit with a P that is not SPD, then NaN x */
    assert_int_equal(dkf_tw_meas_packet(info, &nodes[1], &C.sens[1], &C.my[1], DKF_R(1.0)), DKF_OK);
    assert_int_equal(dkf_tw_node_local(&nodes[1], &C.model, info, pkt), DKF_OK);
    memcpy(snap_pkt, pkt, sizeof pkt);
    snap_pkt[TW_N] = DKF_R(-1.0); /* P(0, 0) < 0 */
    assert_int_equal(dkf_tw_node_commit(&nodes[1], NULL, snap_pkt + TW_N), DKF_ERR_NOT_SPD);
    snap_pkt[0] = (dkf_real_t)NAN;
    assert_int_equal(dkf_tw_node_commit(&nodes[1], snap_pkt, NULL), DKF_ERR_NONFINITE);
    assert_unchanged(&s, &nodes[1], 1);
    /* the pending step survives a refused commit */
    assert_int_equal(dkf_tw_node_commit(&nodes[1], NULL, NULL), DKF_OK);
    assert_memory_equal(nodes[1].x.data, pkt, TW_N * sizeof(dkf_real_t));
    assert_int_equal(nodes[1].k, s.k[0] + 1);
}

/* The storage macros are exact: one real less is refused. p > n refused. */
static void test_tw_storage_macros_are_exact(void **state)
{
    static const size_t dims[][3] = {{4, 2, 2}, {1, 1, 1}, {6, 3, 5}, {5, 5, 1}}; /* n, p, m */
    static dkf_tw_net_t net;
    dkf_real_t x[6] = {0}, P[36] = {0};
    dkf_tw_node_t nd;
    size_t d, i;
    (void)state;
    for (d = 0; d < sizeof dims / sizeof dims[0]; ++d) {
        const size_t n = dims[d][0], p = dims[d][1], m = dims[d][2];
        const size_t len = DKF_TW_NODE_STORAGE_LEN(n, m, p);
        dkf_mat_t X = test_view(n, 1, x), P0 = test_view(n, n, P);
        memset(P, 0, sizeof P);
        for (i = 0; i < n; ++i) P[i * n + i] = 1;
        assert_true(len <= sizeof storage / sizeof storage[0]);
        assert_int_equal(dkf_tw_node_init(&nd, n, m, p, storage, len - 1, &X, &P0), DKF_ERR_CAPACITY);
        assert_int_equal(dkf_tw_node_init(&nd, n, m, p, storage, len, &X, &P0), DKF_OK);
    }
    {
        dkf_mat_t X = test_view(2, 1, x), P0 = test_view(2, 2, P);
        P[0] = P[3] = 1, P[1] = P[2] = 0;
        assert_int_equal(dkf_tw_node_init(&nd, 2, 2, 3, storage, DKF_TW_NODE_STORAGE_LEN(2, 2, 3), &X, &P0),
                         DKF_ERR_RANK);
        P[0] = -1;
        assert_int_equal(dkf_tw_node_init(&nd, 2, 2, 1, storage, DKF_TW_NODE_STORAGE_LEN(2, 2, 1), &X, &P0),
                         DKF_ERR_NOT_SPD);
    }
    load("uif/s003_200node_alg1.json");
    assert_int_equal(dkf_tw_net_init(&net, &C.g, nodes, TW_N, TW_M, TW_P, storage,
                                     DKF_TW_NET_STORAGE_LEN(C.N, TW_N, TW_M, TW_P) - 1, &C.mx0, &C.mP0),
                     DKF_ERR_CAPACITY);
    assert_int_equal(dkf_tw_net_init(&net, &C.g, nodes, TW_N, TW_M, TW_P, storage,
                                     DKF_TW_NET_STORAGE_LEN(C.N, TW_N, TW_M, TW_P), &C.mx0, &C.mP0),
                     DKF_OK);
    print_message("storage: %zu reals per node, %zu for the 200-node simulation (%zu bytes)\n",
                  (size_t)NODE_LEN, (size_t)DKF_TW_NET_STORAGE_LEN(C.N, TW_N, TW_M, TW_P),
                  (size_t)DKF_TW_NET_STORAGE_LEN(C.N, TW_N, TW_M, TW_P) * sizeof(dkf_real_t));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tw_alg2_complete_graph_is_alg1),
        cmocka_unit_test(test_tw_alg3_approaches_alg1),
        cmocka_unit_test(test_tw_node_api_matches_simulation),
        cmocka_unit_test(test_tw_failures_are_atomic),
        cmocka_unit_test(test_tw_storage_macros_are_exact),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
