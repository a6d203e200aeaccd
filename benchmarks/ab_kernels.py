"""Kernel time of the default pipeline at 2 MPx, this tree against another commit, in
alternating processes: this VM's speed drifts up to 2x within minutes, so only a same-run
comparison says whether a change is faster. Each process runs `--frames` frames and
reports its best and median kernel_ms, a numpy copy of the image, and the median of each
run's kernel_ms over an in-place copy of the image taken right after it (the drift moves
both alike, so this ratio is the one to compare). Its spread on an AMD EPYC VM: two 5-round
runs of the same change gave 1.15x and 0.97x, so a change under ~10 % needs 8+ rounds, twice.

    python benchmarks/ab_kernels.py <commit> [--rounds 3] [--frames 8] [--avx2] [--medium M] [--set K=V ...]

The other commit is checked out in a temporary git worktree; --avx2 runs both under
benchmarks/avx2/run.sh znver1 (the kernels as an AMD EPYC Zen 1 compiles them).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import json, sys
import numpy as np
sys.path.insert(0, {bench!r})
from fogcli import apply
from fogcli.api import make_config
from fogcli.pipeline import Timings, kernel_ms
from fogcli.scenes import harbour_sample
from performance import copy_in_place_ms, copy_ms, size_for
w, h = size_for(2)
rgb, z, fov = harbour_sample(w, h)
cfg = make_config("fog")
apply(rgb, z, cfg)
ts, paired = [], []
for _ in range({frames}):
    t = Timings()
    apply(rgb, z, cfg, timings=t)
    ts.append(kernel_ms(t)[1])
    paired.append(ts[-1] / copy_in_place_ms((h, w, 4), reps=5))    # the copy right after the run
print(json.dumps(dict(best=min(ts), median=float(np.median(ts)), copy=copy_ms((h, w, 4)),
                      paired=float(np.median(paired)))))
"""


def run(tree: Path, frames: int, avx2: bool, medium: str = "fog", sets: tuple = ()) -> dict:
    cmd = ([str(ROOT / "benchmarks" / "avx2" / "run.sh"), "znver1"] if avx2 else []) + [
        sys.executable, "-c", CHILD.format(bench=str(ROOT / "benchmarks"), frames=frames, medium=medium,
                                           sets=list(sets))]
    r = subprocess.run(cmd, capture_output=True, text=True, check=True,
                       env={**os.environ, "PYTHONPATH": str(tree / "src")})
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("commit")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--avx2", action="store_true")
    ap.add_argument("--medium", default="fog", help="a preset or config file (default fog)")
    ap.add_argument("--set", action="append", default=[], dest="sets", help="a config key, as fogcli apply --set")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        other = Path(tmp) / "other"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "-q", "--detach", str(other), args.commit], check=True)
        try:
            res = {args.commit: [], "this tree": []}
            for _ in range(args.rounds):
                for name, tree in ((args.commit, other), ("this tree", ROOT)):
                    r = run(tree, args.frames, args.avx2, args.medium, args.sets)
                    res[name].append(r)
                    print(f"{name}: best {r['best']:.1f} ms, median {r['median']:.1f} ms, copy {r['copy']:.2f} ms "
                          f"({r['best'] / r['copy']:.1f} copies), each run in the in-place copy after it {r['paired']:.1f} (median)",
                          flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(other)], check=False)
    for name, rs in res.items():
        print(f"{name}: best of rounds {min(r['best'] for r in rs):.1f} ms, "
              f"median of medians {sorted(r['median'] for r in rs)[len(rs) // 2]:.1f} ms, "
              f"paired copies, median of rounds {sorted(r['paired'] for r in rs)[len(rs) // 2]:.1f}")
    a, b = (sorted(r["paired"] for r in rs)[len(rs) // 2] for rs in res.values())
    print(f"this tree / {args.commit}, in paired copies: {b / a:.3f} (the ratio least moved by the VM's drift)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
