"""A 16000 x 12000 EXR with Z (issue 12): what `fogcli apply` does with an image larger than
one device allocation, and a 12000 x 8000 one beyond limits.memory (issue 37); the peak
resident memory of each refusal. Writes the file strip by strip (zip:
a smooth image compresses to a few MB), runs `fogcli apply` on it in a new process and
reads that process's peak RSS. Writes its block of docs/performance.md.

    python tools/huge_image.py        # about a minute
"""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tools")]

from docblock import markers, publish_performance  # noqa: E402
from process_peak import run_measured  # noqa: E402

BEGIN, END = markers("huge-image")
W, H = 16000, 12000


def write_big(path: Path, w: int, h: int) -> None:
    import OpenImageIO as oiio

    spec = oiio.ImageSpec(w, h, 4, "half")
    spec.channelnames = ("R", "G", "B", "Z")
    spec.attribute("compression", "zip")
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), oiio.geterror()
    x = np.linspace(0, 1, w, dtype=np.float32)
    for y0 in range(0, h, 500):
        rows = np.empty((500, w, 4), np.float32)
        rows[..., 0] = x
        rows[..., 1] = 0.5
        rows[..., 2] = (y0 / h)
        rows[..., 3] = 10.0 + 40.0 * x
        assert out.write_scanlines(y0, y0 + 500, 0, rows), out.geterror()
    out.close()


def refuse(src: Path, out: Path, *extra) -> tuple[int, str, float, float]:
    """(exit code, stderr, wall s, peak RSS MiB) of `fogcli apply src -o out` in a new process
    (its own peak: process_peak)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    r = run_measured([sys.executable, "-m", "fogcli", "apply", str(src), "-o", str(out), *extra], env)
    return r["code"], r["stderr"], r["wall"], r["maxrss"] / 2**20


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "big.exr"
        write_big(src, W, H)
        code, err, wall, peak = refuse(src, Path(tmp) / "out.exr")
        mid = Path(tmp) / "mid.exr"           # within the device's limit, beyond the memory allowed
        write_big(mid, 12000, 8000)
        code2, err2, wall2, peak2 = refuse(mid, Path(tmp) / "out2.exr", "--set", "limits.memory=4GiB")
        mb, mb2 = src.stat().st_size / 1e6, mid.stat().st_size / 1e6

    def last(e):
        return e.strip().splitlines()[-1] if e.strip() else ""

    lines = [BEGIN, "## Images larger than the device or the memory allows", "",
             "`python tools/huge_image.py`: `fogcli apply` in a new process of half-float EXRs with R, G, B, Z. "
             "fogcli does not tile yet; it refuses from the file's header, before reading a pixel.", "",
             f"- {W} x {H} ({mb:.0f} MB zip): exit code {code} after {wall:.1f} s, peak resident memory {peak:.0f} MiB:",
             "", "```", last(err), "```", "",
             f"- 12000 x 8000 ({mb2:.0f} MB zip) with `--set limits.memory=4GiB` (by default, 60 % of the memory "
             f"available): exit code {code2} after {wall2:.1f} s, peak resident memory {peak2:.0f} MiB:",
             "", "```", last(err2), "```", END]
    return publish_performance(lines)


if __name__ == "__main__":
    sys.exit(main())
