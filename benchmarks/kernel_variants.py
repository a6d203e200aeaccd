"""One kernel's source variants timed against the kernel as it is, in one process, on the
arguments the default pipeline gives it at the largest launch of a frame, the variants'
launches interleaved (this VM's speed drifts between processes; within one, ratios hold).
A variant is a set of text substitutions in kernels/ (a copy of it), as JSON:

    {"no_table": {"common.h": [["old text", "new text"], ...], "preprocess.cl": [...]}, ...}

    python benchmarks/kernel_variants.py preprocess preprocess variants.json [--mpx 2 | --size WxH]
        [--rounds 15] [--lanes 1]

The first two arguments: the kernel's name and its program (kernels/<program>.cl). The
variants build with the options of the program the pipeline launched the kernel from. --lanes 1 makes the pipeline take the paths it takes on a
CPU that is not 8 wide (reduce_source_inner, for one). A variant that only removes work
measures that work's cost; one that reads other data (a faked layout) measures its access
pattern, not its result.
"""
from __future__ import annotations

import argparse
import json
import shlex
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "benchmarks")]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kernel")
    ap.add_argument("program")
    ap.add_argument("variants", help="JSON file of text substitutions per variant")
    ap.add_argument("--mpx", type=float, default=2.0)
    ap.add_argument("--size", help="WxH instead of --mpx")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--lanes", type=int, help="Runtime.lanes to force (1: the paths of a CPU that is not 8 wide)")
    args = ap.parse_args()
    variants = json.loads(Path(args.variants).read_text())

    import pyopencl as cl

    import fogcli.runtime as R
    from fogcli import apply
    from fogcli.api import make_config
    from fogcli.scenes import harbour_sample
    from performance import size_for

    calls = []
    real_call = cl.Kernel.__call__

    def call(self, queue, global_size, local_size, *a, **kw):
        if self.function_name == args.kernel and not kw:
            prog = self.get_info(cl.kernel_info.PROGRAM)
            built = prog.get_build_info(queue.device, cl.program_build_info.OPTIONS)
            calls.append((global_size, local_size, a, shlex.split(built)))
        return real_call(self, queue, global_size, local_size, *a, **kw)

    cl.Kernel.__call__ = call
    w, h = (int(v) for v in args.size.split("x")) if args.size else size_for(args.mpx)
    rgb, z, _ = harbour_sample(w, h)
    rt = R.get_runtime(None)
    if args.lanes:
        rt.lanes = args.lanes
    apply(rgb, z, make_config("fog"))
    cl.Kernel.__call__ = real_call
    if not calls:
        print(f"{args.kernel} was not launched by the default pipeline at {w}x{h}", file=sys.stderr)
        return 2
    # the largest launch, with the options its own program was built with
    gsize, lsize, kargs, base_opts = max(calls, key=lambda c: int(np.prod(c[0])))
    kernels = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, subs in {"as it is": {}, **variants}.items():
            d = Path(tmp) / f"v{len(kernels)}"
            shutil.copytree(R.KERNEL_DIR, d)
            for fname, pairs in subs.items():
                p = d / fname
                text = p.read_text()
                for old, new in pairs:
                    if old not in text:
                        print(f"variant {name}: {fname} has no {old[:60]!r}", file=sys.stderr)
                        return 2
                    text = text.replace(old, new)
                p.write_text(text)
            o = [str(d) if x == str(R.KERNEL_DIR) else x for x in base_opts]
            prog = cl.Program(rt.ctx, (d / f"{args.program}.cl").read_text()).build(options=o)
            kernels[name] = cl.Kernel(prog, args.kernel)
        times = {name: [] for name in kernels}
        for _ in range(args.rounds):
            for name, k in kernels.items():
                k.set_args(*kargs)
                ev = cl.enqueue_nd_range_kernel(rt.queue, k, gsize, lsize)
                ev.wait()
                times[name].append((ev.profile.end - ev.profile.start) * 1e-6)
    base = float(np.median(times["as it is"]))
    print(f"{args.kernel} at {w}x{h}, global {tuple(gsize)}, local {lsize}, {args.rounds} rounds interleaved")
    for name, t in times.items():
        print(f"  {name:28s} best {min(t):8.2f} ms  median {np.median(t):8.2f} ms  {np.median(t) / base:5.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
