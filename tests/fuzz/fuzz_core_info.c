/*
 * fuzz_core_info - the information filter (dkf/info.h): init, then up to
 * 24 predicts, contributions and fusions of 0-2 contributions, on
 * byte-edited inputs (fuzz_core.h, fz_run). Property: a failed call leaves
 * the struct and DKF_INFO_STATE_LEN reals of storage (a failed
 * contribution: its outputs i, I) byte-identical; after a successful one
 * x, P, y, Y are finite and Y is exactly symmetric.
 */
#include "dkf/info.h"
#include "fuzz_core.h"

#define NMAX 5
#define MMAX 4

static dkf_real_t st[DKF_INFO_STORAGE_LEN(NMAX)];
static dkf_real_t work[DKF_INFO_CONTRIB_WORK(NMAX + 1, MMAX + 1)];
static fz_snap_t out;
static fz_mat_t x0, P0, F, Q, C, R, zm, ci[2], cI[2];
static dkf_info_t f;
static size_t n;
static int sym;

/* Both contribution slots back to their defaults (i = 0.1, I = identity). */
static void reset_contributions(void)
{
    size_t j;
    for (j = 0; j < 2; ++j) {
        fz_set(&ci[j], n, 1, DKF_R(0.0), DKF_R(0.1));
        fz_set(&cI[j], n, n, DKF_R(1.0), DKF_R(0.0));
    }
}

static void decode(fz_t *z)
{
    n = fz_dim(z, NMAX);
    sym = fz_kf_prior(z, &x0, &P0, n);
    reset_contributions();
}

static dkf_status_t init(void) { return dkf_info_init(&f, n, st, DKF_INFO_STORAGE_LEN(n), &x0.v, &P0.v); }

static void guard(fz_snap_t *s) { fz_region(s, st, DKF_INFO_STATE_LEN(n) * sizeof *st); }

/* A sensor's contribution into slot j (touches no filter): an error leaves
 * the slot's outputs untouched, a success gives finite outputs and an
 * exactly symmetric I. */
static void contribution(fz_t *z, size_t j)
{
    fz_mat_t *const con_m[] = {&C, &R, &zm};
    const size_t m = fz_dim(z, MMAX);
    fz_set(&C, m, n, DKF_R(1.0), DKF_R(0.0));
    fz_set(&R, m, m, DKF_R(0.5), DKF_R(0.0));
    fz_set(&zm, m, 1, DKF_R(0.2), DKF_R(0.2));
    fz_edit(z, con_m, 3);
    fz_regions_clear(&out);
    fz_region(&out, ci[j].d, sizeof ci[j].d);
    fz_region(&out, cI[j].d, sizeof cI[j].d);
    fz_take(&out);
    if (fz_after(&out, dkf_info_contribution(&ci[j].v, &cI[j].v, &(dkf_kf_meas_t){&C.v, &R.v},
                                             &zm.v, work))) {
        fz_finite(ci[j].d, n);
        fz_finite(cI[j].d, n * n);
        fz_symmetric(cI[j].d, n, 1);
    }
}

static dkf_status_t op(fz_t *z, uint8_t code, fz_snap_t *s)
{
    dkf_status_t r;
    if (code % 3 == 0) {
        fz_mat_t *const pred_m[] = {&F, &Q};
        fz_set(&F, n, n, DKF_R(1.0), DKF_R(0.05));
        fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
        fz_edit(z, pred_m, 2);
        fz_take(s);
        return dkf_info_predict(&f, &(dkf_kf_dyn_t){&F.v, &Q.v});
    }
    if (code % 3 == 1) { /* checked by contribution itself */
        contribution(z, (code >> 2) & 1);
        return FZ_SKIP;
    }
    {
        fz_mat_t *const fuse_m[] = {&ci[0], &ci[1], &cI[0], &cI[1]};
        const dkf_mat_t iv[2] = {ci[0].v, ci[1].v}, Iv[2] = {cI[0].v, cI[1].v};
        fz_edit(z, fuse_m, 4);
        fz_take(s);
        r = dkf_info_fuse(&f, iv, Iv, (size_t)(code >> 2) % 3);
        reset_contributions();
        return r;
    }
}

static void ok(void)
{
    fz_finite(st, DKF_INFO_STATE_LEN(n));
    fz_symmetric(f.Y.data, n, sym);
}

FZ_HARNESS(f, guard)
