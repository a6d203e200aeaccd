"""Alpha (issue 9): pixels with alpha 0 are empty, not depth holes; the output alpha is the
coverage of the result, so that fogcli-then-composite equals composite-then-fogcli."""
import math

import numpy as np
import pytest

import fogcli
from fogcli.physics.luminance import luminance
from helpers import read, run, write_img
from oracles import optical_depth_quadrature as _quadrature

H, W = 72, 96


def _render():
    yy, xx = np.mgrid[0:H, 0:W]
    a = np.clip(16.5 - np.hypot(xx - 48, yy - 36), 0, 1).astype(np.float32)   # a disc, 1-px soft edge
    rgb = (a[:, :, None] * np.array([2.0, 1.5, 1.0], np.float32)).astype(np.float32)
    z = np.where(a > 0, 10.0, 0.0).astype(np.float32)                          # renderers write 0 where empty
    plate = (np.array([0.3, 0.4, 0.5]) * (1 + 0.2 * xx / W)[:, :, None]).astype(np.float32)
    return rgb, a, z, plate


@pytest.mark.parametrize("medium", ["fog", "haze", "sea"])
def test_fog_then_composite_equals_composite_then_fog(medium):
    """The documented convention (camera.empty_depth 0: the plate carries its own medium):
    over(fogcli(render), plate) against fogcli(over(render, plate)) with the plate at depth 0,
    within 1 % relative L1 (measured table: docs/config.md, tools/compositing.py); the
    edge pixels, whose plate part is attenuated as the object in the second order, make the
    difference."""
    rgb, a, z, plate = _render()
    cfg = fogcli.make_config(medium)
    out = fogcli.apply(rgb, z, cfg, alpha=a)
    assert out.shape == (H, W, 4)
    after = out[:, :, :3] + (1 - out[:, :, 3:]) * plate
    before = fogcli.apply(rgb + (1 - a[:, :, None]) * plate, np.where(a > 0, z, 1e-4), cfg)
    rel = np.abs(after - before).sum() / np.abs(before).sum()
    assert rel < 0.01, rel
    np.testing.assert_allclose(out[:, :, 3], a, atol=1e-6)          # nothing in front of the plate
    assert out[a == 0][:, :3].max() > 1e-4                          # the disc's glow spills into empty pixels


def test_empty_pixels_are_not_holes(tmp_path):
    """Z 0 under alpha 0 is empty space, not a hole to fill from the object: no warning, and
    no medium light (ambient) in it; filled as a hole it took the object's depth and its
    ambient in-scatter (0.25 of the 0.3 ambient here)."""
    rgb, a, z, _ = _render()
    p = tmp_path / "render.exr"
    write_img(p, np.dstack([rgb, a, z]), ["R", "G", "B", "A", "Z"])
    sets = ("--set", "medium.ambient=0.3")
    code, text, _ = run("apply", p, "-o", tmp_path / "o.exr", "--medium", "smoke", *sets)
    assert code == 0, text
    assert "invalid depth" not in text
    spec, px = read(tmp_path / "o.exr")
    np.testing.assert_array_equal(px[:, :, 3], a)
    holes = fogcli.apply(rgb, np.where(a > 0, z, np.nan), fogcli.make_config("smoke", sets=[sets[1]]))
    far = (slice(0, 4), slice(0, 4))
    assert px[far][:, :, :3].max() < 0.015 and holes[far].min() > 0.2


def test_coverage_kernel_against_quadrature():
    """Output alpha with camera.empty_depth 30 m in a heterogeneous medium: 1 - (1 - a) t_e,
    t_e the luminance-weighted transmitted plus scattered share of a source at 30 m (Gaussian
    psf: exp(-sa P)); P by quadrature along each pixel's ray to z = 30 m. Tolerance 2e-4."""
    prims = [{"type": "homogeneous", "factor": 0.6},
             {"type": "exponential", "factor": 1.5, "falloff": 0.08, "direction": [0, 1, 0], "offset": [0, -2, 0]}]
    dens = "[" + ", ".join("{" + ", ".join(f'"{k}": {v!r}'.replace("'", '"') for k, v in p.items()) + "}"
                           for p in prims) + "]"
    cfg = fogcli.make_config("haze", sets=["render.psf=gaussian", "camera.empty_depth=30", f"medium.density={dens}"])
    h, w = 9, 12
    rng = np.random.default_rng(4)
    a = rng.uniform(0, 1, (h, w)).astype(np.float32)
    a[0, 0], a[1, 1] = 0.0, 1.0
    out = fogcli.apply(np.full((h, w, 3), 0.5, np.float32), np.full((h, w), 5.0, np.float32), cfg, alpha=a)
    f = cfg.camera.focal(w)
    sa = np.array(cfg.medium.absorption)
    for j in range(h):
        for i in range(w):
            d = np.array([(i + 0.5 - w / 2) / f, -(j + 0.5 - h / 2) / f, -1.0])
            D = 30.0 * np.linalg.norm(d)
            P = _quadrature(np.zeros(3), d / np.linalg.norm(d), D, prims)
            te = float(luminance(np.exp(-sa * P)))
            want = 1 - (1 - a[j, i]) * te
            assert abs(out[j, i, 3] - want) < 2e-4, (i, j, out[j, i, 3], want)
    assert out[1, 1, 3] == 1.0 and math.isclose(a[0, 0], 0.0)


def test_api_types_and_messages():
    rgb, a, z, _ = _render()
    with pytest.raises(fogcli.UserError, match="image: uint8 pixels are display values"):
        fogcli.apply((rgb * 100).astype(np.uint8), z)
    u8 = np.full((H, W, 3), 128, np.uint8)
    out = fogcli.apply(u8, np.full((H, W), 5.0, np.float32), colour="srgb")
    ref = fogcli.apply(np.full((H, W, 3), ((128 / 255 + 0.055) / 1.055) ** 2.4, np.float32),
                       np.full((H, W), 5.0, np.float32))
    np.testing.assert_allclose(out, ref, rtol=1e-4)
    with pytest.raises(fogcli.UserError, match=r"depth: expected an \(h, w\) numeric array"):
        fogcli.apply(rgb, np.zeros((H, W, 2)))
    with pytest.raises(fogcli.UserError, match="alpha: expected shape"):
        fogcli.apply(rgb, z, alpha=a[:-1])
    with pytest.raises(ValueError, match="make_config: render.kernel"):
        fogcli.make_config("fog", render__kernel=5)
