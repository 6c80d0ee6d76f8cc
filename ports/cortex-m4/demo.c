/*
 * demo.c - a 2-D constant-velocity Kalman filter through the public API.
 *
 * State x = [px, py, vx, vy], sample time dt = 0.1 s:
 *   F = [I dt*I; 0 I],  Q = q [dt^3/3 I, 0; 0, dt I] (q = 0.01, cross terms
 *   dropped to keep the table short),  H = [I 0],  R = 0.05^2 I.
 * The track is px = 0.5 + t, py = 2 - 0.5 t sampled at t = 0.1 .. 4.0 with
 * N(0, 0.05^2) noise (fixed seed, rounded to 4 decimals).
 */
#include "demo.h"

#define DEMO_N 4
#define DEMO_M 2
#define DEMO_STEPS 40

static const dkf_real_t track[DEMO_STEPS][DEMO_M] = {
    {DKF_R(0.6001), DKF_R(1.9555)}, {DKF_R(0.7149), DKF_R(1.9032)},
    {DKF_R(0.7863), DKF_R(1.7887)}, {DKF_R(0.8555), DKF_R(1.8038)},
    {DKF_R(0.9773), DKF_R(1.8179)}, {DKF_R(1.0504), DKF_R(1.6226)},
    {DKF_R(1.2030), DKF_R(1.6930)}, {DKF_R(1.3670), DKF_R(1.6060)},
    {DKF_R(1.3754), DKF_R(1.5179)}, {DKF_R(1.4690), DKF_R(1.6000)},
    {DKF_R(1.6245), DKF_R(1.4881)}, {DKF_R(1.7178), DKF_R(1.3400)},
    {DKF_R(1.8053), DKF_R(1.3537)}, {DKF_R(1.8535), DKF_R(1.3288)},
    {DKF_R(1.9985), DKF_R(1.2406)}, {DKF_R(2.1348), DKF_R(1.2341)},
    {DKF_R(2.1328), DKF_R(1.1467)}, {DKF_R(2.2771), DKF_R(1.1334)},
    {DKF_R(2.3049), DKF_R(1.1219)}, {DKF_R(2.4355), DKF_R(0.9662)},
    {DKF_R(2.5079), DKF_R(0.9602)}, {DKF_R(2.6882), DKF_R(0.8768)},
    {DKF_R(2.7366), DKF_R(0.8564)}, {DKF_R(2.9136), DKF_R(0.7406)},
    {DKF_R(3.0078), DKF_R(0.7210)}, {DKF_R(3.0907), DKF_R(0.6902)},
    {DKF_R(3.0742), DKF_R(0.6949)}, {DKF_R(3.2731), DKF_R(0.6573)},
    {DKF_R(3.3976), DKF_R(0.4838)}, {DKF_R(3.5057), DKF_R(0.4603)},
    {DKF_R(3.5235), DKF_R(0.4823)}, {DKF_R(3.6761), DKF_R(0.3004)},
    {DKF_R(3.7511), DKF_R(0.3268)}, {DKF_R(3.8596), DKF_R(0.2951)},
    {DKF_R(4.0530), DKF_R(0.3129)}, {DKF_R(4.0596), DKF_R(0.2345)},
    {DKF_R(4.1984), DKF_R(0.1336)}, {DKF_R(4.3442), DKF_R(0.0816)},
    {DKF_R(4.3708), DKF_R(0.0375)}, {DKF_R(4.4944), DKF_R(0.0762)},
};

/* Final state of the same filter computed in double precision with numpy
 * (Joseph form; the simple form agrees to 1e-9 here). */
static const dkf_real_t x_reference[DEMO_N] = {
    DKF_R(4.50165265), DKF_R(0.02141486), DKF_R(1.03096573), DKF_R(-0.45266676)};

/* Agreement with the reference. 40 float steps on well-conditioned 4x4 and
 * 2x2 matrices lose a few hundred FLT_EPSILON (1.2e-7) relative at most,
 * i.e. ~1e-4 on values of order 1-5; 2e-3 leaves a wide margin yet still
 * catches a wrong gain or a dropped term (those move the result by > 1e-2). */
#define DEMO_TOL DKF_R(2e-3)

/* The filter lives in static storage: no heap, and no big stack frame. */
DKF_KF_DECLARE(static, filter, DEMO_N, DEMO_M);

static dkf_real_t abs_diff(dkf_real_t a, dkf_real_t b)
{
    return a > b ? a - b : b - a;
}

dkf_status_t m4_demo_run(dkf_real_t x_out[4])
{
    const dkf_real_t dt = DKF_R(0.1);
    const dkf_real_t q = DKF_R(0.01);
    DKF_MAT_DECLARE(, F, DEMO_N, DEMO_N);
    DKF_MAT_DECLARE(, Q, DEMO_N, DEMO_N);
    DKF_MAT_DECLARE(, H, DEMO_M, DEMO_N);
    DKF_MAT_DECLARE(, R, DEMO_M, DEMO_M);
    DKF_MAT_DECLARE(, x0, DEMO_N, 1);
    DKF_MAT_DECLARE(, P0, DEMO_N, DEMO_N);
    dkf_real_t y_data[DEMO_M];
    dkf_mat_t y = DKF_MAT(DEMO_M, 1, y_data);
    const dkf_kf_dyn_t dyn = {&F, &Q};   /* x' = F x + v, v ~ (0, Q) */
    const dkf_kf_meas_t meas = {&H, &R}; /* y = H x + w, w ~ (0, R) */
    dkf_status_t s;
    size_t k, i;

    s = dkf_mat_identity(&F);
    if (s != DKF_OK) return s;
    DKF_AT(&F, 0, 2) = dt;
    DKF_AT(&F, 1, 3) = dt;
    s = dkf_mat_zero(&Q);
    if (s != DKF_OK) return s;
    DKF_AT(&Q, 0, 0) = DKF_AT(&Q, 1, 1) = q * dt * dt * dt / DKF_R(3.0);
    DKF_AT(&Q, 2, 2) = DKF_AT(&Q, 3, 3) = q * dt;
    s = dkf_mat_zero(&H);
    if (s != DKF_OK) return s;
    DKF_AT(&H, 0, 0) = DKF_AT(&H, 1, 1) = DKF_R(1.0);
    s = dkf_mat_identity(&R);
    if (s != DKF_OK) return s;
    s = dkf_mat_scale(&R, &R, DKF_R(0.0025));
    if (s != DKF_OK) return s;
    s = dkf_mat_zero(&x0);
    if (s != DKF_OK) return s;
    s = dkf_mat_identity(&P0);
    if (s != DKF_OK) return s;
    s = dkf_mat_scale(&P0, &P0, DKF_R(10.0));
    if (s != DKF_OK) return s;

    s = dkf_kf_init(&filter, DEMO_N, DEMO_M, filter_storage,
                    sizeof filter_storage / sizeof filter_storage[0], &x0, &P0);
    if (s != DKF_OK) return s;
    for (k = 0; k < DEMO_STEPS; ++k) {
        s = dkf_kf_predict(&filter, &dyn, NULL);
        if (s != DKF_OK) return s;
        y_data[0] = track[k][0];
        y_data[1] = track[k][1];
        s = dkf_kf_update(&filter, &meas, &y);
        if (s != DKF_OK) return s;
    }
    for (i = 0; i < DEMO_N; ++i) {
        x_out[i] = filter.x.data[i];
        if (!(abs_diff(x_out[i], x_reference[i]) <= DEMO_TOL)) return DKF_ERR_ARG;
    }
    return DKF_OK;
}
