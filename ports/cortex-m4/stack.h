/*
 * stack.h - the stack high-water mark of the QEMU images (qemu_main.c,
 * live_main.c): the stack section (_sstack.._estack of mps2_an386.ld) is
 * painted at main's entry and scanned at the end (docs/decisions.md,
 * decision 64).
 */
#ifndef M4_STACK_H
#define M4_STACK_H

#include <stdint.h>

/* Paints from the bottom of the stack to 256 bytes below this call's frame. */
void m4_stack_paint(void);
/* Bytes of the stack written since the paint (from its top down to the
 * lowest word no longer painted). */
uint32_t m4_stack_used(void);
/* Bytes of the stack section. */
uint32_t m4_stack_size(void);

#endif /* M4_STACK_H */
