/*
 * LU factorisation with partial pivoting, solves and general inverse
 * (dkf/mat.h).
 *
 * Right-looking elimination on row-major storage: each step updates the
 * trailing rows with a multiple of the pivot row, an inner loop along
 * contiguous rows. Solves and the inverse go one column at a time through
 * a contiguous DKF_MAX_DIM array, which also makes X == B safe.
 */
#include <string.h>

#include "internal.h"
#include "kernels.h"

/* W = A (n x n) while measuring max|A|; DKF_ERR_NONFINITE if any element
 * is NaN or infinite. One pass does the copy, the scan and the scale. */
static dkf_status_t copy_measure(dkf_real_t *W, dkf_real_t *amax, const dkf_real_t *A, size_t n)
{
    dkf_real_t m = DKF_R(0.0);
    size_t i;
    int finite = 1;
    for (i = 0; i < n * n; ++i) {
        const dkf_real_t v = A[i];
        const dkf_real_t a = DKF_FABS(v);
        finite &= (a <= DKF_REAL_MAX); /* false for NaN and infinity */
        if (a > m) m = a;
        W[i] = v;
    }
    *amax = m;
    return finite ? DKF_OK : DKF_ERR_NONFINITE;
}

/* (kernels.h) */
int dkf__lu_inplace(dkf_real_t *W, size_t *perm, size_t n, dkf_real_t tol, int finite)
{
    size_t i, j, k;
    for (i = 0; i < n; ++i) perm[i] = i;
    for (k = 0; k < n; ++k) {
        dkf_real_t *wk = W + k * n;
        dkf_real_t pmax = DKF_FABS(wk[k]), inv;
        size_t p = k;
        for (i = k + 1; i < n; ++i) {
            const dkf_real_t a = DKF_FABS(W[i * n + k]);
            if (a > pmax) {
                pmax = a;
                p = i;
            }
        }
        if (!(pmax > tol) || (finite && !(pmax <= DKF_REAL_MAX))) return -1;
        if (p != k) {
            dkf_real_t *wp = W + p * n;
            const size_t t = perm[k];
            perm[k] = perm[p];
            perm[p] = t;
            for (j = 0; j < n; ++j) {
                const dkf_real_t v = wk[j];
                wk[j] = wp[j];
                wp[j] = v;
            }
        }
        inv = DKF_R(1.0) / wk[k];
        for (i = k + 1; i < n; ++i) {
            dkf_real_t *wi = W + i * n;
            const dkf_real_t l = wi[k] * inv;
            wi[k] = l;
            if (l != DKF_R(0.0))
                for (j = k + 1; j < n; ++j) wi[j] -= l * wk[j];
        }
    }
    return 0;
}

/* P A = L U in W (a copy of A) with perm[i] = original row now at row i.
 * DKF_ERR_SINGULAR when the largest candidate pivot of a column has
 * magnitude <= n * eps * max|A| (or is NaN after overflow). */
static dkf_status_t lu_factor(dkf_real_t *W, size_t *perm, const dkf_real_t *A, size_t n)
{
    dkf_real_t amax;
    DKF_TRY(copy_measure(W, &amax, A, n));
    /* (n * eps) < 1 is formed first so the product cannot overflow */
    return dkf__lu_inplace(W, perm, n, ((dkf_real_t)n * DKF_REAL_EPSILON) * amax, 0) == 0
               ? DKF_OK
               : DKF_ERR_SINGULAR;
}

dkf_status_t dkf_mat_lu(dkf_mat_t *LU, size_t *piv, const dkf_mat_t *A, dkf_real_t *work)
{
    size_t perm[DKF_MAX_DIM];
    size_t n;
    DKF_TRY(dkf__check_mat(LU));
    DKF_TRY(dkf__check_mat(A));
    n = A->rows;
    if (A->cols != n || LU->rows != n || LU->cols != n) return DKF_ERR_DIM;
    DKF_CHECK_NULL(piv);
    DKF_CHECK_NULL(work);
    DKF_CHECK_SAME_OR_DISJOINT(LU, A);
    DKF_CHECK_NO_ALIAS_BUF(LU, work, n * n);
    DKF_CHECK_NO_ALIAS_BUF(A, work, n * n);
    DKF_TRY(lu_factor(work, perm, A->data, n));
    memcpy(LU->data, work, n * n * sizeof(dkf_real_t));
    memcpy(piv, perm, n * sizeof(size_t));
    return DKF_OK;
}

/* x = U^{-1} L^{-1} t in place: unit lower L and upper U packed in LU,
 * inv[i] = 1 / U(i,i). The forward sweep starts at row `first`, t being
 * zero above it (a permuted unit vector when inverting). Both sweeps are
 * dot products along contiguous rows of LU. */
static void lu_substitute(dkf_real_t *t, const dkf_real_t *LU, const dkf_real_t *inv, size_t n,
                          size_t first)
{
    size_t i, j;
    for (i = first + 1; i < n; ++i) {
        const dkf_real_t *r = LU + i * n;
        dkf_real_t s = t[i];
        for (j = first; j < i; ++j) s -= r[j] * t[j];
        t[i] = s;
    }
    for (i = n; i-- > 0;) {
        const dkf_real_t *r = LU + i * n;
        dkf_real_t s = t[i];
        for (j = i + 1; j < n; ++j) s -= r[j] * t[j];
        t[i] = s * inv[i];
    }
}

dkf_status_t dkf_mat_lu_solve(dkf_mat_t *X, const dkf_mat_t *LU, const size_t *piv,
                              const dkf_mat_t *B)
{
    dkf_real_t inv[DKF_MAX_DIM], t[DKF_MAX_DIM];
    unsigned char seen[DKF_MAX_DIM];
    size_t n, m, i, c;
    DKF_TRY(dkf__check_mat(X));
    DKF_TRY(dkf__check_mat(LU));
    DKF_TRY(dkf__check_mat(B));
    n = LU->rows;
    m = B->cols;
    if (LU->cols != n || B->rows != n) return DKF_ERR_DIM;
    if (X->rows != n || X->cols != m) return DKF_ERR_DIM;
    DKF_CHECK_NULL(piv);
    DKF_CHECK_NO_ALIAS(X, LU);
    DKF_CHECK_SAME_OR_DISJOINT(X, B);
    /* piv indexes B: it must be a permutation of 0..n-1, or rows of B
     * outside the matrix would be read. */
    memset(seen, 0, sizeof seen);
    for (i = 0; i < n; ++i) {
        if (piv[i] >= n || seen[piv[i]]) return DKF_ERR_ARG;
        seen[piv[i]] = 1;
    }
    if (!dkf__all_finite(LU->data, n * n) || !dkf__all_finite(B->data, n * m))
        return DKF_ERR_NONFINITE;
    for (i = 0; i < n; ++i) {
        const dkf_real_t u = LU->data[i * n + i];
        if (u == DKF_R(0.0)) return DKF_ERR_SINGULAR;
        inv[i] = DKF_R(1.0) / u;
    }
    for (c = 0; c < m; ++c) {
        for (i = 0; i < n; ++i) t[i] = B->data[piv[i] * m + c];
        lu_substitute(t, LU->data, inv, n, 0);
        for (i = 0; i < n; ++i) X->data[i * m + c] = t[i];
    }
    return DKF_OK;
}

dkf_status_t dkf_mat_inverse(dkf_mat_t *Ainv, const dkf_mat_t *A, size_t *piv, dkf_real_t *work)
{
    dkf_real_t inv[DKF_MAX_DIM], t[DKF_MAX_DIM];
    size_t perm[DKF_MAX_DIM], pos[DKF_MAX_DIM];
    size_t n, i, c;
    DKF_TRY(dkf__check_mat(Ainv));
    DKF_TRY(dkf__check_mat(A));
    n = A->rows;
    if (A->cols != n || Ainv->rows != n || Ainv->cols != n) return DKF_ERR_DIM;
    DKF_CHECK_NULL(piv);
    DKF_CHECK_NULL(work);
    DKF_CHECK_SAME_OR_DISJOINT(Ainv, A);
    DKF_CHECK_NO_ALIAS_BUF(Ainv, work, n * n);
    DKF_CHECK_NO_ALIAS_BUF(A, work, n * n);
    /* Only the first n*n reals of the DKF_MAT_INV_WORK are needed: the
     * columns of the inverse go straight to Ainv, A being dead once
     * factored (so Ainv == A is safe). */
    DKF_TRY(lu_factor(work, perm, A->data, n));
    for (i = 0; i < n; ++i) {
        inv[i] = DKF_R(1.0) / work[i * n + i];
        pos[perm[i]] = i;
    }
    /* Column c of A^{-1} solves L U x = P e_c; P e_c is the unit vector at
     * pos[c], so the forward sweep skips the zeros above it. */
    for (c = 0; c < n; ++c) {
        const size_t first = pos[c];
        for (i = 0; i < n; ++i) t[i] = DKF_R(0.0);
        t[first] = DKF_R(1.0);
        lu_substitute(t, work, inv, n, first);
        for (i = 0; i < n; ++i) Ainv->data[i * n + c] = t[i];
    }
    memcpy(piv, perm, n * sizeof(size_t));
    return DKF_OK;
}
