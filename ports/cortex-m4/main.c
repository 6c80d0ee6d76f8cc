/*
 * main.c - Cortex-M4 image entry: run the demo filter once, then idle.
 *
 * The outcome is left in globals a debugger (or a test harness reading
 * RAM) can inspect: m4_status is DKF_OK (0) on success.
 */
#include "demo.h"

volatile dkf_status_t m4_status = DKF_ERR_STATE;
volatile dkf_real_t m4_state[4];

int main(void)
{
    dkf_real_t x[4] = {DKF_R(0.0), DKF_R(0.0), DKF_R(0.0), DKF_R(0.0)};
    size_t i;

    m4_status = m4_demo_run(x);
    for (i = 0; i < 4; ++i) m4_state[i] = x[i];
    for (;;) {
        /* Wait for interrupt: nothing else to do. */
        __asm__ volatile("wfi");
    }
}
