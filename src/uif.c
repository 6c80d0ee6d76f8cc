/*
 * Joint state and unknown-input filters (dkf/uif.h): RTSF, NRTSF-DF and
 * NRTSF of seed 004 in the corrected form of docs/design/uif.md. Letters as in
 * dkf/ui_model.h: the paper's A, C, H (and its F = C Gbar) are F, H, D
 * (and HG = H Gbar) here, its input dimension m is p, its p is m.
 *
 * The three filters share one measurement step. With B the m x r matrix
 * through which the (virtual) input reaches the innovation
 *   y~ = y - H x_{k|k-1} = B dbar + e,   e ~ (0, R~),  R~ = H P_{k|k-1} H^T + R
 * (B = D (RTSF), Dbar (NRTSF-DF, D = Dbar T), HG = H Gbar (NRTSF,
 * G_{k-1} = Gbar T)), the input is the weighted least-squares estimate
 *   Pdbar = (B^T R~^-1 B)^-1,  Mbar = Pdbar B^T R~^-1,  dbar = Mbar y~   (28), (52)
 * and, with K = P_{k|k-1} H^T R~^-1 and
 *   Z = -K Dbar (feedthrough)   or   Z = (I - K H) Gbar (NRTSF),
 * both papers' state updates are the one formula
 *   x_{k|k} = x_{k|k-1} + K y~ + Z dbar,     L = K + Z Mbar             (29), (53)
 *   P_{k|k} = P_{k|k-1} - K R~ K^T + Z Pdbar Z^T                        (24), (50)
 *   Pxd = Z Pdbar T^+T,  d = T^+ dbar,  Pd = T^+ Pdbar T^+T,  M = T^+ Mbar
 * (for feedthrough x = x_pred + K (y~ - Dbar dbar); for NRTSF L = K + (I -
 * K H) Gbar Mbar; Pxd = -K Dbar Pdbar T^+T (29) and (I - K H) Gbar Pdbar
 * T^+T (docs/design/derivation-seed003-004.md §1, added)). With DKF_JOSEPH the covariance is the Joseph
 * form (20)/(47), (I - L H) P (I - L H)^T + L R L^T, valid for any L that
 * meets the unbiasedness constraint L Dbar = 0 (19) / L H Gbar = Gbar (46).
 * T comes from the SVD (dkf_mat_frd), so T^+ = T^T; RTSF uses B = D, T = I.
 *
 * A step computes every output into a pending copy of the output block
 * and copies it over the state only when every check has passed. The
 * full-rank decomposition is cached against a bitwise copy of the matrix
 * it came from (a time-invariant D or G costs one SVD in all); a new one
 * is computed into scratch and enters the cache with the commit, so a
 * failed step leaves the cache (and its fields in the struct) as it was.
 */
#include "dkf/uif.h"

#include <string.h>

#include "internal.h"
#include "kernels.h"

/* The output block; the filter's views and the pending copy share it. */
typedef struct {
    dkf_real_t *x, *Px, *d, *Pd, *Pxd, *xp, *Pp, *Rt, *K, *L, *M, *proj;
} out_t;

typedef struct {
    /* cache: the decomposed matrix, Dbar (rows x r), T (r x p); part of
     * the DKF_UIF_STATE_LEN reals a failed step leaves untouched */
    dkf_real_t *Dlast, *Dbar, *Tc;
    out_t nx; /* pending outputs */
    /* scratch */
    dkf_real_t *Dbn, *Tn; /* a new decomposition, cached on commit  rows x r, r x p */
    dkf_real_t *HP;   /* H P_{k|k-1}                       m x n */
    dkf_real_t *Kt;   /* K^T = R~^-1 H P                   m x n */
    dkf_real_t *Lr;   /* Cholesky factor of R~             m x m */
    dkf_real_t *Bm;   /* HG = H Gbar (NRTSF)               m x r */
    dkf_real_t *W;    /* R~^-1 B                           m x r */
    dkf_real_t *Bt;   /* B^T, then T^T                     r x m, p x r */
    dkf_real_t *Mbar; /* Pdbar B^T R~^-1                   r x m */
    dkf_real_t *S;    /* B^T R~^-1 B                       r x r */
    dkf_real_t *Ls;   /* its Cholesky factor               r x r */
    dkf_real_t *Pdb;  /* Pdbar = S^-1                      r x r */
    dkf_real_t *X;    /* Pdbar T                           r x p */
    dkf_real_t *T1;   /* F P + G Pxd^T; (I - L H) P        n x n */
    dkf_real_t *Z;    /* F Pxd + G Pd; then Z              n x p, n x r */
    dkf_real_t *ZP;   /* G Pd; then Z Pdbar                n x p, n x r */
    dkf_real_t *T3;   /* L^T (Joseph); -K (short form)     m x n, n x m */
    dkf_real_t *svdw;
    dkf_real_t *J;    /* dkf__joseph's workspace; the PSD check's factor */
} layout_t;

static size_t out_layout(out_t *o, dkf_real_t *base, size_t n, size_t m, size_t p)
{
    size_t used = 0;
    DKF_TAKE(o->x, n);
    DKF_TAKE(o->Px, n * n);
    DKF_TAKE(o->d, p);
    DKF_TAKE(o->Pd, p * p);
    DKF_TAKE(o->Pxd, n * p);
    DKF_TAKE(o->xp, n);
    DKF_TAKE(o->Pp, n * n);
    DKF_TAKE(o->Rt, m * m);
    DKF_TAKE(o->K, n * m);
    DKF_TAKE(o->L, n * m);
    DKF_TAKE(o->M, p * m);
    DKF_TAKE(o->proj, p * p);
    return used;
}

/* Everything after the output block; with base == NULL it only counts. */
static size_t layout(layout_t *L, dkf_real_t *base, size_t n, size_t m, size_t p)
{
    const size_t q = DKF__UIF_Q(n, m);
    size_t used = 0;
    DKF_TAKE(L->Dlast, q * p);
    DKF_TAKE(L->Dbar, q * p);
    DKF_TAKE(L->Tc, p * p);
    used += out_layout(&L->nx, base != NULL ? base + used : NULL, n, m, p);
    DKF_TAKE(L->Dbn, q * p);
    DKF_TAKE(L->Tn, p * p);
    DKF_TAKE(L->HP, m * n);
    DKF_TAKE(L->Kt, m * n);
    DKF_TAKE(L->Lr, m * m);
    DKF_TAKE(L->Bm, m * p);
    DKF_TAKE(L->W, m * p);
    DKF_TAKE(L->Bt, p * m);
    DKF_TAKE(L->Mbar, p * m);
    DKF_TAKE(L->S, p * p);
    DKF_TAKE(L->Ls, p * p);
    DKF_TAKE(L->Pdb, p * p);
    DKF_TAKE(L->X, p * p);
    DKF_TAKE(L->T1, n * n);
    DKF_TAKE(L->Z, n * p);
    DKF_TAKE(L->ZP, n * p);
    DKF_TAKE(L->T3, n * m);
    DKF_TAKE(L->svdw, DKF_MAT_SVD_WORK(q, p));
    DKF_TAKE(L->J, DKF__JOSEPH_WORK(n, m));
    return used;
}

static layout_t mem_of(const dkf_uif_t *f)
{
    layout_t L;
    (void)layout(&L, f->priv.mem, f->n, f->m, f->p);
    return L;
}

dkf_status_t dkf_uif_init(dkf_uif_t *f, dkf_uif_kind_t kind, size_t n, size_t m, size_t p,
                          dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                          const dkf_mat_t *P0)
{
    dkf_real_t inv[DKF_MAX_DIM];
    dkf_uif_t g;
    layout_t L;
    out_t o;
    size_t total;
    DKF_CHECK_NULL(f);
    DKF_CHECK_NULL(storage);
    if (kind != DKF_UIF_RTSF && kind != DKF_UIF_NRTSF_DF && kind != DKF_UIF_NRTSF)
        return DKF_ERR_ARG;
    if (n == 0 || p == 0 || m == 0 || n > DKF_MAX_DIM || p > DKF_MAX_DIM || m > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    /* RTSF needs rank D = p, impossible with fewer measurements */
    if (kind == DKF_UIF_RTSF && m < p) return DKF_ERR_RANK;
    total = out_layout(&o, NULL, n, m, p) + layout(&L, NULL, n, m, p);
    if (storage_len < total) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));

    memset(&g, 0, sizeof g);
    g.n = n;
    g.p = p;
    g.m = m;
    g.kind = kind;
    g.priv.mem = storage + out_layout(&o, storage, n, m, p);
    L = mem_of(&g);
    /* P0 must be SPD (factored in scratch, which holds nothing yet) */
    if (dkf__chol(L.T1, inv, P0->data, n) != 0) return DKF_ERR_NOT_SPD;
    memset(storage, 0, total * sizeof *storage);
    dkf__view(&g.x, n, 1, o.x);
    dkf__view(&g.Px, n, n, o.Px);
    dkf__view(&g.d, p, 1, o.d);
    dkf__view(&g.Pd, p, p, o.Pd);
    dkf__view(&g.Pxd, n, p, o.Pxd);
    dkf__view(&g.x_pred, n, 1, o.xp);
    dkf__view(&g.P_pred, n, n, o.Pp);
    dkf__view(&g.Rtilde, m, m, o.Rt);
    dkf__view(&g.K, n, m, o.K);
    dkf__view(&g.L, n, m, o.L);
    dkf__view(&g.M, p, m, o.M);
    dkf__view(&g.proj, p, p, o.proj);
    dkf__copy(o.x, x0->data, n);
    dkf__copy(o.Px, P0->data, n * n);
    g.rank_tol = DKF_RANK_TOL_DEFAULT;
    g.priv.ready = 1;
    *f = g;
    return DKF_OK;
}

/* Shapes and finiteness of everything a step reads, and the call sequence:
 * a feedthrough filter's first step has no dynamics, every other step has. */
static dkf_status_t check_step_args(const dkf_uif_t *f, const dkf_uif_dyn_t *dyn,
                                    const dkf_ui_meas_t *meas, const dkf_mat_t *y)
{
    const size_t n = f->n, p = f->p, m = f->m;
    const int want_dyn = f->kind == DKF_UIF_NRTSF || f->k > 0;
    DKF_CHECK_NULL(meas);
    if ((dyn != NULL) != want_dyn) return DKF_ERR_STATE;
    if (dyn != NULL) {
        DKF_TRY(dkf__check_input(dyn->F, n, n));
        DKF_TRY(dkf__check_input(dyn->G, n, p));
        DKF_TRY(dkf__check_input(dyn->Q, n, n));
    }
    DKF_TRY(dkf__check_input(meas->H, m, n));
    DKF_TRY(dkf__check_input(meas->R, m, m));
    if (f->kind == DKF_UIF_NRTSF) {
        if (meas->D != NULL) return DKF_ERR_ARG;
    } else {
        DKF_TRY(dkf__check_input(meas->D, m, p));
    }
    return dkf__check_input(y, m, 1);
}

/* x_{k|k-1}, P_{k|k-1} into the pending block:
 *   feedthrough  x = F x + G d,  P = [F G] [Px Pxd; Pxd^T Pd] [F G]^T + Q   (27)
 *   NRTSF        x = F x,        P = F P F^T + Q                           (51)
 * and the prior itself at the first feedthrough step. The two congruence
 * terms are each non-symmetric but their sum is not, so the upper triangles
 * are accumulated and mirrored (dkf__mul_nt_sym). */
static void predict(const dkf_uif_t *f, const layout_t *L, const dkf_uif_dyn_t *dyn)
{
    const size_t n = f->n, p = f->p;
    dkf_real_t Gd[DKF_MAX_DIM];
    size_t i;
    if (dyn == NULL) {
        dkf__copy(L->nx.xp, f->x.data, n);
        dkf__copy(L->nx.Pp, f->Px.data, n * n);
        return;
    }
    dkf__mul_vec(L->nx.xp, dyn->F->data, f->x.data, n, n);
    dkf__mul_nn(L->T1, dyn->F->data, f->Px.data, n, n, n);
    if (f->kind == DKF_UIF_NRTSF) {
        dkf__mul_nt_sym(L->nx.Pp, L->T1, dyn->F->data, dyn->Q->data, n, n);
        return;
    }
    dkf__mul_vec(Gd, dyn->G->data, f->d.data, n, p);
    for (i = 0; i < n; ++i) L->nx.xp[i] += Gd[i];
    /* T1 = F Px + G Pxd^T, Z = F Pxd + G Pd (pending Px as a temporary) */
    dkf__mul_nt(L->nx.Px, dyn->G->data, f->Pxd.data, n, p, n);
    for (i = 0; i < n * n; ++i) L->T1[i] += L->nx.Px[i];
    dkf__mul_nn(L->Z, dyn->F->data, f->Pxd.data, n, n, p);
    dkf__mul_nn(L->ZP, dyn->G->data, f->Pd.data, n, p, p);
    for (i = 0; i < n * p; ++i) L->Z[i] += L->ZP[i];
    dkf__mul_nt_sym(L->nx.Pp, L->T1, dyn->F->data, dyn->Q->data, n, n);
    dkf__mul_nt_sym(L->nx.Pp, L->Z, dyn->G->data, L->nx.Pp, n, p);
}

/* R~ = H P H^T + R (upper triangle of R), its Cholesky factor, K, and the
 * innovation y~ = y - H x_{k|k-1}. DKF_ERR_NOT_SPD if R~ is not SPD. */
static dkf_status_t innovation(const dkf_uif_t *f, const layout_t *L, const dkf_ui_meas_t *meas,
                               const dkf_mat_t *y, dkf_real_t *invr, dkf_real_t *yt)
{
    const size_t n = f->n, m = f->m;
    size_t i;
    if (!dkf__all_finite(L->nx.xp, n) || !dkf__all_finite(L->nx.Pp, n * n))
        return DKF_ERR_NONFINITE; /* overflow in the time update */
    dkf__mul_nn(L->HP, meas->H->data, L->nx.Pp, m, n, n);
    dkf__mul_nt_sym(L->nx.Rt, L->HP, meas->H->data, meas->R->data, m, n);
    if (dkf__chol(L->Lr, invr, L->nx.Rt, m) != 0) return DKF_ERR_NOT_SPD;
    /* K^T = R~^-1 (H P)  (P, R~ symmetric) */
    dkf__copy(L->Kt, L->HP, m * n);
    dkf__chol_solve(L->Lr, invr, L->Kt, m, n);
    dkf__transpose(L->nx.K, L->Kt, m, n);
    dkf__mul_vec(yt, meas->H->data, L->nx.xp, m, n);
    for (i = 0; i < m; ++i) yt[i] = y->data[i] - yt[i];
    return DKF_OK;
}

/* The full-rank decomposition D = Dbar T (rows x p) a step uses: the
 * cached one while D and the tolerance are bitwise unchanged, else a new
 * one in scratch (fresh = 1), which cache_commit stores once the step has
 * succeeded. */
typedef struct {
    const dkf_mat_t *D;
    const dkf_real_t *Dbar, *T;
    size_t rank;
    int fresh;
} frd_t;

/* Rank 0 is not an error here (dkf_mat_frd's only DKF_ERR_RANK is rank
 * 0): the caller decides. Writes only scratch. */
static dkf_status_t decompose(const dkf_uif_t *f, const layout_t *L, const dkf_mat_t *D,
                              frd_t *d)
{
    const size_t rows = D->rows, p = f->p;
    const size_t bytes = rows * p * sizeof(dkf_real_t);
    dkf_mat_t Dbar = DKF_MAT(rows, p, L->Dbn);
    dkf_mat_t T = DKF_MAT(p, p, L->Tn);
    dkf_status_t st;
    size_t r = 0;
    d->D = D;
    if (f->priv.cached && f->priv.cache_rows == rows &&
        memcmp(&f->priv.cache_tol, &f->rank_tol, sizeof f->rank_tol) == 0 &&
        memcmp(L->Dlast, D->data, bytes) == 0) {
        d->Dbar = L->Dbar;
        d->T = L->Tc;
        d->rank = f->priv.cache_rank;
        d->fresh = 0;
        return DKF_OK;
    }
    st = dkf_mat_frd(&Dbar, &T, &r, D, f->rank_tol, L->svdw);
    if (st == DKF_ERR_RANK)
        r = 0;
    else if (st != DKF_OK)
        return st;
    d->Dbar = L->Dbn;
    d->T = L->Tn;
    d->rank = r;
    d->fresh = 1;
    return DKF_OK;
}

/* The commit of a new decomposition into the cache. */
static void cache_commit(dkf_uif_t *f, const layout_t *L, const frd_t *d)
{
    const size_t rows = d->D->rows, p = f->p;
    if (!d->fresh) return;
    dkf__copy(L->Dlast, d->D->data, rows * p);
    dkf__copy(L->Dbar, d->Dbar, rows * p);
    dkf__copy(L->Tc, d->T, p * p);
    f->priv.cache_rows = rows;
    f->priv.cache_rank = d->rank;
    f->priv.cache_tol = f->rank_tol;
    f->priv.cached = 1;
}

/* The input direction matrix B (m x r) and T (r x p, NULL for T = I) of
 * this step, with the existence conditions of each filter. */
static dkf_status_t input_directions(const dkf_uif_t *f, const layout_t *L,
                                     const dkf_uif_dyn_t *dyn, const dkf_ui_meas_t *meas,
                                     frd_t *d, const dkf_real_t **B, const dkf_real_t **T)
{
    const size_t n = f->n, p = f->p, m = f->m;
    size_t r, rf;
    if (f->kind == DKF_UIF_RTSF) {
        DKF_TRY(decompose(f, L, meas->D, d));
        if (d->rank < p) return DKF_ERR_RANK; /* D^T R~^-1 D singular */
        *B = meas->D->data;
        *T = NULL;
    } else if (f->kind == DKF_UIF_NRTSF_DF) {
        DKF_TRY(decompose(f, L, meas->D, d));
        *B = d->Dbar;
        *T = d->T;
    } else {
        DKF_TRY(decompose(f, L, dyn->G, d));
        r = d->rank;
        if (r > 0) {
            dkf_mat_t HG = DKF_MAT(m, r, L->Bm);
            /* HG = C_k Gbar_{k-1} must keep the rank of G_{k-1} (Theorem 5) */
            if (r > m) return DKF_ERR_RANK;
            dkf__mul_nn(L->Bm, meas->H->data, d->Dbar, m, n, r);
            DKF_TRY(dkf_mat_rank(&rf, &HG, f->rank_tol, L->svdw));
            if (rf < r) return DKF_ERR_RANK;
        }
        *B = L->Bm;
        *T = d->T;
    }
    return DKF_OK;
}

/* Weighted least squares for dbar and the state update (file comment),
 * r >= 1. DKF_ERR_RANK if B^T R~^-1 B is numerically singular. */
static dkf_status_t input_update(const dkf_uif_t *f, const layout_t *L, const dkf_real_t *B,
                                 const dkf_real_t *T, const dkf_real_t *Dbar, size_t r,
                                 const dkf_real_t *invr, const dkf_real_t *yt)
{
    const size_t n = f->n, p = f->p, m = f->m;
    dkf_real_t invs[DKF_MAX_DIM], db[DKF_MAX_DIM], v[DKF_MAX_DIM];
    size_t i;
    dkf__copy(L->W, B, m * r);
    dkf__chol_solve(L->Lr, invr, L->W, m, r);
    dkf__transpose(L->Bt, B, m, r);
    dkf__mul_nn_sym(L->S, L->Bt, L->W, NULL, r, m);
    if (dkf__chol(L->Ls, invs, L->S, r) != 0) return DKF_ERR_RANK;
    dkf__chol_inverse(L->Pdb, L->Ls, invs, r);
    dkf__mul_nt(L->Mbar, L->Pdb, L->W, r, r, m);
    dkf__mul_vec(db, L->Mbar, yt, r, m);

    /* Z = -K Dbar (feedthrough) or Gbar - K HG (NRTSF); Z Pdbar */
    dkf__mul_nn(L->Z, L->nx.K, B, n, m, r);
    if (f->kind == DKF_UIF_NRTSF)
        for (i = 0; i < n * r; ++i) L->Z[i] = Dbar[i] - L->Z[i];
    else
        for (i = 0; i < n * r; ++i) L->Z[i] = -L->Z[i];
    dkf__mul_nn(L->ZP, L->Z, L->Pdb, n, r, r);
    /* x += Z dbar;  L = K + Z Mbar */
    dkf__mul_vec(v, L->Z, db, n, r);
    for (i = 0; i < n; ++i) L->nx.x[i] += v[i];
    dkf__mul_nn(L->nx.L, L->Z, L->Mbar, n, r, m);
    for (i = 0; i < n * m; ++i) L->nx.L[i] += L->nx.K[i];

    if (T == NULL) { /* RTSF: T = I, r = p */
        dkf__copy(L->nx.d, db, p);
        dkf__copy(L->nx.M, L->Mbar, p * m);
        dkf__copy(L->nx.Pd, L->Pdb, p * p);
        dkf__copy(L->nx.Pxd, L->ZP, n * p);
        for (i = 0; i < p * p; ++i) L->nx.proj[i] = DKF_R(0.0);
        for (i = 0; i < p; ++i) L->nx.proj[i * p + i] = DKF_R(1.0);
        return DKF_OK;
    }
    /* d = T^T dbar, M = T^T Mbar, Pd = T^T Pdbar T, Pxd = Z Pdbar T, proj = T^T T */
    dkf__mul_tn(L->nx.d, T, db, NULL, r, p, 1);
    dkf__mul_tn(L->nx.M, T, L->Mbar, NULL, r, p, m);
    dkf__mul_nn(L->X, L->Pdb, T, r, r, p);
    dkf__transpose(L->Bt, T, r, p); /* r <= m, so T^T fits where B^T was */
    dkf__mul_nn_sym(L->nx.Pd, L->Bt, L->X, NULL, p, r);
    dkf__mul_nn(L->nx.Pxd, L->ZP, T, n, r, p);
    dkf__mul_nn_sym(L->nx.proj, L->Bt, T, NULL, p, r);
    return DKF_OK;
}

/* P_{k|k}: Joseph form (20)/(47) or the short form (24)/(50). */
static void state_covariance(const dkf_uif_t *f, const layout_t *L, const dkf_ui_meas_t *meas,
                             size_t r)
{
    const size_t n = f->n, m = f->m;
#if DKF_JOSEPH
    /* (I - L H) P (I - L H)^T + L R L^T as written, A = I - L H formed
     * (dkf__joseph: accurate also when P_{k|k} << P_{k|k-1}; the rewrite
     * P - L (H P) + (L R - (P - L H P) H^T) L^T used before subtracted
     * from P; docs/decisions.md item 17) */
    dkf__transpose(L->T3, L->nx.L, n, m); /* T3 = L^T */
    dkf__joseph(L->nx.Px, L->nx.Pp, L->T3, meas->H->data, meas->R->data, n, m, L->J);
    (void)r;
#else
    /* P - K R~ K^T = P - K (H P), then + (Z Pdbar) Z^T */
    size_t i;
    (void)meas;
    for (i = 0; i < n * m; ++i) L->T3[i] = -L->nx.K[i];
    dkf__mul_nn_sym(L->nx.Px, L->T3, L->HP, L->nx.Pp, n, m);
    if (r > 0) dkf__mul_nt_sym(L->nx.Px, L->ZP, L->Z, L->nx.Px, n, r);
#endif
}

/* Largest |G (I - proj)| against sqrt(eps) max|G|: the part of the input
 * that NRTSF-DF's time update feeds with the minimum-norm 0 instead of
 * an estimate. */
static int bias_risk(const dkf_mat_t *G, const dkf_real_t *proj)
{
    const size_t n = G->rows, p = G->cols;
    const dkf_real_t *g = G->data;
    dkf_real_t gmax = DKF_R(0.0), worst = DKF_R(0.0);
    size_t i, j, l;
    for (i = 0; i < n * p; ++i)
        if (DKF_FABS(g[i]) > gmax) gmax = DKF_FABS(g[i]);
    for (i = 0; i < n; ++i)
        for (j = 0; j < p; ++j) {
            dkf_real_t acc = g[i * p + j];
            for (l = 0; l < p; ++l) acc -= g[i * p + l] * proj[l * p + j];
            if (DKF_FABS(acc) > worst) worst = DKF_FABS(acc);
        }
    return worst > DKF_SQRT(DKF_REAL_EPSILON) * gmax;
}

static unsigned char classify(dkf_real_t diag)
{
    const dkf_real_t tau = DKF_SQRT(DKF_REAL_EPSILON);
    if (diag >= DKF_R(1.0) - tau) return DKF_UIF_EST_FULL;
    if (diag <= tau) return DKF_UIF_EST_NONE;
    return DKF_UIF_EST_PARTIAL;
}

dkf_status_t dkf_uif_step(dkf_uif_t *f, const dkf_uif_dyn_t *dyn, const dkf_ui_meas_t *meas,
                          const dkf_mat_t *y)
{
    dkf_real_t invr[DKF_MAX_DIM], yt[DKF_MAX_DIM];
    const dkf_real_t *B = NULL, *T = NULL;
    size_t n, m, p, r = 0, i, olen;
    int risk = 0;
    frd_t d;
    layout_t L;
    out_t o;
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
    DKF_TRY(check_step_args(f, dyn, meas, y));
    n = f->n;
    p = f->p;
    m = f->m;
    L = mem_of(f);

    predict(f, &L, dyn);
    DKF_TRY(innovation(f, &L, meas, y, invr, yt));
    DKF_TRY(input_directions(f, &L, dyn, meas, &d, &B, &T));
    r = d.rank;
    /* x = x_{k|k-1} + K y~ (+ Z dbar below); L = K when r = 0 */
    dkf__mul_vec(L.nx.x, L.nx.K, yt, n, m);
    for (i = 0; i < n; ++i) L.nx.x[i] += L.nx.xp[i];
    if (r > 0) {
        DKF_TRY(input_update(f, &L, B, T, d.Dbar, r, invr, yt));
    } else { /* nothing to estimate: a Kalman step, d = 0 */
        dkf__copy(L.nx.L, L.nx.K, n * m);
        memset(L.nx.d, 0, p * sizeof(dkf_real_t));
        memset(L.nx.M, 0, p * m * sizeof(dkf_real_t));
        memset(L.nx.Pd, 0, p * p * sizeof(dkf_real_t));
        memset(L.nx.Pxd, 0, n * p * sizeof(dkf_real_t));
        memset(L.nx.proj, 0, p * p * sizeof(dkf_real_t));
    }
    state_covariance(f, &L, meas, r);
    if (f->kind == DKF_UIF_NRTSF_DF && dyn != NULL) risk = bias_risk(dyn->G, f->proj.data);
    olen = out_layout(&o, NULL, n, m, p);
    if (!dkf__all_finite(L.nx.x, olen)) return DKF_ERR_NONFINITE;
    /* P_{k|k} and P_{k|k-1} PSD up to rounding (docs/decisions.md item 17) */
    if (!dkf__psd_within_rounding(L.J, L.nx.Px, n) ||
        !dkf__psd_within_rounding(L.J, L.nx.Pp, n))
        return DKF_ERR_NOT_SPD;

    /* commit */
    dkf__copy(f->x.data, L.nx.x, olen);
    cache_commit(f, &L, &d);
    f->rank = r;
    for (i = 0; i < p; ++i) f->estimable[i] = classify(f->proj.data[i * p + i]);
    f->bias_risk = risk;
    if (risk) ++f->bias_steps;
    ++f->k;
    return DKF_OK;
}
