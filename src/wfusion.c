/*
 * Weighted fusion of local Kalman filters with cross covariances
 * (dkf/wfusion.h). Equation references are to seed 002 (Zhang): Theorem 1
 * (the local filters), its cross-covariance recursion as corrected in
 * docs/design/weighted-fusion.md, Theorem 2 (scalar weights) and the matrix
 * weights of Sun and Deng (2004).
 *
 * Every step computes the next state of every object into scratch laid
 * out exactly like the state, checks it, and then commits it with one
 * copy, so a failed call leaves every filter and P_ij bit-identical.
 */
#include "dkf/wfusion.h"

#include "dkf/mat_riccati.h"
#include "internal.h"
#include "kernels.h"

/* ---- one local filter ------------------------------------------------------ */

/* Storage of a local filter (loc_layout; DKF_WFUSION_LOCAL_STORAGE_LEN):
 *   st   the state x (n), P, Sp (n*n), K (n*m), Psi, J (n*n)
 *        (DKF_WFUSION_LOCAL_STATE_LEN)
 *   nx   the next state, the same regions in the same order (one copy
 *        commits it)
 *   JQ   J Q (n*n): the fusion's cross-covariance term of this sensor
 *   T    F P (n*n); the PSD check's factor
 *   B    H Sp (m*n), Kt = K^T (m*n), S = H Sp H^T + R (m*m), Lc its
 *        Cholesky factor (m*m)
 *   jw   the Joseph product's scratch, or dkf_mat_dare's */
typedef struct {
    dkf_real_t *x, *P, *Sp, *K, *Psi, *J;
} loc_state_t;

typedef struct {
    loc_state_t st, nx;
    dkf_real_t *JQ, *T, *B, *Kt, *S, *Lc, *jw;
} loc_layout_t;

static size_t take_state(loc_state_t *st, dkf_real_t *base, size_t used, size_t n, size_t m)
{
    DKF_TAKE(st->x, n);
    DKF_TAKE(st->P, n * n);
    DKF_TAKE(st->Sp, n * n);
    DKF_TAKE(st->K, n * m);
    DKF_TAKE(st->Psi, n * n);
    DKF_TAKE(st->J, n * n);
    return used;
}

/* Walks a local filter's storage in the order above; base == NULL counts. */
static size_t loc_layout(loc_layout_t *L, dkf_real_t *base, size_t n, size_t m)
{
    size_t used = take_state(&L->st, base, 0, n, m);
    used = take_state(&L->nx, base, used, n, m);
    DKF_TAKE(L->JQ, n * n);
    DKF_TAKE(L->T, n * n);
    DKF_TAKE(L->B, m * n);
    DKF_TAKE(L->Kt, m * n);
    DKF_TAKE(L->S, m * m);
    DKF_TAKE(L->Lc, m * m);
    DKF_TAKE(L->jw, DKF__WFUSION_MAX(DKF__JOSEPH_WORK(n, m), DKF_MAT_DARE_WORK(n, m)));
    return used;
}

static loc_layout_t loc_mem(const dkf_wfusion_local_t *loc)
{
    loc_layout_t L;
    (void)loc_layout(&L, loc->x.data, loc->n, loc->m);
    return L;
}

dkf_status_t dkf_wfusion_local_init(dkf_wfusion_local_t *loc, size_t n, size_t m,
                                    dkf_real_t *storage, size_t storage_len,
                                    const dkf_mat_t *x0, const dkf_mat_t *P0)
{
    dkf_wfusion_local_t g; /* built aside: a failed init leaves *loc as it was */
    loc_layout_t L;
    size_t i;
    DKF_CHECK_NULL(loc);
    DKF_CHECK_NULL(storage);
    if (n == 0 || m == 0 || n > DKF_MAX_DIM || m > DKF_MAX_DIM ||
        storage_len < loc_layout(&L, NULL, n, m))
        return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    (void)loc_layout(&L, storage, n, m);
    if (!dkf__psd_within_rounding(L.T, P0->data, n)) return DKF_ERR_NOT_SPD;
    for (i = 0; i < n * n; ++i) /* symmetric within rounding: as the steps keep it */
        if (P0->data[i] != P0->data[(i % n) * n + i / n]) return DKF_ERR_NOT_SPD;
    g.n = n;
    g.m = m;
    dkf__view(&g.x, n, 1, L.st.x);
    dkf__view(&g.P, n, n, L.st.P);
    dkf__view(&g.Sp, n, n, L.st.Sp);
    dkf__view(&g.K, n, m, L.st.K);
    dkf__view(&g.Psi, n, n, L.st.Psi);
    dkf__view(&g.J, n, n, L.st.J);
    g.priv.work = L.nx.x;
    g.t = 0;
    g.steady = 0;
    g.priv.ready = 1;
    /* x(0|0) = x0, P(0|0) = P0; Sp, K, Psi, J are defined by the first
     * step (Sp = P0, K = 0, Psi = J = I until then) */
    for (i = 0; i < DKF_WFUSION_LOCAL_STATE_LEN(n, m); ++i) storage[i] = DKF_R(0.0);
    dkf__copy(L.st.x, x0->data, n);
    dkf__copy(L.st.P, P0->data, n * n);
    dkf__copy(L.st.Sp, P0->data, n * n);
    for (i = 0; i < n; ++i) L.st.Psi[i * n + i] = L.st.J[i * n + i] = DKF_R(1.0);
    *loc = g;
    return DKF_OK;
}

/* The model's shapes and finiteness for a filter of state n, measurement m. */
static dkf_status_t check_model(const dkf_kf_dyn_t *dyn, const dkf_kf_meas_t *meas, size_t n,
                                size_t m)
{
    DKF_CHECK_NULL(dyn);
    DKF_CHECK_NULL(meas);
    DKF_TRY(dkf__check_input(dyn->F, n, n));
    DKF_TRY(dkf__check_input(dyn->Q, n, n));
    DKF_TRY(dkf__check_input(meas->H, m, n));
    return dkf__check_input(meas->R, m, m);
}

/* From the prior covariance Sp = Sigma(t|t-1) already in L->nx.Sp, the
 * rest of the next state (Theorem 1): K = Sp H^T (H Sp H^T + R)^{-1},
 * J = I - K H, Psi = J F, P = J Sp J^T + K R K^T (Joseph form, evaluated as
 * written: P must be the P_ii of the cross recursion, and it stays PSD).
 * DKF_ERR_NONFINITE (an overflow), DKF_ERR_NOT_SPD (S or P). */
static dkf_status_t gains_from_prior(const loc_layout_t *L, const dkf_real_t *F,
                                     const dkf_real_t *H, const dkf_real_t *R, size_t n, size_t m)
{
    dkf_real_t inv[DKF_MAX_DIM];
    size_t i, j;
    /* B = H Sp (m x n); S = B H^T + R */
    dkf__mul_nn(L->B, H, L->nx.Sp, m, n, n);
    dkf__mul_nt_sym(L->S, L->B, H, R, m, n);
    if (!dkf__all_finite(L->S, m * m)) return DKF_ERR_NONFINITE;
    if (dkf__chol(L->Lc, inv, L->S, m) != 0) return DKF_ERR_NOT_SPD;
    /* K^T = S^{-1} H Sp (S and Sp symmetric) */
    dkf__copy(L->Kt, L->B, m * n);
    dkf__chol_solve(L->Lc, inv, L->Kt, m, n);
    dkf__transpose(L->nx.K, L->Kt, m, n);
    /* J = I - K H; Psi = J F */
    dkf__mul_nn(L->nx.J, L->nx.K, H, n, m, n);
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j)
            L->nx.J[i * n + j] = (i == j ? DKF_R(1.0) : DKF_R(0.0)) - L->nx.J[i * n + j];
    dkf__mul_nn(L->nx.Psi, L->nx.J, F, n, n, n);
    dkf__joseph(L->nx.P, L->nx.Sp, L->Kt, H, R, n, m, L->jw);
    if (!dkf__all_finite(L->nx.P, n * n) || !dkf__all_finite(L->nx.Psi, n * n) ||
        !dkf__all_finite(L->nx.K, n * m))
        return DKF_ERR_NONFINITE;
    if (!dkf__psd_within_rounding(L->T, L->nx.P, n)) return DKF_ERR_NOT_SPD;
    return DKF_OK;
}

/* The next state of loc into its scratch (nothing committed): the gains
 * (time-varying mode) and x = Psi x + K y (y may be NULL). */
static dkf_status_t local_compute(const dkf_wfusion_local_t *loc, const loc_layout_t *L,
                                  const dkf_kf_dyn_t *dyn, const dkf_kf_meas_t *meas,
                                  const dkf_mat_t *y)
{
    const size_t n = loc->n, m = loc->m;
    size_t i;
    DKF_TRY(check_model(dyn, meas, n, m));
    if (y != NULL) DKF_TRY(dkf__check_input(y, m, 1));
    if (loc->steady) {
        dkf__copy(L->nx.x, L->st.x, DKF_WFUSION_LOCAL_STATE_LEN(n, m));
    } else {
        /* Sigma(t|t-1) = F P(t-1|t-1) F^T + Q */
        dkf__mul_nn(L->T, dyn->F->data, L->st.P, n, n, n);
        dkf__mul_nt_sym(L->nx.Sp, L->T, dyn->F->data, dyn->Q->data, n, n);
        if (!dkf__all_finite(L->nx.Sp, n * n)) return DKF_ERR_NONFINITE;
        DKF_TRY(gains_from_prior(L, dyn->F->data, meas->H->data, meas->R->data, n, m));
    }
    /* x(t|t) = Psi(t) x(t-1|t-1) + K(t) y(t) */
    if (y == NULL) {
        dkf__copy(L->nx.x, L->st.x, n);
        return DKF_OK;
    }
    dkf__mul_vec(L->nx.x, L->nx.Psi, L->st.x, n, n);
    for (i = 0; i < n; ++i) L->nx.x[i] += dkf__dot(L->nx.K + i * m, y->data, m);
    return dkf__all_finite(L->nx.x, n) ? DKF_OK : DKF_ERR_NONFINITE;
}

/* Commits the staged next state; a step (not a switch to steady) counts. */
static void local_commit(dkf_wfusion_local_t *loc, const loc_layout_t *L, int is_step)
{
    dkf__copy(L->st.x, L->nx.x, DKF_WFUSION_LOCAL_STATE_LEN(loc->n, loc->m));
    if (is_step) loc->t++;
}

dkf_status_t dkf_wfusion_local_step(dkf_wfusion_local_t *loc, const dkf_kf_dyn_t *dyn,
                                    const dkf_kf_meas_t *meas, const dkf_mat_t *y)
{
    loc_layout_t L;
    DKF_CHECK_NULL(loc);
    if (!loc->priv.ready) return DKF_ERR_STATE;
    L = loc_mem(loc);
    DKF_TRY(local_compute(loc, &L, dyn, meas, y));
    local_commit(loc, &L, 1);
    return DKF_OK;
}

/* The steady next state into scratch: Sp = the DARE's stabilising
 * solution, then the gains from it; x is kept. */
static dkf_status_t local_steady_compute(const dkf_wfusion_local_t *loc, const loc_layout_t *L,
                                         const dkf_kf_dyn_t *dyn, const dkf_kf_meas_t *meas)
{
    const size_t n = loc->n, m = loc->m;
    dkf_mat_t X;
    DKF_TRY(check_model(dyn, meas, n, m));
    dkf__view(&X, n, n, L->nx.Sp);
    DKF_TRY(dkf_mat_dare(&X, dyn->F, meas->H, dyn->Q, meas->R, L->jw));
    DKF_TRY(gains_from_prior(L, dyn->F->data, meas->H->data, meas->R->data, n, m));
    dkf__copy(L->nx.x, L->st.x, n);
    return DKF_OK;
}

dkf_status_t dkf_wfusion_local_steady(dkf_wfusion_local_t *loc, const dkf_kf_dyn_t *dyn,
                                      const dkf_kf_meas_t *meas)
{
    loc_layout_t L;
    DKF_CHECK_NULL(loc);
    if (!loc->priv.ready) return DKF_ERR_STATE;
    L = loc_mem(loc);
    DKF_TRY(local_steady_compute(loc, &L, dyn, meas));
    local_commit(loc, &L, 0);
    loc->steady = 1;
    return DKF_OK;
}

/* ---- the fusion -------------------------------------------------------------- */

/* The fusion's own storage (fu_layout, after the l local filters'):
 *   Pj   joint covariance (P_ij), N x N, N = n l         (state)
 *   Hs   signal row (n)                                 (state)
 *   PS, w, A, xf, Pf: the last fusions' results (l*l, l, n*N, n, n*n)
 *   Pn   the next Pj (N*N); fuse: the present sub-block S
 *   C    k*k, k = N + n: the KKT matrix, or S's Cholesky factor; steady:
 *        the Stein term
 *   X    k*k: the KKT system's pseudo-inverse; steady: a Stein solution
 *   sw   the pseudo-inverse's scratch, or dkf_mat_stein's
 *   Z    k*n: the weights transposed (the KKT solution)
 *   wt, At, xft, Pft, PSt: staged results (l, n*N, n, n*n, l*l) */
typedef struct {
    dkf_real_t *Pj, *Hs, *PS, *w, *A, *xf, *Pf;
    dkf_real_t *Pn, *C, *X, *sw, *Z, *wt, *At, *xft, *Pft, *PSt;
} fu_layout_t;

static size_t fu_layout(fu_layout_t *L, dkf_real_t *base, size_t n, size_t l)
{
    const size_t N = n * l, k = N + n;
    size_t used = 0;
    DKF_TAKE(L->Pj, N * N);
    DKF_TAKE(L->Hs, n);
    DKF_TAKE(L->PS, l * l);
    DKF_TAKE(L->w, l);
    DKF_TAKE(L->A, n * N);
    DKF_TAKE(L->xf, n);
    DKF_TAKE(L->Pf, n * n);
    DKF_TAKE(L->Pn, N * N);
    DKF_TAKE(L->C, k * k);
    DKF_TAKE(L->X, k * k);
    DKF_TAKE(L->sw, DKF__WFUSION_MAX(DKF_MAT_PINV_WORK(k, k), DKF_MAT_STEIN_WORK(n, n)));
    DKF_TAKE(L->Z, k * n);
    DKF_TAKE(L->wt, l);
    DKF_TAKE(L->At, n * N);
    DKF_TAKE(L->xft, n);
    DKF_TAKE(L->Pft, n * n);
    DKF_TAKE(L->PSt, l * l);
    return used;
}

size_t dkf_wfusion_storage_len(size_t n, size_t l, const size_t m[])
{
    fu_layout_t L;
    loc_layout_t ll;
    size_t i, len;
    if (n == 0 || l == 0 || m == NULL || n > DKF_MAX_DIM || l > DKF_MAX_DIM ||
        n * l + n > DKF_MAX_DIM)
        return 0;
    len = fu_layout(&L, NULL, n, l);
    for (i = 0; i < l; ++i) {
        if (m[i] == 0 || m[i] > DKF_MAX_DIM) return 0;
        len += loc_layout(&ll, NULL, n, m[i]);
    }
    return len;
}

static fu_layout_t fu_mem(const dkf_wfusion_t *fu)
{
    fu_layout_t L;
    (void)fu_layout(&L, fu->Pj.data, fu->n, fu->l);
    return L;
}

dkf_status_t dkf_wfusion_init(dkf_wfusion_t *fu, size_t n, size_t l, const size_t m[],
                              dkf_wfusion_local_t nodes[], dkf_real_t *storage,
                              size_t storage_len, const dkf_mat_t *Hs, const dkf_mat_t *x0,
                              const dkf_mat_t *P0)
{
    dkf_wfusion_t g;
    fu_layout_t L;
    loc_layout_t ll;
    size_t i, j, r, used = 0;
    const size_t N = n * l;
    DKF_CHECK_NULL(fu);
    DKF_CHECK_NULL(m);
    DKF_CHECK_NULL(nodes);
    DKF_CHECK_NULL(storage);
    if (dkf_wfusion_storage_len(n, l, m) == 0 ||
        storage_len < dkf_wfusion_storage_len(n, l, m))
        return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(Hs, 1, n));
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    /* the first local filter checks P0; the others get the same prior.
     * Nothing below fails once the first init has passed, so no node is
     * bound unless all are. */
    DKF_TRY(dkf_wfusion_local_init(&nodes[0], n, m[0], storage, storage_len, x0, P0));
    used = loc_layout(&ll, NULL, n, m[0]);
    for (i = 1; i < l; ++i) {
        (void)dkf_wfusion_local_init(&nodes[i], n, m[i], storage + used, storage_len - used, x0,
                                     P0);
        used += loc_layout(&ll, NULL, n, m[i]);
    }
    (void)fu_layout(&L, storage + used, n, l);
    g.n = n;
    g.l = l;
    g.nodes = nodes;
    dkf__view(&g.Pj, N, N, L.Pj);
    dkf__view(&g.Hs, 1, n, L.Hs);
    dkf__view(&g.PS, l, l, L.PS);
    dkf__view(&g.w, l, 1, L.w);
    dkf__view(&g.A, n, N, L.A);
    dkf__view(&g.xf, n, 1, L.xf);
    dkf__view(&g.Pf, n, n, L.Pf);
    g.priv.work = L.Pn;
    g.s0 = g.PS0 = DKF_R(0.0);
    g.w_unique = g.A_unique = 0;
    g.used = 0;
    g.t = 0;
    g.steady = 0;
    g.priv.ready = 1;
    /* P_ij(0|0) = P0 for every pair: the common initial estimate */
    for (i = 0; i < l; ++i)
        for (j = 0; j < l; ++j)
            for (r = 0; r < n; ++r) dkf__copy(L.Pj + (i * n + r) * N + j * n, P0->data + r * n, n);
    dkf__copy(L.Hs, Hs->data, n);
    for (i = 0; i < l * l + l + n * N + n + n * n; ++i) L.PS[i] = DKF_R(0.0);
    *fu = g;
    return DKF_OK;
}

/* DKF_ERR_NULL, or DKF_ERR_STATE before dkf_wfusion_init. */
static dkf_status_t check_fusion(const dkf_wfusion_t *fu)
{
    DKF_CHECK_NULL(fu);
    return fu->priv.ready ? DKF_OK : DKF_ERR_STATE;
}

/* Block (i, j) of the N x N joint matrix at P: its first element. */
static dkf_real_t *block(dkf_real_t *P, size_t n, size_t l, size_t i, size_t j)
{
    return P + i * n * (n * l) + j * n;
}

/* Copies the n x n block (i, j) of the joint P into the contiguous out, or
 * back (put != 0). */
static void move_block(dkf_real_t *P, dkf_real_t *out, size_t n, size_t l, size_t i, size_t j,
                       int put)
{
    size_t r;
    for (r = 0; r < n; ++r) {
        dkf_real_t *row = block(P, n, l, i, j) + r * n * l;
        if (put)
            dkf__copy(row, out + r * n, n);
        else
            dkf__copy(out + r * n, row, n);
    }
}

/* The next joint covariance into L->Pn from the nodes' staged gains:
 * P_ij = Psi_i P_ij Psi_j^T + J_i Q J_j^T (i != j), and P_ii the node's
 * own staged P_i (the same recursion with its K_i R_i K_i^T term, which
 * the node has already formed). Scratch: C, X (n*n each). The nodes'
 * layouts are recomputed where needed (pointer arithmetic): an array of
 * them would cost l * 19 pointers of stack. */
static void cross_step(const dkf_wfusion_t *fu, const fu_layout_t *L, const dkf_real_t *Q)
{
    const size_t n = fu->n, l = fu->l;
    size_t i, j, e;
    for (i = 0; i < l; ++i) {
        const loc_layout_t li = loc_mem(&fu->nodes[i]);
        dkf__mul_nn(li.JQ, li.nx.J, Q, n, n, n);
    }
    for (i = 0; i < l; ++i) {
        const loc_layout_t li = loc_mem(&fu->nodes[i]);
        move_block(L->Pn, li.nx.P, n, l, i, i, 1);
        for (j = i + 1; j < l; ++j) {
            const loc_layout_t lj = loc_mem(&fu->nodes[j]);
            move_block(L->Pj, L->C, n, l, i, j, 0);
            dkf__mul_nn(L->X, li.nx.Psi, L->C, n, n, n); /* Psi_i P_ij */
            dkf__mul_nt(L->C, L->X, lj.nx.Psi, n, n, n); /* (Psi_i P_ij) Psi_j^T */
            dkf__mul_nt(L->X, li.JQ, lj.nx.J, n, n, n);  /* J_i Q J_j^T */
            for (e = 0; e < n * n; ++e) L->C[e] += L->X[e];
            move_block(L->Pn, L->C, n, l, i, j, 1);
            dkf__transpose(L->X, L->C, n, n);
            move_block(L->Pn, L->X, n, l, j, i, 1);
        }
    }
}

dkf_status_t dkf_wfusion_step(dkf_wfusion_t *fu, const dkf_kf_dyn_t *dyn,
                              const dkf_kf_meas_t meas[], const dkf_mat_t y[])
{
    fu_layout_t L;
    size_t i, N;
    DKF_TRY(check_fusion(fu));
    DKF_CHECK_NULL(meas);
    N = fu->n * fu->l;
    L = fu_mem(fu);
    for (i = 0; i < fu->l; ++i) {
        const loc_layout_t li = loc_mem(&fu->nodes[i]);
        DKF_TRY(local_compute(&fu->nodes[i], &li, dyn, &meas[i], y != NULL ? &y[i] : NULL));
    }
    if (!fu->steady) {
        cross_step(fu, &L, dyn->Q->data);
        if (!dkf__all_finite(L.Pn, N * N)) return DKF_ERR_NONFINITE;
    }
    for (i = 0; i < fu->l; ++i) {
        const loc_layout_t li = loc_mem(&fu->nodes[i]);
        local_commit(&fu->nodes[i], &li, 1);
    }
    if (!fu->steady) dkf__copy(L.Pj, L.Pn, N * N);
    fu->t++;
    return DKF_OK;
}

dkf_status_t dkf_wfusion_steady(dkf_wfusion_t *fu, const dkf_kf_dyn_t *dyn,
                                const dkf_kf_meas_t meas[])
{
    fu_layout_t L;
    dkf_mat_t X, Pi, Pj, C;
    size_t i, j, n, N;
    DKF_TRY(check_fusion(fu));
    DKF_CHECK_NULL(meas);
    n = fu->n;
    N = n * fu->l;
    L = fu_mem(fu);
    for (i = 0; i < fu->l; ++i) {
        const loc_layout_t li = loc_mem(&fu->nodes[i]);
        DKF_TRY(local_steady_compute(&fu->nodes[i], &li, dyn, &meas[i]));
        dkf__mul_nn(li.JQ, li.nx.J, dyn->Q->data, n, n, n);
        move_block(L.Pn, li.nx.P, n, fu->l, i, i, 1);
    }
    /* P_ij = Psi_i P_ij Psi_j^T + J_i Q J_j^T (i != j): a Stein equation
     * per pair; P_ii the node's steady P */
    dkf__view(&X, n, n, L.X);
    dkf__view(&C, n, n, L.C);
    for (i = 0; i < fu->l; ++i) {
        const loc_layout_t li = loc_mem(&fu->nodes[i]);
        for (j = i + 1; j < fu->l; ++j) {
            const loc_layout_t lj = loc_mem(&fu->nodes[j]);
            dkf__mul_nt(L.C, li.JQ, lj.nx.J, n, n, n);
            dkf__view(&Pi, n, n, li.nx.Psi);
            dkf__view(&Pj, n, n, lj.nx.Psi);
            DKF_TRY(dkf_mat_stein(&X, &Pi, &Pj, &C, L.sw));
            move_block(L.Pn, L.X, n, fu->l, i, j, 1);
            dkf__transpose(L.C, L.X, n, n);
            move_block(L.Pn, L.C, n, fu->l, j, i, 1);
        }
    }
    for (i = 0; i < fu->l; ++i) {
        const loc_layout_t li = loc_mem(&fu->nodes[i]);
        local_commit(&fu->nodes[i], &li, 0);
        fu->nodes[i].steady = 1;
    }
    dkf__copy(L.Pj, L.Pn, N * N);
    fu->steady = 1;
    return DKF_OK;
}

/* ---- the weights ------------------------------------------------------------- */

/* Minimum-variance fusion of u unbiased estimates of a q-vector whose
 * joint error covariance is S (uq x uq, in L->Pn): the weights
 * W^T = [A_1 ... A_u]^T into Z (uq x q) and Pf (q x q) into Pft, solving
 * min tr(A S A^T) s.t. sum_i A_i = I. SPD S: by Cholesky,
 * Z = S^{-1} E (e^T S^{-1} e)^{-1}, Pf = (e^T S^{-1} e)^{-1}; otherwise
 * (S singular, or so ill-conditioned that a pivot falls below
 * 64 uq eps max diag S) the KKT system [[S, E], [E^T, 0]] [Z; -Pf] = [0; I]
 * by its pseudo-inverse, with *unique = (it has full rank).
 * DKF_ERR_NOT_SPD: S indefinite beyond rounding, or Pf not PSD. */
static dkf_status_t fuse_weights(const fu_layout_t *L, size_t u, size_t q, int *unique)
{
    const size_t N = u * q, k = N + q;
    dkf_real_t inv[DKF_MAX_DIM], row[DKF_MAX_DIM], dmax = DKF_R(0.0), pmin;
    size_t i, j, r, rank = 0;
    dkf_mat_t Km, Xm;
    if (!dkf__all_finite(L->Pn, N * N)) return DKF_ERR_NONFINITE;
    for (i = 0; i < N; ++i) dmax = DKF__WFUSION_MAX(dmax, L->Pn[i * N + i]);
    if (dkf__chol(L->C, inv, L->Pn, N) == 0) {
        dkf_real_t imax = DKF_R(0.0); /* 1 / the smallest pivot L(i,i) */
        for (i = 0; i < N; ++i) imax = DKF__WFUSION_MAX(imax, inv[i]);
        pmin = DKF_R(1.0) / imax;
        if (pmin * pmin > DKF_R(64.0) * (dkf_real_t)N * DKF_REAL_EPSILON * dmax) {
            /* Z = S^{-1} E; M = E^T Z; Pf = M^{-1}; Z <- Z Pf */
            for (i = 0; i < N * q; ++i) L->Z[i] = DKF_R(0.0);
            for (i = 0; i < N; ++i) L->Z[i * q + i % q] = DKF_R(1.0);
            dkf__chol_solve(L->C, inv, L->Z, N, q);
            for (i = 0; i < q * q; ++i) L->X[i] = DKF_R(0.0);
            for (i = 0; i < N; ++i)
                for (j = 0; j < q; ++j) L->X[(i % q) * q + j] += L->Z[i * q + j];
            dkf__symmetrise(L->X, q);
            if (!dkf__all_finite(L->X, q * q)) return DKF_ERR_NONFINITE;
            if (dkf__chol(L->X + q * q, inv, L->X, q) != 0) return DKF_ERR_NOT_SPD;
            dkf__chol_inverse(L->Pft, L->X + q * q, inv, q);
            for (i = 0; i < N; ++i) {
                dkf__mul_vec(row, L->Pft, L->Z + i * q, q, q); /* (Z Pf)_i = Pf Z_i^T */
                dkf__copy(L->Z + i * q, row, q);
            }
            *unique = 1;
            return dkf__all_finite(L->Z, N * q) ? DKF_OK : DKF_ERR_NONFINITE;
        }
    }
    if (!dkf__psd_within_rounding(L->C, L->Pn, N)) return DKF_ERR_NOT_SPD;
    /* the KKT matrix [[S, E], [E^T, 0]] */
    for (i = 0; i < k * k; ++i) L->C[i] = DKF_R(0.0);
    for (i = 0; i < N; ++i) {
        dkf__copy(L->C + i * k, L->Pn + i * N, N);
        L->C[i * k + N + i % q] = DKF_R(1.0);
        L->C[(N + i % q) * k + i] = DKF_R(1.0);
    }
    dkf__view(&Km, k, k, L->C);
    dkf__view(&Xm, k, k, L->X);
    DKF_TRY(dkf_mat_pinv(&Xm, &rank, &Km, DKF_RANK_TOL_DEFAULT, L->sw));
    /* [Z; -Pf] = the last q columns of the pseudo-inverse */
    for (r = 0; r < N; ++r) dkf__copy(L->Z + r * q, L->X + r * k + N, q);
    for (r = 0; r < q; ++r)
        for (j = 0; j < q; ++j) L->Pft[r * q + j] = -L->X[(N + r) * k + N + j];
    dkf__symmetrise(L->Pft, q);
    if (!dkf__all_finite(L->Z, N * q) || !dkf__all_finite(L->Pft, q * q))
        return DKF_ERR_NONFINITE;
    if (!dkf__psd_within_rounding(L->C, L->Pft, q)) return DKF_ERR_NOT_SPD;
    *unique = rank == k;
    return DKF_OK;
}

/* The sensors present (x == NULL: all, the nodes' own estimates) into
 * idx[0..u-1] and their estimates into xs[]; DKF_ERR_ARG if none. */
static dkf_status_t present_set(const dkf_wfusion_t *fu, const dkf_mat_t *const x[],
                                size_t idx[], const dkf_real_t *xs[], size_t *u)
{
    size_t i;
    *u = 0;
    for (i = 0; i < fu->l; ++i) {
        if (x != NULL && x[i] == NULL) continue;
        if (x != NULL) DKF_TRY(dkf__check_input(x[i], fu->n, 1));
        xs[*u] = x != NULL ? x[i]->data : fu->nodes[i].x.data;
        idx[(*u)++] = i;
    }
    return *u > 0 ? DKF_OK : DKF_ERR_ARG;
}

dkf_status_t dkf_wfusion_fuse_scalar(dkf_wfusion_t *fu, const dkf_mat_t *const x[])
{
    size_t idx[DKF_MAX_DIM], i, j, u, l, n;
    const dkf_real_t *xs[DKF_MAX_DIM];
    dkf_real_t s0 = DKF_R(0.0);
    fu_layout_t L;
    int unique = 0;
    DKF_TRY(check_fusion(fu));
    n = fu->n;
    l = fu->l;
    DKF_TRY(present_set(fu, x, idx, xs, &u));
    L = fu_mem(fu);
    /* P_S(i, j) = Hs P_ij Hs^T for every pair (Theorem 2) */
    for (i = 0; i < l; ++i)
        for (j = i; j < l; ++j) {
            const dkf_real_t *B = block(L.Pj, n, l, i, j);
            dkf_real_t v = DKF_R(0.0);
            size_t a;
            for (a = 0; a < n; ++a) v += L.Hs[a] * dkf__dot(B + a * n * l, L.Hs, n);
            L.PSt[i * l + j] = L.PSt[j * l + i] = v;
        }
    /* every pair's, not only the present ones': an absent sensor's entry
     * may overflow, and P_S is a result */
    if (!dkf__all_finite(L.PSt, l * l)) return DKF_ERR_NONFINITE;
    for (i = 0; i < u; ++i)
        for (j = 0; j < u; ++j) L.Pn[i * u + j] = L.PSt[idx[i] * l + idx[j]];
    DKF_TRY(fuse_weights(&L, u, 1, &unique));
    for (i = 0; i < l; ++i) L.wt[i] = DKF_R(0.0);
    for (i = 0; i < u; ++i) {
        L.wt[idx[i]] = L.Z[i];
        s0 += L.Z[i] * dkf__dot(L.Hs, xs[i], n);
    }
    if (!dkf__all_finite(&s0, 1)) return DKF_ERR_NONFINITE;
    dkf__copy(L.PS, L.PSt, l * l);
    dkf__copy(L.w, L.wt, l);
    fu->s0 = s0;
    fu->PS0 = L.Pft[0];
    fu->w_unique = unique;
    fu->used = u;
    return DKF_OK;
}

dkf_status_t dkf_wfusion_fuse_matrix(dkf_wfusion_t *fu, const dkf_mat_t *const x[])
{
    size_t idx[DKF_MAX_DIM], i, j, r, u, l, n, N, U;
    const dkf_real_t *xs[DKF_MAX_DIM];
    fu_layout_t L;
    int unique = 0;
    DKF_TRY(check_fusion(fu));
    n = fu->n;
    l = fu->l;
    N = n * l;
    DKF_TRY(present_set(fu, x, idx, xs, &u));
    L = fu_mem(fu);
    U = u * n;
    /* S = the present sensors' sub-block of (P_ij) */
    for (i = 0; i < u; ++i)
        for (j = 0; j < u; ++j)
            for (r = 0; r < n; ++r)
                dkf__copy(L.Pn + (i * n + r) * U + j * n,
                          block(L.Pj, n, l, idx[i], idx[j]) + r * N, n);
    DKF_TRY(fuse_weights(&L, u, n, &unique));
    /* A_i = (Z_i)^T, xf = sum_i A_i x_i */
    for (i = 0; i < n * N; ++i) L.At[i] = DKF_R(0.0);
    for (i = 0; i < n; ++i) L.xft[i] = DKF_R(0.0);
    for (i = 0; i < u; ++i)
        for (r = 0; r < n; ++r)
            for (j = 0; j < n; ++j) {
                const dkf_real_t a = L.Z[(i * n + j) * n + r]; /* A_i(r, j) = Z(i n + j, r) */
                L.At[r * N + idx[i] * n + j] = a;
                L.xft[r] += a * xs[i][j];
            }
    if (!dkf__all_finite(L.xft, n)) return DKF_ERR_NONFINITE;
    dkf__copy(L.A, L.At, n * N);
    dkf__copy(L.xf, L.xft, n);
    dkf__copy(L.Pf, L.Pft, n * n);
    fu->A_unique = unique;
    fu->used = u;
    return DKF_OK;
}

/* ---- checkpoints ----------------------------------------------------------------- */

#define WF_CKPT_TAG 0x5746u /* "WF" */

/* header: tag, n, l, m_0..m_{l-1}, steady, t (DKF__CKPT_K_LEN digits) */
static size_t ckpt_header_len(size_t l) { return 4 + l + DKF__CKPT_K_LEN; }

size_t dkf_wfusion_checkpoint_len(const dkf_wfusion_t *fu)
{
    size_t i, len;
    if (fu == NULL || !fu->priv.ready) return 0;
    len = ckpt_header_len(fu->l) + fu->n * fu->l * fu->n * fu->l;
    for (i = 0; i < fu->l; ++i)
        len += DKF__CKPT_K_LEN + DKF_WFUSION_LOCAL_STATE_LEN(fu->n, fu->nodes[i].m);
    return len;
}

dkf_status_t dkf_wfusion_save(const dkf_wfusion_t *fu, dkf_real_t *buf, size_t len)
{
    size_t i, k = 0, sl;
    DKF_TRY(check_fusion(fu));
    DKF_CHECK_NULL(buf);
    if (len < dkf_wfusion_checkpoint_len(fu)) return DKF_ERR_CAPACITY;
    buf[k++] = (dkf_real_t)WF_CKPT_TAG;
    buf[k++] = (dkf_real_t)fu->n;
    buf[k++] = (dkf_real_t)fu->l;
    for (i = 0; i < fu->l; ++i) buf[k++] = (dkf_real_t)fu->nodes[i].m;
    buf[k++] = (dkf_real_t)(fu->steady != 0);
    dkf__ckpt_put_k(buf + k, (size_t)fu->t);
    k += DKF__CKPT_K_LEN;
    for (i = 0; i < fu->l; ++i) {
        sl = DKF_WFUSION_LOCAL_STATE_LEN(fu->n, fu->nodes[i].m);
        dkf__ckpt_put_k(buf + k, (size_t)fu->nodes[i].t);
        k += DKF__CKPT_K_LEN;
        dkf__copy(buf + k, fu->nodes[i].x.data, sl);
        k += sl;
    }
    dkf__copy(buf + k, fu->Pj.data, fu->n * fu->l * fu->n * fu->l);
    return DKF_OK;
}

dkf_status_t dkf_wfusion_restore(dkf_wfusion_t *fu, const dkf_real_t *buf, size_t len)
{
    size_t i, k = 0, sl, steady = 0, t = 0, tn[DKF_MAX_DIM];
    const size_t NN = fu != NULL ? fu->n * fu->l * fu->n * fu->l : 0;
    DKF_TRY(check_fusion(fu));
    DKF_CHECK_NULL(buf);
    if (len < dkf_wfusion_checkpoint_len(fu)) return DKF_ERR_CAPACITY;
    /* every check first: nothing is written unless all pass */
    if (!dkf__ckpt_is(buf[0], WF_CKPT_TAG) || !dkf__ckpt_is(buf[1], fu->n) ||
        !dkf__ckpt_is(buf[2], fu->l))
        return DKF_ERR_ARG;
    for (i = 0; i < fu->l; ++i)
        if (!dkf__ckpt_is(buf[3 + i], fu->nodes[i].m)) return DKF_ERR_ARG;
    k = 3 + fu->l;
    if (!dkf__ckpt_int(buf[k++], 1, &steady)) return DKF_ERR_ARG;
    DKF_TRY(dkf__ckpt_get_k(buf + k, &t));
    k += DKF__CKPT_K_LEN;
    for (i = 0; i < fu->l; ++i) {
        sl = DKF_WFUSION_LOCAL_STATE_LEN(fu->n, fu->nodes[i].m);
        DKF_TRY(dkf__ckpt_get_k(buf + k, &tn[i]));
        k += DKF__CKPT_K_LEN;
        if (!dkf__all_finite(buf + k, sl)) return DKF_ERR_NONFINITE;
        k += sl;
    }
    if (!dkf__all_finite(buf + k, NN)) return DKF_ERR_NONFINITE;
    k = ckpt_header_len(fu->l);
    for (i = 0; i < fu->l; ++i) {
        sl = DKF_WFUSION_LOCAL_STATE_LEN(fu->n, fu->nodes[i].m);
        k += DKF__CKPT_K_LEN;
        dkf__copy(fu->nodes[i].x.data, buf + k, sl);
        fu->nodes[i].t = (unsigned long)tn[i];
        fu->nodes[i].steady = (int)steady;
        k += sl;
    }
    dkf__copy(fu->Pj.data, buf + k, NN);
    fu->t = (unsigned long)t;
    fu->steady = (int)steady;
    return DKF_OK;
}
