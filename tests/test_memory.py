"""limits.memory refuses an image from the estimate of its header (memory.estimate): the
estimate must not be below what a frame really takes, or an image that does not fit would be
let through (measured: the peak resident memory of a new `fogcli apply` process, less that
of the same command on a tiny frame)."""
import os
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from fogcli.api import make_config
from fogcli.device.memory import estimate, limit_bytes
from hdr_scenes import scene

ROOT = Path(__file__).resolve().parents[1]


def write_rgbz(path: Path, w: int, h: int) -> None:
    rgb, z, _ = scene(w, h, seed=1)
    spec = oiio.ImageSpec(w, h, 4, "half")
    spec.channelnames = ("R", "G", "B", "Z")
    spec.attribute("compression", "zip")
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(np.ascontiguousarray(np.dstack([rgb, z]), np.float32))
    out.close()


def peak_rss(*args) -> int:
    """Peak resident bytes of `fogcli apply ...` in a process of its own."""
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        from process_peak import run_measured
    finally:
        sys.path.remove(str(ROOT / "tools"))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    r = run_measured([sys.executable, "-m", "fogcli", "apply", *args], env)
    assert r["code"] == 0, r["stderr"]
    return r["maxrss"]


def test_the_estimate_covers_what_a_frame_takes(tmp_path):
    w, h = 1280, 800
    write_rgbz(tmp_path / "big.exr", w, h)
    write_rgbz(tmp_path / "tiny.exr", 64, 40)
    # kernels built first: on a cold cache (CI) the big frame's run built programs the tiny
    # one had not (LLVM's peak, ~35 B/px of this frame, is the build's, not the frame's)
    peak_rss(tmp_path / "big.exr", "-o", tmp_path / "warm.exr")
    base = peak_rss(tmp_path / "tiny.exr", "-o", tmp_path / "t.exr")
    took = peak_rss(tmp_path / "big.exr", "-o", tmp_path / "b.exr") - base
    est = estimate(w, h, 4, 2, make_config("fog"))
    assert took <= est, (took / (w * h), est / (w * h))
    assert est <= 2.5 * took, "an estimate this loose refuses images that fit"


def test_limit_of_a_share_and_of_a_size(monkeypatch):
    from fogcli.device import memory

    monkeypatch.setattr(memory, "available_bytes", lambda: 10 * 2**30)
    assert limit_bytes("auto") == int(0.6 * 10 * 2**30)
    assert limit_bytes("25%") == int(0.25 * 10 * 2**30)
    assert limit_bytes(123456789) == 123456789
    assert make_config("fog", sets=["limits.memory=1.5GiB"]).limits.memory == int(1.5 * 2**30)
