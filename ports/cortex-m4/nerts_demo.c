/*
 * nerts_demo.c - one DNERTSIF node on a Cortex-M4 (nerts_demo.h).
 *
 * Model (seed 001, eq. 62, T = 1): x = [xi, xi_dot, eta, eta_dot],
 * d = omega; f(x, d) = F_CT(omega) x; h(x, d) = [range, bearing, 10 omega]
 * from the radar at (20, -40); bearings wrapped by y_diff. No Jacobians:
 * the cubature filter needs f and h only, and the library differences
 * Hd = dh/dd itself. Static storage, DKF_NERTS_DECLARE.
 */
#include "nerts_demo.h"

#include <math.h>

#if DKF_USE_FLOAT
#define M_SIN sinf
#define M_COS cosf
#define M_ATAN2 atan2f
#define M_SQRT sqrtf
#define M_FLOOR floorf
#define M_FABS fabsf
#else
#define M_SIN sin
#define M_COS cos
#define M_ATAN2 atan2
#define M_SQRT sqrt
#define M_FLOOR floor
#define M_FABS fabs
#endif

#define NN 4
#define NM 3
#define NP 1

static const dkf_real_t PI_R = DKF_R(3.14159265358979323846);

DKF_NERTS_DECLARE(static, node, NN, NM, NP);

/* x_next = F_CT(omega) x */
static int ct_f(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                const dkf_real_t *u, dkf_real_t *xn)
{
    const dkf_real_t w = d[0], s = M_SIN(w), c = M_COS(w);
    dkf_real_t a = DKF_R(1.0), b = DKF_R(0.0);
    (void)ctx, (void)k, (void)u;
    if (M_FABS(w) > DKF_R(1e-6)) {
        a = s / w;
        b = (DKF_R(1.0) - c) / w;
    }
    xn[0] = x[0] + a * x[1] - b * x[3];
    xn[1] = c * x[1] - s * x[3];
    xn[2] = b * x[1] + x[2] + a * x[3];
    xn[3] = s * x[1] + c * x[3];
    return 0;
}

/* [range, bearing, 10 omega] from the radar */
static int radar_h(void *ctx, size_t k, const dkf_real_t *x, const dkf_real_t *d,
                   const dkf_real_t *u, dkf_real_t *z)
{
    const dkf_real_t dx = x[0] - DKF_R(20.0), dy = x[2] + DKF_R(40.0);
    (void)ctx, (void)k, (void)u;
    z[0] = M_SQRT(dx * dx + dy * dy);
    z[1] = M_ATAN2(dy, dx);
    z[2] = DKF_R(10.0) * d[0];
    return 0;
}

/* a - b, the bearing wrapped into [-pi, pi) */
static void wrap_diff(void *ctx, const dkf_real_t *a, const dkf_real_t *b, dkf_real_t *out)
{
    dkf_real_t e = a[1] - b[1];
    (void)ctx;
    e -= DKF_R(2.0) * PI_R * M_FLOOR((e + PI_R) / (DKF_R(2.0) * PI_R));
    out[0] = a[0] - b[0];
    out[1] = e;
    out[2] = a[2] - b[2];
}

static const dkf_nl_model_t model = {NULL, NN, NM, NP, 0, ct_f, radar_h, NULL, NULL, wrap_diff};

dkf_status_t m4_nerts_run(dkf_real_t x_out[4], dkf_real_t *omega_out)
{
    static const dkf_real_t x_true0[NN] = {DKF_R(-40.0), DKF_R(3.0), DKF_R(10.0), DKF_R(1.0)};
    const dkf_real_t omega = DKF_R(-0.05235987755982989); /* -3 deg/s */
    DKF_MAT_DECLARE(static, x0, NN, 1);
    DKF_MAT_DECLARE(static, P0, NN, NN);
    DKF_MAT_DECLARE(static, d0, NP, 1);
    DKF_MAT_DECLARE(static, Pd0, NP, NP);
    DKF_MAT_DECLARE(static, Pxd0, NN, NP);
    DKF_MAT_DECLARE(static, Q, NN, NN);
    DKF_MAT_DECLARE(static, R, NM, NM);
    DKF_MAT_DECLARE(static, z, NM, 1);
    dkf_real_t xt[NN], xn[NN], w = omega, e0, e2;
    dkf_status_t st;
    size_t i, k;
    dkf_mat_zero(&P0);
    dkf_mat_zero(&Q);
    dkf_mat_zero(&R);
    dkf_mat_zero(&Pxd0);
    for (i = 0; i < NN; ++i) xt[i] = x_true0[i];
    x0.data[0] = xt[0] + DKF_R(1.5);
    x0.data[1] = xt[1] - DKF_R(0.1);
    x0.data[2] = xt[2] - DKF_R(1.5);
    x0.data[3] = xt[3] + DKF_R(0.1);
    P0.data[0] = P0.data[10] = DKF_R(4.0);
    P0.data[5] = P0.data[15] = DKF_R(0.01);
    d0.data[0] = DKF_R(0.0);
    Pd0.data[0] = DKF_R(1e-2);
    /* Q = Gamma (0.04 I2) Gamma^T, Gamma = [.5 0; 1 0; 0 .5; 0 1] */
    Q.data[0] = Q.data[10] = DKF_R(0.01);
    Q.data[1] = Q.data[4] = Q.data[11] = Q.data[14] = DKF_R(0.02);
    Q.data[5] = Q.data[15] = DKF_R(0.04);
    R.data[0] = DKF_R(0.04);
    R.data[4] = DKF_R(2.25e-4);
    R.data[8] = DKF_R(1e-6);
    st = dkf_nerts_init(&node, DKF_NERTS_DNERTSIF, NN, NM, NP, node_storage,
                        DKF_NERTS_STORAGE_LEN(NN, NM, NP), &x0, &P0, &d0, &Pd0, &Pxd0);
    for (k = 1; st == DKF_OK && k <= M4_NERTS_STEPS; ++k) {
        (void)ct_f(NULL, k, xt, &w, NULL, xn);
        for (i = 0; i < NN; ++i) xt[i] = xn[i];
        (void)radar_h(NULL, k, xt, &w, NULL, z.data);
        st = dkf_nerts_step(&node, &model, NULL, &Q, NULL, &R, &z);
    }
    if (st != DKF_OK) return st;
    for (i = 0; i < NN; ++i) x_out[i] = node.x.data[i];
    *omega_out = node.d.data[0];
    e0 = node.x.data[0] - xt[0];
    e2 = node.x.data[2] - xt[2];
    if (!(M_SQRT(e0 * e0 + e2 * e2) < DKF_R(0.5)) || !(M_FABS(node.d.data[0] - omega) < DKF_R(1e-3)))
        return DKF_ERR_ARG;
    return DKF_OK;
}
