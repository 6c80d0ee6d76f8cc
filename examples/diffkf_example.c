/*
 * examples/diffkf_example.c - the Difference Kalman filter (dkf/diffkf.h,
 * seed 000) tracking a 1-D position and velocity from one sensor whose
 * bias d is unknown and drifts:
 *
 *   x_{k+1} = F x_k + v_k          x = [position; velocity], F = [1 1; 0 1]
 *   y_k     = H x_k + D d_k + w_k  H = [1 0], D = [1]: the bias adds to y
 *   d_{k+1} = B d_k + wd_k         B = [0.9]
 *
 * The filter removes d by differencing consecutive measurements, so it
 * never needs d_0 (here 20, far from anything it is told). One-step delay:
 * the step that takes y_{k+1} gives x_{k|k} (f.xf, time f.k); f.xp is
 * x_{k|k-1} and f.xn the prediction x_{k+1|k}.
 *
 * The noise is a fixed-seed uniform sequence with the variances given to
 * the filter, so the run is reproducible. Exit status 0 when every call
 * returns DKF_OK and the errors are consistent with the filter's own
 * covariance: the mean of e^T P_{k|k}^{-1} e over the run (2 degrees of
 * freedom, so about 2 for a consistent filter) must stay below 6. A filter
 * that took y at face value would be off by the bias (20 at the start,
 * then decaying as 0.9^k) and far above.
 * Built and run by the ctest `example_diffkf` (examples/CMakeLists.txt).
 */
#include <stdio.h>

#include "dkf/diffkf.h"

#define STEPS 60

DKF_DIFFKF_DECLARE(static, f, 2, 1, 1); /* n = 2 states, m = 1 measurement, p = 1 input */
DKF_MAT_DECLARE(static, F, 2, 2);
DKF_MAT_DECLARE(static, Q, 2, 2);
DKF_MAT_DECLARE(static, H, 1, 2);
DKF_MAT_DECLARE(static, D, 1, 1);
DKF_MAT_DECLARE(static, R, 1, 1);
DKF_MAT_DECLARE(static, B, 1, 1);
DKF_MAT_DECLARE(static, Rd, 1, 1);
DKF_MAT_DECLARE(static, x0, 2, 1);
DKF_MAT_DECLARE(static, P0, 2, 2);
DKF_MAT_DECLARE(static, y, 1, 1);

/* Uniform on [-a, a] (variance a^2 / 3) from a fixed-seed LCG. */
static double uniform(double a)
{
    static unsigned long s = 12345UL;
    s = (s * 1103515245UL + 12345UL) & 0x7fffffffUL;
    return a * ((double)s / 1073741823.5 - 1.0);
}

/* The truth one step on (x_k from x_{k-1}, d_k from d_{k-1}) and y_k. */
static void simulate(double x[2], double *d)
{
    x[0] += x[1];
    x[1] += uniform(0.1);
    *d = 0.9 * *d + uniform(0.3);
    y_data[0] = (dkf_real_t)(x[0] + *d + uniform(0.5));
}

int main(void)
{
    double x[2] = {0.0, 1.0}, d = 20.0, truth[2] = {0.0, 0.0}, nees = 0.0;
    const dkf_ui_dyn_t dyn = {&F, &Q, &B, &Rd};
    const dkf_ui_meas_t meas = {&H, &D, &R};
    dkf_status_t s;
    int k;

    /* the noise variances a^2 / 3 of simulate()'s half-widths a */
    F_data[0] = 1; F_data[1] = 1; F_data[3] = 1;
    Q_data[3] = (dkf_real_t)(0.1 * 0.1 / 3.0);
    H_data[0] = 1;
    D_data[0] = 1;
    R_data[0] = (dkf_real_t)(0.5 * 0.5 / 3.0);
    B_data[0] = DKF_R(0.9);
    Rd_data[0] = (dkf_real_t)(0.3 * 0.3 / 3.0);
    P0_data[0] = 4; P0_data[3] = 1; /* x_{0|0} = 0: 1 sigma off in velocity */

    s = dkf_diffkf_init(&f, 2, 1, 1, f_storage, DKF_DIFFKF_STORAGE_LEN(2, 1, 1), &x0, &P0);
    simulate(x, &d); /* y_1 */
    if (s == DKF_OK) s = dkf_diffkf_start(&f, &F, &Q, &meas, &y);
    for (k = 1; s == DKF_OK && k < STEPS; ++k) {
        double e0, e1, det;
        truth[0] = x[0]; /* x_k */
        truth[1] = x[1];
        simulate(x, &d);                          /* y_{k+1} */
        s = dkf_diffkf_step(&f, &dyn, &meas, &y); /* -> x_{k|k}; on error f is unchanged */
        if (s != DKF_OK) break;
        e0 = (double)f.xf.data[0] - truth[0];
        e1 = (double)f.xf.data[1] - truth[1];
        det = (double)f.Pf.data[0] * (double)f.Pf.data[3] -
              (double)f.Pf.data[1] * (double)f.Pf.data[2];
        nees += ((double)f.Pf.data[3] * e0 * e0 - 2.0 * (double)f.Pf.data[1] * e0 * e1 +
                 (double)f.Pf.data[0] * e1 * e1) / det;
    }
    if (s != DKF_OK) {
        fprintf(stderr, "diffkf_example: step %d: %s\n", k, dkf_status_str(s));
        return 1;
    }
    nees /= STEPS - 1;
    printf("k = %u: position %.3f (true %.3f), velocity %.3f (true %.3f), bias %.2f; "
           "mean NEES %.2f\n", (unsigned)f.k, (double)f.xf.data[0], truth[0],
           (double)f.xf.data[1], truth[1], d, nees);
    return nees < 6.0 ? 0 : 1;
}
