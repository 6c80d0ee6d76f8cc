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

/* Scratch layout for state n, measurement m (DKF_KF_STORAGE_LEN):
 *   xn  n      new state
 *   A   n*n    F P, then (I - K H)
 *   B   n*n    new P
 *   C   n*n    (I - K H) P
 *   PHt n*m    P H^T
 *   Kt  m*n    K^T = S^{-1} H P
 *   KR  n*m    K R
 *   S   m*m    innovation covariance H P H^T + R
 *   L   m*m    its Cholesky factor                                     */
typedef struct {
    dkf_real_t *xn, *A, *B, *C, *PHt, *Kt, *KR, *S, *L;
} kf_scratch_t;

static kf_scratch_t kf_scratch(const dkf_kf_t *kf)
{
    const size_t n = kf->n, m = kf->m_max;
    kf_scratch_t s;
    s.xn = kf->work;
    s.A = s.xn + n;
    s.B = s.A + n * n;
    s.C = s.B + n * n;
    s.PHt = s.C + n * n;
    s.Kt = s.PHt + n * m;
    s.KR = s.Kt + m * n;
    s.S = s.KR + n * m;
    s.L = s.S + m * m;
    return s;
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
    DKF_TRY(dkf__check_input(F, n, n));
    DKF_TRY(dkf__check_input(Q, n, n));
    if (u != NULL) DKF_TRY(dkf__check_input(u, n, 1));
    s = kf_scratch(kf);

    /* x = F x + u */
    dkf__mul_vec(s.xn, F->data, kf->x.data, n, n);
    if (u != NULL) {
        size_t i;
        for (i = 0; i < n; ++i) s.xn[i] += u->data[i];
    }
    /* P = F P F^T + Q, symmetric by construction (upper triangle of Q read) */
    dkf__mul_nn(s.A, F->data, kf->P.data, n, n, n);
    dkf__mul_nt_sym(s.B, s.A, F->data, Q->data, n, n);
    if (!dkf__all_finite(s.xn, n) || !dkf__all_finite(s.B, n * n)) return DKF_ERR_NONFINITE;

    dkf__copy(kf->x.data, s.xn, n);
    dkf__copy(kf->P.data, s.B, n * n);
    return DKF_OK;
}

#if DKF_JOSEPH
/* P+ = (I - K H) P (I - K H)^T + K R K^T (Joseph form): keeps P+ symmetric
 * positive semi-definite under rounding whatever the gain. */
static void joseph_update(const dkf_kf_t *kf, const kf_scratch_t *s, const dkf_mat_t *H,
                          const dkf_mat_t *R, size_t m)
{
    const size_t n = kf->n;
    size_t i, j, l;
    /* A = I - K H, with K = Kt^T */
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) {
            dkf_real_t v = (i == j) ? DKF_R(1.0) : DKF_R(0.0);
            for (l = 0; l < m; ++l) v -= s->Kt[l * n + i] * H->data[l * n + j];
            s->A[i * n + j] = v;
        }
    /* KR = K R */
    for (i = 0; i < n; ++i)
        for (j = 0; j < m; ++j) {
            dkf_real_t v = DKF_R(0.0);
            for (l = 0; l < m; ++l) v += s->Kt[l * n + i] * R->data[l * m + j];
            s->KR[i * m + j] = v;
        }
    /* C = A P; B = C A^T; B += KR K^T (upper triangles, mirrored) */
    dkf__mul_nn(s->C, s->A, kf->P.data, n, n, n);
    dkf__mul_nt_sym(s->B, s->C, s->A, NULL, n, n);
    for (i = 0; i < n; ++i)
        for (j = i; j < n; ++j) {
            dkf_real_t v = DKF_R(0.0);
            for (l = 0; l < m; ++l) v += s->KR[i * m + l] * s->Kt[l * n + j];
            s->B[i * n + j] += v;
            if (j != i) s->B[j * n + i] = s->B[i * n + j];
        }
}

#else
/* P+ = P - K (H P) = P - K S K^T, symmetrised. */
static void simple_update(const dkf_kf_t *kf, const kf_scratch_t *s, size_t m)
{
    const size_t n = kf->n;
    size_t i, j, l;
    for (i = 0; i < n; ++i)
        for (j = i; j < n; ++j) {
            dkf_real_t v = DKF_R(0.0);
            for (l = 0; l < m; ++l) v += s->PHt[i * m + l] * s->Kt[l * n + j];
            s->B[i * n + j] = kf->P.data[i * n + j] - v;
            s->B[j * n + i] = s->B[i * n + j];
        }
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
    DKF_TRY(dkf__check_input(H, m, n));
    DKF_TRY(dkf__check_input(R, m, m));
    DKF_TRY(dkf__check_input(y, m, 1));
    s = kf_scratch(kf);

    /* nu = y - H x;  PHt = P H^T;  S = H PHt + R (upper triangle of R read) */
    dkf__mul_vec(nu, H->data, kf->x.data, m, n);
    for (i = 0; i < m; ++i) nu[i] = y->data[i] - nu[i];
    dkf__mul_nt(s.PHt, kf->P.data, H->data, n, n, m);
    for (i = 0; i < m; ++i)
        for (j = i; j < m; ++j) {
            dkf_real_t v = R->data[i * m + j];
            size_t l;
            for (l = 0; l < n; ++l) v += H->data[i * n + l] * s.PHt[l * m + j];
            s.S[i * m + j] = v;
            s.S[j * m + i] = v;
        }
    if (dkf__chol(s.L, inv, s.S, m) != 0) return DKF_ERR_NOT_SPD;
    /* Kt = K^T = S^{-1} (P H^T)^T, m x n */
    for (i = 0; i < m; ++i)
        for (j = 0; j < n; ++j) s.Kt[i * n + j] = s.PHt[j * m + i];
    dkf__chol_solve(s.L, inv, s.Kt, m, n);
    /* NIS = nu^T S^{-1} nu = |L^{-1} nu|^2 */
    dkf__copy(w, nu, m);
    dkf__tri_lower_solve_vec(s.L, inv, w, m);
    for (i = 0; i < m; ++i) nis += w[i] * w[i];
    /* x+ = x + K nu */
    for (i = 0; i < n; ++i) {
        dkf_real_t v = kf->x.data[i];
        for (j = 0; j < m; ++j) v += s.Kt[j * n + i] * nu[j];
        s.xn[i] = v;
    }
#if DKF_JOSEPH
    joseph_update(kf, &s, H, R, m);
#else
    simple_update(kf, &s, m);
#endif
    if (!dkf__all_finite(s.xn, n) || !dkf__all_finite(s.B, n * n) || !isfinite(nis))
        return DKF_ERR_NONFINITE;

    dkf__copy(kf->x.data, s.xn, n);
    dkf__copy(kf->P.data, s.B, n * n);
    kf->nu.rows = m;
    kf->S.rows = kf->S.cols = m;
    dkf__copy(kf->nu.data, nu, m);
    dkf__copy(kf->S.data, s.S, m * m);
    kf->nis = nis;
    return DKF_OK;
}
