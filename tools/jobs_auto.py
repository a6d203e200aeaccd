"""`fogcli batch --jobs` against the batch's size (issue 41): ten 640x360 frames and 24 frames
of 1920x1080 (EXR, half, embedded Z, default fog), each command a new process as a user
runs it (discovery, worker start-up and report included), the modes alternated in every
round (the machine is noisy); median and best wall time of the rounds, and the command's
core time (user + system, its workers' included) over the frames. Prints a table and writes
its section of docs/performance.md.

    python tools/jobs_auto.py [--rounds 5]
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tests"), str(ROOT / "tools")]

from docblock import cpu_kind, cpu_name, markers, publish_performance  # noqa: E402

BEGIN, END = markers(f"batch-jobs-{cpu_kind()}")
BATCHES = [("10 frames of 640x360", 10, 640, 360, ("auto", "1", "2")),
           ("24 frames of 1920x1080", 24, 1920, 1080, ("auto", "1", "2"))]


def make(folder: Path, n: int, w: int, h: int) -> None:
    from hdr_scenes import scene
    from helpers import write_img

    folder.mkdir(parents=True)
    for i in range(n):
        rgb, z, _ = scene(w, h, seed=900 + i)
        write_img(folder / f"f{i:03d}.exr", np.dstack([rgb, z]), ["R", "G", "B", "Z"], fmt="half")


def run(src: Path, out: Path, jobs: str) -> tuple[float, float]:
    """(wall s, core s) of one `fogcli batch` process with its workers."""
    shutil.rmtree(out, ignore_errors=True)
    t0, r0 = time.perf_counter(), os.times()
    p = subprocess.run([sys.executable, "-m", "fogcli", "batch", str(src), str(out), "-q", "--jobs", jobs],
                       capture_output=True, text=True)
    wall, r1 = time.perf_counter() - t0, os.times()
    if p.returncode != 0:
        raise SystemExit(f"--jobs {jobs}: exit {p.returncode}: {p.stderr.strip()}")
    return wall, (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args()
    from fogcli.batch.worker_count import auto_jobs, usable_cores

    lines = [BEGIN, f"## `fogcli batch --jobs` on {cpu_name()}", "",
             f"`python tools/jobs_auto.py --rounds {a.rounds}`, {usable_cores()} cores. Each command a new "
             "process (discovery, worker start-up and the report included), the modes alternated in every round; "
             "wall time median (best) of the rounds; vs --jobs 1: the median of the rounds' ratios; core s a frame: the command's user + system time, its "
             "workers' included, over the frames (median). `--jobs auto` is what the batch runs without --jobs.", "",
             "| batch | --jobs | workers | wall s | vs --jobs 1 | core s a frame |", "|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        for label, n, w, h, modes in BATCHES:
            src = d / f"in_{w}x{h}"
            make(src, n, w, h)
            res = {m: [] for m in modes}
            for r in range(a.rounds):
                for m in (modes if r % 2 == 0 else modes[::-1]):
                    res[m].append(run(src, d / f"out_{m}", m))
            for m in modes:
                walls = [x for x, _ in res[m]]
                ratio = np.median([b / x for (b, _), x in zip(res["1"], walls)])     # of each round's pair
                workers = auto_jobs(n, w * h) if m == "auto" else int(m)
                lines.append(f"| {label} | {m} | {workers} | {np.median(walls):.2f} ({min(walls):.2f}) | "
                             f"{ratio:.2f}x | {np.median([c for _, c in res[m]]) / n:.3f} |")
    lines += ["", "One process keeps both cores of this machine busy (PoCL's threads in the kernels, the reads "
              "and writes on threads beside them), so spawned workers add their start-up and gain no core time: "
              "`--jobs auto` runs one process here, and one worker per 4 cores on larger machines for batches "
              "long enough to pay the workers' start-up (src/fogcli/batch/worker_count.py).", END]
    return publish_performance(lines)


if __name__ == "__main__":
    sys.exit(main())
