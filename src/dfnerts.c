/*
 * DF-DNERTSIF / DF-CKF (dkf/dfnerts.h): seed 001 Algorithm 3 on top of the
 * single-node phases of dkf/nerts.h, and the joint-information variant.
 * Equation numbers are the paper's; docs/design/infofusion.md has the
 * corrections (the tau = 1 contribution scaled by s, the mixed joint
 * covariance of section 4 item 6).
 */
#include "dkf/dfnerts.h"

#include <string.h>

#include "internal.h"
#include "kernels.h"
#include "nerts_internal.h"

/* Node storage (DKF_DFNERTS_NODE_STORAGE_LEN): the filter's storage (its
 * state first), the current packet, s * contribution, the snapshot of
 * the filter's state, then scratch. With base == NULL it only counts. */
typedef struct {
    dkf_real_t *f, *pkt, *contrib, *snap;
    dkf_real_t *mixed;         /* a round's mix before it is accepted */
    dkf_real_t *A, *Lc, *Pinv; /* q x q: unpacked Y, its factor, its inverse */
    dkf_real_t *Yx;            /* q x q: the x marginal's information (JOINT) */
    dkf_real_t *v, *yx, *inv;  /* q: vectors, the factor's inverse diagonal */
    dkf_real_t *CH, *Wh;       /* m x q: [C Hd], its whitened form */
    dkf_real_t *Lr;            /* m x m: chol(Rbar) */
    dkf_real_t *zt, *w;        /* m: nu + C x_pred, whitened */
} layout_t;

static size_t layout(layout_t *L, dkf_real_t *base, size_t n, size_t m, size_t p)
{
    const size_t q = n + p, pkt = DKF_DFNERTS_PKT_MAX(n, p);
    size_t used = 0;
    DKF_TAKE(L->f, DKF_NERTS_STORAGE_LEN(n, m, p));
    DKF_TAKE(L->pkt, pkt);
    DKF_TAKE(L->contrib, pkt);
    DKF_TAKE(L->snap, DKF_NERTS_STATE_LEN(n, m, p));
    DKF_TAKE(L->mixed, pkt);
    DKF_TAKE(L->A, q * q);
    DKF_TAKE(L->Lc, q * q);
    DKF_TAKE(L->Pinv, q * q);
    DKF_TAKE(L->Yx, q * q);
    DKF_TAKE(L->v, q);
    DKF_TAKE(L->yx, q);
    DKF_TAKE(L->inv, q);
    DKF_TAKE(L->CH, m * q);
    DKF_TAKE(L->Wh, m * q);
    DKF_TAKE(L->Lr, m * m);
    DKF_TAKE(L->zt, m);
    DKF_TAKE(L->w, m);
    return used;
}

static layout_t mem_of(const dkf_dfnerts_node_t *nd)
{
    layout_t L;
    (void)layout(&L, nd->priv.mem, nd->n, nd->m, nd->p);
    return L;
}

static int dims_ok(size_t n, size_t m, size_t p)
{
    return n > 0 && m > 0 && n <= DKF_MAX_DIM && m <= DKF_MAX_DIM && p <= DKF_MAX_DIM &&
           n + p <= DKF_MAX_DIM;
}

/* The checks of dkf_dfnerts_node_init before its filter's: kind,
 * variant, dimensions, storage; *L maps the storage. */
static dkf_status_t check_node_args(layout_t *L, dkf_nerts_kind_t kind,
                                    dkf_dfnerts_variant_t variant, size_t n, size_t m, size_t p,
                                    dkf_real_t *storage, size_t storage_len)
{
    DKF_CHECK_NULL(storage);
    if (kind != DKF_NERTS_NERTSIF && kind != DKF_NERTS_DNERTSIF) return DKF_ERR_ARG;
    if (variant != DKF_DFNERTS_PAPER && variant != DKF_DFNERTS_JOINT) return DKF_ERR_ARG;
    if (!dims_ok(n, m, p)) return DKF_ERR_CAPACITY;
    if (storage_len < layout(L, NULL, n, m, p)) return DKF_ERR_CAPACITY;
    (void)layout(L, storage, n, m, p);
    return DKF_OK;
}

/* Every check of dkf_dfnerts_node_init, its filter's prior included
 * (formed in the storage's scratch); nothing else is written. */
static dkf_status_t check_node_init(dkf_nerts_kind_t kind, dkf_dfnerts_variant_t variant, size_t n,
                                    size_t m, size_t p, dkf_real_t *storage, size_t storage_len,
                                    const dkf_mat_t *x0, const dkf_mat_t *P0,
                                    const dkf_mat_t *d0, const dkf_mat_t *Pd0,
                                    const dkf_mat_t *Pxd0)
{
    layout_t L;
    DKF_TRY(check_node_args(&L, kind, variant, n, m, p, storage, storage_len));
    return dkf__nerts_check_init(kind, n, m, p, L.f, DKF_NERTS_STORAGE_LEN(n, m, p), x0, P0, d0,
                                 Pd0, Pxd0);
}

dkf_status_t dkf_dfnerts_node_init(dkf_dfnerts_node_t *nd, dkf_nerts_kind_t kind,
                                   dkf_dfnerts_variant_t variant, size_t n, size_t m, size_t p,
                                   dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                                   const dkf_mat_t *P0, const dkf_mat_t *d0,
                                   const dkf_mat_t *Pd0, const dkf_mat_t *Pxd0)
{
    layout_t L;
    DKF_CHECK_NULL(nd);
    DKF_TRY(check_node_args(&L, kind, variant, n, m, p, storage, storage_len));
    /* a failed dkf_nerts_init leaves nd->f and the storage's state as they
     * were; nothing fails after it (no copy of the node on the stack: it
     * is ~1 KiB on a Cortex-M) */
    DKF_TRY(dkf_nerts_init(&nd->f, kind, n, m, p, L.f, DKF_NERTS_STORAGE_LEN(n, m, p), x0, P0,
                           d0, Pd0, Pxd0));
    nd->variant = variant;
    nd->n = n;
    nd->m = m;
    nd->p = p;
    nd->q = variant == DKF_DFNERTS_JOINT ? n + p : n;
    nd->pkt_len = DKF_DFNERTS_PKT_LEN(nd->q);
    nd->tau = 0;
    nd->pending = 0;
    nd->scale = DKF_R(0.0);
    nd->pkt = L.pkt;
    nd->priv.mem = storage;
    nd->priv.ready = 1;
    nd->priv.saved = nd->f;
    return DKF_OK;
}

/* The filter back to the snapshot taken by the last local. */
static void restore(dkf_dfnerts_node_t *nd, const layout_t *L)
{
    nd->f = nd->priv.saved;
    dkf__copy(L->f, L->snap, DKF_NERTS_STATE_LEN(nd->n, nd->m, nd->p));
    nd->pending = 0;
    nd->tau = 0;
    nd->scale = DKF_R(0.0);
}

/* JOINT's contribution of z^l, unscaled: J = [C Hd]^T Rbar^{-1} [C Hd]
 * into L->A and j = [C Hd]^T Rbar^{-1} (nu + C x_pred) into L->v, from
 * the staged statistics s, in square-root form (Rbar = Lr Lr^T,
 * Wh = Lr^{-1} [C Hd]: J = Wh^T Wh, a Gram matrix). DKF_ERR_NOT_SPD if
 * Rbar is not. */
static dkf_status_t joint_contribution(const dkf_dfnerts_node_t *nd, const layout_t *L,
                                       const dkf__nerts_staged_t *s)
{
    dkf_real_t inv[DKF_MAX_DIM];
    const size_t n = nd->n, m = nd->m, p = nd->p, q = nd->q;
    size_t r;
    dkf__put_block(L->CH, q, 0, 0, s->C, m, n);
    if (p > 0) dkf__put_block(L->CH, q, 0, n, s->Hd, m, p);
    dkf__mul_vec(L->zt, s->C, s->x_pred, m, n);
    for (r = 0; r < m; ++r) L->zt[r] += s->nu[r];
    if (dkf__chol(L->Lr, inv, s->Rbar, m) != 0) return DKF_ERR_NOT_SPD;
    dkf__whiten(L->Wh, L->w, L->Lr, inv, L->CH, L->zt, m, q);
    dkf__mul_tn(L->A, L->Wh, L->Wh, NULL, m, q, q);
    dkf__mul_tn(L->v, L->Wh, L->w, NULL, m, q, 1);
    return DKF_OK;
}

/* The contribution's vector and matrix (q and q x q): PAPER's i, I
 * (Alg. 3, (56)-(57)), JOINT's j, J (joint_contribution's, in scratch). */
static void contribution_of(const dkf_dfnerts_node_t *nd, const layout_t *L,
                            const dkf__nerts_staged_t *s, const dkf_real_t **cv,
                            const dkf_real_t **CM)
{
    const int joint = nd->variant == DKF_DFNERTS_JOINT;
    *cv = joint ? L->v : s->i;
    *CM = joint ? L->A : s->I;
}

/* 1 if sc times every entry of v (q) and of the upper triangle of A
 * (q x q) is finite: the packet [v | packed A] scaled by sc is. */
static int packet_finite(const dkf_real_t *v, const dkf_real_t *A, size_t q, dkf_real_t sc)
{
    size_t r, c;
    for (r = 0; r < q; ++r) {
        dkf_real_t e = sc * v[r];
        if (!dkf__all_finite(&e, 1)) return 0;
        for (c = r; c < q; ++c) {
            e = sc * A[r * q + c];
            if (!dkf__all_finite(&e, 1)) return 0;
        }
    }
    return 1;
}

/* Every check of the step's packets (JOINT: its contribution formed into
 * scratch): DKF_ERR_NOT_SPD (JOINT's Rbar), DKF_ERR_NONFINITE. Writes
 * neither packet. */
static dkf_status_t check_packets(const dkf_dfnerts_node_t *nd, const layout_t *L,
                                  const dkf__nerts_staged_t *s, dkf_real_t scale)
{
    const dkf_real_t *cv, *CM;
    if (nd->variant == DKF_DFNERTS_JOINT) DKF_TRY(joint_contribution(nd, L, s));
    contribution_of(nd, L, s, &cv, &CM);
    if (!packet_finite(s->y_pred, s->Y_pred, nd->n, DKF_R(1.0)) ||
        !packet_finite(cv, CM, nd->q, scale))
        return DKF_ERR_NONFINITE;
    return DKF_OK;
}

/* The checked packets: the tau = 0 packet pkt = [y_pred | Y_pred]
 * (Alg. 3, Init.; JOINT [y_pred; 0 | blkdiag(Y_pred, 0)], the diagonal
 * block formed in Yx) and contrib = s [i | I] (JOINT s [j | J]). */
static void put_packets(const dkf_dfnerts_node_t *nd, const layout_t *L,
                        const dkf__nerts_staged_t *s, dkf_real_t scale)
{
    const size_t n = nd->n, q = nd->q;
    const dkf_real_t *cv, *CM;
    size_t e;
    contribution_of(nd, L, s, &cv, &CM);
    for (e = 0; e < q * q; ++e) L->Yx[e] = DKF_R(0.0);
    dkf__put_block(L->Yx, q, 0, 0, s->Y_pred, n, n);
    dkf__copy(L->pkt, s->y_pred, n);
    for (e = n; e < q; ++e) L->pkt[e] = DKF_R(0.0);
    dkf__pack_sym(L->pkt + q, L->Yx, q);
    dkf__copy(L->contrib, cv, q);
    dkf__pack_sym(L->contrib + q, CM, q);
    for (e = 0; e < nd->pkt_len; ++e) L->contrib[e] *= scale;
}

/* The step is formed aside (the filter's stage, from the snapshot of the
 * posterior when a step is pending, as if it were cancelled first; the
 * packets' checks in scratch) and written only once every check passed:
 * a failure leaves the node, and a pending step, as they were. */
dkf_status_t dkf_dfnerts_node_local(dkf_dfnerts_node_t *nd, const dkf_nl_model_t *model,
                                    const dkf_real_t *u_prev, const dkf_mat_t *Q,
                                    const dkf_real_t *u, const dkf_mat_t *R, const dkf_mat_t *z,
                                    dkf_real_t scale, dkf_real_t *pkt)
{
    dkf__nerts_staged_t s;
    layout_t L;
    DKF_CHECK_NULL(nd);
    if (!nd->priv.ready) return DKF_ERR_STATE;
    if (!dkf__all_finite(&scale, 1) || !(scale > DKF_R(0.0))) return DKF_ERR_ARG;
    L = mem_of(nd);
    DKF_TRY(dkf__nerts_stage_local(&nd->f, nd->pending ? L.snap : NULL, model, u_prev, Q, u, R,
                                   z, &s));
    DKF_TRY(check_packets(nd, &L, &s, scale));
    /* commit: the snapshot a cancel restores (a pending step's is kept),
     * the filter's new state, the packets */
    if (!nd->pending) {
        nd->priv.saved = nd->f;
        dkf__copy(L.snap, L.f, DKF_NERTS_STATE_LEN(nd->n, nd->m, nd->p));
    }
    put_packets(nd, &L, &s, scale);
    dkf__nerts_commit_stage(&nd->f);
    nd->scale = scale;
    nd->tau = 0;
    nd->pending = 1;
    if (pkt != NULL) dkf__copy(pkt, L.pkt, nd->pkt_len);
    return DKF_OK;
}

/* Accepts a round's mix (in L->mixed): + s contribution at tau = 1
 * (Remark 1), then it becomes the node's packet. */
static dkf_status_t absorb(dkf_dfnerts_node_t *nd, const layout_t *L, dkf_real_t *mixed)
{
    size_t e;
    if (nd->tau == 0)
        for (e = 0; e < nd->pkt_len; ++e) mixed[e] += L->contrib[e];
    if (!dkf__all_finite(mixed, nd->pkt_len)) return DKF_ERR_NONFINITE;
    dkf__copy(L->pkt, mixed, nd->pkt_len);
    ++nd->tau;
    return DKF_OK;
}

dkf_status_t dkf_dfnerts_node_mix(dkf_dfnerts_node_t *nd, const dkf_real_t *const in[],
                                  const dkf_real_t *w, size_t count, dkf_real_t *out)
{
    layout_t L;
    DKF_CHECK_NULL(nd);
    if (!nd->priv.ready || !nd->pending) return DKF_ERR_STATE;
    L = mem_of(nd);
    DKF_TRY(dkf_graph_mix(L.mixed, nd->pkt_len, in, w, count));
    DKF_TRY(absorb(nd, &L, L.mixed));
    if (out != NULL) dkf__copy(out, L.pkt, nd->pkt_len);
    return DKF_OK;
}

/* JOINT commit: P_X = Y_X^{-1}, X = P_X y_X; the blocks into the filter
 * as a commit of dkf/nerts.h would leave them (phase POSTERIOR, k + 1),
 * with its Y = Px^{-1}, y = Y x. Everything is formed in scratch first. */
static dkf_status_t joint_commit(dkf_dfnerts_node_t *nd, const layout_t *L)
{
    dkf_nerts_t *f = &nd->f;
    const size_t n = nd->n, p = nd->p, q = nd->q;
    size_t r, c;
    dkf__unpack_sym(L->A, L->pkt + q, q);
    if (dkf__chol(L->Lc, L->inv, L->A, q) != 0) return DKF_ERR_NOT_SPD;
    dkf__chol_inverse(L->Pinv, L->Lc, L->inv, q);
    dkf__mul_vec(L->v, L->Pinv, L->pkt, q, q);
    if (!dkf__all_finite(L->Pinv, q * q) || !dkf__all_finite(L->v, q)) return DKF_ERR_NONFINITE;
    /* the x marginal's information Px^{-1} (Lc, A reused: n x n) */
    for (r = 0; r < n; ++r)
        for (c = 0; c < n; ++c) L->A[r * n + c] = L->Pinv[r * q + c];
    if (dkf__chol(L->Lc, L->inv, L->A, n) != 0) return DKF_ERR_NOT_SPD;
    dkf__chol_inverse(L->Yx, L->Lc, L->inv, n);
    dkf__mul_vec(L->yx, L->Yx, L->v, n, n);
    if (!dkf__all_finite(L->Yx, n * n) || !dkf__all_finite(L->yx, n)) return DKF_ERR_NONFINITE;
    /* apply */
    dkf__copy(f->x.data, L->v, n);
    dkf__copy(f->Px.data, L->A, n * n);
    for (r = 0; r < n; ++r)
        for (c = 0; c < p; ++c) f->Pxd.data[r * p + c] = L->Pinv[r * q + n + c];
    for (r = 0; r < p; ++r) {
        f->d.data[r] = L->v[n + r];
        for (c = 0; c < p; ++c) f->Pd.data[r * p + c] = L->Pinv[(n + r) * q + n + c];
    }
    dkf__copy(f->Y.data, L->Yx, n * n);
    dkf__copy(f->y.data, L->yx, n);
    f->phase = DKF_NERTS_POSTERIOR;
    ++f->k;
    return DKF_OK;
}

/* The commit without accepting it: the snapshot stays (the network may
 * still undo it). */
static dkf_status_t commit_step(dkf_dfnerts_node_t *nd)
{
    layout_t L;
    if (!nd->priv.ready || !nd->pending || nd->tau == 0) return DKF_ERR_STATE;
    L = mem_of(nd);
    if (nd->variant == DKF_DFNERTS_JOINT) {
        DKF_TRY(joint_commit(nd, &L));
    } else {
        dkf_mat_t Y, y;
        dkf__view(&Y, nd->n, nd->n, L.A);
        dkf__view(&y, nd->n, 1, L.v);
        dkf__unpack_sym(L.A, L.pkt + nd->n, nd->n);
        dkf__copy(L.v, L.pkt, nd->n);
        DKF_TRY(dkf_nerts_commit_info(&nd->f, &Y, &y));
    }
    nd->pending = 0;
    nd->tau = 0;
    nd->scale = DKF_R(0.0);
    return DKF_OK;
}

/* Between steps saved == f, so a failed call leaves the struct as it was. */
dkf_status_t dkf_dfnerts_node_commit(dkf_dfnerts_node_t *nd)
{
    DKF_CHECK_NULL(nd);
    DKF_TRY(commit_step(nd));
    nd->priv.saved = nd->f;
    return DKF_OK;
}

dkf_status_t dkf_dfnerts_node_cancel(dkf_dfnerts_node_t *nd)
{
    layout_t L;
    DKF_CHECK_NULL(nd);
    if (!nd->priv.ready || !nd->pending) return DKF_ERR_STATE;
    L = mem_of(nd);
    restore(nd, &L);
    return DKF_OK;
}

dkf_status_t dkf_dfnerts_node_restart(dkf_dfnerts_node_t *nd, size_t k, const dkf_mat_t *x0,
                                      const dkf_mat_t *P0, const dkf_mat_t *d0,
                                      const dkf_mat_t *Pd0, const dkf_mat_t *Pxd0)
{
    layout_t L;
    DKF_CHECK_NULL(nd);
    if (!nd->priv.ready) return DKF_ERR_STATE;
    L = mem_of(nd);
    /* dkf_nerts_init checks the whole prior before it writes the filter or
     * its state: a refused prior leaves the node, and a pending step, as
     * they were; its success replaces the posterior, which drops the step */
    DKF_TRY(dkf_nerts_init(&nd->f, nd->f.kind, nd->n, nd->m, nd->p, L.f,
                           DKF_NERTS_STORAGE_LEN(nd->n, nd->m, nd->p), x0, P0, d0, Pd0, Pxd0));
    nd->f.k = k;
    nd->priv.saved = nd->f;
    nd->pending = 0;
    nd->tau = 0;
    nd->scale = DKF_R(0.0);
    return DKF_OK;
}

/* The prior of a joining node from a neighbour's packet (dfnerts.h). The
 * views point into scratch that dkf_dfnerts_node_restart does not use. */
dkf_status_t dkf_dfnerts_node_rejoin(dkf_dfnerts_node_t *nd, size_t k, const dkf_real_t *pkt,
                                     const dkf_mat_t *d0, const dkf_mat_t *Pd0)
{
    layout_t L;
    dkf_mat_t x0, P0, dj, Pdj, Pxd0;
    size_t n, p, q, r, c;
    DKF_CHECK_NULL(nd);
    DKF_CHECK_NULL(pkt);
    if (!nd->priv.ready) return DKF_ERR_STATE;
    n = nd->n, p = nd->p, q = nd->q;
    if (nd->variant == DKF_DFNERTS_PAPER && p > 0 && (d0 == NULL || Pd0 == NULL))
        return DKF_ERR_NULL;
    if (!dkf__all_finite(pkt, nd->pkt_len)) return DKF_ERR_NONFINITE;
    L = mem_of(nd);
    /* P_q = Y^{-1}, X = P_q y: the neighbour's information as a prior */
    dkf__unpack_sym(L.A, pkt + q, q);
    if (dkf__chol(L.Lc, L.inv, L.A, q) != 0) return DKF_ERR_NOT_SPD;
    dkf__chol_inverse(L.Pinv, L.Lc, L.inv, q);
    dkf__mul_vec(L.v, L.Pinv, pkt, q, q);
    if (!dkf__all_finite(L.Pinv, q * q) || !dkf__all_finite(L.v, q)) return DKF_ERR_NONFINITE;
    /* the x block (n x n) into A, Pxd into Yx (zero for PAPER), Pd into Lc */
    for (r = 0; r < n; ++r)
        for (c = 0; c < n; ++c) L.A[r * n + c] = L.Pinv[r * q + c];
    for (r = 0; r < n * p; ++r) L.Yx[r] = DKF_R(0.0);
    dkf__view(&x0, n, 1, L.v);
    dkf__view(&P0, n, n, L.A);
    dkf__view(&Pxd0, n, p, L.Yx);
    if (nd->variant == DKF_DFNERTS_JOINT) {
        for (r = 0; r < n; ++r)
            for (c = 0; c < p; ++c) L.Yx[r * p + c] = L.Pinv[r * q + n + c];
        for (r = 0; r < p; ++r)
            for (c = 0; c < p; ++c) L.Lc[r * p + c] = L.Pinv[(n + r) * q + n + c];
        dkf__view(&dj, p, 1, L.v + n);
        dkf__view(&Pdj, p, p, L.Lc);
        d0 = &dj;
        Pd0 = &Pdj;
    }
    return dkf_dfnerts_node_restart(nd, k, &x0, &P0, p > 0 ? d0 : NULL, p > 0 ? Pd0 : NULL,
                                    p > 0 ? &Pxd0 : NULL);
}

/* ---- whole network -------------------------------------------------------- */

/* The network's storage: node l's DKF_DFNERTS_NODE_STORAGE_LEN(n, m[l], p)
 * reals one after another, then the two packet buffers (N x
 * DKF_DFNERTS_PKT_MAX each). 0 if a dimension is out of range or the sum
 * does not fit a size_t. */
size_t dkf_dfnerts_net_storage_len(size_t N, size_t n, const size_t m[], size_t p)
{
    const size_t pkts = 2 * DKF_DFNERTS_PKT_MAX(n, p);
    size_t used = 0, l;
    if (N == 0 || m == NULL) return 0;
    for (l = 0; l < N; ++l) {
        size_t node;
        if (!dims_ok(n, m[l], p)) return 0;
        node = DKF_DFNERTS_NODE_STORAGE_LEN(n, m[l], p) + pkts;
        if (used > (size_t)-1 - node) return 0;
        used += node;
    }
    return used;
}

/* The largest m[l] of N (> 0) nodes. */
static size_t largest(const size_t m[], size_t N)
{
    size_t l, mx = m[0];
    for (l = 1; l < N; ++l)
        if (m[l] > mx) mx = m[l];
    return mx;
}

dkf_status_t dkf_dfnerts_net_init(dkf_dfnerts_net_t *net, const dkf_graph_t *g,
                                  dkf_dfnerts_node_t *nodes, dkf_nerts_kind_t kind,
                                  dkf_dfnerts_variant_t variant, size_t n, const size_t m[],
                                  size_t p, dkf_real_t *storage, size_t storage_len,
                                  const dkf_mat_t x0[], const dkf_mat_t P0[], const dkf_mat_t d0[],
                                  const dkf_mat_t Pd0[], const dkf_mat_t Pxd0[])
{
    dkf_graph_t chk;
    dkf_dfnerts_net_t t;
    dkf_real_t *node_mem;
    size_t need, l;
    DKF_CHECK_NULL(net);
    DKF_CHECK_NULL(g);
    DKF_CHECK_NULL(nodes);
    DKF_CHECK_NULL(m);
    DKF_CHECK_NULL(storage);
    DKF_CHECK_NULL(x0);
    DKF_CHECK_NULL(P0);
    DKF_TRY(dkf_graph_init(&chk, g->N, g->start, g->nbr));
    if (p > 0 && (d0 == NULL || Pd0 == NULL || Pxd0 == NULL)) return DKF_ERR_NULL;
    need = dkf_dfnerts_net_storage_len(g->N, n, m, p);
    if (need == 0 || storage_len < need) return DKF_ERR_CAPACITY;
    for (l = 0; l < g->N; ++l)
        if (m[l] < p) return DKF_ERR_RANK; /* rank Hd = p needs m_l >= p (dkf_nerts_init) */
    /* every node's prior is checked before any node is initialised; the
     * inits cannot fail after that */
    for (l = 0, node_mem = storage; l < g->N; node_mem += DKF_DFNERTS_NODE_STORAGE_LEN(n, m[l], p), ++l)
        DKF_TRY(check_node_init(kind, variant, n, m[l], p, node_mem,
                                DKF_DFNERTS_NODE_STORAGE_LEN(n, m[l], p), &x0[l], &P0[l],
                                p > 0 ? &d0[l] : NULL, p > 0 ? &Pd0[l] : NULL,
                                p > 0 ? &Pxd0[l] : NULL));
    for (l = 0, node_mem = storage; l < g->N; node_mem += DKF_DFNERTS_NODE_STORAGE_LEN(n, m[l], p), ++l)
        (void)dkf_dfnerts_node_init(&nodes[l], kind, variant, n, m[l], p, node_mem,
                                    DKF_DFNERTS_NODE_STORAGE_LEN(n, m[l], p), &x0[l], &P0[l],
                                    p > 0 ? &d0[l] : NULL, p > 0 ? &Pd0[l] : NULL,
                                    p > 0 ? &Pxd0[l] : NULL);
    memset(&t, 0, sizeof t);
    t.g = g;
    t.N = g->N;
    t.n = n;
    t.p = p;
    t.m_max = largest(m, g->N);
    t.nodes = nodes;
    t.priv.cur = node_mem;
    t.priv.nxt = node_mem + g->N * DKF_DFNERTS_PKT_MAX(n, p);
    *net = t;
    return DKF_OK;
}

/* Nodes 0 .. count-1 back to before the step (those committed too). */
static dkf_status_t undo(dkf_dfnerts_net_t *net, size_t count, dkf_status_t st)
{
    size_t l;
    for (l = 0; l < count; ++l) {
        const layout_t L = mem_of(&net->nodes[l]);
        restore(&net->nodes[l], &L);
    }
    return st;
}

/* T_p rounds (61) over the whole graph from the packets in *cur, the
 * other buffer *nxt; the two are swapped per round, so the last round's
 * packets are in *cur on return. */
static dkf_status_t rounds(const dkf_dfnerts_net_t *net, const dkf_real_t *W, size_t Tp,
                           dkf_real_t **cur, dkf_real_t **nxt)
{
    const size_t stride = DKF_DFNERTS_PKT_MAX(net->n, net->p);
    const size_t len = net->nodes[0].pkt_len;
    size_t t, l;
    for (t = 0; t < Tp; ++t) {
        dkf_real_t *sw;
        DKF_TRY(dkf_graph_mix_all(*nxt, *cur, len, stride, net->g, W));
        for (l = 0; l < net->N; ++l) {
            const layout_t L = mem_of(&net->nodes[l]);
            DKF_TRY(absorb(&net->nodes[l], &L, *nxt + l * stride));
        }
        sw = *cur;
        *cur = *nxt;
        *nxt = sw;
    }
    return DKF_OK;
}

dkf_status_t dkf_dfnerts_net_step(dkf_dfnerts_net_t *net, const dkf_nl_model_t models[],
                                  const dkf_real_t *u_prev, const dkf_mat_t Q[],
                                  const dkf_real_t *u, const dkf_mat_t R[], const dkf_mat_t z[],
                                  const dkf_real_t *W, size_t Tp, dkf_real_t scale)
{
    dkf_real_t *cur, *nxt;
    size_t stride, l;
    DKF_CHECK_NULL(net);
    if (net->nodes == NULL || net->g == NULL) return DKF_ERR_STATE;
    /* a node with a step of its own pending (stepped by hand): undo could
     * not give that step back */
    for (l = 0; l < net->N; ++l)
        if (net->nodes[l].pending) return DKF_ERR_STATE;
    DKF_CHECK_NULL(models);
    DKF_CHECK_NULL(Q);
    DKF_CHECK_NULL(R);
    DKF_CHECK_NULL(z);
    if (Tp == 0 || Tp > DKF_DFNERTS_MAX_TP) return DKF_ERR_ARG;
    if (!dkf__all_finite(&scale, 1) || !(scale > DKF_R(0.0))) return DKF_ERR_ARG;
    DKF_TRY(dkf_graph_check_doubly_stochastic(net->g, W));
    stride = DKF_DFNERTS_PKT_MAX(net->n, net->p);
    /* the buffers' roles change per round: net->priv.cur, nxt follow on success */
    cur = net->priv.cur;
    nxt = net->priv.nxt;
    for (l = 0; l < net->N; ++l) {
        const dkf_status_t st = dkf_dfnerts_node_local(&net->nodes[l], &models[l], u_prev, &Q[l],
                                                       u, &R[l], &z[l], scale, cur + l * stride);
        if (st != DKF_OK) return undo(net, l, st);
    }
    {
        const dkf_status_t st = rounds(net, W, Tp, &cur, &nxt);
        if (st != DKF_OK) return undo(net, net->N, st);
    }
    for (l = 0; l < net->N; ++l) {
        const dkf_status_t st = commit_step(&net->nodes[l]);
        if (st != DKF_OK) return undo(net, net->N, st);
    }
    for (l = 0; l < net->N; ++l) net->nodes[l].priv.saved = net->nodes[l].f;
    net->priv.cur = cur;
    net->priv.nxt = nxt;
    net->reals_sent += (unsigned long)(net->N * Tp * net->nodes[0].pkt_len);
    net->broadcasts += (unsigned long)(net->N * Tp);
    ++net->steps;
    return DKF_OK;
}
