/*
 * Cholesky factorisation, solves and inverses of SPD matrices (dkf/mat.h).
 *
 * The factor is computed row by row (Cholesky-Banachiewicz): row i of L
 * needs only rows 0..i-1 of L and row i of A, so every inner product runs
 * along two contiguous rows. Divisions by L(j,j) are replaced by products
 * with its reciprocal, kept in a DKF_MAX_DIM array (one division per row
 * instead of one per element; it costs at most one extra rounding).
 */
#include <string.h>

#include "internal.h"
#include "kernels.h"

/* Status of a failed factorisation: a NaN or infinity anywhere in the
 * lower triangle of A outranks the pivot failure it caused. Only called
 * on the failure path, so a successful factorisation costs no scan. */
static dkf_status_t chol_failure(const dkf_real_t *A, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i)
        if (!dkf__all_finite(A + i * n, i + 1)) return DKF_ERR_NONFINITE;
    return DKF_ERR_NOT_SPD;
}

dkf_status_t dkf_mat_chol(dkf_mat_t *L, const dkf_mat_t *A, dkf_real_t *work)
{
    dkf_real_t inv[DKF_MAX_DIM];
    size_t n;
    DKF_TRY(dkf__check_mat(L));
    DKF_TRY(dkf__check_mat(A));
    n = A->rows;
    if (A->cols != n) return DKF_ERR_DIM;
    if (L->rows != n || L->cols != n) return DKF_ERR_DIM;
    DKF_CHECK_NULL(work);
    DKF_CHECK_SAME_OR_DISJOINT(L, A);
    DKF_CHECK_NO_ALIAS_BUF(L, work, n * n);
    DKF_CHECK_NO_ALIAS_BUF(A, work, n * n);
    if (dkf__chol(work, inv, A->data, n) != 0) return chol_failure(A->data, n);
    memcpy(L->data, work, n * n * sizeof(dkf_real_t));
    return DKF_OK;
}

/* Validates a given Cholesky factor: its lower triangle must be finite
 * (DKF_ERR_NONFINITE) and its diagonal positive (DKF_ERR_SINGULAR).
 * Fills inv[i] = 1 / L(i,i). */
static dkf_status_t check_factor(dkf_real_t *inv, const dkf_real_t *L, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i)
        if (!dkf__all_finite(L + i * n, i + 1)) return DKF_ERR_NONFINITE;
    for (i = 0; i < n; ++i) {
        const dkf_real_t d = L[i * n + i];
        if (!(d > DKF_R(0.0))) return DKF_ERR_SINGULAR;
        inv[i] = DKF_R(1.0) / d;
    }
    return DKF_OK;
}

dkf_status_t dkf_mat_chol_solve(dkf_mat_t *X, const dkf_mat_t *L, const dkf_mat_t *B)
{
    dkf_real_t inv[DKF_MAX_DIM];
    size_t n, m;
    DKF_TRY(dkf__check_mat(X));
    DKF_TRY(dkf__check_mat(L));
    DKF_TRY(dkf__check_mat(B));
    n = L->rows;
    m = B->cols;
    if (L->cols != n || B->rows != n) return DKF_ERR_DIM;
    if (X->rows != n || X->cols != m) return DKF_ERR_DIM;
    DKF_CHECK_NO_ALIAS(X, L);
    DKF_CHECK_SAME_OR_DISJOINT(X, B);
    if (!dkf__all_finite(B->data, n * m)) return DKF_ERR_NONFINITE;
    DKF_TRY(check_factor(inv, L->data, n));
    if (X->data != B->data) memcpy(X->data, B->data, n * m * sizeof(dkf_real_t));
    dkf__chol_solve(L->data, inv, X->data, n, m);
    return DKF_OK;
}

dkf_status_t dkf_mat_chol_inverse(dkf_mat_t *Ainv, const dkf_mat_t *L)
{
    dkf_real_t inv[DKF_MAX_DIM];
    size_t n;
    DKF_TRY(dkf__check_mat(Ainv));
    DKF_TRY(dkf__check_mat(L));
    n = L->rows;
    if (L->cols != n || Ainv->rows != n || Ainv->cols != n) return DKF_ERR_DIM;
    DKF_CHECK_NO_ALIAS(Ainv, L);
    DKF_TRY(check_factor(inv, L->data, n));
    dkf__chol_inverse(Ainv->data, L->data, inv, n);
    return DKF_OK;
}

dkf_status_t dkf_mat_spd_inverse(dkf_mat_t *Ainv, const dkf_mat_t *A, dkf_real_t *work)
{
    dkf_real_t inv[DKF_MAX_DIM];
    size_t n;
    DKF_TRY(dkf__check_mat(Ainv));
    DKF_TRY(dkf__check_mat(A));
    n = A->rows;
    if (A->cols != n || Ainv->rows != n || Ainv->cols != n) return DKF_ERR_DIM;
    DKF_CHECK_NULL(work);
    DKF_CHECK_SAME_OR_DISJOINT(Ainv, A);
    DKF_CHECK_NO_ALIAS_BUF(Ainv, work, n * n);
    DKF_CHECK_NO_ALIAS_BUF(A, work, n * n);
    /* A is dead once factored, so Ainv == A is safe from here on. */
    if (dkf__chol(work, inv, A->data, n) != 0) return chol_failure(A->data, n);
    dkf__chol_inverse(Ainv->data, work, inv, n);
    return DKF_OK;
}
