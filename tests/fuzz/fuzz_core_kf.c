/*
 * fuzz_core_kf - the Kalman filter (dkf/kf.h): init, then up to 24
 * predicts, updates and inits over the live filter (its own storage) on
 * byte-edited models and priors (fuzz_core.h). Property: a failed call
 * leaves the struct and DKF_KF_STATE_LEN reals of storage byte-identical;
 * after a successful one x, P, nu, S and the NIS are finite and P is
 * exactly symmetric.
 */
#include "dkf/kf.h"
#include "fuzz_core.h"

#define NMAX 5
#define MMAX 4

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static dkf_real_t st[DKF_KF_STORAGE_LEN(NMAX, MMAX)];
    static fz_snap_t snap;
    static fz_mat_t x0, P0, F, Q, u, H, R, y;
    fz_mat_t *const init_m[] = {&x0, &P0}, *const pred_m[] = {&F, &Q, &u},
                    *const upd_m[] = {&H, &R, &y};
    fz_t z = {data, size, 0};
    dkf_kf_t kf;
    dkf_status_t s;
    size_t n, mmax, m, op;
    n = fz_dim(&z, NMAX);
    mmax = fz_dim(&z, MMAX);
    memset(&kf, 0, sizeof kf);
    fz_set(&x0, n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(&P0, n, n, DKF_R(1.0), DKF_R(0.1));
    fz_edit(&z, init_m, 2);
    /* a non-symmetric prior is accepted (one triangle is read): then no
     * symmetry is promised */
    int sym = P0.v.data == NULL || fz_is_symmetric(P0.v.data, P0.v.rows);
    /* a failed init never writes *kf */
    fz_regions_clear(&snap);
    fz_region(&snap, &kf, sizeof kf);
    fz_take(&snap);
    s = dkf_kf_init(&kf, n, mmax, st, DKF_KF_STORAGE_LEN(n, mmax), &x0.v, &P0.v);
    if (!fz_after(&snap, s)) return 0;
    fz_regions_clear(&snap);
    fz_region(&snap, &kf, sizeof kf);
    fz_region(&snap, st, DKF_KF_STATE_LEN(n, mmax) * sizeof(dkf_real_t));
    for (op = 0; op < 24 && fz_more(&z); ++op) {
        const uint8_t code = fz_byte(&z);
        if (code % 5 == 4) { /* a new prior over the live filter */
            fz_set(&x0, n, 1, DKF_R(0.5), DKF_R(0.5));
            fz_set(&P0, n, n, DKF_R(1.0), DKF_R(0.1));
            fz_edit(&z, init_m, 2);
            fz_take(&snap);
            s = dkf_kf_init(&kf, n, mmax, st, DKF_KF_STORAGE_LEN(n, mmax), &x0.v, &P0.v);
            if (s == DKF_OK) sym = fz_is_symmetric(P0.v.data, n);
        } else if (code % 2 == 0) {
            fz_set(&F, n, n, DKF_R(1.0), DKF_R(0.05));
            fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
            fz_set(&u, n, 1, DKF_R(0.0), DKF_R(0.01));
            fz_edit(&z, pred_m, 3);
            fz_take(&snap);
            s = dkf_kf_predict(&kf, &(dkf_kf_dyn_t){&F.v, &Q.v}, code & 2 ? &u.v : NULL);
        } else {
            m = 1 + (size_t)(code >> 1) % mmax;
            fz_set(&H, m, n, DKF_R(1.0), DKF_R(0.0));
            fz_set(&R, m, m, DKF_R(0.5), DKF_R(0.0));
            fz_set(&y, m, 1, DKF_R(0.3), DKF_R(0.3));
            fz_edit(&z, upd_m, 3);
            fz_take(&snap);
            s = dkf_kf_update(&kf, &(dkf_kf_meas_t){&H.v, &R.v}, &y.v);
        }
        if (fz_after(&snap, s)) {
            fz_finite(st, DKF_KF_STATE_LEN(n, mmax));
            fz_finite(&kf.nis, 1);
            fz_symmetric(kf.P.data, n, sym);
        }
    }
    return 0;
}
