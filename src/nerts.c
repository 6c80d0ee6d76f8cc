/*
 * Seed 001's single-node nonlinear unknown-input filters (dkf/nerts.h):
 * NERTSF / NERTSIF (EKF, eqs 10-34, Algorithm 1) and DNERTSF / DNERTSIF
 * (cubature, eqs 35-57, Algorithm 2), with the corrections of
 * docs/design/infofusion.md: R_tilde = Pzz + R (46), the generalised inverse
 * Pi(Rbar, Hd) in place of the non-existent (I - Hd M)^{-1} (22, 53), the
 * re-drawn measurement points (43).
 *
 * Every phase works on a staged copy of the state region and copies it
 * back only when the whole phase succeeded, so a failure leaves the filter
 * bit-identical. The information kinds use dkf/info.h for their
 * information-form algebra: Y_pred, y_pred (dkf_info_init from the
 * prediction), the contribution of the input-free measurement N z
 * (dkf_info_contribution, N a left annihilator of Hd) and the update
 * (dkf_info_fuse).
 */
#include "dkf/nerts.h"

#include <string.h>

#include "internal.h"
#include "kernels.h"
#include "nerts_internal.h"

/* The views of the state region (or of its staged copy), in layout order:
 * the count is DKF__NERTS_OUT_LEN. */
typedef struct {
    dkf_real_t *x, *Px, *d, *Pd, *Pxd;
    dkf_real_t *x_pred, *P_pred, *Y_pred, *y_pred, *Fx, *Fd;
    dkf_real_t *z_hat, *nu, *h_c, *R_tilde, *Pzz, *Rbar, *Rbar_inv, *Pxz, *Hd, *Hx, *C, *M;
    dkf_real_t *d_loc, *Pd_loc, *Pxd_loc, *i, *I, *Y, *y;
} out_t;

static size_t out_layout(out_t *o, dkf_real_t *base, size_t n, size_t m, size_t p)
{
    size_t used = 0;
    DKF_TAKE(o->x, n);
    DKF_TAKE(o->Px, n * n);
    DKF_TAKE(o->d, p);
    DKF_TAKE(o->Pd, p * p);
    DKF_TAKE(o->Pxd, n * p);
    DKF_TAKE(o->x_pred, n);
    DKF_TAKE(o->P_pred, n * n);
    DKF_TAKE(o->Y_pred, n * n);
    DKF_TAKE(o->y_pred, n);
    DKF_TAKE(o->Fx, n * n);
    DKF_TAKE(o->Fd, n * p);
    DKF_TAKE(o->z_hat, m);
    DKF_TAKE(o->nu, m);
    DKF_TAKE(o->h_c, m);
    DKF_TAKE(o->R_tilde, m * m);
    DKF_TAKE(o->Pzz, m * m);
    DKF_TAKE(o->Rbar, m * m);
    DKF_TAKE(o->Rbar_inv, m * m);
    DKF_TAKE(o->Pxz, n * m);
    DKF_TAKE(o->Hd, m * p);
    DKF_TAKE(o->Hx, m * n);
    DKF_TAKE(o->C, m * n);
    DKF_TAKE(o->M, p * m);
    DKF_TAKE(o->d_loc, p);
    DKF_TAKE(o->Pd_loc, p * p);
    DKF_TAKE(o->Pxd_loc, n * p);
    DKF_TAKE(o->i, n);
    DKF_TAKE(o->I, n * n);
    DKF_TAKE(o->Y, n * n);
    DKF_TAKE(o->y, n);
    return used;
}

#define NERTS_NW 8 /* square scratch matrices */
#define NERTS_NV 8 /* scratch vectors (kept off the stack: Cortex-M4 budget) */

/* The storage: the state (o), its staged copy (s), then scratch: cubature
 * offsets (pts, 2 (n + p) x (n + p)) and images (img, 2 (n + p) x
 * max(n, m)), NERTS_NW matrices of max(n + p, m)^2, NERTS_NV vectors of
 * max(n + p, m), the Jacobians' and the contribution's workspace and an
 * information filter's storage. */
typedef struct {
    out_t o, s;
    size_t out_len;
    dkf_real_t *pts, *img, *w[NERTS_NW], *v[NERTS_NV], *jac, *cw, *info;
} layout_t;

static size_t layout(layout_t *L, dkf_real_t *base, size_t n, size_t m, size_t p)
{
    const size_t nx = n + p, r = nx > m ? nx : m, mx = n > m ? n : m;
    size_t used, j;
    used = out_layout(&L->o, base, n, m, p);
    L->out_len = used;
    used += out_layout(&L->s, base != NULL ? base + used : NULL, n, m, p);
    DKF_TAKE(L->pts, 2 * nx * nx);
    DKF_TAKE(L->img, 2 * nx * mx);
    for (j = 0; j < NERTS_NW; ++j) DKF_TAKE(L->w[j], r * r);
    for (j = 0; j < NERTS_NV; ++j) DKF_TAKE(L->v[j], r);
    DKF_TAKE(L->jac, DKF_NL_JAC_WORK(n, m, p));
    DKF_TAKE(L->cw, DKF_INFO_CONTRIB_WORK(n, m));
    DKF_TAKE(L->info, DKF_INFO_STORAGE_LEN(n));
    return used;
}

static int is_info(const dkf_nerts_t *f)
{
    return f->kind == DKF_NERTS_NERTSIF || f->kind == DKF_NERTS_DNERTSIF;
}

static int is_cubature(const dkf_nerts_t *f)
{
    return f->kind == DKF_NERTS_DNERTSF || f->kind == DKF_NERTS_DNERTSIF;
}

/* d as the callbacks get it: NULL when p = 0. */
static const dkf_real_t *input_arg(const dkf_real_t *d, size_t p)
{
    return p > 0 ? d : NULL;
}

/* ---- callbacks ----------------------------------------------------------- */

static dkf_status_t call_f(const dkf_nl_model_t *md, size_t k, const dkf_real_t *x,
                           const dkf_real_t *d, const dkf_real_t *u, dkf_real_t *out)
{
    if (md->f(md->ctx, k, x, input_arg(d, md->p), u, out) != 0) return DKF_ERR_MODEL;
    return dkf__all_finite(out, md->n) ? DKF_OK : DKF_ERR_NONFINITE;
}

static dkf_status_t call_h(const dkf_nl_model_t *md, size_t k, const dkf_real_t *x,
                           const dkf_real_t *d, const dkf_real_t *u, dkf_real_t *out)
{
    if (md->h(md->ctx, k, x, input_arg(d, md->p), u, out) != 0) return DKF_ERR_MODEL;
    return dkf__all_finite(out, md->m) ? DKF_OK : DKF_ERR_NONFINITE;
}

/* The model fits f and u is given (and finite) when the model has one. */
static dkf_status_t check_model(const dkf_nerts_t *f, const dkf_nl_model_t *md,
                                const dkf_real_t *u)
{
    DKF_TRY(dkf_nl_model_check(md));
    if (md->n != f->n || md->m != f->m || md->p != f->p) return DKF_ERR_DIM;
    if (md->q > 0) {
        if (u == NULL) return DKF_ERR_NULL;
        if (!dkf__all_finite(u, md->q)) return DKF_ERR_NONFINITE;
    }
    return DKF_OK;
}

/* ---- small shared pieces --------------------------------------------------- */

/* J (n + p square) = [[Px, Pxd], [Pxd^T, Pd]], eq 37. */
static void joint_cov(dkf_real_t *J, const dkf_real_t *Px, const dkf_real_t *Pd,
                      const dkf_real_t *Pxd, size_t n, size_t p)
{
    dkf__put_sym_blocks(J, Px, p > 0 ? Pxd : NULL, Pd, n, p);
}

/* Out (ra x rb) = D + (1/count) sum_l A_l B_l^T for the rows A_l (ra), B_l
 * (rb) of A (count x ra) and B (count x rb): the cubature rule's sample
 * (cross) covariance of centred images, eqs 42, 46, 47. D may be NULL. */
static void sample_cov(dkf_real_t *out, const dkf_real_t *A, const dkf_real_t *B, size_t count,
                       size_t ra, size_t rb, const dkf_real_t *D)
{
    const dkf_real_t w = (dkf_real_t)count;
    size_t e;
    dkf__mul_tn(out, A, B, NULL, count, ra, rb);
    for (e = 0; e < ra * rb; ++e) out[e] = out[e] / w + (D != NULL ? D[e] : DKF_R(0.0));
}

/* The 2 nx offsets +-sqrt(nx) S e_j (rows of off, nx x ... ) of the
 * cubature points of N(mean, S S^T), S lower (nx x nx): points j and
 * nx + j are mean + and - sqrt(nx) times column j of S (eq 39). */
static void cubature_offsets(dkf_real_t *off, const dkf_real_t *S, size_t nx)
{
    const dkf_real_t c = DKF_SQRT((dkf_real_t)nx);
    size_t j, a;
    for (j = 0; j < nx; ++j)
        for (a = 0; a < nx; ++a) {
            off[j * nx + a] = c * S[a * nx + j];
            off[(nx + j) * nx + a] = -(c * S[a * nx + j]);
        }
}

/* mean (r) of the count rows of img (count x r), and img's rows centred
 * on it in place. */
static void centre_rows(dkf_real_t *mean, dkf_real_t *img, size_t count, size_t r)
{
    size_t l, a;
    for (a = 0; a < r; ++a) mean[a] = DKF_R(0.0);
    for (l = 0; l < count; ++l)
        for (a = 0; a < r; ++a) mean[a] += img[l * r + a];
    for (a = 0; a < r; ++a) mean[a] /= (dkf_real_t)count;
    for (l = 0; l < count; ++l)
        for (a = 0; a < r; ++a) img[l * r + a] -= mean[a];
}

/* DKF_ERR_NOT_SPD unless the joint covariance of (x, d) is positive
 * definite (the next cubature step factors it); W: (n + p)^2 scratch,
 * chol: another, inv: n + p. */
static dkf_status_t check_joint(const out_t *s, size_t n, size_t p, dkf_real_t *W,
                                dkf_real_t *chol, dkf_real_t *inv)
{
    joint_cov(W, s->Px, s->Pd, s->Pxd, n, p);
    return dkf__chol(chol, inv, W, n + p) == 0 ? DKF_OK : DKF_ERR_NOT_SPD;
}

/* ---- phase 1: time update ------------------------------------------------- */

/* EKF: Fx, Fd at (x, d) (6)-(7), x_pred = f(x, d) (10),
 * P_pred = [Fx Fd] P_joint [Fx Fd]^T + Q (11). */
static dkf_status_t predict_ekf(const dkf_nerts_t *f, layout_t *L, const dkf_nl_model_t *md,
                                const dkf_real_t *u, const dkf_real_t *Q)
{
    const size_t n = f->n, p = f->p, nx = n + p;
    out_t *s = &L->s;
    dkf_real_t *J = L->w[0], *Pj = L->w[1], *T = L->w[2];
    DKF_TRY(dkf_nl_f_jacobian(md, f->k, s->x, input_arg(s->d, p), u, s->Fx, s->Fd, L->jac));
    DKF_TRY(call_f(md, f->k, s->x, s->d, u, s->x_pred));
    dkf__put_block(J, nx, 0, 0, s->Fx, n, n);
    if (p > 0) dkf__put_block(J, nx, 0, n, s->Fd, n, p);
    joint_cov(Pj, s->Px, s->Pd, s->Pxd, n, p);
    dkf__mul_nn(T, J, Pj, n, nx, nx);
    dkf__mul_nt_sym(s->P_pred, T, J, Q, n, nx);
    return dkf__all_finite(s->P_pred, n * n) ? DKF_OK : DKF_ERR_NONFINITE;
}

/* Cubature: the 2 (n + p) points of N([x; d], P_joint) through f (38)-(40),
 * x_pred = mean (41), P_pred = centred sample covariance + Q (42). */
static dkf_status_t predict_cubature(const dkf_nerts_t *f, layout_t *L, const dkf_nl_model_t *md,
                                     const dkf_real_t *u, const dkf_real_t *Q)
{
    const size_t n = f->n, p = f->p, nx = n + p, count = 2 * nx;
    out_t *s = &L->s;
    dkf_real_t *Pj = L->w[0], *S = L->w[1], *inv = L->v[0], *pt = L->v[1];
    size_t l, a;
    joint_cov(Pj, s->Px, s->Pd, s->Pxd, n, p);
    if (dkf__chol(S, inv, Pj, nx) != 0) return DKF_ERR_NOT_SPD;
    cubature_offsets(L->pts, S, nx);
    for (l = 0; l < count; ++l) {
        for (a = 0; a < n; ++a) pt[a] = s->x[a] + L->pts[l * nx + a];
        for (a = 0; a < p; ++a) pt[n + a] = s->d[a] + L->pts[l * nx + n + a];
        DKF_TRY(call_f(md, f->k, pt, pt + n, u, L->img + l * n));
    }
    centre_rows(s->x_pred, L->img, count, n);
    sample_cov(s->P_pred, L->img, L->img, count, n, n, Q);
    dkf__symmetrise(s->P_pred, n);
    return dkf__all_finite(s->P_pred, n * n) ? DKF_OK : DKF_ERR_NONFINITE;
}

/* Y_pred = P_pred^{-1}, y_pred = Y_pred x_pred (Algorithm 1 step 3, eqs
 * 33-34) by the information filter's own initialisation. */
static dkf_status_t info_from_prediction(dkf_info_t *inf, const dkf_nerts_t *f, layout_t *L)
{
    dkf_mat_t xv, Pv;
    dkf__view(&xv, f->n, 1, L->s.x_pred);
    dkf__view(&Pv, f->n, f->n, L->s.P_pred);
    return dkf_info_init(inf, f->n, L->info, DKF_INFO_STORAGE_LEN(f->n), &xv, &Pv);
}

static dkf_status_t predict_staged(const dkf_nerts_t *f, layout_t *L, const dkf_nl_model_t *md,
                                   const dkf_real_t *u, const dkf_real_t *Q)
{
    const size_t n = f->n;
    DKF_TRY(is_cubature(f) ? predict_cubature(f, L, md, u, Q) : predict_ekf(f, L, md, u, Q));
    if (is_info(f)) {
        dkf_info_t inf;
        DKF_TRY(info_from_prediction(&inf, f, L));
        dkf__copy(L->s.Y_pred, inf.Y.data, n * n);
        dkf__copy(L->s.y_pred, inf.y.data, n);
    } else {
        if (dkf__chol(L->w[0], L->v[0], L->s.P_pred, n) != 0) return DKF_ERR_NOT_SPD;
    }
    return DKF_OK;
}

/* ---- phase 2: local measurement statistics -------------------------------- */

/* EKF: Hx, Hd at (x_pred, d) (8)-(9); h_c = h(x_pred, d);
 * Pxz = P_pred Hx^T, Pzz = Hx P_pred Hx^T (12), C = Hx. */
static dkf_status_t local_ekf(const dkf_nerts_t *f, layout_t *L, const dkf_nl_model_t *md,
                              const dkf_real_t *u)
{
    const size_t n = f->n, m = f->m, p = f->p;
    out_t *s = &L->s;
    DKF_TRY(dkf_nl_h_jacobian(md, f->k + 1, s->x_pred, input_arg(s->d, p), u, s->Hx, s->Hd,
                              L->jac));
    DKF_TRY(call_h(md, f->k + 1, s->x_pred, s->d, u, s->h_c));
    dkf__mul_nt(s->Pxz, s->P_pred, s->Hx, n, n, m);
    dkf__mul_nn_sym(s->Pzz, s->Hx, s->Pxz, NULL, m, n);
    dkf__copy(s->C, s->Hx, m * n);
    return DKF_OK;
}

/* Cubature: Hd (eq 44, with Hx) at (x_pred, d) when there is an input
 * (p > 0; without one the cubature rule needs no Jacobian, and Hx is not
 * computed), h_c = h(x_pred, d); the 2n
 * points of N(x_pred, P_pred) through h, unwrapped around h_c by y_diff
 * (43); their mean z_bar (45, before the input term) into z_hat, Pzz,
 * Pxz (46)-(47); C = Pxz^T P_pred^{-1} (50) and the statistical
 * linearisation's residual Rbar - R = Pzz - Pxz^T P_pred^{-1} Pxz (53)
 * into Rbar (R added by the caller). Leaves chol(P_pred) in w[0]. */
static dkf_status_t local_cubature(const dkf_nerts_t *f, layout_t *L, const dkf_nl_model_t *md,
                                   const dkf_real_t *u)
{
    const size_t n = f->n, m = f->m, p = f->p, count = 2 * n;
    out_t *s = &L->s;
    dkf_real_t *S = L->w[0], *V = L->w[1], *Ct = L->w[2];
    dkf_real_t *inv = L->v[0], *pt = L->v[1], *v = L->v[2];
    size_t l, a;
    if (p > 0)
        DKF_TRY(dkf_nl_h_jacobian(md, f->k + 1, s->x_pred, s->d, u, s->Hx, s->Hd, L->jac));
    DKF_TRY(call_h(md, f->k + 1, s->x_pred, s->d, u, s->h_c));
    if (dkf__chol(S, inv, s->P_pred, n) != 0) return DKF_ERR_NOT_SPD;
    cubature_offsets(L->pts, S, n);
    for (l = 0; l < count; ++l) {
        dkf_real_t *z = L->img + l * m;
        for (a = 0; a < n; ++a) pt[a] = s->x_pred[a] + L->pts[l * n + a];
        DKF_TRY(call_h(md, f->k + 1, pt, s->d, u, z));
        if (md->y_diff != NULL) md->y_diff(md->ctx, z, s->h_c, z); /* offset from h_c */
    }
    centre_rows(s->z_hat, L->img, count, m);
    if (md->y_diff != NULL)
        for (a = 0; a < m; ++a) s->z_hat[a] += s->h_c[a];
    sample_cov(s->Pzz, L->img, L->img, count, m, m, NULL);
    sample_cov(s->Pxz, L->pts, L->img, count, n, m, NULL);
    /* V = S^{-1} Pxz: Pxz^T P_pred^{-1} Pxz = V^T V, a Gram matrix */
    dkf__whiten(V, v, S, inv, s->Pxz, s->x_pred, n, m);
    dkf__sub_tn_sym(s->Rbar, s->Pzz, V, V, n, m);
    /* C^T = P_pred^{-1} Pxz */
    dkf__copy(Ct, s->Pxz, n * m);
    dkf__chol_solve(S, inv, Ct, n, m);
    dkf__transpose(s->C, Ct, n, m);
    return DKF_OK;
}

/* The input estimate from R_tilde = L L^T (Lr, inv) and Hd: W = L^{-1} Hd
 * must have full column rank p, decided on the Cholesky factor of the Gram
 * matrix G = W^T W = Hd^T R_tilde^{-1} Hd: DKF_ERR_RANK unless every pivot
 * satisfies L_ii^2 > 16 p eps G_ii, i.e. no column of W lies within an
 * angle of ~ sqrt(16 p eps) (1e-7 in double) of the span of the others
 * (a bare Cholesky would accept the rounding noise of a rank-deficient G
 * whenever it comes out positive). Then Pd_loc = G^{-1} = M R_tilde M^T
 * (15), M = Pd_loc Hd^T R_tilde^{-1} (13), d_loc = M nu (14),
 * Pxd_loc = -Pxz M^T (20). Rinv = R_tilde^{-1}. */
static dkf_status_t input_estimate(const dkf_nerts_t *f, layout_t *L, const dkf_real_t *Lr,
                                   const dkf_real_t *inv, const dkf_real_t *Rinv)
{
    const size_t n = f->n, m = f->m, p = f->p;
    const dkf_real_t tol = DKF_R(16.0) * (dkf_real_t)p * DKF_REAL_EPSILON;
    out_t *s = &L->s;
    dkf_real_t *W = L->w[4], *G = L->w[5], *Lg = L->w[6], *Mt = L->w[7];
    dkf_real_t *w = L->v[5], *ginv = L->v[6];
    size_t e;
    dkf__whiten(W, w, Lr, inv, s->Hd, s->nu, m, p);
    dkf__mul_tn(G, W, W, NULL, m, p, p);
    if (dkf__chol(Lg, ginv, G, p) != 0) return DKF_ERR_RANK;
    for (e = 0; e < p; ++e)
        if (!(Lg[e * p + e] * Lg[e * p + e] > tol * G[e * p + e])) return DKF_ERR_RANK;
    dkf__chol_inverse(s->Pd_loc, Lg, ginv, p);
    /* M^T = R_tilde^{-1} Hd Pd_loc (m x p) */
    dkf__mul_nn(G, Rinv, s->Hd, m, m, p);
    dkf__mul_nn(Mt, G, s->Pd_loc, m, p, p);
    dkf__transpose(s->M, Mt, m, p);
    dkf__mul_vec(s->d_loc, s->M, s->nu, p, m);
    dkf__mul_nn(s->Pxd_loc, s->Pxz, Mt, n, m, p);
    for (e = 0; e < n * p; ++e) s->Pxd_loc[e] = -s->Pxd_loc[e];
    return DKF_OK;
}

/* Information contributions (31)-(32), (56)-(57) with
 * Rbar_inv = Pi(Rbar, Hd) = N^T (N Rbar N^T)^{-1} N, N ((m - p) x m) the
 * orthonormal left annihilator of Hd from its QR factorisation (note
 * section 1): i, I are the information filter's contribution of the
 * input-free measurement N z = N C x + N v, computed by
 * dkf_info_contribution with (N C, N Rbar N^T, N (nu + C x_pred)). With
 * p = 0, N = I: the plain contribution of (C, Rbar). With m = p the
 * measurement carries no state information: i = 0, I = 0. */
static dkf_status_t info_contribution(const dkf_nerts_t *f, layout_t *L)
{
    const size_t n = f->n, m = f->m, p = f->p, q = m - p;
    out_t *s = &L->s;
    dkf_real_t *zc = L->v[0], *zn = L->v[1], *tau = L->v[2];
    dkf_real_t *QR = L->w[0], *Q = L->w[1], *N = L->w[2], *CN = L->w[3], *T = L->w[4];
    dkf_real_t *RN = L->w[5], *RNinv = L->w[6];
    dkf_mat_t iv, Iv, Hv, Rv, zv, A, B;
    dkf_kf_meas_t meas;
    size_t r, c;
    dkf__view(&iv, n, 1, s->i);
    dkf__view(&Iv, n, n, s->I);
    /* zc = nu + C x_pred */
    dkf__mul_vec(zc, s->C, s->x_pred, m, n);
    for (r = 0; r < m; ++r) zc[r] += s->nu[r];
    if (q == 0) {
        for (r = 0; r < n; ++r) s->i[r] = DKF_R(0.0);
        for (r = 0; r < n * n; ++r) s->I[r] = DKF_R(0.0);
        for (r = 0; r < m * m; ++r) s->Rbar_inv[r] = DKF_R(0.0);
        return DKF_OK;
    }
    if (p == 0) {
        for (r = 0; r < m; ++r)
            for (c = 0; c < m; ++c) N[r * m + c] = r == c ? DKF_R(1.0) : DKF_R(0.0);
    } else {
        dkf__view(&A, m, p, s->Hd);
        dkf__view(&B, m, p, QR);
        DKF_TRY(dkf_mat_qr(&B, tau, &A));
        dkf__view(&A, m, m, Q);
        DKF_TRY(dkf_mat_qr_q(&A, &B, tau));
        for (r = 0; r < q; ++r)
            for (c = 0; c < m; ++c) N[r * m + c] = Q[c * m + p + r];
    }
    dkf__mul_nn(CN, N, s->C, q, m, n);
    dkf__mul_nn(T, N, s->Rbar, q, m, m);
    dkf__mul_nt_sym(RN, T, N, NULL, q, m);
    dkf__mul_vec(zn, N, zc, q, m);
    dkf__view(&Hv, q, n, CN);
    dkf__view(&Rv, q, q, RN);
    dkf__view(&zv, q, 1, zn);
    meas.H = &Hv;
    meas.R = &Rv;
    DKF_TRY(dkf_info_contribution(&iv, &Iv, &meas, &zv, L->cw));
    /* Rbar_inv = N^T RN^{-1} N (inspection, and the derivation's (docs/design/derivation-seed001-002.md) Pi) */
    dkf__view(&A, q, q, RNinv);
    DKF_TRY(dkf_mat_spd_inverse(&A, &Rv, L->w[7]));
    dkf__mul_nn(T, RNinv, N, q, q, m);
    dkf__mul_tn(s->Rbar_inv, N, T, NULL, q, m, m);
    dkf__symmetrise(s->Rbar_inv, m);
    return dkf__all_finite(s->Rbar_inv, m * m) ? DKF_OK : DKF_ERR_NONFINITE;
}

static dkf_status_t local_staged(const dkf_nerts_t *f, layout_t *L, const dkf_nl_model_t *md,
                                 const dkf_real_t *u, const dkf_real_t *R, const dkf_real_t *z)
{
    const size_t m = f->m, p = f->p;
    out_t *s = &L->s;
    /* v[0..2] are local_cubature's, v[5..6] input_estimate's */
    dkf_real_t *inv = L->v[3], *zbar = L->v[4];
    /* w[0..2] are local_cubature's; Lr, Rinv reuse w[0], w[1] after it */
    dkf_real_t *Rs = L->w[3], *Lr = L->w[0], *Rinv = L->w[1];
    size_t e;
    /* R symmetrised, SPD */
    dkf__copy(Rs, R, m * m);
    dkf__symmetrise(Rs, m);
    if (dkf__chol(Lr, inv, Rs, m) != 0) return DKF_ERR_NOT_SPD;
    if (is_cubature(f)) {
        DKF_TRY(local_cubature(f, L, md, u));
        dkf__copy(zbar, s->z_hat, m);
        for (e = 0; e < m * m; ++e) s->Rbar[e] += Rs[e];
    } else {
        DKF_TRY(local_ekf(f, L, md, u));
        dkf__copy(zbar, s->h_c, m);
        dkf__copy(s->Rbar, Rs, m * m);
    }
    /* R_tilde = Pzz + R (12), (46) corrected; z_hat = z_bar - Hd d (14), (43) */
    for (e = 0; e < m * m; ++e) s->R_tilde[e] = s->Pzz[e] + Rs[e];
    dkf__mul_vec(s->z_hat, s->Hd, s->d, m, p);
    for (e = 0; e < m; ++e) s->z_hat[e] = zbar[e] - (p > 0 ? s->z_hat[e] : DKF_R(0.0));
    dkf_nl_y_diff(md, z, s->z_hat, s->nu);
    if (!dkf__all_finite(s->nu, m) || !dkf__all_finite(s->R_tilde, m * m) ||
        !dkf__all_finite(s->Rbar, m * m) || !dkf__all_finite(s->C, m * f->n))
        return DKF_ERR_NONFINITE;
    if (dkf__chol(Lr, inv, s->R_tilde, m) != 0) return DKF_ERR_NOT_SPD;
    dkf__chol_inverse(Rinv, Lr, inv, m);
    if (p > 0) DKF_TRY(input_estimate(f, L, Lr, inv, Rinv));
    if (dkf__chol(Lr, inv, s->Rbar, m) != 0) return DKF_ERR_NOT_SPD;
    if (is_info(f)) DKF_TRY(info_contribution(f, L));
    if (!dkf__all_finite(s->d_loc, p) || !dkf__all_finite(s->Pd_loc, p * p) ||
        !dkf__all_finite(s->Pxd_loc, f->n * p) || !dkf__all_finite(s->M, p * m))
        return DKF_ERR_NONFINITE;
    return DKF_OK;
}

/* ---- phase 3: commits ----------------------------------------------------- */

/* The posterior's input part from the local statistics, then the checks
 * every commit makes: finite, Px PSD within rounding (docs/decisions.md
 * item 17) and the joint covariance positive definite. */
static dkf_status_t finish_commit(const dkf_nerts_t *f, layout_t *L)
{
    const size_t n = f->n, p = f->p;
    out_t *s = &L->s;
    dkf__copy(s->d, s->d_loc, p);
    dkf__copy(s->Pd, s->Pd_loc, p * p);
    dkf__copy(s->Pxd, s->Pxd_loc, n * p);
    if (!dkf__all_finite(s->x, n) || !dkf__all_finite(s->Px, n * n)) return DKF_ERR_NONFINITE;
    if (!dkf__psd_within_rounding(L->w[0], s->Px, n)) return DKF_ERR_NOT_SPD;
    return check_joint(s, n, p, L->w[0], L->w[1], L->v[0]);
}

/* Covariance form: K = Pxz R_tilde^{-1} (16), Lg = K (I - Hd M) (17),
 * x = x_pred + Lg nu (18); Px = P_pred - Lg Pxz^T (19), or with DKF_JOSEPH
 * (I - Lg C) P_pred (I - Lg C)^T + Lg Rbar Lg^T (equal since Lg Hd = 0 and
 * Pi R_tilde Pi = Pi; C, Rbar the linearisation). */
static dkf_status_t update_covariance(const dkf_nerts_t *f, layout_t *L)
{
    const size_t n = f->n, m = f->m, p = f->p;
    out_t *s = &L->s;
    dkf_real_t *Lr = L->w[0], *Rinv = L->w[1], *K = L->w[2], *IHM = L->w[3], *Lg = L->w[4];
    dkf_real_t *inv = L->v[0];
    size_t a, b;
    if (dkf__chol(Lr, inv, s->R_tilde, m) != 0) return DKF_ERR_NOT_SPD;
    dkf__chol_inverse(Rinv, Lr, inv, m);
    dkf__mul_nn(K, s->Pxz, Rinv, n, m, m);
    if (p > 0) dkf__mul_nn(IHM, s->Hd, s->M, m, p, m);
    for (a = 0; a < m; ++a)
        for (b = 0; b < m; ++b)
            IHM[a * m + b] = (a == b ? DKF_R(1.0) : DKF_R(0.0)) - (p > 0 ? IHM[a * m + b] : DKF_R(0.0));
    dkf__mul_nn(Lg, K, IHM, n, m, m);
    dkf__mul_vec(s->x, Lg, s->nu, n, m);
    for (a = 0; a < n; ++a) s->x[a] += s->x_pred[a];
#if DKF_JOSEPH
    dkf__transpose(L->img, Lg, n, m);
    dkf__joseph(s->Px, s->P_pred, L->img, s->C, s->Rbar, n, m, L->w[0]);
#else
    dkf__mul_nt(K, Lg, s->Pxz, n, m, n);
    for (a = 0; a < n * n; ++a) s->Px[a] = s->P_pred[a] - K[a];
    dkf__symmetrise(s->Px, n);
#endif
    return finish_commit(f, L);
}

/* Information form (Algorithm 1 steps 5-6): Y = Y_pred + I, y = y_pred + i,
 * Px = Y^{-1}, x = Px y, by the information filter's fuse. */
static dkf_status_t update_information(const dkf_nerts_t *f, layout_t *L)
{
    const size_t n = f->n;
    out_t *s = &L->s;
    dkf_info_t inf;
    dkf_mat_t iv, Iv;
    DKF_TRY(info_from_prediction(&inf, f, L));
    dkf__view(&iv, n, 1, s->i);
    dkf__view(&Iv, n, n, s->I);
    DKF_TRY(dkf_info_fuse(&inf, &iv, &Iv, 1));
    dkf__copy(s->x, inf.x.data, n);
    dkf__copy(s->Px, inf.P.data, n * n);
    dkf__copy(s->y, inf.y.data, n);
    dkf__copy(s->Y, inf.Y.data, n * n);
    return finish_commit(f, L);
}

static dkf_status_t update_staged(const dkf_nerts_t *f, layout_t *L)
{
    return is_info(f) ? update_information(f, L) : update_covariance(f, L);
}

/* ---- the public phases ----------------------------------------------------- */

static void bind(dkf_nerts_t *g, const out_t *o)
{
    const size_t n = g->n, m = g->m, p = g->p;
    dkf__view(&g->x, n, 1, o->x);
    dkf__view(&g->Px, n, n, o->Px);
    dkf__view(&g->d, p, 1, p > 0 ? o->d : NULL);
    dkf__view(&g->Pd, p, p, p > 0 ? o->Pd : NULL);
    dkf__view(&g->Pxd, n, p, p > 0 ? o->Pxd : NULL);
    dkf__view(&g->x_pred, n, 1, o->x_pred);
    dkf__view(&g->P_pred, n, n, o->P_pred);
    dkf__view(&g->Y_pred, n, n, o->Y_pred);
    dkf__view(&g->y_pred, n, 1, o->y_pred);
    dkf__view(&g->Fx, n, n, o->Fx);
    dkf__view(&g->Fd, n, p, p > 0 ? o->Fd : NULL);
    dkf__view(&g->z_hat, m, 1, o->z_hat);
    dkf__view(&g->nu, m, 1, o->nu);
    dkf__view(&g->h_c, m, 1, o->h_c);
    dkf__view(&g->Hx, m, n, o->Hx);
    dkf__view(&g->R_tilde, m, m, o->R_tilde);
    dkf__view(&g->Pzz, m, m, o->Pzz);
    dkf__view(&g->Pxz, n, m, o->Pxz);
    dkf__view(&g->Hd, m, p, p > 0 ? o->Hd : NULL);
    dkf__view(&g->C, m, n, o->C);
    dkf__view(&g->Rbar, m, m, o->Rbar);
    dkf__view(&g->Rbar_inv, m, m, o->Rbar_inv);
    dkf__view(&g->M, p, m, p > 0 ? o->M : NULL);
    dkf__view(&g->d_loc, p, 1, p > 0 ? o->d_loc : NULL);
    dkf__view(&g->Pd_loc, p, p, p > 0 ? o->Pd_loc : NULL);
    dkf__view(&g->Pxd_loc, n, p, p > 0 ? o->Pxd_loc : NULL);
    dkf__view(&g->i, n, 1, o->i);
    dkf__view(&g->I, n, n, o->I);
    dkf__view(&g->Y, n, n, o->Y);
    dkf__view(&g->y, n, 1, o->y);
}

/* The layout of f's storage with a state copied into the stage: the one
 * at `from` (laid out as f's state, e.g. a snapshot of it), or f's own
 * (from == NULL). */
static void stage_from(const dkf_nerts_t *f, layout_t *L, const dkf_real_t *from)
{
    (void)layout(L, f->priv.mem, f->n, f->m, f->p);
    dkf__copy(L->s.x, from != NULL ? from : L->o.x, L->out_len);
}

static void stage(const dkf_nerts_t *f, layout_t *L)
{
    stage_from(f, L, NULL);
}

static void unstage(const layout_t *L)
{
    dkf__copy(L->o.x, L->s.x, L->out_len);
}

/* A p x c input (p may be 0: then the view must be NULL). */
static dkf_status_t check_input_part(const dkf_mat_t *M, size_t p, size_t r, size_t c)
{
    if (p == 0) return M == NULL ? DKF_OK : DKF_ERR_DIM;
    return dkf__check_input(M, r, c);
}

/* Every check of dkf_nerts_init. The prior is formed and checked in the
 * stage of storage (its scratch), mapped by *L; nothing else is written,
 * so a refused prior leaves the storage's state, a live filter's
 * included, as it was. */
static dkf_status_t init_staged(layout_t *L, dkf_nerts_kind_t kind, size_t n, size_t m, size_t p,
                                dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                                const dkf_mat_t *P0, const dkf_mat_t *d0, const dkf_mat_t *Pd0,
                                const dkf_mat_t *Pxd0)
{
    DKF_CHECK_NULL(storage);
    if (kind != DKF_NERTS_NERTSF && kind != DKF_NERTS_NERTSIF && kind != DKF_NERTS_DNERTSF &&
        kind != DKF_NERTS_DNERTSIF)
        return DKF_ERR_ARG;
    if (n == 0 || m == 0 || n > DKF_MAX_DIM || m > DKF_MAX_DIM || p > DKF_MAX_DIM ||
        n + p > DKF_MAX_DIM)
        return DKF_ERR_CAPACITY;
    if (storage_len < layout(L, NULL, n, m, p)) return DKF_ERR_CAPACITY;
    if (m < p) return DKF_ERR_RANK;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    DKF_TRY(check_input_part(d0, p, p, 1));
    DKF_TRY(check_input_part(Pd0, p, p, p));
    DKF_TRY(check_input_part(Pxd0, p, n, p));
    (void)layout(L, storage, n, m, p);
    memset(L->s.x, 0, L->out_len * sizeof *storage);
    dkf__copy(L->s.x, x0->data, n);
    dkf__copy(L->s.Px, P0->data, n * n);
    dkf__symmetrise(L->s.Px, n);
    if (p > 0) {
        dkf__copy(L->s.d, d0->data, p);
        dkf__copy(L->s.Pd, Pd0->data, p * p);
        dkf__symmetrise(L->s.Pd, p);
        dkf__copy(L->s.Pxd, Pxd0->data, n * p);
    }
    return check_joint(&L->s, n, p, L->w[0], L->w[1], L->v[0]);
}

dkf_status_t dkf_nerts_init(dkf_nerts_t *f, dkf_nerts_kind_t kind, size_t n, size_t m, size_t p,
                            dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                            const dkf_mat_t *P0, const dkf_mat_t *d0, const dkf_mat_t *Pd0,
                            const dkf_mat_t *Pxd0)
{
    dkf_nerts_t g; /* built aside so a failed init leaves *f as it was */
    layout_t L;
    DKF_CHECK_NULL(f);
    DKF_TRY(init_staged(&L, kind, n, m, p, storage, storage_len, x0, P0, d0, Pd0, Pxd0));
    unstage(&L);
    g.n = n;
    g.m = m;
    g.p = p;
    g.kind = kind;
    g.k = 0;
    g.phase = DKF_NERTS_POSTERIOR;
    g.priv.mem = storage;
    g.priv.ready = 1;
    bind(&g, &L.o);
    *f = g;
    return DKF_OK;
}

/* (nerts_internal.h) */
dkf_status_t dkf__nerts_check_init(dkf_nerts_kind_t kind, size_t n, size_t m, size_t p,
                                   dkf_real_t *storage, size_t storage_len, const dkf_mat_t *x0,
                                   const dkf_mat_t *P0, const dkf_mat_t *d0, const dkf_mat_t *Pd0,
                                   const dkf_mat_t *Pxd0)
{
    layout_t L;
    return init_staged(&L, kind, n, m, p, storage, storage_len, x0, P0, d0, Pd0, Pxd0);
}

static dkf_status_t check_ready(const dkf_nerts_t *f)
{
    DKF_CHECK_NULL(f);
    return f->priv.ready ? DKF_OK : DKF_ERR_STATE;
}

dkf_status_t dkf_nerts_predict(dkf_nerts_t *f, const dkf_nl_model_t *model, const dkf_real_t *u,
                               const dkf_mat_t *Q)
{
    layout_t L;
    DKF_TRY(check_ready(f));
    DKF_TRY(check_model(f, model, u));
    DKF_TRY(dkf__check_input(Q, f->n, f->n));
    stage(f, &L);
    DKF_TRY(predict_staged(f, &L, model, u, Q->data));
    unstage(&L);
    f->phase = DKF_NERTS_PREDICTED;
    return DKF_OK;
}

static dkf_status_t check_meas(const dkf_nerts_t *f, const dkf_mat_t *R, const dkf_mat_t *z)
{
    DKF_TRY(dkf__check_input(R, f->m, f->m));
    return dkf__check_input(z, f->m, 1);
}

dkf_status_t dkf_nerts_local(dkf_nerts_t *f, const dkf_nl_model_t *model, const dkf_real_t *u,
                             const dkf_mat_t *R, const dkf_mat_t *z)
{
    layout_t L;
    DKF_TRY(check_ready(f));
    if (f->phase == DKF_NERTS_POSTERIOR) return DKF_ERR_STATE;
    DKF_TRY(check_model(f, model, u));
    DKF_TRY(check_meas(f, R, z));
    stage(f, &L);
    DKF_TRY(local_staged(f, &L, model, u, R->data, z->data));
    unstage(&L);
    f->phase = DKF_NERTS_LOCAL;
    return DKF_OK;
}

dkf_status_t dkf_nerts_update(dkf_nerts_t *f)
{
    layout_t L;
    DKF_TRY(check_ready(f));
    if (f->phase != DKF_NERTS_LOCAL) return DKF_ERR_STATE;
    stage(f, &L);
    DKF_TRY(update_staged(f, &L));
    unstage(&L);
    f->phase = DKF_NERTS_POSTERIOR;
    f->k += 1;
    return DKF_OK;
}

dkf_status_t dkf_nerts_commit_info(dkf_nerts_t *f, const dkf_mat_t *Y, const dkf_mat_t *y)
{
    layout_t L;
    dkf_mat_t Yv, Pv;
    size_t n;
    DKF_TRY(check_ready(f));
    if (f->phase != DKF_NERTS_LOCAL || !is_info(f)) return DKF_ERR_STATE;
    n = f->n;
    DKF_TRY(dkf__check_input(Y, n, n));
    DKF_TRY(dkf__check_input(y, n, 1));
    stage(f, &L);
    /* Px = Y^{-1}, x = Px y (Algorithm 3, recovery) */
    dkf__copy(L.s.Y, Y->data, n * n);
    dkf__symmetrise(L.s.Y, n);
    dkf__copy(L.s.y, y->data, n);
    dkf__view(&Yv, n, n, L.s.Y);
    dkf__view(&Pv, n, n, L.s.Px);
    DKF_TRY(dkf_mat_spd_inverse(&Pv, &Yv, L.w[0]));
    dkf__mul_vec(L.s.x, L.s.Px, L.s.y, n, n);
    DKF_TRY(finish_commit(f, &L));
    unstage(&L);
    f->phase = DKF_NERTS_POSTERIOR;
    f->k += 1;
    return DKF_OK;
}

/* Phases 1 and 2 in the stage, from the state at `from` (NULL: f's own):
 * every argument is checked first; nothing of f is written. */
static dkf_status_t predict_local_staged(const dkf_nerts_t *f, layout_t *L, const dkf_real_t *from,
                                         const dkf_nl_model_t *model, const dkf_real_t *u_prev,
                                         const dkf_mat_t *Q, const dkf_real_t *u,
                                         const dkf_mat_t *R, const dkf_mat_t *z)
{
    DKF_TRY(check_model(f, model, u_prev));
    DKF_TRY(check_model(f, model, u));
    DKF_TRY(dkf__check_input(Q, f->n, f->n));
    DKF_TRY(check_meas(f, R, z));
    stage_from(f, L, from);
    DKF_TRY(predict_staged(f, L, model, u_prev, Q->data));
    return local_staged(f, L, model, u, R->data, z->data);
}

dkf_status_t dkf_nerts_step(dkf_nerts_t *f, const dkf_nl_model_t *model, const dkf_real_t *u_prev,
                            const dkf_mat_t *Q, const dkf_real_t *u, const dkf_mat_t *R,
                            const dkf_mat_t *z)
{
    layout_t L;
    DKF_TRY(check_ready(f));
    DKF_TRY(predict_local_staged(f, &L, NULL, model, u_prev, Q, u, R, z));
    DKF_TRY(update_staged(f, &L));
    unstage(&L);
    f->phase = DKF_NERTS_POSTERIOR;
    f->k += 1;
    return DKF_OK;
}

/* (nerts_internal.h) */
dkf_status_t dkf__nerts_stage_local(const dkf_nerts_t *f, const dkf_real_t *from,
                                    const dkf_nl_model_t *model, const dkf_real_t *u_prev,
                                    const dkf_mat_t *Q, const dkf_real_t *u, const dkf_mat_t *R,
                                    const dkf_mat_t *z, dkf__nerts_staged_t *out)
{
    layout_t L;
    DKF_TRY(check_ready(f));
    DKF_TRY(predict_local_staged(f, &L, from, model, u_prev, Q, u, R, z));
    out->x_pred = L.s.x_pred;
    out->y_pred = L.s.y_pred;
    out->Y_pred = L.s.Y_pred;
    out->nu = L.s.nu;
    out->C = L.s.C;
    out->Hd = L.s.Hd;
    out->Rbar = L.s.Rbar;
    out->i = L.s.i;
    out->I = L.s.I;
    return DKF_OK;
}

void dkf__nerts_commit_stage(dkf_nerts_t *f)
{
    layout_t L;
    (void)layout(&L, f->priv.mem, f->n, f->m, f->p);
    unstage(&L);
    f->phase = DKF_NERTS_LOCAL;
}
