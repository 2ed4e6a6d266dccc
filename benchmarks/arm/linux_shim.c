/*
 * linux_shim.c: newlib's system calls as Linux EABI syscalls, and a _start, so that a program built
 * with arm-none-eabi-gcc for a Cortex-M (Thumb-2, -mfloat-abi=hard) runs under qemu-arm user mode
 * (`qemu-arm -cpu max PROGRAM ARGS`): the M-profile code runs on the emulated A-profile core, whose
 * Thumb-2 and VFP instruction sets contain the Cortex-M4F's and M7's. For measurement only
 * (benchmarks/arm_target.py): a board runs the export with its own start-up code.
 *
 * Link: arm-none-eabi-gcc ... -nostartfiles PROGRAM.c linux_shim.c -lc -lgcc
 */
#include <errno.h>
#include <stdint.h>
#include <sys/stat.h>
#include <sys/types.h>

#undef errno
extern int errno;

static long sys3(long n, long a, long b, long c)
{
    register long r0 __asm__("r0") = a;
    register long r1 __asm__("r1") = b;
    register long r2 __asm__("r2") = c;
    register long r7 __asm__("r7") = n;
    __asm__ volatile("svc 0" : "+r"(r0) : "r"(r1), "r"(r2), "r"(r7) : "memory");
    return r0;
}

static long ret(long r)
{
    if (r < 0 && r > -4096) {
        errno = (int)-r;
        return -1;
    }
    return r;
}

void _exit(int code)
{
    for (;;)
        sys3(248, code, 0, 0);   /* exit_group */
}

int _write(int fd, const char *p, int n) { return (int)ret(sys3(4, fd, (long)p, n)); }
int _read(int fd, char *p, int n) { return (int)ret(sys3(3, fd, (long)p, n)); }
int _open(const char *path, int flags, int mode) { return (int)ret(sys3(5, (long)path, flags, mode)); }
int _close(int fd) { return (int)ret(sys3(6, fd, 0, 0)); }
int _lseek(int fd, int off, int whence) { return (int)ret(sys3(19, fd, off, whence)); }
int _isatty(int fd) { return fd < 3; }
int _fstat(int fd, struct stat *st) { (void)fd; st->st_mode = S_IFCHR; return 0; }
int _kill(int pid, int sig) { (void)pid; (void)sig; errno = EINVAL; return -1; }
int _getpid(void) { return 1; }

static char heap[1 << 20];
static char *brk_ = heap;

void *_sbrk(ptrdiff_t n)
{
    char *p = brk_;
    if (brk_ + n > heap + sizeof heap) {
        errno = ENOMEM;
        return (void *)-1;
    }
    brk_ += n;
    return p;
}

extern int main(int argc, char **argv);
extern void exit(int code);

__attribute__((used)) void shim_cstart(long *sp)
{
    exit(main((int)sp[0], (char **)(sp + 1)));
}

/* Linux enters with sp at argc, argv[]; the FPU is on (CPACR) in user mode. */
__attribute__((naked)) void _start(void)
{
    __asm__ volatile("mov r0, sp\n\tbl shim_cstart\n");
}

void _init(void) {}
void _fini(void) {}
