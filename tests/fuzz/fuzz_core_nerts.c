/*
 * fuzz_core_nerts - seed 001's single-node filters (dkf/nerts.h): a kind
 * (NERTSF, NERTSIF, DNERTSF, DNERTSIF; also an invalid one), dimensions
 * with p = 0 .. 2, init on byte-edited priors, then up to 24 phase calls
 * (predict, local, update, commit_info, step, and an init over the live
 * filter with its own storage and a byte-edited prior: in any order, so
 * out of sequence too) on the lin_x_sin_d model of tests/nerts_fixture.h with
 * byte-edited model matrices, Q, R, z, (Y, y), analytic or differenced
 * Jacobians and callbacks that fail or give NaN (fuzz_core.h, fz_run).
 * Property: a failed call leaves the struct and DKF_NERTS_STATE_LEN reals
 * of storage byte-identical; after a successful one that state is finite
 * and Px, P_pred are exactly symmetric.
 */
#include "dkf/nerts.h"
#include "fuzz_nerts.h"

#define NMAX 4
#define MMAX 4
#define PMAX 2

static dkf_real_t st[DKF_NERTS_STORAGE_LEN(NMAX, MMAX, PMAX)];
static fz_mat_t Y, y;
static fz_node_t o;
static dkf_nerts_t f;
static uint8_t kind;

static void decode(fz_t *z)
{
    kind = fz_byte(z) % 5; /* 4 is not a kind */
    fz_node_decode(z, &o, NMAX, MMAX, PMAX);
}

/* An init with the prior over f's storage: the first, or over the live filter. */
static dkf_status_t init_as(dkf_nerts_kind_t k)
{
    return dkf_nerts_init(&f, k, o.n, o.m, o.p, st, DKF_NERTS_STORAGE_LEN(o.n, o.m, o.p), &o.x0.v,
                          &o.P0.v, FZ_NODE_D(&o, d0), FZ_NODE_D(&o, Pd0), FZ_NODE_D(&o, Pxd0));
}

static dkf_status_t init(void) { return init_as((dkf_nerts_kind_t)kind); }

static void guard(fz_snap_t *s)
{
    fz_region(s, st, DKF_NERTS_STATE_LEN(o.n, o.m, o.p) * sizeof *st);
}

static dkf_status_t op(fz_t *z, uint8_t code, fz_snap_t *s)
{
    fz_mat_t *const info_m[] = {&Y, &y};
    fz_set(&Y, o.n, o.n, DKF_R(2.0), DKF_R(0.1));
    fz_set(&y, o.n, 1, DKF_R(0.4), DKF_R(0.4));
    fz_node_step(z, &o, info_m, 2, (uint8_t)((code >> 3) % 8));
    if (code % 6 == 5) fz_node_prior(z, &o);
    fz_take(s);
    switch (code % 6) {
    case 0: return dkf_nerts_predict(&f, &o.md, NULL, &o.Q.v);
    case 1: return dkf_nerts_local(&f, &o.md, NULL, &o.R.v, &o.zz.v);
    case 2: return dkf_nerts_update(&f);
    case 3: return dkf_nerts_commit_info(&f, &Y.v, &y.v);
    case 4: return dkf_nerts_step(&f, &o.md, NULL, &o.Q.v, NULL, &o.R.v, &o.zz.v);
    default: return init_as(f.kind);
    }
}

static void ok(void)
{
    fz_finite(st, DKF_NERTS_STATE_LEN(o.n, o.m, o.p));
    fz_symmetric(f.Px.data, o.n, 1);
    fz_symmetric(f.P_pred.data, o.n, 1);
}

FZ_HARNESS(f, guard)
