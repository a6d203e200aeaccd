/* fakecpu.so: make a process see an AVX2-only x86-64 CPU on an AVX-512 host.
 *
 * LD_PRELOAD=/path/fakecpu.so FAKECPU=znver1|haswell  <program>
 *
 * Linux CPUID faulting (arch_prctl(ARCH_SET_CPUID, 0), /proc/cpuinfo flag
 * "cpuid_fault") turns every CPUID instruction executed after this library's
 * constructor into SIGSEGV; the handler runs the real CPUID and edits the
 * answer:
 *   - leaf 7: AVX-512 (all of it), AVX-VNNI, VAES, GFNI, ... removed: ebx keeps
 *     only fsgsbase bmi1 avx2 smep bmi2 rdseed adx smap clflushopt sha, ecx and
 *     edx are cleared; leaf 7 subleaf 1 cleared.
 *   - FAKECPU=znver1 (default): vendor AuthenticAMD, family 17h model 01h
 *     (EPYC 7001 "Naples"), leaf 0x80000001 ecx gains sse4a.
 *     LLVM's sys::getHostCPUName() then says "znver1".
 *   - FAKECPU=haswell: vendor kept (GenuineIntel), family 6 model 3Ch;
 *     LLVM says "haswell".
 * Everything else is the host's. glibc and ld.so detected the CPU before the
 * constructor ran, so libc's own string functions keep their AVX-512/EVEX
 * code; code that asks CPUID later (LLVM inside PoCL, numpy's dispatch,
 * hwloc) sees the fake CPU.
 *
 * The SIGSEGV handler stays installed: sigaction()/signal() calls for SIGSEGV
 * by the program (e.g. Python's faulthandler, which pytest enables) are
 * recorded, not installed, and a SIGSEGV that is not a CPUID fault is passed
 * on to the recorded handler (or kills the process as usual).
 * CPUID faulting is per thread, inherited by threads and fork children, reset
 * by execve (a child process gets it again through LD_PRELOAD in its env).
 * FAKECPU_DEBUG=1 prints every emulated CPUID to stderr.
 */
#define _GNU_SOURCE
#include <asm/prctl.h>
#include <dlfcn.h>
#include <errno.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/syscall.h>
#include <ucontext.h>
#include <unistd.h>

static int fake_amd = 1;
static int debug = 0;
static struct sigaction app_segv; /* what the program asked for */
static int (*real_sigaction)(int, const struct sigaction *, struct sigaction *);

static inline void real_cpuid(uint32_t leaf, uint32_t sub, uint32_t r[4])
{
  __asm__ volatile("cpuid" : "=a"(r[0]), "=b"(r[1]), "=c"(r[2]), "=d"(r[3]) : "a"(leaf), "c"(sub));
}

static void edit(uint32_t leaf, uint32_t sub, uint32_t r[4])
{
  switch (leaf) {
  case 0:
    if (fake_amd) { r[1] = 0x68747541; r[3] = 0x69746e65; r[2] = 0x444d4163; } /* AuthenticAMD */
    break;
  case 1:
    /* family/model/stepping */
    r[0] = fake_amd ? 0x00800F12 /* fam 0xF+0x8=17h, model 01h, step 2 */
                    : 0x000306C3 /* fam 6, model 3Ch, step 3 (Haswell) */;
    break;
  case 7:
    if (sub == 0) {
      const uint32_t keep = (1u << 0) | (1u << 3) | (1u << 5) | (1u << 7) | (1u << 8) | (1u << 18)
                            | (1u << 19) | (1u << 20) | (1u << 23) | (1u << 29);
      r[1] &= keep;
      r[2] = 0;
      r[3] = 0;
    } else {
      r[0] = r[1] = r[2] = r[3] = 0;
    }
    break;
  case 0x80000001:
    if (fake_amd) r[2] |= 1u << 6; /* sse4a */
    break;
  }
}

static void handler(int sig, siginfo_t *si, void *vctx)
{
  ucontext_t *uc = (ucontext_t *)vctx;
  greg_t *g = uc->uc_mcontext.gregs;
  const unsigned char *ip = (const unsigned char *)g[REG_RIP];
  if (si->si_code == SI_KERNEL && ip && ip[0] == 0x0F && ip[1] == 0xA2) {
    int saved = errno;
    uint32_t leaf = (uint32_t)g[REG_RAX], sub = (uint32_t)g[REG_RCX], r[4];
    syscall(SYS_arch_prctl, ARCH_SET_CPUID, 1);
    real_cpuid(leaf, sub, r);
    syscall(SYS_arch_prctl, ARCH_SET_CPUID, 0);
    edit(leaf, sub, r);
    if (debug) {
      char b[128];
      int n = snprintf(b, sizeof b, "fakecpu: cpuid(%#x,%#x) = %08x %08x %08x %08x\n", leaf, sub, r[0], r[1], r[2], r[3]);
      if (write(2, b, n) < 0) {}
    }
    g[REG_RAX] = r[0]; g[REG_RBX] = r[1]; g[REG_RCX] = r[2]; g[REG_RDX] = r[3];
    g[REG_RIP] += 2;
    errno = saved;
    return;
  }
  /* not ours: hand it to the program's handler, or die the default way */
  if (app_segv.sa_flags & SA_SIGINFO) {
    if (app_segv.sa_sigaction) { app_segv.sa_sigaction(sig, si, vctx); return; }
  } else if (app_segv.sa_handler == SIG_IGN) {
    return;
  } else if (app_segv.sa_handler != SIG_DFL) {
    app_segv.sa_handler(sig);
    return;
  }
  struct sigaction dfl;
  memset(&dfl, 0, sizeof dfl);
  dfl.sa_handler = SIG_DFL;
  real_sigaction(SIGSEGV, &dfl, NULL); /* returning re-executes the faulting insn */
}

int sigaction(int sig, const struct sigaction *act, struct sigaction *old)
{
  if (!real_sigaction) real_sigaction = dlsym(RTLD_NEXT, "sigaction");
  if (sig != SIGSEGV) return real_sigaction(sig, act, old);
  if (old) *old = app_segv;
  if (act) app_segv = *act;
  return 0;
}

sighandler_t signal(int sig, sighandler_t h)
{
  struct sigaction a, o;
  memset(&a, 0, sizeof a);
  a.sa_handler = h;
  a.sa_flags = SA_RESTART;
  sigemptyset(&a.sa_mask);
  if (sigaction(sig, &a, &o) != 0) return SIG_ERR;
  return (o.sa_flags & SA_SIGINFO) ? (sighandler_t)o.sa_sigaction : o.sa_handler;
}

__attribute__((constructor)) static void fakecpu_init(void)
{
  const char *m = getenv("FAKECPU");
  if (m && strcmp(m, "haswell") == 0) fake_amd = 0;
  else if (m && *m && strcmp(m, "znver1") != 0) {
    fprintf(stderr, "fakecpu: FAKECPU=%s unknown (znver1 or haswell)\n", m);
    return;
  }
  debug = getenv("FAKECPU_DEBUG") && *getenv("FAKECPU_DEBUG") == '1';
  real_sigaction = dlsym(RTLD_NEXT, "sigaction");
  memset(&app_segv, 0, sizeof app_segv);
  app_segv.sa_handler = SIG_DFL;
  struct sigaction a;
  memset(&a, 0, sizeof a);
  a.sa_sigaction = handler;
  a.sa_flags = SA_SIGINFO | SA_NODEFER | SA_ONSTACK;
  sigemptyset(&a.sa_mask);
  if (real_sigaction(SIGSEGV, &a, NULL) != 0 || syscall(SYS_arch_prctl, ARCH_SET_CPUID, 0) != 0) {
    fprintf(stderr, "fakecpu: CPUID faulting unavailable (%s); CPU NOT faked\n", strerror(errno));
    return;
  }
}
