/*
 * startup.c - minimal Cortex-M4F reset path and vector table.
 *
 * Reset_Handler copies .data from flash, zeroes .bss, enables the FPU
 * (CP10/CP11 full access in CPACR) before any floating-point instruction,
 * and calls main. Every other exception parks in Default_Handler. Symbols
 * come from stm32f4.ld.
 */
#include <stdint.h>

extern uint32_t _sidata[], _sdata[], _edata[], _sbss[], _ebss[], _estack[];
int main(void);

void Reset_Handler(void);
void Default_Handler(void);

/* Coprocessor Access Control Register (ARMv7-M ARM, B3.2.20). */
#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)

void Default_Handler(void)
{
    for (;;) {
    }
}

void Reset_Handler(void)
{
    uint32_t *src = _sidata;
    uint32_t *dst;

    for (dst = _sdata; dst < _edata; ++dst) *dst = *src++;
    for (dst = _sbss; dst < _ebss; ++dst) *dst = 0u;
    SCB_CPACR |= (0xFu << 20);
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    (void)main();
    for (;;) {
    }
}

typedef void (*m4_vector_t)(void);

/* Initial SP, then the 15 system exceptions of ARMv7-M (device IRQs are not
 * used by this image). The stack pointer entry is an address, not code; the
 * cast through uintptr_t is the usual way to place it in this table. */
__attribute__((section(".isr_vector"), used))
const m4_vector_t m4_vectors[16] = {
    (m4_vector_t)(uintptr_t)_estack,
    Reset_Handler,   /* Reset */
    Default_Handler, /* NMI */
    Default_Handler, /* HardFault */
    Default_Handler, /* MemManage */
    Default_Handler, /* BusFault */
    Default_Handler, /* UsageFault */
    0, 0, 0, 0,      /* reserved */
    Default_Handler, /* SVCall */
    Default_Handler, /* DebugMonitor */
    0,               /* reserved */
    Default_Handler, /* PendSV */
    Default_Handler, /* SysTick */
};
