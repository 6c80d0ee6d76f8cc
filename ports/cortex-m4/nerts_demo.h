/*
 * nerts_demo.h - one DNERTSIF node (seed 001, dkf/nerts.h) as the second
 * Cortex-M4 image runs it: the constant-turn target seen by one radar,
 * the turn rate as the unknown input (n = 4, p = 1, m = 3).
 *
 * Built into its own image (dkf_m4_nerts.elf) to measure what a seed-001
 * node costs on the part (docs/results/footprint.md), and on the host to check it.
 */
#ifndef M4_NERTS_DEMO_H
#define M4_NERTS_DEMO_H

#include "dkf/nerts.h"

/* Runs M4_NERTS_STEPS DNERTSIF steps on noise-free measurements of a known
 * turning track from a wrong initial estimate; writes the final state and
 * turn-rate estimate. DKF_OK, a library error, or DKF_ERR_ARG if the
 * estimate has not converged (position error >= 0.5, turn rate >= 1e-3). */
#define M4_NERTS_STEPS 30
dkf_status_t m4_nerts_run(dkf_real_t x_out[4], dkf_real_t *omega_out);

#endif /* M4_NERTS_DEMO_H */
