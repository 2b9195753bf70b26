/* ARM semihosting (the host debugger/QEMU services the "bkpt 0xab" trap): just what the harness needs. */
#ifndef MCU_SEMIHOST_H
#define MCU_SEMIHOST_H

#include <stddef.h>

/* the command line given to QEMU (-semihosting-config ...,arg=...), NUL-terminated; -1 on failure */
int sh_cmdline(char *buf, int len);
/* open a host file, mode "rb" (0) or "wb" (1): a handle, or -1 */
int sh_open(const char *path, int write);
int sh_close(int fd);
/* the file's length in bytes, or -1 */
long sh_flen(int fd);
/* 0 when all n bytes were transferred */
int sh_read(int fd, void *buf, size_t n);
int sh_write(int fd, const void *buf, size_t n);
/* a message on the host's standard error/output console */
void sh_puts(const char *s);

#endif
