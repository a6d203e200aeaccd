"""A 16000 x 12000 EXR with Z (issue 12): what `fogcli apply` does with an image larger than
one device allocation, and its peak resident memory. Writes the file strip by strip (zip:
a smooth image compresses to a few MB), runs `fogcli apply` on it in a new process and
reads that process's peak RSS. Writes its block of docs/performance.md.

    python benchmarks/huge_image.py        # about a minute
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "benchmarks")]

from docblock import publish_performance  # noqa: E402

BEGIN, END = "<!-- huge-image: begin -->", "<!-- huge-image: end -->"
W, H = 16000, 12000


def write_big(path: Path) -> None:
    import OpenImageIO as oiio

    spec = oiio.ImageSpec(W, H, 4, "half")
    spec.channelnames = ("R", "G", "B", "Z")
    spec.attribute("compression", "zip")
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), oiio.geterror()
    x = np.linspace(0, 1, W, dtype=np.float32)
    for y0 in range(0, H, 500):
        rows = np.empty((500, W, 4), np.float32)
        rows[..., 0] = x
        rows[..., 1] = 0.5
        rows[..., 2] = (y0 / H)
        rows[..., 3] = 10.0 + 40.0 * x
        assert out.write_scanlines(y0, y0 + 500, 0, rows), out.geterror()
    out.close()


def refuse(src: Path, out: Path, **extra) -> tuple[int, str, float, float]:
    """(exit code, stderr, wall s, peak RSS MiB) of `fogcli apply src -o out` in a new process
    (its own rusage, from wait4)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), FOGCLI_SERVER="0", **extra)     # its own peak, not a server's
    t = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "fogcli", "apply", str(src), "-o", str(out)],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    err = p.stderr.read()
    _, status, ru = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    return p.returncode, err, time.perf_counter() - t, ru.ru_maxrss / 1024


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "big.exr"
        write_big(src)
        code, err, wall, peak = refuse(src, Path(tmp) / "out.exr")
        _, _, wall0, peak0 = refuse(src, Path(tmp) / "out.exr", FOGCLI_PREFAULT="0")
        mb = src.stat().st_size / 1e6
    msg = err.strip().splitlines()[-1] if err.strip() else ""
    lines = [BEGIN, "## Images larger than the device allows", "",
             f"`python benchmarks/huge_image.py`: `fogcli apply` of a {W} x {H} half-float EXR with R, G, B, Z "
             f"({mb:.0f} MB zip) in a new process: exit code {code} after {wall:.1f} s, peak resident "
             f"memory {peak:.0f} MiB ({peak0:.0f} MiB and {wall0:.1f} s with FOGCLI_PREFAULT=0: the difference is the heap "
             "the previous `fogcli apply` held, touched ahead while Python starts; docs/distributed.md). fogcli does "
             "not tile yet; it refuses from the file's header, before reading a pixel:", "", "```", msg, "```", END]
    return publish_performance(lines)


if __name__ == "__main__":
    sys.exit(main())
