/*
 * Distributed Difference KF (dkf/diffkf_fusion.h): the fusion centre that
 * rebuilds the centralized estimate exactly, docs/diffkf-fusion.md and the
 * math note's §6 (not the paper's (30)-(36), which are exact only when the
 * stacked H has full row rank).
 *
 * Per step k and node i (library dimensions: state n, z^i of size p_i):
 *   K^i_k  = J^i_k (L^i_k)^{-1}                                  replica gain
 *   dz^i_k = (K^i_k)^+ (x^i_{k|k} - x^i_{k|k-1})                 (24) solved, cf. (33)
 *   z^i_k  = dz^i_k + M^i_k x^i_{k|k-1} + C^i_k (L^i_{k-1})^{-1} dz^i_{k-1}   (26)/(32)
 * and z_k = [z^1_k; ...; z^l_k] drives one step of the Difference KF on the
 * stacked model (27)-(29). (24) gives x_{k|k} - x_{k|k-1} = K dz exactly, so
 * dz is recovered exactly iff K has full column rank p_i.
 *
 * The replica of node i is the core filter run with the node's own prior
 * covariance: its covariances, gains and the carried C L^{-1} are those of
 * node i. Its x is replaced by the message's x^i_{k|k-1} before each
 * update, so the innovation it computes and carries - the dz^i_{k-1} of the
 * next step's correction term - is the recovered dz^i_k (up to one
 * rounding of z - M x - zcorr) and no x recursion of its own can drift.
 *
 * Degraded steps (docs/diffkf-fusion.md §8): a node's rows enter the
 * central step only if its message is present and its replica carries the
 * true dz^i_{k-1} (sync); the central filter then runs the row-masked
 * Difference KF, the exact estimate given the rows received. Checkpoints
 * and replica restarts support rollback/replay and restarted/late nodes.
 *
 * Atomicity: everything that can fail (replica gains, rank of K^i, the
 * central gain, the updates' overflow checks) runs against snapshots of
 * the replicas and of the central filter (struct and state part of its
 * storage, caches included); a failure restores them.
 */
#include "dkf/diffkf_fusion.h"

#include <string.h>

#include "internal.h"
#include "kernels.h"

/* ---- message ------------------------------------------------------------- */

dkf_status_t dkf_diffkf_msg_fill(dkf_diffkf_msg_t *msg, uint16_t node, const dkf_diffkf_t *f)
{
    DKF_CHECK_NULL(msg);
    DKF_CHECK_NULL(f);
    if (!f->ready || !f->started || f->k == 0) return DKF_ERR_STATE;
#if SIZE_MAX > UINT32_MAX
    if (f->k > (size_t)UINT32_MAX) return DKF_ERR_CAPACITY;
#endif
    memset(msg, 0, sizeof *msg);
    msg->node = node;
    msg->k = (uint32_t)f->k;
    msg->n = (uint16_t)f->n;
    dkf__copy(msg->xf, f->xf.data, f->n);
    dkf__copy(msg->xp, f->xp.data, f->n);
    return DKF_OK;
}

/* ---- stacked model ------------------------------------------------------- */

/* Block (r0, c0) of the rows x cols row-major D = the r x c block S. */
static void put_block(dkf_real_t *D, size_t cols, size_t r0, size_t c0, const dkf_real_t *S,
                      size_t r, size_t c)
{
    size_t i;
    for (i = 0; i < r; ++i) dkf__copy(D + (r0 + i) * cols + c0, S + i * c, c);
}

static dkf_status_t check_out(const dkf_mat_t *X, size_t rows, size_t cols)
{
    return X == NULL ? DKF_OK : dkf__check_shape(X, rows, cols);
}

#if DKF_DEBUG_CHECKS
static int overlaps_any(const dkf_mat_t *X, const dkf_mat_t *Y)
{
    return X != NULL && Y != NULL && dkf__overlap(X, Y);
}
#endif

dkf_status_t dkf_diffkf_stack_meas(dkf_mat_t *H, dkf_mat_t *D, dkf_mat_t *R,
                                   const dkf_ui_meas_t *const meas[], size_t l)
{
    size_t i, n = 0, ms = 0, ps = 0, r0 = 0, c0 = 0;
    DKF_CHECK_NULL(meas);
    if (l == 0 || l > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    for (i = 0; i < l; ++i) {
        const dkf_ui_meas_t *s = meas[i];
        DKF_CHECK_NULL(s);
        DKF_TRY(dkf__check_mat(s->H));
        DKF_TRY(dkf__check_mat(s->D));
        DKF_TRY(dkf__check_mat(s->R));
        if (i == 0) n = s->H->cols;
        if (s->H->cols != n || s->D->rows != s->H->rows ||
            s->R->rows != s->H->rows || s->R->cols != s->H->rows)
            return DKF_ERR_DIM;
        ms += s->H->rows;
        ps += s->D->cols;
    }
    if (ms > DKF_MAX_DIM || ps > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    DKF_TRY(check_out(H, ms, n));
    DKF_TRY(check_out(D, ms, ps));
    DKF_TRY(check_out(R, ms, ms));
#if DKF_DEBUG_CHECKS
    if (overlaps_any(H, D) || overlaps_any(H, R) || overlaps_any(D, R)) return DKF_ERR_ALIAS;
    for (i = 0; i < l; ++i) {
        const dkf_ui_meas_t *s = meas[i];
        if (overlaps_any(H, s->H) || overlaps_any(H, s->D) || overlaps_any(H, s->R) ||
            overlaps_any(D, s->H) || overlaps_any(D, s->D) || overlaps_any(D, s->R) ||
            overlaps_any(R, s->H) || overlaps_any(R, s->D) || overlaps_any(R, s->R))
            return DKF_ERR_ALIAS;
    }
#endif
    if (D != NULL) memset(D->data, 0, ms * ps * sizeof(dkf_real_t));
    if (R != NULL) memset(R->data, 0, ms * ms * sizeof(dkf_real_t));
    for (i = 0; i < l; ++i) {
        const dkf_ui_meas_t *s = meas[i];
        const size_t mi = s->H->rows, pi = s->D->cols;
        if (H != NULL) put_block(H->data, n, r0, 0, s->H->data, mi, n);
        if (D != NULL) put_block(D->data, ps, r0, c0, s->D->data, mi, pi);
        if (R != NULL) put_block(R->data, ms, r0, r0, s->R->data, mi, mi);
        r0 += mi;
        c0 += pi;
    }
    return DKF_OK;
}

dkf_status_t dkf_diffkf_stack_input(dkf_mat_t *B, dkf_mat_t *Rd, const dkf_mat_t *const Bi[],
                                    const dkf_mat_t *const Rdi[], size_t l)
{
    size_t i, ps = 0, c0 = 0;
    if (l == 0 || l > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    if ((B != NULL && Bi == NULL) || (Rd != NULL && Rdi == NULL)) return DKF_ERR_NULL;
    for (i = 0; i < l; ++i) {
        size_t pi = 0;
        if (B != NULL) {
            DKF_TRY(dkf__check_mat(Bi[i]));
            if (Bi[i]->rows != Bi[i]->cols) return DKF_ERR_DIM;
            pi = Bi[i]->rows;
        }
        if (Rd != NULL) {
            DKF_TRY(dkf__check_mat(Rdi[i]));
            if (Rdi[i]->rows != Rdi[i]->cols || (B != NULL && Rdi[i]->rows != pi))
                return DKF_ERR_DIM;
            pi = Rdi[i]->rows;
        }
        ps += pi;
    }
    if (B == NULL && Rd == NULL) return DKF_OK;
    if (ps > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    DKF_TRY(check_out(B, ps, ps));
    DKF_TRY(check_out(Rd, ps, ps));
#if DKF_DEBUG_CHECKS
    if (overlaps_any(B, Rd)) return DKF_ERR_ALIAS;
    for (i = 0; i < l; ++i)
        if ((B != NULL && (dkf__overlap(B, Bi[i]) || (Rd != NULL && dkf__overlap(B, Rdi[i])))) ||
            (Rd != NULL && (dkf__overlap(Rd, Rdi[i]) || (B != NULL && dkf__overlap(Rd, Bi[i])))))
            return DKF_ERR_ALIAS;
#endif
    if (B != NULL) memset(B->data, 0, ps * ps * sizeof(dkf_real_t));
    if (Rd != NULL) memset(Rd->data, 0, ps * ps * sizeof(dkf_real_t));
    for (i = 0; i < l; ++i) {
        const size_t pi = B != NULL ? Bi[i]->rows : Rdi[i]->rows;
        if (B != NULL) put_block(B->data, ps, c0, c0, Bi[i]->data, pi, pi);
        if (Rd != NULL) put_block(Rd->data, ps, c0, c0, Rdi[i]->data, pi, pi);
        c0 += pi;
    }
    return DKF_OK;
}

/* ---- fusion centre: storage ---------------------------------------------- */

static size_t max_sz(size_t a, size_t b) { return a > b ? a : b; }

/* Workspace reals: SVD of K^i (n x p_i) and of D^i (m_i x p_i), LU of B^i
 * (LU + work), Cholesky of a prior (factor + work). */
static size_t work_len_of(size_t n, size_t mi, size_t pi)
{
    size_t w = max_sz(DKF_MAT_PINV_WORK(n, pi), DKF_MAT_RANK_WORK(mi, pi));
    w = max_sz(w, pi * pi + DKF_MAT_LU_WORK(pi));
    return max_sz(w, n * n + DKF_MAT_CHOL_WORK(n));
}

/* Validates the dimensions; on success *ms, *ps, *pmax, *work are set. */
static dkf_status_t check_dims(size_t n, size_t l, const size_t m[], const size_t p[],
                               size_t *ms, size_t *ps, size_t *pmax, size_t *work,
                               dkf_diffkf_fc_fault_t *f)
{
    size_t i;
    *ms = *ps = *pmax = *work = 0;
    if (l == 0 || l > DKF_MAX_DIM || n == 0 || n > DKF_MAX_DIM) {
        if (f) f->which = DKF_DIFFKF_FC_ARG, f->node = DKF_DIFFKF_FC_NO_NODE;
        return DKF_ERR_CAPACITY;
    }
    for (i = 0; i < l; ++i) {
        if (m[i] == 0 || p[i] == 0 || m[i] > DKF_MAX_DIM || p[i] > DKF_MAX_DIM) {
            if (f) f->which = DKF_DIFFKF_FC_ARG, f->node = i;
            return DKF_ERR_CAPACITY;
        }
        if (p[i] > n) {
            if (f) f->which = DKF_DIFFKF_FC_INPUT_DIM, f->node = i;
            return DKF_ERR_RANK;
        }
        if (p[i] > m[i]) {
            if (f) f->which = DKF_DIFFKF_FC_INPUT_MEAS, f->node = i;
            return DKF_ERR_RANK;
        }
        *ms += m[i];
        *ps += p[i];
        *pmax = max_sz(*pmax, p[i]);
        *work = max_sz(*work, work_len_of(n, m[i], p[i]));
    }
    if (*ms > DKF_MAX_DIM || *ps > DKF_MAX_DIM) {
        if (f) f->which = DKF_DIFFKF_FC_STACK_CAPACITY, f->node = DKF_DIFFKF_FC_NO_NODE;
        return DKF_ERR_CAPACITY;
    }
    return DKF_OK;
}

/* Storage order: the state first (dkf_diffkf_fc_state_len: the replicas'
 * storage, the committed z dz, the central filter's storage, whose first
 * DKF_DIFFKF_STATE_LEN reals end the state), then scratch: the replicas'
 * snapshots, the snapshot of the central state, stacked H D R B Rd, the
 * pending z dz, (K^i)^+, work. */
static size_t state_len_of(size_t n, size_t l, const size_t m[], const size_t p[], size_t ms,
                           size_t ps)
{
    size_t i, len = 0;
    for (i = 0; i < l; ++i) len += DKF_DIFFKF_STORAGE_LEN(n, m[i], p[i]);
    return len + 2 * ps + DKF_DIFFKF_STATE_LEN(n, ms, ps);
}

static size_t layout_len(size_t n, size_t l, const size_t m[], const size_t p[], size_t ms,
                         size_t ps, size_t pmax, size_t work)
{
    size_t i, len = 0;
    for (i = 0; i < l; ++i) len += 2 * DKF_DIFFKF_STORAGE_LEN(n, m[i], p[i]);
    len += DKF_DIFFKF_STORAGE_LEN(n, ms, ps) + DKF_DIFFKF_STATE_LEN(n, ms, ps);
    len += ms * n + ms * ps + ms * ms + 2 * ps * ps;
    len += 4 * ps + pmax * n + work;
    return len;
}

size_t dkf_diffkf_fc_storage_len(size_t n, size_t l, const size_t m[], const size_t p[])
{
    size_t ms, ps, pmax, work;
    if (m == NULL || p == NULL) return 0;
    if (check_dims(n, l, m, p, &ms, &ps, &pmax, &work, NULL) != DKF_OK) return 0;
    return layout_len(n, l, m, p, ms, ps, pmax, work);
}

size_t dkf_diffkf_fc_state_len(size_t n, size_t l, const size_t m[], const size_t p[])
{
    size_t ms, ps, pmax, work;
    if (m == NULL || p == NULL) return 0;
    if (check_dims(n, l, m, p, &ms, &ps, &pmax, &work, NULL) != DKF_OK) return 0;
    return state_len_of(n, l, m, p, ms, ps);
}

static dkf_status_t report(dkf_diffkf_fc_fault_t *f, dkf_status_t st, dkf_diffkf_fc_cond_t which,
                           size_t node)
{
    if (f != NULL) {
        f->which = st == DKF_OK ? DKF_DIFFKF_FC_NO_FAULT : which;
        f->node = st == DKF_OK ? DKF_DIFFKF_FC_NO_NODE : node;
    }
    return st;
}

/* ---- fusion centre: set-up ---------------------------------------------- */

dkf_status_t dkf_diffkf_fc_init(dkf_diffkf_fc_t *fc, dkf_diffkf_fc_node_t nodes[], size_t l,
                                size_t n, const size_t m[], const size_t p[], dkf_real_t *storage,
                                size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0,
                                const dkf_mat_t *const P0_local[], dkf_diffkf_fc_fault_t *fault)
{
    const dkf_diffkf_fc_cond_t arg = DKF_DIFFKF_FC_ARG;
    const size_t none = DKF_DIFFKF_FC_NO_NODE;
    size_t ms, ps, pmax, work, i, zoff = 0;
    dkf_real_t *cur, *zs;
    dkf_status_t st;
    dkf_diffkf_fc_t g;
    if (fc == NULL || nodes == NULL || m == NULL || p == NULL || storage == NULL || x0 == NULL ||
        P0 == NULL)
        return report(fault, DKF_ERR_NULL, arg, none);
    st = check_dims(n, l, m, p, &ms, &ps, &pmax, &work, fault);
    if (st != DKF_OK) return st;
    if (storage_len < layout_len(n, l, m, p, ms, ps, pmax, work))
        return report(fault, DKF_ERR_CAPACITY, DKF_DIFFKF_FC_STORAGE, none);
    st = dkf__check_input(x0, n, 1);
    if (st == DKF_OK) st = dkf__check_input(P0, n, n);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, none);

    /* every prior must be SPD before anything is initialised (the work
     * area at the end of storage is the scratch) */
    memset(&g, 0, sizeof g);
    g.n = n;
    g.l = l;
    g.ms = ms;
    g.ps = ps;
    g.work_len = work;
    g.work = storage + layout_len(n, l, m, p, ms, ps, pmax, work) - work;
    for (i = 0; i <= l; ++i) {
        const dkf_mat_t *Pi = i < l && P0_local != NULL && P0_local[i] != NULL ? P0_local[i] : P0;
        dkf_mat_t Lc = DKF_MAT(n, n, g.work);
        st = dkf__check_input(Pi, n, n);
        if (st == DKF_OK) st = dkf_mat_chol(&Lc, Pi, g.work + n * n);
        if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, i < l ? i : none);
    }

    /* the state: replicas, committed z dz, central */
    cur = storage;
    for (i = 0; i < l; ++i) {
        nodes[i].store = cur;
        nodes[i].store_len = DKF_DIFFKF_STORAGE_LEN(n, m[i], p[i]);
        cur += nodes[i].store_len;
    }
    zs = cur;
    memset(zs, 0, 2 * ps * sizeof(dkf_real_t));
    cur += 2 * ps;
    {
        const size_t clen = DKF_DIFFKF_STORAGE_LEN(n, ms, ps);
        /* cannot fail: dimensions, storage and the SPD prior are checked */
        st = dkf_diffkf_init(&g.central, n, ms, ps, cur, clen, x0, P0);
        if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, none);
        g.central_store = cur;
        cur += clen;
    }
    /* scratch */
    for (i = 0; i < l; ++i) {
        nodes[i].saved_store = cur;
        cur += nodes[i].store_len;
    }
    g.central_snap = cur, cur += DKF_DIFFKF_STATE_LEN(n, ms, ps);
    g.H.rows = ms, g.H.cols = n, g.H.data = cur, cur += ms * n;
    g.D.rows = ms, g.D.cols = ps, g.D.data = cur, cur += ms * ps;
    g.R.rows = ms, g.R.cols = ms, g.R.data = cur, cur += ms * ms;
    g.B.rows = ps, g.B.cols = ps, g.B.data = cur, cur += ps * ps;
    g.Rd.rows = ps, g.Rd.cols = ps, g.Rd.data = cur, cur += ps * ps;
    g.pend = cur;
    memset(cur, 0, 2 * ps * sizeof(dkf_real_t));
    cur += 2 * ps; /* pending z, dz */
    for (i = 0; i < l; ++i) {
        const dkf_mat_t *Pi = P0_local != NULL && P0_local[i] != NULL ? P0_local[i] : P0;
        st = dkf_diffkf_init(&nodes[i].rep, n, m[i], p[i], nodes[i].store, nodes[i].store_len, x0,
                             Pi);
        if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, i);
        nodes[i].m = m[i];
        nodes[i].p = p[i];
        nodes[i].z.rows = p[i], nodes[i].z.cols = 1, nodes[i].z.data = zs + zoff;
        nodes[i].dz.rows = p[i], nodes[i].dz.cols = 1, nodes[i].dz.data = zs + ps + zoff;
        zoff += p[i];
        nodes[i].sync = 1; /* the first step has no previous innovation */
        nodes[i].saved = nodes[i].rep;
    }
    g.Kp = cur;
    g.nodes = nodes;
    g.ready = 1;
    *fc = g;
    return report(fault, DKF_OK, DKF_DIFFKF_FC_NO_FAULT, none);
}

/* ---- fusion centre: snapshots -------------------------------------------- */

static void save_replicas(dkf_diffkf_fc_t *fc)
{
    size_t i;
    for (i = 0; i < fc->l; ++i) {
        dkf_diffkf_fc_node_t *nd = &fc->nodes[i];
        nd->saved = nd->rep;
        memcpy(nd->saved_store, nd->store, nd->store_len * sizeof(dkf_real_t));
    }
}

static void restore_replicas(dkf_diffkf_fc_t *fc)
{
    size_t i;
    for (i = 0; i < fc->l; ++i) {
        dkf_diffkf_fc_node_t *nd = &fc->nodes[i];
        nd->rep = nd->saved;
        memcpy(nd->store, nd->saved_store, nd->store_len * sizeof(dkf_real_t));
    }
}

/* After a successful call the snapshot structs equal the replicas, so a
 * later failed call (snapshot, fail, restore) leaves the node array
 * bit-identical, not just the replicas. */
static void refresh_saved(dkf_diffkf_fc_t *fc)
{
    size_t i;
    for (i = 0; i < fc->l; ++i) fc->nodes[i].saved = fc->nodes[i].rep;
}

static size_t central_state_len(const dkf_diffkf_fc_t *fc)
{
    return DKF_DIFFKF_STATE_LEN(fc->n, fc->ms, fc->ps);
}

/* Snapshots of everything a call may change before it can fail: the
 * replicas, the central filter's struct and the state part of its storage
 * (a successful central gain commits its caches of A^+, B^{-1} and the
 * model block, which a later failure must take back too). */
static void save_state(dkf_diffkf_fc_t *fc, dkf_diffkf_t *central_saved)
{
    save_replicas(fc);
    *central_saved = fc->central;
    dkf__copy(fc->central_snap, fc->central_store, central_state_len(fc));
}

/* Restores what save_state saved and reports the failure. */
static dkf_status_t roll_back(dkf_diffkf_fc_t *fc, const dkf_diffkf_t *central_saved,
                              dkf_diffkf_fc_fault_t *fault, dkf_status_t st,
                              dkf_diffkf_fc_cond_t which, size_t node)
{
    restore_replicas(fc);
    fc->central = *central_saved;
    dkf__copy(fc->central_store, fc->central_snap, central_state_len(fc));
    return report(fault, st, which, node);
}

/* The fault a failed core call (start, gain, update) stands for. */
static dkf_diffkf_fc_cond_t cond_of(dkf_status_t st)
{
    switch (st) {
    case DKF_ERR_RANK: return DKF_DIFFKF_FC_D_RANK;
    case DKF_ERR_SINGULAR: return DKF_DIFFKF_FC_B_SINGULAR;
    case DKF_ERR_NOT_SPD: return DKF_DIFFKF_FC_L_NOT_SPD;
    case DKF_ERR_NONFINITE: return DKF_DIFFKF_FC_NONFINITE;
    default: return DKF_DIFFKF_FC_MODEL;
    }
}

/* ---- fusion centre: model checks and stacking ---------------------------- */

/* Shapes and finiteness of sensor i's matrices; B/Rd only when wanted. */
static dkf_status_t check_sensor(const dkf_diffkf_fc_t *fc, size_t i, const dkf_diffkf_sensor_t *s,
                                 int want_rd)
{
    const size_t n = fc->n, mi = fc->nodes[i].m, pi = fc->nodes[i].p;
    DKF_TRY(dkf__check_input(s->meas.H, mi, n));
    DKF_TRY(dkf__check_input(s->meas.D, mi, pi));
    DKF_TRY(dkf__check_input(s->meas.R, mi, mi));
    DKF_TRY(dkf__check_input(s->B, pi, pi));
    if (want_rd) DKF_TRY(dkf__check_input(s->Rd, pi, pi));
    return DKF_OK;
}

static dkf_status_t check_sensors(const dkf_diffkf_fc_t *fc, const dkf_diffkf_sensor_t sensors[],
                                  int want_rd, dkf_diffkf_fc_fault_t *fault)
{
    size_t i;
    for (i = 0; i < fc->l; ++i) {
        const dkf_status_t st = check_sensor(fc, i, &sensors[i], want_rd);
        if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, i);
    }
    return DKF_OK;
}

/* fc->H, D, R (and B, Rd when want_input) from the sensors' models. */
static dkf_status_t stack_model(dkf_diffkf_fc_t *fc, const dkf_diffkf_sensor_t sensors[],
                                int want_input)
{
    const dkf_ui_meas_t *meas[DKF_MAX_DIM];
    const dkf_mat_t *Bi[DKF_MAX_DIM], *Rdi[DKF_MAX_DIM];
    size_t i;
    for (i = 0; i < fc->l; ++i) {
        meas[i] = &sensors[i].meas;
        Bi[i] = sensors[i].B;
        Rdi[i] = sensors[i].Rd;
    }
    DKF_TRY(dkf_diffkf_stack_meas(&fc->H, &fc->D, &fc->R, meas, fc->l));
    if (want_input) DKF_TRY(dkf_diffkf_stack_input(&fc->B, &fc->Rd, Bi, Rdi, fc->l));
    return DKF_OK;
}

/* The set-up conditions on sensor i's model at one time: D^i of full
 * column rank (rank by SVD with the library's default tolerance) and B^i
 * nonsingular (LU pivot test of dkf_mat_lu). */
static dkf_status_t check_ranks(dkf_diffkf_fc_t *fc, const dkf_diffkf_sensor_t sensors[],
                                dkf_diffkf_fc_fault_t *fault)
{
    size_t i, rank = 0, piv[DKF_MAX_DIM];
    dkf_status_t st;
    for (i = 0; i < fc->l; ++i) {
        const size_t pi = fc->nodes[i].p;
        dkf_mat_t LU = DKF_MAT(pi, pi, fc->work);
        st = dkf_mat_rank(&rank, sensors[i].meas.D, DKF_RANK_TOL_DEFAULT, fc->work);
        if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, i);
        if (rank != pi) return report(fault, DKF_ERR_RANK, DKF_DIFFKF_FC_D_RANK, i);
        st = dkf_mat_lu(&LU, piv, sensors[i].B, fc->work + pi * pi);
        if (st == DKF_ERR_SINGULAR)
            return report(fault, DKF_ERR_SINGULAR, DKF_DIFFKF_FC_B_SINGULAR, i);
        if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, i);
    }
    return DKF_OK;
}

/* ---- fusion centre: start and step --------------------------------------- */

dkf_status_t dkf_diffkf_fc_start(dkf_diffkf_fc_t *fc, const dkf_mat_t *F0, const dkf_mat_t *Q0,
                                 const dkf_diffkf_sensor_t sensors[], dkf_diffkf_fc_fault_t *fault)
{
    const size_t none = DKF_DIFFKF_FC_NO_NODE;
    dkf_diffkf_t central_saved;
    dkf_ui_meas_t cmeas;
    dkf_status_t st;
    size_t i;
    if (fc == NULL || sensors == NULL) return report(fault, DKF_ERR_NULL, DKF_DIFFKF_FC_ARG, none);
    if (!fc->ready || fc->started)
        return report(fault, DKF_ERR_STATE, DKF_DIFFKF_FC_SEQUENCE, none);
    st = dkf__check_input(F0, fc->n, fc->n);
    if (st == DKF_OK) st = dkf__check_input(Q0, fc->n, fc->n);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, none);
    DKF_TRY(check_sensors(fc, sensors, 0, fault));
    DKF_TRY(check_ranks(fc, sensors, fault));
    st = stack_model(fc, sensors, 0);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, none);
    cmeas.H = &fc->H;
    cmeas.D = &fc->D;
    cmeas.R = &fc->R;

    save_state(fc, &central_saved);
    for (i = 0; i < fc->l; ++i) {
        st = dkf_diffkf_start(&fc->nodes[i].rep, F0, Q0, &sensors[i].meas, NULL);
        if (st != DKF_OK) return roll_back(fc, &central_saved, fault, st, cond_of(st), i);
    }
    st = dkf_diffkf_start(&fc->central, F0, Q0, &cmeas, NULL);
    if (st != DKF_OK) return roll_back(fc, &central_saved, fault, st, cond_of(st), none);
    refresh_saved(fc);
    fc->started = 1;
    fc->k = 0;
    return report(fault, DKF_OK, DKF_DIFFKF_FC_NO_FAULT, none);
}

/* Message checks of the present nodes, in the order node, step,
 * dimension, finiteness. */
static dkf_status_t check_msgs(const dkf_diffkf_fc_t *fc, const dkf_diffkf_msg_t msgs[],
                               const unsigned char present[], dkf_diffkf_fc_fault_t *fault)
{
    size_t i;
    for (i = 0; i < fc->l; ++i) {
        const dkf_diffkf_msg_t *g = &msgs[i];
        if (present != NULL && present[i] == 0) continue;
        if ((size_t)g->node != i) return report(fault, DKF_ERR_ARG, DKF_DIFFKF_FC_MSG_NODE, i);
        if ((size_t)g->k != fc->k + 1)
            return report(fault, DKF_ERR_STATE, DKF_DIFFKF_FC_MSG_STEP, i);
        if ((size_t)g->n != fc->n) return report(fault, DKF_ERR_DIM, DKF_DIFFKF_FC_MSG_DIM, i);
        if (!dkf__all_finite(g->xf, fc->n) || !dkf__all_finite(g->xp, fc->n))
            return report(fault, DKF_ERR_NONFINITE, DKF_DIFFKF_FC_MSG_NONFINITE, i);
    }
    return DKF_OK;
}

/* Replica i's gain of step k, then the recovered innovation and datum
 *   dz = K^+ (x_{k|k} - x_{k|k-1}),  z = dz + M x_{k|k-1} + zcorr
 * into dz, z (p_i each). DKF_ERR_RANK (K_RANK) if rank K < p_i. Without a
 * message (msg NULL) only the gain runs, and z = dz = 0. */
static dkf_status_t recover_node(dkf_diffkf_fc_t *fc, size_t i, const dkf_mat_t *F,
                                 const dkf_mat_t *Q, const dkf_diffkf_sensor_t *s,
                                 const dkf_diffkf_msg_t *msg, dkf_real_t *z, dkf_real_t *dz,
                                 dkf_diffkf_fc_cond_t *which)
{
    dkf_diffkf_fc_node_t *nd = &fc->nodes[i];
    const size_t n = fc->n, pi = nd->p;
    dkf_real_t diff[DKF_MAX_DIM], Mx[DKF_MAX_DIM];
    dkf_mat_t M, K, zc, Kp = DKF_MAT(pi, n, fc->Kp);
    dkf_ui_dyn_t dyn;
    size_t rank = 0, j;
    dkf_status_t st;
    dyn.F = F;
    dyn.Q = Q;
    dyn.B = s->B;
    dyn.Rd = s->Rd;
    st = dkf_diffkf_gain(&nd->rep, &dyn, &s->meas);
    if (st != DKF_OK) {
        *which = cond_of(st);
        return st;
    }
    if (msg == NULL) {
        memset(z, 0, pi * sizeof *z);
        memset(dz, 0, pi * sizeof *dz);
        return DKF_OK;
    }
    DKF_TRY(dkf_diffkf_pending(&nd->rep, &M, &K, &zc));
    /* rank K = p_i is exactly the condition for (24) to determine dz */
    st = dkf_mat_pinv(&Kp, &rank, &K, DKF_RANK_TOL_DEFAULT, fc->work);
    if (st == DKF_OK && rank != pi) st = DKF_ERR_RANK;
    if (st != DKF_OK) {
        *which = st == DKF_ERR_RANK ? DKF_DIFFKF_FC_K_RANK : cond_of(st);
        return st;
    }
    for (j = 0; j < n; ++j) diff[j] = msg->xf[j] - msg->xp[j];
    dkf__mul_vec(dz, fc->Kp, diff, pi, n);
    dkf__mul_vec(Mx, M.data, msg->xp, pi, n);
    for (j = 0; j < pi; ++j) z[j] = dz[j] + Mx[j] + zc.data[j];
    if (!dkf__all_finite(z, pi) || !dkf__all_finite(dz, pi)) {
        *which = DKF_DIFFKF_FC_NONFINITE;
        return DKF_ERR_NONFINITE;
    }
    return DKF_OK;
}

/* Replica i completes its step. With a message, from the node's
 * x_{k|k-1} and the recovered z^i_k, so the innovation it carries into
 * step k+1 is the recovered dz^i_k. Without one, from x = 0 and the datum
 * z = zcorr (dz = 0): only its data-independent recursion matters until it
 * is in sync again, and zeros cannot overflow however long the gap. */
static dkf_status_t complete_replica(dkf_diffkf_fc_node_t *nd, size_t n,
                                     const dkf_diffkf_msg_t *msg, dkf_real_t *z)
{
    dkf_mat_t zi = DKF_MAT(nd->p, 1, z);
    if (msg != NULL) {
        dkf__copy(nd->rep.xn.data, msg->xp, n);
    } else {
        DKF_TRY(dkf_diffkf_pending(&nd->rep, NULL, NULL, &zi));
        memset(nd->rep.xn.data, 0, n * sizeof(dkf_real_t));
    }
    return dkf_diffkf_update_z(&nd->rep, &zi, NULL);
}

dkf_status_t dkf_diffkf_fc_step_partial(dkf_diffkf_fc_t *fc, const dkf_mat_t *F, const dkf_mat_t *Q,
                                        const dkf_diffkf_sensor_t sensors[],
                                        const dkf_diffkf_msg_t msgs[], const unsigned char present[],
                                        unsigned char contributed[], dkf_diffkf_fc_fault_t *fault)
{
    const size_t none = DKF_DIFFKF_FC_NO_NODE;
    dkf_diffkf_t central_saved;
    dkf_diffkf_fc_cond_t which = DKF_DIFFKF_FC_MODEL;
    dkf_ui_meas_t cmeas;
    dkf_ui_dyn_t cdyn;
    dkf_real_t *zs, *zt, *dzt, zk[DKF_MAX_DIM];
    unsigned char here[DKF_MAX_DIM], contrib[DKF_MAX_DIM], rows[DKF_MAX_DIM];
    dkf_mat_t zv;
    dkf_status_t st;
    size_t i, j, off, pk = 0, nhere = 0;
    if (fc == NULL || sensors == NULL) return report(fault, DKF_ERR_NULL, DKF_DIFFKF_FC_ARG, none);
    if (!fc->ready || !fc->started)
        return report(fault, DKF_ERR_STATE, DKF_DIFFKF_FC_SEQUENCE, none);
    for (i = 0; i < fc->l; ++i) {
        here[i] = (unsigned char)(present == NULL || present[i] != 0);
        nhere += here[i];
    }
    if (msgs == NULL && nhere > 0) return report(fault, DKF_ERR_NULL, DKF_DIFFKF_FC_ARG, none);
    if (nhere > 0) DKF_TRY(check_msgs(fc, msgs, here, fault));
    st = dkf__check_input(F, fc->n, fc->n);
    if (st == DKF_OK) st = dkf__check_input(Q, fc->n, fc->n);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, none);
    DKF_TRY(check_sensors(fc, sensors, 1, fault));
    st = stack_model(fc, sensors, 1);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, none);
    zs = fc->nodes[0].z.data; /* committed z, dz */
    zt = fc->pend;            /* pending z, dz */
    dzt = fc->pend + fc->ps;
    /* the sync rule: z^i_k needs the true dz^i_{k-1} (its zcorr) */
    for (i = 0, off = 0; i < fc->l; off += fc->nodes[i].p, ++i) {
        contrib[i] = (unsigned char)(here[i] && fc->nodes[i].sync);
        for (j = 0; j < fc->nodes[i].p; ++j) rows[off + j] = contrib[i];
    }

    save_state(fc, &central_saved);
    for (i = 0, off = 0; i < fc->l; off += fc->nodes[i].p, ++i) {
        st = recover_node(fc, i, F, Q, &sensors[i], here[i] ? &msgs[i] : NULL, zt + off, dzt + off,
                          &which);
        if (st != DKF_OK) return roll_back(fc, &central_saved, fault, st, which, i);
    }
    /* the centralized Difference KF on the stacked model (27)-(29), on the
     * rows received */
    cdyn.F = F;
    cdyn.Q = Q;
    cdyn.B = &fc->B;
    cdyn.Rd = &fc->Rd;
    cmeas.H = &fc->H;
    cmeas.D = &fc->D;
    cmeas.R = &fc->R;
    st = dkf_diffkf_gain_masked(&fc->central, &cdyn, &cmeas, rows);
    if (st != DKF_OK) return roll_back(fc, &central_saved, fault, st, cond_of(st), none);

    for (i = 0, off = 0; i < fc->l; off += fc->nodes[i].p, ++i) {
        st = complete_replica(&fc->nodes[i], fc->n, here[i] ? &msgs[i] : NULL, zt + off);
        if (st != DKF_OK) return roll_back(fc, &central_saved, fault, st, cond_of(st), i);
    }
    for (i = 0; i < fc->ps; ++i)
        if (rows[i]) zk[pk++] = zt[i];
    zv.rows = pk;
    zv.cols = 1;
    zv.data = zk;
    st = dkf_diffkf_update_z(&fc->central, pk > 0 ? &zv : NULL, NULL);
    if (st != DKF_OK) return roll_back(fc, &central_saved, fault, st, cond_of(st), none);

    /* an absent node's replica z was its own zcorr: report zeros */
    for (i = 0, off = 0; i < fc->l; off += fc->nodes[i].p, ++i)
        if (!here[i]) memset(zt + off, 0, fc->nodes[i].p * sizeof(dkf_real_t));
    dkf__copy(zs, zt, 2 * fc->ps);
    for (i = 0; i < fc->l; ++i) {
        fc->nodes[i].sync = here[i];
        if (contributed != NULL) contributed[i] = contrib[i];
    }
    refresh_saved(fc);
    fc->k += 1;
    return report(fault, DKF_OK, DKF_DIFFKF_FC_NO_FAULT, none);
}

dkf_status_t dkf_diffkf_fc_step(dkf_diffkf_fc_t *fc, const dkf_mat_t *F, const dkf_mat_t *Q,
                                const dkf_diffkf_sensor_t sensors[], const dkf_diffkf_msg_t msgs[],
                                dkf_diffkf_fc_fault_t *fault)
{
    const size_t none = DKF_DIFFKF_FC_NO_NODE;
    if (msgs == NULL) return report(fault, DKF_ERR_NULL, DKF_DIFFKF_FC_ARG, none);
    return dkf_diffkf_fc_step_partial(fc, F, Q, sensors, msgs, NULL, NULL, fault);
}

/* ---- degraded operation: restarts and checkpoints -------------------------- */

dkf_status_t dkf_diffkf_fc_restart_node(dkf_diffkf_fc_t *fc, size_t node, size_t k_start,
                                        const dkf_mat_t *P_prior,
                                        const dkf_diffkf_sensor_t *sensor_at_kstart,
                                        dkf_diffkf_fc_fault_t *fault)
{
    const size_t none = DKF_DIFFKF_FC_NO_NODE;
    dkf_real_t x0s[DKF_MAX_DIM];
    dkf_diffkf_fc_node_t *nd;
    dkf_mat_t x0, Lc;
    size_t rank = 0;
    dkf_status_t st;
    if (fc == NULL || P_prior == NULL || sensor_at_kstart == NULL)
        return report(fault, DKF_ERR_NULL, DKF_DIFFKF_FC_ARG, none);
    if (!fc->ready || !fc->started)
        return report(fault, DKF_ERR_STATE, DKF_DIFFKF_FC_SEQUENCE, none);
    if (node >= fc->l) return report(fault, DKF_ERR_ARG, DKF_DIFFKF_FC_ARG, none);
    if (k_start != fc->k + 1) return report(fault, DKF_ERR_STATE, DKF_DIFFKF_FC_SEQUENCE, node);
    nd = &fc->nodes[node];
    Lc.rows = fc->n, Lc.cols = fc->n, Lc.data = fc->work;
    st = dkf__check_input(P_prior, fc->n, fc->n);
    if (st == DKF_OK) st = dkf_mat_chol(&Lc, P_prior, fc->work + fc->n * fc->n);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, node);
    st = dkf__check_input(sensor_at_kstart->meas.H, nd->m, fc->n);
    if (st == DKF_OK) st = dkf__check_input(sensor_at_kstart->meas.D, nd->m, nd->p);
    if (st == DKF_OK) st = dkf__check_input(sensor_at_kstart->meas.R, nd->m, nd->m);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, node);
    st = dkf_mat_rank(&rank, sensor_at_kstart->meas.D, DKF_RANK_TOL_DEFAULT, fc->work);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, node);
    if (rank != nd->p) return report(fault, DKF_ERR_RANK, DKF_DIFFKF_FC_D_RANK, node);

    /* as the node: init (its x prior is irrelevant: the replica's x is the
     * message's) and a start at k_start with no previous innovation */
    memset(x0s, 0, sizeof x0s);
    x0.rows = fc->n, x0.cols = 1, x0.data = x0s;
    nd->saved = nd->rep;
    memcpy(nd->saved_store, nd->store, nd->store_len * sizeof(dkf_real_t));
    st = dkf_diffkf_init(&nd->rep, fc->n, nd->m, nd->p, nd->store, nd->store_len, &x0, P_prior);
    if (st == DKF_OK) st = dkf_diffkf_start(&nd->rep, NULL, NULL, &sensor_at_kstart->meas, NULL);
    if (st != DKF_OK) {
        nd->rep = nd->saved;
        memcpy(nd->store, nd->saved_store, nd->store_len * sizeof(dkf_real_t));
        return report(fault, st, cond_of(st), node);
    }
    nd->saved = nd->rep;
    nd->sync = 1;
    return report(fault, DKF_OK, DKF_DIFFKF_FC_NO_FAULT, none);
}

/* FC checkpoint header (reals, small integers): tag, n, l, sum m_i,
 * sum p_i, k as four 16-bit digits (least significant first), started. */
#define FC_CKPT_TAG 17987 /* "FC" */
#define FC_CKPT_HEAD 10

size_t dkf_diffkf_fc_checkpoint_len(const dkf_diffkf_fc_t *fc)
{
    size_t i, len;
    if (fc == NULL || !fc->ready) return 0;
    len = FC_CKPT_HEAD + dkf_diffkf_checkpoint_len(&fc->central) + fc->l + 2 * fc->ps;
    for (i = 0; i < fc->l; ++i) len += dkf_diffkf_checkpoint_len(&fc->nodes[i].rep);
    return len;
}

dkf_status_t dkf_diffkf_fc_save(const dkf_diffkf_fc_t *fc, dkf_real_t *buf, size_t len)
{
    size_t i, k, off = FC_CKPT_HEAD;
    DKF_CHECK_NULL(fc);
    DKF_CHECK_NULL(buf);
    if (!fc->ready) return DKF_ERR_STATE;
    if (len < dkf_diffkf_fc_checkpoint_len(fc)) return DKF_ERR_CAPACITY;
    buf[0] = (dkf_real_t)FC_CKPT_TAG;
    buf[1] = (dkf_real_t)fc->n;
    buf[2] = (dkf_real_t)fc->l;
    buf[3] = (dkf_real_t)fc->ms;
    buf[4] = (dkf_real_t)fc->ps;
    for (i = 0, k = fc->k; i < 4; ++i, k = (k >> 8) >> 8) buf[5 + i] = (dkf_real_t)(k & 0xFFFFu);
    buf[9] = (dkf_real_t)(fc->started ? 1 : 0);
    DKF_TRY(dkf_diffkf_save(&fc->central, buf + off, len - off));
    off += dkf_diffkf_checkpoint_len(&fc->central);
    for (i = 0; i < fc->l; ++i) {
        DKF_TRY(dkf_diffkf_save(&fc->nodes[i].rep, buf + off, len - off));
        off += dkf_diffkf_checkpoint_len(&fc->nodes[i].rep);
    }
    for (i = 0; i < fc->l; ++i) buf[off++] = (dkf_real_t)(fc->nodes[i].sync ? 1 : 0);
    dkf__copy(buf + off, fc->nodes[0].z.data, 2 * fc->ps);
    return DKF_OK;
}

/* 1 if x is the integer v (v < 2^16: exact in any real type). */
static int is_int(dkf_real_t x, size_t v)
{
    return x == (dkf_real_t)v;
}

/* The header's k, or DKF_ERR_ARG if a digit is not an integer in
 * [0, 2^16), DKF_ERR_CAPACITY if k does not fit in size_t. */
static dkf_status_t header_k(const dkf_real_t *d, size_t *k)
{
    size_t i, v = 0;
    for (i = 4; i-- > 0;) {
        const dkf_real_t x = d[i];
        if (!(x >= DKF_R(0.0) && x < DKF_R(65536.0)) || x != (dkf_real_t)(size_t)x)
            return DKF_ERR_ARG;
#if SIZE_MAX <= 0xFFFFFFFFu
        if (i >= 2 && x != DKF_R(0.0)) return DKF_ERR_CAPACITY;
#endif
        v = ((v << 8) << 8) + (size_t)x;
    }
    *k = v;
    return DKF_OK;
}

dkf_status_t dkf_diffkf_fc_restore(dkf_diffkf_fc_t *fc, const dkf_real_t *buf, size_t len)
{
    size_t i, k = 0, off = FC_CKPT_HEAD;
    DKF_CHECK_NULL(fc);
    DKF_CHECK_NULL(buf);
    if (!fc->ready) return DKF_ERR_STATE;
    if (len < dkf_diffkf_fc_checkpoint_len(fc)) return DKF_ERR_CAPACITY;
    /* validate everything before writing anything */
    if (!is_int(buf[0], FC_CKPT_TAG)) return DKF_ERR_ARG;
    if (!is_int(buf[1], fc->n) || !is_int(buf[2], fc->l) || !is_int(buf[3], fc->ms) ||
        !is_int(buf[4], fc->ps))
        return DKF_ERR_DIM;
    DKF_TRY(header_k(buf + 5, &k));
    if (!is_int(buf[9], 0) && !is_int(buf[9], 1)) return DKF_ERR_ARG;
    DKF_TRY(dkf_diffkf_checkpoint_check(&fc->central, buf + off, len - off));
    off += dkf_diffkf_checkpoint_len(&fc->central);
    for (i = 0; i < fc->l; ++i) {
        DKF_TRY(dkf_diffkf_checkpoint_check(&fc->nodes[i].rep, buf + off, len - off));
        off += dkf_diffkf_checkpoint_len(&fc->nodes[i].rep);
    }
    for (i = 0; i < fc->l; ++i)
        if (!is_int(buf[off + i], 0) && !is_int(buf[off + i], 1)) return DKF_ERR_ARG;
    if (!dkf__all_finite(buf + off + fc->l, 2 * fc->ps)) return DKF_ERR_NONFINITE;

    off = FC_CKPT_HEAD;
    (void)dkf_diffkf_restore(&fc->central, buf + off, len - off);
    off += dkf_diffkf_checkpoint_len(&fc->central);
    for (i = 0; i < fc->l; ++i) {
        (void)dkf_diffkf_restore(&fc->nodes[i].rep, buf + off, len - off);
        off += dkf_diffkf_checkpoint_len(&fc->nodes[i].rep);
    }
    for (i = 0; i < fc->l; ++i) fc->nodes[i].sync = is_int(buf[off + i], 1);
    dkf__copy(fc->nodes[0].z.data, buf + off + fc->l, 2 * fc->ps);
    refresh_saved(fc);
    fc->k = k;
    fc->started = is_int(buf[9], 1);
    return DKF_OK;
}
