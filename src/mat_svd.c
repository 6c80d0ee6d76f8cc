/*
 * Thin SVD by one-sided (Hestenes) Jacobi, and the routines built on it:
 * pseudo-inverse, numerical rank, full-rank decomposition.
 *
 * Let G be A (r >= c) or A^T (r < c), so G is m x n with m >= n. Plane
 * rotations J applied from the right, G <- G J and V <- V J (V = I at
 * first), orthogonalise G's columns while keeping G = A' V. Once every
 * pair is orthogonal, G = U diag(s) with s_j = ||g_j||, u_j = g_j / s_j,
 * so A' = U diag(s) V^T. For A' = A^T the roles of U and V swap.
 *
 * The computed factors are backward stable (U S V^T = A + E with
 * ||E|| = O(m eps ||A||)), and for A = B D with B well conditioned the
 * singular values even have small relative errors (Demmel & Veselic
 * 1992). Zero singular values of rank-deficient matrices come out at the
 * level eps ||A||, which the rank tolerance max(r, c) eps sigma_max is
 * designed to catch.
 *
 * Workspace layout (DKF_MAT_SVD_WORK(r, c) reals, k = n = min(r, c)):
 *   g  : m*n  G's columns, column j contiguous at g + j*m
 *   v  : n*n  the rotation accumulator, column j at v + j*n
 *   sv : n    unsorted singular values (squared column norms for the
 *             pivoting while the sweeps run)
 */
#include "internal.h"

typedef struct {
    size_t r, c;     /* shape of A */
    size_t m, n;     /* shape of G, m >= n */
    int transposed;  /* G = A^T */
    dkf_real_t *g;   /* n columns of length m */
    dkf_real_t *v;   /* n columns of length n */
    dkf_real_t *sv;  /* n singular values, unsorted */
    /* Columns of A's factors: U's column j (length r) at ubase + j*r, V's
     * column j (length c) at vbase + j*c, in unsorted order. */
    dkf_real_t *ubase;
    dkf_real_t *vbase;
    size_t perm[DKF_MAX_DIM]; /* perm[0..n-1]: indices by descending sv */
} svd_t;

/* What the caller needs beyond the singular values. */
enum {
    SVD_DIRS = 1,     /* g normalised to unit columns (s_j > 0 only) */
    SVD_COMPLETE = 2, /* zero columns of g replaced by an orthonormal completion */
    SVD_ACCUM = 4     /* the rotations accumulated in v */
};

static dkf_real_t dot(const dkf_real_t *x, const dkf_real_t *y, size_t n)
{
    dkf_real_t acc = DKF_R(0.0);
    size_t i;
    for (i = 0; i < n; ++i) acc += x[i] * y[i];
    return acc;
}

/* Loads G (A or A^T) scaled by 1/max|A|, so that the squared column norms
 * below can neither overflow nor (for columns that matter) underflow.
 * Division rather than multiplication by the reciprocal: 1/max|A| may
 * overflow when max|A| is subnormal. Returns max|A|. */
static dkf_real_t load_scaled(svd_t *S, const dkf_mat_t *A)
{
    size_t i, j, len = S->m * S->n;
    dkf_real_t amax = DKF_R(0.0);
    for (i = 0; i < len; ++i)
        if (DKF_FABS(A->data[i]) > amax) amax = DKF_FABS(A->data[i]);
    /* column j of G: column j of A, or row j of A when transposed */
    for (j = 0; j < S->n; ++j)
        for (i = 0; i < S->m; ++i)
            S->g[j * S->m + i] = S->transposed ? A->data[j * S->c + i] : A->data[i * S->c + j];
    if (amax > DKF_R(0.0))
        for (i = 0; i < len; ++i) S->g[i] /= amax;
    return amax;
}

/* A column whose squared norm is below the normal range holds entries
 * below ~1e-154 (double) / 1e-19 (float) times max|A|: its singular value
 * is far below eps sigma_max, so it is treated as exactly zero and kept
 * out of the rotations, whose arithmetic on subnormals would be noise. */
static int negligible(dkf_real_t sq_norm) { return sq_norm < DKF_REAL_MIN; }

/* x <- c x - s y, y <- s x + c y over n entries. */
static void rotate(dkf_real_t *x, dkf_real_t *y, size_t n, dkf_real_t cs, dkf_real_t sn)
{
    size_t i;
    for (i = 0; i < n; ++i) {
        dkf_real_t a = x[i], b = y[i];
        x[i] = cs * a - sn * b;
        y[i] = sn * a + cs * b;
    }
}

/* Exchanges columns i and j of an n-column array with columns of length len. */
static void swap_columns(dkf_real_t *x, size_t len, size_t i, size_t j)
{
    size_t l;
    for (l = 0; l < len; ++l) {
        dkf_real_t t = x[i * len + l];
        x[i * len + l] = x[j * len + l];
        x[j * len + l] = t;
    }
}

/* de Rijk's pivoting (SIAM J. Sci. Stat. Comput. 10, 1989): before column
 * p is paired with the ones after it, the remaining column of largest norm
 * is moved to p. With the cyclic order alone, 48 x 48 matrices of
 * condition 1e15 or of low rank needed up to 25 sweeps; with it <= 13.
 * sq holds squared column norms, exact or (after rotations) updated by
 * the rotation formula: good enough to choose a pivot, never used for a
 * decision about convergence. */
static void pivot_largest(svd_t *S, dkf_real_t *sq, size_t p, int accumulate)
{
    size_t j, best = p;
    dkf_real_t t;
    for (j = p + 1; j < S->n; ++j)
        if (sq[j] > sq[best]) best = j;
    if (best == p) return;
    swap_columns(S->g, S->m, p, best);
    if (accumulate) swap_columns(S->v, S->n, p, best);
    t = sq[p];
    sq[p] = sq[best];
    sq[best] = t;
}

/* One sweep over all column pairs; returns the number of rotations. Every
 * pair is examined once per sweep (pivoting only permutes columns not yet
 * visited), so a sweep without rotations means all pairs are orthogonal.
 *
 * Pair (p, q) is taken as orthogonal when |g_p.g_q| <= m eps ||g_p|| ||g_q||:
 * the computed dot product of two m-vectors carries an error up to
 * m eps ||g_p|| ||g_q|| (Higham, ASNA eq. 3.5), so a tighter threshold
 * could not be certified and might cycle. The rotation zeroes the pair's
 * inner product (Golub & Van Loan, alg. 8.6.1, sym.schur2):
 *   zeta = (beta - alpha) / (2 gamma), t = sign(zeta)/(|zeta| + sqrt(1+zeta^2)),
 *   c = 1/sqrt(1 + t^2), s = c t,
 * with the hypot form keeping zeta^2 from overflowing; the squared norms
 * become alpha - t gamma and beta + t gamma. */
static size_t jacobi_sweep(svd_t *S, dkf_real_t *sq, int accumulate)
{
    const dkf_real_t tol = (dkf_real_t)S->m * DKF_REAL_EPSILON;
    size_t p, q, rotations = 0;
    for (p = 0; p + 1 < S->n; ++p) {
        dkf_real_t *gp = S->g + p * S->m;
        pivot_largest(S, sq, p, accumulate);
        for (q = p + 1; q < S->n; ++q) {
            dkf_real_t *gq = S->g + q * S->m;
            dkf_real_t alpha = dot(gp, gp, S->m), beta = dot(gq, gq, S->m);
            dkf_real_t gamma, zeta, t, cs, sn;
            sq[p] = alpha;
            sq[q] = beta;
            if (negligible(alpha) || negligible(beta)) continue;
            gamma = dot(gp, gq, S->m);
            if (DKF_FABS(gamma) <= tol * DKF_SQRT(alpha) * DKF_SQRT(beta)) continue;
            zeta = (beta - alpha) / (DKF_R(2.0) * gamma);
            t = DKF_R(1.0) / (DKF_FABS(zeta) + DKF_HYPOT(DKF_R(1.0), zeta));
            if (zeta < DKF_R(0.0)) t = -t;
            cs = DKF_R(1.0) / DKF_SQRT(DKF_R(1.0) + t * t);
            sn = cs * t;
            /* a rotation that rounds to the identity changes nothing and
             * must not keep the sweep loop alive */
            if (sn == DKF_R(0.0)) continue;
            rotate(gp, gq, S->m, cs, sn);
            if (accumulate) rotate(S->v + p * S->n, S->v + q * S->n, S->n, cs, sn);
            sq[p] = alpha - t * gamma;
            sq[q] = beta + t * gamma;
            ++rotations;
        }
    }
    return rotations;
}

/* Replaces column j of g (a zero singular value) with a unit vector
 * orthogonal to the columns flagged in `done` (orthonormal already).
 * The seed is the e_i with the largest residual 1 - sum_w w_i^2, which is
 * >= 1 - (n-1)/m >= 1/m, so the projection cannot cancel badly;
 * Gram-Schmidt is run twice ("twice is enough", Parlett). */
static void complete_column(svd_t *S, size_t j, const unsigned char *done)
{
    dkf_real_t *u = S->g + j * S->m;
    dkf_real_t best = -DKF_R(1.0), nrm;
    size_t i, l, pass, ibest = 0;
    for (i = 0; i < S->m; ++i) {
        dkf_real_t res = DKF_R(1.0);
        for (l = 0; l < S->n; ++l)
            if (done[l]) res -= S->g[l * S->m + i] * S->g[l * S->m + i];
        if (res > best) {
            best = res;
            ibest = i;
        }
    }
    for (i = 0; i < S->m; ++i) u[i] = (i == ibest) ? DKF_R(1.0) : DKF_R(0.0);
    for (pass = 0; pass < 2; ++pass)
        for (l = 0; l < S->n; ++l)
            if (done[l]) {
                const dkf_real_t *w = S->g + l * S->m;
                dkf_real_t d = dot(w, u, S->m);
                for (i = 0; i < S->m; ++i) u[i] -= d * w[i];
            }
    nrm = DKF_SQRT(dot(u, u, S->m));
    for (i = 0; i < S->m; ++i) u[i] /= nrm;
}

/* s_j = ||g_j|| (times the load scale); optionally g_j / s_j, and an
 * orthonormal completion for the zero columns. */
static void extract(svd_t *S, dkf_real_t amax, int flags)
{
    unsigned char done[DKF_MAX_DIM];
    size_t i, j;
    for (j = 0; j < S->n; ++j) {
        dkf_real_t *gj = S->g + j * S->m;
        dkf_real_t sq = dot(gj, gj, S->m);
        dkf_real_t nrm = negligible(sq) ? DKF_R(0.0) : DKF_SQRT(sq);
        done[j] = (unsigned char)(nrm > DKF_R(0.0));
        if ((flags & SVD_DIRS) && done[j])
            for (i = 0; i < S->m; ++i) gj[i] /= nrm;
        S->sv[j] = nrm * amax;
    }
    if (flags & SVD_COMPLETE)
        for (j = 0; j < S->n; ++j)
            if (!done[j]) {
                complete_column(S, j, done);
                done[j] = 1;
            }
}

/* perm = indices of sv in descending order; insertion sort, stable, so
 * equal values keep their column order. */
static void sort_descending(svd_t *S)
{
    size_t i, j;
    for (i = 0; i < S->n; ++i) {
        size_t x = S->perm[i] = i;
        for (j = i; j > 0 && S->sv[S->perm[j - 1]] < S->sv[x]; --j) S->perm[j] = S->perm[j - 1];
        S->perm[j] = x;
    }
}

/* The SVD of A (already validated, finite) into S over `work`. */
static dkf_status_t jacobi_svd(svd_t *S, const dkf_mat_t *A, dkf_real_t *work, int flags)
{
    size_t i, sweep;
    dkf_real_t amax;
    int converged = 0;
    S->r = A->rows;
    S->c = A->cols;
    S->transposed = A->rows < A->cols;
    S->m = S->transposed ? A->cols : A->rows;
    S->n = S->transposed ? A->rows : A->cols;
    S->g = work;
    S->v = work + S->m * S->n;
    S->sv = S->v + S->n * S->n;
    S->ubase = S->transposed ? S->v : S->g;
    S->vbase = S->transposed ? S->g : S->v;

    amax = load_scaled(S, A);
    if (flags & SVD_ACCUM)
        for (i = 0; i < S->n * S->n; ++i)
            S->v[i] = (i % (S->n + 1) == 0) ? DKF_R(1.0) : DKF_R(0.0);
    /* sv is free until extract(): it holds the pivoting norms meanwhile */
    for (i = 0; i < S->n; ++i) S->sv[i] = dot(S->g + i * S->m, S->g + i * S->m, S->m);
    for (sweep = 0; sweep < DKF_SVD_MAX_SWEEPS && !converged; ++sweep)
        converged = jacobi_sweep(S, S->sv, flags & SVD_ACCUM) == 0;
    if (!converged) return DKF_ERR_NO_CONVERGENCE;
    extract(S, amax, flags);
    sort_descending(S);
    return DKF_OK;
}

/* The numerical rank: count of sorted singular values > tol, with the
 * documented default max(r, c) eps sigma_max for tol < 0. */
static size_t count_rank(const svd_t *S, dkf_real_t tol)
{
    size_t k = 0;
    if (tol < DKF_R(0.0))
        tol = (dkf_real_t)S->m * DKF_REAL_EPSILON * S->sv[S->perm[0]];
    while (k < S->n && S->sv[S->perm[k]] > tol) ++k;
    return k;
}

/* Argument checks shared by every routine here: A and its workspace. */
static dkf_status_t check_rank_args(const dkf_mat_t *A, const dkf_real_t *work)
{
    DKF_TRY(dkf__check_mat(A));
    DKF_CHECK_NULL(work);
    DKF_CHECK_NO_ALIAS_BUF(A, work, DKF_MAT_SVD_WORK(A->rows, A->cols));
    (void)work; /* unused when DKF_DEBUG_CHECKS is 0 */
    return DKF_OK;
}

/* Inputs must be finite: A's entries and the tolerance (a NaN tol would
 * silently give rank 0; an infinite one is no tolerance at all). */
static dkf_status_t check_finite_args(const dkf_mat_t *A, dkf_real_t tol)
{
    if (!dkf__all_finite(A->data, A->rows * A->cols) || !isfinite(tol))
        return DKF_ERR_NONFINITE;
    return DKF_OK;
}

dkf_status_t dkf_mat_svd(dkf_mat_t *U, dkf_real_t *s, dkf_mat_t *V, const dkf_mat_t *A,
                         dkf_real_t *work)
{
    svd_t S;
    size_t r, c, k, i, j, wlen;
    int flags = 0;
    DKF_CHECK_NULL(s);
    DKF_TRY(check_rank_args(A, work));
    r = A->rows;
    c = A->cols;
    k = r < c ? r : c;
    wlen = DKF_MAT_SVD_WORK(r, c);
    (void)wlen;
    {
        dkf_mat_t sview = DKF_MAT(k, 1, s);
        (void)sview; /* unused when DKF_DEBUG_CHECKS is 0 */
        DKF_CHECK_NO_ALIAS_BUF(A, s, k);
        DKF_CHECK_NO_ALIAS_BUF(&sview, work, wlen);
        if (U != NULL) {
            DKF_TRY(dkf__check_shape(U, r, k));
            DKF_CHECK_NO_ALIAS(U, A);
            DKF_CHECK_NO_ALIAS_BUF(U, s, k);
            DKF_CHECK_NO_ALIAS_BUF(U, work, wlen);
        }
        if (V != NULL) {
            DKF_TRY(dkf__check_shape(V, c, k));
            DKF_CHECK_NO_ALIAS(V, A);
            DKF_CHECK_NO_ALIAS_BUF(V, s, k);
            DKF_CHECK_NO_ALIAS_BUF(V, work, wlen);
            if (U != NULL) DKF_CHECK_NO_ALIAS(U, V);
        }
    }
    DKF_TRY(check_finite_args(A, DKF_R(0.0)));

    /* G's columns become U's (or V's, when transposed) and need unit length
     * and a completion; the accumulator is the other factor. */
    if (r < c) {
        if (V != NULL) flags |= SVD_DIRS | SVD_COMPLETE;
        if (U != NULL) flags |= SVD_ACCUM;
    } else {
        if (U != NULL) flags |= SVD_DIRS | SVD_COMPLETE;
        if (V != NULL) flags |= SVD_ACCUM;
    }
    DKF_TRY(jacobi_svd(&S, A, work, flags));

    for (j = 0; j < k; ++j) {
        size_t pj = S.perm[j];
        s[j] = S.sv[pj];
        if (U != NULL)
            for (i = 0; i < r; ++i) U->data[i * k + j] = S.ubase[pj * r + i];
        if (V != NULL)
            for (i = 0; i < c; ++i) V->data[i * k + j] = S.vbase[pj * c + i];
    }
    return DKF_OK;
}

dkf_status_t dkf_mat_pinv(dkf_mat_t *X, size_t *rank, const dkf_mat_t *A, dkf_real_t tol,
                          dkf_real_t *work)
{
    svd_t S;
    size_t r, c, kr, i, l, j;
    DKF_TRY(check_rank_args(A, work));
    r = A->rows;
    c = A->cols;
    DKF_TRY(dkf__check_shape(X, c, r));
    DKF_CHECK_NO_ALIAS(X, A);
    DKF_CHECK_NO_ALIAS_BUF(X, work, DKF_MAT_SVD_WORK(r, c));
    DKF_TRY(check_finite_args(A, tol));
    DKF_TRY(jacobi_svd(&S, A, work, SVD_DIRS | SVD_ACCUM));
    kr = count_rank(&S, tol);

    /* A+ = sum_{j < rank} v_j u_j^T / s_j */
    for (i = 0; i < c; ++i)
        for (l = 0; l < r; ++l) {
            dkf_real_t acc = DKF_R(0.0);
            for (j = 0; j < kr; ++j) {
                size_t pj = S.perm[j];
                acc += S.vbase[pj * c + i] * S.ubase[pj * r + l] / S.sv[pj];
            }
            X->data[i * r + l] = acc;
        }
    if (rank != NULL) *rank = kr;
    return DKF_OK;
}

dkf_status_t dkf_mat_rank(size_t *rank, const dkf_mat_t *A, dkf_real_t tol, dkf_real_t *work)
{
    svd_t S;
    DKF_CHECK_NULL(rank);
    DKF_TRY(check_rank_args(A, work));
    DKF_TRY(check_finite_args(A, tol));
    DKF_TRY(jacobi_svd(&S, A, work, 0));
    *rank = count_rank(&S, tol);
    return DKF_OK;
}

dkf_status_t dkf_mat_frd(dkf_mat_t *Abar, dkf_mat_t *T, size_t *rank, const dkf_mat_t *A,
                         dkf_real_t tol, dkf_real_t *work)
{
    svd_t S;
    size_t r, c, kr, i, j, wlen;
    DKF_CHECK_NULL(rank);
    DKF_TRY(check_rank_args(A, work));
    DKF_TRY(dkf__check_mat(Abar));
    DKF_TRY(dkf__check_mat(T));
    r = A->rows;
    c = A->cols;
    wlen = DKF_MAT_SVD_WORK(r, c);
    (void)wlen;
    if (Abar->rows != r || T->cols != c) return DKF_ERR_DIM;
    DKF_CHECK_NO_ALIAS(Abar, A);
    DKF_CHECK_NO_ALIAS(T, A);
    DKF_CHECK_NO_ALIAS(Abar, T);
    DKF_CHECK_NO_ALIAS_BUF(Abar, work, wlen);
    DKF_CHECK_NO_ALIAS_BUF(T, work, wlen);
    DKF_TRY(check_finite_args(A, tol));
    DKF_TRY(jacobi_svd(&S, A, work, SVD_DIRS | SVD_ACCUM));
    kr = count_rank(&S, tol);
    if (kr == 0) return DKF_ERR_RANK;
    if (Abar->cols < kr || T->rows < kr) return DKF_ERR_CAPACITY;

    /* Abar = U_k S_k (r x rank), T = V_k^T (rank x c), both row-major in
     * the resized views. */
    Abar->cols = kr;
    T->rows = kr;
    for (j = 0; j < kr; ++j) {
        size_t pj = S.perm[j];
        for (i = 0; i < r; ++i) Abar->data[i * kr + j] = S.ubase[pj * r + i] * S.sv[pj];
        for (i = 0; i < c; ++i) T->data[j * c + i] = S.vbase[pj * c + i];
    }
    *rank = kr;
    return DKF_OK;
}
