/*
 * nerts_host_main.c - runs the DNERTSIF firmware demo on the build host and
 * reports it (the M4 image is only linked and measured).
 */
#include <stdio.h>

#include "nerts_demo.h"

int main(void)
{
    dkf_real_t x[4] = {DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(0.0)}, w = DKF_R(0.0);
    dkf_status_t s = m4_nerts_run(x, &w);

    printf("m4 nerts demo: %s, x = [%.6f %.6f %.6f %.6f], omega = %.6f\n", dkf_status_str(s),
           (double)x[0], (double)x[1], (double)x[2], (double)x[3], (double)w);
    return s == DKF_OK ? 0 : 1;
}
