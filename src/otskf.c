/*
 * Optimal two-stage Kalman filter (dkf/otskf.h), in the form of the
 * docs/design/derivation-seed000.md §5 (docs/design/diffkf.md), derived for d_{k+1} = B d_k + wd_k.
 *
 * Time update, from x = x~ + Bl d (Bl = V_{k-1} after an update):
 *   d_{k|k-1}   = B d                    P^d_{k|k-1} = B P^d B^T + Rd
 *   Ubar        = F Bl B^{-1}            U = Ubar (I - Rd (P^d_{k|k-1})^{-1})
 *   x~_{k|k-1}  = F x~ + (Ubar - U) d_{k|k-1}
 *   P^x_{k|k-1} = F P^x F^T + Q + U Rd Ubar^T
 * Ubar - U = Ubar T and U Rd Ubar^T = Ubar Y Ubar^T with T = Rd (P^d)^{-1}
 * and Y = Rd - Rd (P^d)^{-1} Rd, which is symmetric, so P^x stays exactly
 * symmetric. (The tempting (Ubar - U) Rd Ubar^T is wrong: derivation §5.)
 *
 * Measurement update, from x = x~ + U d (U = U_k after a predict; A is the
 * feedthrough meas->D, the paper's A_k):
 *   S   = H U + A                         Sx = H P^x H^T + R
 *   K^x = P^x H^T Sx^{-1}                 x~ += K^x (y - H x~)
 *   P^x = (I - K^x H) P^x (I - K^x H)^T + K^x R K^x^T   (Joseph; DKF_JOSEPH=0:
 *                                         P^x -= K^x Sx K^x^T)
 *   Sd  = Sx + S P^d S^T                  K^d = P^d S^T Sd^{-1}
 *   d   += K^d (y - H x~_{k|k-1} - S d)
 *   P^d = (I - K^d S) P^d (I - K^d S)^T + K^d Sx K^d^T (Joseph; or P^d -= K^d Sd K^d^T)
 *   V   = U - K^x S
 * and the combined estimate x = x~ + V d, P = P^x + V P^d V^T.
 *
 * Every step validates its inputs once, computes into scratch with the
 * unchecked kernels, and copies over the state only when every result is
 * finite, so a failed step leaves the filter bit-identical. Nothing of
 * size n + p is ever formed: that is the OTSKF's saving over the ASKF.
 */
#include "dkf/otskf.h"

#include <string.h>

#include "internal.h"
#include "kernels.h"

/* Scratch of the time update (DKF__OTSKF_PREDICT_LEN). W1, W2 are the LU
 * workspace of B^{-1} (2 p^2, contiguous), then hold T^T = P^d^{-1} Rd
 * and Y. Lpd first holds B P^d. FV (F Bl) later holds Ubar T. */
typedef struct {
    dkf_real_t *Binv, *W1, *W2, *Pdn, *Lpd, *FV, *Ubar, *Un, *T, *N1, *N2, *Pn, *dn, *xtn, *xn;
} pred_scratch_t;

/* Scratch of the measurement update (DKF__OTSKF_UPDATE_LEN). Sd holds its
 * own Cholesky factor. */
typedef struct {
    dkf_real_t *Sk, *HP, *Sx, *Lx, *KxT, *Sd, *SkPd, *KdT, *Pxn, *Pn, *Pdn, *Vn, *T, *r, *xtn,
        *dn, *xn, *J;
} upd_scratch_t;

/* Walks the time update's scratch from base (DKF__OTSKF_PREDICT_LEN
 * reals); with base == NULL it only counts. */
static size_t pred_layout(pred_scratch_t *s, dkf_real_t *base, size_t n, size_t p)
{
    size_t used = 0;
    DKF_TAKE(s->Binv, p * p);
    DKF_TAKE(s->W1, p * p);
    DKF_TAKE(s->W2, p * p);
    DKF_TAKE(s->Pdn, p * p);
    DKF_TAKE(s->Lpd, p * p);
    DKF_TAKE(s->FV, n * p);
    DKF_TAKE(s->Ubar, n * p);
    DKF_TAKE(s->Un, n * p);
    DKF_TAKE(s->T, n * p);
    DKF_TAKE(s->N1, n * n);
    DKF_TAKE(s->N2, n * n);
    DKF_TAKE(s->Pn, n * n);
    DKF_TAKE(s->dn, p);
    DKF_TAKE(s->xtn, n);
    DKF_TAKE(s->xn, n);
    return used;
}

/* The measurement update's scratch likewise (DKF__OTSKF_UPDATE_LEN). */
static size_t upd_layout(upd_scratch_t *s, dkf_real_t *base, size_t n, size_t m, size_t p)
{
    size_t used = 0;
    DKF_TAKE(s->Sk, m * p);
    DKF_TAKE(s->HP, m * n);
    DKF_TAKE(s->Sx, m * m);
    DKF_TAKE(s->Lx, m * m);
    DKF_TAKE(s->KxT, m * n);
    DKF_TAKE(s->Sd, m * m);
    DKF_TAKE(s->SkPd, m * p);
    DKF_TAKE(s->KdT, m * p);
    DKF_TAKE(s->Pxn, n * n);
    DKF_TAKE(s->Pn, n * n);
    DKF_TAKE(s->Pdn, p * p);
    DKF_TAKE(s->Vn, n * p);
    DKF_TAKE(s->T, n * p);
    DKF_TAKE(s->r, m);
    DKF_TAKE(s->xtn, n);
    DKF_TAKE(s->dn, p);
    DKF_TAKE(s->xn, n);
    DKF_TAKE(s->J, DKF__JOSEPH_WORK(n > p ? n : p, m));
    return used;
}

/* The whole storage: the state (DKF_OTSKF_STATE_LEN), the scratch both
 * steps share (the larger of their layouts), then the last D_k that
 * passed the rank check (m p). */
typedef struct {
    dkf_real_t *xt, *x, *Px, *P, *d, *Pd, *U, *V; /* state */
    dkf_real_t *work, *D_ok;
} otskf_layout_t;

static size_t otskf_layout(otskf_layout_t *L, dkf_real_t *base, size_t n, size_t m, size_t p)
{
    pred_scratch_t ps;
    upd_scratch_t us;
    const size_t pl = pred_layout(&ps, NULL, n, p), ul = upd_layout(&us, NULL, n, m, p);
    size_t used = 0;
    DKF_TAKE(L->xt, n);
    DKF_TAKE(L->x, n);
    DKF_TAKE(L->Px, n * n);
    DKF_TAKE(L->P, n * n);
    DKF_TAKE(L->d, p);
    DKF_TAKE(L->Pd, p * p);
    DKF_TAKE(L->U, n * p);
    DKF_TAKE(L->V, n * p);
    DKF_TAKE(L->work, pl > ul ? pl : ul);
    DKF_TAKE(L->D_ok, m * p);
    return used;
}

static pred_scratch_t pred_scratch(const dkf_otskf_t *f)
{
    pred_scratch_t s;
    (void)pred_layout(&s, f->priv.work, f->n, f->p);
    return s;
}

static upd_scratch_t upd_scratch(const dkf_otskf_t *f)
{
    upd_scratch_t s;
    (void)upd_layout(&s, f->priv.work, f->n, f->m, f->p);
    return s;
}

/* y (n) = a (n) + A (n x c) b (c). */
static void add_mul_vec(dkf_real_t *y, const dkf_real_t *a, const dkf_real_t *A,
                        const dkf_real_t *b, size_t n, size_t c)
{
    size_t i;
    for (i = 0; i < n; ++i) y[i] = a[i] + dkf__dot(A + i * c, b, c);
}

dkf_status_t dkf_otskf_init(dkf_otskf_t *f, size_t n, size_t m, size_t p, dkf_real_t *storage,
                            size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0,
                            const dkf_mat_t *d0, const dkf_mat_t *Pd0)
{
    dkf_real_t inv[DKF_MAX_DIM];
    otskf_layout_t L;
    dkf_otskf_t g;
    DKF_CHECK_NULL(f);
    DKF_CHECK_NULL(storage);
    if (n == 0 || m == 0 || p == 0 || n > DKF_MAX_DIM || m > DKF_MAX_DIM || p > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    if (storage_len < otskf_layout(&L, NULL, n, m, p)) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    DKF_TRY(dkf__check_input(d0, p, 1));
    DKF_TRY(dkf__check_input(Pd0, p, p));
    /* both priors must be SPD (factored in the scratch, which holds nothing) */
    (void)otskf_layout(&L, storage, n, m, p);
    if (dkf__chol(L.work, inv, P0->data, n) != 0) return DKF_ERR_NOT_SPD;
    if (dkf__chol(L.work, inv, Pd0->data, p) != 0) return DKF_ERR_NOT_SPD;

    memset(&g, 0, sizeof g);
    g.n = n;
    g.m = m;
    g.p = p;
    dkf__view(&g.xt, n, 1, L.xt);
    dkf__view(&g.x, n, 1, L.x);
    dkf__view(&g.Px, n, n, L.Px);
    dkf__view(&g.P, n, n, L.P);
    dkf__view(&g.d, p, 1, L.d);
    dkf__view(&g.Pd, p, p, L.Pd);
    dkf__view(&g.U, n, p, L.U);
    dkf__view(&g.V, n, p, L.V);
    g.priv.work = L.work;
    g.priv.D_ok = L.D_ok;
    /* V_0 = 0: x~_{0|0} = x_{0|0}, P^x_{0|0} = P_{0|0} */
    dkf__copy(g.xt.data, x0->data, n);
    dkf__copy(g.x.data, x0->data, n);
    dkf__copy(g.Px.data, P0->data, n * n);
    dkf__copy(g.P.data, P0->data, n * n);
    dkf__copy(g.d.data, d0->data, p);
    dkf__copy(g.Pd.data, Pd0->data, p * p);
    memset(g.U.data, 0, 2 * n * p * sizeof(dkf_real_t));
    g.priv.blend_is_v = 1;
    g.priv.ready = 1;
    *f = g;
    return DKF_OK;
}

/* The blending matrix that currently ties x to x~ and d. */
static const dkf_real_t *blend(const dkf_otskf_t *f)
{
    return f->priv.blend_is_v ? f->V.data : f->U.data;
}

/* The end of both steps: the combined estimate x = x~ + B d and
 * P = P^x + B P^d B^T for the new blending matrix B (U after a predict, V
 * after an update), a finiteness check of every result, the check that
 * P^x, P^d and P are PSD up to rounding (DKF_ERR_NOT_SPD otherwise:
 * docs/decisions.md item 17), and the commit. T (n x p), xn (n), Pn
 * (n x n) and W (max(n, p)^2, the check's factor) are scratch. */
static dkf_status_t combine_and_commit(dkf_otskf_t *f, const dkf_real_t *xt,
                                       const dkf_real_t *Px, const dkf_real_t *d,
                                       const dkf_real_t *Pd, const dkf_real_t *B, int blend_is_v,
                                       dkf_real_t *T, dkf_real_t *xn, dkf_real_t *Pn,
                                       dkf_real_t *W)
{
    const size_t n = f->n, p = f->p;
    add_mul_vec(xn, xt, B, d, n, p);
    dkf__mul_nn(T, B, Pd, n, p, p);
    dkf__mul_nt_sym(Pn, T, B, Px, n, p);
    if (!dkf__all_finite(xt, n) || !dkf__all_finite(Px, n * n) || !dkf__all_finite(d, p) ||
        !dkf__all_finite(Pd, p * p) || !dkf__all_finite(B, n * p) || !dkf__all_finite(xn, n) ||
        !dkf__all_finite(Pn, n * n))
        return DKF_ERR_NONFINITE;
    if (!dkf__psd_within_rounding(W, Px, n) || !dkf__psd_within_rounding(W, Pd, p) ||
        !dkf__psd_within_rounding(W, Pn, n))
        return DKF_ERR_NOT_SPD;
    dkf__copy(f->xt.data, xt, n);
    dkf__copy(f->Px.data, Px, n * n);
    dkf__copy(f->d.data, d, p);
    dkf__copy(f->Pd.data, Pd, p * p);
    dkf__copy(blend_is_v ? f->V.data : f->U.data, B, n * p);
    dkf__copy(f->x.data, xn, n);
    dkf__copy(f->P.data, Pn, n * n);
    f->priv.blend_is_v = blend_is_v;
    return DKF_OK;
}

dkf_status_t dkf_otskf_predict(dkf_otskf_t *f, const dkf_ui_dyn_t *dyn)
{
    dkf_real_t inv[DKF_MAX_DIM];
    size_t piv[DKF_MAX_DIM];
    size_t n, p, i;
    const dkf_real_t *F, *Q, *B, *Rd;
    dkf_mat_t Binv;
    pred_scratch_t s;
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
    DKF_CHECK_NULL(dyn);
    n = f->n;
    p = f->p;
    DKF_TRY(dkf__check_input(dyn->F, n, n));
    DKF_TRY(dkf__check_input(dyn->Q, n, n));
    DKF_TRY(dkf__check_input(dyn->B, p, p));
    DKF_TRY(dkf__check_input(dyn->Rd, p, p));
    F = dyn->F->data;
    Q = dyn->Q->data;
    B = dyn->B->data;
    Rd = dyn->Rd->data;
    s = pred_scratch(f);

    /* B^{-1} by LU: DKF_ERR_SINGULAR for a (numerically) singular B */
    Binv.rows = Binv.cols = p, Binv.data = s.Binv;
    DKF_TRY(dkf_mat_inverse(&Binv, dyn->B, piv, s.W1));

    /* bias filter: d = B d, P^d = B P^d B^T + Rd (SPD, or no T) */
    dkf__mul_vec(s.dn, B, f->d.data, p, p);
    dkf__mul_nn(s.Lpd, B, f->Pd.data, p, p, p);
    dkf__mul_nt_sym(s.Pdn, s.Lpd, B, Rd, p, p);
    if (dkf__chol(s.Lpd, inv, s.Pdn, p) != 0) return DKF_ERR_NOT_SPD;
    /* W1 = T^T = P^d^{-1} Rd;  W2 = Y = Rd - Rd P^d^{-1} Rd (symmetric) */
    dkf__copy(s.W1, Rd, p * p);
    dkf__chol_solve(s.Lpd, inv, s.W1, p, p);
    dkf__sub_tn_sym(s.W2, Rd, Rd, s.W1, p, p); /* Rd^T = Rd */

    /* Ubar = F Bl B^{-1};  FV := Ubar T;  U = Ubar - Ubar T */
    dkf__mul_nn(s.FV, F, blend(f), n, n, p);
    dkf__mul_nn(s.Ubar, s.FV, s.Binv, n, p, p);
    dkf__mul_nt(s.FV, s.Ubar, s.W1, n, p, p);
    for (i = 0; i < n * p; ++i) s.Un[i] = s.Ubar[i] - s.FV[i];

    /* x~ = F x~ + (Ubar - U) d_{k|k-1} */
    dkf__mul_vec(s.xtn, F, f->xt.data, n, n);
    add_mul_vec(s.xtn, s.xtn, s.FV, s.dn, n, p);
    /* P^x = F P^x F^T + Q + Ubar Y Ubar^T  (= ... + U Rd Ubar^T), into N1 */
    dkf__mul_nn(s.N1, F, f->Px.data, n, n, n);
    dkf__mul_nt_sym(s.N2, s.N1, F, Q, n, n);
    dkf__mul_nn(s.T, s.Ubar, s.W2, n, p, p);
    dkf__mul_nt_sym(s.N1, s.T, s.Ubar, s.N2, n, p);

    /* the check's factor: N2 (n^2) or W1 (p^2), both free now */
    return combine_and_commit(f, s.xtn, s.N1, s.dn, s.Pdn, s.Un, 0, s.T, s.xn, s.Pn,
                              n >= p ? s.N2 : s.W1);
}

/* A_k of full column rank p (dkf/ui_model.h), by SVD with the default
 * tolerance (docs/reference/matrix.md), before anything is computed; skipped when A_k
 * is bitwise the last matrix that passed (D_ok), *is_new = 1 otherwise.
 * The SVD's workspace, DKF_MAT_SVD_WORK(m, p) reals, never exceeds the
 * update scratch (DKF__OTSKF_UPDATE_LEN has 3 m p + m^2 + p^2 + m + p of
 * it). DKF_ERR_RANK unless rank A_k = p. */
static dkf_status_t check_rank_of_D(const dkf_otskf_t *f, const dkf_mat_t *A, int *is_new)
{
    size_t rank = 0;
    *is_new = 0;
    if (f->priv.d_checked && memcmp(f->priv.D_ok, A->data, f->m * f->p * sizeof *A->data) == 0)
        return DKF_OK;
    DKF_TRY(dkf_mat_rank(&rank, A, DKF_RANK_TOL_DEFAULT, f->priv.work));
    if (rank != f->p) return DKF_ERR_RANK;
    *is_new = 1;
    return DKF_OK;
}

dkf_status_t dkf_otskf_update(dkf_otskf_t *f, const dkf_ui_meas_t *meas, const dkf_mat_t *y)
{
    dkf_real_t inv[DKF_MAX_DIM];
    size_t n, m, p, i;
    int a_new;
    dkf_status_t st;
    const dkf_real_t *H, *A, *R, *Bl;
    upd_scratch_t s;
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
    DKF_CHECK_NULL(meas);
    n = f->n;
    m = f->m;
    p = f->p;
    DKF_TRY(dkf__check_input(meas->H, m, n));
    DKF_TRY(dkf__check_input(meas->D, m, p));
    DKF_TRY(dkf__check_input(meas->R, m, m));
    DKF_TRY(dkf__check_input(y, m, 1));
    DKF_TRY(check_rank_of_D(f, meas->D, &a_new));
    H = meas->H->data;
    A = meas->D->data;
    R = meas->R->data;
    Bl = blend(f);
    s = upd_scratch(f);

    /* S = H U + A: how d enters the bias-free filter's innovation */
    dkf__mul_nn(s.Sk, H, Bl, m, n, p);
    for (i = 0; i < m * p; ++i) s.Sk[i] += A[i];

    /* bias-free filter: Sx = H P^x H^T + R;  K^x^T = Sx^{-1} H P^x */
    dkf__mul_nn(s.HP, H, f->Px.data, m, n, n);
    dkf__mul_nt_sym(s.Sx, s.HP, H, R, m, n);
    if (dkf__chol(s.Lx, inv, s.Sx, m) != 0) return DKF_ERR_NOT_SPD;
    dkf__copy(s.KxT, s.HP, m * n);
    dkf__chol_solve(s.Lx, inv, s.KxT, m, n);
    /* r = y - H x~_{k|k-1};  x~ += K^x r;  P^x by the Joseph form
     * (I - K^x H) P^x (I - K^x H)^T + K^x R K^x^T (DKF_JOSEPH; the short
     * form P^x - (H P^x)^T K^x^T otherwise) */
    dkf__mul_vec(s.r, H, f->xt.data, m, n);
    for (i = 0; i < m; ++i) s.r[i] = y->data[i] - s.r[i];
    dkf__mul_tn(s.xtn, s.KxT, s.r, f->xt.data, m, n, 1);
#if DKF_JOSEPH
    dkf__joseph(s.Pxn, f->Px.data, s.KxT, H, R, n, m, s.J);
#else
    dkf__sub_tn_sym(s.Pxn, f->Px.data, s.HP, s.KxT, m, n);
#endif

    /* bias filter: Sd = Sx + S P^d S^T;  K^d^T = Sd^{-1} S P^d */
    dkf__mul_nn(s.SkPd, s.Sk, f->Pd.data, m, p, p);
    dkf__mul_nt_sym(s.Sd, s.SkPd, s.Sk, s.Sx, m, p);
    if (dkf__chol(s.Sd, inv, s.Sd, m) != 0) return DKF_ERR_NOT_SPD;
    dkf__copy(s.KdT, s.SkPd, m * p);
    dkf__chol_solve(s.Sd, inv, s.KdT, m, p);
    /* r := r - S d;  d += K^d r;  P^d by the Joseph form of the bias
     * filter, whose measurement matrix is S and noise Sx:
     * (I - K^d S) P^d (I - K^d S)^T + K^d Sx K^d^T (short form
     * P^d - (S P^d)^T K^d^T without DKF_JOSEPH) */
    for (i = 0; i < m; ++i) s.r[i] -= dkf__dot(s.Sk + i * p, f->d.data, p);
    dkf__mul_tn(s.dn, s.KdT, s.r, f->d.data, m, p, 1);
#if DKF_JOSEPH
    dkf__joseph(s.Pdn, f->Pd.data, s.KdT, s.Sk, s.Sx, p, m, s.J);
#else
    dkf__sub_tn_sym(s.Pdn, f->Pd.data, s.SkPd, s.KdT, m, p);
#endif

    /* V = U - K^x S;  x = x~ + V d;  P = P^x + V P^d V^T */
    dkf__sub_tn(s.Vn, Bl, s.KxT, s.Sk, m, n, p);
    st = combine_and_commit(f, s.xtn, s.Pxn, s.dn, s.Pdn, s.Vn, 1, s.T, s.xn, s.Pn, s.J);
    /* A_k passed the check: remembered only with a step that succeeded, so
     * a failed update leaves all of *f and its storage as they were */
    if (st == DKF_OK && a_new) {
        dkf__copy(f->priv.D_ok, A, m * p);
        f->priv.d_checked = 1;
    }
    return st;
}
