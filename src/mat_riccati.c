/*
 * Steady-state equations of the matrix core (dkf/mat_riccati.h): the
 * filtering DARE by the structure-preserving doubling algorithm (SDA) and
 * the Stein equation by Smith doubling. docs/reference/matrix.md, "Riccati and Stein
 * equations", gives the methods, the stopping rule, the certificate and
 * the measured iteration counts.
 *
 * References (the iterations are written out here, so no equation number
 * of theirs is needed to read the code):
 *  - SDA: E. K.-W. Chu, H.-Y. Fan, W.-W. Lin, C.-S. Wang, "Structure-
 *    preserving algorithms for periodic discrete-time algebraic Riccati
 *    equations", Int. J. Control 77 (2004); convergence: W.-W. Lin,
 *    S.-F. Xu, SIAM J. Matrix Anal. Appl. 28 (2006) 26-39.
 *  - Smith doubling: R. A. Smith, "Matrix equation XA + BX = C", SIAM J.
 *    Appl. Math. 16 (1968) 198-201.
 *
 * Symbols. The filtering DARE
 *   X = F X F^T - F X H^T (H X H^T + R)^{-1} H X F^T + Q           (D1)
 * is the control DARE of the dual pair (F^T, H^T). SDA on it keeps three
 * n x n iterates (A_k, G_k, H_k; H_k is "Hk" here, not the measurement H):
 *   A_0 = F^T,  G_0 = H^T R^{-1} H,  H_0 = Q,                       (S0)
 *   W_k = I + G_k H_k,                                               (S1)
 *   A_{k+1} = A_k W_k^{-1} A_k,                                      (S2)
 *   G_{k+1} = G_k + A_k W_k^{-1} G_k A_k^T,                          (S3)
 *   H_{k+1} = H_k + A_k^T H_k W_k^{-1} A_k,                          (S4)
 * with H_k -> X and A_k -> 0 quadratically when (F, H) is detectable and
 * (F, Q^{1/2}) has no unreachable mode on the unit circle. G_k, H_k are
 * symmetric PSD: W_k^{-1} G_k = G_k (I + H_k G_k)^{-1} and
 * H_k W_k^{-1} = (I + H_k G_k)^{-1} H_k are symmetric, so (S3), (S4) are
 * formed as symmetric products (upper triangle computed and mirrored).
 * After convergence the closed loop Phi = F (I - K H),
 * K = X H^T (H X H^T + R)^{-1}, is certified stable by repeated squaring:
 * ||Phi^(2^j)||_1 <= 1/2 for some j proves rho(Phi) <= 2^(-1/2^j) < 1.
 *
 * The Stein equation X = A X B^T + C (A r x r, B c x c) by
 *   X_0 = C, X_{k+1} = X_k + A_k X_k B_k^T, A_{k+1} = A_k^2,
 *   B_{k+1} = B_k^2,                                                 (M1)
 * so X_k = sum_{j < 2^k} A^j C (B^T)^j; ||A_k||_1 ||B_k||_1 <= 1/2 at
 * some k certifies rho(A) rho(B) < 1.
 */
#include <string.h>

#include "dkf/mat_riccati.h"
#include "internal.h"
#include "kernels.h"

/* Relative stopping tolerance: ||Y_{k+1} - Y_k||_1 <= STOP_TOL(n) ||Y_{k+1}||_1.
 * The increment of (S4) / (M1) is a product that goes to 0 with A_k, not
 * a difference of nearly equal numbers, so it falls below the rounding
 * level of the iterate itself (one ulp per element is <= eps ||Y||_1 in
 * the 1-norm); n eps leaves a factor n over that floor in float and double,
 * and quadratic convergence reaches it one or two steps after it is within
 * sqrt(eps). */
#define STOP_TOL(n) ((dkf_real_t)(n) * DKF_REAL_EPSILON)
/* ||M^(2^j)||_1 at or below this certifies rho(M) < 1 with margin. */
#define CONTRACT DKF_R(0.5)

/* max column sum |.| of the r x c row-major A (the induced 1-norm, so
 * rho(A) <= ||A||_1); NaN if any element is NaN. */
static dkf_real_t norm1(const dkf_real_t *A, size_t r, size_t c)
{
    dkf_real_t best = DKF_R(0.0);
    size_t i, j;
    for (j = 0; j < c; ++j) {
        dkf_real_t s = DKF_R(0.0);
        for (i = 0; i < r; ++i) s += DKF_FABS(A[i * c + j]);
        if (!(s <= best)) best = s; /* also takes a NaN */
    }
    return best;
}

/* ||A - B||_1 for r x c A, B. */
static dkf_real_t diff_norm1(const dkf_real_t *A, const dkf_real_t *B, size_t r, size_t c)
{
    dkf_real_t best = DKF_R(0.0);
    size_t i, j;
    for (j = 0; j < c; ++j) {
        dkf_real_t s = DKF_R(0.0);
        for (i = 0; i < r; ++i) s += DKF_FABS(A[i * c + j] - B[i * c + j]);
        if (!(s <= best)) best = s;
    }
    return best;
}

/* 1 if the finite n x n A is symmetric within rounding:
 * |A(i,j) - A(j,i)| <= 4 n eps max|A| (the tolerance of
 * dkf__psd_within_rounding, with max|A| for tr(A)). */
static int sym_within_rounding(const dkf_real_t *A, size_t n)
{
    dkf_real_t amax = DKF_R(0.0), tol;
    size_t i, j;
    for (i = 0; i < n * n; ++i)
        if (DKF_FABS(A[i]) > amax) amax = DKF_FABS(A[i]);
    tol = DKF_R(4.0) * (dkf_real_t)n * DKF_REAL_EPSILON * amax;
    for (i = 0; i < n; ++i)
        for (j = i + 1; j < n; ++j)
            if (!(DKF_FABS(A[i * n + j] - A[j * n + i]) <= tol)) return 0;
    return 1;
}

/* The certificate window: the largest j with 2^j n eps < 1. A contraction
 * ||M^(2^j)|| <= 1/2 proves rho(M) <= 2^(-2^-j), i.e. 1 - rho(M) >~
 * 0.69 / 2^j; a j beyond this window would certify 1 - rho(M) below
 * ~n eps, which the rounding of M's own entries (and of the products
 * that square it) can create or remove: such an M is on the unit circle
 * within rounding, and its equation has no reliable solution (its
 * condition number is ~1 / (1 - rho^2) >~ 1 / (n eps)). */
static size_t cert_window(size_t n)
{
    dkf_real_t t = (dkf_real_t)n * DKF_REAL_EPSILON;
    size_t j = 0;
    while (t * DKF_R(2.0) < DKF_R(1.0) && j < DKF_MAT_DOUBLING_MAX_ITER) {
        t *= DKF_R(2.0);
        ++j;
    }
    return j;
}

/* P = M (n x n), then P <- P^2 until ||P||_1 <= CONTRACT (returns 1: M is
 * a contraction, rho(M) < 1) or cert_window(n) squarings or an overflow
 * (returns 0). P, T: n^2 reals each, distinct from M. */
static int certify_contraction(dkf_real_t *P, dkf_real_t *T, const dkf_real_t *M, size_t n)
{
    const size_t jmax = cert_window(n);
    size_t j;
    memcpy(P, M, n * n * sizeof *P);
    for (j = 0; j <= jmax; ++j) {
        const dkf_real_t nrm = norm1(P, n, n);
        dkf_real_t *s;
        if (nrm <= CONTRACT) return 1;
        if (!(nrm <= DKF_REAL_MAX)) return 0; /* overflow or NaN: rho(M) > 1 */
        dkf__mul_nn(T, P, P, n, n, n);
        s = P;
        P = T;
        T = s;
    }
    return 0;
}

/* Status of an iteration that broke down (a non-finite iterate or a
 * singular W_k) or hit the iteration limit: the doubled closed loop A_k
 * that is not contracting (||A_k||_1 >= 1, or not finite) means the
 * series diverges (DKF_ERR_UNSTABLE); otherwise it was an overflow
 * (breakdown: DKF_ERR_NONFINITE) or slow convergence (the limit:
 * DKF_ERR_NO_CONVERGENCE). */
static dkf_status_t failure(dkf_real_t anorm, int limit)
{
    if (!(anorm < DKF_R(1.0))) return DKF_ERR_UNSTABLE;
    return limit ? DKF_ERR_NO_CONVERGENCE : DKF_ERR_NONFINITE;
}

/* Y = W^{-1} B for B n x n from dkf__lu_inplace's factors, column by column
 * through the contiguous t. Y must not overlap LU or B. */
static void lu_solve_nn(dkf_real_t *Y, const dkf_real_t *LU, const size_t *perm,
                        const dkf_real_t *B, size_t n)
{
    dkf_real_t t[DKF_MAX_DIM];
    size_t i, j, c;
    for (c = 0; c < n; ++c) {
        for (i = 0; i < n; ++i) t[i] = B[perm[i] * n + c];
        for (i = 1; i < n; ++i) t[i] -= dkf__dot(LU + i * n, t, i);
        for (i = n; i-- > 0;) {
            const dkf_real_t *ri = LU + i * n;
            dkf_real_t s = t[i];
            for (j = i + 1; j < n; ++j) s -= ri[j] * t[j];
            t[i] = s / ri[i];
        }
        for (i = 0; i < n; ++i) Y[i * n + c] = t[i];
    }
}

static void swap_ptr(dkf_real_t **a, dkf_real_t **b)
{
    dkf_real_t *t = *a;
    *a = *b;
    *b = t;
}

/* ---- DARE ---------------------------------------------------------------- */

/* Work layout of dkf_mat_dare (DKF_MAT_DARE_WORK(n, m) reals):
 *   A, G, Hk   n*n each  the SDA iterates A_k, G_k, H_k (S0)-(S4)
 *   Wb         n*n       W_k and its LU factors; the next G_k / H_k
 *   Lw         n*n       products Y2 A^T, H_k Y1; the next A_k
 *   Y1, Y2     n*n each  W_k^{-1} A_k, W_k^{-1} G_k; A_k^T
 *   Rl         m*m       Cholesky factor of R (for G_0)
 *   Sm         m*m       S = H X H^T + R and its factor (certificate)
 *   Mb, Kb     m*n each  whitened H (L^{-1} H); H X and K^T = S^{-1} H X
 */
dkf_status_t dkf_mat_dare(dkf_mat_t *X, const dkf_mat_t *F, const dkf_mat_t *H,
                          const dkf_mat_t *Q, const dkf_mat_t *R, dkf_real_t *work)
{
    dkf_real_t inv[DKF_MAX_DIM], zero[DKF_MAX_DIM], wv[DKF_MAX_DIM];
    size_t piv[DKF_MAX_DIM];
    dkf_real_t *A, *G, *Hk, *Wb, *Lw, *Y1, *Y2, *Rl, *Sm, *Mb, *Kb;
    dkf_real_t anorm = DKF_R(0.0);
    size_t n, m, nn, len, i, j, k;
    int converged = 0;
    DKF_TRY(dkf__check_mat(X));
    DKF_TRY(dkf__check_mat(F));
    DKF_TRY(dkf__check_mat(H));
    DKF_TRY(dkf__check_mat(Q));
    DKF_TRY(dkf__check_mat(R));
    n = F->rows;
    m = H->rows;
    if (F->cols != n || H->cols != n) return DKF_ERR_DIM;
    DKF_TRY(dkf__check_shape(Q, n, n));
    DKF_TRY(dkf__check_shape(R, m, m));
    DKF_TRY(dkf__check_shape(X, n, n));
    DKF_CHECK_NULL(work);
    nn = n * n;
    len = (size_t)DKF_MAT_DARE_WORK(n, m);
    DKF_CHECK_NO_ALIAS(X, F);
    DKF_CHECK_NO_ALIAS(X, H);
    DKF_CHECK_NO_ALIAS(X, Q);
    DKF_CHECK_NO_ALIAS(X, R);
    DKF_CHECK_NO_ALIAS_BUF(X, work, len);
    DKF_CHECK_NO_ALIAS_BUF(F, work, len);
    DKF_CHECK_NO_ALIAS_BUF(H, work, len);
    DKF_CHECK_NO_ALIAS_BUF(Q, work, len);
    DKF_CHECK_NO_ALIAS_BUF(R, work, len);
    (void)len; /* read only by the alias checks (DKF_DEBUG_CHECKS) */
    if (!dkf__all_finite(F->data, nn) || !dkf__all_finite(H->data, m * n) ||
        !dkf__all_finite(Q->data, nn) || !dkf__all_finite(R->data, m * m))
        return DKF_ERR_NONFINITE;

    A = work;
    G = A + nn;
    Hk = G + nn;
    Wb = Hk + nn;
    Lw = Wb + nn;
    Y1 = Lw + nn;
    Y2 = Y1 + nn;
    Rl = Y2 + nn;
    Sm = Rl + m * m;
    Mb = Sm + m * m;
    Kb = Mb + m * n;

    /* R SPD: symmetric within rounding and a Cholesky factor R = L L^T */
    if (!sym_within_rounding(R->data, m) || dkf__chol(Rl, inv, R->data, m) != 0)
        return DKF_ERR_NOT_SPD;
    /* G_0 = H^T R^{-1} H = (L^{-1} H)^T (L^{-1} H): a Gram matrix, exactly
     * symmetric (S0) */
    for (i = 0; i < m; ++i) zero[i] = DKF_R(0.0);
    dkf__whiten(Mb, wv, Rl, inv, H->data, zero, m, n);
    dkf__mul_tn(G, Mb, Mb, NULL, m, n, n);
    /* H_0 = (Q + Q^T) / 2 for Q symmetric PSD within rounding (S0) */
    if (!sym_within_rounding(Q->data, n)) return DKF_ERR_NOT_SPD;
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j)
            Hk[i * n + j] = DKF_R(0.5) * (Q->data[i * n + j] + Q->data[j * n + i]);
    if (!dkf__psd_within_rounding(Wb, Hk, n)) return DKF_ERR_NOT_SPD;
    /* A_0 = F^T (S0) */
    dkf__transpose(A, F->data, n, n);

    for (k = 0; k < DKF_MAT_DOUBLING_MAX_ITER && !converged; ++k) {
        dkf_real_t dn, hn;
        anorm = norm1(A, n, n);
        /* (S1) W_k = I + G_k H_k, LU-factored in place. W_k is nonsingular
         * in exact arithmetic (G_k H_k is similar to the PSD
         * H_k^{1/2} G_k H_k^{1/2}, so every eigenvalue of W_k is >= 1), but
         * its entries can be ~||G_k|| ||H_k|| >> 1 (R tiny), so dkf_mat_lu's
         * relative test (pivot <= n eps max|W|) would refuse unit pivots
         * that are exact: only a zero or non-finite pivot fails here. */
        dkf__mul_nn(Wb, G, Hk, n, n, n);
        for (i = 0; i < n; ++i) Wb[i * n + i] += DKF_R(1.0);
        if (dkf__lu_inplace(Wb, piv, n, DKF_R(0.0), 1) != 0) return failure(anorm, 0);
        /* Y1 = W_k^{-1} A_k, Y2 = W_k^{-1} G_k */
        lu_solve_nn(Y1, Wb, piv, A, n);
        lu_solve_nn(Y2, Wb, piv, G, n);
        /* (S3) G_{k+1} = G_k + A_k (Y2 A_k^T), symmetric */
        dkf__mul_nt(Lw, Y2, A, n, n, n);
        dkf__mul_nn_sym(Wb, A, Lw, G, n, n);
        swap_ptr(&G, &Wb);
        /* (S4) H_{k+1} = H_k + A_k^T (H_k Y1), symmetric */
        dkf__mul_nn(Lw, Hk, Y1, n, n, n);
        dkf__transpose(Y2, A, n, n);
        dkf__mul_nn_sym(Wb, Y2, Lw, Hk, n, n);
        dn = diff_norm1(Wb, Hk, n, n);
        hn = norm1(Wb, n, n);
        swap_ptr(&Hk, &Wb);
        /* (S2) A_{k+1} = A_k Y1 */
        dkf__mul_nn(Lw, A, Y1, n, n, n);
        swap_ptr(&A, &Lw);
        if (!dkf__all_finite(Hk, nn) || !dkf__all_finite(G, nn) || !dkf__all_finite(A, nn))
            return failure(anorm, 0);
        converged = dn <= STOP_TOL(n) * hn;
    }
    if (!converged) return failure(norm1(A, n, n), 1);

    /* Certificate: Phi = F (I - K H) with K^T = S^{-1} H X,
     * S = H X H^T + R, must be a contraction. */
    dkf__mul_nn(Mb, H->data, Hk, m, n, n);             /* H X */
    dkf__mul_nt_sym(Sm, Mb, H->data, R->data, m, n);   /* S = (H X) H^T + R */
    if (dkf__chol(Sm, inv, Sm, m) != 0) return DKF_ERR_UNSTABLE;
    memcpy(Kb, Mb, m * n * sizeof *Kb);
    dkf__chol_solve(Sm, inv, Kb, m, n);                /* K^T = S^{-1} H X */
    for (i = 0; i < nn; ++i) Y2[i] = DKF_R(0.0);
    for (i = 0; i < n; ++i) Y2[i * n + i] = DKF_R(1.0);
    dkf__sub_tn(Y1, Y2, Kb, H->data, m, n, n);         /* I - K H */
    dkf__mul_nn(Y2, F->data, Y1, n, n, n);             /* Phi */
    if (!dkf__all_finite(Y2, nn) || !certify_contraction(A, G, Y2, n)) return DKF_ERR_UNSTABLE;
    /* X symmetric (by construction) and PSD within rounding */
    if (!dkf__psd_within_rounding(Wb, Hk, n)) return DKF_ERR_UNSTABLE;

    memcpy(X->data, Hk, nn * sizeof *Hk);
    work[0] = (dkf_real_t)k; /* doubling steps taken (documented in the header) */
    return DKF_OK;
}

/* Scales A_k by 2^-e and B_k by 2^e (r x r, c x c) with e the half
 * difference of the binary exponents of their norms an, bn (updated):
 * the terms A_k^j X (B_k^T)^j of (M1) are unchanged (exactly: powers of
 * two), and both factors shrink together, so neither overflows while
 * the other underflows when rho(A) > 1 > rho(B) with rho(A) rho(B) < 1.
 * |e| <= 60 per step keeps 2^e finite in float. */
static void balance(dkf_real_t *A, dkf_real_t *B, dkf_real_t *an, dkf_real_t *bn, size_t r,
                    size_t c)
{
    int ea, eb, e;
    dkf_real_t sa, sb;
    size_t i;
    if (!(*an > DKF_R(0.0) && *bn > DKF_R(0.0) && *an <= DKF_REAL_MAX && *bn <= DKF_REAL_MAX))
        return;
    (void)frexp((double)*an, &ea);
    (void)frexp((double)*bn, &eb);
    e = (ea - eb) / 2;
    if (e > 60) e = 60;
    if (e < -60) e = -60;
    if (e == 0) return;
    sa = (dkf_real_t)ldexp(1.0, -e);
    sb = (dkf_real_t)ldexp(1.0, e);
    for (i = 0; i < r * r; ++i) A[i] *= sa;
    for (i = 0; i < c * c; ++i) B[i] *= sb;
    *an *= sa;
    *bn *= sb;
}

/* ---- Stein ----------------------------------------------------------------- */

/* Work layout of dkf_mat_stein (DKF_MAT_STEIN_WORK(r, c) reals):
 *   Ak, An  r*r each  A_k and A_k^2
 *   Bk, Bn  c*c each  B_k and B_k^2
 *   Xk, Xn  r*c each  X_k and X_{k+1}
 *   T       r*c       A_k X_k
 */
dkf_status_t dkf_mat_stein(dkf_mat_t *X, const dkf_mat_t *A, const dkf_mat_t *B,
                           const dkf_mat_t *C, dkf_real_t *work)
{
    dkf_real_t *Ak, *An, *Bk, *Bn, *Xk, *Xn, *T;
    size_t r, c, rc, len, i, j, k, kwin;
    int certified = 0, converged = 0, lyap;
    DKF_TRY(dkf__check_mat(X));
    DKF_TRY(dkf__check_mat(A));
    DKF_TRY(dkf__check_mat(B));
    DKF_TRY(dkf__check_mat(C));
    r = A->rows;
    c = B->rows;
    if (A->cols != r || B->cols != c) return DKF_ERR_DIM;
    DKF_TRY(dkf__check_shape(C, r, c));
    DKF_TRY(dkf__check_shape(X, r, c));
    DKF_CHECK_NULL(work);
    rc = r * c;
    len = (size_t)DKF_MAT_STEIN_WORK(r, c);
    DKF_CHECK_NO_ALIAS(X, A);
    DKF_CHECK_NO_ALIAS(X, B);
    DKF_CHECK_NO_ALIAS(X, C);
    DKF_CHECK_NO_ALIAS_BUF(X, work, len);
    DKF_CHECK_NO_ALIAS_BUF(A, work, len);
    DKF_CHECK_NO_ALIAS_BUF(B, work, len);
    DKF_CHECK_NO_ALIAS_BUF(C, work, len);
    (void)len; /* read only by the alias checks (DKF_DEBUG_CHECKS) */
    if (!dkf__all_finite(A->data, r * r) || !dkf__all_finite(B->data, c * c) ||
        !dkf__all_finite(C->data, rc))
        return DKF_ERR_NONFINITE;

    Ak = work;
    An = Ak + r * r;
    Bk = An + r * r;
    Bn = Bk + c * c;
    Xk = Bn + c * c;
    Xn = Xk + rc;
    T = Xn + rc;

    /* The Lyapunov case (A = B, C exactly symmetric): X_k stays exactly
     * symmetric when the increment is formed as a symmetric product. */
    kwin = cert_window(r > c ? r : c);
    lyap = r == c && memcmp(A->data, B->data, r * r * sizeof *Ak) == 0;
    for (i = 0; lyap && i < r; ++i)
        for (j = i + 1; j < r; ++j)
            if (C->data[i * r + j] != C->data[j * r + i]) lyap = 0;

    memcpy(Ak, A->data, r * r * sizeof *Ak);
    memcpy(Bk, B->data, c * c * sizeof *Bk);
    memcpy(Xk, C->data, rc * sizeof *Xk); /* X_0 = C (M1) */
    for (k = 0; k < DKF_MAT_DOUBLING_MAX_ITER; ++k) {
        dkf_real_t an = norm1(Ak, r, r), bn = norm1(Bk, c, c);
        dkf_real_t dn, xn;
        balance(Ak, Bk, &an, &bn, r, c);
        /* ||A_k|| ||B_k|| <= 1/2 proves rho(A)^(2^k) rho(B)^(2^k) < 1,
         * inside the window of cert_window (else on the unit circle) */
        if (!certified && k > kwin) return DKF_ERR_UNSTABLE;
        if (an * bn <= CONTRACT) certified = 1;
        /* (M1) X_{k+1} = X_k + (A_k X_k) B_k^T */
        dkf__mul_nn(T, Ak, Xk, r, r, c);
        if (lyap) {
            dkf__mul_nt_sym(Xn, T, Bk, Xk, r, r);
        } else {
            dkf__mul_nt(Xn, T, Bk, r, c, c);
            for (i = 0; i < rc; ++i) Xn[i] += Xk[i];
        }
        dn = diff_norm1(Xn, Xk, r, c);
        xn = norm1(Xn, r, c);
        swap_ptr(&Xk, &Xn);
        if (!dkf__all_finite(Xk, rc)) return certified ? DKF_ERR_NONFINITE : DKF_ERR_UNSTABLE;
        converged = dn <= STOP_TOL(r > c ? r : c) * xn;
        if (converged && certified) break;
        /* (M1) A_{k+1} = A_k^2, B_{k+1} = B_k^2 */
        dkf__mul_nn(An, Ak, Ak, r, r, r);
        dkf__mul_nn(Bn, Bk, Bk, c, c, c);
        swap_ptr(&Ak, &An);
        swap_ptr(&Bk, &Bn);
        if (!dkf__all_finite(Ak, r * r) || !dkf__all_finite(Bk, c * c)) {
            if (!certified) return DKF_ERR_UNSTABLE;
            if (!converged) return DKF_ERR_NONFINITE;
            /* converged and certified cannot reach here (break above) */
        }
    }
    if (!(converged && certified)) return certified ? DKF_ERR_NO_CONVERGENCE : DKF_ERR_UNSTABLE;

    memcpy(X->data, Xk, rc * sizeof *Xk);
    work[0] = (dkf_real_t)(k + 1); /* doubling steps taken (documented in the header) */
    return DKF_OK;
}
