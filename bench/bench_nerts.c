/*
 * bench/bench_nerts.c - per-step cost of seed 001's nonlinear unknown-input
 * information filters against the plain filters of the same size, in ONE
 * run (dkf/nerts.h):
 *
 *   nerts-nertsif    NERTSIF (Algorithm 1, EKF, information form), p = 1
 *   nerts-dnertsif   DNERTSIF (Algorithm 2, cubature, information form), p = 1
 *   nerts-ekf        a plain EKF: NERTSF with p = 0 (covariance form; with
 *                    no unknown input its equations are the EKF's)
 *   nerts-ckf        a plain cubature KF: DNERTSF with p = 0
 *
 * Model: seed 001's constant-turn target (eq. 62, T = 1), n = 4, seen by
 * one radar at (20, -40); m = 3.
 *   unknown-input filters: d = omega (p = 1), z = [range, bearing, 10 omega]
 *   plain filters: omega fixed at -3 deg/s (p = 0), z = [range, bearing,
 *   range from a second radar at (60, -40)]
 * Q = Gamma (0.04 I2) Gamma^T, R = diag(0.04, 2.25e-4, 8.8e-8) (plain:
 * diag(0.04, 2.25e-4, 0.04)). Jacobians analytic for the EKF kinds (the
 * cubature kinds use f and h only, and forward differences for Hd; the
 * EKF kinds with forward differences are a fourth of the cost more: not
 * timed). Bearings are wrapped by the model's y_diff.
 *
 * Data: one trajectory simulated in double with bench_common.h's generator
 * (fixed seed, omega switching between -3 and 6 deg/s every 64 steps),
 * BENCH_NMEAS measurements cycled; every BENCH_NMEAS steps the filter is
 * re-initialised outside the timing's concern (the cost of a step does not
 * depend on the data, and cycling keeps the target near the radar).
 *
 * Output, one line per filter (bench_kf's columns):
 *   impl type n m ns_per_step steps_per_repeat repeats checksum
 * checksum = sum(x) + trace(Px) after BENCH_NMEAS - 1 steps (printed, not
 * compared: the filters estimate different things).
 *
 * Options: --filter NAME (nertsif, dnertsif, ekf, ckf; default all four,
 * back to back), --repeats R, --target-ms T, --steps S (as bench_uif).
 */
#include "bench_common.h"

#include "dkf/nerts.h"

#if DKF_USE_FLOAT
#define BENCH_TYPE "float"
#else
#define BENCH_TYPE "double"
#endif

#define NN 4
#define NM 3

static const double deg = 3.14159265358979323846 / 180.0;

typedef struct {
    int with_input;  /* 1: d = omega; 0: omega fixed, a second radar */
    double omega0;   /* the fixed omega (plain filters) */
} radar_t;

static radar_t ui_ctx = {1, 0.0}, plain_ctx = {0, 0.0};

static void ct(double w, double F[NN * NN], double dF[NN * NN])
{
    const double s = sin(w), c = cos(w);
    double a, b, da, db;
    if (fabs(w) < 1e-9) {
        a = 1.0, b = 0.0, da = 0.0, db = 0.5;
    } else {
        a = s / w, b = (1.0 - c) / w;
        da = (c * w - s) / (w * w), db = (s * w - (1.0 - c)) / (w * w);
    }
    {
        const double Fv[NN * NN] = {1, a, 0, -b, 0, c, 0, -s, 0, b, 1, a, 0, s, 0, c};
        const double dFv[NN * NN] = {0, da, 0, -db, 0, -s, 0, -c, 0, db, 0, da, 0, c, 0, -s};
        memcpy(F, Fv, sizeof Fv);
        if (dF != NULL) memcpy(dF, dFv, sizeof dFv);
    }
}

static double omega_of(const radar_t *r, const dkf_real_t *d)
{
    return r->with_input ? (double)d[0] : r->omega0;
}

static int f_ct(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                const dkf_real_t *u, dkf_real_t *xn)
{
    double F[NN * NN];
    int i, j;
    (void)k, (void)u;
    ct(omega_of(ctx, d), F, NULL);
    for (i = 0; i < NN; ++i) {
        double s = 0.0;
        for (j = 0; j < NN; ++j) s += F[i * NN + j] * (double)x[j];
        xn[i] = (dkf_real_t)s;
    }
    return 0;
}

static int f_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                 const dkf_real_t *u, dkf_real_t *Fx, dkf_real_t *Fd)
{
    const radar_t *r = ctx;
    double F[NN * NN], dF[NN * NN];
    int i, j;
    (void)k, (void)u;
    ct(omega_of(r, d), F, dF);
    for (i = 0; i < NN * NN; ++i) Fx[i] = (dkf_real_t)F[i];
    if (r->with_input)
        for (i = 0; i < NN; ++i) {
            double s = 0.0;
            for (j = 0; j < NN; ++j) s += dF[i * NN + j] * (double)x[j];
            Fd[i] = (dkf_real_t)s;
        }
    return 0;
}

static void radar(double sx, double sy, const dkf_real_t *x, double *rg, double *br,
                  double Hr[NN], double Hb[NN])
{
    const double dx = (double)x[0] - sx, dy = (double)x[2] - sy, r2 = dx * dx + dy * dy;
    *rg = sqrt(r2);
    *br = atan2(dy, dx);
    if (Hr != NULL) {
        const double Hrv[NN] = {dx / *rg, 0, dy / *rg, 0}, Hbv[NN] = {-dy / r2, 0, dx / r2, 0};
        memcpy(Hr, Hrv, sizeof Hrv);
        memcpy(Hb, Hbv, sizeof Hbv);
    }
}

static int h_radar(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                   const dkf_real_t *u, dkf_real_t *z)
{
    const radar_t *r = ctx;
    double rg, br, rg2, br2;
    (void)k, (void)u;
    radar(20.0, -40.0, x, &rg, &br, NULL, NULL);
    z[0] = (dkf_real_t)rg;
    z[1] = (dkf_real_t)br;
    if (r->with_input) {
        z[2] = (dkf_real_t)(10.0 * (double)d[0]);
    } else {
        radar(60.0, -40.0, x, &rg2, &br2, NULL, NULL);
        z[2] = (dkf_real_t)rg2;
    }
    return 0;
}

static int h_jac(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                 const dkf_real_t *u, dkf_real_t *Hx, dkf_real_t *Hd)
{
    const radar_t *r = ctx;
    double rg, br, Hr[NN], Hb[NN], H2[NN], Hb2[NN];
    int j;
    (void)k, (void)u, (void)d;
    radar(20.0, -40.0, x, &rg, &br, Hr, Hb);
    if (r->with_input) {
        memset(H2, 0, sizeof H2);
        Hd[0] = 0, Hd[1] = 0, Hd[2] = (dkf_real_t)10.0;
    } else {
        radar(60.0, -40.0, x, &rg, &br, H2, Hb2);
    }
    for (j = 0; j < NN; ++j) {
        Hx[j] = (dkf_real_t)Hr[j];
        Hx[NN + j] = (dkf_real_t)Hb[j];
        Hx[2 * NN + j] = (dkf_real_t)H2[j];
    }
    return 0;
}

/* a - b with the bearing (channel 1) wrapped into [-pi, pi) */
static void wrap_bearing(void *ctx, const dkf_real_t *a, const dkf_real_t *b, dkf_real_t *out)
{
    const double pi = 3.14159265358979323846;
    double e = (double)a[1] - (double)b[1];
    (void)ctx;
    e = e - 2.0 * pi * floor((e + pi) / (2.0 * pi));
    out[0] = a[0] - b[0];
    out[1] = (dkf_real_t)e;
    out[2] = a[2] - b[2];
}

static dkf_nl_model_t ui_model, plain_model;
static dkf_real_t mQ[NN * NN], mR_ui[NM * NM], mR_plain[NM * NM], mx0[NN], mP0[NN * NN];
static dkf_real_t md0[1], mPd0[1], mPxd0[NN];
static dkf_real_t zui[BENCH_NMEAS * NM], zpl[BENCH_NMEAS * NM];

static void make_model(void)
{
    static const double G[NN * 2] = {0.5, 0, 1, 0, 0, 0.5, 0, 1};
    const double x0[NN] = {-40.0, 3.0, 10.0, 1.0};
    bench_rng_t rng;
    double xt[NN], xn[NN], F[NN * NN], w;
    dkf_real_t xr[NN], z[NM];
    int i, j, k;
    ui_model.ctx = &ui_ctx, ui_model.n = NN, ui_model.m = NM, ui_model.p = 1;
    ui_model.f = f_ct, ui_model.h = h_radar, ui_model.f_jac = f_jac, ui_model.h_jac = h_jac;
    ui_model.y_diff = wrap_bearing;
    plain_ctx.omega0 = -3.0 * deg;
    plain_model = ui_model;
    plain_model.ctx = &plain_ctx, plain_model.p = 0;
    for (i = 0; i < NN; ++i)
        for (j = 0; j < NN; ++j)
            mQ[i * NN + j] = (dkf_real_t)(0.04 * (G[i * 2] * G[j * 2] + G[i * 2 + 1] * G[j * 2 + 1]));
    mR_ui[0] = (dkf_real_t)0.04, mR_ui[4] = (dkf_real_t)2.25e-4, mR_ui[8] = (dkf_real_t)8.8e-8;
    mR_plain[0] = (dkf_real_t)0.04, mR_plain[4] = (dkf_real_t)2.25e-4,
    mR_plain[8] = (dkf_real_t)0.04;
    for (i = 0; i < NN; ++i) mx0[i] = (dkf_real_t)x0[i];
    mP0[0] = 4, mP0[5] = (dkf_real_t)0.01, mP0[10] = 4, mP0[15] = (dkf_real_t)0.01;
    md0[0] = (dkf_real_t)(-3.0 * deg);
    mPd0[0] = (dkf_real_t)8.8e-10;

    rng.s = UINT64_C(0x5EED00001);
    memcpy(xt, x0, sizeof xt);
    for (k = 0; k < BENCH_NMEAS; ++k) {
        w = ((k / 64) % 2 ? 6.0 : -3.0) * deg;
        ct(w, F, NULL);
        for (i = 0; i < NN; ++i) {
            double s = 0.0;
            for (j = 0; j < NN; ++j) s += F[i * NN + j] * xt[j];
            xn[i] = s;
        }
        {
            const double a0 = 0.2 * bench_rng_normal(&rng), a1 = 0.2 * bench_rng_normal(&rng);
            for (i = 0; i < NN; ++i) xn[i] += G[i * 2] * a0 + G[i * 2 + 1] * a1;
        }
        memcpy(xt, xn, sizeof xt);
        for (i = 0; i < NN; ++i) xr[i] = (dkf_real_t)xt[i];
        {
            dkf_real_t dw = (dkf_real_t)w;
            h_radar(&ui_ctx, 0, xr, &dw, NULL, z);
            zui[k * NM + 0] = z[0] + (dkf_real_t)(0.2 * bench_rng_normal(&rng));
            zui[k * NM + 1] = z[1] + (dkf_real_t)(0.015 * bench_rng_normal(&rng));
            zui[k * NM + 2] = z[2] + (dkf_real_t)(2.97e-4 * bench_rng_normal(&rng));
            h_radar(&plain_ctx, 0, xr, NULL, NULL, z);
            zpl[k * NM + 0] = z[0] + (dkf_real_t)(0.2 * bench_rng_normal(&rng));
            zpl[k * NM + 1] = z[1] + (dkf_real_t)(0.015 * bench_rng_normal(&rng));
            zpl[k * NM + 2] = z[2] + (dkf_real_t)(0.2 * bench_rng_normal(&rng));
        }
    }
}

static dkf_nerts_t flt;
static dkf_real_t flt_storage[DKF_NERTS_STORAGE_LEN(NN, NM, 1)];

static int start(dkf_nerts_kind_t kind, int with_input)
{
    dkf_mat_t x0 = DKF_MAT(NN, 1, mx0), P0 = DKF_MAT(NN, NN, mP0), d0 = DKF_MAT(1, 1, md0),
              Pd0 = DKF_MAT(1, 1, mPd0), Pxd0 = DKF_MAT(NN, 1, mPxd0);
    const size_t p = with_input ? 1 : 0;
    return dkf_nerts_init(&flt, kind, NN, NM, p, flt_storage, DKF_NERTS_STORAGE_LEN(NN, NM, p), &x0,
                          &P0, with_input ? &d0 : NULL, with_input ? &Pd0 : NULL,
                          with_input ? &Pxd0 : NULL) == DKF_OK
               ? 0
               : -1;
}

/* steps of kind over the cycled data; restarted every BENCH_NMEAS steps */
static double run_kind(dkf_nerts_kind_t kind, int with_input, long steps)
{
    const dkf_nl_model_t *md = with_input ? &ui_model : &plain_model;
    const dkf_real_t *zs = with_input ? zui : zpl;
    dkf_mat_t Q = DKF_MAT(NN, NN, mQ), R = DKF_MAT(NM, NM, with_input ? mR_ui : mR_plain),
              z = DKF_MAT(NM, 1, (dkf_real_t *)zs);
    double cs = 0.0;
    long k;
    int i;
    if (start(kind, with_input) != 0) return NAN;
    for (k = 0; k < steps; ++k) {
        const long j = k % BENCH_NMEAS;
        if (j == 0 && k > 0 && start(kind, with_input) != 0) return NAN;
        z.data = (dkf_real_t *)zs + j * NM;
        if (dkf_nerts_step(&flt, md, NULL, &Q, NULL, &R, &z) != DKF_OK) return NAN;
    }
    for (i = 0; i < NN; ++i) cs += (double)flt.x.data[i] + (double)flt.Px.data[i * NN + i];
    return cs;
}

static double run_nertsif(long s) { return run_kind(DKF_NERTS_NERTSIF, 1, s); }
static double run_dnertsif(long s) { return run_kind(DKF_NERTS_DNERTSIF, 1, s); }
static double run_ekf(long s) { return run_kind(DKF_NERTS_NERTSF, 0, s); }
static double run_ckf(long s) { return run_kind(DKF_NERTS_DNERTSF, 0, s); }

static const bench_filter_t filters[4] = {
    {"nertsif", run_nertsif}, {"dnertsif", run_dnertsif}, {"ekf", run_ekf}, {"ckf", run_ckf}};

int main(int argc, char **argv)
{
    make_model();
    return bench_filters_main(argc, argv, "nerts", BENCH_TYPE, NN, NM, filters, 4,
                              BENCH_NMEAS - 1);
}
