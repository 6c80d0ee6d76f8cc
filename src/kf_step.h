/*
 * src/kf_step.h - the Kalman step bodies of kf.c (dkf/kf.h), compiled
 * once per instance: by kf.c for the baseline ISA and, on x86-64 under
 * GCC in double, by kf_avx.c for AVX (32-byte vectors; dkf__isa_avx picks
 * one per call, docs/decisions.md item 25). Both instances run the same
 * operations in the same order and return the same bits. Not installed.
 *
 * Each step computes its results in the filter's scratch and copies them
 * over the state only once every check has passed, so a failed step leaves
 * the filter bit-identical.
 */
#ifndef DKF_KF_STEP_H
#define DKF_KF_STEP_H

#include <string.h>

#include "dkf/kf.h"
#include "internal.h"
#include "kernels.h"
#include "kernels_inline.h"

/* Storage layout for state n, measurement capacity m (kf_layout; its
 * count is DKF_KF_STORAGE_LEN): the state x, P, nu, S
 * (DKF_KF_STATE_LEN), then the scratch of one step:
 *   xn  n           new state
 *   Pn  n*n         new P (right after xn: one commit copy covers both,
 *                   as x and P are adjacent)
 *   W   w = max(2n^2, 2nm), shared by the two steps:
 *       predict: T = F P (n*n) and Ft = F^T (n*n); after P is formed,
 *                the PSD check's factor (n*n)
 *       update:  Ht = H^T (n*m); then (Joseph) G = [P A^T; -R K^T]
 *                ((n+m) x n) of the covariance update, then the PSD
 *                check's factor (n*n)
 *   HP  m*n         H P (= (P H^T)^T, P symmetric)
 *   Kt  m*n         -K^T = S^{-1} (-H P), the gain negated, right after HP
 *   Sc  m*m         innovation covariance H P H^T + R
 *   L   m*m         its Cholesky factor; then (Joseph) R mirrored from
 *                   its upper triangle
 * Joseph form: At = A^T = I - H^T K^T (n*n) ends where Kt starts, so
 * that [At; Kt] is one (n+m) x n array; it covers HP (dead once Kt is
 * solved) and the last n^2 - nm reals of W (if n > m): it starts at
 * W + w + nm - n^2 >= W + n^2 + nm, past the end of G (and of Ht).
 * Every product runs on the row-major register-blocked kernels (row i of
 * the result accumulates rows of the right operand); the transposed
 * copies F^T and H^T, O(n^2) and O(n m), are what makes that possible
 * (F x and H x too run as x^T F^T and x^T H^T). */
typedef struct {
    dkf_real_t *x, *P, *nu, *S;                 /* state */
    dkf_real_t *xn, *Pn, *W, *HP, *Kt, *Sc, *L; /* scratch */
} kf_layout_t;

/* Walks the storage in the order above; with base == NULL it only counts. */
DKF__INLINE size_t kf_layout(kf_layout_t *L, dkf_real_t *base, size_t n, size_t m)
{
    size_t used = 0;
    DKF_TAKE(L->x, n);
    DKF_TAKE(L->P, n * n);
    DKF_TAKE(L->nu, m);
    DKF_TAKE(L->S, m * m);
    DKF_TAKE(L->xn, n);
    DKF_TAKE(L->Pn, n * n);
    DKF_TAKE(L->W, 2 * (n > m ? n * n : n * m));
    DKF_TAKE(L->HP, m * n);
    DKF_TAKE(L->Kt, m * n);
    DKF_TAKE(L->Sc, m * m);
    DKF_TAKE(L->L, m * m);
    return used;
}

/* A step's scratch: the layout's regions and the aliases above. */
typedef struct {
    dkf_real_t *xn, *Pn, *T, *Ft, *Ht, *HP, *Kt, *At, *S, *L;
} kf_scratch_t;

DKF__INLINE kf_scratch_t kf_scratch(const dkf_kf_t *kf)
{
    const size_t n = kf->n;
    kf_layout_t L;
    kf_scratch_t s;
    (void)kf_layout(&L, kf->x.data, n, kf->m_max);
    s.xn = L.xn;
    s.Pn = L.Pn;
    s.T = s.Ht = L.W;
    s.Ft = L.W + n * n;
    s.HP = L.HP;
    s.Kt = L.Kt;
    s.At = L.Kt - n * n;
    s.S = L.Sc;
    s.L = L.L;
    return s;
}

/* y += alpha x on n reals that do not overlap (restrict parameters are
 * what lets GCC vectorise it once inlined). */
DKF__INLINE void axpy(dkf_real_t *restrict y, dkf_real_t alpha, const dkf_real_t *restrict x,
                      size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) y[i] += alpha * x[i];
}

/* x, P = xn, Pn: both pairs are adjacent (x then P in the storage, xn
 * then Pn in the scratch), one copy of n + n^2 reals. Up to 256 bytes
 * with the step's n (a compile-time constant in a fixed-size step: a few
 * inlined moves); above, with the filter's n, so that it is a library
 * call: GCC expands a constant-length copy of a few hundred bytes as
 * `rep movs`, whose start-up costs more than the call. */
DKF__INLINE void commit_state(dkf_kf_t *kf, const kf_scratch_t *s, size_t n)
{
    const size_t len = (n + n * n) * sizeof *s->xn;
    if (len <= 256)
        memcpy(kf->x.data, s->xn, len);
    else
        memcpy(kf->x.data, s->xn, (kf->n + kf->n * kf->n) * sizeof *s->xn);
}

/* The step bodies below are written once for any size and forced inline:
 * the entry points expand them once with the run-time n (and m), and once
 * per size of DKF_KF_FIXED_SIZES with literal sizes, so that each of those
 * compiles to a step of exactly that size (constant trip counts, unrolled
 * and vectorised blocks, no remainder code). Both run the same operations
 * in the same order, so they return the same bits.
 *
 * Which inputs are scanned for NaN/Inf: x and P are finite (nothing else
 * is ever committed), and under IEEE arithmetic a non-finite term makes
 * every sum it enters non-finite (Inf * 0 is NaN, Inf - Inf is NaN). So a
 * non-finite F(i,k) makes row i of F P, hence (F P F^T)(i,i), non-finite;
 * u(i) makes x(i) non-finite; H(i,k) makes S(i,i) non-finite, which the
 * Cholesky factorisation rejects; y(i) makes the NIS non-finite. The
 * scans of the results (x and the NIS; P only where the PSD check, which
 * refuses a non-finite P, failed: pn_refused) and of a failed
 * factorisation's inputs therefore report every non-finite F, u, H, y as
 * DKF_ERR_NONFINITE without scanning them on the way in. Q and R are
 * scanned whole: only their upper triangles enter the products, and a
 * NaN in a lower triangle must not pass unnoticed. */

/* The status of a new P (symmetric) that inl_psd_within_rounding refused:
 * the check refuses every P with a NaN or Inf too, so P is scanned only
 * here, to report that as such. */
DKF__INLINE dkf_status_t pn_refused(const dkf_real_t *Pn, size_t n)
{
    return inl_any_nonfinite(Pn, n * n) ? DKF_ERR_NONFINITE : DKF_ERR_NOT_SPD;
}

/* x = F x + u, P = (F P) F^T + Q into scratch; commits after the checks. */
DKF__INLINE dkf_status_t predict_step(dkf_kf_t *kf, const dkf_real_t *F, const dkf_real_t *Q,
                                      const dkf_real_t *u, size_t n)
{
    const kf_scratch_t s = kf_scratch(kf);
    size_t i;
    if (DKF__UNLIKELY(inl_any_nonfinite(Q, n * n))) return DKF_ERR_NONFINITE; /* F, u: see above */
    /* x = (x^T F^T)^T + u; P = (F P) F^T + Q: upper triangle (of Q too), mirrored */
    inl_transpose_input(s.Ft, F, n, n);
    inl_mul_nn(s.xn, kf->x.data, s.Ft, 1, n, n);
    if (u != NULL)
        for (i = 0; i < n; ++i) s.xn[i] += u[i];
    inl_mul_nn(s.T, F, kf->P.data, n, n, n);
    inl_mul_nn_sym(s.Pn, s.T, s.Ft, Q, n, n);
    if (DKF__UNLIKELY(inl_any_nonfinite(s.xn, n))) return DKF_ERR_NONFINITE;
    /* an indefinite Q (or an indefinite P from outside) must not pass */
    if (DKF__UNLIKELY(!inl_psd_sym_within_rounding(s.T, s.Pn, n))) return pn_refused(s.Pn, n);

    commit_state(kf, &s, n);
    return DKF_OK;
}


/* Covariance update, upper triangle computed and mirrored.
 * Joseph form (DKF_JOSEPH=1), for the gain K actually computed, as
 * written: P+ = A P A^T + K R K^T with A = I - K H formed (inl_joseph:
 * accurate also when the data pin the state, P+ << P; docs/decisions.md
 * item 17). O(n^3 + n^2 m). At is placed right before Kt, so [At; Kt] is
 * the (n+m) x n array inl_joseph wants, G = [P A^T; -R K^T] goes to W
 * (over Ht, which inl_joseph reads first) and R's mirror to L's place.
 * Short form (DKF_JOSEPH=0): P+ = P - K (H P) = P + (-K^T)^T (HP). Kt
 * holds -K^T in both. */
DKF__INLINE void covariance_update(const dkf_kf_t *kf, const kf_scratch_t *s, const dkf_real_t *R,
                                   size_t n, size_t m)
{
#if DKF_JOSEPH
    inl_joseph(s->Pn, s->At, s->T, s->L, kf->P.data, s->Ht, R, n, m);
#else
    (void)R;
    inl_mul_tn_sym(s->Pn, s->Kt, s->HP, kf->P.data, n, m); /* Kt holds -K^T */
#endif
}

/* nu = y - H x, S = H P H^T + R, K^T = S^{-1} H P, x + K nu and P+ into
 * scratch; commits after the checks. */
DKF__INLINE dkf_status_t update_step(dkf_kf_t *kf, const dkf_real_t *H, const dkf_real_t *R,
                                     const dkf_real_t *y, size_t n, size_t m)
{
    const kf_scratch_t s = kf_scratch(kf);
    dkf_real_t nu[DKF_MAX_DIM], w[DKF_MAX_DIM], inv[DKF_MAX_DIM];
    dkf_real_t nis = DKF_R(0.0);
    size_t i, j;
    int spd;
    /* HP = H P;  S = HP H^T + R (upper triangle of R read), factored */
    inl_transpose_input(s.Ht, H, m, n);
    inl_mul_nn(s.HP, H, kf->P.data, m, n, n);
    inl_mul_nn_sym(s.S, s.HP, s.Ht, R, m, n);
    spd = chol_rows(s.L, inv, s.S, m, 1) == 0; /* quot: chol_diag2 */
    /* after the factorisation, so that the scan runs while its sqrt/divide
     * chain is in flight; a failed one is the input's fault if H, R or y
     * is not finite (see above), and reported as such */
    if (DKF__UNLIKELY(inl_any_nonfinite(R, m * m))) return DKF_ERR_NONFINITE;
    if (DKF__UNLIKELY(!spd))
        return inl_any_nonfinite(H, m * n) | inl_any_nonfinite(y, m) ? DKF_ERR_NONFINITE
                                                                      : DKF_ERR_NOT_SPD;
    /* nu = y - H x, as x^T H^T */
    inl_mul_nn(nu, kf->x.data, s.Ht, 1, n, m);
    for (i = 0; i < m; ++i) nu[i] = y[i] - nu[i];
    /* -K^T = S^{-1} (-H P) (P and S symmetric): the negated gain, exactly
     * (IEEE rounding is symmetric), which the covariance update wants */
    inl_negate(s.Kt, s.HP, m * n);
    inl_chol_solve(s.L, inv, s.Kt, m, n);
    /* NIS = nu^T S^{-1} nu = |L^{-1} nu|^2 */
    memcpy(w, nu, m * sizeof *w);
    inl_tri_lower_solve_vec(s.L, inv, w, m);
    for (i = 0; i < m; ++i) nis += w[i] * w[i];
    /* x+ = x + K nu, accumulating the rows of -K^T times -nu */
    memcpy(s.xn, kf->x.data, n * sizeof *s.xn);
    for (j = 0; j < m; ++j) axpy(s.xn, -nu[j], s.Kt + j * n, n);
    covariance_update(kf, &s, R, n, m);
    if (DKF__UNLIKELY(inl_any_nonfinite(s.xn, n) | inl_any_nonfinite(&nis, 1)))
        return DKF_ERR_NONFINITE;
    /* P+ indefinite beyond rounding (the short form under stress, an R
     * that is not PSD) or not finite: refused, the filter unchanged */
    if (DKF__UNLIKELY(!inl_psd_sym_within_rounding(s.T, s.Pn, n))) return pn_refused(s.Pn, n);

    commit_state(kf, &s, n);
    kf->nu.rows = m;
    kf->S.rows = kf->S.cols = m;
    memcpy(kf->nu.data, nu, m * sizeof *nu);
    memcpy(kf->S.data, s.S, m * m * sizeof *s.S);
    kf->nis = nis;
    return DKF_OK;
}

/* The step for the filter's n (and m): the instance compiled for that
 * size if it is one of DKF_KF_FIXED_SIZES, else the run-time one. */
DKF__INLINE dkf_status_t predict_any(dkf_kf_t *kf, const dkf_real_t *F, const dkf_real_t *Q,
                                     const dkf_real_t *u)
{
    const size_t n = kf->n;
#define DKF__KF_PREDICT_FIXED(N, M) \
    if ((N) <= DKF_MAX_DIM && n == (N)) return predict_step(kf, F, Q, u, (N));
    DKF_KF_FIXED_SIZES(DKF__KF_PREDICT_FIXED)
#undef DKF__KF_PREDICT_FIXED
    return predict_step(kf, F, Q, u, n);
}

DKF__INLINE dkf_status_t update_any(dkf_kf_t *kf, const dkf_real_t *H, const dkf_real_t *R,
                                    const dkf_real_t *y, size_t m)
{
    const size_t n = kf->n;
#define DKF__KF_UPDATE_FIXED(N, M) \
    if ((N) <= DKF_MAX_DIM && (M) <= DKF_MAX_DIM && n == (N) && m == (M)) \
        return update_step(kf, H, R, y, (N), (M));
    DKF_KF_FIXED_SIZES(DKF__KF_UPDATE_FIXED)
#undef DKF__KF_UPDATE_FIXED
    return update_step(kf, H, R, y, n, m);
}

/* The step of one instance (kf.c) for arguments the entry points have
 * checked: avx = 1 (only where dkf__isa_avx() is 1) takes the AVX one if
 * this build has it (DKF__KF_AVX), else the baseline one. The entry points
 * choose by the CPU and the size (kf_use_avx in kf.c); test_kf_isa passes
 * both at every size and compares the bits. */
dkf_status_t dkf__kf_predict_isa(int avx, dkf_kf_t *kf, const dkf_real_t *F, const dkf_real_t *Q,
                                 const dkf_real_t *u);
dkf_status_t dkf__kf_update_isa(int avx, dkf_kf_t *kf, const dkf_real_t *H, const dkf_real_t *R,
                                const dkf_real_t *y, size_t m);

/* The AVX instance (kf_avx.c): predict_any and update_any. */
#define DKF__KF_AVX (DKF__AVX && !DKF_USE_FLOAT)
#if DKF__KF_AVX
dkf_status_t dkf__kf_predict_avx(dkf_kf_t *kf, const dkf_real_t *F, const dkf_real_t *Q,
                                 const dkf_real_t *u);
dkf_status_t dkf__kf_update_avx(dkf_kf_t *kf, const dkf_real_t *H, const dkf_real_t *R,
                                const dkf_real_t *y, size_t m);
#endif

#endif /* DKF_KF_STEP_H */
