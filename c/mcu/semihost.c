/* ARM semihosting calls (operation numbers from the Arm semihosting specification). */
#include "semihost.h"

#include <stdint.h>

#define SYS_OPEN 0x01
#define SYS_CLOSE 0x02
#define SYS_WRITE0 0x04
#define SYS_WRITE 0x05
#define SYS_READ 0x06
#define SYS_FLEN 0x0C
#define SYS_GET_CMDLINE 0x15

static int sh_call(int op, void *arg)
{
    register int r0 __asm__("r0") = op;
    register void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

static size_t length(const char *s)
{
    size_t n = 0;
    while (s[n])
        n++;
    return n;
}

int sh_cmdline(char *buf, int len)
{
    uintptr_t block[2];
    block[0] = (uintptr_t)buf;
    block[1] = (uintptr_t)len;
    return sh_call(SYS_GET_CMDLINE, block) == 0 ? 0 : -1;
}

int sh_open(const char *path, int write)
{
    uintptr_t block[3];
    block[0] = (uintptr_t)path;
    block[1] = write ? 5u : 1u; /* ISO C fopen modes: 1 = "rb", 5 = "wb" */
    block[2] = (uintptr_t)length(path);
    return sh_call(SYS_OPEN, block);
}

int sh_close(int fd)
{
    uintptr_t block[1];
    block[0] = (uintptr_t)fd;
    return sh_call(SYS_CLOSE, block);
}

long sh_flen(int fd)
{
    uintptr_t block[1];
    block[0] = (uintptr_t)fd;
    return sh_call(SYS_FLEN, block);
}

/* SYS_READ and SYS_WRITE answer with the number of bytes NOT transferred */
int sh_read(int fd, void *buf, size_t n)
{
    uintptr_t block[3];
    block[0] = (uintptr_t)fd;
    block[1] = (uintptr_t)buf;
    block[2] = (uintptr_t)n;
    return sh_call(SYS_READ, block) == 0 ? 0 : -1;
}

int sh_write(int fd, const void *buf, size_t n)
{
    uintptr_t block[3];
    block[0] = (uintptr_t)fd;
    block[1] = (uintptr_t)buf;
    block[2] = (uintptr_t)n;
    return sh_call(SYS_WRITE, block) == 0 ? 0 : -1;
}

void sh_puts(const char *s)
{
    sh_call(SYS_WRITE0, (void *)(uintptr_t)s);
}
