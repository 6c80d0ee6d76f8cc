/*
 * nerts_main.c - the second Cortex-M4 image's entry: one DNERTSIF node
 * (nerts_demo.h) run once, then idle; the outcome stays in globals.
 */
#include "nerts_demo.h"

volatile dkf_status_t m4_status = DKF_ERR_STATE;
volatile dkf_real_t m4_state[5];

int main(void)
{
    dkf_real_t x[4] = {DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(0.0)}, w = DKF_R(0.0);
    size_t i;

    m4_status = m4_nerts_run(x, &w);
    for (i = 0; i < 4; ++i) m4_state[i] = x[i];
    m4_state[4] = w;
    for (;;) {
        /* Wait for interrupt: nothing else to do. */
        __asm__ volatile("wfi");
    }
}
