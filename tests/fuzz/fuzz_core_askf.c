/*
 * fuzz_core_askf - the ASKF (dkf/askf.h): init, then up to 24 predicts,
 * updates and inits over the live filter (its own storage) on byte-edited
 * unknown-input models and priors (fuzz_core.h, fz_run). Property: a failed
 * call leaves the struct and the state part of the storage byte-identical
 * (a failed first init: the struct); after a successful one the state is
 * finite and the covariances are exactly symmetric.
 */
#include "dkf/askf.h"
#include "fuzz_core.h"

#define NMAX 4
#define MMAX 4
#define PMAX 3

static dkf_real_t st[DKF_ASKF_STORAGE_LEN(NMAX, MMAX, PMAX)];
static fz_mat_t x0, P0, d0, Pd0;
static fz_mat_t *const prior_m[] = {&x0, &P0, &d0, &Pd0};
static fz_ui_t u;
static dkf_askf_t f;
static size_t n, m, p;
static int sym;

static void decode(fz_t *z)
{
    fz_nmp(z, &n, &m, &p, NMAX, MMAX, PMAX);
    sym = fz_ui_prior(z, prior_m, n, p);
}

static dkf_status_t init(void)
{
    return dkf_askf_init(&f, n, m, p, st, DKF_ASKF_STORAGE_LEN(n, m, p), &x0.v, &P0.v, &d0.v,
                         &Pd0.v, NULL);
}

static void guard(fz_snap_t *s) { fz_region(s, st, DKF_ASKF_STATE_LEN(n, m, p) * sizeof *st); }

static dkf_status_t op(fz_t *z, uint8_t code, fz_snap_t *s)
{
    dkf_status_t r;
    if (code % 5 == 4) { /* a new prior over the live filter */
        const int psym = fz_ui_prior(z, prior_m, n, p);
        fz_take(s);
        r = init();
        if (r == DKF_OK) sym = psym;
        return r;
    }
    fz_ui_default(&u, n, m, p);
    fz_ui_edit(z, &u, code % 2 == 0);
    fz_take(s);
    return code % 2 == 0 ? dkf_askf_predict(&f, &u.dyn) : dkf_askf_update(&f, &u.meas, &u.y.v);
}

static void ok(void)
{
    fz_finite(st, DKF_ASKF_STATE_LEN(n, m, p));
    fz_symmetric(f.kf.P.data, n + p, sym);
}

FZ_HARNESS(f, guard)
