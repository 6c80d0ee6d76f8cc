/*
 * host_main.c - runs the firmware demo on the build host and reports it,
 * so the M4 image's filter code is checked for its result, not only linked.
 */
#include <stdio.h>

#include "demo.h"

int main(void)
{
    dkf_real_t x[4] = {DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(0.0)};
    dkf_status_t s = m4_demo_run(x);

    printf("m4 demo: %s, x = [%.6f %.6f %.6f %.6f]\n", dkf_status_str(s), (double)x[0],
           (double)x[1], (double)x[2], (double)x[3]);
    return s == DKF_OK ? 0 : 1;
}
