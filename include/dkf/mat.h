/*
 * dkf/mat.h - fixed-size matrix routines over caller-owned storage.
 *
 * A dkf_mat_t is a view: rows, cols and a pointer to rows*cols reals stored
 * row-major (element (i,j) at data[i*cols + j]). dkf never allocates; the
 * caller owns every buffer, usually declared with DKF_MAT_DECLARE. Vectors
 * are n x 1 matrices.
 *
 * Conventions (docs/reference/matrix.md has the full text):
 *  - Outputs come first, inputs after: dkf_mat_mul(C, A, B) is C = A B.
 *  - Every function validates before it writes. On any error the outputs
 *    are left exactly as they were. Routines that discover failure only
 *    part-way (factorisations) therefore compute in caller workspace `work`
 *    and copy to the outputs on success; the required number of reals is
 *    given by the matching DKF_MAT_*_WORK macro.
 *  - Aliasing: element-wise routines (copy, add, sub, scale, axpy,
 *    symmetrise) accept any output that is identical to an input. Products,
 *    transpose, congruence and block routines return DKF_ERR_ALIAS when an
 *    output overlaps an input or the workspace. Routines documented "may
 *    alias" accept output == input exactly (never a partial overlap).
 *  - Non-finite inputs give DKF_ERR_NONFINITE in every routine that
 *    factorises, inverts or decides a rank; the cheap element-wise and
 *    product routines do not scan their inputs (NaN propagates).
 *  - Dimensions must be in [1, DKF_MAX_DIM], else DKF_ERR_CAPACITY.
 */
#ifndef DKF_MAT_H
#define DKF_MAT_H

#include <stddef.h>

#include "dkf/config.h"
#include "dkf/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    size_t rows;
    size_t cols;
    dkf_real_t *data; /* rows*cols reals, row-major, owned by the caller */
} dkf_mat_t;

/* A view over existing storage: dkf_mat_t A = DKF_MAT(2, 3, buf); */
#define DKF_MAT(r, c, buf) {(r), (c), (buf)}

/* Declares exactly-sized storage `name_data` and a view `name` over it.
 * The first argument is the storage class of both, written once:
 * DKF_MAT_DECLARE(static, P, 4, 4); at file scope or in a function, or
 * DKF_MAT_DECLARE(, P, 4, 4); (empty) for automatic storage in a function.
 * (Not `extern`: the view has an initializer.) docs/layout.md. */
#define DKF_MAT_DECLARE(sc, name, r, c) \
    sc dkf_real_t name##_data[(r) * (c)]; \
    sc dkf_mat_t name = {(r), (c), name##_data}

/* Element access without checks. */
#define DKF_AT(m, i, j) ((m)->data[(i) * (m)->cols + (j)])

/* ---- workspace sizes (in reals) --------------------------------------- */
#define DKF_MAT_CONGRUENCE_WORK(r, c) ((r) * (c))
#define DKF_MAT_CHOL_WORK(n) ((n) * (n))
#define DKF_MAT_SPD_INV_WORK(n) ((n) * (n))
#define DKF_MAT_LU_WORK(n) ((n) * (n))
#define DKF_MAT_INV_WORK(n) (2 * (n) * (n))
#define DKF_MAT_QR_SOLVE_WORK(r, c) ((r) * (c) + (c))
/* SVD/pinv/rank/frd of an r x c matrix; k = min(r, c), q = max(r, c). */
#define DKF_MAT_SVD_WORK(r, c) \
    (((r) > (c) ? (r) : (c)) * ((r) < (c) ? (r) : (c)) + \
     ((r) < (c) ? (r) : (c)) * ((r) < (c) ? (r) : (c)) + \
     ((r) < (c) ? (r) : (c)))
#define DKF_MAT_PINV_WORK(r, c) DKF_MAT_SVD_WORK(r, c)
#define DKF_MAT_RANK_WORK(r, c) DKF_MAT_SVD_WORK(r, c)
#define DKF_MAT_FRD_WORK(r, c) DKF_MAT_SVD_WORK(r, c)

/* ---- views and elementary operations ----------------------------------- */

/* Points m at rows x cols reals in data. DKF_ERR_CAPACITY if a dimension
 * is 0 or above DKF_MAX_DIM. */
dkf_status_t dkf_mat_init(dkf_mat_t *m, size_t rows, size_t cols, dkf_real_t *data);

/* A = 0. */
dkf_status_t dkf_mat_zero(dkf_mat_t *A);
/* A = I (A square). */
dkf_status_t dkf_mat_identity(dkf_mat_t *A);
/* A = values, rows*cols reals row-major. */
dkf_status_t dkf_mat_set(dkf_mat_t *A, const dkf_real_t *values);
/* B = A (same shape). May alias. */
dkf_status_t dkf_mat_copy(dkf_mat_t *B, const dkf_mat_t *A);
/* B = A^T. No alias. */
dkf_status_t dkf_mat_transpose(dkf_mat_t *B, const dkf_mat_t *A);

/* C = A + B, C = A - B, B = s A, Y = Y + s X. May alias. */
dkf_status_t dkf_mat_add(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B);
dkf_status_t dkf_mat_sub(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B);
dkf_status_t dkf_mat_scale(dkf_mat_t *B, const dkf_mat_t *A, dkf_real_t s);
dkf_status_t dkf_mat_axpy(dkf_mat_t *Y, dkf_real_t s, const dkf_mat_t *X);

/* C = A B,  C = A B^T,  C = A^T B. No alias. */
dkf_status_t dkf_mat_mul(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B);
dkf_status_t dkf_mat_mul_abt(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B);
dkf_status_t dkf_mat_mul_atb(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *B);

/* C = A P A^T for symmetric P (only P's symmetry is exploited: the upper
 * triangle of C is computed and mirrored, so C is exactly symmetric).
 * A is r x c, P is c x c, C is r x r. work: DKF_MAT_CONGRUENCE_WORK(r, c).
 * No alias. */
dkf_status_t dkf_mat_congruence(dkf_mat_t *C, const dkf_mat_t *A, const dkf_mat_t *P,
                                dkf_real_t *work);

/* A = (A + A^T) / 2 in place (A square). */
dkf_status_t dkf_mat_symmetrise(dkf_mat_t *A);

/* B = the r x c block of A whose top-left element is A(r0, c0), where
 * r x c is B's shape. No alias. DKF_ERR_DIM if the block leaves A. */
dkf_status_t dkf_mat_get_block(dkf_mat_t *B, const dkf_mat_t *A, size_t r0, size_t c0);
/* The block of A at (r0, c0) with B's shape = B. No alias. */
dkf_status_t dkf_mat_set_block(dkf_mat_t *A, size_t r0, size_t c0, const dkf_mat_t *B);
/* D = blockdiag(blocks[0], ..., blocks[count-1]), zeros elsewhere. D must
 * be exactly (sum rows) x (sum cols). No alias. */
dkf_status_t dkf_mat_blkdiag(dkf_mat_t *D, const dkf_mat_t *const blocks[], size_t count);

/* DKF_OK if every element is finite, else DKF_ERR_NONFINITE. */
dkf_status_t dkf_mat_check_finite(const dkf_mat_t *A);

/* ---- symmetric positive definite --------------------------------------- */

/* Cholesky: A = L L^T, L lower triangular with positive diagonal, strict
 * upper triangle set to 0. Only the lower triangle of A is read.
 * DKF_ERR_NOT_SPD when a pivot is <= 0 or not finite (that includes
 * numerically semi-definite A). L may alias A. work: DKF_MAT_CHOL_WORK(n). */
dkf_status_t dkf_mat_chol(dkf_mat_t *L, const dkf_mat_t *A, dkf_real_t *work);
/* Solves (L L^T) X = B given the Cholesky factor L. X may alias B.
 * DKF_ERR_SINGULAR if a diagonal element of L is not positive. */
dkf_status_t dkf_mat_chol_solve(dkf_mat_t *X, const dkf_mat_t *L, const dkf_mat_t *B);
/* Ainv = (L L^T)^{-1}, exactly symmetric. No alias. */
dkf_status_t dkf_mat_chol_inverse(dkf_mat_t *Ainv, const dkf_mat_t *L);
/* Ainv = A^{-1} for SPD A (Cholesky route). May alias.
 * work: DKF_MAT_SPD_INV_WORK(n). */
dkf_status_t dkf_mat_spd_inverse(dkf_mat_t *Ainv, const dkf_mat_t *A, dkf_real_t *work);

/* ---- general square systems --------------------------------------------- */

/* LU with partial (row) pivoting: P A = L U, L unit lower and U upper
 * packed into LU, piv[i] = original row placed at row i. DKF_ERR_SINGULAR
 * if a pivot magnitude is <= n * eps * max|A|. LU may alias A.
 * piv has n entries. work: DKF_MAT_LU_WORK(n). */
dkf_status_t dkf_mat_lu(dkf_mat_t *LU, size_t *piv, const dkf_mat_t *A, dkf_real_t *work);
/* Solves A X = B from dkf_mat_lu's output. X may alias B. */
dkf_status_t dkf_mat_lu_solve(dkf_mat_t *X, const dkf_mat_t *LU, const size_t *piv,
                              const dkf_mat_t *B);
/* Ainv = A^{-1} by LU. May alias. piv: n entries of scratch.
 * work: DKF_MAT_INV_WORK(n). */
dkf_status_t dkf_mat_inverse(dkf_mat_t *Ainv, const dkf_mat_t *A, size_t *piv,
                             dkf_real_t *work);

/* ---- orthogonal factorisations ----------------------------------------- */

/* Householder QR of an r x c matrix, r >= c: A = Q R. Compact LAPACK-style
 * output: R on and above the diagonal of QR, the Householder vectors
 * (unit leading element implied) below it, scalars in tau (c entries).
 * QR may alias A. Never fails numerically. */
dkf_status_t dkf_mat_qr(dkf_mat_t *QR, dkf_real_t *tau, const dkf_mat_t *A);
/* Q (r x k, k = Q->cols in [c, r]: thin when k = c, full when k = r) from
 * dkf_mat_qr's output. No alias. */
dkf_status_t dkf_mat_qr_q(dkf_mat_t *Q, const dkf_mat_t *QR, const dkf_real_t *tau);
/* R (c x c upper triangular) from dkf_mat_qr's output. No alias. */
dkf_status_t dkf_mat_qr_r(dkf_mat_t *R, const dkf_mat_t *QR, const dkf_real_t *tau);
/* Least squares: X = argmin ||A X - B|| for r x c A of full column rank
 * (DKF_ERR_RANK otherwise, judged by |R_ii| <= c * eps * max|R_jj|).
 * X is c x k, B is r x k. No alias. work: DKF_MAT_QR_SOLVE_WORK(r, c). */
dkf_status_t dkf_mat_qr_solve(dkf_mat_t *X, const dkf_mat_t *A, const dkf_mat_t *B,
                              dkf_real_t *work);

/* ---- singular values, pseudo-inverse, rank ----------------------------- */

/* Default rank tolerance: pass tol < 0 to any routine below to use
 *   tol = max(r, c) * eps * sigma_max
 * (the LAPACK/NumPy convention); a singular value counts iff it is > tol. */
#define DKF_RANK_TOL_DEFAULT (DKF_R(-1.0))

/* Thin SVD A = U diag(s) V^T by one-sided Jacobi; k = min(r, c):
 * U r x k with orthonormal columns, s k values in descending order,
 * V c x k with orthonormal columns. U or V may be NULL if not wanted.
 * DKF_ERR_NO_CONVERGENCE after DKF_SVD_MAX_SWEEPS sweeps.
 * No alias. work: DKF_MAT_SVD_WORK(r, c). */
dkf_status_t dkf_mat_svd(dkf_mat_t *U, dkf_real_t *s, dkf_mat_t *V, const dkf_mat_t *A,
                         dkf_real_t *work);
/* Moore-Penrose pseudo-inverse X (c x r) of A (r x c); singular values
 * <= tol are treated as zero. rank (may be NULL) receives the numerical
 * rank. No alias. work: DKF_MAT_PINV_WORK(r, c). */
dkf_status_t dkf_mat_pinv(dkf_mat_t *X, size_t *rank, const dkf_mat_t *A, dkf_real_t tol,
                          dkf_real_t *work);
/* Numerical rank of A. work: DKF_MAT_RANK_WORK(r, c). */
dkf_status_t dkf_mat_rank(size_t *rank, const dkf_mat_t *A, dkf_real_t tol, dkf_real_t *work);

/* Full-rank decomposition (seed 004): A (r x c) = Abar T with
 * Abar r x rank of full column rank and T rank x c of full row rank.
 * Computed from the SVD A = U S V^T as Abar = U_k S_k, T = V_k^T, so T has
 * orthonormal rows and T^+ = T^T (docs/reference/matrix.md says why this route).
 * Abar and T must have at least `rank` columns / rows of storage: their
 * views are resized (Abar->cols = T->rows = rank) on success. Rank 0 gives
 * DKF_ERR_RANK. No alias. work: DKF_MAT_FRD_WORK(r, c). */
dkf_status_t dkf_mat_frd(dkf_mat_t *Abar, dkf_mat_t *T, size_t *rank, const dkf_mat_t *A,
                         dkf_real_t tol, dkf_real_t *work);

#ifdef __cplusplus
}
#endif

#endif /* DKF_MAT_H */
