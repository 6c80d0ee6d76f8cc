/*
 * fuzz_core_diffkf - the Difference KF (dkf/diffkf.h): init, start, then
 * up to 24 one-phase steps, masked gains, updates with z, checkpoint
 * restores (of a byte-edited checkpoint), the steady gain switched on and
 * off, and out-of-sequence calls, on byte-edited models (fuzz_core.h,
 * fz_run). Property: a failed call leaves the struct and
 * DKF_DIFFKF_STATE_LEN reals of storage byte-identical, and the pending
 * gain (DKF_DIFFKF_PENDING_LEN more) while one is pending, except that a
 * failed gain sets pending = 0, pk = z.rows as documented; after a
 * successful call the state is finite and P_{k|k}, P_{k+1|k} are exactly
 * symmetric.
 */
#include "dkf/diffkf.h"
#include "fuzz_core.h"

#define NMAX 4
#define MMAX 4
#define PMAX 3

static dkf_real_t st[DKF_DIFFKF_STORAGE_LEN(NMAX, MMAX, PMAX)];
static dkf_real_t ck[DKF_DIFFKF_STORAGE_LEN(NMAX, MMAX, PMAX)];
static fz_mat_t x0, P0, zv, yv;
static fz_ui_t u;
static dkf_diffkf_t f;
static size_t n, m, p, cklen;
static int sym;

static void decode(fz_t *z)
{
    fz_nmp(z, &n, &m, &p, NMAX, MMAX, PMAX);
    sym = fz_kf_prior(z, &x0, &P0, n);
    cklen = 0;
}

static dkf_status_t init(void)
{
    return dkf_diffkf_init(&f, n, m, p, st, DKF_DIFFKF_STORAGE_LEN(n, m, p), &x0.v, &P0.v);
}

/* A masked gain: a failure may only cancel a pending gain (the struct then
 * differs from before only in pending = 0, pk = z.rows). */
static dkf_status_t gain_masked(uint8_t code, fz_snap_t *s)
{
    dkf_diffkf_t before = f;
    unsigned char rows[PMAX];
    dkf_status_t r;
    size_t i;
    for (i = 0; i < p; ++i) rows[i] = (unsigned char)((code >> (3 + i)) & 1);
    fz_regions_clear(s);
    fz_region(s, st, DKF_DIFFKF_STATE_LEN(n, m, p) * sizeof *st);
    fz_take(s);
    r = dkf_diffkf_gain_masked(&f, &u.dyn, &u.meas, code & 128 ? NULL : rows);
    if (r != DKF_OK) {
        before.pending = 0;
        before.pk = before.z.rows;
        FZ_CHECK(memcmp(&before, &f, sizeof f) == 0);
    }
    return r;
}

/* The steady gain on (tol 0.5: it settles often) or off; or save a
 * checkpoint, or restore a byte-edited one. */
static dkf_status_t steady_or_checkpoint(fz_t *z, uint8_t code, fz_snap_t *s)
{
    size_t len;
    if ((code & 192) == 192) {
        FZ_CHECK(dkf_diffkf_set_steady(&f, f.priv.steady_tol > 0 ? DKF_R(0.0) : DKF_R(0.5)) == DKF_OK);
        return FZ_SKIP;
    }
    if (code & 8) {
        cklen = dkf_diffkf_checkpoint_len(&f);
        FZ_CHECK(cklen <= sizeof ck / sizeof ck[0]);
        FZ_CHECK(dkf_diffkf_save(&f, ck, cklen) == DKF_OK);
        return FZ_SKIP;
    }
    len = fz_ckpt_restore_len(z, code, ck, cklen, &sym);
    if (len == 0) return FZ_SKIP;
    fz_take(s);
    return dkf_diffkf_restore(&f, ck, len);
}

static dkf_status_t op(fz_t *z, uint8_t code, fz_snap_t *s)
{
    fz_mat_t *const z_m[] = {&zv, &yv};
    fz_regions_clear(s);
    fz_region(s, &f, sizeof f);
    fz_region(s, st,
              (DKF_DIFFKF_STATE_LEN(n, m, p) + (f.pending ? DKF_DIFFKF_PENDING_LEN(n, m, p) : 0)) *
                  sizeof *st);
    fz_ui_default(&u, n, m, p);
    fz_ui_edit(z, &u, 1);
    fz_ui_edit(z, &u, 0);
    switch (code % 6) {
    case 0: /* start, with (F0, Q0) or with the prior as x_{1|0} */
        fz_take(s);
        return code & 8 ? dkf_diffkf_start(&f, &u.F.v, &u.Q.v, &u.meas, &u.y.v)
                        : dkf_diffkf_start(&f, NULL, NULL, &u.meas, code & 16 ? NULL : &u.y.v);
    case 1:
    case 2: /* one-phase step */
        fz_take(s);
        return dkf_diffkf_step(&f, &u.dyn, &u.meas, &u.y.v);
    case 3: return gain_masked(code, s);
    case 4: /* the update of a pending gain with z (pk rows) */
        fz_set(&zv, f.pk, 1, DKF_R(0.1), DKF_R(0.1));
        fz_set(&yv, m, 1, DKF_R(0.2), DKF_R(0.2));
        fz_edit(z, z_m, 2);
        fz_take(s);
        return dkf_diffkf_update_z(&f, f.pk == 0 && (code & 8) ? NULL : &zv.v,
                                   code & 16 ? NULL : &yv.v);
    default: return steady_or_checkpoint(z, code, s);
    }
}

static void ok(void)
{
    fz_finite(st, DKF_DIFFKF_STATE_LEN(n, m, p));
    fz_symmetric(f.Pf.data, n, sym);
    fz_symmetric(f.Pn.data, n, sym);
}

FZ_HARNESS(f, NULL)
