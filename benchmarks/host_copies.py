"""The host's whole-frame moves at 2 MPx (fogcli/pixels.py through OpenCV against the numpy
expressions they replace), best of 9 each, in one run, and the time they save per frame.
Writes its block of docs/performance.md.

    python benchmarks/host_copies.py        # a few seconds
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "benchmarks")]

from docblock import cpu_kind, cpu_name, markers, publish_performance  # noqa: E402
from fogcli import pixels  # noqa: E402

BEGIN, END = markers(f"host-copies-{cpu_kind()}")
W, H = 1888, 1062


def best(fn, n=9) -> float:
    t = 1e9
    for _ in range(n):
        s = time.perf_counter()
        fn()
        t = min(t, time.perf_counter() - s)
    return t * 1e3


def main() -> int:
    from fogcli.runtime import get_runtime

    cpu = get_runtime(None).info.label()
    rng = np.random.default_rng(0)
    half = (rng.random((H, W, 4)) * 10).astype(np.float16)
    rgba = half.astype(np.float32)
    rgb = np.ascontiguousarray(rgba[:, :, :3])
    dst = np.empty_like(rgba)
    kept = half.copy()

    def numpy_gather():      # exr.py's strips before: each channel assigned into the half output
        out = np.empty((H, W, 4), np.float16)
        for c in range(3):
            out[:, :, c] = rgb[:, :, c]
        out[:, :, 3] = kept[:, :, 3]
        return out

    rows = [
        ("RGB + Z -> half RGBZ (write)", numpy_gather,
         lambda: pixels.gather([(rgb, 0), (rgb, 1), (rgb, 2), (kept, 3)], np.float16)),
        ("half RGBZ -> float (read)", lambda: half.astype(np.float32), lambda: pixels.widen(half)),
        ("RGB of RGBZ (read)", lambda: np.ascontiguousarray(rgba[:, :, [0, 1, 2]]), lambda: pixels.take(rgba, [0, 1, 2])),
        ("RGB into RGBA (upload)", lambda: (dst.__setitem__((slice(None), slice(None), slice(0, 3)), rgb),
                                            dst.__setitem__((slice(None), slice(None), 3), 1.0)),
         lambda: pixels.pack_rgba(dst, rgb, None)),
    ]
    lines = [BEGIN, f"## Host copies on {cpu_name()}", "",
             f"`python benchmarks/host_copies.py` on {cpu}, {os.cpu_count()} cores: the whole-frame moves of reading "
             f"and uploading a {W}x{H} frame, numpy's expression against `fogcli/pixels.py` (OpenCV; the same bits), "
             "best of 9 each, in one run.", "",
             "| move | numpy ms | pixels.py ms | ratio |", "|---|---|---|---|"]
    saved = 0.0
    for name, a, b in rows:
        ta, tb = best(a), best(b)
        saved += ta - tb
        lines.append(f"| {name} | {ta:.1f} | {tb:.1f} | {ta / tb:.1f}x |")
    lines += ["", f"Saved per frame: {saved:.0f} ms.", END]
    return publish_performance(lines)


if __name__ == "__main__":
    sys.exit(main())
