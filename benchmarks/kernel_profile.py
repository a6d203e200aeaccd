"""Every kernel launch of one frame of the default pipeline, by kernel and global size: best
and median over the frames of one process (OpenCL profiling events), the frame's kernel_ms,
and an in-place numpy copy of the RGBA image measured right after, in the same process.
Where performance.py gives a stage's time, this says which launch inside it costs what
(the checked strips around a whole-groups launch show up as their own rows).

    python benchmarks/kernel_profile.py [--mpx 2] [--frames 6] [--medium fog] [--set K=V ...]
"""
from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "benchmarks")]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mpx", type=float, default=2.0)
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--medium", default="fog", help="a preset or config file (default fog)")
    ap.add_argument("--set", action="append", default=[], dest="sets", help="a config key, as fogcli apply --set")
    args = ap.parse_args()

    import pyopencl as cl

    from fogcli import apply
    from fogcli.api import make_config
    from fogcli.pipeline import Timings, kernel_ms
    from fogcli.scenes import harbour_sample
    from performance import copy_in_place_ms, size_for

    launches = []
    real = cl.Kernel.__call__

    def recorded(self, queue, global_size, *rest, **kw):
        ev = real(self, queue, global_size, *rest, **kw)
        launches.append((f"{self.function_name} {tuple(int(g) for g in global_size)}", ev))
        return ev

    cl.Kernel.__call__ = recorded
    w, h = size_for(args.mpx)
    rgb, z, _ = harbour_sample(w, h)
    cfg = make_config(args.medium, sets=args.sets)
    apply(rgb, z, cfg)                      # programs and buffers
    per, totals = collections.defaultdict(list), []
    for _ in range(args.frames):
        launches.clear()
        t = Timings()
        apply(rgb, z, cfg, timings=t)
        totals.append(kernel_ms(t)[1])
        frame = collections.defaultdict(float)
        for name, ev in launches:
            frame[name] += (ev.profile.end - ev.profile.start) * 1e-6
        for name, ms in frame.items():
            per[name].append(ms)
    copy = copy_in_place_ms((h, w, 4))
    print(f"{w}x{h}, {args.medium} {' '.join(args.sets)}: kernel_ms best {min(totals):.1f}, median "
          f"{np.median(totals):.1f}; in-place copy {copy:.2f} ms ({min(totals) / copy:.1f} copies); "
          f"{len(per)} kernel x size rows, launches of a frame {len(launches)}")
    print(f"{'kernel (global size)':44s} {'best ms':>8s} {'median':>8s}")
    for name, ms in sorted(per.items(), key=lambda kv: -min(kv[1])):
        print(f"{name:44s} {min(ms):8.2f} {np.median(ms):8.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
