"""Depth that is not what it seems (issue 9): millimetres without a scale, garbage values."""
import subprocess
import sys
import warnings

import numpy as np
import OpenImageIO as oiio

import fogcli
from fogcli.config.model import Camera
from fogcli.io.depth import decode
from helpers import ROOT, write_img


def _png16(path, mm):
    spec = oiio.ImageSpec(mm.shape[1], mm.shape[0], 1, "uint16")
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(np.ascontiguousarray(mm.astype(np.uint16)[:, :, None]))
    out.close()


def _cli(*args):
    r = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-m", "fogcli", *map(str, args)],
                       capture_output=True, text=True, timeout=300, cwd=ROOT)
    return r.returncode, r.stderr


def test_millimetre_png_is_read_as_millimetres_and_said(tmp_path):
    h, w = 30, 40
    rgb = np.random.default_rng(0).uniform(0, 1, (h, w, 3)).astype(np.float32)
    write_img(tmp_path / "c.exr", rgb, ["R", "G", "B"])
    mm = np.random.default_rng(1).integers(2000, 6000, (h, w))      # a room, in millimetres
    _png16(tmp_path / "d.png", mm)
    code, err = _cli("apply", tmp_path / "c.exr", "--depth", tmp_path / "d.png", "-o", tmp_path / "o.exr",
                     "--save-depth", tmp_path / "m.npy")
    assert code == 0, err
    assert "read as millimetres" in err and "camera.depth_scale" in err
    np.testing.assert_allclose(np.load(tmp_path / "m.npy"), mm / 1000.0, rtol=1e-6)
    # an explicit scale of 1 on millimetre codes: the warning names the fix
    code, err = _cli("apply", tmp_path / "c.exr", "--depth", tmp_path / "d.png", "-o", tmp_path / "o2.exr",
                     "--set", "camera.depth_scale=1")
    assert code == 0 and "looks like millimetres: set camera.depth_scale=0.001" in err, err


def test_garbage_depth_gives_finite_output_without_numpy_warnings(tmp_path):
    h, w = 24, 32
    rng = np.random.default_rng(1)
    z = rng.uniform(2, 50, (h, w)).astype(np.float32)
    junk = [np.nan, np.inf, -np.inf, 3.4e38, -3.4e38, 1e30, 1e-30, -1e-30, 0.0, 1e-45]
    idx = rng.choice(h * w, 200, replace=False)
    z.flat[idx] = np.array(junk, np.float32)[np.arange(200) % len(junk)]
    rgb = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    write_img(tmp_path / "g.exr", np.dstack([rgb, z]), ["R", "G", "B", "Z"])
    code, err = _cli("apply", tmp_path / "g.exr", "-o", tmp_path / "o.exr")
    assert code == 0, err
    assert "Warning" not in err and "Traceback" not in err
    px = oiio.ImageInput.open(str(tmp_path / "o.exr")).read_image("float")[:, :, :3]
    assert np.isfinite(px).all()
    with np.errstate(over="ignore"):
        huge = z.astype(np.float64) * 1e300
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = decode(huge, Camera(depth_scale=1e10), "z", w)         # overflows float64 in the decoder
        out = fogcli.apply(rgb, z, "fog")
    assert np.isfinite(out).all() and np.isposinf(d[z > 1]).all()


def test_absurd_metric_values_are_holes_or_sky():
    d = decode(np.array([[1e-9, 5e-7, 2e-6, 3.0, 9e6, 2e7, np.inf, -np.inf, np.nan]]), Camera(depth_scale=1.0), "z", 9)
    assert np.isnan(d[0, [0, 1, 7, 8]]).all()
    np.testing.assert_allclose(d[0, [2, 3, 4]], [2e-6, 3.0, 9e6], rtol=1e-6)
    assert np.isposinf(d[0, [5, 6]]).all()
