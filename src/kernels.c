/* Unchecked dense kernels (see kernels.h), shared by the public matrix
 * routines and the filters' hot paths. Loop orders keep the innermost loop
 * on contiguous rows of row-major storage. */
#include "peel.h" /* first: before any definition */

#include "kernels.h"
#include "kernels_inline.h"

#include <string.h>

void dkf__copy(dkf_real_t *dst, const dkf_real_t *src, size_t n)
{
    memcpy(dst, src, n * sizeof *dst);
}

void dkf__mul_nn(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r, size_t k,
                 size_t c)
{
    inl_mul_nn(C, A, B, r, k, c);
}

void dkf__mul_nn_sym(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, const dkf_real_t *D,
                     size_t r, size_t k)
{
    inl_mul_nn_sym(C, A, B, D, r, k);
}

dkf_real_t dkf__dot(const dkf_real_t *a, const dkf_real_t *b, size_t k)
{
    return inl_dot(a, b, k);
}

/* out[t] = a . b_t for the 4 rows b_t = b + t*ldb (length k): 4 independent
 * chains (a dot product's adds are otherwise one serial chain, bound by the
 * add latency), and a[l] is loaded once for 4 products. Each chain sums in
 * the order of inl_dot, so the results are bit-identical to 4 calls. */
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

/* y = A x: y(i) = x . (row i of A), the dot products of dots_row. */
void dkf__mul_vec(dkf_real_t *y, const dkf_real_t *A, const dkf_real_t *x, size_t r, size_t c)
{
    dots_row(y, x, A, c, r);
}

void dkf__transpose(dkf_real_t *At, const dkf_real_t *A, size_t r, size_t c)
{
    inl_transpose(At, A, r, c);
}

void dkf__mul_tn(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, const dkf_real_t *D,
                 size_t k, size_t r, size_t c)
{
    size_t i, j, l;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) {
            dkf_real_t v = D != NULL ? D[i * c + j] : DKF_R(0.0);
            for (l = 0; l < k; ++l) v += A[l * r + i] * B[l * c + j];
            C[i * c + j] = v;
        }
}

void dkf__sub_tn(dkf_real_t *C, const dkf_real_t *D, const dkf_real_t *A, const dkf_real_t *B,
                 size_t k, size_t r, size_t c)
{
    size_t i, j, l;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) {
            dkf_real_t v = D[i * c + j];
            for (l = 0; l < k; ++l) v -= A[l * r + i] * B[l * c + j];
            C[i * c + j] = v;
        }
}

void dkf__sub_tn_sym(dkf_real_t *C, const dkf_real_t *D, const dkf_real_t *A, const dkf_real_t *B,
                     size_t k, size_t r)
{
    size_t i, j, l;
    for (i = 0; i < r; ++i)
        for (j = i; j < r; ++j) {
            dkf_real_t v = D[i * r + j];
            for (l = 0; l < k; ++l) v -= A[l * r + i] * B[l * r + j];
            C[i * r + j] = v;
            C[j * r + i] = v;
        }
}

void dkf__put_block(dkf_real_t *D, size_t cols, size_t r0, size_t c0, const dkf_real_t *S,
                    size_t r, size_t c)
{
    size_t i;
    for (i = 0; i < r; ++i) dkf__copy(D + (r0 + i) * cols + c0, S + i * c, c);
}

void dkf__put_sym_blocks(dkf_real_t *Out, const dkf_real_t *X, const dkf_real_t *Y,
                         const dkf_real_t *Z, size_t n, size_t p)
{
    const size_t N = n + p;
    size_t i, j;
    dkf__put_block(Out, N, 0, 0, X, n, n);
    dkf__put_block(Out, N, n, n, Z, p, p);
    for (i = 0; i < n; ++i)
        for (j = 0; j < p; ++j) {
            const dkf_real_t y = Y != NULL ? Y[i * p + j] : DKF_R(0.0);
            Out[i * N + n + j] = y;
            Out[(n + j) * N + i] = y;
        }
}

void dkf__pack_sym(dkf_real_t *p, const dkf_real_t *A, size_t n)
{
    size_t i, j, e = 0;
    for (i = 0; i < n; ++i)
        for (j = i; j < n; ++j) p[e++] = A[i * n + j];
}

void dkf__unpack_sym(dkf_real_t *A, const dkf_real_t *p, size_t n)
{
    size_t i, j, e = 0;
    for (i = 0; i < n; ++i)
        for (j = i; j < n; ++j) {
            A[i * n + j] = p[e];
            A[j * n + i] = p[e];
            ++e;
        }
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

/* ---- products that skip exact zeros ----------------------------------------
 * The stacked model of a fusion centre (docs/design/diffkf-fusion.md §1) has
 * block-diagonal A, B, C and hence block-structured A^+, B^{-1}, G: each
 * row is zero outside one node's columns. The helpers below skip, for each
 * row, the terms outside its nonzero span [lo, hi). Every skipped term is
 * a finite number times an exact zero, which does not change an IEEE sum
 * (s + (+-0) = s for s != 0, and +0 + (+-0) = +0; an index-order sum
 * starts at +0), so the results are those of the dense kernels (at most
 * the sign of an exact zero differs) and hold for any matrix, block
 * diagonal or not; a dense one only costs the span scan. Non-finite
 * factors would not give the dense result (inf * 0 = NaN): the callers
 * refuse them first, with the dense product's status. */

/* lo[i], hi[i]: the first nonzero and one past the last nonzero column of
 * row i of A (r x c); lo = hi for a zero row. */
void dkf__row_spans(size_t *lo, size_t *hi, const dkf_real_t *A, size_t r, size_t c)
{
    size_t i, a, b;
    for (i = 0; i < r; ++i) {
        const dkf_real_t *ai = A + i * c;
        for (a = 0; a < c && ai[a] == DKF_R(0.0); ++a) continue;
        for (b = c; b > a && ai[b - 1] == DKF_R(0.0); --b) continue;
        lo[i] = a;
        hi[i] = b;
    }
}

/* Out (r x s) = A (r x c) B^T for B (s x c) whose row j is zero outside
 * [lo[j], hi[j]): element (i, j) is the index-order dot product over the
 * span, as dkf__mul_nt sums it over all of 0..c-1. */
void dkf__mul_nt_spans(dkf_real_t *Out, const dkf_real_t *A, const dkf_real_t *B, size_t r,
                       size_t c, size_t s, const size_t *lo, const size_t *hi)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = 0; j < s; ++j)
            Out[i * s + j] = inl_dot(A + i * c + lo[j], B + j * c + lo[j], hi[j] - lo[j]);
}

/* C (r x c) = A (r x k) B for A zero outside [lo[i], hi[i]) in row i: row
 * i of C sums l over the span only, in index order (mul_nn_row1). */
void dkf__mul_nn_spans(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r,
                       size_t k, size_t c, const size_t *lo, const size_t *hi)
{
    size_t i;
    for (i = 0; i < r; ++i) {
        if (hi[i] > lo[i])
            mul_nn_row1(C + i * c, A + i * k + lo[i], B + lo[i] * c, hi[i] - lo[i], c);
        else
            memset(C + i * c, 0, c * sizeof *C);
    }
}

/* C (r x r) = A (r x k) B^T + D for B (r x k) zero outside its row spans,
 * symmetric by construction: the upper triangle, each element the dot
 * product over row j's span plus D(i, j) (D NULL: 0; D may be C), mirrored. */
void dkf__mul_nt_sym_spans(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B,
                           const dkf_real_t *D, size_t r, size_t k, const size_t *lo,
                           const size_t *hi)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = i; j < r; ++j) {
            const dkf_real_t v = inl_dot(A + i * k + lo[j], B + j * k + lo[j], hi[j] - lo[j]);
            C[i * r + j] = D != NULL ? v + D[i * r + j] : v;
            C[j * r + i] = C[i * r + j];
        }
}

int dkf__chol(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n)
{
    return inl_chol(W, inv, A, n);
}

/* The large-model kernels for the baseline ISA (kernels_wide.h), and the
 * choice between them and kernels_avx.c's at run time. */
#define KW(name) name##_base
#define KW_W 8
#define KW_NN nn_2x8
#define KW_SOLVE solve_2x8
#include "kernels_wide.h"
#undef KW
#undef KW_W
#undef KW_NN
#undef KW_SOLVE

int dkf__isa_avx(void)
{
#if DKF__AVX
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx") != 0;
#else
    return 0;
#endif
}

int dkf__chol_wide_isa(int avx, dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n,
                       dkf_real_t *T)
{
#if DKF__AVX
    if (avx) return dkf__chol_wide_avx(W, inv, A, n, T);
#endif
    (void)avx;
    return dkf__chol_wide_base(W, inv, A, n, T);
}

void dkf__whiten_spans_isa(int avx, dkf_real_t *Out, const dkf_real_t *Y, const dkf_real_t *Lc,
                           const dkf_real_t *inv, size_t r, size_t p, const size_t *lo)
{
#if DKF__AVX
    if (avx) {
        dkf__whiten_spans_avx(Out, Y, Lc, inv, r, p, lo);
        return;
    }
#endif
    (void)avx;
    dkf__whiten_spans_base(Out, Y, Lc, inv, r, p, lo);
}

void dkf__tn_self_spans_isa(int avx, dkf_real_t *C, const dkf_real_t *A, size_t r, size_t k,
                            size_t *lo)
{
#if DKF__AVX
    if (avx) {
        dkf__tn_self_spans_avx(C, A, r, k, lo);
        return;
    }
#endif
    (void)avx;
    dkf__tn_self_spans_base(C, A, r, k, lo);
}

int dkf__chol_wide(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n, dkf_real_t *T)
{
    return dkf__chol_wide_isa(dkf__isa_avx(), W, inv, A, n, T);
}

void dkf__whiten_spans(dkf_real_t *Out, const dkf_real_t *Y, const dkf_real_t *Lc,
                       const dkf_real_t *inv, size_t r, size_t p, const size_t *lo)
{
    dkf__whiten_spans_isa(dkf__isa_avx(), Out, Y, Lc, inv, r, p, lo);
}

void dkf__tn_self_spans(dkf_real_t *C, const dkf_real_t *A, size_t r, size_t k, size_t *lo)
{
    dkf__tn_self_spans_isa(dkf__isa_avx(), C, A, r, k, lo);
}



void dkf__chol_solve(const dkf_real_t *L, const dkf_real_t *inv, dkf_real_t *B, size_t n,
                     size_t c)
{
    inl_chol_solve(L, inv, B, n, c);
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

void dkf__joseph(dkf_real_t *Pn, const dkf_real_t *P, const dkf_real_t *Kt, const dkf_real_t *H,
                 const dkf_real_t *R, size_t n, size_t m, dkf_real_t *work)
{
    dkf_real_t *AK = work, *G = AK + (n + m) * n, *Rs = G + (n + m) * n;
    inl_negate(AK + n * n, Kt, m * n); /* inl_joseph takes -K^T */
    inl_transpose(G, H, m, n); /* G starts as H^T (inl_joseph reads it first) */
    inl_joseph(Pn, AK, G, Rs, P, G, R, n, m);
}

int dkf__psd_within_rounding(dkf_real_t *work, const dkf_real_t *P, size_t n)
{
    return inl_psd_within_rounding(work, P, n);
}

int dkf__psd_sym_within_rounding(dkf_real_t *work, const dkf_real_t *P, size_t n)
{
    return inl_psd_sym_within_rounding(work, P, n);
}

void dkf__whiten(dkf_real_t *W, dkf_real_t *w, const dkf_real_t *L, const dkf_real_t *inv,
                 const dkf_real_t *C, const dkf_real_t *z, size_t m, size_t n)
{
    size_t l, b, a;
    for (l = 0; l < m; ++l) {
        const dkf_real_t *ll = L + l * m;
        dkf_real_t v = z[l];
        for (b = 0; b < l; ++b) v -= ll[b] * w[b];
        w[l] = v * inv[l];
        for (a = 0; a < n; ++a) {
            dkf_real_t t = C[l * n + a];
            for (b = 0; b < l; ++b) t -= ll[b] * W[b * n + a];
            W[l * n + a] = t * inv[l];
        }
    }
}
