/*
 * Linear Kalman filter, covariance form (dkf/kf.h): the entry points,
 * which check their arguments and run the step (kf_step.h) of the
 * instance for this CPU.
 */
#include "peel.h" /* first: before any definition */

#include "dkf/kf.h"

#include "kf_step.h"

dkf_status_t dkf_kf_init(dkf_kf_t *kf, size_t n, size_t m_max, dkf_real_t *storage,
                         size_t storage_len, const dkf_mat_t *x0, const dkf_mat_t *P0)
{
    kf_layout_t L;
    size_t i;
    DKF_CHECK_NULL(kf);
    DKF_CHECK_NULL(storage);
    if (n == 0 || m_max == 0 || n > DKF_MAX_DIM || m_max > DKF_MAX_DIM) return DKF_ERR_CAPACITY;
    if (storage_len < kf_layout(&L, NULL, n, m_max)) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_input(x0, n, 1));
    DKF_TRY(dkf__check_input(P0, n, n));
    /* P0 must be SPD: factored in the scratch W (2 max(n^2, n m) >= n^2 + n
     * reals), so a refused P0 leaves the state part of the storage, a live
     * filter's included, as it was */
    (void)kf_layout(&L, storage, n, m_max);
    if (dkf__chol(L.W, L.W + n * n, P0->data, n) != 0) return DKF_ERR_NOT_SPD;

    kf->n = n;
    kf->m_max = m_max;
    dkf__view(&kf->x, n, 1, L.x);
    dkf__view(&kf->P, n, n, L.P);
    dkf__view(&kf->nu, m_max, 1, L.nu);
    dkf__view(&kf->S, m_max, m_max, L.S);
    kf->priv.work = L.xn;
    dkf__copy(kf->x.data, x0->data, n);
    dkf__copy(kf->P.data, P0->data, n * n);
    for (i = 0; i < m_max * (m_max + 1); ++i) kf->nu.data[i] = DKF_R(0.0);
    kf->nis = DKF_R(0.0);
    kf->priv.ready = 1;
    return DKF_OK;
}

/* Whether a step of state size n takes the AVX instance: where the CPU
 * has AVX, from n = 6. Below, its 4-wide vectors cover the 2-wide blocks
 * of m = 2 poorly: at (n, m) = (4, 2) the AVX step took 240.7-251.6 ns
 * against the baseline's 186.2-216.2 (6 rounds, 2026-12-05), while at n = 6 (the ASKF's
 * augmented step of seed 000), 8 and 12 it is faster (docs/results/bench.md). */
static int kf_use_avx(size_t n)
{
    return n >= 6 && dkf__isa_avx();
}

dkf_status_t dkf__kf_predict_isa(int avx, dkf_kf_t *kf, const dkf_real_t *F, const dkf_real_t *Q,
                                 const dkf_real_t *u)
{
#if DKF__KF_AVX
    if (avx) return dkf__kf_predict_avx(kf, F, Q, u);
#else
    (void)avx;
#endif
    return predict_any(kf, F, Q, u);
}

dkf_status_t dkf__kf_update_isa(int avx, dkf_kf_t *kf, const dkf_real_t *H, const dkf_real_t *R,
                                const dkf_real_t *y, size_t m)
{
#if DKF__KF_AVX
    if (avx) return dkf__kf_update_avx(kf, H, R, y, m);
#else
    (void)avx;
#endif
    return update_any(kf, H, R, y, m);
}

dkf_status_t dkf_kf_predict(dkf_kf_t *kf, const dkf_kf_dyn_t *dyn, const dkf_mat_t *u)
{
    const dkf_real_t *ud = NULL;
    const dkf_mat_t *F, *Q;
    size_t n;
    DKF_CHECK_NULL(kf);
    if (!kf->priv.ready) return DKF_ERR_STATE;
    DKF_CHECK_NULL(dyn);
    F = dyn->F;
    Q = dyn->Q;
    n = kf->n;
    /* shapes here; finiteness in the step (kf_step.h) */
    DKF_TRY(dkf__check_shape(F, n, n));
    DKF_TRY(dkf__check_shape(Q, n, n));
    if (u != NULL) {
        DKF_TRY(dkf__check_shape(u, n, 1));
        ud = u->data;
    }
    return dkf__kf_predict_isa(kf_use_avx(n), kf, F->data, Q->data, ud);
}

dkf_status_t dkf_kf_update(dkf_kf_t *kf, const dkf_kf_meas_t *meas, const dkf_mat_t *y)
{
    const dkf_mat_t *H, *R;
    size_t n, m;
    DKF_CHECK_NULL(kf);
    if (!kf->priv.ready) return DKF_ERR_STATE;
    DKF_CHECK_NULL(meas);
    H = meas->H;
    R = meas->R;
    n = kf->n;
    DKF_TRY(dkf__check_mat(H));
    m = H->rows;
    if (m > kf->m_max) return DKF_ERR_CAPACITY;
    DKF_TRY(dkf__check_shape(H, m, n));
    DKF_TRY(dkf__check_shape(R, m, m));
    DKF_TRY(dkf__check_shape(y, m, 1));
    return dkf__kf_update_isa(kf_use_avx(n), kf, H->data, R->data, y->data, m);
}
