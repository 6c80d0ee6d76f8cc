/*
 * fuzz_core_dfnerts - one node of seed 001's consensus network
 * (dkf/dfnerts.h): a kind (NERTSIF, DNERTSIF, or a covariance / invalid
 * one), a variant (PAPER, JOINT, or an invalid one), dimensions with
 * p = 0 .. 2, init on byte-edited priors, then up to 24 node calls (local,
 * mix, commit, cancel, restart, rejoin: in any order, so out of sequence
 * and over a pending step too) on the lin_x_sin_d model of
 * tests/nerts_fixture.h with byte-edited model matrices, Q, R, z, scale,
 * rounds over the node's own packet and a byte-edited neighbour packet
 * with byte-chosen weights, restarts on byte-edited priors and rejoins
 * from a byte-edited packet (the node's own while a step is pending, else
 * y = 1/2, Y = I) with byte-edited d0, Pd0 (fuzz_core.h).
 * Property: a failed call leaves the struct, DKF_DFNERTS_NODE_STATE_LEN
 * reals of storage and, while a step is pending, the pending step
 * (DKF_DFNERTS_NODE_PENDING_LEN reals from DKF_DFNERTS_NODE_PENDING_AT)
 * byte-identical; after a successful call the state is finite and Px is
 * exactly symmetric.
 *
 * A first byte >= 128 drives the in-process network instead (fuzz_net):
 * three nodes on a path, each with its own byte-chosen m_l (0, above
 * DKF_MAX_DIM or below p included), a storage length of the runtime size
 * or one less, the common prior byte-edited, then up to 8 network steps
 * with every node's model, R and z of its own size or (a fault) another
 * size, byte-edited, T_p 1..3, byte-chosen scale and weights. Property: a
 * failed init or step leaves the network struct, every node struct and
 * every node's state (its own m) byte-identical; after a successful step
 * every node's state is finite and its Px exactly symmetric.
 */
#include "dkf/dfnerts.h"
#include "fuzz_nerts.h"

#define NMAX 4
#define MMAX 4
#define PMAX 2
#define PKT DKF_DFNERTS_PKT_MAX(NMAX, PMAX)
#define NET_N 3

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* A rejoin's packet into out: the node's current one while a step is
 * pending, else y = 1/2, Y = I (q = nd->q, packed as dkf/dfnerts.h);
 * with code & 64 one byte-chosen entry takes a byte-chosen real. */
static void rejoin_packet(fz_t *z, uint8_t code, const dkf_dfnerts_node_t *nd, dkf_real_t *out)
{
    const size_t q = nd->q;
    size_t e;
    if (nd->pending) {
        memcpy(out, nd->pkt, nd->pkt_len * sizeof *out);
    } else {
        for (e = 0; e < nd->pkt_len; ++e) out[e] = DKF_R(0.0);
        for (e = 0; e < q; ++e) {
            out[e] = DKF_R(0.5);
            out[q + e * q - e * (e - 1) / 2] = DKF_R(1.0);
        }
    }
    if (code & 64) out[fz_byte(z) % nd->pkt_len] = fz_real(z);
}

/* m_l from a byte: 1 .. MMAX + 1 mostly, else 0 or DKF_MAX_DIM + 1. */
static size_t net_m(fz_t *z)
{
    const uint8_t b = fz_byte(z);
    if (b == 255) return (size_t)DKF_MAX_DIM + 1;
    return b % (MMAX + 2);
}

/* Every node's struct and state (node l's own m) into the snapshot. */
static void net_regions(fz_snap_t *snap, const dkf_dfnerts_net_t *net,
                        const dkf_dfnerts_node_t *nodes)
{
    size_t l;
    fz_regions_clear(snap);
    fz_region(snap, net, sizeof *net);
    for (l = 0; l < NET_N; ++l) {
        fz_region(snap, &nodes[l], sizeof nodes[l]);
        if (nodes[l].priv.ready)
            fz_region(snap, nodes[l].priv.mem,
                      DKF_DFNERTS_NODE_STATE_LEN(nodes[l].n, nodes[l].m, nodes[l].p) *
                          sizeof(dkf_real_t));
    }
    fz_take(snap);
}

static void fuzz_net(fz_t *z, dkf_nerts_kind_t kind, dkf_dfnerts_variant_t variant)
{
    static dkf_real_t st[DKF_DFNERTS_NET_STORAGE_LEN(NET_N, NMAX, MMAX + 1, PMAX)];
    static dkf_dfnerts_node_t nodes[NET_N];
    static dkf_dfnerts_net_t net;
    static fz_snap_t snap;
    static fz_mat_t x0, P0, d0, Pd0, Pxd0, Q[NET_N], R[NET_N], zz[NET_N];
    static lxs_t c[NET_N];
    static const size_t edges[4] = {0, 1, 1, 2};
    static size_t start[NET_N + 1], nbr[DKF_GRAPH_NNZ(NET_N, 2)];
    fz_mat_t *const init_m[] = {&x0, &P0, &d0, &Pd0, &Pxd0};
    dkf_mat_t mx0[NET_N], mP0[NET_N], md0[NET_N], mPd0[NET_N], mPxd0[NET_N];
    dkf_mat_t mQ[NET_N], mR[NET_N], mz[NET_N];
    dkf_nl_model_t md[NET_N];
    dkf_real_t W[DKF_GRAPH_NNZ(NET_N, 2)];
    dkf_graph_t g;
    size_t m[NET_N], len, l, i, op;
    dkf_status_t s;
    const size_t n = fz_dim(z, NMAX), p = fz_byte(z) % (PMAX + 1);
    for (l = 0; l < NET_N; ++l) m[l] = net_m(z);
    len = dkf_dfnerts_net_storage_len(NET_N, n, m, p);
    if (len > sizeof st / sizeof st[0]) len = sizeof st / sizeof st[0];
    if (len > 0 && (fz_byte(z) & 1)) --len;
    if (dkf_graph_from_edges(&g, start, nbr, DKF_GRAPH_NNZ(NET_N, 2), NET_N, edges, 2) != DKF_OK)
        return;
    fz_nerts_prior(z, init_m, n, p);
    /* one prior for every node: a prior is refused at node 0 or nowhere */
    for (l = 0; l < NET_N; ++l) {
        mx0[l] = x0.v, mP0[l] = P0.v, md0[l] = d0.v, mPd0[l] = Pd0.v, mPxd0[l] = Pxd0.v;
    }
    memset(nodes, 0, sizeof nodes);
    memset(&net, 0, sizeof net);
    net_regions(&snap, &net, nodes);
    s = dkf_dfnerts_net_init(&net, &g, nodes, kind, variant, n, m, p, st, len, mx0, mP0,
                             p > 0 ? md0 : NULL, p > 0 ? mPd0 : NULL, p > 0 ? mPxd0 : NULL);
    if (!fz_after(&snap, s)) return;
    for (op = 0; op < 8 && fz_more(z); ++op) {
        const uint8_t code = fz_byte(z), fault = (uint8_t)(code % 8);
        const size_t odd = fz_byte(z) % NET_N;
        const dkf_real_t scale = fault == 5 ? fz_real(z) : DKF_R(1.0) + (dkf_real_t)(code >> 7);
        if (dkf_graph_weights_metropolis(W, &g) != DKF_OK) return;
        if (fault == 6) W[fz_byte(z) % g.nnz] = fz_real(z);
        for (l = 0; l < NET_N; ++l) {
            /* node l's sizes, or (fault 7) another node's m at node `odd` */
            const size_t ml = fault == 7 && l == odd ? m[(l + 1) % NET_N] : m[l];
            fz_mat_t *const step_m[] = {&Q[l], &R[l], &zz[l]};
            memset(&c[l], 0, sizeof c[l]);
            c[l].n = n, c[l].m = ml, c[l].p = p;
            c[l].linear = fault == 4;
            c[l].fail_h = fault == 2 && l == odd;
            c[l].nan_h = fault == 3 && l == odd;
            for (i = 0; i < n * n; ++i) c[l].A[i] = i % (n + 1) == 0 ? 0.9 : 0.05;
            for (i = 0; i < n * p; ++i) c[l].B[i] = 0.5;
            for (i = 0; i < ml * n && i < LXS_MAX * LXS_MAX; ++i)
                c[l].C[i] = i % (n + 1) == 0 ? 1.0 : 0.2 + 0.1 * (double)l;
            for (i = 0; i < ml * p && i < LXS_MAX * LXS_MAX; ++i)
                c[l].H[i] = i % (p + 1) == 0 ? 1.0 : 0.0;
            md[l] = lxs_model(&c[l], (int)(code >> 6) & 1);
            fz_set(&Q[l], n, n, DKF_R(0.1), DKF_R(0.0));
            fz_set(&R[l], ml, ml, DKF_R(0.5), DKF_R(0.0));
            fz_set(&zz[l], ml, 1, DKF_R(0.3), DKF_R(0.3));
            if (l == odd) fz_edit(z, step_m, 3);
            mQ[l] = Q[l].v, mR[l] = R[l].v, mz[l] = zz[l].v;
        }
        net_regions(&snap, &net, nodes);
        s = dkf_dfnerts_net_step(&net, md, NULL, mQ, NULL, mR, mz, W, 1 + (size_t)(code >> 5) % 3,
                                 scale);
        if (fz_after(&snap, s))
            for (l = 0; l < NET_N; ++l) {
                fz_finite(nodes[l].priv.mem, DKF_DFNERTS_NODE_STATE_LEN(n, m[l], p));
                fz_symmetric(nodes[l].f.Px.data, n, 1);
            }
    }
}

static dkf_real_t st[DKF_DFNERTS_NODE_STORAGE_LEN(NMAX, MMAX, PMAX)];
static dkf_real_t own[PKT], other[PKT];
static fz_node_t o;
static dkf_dfnerts_node_t nd;
static dkf_nerts_kind_t kind;
static dkf_dfnerts_variant_t variant;

static void decode(fz_t *z) { fz_node_decode(z, &o, NMAX, MMAX, PMAX); }

static dkf_status_t init(void)
{
    return dkf_dfnerts_node_init(&nd, kind, variant, o.n, o.m, o.p, st,
                                 DKF_DFNERTS_NODE_STORAGE_LEN(o.n, o.m, o.p), &o.x0.v, &o.P0.v,
                                 FZ_NODE_D(&o, d0), FZ_NODE_D(&o, Pd0), FZ_NODE_D(&o, Pxd0));
}

/* A round: the node's own packet and an edited copy, byte-chosen weights. */
static dkf_status_t mix(fz_t *z, uint8_t code)
{
    const dkf_real_t *in[2] = {own, other};
    dkf_real_t w[2];
    if (nd.pending) {
        memcpy(own, nd.pkt, nd.pkt_len * sizeof *own);
        memcpy(other, nd.pkt, nd.pkt_len * sizeof *own);
        if (code & 64) other[fz_byte(z) % nd.pkt_len] = fz_real(z);
    }
    w[0] = code & 128 ? fz_real(z) : DKF_R(0.5);
    w[1] = DKF_R(1.0) - w[0];
    return dkf_dfnerts_node_mix(&nd, in, w, 1 + (size_t)((code >> 6) & 1), NULL);
}

/* A prior from a packet and (PAPER) the caller's d0, Pd0. */
static dkf_status_t rejoin(fz_t *z, uint8_t code, uint8_t fault)
{
    fz_mat_t *const input_m[] = {&o.d0, &o.Pd0};
    rejoin_packet(z, code, &nd, own);
    fz_set(&o.d0, o.p, 1, DKF_R(0.2), DKF_R(0.2));
    fz_set(&o.Pd0, o.p, o.p, DKF_R(0.5), DKF_R(0.0));
    fz_edit(z, input_m, 2);
    return dkf_dfnerts_node_rejoin(&nd, fz_byte(z), fault == 7 ? NULL : own, FZ_NODE_D(&o, d0),
                                   FZ_NODE_D(&o, Pd0));
}

/* One node call; a pending step (its packet included) is guarded too. */
static dkf_status_t node_call(fz_t *z, uint8_t code, fz_snap_t *s)
{
    const uint8_t fault = (uint8_t)((code >> 3) % 8);
    const size_t n = o.n, m = o.m, p = o.p;
    fz_node_step(z, &o, NULL, 0, fault);
    fz_regions_clear(s);
    fz_region(s, &nd, sizeof nd);
    fz_region(s, st, DKF_DFNERTS_NODE_STATE_LEN(n, m, p) * sizeof *st);
    if (nd.pending)
        fz_region(s, st + DKF_DFNERTS_NODE_PENDING_AT(n, m, p),
                  DKF_DFNERTS_NODE_PENDING_LEN(n, m, p) * sizeof *st);
    fz_take(s);
    switch (code % 6) {
    case 0: {
        const dkf_real_t scale = fault == 5 ? fz_real(z) : DKF_R(1.0) + (dkf_real_t)(code >> 7);
        return dkf_dfnerts_node_local(&nd, &o.md, NULL, &o.Q.v, NULL, &o.R.v, &o.zz.v, scale, NULL);
    }
    case 1: return mix(z, code);
    case 2: return dkf_dfnerts_node_commit(&nd);
    case 3: return dkf_dfnerts_node_cancel(&nd);
    case 4: /* a new prior, as the posterior of a byte-chosen step */
        fz_node_prior(z, &o);
        return dkf_dfnerts_node_restart(&nd, fz_byte(z), &o.x0.v, &o.P0.v, FZ_NODE_D(&o, d0),
                                        FZ_NODE_D(&o, Pd0), FZ_NODE_D(&o, Pxd0));
    default: return rejoin(z, code, fault);
    }
}

static dkf_status_t op(fz_t *z, uint8_t code, fz_snap_t *s)
{
    const dkf_status_t r = node_call(z, code, s);
    if (nd.pending) fz_finite(nd.pkt, nd.pkt_len);
    return r;
}

static void ok(void)
{
    fz_finite(st, DKF_DFNERTS_NODE_STATE_LEN(o.n, o.m, o.p));
    fz_symmetric(nd.f.Px.data, o.n, 1);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const dkf_nerts_kind_t kinds[4] = {DKF_NERTS_DNERTSIF, DKF_NERTS_NERTSIF,
                                              DKF_NERTS_DNERTSF, (dkf_nerts_kind_t)9};
    static const fz_family_t fam = {&nd, sizeof nd, decode, init, NULL, op, ok};
    fz_t z = {data, size, 0};
    const uint8_t first = fz_byte(&z);
    kind = kinds[first % 4];
    variant = (dkf_dfnerts_variant_t)(fz_byte(&z) % 3);
    if (first >= 128) {
        fuzz_net(&z, kind, variant);
        return 0;
    }
    return fz_run(&fam, &z);
}
