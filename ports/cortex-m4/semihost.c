/*
 * semihost.c - ARM semihosting calls (semihost.h).
 */
#include "semihost.h"

#include <stdint.h>
#include <string.h>

#define SYS_OPEN 0x01
#define SYS_CLOSE 0x02
#define SYS_WRITE0 0x04
#define SYS_WRITE 0x05
#define SYS_READ 0x06
#define SYS_EXIT_EXTENDED 0x20
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u

/* Operation op with r1 = arg; returns r0. */
static int sh_call(int op, const void *arg)
{
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

int sh_open(const char *name, int write)
{
    /* modes of fopen: 1 = "rb", 5 = "wb" */
    uint32_t block[3];
    block[0] = (uint32_t)(uintptr_t)name;
    block[1] = write ? 5u : 1u;
    block[2] = (uint32_t)strlen(name);
    return sh_call(SYS_OPEN, block);
}

int sh_read(int handle, void *buf, size_t len)
{
    uint32_t block[3];
    block[0] = (uint32_t)handle;
    block[1] = (uint32_t)(uintptr_t)buf;
    block[2] = (uint32_t)len;
    /* r0 = the number of bytes NOT read */
    return sh_call(SYS_READ, block) == 0 ? 0 : -1;
}

long sh_read_part(int handle, void *buf, size_t len)
{
    uint32_t block[3];
    int left;
    block[0] = (uint32_t)handle;
    block[1] = (uint32_t)(uintptr_t)buf;
    block[2] = (uint32_t)len;
    left = sh_call(SYS_READ, block);
    if (left < 0 || (size_t)left > len) return -1;
    return (long)(len - (size_t)left);
}

int sh_write(int handle, const void *buf, size_t len)
{
    uint32_t block[3];
    block[0] = (uint32_t)handle;
    block[1] = (uint32_t)(uintptr_t)buf;
    block[2] = (uint32_t)len;
    return sh_call(SYS_WRITE, block) == 0 ? 0 : -1;
}

int sh_close(int handle)
{
    uint32_t block[1];
    block[0] = (uint32_t)handle;
    return sh_call(SYS_CLOSE, block);
}

void sh_puts(const char *s)
{
    (void)sh_call(SYS_WRITE0, s);
}

void sh_exit(int code)
{
    uint32_t block[2];
    block[0] = ADP_STOPPED_APPLICATION_EXIT;
    block[1] = (uint32_t)code;
    (void)sh_call(SYS_EXIT_EXTENDED, block);
    for (;;) {
    }
}
