/*
 * Distributed Difference KF (dkf/diffkf_fusion.h): the fusion centre that
 * rebuilds the centralized estimate exactly, docs/design/diffkf-fusion.md and the
 * docs/design/derivation-seed000.md §6 (not the paper's (30)-(36), which are exact only when the
 * stacked S = Q H^T A^{+T} B^{-T} has full column rank, so sum p_i <= n; §5).
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
 * Degraded steps (docs/design/diffkf-fusion.md §8): a node's rows enter the
 * central step only if its message is present and its replica carries the
 * true dz^i_{k-1} (sync); the central filter then runs the row-masked
 * Difference KF, the exact estimate given the rows received. Checkpoints
 * and replica restarts support rollback/replay and restarted/late nodes.
 *
 * Atomicity: everything that can fail (replica gains, rank of K^i, the
 * central gain, the updates' overflow checks) runs against snapshots of
 * the replicas and of the central filter's struct; a failure restores
 * them. The central filter's update comes last and is atomic itself, so
 * its carry needs no copy; its caches (A^+, B^{-1}, the model block: most
 * of its state at large N), which a successful central gain may rewrite,
 * change only when its cache_gen advances, so their snapshot is a mirror
 * refreshed after each successful call that wrote them (commit_state).
 */
#include "dkf/diffkf_fusion.h"

#include <string.h>

#include "diffkf_fusion_internal.h"
#include "diffkf_internal.h"
#include "internal.h"
#include "kernels.h"

/* ---- fusion centre: storage ---------------------------------------------- */

/* The dimensions check_dims derives: sum m_i, sum p_i, max p_i and the
 * workspace (the largest DKF__DIFFKF_FC_WORK of a sensor). */
typedef struct {
    size_t ms, ps, pmax, work;
} fc_dims_t;

/* Validates the dimensions; on success *d is set. */
static dkf_status_t check_dims(size_t n, size_t l, const size_t m[], const size_t p[],
                               fc_dims_t *d, dkf_diffkf_fc_fault_t *f)
{
    size_t i;
    d->ms = d->ps = d->pmax = d->work = 0;
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
        d->ms += m[i];
        d->ps += p[i];
        d->pmax = DKF__DIFFKF_FC_MAX(d->pmax, p[i]);
        d->work = DKF__DIFFKF_FC_MAX(d->work, DKF__DIFFKF_FC_WORK(n, m[i], p[i]));
    }
    if (d->ms > DKF_MAX_DIM || d->ps > DKF_MAX_DIM) {
        if (f) f->which = DKF_DIFFKF_FC_STACK_CAPACITY, f->node = DKF_DIFFKF_FC_NO_NODE;
        return DKF_ERR_CAPACITY;
    }
    return DKF_OK;
}

static size_t central_state_len(const dkf_diffkf_fc_t *fc)
{
    return DKF_DIFFKF_STATE_LEN(fc->n, fc->ms, fc->ps);
}

/* Copies the central filter's caches (its state after the carry) to their
 * mirror (to_snap) or back. */
static void copy_caches(const dkf_diffkf_fc_t *fc, int to_snap)
{
    const size_t c = DKF__DIFFKF_CARRY_LEN(fc->n, fc->ps), len = central_state_len(fc) - c;
    if (to_snap)
        dkf__copy(fc->priv.cache_snap, fc->priv.central_store + c, len);
    else
        dkf__copy(fc->priv.central_store + c, fc->priv.cache_snap, len);
}

/* The storage, state first (dkf_diffkf_fc_state_len: the replicas'
 * storage, the committed z dz, the mirror of the central filter's caches,
 * the central filter's storage, whose first DKF_DIFFKF_STATE_LEN reals end
 * the state), then scratch: the replicas' snapshots, the stacked H D R B
 * Rd, the pending z dz, (K^i)^+, the workspace. */
typedef struct {
    dkf_real_t *zs, *cache_snap, *central;                   /* state (with the replicas') */
    dkf_real_t *H, *D, *R, *B, *Rd, *pend, *Kp, *work; /* scratch */
    size_t state_len;
} fc_layout_t;

/* Walks the storage in the order above; with base == NULL it only counts.
 * nodes (may be NULL) get their replica's storage and its snapshot. */
static size_t fc_layout(fc_layout_t *L, dkf_real_t *base, dkf_diffkf_fc_node_t *nodes, size_t n,
                        size_t l, const size_t m[], const size_t p[], const fc_dims_t *d)
{
    const size_t clen = DKF_DIFFKF_STORAGE_LEN(n, d->ms, d->ps),
                 carry = DKF__DIFFKF_CARRY_LEN(n, d->ps);
    dkf_real_t *rep;
    size_t used = 0, i;
    for (i = 0; i < l; ++i) {
        DKF_TAKE(rep, DKF_DIFFKF_STORAGE_LEN(n, m[i], p[i]));
        if (nodes != NULL) nodes[i].priv.store = rep;
        if (nodes != NULL) nodes[i].priv.store_len = DKF_DIFFKF_STORAGE_LEN(n, m[i], p[i]);
    }
    DKF_TAKE(L->zs, 2 * d->ps);
    DKF_TAKE(L->cache_snap, DKF_DIFFKF_STATE_LEN(n, d->ms, d->ps) - carry);
    DKF_TAKE(L->central, clen);
    L->state_len = used - clen + DKF_DIFFKF_STATE_LEN(n, d->ms, d->ps);
    for (i = 0; i < l; ++i) {
        DKF_TAKE(rep, DKF_DIFFKF_STORAGE_LEN(n, m[i], p[i]));
        if (nodes != NULL) nodes[i].priv.saved_store = rep;
    }
    DKF_TAKE(L->H, d->ms * n);
    DKF_TAKE(L->D, d->ms * d->ps);
    DKF_TAKE(L->R, d->ms * d->ms);
    DKF_TAKE(L->B, d->ps * d->ps);
    DKF_TAKE(L->Rd, d->ps * d->ps);
    DKF_TAKE(L->pend, 2 * d->ps);
    DKF_TAKE(L->Kp, d->pmax * n);
    DKF_TAKE(L->work, d->work);
    return used;
}

size_t dkf_diffkf_fc_storage_len(size_t n, size_t l, const size_t m[], const size_t p[])
{
    fc_dims_t d;
    fc_layout_t L;
    if (m == NULL || p == NULL) return 0;
    if (check_dims(n, l, m, p, &d, NULL) != DKF_OK) return 0;
    return fc_layout(&L, NULL, NULL, n, l, m, p, &d);
}

size_t dkf_diffkf_fc_state_len(size_t n, size_t l, const size_t m[], const size_t p[])
{
    fc_dims_t d;
    fc_layout_t L;
    if (m == NULL || p == NULL) return 0;
    if (check_dims(n, l, m, p, &d, NULL) != DKF_OK) return 0;
    (void)fc_layout(&L, NULL, NULL, n, l, m, p, &d);
    return L.state_len;
}

const char *dkf_diffkf_fc_cond_str(dkf_diffkf_fc_cond_t which)
{
    static const char *const names[] = {
        "no fault",      "argument",          "storage",         "p_i > n",
        "p_i > m_i",     "stacked capacity",  "prior",           "model",
        "D rank",        "B singular",        "L not SPD",       "K rank",
        "non-finite",    "message node",      "message step",    "message dimension",
        "message non-finite", "sequence"};
    const size_t i = (size_t)which;
    return i < sizeof names / sizeof names[0] ? names[i] : "unknown condition";
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
    size_t i, zoff = 0;
    fc_dims_t d;
    fc_layout_t L;
    dkf_status_t st;
    dkf_diffkf_fc_t g;
    if (fc == NULL || nodes == NULL || m == NULL || p == NULL || storage == NULL || x0 == NULL ||
        P0 == NULL)
        return report(fault, DKF_ERR_NULL, arg, none);
    st = check_dims(n, l, m, p, &d, fault);
    if (st != DKF_OK) return st;
    if (storage_len < fc_layout(&L, NULL, NULL, n, l, m, p, &d))
        return report(fault, DKF_ERR_CAPACITY, DKF_DIFFKF_FC_STORAGE, none);
    st = dkf__check_input(x0, n, 1);
    if (st == DKF_OK) st = dkf__check_input(P0, n, n);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, none);

    /* every prior must be SPD before anything is initialised (the work
     * area at the end of storage is the scratch) */
    (void)fc_layout(&L, storage, NULL, n, l, m, p, &d);
    memset(&g, 0, sizeof g);
    g.n = n;
    g.l = l;
    g.ms = d.ms;
    g.ps = d.ps;
    g.priv.work_len = d.work;
    g.priv.work = L.work;
    for (i = 0; i <= l; ++i) {
        const dkf_mat_t *Pi = i < l && P0_local != NULL && P0_local[i] != NULL ? P0_local[i] : P0;
        dkf_mat_t Lc = DKF_MAT(n, n, g.priv.work);
        st = dkf__check_input(Pi, n, n);
        if (st == DKF_OK) st = dkf_mat_chol(&Lc, Pi, g.priv.work + n * n);
        if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, i < l ? i : none);
    }

    /* the state: replicas, committed z dz, central; then the scratch */
    (void)fc_layout(&L, storage, nodes, n, l, m, p, &d);
    memset(L.zs, 0, 2 * d.ps * sizeof(dkf_real_t));
    /* cannot fail: dimensions, storage and the SPD prior are checked */
    st = dkf_diffkf_init(&g.central, n, d.ms, d.ps, L.central,
                         DKF_DIFFKF_STORAGE_LEN(n, d.ms, d.ps), x0, P0);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, none);
    g.priv.central_store = L.central;
    g.priv.cache_snap = L.cache_snap;
    copy_caches(&g, 1); /* the mirror holds the caches from here on (roll_back) */
    dkf__view(&g.priv.H, d.ms, n, L.H);
    dkf__view(&g.priv.D, d.ms, d.ps, L.D);
    dkf__view(&g.priv.R, d.ms, d.ms, L.R);
    dkf__view(&g.priv.B, d.ps, d.ps, L.B);
    dkf__view(&g.priv.Rd, d.ps, d.ps, L.Rd);
    g.priv.pend = L.pend;
    memset(g.priv.pend, 0, 2 * d.ps * sizeof(dkf_real_t)); /* pending z, dz */
    for (i = 0; i < l; ++i) {
        const dkf_mat_t *Pi = P0_local != NULL && P0_local[i] != NULL ? P0_local[i] : P0;
        st = dkf_diffkf_init(&nodes[i].rep, n, m[i], p[i], nodes[i].priv.store,
                             nodes[i].priv.store_len, x0, Pi);
        if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, i);
        nodes[i].m = m[i];
        nodes[i].p = p[i];
        dkf__view(&nodes[i].z, p[i], 1, L.zs + zoff);
        dkf__view(&nodes[i].dz, p[i], 1, L.zs + d.ps + zoff);
        zoff += p[i];
        nodes[i].sync = 1; /* the first step has no previous innovation */
        nodes[i].priv.saved = nodes[i].rep;
    }
    g.priv.Kp = L.Kp;
    g.nodes = nodes;
    g.priv.ready = 1;
    *fc = g;
    return report(fault, DKF_OK, DKF_DIFFKF_FC_NO_FAULT, none);
}

dkf_status_t dkf_diffkf_fc_set_steady(dkf_diffkf_fc_t *fc, dkf_real_t tol)
{
    size_t i;
    DKF_CHECK_NULL(fc);
    if (!fc->priv.ready) return DKF_ERR_STATE;
    DKF_TRY(dkf_diffkf_set_steady(&fc->central, tol));
    for (i = 0; i < fc->l; ++i) {
        fc->nodes[i].rep.priv.steady_tol = tol;
        fc->nodes[i].priv.saved.priv.steady_tol = tol;
    }
    return DKF_OK;
}

/* ---- fusion centre: snapshots -------------------------------------------- */

static void save_replicas(dkf_diffkf_fc_t *fc)
{
    size_t i;
    for (i = 0; i < fc->l; ++i) {
        dkf_diffkf_fc_node_t *nd = &fc->nodes[i];
        nd->priv.saved = nd->rep;
        memcpy(nd->priv.saved_store, nd->priv.store, nd->priv.store_len * sizeof(dkf_real_t));
    }
}

static void restore_replicas(dkf_diffkf_fc_t *fc)
{
    size_t i;
    for (i = 0; i < fc->l; ++i) {
        dkf_diffkf_fc_node_t *nd = &fc->nodes[i];
        nd->rep = nd->priv.saved;
        memcpy(nd->priv.store, nd->priv.saved_store, nd->priv.store_len * sizeof(dkf_real_t));
    }
}

/* (diffkf_fusion_internal.h) */
void dkf__fc_refresh_saved(dkf_diffkf_fc_t *fc)
{
    size_t i;
    for (i = 0; i < fc->l; ++i) fc->nodes[i].priv.saved = fc->nodes[i].rep;
}

/* Snapshots of everything a call may change before it can fail: the
 * replicas and the central filter's struct. The central filter's carry
 * needs none: the call's last fallible operation is its own update (start
 * in dkf_diffkf_fc_start), which leaves it untouched on failure, and its
 * gain writes only the pending area and the caches. The caches have a
 * mirror in the state (fc->priv.cache_snap), refreshed after every successful
 * call that wrote them (commit_state). */
static void save_state(dkf_diffkf_fc_t *fc, dkf_diffkf_t *central_saved)
{
    save_replicas(fc);
    *central_saved = fc->central;
}

/* Restores what save_state saved, and the caches if a successful central
 * gain wrote them, and reports the failure. */
static dkf_status_t roll_back(dkf_diffkf_fc_t *fc, const dkf_diffkf_t *central_saved,
                              dkf_diffkf_fc_fault_t *fault, dkf_status_t st,
                              dkf_diffkf_fc_cond_t which, size_t node)
{
    restore_replicas(fc);
    if (fc->central.priv.cache_gen != central_saved->priv.cache_gen) copy_caches(fc, 0);
    fc->central = *central_saved;
    return report(fault, st, which, node);
}

/* After a successful call: the node array's snapshot structs equal the
 * replicas, and the snapshot's cache part the caches this call wrote. */
static void commit_state(dkf_diffkf_fc_t *fc, const dkf_diffkf_t *central_saved)
{
    dkf__fc_refresh_saved(fc);
    if (fc->central.priv.cache_gen != central_saved->priv.cache_gen) copy_caches(fc, 1);
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

/* 1 if the r x c block of D (`cols` columns) at (r0, c0) is S bit for bit. */
static int block_is(const dkf_real_t *D, size_t cols, size_t r0, size_t c0, const dkf_mat_t *S)
{
    size_t i;
    for (i = 0; i < S->rows; ++i)
        if (memcmp(D + (r0 + i) * cols + c0, S->data + i * S->cols, S->cols * sizeof *D) != 0)
            return 0;
    return 1;
}

/* 1 if fc->priv.H, D, R (and B, Rd when want_input) hold the stacking of these
 * sensors already: a stacking completed in an earlier successful call
 * (fc->priv.stacked) left zeros outside the blocks, so equal blocks make equal
 * matrices. A time-invariant model is stacked once: each step then
 * compares the sum of the blocks' sizes instead of writing ms^2 + ps^2
 * reals. */
static int blocks_are(const dkf_diffkf_fc_t *fc, const dkf_real_t *H, const dkf_real_t *D,
                      const dkf_real_t *R, const dkf_real_t *B, const dkf_real_t *Rd,
                      const dkf_diffkf_sensor_t sensors[], int want_input)
{
    size_t i, r0 = 0, c0 = 0;
    for (i = 0; i < fc->l; ++i) {
        const dkf_diffkf_sensor_t *s = &sensors[i];
        if (!block_is(H, fc->n, r0, 0, s->meas.H) || !block_is(D, fc->ps, r0, c0, s->meas.D) ||
            !block_is(R, fc->ms, r0, r0, s->meas.R) ||
            (want_input &&
             (!block_is(B, fc->ps, c0, c0, s->B) || !block_is(Rd, fc->ps, c0, c0, s->Rd))))
            return 0;
        r0 += fc->nodes[i].m;
        c0 += fc->nodes[i].p;
    }
    return 1;
}

static int stacked_already(const dkf_diffkf_fc_t *fc, const dkf_diffkf_sensor_t sensors[],
                           int want_input)
{
    return fc->priv.stacked >= 1 + want_input &&
           blocks_are(fc, fc->priv.H.data, fc->priv.D.data, fc->priv.R.data, fc->priv.B.data,
                      fc->priv.Rd.data, sensors, want_input);
}

/* 1 if the central filter's model memo holds the stacked model of these
 * sensors (after stack_model): its inputs B, Rd, H, D, R are copies of
 * this centre's stacked arrays (the central filter steps only on them),
 * so they have zeros outside the blocks too, and equal blocks make them
 * bitwise the arrays. */
static int memo_is_stacked(const dkf_diffkf_fc_t *fc, const dkf_diffkf_sensor_t sensors[])
{
    const dkf_real_t *H, *D, *R, *B, *Rd;
    return dkf__diffkf_memo(&fc->central, &H, &D, &R, &B, &Rd) &&
           blocks_are(fc, H, D, R, B, Rd, sensors, 1);
}

/* fc->priv.H, D, R (and B, Rd when want_input) from the sensors' models
 * (shapes checked by check_sensors). */
static dkf_status_t stack_model(dkf_diffkf_fc_t *fc, const dkf_diffkf_sensor_t sensors[],
                                int want_input)
{
    const dkf_ui_meas_t *meas[DKF_MAX_DIM];
    const dkf_mat_t *Bi[DKF_MAX_DIM], *Rdi[DKF_MAX_DIM];
    size_t i;
    if (stacked_already(fc, sensors, want_input)) return DKF_OK;
    for (i = 0; i < fc->l; ++i) {
        meas[i] = &sensors[i].meas;
        Bi[i] = sensors[i].B;
        Rdi[i] = sensors[i].Rd;
    }
    DKF_TRY(dkf_diffkf_stack_meas(&fc->priv.H, &fc->priv.D, &fc->priv.R, meas, fc->l));
    if (want_input) DKF_TRY(dkf_diffkf_stack_input(&fc->priv.B, &fc->priv.Rd, Bi, Rdi, fc->l));
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
        dkf_mat_t LU = DKF_MAT(pi, pi, fc->priv.work);
        st = dkf_mat_rank(&rank, sensors[i].meas.D, DKF_RANK_TOL_DEFAULT, fc->priv.work);
        if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, i);
        if (rank != pi) return report(fault, DKF_ERR_RANK, DKF_DIFFKF_FC_D_RANK, i);
        st = dkf_mat_lu(&LU, piv, sensors[i].B, fc->priv.work + pi * pi);
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
    if (!fc->priv.ready || fc->priv.started)
        return report(fault, DKF_ERR_STATE, DKF_DIFFKF_FC_SEQUENCE, none);
    st = dkf__check_input(F0, fc->n, fc->n);
    if (st == DKF_OK) st = dkf__check_input(Q0, fc->n, fc->n);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, none);
    DKF_TRY(check_sensors(fc, sensors, 0, fault));
    DKF_TRY(check_ranks(fc, sensors, fault));
    st = stack_model(fc, sensors, 0);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, none);
    cmeas.H = &fc->priv.H;
    cmeas.D = &fc->priv.D;
    cmeas.R = &fc->priv.R;

    save_state(fc, &central_saved);
    for (i = 0; i < fc->l; ++i) {
        st = dkf_diffkf_start(&fc->nodes[i].rep, F0, Q0, &sensors[i].meas, NULL);
        if (st != DKF_OK) return roll_back(fc, &central_saved, fault, st, cond_of(st), i);
    }
    st = dkf_diffkf_start(&fc->central, F0, Q0, &cmeas, NULL);
    if (st != DKF_OK) return roll_back(fc, &central_saved, fault, st, cond_of(st), none);
    commit_state(fc, &central_saved);
    fc->priv.started = 1;
    fc->priv.stacked = 1;
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
    dkf_mat_t M, K, zc, Kp = DKF_MAT(pi, n, fc->priv.Kp);
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
    st = dkf_mat_pinv(&Kp, &rank, &K, DKF_RANK_TOL_DEFAULT, fc->priv.work);
    if (st == DKF_OK && rank != pi) st = DKF_ERR_RANK;
    if (st != DKF_OK) {
        *which = st == DKF_ERR_RANK ? DKF_DIFFKF_FC_K_RANK : cond_of(st);
        return st;
    }
    for (j = 0; j < n; ++j) diff[j] = msg->xf[j] - msg->xp[j];
    dkf__mul_vec(dz, fc->priv.Kp, diff, pi, n);
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
    if (!fc->priv.ready || !fc->priv.started)
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
    zt = fc->priv.pend;            /* pending z, dz */
    dzt = fc->priv.pend + fc->ps;
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
    cdyn.B = &fc->priv.B;
    cdyn.Rd = &fc->priv.Rd;
    cmeas.H = &fc->priv.H;
    cmeas.D = &fc->priv.D;
    cmeas.R = &fc->priv.R;
    /* the central filter need not compare the stacked model with its memo,
     * O(ms^2 + ps^2), when this centre finds them equal in O(N) */
    st = dkf__diffkf_gain_masked_memo(&fc->central, &cdyn, &cmeas, rows,
                                      memo_is_stacked(fc, sensors));
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
    commit_state(fc, &central_saved);
    fc->k += 1;
    fc->priv.stacked = 2;
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
    if (!fc->priv.ready || !fc->priv.started)
        return report(fault, DKF_ERR_STATE, DKF_DIFFKF_FC_SEQUENCE, none);
    if (node >= fc->l) return report(fault, DKF_ERR_ARG, DKF_DIFFKF_FC_ARG, none);
    if (k_start != fc->k + 1) return report(fault, DKF_ERR_STATE, DKF_DIFFKF_FC_SEQUENCE, node);
    nd = &fc->nodes[node];
    Lc.rows = fc->n, Lc.cols = fc->n, Lc.data = fc->priv.work;
    st = dkf__check_input(P_prior, fc->n, fc->n);
    if (st == DKF_OK) st = dkf_mat_chol(&Lc, P_prior, fc->priv.work + fc->n * fc->n);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_PRIOR, node);
    st = dkf__check_input(sensor_at_kstart->meas.H, nd->m, fc->n);
    if (st == DKF_OK) st = dkf__check_input(sensor_at_kstart->meas.D, nd->m, nd->p);
    if (st == DKF_OK) st = dkf__check_input(sensor_at_kstart->meas.R, nd->m, nd->m);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, node);
    st = dkf_mat_rank(&rank, sensor_at_kstart->meas.D, DKF_RANK_TOL_DEFAULT, fc->priv.work);
    if (st != DKF_OK) return report(fault, st, DKF_DIFFKF_FC_MODEL, node);
    if (rank != nd->p) return report(fault, DKF_ERR_RANK, DKF_DIFFKF_FC_D_RANK, node);

    /* as the node: init (its x prior is irrelevant: the replica's x is the
     * message's) and a start at k_start with no previous innovation */
    memset(x0s, 0, sizeof x0s);
    x0.rows = fc->n, x0.cols = 1, x0.data = x0s;
    nd->priv.saved = nd->rep;
    memcpy(nd->priv.saved_store, nd->priv.store, nd->priv.store_len * sizeof(dkf_real_t));
    st = dkf_diffkf_init(&nd->rep, fc->n, nd->m, nd->p, nd->priv.store, nd->priv.store_len, &x0,
                         P_prior);
    /* the centre's setting, which init cleared */
    nd->rep.priv.steady_tol = nd->priv.saved.priv.steady_tol;
    if (st == DKF_OK) st = dkf_diffkf_start(&nd->rep, NULL, NULL, &sensor_at_kstart->meas, NULL);
    if (st != DKF_OK) {
        nd->rep = nd->priv.saved;
        memcpy(nd->priv.store, nd->priv.saved_store, nd->priv.store_len * sizeof(dkf_real_t));
        return report(fault, st, cond_of(st), node);
    }
    nd->priv.saved = nd->rep;
    nd->sync = 1;
    return report(fault, DKF_OK, DKF_DIFFKF_FC_NO_FAULT, none);
}
