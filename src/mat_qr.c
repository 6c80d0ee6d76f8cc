/*
 * Householder QR (compact, LAPACK xGEQRF layout) and least squares.
 *
 * A = Q R with Q = H_0 H_1 ... H_{c-1}, H_j = I - tau_j v_j v_j^T, where
 * v_j has v_j(i) = 0 for i < j, v_j(j) = 1 (implied) and v_j(i) for i > j
 * stored below the diagonal of column j. Householder QR is backward
 * stable: the computed factors satisfy A + dA = Q R with
 * ||dA|| <= O(r c eps) ||A|| (Higham, ASNA 2nd ed., thm 19.4).
 */
#include "internal.h"

/* ||x||_2 of n reals spaced `stride` apart, scaled by max|x_i| so that
 * squaring neither overflows nor underflows. */
static dkf_real_t scaled_norm(const dkf_real_t *x, size_t n, size_t stride)
{
    dkf_real_t big = DKF_R(0.0), sum = DKF_R(0.0);
    size_t i;
    for (i = 0; i < n; ++i)
        if (DKF_FABS(x[i * stride]) > big) big = DKF_FABS(x[i * stride]);
    if (big == DKF_R(0.0)) return DKF_R(0.0);
    for (i = 0; i < n; ++i) {
        dkf_real_t t = x[i * stride] / big;
        sum += t * t;
    }
    return big * DKF_SQRT(sum);
}

/* Builds H = I - tau v v^T with H (alpha, x)^T = (beta, 0)^T (xLARFG):
 * beta = -sign(alpha) ||(alpha, x)||, tau = (beta - alpha) / beta,
 * v = (1, x / (alpha - beta)). The sign choice makes alpha - beta a sum
 * of like-signed terms, so there is no cancellation. Overwrites *alpha
 * with beta and x with v's tail; returns tau (0 when x = 0: H = I). */
static dkf_real_t make_reflector(dkf_real_t *alpha, dkf_real_t *x, size_t n, size_t stride)
{
    dkf_real_t xnorm = scaled_norm(x, n, stride);
    dkf_real_t h, beta, tau, inv;
    size_t i;
    if (xnorm == DKF_R(0.0)) return DKF_R(0.0);
    h = DKF_HYPOT(*alpha, xnorm);
    beta = (*alpha >= DKF_R(0.0)) ? -h : h;
    tau = (beta - *alpha) / beta;
    inv = DKF_R(1.0) / (*alpha - beta);
    for (i = 0; i < n; ++i) x[i * stride] *= inv;
    *alpha = beta;
    return tau;
}

/* B(j:r-1, c0:c1-1) = H_j B(j:r-1, c0:c1-1) for the reflector stored in
 * column j of V (row stride ldv): B -= tau v (v^T B). B has row stride ldb
 * and r rows. The row products v^T B are gathered row by row so that both
 * matrices are walked contiguously. */
static void apply_reflector(dkf_real_t *B, size_t ldb, size_t r, size_t c0, size_t c1,
                            const dkf_real_t *V, size_t ldv, size_t j, dkf_real_t tau)
{
    dkf_real_t w[DKF_MAX_DIM];
    size_t i, l;
    if (tau == DKF_R(0.0)) return;
    for (l = c0; l < c1; ++l) w[l] = B[j * ldb + l];
    for (i = j + 1; i < r; ++i) {
        dkf_real_t vi = V[i * ldv + j];
        for (l = c0; l < c1; ++l) w[l] += vi * B[i * ldb + l];
    }
    for (l = c0; l < c1; ++l) {
        w[l] *= tau;
        B[j * ldb + l] -= w[l];
    }
    for (i = j + 1; i < r; ++i) {
        dkf_real_t vi = V[i * ldv + j];
        for (l = c0; l < c1; ++l) B[i * ldb + l] -= vi * w[l];
    }
}

/* In-place factorisation of the r x c (r >= c) row-major matrix F. */
static void householder_qr(dkf_real_t *F, dkf_real_t *tau, size_t r, size_t c)
{
    size_t j;
    for (j = 0; j < c; ++j) {
        /* the last column of a square matrix has nothing below the diagonal */
        tau[j] = (j + 1 < r) ? make_reflector(&F[j * c + j], &F[(j + 1) * c + j], r - j - 1, c)
                             : DKF_R(0.0);
        apply_reflector(F, c, r, j + 1, c, F, c, j, tau[j]);
    }
}

dkf_status_t dkf_mat_qr(dkf_mat_t *QR, dkf_real_t *tau, const dkf_mat_t *A)
{
    size_t r, c, i;
    DKF_CHECK_NULL(tau);
    DKF_TRY(dkf__check_mat(A));
    r = A->rows;
    c = A->cols;
    DKF_TRY(dkf__check_shape(QR, r, c));
    if (r < c) return DKF_ERR_DIM;
    DKF_CHECK_SAME_OR_DISJOINT(QR, A);
    DKF_CHECK_NO_ALIAS_BUF(QR, tau, c);
    DKF_CHECK_NO_ALIAS_BUF(A, tau, c);
    if (!dkf__all_finite(A->data, r * c)) return DKF_ERR_NONFINITE;

    /* Nothing below can fail, so the outputs may be written directly. */
    if (QR->data != A->data)
        for (i = 0; i < r * c; ++i) QR->data[i] = A->data[i];
    householder_qr(QR->data, tau, r, c);
    return DKF_OK;
}

dkf_status_t dkf_mat_qr_q(dkf_mat_t *Q, const dkf_mat_t *QR, const dkf_real_t *tau)
{
    size_t r, c, k, i, j;
    DKF_CHECK_NULL(tau);
    DKF_TRY(dkf__check_mat(QR));
    DKF_TRY(dkf__check_mat(Q));
    r = QR->rows;
    c = QR->cols;
    k = Q->cols;
    if (r < c || Q->rows != r || k < c || k > r) return DKF_ERR_DIM;
    DKF_CHECK_NO_ALIAS(Q, QR);
    DKF_CHECK_NO_ALIAS_BUF(Q, tau, c);
    if (!dkf__all_finite(QR->data, r * c) || !dkf__all_finite(tau, c))
        return DKF_ERR_NONFINITE;

    /* Q = H_0 ... H_{c-1} I(:, 0:k-1), accumulated backwards: before H_j is
     * applied the product differs from I only in rows/columns > j, so H_j
     * needs only the block (j:r-1, j:k-1). */
    for (i = 0; i < r; ++i)
        for (j = 0; j < k; ++j) Q->data[i * k + j] = (i == j) ? DKF_R(1.0) : DKF_R(0.0);
    for (j = c; j-- > 0;) apply_reflector(Q->data, k, r, j, k, QR->data, c, j, tau[j]);
    return DKF_OK;
}

/* tau is not read: R is the upper triangle of QR whatever the reflectors. */
dkf_status_t dkf_mat_qr_r(dkf_mat_t *R, const dkf_mat_t *QR, const dkf_real_t *tau)
{
    size_t r, c, i, j;
    (void)tau;
    DKF_TRY(dkf__check_mat(QR));
    r = QR->rows;
    c = QR->cols;
    DKF_TRY(dkf__check_shape(R, c, c));
    if (r < c) return DKF_ERR_DIM;
    DKF_CHECK_NO_ALIAS(R, QR);
    if (!dkf__all_finite(QR->data, r * c)) return DKF_ERR_NONFINITE;

    for (i = 0; i < c; ++i)
        for (j = 0; j < c; ++j) R->data[i * c + j] = (j >= i) ? QR->data[i * c + j] : DKF_R(0.0);
    return DKF_OK;
}

/* DKF_ERR_RANK unless every |R_ii| > c eps max_j |R_jj| (the documented
 * rule; without column pivoting it detects near-dependence of a column on
 * the ones before it). */
static dkf_status_t check_full_rank(const dkf_real_t *F, size_t c)
{
    dkf_real_t rmax = DKF_R(0.0), tol;
    size_t i;
    for (i = 0; i < c; ++i)
        if (DKF_FABS(F[i * c + i]) > rmax) rmax = DKF_FABS(F[i * c + i]);
    tol = (dkf_real_t)c * DKF_REAL_EPSILON * rmax;
    for (i = 0; i < c; ++i)
        if (!(DKF_FABS(F[i * c + i]) > tol)) return DKF_ERR_RANK;
    return DKF_OK;
}

dkf_status_t dkf_mat_qr_solve(dkf_mat_t *X, const dkf_mat_t *A, const dkf_mat_t *B,
                              dkf_real_t *work)
{
    size_t r, c, k, i, j, l;
    dkf_real_t *F, *tau;
    dkf_real_t y[DKF_MAX_DIM];
    DKF_CHECK_NULL(work);
    DKF_TRY(dkf__check_mat(A));
    DKF_TRY(dkf__check_mat(B));
    DKF_TRY(dkf__check_mat(X));
    r = A->rows;
    c = A->cols;
    k = B->cols;
    if (r < c || B->rows != r || X->rows != c || X->cols != k) return DKF_ERR_DIM;
    DKF_CHECK_NO_ALIAS(X, A);
    DKF_CHECK_NO_ALIAS(X, B);
    DKF_CHECK_NO_ALIAS_BUF(X, work, DKF_MAT_QR_SOLVE_WORK(r, c));
    DKF_CHECK_NO_ALIAS_BUF(A, work, DKF_MAT_QR_SOLVE_WORK(r, c));
    DKF_CHECK_NO_ALIAS_BUF(B, work, DKF_MAT_QR_SOLVE_WORK(r, c));
    if (!dkf__all_finite(A->data, r * c) || !dkf__all_finite(B->data, r * k))
        return DKF_ERR_NONFINITE;

    F = work;
    tau = work + r * c;
    for (i = 0; i < r * c; ++i) F[i] = A->data[i];
    householder_qr(F, tau, r, c);
    DKF_TRY(check_full_rank(F, c));

    /* Per column of B: y = Q^T b = H_{c-1} ... H_0 b, then R x = y(0:c-1).
     * The residual rows y(c:r-1) are orthogonal to range(A) and dropped. */
    for (l = 0; l < k; ++l) {
        for (i = 0; i < r; ++i) y[i] = B->data[i * k + l];
        for (j = 0; j < c; ++j) apply_reflector(y, 1, r, 0, 1, F, c, j, tau[j]);
        for (i = c; i-- > 0;) {
            dkf_real_t acc = y[i];
            for (j = i + 1; j < c; ++j) acc -= F[i * c + j] * y[j];
            y[i] = acc / F[i * c + i];
        }
        for (i = 0; i < c; ++i) X->data[i * k + l] = y[i];
    }
    return DKF_OK;
}
