/*
 * fuzz_core_kf - the Kalman filter (dkf/kf.h): init, then up to 24
 * predicts, updates and inits over the live filter (its own storage) on
 * byte-edited models and priors (fuzz_core.h, fz_run). Property: a failed
 * call leaves the struct and DKF_KF_STATE_LEN reals of storage
 * byte-identical; after a successful one x, P, nu, S and the NIS are
 * finite and P is exactly symmetric.
 */
#include "dkf/kf.h"
#include "fuzz_core.h"

#define NMAX 5
#define MMAX 4

static dkf_real_t st[DKF_KF_STORAGE_LEN(NMAX, MMAX)];
static fz_mat_t x0, P0, F, Q, u, H, R, y;
static dkf_kf_t kf;
static size_t n, mmax;
static int sym;

static void decode(fz_t *z)
{
    n = fz_dim(z, NMAX);
    mmax = fz_dim(z, MMAX);
    sym = fz_kf_prior(z, &x0, &P0, n);
}

static dkf_status_t init(void)
{
    return dkf_kf_init(&kf, n, mmax, st, DKF_KF_STORAGE_LEN(n, mmax), &x0.v, &P0.v);
}

static void guard(fz_snap_t *s) { fz_region(s, st, DKF_KF_STATE_LEN(n, mmax) * sizeof *st); }

static dkf_status_t op(fz_t *z, uint8_t code, fz_snap_t *s)
{
    if (code % 5 == 4) { /* a new prior over the live filter */
        const int psym = fz_kf_prior(z, &x0, &P0, n);
        dkf_status_t r;
        fz_take(s);
        r = init();
        if (r == DKF_OK) sym = psym;
        return r;
    }
    if (code % 2 == 0) {
        fz_mat_t *const pred_m[] = {&F, &Q, &u};
        fz_set(&F, n, n, DKF_R(1.0), DKF_R(0.05));
        fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
        fz_set(&u, n, 1, DKF_R(0.0), DKF_R(0.01));
        fz_edit(z, pred_m, 3);
        fz_take(s);
        return dkf_kf_predict(&kf, &(dkf_kf_dyn_t){&F.v, &Q.v}, code & 2 ? &u.v : NULL);
    } else {
        fz_mat_t *const upd_m[] = {&H, &R, &y};
        const size_t m = 1 + (size_t)(code >> 1) % mmax;
        fz_set(&H, m, n, DKF_R(1.0), DKF_R(0.0));
        fz_set(&R, m, m, DKF_R(0.5), DKF_R(0.0));
        fz_set(&y, m, 1, DKF_R(0.3), DKF_R(0.3));
        fz_edit(z, upd_m, 3);
        fz_take(s);
        return dkf_kf_update(&kf, &(dkf_kf_meas_t){&H.v, &R.v}, &y.v);
    }
}

static void ok(void)
{
    fz_finite(st, DKF_KF_STATE_LEN(n, mmax));
    fz_finite(&kf.nis, 1);
    fz_symmetric(kf.P.data, n, sym);
}

FZ_HARNESS(kf, guard)
