/*
 * src/kernels.h - unchecked dense kernels on raw row-major arrays.
 *
 * The hot paths of the filters validate their arguments once at the API
 * boundary and then run on these, so a Kalman step pays for no repeated
 * checks. Shapes are given explicitly; outputs never alias inputs unless a
 * kernel says so. Not installed.
 */
#ifndef DKF_KERNELS_H
#define DKF_KERNELS_H

#include <stddef.h>

#include "dkf/config.h"

/* dst = src, n reals (memcpy; the regions must not overlap). */
void dkf__copy(dkf_real_t *dst, const dkf_real_t *src, size_t n);
/* C (r x c) = A (r x k) B (k x c). C must not overlap A or B. */
void dkf__mul_nn(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r, size_t k,
                 size_t c);
/* Dot product of two contiguous vectors of length k (k may be 0), summed
 * in index order. */
dkf_real_t dkf__dot(const dkf_real_t *a, const dkf_real_t *b, size_t k);
/* C (r x c) = A (r x k) B^T, B c x k. */
void dkf__mul_nt(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r, size_t k,
                 size_t c);
/* C (r x r) = A (r x k) B^T + D, B r x k, symmetric by construction: only
 * the upper triangle is computed and mirrored. D (r x r) may be NULL; if
 * given, only its upper triangle is read, and D may be C itself (C += A B^T
 * on the upper triangle); C must not overlap A or B. */
void dkf__mul_nt_sym(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, const dkf_real_t *D,
                     size_t r, size_t k);
/* C (r x r) = A (r x k) B (k x r) + D for a product known to be symmetric
 * (e.g. F (P F^T), K (H P)): only the upper triangle is computed, with
 * the row-major blocks of dkf__mul_nn, and mirrored as it is stored. D
 * (r x r) may be NULL; if given, only its upper triangle is read. C must
 * not overlap A, B or D (unlike dkf__mul_nt_sym, D may not be C). */
void dkf__mul_nn_sym(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, const dkf_real_t *D,
                     size_t r, size_t k);
/* y (r) = A (r x c) x (c). y must not overlap A or x. */
void dkf__mul_vec(dkf_real_t *y, const dkf_real_t *A, const dkf_real_t *x, size_t r, size_t c);
/* At (c x r) = A^T for A r x c. At must not overlap A. */
void dkf__transpose(dkf_real_t *At, const dkf_real_t *A, size_t r, size_t c);
/* C (r x c) = D + A^T B for A k x r, B k x c (D r x c, or NULL for 0):
 * element (i, j) is D(i,j) + A(0,i) B(0,j) + A(1,i) B(1,j) + ..., summed
 * in that order. C must not overlap A or B; D may be C. */
void dkf__mul_tn(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, const dkf_real_t *D,
                 size_t k, size_t r, size_t c);
/* C (r x c) = D - A^T B (D r x c, not NULL), in the order of
 * dkf__mul_tn: D(i,j) - A(0,i) B(0,j) - A(1,i) B(1,j) - ... */
void dkf__sub_tn(dkf_real_t *C, const dkf_real_t *D, const dkf_real_t *A, const dkf_real_t *B,
                 size_t k, size_t r, size_t c);
/* dkf__sub_tn for a result known to be symmetric (A, B k x r): the upper
 * triangle is formed and mirrored, only D's upper triangle is read. */
void dkf__sub_tn_sym(dkf_real_t *C, const dkf_real_t *D, const dkf_real_t *A, const dkf_real_t *B,
                     size_t k, size_t r);
/* The r x c block S into the row-major D (`cols` columns) at (r0, c0):
 * the stacking of block matrices (block-diagonal and stacked models). */
void dkf__put_block(dkf_real_t *D, size_t cols, size_t r0, size_t c0, const dkf_real_t *S,
                    size_t r, size_t c);
/* Out (N x N, N = n + p) = [[X, Y], [Y^T, Z]] with X n x n, Z p x p and
 * Y n x p (Y NULL: zero blocks): an augmented or joint covariance (askf's
 * P^a, nerts' [[Px, Pxd], [Pxd^T, Pd]]). p may be 0. */
void dkf__put_sym_blocks(dkf_real_t *Out, const dkf_real_t *X, const dkf_real_t *Y,
                         const dkf_real_t *Z, size_t n, size_t p);
/* Packed upper triangle of the symmetric n x n A, row by row (A(0,0..n-1),
 * A(1,1..n-1), ...): n (n + 1) / 2 reals into p; unpack_sym writes both
 * triangles of A back from p. */
void dkf__pack_sym(dkf_real_t *p, const dkf_real_t *A, size_t n);
void dkf__unpack_sym(dkf_real_t *A, const dkf_real_t *p, size_t n);
/* A = (A + A^T) / 2 for n x n A. */
void dkf__symmetrise(dkf_real_t *A, size_t n);

/* Joseph-form covariance update P+ = (I - K H) P (I - K H)^T + K R K^T,
 * evaluated as written (inl_joseph in kernels_inline.h), for the gain
 * given as Kt = K^T (m x n), H (m x n), R (m x m, upper triangle read).
 * work: DKF__JOSEPH_WORK(n, m) reals, overlapping none of the others;
 * Pn (n x n) must not overlap P, Kt, H or R. */
#define DKF__JOSEPH_WORK(n, m) (2 * ((n) + (m)) * (n) + (m) * (m))
void dkf__joseph(dkf_real_t *Pn, const dkf_real_t *P, const dkf_real_t *Kt, const dkf_real_t *H,
                 const dkf_real_t *R, size_t n, size_t m, dkf_real_t *work);
/* 1 if the symmetric n x n P is positive semi-definite within 4 n eps
 * tr(P) (inl_psd_within_rounding), 0 if not or if any entry is NaN or
 * Inf; work: n^2 reals, not P. */
int dkf__psd_within_rounding(dkf_real_t *work, const dkf_real_t *P, size_t n);
/* The same verdict for a P that is exactly symmetric (P(i,j) == P(j,i)
 * bit for bit: a mirrored product), faster (inl_psd_sym_within_rounding). */
int dkf__psd_sym_within_rounding(dkf_real_t *work, const dkf_real_t *P, size_t n);

/* Whitening by the Cholesky factor L (m x m, inv from dkf__chol) of a
 * noise covariance R = L L^T: W = L^{-1} C (C m x n) and w = L^{-1} z
 * (z m x 1), forward substitution. The information C^T R^{-1} C is then
 * the Gram matrix W^T W (symmetric, PSD up to the rounding of its dot
 * products) and C^T R^{-1} z = W^T w. W, w must not overlap the inputs. */
void dkf__whiten(dkf_real_t *W, dkf_real_t *w, const dkf_real_t *L, const dkf_real_t *inv,
                 const dkf_real_t *C, const dkf_real_t *z, size_t m, size_t n);

/* Products that skip exact zeros (src/kernels.c, "sparse products"): each
 * element is the dense kernel's, up to the sign of an exact zero, when
 * the factors are finite. For the block-diagonal correlation C of a
 * stacked Difference KF (docs/design/diffkf-fusion.md §9).
 * lo[i], hi[i]: the first nonzero column of row i of A (r x c) and one past
 * its last; lo = hi for a zero row. */
void dkf__row_spans(size_t *lo, size_t *hi, const dkf_real_t *A, size_t r, size_t c);
/* Out (r x s) = A (r x c) B^T for B (s x c) zero outside [lo[j], hi[j]) in
 * row j: each element an index-order dot product over the span. */
void dkf__mul_nt_spans(dkf_real_t *Out, const dkf_real_t *A, const dkf_real_t *B, size_t r,
                       size_t c, size_t s, const size_t *lo, const size_t *hi);
/* C (r x c) = A (r x k) B for A zero outside [lo[i], hi[i]) in row i. */
void dkf__mul_nn_spans(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B, size_t r,
                       size_t k, size_t c, const size_t *lo, const size_t *hi);
/* C (r x r) = A (r x k) B^T + D, symmetric by construction (upper triangle
 * formed, mirrored; D NULL for 0, may be C), B (r x k) zero outside its row
 * spans. */
void dkf__mul_nt_sym_spans(dkf_real_t *C, const dkf_real_t *A, const dkf_real_t *B,
                           const dkf_real_t *D, size_t r, size_t k, const size_t *lo,
                           const size_t *hi);
/* Out (p x r) = Lc^{-1} Y^T (forward substitution, inv from dkf__chol) for
 * Y (r x p) zero before column lo[i] in row i: each element's terms in
 * inl_chol_forward's order (l ascending), from its column's first nonzero. */
void dkf__whiten_spans(dkf_real_t *Out, const dkf_real_t *Y, const dkf_real_t *Lc,
                       const dkf_real_t *inv, size_t r, size_t p, const size_t *lo);
/* C (r x r) = A^T A for A (k x r), the upper triangle mirrored, each sum in
 * index order from the block's first row with a nonzero factor; lo (r
 * entries) is scratch. */
void dkf__tn_self_spans(dkf_real_t *C, const dkf_real_t *A, size_t r, size_t k, size_t *lo);

/* Cholesky factor of the n x n A into W (W may be A): the lower triangle
 * of W gets L with A = L L^T, its strict upper triangle zeros, and
 * inv[i] = 1 / L(i,i). Only the lower triangle of A is read. Returns 0,
 * or -1 as soon as a pivot is not in (0, REAL_MAX] (W is then partly
 * written). A non-finite input always ends in such a pivot. */
int dkf__chol(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n);
/* dkf__chol for large n, the same W and inv bit for bit: the finished
 * rows are also stored transposed in T (n x n scratch, overlapping none of
 * the others), so that two rows are summed against 8 (AVX: 16 double, 32
 * float) columns at a time along contiguous vectors. */
int dkf__chol_wide(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n, dkf_real_t *T);

/* The large-model kernels (dkf__chol_wide, dkf__whiten_spans,
 * dkf__tn_self_spans) come in two instances of one source
 * (kernels_wide.h): for the baseline ISA, and on x86-64 under GCC
 * (DKF__AVX) for AVX, taken when the CPU has it (dkf__isa_avx). AVX only
 * widens the register blocks (no FMA), so both return the same bits and
 * the library needs no -march: a baseline build runs on every x86-64, and
 * its results do not depend on the CPU (docs/decisions.md item 25).
 * The _isa forms take the choice as an argument (avx = 1 only where
 * dkf__isa_avx() is 1), for the tests that compare the two. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && DKF_SIMD && \
    defined(__SSE2_MATH__)
#define DKF__AVX 1
#else
#define DKF__AVX 0
#endif
int dkf__isa_avx(void);
int dkf__chol_wide_isa(int avx, dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n,
                       dkf_real_t *T);
void dkf__whiten_spans_isa(int avx, dkf_real_t *Out, const dkf_real_t *Y, const dkf_real_t *Lc,
                           const dkf_real_t *inv, size_t r, size_t p, const size_t *lo);
void dkf__tn_self_spans_isa(int avx, dkf_real_t *C, const dkf_real_t *A, size_t r, size_t k,
                            size_t *lo);
/* the instances (kernels.c, kernels_avx.c) */
int dkf__chol_wide_base(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n,
                        dkf_real_t *T);
void dkf__whiten_spans_base(dkf_real_t *Out, const dkf_real_t *Y, const dkf_real_t *Lc,
                            const dkf_real_t *inv, size_t r, size_t p, const size_t *lo);
void dkf__tn_self_spans_base(dkf_real_t *C, const dkf_real_t *A, size_t r, size_t k, size_t *lo);
#if DKF__AVX
int dkf__chol_wide_avx(dkf_real_t *W, dkf_real_t *inv, const dkf_real_t *A, size_t n,
                       dkf_real_t *T);
void dkf__whiten_spans_avx(dkf_real_t *Out, const dkf_real_t *Y, const dkf_real_t *Lc,
                           const dkf_real_t *inv, size_t r, size_t p, const size_t *lo);
void dkf__tn_self_spans_avx(dkf_real_t *C, const dkf_real_t *A, size_t r, size_t k, size_t *lo);
#endif
/* P A = L U in place of W (n x n, A on entry), partial pivoting:
 * perm[i] = the original row now at row i, L unit lower below the
 * diagonal, U on and above it; a row whose multiplier is 0 is left as it
 * is. The caller's singularity test: returns -1 (W part-way) at the first
 * column whose largest candidate pivot |u| is not above tol (NaN too) or,
 * with finite != 0, not finite; 0 otherwise. dkf_mat_lu: tol = n eps
 * max|A|, finite = 0; the Riccati solver's W_k: tol = 0, finite = 1. */
int dkf__lu_inplace(dkf_real_t *W, size_t *perm, size_t n, dkf_real_t tol, int finite);
/* Solves (L L^T) X = B in place for B n x c; inv from dkf__chol. */
void dkf__chol_solve(const dkf_real_t *L, const dkf_real_t *inv, dkf_real_t *B, size_t n,
                     size_t c);
/* Ainv = (L L^T)^{-1}, exactly symmetric. Ainv must not overlap L. */
void dkf__chol_inverse(dkf_real_t *Ainv, const dkf_real_t *L, const dkf_real_t *inv, size_t n);

#endif /* DKF_KERNELS_H */
