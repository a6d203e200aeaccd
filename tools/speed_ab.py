"""The default pipeline's speed at 2 MPx against another revision, in one run: rounds
alternate between a checkout of BASE (a temporary git worktree) and this tree, each round
a fresh process timing fogcli.apply on the 1920 x 1080 night scene (tools/hdr_scenes,
seed 3, `--medium fog`) as the median of 8 calls after a warm-up. Prints every round and
the ratio of the medians (this tree over BASE). Machines are noisy: read the rounds.

    python tools/speed_ab.py BASE [--rounds 6]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CHILD = r'''
import sys, time, numpy as np
sys.path.insert(0, sys.argv[1])
from hdr_scenes import scene
from fogcli import apply
from fogcli.api import make_config
rgb, z, fov = scene(1920, 1080, seed=3)
cfg = make_config("fog", sets=[f"camera.fov={fov}"])
apply(rgb, z, cfg)
ts = []
for _ in range(8):
    t = time.perf_counter(); apply(rgb, z, cfg); ts.append(time.perf_counter() - t)
print(np.median(ts))
'''


def one(tree: Path) -> float:
    env = dict(os.environ, PYTHONPATH=str(tree / "src"))
    r = subprocess.run([sys.executable, "-c", CHILD, str(ROOT / "tools")], cwd=tree, env=env,
                       capture_output=True, text=True, check=True)
    return float(r.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("base", help="a git revision")
    ap.add_argument("--rounds", type=int, default=6)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(base), args.base], check=True)
        try:
            got = {"base": [], "this tree": []}
            for k in range(args.rounds):
                for name, tree in (("base", base), ("this tree", ROOT)):
                    got[name].append(one(tree))
                    print(f"round {k + 1} {name:9s} {got[name][-1] * 1e3:7.1f} ms", flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)], check=True)
    b, t = float(np.median(got["base"])), float(np.median(got["this tree"]))
    print(f"median: base {args.base} {b * 1e3:.1f} ms, this tree {t * 1e3:.1f} ms, ratio {t / b:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
