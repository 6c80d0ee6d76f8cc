/*
 * Consumer of an installed dkf: a 2-state (position, velocity) filter with
 * position measurements, checked step by step against a scalar-coded
 * reference in double that shares no code with the library.
 * Exit status 0 on agreement, 1 otherwise.
 */
#ifndef DKF_USE_FLOAT
#error "dkf::dkf did not bring the DKF_USE_FLOAT definition"
#endif
#ifndef DKF_JOSEPH
#error "dkf::dkf did not bring the DKF_JOSEPH definition"
#endif
#if DKF_USE_FLOAT != CONSUMER_EXPECT_FLOAT
#error "DKF_USE_FLOAT of dkf::dkf disagrees with DKF_REAL of the package"
#endif

#include <float.h>
#include <math.h>
#include <stdio.h>

#include "dkf/diffkf_fusion.h"
#include "dkf/kf.h"

#ifdef CONSUMER_EXPECT_MAX_DIM
/* The installed headers give the library's DKF_MAX_DIM, so the message
 * layout is the library's. */
DKF_STATIC_ASSERT(DKF_MAX_DIM == CONSUMER_EXPECT_MAX_DIM, max_dim_is_the_built_one);
DKF_STATIC_ASSERT(sizeof(((dkf_diffkf_msg_t *)0)->xf) == CONSUMER_EXPECT_MAX_DIM * sizeof(dkf_real_t),
                  message_layout_is_the_built_one);
#endif

#define STEPS 8

/* Reference filter, F = [1 dt; 0 1], Q = diag(q, q), H = [1 0], R = r.
 * x = [p v], P symmetric as (p00, p01, p11). */
typedef struct {
    double x0, x1, p00, p01, p11;
} ref_t;

static void ref_step(ref_t *f, double dt, double q, double r, double y)
{
    double a00, a01, a11, s, k0, k1, nu;
    f->x0 += dt * f->x1;
    a00 = f->p00 + 2.0 * dt * f->p01 + dt * dt * f->p11 + q;
    a01 = f->p01 + dt * f->p11;
    a11 = f->p11 + q;
    s = a00 + r;
    k0 = a00 / s;
    k1 = a01 / s;
    nu = y - f->x0;
    f->x0 += k0 * nu;
    f->x1 += k1 * nu;
    /* P+ = P - K S K^T (equal to the Joseph form in exact arithmetic). */
    f->p00 = a00 - k0 * k0 * s;
    f->p01 = a01 - k0 * k1 * s;
    f->p11 = a11 - k1 * k1 * s;
}

static int close_to(double got, double want, double tol, const char *what, int k)
{
    if (fabs(got - want) <= tol * (1.0 + fabs(want))) return 1;
    printf("step %d: %s = %.9g, reference %.9g\n", k, what, got, want);
    return 0;
}

int main(void)
{
    static const double ys[STEPS] = {0.9, 2.1, 2.9, 4.2, 5.0, 5.8, 7.1, 8.0};
    /* 8 steps of 2x2 arithmetic lose at most a few dozen epsilons of the
     * real type relative; 1e3 epsilons (1.2e-4 in float, 2.2e-13 in
     * double) is far above that and far below any modelling error. */
    const double tol = 1e3 * (double)DKF_REAL_EPSILON;
    DKF_KF_DECLARE(, kf, 2, 1);
    DKF_MAT_DECLARE(, F, 2, 2);
    DKF_MAT_DECLARE(, Q, 2, 2);
    DKF_MAT_DECLARE(, H, 1, 2);
    DKF_MAT_DECLARE(, R, 1, 1);
    DKF_MAT_DECLARE(, x0, 2, 1);
    DKF_MAT_DECLARE(, P0, 2, 2);
    DKF_MAT_DECLARE(, y, 1, 1);
    ref_t ref = {0.0, 1.0, 4.0, 0.0, 4.0};
    int ok = 1, k;

    F_data[0] = DKF_R(1.0); F_data[1] = DKF_R(1.0); F_data[2] = DKF_R(0.0); F_data[3] = DKF_R(1.0);
    Q_data[0] = DKF_R(0.01); Q_data[1] = DKF_R(0.0); Q_data[2] = DKF_R(0.0); Q_data[3] = DKF_R(0.01);
    H_data[0] = DKF_R(1.0); H_data[1] = DKF_R(0.0);
    R_data[0] = DKF_R(0.25);
    x0_data[0] = DKF_R(0.0); x0_data[1] = DKF_R(1.0);
    P0_data[0] = DKF_R(4.0); P0_data[1] = DKF_R(0.0); P0_data[2] = DKF_R(0.0); P0_data[3] = DKF_R(4.0);

    if (dkf_kf_init(&kf, 2, 1, kf_storage, sizeof kf_storage / sizeof kf_storage[0], &x0, &P0) !=
        DKF_OK) {
        printf("dkf_kf_init failed\n");
        return 1;
    }
    for (k = 0; k < STEPS; ++k) {
        dkf_status_t s = dkf_kf_predict(&kf, &(dkf_kf_dyn_t){&F, &Q}, NULL);
        y_data[0] = (dkf_real_t)ys[k];
        if (s == DKF_OK) s = dkf_kf_update(&kf, &(dkf_kf_meas_t){&H, &R}, &y);
        if (s != DKF_OK) {
            printf("step %d: %s\n", k, dkf_status_str(s));
            return 1;
        }
        ref_step(&ref, 1.0, 0.01, 0.25, (double)y_data[0]);
        ok &= close_to((double)kf.x.data[0], ref.x0, tol, "x[0]", k);
        ok &= close_to((double)kf.x.data[1], ref.x1, tol, "x[1]", k);
        ok &= close_to((double)kf.P.data[0], ref.p00, tol, "P[0][0]", k);
        ok &= close_to((double)kf.P.data[1], ref.p01, tol, "P[0][1]", k);
        ok &= close_to((double)kf.P.data[3], ref.p11, tol, "P[1][1]", k);
    }
    printf("consumer: %s (DKF_USE_FLOAT=%d DKF_JOSEPH=%d DKF_MAX_DIM=%d) x = [%.6f %.6f]\n",
           ok ? "ok" : "FAILED", DKF_USE_FLOAT, DKF_JOSEPH, DKF_MAX_DIM, (double)kf.x.data[0],
           (double)kf.x.data[1]);
    return ok ? 0 : 1;
}
