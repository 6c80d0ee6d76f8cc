/*
 * semihost.h - the few ARM semihosting calls the emulated-M4 image uses
 * (QEMU -semihosting-config enable=on,target=native): files of the host's
 * working directory, a console line, and the exit status.
 *
 * Each call is one `bkpt 0xab` (the Thumb semihosting trap): no newlib
 * stdio, so no FILE buffers and no heap. Semihosting operation numbers and
 * argument blocks: Arm "Semihosting for AArch32 and AArch64", v2.0.
 */
#ifndef M4_SEMIHOST_H
#define M4_SEMIHOST_H

#include <stddef.h>

/* Opens `name` of the host for reading (write = 0) or writing, binary;
 * the handle, or -1. */
int sh_open(const char *name, int write);
/* Reads exactly len bytes; 0 if all were read, -1 otherwise. */
int sh_read(int handle, void *buf, size_t len);
/* Reads at most len bytes: the number read (0 at the end of the file or
 * when the writer of a pipe has closed it), or -1. A pipe may return fewer
 * bytes than asked for while more are on their way. */
long sh_read_part(int handle, void *buf, size_t len);
/* Writes len bytes; 0 if all were written, -1 otherwise. */
int sh_write(int handle, const void *buf, size_t len);
int sh_close(int handle);
/* A NUL-terminated string on the host's console (QEMU's stderr/stdout). */
void sh_puts(const char *s);
/* Ends the program with `code` as QEMU's exit status
 * (SYS_EXIT_EXTENDED, reason ADP_Stopped_ApplicationExit). */
void sh_exit(int code);

#endif /* M4_SEMIHOST_H */
