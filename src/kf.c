/*
 * Linear Kalman filter, covariance form (dkf/kf.h).
 *
 * Each step computes its results in the filter's scratch and copies them
 * over the state only once every check has passed, so a failed step leaves
 * the filter bit-identical.
 */
#include "dkf/kf.h"

#include "internal.h"
#include "kernels.h"

/* Scratch layout for state n, measurement m (DKF_KF_STORAGE_LEN gives
 * n + 3 n^2 + 3 n m + 2 m^2 reals of scratch):
 *   xn  n      new state
 *   Pn  n*n    new P (right after xn: one finiteness scan covers both)
 *   T   n*n    F P (predict); A P = (I - K H) P (Joseph update)
 *   Ft  n*n    F^T (predict)
 *   Ht  n*m    H^T; then R K^T (Joseph) or -K (simple update)
 *   HP  m*n    H P (= (P H^T)^T, P symmetric); then K R - (A P) H^T
 *   Kt  m*n    K^T = S^{-1} H P
 *   S   m*m    innovation covariance H P H^T + R
 *   L   m*m    its Cholesky factor
 * Every product runs on the row-major register-blocked kernels (row i of
 * the result accumulates rows of the right operand); the transposed
 * copies F^T and H^T, O(n^2) and O(n m), are what makes that possible. */
typedef struct {
    dkf_real_t *xn, *T, *Pn, *Ft, *Ht, *HP, *Kt, *S, *L;
} kf_scratch_t;

static kf_scratch_t kf_scratch(const dkf_kf_t *kf)
{
    const size_t n = kf->n, m = kf->m_max;
    kf_scratch_t s;
    s.xn = kf->work;
    s.Pn = s.xn + n;
    s.T = s.Pn + n * n;
    s.Ft = s.T + n * n;
    s.Ht = s.Ft + n * n;
    s.HP = s.Ht + n * m;
    s.Kt = s.HP + m * n;
    s.S = s.Kt + m * n;
    s.L = s.S + m * m;
    return s;
}

/* At (c x r) = A^T for A r x c. */
static void transpose(dkf_real_t *restrict At, const dkf_real_t *restrict A, size_t r, size_t c)
{
    size_t i, j;
    for (i = 0; i < r; ++i)
        for (j = 0; j < c; ++j) At[j * r + i] = A[i * c + j];
}

/* Finiteness without classifying each element: x - x is +0 for every
 * finite x and NaN for an infinity or a NaN, and a NaN survives every
 * later addition, so nan_sum(p, n) == 0 iff all n reals are finite, and
 * the sums of several arrays are tested once (nonfinite below). Branch-
 * free, 4 independent sums (vectorised at -O2). Relies on IEEE
 * arithmetic, as all of dkf does: no -ffinite-math-only (so no
 * -ffast-math), under which x - x would fold to 0. */
static dkf_real_t nan_sum(const dkf_real_t *p, size_t n)
{
    dkf_real_t s0 = DKF_R(0.0), s1 = DKF_R(0.0), s2 = DKF_R(0.0), s3 = DKF_R(0.0);
    size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        s0 += p[i] - p[i];
        s1 += p[i + 1] - p[i + 1];
        s2 += p[i + 2] - p[i + 2];
        s3 += p[i + 3] - p[i + 3];
    }
    for (; i < n; ++i) s0 += p[i] - p[i];
    return (s0 + s1) + (s2 + s3);
}

static int nonfinite(dkf_real_t sum)
{
    return !(sum == DKF_R(0.0));
}

dkf_status_t dkf_kf_init(dkf_kf_t *kf, size_t n, size_t m_max, dkf_real_t *storage,
                         size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0)
{
    size_t i;
    DKF_CHECK_NULL(kf);
    DKF_CHECK_NULL(storage);
    if (n == 0 || m_max == 0 || n > DKF_MAX_DIM || m_max > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    if (storage_len < DKF_KF_STORAGE_LEN(n, m_max)) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    /* P0 must be SPD: factor it into the storage, which holds no state yet */
    if (dkf__chol(storage, storage + n * n, P0->data, n) != 0) return DKF_ERR_NOT_SPD;

    kf->n = n;
    kf->m_max = m_max;
    kf->x.rows = n, kf->x.cols = 1, kf->x.data = storage;
    kf->P.rows = n, kf->P.cols = n, kf->P.data = storage + n;
    kf->nu.rows = m_max, kf->nu.cols = 1, kf->nu.data = kf->P.data + n * n;
    kf->S.rows = m_max, kf->S.cols = m_max, kf->S.data = kf->nu.data + m_max;
    kf->work = kf->S.data + m_max * m_max;
    dkf__copy(kf->x.data, x0->data, n);
    dkf__copy(kf->P.data, P0->data, n * n);
    for (i = 0; i < m_max * (m_max + 1); ++i) kf->nu.data[i] = DKF_R(0.0);
    kf->nis = DKF_R(0.0);
    kf->ready = 1;
    return DKF_OK;
}

dkf_status_t dkf_kf_predict(dkf_kf_t *kf, const dkf_mat_t *F, const dkf_mat_t *Q,
                            const dkf_mat_t *u)
{
    size_t n;
    kf_scratch_t s;
    DKF_CHECK_NULL(kf);
    if (!kf->ready) return DKF_ERR_STATE;
    n = kf->n;
    /* shapes first, then the finiteness of every input in one test */
    DKF_TRY(dkf__check_shape(F, n, n));
    DKF_TRY(dkf__check_shape(Q, n, n));
    if (u != NULL) DKF_TRY(dkf__check_shape(u, n, 1));
    if (nonfinite(nan_sum(F->data, n * n) + nan_sum(Q->data, n * n) +
                  (u != NULL ? nan_sum(u->data, n) : DKF_R(0.0))))
        return DKF_ERR_NONFINITE;
    s = kf_scratch(kf);

    /* x = F x + u */
    dkf__mul_vec(s.xn, F->data, kf->x.data, n, n);
    if (u != NULL) {
        size_t i;
        for (i = 0; i < n; ++i) s.xn[i] += u->data[i];
    }
    /* P = (F P) F^T + Q: upper triangle (of Q too), mirrored */
    transpose(s.Ft, F->data, n, n);
    dkf__mul_nn(s.T, F->data, kf->P.data, n, n, n);
    dkf__mul_nn_sym(s.Pn, s.T, s.Ft, Q->data, n, n);
    if (nonfinite(nan_sum(s.xn, n + n * n))) return DKF_ERR_NONFINITE; /* xn and Pn */

    dkf__copy(kf->x.data, s.xn, n);
    dkf__copy(kf->P.data, s.Pn, n * n);
    return DKF_OK;
}

#if DKF_JOSEPH
/* T (n x n) = P - K HP, K = Kt^T (Kt m x n), HP m x n: A P with
 * A = I - K H, without forming A (O(n^2 m), not O(n^3)). Row i of T
 * accumulates the rows of HP, 4 columns at a time in registers. */
static void minus_k_hp(dkf_real_t *restrict T, const dkf_real_t *restrict P,
                       const dkf_real_t *restrict Kt, const dkf_real_t *restrict HP, size_t n,
                       size_t m)
{
    size_t i, j, l;
    for (i = 0; i < n; ++i) {
        const dkf_real_t *pi = P + i * n;
        dkf_real_t *ti = T + i * n;
        for (j = 0; j + 4 <= n; j += 4) {
            dkf_real_t t0 = pi[j], t1 = pi[j + 1], t2 = pi[j + 2], t3 = pi[j + 3];
            for (l = 0; l < m; ++l) {
                const dkf_real_t a = Kt[l * n + i];
                const dkf_real_t *h = HP + l * n + j;
                t0 -= a * h[0];
                t1 -= a * h[1];
                t2 -= a * h[2];
                t3 -= a * h[3];
            }
            ti[j] = t0, ti[j + 1] = t1, ti[j + 2] = t2, ti[j + 3] = t3;
        }
        for (; j < n; ++j) {
            dkf_real_t t = pi[j];
            for (l = 0; l < m; ++l) t -= Kt[l * n + i] * HP[l * n + j];
            ti[j] = t;
        }
    }
}

/* P+ = (I - K H) P (I - K H)^T + K R K^T (Joseph form: symmetric positive
 * semi-definite under rounding whatever the gain), through the structure
 * of A = I - K H instead of A itself (O(n^2 m) instead of O(n^3)):
 *   A P = P - K (H P);   (A P) A^T = A P - ((A P) H^T) K^T;
 *   P+ = A P + (K R - (A P) H^T) K^T,
 * upper triangle, mirrored (exactly symmetric). K R = (R K^T)^T, R
 * symmetric. */
static void joseph_update(const dkf_kf_t *kf, const kf_scratch_t *s, const dkf_mat_t *R, size_t m)
{
    const size_t n = kf->n;
    dkf_real_t *E = s->HP, *RKt = s->Ht; /* each consumed before it is reused */
    size_t i, l;
    minus_k_hp(s->T, kf->P.data, s->Kt, s->HP, n, m);
    dkf__mul_nn(E, s->T, s->Ht, n, n, m);  /* (A P) H^T */
    dkf__mul_nn(RKt, R->data, s->Kt, m, m, n);
    for (i = 0; i < n; ++i)
        for (l = 0; l < m; ++l) E[i * m + l] = RKt[l * n + i] - E[i * m + l];
    dkf__mul_nn_sym(s->Pn, E, s->Kt, s->T, n, m);
}

#else
/* P+ = P - K (H P) = P - K S K^T: upper triangle, mirrored (negation is
 * exact, so (-K) (H P) + P is that difference). */
static void simple_update(const dkf_kf_t *kf, const kf_scratch_t *s, size_t m)
{
    const size_t n = kf->n;
    dkf_real_t *Kneg = s->Ht; /* consumed by now */
    size_t i, l;
    for (i = 0; i < n; ++i)
        for (l = 0; l < m; ++l) Kneg[i * m + l] = -s->Kt[l * n + i];
    dkf__mul_nn_sym(s->Pn, Kneg, s->HP, kf->P.data, n, m);
}
#endif

dkf_status_t dkf_kf_update(dkf_kf_t *kf, const dkf_mat_t *H, const dkf_mat_t *R,
                           const dkf_mat_t *y)
{
    dkf_real_t nu[DKF_MAX_DIM], w[DKF_MAX_DIM], inv[DKF_MAX_DIM];
    dkf_real_t nis = DKF_R(0.0);
    size_t n, m, i, j;
    kf_scratch_t s;
    DKF_CHECK_NULL(kf);
    if (!kf->ready) return DKF_ERR_STATE;
    n = kf->n;
    DKF_TRY(dkf__check_mat(H));
    m = H->rows;
    if (m > kf->m_max) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_shape(H, m, n));
    DKF_TRY(dkf__check_shape(R, m, m));
    DKF_TRY(dkf__check_shape(y, m, 1));
    if (nonfinite(nan_sum(H->data, m * n) + nan_sum(R->data, m * m) + nan_sum(y->data, m)))
        return DKF_ERR_NONFINITE;
    s = kf_scratch(kf);

    /* nu = y - H x;  HP = H P;  S = HP H^T + R (upper triangle of R read) */
    dkf__mul_vec(nu, H->data, kf->x.data, m, n);
    for (i = 0; i < m; ++i) nu[i] = y->data[i] - nu[i];
    transpose(s.Ht, H->data, m, n);
    dkf__mul_nn(s.HP, H->data, kf->P.data, m, n, n);
    dkf__mul_nn_sym(s.S, s.HP, s.Ht, R->data, m, n);
    if (dkf__chol(s.L, inv, s.S, m) != 0) return DKF_ERR_NOT_SPD;
    /* K^T = S^{-1} (H P) (P and S symmetric) */
    dkf__copy(s.Kt, s.HP, m * n);
    dkf__chol_solve(s.L, inv, s.Kt, m, n);
    /* NIS = nu^T S^{-1} nu = |L^{-1} nu|^2 */
    dkf__copy(w, nu, m);
    dkf__tri_lower_solve_vec(s.L, inv, w, m);
    for (i = 0; i < m; ++i) nis += w[i] * w[i];
    /* x+ = x + K nu, accumulating the rows of K^T */
    dkf__copy(s.xn, kf->x.data, n);
    for (j = 0; j < m; ++j) {
        const dkf_real_t *kj = s.Kt + j * n;
        const dkf_real_t nuj = nu[j];
        for (i = 0; i < n; ++i) s.xn[i] += kj[i] * nuj;
    }
#if DKF_JOSEPH
    joseph_update(kf, &s, R, m);
#else
    simple_update(kf, &s, m);
#endif
    if (nonfinite(nan_sum(s.xn, n + n * n) + (nis - nis))) /* xn, Pn and the NIS */
        return DKF_ERR_NONFINITE;

    dkf__copy(kf->x.data, s.xn, n);
    dkf__copy(kf->P.data, s.Pn, n * n);
    kf->nu.rows = m;
    kf->S.rows = kf->S.cols = m;
    dkf__copy(kf->nu.data, nu, m);
    dkf__copy(kf->S.data, s.S, m * m);
    kf->nis = nis;
    return DKF_OK;
}
