/*
 * fuzz_core_nerts - seed 001's single-node filters (dkf/nerts.h): a kind
 * (NERTSF, NERTSIF, DNERTSF, DNERTSIF; also an invalid one), dimensions
 * with p = 0 .. 2, init on byte-edited priors, then up to 24 phase calls
 * (predict, local, update, commit_info, step, and an init over the live
 * filter with its own storage and a byte-edited prior: in any order, so
 * out of sequence too) on the lin_x_sin_d model of tests/nerts_fixture.h with
 * byte-edited model matrices, Q, R, z, (Y, y), analytic or differenced
 * Jacobians and callbacks that fail or give NaN (fuzz_core.h).
 * Property: a failed call leaves the struct and DKF_NERTS_STATE_LEN reals
 * of storage byte-identical; after a successful one that state is finite
 * and Px, P_pred are exactly symmetric.
 */
#include "dkf/nerts.h"
#include "fuzz_core.h"
#include "../nerts_fixture.h"

#define NMAX 4
#define MMAX 4
#define PMAX 2

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The default prior (x0, P0, d0, Pd0, Pxd0), then byte-chosen edits. */
static void edited_prior(fz_t *z, fz_mat_t *const prior[5], size_t n, size_t p)
{
    fz_nerts_prior(prior, n, p);
    fz_edit(z, prior, 5);
}

/* The model matrix b (r x c, edited) into the model's doubles. */
static void to_model(double *dst, const fz_mat_t *b, size_t r, size_t c)
{
    size_t i;
    for (i = 0; i < r * c; ++i) dst[i] = (double)b->d[i];
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static dkf_real_t st[DKF_NERTS_STORAGE_LEN(NMAX, MMAX, PMAX)];
    static fz_snap_t snap;
    static fz_mat_t x0, P0, d0, Pd0, Pxd0, A, B, C, H, Q, R, zz, Y, y;
    static lxs_t c;
    fz_mat_t *const init_m[] = {&x0, &P0, &d0, &Pd0, &Pxd0};
    fz_mat_t *const step_m[] = {&A, &B, &C, &H, &Q, &R, &zz, &Y, &y};
    fz_t z = {data, size, 0};
    dkf_nerts_t f;
    dkf_nl_model_t md;
    dkf_status_t s;
    size_t n, m, p, op;
    const uint8_t kind = fz_byte(&z) % 5; /* 4 is not a kind */
    n = fz_dim(&z, NMAX);
    m = fz_dim(&z, MMAX);
    p = fz_byte(&z) % (PMAX + 1);
    const int jac = fz_byte(&z) & 1;
    memset(&f, 0, sizeof f);
    edited_prior(&z, init_m, n, p);
    fz_regions_clear(&snap);
    fz_region(&snap, &f, sizeof f);
    fz_take(&snap);
    s = dkf_nerts_init(&f, (dkf_nerts_kind_t)kind, n, m, p, st, DKF_NERTS_STORAGE_LEN(n, m, p),
                       &x0.v, &P0.v, p > 0 ? &d0.v : NULL, p > 0 ? &Pd0.v : NULL,
                       p > 0 ? &Pxd0.v : NULL);
    if (!fz_after(&snap, s)) return 0;
    fz_region(&snap, st, DKF_NERTS_STATE_LEN(n, m, p) * sizeof(dkf_real_t));
    memset(&c, 0, sizeof c);
    c.n = n, c.m = m, c.p = p;
    md = lxs_model(&c, jac);
    for (op = 0; op < 24 && fz_more(&z); ++op) {
        const uint8_t code = fz_byte(&z), fault = (uint8_t)((code >> 3) % 8);
        fz_set(&A, n, n, DKF_R(0.9), DKF_R(0.05));
        fz_set(&B, n, p, DKF_R(0.5), DKF_R(0.1));
        fz_set(&C, m, n, DKF_R(1.0), DKF_R(0.2));
        fz_set(&H, m, p, DKF_R(1.0), DKF_R(0.0));
        fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
        fz_set(&R, m, m, DKF_R(0.5), DKF_R(0.0));
        fz_set(&zz, m, 1, DKF_R(0.3), DKF_R(0.3));
        fz_set(&Y, n, n, DKF_R(2.0), DKF_R(0.1));
        fz_set(&y, n, 1, DKF_R(0.4), DKF_R(0.4));
        fz_edit(&z, step_m, 9);
        to_model(c.A, &A, n, n);
        to_model(c.B, &B, n, p);
        to_model(c.C, &C, m, n);
        to_model(c.H, &H, m, p);
        c.fail_f = fault == 1;
        c.fail_h = fault == 2;
        c.nan_h = fault == 3;
        c.linear = fault == 4;
        if (code % 6 == 5) edited_prior(&z, init_m, n, p);
        fz_take(&snap);
        switch (code % 6) {
        case 0: s = dkf_nerts_predict(&f, &md, NULL, &Q.v); break;
        case 1: s = dkf_nerts_local(&f, &md, NULL, &R.v, &zz.v); break;
        case 2: s = dkf_nerts_update(&f); break;
        case 3: s = dkf_nerts_commit_info(&f, &Y.v, &y.v); break;
        case 4: s = dkf_nerts_step(&f, &md, NULL, &Q.v, NULL, &R.v, &zz.v); break;
        default:
            s = dkf_nerts_init(&f, f.kind, n, m, p, st, DKF_NERTS_STORAGE_LEN(n, m, p), &x0.v,
                               &P0.v, p > 0 ? &d0.v : NULL, p > 0 ? &Pd0.v : NULL,
                               p > 0 ? &Pxd0.v : NULL);
            break;
        }
        if (fz_after(&snap, s)) {
            fz_finite(st, DKF_NERTS_STATE_LEN(n, m, p));
            fz_symmetric(f.Px.data, n, 1);
            fz_symmetric(f.P_pred.data, n, 1);
        }
    }
    return 0;
}
