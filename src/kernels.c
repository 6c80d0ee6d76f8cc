/* Unchecked dense kernels (see kernels.h). Loop orders keep the innermost
 * loop on contiguous rows of row-major storage. */
#include "kernels.h"

#include <math.h>

void dkf__mul_nn(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r, size_t k,
                 size_t c)
{
    size_t i, j, l;
    for (i = 0; i < r; ++i) {
        dkf_real_t *ci = C + i * c;
        const dkf_real_t *ai = A + i * k;
        for (j = 0; j < c; ++j) ci[j] = DKF_R(0.0);
        for (l = 0; l < k; ++l) {
            const dkf_real_t a = ai[l];
            const dkf_real_t *bl = B + l * c;
            for (j = 0; j < c; ++j) ci[j] += a * bl[j];
        }
    }
}

static dkf_real_t dot(const dkf_real_t *a, const dkf_real_t *b, size_t k)
{
    dkf_real_t s = DKF_R(0.0);
    size_t l;
    for (l = 0; l < k; ++l) s += a[l] * b[l];
    return s;
}

void dkf__mul_nt(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r, size_t k,
                 size_t c)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) C[i * c + j] = dot(A + i * k, B + j * k, k);
}

void dkf__mul_nt_sym(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, const dkf_real_t *D,
                     size_t r, size_t k)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = i; j < r; ++j) {
            dkf_real_t v = dot(A + i * k, B + j * k, k);
            if (D != NULL) v += D[i * r + j];
            C[i * r + j] = v;
            C[j * r + i] = v;
        }
}

void dkf__mul_vec(dkf_real_t *y, const dkf_real_t *A, const dkf_real_t *x, size_t r, size_t c)
{
    size_t i;
    for (i = 0; i < r; ++i) y[i] = dot(A + i * c, x, c);
}

void dkf__symmetrise(dkf_real_t *A, size_t n)
{
    size_t i, j;
    for (i = 0; i < n; ++i)
        for (j = i + 1; j < n; ++j) {
            dkf_real_t v = DKF_R(0.5) * (A[i * n + j] + A[j * n + i]);
            A[i * n + j] = v;
            A[j * n + i] = v;
        }
}

/* Row-oriented Cholesky-Banachiewicz: row i of L needs rows 0..i-1 only,
 * and every inner product runs over two contiguous row prefixes. */
int dkf__chol_inplace(dkf_real_t *A, size_t n)
{
    size_t i, j;
    for (i = 0; i < n; ++i) {
        dkf_real_t *li = A + i * n;
        for (j = 0; j < i; ++j) {
            const dkf_real_t *lj = A + j * n;
            li[j] = (li[j] - dot(li, lj, j)) / lj[j];
        }
        {
            dkf_real_t d = li[i] - dot(li, li, i);
            if (!(d > DKF_R(0.0)) || !isfinite(d)) return -1;
            li[i] = DKF_SQRT(d);
        }
        for (j = i + 1; j < n; ++j) li[j] = DKF_R(0.0);
    }
    return 0;
}

void dkf__tri_lower_solve_vec(const dkf_real_t *L, dkf_real_t *b, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) b[i] = (b[i] - dot(L + i * n, b, i)) / L[i * n + i];
}

void dkf__chol_solve_inplace(const dkf_real_t *L, dkf_real_t *B, size_t n, size_t c)
{
    size_t i, j, l;
    /* forward: L W = B, row by row (row i of W needs rows < i) */
    for (i = 0; i < n; ++i) {
        dkf_real_t *bi = B + i * c;
        for (l = 0; l < i; ++l) {
            const dkf_real_t a = L[i * n + l];
            const dkf_real_t *bl = B + l * c;
            for (j = 0; j < c; ++j) bi[j] -= a * bl[j];
        }
        {
            const dkf_real_t inv = DKF_R(1.0) / L[i * n + i];
            for (j = 0; j < c; ++j) bi[j] *= inv;
        }
    }
    /* backward: L^T X = W, row i of X needs rows > i */
    for (i = n; i-- > 0;) {
        dkf_real_t *bi = B + i * c;
        for (l = i + 1; l < n; ++l) {
            const dkf_real_t a = L[l * n + i];
            const dkf_real_t *bl = B + l * c;
            for (j = 0; j < c; ++j) bi[j] -= a * bl[j];
        }
        {
            const dkf_real_t inv = DKF_R(1.0) / L[i * n + i];
            for (j = 0; j < c; ++j) bi[j] *= inv;
        }
    }
}

/* (L L^T)^{-1} = L^{-T} L^{-1}: invert L into the lower triangle of Ainv,
 * then form the product's upper triangle and mirror it. */
void dkf__chol_inverse(dkf_real_t *Ainv, const dkf_real_t *L, size_t n)
{
    size_t i, j, l;
    /* M = L^{-1}, lower triangular, stored in the lower triangle of Ainv */
    for (j = 0; j < n; ++j) {
        Ainv[j * n + j] = DKF_R(1.0) / L[j * n + j];
        for (i = j + 1; i < n; ++i) {
            dkf_real_t s = DKF_R(0.0);
            for (l = j; l < i; ++l) s += L[i * n + l] * Ainv[l * n + j];
            Ainv[i * n + j] = -s / L[i * n + i];
        }
    }
    /* (M^T M)_ij = sum_{l >= j} M_li M_lj for i <= j reads only the lower
     * triangle. Writing row i's upper part (j from n-1 down to i) leaves
     * M intact until M_ii itself, which no later entry needs. */
    for (i = 0; i < n; ++i)
        for (j = n; j-- > i;) {
            dkf_real_t s = DKF_R(0.0);
            for (l = j; l < n; ++l) s += Ainv[l * n + i] * Ainv[l * n + j];
            Ainv[i * n + j] = s;
        }
    for (i = 0; i < n; ++i)
        for (j = 0; j < i; ++j) Ainv[i * n + j] = Ainv[j * n + i];
}
