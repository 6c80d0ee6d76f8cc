/*
 * Talebi-Werner filters with unknown actuations (dkf/tw.h): seed 003
 * Algorithms 1-3 as corrected in docs/design/graph-filters.md.
 *
 * Letters of dkf/tw.h: F, G, Q, R, d, I, i, Gpost are the paper's A, B,
 * Sv, Sw, z, Q (Upsilon), s (varphi), G. The local step evaluates the
 * information form (9)-(20) through product identities that avoid the
 * cancellations of the printed formulas (Psi = Phi-^{-1} + I,
 * Phi+ = Psi^{-1}, Lambda = I_n - I Psi^{-1}):
 *   Lambda = Phi-^{-1} Phi+          since (Psi - I) Psi^{-1} = Phi-^{-1} Psi^{-1}
 *   Phi- Lambda = Phi+               so (19)-(20): phi+ = phi- + Phi+ (i - I phi-)
 *   (I_n - Phi- Pi) = I_n - Phi+ I = Phi+ Phi-^{-1}   so (8a): Gpost = Phi+ (Phi-^{-1} G)
 *   Pi = Lambda I,  G^T Lambda = Gpost^T  so (12): S = Gpost^T (I G),
 *   (18): d = S^{-1} Gpost^T (i - I phi-)
 * Pi = I - I Psi^{-1} I itself is never formed: with 200 nodes I is ~1e3
 * times Pi and the subtraction would cost three digits (float: all of
 * the margin). Every product above has positive factors only.
 */
#include "dkf/tw.h"

#include <string.h>

#include "internal.h"
#include "kernels.h"

/* What a step shows: d and the views, in this order, once committed and
 * once pending, so a commit is one copy. */
typedef struct {
    dkf_real_t *d, *phi, *Phi, *I, *i, *phi_post, *Phi_post, *S, *Gpost, *psi, *Ploc;
} block_t;

/* Walks a block; with base == NULL it only counts. */
static size_t block_layout(block_t *k, dkf_real_t *base, size_t n, size_t p)
{
    size_t used = 0;
    DKF_TAKE(k->d, p);
    DKF_TAKE(k->phi, n);
    DKF_TAKE(k->Phi, n * n);
    DKF_TAKE(k->I, n * n);
    DKF_TAKE(k->i, n);
    DKF_TAKE(k->phi_post, n);
    DKF_TAKE(k->Phi_post, n * n);
    DKF_TAKE(k->S, p * p);
    DKF_TAKE(k->Gpost, n * p);
    DKF_TAKE(k->psi, n);
    DKF_TAKE(k->Ploc, n * n);
    return used;
}

static size_t block_len(size_t n, size_t p)
{
    block_t k;
    return block_layout(&k, NULL, n, p);
}

static block_t block_at(dkf_real_t *b, size_t n, size_t p)
{
    block_t k;
    (void)block_layout(&k, b, n, p);
    return k;
}

/* The start of node storage, the committed state: x, P and the committed
 * block (DKF_TW_NODE_STATE_LEN together with the pending block of mem). */
typedef struct {
    dkf_real_t *x, *P, *blk;
} committed_t;

static size_t committed_layout(committed_t *c, dkf_real_t *base, size_t n, size_t p)
{
    size_t used = 0;
    DKF_TAKE(c->x, n);
    DKF_TAKE(c->P, n * n);
    DKF_TAKE(c->blk, block_len(n, p));
    return used;
}

/* nd->priv.mem: pending block, then scratch: the next pending block (a local
 * step is formed there and becomes the pending one only if it succeeds),
 * then the local step's and the packets' working areas. */
typedef struct {
    dkf_real_t *pend, *next;
    dkf_real_t *J, *C, *T;       /* n x n: Phi-^{-1}, Cholesky factors, Psi / unpacked P */
    dkf_real_t *JG, *IG, *GSi;   /* n x p */
    dkf_real_t *Sc, *Si;         /* p x p: Cholesky of S, S^{-1} */
    dkf_real_t *r;               /* n: i - I phi- */
    dkf_real_t *Lw, *RiH, *Riy;  /* measurement: chol(R) = Lw, Lw^{-1} H, Lw^{-1} y */
    dkf_real_t *stage, *acc;     /* packets: one being built, the central sum */
} layout_t;

static size_t layout(layout_t *L, dkf_real_t *base, size_t n, size_t m, size_t p)
{
    size_t used = 0;
    DKF_TAKE(L->pend, block_len(n, p));
    DKF_TAKE(L->next, block_len(n, p));
    DKF_TAKE(L->J, n * n);
    DKF_TAKE(L->C, n * n);
    DKF_TAKE(L->T, n * n);
    DKF_TAKE(L->JG, n * p);
    DKF_TAKE(L->IG, n * p);
    DKF_TAKE(L->GSi, n * p);
    DKF_TAKE(L->Sc, p * p);
    DKF_TAKE(L->Si, p * p);
    DKF_TAKE(L->r, n);
    DKF_TAKE(L->Lw, m * m);
    DKF_TAKE(L->RiH, m * n);
    DKF_TAKE(L->Riy, m);
    DKF_TAKE(L->stage, DKF_TW_PKT_LEN(n));
    DKF_TAKE(L->acc, DKF_TW_PKT_LEN(n));
    return used;
}

static layout_t mem_of(const dkf_tw_node_t *nd)
{
    layout_t L;
    (void)layout(&L, nd->priv.mem, nd->n, nd->m_max, nd->p);
    return L;
}

dkf_status_t dkf_tw_node_init(dkf_tw_node_t *nd, size_t n, size_t m_max, size_t p,
                              dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                              const dkf_mat_t *P0)
{
    dkf_tw_node_t g;
    dkf_real_t inv[DKF_MAX_DIM];
    layout_t L;
    committed_t c;
    block_t b;
    size_t total;
    DKF_CHECK_NULL(nd);
    DKF_CHECK_NULL(storage);
    if (n == 0 || p == 0 || m_max == 0 || n > DKF_MAX_DIM || p > DKF_MAX_DIM || m_max > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    if (p > n) return DKF_ERR_RANK;
    total = committed_layout(&c, NULL, n, p) + layout(&L, NULL, n, m_max, p);
    if (storage_len < total) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    memset(&g, 0, sizeof g);
    g.n = n;
    g.p = p;
    g.m_max = m_max;
    g.priv.mem = storage + committed_layout(&c, storage, n, p);
    L = mem_of(&g);
    /* P0 must be SPD. The test factorisation writes into the scratch part
     * of storage only: every caller-visible value is set after it. */
    if (dkf__chol(L.C, inv, P0->data, n) != 0) return DKF_ERR_NOT_SPD;
    memset(storage, 0, total * sizeof *storage);
    dkf__view(&g.x, n, 1, c.x);
    dkf__view(&g.P, n, n, c.P);
    b = block_at(c.blk, n, p);
    dkf__view(&g.d, p, 1, b.d);
    dkf__view(&g.phi, n, 1, b.phi);
    dkf__view(&g.Phi, n, n, b.Phi);
    dkf__view(&g.I, n, n, b.I);
    dkf__view(&g.i, n, 1, b.i);
    dkf__view(&g.phi_post, n, 1, b.phi_post);
    dkf__view(&g.Phi_post, n, n, b.Phi_post);
    dkf__view(&g.S, p, p, b.S);
    dkf__view(&g.Gpost, n, p, b.Gpost);
    dkf__view(&g.psi, n, 1, b.psi);
    dkf__view(&g.Ploc, n, n, b.Ploc);
    dkf__copy(g.x.data, x0->data, n);
    dkf__copy(g.P.data, P0->data, n * n);
    g.priv.ready = 1;
    *nd = g;
    return DKF_OK;
}

/* Builds scale * [H^T R^{-1} y | packed H^T R^{-1} H] in L.stage. */
static dkf_status_t meas_info(dkf_tw_node_t *nd, const layout_t *L, const dkf_kf_meas_t *meas,
                              const dkf_mat_t *y, dkf_real_t scale)
{
    dkf_real_t inv[DKF_MAX_DIM];
    const size_t n = nd->n;
    size_t m, a, b, l, e;
    DKF_CHECK_NULL(meas);
    DKF_TRY(dkf__check_mat(meas->H));
    m = meas->H->rows;
    if (m > nd->m_max) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(meas->H, m, n));
    DKF_TRY(dkf__check_input(meas->R, m, m));
    DKF_TRY(dkf__check_input(y, m, 1));
    if (!dkf__all_finite(&scale, 1)) return DKF_ERR_NONFINITE;
    /* (17), (21) in square-root form: R = Lw Lw^T, W = Lw^{-1} H and
     * w = Lw^{-1} y (in RiH, Riy), H^T R^{-1} H = W^T W (a Gram matrix:
     * PSD up to rounding, which H^T (R^{-1} H) is not for an
     * ill-conditioned R) and H^T R^{-1} y = W^T w */
    if (dkf__chol(L->Lw, inv, meas->R->data, m) != 0) return DKF_ERR_NOT_SPD;
    dkf__whiten(L->RiH, L->Riy, L->Lw, inv, meas->H->data, y->data, m, n);
    e = n;
    for (a = 0; a < n; ++a) {
        dkf_real_t v = DKF_R(0.0);
        for (l = 0; l < m; ++l) v += L->RiH[l * n + a] * L->Riy[l];
        L->stage[a] = scale * v;
        for (b = a; b < n; ++b) {
            dkf_real_t w = DKF_R(0.0);
            for (l = 0; l < m; ++l) w += L->RiH[l * n + a] * L->RiH[l * n + b];
            L->stage[e++] = scale * w;
        }
    }
    if (!dkf__all_finite(L->stage, DKF_TW_PKT_LEN(n))) return DKF_ERR_NONFINITE;
    return DKF_OK;
}

dkf_status_t dkf_tw_meas_packet(dkf_real_t *pkt, dkf_tw_node_t *nd, const dkf_kf_meas_t *meas,
                                const dkf_mat_t *y, dkf_real_t scale)
{
    layout_t L;
    DKF_CHECK_NULL(pkt);
    DKF_CHECK_NULL(nd);
    if (!nd->priv.ready) return DKF_ERR_STATE;
    L = mem_of(nd);
    DKF_TRY(meas_info(nd, &L, meas, y, scale));
    dkf__copy(pkt, L.stage, DKF_TW_PKT_LEN(nd->n));
    return DKF_OK;
}

/* S must be numerically positive definite: a Cholesky pivot below
 * 16 p eps of the largest diagonal entry means rank(H G) < p for the
 * information at hand (S = G^T Pi G is then singular up to rounding). */
static int chol_rank_ok(dkf_real_t *Lc, dkf_real_t *inv, const dkf_real_t *S, size_t p)
{
    dkf_real_t dmax = DKF_R(0.0);
    size_t i;
    if (dkf__chol(Lc, inv, S, p) != 0) return 0;
    for (i = 0; i < p; ++i)
        if (S[i * p + i] > dmax) dmax = S[i * p + i];
    for (i = 0; i < p; ++i)
        if (Lc[i * p + i] * Lc[i * p + i] <= DKF_R(16.0) * (dkf_real_t)p * DKF_REAL_EPSILON * dmax)
            return 0;
    return 1;
}

static dkf_status_t check_model(const dkf_tw_node_t *nd, const dkf_uif_dyn_t *dyn)
{
    DKF_CHECK_NULL(dyn);
    DKF_TRY(dkf__check_input(dyn->F, nd->n, nd->n));
    DKF_TRY(dkf__check_input(dyn->G, nd->n, nd->p));
    return dkf__check_input(dyn->Q, nd->n, nd->n);
}

/* The local step into L->next (see the top of the file). */
static dkf_status_t local_step(dkf_tw_node_t *nd, const layout_t *L, const dkf_uif_dyn_t *dyn,
                               const dkf_real_t *info)
{
    dkf_real_t inv[DKF_MAX_DIM], u[DKF_MAX_DIM];
    const size_t n = nd->n, p = nd->p;
    const block_t b = block_at(L->next, n, p);
    const dkf_real_t *F = dyn->F->data, *G = dyn->G->data;
    size_t i;

    /* unpack the info first: info may live in the caller's est buffer */
    dkf__copy(b.i, info, n);
    dkf__unpack_sym(b.I, info + n, n);

    /* (6a)-(6b): phi- = F x, Phi- = F P F^T + Q */
    dkf__mul_vec(b.phi, F, nd->x.data, n, n);
    dkf__mul_nn(L->T, F, nd->P.data, n, n, n);
    dkf__mul_nt_sym(b.Phi, L->T, F, dyn->Q->data, n, n);
    if (dkf__chol(L->C, inv, b.Phi, n) != 0) return DKF_ERR_NOT_SPD;
    dkf__chol_inverse(L->J, L->C, inv, n);

    /* (10), (7b): Psi = Phi-^{-1} + I, Phi+ = Psi^{-1} */
    for (i = 0; i < n * n; ++i) L->T[i] = L->J[i] + b.I[i];
    if (dkf__chol(L->C, inv, L->T, n) != 0) return DKF_ERR_NOT_SPD;
    dkf__chol_inverse(b.Phi_post, L->C, inv, n);

    /* (14), (17): r = i - I phi- (the summed xi_l);  (20): phi+ = phi- + Phi+ r */
    dkf__mul_vec(L->r, b.I, b.phi, n, n);
    for (i = 0; i < n; ++i) L->r[i] = b.i[i] - L->r[i];
    dkf__mul_vec(b.phi_post, b.Phi_post, L->r, n, n);
    for (i = 0; i < n; ++i) b.phi_post[i] += b.phi[i];

    /* (8a): Gpost = Phi+ (Phi-^{-1} G);  (12): S = Gpost^T (I G), symmetrised */
    dkf__mul_nn(L->JG, L->J, G, n, n, p);
    dkf__mul_nn(b.Gpost, b.Phi_post, L->JG, n, n, p);
    dkf__mul_nn(L->IG, b.I, G, n, n, p);
    dkf__mul_tn(b.S, b.Gpost, L->IG, NULL, n, p, p);
    dkf__symmetrise(b.S, p);
    if (!dkf__all_finite(b.S, p * p)) return DKF_ERR_NONFINITE;
    if (!chol_rank_ok(L->Sc, inv, b.S, p)) return DKF_ERR_RANK;

    /* (18): d = S^{-1} Gpost^T r;  (8b): psi = phi+ + Gpost d */
    dkf__mul_tn(u, b.Gpost, L->r, NULL, n, p, 1);
    dkf__chol_solve(L->Sc, inv, u, p, 1);
    dkf__copy(b.d, u, p);
    dkf__mul_vec(b.psi, b.Gpost, b.d, n, p);
    for (i = 0; i < n; ++i) b.psi[i] += b.phi_post[i];

    /* (8c) corrected: Ploc = Phi+ + Gpost S^{-1} Gpost^T */
    dkf__chol_inverse(L->Si, L->Sc, inv, p);
    dkf__mul_nn(L->GSi, b.Gpost, L->Si, n, p, p);
    dkf__mul_nt_sym(b.Ploc, L->GSi, b.Gpost, b.Phi_post, n, p);

    if (!dkf__all_finite(L->next, block_len(n, p))) return DKF_ERR_NONFINITE;
    return DKF_OK;
}

/* The local step on info into L->next, its arguments checked first. */
static dkf_status_t checked_local_step(dkf_tw_node_t *nd, const layout_t *L,
                                       const dkf_uif_dyn_t *dyn, const dkf_real_t *info)
{
    DKF_CHECK_NULL(info);
    DKF_TRY(check_model(nd, dyn));
    if (!dkf__all_finite(info, DKF_TW_PKT_LEN(nd->n))) return DKF_ERR_NONFINITE;
    return local_step(nd, L, dyn, info);
}

/* The step is formed in L.next and replaces the pending one only once it
 * succeeded: a failure leaves a pending step as it was. */
dkf_status_t dkf_tw_node_local(dkf_tw_node_t *nd, const dkf_uif_dyn_t *dyn, const dkf_real_t *info,
                               dkf_real_t *est)
{
    layout_t L;
    DKF_CHECK_NULL(nd);
    if (!nd->priv.ready) return DKF_ERR_STATE;
    L = mem_of(nd);
    DKF_TRY(checked_local_step(nd, &L, dyn, info));
    dkf__copy(L.pend, L.next, block_len(nd->n, nd->p));
    if (est != NULL) {
        const block_t b = block_at(L.pend, nd->n, nd->p);
        dkf__copy(est, b.psi, nd->n);
        dkf__pack_sym(est + nd->n, b.Ploc, nd->n);
    }
    nd->pending = 1;
    return DKF_OK;
}

/* Checks a commit of the step in blk (L->pend, or L->next) with x and
 * packed P (NULL: the step's own psi, Ploc) and leaves the full P in L->T. */
static dkf_status_t check_commit(const dkf_tw_node_t *nd, const layout_t *L, dkf_real_t *blk,
                                 const dkf_real_t *x, const dkf_real_t *Ppacked)
{
    dkf_real_t inv[DKF_MAX_DIM];
    const size_t n = nd->n;
    const block_t b = block_at(blk, n, nd->p);
    if (x != NULL && !dkf__all_finite(x, n)) return DKF_ERR_NONFINITE;
    if (Ppacked != NULL) {
        if (!dkf__all_finite(Ppacked, n * (n + 1) / 2)) return DKF_ERR_NONFINITE;
        dkf__unpack_sym(L->T, Ppacked, n);
    } else {
        dkf__copy(L->T, b.Ploc, n * n);
    }
    if (dkf__chol(L->C, inv, L->T, n) != 0) return DKF_ERR_NOT_SPD;
    return DKF_OK;
}

/* Commits the step in blk as check_commit left it; no step is pending
 * afterwards. */
static void apply_commit(dkf_tw_node_t *nd, const layout_t *L, dkf_real_t *blk,
                         const dkf_real_t *x)
{
    const size_t n = nd->n;
    const block_t b = block_at(blk, n, nd->p);
    dkf__copy(nd->x.data, x != NULL ? x : b.psi, n);
    dkf__copy(nd->P.data, L->T, n * n);
    dkf__copy(nd->d.data, blk, block_len(n, nd->p));
    nd->pending = 0;
    ++nd->k;
}

dkf_status_t dkf_tw_node_commit(dkf_tw_node_t *nd, const dkf_real_t *x, const dkf_real_t *Ppacked)
{
    layout_t L;
    DKF_CHECK_NULL(nd);
    if (!nd->priv.ready || !nd->pending) return DKF_ERR_STATE;
    L = mem_of(nd);
    DKF_TRY(check_commit(nd, &L, L.pend, x, Ppacked));
    apply_commit(nd, &L, L.pend, x);
    return DKF_OK;
}

dkf_status_t dkf_tw_central_step(dkf_tw_node_t *nd, const dkf_uif_dyn_t *dyn,
                                 const dkf_kf_meas_t meas[], const dkf_mat_t y[], size_t N)
{
    layout_t L;
    size_t l, e, len;
    DKF_CHECK_NULL(nd);
    if (!nd->priv.ready) return DKF_ERR_STATE;
    len = DKF_TW_PKT_LEN(nd->n);
    DKF_CHECK_NULL(meas);
    DKF_CHECK_NULL(y);
    if (N == 0) return DKF_ERR_ARG;
    L = mem_of(nd);
    /* the fusion centre's sums I = sum H^T R^{-1} H (21), i = sum H^T R^{-1} y */
    for (e = 0; e < len; ++e) L.acc[e] = DKF_R(0.0);
    for (l = 0; l < N; ++l) {
        DKF_TRY(meas_info(nd, &L, &meas[l], &y[l], DKF_R(1.0)));
        for (e = 0; e < len; ++e) L.acc[e] += L.stage[e];
    }
    /* the local step and its commit's checks on L.next: a failure leaves
     * the node, and a pending step, as they were; the commit completes the
     * node's step (a pending one is superseded) */
    DKF_TRY(checked_local_step(nd, &L, dyn, L.acc));
    DKF_TRY(check_commit(nd, &L, L.next, NULL, NULL));
    apply_commit(nd, &L, L.next, NULL);
    return DKF_OK;
}

/* ---- whole-graph simulation --------------------------------------------- */

/* The network's storage (DKF_TW_NET_STORAGE_LEN): the N nodes' storage
 * (node l's from node0 + l DKF_TW_NODE_STORAGE_LEN), then three buffers of
 * N packets. With base == NULL it only counts. */
typedef struct {
    dkf_real_t *node0, *out, *mix, *tmp;
} net_layout_t;

static size_t net_layout(net_layout_t *L, dkf_real_t *base, size_t N, size_t n, size_t m_max,
                         size_t p)
{
    size_t used = 0;
    DKF_TAKE(L->node0, N * DKF_TW_NODE_STORAGE_LEN(n, m_max, p));
    DKF_TAKE(L->out, N * DKF_TW_PKT_LEN(n));
    DKF_TAKE(L->mix, N * DKF_TW_PKT_LEN(n));
    DKF_TAKE(L->tmp, N * DKF_TW_PKT_LEN(n));
    return used;
}

dkf_status_t dkf_tw_net_init(dkf_tw_net_t *net, const dkf_graph_t *g, dkf_tw_node_t *nodes,
                             size_t n, size_t m_max, size_t p, dkf_real_t *storage,
                             size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0)
{
    dkf_graph_t chk;
    dkf_tw_net_t t;
    net_layout_t L;
    size_t node_len, l;
    DKF_CHECK_NULL(net);
    DKF_CHECK_NULL(g);
    DKF_CHECK_NULL(nodes);
    DKF_CHECK_NULL(storage);
    DKF_TRY(dkf_graph_init(&chk, g->N, g->start, g->nbr));
    if (n == 0 || p == 0 || m_max == 0 || n > DKF_MAX_DIM || p > DKF_MAX_DIM || m_max > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    if (storage_len < net_layout(&L, NULL, g->N, n, m_max, p)) return DKF_ERR_CAPACITY;
    (void)net_layout(&L, storage, g->N, n, m_max, p);
    node_len = DKF_TW_NODE_STORAGE_LEN(n, m_max, p);
    /* node 0 checks (x0, P0, p <= n); the others cannot fail after it */
    DKF_TRY(dkf_tw_node_init(&nodes[0], n, m_max, p, L.node0, node_len, x0, P0));
    for (l = 1; l < g->N; ++l)
        (void)dkf_tw_node_init(&nodes[l], n, m_max, p, L.node0 + l * node_len, node_len, x0, P0);
    memset(&t, 0, sizeof t);
    t.g = g;
    t.N = g->N;
    t.n = n;
    t.p = p;
    t.nodes = nodes;
    t.priv.out = L.out;
    t.priv.mix = L.mix;
    t.priv.tmp = L.tmp;
    *net = t;
    return DKF_OK;
}

static dkf_status_t check_net(const dkf_tw_net_t *net, const dkf_uif_dyn_t *dyn,
                              const dkf_kf_meas_t meas[], const dkf_mat_t y[])
{
    size_t l;
    DKF_CHECK_NULL(net);
    if (net->nodes == NULL || net->g == NULL) return DKF_ERR_STATE;
    /* a node with a step of its own pending (stepped by hand): a failed
     * step, which cancels the steps it ran, could not give it back */
    for (l = 0; l < net->N; ++l)
        if (net->nodes[l].pending) return DKF_ERR_STATE;
    DKF_CHECK_NULL(meas);
    DKF_CHECK_NULL(y);
    /* only those checks read them, and DKF_DEBUG_CHECKS=0 compiles them out */
    (void)meas;
    (void)y;
    return check_model(&net->nodes[0], dyn);
}

/* Every node's info packet, scaled, into net->priv.out. */
static dkf_status_t all_meas(dkf_tw_net_t *net, const dkf_kf_meas_t meas[], const dkf_mat_t y[],
                             dkf_real_t scale)
{
    const size_t pkt = DKF_TW_PKT_LEN(net->n);
    size_t l;
    for (l = 0; l < net->N; ++l)
        DKF_TRY(dkf_tw_meas_packet(net->priv.out + l * pkt, &net->nodes[l], &meas[l], &y[l],
                                   scale));
    return DKF_OK;
}

/* Local step of every node on its row of `info`, estimate packets to est. */
static dkf_status_t all_local(dkf_tw_net_t *net, const dkf_uif_dyn_t *dyn, const dkf_real_t *info,
                              dkf_real_t *est)
{
    const size_t pkt = DKF_TW_PKT_LEN(net->n);
    size_t l;
    for (l = 0; l < net->N; ++l)
        DKF_TRY(dkf_tw_node_local(&net->nodes[l], dyn, info + l * pkt, est + l * pkt));
    return DKF_OK;
}

/* A failed net step leaves no node pending: the nodes whose local step
 * succeeded before the failure are as they were before the call (none
 * was pending then: check_net). */
static dkf_status_t cancel_all(dkf_tw_net_t *net, dkf_status_t st)
{
    size_t l;
    if (st != DKF_OK)
        for (l = 0; l < net->N; ++l) net->nodes[l].pending = 0;
    return st;
}

/* All commits are checked before any is applied: a failing node leaves
 * every node as it was. x of node l at xs + l * pkt, packed P at
 * Ps + l * pkt (Ps NULL: local P). */
static dkf_status_t commit_all(dkf_tw_net_t *net, const dkf_real_t *xs, const dkf_real_t *Ps)
{
    const size_t pkt = DKF_TW_PKT_LEN(net->n);
    size_t l;
    for (l = 0; l < net->N; ++l) {
        const layout_t L = mem_of(&net->nodes[l]);
        DKF_TRY(check_commit(&net->nodes[l], &L, L.pend, xs + l * pkt,
                             Ps != NULL ? Ps + l * pkt : NULL));
    }
    for (l = 0; l < net->N; ++l) {
        const layout_t L = mem_of(&net->nodes[l]);
        /* check_commit again: it leaves the node's P in its scratch T */
        (void)check_commit(&net->nodes[l], &L, L.pend, xs + l * pkt,
                           Ps != NULL ? Ps + l * pkt : NULL);
        apply_commit(&net->nodes[l], &L, L.pend, xs + l * pkt);
    }
    return DKF_OK;
}

dkf_status_t dkf_tw_net_diffusion_step(dkf_tw_net_t *net, const dkf_real_t *alpha,
                                       const dkf_uif_dyn_t *dyn, const dkf_kf_meas_t meas[],
                                       const dkf_mat_t y[])
{
    size_t pkt;
    DKF_TRY(check_net(net, dyn, meas, y));
    DKF_TRY(dkf_graph_check_row_stochastic(net->g, alpha));
    pkt = DKF_TW_PKT_LEN(net->n);
    /* broadcast 1: info packets; (24c) and the data sum of (25a) over N_l */
    DKF_TRY(all_meas(net, meas, y, DKF_R(1.0)));
    DKF_TRY(dkf_graph_mix_all(net->priv.tmp, net->priv.out, pkt, pkt, net->g, NULL));
    DKF_TRY(cancel_all(net, all_local(net, dyn, net->priv.tmp, net->priv.mix)));
    /* broadcast 2: psi_k (the first n reals of the estimate packet); (26b) */
    DKF_TRY(cancel_all(net, dkf_graph_mix_all(net->priv.out, net->priv.mix, net->n, pkt, net->g,
                                              alpha)));
    DKF_TRY(cancel_all(net, commit_all(net, net->priv.out, NULL)));
    net->reals_sent += (unsigned long)(net->N * (pkt + net->n));
    net->broadcasts += (unsigned long)(2 * net->N);
    ++net->steps;
    return DKF_OK;
}

dkf_status_t dkf_tw_net_consensus_step(dkf_tw_net_t *net, const dkf_real_t *W, size_t eta,
                                       const dkf_uif_dyn_t *dyn, const dkf_kf_meas_t meas[],
                                       const dkf_mat_t y[])
{
    size_t pkt;
    DKF_TRY(check_net(net, dyn, meas, y));
    if (eta > DKF_TW_MAX_ETA) return DKF_ERR_ARG;
    DKF_TRY(dkf_graph_check_doubly_stochastic(net->g, W));
    pkt = DKF_TW_PKT_LEN(net->n);
    /* (32c), (33a): ACF of |N| H^T R^{-1} [y | H], one packet per iteration */
    DKF_TRY(all_meas(net, meas, y, (dkf_real_t)net->N));
    DKF_TRY(dkf_graph_acf(net->priv.out, pkt, net->g, W, eta, net->priv.tmp));
    DKF_TRY(cancel_all(net, all_local(net, dyn, net->priv.out, net->priv.mix)));
    /* (34b)-(34c): ACF of [psi_k | Ploc_k] */
    DKF_TRY(cancel_all(net, dkf_graph_acf(net->priv.mix, pkt, net->g, W, eta, net->priv.tmp)));
    DKF_TRY(cancel_all(net, commit_all(net, net->priv.mix, net->priv.mix + net->n)));
    net->reals_sent += (unsigned long)(net->N * 2 * eta * pkt);
    net->broadcasts += (unsigned long)(net->N * 2 * eta);
    ++net->steps;
    return DKF_OK;
}
