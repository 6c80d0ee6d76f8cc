/*
 * Properties of DF-DNERTSIF (dkf/dfnerts.h) that hold exactly:
 *  - with W = 1 1^T / N (Metropolis weights of the complete graph),
 *    T_p = 2 and s = N, a p = 0 network (DF-CKF form) equals the
 *    centralised linear information filter (dkf/info.h) on all sensors,
 *    and a JOINT network with an unknown input equals the centralised
 *    NERTSF on the stacked sensors (dkf_nerts_stack), at every node;
 *  - the JOINT commit is the hand-computed joint information P_X = Y_X^-1;
 *  - Algorithm 3's mixed joint covariance [[Px(consensus), Pxd], [Pdx,
 *    Pd]] made indefinite by a node whose input channel depends strongly
 *    on x (note section 4 item 6): the step fails with DKF_ERR_NOT_SPD and
 *    every node is left as it was (the node that committed before the
 *    failing one too); the JOINT variant runs the same data;
 *  - nodes with different sensors (m_l = 2, 2, 1, 1): the JOINT network
 *    still equals the centralised NERTSF on the stacked sensors;
 *  - out-of-order calls, bad arguments and bad input (a model, R or z of
 *    another node's size): specific statuses, nodes bit-identical.
 * Models are linear (tests/nerts_fixture.h's lin_x_sin_d without the
 * sine): the cubature kinds are exact on them, so the comparisons have no
 * linearisation error.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "dkf/dfnerts.h"
#include "dkf/info.h"
#include "dkf_test.h"
#include "dfnerts_fixture.h"
#include "nerts_fixture.h"

/* Equalities: the two sides are different algebra over the same numbers
 * (consensus sums of information vs one stacked update), so they agree to
 * rounding times the conditioning of Y (cond <= 1e4 here): 1e-9 in double
 * (the vectors' tolerance; measured 1.4e-13, printed), 1e-3 in float (rounding
 * 6e-8 times cond 1e4 = 6e-4; measured 5.0e-5, printed). */
#if DKF_USE_FLOAT
#define EQ_REL 1e-3
#else
#define EQ_REL 1e-9
#endif

#define NN 4 /* nodes */
#define XN 2
#define ZM 2
#define DP 1
#define STEPS 25
#define NODE_LEN DKF_DFNERTS_NODE_STORAGE_LEN(XN, ZM, DP)
#define NODE_LEN0 DKF_DFNERTS_NODE_STORAGE_LEN(XN, ZM, 0)
#define STATE_LEN DKF_DFNERTS_NODE_STATE_LEN(XN, ZM, DP)

typedef struct {
    size_t N, p;
    size_t m[NN]; /* node l measures m[l] <= ZM values: its first rows of dfn_H[l], dfn_D[l] */
    lxs_t ctx[NN];
    dkf_nl_model_t md[NN];
    dkf_real_t Q[XN * XN], R[NN][ZM * ZM], z[NN][ZM];
    dkf_mat_t mQ[NN], mR[NN], mz[NN];
    dkf_real_t x0[XN], P0[XN * XN], d0[DP], Pd0[DP * DP], Pxd0[XN * DP];
    dkf_mat_t mx0[NN], mP0[NN], md0[NN], mPd0[NN], mPxd0[NN];
    size_t start[NN + 1], nbr[DKF_GRAPH_NNZ(NN, 6)];
    dkf_graph_t g;
    dkf_real_t W[DKF_GRAPH_NNZ(NN, 6)];
} scen_t;

static scen_t S;
static dkf_dfnerts_node_t nodes[NN];
static dkf_real_t storage[DKF_DFNERTS_NET_STORAGE_LEN(NN, XN, ZM, DP)];
static dkf_dfnerts_net_t net;

/* A scenario of N nodes on the complete graph (ring = 0) or a ring, with
 * input dimension p (0 or 1), the prior x0 = 0, P0 = I, d0 = 0, Pd0 = 1;
 * every node measures ZM values, or (mixed) nodes 2 and 3 only their
 * first channel (which sees d: rank Hd = p holds). */
static void scen_make_sensors(size_t N, size_t p, int ring, int mixed)
{
    size_t edges[2 * 6] = {0}, E = 0, i, j, l, r;
    memset(&S, 0, sizeof S);
    S.N = N;
    S.p = p;
    for (i = 0; i < N; ++i)
        for (j = i + 1; j < N; ++j)
            if (!ring || j == i + 1 || (i == 0 && j == N - 1)) {
                edges[2 * E] = i;
                edges[2 * E + 1] = j;
                ++E;
            }
    assert_int_equal(dkf_graph_from_edges(&S.g, S.start, S.nbr, DKF_GRAPH_NNZ(NN, 6), N, edges, E),
                     DKF_OK);
    assert_int_equal(dkf_graph_weights_metropolis(S.W, &S.g), DKF_OK);
    test_to_real(S.Q, dfn_Q, XN * XN);
    S.P0[0] = S.P0[3] = DKF_R(1.0);
    S.Pd0[0] = DKF_R(1.0);
    for (l = 0; l < N; ++l) {
        lxs_t *c = &S.ctx[l];
        S.m[l] = mixed && l >= 2 ? 1 : ZM;
        c->n = XN;
        c->m = S.m[l];
        c->p = p;
        c->linear = 1;
        memcpy(c->A, dfn_F, sizeof dfn_F);
        memcpy(c->C, dfn_H[l], sizeof dfn_H[l]);
        if (p > 0) {
            memcpy(c->B, dfn_G, sizeof dfn_G);
            memcpy(c->H, dfn_D[l], sizeof dfn_D[l]);
        }
        S.md[l] = lxs_model(c, 1);
        for (r = 0; r < S.m[l]; ++r) S.R[l][r * S.m[l] + r] = (dkf_real_t)dfn_R[l][r];
        S.mQ[l] = test_view(XN, XN, S.Q);
        S.mR[l] = test_view(S.m[l], S.m[l], S.R[l]);
        S.mz[l] = test_view(S.m[l], 1, S.z[l]);
        S.mx0[l] = test_view(XN, 1, S.x0);
        S.mP0[l] = test_view(XN, XN, S.P0);
        S.md0[l] = test_view(p, 1, S.d0);
        S.mPd0[l] = test_view(p, p, S.Pd0);
        S.mPxd0[l] = test_view(XN, p, S.Pxd0);
    }
}

static void scen_make(size_t N, size_t p, int ring)
{
    scen_make_sensors(N, p, ring, 0);
}

static void net_make_kind(dkf_nerts_kind_t kind, dkf_dfnerts_variant_t v)
{
    assert_int_equal(dkf_dfnerts_net_init(&net, &S.g, nodes, kind, v, XN, S.m, S.p,
                                          storage, sizeof storage / sizeof storage[0], S.mx0,
                                          S.mP0, S.p ? S.md0 : NULL, S.p ? S.mPd0 : NULL,
                                          S.p ? S.mPxd0 : NULL),
                     DKF_OK);
}

static void net_make(dkf_dfnerts_variant_t v)
{
    net_make_kind(DKF_NERTS_DNERTSIF, v);
}

/* One step of nt on the scenario S (its models, Q, R, z and W) with Tp
 * consensus rounds and the given scale; the step's status. */
static dkf_status_t s_step(dkf_dfnerts_net_t *nt, size_t Tp, dkf_real_t scale)
{
    return dkf_dfnerts_net_step(nt, S.md, NULL, S.mQ, NULL, S.mR, S.mz, S.W, Tp, scale);
}

/* Truth: x_{k} = F x_{k-1} + G d_{k-1} + w, z_l = H_l x_k + D_l d_k + v_l. */
static void truth_step(test_rng_t *rng, double *x, size_t k)
{
    const double d_prev = sin(0.3 * (double)(k - 1)) + 0.5, d = sin(0.3 * (double)k) + 0.5;
    const double w0 = 0.1 * test_rng_normal(rng), w1 = 0.2 * test_rng_normal(rng);
    const double x0 = x[0] + x[1] + (S.p ? dfn_G[0] * d_prev : 0) + w0;
    const double x1 = x[1] + (S.p ? dfn_G[1] * d_prev : 0) + w1;
    size_t l, r;
    x[0] = x0;
    x[1] = x1;
    for (l = 0; l < S.N; ++l)
        for (r = 0; r < S.m[l]; ++r) {
            double v = dfn_H[l][2 * r] * x[0] + dfn_H[l][2 * r + 1] * x[1];
            if (S.p) v += dfn_D[l][r] * d;
            S.z[l][r] = (dkf_real_t)(v + sqrt(dfn_R[l][r]) * test_rng_normal(rng));
        }
}

/* ---- centralised equalities ----------------------------------------------- */

static void test_central_info_p0(void **state)
{
    DKF_INFO_DECLARE(static, inf, XN);
    static dkf_real_t iv[NN][XN], Iv[NN][XN * XN], work[DKF_INFO_CONTRIB_WORK(XN, ZM)];
    dkf_mat_t mi[NN], mI[NN], mH[NN], mF;
    dkf_real_t Fr[XN * XN], Hr[NN][ZM * XN];
    test_rng_t rng;
    double x[XN] = {0.3, -0.2};
    size_t k, l;
    (void)state;
    scen_make(NN, 0, 0);
    net_make(DKF_DFNERTS_PAPER);
    test_rng_seed(&rng, 12001);
    test_to_real(Fr, dfn_F, 4);
    mF = test_view(XN, XN, Fr);
    for (l = 0; l < NN; ++l) {
        test_to_real(Hr[l], dfn_H[l], 4);
        mH[l] = test_view(ZM, XN, Hr[l]);
        mi[l] = test_view(XN, 1, iv[l]);
        mI[l] = test_view(XN, XN, Iv[l]);
    }
    assert_int_equal(dkf_info_init(&inf, XN, inf_storage, DKF_INFO_STORAGE_LEN(XN), &S.mx0[0],
                                   &S.mP0[0]),
                     DKF_OK);
    test_reset_worst_rel();
    for (k = 1; k <= STEPS; ++k) {
        truth_step(&rng, x, k);
        assert_int_equal(s_step(&net, 2, (dkf_real_t)NN), DKF_OK);
        assert_int_equal(dkf_info_predict(&inf, &(dkf_kf_dyn_t){&mF, &S.mQ[0]}), DKF_OK);
        for (l = 0; l < NN; ++l)
            assert_int_equal(dkf_info_contribution(&mi[l], &mI[l],
                                                   &(dkf_kf_meas_t){&mH[l], &S.mR[l]}, &S.mz[l],
                                                   work),
                             DKF_OK);
        assert_int_equal(dkf_info_fuse(&inf, mi, mI, NN), DKF_OK);
        for (l = 0; l < NN; ++l) {
            double ex[XN], eP[XN * XN];
            test_to_double(ex, inf.x.data, XN);
            test_to_double(eP, inf.P.data, XN * XN);
            test_assert_close("x vs centralised IF", nodes[l].f.x.data, ex, XN, EQ_REL);
            test_assert_close("Px vs centralised IF", nodes[l].f.Px.data, eP, XN * XN, EQ_REL);
        }
    }
    print_message("p = 0, W = 11^T/N, s = N: worst relative difference to the centralised IF "
                  "%.3e over %d steps x %d nodes\n",
                  test_worst_rel(), STEPS, NN);
}

/* The JOINT network of the given kind against the centralised NERTSF on
 * the M = sum m_l stacked sensors. */
static void central_joint(dkf_nerts_kind_t kind, const char *name, int mixed)
{
    DKF_NERTS_DECLARE(static, cf, XN, NN * ZM, DP);
    static dkf_nerts_stack_t st;
    dkf_nl_model_t stacked;
    dkf_real_t Rst[NN * ZM * NN * ZM], zst[NN * ZM];
    dkf_mat_t mRst, mzst;
    test_rng_t rng;
    double x[XN] = {0.3, -0.2};
    size_t k, l, r, M = 0, off;
    scen_make_sensors(NN, DP, 0, mixed);
    net_make_kind(kind, DKF_DFNERTS_JOINT);
    test_rng_seed(&rng, 12002);
    assert_int_equal(dkf_nerts_stack(&stacked, &st, S.md, NN), DKF_OK);
    for (l = 0; l < NN; ++l) M += S.m[l];
    mRst = test_view(M, M, Rst);
    mzst = test_view(M, 1, zst);
    memset(Rst, 0, sizeof Rst);
    for (l = 0, off = 0; l < NN; off += S.m[l], ++l)
        for (r = 0; r < S.m[l]; ++r) Rst[(off + r) * M + off + r] = S.R[l][r * S.m[l] + r];
    /* the reference: Hsieh's NERTSF (EKF, covariance form) on all sensors */
    assert_int_equal(dkf_nerts_init(&cf, DKF_NERTS_NERTSF, XN, M, DP, cf_storage,
                                    DKF_NERTS_STORAGE_LEN(XN, M, DP), &S.mx0[0], &S.mP0[0],
                                    &S.md0[0], &S.mPd0[0], &S.mPxd0[0]),
                     DKF_OK);
    test_reset_worst_rel();
    for (k = 1; k <= STEPS; ++k) {
        truth_step(&rng, x, k);
        for (l = 0, off = 0; l < NN; off += S.m[l], ++l)
            memcpy(zst + off, S.z[l], S.m[l] * sizeof S.z[l][0]);
        assert_int_equal(s_step(&net, 2, (dkf_real_t)NN), DKF_OK);
        assert_int_equal(dkf_nerts_step(&cf, &stacked, NULL, &S.mQ[0], NULL, &mRst, &mzst),
                         DKF_OK);
        for (l = 0; l < NN; ++l) {
            const dkf_nerts_t *f = &nodes[l].f;
            double e[XN * XN];
            test_to_double(e, cf.x.data, XN);
            test_assert_close("x", f->x.data, e, XN, EQ_REL);
            test_to_double(e, cf.Px.data, XN * XN);
            test_assert_close("Px", f->Px.data, e, XN * XN, EQ_REL);
            test_to_double(e, cf.d.data, DP);
            test_assert_close("d", f->d.data, e, DP, EQ_REL);
            test_to_double(e, cf.Pd.data, DP);
            test_assert_close("Pd", f->Pd.data, e, DP, EQ_REL);
            test_to_double(e, cf.Pxd.data, XN * DP);
            test_assert_close("Pxd", f->Pxd.data, e, XN * DP, EQ_REL);
        }
    }
    print_message("JOINT %s, W = 11^T/N, s = N, m_l = %zu %zu %zu %zu: worst relative difference "
                  "to the centralised NERTSF (x, Px, d, Pd, Pxd) %.3e over %d steps x %d nodes\n",
                  name, S.m[0], S.m[1], S.m[2], S.m[3], test_worst_rel(), STEPS, NN);
}

static void test_central_joint(void **state)
{
    (void)state;
    central_joint(DKF_NERTS_DNERTSIF, "DNERTSIF", 0);
    central_joint(DKF_NERTS_NERTSIF, "NERTSIF", 0);
}

/* Nodes with different sensors: the same equality, M = 6 stacked rows. */
static void test_central_joint_mixed(void **state)
{
    (void)state;
    central_joint(DKF_NERTS_DNERTSIF, "DNERTSIF", 1);
    central_joint(DKF_NERTS_NERTSIF, "NERTSIF", 1);
}

/* ---- the indefinite mixed covariance (note section 4 item 6) -------------- */

/* n = 1, p = 1, two nodes: node 0 measures x well and d alone (z = [x; d]
 * + v, Hd = [0; 1]); node 1 measures x + d and nothing else (Hd = [1; 0]:
 * Pi removes the only x channel, I = 0, but Pxd = -P_pred, Pd = P_pred +
 * R). After consensus Px ~ 1 / 100 and node 1's Schur complement
 * Pd - Pdx Px^-1 Pxd = 1.02 - 1.01^2 / 0.0099 < 0. */
static lxs_t ic[2];
static dkf_nl_model_t imd[2];
static dkf_real_t iQ[1] = {0.01}, iR[4] = {0.01, 0, 0, 1}, iz[2][2] = {{0.4, -0.3}, {0.7, 0.2}};
static dkf_real_t ix0[1] = {0}, iP0[1] = {1}, id0[1] = {0}, iPd0[1] = {1}, iPxd0[1] = {0};
static dkf_mat_t imQ[2], imR[2], imz[2], imx0[2], imP0[2], imd0[2], imPd0[2], imPxd0[2];
static size_t istart[3], inbr[4];
static dkf_graph_t ig;
static dkf_real_t iW[4];
static const size_t im[2] = {2, 2};

static void indef_make(void)
{
    static const size_t edge[2] = {0, 1};
    size_t l;
    memset(ic, 0, sizeof ic);
    for (l = 0; l < 2; ++l) {
        ic[l].n = 1;
        ic[l].m = 2;
        ic[l].p = 1;
        ic[l].linear = 1;
        ic[l].A[0] = 1;
        ic[l].C[0] = 1;
        imQ[l] = test_view(1, 1, iQ);
        imR[l] = test_view(2, 2, iR);
        imz[l] = test_view(2, 1, iz[l]);
        imx0[l] = test_view(1, 1, ix0);
        imP0[l] = test_view(1, 1, iP0);
        imd0[l] = test_view(1, 1, id0);
        imPd0[l] = test_view(1, 1, iPd0);
        imPxd0[l] = test_view(1, 1, iPxd0);
    }
    ic[0].H[1] = 1; /* node 0: z = [x; d] */
    ic[1].H[0] = 1; /* node 1: z = [x + d; 0] */
    imd[0] = lxs_model(&ic[0], 1);
    imd[1] = lxs_model(&ic[1], 1);
    assert_int_equal(dkf_graph_from_edges(&ig, istart, inbr, 4, 2, edge, 1), DKF_OK);
    assert_int_equal(dkf_graph_weights_metropolis(iW, &ig), DKF_OK);
    assert_int_equal(dkf_dfnerts_net_init(&net, &ig, nodes, DKF_NERTS_DNERTSIF, DKF_DFNERTS_PAPER,
                                          1, im, 1, storage, sizeof storage / sizeof storage[0],
                                          imx0, imP0, imd0, imPd0, imPxd0),
                     DKF_OK);
}

static unsigned char snap_nodes[NN][sizeof(dkf_dfnerts_node_t)];
static dkf_real_t snap_state[NN][STATE_LEN];
static unsigned char snap_net[sizeof(dkf_dfnerts_net_t)];

/* Reals of node l's state (its own m). */
static size_t state_len(size_t l)
{
    return DKF_DFNERTS_NODE_STATE_LEN(nodes[l].n, nodes[l].m, nodes[l].p);
}

static void snap_all(size_t N)
{
    size_t l;
    for (l = 0; l < N; ++l) {
        memcpy(snap_nodes[l], &nodes[l], sizeof nodes[l]);
        memcpy(snap_state[l], nodes[l].priv.mem, state_len(l) * sizeof(dkf_real_t));
    }
    memcpy(snap_net, &net, sizeof net);
}

static void assert_all_untouched(const char *what, size_t N)
{
    size_t l;
    for (l = 0; l < N; ++l) {
        if (memcmp(snap_nodes[l], &nodes[l], sizeof nodes[l]) != 0 ||
            memcmp(snap_state[l], nodes[l].priv.mem, state_len(l) * sizeof(dkf_real_t)) != 0) {
            print_error("%s: node %zu changed\n", what, l);
            fail();
        }
    }
    assert_memory_equal(snap_net, &net, sizeof net);
}

static void test_indefinite_mixed_covariance(void **state)
{
    const dkf_real_t *in[2];
    (void)state;
    indef_make();
    /* the network: node 0 commits, node 1 fails, both are rolled back */
    snap_all(2);
    assert_int_equal(dkf_dfnerts_net_step(&net, imd, NULL, imQ, NULL, imR, imz, iW, 2, DKF_R(2.0)),
                     DKF_ERR_NOT_SPD);
    assert_all_untouched("net step, mixed covariance indefinite", 2);
    /* literal s = 1 too */
    assert_int_equal(dkf_dfnerts_net_step(&net, imd, NULL, imQ, NULL, imR, imz, iW, 2, DKF_R(1.0)),
                     DKF_ERR_NOT_SPD);
    assert_all_untouched("net step s = 1", 2);
    /* an odd T_p: the rounds swap the packet buffers an odd number of
     * times before the commit fails; the network's buffers stay as well */
    assert_int_equal(dkf_dfnerts_net_step(&net, imd, NULL, imQ, NULL, imR, imz, iW, 3, DKF_R(2.0)),
                     DKF_ERR_NOT_SPD);
    assert_all_untouched("net step T_p = 3", 2);
    /* the node API: node 1's commit fails, node 1 stays as it was (pending) */
    assert_int_equal(dkf_dfnerts_node_local(&nodes[0], &imd[0], NULL, &imQ[0], NULL, &imR[0],
                                            &imz[0], DKF_R(2.0), NULL),
                     DKF_OK);
    assert_int_equal(dkf_dfnerts_node_local(&nodes[1], &imd[1], NULL, &imQ[1], NULL, &imR[1],
                                            &imz[1], DKF_R(2.0), NULL),
                     DKF_OK);
    {
        static dkf_real_t p0[DKF_DFNERTS_PKT_LEN(1)], p1[DKF_DFNERTS_PKT_LEN(1)];
        int t;
        for (t = 0; t < 2; ++t) {
            memcpy(p0, nodes[0].pkt, sizeof p0);
            memcpy(p1, nodes[1].pkt, sizeof p1);
            in[0] = p0;
            in[1] = p1;
            assert_int_equal(dkf_dfnerts_node_mix(&nodes[0], in, iW + istart[0], 2, NULL), DKF_OK);
            assert_int_equal(dkf_dfnerts_node_mix(&nodes[1], in, iW + istart[1], 2, NULL), DKF_OK);
        }
    }
    snap_all(2);
    assert_int_equal(dkf_dfnerts_node_commit(&nodes[1]), DKF_ERR_NOT_SPD);
    assert_all_untouched("node commit, mixed covariance indefinite", 2);
    assert_int_equal(dkf_dfnerts_node_commit(&nodes[0]), DKF_OK);
    assert_int_equal(dkf_dfnerts_node_cancel(&nodes[1]), DKF_OK);
}

/* The JOINT variant on the same data: P_X = Y_X^{-1} with Y_X computed here
 * by hand (n = p = 1: Y_pred = 1 / 1.01, J_0 = diag(100, 1), J_1 = 100 *
 * [1 1; 1 1]; j = [C Hd]^T R^-1 z with x_pred = 0, nu = z; s = N = 2,
 * W = 11^T/2, T_p = 2: Y_X = diag(Y_pred, 0) + J_0 + J_1). */
static void test_joint_commit_by_hand(void **state)
{
    const double Yp = 1.0 / 1.01;
    double Y[4], y[2], det, P[4], X[2];
    size_t l;
    (void)state;
    indef_make();
    assert_int_equal(dkf_dfnerts_net_init(&net, &ig, nodes, DKF_NERTS_DNERTSIF, DKF_DFNERTS_JOINT,
                                          1, im, 1, storage, sizeof storage / sizeof storage[0],
                                          imx0, imP0, imd0, imPd0, imPxd0),
                     DKF_OK);
    assert_int_equal(dkf_dfnerts_net_step(&net, imd, NULL, imQ, NULL, imR, imz, iW, 2, DKF_R(2.0)),
                     DKF_OK);
    Y[0] = Yp + 100 + 100;
    Y[1] = Y[2] = 100;
    Y[3] = 1 + 100;
    /* node 0: [C Hd] = [1 0; 0 1]: j0 = [100 z00; z01]; node 1: [1 1; 0 0]: j1 = 100 z10 [1; 1] */
    y[0] = 100 * (double)iz[0][0] + 100 * (double)iz[1][0];
    y[1] = (double)iz[0][1] + 100 * (double)iz[1][0];
    det = Y[0] * Y[3] - Y[1] * Y[2];
    P[0] = Y[3] / det;
    P[1] = P[2] = -Y[1] / det;
    P[3] = Y[0] / det;
    X[0] = P[0] * y[0] + P[1] * y[1];
    X[1] = P[2] * y[0] + P[3] * y[1];
    for (l = 0; l < 2; ++l) {
        const dkf_nerts_t *f = &nodes[l].f;
        test_assert_close("joint x", f->x.data, &X[0], 1, EQ_REL);
        test_assert_close("joint d", f->d.data, &X[1], 1, EQ_REL);
        test_assert_close("joint Px", f->Px.data, &P[0], 1, EQ_REL);
        test_assert_close("joint Pxd", f->Pxd.data, &P[1], 1, EQ_REL);
        test_assert_close("joint Pd", f->Pd.data, &P[3], 1, EQ_REL);
        assert_int_equal(f->k, 1);
        assert_int_equal(f->phase, DKF_NERTS_POSTERIOR);
    }
    /* and the next step runs from that joint posterior */
    assert_int_equal(dkf_dfnerts_net_step(&net, imd, NULL, imQ, NULL, imR, imz, iW, 2, DKF_R(2.0)),
                     DKF_OK);
}

/* A node that restarts from a prior at step k rejoins: restarted from its
 * own posterior, the network continues bit-identically to one that ran
 * undisturbed; a refused prior (P0 not SPD) leaves the node as it was. */
static void test_restart_rejoins(void **state)
{
    DKF_DFNERTS_NET_DECLARE(static, ref, NN, XN, ZM, DP);
    static dkf_real_t cx[XN], cP[XN * XN], cd[DP], cPd[DP * DP], cPxd[XN * DP], bad[XN * XN];
    dkf_mat_t mx = test_view(XN, 1, cx), mP = test_view(XN, XN, cP), md = test_view(DP, 1, cd);
    dkf_mat_t mPd = test_view(DP, DP, cPd), mPxd = test_view(XN, DP, cPxd);
    dkf_mat_t mbad = test_view(XN, XN, bad);
    test_rng_t rng;
    double x[XN] = {0.3, -0.2};
    size_t k, l;
    (void)state;
    scen_make(NN, DP, 1);
    net_make(DKF_DFNERTS_JOINT);
    assert_int_equal(dkf_dfnerts_net_init(&ref, &S.g, ref_nodes, DKF_NERTS_DNERTSIF,
                                          DKF_DFNERTS_JOINT, XN, S.m, DP, ref_storage,
                                          sizeof ref_storage / sizeof ref_storage[0], S.mx0,
                                          S.mP0, S.md0, S.mPd0, S.mPxd0),
                     DKF_OK);
    test_rng_seed(&rng, 12004);
    for (k = 1; k <= 10; ++k) {
        truth_step(&rng, x, k);
        assert_int_equal(s_step(&net, 5, (dkf_real_t)NN), DKF_OK);
        assert_int_equal(s_step(&ref, 5, (dkf_real_t)NN), DKF_OK);
        if (k == 5) {
            const dkf_nerts_t *f = &nodes[2].f;
            memcpy(cx, f->x.data, sizeof cx);
            memcpy(cP, f->Px.data, sizeof cP);
            memcpy(cd, f->d.data, sizeof cd);
            memcpy(cPd, f->Pd.data, sizeof cPd);
            memcpy(cPxd, f->Pxd.data, sizeof cPxd);
            memset(bad, 0, sizeof bad);
            bad[0] = DKF_R(-1.0), bad[3] = DKF_R(1.0);
            snap_all(NN);
            assert_int_equal(dkf_dfnerts_node_restart(&nodes[2], 5, &mx, &mbad, &md, &mPd, &mPxd),
                             DKF_ERR_NOT_SPD);
            assert_all_untouched("restart with P0 not SPD", NN);
            assert_int_equal(dkf_dfnerts_node_restart(&nodes[2], 5, &mx, &mP, &md, &mPd, &mPxd),
                             DKF_OK);
            assert_int_equal(nodes[2].f.k, 5);
        }
        if (k > 5)
            for (l = 0; l < NN; ++l)
                assert_memory_equal(nodes[l].priv.mem, ref_nodes[l].priv.mem,
                                    STATE_LEN * sizeof(dkf_real_t));
    }
}

/* A joining node's prior from a neighbour's packet (dkf_dfnerts_node_rejoin):
 * JOINT, after a step node 1's packet is the final consensus pair it
 * committed from, so node 2 rejoined from it holds node 1's posterior (the
 * same operations on the same reals: bit for bit); a packet whose Y is not
 * SPD is refused and every node is untouched; the network then steps on. */
static void test_rejoin_from_packet(void **state)
{
    dkf_real_t badpkt[DKF_DFNERTS_PKT_MAX(XN, DP)];
    test_rng_t rng;
    double x[XN] = {0.3, -0.2};
    size_t k;
    (void)state;
    scen_make(NN, DP, 1);
    net_make(DKF_DFNERTS_JOINT);
    test_rng_seed(&rng, 12005);
    for (k = 1; k <= 4; ++k) {
        truth_step(&rng, x, k);
        assert_int_equal(s_step(&net, 5, (dkf_real_t)NN), DKF_OK);
    }
    memset(badpkt, 0, sizeof badpkt);
    snap_all(NN);
    assert_int_equal(dkf_dfnerts_node_rejoin(&nodes[2], 4, badpkt, NULL, NULL), DKF_ERR_NOT_SPD);
    assert_all_untouched("rejoin from a packet with Y = 0", NN);
    badpkt[0] = (dkf_real_t)NAN;
    assert_int_equal(dkf_dfnerts_node_rejoin(&nodes[2], 4, badpkt, NULL, NULL), DKF_ERR_NONFINITE);
    assert_all_untouched("rejoin from a NaN packet", NN);
    assert_int_equal(dkf_dfnerts_node_rejoin(&nodes[2], 4, nodes[1].pkt, NULL, NULL), DKF_OK);
    assert_int_equal(nodes[2].f.k, 4);
    assert_memory_equal(nodes[2].f.x.data, nodes[1].f.x.data, XN * sizeof(dkf_real_t));
    assert_memory_equal(nodes[2].f.Px.data, nodes[1].f.Px.data, XN * XN * sizeof(dkf_real_t));
    assert_memory_equal(nodes[2].f.d.data, nodes[1].f.d.data, DP * sizeof(dkf_real_t));
    assert_memory_equal(nodes[2].f.Pd.data, nodes[1].f.Pd.data, DP * DP * sizeof(dkf_real_t));
    assert_memory_equal(nodes[2].f.Pxd.data, nodes[1].f.Pxd.data, XN * DP * sizeof(dkf_real_t));
    truth_step(&rng, x, 5);
    assert_int_equal(s_step(&net, 5, (dkf_real_t)NN), DKF_OK);
}

/* ---- statuses and untouched nodes ---------------------------------------- */

/* One network (ring, nodes of 2, 2, 1, 1 measurements) of the variant
 * with input dimension p, after a successful step: every failure leaves
 * every node as it was. */
static void errors_run(dkf_dfnerts_variant_t variant, size_t p)
{
    const dkf_real_t *in[NN];
    dkf_real_t Wbad[DKF_GRAPH_NNZ(NN, 6)], pkt[DKF_DFNERTS_PKT_MAX(XN, DP)];
    test_rng_t rng;
    double x[XN] = {0.1, 0.2};
    size_t l;
    scen_make_sensors(NN, p, 1, 1);
    net_make(variant);
    test_rng_seed(&rng, 12003);
    truth_step(&rng, x, 1);
    assert_int_equal(s_step(&net, 3, DKF_R(1.0)), DKF_OK);
    truth_step(&rng, x, 2);

    snap_all(NN);
    /* arguments */
    assert_int_equal(s_step(&net, 0, DKF_R(1.0)), DKF_ERR_ARG);
    assert_int_equal(s_step(&net, (size_t)DKF_DFNERTS_MAX_TP + 1, DKF_R(1.0)), DKF_ERR_ARG);
    assert_int_equal(s_step(&net, 3, DKF_R(0.0)), DKF_ERR_ARG);
    assert_int_equal(s_step(&net, 3, (dkf_real_t)NAN), DKF_ERR_ARG);
    memcpy(Wbad, S.W, sizeof Wbad);
    Wbad[0] += DKF_R(0.25);
    assert_int_equal(dkf_dfnerts_net_step(&net, S.md, NULL, S.mQ, NULL, S.mR, S.mz, Wbad, 3,
                                          DKF_R(1.0)),
                     DKF_ERR_WEIGHTS);
    assert_all_untouched("bad arguments", NN);
    /* bad input at the last node: the nodes before it ran their local step */
    S.z[NN - 1][0] = (dkf_real_t)NAN;
    assert_int_equal(s_step(&net, 3, DKF_R(1.0)), DKF_ERR_NONFINITE);
    assert_all_untouched("z NaN at the last node", NN);
    S.z[NN - 1][0] = DKF_R(0.5);
    S.ctx[2].fail_h = 1;
    assert_int_equal(s_step(&net, 3, DKF_R(1.0)), DKF_ERR_MODEL);
    assert_all_untouched("failing h at node 2", NN);
    S.ctx[2].fail_h = 0;
    S.R[1][0] = DKF_R(-1.0);
    assert_int_equal(s_step(&net, 3, DKF_R(1.0)), DKF_ERR_NOT_SPD);
    assert_all_untouched("R not SPD at node 1", NN);
    S.R[1][0] = (dkf_real_t)dfn_R[1][0];
    /* another node's sizes at the last node (m = 1): z, R, the model */
    S.mz[NN - 1] = S.mz[0];
    assert_int_equal(s_step(&net, 3, DKF_R(1.0)), DKF_ERR_DIM);
    assert_all_untouched("node 0's z at node 3", NN);
    S.mz[NN - 1] = test_view(S.m[NN - 1], 1, S.z[NN - 1]);
    S.mR[NN - 1] = S.mR[0];
    assert_int_equal(s_step(&net, 3, DKF_R(1.0)), DKF_ERR_DIM);
    assert_all_untouched("node 0's R at node 3", NN);
    S.mR[NN - 1] = test_view(S.m[NN - 1], S.m[NN - 1], S.R[NN - 1]);
    {
        const dkf_nl_model_t own = S.md[NN - 1];
        S.md[NN - 1] = S.md[0];
        assert_int_equal(s_step(&net, 3, DKF_R(1.0)), DKF_ERR_DIM);
        assert_all_untouched("node 0's model at node 3", NN);
        S.md[NN - 1] = own;
    }
    assert_int_equal(s_step(&net, 3, DKF_R(1.0)), DKF_OK);
    snap_all(NN);

    /* the node API out of order */
    assert_int_equal(dkf_dfnerts_node_mix(&nodes[0], in, S.W, 1, pkt), DKF_ERR_STATE);
    assert_int_equal(dkf_dfnerts_node_commit(&nodes[0]), DKF_ERR_STATE);
    assert_int_equal(dkf_dfnerts_node_cancel(&nodes[0]), DKF_ERR_STATE);
    assert_int_equal(dkf_dfnerts_node_local(&nodes[0], &S.md[0], NULL, &S.mQ[0], NULL, &S.mR[0],
                                            &S.mz[0], DKF_R(-1.0), pkt),
                     DKF_ERR_ARG);
    assert_all_untouched("node calls out of order", NN);
    assert_int_equal(dkf_dfnerts_node_local(&nodes[0], &S.md[0], NULL, &S.mQ[0], NULL, &S.mR[0],
                                            &S.mz[0], DKF_R(1.0), pkt),
                     DKF_OK);
    assert_memory_equal(pkt, nodes[0].pkt, nodes[0].pkt_len * sizeof(dkf_real_t));
    assert_int_equal(dkf_dfnerts_node_commit(&nodes[0]), DKF_ERR_STATE); /* no round yet */
    /* a round with a NaN packet: refused, the node's packet as it was */
    for (l = 0; l < 3; ++l) in[l] = pkt;
    pkt[2] = (dkf_real_t)NAN;
    {
        dkf_real_t before[DKF_DFNERTS_PKT_MAX(XN, DP)];
        memcpy(before, nodes[0].pkt, sizeof before);
        assert_int_equal(dkf_dfnerts_node_mix(&nodes[0], in, S.W + S.start[0], 3, NULL),
                         DKF_ERR_NONFINITE);
        assert_memory_equal(before, nodes[0].pkt, nodes[0].pkt_len * sizeof(dkf_real_t));
        assert_int_equal(nodes[0].tau, 0);
    }
    /* cancel puts the filter back exactly */
    assert_int_equal(dkf_dfnerts_node_cancel(&nodes[0]), DKF_OK);
    assert_all_untouched("local then cancel", NN);
    /* a failed local over a pending step leaves that step pending, its
     * packet as it was; a cancel then puts the filter back as before it */
    {
        static unsigned char before[sizeof(dkf_dfnerts_node_t)];
        static dkf_real_t before_state[STATE_LEN], pending_pkt[DKF_DFNERTS_PKT_MAX(XN, DP)];
        memcpy(before, &nodes[0], sizeof before);
        memcpy(before_state, nodes[0].priv.mem, state_len(0) * sizeof(dkf_real_t));
        assert_int_equal(dkf_dfnerts_node_local(&nodes[0], &S.md[0], NULL, &S.mQ[0], NULL,
                                                &S.mR[0], &S.mz[0], DKF_R(1.0), NULL),
                         DKF_OK);
        memcpy(pending_pkt, nodes[0].pkt, nodes[0].pkt_len * sizeof(dkf_real_t));
        snap_all(NN);
        S.z[0][0] = (dkf_real_t)INFINITY;
        assert_int_equal(dkf_dfnerts_node_local(&nodes[0], &S.md[0], NULL, &S.mQ[0], NULL,
                                                &S.mR[0], &S.mz[0], DKF_R(1.0), NULL),
                         DKF_ERR_NONFINITE);
        assert_all_untouched("failed local over a pending step", NN);
        assert_memory_equal(pending_pkt, nodes[0].pkt, nodes[0].pkt_len * sizeof(dkf_real_t));
        assert_int_equal(dkf_dfnerts_node_cancel(&nodes[0]), DKF_OK);
        assert_memory_equal(before, &nodes[0], sizeof before);
        assert_memory_equal(before_state, nodes[0].priv.mem, state_len(0) * sizeof(dkf_real_t));
    }
    S.z[0][0] = DKF_R(0.0);
    /* a network step while a node has a step of its own pending: refused
     * before anything (an undo could not give that step back) */
    assert_int_equal(dkf_dfnerts_node_local(&nodes[1], &S.md[1], NULL, &S.mQ[1], NULL, &S.mR[1],
                                            &S.mz[1], DKF_R(1.0), NULL),
                     DKF_OK);
    snap_all(NN);
    assert_int_equal(s_step(&net, 3, DKF_R(1.0)), DKF_ERR_STATE);
    assert_all_untouched("net step with a node pending", NN);
    assert_int_equal(dkf_dfnerts_node_cancel(&nodes[1]), DKF_OK);
}

static void test_errors_untouched(void **state)
{
    (void)state;
    errors_run(DKF_DFNERTS_JOINT, DP);
    errors_run(DKF_DFNERTS_PAPER, 0); /* DF-CKF form: Algorithm 3 with p = 0 */
}

static void test_init_statuses(void **state)
{
    (void)state;
    scen_make(NN, DP, 1);
    {
        static dkf_dfnerts_node_t nd;
        static dkf_real_t st[NODE_LEN];
        assert_int_equal(dkf_dfnerts_node_init(&nd, DKF_NERTS_DNERTSF, DKF_DFNERTS_PAPER, XN, ZM,
                                               DP, st, NODE_LEN, &S.mx0[0], &S.mP0[0], &S.md0[0],
                                               &S.mPd0[0], &S.mPxd0[0]),
                         DKF_ERR_ARG);
        assert_int_equal(dkf_dfnerts_node_init(&nd, DKF_NERTS_DNERTSIF, (dkf_dfnerts_variant_t)7,
                                               XN, ZM, DP, st, NODE_LEN, &S.mx0[0], &S.mP0[0],
                                               &S.md0[0], &S.mPd0[0], &S.mPxd0[0]),
                         DKF_ERR_ARG);
        assert_int_equal(dkf_dfnerts_node_init(&nd, DKF_NERTS_DNERTSIF, DKF_DFNERTS_JOINT, XN, ZM,
                                               DP, st, NODE_LEN - 1, &S.mx0[0], &S.mP0[0],
                                               &S.md0[0], &S.mPd0[0], &S.mPxd0[0]),
                         DKF_ERR_CAPACITY);
        assert_int_equal(dkf_dfnerts_node_init(&nd, DKF_NERTS_NERTSIF, DKF_DFNERTS_JOINT, XN, ZM,
                                               0, st, NODE_LEN0, &S.mx0[0], &S.mP0[0], NULL,
                                               NULL, NULL),
                         DKF_OK);
    }
    /* the network's m[]: sizes checked before any node is touched */
    scen_make_sensors(NN, DP, 1, 1);
    {
        const size_t mixed_len = dkf_dfnerts_net_storage_len(NN, XN, S.m, DP);
        size_t m[NN], l;
        for (l = 0; l < NN; ++l) m[l] = ZM;
        assert_int_equal(dkf_dfnerts_net_storage_len(NN, XN, m, DP),
                         DKF_DFNERTS_NET_STORAGE_LEN(NN, XN, ZM, DP));
        assert_true(mixed_len > 0 && mixed_len < DKF_DFNERTS_NET_STORAGE_LEN(NN, XN, ZM, DP));
        assert_int_equal(dkf_dfnerts_net_storage_len(NN, XN, NULL, DP), 0);
        assert_int_equal(dkf_dfnerts_net_storage_len(0, XN, m, DP), 0);
        memset(nodes, 0x5a, sizeof nodes);
        memset(&net, 0x5a, sizeof net);
        snap_all(0);
        memcpy(snap_nodes, nodes, sizeof snap_nodes);
        assert_int_equal(dkf_dfnerts_net_init(&net, &S.g, nodes, DKF_NERTS_DNERTSIF,
                                              DKF_DFNERTS_JOINT, XN, NULL, DP, storage,
                                              mixed_len, S.mx0, S.mP0, S.md0, S.mPd0, S.mPxd0),
                         DKF_ERR_NULL);
        assert_int_equal(dkf_dfnerts_net_init(&net, &S.g, nodes, DKF_NERTS_DNERTSIF,
                                              DKF_DFNERTS_JOINT, XN, S.m, DP, storage,
                                              mixed_len - 1, S.mx0, S.mP0, S.md0, S.mPd0,
                                              S.mPxd0),
                         DKF_ERR_CAPACITY);
        for (l = 0; l < NN; ++l) m[l] = S.m[l];
        m[NN - 1] = 0;
        assert_int_equal(dkf_dfnerts_net_init(&net, &S.g, nodes, DKF_NERTS_DNERTSIF,
                                              DKF_DFNERTS_JOINT, XN, m, DP, storage,
                                              sizeof storage / sizeof storage[0], S.mx0, S.mP0,
                                              S.md0, S.mPd0, S.mPxd0),
                         DKF_ERR_CAPACITY);
        m[NN - 1] = DKF_MAX_DIM + 1;
        assert_int_equal(dkf_dfnerts_net_init(&net, &S.g, nodes, DKF_NERTS_DNERTSIF,
                                              DKF_DFNERTS_JOINT, XN, m, DP, storage,
                                              sizeof storage / sizeof storage[0], S.mx0, S.mP0,
                                              S.md0, S.mPd0, S.mPxd0),
                         DKF_ERR_CAPACITY);
        assert_memory_equal(snap_nodes, nodes, sizeof nodes);
        assert_memory_equal(snap_net, &net, sizeof net);
        /* exactly the runtime length: node l measures S.m[l] */
        assert_int_equal(dkf_dfnerts_net_init(&net, &S.g, nodes, DKF_NERTS_DNERTSIF,
                                              DKF_DFNERTS_JOINT, XN, S.m, DP, storage, mixed_len,
                                              S.mx0, S.mP0, S.md0, S.mPd0, S.mPxd0),
                         DKF_OK);
        for (l = 0; l < NN; ++l) assert_int_equal(nodes[l].m, S.m[l]);
        assert_int_equal(net.m_max, ZM);
    }
}


int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_central_info_p0),
        cmocka_unit_test(test_central_joint),
        cmocka_unit_test(test_central_joint_mixed),
        cmocka_unit_test(test_indefinite_mixed_covariance),
        cmocka_unit_test(test_joint_commit_by_hand),
        cmocka_unit_test(test_restart_rejoins),
        cmocka_unit_test(test_rejoin_from_packet),
        cmocka_unit_test(test_errors_untouched),
        cmocka_unit_test(test_init_statuses),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
