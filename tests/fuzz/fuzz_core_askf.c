/*
 * fuzz_core_askf - the ASKF (dkf/askf.h): init, then up to 24 predicts,
 * updates and inits over the live filter (its own storage) on byte-edited
 * unknown-input models and priors (fuzz_core.h). Property: a failed call
 * leaves the struct and the state part of the storage byte-identical (a
 * failed first init: the struct); after a successful one the state is
 * finite and the covariances are exactly symmetric.
 */
#include "dkf/askf.h"
#include "fuzz_core.h"

#define NMAX 4
#define MMAX 4
#define PMAX 3

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The default prior (x0, P0, d0, Pd0), then byte-chosen edits. */
static void edited_prior(fz_t *z, fz_mat_t *const prior[4], size_t n, size_t p)
{
    fz_set(prior[0], n, 1, DKF_R(0.5), DKF_R(0.5));
    fz_set(prior[1], n, n, DKF_R(1.0), DKF_R(0.1));
    fz_set(prior[2], p, 1, DKF_R(0.1), DKF_R(0.1));
    fz_set(prior[3], p, p, DKF_R(1.0), DKF_R(0.0));
    fz_edit(z, prior, 4);
}

/* 1 if both covariances of a prior are exactly symmetric (or missing). */
static int prior_symmetric(const fz_mat_t *P0, const fz_mat_t *Pd0)
{
    return (P0->v.data == NULL || fz_is_symmetric(P0->v.data, P0->v.rows)) &&
           (Pd0->v.data == NULL || fz_is_symmetric(Pd0->v.data, Pd0->v.rows));
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static dkf_real_t st[DKF_ASKF_STORAGE_LEN(NMAX, MMAX, PMAX)];
    static fz_snap_t snap;
    static fz_mat_t x0, P0, d0, Pd0;
    static fz_ui_t u;
    fz_mat_t *const init_m[] = {&x0, &P0, &d0, &Pd0};
    fz_t z = {data, size, 0};
    dkf_askf_t f;
    dkf_status_t s;
    size_t n, m, p, op;
    n = fz_dim(&z, NMAX);
    m = fz_dim(&z, MMAX);
    p = fz_dim(&z, PMAX);
    memset(&f, 0, sizeof f);
    edited_prior(&z, init_m, n, p);
    /* a non-symmetric prior is accepted (one triangle is read): then no
     * symmetry is promised */
    int sym = prior_symmetric(&P0, &Pd0);
    fz_regions_clear(&snap);
    fz_region(&snap, &f, sizeof f);
    fz_take(&snap);
    s = dkf_askf_init(&f, n, m, p, st, DKF_ASKF_STORAGE_LEN(n, m, p), &x0.v, &P0.v, &d0.v, &Pd0.v,
                      NULL);
    if (!fz_after(&snap, s)) return 0;
    fz_region(&snap, st, DKF_ASKF_STATE_LEN(n, m, p) * sizeof(dkf_real_t));
    for (op = 0; op < 24 && fz_more(&z); ++op) {
        const uint8_t code = fz_byte(&z);
        if (code % 5 == 4) { /* a new prior over the live filter */
            edited_prior(&z, init_m, n, p);
            fz_take(&snap);
            s = dkf_askf_init(&f, n, m, p, st, DKF_ASKF_STORAGE_LEN(n, m, p), &x0.v, &P0.v, &d0.v,
                              &Pd0.v, NULL);
            if (s == DKF_OK) sym = prior_symmetric(&P0, &Pd0);
        } else {
            fz_ui_default(&u, n, m, p);
            fz_ui_edit(&z, &u, code % 2 == 0);
            fz_take(&snap);
            s = code % 2 == 0 ? dkf_askf_predict(&f, &u.dyn)
                              : dkf_askf_update(&f, &u.meas, &u.y.v);
        }
        if (fz_after(&snap, s)) {
            fz_finite(st, DKF_ASKF_STATE_LEN(n, m, p));
            fz_symmetric(f.kf.P.data, n + p, sym);
        }
    }
    return 0;
}
