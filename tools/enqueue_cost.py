"""What launching a kernel costs the host, with the scalar argument types declared
(runtime._Kernel, the default) and without (pyopencl's generic path for each argument):
one kernel of 18 arguments (8 buffers, 8 ints, 2 floats, the shape of fogcli's) enqueued
while the device waits on a user event, so only the host's work is timed; and a 2 MPx frame
of the default pipeline: its launches, the host time in them, kernel_ms and the wall time of
`apply`, each mode in a process of its own (the types are declared once per process), the
two alternating. The host's time comes out of the two cores the kernels run on.
Writes its block of docs/performance.md.

    python tools/enqueue_cost.py [--rounds 3]     # about a minute
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tools")]

from docblock import cpu_kind, cpu_name, markers, publish_performance  # noqa: E402

BEGIN, END = markers(f"enqueue-cost-{cpu_kind()}")

CHILD = r"""
import json, sys, time
import numpy as np
sys.path[:0] = [{src!r}, {bench!r}]
import fogcli.device.runtime as R
if not {declared}:
    R._arg_dtype = lambda arg: None          # every argument through pyopencl's generic path
rt = R.get_runtime(None)
cl, q = rt.cl, rt.queue
# 1. one kernel, 18 arguments, the device held idle by a user event
args = ", ".join([f"__global float *b{{i}}" for i in range(8)] + [f"const int n{{i}}" for i in range(8)]
                 + ["const float f0", "const float f1"])
src = f"__kernel void k({{args}}) {{{{ int i = get_global_id(0); if (i < n0) b0[i] = f0 + f1; }}}}"
prog = R._Kernels(cl, lambda: R.build_source(cl, rt.ctx, src, ["-cl-kernel-arg-info"]))
k = prog.k
bufs = [cl.Buffer(rt.ctx, cl.mem_flags.READ_WRITE, 4096) for _ in range(8)]
a = dict(zip([f"b{{i}}" for i in range(8)] + [f"n{{i}}" for i in range(8)] + ["f0", "f1"],
             bufs + [np.int32(i + 1) for i in range(8)] + [np.float32(1), np.float32(2)]))
k(q, (64,), (64,), **a).wait()
gate = cl.UserEvent(rt.ctx)
cl.enqueue_marker(q, wait_for=[gate])
n = 300
t0 = time.perf_counter()
for _ in range(n):
    k(q, (64,), (64,), **a)
one = (time.perf_counter() - t0) / n * 1e6
gate.set_status(cl.command_execution_status.COMPLETE)
q.finish()
# 2. a 2 MPx frame of the default pipeline
import pyopencl
from fogcli import apply
from fogcli.api import make_config
from fogcli.device.plan import Timings
from fogcli.device.run import kernel_ms
from hdr_scenes import harbour_sample
from performance import size_for
spent = [0.0, 0]
real = pyopencl.Kernel.__call__
def timed(self, *a, **kw):
    t = time.perf_counter()
    ev = real(self, *a, **kw)
    spent[0] += time.perf_counter() - t
    spent[1] += 1
    return ev
pyopencl.Kernel.__call__ = timed
w, h = size_for(2)
rgb, z, fov = harbour_sample(w, h)
cfg = make_config("fog")
apply(rgb, z, cfg)
host, kms, wall, cpu = [], [], [], []
for _ in range({frames}):
    spent[:] = [0.0, 0]
    t = Timings()
    t0, c0 = time.perf_counter(), time.process_time()
    apply(rgb, z, cfg, timings=t)
    wall.append((time.perf_counter() - t0) * 1e3)
    cpu.append((time.process_time() - c0) * 1e3)
    kms.append(kernel_ms(t)[1])
    host.append(spent[0] * 1e3)
print(json.dumps(dict(one=one, launches=spent[1], host=float(np.median(host)), kernel=float(np.median(kms)),
                      wall=float(np.median(wall)), cpu=float(np.median(cpu)))))
"""


def run(declared: bool, frames: int) -> dict:
    code = CHILD.format(src=str(ROOT / "src"), bench=str(ROOT / "tools"), declared=declared, frames=frames)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=6)
    args = ap.parse_args()
    res = {True: [], False: []}
    for _ in range(args.rounds):
        for declared in (False, True):
            res[declared].append(run(declared, args.frames))
            print(("declared" if declared else "undeclared"), res[declared][-1], flush=True)

    def med(declared, key):
        xs = sorted(r[key] for r in res[declared])
        return xs[len(xs) // 2]

    lines = [BEGIN, f"## Launch cost on {cpu_name()}", "",
             f"`python tools/enqueue_cost.py --rounds {args.rounds}` ({os.cpu_count()} cores): the host's time to "
             "launch kernels, with the scalar arguments' types declared at a kernel's first launch (`runtime._Kernel`, "
             "the default) and without (pyopencl's generic path for each argument), each in processes of its own, "
             f"alternating; medians of {args.rounds} processes. The frame: the default pipeline at 2 MPx, median of "
             f"{args.frames} frames a process.", "",
             "| | undeclared | declared | ratio |", "|---|---|---|---|"]
    rows = [("one launch of 18 arguments, device idle (us)", "one", 1),
            (f"host time in a frame's {med(True, 'launches')} launches (ms)", "host", 1),
            ("kernel_ms of the frame (ms)", "kernel", 1), ("wall time of `apply` (ms)", "wall", 1),
            ("CPU time of `apply`, every thread (ms)", "cpu", 1)]
    for name, key, _ in rows:
        u, d = med(False, key), med(True, key)
        lines.append(f"| {name} | {u:.1f} | {d:.1f} | {u / d:.2f}x |")
    lines += ["", "The host's launch time is taken from the cores the kernels run on, so it shows in their "
              "profiling times too (kernel_ms).", END]
    return publish_performance(lines)


if __name__ == "__main__":
    sys.exit(main())
