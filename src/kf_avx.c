/*
 * src/kf_avx.c - the Kalman step (kf_step.h) compiled for AVX, on x86-64
 * under GCC in double (DKF__KF_AVX); dkf_kf_predict and dkf_kf_update
 * call it when the CPU has AVX (dkf__isa_avx). The target pragma comes
 * before any definition, so every function here is AVX code while the
 * library is built for the baseline ISA. The kernels' vectors are 32
 * bytes (4 doubles, DKF__VEC_BYTES), and no FMA is enabled: each lane does
 * the baseline's IEEE product or sum in its order, so both instances
 * return the same bits (kf_paths_identical, docs/decisions.md item 25).
 */
#include "peel.h" /* first: before any definition */

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#pragma GCC target("avx")
#endif

#include "kernels.h"

#if DKF__AVX && !DKF_USE_FLOAT /* = DKF__KF_AVX, which kf_step.h defines after this choice */
#define DKF__VEC_BYTES 32
#include "kf_step.h"

dkf_status_t dkf__kf_predict_avx(dkf_kf_t *kf, const dkf_real_t *F, const dkf_real_t *Q,
                                 const dkf_real_t *u)
{
    return predict_any(kf, F, Q, u);
}

dkf_status_t dkf__kf_update_avx(dkf_kf_t *kf, const dkf_real_t *H, const dkf_real_t *R,
                                const dkf_real_t *y, size_t m)
{
    return update_any(kf, H, R, y, m);
}
#else
typedef int dkf__kf_avx_unused; /* ISO C: a translation unit is not empty */
#endif
