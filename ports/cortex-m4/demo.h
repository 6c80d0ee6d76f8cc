/*
 * demo.h - the fixed-size tracking filter the Cortex-M4 image runs.
 *
 * Kept apart from main.c so the same code also builds and runs on the host
 * (tools/check_firmware.sh), which is how its result is checked: the M4
 * image itself is only linked and measured, never executed.
 */
#ifndef M4_DEMO_H
#define M4_DEMO_H

#include "dkf/kf.h"

/* Runs a constant-velocity filter (n = 4, m = 2) over the built-in position
 * track and writes the final state [px, py, vx, vy] to x_out. Returns
 * DKF_OK, a library error, or DKF_ERR_ARG if the estimate is wrong. */
dkf_status_t m4_demo_run(dkf_real_t x_out[4]);

#endif /* M4_DEMO_H */
