/*
 * fuzz_core_diffkf - the Difference KF (dkf/diffkf.h): init, start, then
 * up to 24 one-phase steps, masked gains, updates with z, checkpoint
 * restores (of a byte-edited checkpoint), the steady gain switched on and
 * off, and out-of-sequence calls, on byte-edited models (fuzz_core.h).
 * Property: a failed call leaves the
 * struct and DKF_DIFFKF_STATE_LEN reals of storage byte-identical, and the
 * pending gain (DKF_DIFFKF_PENDING_LEN more) while one is pending, except
 * that a failed gain sets pending = 0, pk = z.rows as documented; after a
 * successful call the state is finite and P_{k|k}, P_{k+1|k} are exactly
 * symmetric.
 */
#include "dkf/diffkf.h"
#include "fuzz_core.h"

#define NMAX 4
#define MMAX 4
#define PMAX 3

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_ok(const dkf_diffkf_t *f, const dkf_real_t *st, int sym)
{
    fz_finite(st, DKF_DIFFKF_STATE_LEN(f->n, f->m, f->p));
    fz_symmetric(f->Pf.data, f->n, sym);
    fz_symmetric(f->Pn.data, f->n, sym);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static dkf_real_t st[DKF_DIFFKF_STORAGE_LEN(NMAX, MMAX, PMAX)];
    static dkf_real_t ck[DKF_DIFFKF_STORAGE_LEN(NMAX, MMAX, PMAX)];
    static fz_snap_t snap;
    static fz_mat_t x0, P0, zv, yv;
    static fz_ui_t u;
    fz_mat_t *const init_m[] = {&x0, &P0}, *const z_m[] = {&zv, &yv};
    fz_t z = {data, size, 0};
    dkf_diffkf_t f, before;
    dkf_status_t s;
    unsigned char rows[PMAX];
    size_t n, m, p, op, i, cklen = 0;
    n = fz_dim(&z, NMAX);
    m = fz_dim(&z, MMAX);
    p = fz_dim(&z, PMAX);
    memset(&f, 0, sizeof f);
    fz_set(&x0, n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(&P0, n, n, DKF_R(1.0), DKF_R(0.1));
    fz_edit(&z, init_m, 2);
    /* a non-symmetric prior is accepted (one triangle is read): then no
     * symmetry is promised */
    int sym = P0.v.data == NULL || fz_is_symmetric(P0.v.data, P0.v.rows);
    fz_regions_clear(&snap);
    fz_region(&snap, &f, sizeof f);
    fz_take(&snap);
    s = dkf_diffkf_init(&f, n, m, p, st, DKF_DIFFKF_STORAGE_LEN(n, m, p), &x0.v, &P0.v);
    if (!fz_after(&snap, s)) return 0;
    for (op = 0; op < 24 && fz_more(&z); ++op) {
        const uint8_t code = fz_byte(&z);
        fz_regions_clear(&snap);
        fz_region(&snap, &f, sizeof f);
        fz_region(&snap, st,
                  (DKF_DIFFKF_STATE_LEN(n, m, p) + (f.pending ? DKF_DIFFKF_PENDING_LEN(n, m, p) : 0)) *
                      sizeof(dkf_real_t));
        fz_ui_default(&u, n, m, p);
        fz_ui_edit(&z, &u, 1);
        fz_ui_edit(&z, &u, 0);
        before = f;
        switch (code % 6) {
        case 0: /* start, with (F0, Q0) or with the prior as x_{1|0} */
            fz_take(&snap);
            s = code & 8 ? dkf_diffkf_start(&f, &u.F.v, &u.Q.v, &u.meas, &u.y.v)
                         : dkf_diffkf_start(&f, NULL, NULL, &u.meas, code & 16 ? NULL : &u.y.v);
            break;
        case 1:
        case 2: /* one-phase step */
            fz_take(&snap);
            s = dkf_diffkf_step(&f, &u.dyn, &u.meas, &u.y.v);
            break;
        case 3: /* masked gain: a failure may only cancel a pending gain */
            for (i = 0; i < p; ++i) rows[i] = (unsigned char)((code >> (3 + i)) & 1);
            fz_regions_clear(&snap);
            fz_region(&snap, st, DKF_DIFFKF_STATE_LEN(n, m, p) * sizeof(dkf_real_t));
            fz_take(&snap);
            s = dkf_diffkf_gain_masked(&f, &u.dyn, &u.meas, code & 128 ? NULL : rows);
            if (s != DKF_OK) {
                before.pending = 0;
                before.pk = before.z.rows;
                FZ_CHECK(memcmp(&before, &f, sizeof f) == 0);
            }
            break;
        case 4: /* the update of a pending gain with z (pk rows) */
            fz_set(&zv, f.pk, 1, DKF_R(0.1), DKF_R(0.1));
            fz_set(&yv, m, 1, DKF_R(0.2), DKF_R(0.2));
            fz_edit(&z, z_m, 2);
            fz_take(&snap);
            s = dkf_diffkf_update_z(&f, f.pk == 0 && (code & 8) ? NULL : &zv.v,
                                    code & 16 ? NULL : &yv.v);
            break;
        default: /* the steady gain on (tol 0.5: it settles often) or off; or save a
                  checkpoint, or restore a byte-edited one */
            if ((code & 192) == 192) {
                FZ_CHECK(dkf_diffkf_set_steady(&f, f.priv.steady_tol > 0 ? DKF_R(0.0) : DKF_R(0.5)) ==
                         DKF_OK);
                continue;
            }
            if (code & 8) {
                cklen = dkf_diffkf_checkpoint_len(&f);
                FZ_CHECK(cklen <= sizeof ck / sizeof ck[0]);
                FZ_CHECK(dkf_diffkf_save(&f, ck, cklen) == DKF_OK);
                continue;
            }
            i = fz_ckpt_restore_len(&z, code, ck, cklen, &sym);
            if (i == 0) continue;
            fz_take(&snap);
            s = dkf_diffkf_restore(&f, ck, i);
            break;
        }
        if (fz_after(&snap, s)) check_ok(&f, st, sym);
    }
    return 0;
}
