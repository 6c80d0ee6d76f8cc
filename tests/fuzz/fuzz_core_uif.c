/*
 * fuzz_core_uif - the joint state and input filters (dkf/uif.h): a kind
 * (RTSF, NRTSF-DF, NRTSF; also invalid ones), init, then up to 24 steps on
 * byte-edited models, with or without dynamics (out of sequence when
 * wrong), with H given or not, and rank tolerances changed between steps
 * (fuzz_core.h, fz_run). Property: a failed call leaves the struct and
 * DKF_UIF_STATE_LEN reals of storage (outputs and the decomposition
 * cache) byte-identical; after a successful one the outputs are finite and
 * Px, Pd are exactly symmetric.
 */
#include "dkf/uif.h"
#include "fuzz_core.h"

#define NMAX 4
#define PMAX 3
#define MMAX 4

static dkf_real_t st[DKF_UIF_STORAGE_LEN(NMAX, MMAX, PMAX)];
static fz_mat_t x0, P0, A, G, Q, C, H, R, y;
static dkf_uif_dyn_t dyn = {.F = &A.v, .G = &G.v, .Q = &Q.v};
static dkf_ui_meas_t meas = {.H = &C.v, .R = &R.v};
static dkf_uif_t f;
static size_t n, p, m;
static uint8_t kind;
static int sym;

static void decode(fz_t *z)
{
    kind = fz_byte(z) % 4; /* 3 is not a kind */
    n = fz_dim(z, NMAX);
    p = fz_dim(z, PMAX);
    m = fz_dim(z, MMAX);
    sym = fz_kf_prior(z, &x0, &P0, n);
}

static dkf_status_t init(void)
{
    return dkf_uif_init(&f, (dkf_uif_kind_t)kind, n, m, p, st, DKF_UIF_STORAGE_LEN(n, m, p),
                        &x0.v, &P0.v);
}

static void guard(fz_snap_t *s) { fz_region(s, st, DKF_UIF_STATE_LEN(n, m, p) * sizeof *st); }

static dkf_status_t op(fz_t *z, uint8_t code, fz_snap_t *s)
{
    fz_mat_t *const step_m[] = {&A, &G, &Q, &C, &H, &R, &y};
    int with_dyn = f.kind == DKF_UIF_NRTSF || f.k > 0;
    if (code & 1) with_dyn = !with_dyn; /* out of sequence */
    if (code & 2) f.rank_tol = fz_real(z) * DKF_R(1e-3);
    fz_set(&A, n, n, DKF_R(0.9), DKF_R(0.05));
    fz_set(&G, n, p, DKF_R(1.0), DKF_R(0.0));
    fz_set(&Q, n, n, DKF_R(0.1), DKF_R(0.0));
    fz_set(&C, m, n, DKF_R(1.0), DKF_R(0.0));
    fz_set(&H, m, p, DKF_R(1.0), DKF_R(0.0));
    fz_set(&R, m, m, DKF_R(0.5), DKF_R(0.0));
    fz_set(&y, m, 1, DKF_R(0.3), DKF_R(0.3));
    if (code & 4) { /* G (or H) loses a rank: a column of zeros */
        size_t i;
        for (i = 0; i < n; ++i) G.d[i * p] = DKF_R(0.0);
        for (i = 0; i < m; ++i) H.d[i * p] = DKF_R(0.0);
    }
    fz_edit(z, step_m, 7);
    meas.D = (f.kind == DKF_UIF_NRTSF) != ((code & 8) != 0) ? NULL : &H.v;
    fz_take(s);
    return dkf_uif_step(&f, with_dyn ? &dyn : NULL, &meas, &y.v);
}

static void ok(void)
{
    fz_finite(st, DKF__UIF_OUT_LEN(n, m, p));
    fz_symmetric(f.Px.data, n, sym);
    fz_symmetric(f.Pd.data, p, sym);
}

FZ_HARNESS(f, guard)
