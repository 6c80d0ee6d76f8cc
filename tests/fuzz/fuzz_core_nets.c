/*
 * fuzz_core_nets - the in-process networks, whose steps compose a call of
 * every node: the dfnerts network (dkf/dfnerts.h: every node's local
 * step, T_p rounds, every commit; PAPER or JOINT, DNERTSIF, p = 0 or 1)
 * and the Talebi-Werner network (dkf/tw.h: diffusion and consensus
 * steps), on 2 or 3 nodes (a path, or the triangle) with Metropolis
 * weights (byte-edited: then not stochastic), n up to 3, m up to 2.
 * Up to 16 operations: a network step with byte-edited models, Q, R,
 * measurements, T_p or eta and scale; and node calls on the network's
 * nodes (a local step, which leaves the node pending; a cancel or a
 * commit), so that a step meets a node pending. Every node's model is the
 * lin_x_sin_d model of tests/nerts_fixture.h (dfnerts) or the shared
 * (F, G, Q) with its own (H, R) and y (tw); a callback may fail.
 * Property: a failed call leaves the network struct, the node array and
 * every node's state (and a node's pending step while it is pending)
 * byte-identical; after a successful one every node's state is finite.
 */
#include "dkf/dfnerts.h"
#include "dkf/tw.h"
#include "fuzz_core.h"
#include "../nerts_fixture.h"

#define NODES 3
#define NMAX 3
#define MMAX 2

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The graph: nodes 0 - 1 (- 2), and 2 - 0 with `triangle`; its
 * Metropolis weights into W. */
static void make_graph(dkf_graph_t *g, size_t *start, size_t *nbr, dkf_real_t *W, size_t N,
                       int triangle)
{
    static const size_t edges[6] = {0, 1, 1, 2, 2, 0};
    const size_t E = N == 2 ? 1 : (triangle ? 3 : 2);
    FZ_CHECK(dkf_graph_from_edges(g, start, nbr, DKF_GRAPH_NNZ(NODES, 3), N, edges, E) == DKF_OK);
    FZ_CHECK(dkf_graph_weights_metropolis(W, g) == DKF_OK);
}

/* With code & 1 one byte-chosen weight takes a byte-chosen real. */
static void edit_weights(fz_t *z, uint8_t code, dkf_real_t *W, const dkf_graph_t *g)
{
    if (code & 1) W[fz_byte(z) % g->nnz] = fz_real(z);
}

/* The regions of a network of N nodes: its struct, the node array and
 * each node's state (state_len reals from node l's storage, node_len
 * apart), and pend_len more from pend_at where a node is pending. */
static void net_regions(fz_snap_t *s, const void *net, size_t net_size, const void *nodes,
                        size_t nodes_size, const dkf_real_t *st, size_t N, size_t node_len,
                        size_t state_len, const int *pending, size_t pend_at, size_t pend_len)
{
    size_t l;
    fz_regions_clear(s);
    fz_region(s, net, net_size);
    fz_region(s, nodes, nodes_size);
    for (l = 0; l < N; ++l) {
        fz_region(s, st + l * node_len, state_len * sizeof *st);
        if (pending[l]) fz_region(s, st + l * node_len + pend_at, pend_len * sizeof *st);
    }
    fz_take(s);
}

/* ---- the dfnerts network ----------------------------------------------------- */

static void run_dfnerts(fz_t *z, size_t N, size_t n, size_t m, size_t p, int triangle,
                        dkf_dfnerts_variant_t variant)
{
    static dkf_real_t st[DKF_DFNERTS_NET_STORAGE_LEN(NODES, NMAX, MMAX, 1)];
    static dkf_dfnerts_node_t nodes[NODES];
    static dkf_dfnerts_net_t net;
    static fz_snap_t snap;
    static fz_mat_t x0, P0, d0, Pd0, Pxd0, Q, R[NODES], zz[NODES];
    fz_mat_t *const prior_m[] = {&x0, &P0, &d0, &Pd0, &Pxd0};
    static lxs_t c[NODES];
    static size_t start[NODES + 1], nbr[DKF_GRAPH_NNZ(NODES, 3)];
    static dkf_real_t W[DKF_GRAPH_NNZ(NODES, 3)];
    fz_mat_t *const meas_m[] = {&Q, &R[0], &zz[0], &R[1], &zz[1], &R[2], &zz[2]};
    const size_t node_len = DKF_DFNERTS_NODE_STORAGE_LEN(n, m, p);
    dkf_mat_t mx0[NODES], mP0[NODES], md0[NODES], mPd0[NODES], mPxd0[NODES];
    dkf_mat_t mQ[NODES], mR[NODES], mz[NODES];
    dkf_nl_model_t md[NODES];
    dkf_graph_t g;
    size_t l, op, ms[NODES];
    int pending[NODES];
    dkf_status_t s;
    make_graph(&g, start, nbr, W, N, triangle);
    fz_nerts_prior(NULL, prior_m, n, p);
    for (l = 0; l < N; ++l) {
        static const double A[9] = {0.9, 0.1, 0, 0, 0.9, 0.1, 0, 0, 0.9};
        static const double C[6] = {1, 0, 0.5, 0, 1, 0}, H[2] = {1, 0.5};
        memset(&c[l], 0, sizeof c[l]);
        c[l].n = n, c[l].m = m, c[l].p = p;
        memcpy(c[l].A, A, sizeof A);
        memcpy(c[l].C, C, sizeof C);
        memcpy(c[l].H, H, sizeof H);
        c[l].B[0] = 0.2 * (double)(l + 1);
        c[l].C[0] += 0.1 * (double)l;
        md[l] = lxs_model(&c[l], 1);
        mx0[l] = x0.v, mP0[l] = P0.v, md0[l] = d0.v, mPd0[l] = Pd0.v, mPxd0[l] = Pxd0.v;
        ms[l] = m; /* equal nodes here: fuzz_core_dfnerts's network mode mixes them */
    }
    s = dkf_dfnerts_net_init(&net, &g, nodes, DKF_NERTS_DNERTSIF, variant, n, ms, p, st,
                             DKF_DFNERTS_NET_STORAGE_LEN(N, n, m, p), mx0, mP0,
                             p > 0 ? md0 : NULL, p > 0 ? mPd0 : NULL, p > 0 ? mPxd0 : NULL);
    FZ_CHECK(s == DKF_OK);
    for (op = 0; op < 16 && fz_more(z); ++op) {
        const uint8_t code = fz_byte(z), fault = (uint8_t)((code >> 2) % 8);
        const size_t at = (size_t)(code >> 5) % N;
        fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
        for (l = 0; l < N; ++l) {
            fz_set(&R[l], m, m, DKF_R(0.5), DKF_R(0.0));
            fz_set(&zz[l], m, 1, DKF_R(0.3), DKF_R(0.1) * (dkf_real_t)l);
        }
        fz_edit(z, meas_m, 1 + 2 * N);
        for (l = 0; l < N; ++l) {
            c[l].fail_h = fault == 1 && l == at;
            c[l].fail_f = fault == 2 && l == at;
            mQ[l] = Q.v, mR[l] = R[l].v, mz[l] = zz[l].v;
            pending[l] = nodes[l].pending;
        }
        net_regions(&snap, &net, sizeof net, nodes, sizeof nodes, st, N, node_len,
                    DKF_DFNERTS_NODE_STATE_LEN(n, m, p), pending,
                    DKF_DFNERTS_NODE_PENDING_AT(n, m, p), DKF_DFNERTS_NODE_PENDING_LEN(n, m, p));
        switch (code % 4) {
        case 0:
        case 1: {
            const size_t Tp = 1 + (size_t)fz_byte(z) % 4;
            const dkf_real_t scale = fault == 3 ? fz_real(z) : (dkf_real_t)(1 + code % 2 * (N - 1));
            edit_weights(z, code >> 1, W, &g);
            s = dkf_dfnerts_net_step(&net, md, NULL, mQ, NULL, mR, mz, W, Tp, scale);
            make_graph(&g, start, nbr, W, N, triangle);
            break;
        }
        case 2:
            s = dkf_dfnerts_node_local(&nodes[at], &md[at], NULL, &mQ[at], NULL, &mR[at], &mz[at],
                                       DKF_R(1.0), NULL);
            break;
        default: s = dkf_dfnerts_node_cancel(&nodes[at]); break;
        }
        if (fz_after(&snap, s))
            for (l = 0; l < N; ++l)
                fz_finite(st + l * node_len, DKF_DFNERTS_NODE_STATE_LEN(n, m, p));
    }
}

/* ---- the Talebi-Werner network ------------------------------------------------ */

static void run_tw(fz_t *z, size_t N, size_t n, size_t m, size_t p, int triangle)
{
    static dkf_real_t st[DKF_TW_NET_STORAGE_LEN(NODES, NMAX, MMAX, NMAX)];
    static dkf_real_t info[DKF_TW_PKT_LEN(NMAX)];
    static dkf_tw_node_t nodes[NODES];
    static dkf_tw_net_t net;
    static fz_snap_t snap;
    static fz_mat_t x0, P0, A, B, Sv, H[NODES], Sw[NODES], y[NODES];
    static size_t start[NODES + 1], nbr[DKF_GRAPH_NNZ(NODES, 3)];
    static dkf_real_t W[DKF_GRAPH_NNZ(NODES, 3)];
    fz_mat_t *const md_m[] = {&A, &B, &Sv}, *const sn_m[] = {&H[0], &Sw[0], &y[0], &H[1],
                                                            &Sw[1], &y[1], &H[2], &Sw[2], &y[2]};
    const size_t node_len = DKF_TW_NODE_STORAGE_LEN(n, m, p), state = DKF_TW_NODE_STATE_LEN(n, p);
    dkf_kf_meas_t sn[NODES];
    dkf_mat_t ys[NODES];
    dkf_uif_dyn_t md;
    dkf_graph_t g;
    size_t l, op;
    int pending[NODES];
    dkf_status_t s;
    make_graph(&g, start, nbr, W, N, triangle);
    fz_set(&x0, n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(&P0, n, n, DKF_R(1.0), DKF_R(0.1));
    FZ_CHECK(dkf_tw_net_init(&net, &g, nodes, n, m, p, st, DKF_TW_NET_STORAGE_LEN(N, n, m, p),
                             &x0.v, &P0.v) == DKF_OK);
    md.F = &A.v, md.G = &B.v, md.Q = &Sv.v;
    for (op = 0; op < 16 && fz_more(z); ++op) {
        const uint8_t code = fz_byte(z);
        const size_t at = (size_t)(code >> 5) % N;
        fz_set(&A, n, n, DKF_R(0.9), DKF_R(0.05));
        fz_set(&B, n, p, DKF_R(1.0), DKF_R(0.0));
        fz_set(&Sv, n, n, DKF_R(0.1), DKF_R(0.0));
        for (l = 0; l < N; ++l) {
            fz_set(&H[l], m, n, DKF_R(1.0), DKF_R(0.1) * (dkf_real_t)(l + 1));
            fz_set(&Sw[l], m, m, DKF_R(0.5), DKF_R(0.0));
            fz_set(&y[l], m, 1, DKF_R(0.3), DKF_R(0.3));
        }
        fz_edit(z, md_m, 3);
        fz_edit(z, sn_m, 3 * N);
        for (l = 0; l < N; ++l) {
            sn[l].H = &H[l].v, sn[l].R = &Sw[l].v, ys[l] = y[l].v;
            pending[l] = nodes[l].pending;
        }
        net_regions(&snap, &net, sizeof net, nodes, sizeof nodes, st, N, node_len, state, pending,
                    state, state - n - n * n);
        switch (code % 5) {
        case 0:
            edit_weights(z, code >> 1, W, &g);
            s = dkf_tw_net_diffusion_step(&net, W, &md, sn, ys);
            break;
        case 1:
            edit_weights(z, code >> 1, W, &g);
            s = dkf_tw_net_consensus_step(&net, W, (size_t)fz_byte(z) % 4, &md, sn, ys);
            break;
        case 2: /* a node's own local step on its own information */
            s = dkf_tw_meas_packet(info, &nodes[at], &sn[at], &ys[at], DKF_R(1.0));
            if (s == DKF_OK) s = dkf_tw_node_local(&nodes[at], &md, info, NULL);
            break;
        default: s = dkf_tw_node_commit(&nodes[at], NULL, NULL); break;
        }
        make_graph(&g, start, nbr, W, N, triangle);
        if (fz_after(&snap, s))
            for (l = 0; l < N; ++l) fz_finite(st + l * node_len, state);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_t z = {data, size, 0};
    const uint8_t which = fz_byte(&z);
    const size_t N = 2 + (size_t)(which >> 2) % 2, n = fz_dim(&z, NMAX), m = fz_dim(&z, MMAX);
    const int triangle = (which >> 3) & 1;
    if (which % 3 == 2)
        run_tw(&z, N, n, m, fz_dim(&z, n), triangle);
    else
        run_dfnerts(&z, N, n, m, fz_byte(&z) % 2, triangle,
                    which % 3 == 0 ? DKF_DFNERTS_PAPER : DKF_DFNERTS_JOINT);
    return 0;
}
