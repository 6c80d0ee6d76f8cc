/* Unchecked dense kernels (see kernels.h), shared by the public matrix
 * routines and the filters' hot paths. Loop orders keep the innermost loop
 * on contiguous rows of row-major storage. */
#include "kernels.h"

#include <math.h>
#include <string.h>

void dkf__copy(dkf_real_t *dst, const dkf_real_t *src, size_t n)
{
    memcpy(dst, src, n * sizeof *dst);
}

void dkf__mul_nn(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r, size_t k,
                 size_t c)
{
    size_t i, j, l;
    /* row i of C accumulates A(i,l) * row l of B */
    for (i = 0; i < r; ++i) {
        dkf_real_t *ci = C + i * c;
        const dkf_real_t *ai = A + i * k;
        const dkf_real_t a0 = ai[0];
        for (j = 0; j < c; ++j) ci[j] = a0 * B[j];
        for (l = 1; l < k; ++l) {
            const dkf_real_t a = ai[l];
            const dkf_real_t *bl = B + l * c;
            for (j = 0; j < c; ++j) ci[j] += a * bl[j];
        }
    }
}

dkf_real_t dkf__dot(const dkf_real_t *a, const dkf_real_t *b, size_t k)
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
        for (j = 0; j < c; ++j) C[i * c + j] = dkf__dot(A + i * k, B + j * k, k);
}

void dkf__mul_nt_sym(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, const dkf_real_t *D,
                     size_t r, size_t k)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = i; j < r; ++j) {
            dkf_real_t v = dkf__dot(A + i * k, B + j * k, k);
            if (D != NULL) v += D[i * r + j];
            C[i * r + j] = v;
            C[j * r + i] = v;
        }
}

void dkf__mul_vec(dkf_real_t *y, const dkf_real_t *A, const dkf_real_t *x, size_t r, size_t c)
{
    size_t i;
    for (i = 0; i < r; ++i) y[i] = dkf__dot(A + i * c, x, c);
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

/* Cholesky-Banachiewicz: row i of L needs only rows 0..i-1 of L and row i
 * of A, so every inner product runs along two contiguous rows, and W == A
 * works (each element is read before it is overwritten). Divisions by
 * L(j,j) become products with its reciprocal: one division per row. */
int dkf__chol(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n)
{
    size_t i, j;
    for (i = 0; i < n; ++i) {
        dkf_real_t *wi = W + i * n;
        const dkf_real_t *ai = A + i * n;
        dkf_real_t d;
        for (j = 0; j < i; ++j) wi[j] = (ai[j] - dkf__dot(wi, W + j * n, j)) * inv[j];
        d = ai[i] - dkf__dot(wi, wi, i);
        if (!(d > DKF_R(0.0) && d <= DKF_REAL_MAX)) return -1;
        d = DKF_SQRT(d);
        wi[i] = d;
        inv[i] = DKF_R(1.0) / d;
        for (j = i + 1; j < n; ++j) wi[j] = DKF_R(0.0);
    }
    return 0;
}

void dkf__tri_lower_solve_vec(const dkf_real_t *L, const dkf_real_t *inv, dkf_real_t *b,
                              size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) b[i] = (b[i] - dkf__dot(L + i * n, b, i)) * inv[i];
}

void dkf__chol_solve(const dkf_real_t *L, const dkf_real_t *inv, dkf_real_t *B, size_t n,
                     size_t c)
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
        for (j = 0; j < c; ++j) bi[j] *= inv[i];
    }
    /* backward: L^T X = W; once row i of X is final, remove L(i,l) x_i from
     * every row l < i, walking row i of L */
    for (i = n; i-- > 0;) {
        dkf_real_t *bi = B + i * c;
        const dkf_real_t *li = L + i * n;
        for (j = 0; j < c; ++j) bi[j] *= inv[i];
        for (l = 0; l < i; ++l) {
            const dkf_real_t a = li[l];
            dkf_real_t *bl = B + l * c;
            for (j = 0; j < c; ++j) bl[j] -= a * bi[j];
        }
    }
}

/* (L L^T)^{-1} = M^T M with M = L^{-1}. M's diagonal is inv; its strict
 * lower triangle is built in the strict lower triangle of Ainv. M^T M =
 * sum_k m_k^T m_k over the rows m_k of M is accumulated row by row into the
 * upper triangle of Ainv, which never overlaps what is still to be read,
 * then mirrored: exactly symmetric. About n^3/3 multiply-adds. */
void dkf__chol_inverse(dkf_real_t *Ainv, const dkf_real_t *L, const dkf_real_t *inv, size_t n)
{
    size_t i, j, k;
    /* M(i, 0:i-1) = -inv_i * sum_k L(i,k) M(k, 0:k) */
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
