/*
 * fuzz_core_selftune - the seed 002 self-tuning identifier (dkf/selftune.h):
 * init on a byte-chosen configuration (orders, lags, P, noise variances,
 * guards, guesses; any of them may be out of range), then up to 24
 * operations: bursts of 1-64 updates (data from a byte-seeded generator,
 * an AR(2)-like signal plus noise, with one byte-chosen real edited in),
 * estimate, model, autocovariances. Properties: a failed call leaves the
 * struct and DKF_SELFTUNE_STATE_LEN reals of storage (a failed model: F
 * and Q) byte-identical; after a success the state is finite; an estimate
 * with ready = 1 reports no guard and |rho| <= rho_max, one with ready = 0
 * holds the values of the last accepted step; the model's F and Q are
 * finite and Q exactly symmetric.
 */
#include "dkf/selftune.h"
#include "fuzz_core.h"

#define LMAX 6
#define NMAX (DKF_SELFTUNE_MAX_NA + DKF_SELFTUNE_MAX_NP)
#define KMAX 12
#define STLEN DKF_SELFTUNE_STORAGE_LEN(DKF_SELFTUNE_MAX_NA, DKF_SELFTUNE_MAX_NP, 1, KMAX)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* A byte-seeded xorshift32 in [-1, 1). */
static dkf_real_t gen(uint32_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 17;
    *s ^= *s << 5;
    return (dkf_real_t)(*s >> 8) / DKF_R(8388608.0) - DKF_R(1.0);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static dkf_real_t st[STLEN];
    static fz_snap_t snap, out;
    static dkf_real_t Fd[NMAX * NMAX], Qd[NMAX * NMAX];
    fz_t z = {data, size, 0};
    dkf_selftune_t id;
    dkf_selftune_cfg_t c;
    dkf_selftune_est_t e, held;
    dkf_real_t p[DKF_SELFTUNE_MAX_NP], sv[LMAX], y[LMAX], r[KMAX + 1], x1 = 0, x2 = 0;
    dkf_status_t s;
    uint32_t seed;
    size_t i, op, n = 0, len;
    uint8_t flags;
    int have_held = 0;
    (void)dkf_selftune_config_default(&c);
    c.na = fz_dim(&z, DKF_SELFTUNE_MAX_NA + 1) - 1 + (fz_byte(&z) & 1); /* 0..5 */
    c.np = (size_t)(fz_byte(&z) % (DKF_SELFTUNE_MAX_NP + 2));          /* 0..5 */
    c.nc = (size_t)(fz_byte(&z) % 3);                                  /* 0..2 */
    c.lags = c.na + c.nc + (size_t)(fz_byte(&z) % 8) - 1;
    c.L = fz_dim(&z, LMAX);
    c.t_min = (size_t)(fz_byte(&z) % 40);
    flags = fz_byte(&z);
    for (i = 0; i < DKF_SELFTUNE_MAX_NP; ++i) p[i] = (flags & 1) ? fz_real(&z) : DKF_R(0.0);
    p[0] = (flags & 1) ? p[0] : DKF_R(-0.5);
    for (i = 0; i < LMAX; ++i) sv[i] = (flags & 2) ? fz_real(&z) : DKF_R(0.1);
    c.p = p;
    c.sigma_v2 = sv;
    c.sigma_xi2 = (flags & 4) ? fz_real(&z) : DKF_R(0.3);
    if (flags & 8) {
        c.root_max = fz_real(&z);
        c.rho_max = fz_real(&z);
        c.sigma_w2_min = fz_real(&z);
    }
    if (flags & 16) {
        for (i = 0; i < DKF_SELFTUNE_MAX_NA; ++i) c.a0[i] = fz_real(&z);
        c.c0 = fz_real(&z);
        c.sigma_w2_0 = fz_real(&z);
    }
    len = dkf_selftune_storage_len(c.na, c.np, c.nc, c.lags);
    if (len == 0 || len > STLEN || c.lags > KMAX) len = STLEN;
    if (flags & 32) len -= 1;
    seed = 0x9e3779b9u ^ (uint32_t)fz_byte(&z) ^ ((uint32_t)fz_byte(&z) << 8);
    if (seed == 0) seed = 1;
    memset(&id, 0, sizeof id);
    fz_regions_clear(&snap);
    fz_region(&snap, &id, sizeof id);
    fz_take(&snap);
    s = dkf_selftune_init(&id, &c, st, len);
    if (!fz_after(&snap, s)) {
        /* an uninitialised object refuses every call */
        FZ_CHECK(dkf_selftune_update(&id, y) == DKF_ERR_STATE);
        return 0;
    }
    FZ_CHECK(len >= DKF_SELFTUNE_STORAGE_LEN(c.na, c.np, c.nc, c.lags));
    fz_region(&snap, st, DKF_SELFTUNE_STATE_LEN(c.na, c.np, c.nc, c.lags) * sizeof(dkf_real_t));
    FZ_CHECK(dkf_selftune_model_dim(&id, &n) == DKF_OK);
    FZ_CHECK(n <= NMAX);
    for (op = 0; op < 24 && fz_more(&z); ++op) {
        const uint8_t code = fz_byte(&z);
        if (code % 4 <= 1) {
            /* a burst of updates; code % 4 == 1: one element byte-edited */
            const size_t count = 1 + (size_t)(fz_byte(&z) % 64);
            const dkf_real_t amp = (dkf_real_t)(1 + (code >> 2)) / DKF_R(8.0);
            size_t k, bad = SIZE_MAX;
            dkf_real_t badv = DKF_R(0.0);
            if (code % 4 == 1) {
                bad = (size_t)fz_byte(&z) % (count * c.L);
                badv = fz_real(&z);
            }
            for (k = 0; k < count; ++k) {
                const dkf_real_t x0 = DKF_R(1.5) * x1 - DKF_R(0.56) * x2 + gen(&seed);
                x2 = x1;
                x1 = x0;
                for (i = 0; i < c.L; ++i) {
                    y[i] = amp * (x0 + DKF_R(0.3) * gen(&seed));
                    if (k * c.L + i == bad) y[i] = badv;
                }
                fz_take(&snap);
                s = dkf_selftune_update(&id, y);
                if (fz_after(&snap, s))
                    fz_finite(st, DKF_SELFTUNE_STATE_LEN(c.na, c.np, c.nc, c.lags));
                FZ_CHECK(dkf_selftune_estimate(&id, &e) == DKF_OK);
                if (e.ready) {
                    FZ_CHECK(e.guard == DKF_SELFTUNE_GUARD_NONE);
                    FZ_CHECK(e.t_accepted == e.t);
                    FZ_CHECK(e.t >= c.t_min && e.t > c.lags);
                    if (c.nc == 1) FZ_CHECK(DKF_FABS(e.rho_raw) <= c.rho_max);
                    FZ_CHECK(e.sigma_w2 >= c.sigma_w2_min);
                    held = e;
                    have_held = 1;
                } else {
                    FZ_CHECK(e.guard != DKF_SELFTUNE_GUARD_NONE);
                    if (have_held) {
                        FZ_CHECK(memcmp(e.a, held.a, sizeof e.a) == 0);
                        FZ_CHECK(memcmp(&e.sigma_w2, &held.sigma_w2, sizeof e.sigma_w2) == 0);
                        FZ_CHECK(e.t_accepted == held.t_accepted);
                    } else {
                        FZ_CHECK(e.t_accepted == 0);
                    }
                }
            }
        } else if (code % 4 == 2) {
            /* the model of the current estimate, or of an edited one */
            dkf_mat_t F = {n, n, Fd}, Q = {n, n, Qd};
            FZ_CHECK(dkf_selftune_estimate(&id, &e) == DKF_OK);
            if (code & 4) e.a[fz_byte(&z) % DKF_SELFTUNE_MAX_NA] = fz_real(&z);
            if (code & 8) e.sigma_w2 = fz_real(&z);
            if (code & 16) e.c1 = fz_real(&z);
            if (code & 32) F.rows = n + 1;
            if (code & 64) e.nc ^= 1;
            fz_regions_clear(&out);
            fz_region(&out, Fd, sizeof Fd);
            fz_region(&out, Qd, sizeof Qd);
            fz_take(&out);
            s = dkf_selftune_model(&id, &e, &F, &Q);
            if (fz_after(&out, s)) {
                fz_finite(Fd, n * n);
                fz_finite(Qd, n * n);
                fz_symmetric(Qd, n, 1);
            }
        } else {
            fz_take(&snap);
            s = dkf_selftune_autocov(&id, r, (size_t)(code >> 2) % (KMAX + 2));
            if (s == DKF_OK) fz_finite(r, c.lags + 1);
            fz_untouched(&snap);
        }
    }
    return 0;
}
