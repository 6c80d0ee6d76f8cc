/*
 * stack.c - painting and scanning the stack (stack.h).
 */
#include "stack.h"

extern uint32_t _sstack[], _estack[];
#define M4_PAINT 0xC5C5C5C5u

__attribute__((noinline)) void m4_stack_paint(void)
{
    volatile uint32_t here = 0u;
    uint32_t *p = _sstack;
    const uintptr_t lim = (uintptr_t)&here - 256u;
    while ((uintptr_t)p < lim) *p++ = M4_PAINT;
    (void)here;
}

uint32_t m4_stack_used(void)
{
    const uint32_t *p = _sstack;
    while (p < _estack && *p == M4_PAINT) ++p;
    return (uint32_t)((uintptr_t)_estack - (uintptr_t)p);
}

uint32_t m4_stack_size(void)
{
    return (uint32_t)((uintptr_t)_estack - (uintptr_t)_sstack);
}
