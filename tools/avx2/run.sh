#!/bin/bash
# Run a command as on an AVX2-only CPU: AMD EPYC of the first Zen generation (LLVM cpu
# znver1, the default) or an Intel Haswell, on a machine that has AVX-512. PoCL compiles
# for the CPU that CPUID reports, so kernels built under this are the code that machine
# would run (its memory and clock are this machine's).
#   tools/avx2/run.sh [znver1|haswell] <command...>
# Needs Linux CPUID faulting (the cpuid_fault flag of /proc/cpuinfo; virtual machines on
# KVM have it). Kernel caches stay apart: PoCL keys its cache on the LLVM cpu and fogcli's
# key on the device version, which names it ("... pthread-x86_64-unknown-linux-gnu-znver1").
here=$(cd "$(dirname "$0")" && pwd)
cpu=znver1; case "$1" in znver1|haswell) cpu=$1; shift;; esac
grep -qw cpuid_fault /proc/cpuinfo || { echo "avx2/run.sh: this CPU or kernel has no cpuid_fault; cannot emulate" >&2; exit 2; }
so="${XDG_CACHE_HOME:-$HOME/.cache}/fogcli/fakecpu.so"
if [ ! -f "$so" ] || [ "$here/fakecpu.c" -nt "$so" ]; then
    mkdir -p "$(dirname "$so")" && gcc -O2 -Wall -shared -fPIC "$here/fakecpu.c" -o "$so.tmp" -ldl && mv "$so.tmp" "$so" || exit 2
fi
export LD_PRELOAD="$so${LD_PRELOAD:+:$LD_PRELOAD}" FAKECPU=$cpu
exec "$@"
