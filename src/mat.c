/*
 * Views, element-wise operations, products and block routines (dkf/mat.h).
 *
 * Every routine validates all arguments before its first write, so an
 * error leaves the outputs untouched. Products keep the innermost loop on a
 * contiguous row of row-major storage and carry no zero-initialisation
 * pass: the first term of each sum initialises the output.
 */
#include <string.h>

#include "internal.h"
#include "kernels.h"

dkf_status_t dkf_mat_init(dkf_mat_t *m, size_t rows, size_t cols, dkf_real_t *data)
{
    dkf_mat_t v;
    DKF_CHECK_NULL(m);
    v.rows = rows;
    v.cols = cols;
    v.data = data;
    DKF_TRY(dkf__check_mat(&v));
    *m = v;
    return DKF_OK;
}

static size_t numel(const dkf_mat_t *m) { return m->rows * m->cols; }

dkf_status_t dkf_mat_zero(dkf_mat_t *A)
{
    size_t i, n;
    DKF_TRY(dkf__check_mat(A));
    n = numel(A);
    for (i = 0; i < n; ++i) A->data[i] = DKF_R(0.0);
    return DKF_OK;
}

dkf_status_t dkf_mat_identity(dkf_mat_t *A)
{
    size_t i, n;
    DKF_TRY(dkf__check_mat(A));
    if (A->rows != A->cols) return DKF_ERR_DIM;
    n = A->rows;
    for (i = 0; i < n * n; ++i) A->data[i] = DKF_R(0.0);
    for (i = 0; i < n; ++i) A->data[i * n + i] = DKF_R(1.0);
    return DKF_OK;
}

dkf_status_t dkf_mat_set(dkf_mat_t *A, const dkf_real_t *values)
{
    DKF_TRY(dkf__check_mat(A));
    DKF_CHECK_NULL(values);
    if (values != A->data) memmove(A->data, values, numel(A) * sizeof(dkf_real_t));
    return DKF_OK;
}

dkf_status_t dkf_mat_copy(dkf_mat_t *B, const dkf_mat_t *A)
{
    DKF_TRY(dkf__check_mat(B));
    DKF_TRY(dkf__check_shape(A, B->rows, B->cols));
    DKF_CHECK_SAME_OR_DISJOINT(B, A);
    if (B->data != A->data) memcpy(B->data, A->data, numel(A) * sizeof(dkf_real_t));
    return DKF_OK;
}

dkf_status_t dkf_mat_transpose(dkf_mat_t *B, const dkf_mat_t *A)
{
    DKF_TRY(dkf__check_mat(B));
    DKF_TRY(dkf__check_shape(A, B->cols, B->rows));
    DKF_CHECK_NO_ALIAS(B, A);
    dkf__transpose(B->data, A->data, A->rows, A->cols);
    return DKF_OK;
}

/* Shared checks of C = op(A, B) element-wise: equal shapes, C identical to
 * or disjoint from each input. */
static dkf_status_t check_elementwise(const dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B)
{
    DKF_TRY(dkf__check_mat(C));
    DKF_TRY(dkf__check_shape(A, C->rows, C->cols));
    DKF_TRY(dkf__check_shape(B, C->rows, C->cols));
    DKF_CHECK_SAME_OR_DISJOINT(C, A);
    DKF_CHECK_SAME_OR_DISJOINT(C, B);
    return DKF_OK;
}

dkf_status_t dkf_mat_add(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B)
{
    size_t i, n;
    DKF_TRY(check_elementwise(C, A, B));
    n = numel(C);
    for (i = 0; i < n; ++i) C->data[i] = A->data[i] + B->data[i];
    return DKF_OK;
}

dkf_status_t dkf_mat_sub(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B)
{
    size_t i, n;
    DKF_TRY(check_elementwise(C, A, B));
    n = numel(C);
    for (i = 0; i < n; ++i) C->data[i] = A->data[i] - B->data[i];
    return DKF_OK;
}

dkf_status_t dkf_mat_scale(dkf_mat_t *B, const dkf_mat_t *A, dkf_real_t s)
{
    size_t i, n;
    DKF_TRY(check_elementwise(B, A, A));
    n = numel(B);
    for (i = 0; i < n; ++i) B->data[i] = s * A->data[i];
    return DKF_OK;
}

dkf_status_t dkf_mat_axpy(dkf_mat_t *Y, dkf_real_t s, const dkf_mat_t *X)
{
    size_t i, n;
    DKF_TRY(check_elementwise(Y, X, X));
    n = numel(Y);
    for (i = 0; i < n; ++i) Y->data[i] += s * X->data[i];
    return DKF_OK;
}

/* ---- products ------------------------------------------------------------ */

/* Checks of C = op(A) op(B): both inputs valid, C exactly r x c, and C
 * disjoint from both inputs (products read inputs after writing C). */
static dkf_status_t check_product(const dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B,
                                  size_t inner_a, size_t inner_b, size_t r, size_t c)
{
    DKF_TRY(dkf__check_mat(C));
    if (inner_a != inner_b) return DKF_ERR_DIM;
    if (C->rows != r || C->cols != c) return DKF_ERR_DIM;
    (void)A; /* used only by the alias checks, which DKF_DEBUG_CHECKS=0 drops */
    (void)B;
    DKF_CHECK_NO_ALIAS(C, A);
    DKF_CHECK_NO_ALIAS(C, B);
    return DKF_OK;
}

dkf_status_t dkf_mat_mul(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B)
{
    DKF_TRY(dkf__check_mat(A));
    DKF_TRY(dkf__check_mat(B));
    DKF_TRY(check_product(C, A, B, A->cols, B->rows, A->rows, B->cols));
    dkf__mul_nn(C->data, A->data, B->data, A->rows, A->cols, B->cols);
    return DKF_OK;
}

dkf_status_t dkf_mat_mul_abt(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B)
{
    DKF_TRY(dkf__check_mat(A));
    DKF_TRY(dkf__check_mat(B));
    DKF_TRY(check_product(C, A, B, A->cols, B->cols, A->rows, B->rows));
    dkf__mul_nt(C->data, A->data, B->data, A->rows, A->cols, B->rows);
    return DKF_OK;
}

dkf_status_t dkf_mat_mul_atb(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B)
{
    size_t i, j, l, r, k, c;
    DKF_TRY(dkf__check_mat(A));
    DKF_TRY(dkf__check_mat(B));
    DKF_TRY(check_product(C, A, B, A->rows, B->rows, A->cols, B->cols));
    k = A->rows;
    r = A->cols;
    c = B->cols;
    /* row i of C = sum_l A(l,i) * row l of B */
    for (i = 0; i < r; ++i) {
        dkf_real_t *restrict ci = C->data + i * c;
        const dkf_real_t *restrict b = B->data;
        const dkf_real_t a0 = A->data[i];
        for (j = 0; j < c; ++j) ci[j] = a0 * b[j];
        for (l = 1; l < k; ++l) {
            const dkf_real_t a = A->data[l * r + i];
            const dkf_real_t *restrict bl = b + l * c;
            for (j = 0; j < c; ++j) ci[j] += a * bl[j];
        }
    }
    return DKF_OK;
}

dkf_status_t dkf_mat_congruence(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *P,
                                dkf_real_t *work)
{
    size_t r, c;
    DKF_TRY(dkf__check_mat(C));
    DKF_TRY(dkf__check_mat(A));
    r = A->rows;
    c = A->cols;
    DKF_TRY(dkf__check_shape(P, c, c));
    if (C->rows != r || C->cols != r) return DKF_ERR_DIM;
    DKF_CHECK_NULL(work);
    DKF_CHECK_NO_ALIAS(C, A);
    DKF_CHECK_NO_ALIAS(C, P);
    DKF_CHECK_NO_ALIAS_BUF(C, work, r * c);
    DKF_CHECK_NO_ALIAS_BUF(A, work, r * c);
    DKF_CHECK_NO_ALIAS_BUF(P, work, r * c);
    /* W = A P (r x c); C = W A^T through its upper triangle, mirrored, so
     * C is symmetric to the last bit whatever the rounding. */
    dkf__mul_nn(work, A->data, P->data, r, c, c);
    dkf__mul_nt_sym(C->data, work, A->data, NULL, r, c);
    return DKF_OK;
}

dkf_status_t dkf_mat_symmetrise(dkf_mat_t *A)
{
    DKF_TRY(dkf__check_mat(A));
    if (A->rows != A->cols) return DKF_ERR_DIM;
    dkf__symmetrise(A->data, A->rows);
    return DKF_OK;
}

/* ---- blocks ---------------------------------------------------------------- */

/* DKF_OK if the (blk->rows x blk->cols) block at (r0, c0) lies inside M.
 * Written without r0 + rows so that no sum can wrap around. */
static dkf_status_t check_block(const dkf_mat_t *M, const dkf_mat_t *blk, size_t r0, size_t c0)
{
    if (blk->rows > M->rows || blk->cols > M->cols) return DKF_ERR_DIM;
    if (r0 > M->rows - blk->rows || c0 > M->cols - blk->cols) return DKF_ERR_DIM;
    return DKF_OK;
}

dkf_status_t dkf_mat_get_block(dkf_mat_t *B, const dkf_mat_t *A, size_t r0, size_t c0)
{
    size_t i;
    DKF_TRY(dkf__check_mat(B));
    DKF_TRY(dkf__check_mat(A));
    DKF_TRY(check_block(A, B, r0, c0));
    DKF_CHECK_NO_ALIAS(B, A);
    for (i = 0; i < B->rows; ++i)
        memcpy(B->data + i * B->cols, A->data + (r0 + i) * A->cols + c0,
               B->cols * sizeof(dkf_real_t));
    return DKF_OK;
}

dkf_status_t dkf_mat_set_block(dkf_mat_t *A, size_t r0, size_t c0, const dkf_mat_t *B)
{
    size_t i;
    DKF_TRY(dkf__check_mat(A));
    DKF_TRY(dkf__check_mat(B));
    DKF_TRY(check_block(A, B, r0, c0));
    DKF_CHECK_NO_ALIAS(A, B);
    for (i = 0; i < B->rows; ++i)
        memcpy(A->data + (r0 + i) * A->cols + c0, B->data + i * B->cols,
               B->cols * sizeof(dkf_real_t));
    return DKF_OK;
}

dkf_status_t dkf_mat_blkdiag(dkf_mat_t *D, const dkf_mat_t *const blocks[], size_t count)
{
    size_t b, i, j, rsum = 0, csum = 0, r0 = 0, c0 = 0, nc;
    DKF_TRY(dkf__check_mat(D));
    DKF_CHECK_NULL(blocks);
    for (b = 0; b < count; ++b) {
        DKF_TRY(dkf__check_mat(blocks[b]));
        DKF_CHECK_NO_ALIAS(D, blocks[b]);
        rsum += blocks[b]->rows;
        csum += blocks[b]->cols;
        /* each term is <= DKF_MAX_DIM, so stopping here keeps sums small */
        if (rsum > D->rows || csum > D->cols) return DKF_ERR_DIM;
    }
    if (rsum != D->rows || csum != D->cols) return DKF_ERR_DIM;
    /* One pass over D: each row is zeros | block row | zeros. */
    nc = D->cols;
    for (b = 0; b < count; ++b) {
        const dkf_mat_t *blk = blocks[b];
        for (i = 0; i < blk->rows; ++i) {
            dkf_real_t *d = D->data + (r0 + i) * nc;
            for (j = 0; j < c0; ++j) d[j] = DKF_R(0.0);
            memcpy(d + c0, blk->data + i * blk->cols, blk->cols * sizeof(dkf_real_t));
            for (j = c0 + blk->cols; j < nc; ++j) d[j] = DKF_R(0.0);
        }
        r0 += blk->rows;
        c0 += blk->cols;
    }
    return DKF_OK;
}

dkf_status_t dkf_mat_check_finite(const dkf_mat_t *A)
{
    DKF_TRY(dkf__check_mat(A));
    return dkf__all_finite(A->data, numel(A)) ? DKF_OK : DKF_ERR_NONFINITE;
}
