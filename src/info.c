/*
 * Linear information filter and exact multi-sensor fusion (dkf/info.h).
 * Equation numbers refer to seed 001 (Ding-Xiao-Zhang 2014) in the linear
 * case, as corrected in docs/ (information contributions (29)-(34), fused
 * sums (54)-(55)).
 */
#include "dkf/info.h"

#include "internal.h"
#include "kernels.h"

/* Storage layout (info_layout; its count is DKF_INFO_STORAGE_LEN): the
 * state x, P, y, Y (DKF_INFO_STATE_LEN), then the scratch of one step,
 * xn, yn (n each) and A, B, C (n*n each). */
typedef struct {
    dkf_real_t *x, *P, *y, *Y;      /* state */
    dkf_real_t *xn, *yn, *A, *B, *C; /* scratch */
} info_layout_t;

/* Walks the storage in the order above; with base == NULL it only counts. */
static size_t info_layout(info_layout_t *L, dkf_real_t *base, size_t n)
{
    size_t used = 0;
    DKF_TAKE(L->x, n);
    DKF_TAKE(L->P, n * n);
    DKF_TAKE(L->y, n);
    DKF_TAKE(L->Y, n * n);
    DKF_TAKE(L->xn, n);
    DKF_TAKE(L->yn, n);
    DKF_TAKE(L->A, n * n);
    DKF_TAKE(L->B, n * n);
    DKF_TAKE(L->C, n * n);
    return used;
}

static info_layout_t info_scratch(const dkf_info_t *f)
{
    info_layout_t L;
    (void)info_layout(&L, f->x.data, f->n);
    return L;
}

/* From the SPD matrix M (n x n, in `spd`) computes its inverse into `inv`
 * and inv * v into `out`; `chol` is n*n scratch. DKF_ERR_NONFINITE if M or
 * v is not finite (an overflow upstream: the inputs are checked, so a
 * non-finite M is never a definiteness question), DKF_ERR_NOT_SPD if M is
 * not SPD. */
static dkf_status_t invert_spd(dkf_real_t *inv, dkf_real_t *out, dkf_real_t *chol,
                               const dkf_real_t *spd, const dkf_real_t *v, size_t n)
{
    dkf_real_t dinv[DKF_MAX_DIM];
    if (!dkf__all_finite(spd, n * n) || !dkf__all_finite(v, n)) return DKF_ERR_NONFINITE;
    if (dkf__chol(chol, dinv, spd, n) != 0) return DKF_ERR_NOT_SPD;
    dkf__chol_inverse(inv, chol, dinv, n);
    dkf__mul_vec(out, inv, v, n, n);
    return DKF_OK;
}

/* Commits (x, P, y, Y) from scratch after a finiteness check and the check
 * that P and Y are PSD up to rounding (docs/decisions.md item 17); W is
 * n x n scratch (the check's factor). */
static dkf_status_t commit(dkf_info_t *f, const dkf_real_t *x, const dkf_real_t *P,
                           const dkf_real_t *y, const dkf_real_t *Y, dkf_real_t *W)
{
    const size_t n = f->n;
    if (!dkf__all_finite(x, n) || !dkf__all_finite(P, n * n) || !dkf__all_finite(y, n) ||
        !dkf__all_finite(Y, n * n))
        return DKF_ERR_NONFINITE;
    if (!dkf__psd_within_rounding(W, P, n) || !dkf__psd_within_rounding(W, Y, n))
        return DKF_ERR_NOT_SPD;
    dkf__copy(f->x.data, x, n);
    dkf__copy(f->P.data, P, n * n);
    dkf__copy(f->y.data, y, n);
    dkf__copy(f->Y.data, Y, n * n);
    return DKF_OK;
}

dkf_status_t dkf_info_init(dkf_info_t *f, size_t n, dkf_real_t *storage, size_t storage_len,
                           const dkf_mat_t *x0, const dkf_mat_t *P0)
{
    dkf_info_t g; /* built aside so a failed init leaves *f as it was */
    info_layout_t s;
    DKF_CHECK_NULL(f);
    DKF_CHECK_NULL(storage);
    if (n == 0 || n > DKF_MAX_DIM || storage_len < info_layout(&s, NULL, n))
        return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    (void)info_layout(&s, storage, n);
    g.n = n;
    dkf__view(&g.x, n, 1, s.x);
    dkf__view(&g.P, n, n, s.P);
    dkf__view(&g.y, n, 1, s.y);
    dkf__view(&g.Y, n, n, s.Y);
    g.priv.work = s.xn;
    g.priv.ready = 1;
    /* Y0 = P0^{-1}, y0 = Y0 x0 */
    DKF_TRY(invert_spd(s.B, s.yn, s.C, P0->data, x0->data, n));
    DKF_TRY(commit(&g, x0->data, P0->data, s.yn, s.B, s.C));
    *f = g;
    return DKF_OK;
}

dkf_status_t dkf_info_predict(dkf_info_t *f, const dkf_kf_dyn_t *dyn)
{
    const dkf_mat_t *F, *Q;
    size_t n;
    info_layout_t s;
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
    DKF_CHECK_NULL(dyn);
    F = dyn->F;
    Q = dyn->Q;
    n = f->n;
    DKF_TRY(dkf__check_input(F, n, n));
    DKF_TRY(dkf__check_input(Q, n, n));
    s = info_scratch(f);
    /* x- = F x;  P- = F P F^T + Q  (A = F P, then the symmetric product) */
    dkf__mul_vec(s.xn, F->data, f->x.data, n, n);
    dkf__mul_nn(s.A, F->data, f->P.data, n, n, n);
    dkf__mul_nt_sym(s.C, s.A, F->data, Q->data, n, n);
    /* Y- = (P-)^{-1}, y- = Y- x- (an overflow of F P F^T is NONFINITE) */
    DKF_TRY(invert_spd(s.B, s.yn, s.A, s.C, s.xn, n));
    return commit(f, s.xn, s.C, s.yn, s.B, s.A);
}

dkf_status_t dkf_info_contribution(dkf_mat_t *i, dkf_mat_t *I, const dkf_kf_meas_t *meas,
                                   const dkf_mat_t *z, dkf_real_t *work)
{
    const dkf_mat_t *C, *R; /* C = meas->H: the measurement matrix (seed 001's C_j) */
    size_t n, m, a, b, l, pass;
    dkf_real_t *L, *W, inv[DKF_MAX_DIM], w[DKF_MAX_DIM];
    DKF_CHECK_NULL(meas);
    C = meas->H;
    R = meas->R;
    DKF_TRY(dkf__check_mat(C));
    n = C->cols;
    m = C->rows;
    DKF_CHECK_NULL(work);
    DKF_TRY(dkf__check_input(C, m, n));
    DKF_TRY(dkf__check_input(R, m, m));
    DKF_TRY(dkf__check_input(z, m, 1));
    DKF_TRY(dkf__check_shape(i, n, 1));
    DKF_TRY(dkf__check_shape(I, n, n));
    DKF_CHECK_NO_ALIAS(i, I);
    DKF_CHECK_NO_ALIAS(I, C);
    DKF_CHECK_NO_ALIAS(I, R);
    DKF_CHECK_NO_ALIAS(I, z);
    DKF_CHECK_NO_ALIAS(i, C);
    DKF_CHECK_NO_ALIAS(i, R);
    DKF_CHECK_NO_ALIAS(i, z);
    if (dkf__overlap_buf(I, work, DKF_INFO_CONTRIB_WORK(n, m)) ||
        dkf__overlap_buf(i, work, DKF_INFO_CONTRIB_WORK(n, m)))
        return DKF_ERR_ALIAS;
    L = work;
    W = L + m * m;
    /* R = L L^T;  W = L^{-1} C, w = L^{-1} z (forward substitution, never
     * R^{-1}): the square-root form of (31)-(34) */
    if (dkf__chol(L, inv, R->data, m) != 0) return DKF_ERR_NOT_SPD;
    dkf__whiten(W, w, L, inv, C->data, z->data, m, n);
    if (!dkf__all_finite(W, m * n) || !dkf__all_finite(w, m)) return DKF_ERR_NONFINITE;
    /* I = W^T W: a Gram matrix, exactly symmetric and PSD up to the rounding
     * of its dot products (the form C^T (R^{-1} C) used before is not a
     * Gram form, and an ill-conditioned R made it indefinite); i = W^T w.
     * Twice: the first pass only checks for overflow, so that a failure
     * leaves the outputs untouched (there is no room to stage n^2 results). */
    for (pass = 0; pass < 2; ++pass)
        for (a = 0; a < n; ++a) {
            dkf_real_t v = DKF_R(0.0);
            for (l = 0; l < m; ++l) v += W[l * n + a] * w[l];
            if (pass == 0 && !dkf__all_finite(&v, 1)) return DKF_ERR_NONFINITE;
            if (pass == 1) i->data[a] = v;
            for (b = a; b < n; ++b) {
                dkf_real_t g = DKF_R(0.0);
                for (l = 0; l < m; ++l) g += W[l * n + a] * W[l * n + b];
                if (pass == 0 && !dkf__all_finite(&g, 1)) return DKF_ERR_NONFINITE;
                if (pass == 1) I->data[a * n + b] = g, I->data[b * n + a] = g;
            }
        }
    return DKF_OK;
}

dkf_status_t dkf_info_fuse(dkf_info_t *f, const dkf_mat_t i[], const dkf_mat_t I[],
                           size_t count)
{
    size_t n, j, e;
    info_layout_t s;
    DKF_CHECK_NULL(f);
    if (!f->priv.ready) return DKF_ERR_STATE;
    if (count > 0) {
        DKF_CHECK_NULL(i);
        DKF_CHECK_NULL(I);
    }
    n = f->n;
    for (j = 0; j < count; ++j) {
        DKF_TRY(dkf__check_input(&i[j], n, 1));
        DKF_TRY(dkf__check_input(&I[j], n, n));
    }
    s = info_scratch(f);
    /* (54)-(55): Y = Y- + sum I_j, y = y- + sum i_j */
    dkf__copy(s.C, f->Y.data, n * n);
    dkf__copy(s.yn, f->y.data, n);
    for (j = 0; j < count; ++j) {
        for (e = 0; e < n * n; ++e) s.C[e] += I[j].data[e];
        for (e = 0; e < n; ++e) s.yn[e] += i[j].data[e];
    }
    /* the I_j come from outside: Y's factorisation reads one triangle */
    dkf__symmetrise(s.C, n);
    /* P = Y^{-1}, x = P y (an overflow of the sums is NONFINITE) */
    DKF_TRY(invert_spd(s.B, s.xn, s.A, s.C, s.yn, n));
    return commit(f, s.xn, s.B, s.yn, s.C, s.A);
}
