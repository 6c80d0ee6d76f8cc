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

/* Register blocks of C = A B (row-major, B with row stride ldb). Each
 * block keeps its sums in registers across the whole l loop: a loaded B
 * element feeds one multiply-add per row of the block, and the sums are
 * independent chains (no add-latency bound). Along a row the 4 (or 2)
 * sums use 4 contiguous B elements, which GCC's basic-block vectoriser
 * turns into SIMD at plain -O2. Every sum runs over l = 0, 1, ... in
 * order from its first product, so each C(i,j) is bit-identical to the
 * textbook loop's. a0, a1 are rows of A, b points at B(0, j). */
static void nn_2x4(dkf_real_t s[8], const dkf_real_t *restrict a0, const dkf_real_t *restrict a1,
                   const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf_real_t x0 = a0[0], x1 = a1[0];
    dkf_real_t s00 = x0 * b[0], s01 = x0 * b[1], s02 = x0 * b[2], s03 = x0 * b[3];
    dkf_real_t s10 = x1 * b[0], s11 = x1 * b[1], s12 = x1 * b[2], s13 = x1 * b[3];
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        x0 = a0[l];
        x1 = a1[l];
        s00 += x0 * bl[0];
        s01 += x0 * bl[1];
        s02 += x0 * bl[2];
        s03 += x0 * bl[3];
        s10 += x1 * bl[0];
        s11 += x1 * bl[1];
        s12 += x1 * bl[2];
        s13 += x1 * bl[3];
    }
    s[0] = s00, s[1] = s01, s[2] = s02, s[3] = s03;
    s[4] = s10, s[5] = s11, s[6] = s12, s[7] = s13;
}

static void nn_2x2(dkf_real_t s[4], const dkf_real_t *restrict a0, const dkf_real_t *restrict a1,
                   const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf_real_t x0 = a0[0], x1 = a1[0];
    dkf_real_t s00 = x0 * b[0], s01 = x0 * b[1], s10 = x1 * b[0], s11 = x1 * b[1];
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        x0 = a0[l];
        x1 = a1[l];
        s00 += x0 * bl[0];
        s01 += x0 * bl[1];
        s10 += x1 * bl[0];
        s11 += x1 * bl[1];
    }
    s[0] = s00, s[1] = s01, s[2] = s10, s[3] = s11;
}

static void nn_2x1(dkf_real_t s[2], const dkf_real_t *restrict a0, const dkf_real_t *restrict a1,
                   const dkf_real_t *restrict b, size_t k, size_t ldb)
{
    dkf_real_t s0 = a0[0] * b[0], s1 = a1[0] * b[0];
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t bl = b[l * ldb];
        s0 += a0[l] * bl;
        s1 += a1[l] * bl;
    }
    s[0] = s0, s[1] = s1;
}

static void nn_1x4(dkf_real_t s[4], const dkf_real_t *restrict a0, const dkf_real_t *restrict b,
                   size_t k, size_t ldb)
{
    dkf_real_t x = a0[0];
    dkf_real_t s0 = x * b[0], s1 = x * b[1], s2 = x * b[2], s3 = x * b[3];
    size_t l;
    for (l = 1; l < k; ++l) {
        const dkf_real_t *bl = b + l * ldb;
        x = a0[l];
        s0 += x * bl[0];
        s1 += x * bl[1];
        s2 += x * bl[2];
        s3 += x * bl[3];
    }
    s[0] = s0, s[1] = s1, s[2] = s2, s[3] = s3;
}

static dkf_real_t nn_1x1(const dkf_real_t *restrict a0, const dkf_real_t *restrict b, size_t k,
                         size_t ldb)
{
    dkf_real_t s0 = a0[0] * b[0];
    size_t l;
    for (l = 1; l < k; ++l) s0 += a0[l] * b[l * ldb];
    return s0;
}

/* Rows c0, c1 of C = A B (rows a0, a1 of A). */
static void mul_nn_rows2(dkf_real_t *restrict c0, dkf_real_t *restrict c1,
                         const dkf_real_t *restrict a0, const dkf_real_t *restrict a1,
                         const dkf_real_t *restrict B, size_t k, size_t c)
{
    dkf_real_t s[8];
    size_t j = 0;
    for (; j + 4 <= c; j += 4) {
        nn_2x4(s, a0, a1, B + j, k, c);
        c0[j] = s[0], c0[j + 1] = s[1], c0[j + 2] = s[2], c0[j + 3] = s[3];
        c1[j] = s[4], c1[j + 1] = s[5], c1[j + 2] = s[6], c1[j + 3] = s[7];
    }
    if (j + 2 <= c) {
        nn_2x2(s, a0, a1, B + j, k, c);
        c0[j] = s[0], c0[j + 1] = s[1], c1[j] = s[2], c1[j + 1] = s[3];
        j += 2;
    }
    if (j < c) {
        nn_2x1(s, a0, a1, B + j, k, c);
        c0[j] = s[0], c1[j] = s[1];
    }
}

/* Row c0 of C = A B (the last row of an odd row count). */
static void mul_nn_row1(dkf_real_t *restrict c0, const dkf_real_t *restrict a0,
                        const dkf_real_t *restrict B, size_t k, size_t c)
{
    dkf_real_t s[4];
    size_t j = 0;
    for (; j + 4 <= c; j += 4) {
        nn_1x4(s, a0, B + j, k, c);
        c0[j] = s[0], c0[j + 1] = s[1], c0[j + 2] = s[2], c0[j + 3] = s[3];
    }
    for (; j < c; ++j) c0[j] = nn_1x1(a0, B + j, k, c);
}

void dkf__mul_nn(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r, size_t k,
                 size_t c)
{
    size_t i = 0;
    for (; i + 2 <= r; i += 2)
        mul_nn_rows2(C + i * c, C + (i + 1) * c, A + i * k, A + (i + 1) * k, B, k, c);
    if (i < r) mul_nn_row1(C + i * c, A + i * k, B, k, c);
}

/* Stands in for a NULL D of dkf__mul_nn_sym: adding +0 changes no sum
 * (but the sign of a zero), and the loops stay free of tests. */
static const dkf_real_t zero_row[DKF_MAX_DIM];

/* Rows i, i+1 of the upper triangle of A B + D, r x r, from column i on,
 * with the register blocks of dkf__mul_nn; d0, d1 are rows i, i+1 of D.
 * The block's (i+1, i) element is below the diagonal: computed, never
 * stored. D(i,j) is read just before C(i,j) is written (D may be C). */
static void mul_nn_sym_rows2(dkf_real_t *C, const dkf_real_t *restrict A,
                             const dkf_real_t *restrict B, const dkf_real_t *d0,
                             const dkf_real_t *d1, size_t i, size_t r, size_t k)
{
    const dkf_real_t *a0 = A + i * k, *a1 = a0 + k;
    dkf_real_t *c0 = C + i * r, *c1 = c0 + r;
    dkf_real_t s[8];
    size_t j = i;
    for (; j + 4 <= r; j += 4) {
        nn_2x4(s, a0, a1, B + j, k, r);
        c0[j] = s[0] + d0[j], c0[j + 1] = s[1] + d0[j + 1];
        c0[j + 2] = s[2] + d0[j + 2], c0[j + 3] = s[3] + d0[j + 3];
        if (j != i) c1[j] = s[4] + d1[j];
        c1[j + 1] = s[5] + d1[j + 1];
        c1[j + 2] = s[6] + d1[j + 2], c1[j + 3] = s[7] + d1[j + 3];
    }
    if (j + 2 <= r) {
        nn_2x2(s, a0, a1, B + j, k, r);
        c0[j] = s[0] + d0[j], c0[j + 1] = s[1] + d0[j + 1];
        if (j != i) c1[j] = s[2] + d1[j];
        c1[j + 1] = s[3] + d1[j + 1];
        j += 2;
    }
    if (j < r) { /* j > i here: r - i >= 2, and 1 is left after blocks */
        nn_2x1(s, a0, a1, B + j, k, r);
        c0[j] = s[0] + d0[j];
        c1[j] = s[1] + d1[j];
    }
}

void dkf__mul_nn_sym(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, const dkf_real_t *D,
                     size_t r, size_t k)
{
    size_t i = 0, j;
    for (; i + 2 <= r; i += 2) {
        const dkf_real_t *d0 = D != NULL ? D + i * r : zero_row;
        const dkf_real_t *d1 = D != NULL ? d0 + r : zero_row;
        mul_nn_sym_rows2(C, A, B, d0, d1, i, r, k);
    }
    if (i < r) /* the last row of an odd count: only its diagonal element */
        C[i * r + i] = nn_1x1(A + i * k, B + i, k, r) + (D != NULL ? D[i * r + i] : DKF_R(0.0));
    for (i = 0; i < r; ++i)
        for (j = i + 1; j < r; ++j) C[j * r + i] = C[i * r + j];
}

/* One chain, summed in index order: the kernels below that take dot
 * products of several pairs at once keep exactly this order per pair. */
dkf_real_t dkf__dot(const dkf_real_t *a, const dkf_real_t *b, size_t k)
{
    dkf_real_t s = DKF_R(0.0);
    size_t l;
    for (l = 0; l < k; ++l) s += a[l] * b[l];
    return s;
}

/* out[t] = a . b_t for the 4 rows b_t = b + t*ldb (length k): 4 independent
 * chains (a dot product's adds are otherwise one serial chain, bound by the
 * add latency), and a[l] is loaded once for 4 products. Each chain sums in
 * the order of dkf__dot, so the results are bit-identical to 4 calls. */
static void dot4(dkf_real_t out[4], const dkf_real_t *restrict a, const dkf_real_t *restrict b,
                 size_t ldb, size_t k)
{
    const dkf_real_t *restrict b0 = b, *restrict b1 = b + ldb;
    const dkf_real_t *restrict b2 = b + 2 * ldb, *restrict b3 = b + 3 * ldb;
    dkf_real_t s0 = DKF_R(0.0), s1 = DKF_R(0.0), s2 = DKF_R(0.0), s3 = DKF_R(0.0);
    size_t l;
    for (l = 0; l < k; ++l) {
        const dkf_real_t x = a[l];
        s0 += x * b0[l];
        s1 += x * b1[l];
        s2 += x * b2[l];
        s3 += x * b3[l];
    }
    out[0] = s0, out[1] = s1, out[2] = s2, out[3] = s3;
}

/* out[t] = a . b_t for 2 rows (see dot4). */
static void dot2(dkf_real_t out[2], const dkf_real_t *restrict a, const dkf_real_t *restrict b,
                 size_t ldb, size_t k)
{
    const dkf_real_t *restrict b0 = b, *restrict b1 = b + ldb;
    dkf_real_t s0 = DKF_R(0.0), s1 = DKF_R(0.0);
    size_t l;
    for (l = 0; l < k; ++l) {
        const dkf_real_t x = a[l];
        s0 += x * b0[l];
        s1 += x * b1[l];
    }
    out[0] = s0, out[1] = s1;
}

/* out[j] = a . (row j of B), j < c, B c x k: the dot products of one row
 * of A B^T, 4 (then 2, then 1) at a time. */
static void dots_row(dkf_real_t *restrict out, const dkf_real_t *restrict a,
                     const dkf_real_t *restrict B, size_t k, size_t c)
{
    size_t j = 0;
    for (; j + 4 <= c; j += 4) dot4(out + j, a, B + j * k, k, k);
    if (j + 2 <= c) {
        dot2(out + j, a, B + j * k, k, k);
        j += 2;
    }
    if (j < c) out[j] = dkf__dot(a, B + j * k, k);
}

void dkf__mul_nt(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r, size_t k,
                 size_t c)
{
    size_t i;
    for (i = 0; i < r; ++i) dots_row(C + i * c, A + i * k, B, k, c);
}

/* Row i of the upper triangle: C(i, i..r-1) = A_i . B_j (+ D(i,j)), then
 * mirrored into column i. D may be C itself: D(i,j), j >= i, is read
 * before C(i,j) is written, and the mirror writes only the strict lower
 * triangle, which D never supplies. */
void dkf__mul_nt_sym(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, const dkf_real_t *D,
                     size_t r, size_t k)
{
    dkf_real_t row[DKF_MAX_DIM];
    size_t i, j;
    for (i = 0; i < r; ++i) {
        dkf_real_t *ci = C + i * r;
        dots_row(row, A + i * k, B + i * k, k, r - i);
        if (D != NULL) {
            const dkf_real_t *di = D + i * r;
            for (j = i; j < r; ++j) ci[j] = row[j - i] + di[j];
        } else {
            for (j = i; j < r; ++j) ci[j] = row[j - i];
        }
        for (j = i + 1; j < r; ++j) C[j * r + i] = ci[j];
    }
}

/* 4 rows of A at a time (see dot4): y(i..i+3) = A(i..i+3, :) x. */
void dkf__mul_vec(dkf_real_t *y, const dkf_real_t *A, const dkf_real_t *x, size_t r, size_t c)
{
    size_t i = 0;
    for (; i + 4 <= r; i += 4) dot4(y + i, x, A + i * c, c, c);
    if (i + 2 <= r) {
        dot2(y + i, x, A + i * c, c, c);
        i += 2;
    }
    if (i < r) y[i] = dkf__dot(A + i * c, x, c);
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

/* Both substitutions work on 4 columns of B at a time kept in registers
 * (row-major friendly, independent chains), and sum each element's terms
 * in the textbook order (forward: l ascending; backward: i descending),
 * so the result is that of the plain row-by-row loops. */
void dkf__chol_solve(const dkf_real_t *L, const dkf_real_t *inv, dkf_real_t *B, size_t n,
                     size_t c)
{
    size_t i, j, l;
    /* forward: L W = B; row i of W = (row i of B - sum_{l<i} L(i,l) W_l) / L(i,i) */
    for (i = 0; i < n; ++i) {
        dkf_real_t *bi = B + i * c;
        const dkf_real_t *li = L + i * n;
        const dkf_real_t d = inv[i];
        for (j = 0; j + 4 <= c; j += 4) {
            dkf_real_t t0 = bi[j], t1 = bi[j + 1], t2 = bi[j + 2], t3 = bi[j + 3];
            for (l = 0; l < i; ++l) {
                const dkf_real_t a = li[l];
                const dkf_real_t *bl = B + l * c + j;
                t0 -= a * bl[0];
                t1 -= a * bl[1];
                t2 -= a * bl[2];
                t3 -= a * bl[3];
            }
            bi[j] = t0 * d, bi[j + 1] = t1 * d, bi[j + 2] = t2 * d, bi[j + 3] = t3 * d;
        }
        for (; j < c; ++j) {
            dkf_real_t t = bi[j];
            for (l = 0; l < i; ++l) t -= li[l] * B[l * c + j];
            bi[j] = t * d;
        }
    }
    /* backward: L^T X = W; row l of X = (row l of W - sum_{i>l, descending}
     * L(i,l) X_i) / L(l,l) */
    for (l = n; l-- > 0;) {
        dkf_real_t *bl = B + l * c;
        const dkf_real_t d = inv[l];
        for (j = 0; j + 4 <= c; j += 4) {
            dkf_real_t t0 = bl[j], t1 = bl[j + 1], t2 = bl[j + 2], t3 = bl[j + 3];
            for (i = n - 1; i > l; --i) {
                const dkf_real_t a = L[i * n + l];
                const dkf_real_t *bi = B + i * c + j;
                t0 -= a * bi[0];
                t1 -= a * bi[1];
                t2 -= a * bi[2];
                t3 -= a * bi[3];
            }
            bl[j] = t0 * d, bl[j + 1] = t1 * d, bl[j + 2] = t2 * d, bl[j + 3] = t3 * d;
        }
        for (; j < c; ++j) {
            dkf_real_t t = bl[j];
            for (i = n - 1; i > l; --i) t -= L[i * n + l] * B[i * c + j];
            bl[j] = t * d;
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
