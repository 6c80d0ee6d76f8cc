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

/* W = L with A = L L^T, reading only the lower triangle of A; inv[i] =
 * 1 / L(i,i). On failure only W and inv are written.
 *
 * A pivot d = A(i,i) - sum_k L(i,k)^2 must satisfy 0 < d <= REAL_MAX.
 * A non-finite A(i,j), j < i, makes L(i,j) non-finite and then d is -Inf
 * or NaN; a non-finite A(i,i) makes d non-finite. So success proves every
 * element read was finite, and no separate finiteness pass is needed. */
static dkf_status_t chol_factor(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n)
{
    size_t i, j, k;
    for (i = 0; i < n; ++i) {
        dkf_real_t *wi = W + i * n;
        const dkf_real_t *ai = A + i * n;
        dkf_real_t d;
        for (j = 0; j < i; ++j) {
            const dkf_real_t *wj = W + j * n;
            dkf_real_t s = ai[j];
            for (k = 0; k < j; ++k) s -= wi[k] * wj[k];
            wi[j] = s * inv[j];
        }
        d = ai[i];
        for (k = 0; k < i; ++k) d -= wi[k] * wi[k];
        if (!(d > DKF_R(0.0) && d <= DKF_REAL_MAX)) return chol_failure(A, n);
        d = DKF_SQRT(d);
        wi[i] = d;
        inv[i] = DKF_R(1.0) / d;
        for (j = i + 1; j < n; ++j) wi[j] = DKF_R(0.0);
    }
    return DKF_OK;
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
    DKF_TRY(chol_factor(work, inv, A->data, n));
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
    dkf_real_t inv[DKF_MAX_DIM], t[DKF_MAX_DIM];
    size_t n, m, i, j, c;
    const dkf_real_t *l;
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
    l = L->data;
    /* One column at a time through a contiguous copy t: column c of B is
     * read completely before column c of X is written, so X == B is safe. */
    for (c = 0; c < m; ++c) {
        for (i = 0; i < n; ++i) t[i] = B->data[i * m + c];
        /* L w = b, row-oriented: w_i = (b_i - L(i,0:i) w) / L(i,i) */
        for (i = 0; i < n; ++i) {
            const dkf_real_t *li = l + i * n;
            dkf_real_t s = t[i];
            for (j = 0; j < i; ++j) s -= li[j] * t[j];
            t[i] = s * inv[i];
        }
        /* L^T x = w, column-oriented so that it too walks rows of L:
         * once x_i is known, remove L(i,j) x_i from every w_j, j < i. */
        for (i = n; i-- > 0;) {
            const dkf_real_t *li = l + i * n;
            const dkf_real_t xi = t[i] * inv[i];
            t[i] = xi;
            for (j = 0; j < i; ++j) t[j] -= li[j] * xi;
        }
        for (i = 0; i < n; ++i) X->data[i * m + c] = t[i];
    }
    return DKF_OK;
}

/* Ainv = (L L^T)^{-1} = M^T M with M = L^{-1}, for a checked factor L
 * (inv[i] = 1 / L(i,i)). Ainv must not overlap L.
 *
 * M's diagonal is inv itself; its strict lower triangle is built in the
 * strict lower triangle of Ainv. M^T M = sum_k m_k^T m_k over the rows m_k
 * of M, so it is accumulated row by row into the upper triangle of Ainv,
 * which never overlaps what is still to be read, then mirrored: the result
 * is symmetric to the last bit. About n^3/3 multiply-adds in all. */
static void chol_inverse_from_factor(dkf_real_t *Ainv, const dkf_real_t *L, const dkf_real_t *inv,
                                     size_t n)
{
    size_t i, j, k;
    /* M(i, 0:i-1) = -inv_i * sum_k L(i,k) M(k, 0:k), as an accumulation of
     * contiguous rows of M. */
    for (i = 0; i < n; ++i) {
        dkf_real_t *mi = Ainv + i * n;
        const dkf_real_t *li = L + i * n;
        for (j = 0; j < i; ++j) mi[j] = DKF_R(0.0);
        for (k = 0; k < i; ++k) {
            const dkf_real_t lik = li[k];
            const dkf_real_t *mk = Ainv + k * n;
            for (j = 0; j < k; ++j) mi[j] += lik * mk[j];
            mi[k] += lik * inv[k];
        }
        for (j = 0; j < i; ++j) mi[j] *= -inv[i];
    }
    /* upper triangle (diagonal included) = M^T M */
    for (i = 0; i < n; ++i)
        for (j = i; j < n; ++j) Ainv[i * n + j] = DKF_R(0.0);
    for (k = 0; k < n; ++k) {
        const dkf_real_t *mk = Ainv + k * n;
        for (i = 0; i < k; ++i) {
            const dkf_real_t mki = mk[i];
            dkf_real_t *ai = Ainv + i * n;
            for (j = i; j < k; ++j) ai[j] += mki * mk[j];
            ai[k] += mki * inv[k];
        }
        Ainv[k * n + k] += inv[k] * inv[k];
    }
    for (i = 0; i < n; ++i)
        for (j = i + 1; j < n; ++j) Ainv[j * n + i] = Ainv[i * n + j];
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
    chol_inverse_from_factor(Ainv->data, L->data, inv, n);
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
    DKF_TRY(chol_factor(work, inv, A->data, n));
    chol_inverse_from_factor(Ainv->data, work, inv, n);
    return DKF_OK;
}
