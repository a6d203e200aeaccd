"""`fogcli batch` throughput, this tree against another commit (issue 12's "1.25x
today's"), in alternating runs of the same frames: 24 EXR frames of 1 MPx with an
embedded Z, `--jobs 1` (the default) and `--jobs 2`, images/s over the whole command and in
the steady state (first to last output written), as benchmarks/throughput.py measures them.

    python benchmarks/ab_batch.py <commit> [--rounds 3] [--frames 24]

The other commit is checked out in a temporary git worktree and run from its own sources.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tests"), str(ROOT / "benchmarks")]

import throughput  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("commit")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=24)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        other, src = Path(tmp) / "other", Path(tmp) / "frames"
        src.mkdir()
        throughput.make_frames(src, args.frames, 1336, 748)
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "-q", "--detach", str(other), args.commit], check=True)
        res: dict = {}
        try:
            for r in range(args.rounds):
                for jobs in ("1", "2"):
                    for name, tree in ((args.commit, other), ("this tree", ROOT)):
                        throughput.ROOT = tree          # run_mode puts ROOT/src on the path
                        out = Path(tmp) / f"out_{r}_{jobs}_{name.replace(' ', '_')}"
                        m = throughput.run_mode(src, out, ["--jobs", jobs])
                        res.setdefault((name, jobs), []).append(m)
                        print(f"{name} --jobs {jobs}: {m['rate']:.2f} images/s, steady {m['steady']:.2f}", flush=True)
        finally:
            throughput.ROOT = ROOT
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(other)], check=False)
    print("\n| --jobs | tree | images/s (best) | steady images/s (best) |\n|---|---|---|---|")
    for (name, jobs), ms in sorted(res.items(), key=lambda kv: (kv[0][1], kv[0][0] != args.commit)):
        print(f"| {jobs} | {name} | {max(m['rate'] for m in ms):.2f} | {max(m['steady'] for m in ms):.2f} |")
    for jobs in ("1", "2"):
        a, b = res[(args.commit, jobs)], res[("this tree", jobs)]
        print(f"--jobs {jobs}: this tree / {args.commit} = {max(m['rate'] for m in b) / max(m['rate'] for m in a):.2f}x "
              f"(steady {max(m['steady'] for m in b) / max(m['steady'] for m in a):.2f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
