"""Physical checks of the whole pipeline (docs/conventions.md), through the public API."""
import math

import numpy as np
import pytest

import oracles
from fogcli import apply
from fogcli.api import make_config
from fogcli.device.plan import LIGHT_SHARE
from metrics import rel_l1
from hdr_scenes import scene


@pytest.mark.parametrize("method", ["pyramid", "naive", "reference"])
def test_pure_absorption_is_exact(method):
    """scattering 0: out = L exp(-sa D) (1e-4 relative L1), D the depth with each pixel at a
    depth edge on the surface whose light it mostly holds (oracles.light_share_depth)."""
    rgb, z, fov = scene(96, 64, seed=3)
    sa = [0.02, 0.01, 0.005]
    cfg = make_config("fog", sets=[f"medium.absorption={sa}", "medium.scattering=0",
                                   f"render.method={method}", f"camera.fov={fov}"])
    out = apply(rgb, z, cfg)
    f = (96 / 2) / math.tan(math.radians(fov) / 2)
    at, sc, *_ = oracles.preprocess(rgb, oracles.light_share_depth(z, rgb, **LIGHT_SHARE), sa, [0, 0, 0], 0.85, f)
    assert not sc.any()
    assert rel_l1(out, at) < 1e-4


def _gauss_blur(img, sigma):
    r = int(math.ceil(4 * sigma))
    x = np.arange(-r, r + 1)
    k = np.exp(-x * x / (2 * sigma * sigma))
    k /= k.sum()
    p = np.pad(img, ((r, r), (r, r), (0, 0)), mode="edge")
    rows = sum(k[i] * p[:, i:i + img.shape[1]] for i in range(len(k)))
    return sum(k[i] * rows[i:i + img.shape[0]] for i in range(len(k)))


@pytest.mark.parametrize("sigma", [2.0, 5.0, 12.0])
@pytest.mark.parametrize("kernel", [4, 6])
def test_constant_depth_is_a_gaussian_blur(sigma, kernel):
    """One depth everywhere: the scattered part is a Gaussian of sigma_px (0.06
    relative L1 away from the borders)."""
    h, w = 160, 192
    rng = np.random.default_rng(5)
    rgb = rng.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32)
    rgb[40:44, 60:64] = 200.0
    rgb[100, 150] = 900.0
    D = 20.0
    # paper model: sigma = scale * W(D) * w / 1280, so pick the scale that gives sigma
    sa, ss, g = 0.01, 0.08, 0.8
    W = float(oracles.spread_w(D, sa, ss, g))
    scale = sigma / (W * w / 1280)
    cfg = make_config("fog", sets=[f"medium.absorption={sa}", f"medium.scattering={ss}", f"medium.asymmetry={g}",
                                   "render.psf=gaussian", "render.spread_model=paper", f"render.spread_scale={scale}",
                                   "camera.depth=distance", f"render.kernel={kernel}"])
    out = apply(rgb, np.full((h, w), D, np.float32), cfg)
    at, sc, s_px, *_ = oracles.preprocess(rgb, np.full((h, w), D), [sa] * 3, [ss] * 3, g, 1.0, scale=scale,
                                          z=False, paper=True)
    assert abs(s_px[0, 0] - sigma) < 1e-6 * sigma + 1e-9
    want = at + _gauss_blur(sc, sigma)
    m = int(math.ceil(3 * sigma))
    err = rel_l1(out[m:-m, m:-m], want[m:-m, m:-m])
    assert err < 0.06, err


def test_reference_conserves_scattered_energy():
    rgb, z, fov = scene(120, 90, seed=4)
    rgb[0, 0] = 5000.0   # an HDR pixel in the corner: its Gaussian is mostly outside
    z[0, 0] = 30.0
    cfg = make_config("fog", sets=["render.method=reference", "render.psf=gaussian", "render.border=closed",
                                   f"camera.fov={fov}", "render.ground=none"])   # a ground's mean leaves its sources
    out, aov = apply(rgb, z, cfg, aovs=("scattered",), return_aovs=True)
    f = (120 / 2) / math.tan(math.radians(fov) / 2)
    cm = cfg.medium
    _, sc, *_ = oracles.preprocess(rgb, oracles.light_share_depth(z, rgb, **LIGHT_SHARE), cm.absorption,
                                   cm.scattering, cm.asymmetry, f, max_depth=1000)
    got = sum(aov[f"scattered.{c}"].astype(np.float64).sum() for c in "RGB")
    assert abs(got / sc.sum() - 1) < 1e-4


@pytest.mark.parametrize("model,medium", [("angular", "fog"), ("paper", "fog"), ("angular", "sea")])
def test_resolution_invariance(model, medium):
    """A 2x2-replicated image, processed and box-downsampled, matches the original
    processed image (0.06 relative L1)."""
    scale = {"fog": 1.0, "sea": 0.15}[medium]
    rgb, z, fov = scene(128, 96, seed=2, scale=scale)
    sets = [f"camera.fov={fov}", f"render.spread_model={model}", "render.spread_scale=2"]
    cfg = make_config(medium, sets=sets)
    small = apply(rgb, z, cfg)
    big = apply(np.repeat(np.repeat(rgb, 2, 0), 2, 1), np.repeat(np.repeat(z, 2, 0), 2, 1), cfg)
    down = big.reshape(96, 2, 128, 2, 3).mean(axis=(1, 3))
    err = rel_l1(down, small)
    assert err < 0.06, err


def test_pyramid_is_close_to_reference_on_a_night_scene():
    """A fidelity floor that a broken pyramid cannot meet (the calibration table in
    docs/calibration.md has the full numbers)."""
    from metrics import ssim

    rgb, z, fov = scene(160, 120, seed=11, night=True)
    sets = [f"camera.fov={fov}", "render.halo_depth=none"]     # the reference has no receiver weight
    ref = apply(rgb, z, make_config("fog", sets=sets + ["render.method=reference"]))
    pyr = apply(rgb, z, make_config("fog", sets=sets))
    naive = apply(rgb, z, make_config("fog", sets=sets + ["render.method=naive"]))
    assert ssim(pyr, ref) > 0.93
    assert rel_l1(pyr, ref) < 0.12
    assert rel_l1(pyr, ref) < rel_l1(naive, ref)


def test_ambient_auto_is_the_far_radiance():
    """ambient: auto takes the median sky colour; at the sky, where P is huge, the medium
    term tends to (ss / st) L_a (Delalandre eq. 7)."""
    from fogcli.physics.ambient import estimate

    rgb, z, fov = scene(96, 64, seed=1, night=False)
    sky = ~np.isfinite(z)
    want = np.median(rgb[sky], axis=0)
    la = estimate(rgb, z, 1000.0)
    np.testing.assert_allclose(la, want, rtol=1e-6)
    cfg = make_config("fog", sets=["medium.ambient=auto", "camera.max_depth=1e5", f"camera.fov={fov}"])
    out, aov = apply(rgb, z, cfg, aovs=("emission",), return_aovs=True)
    em = np.stack([aov[f"emission.{c}"] for c in "RGB"], axis=2)
    cm = cfg.medium
    st = np.add(cm.absorption, cm.scattering)
    np.testing.assert_allclose(em[sky].mean(axis=0), np.array(cm.scattering) / st * want, rtol=1e-3)
    # no sky: the farthest 2 % stand in
    z2 = np.where(sky, 900.0, z).astype(np.float32)
    far = z2 >= np.quantile(z2, 0.98)
    np.testing.assert_allclose(estimate(rgb, z2, 1000.0), np.median(rgb[far], axis=0), rtol=1e-6)


@pytest.mark.parametrize("fetch", ["source", "receiver"])
def test_pixel_separation_on_a_night_scene(fetch):
    """Separation keeps the scattered energy and, for Elek's receiver fetch where it was
    designed (Iser 4.4.4), brings the result much closer to the reference."""
    rgb, z, fov = scene(160, 120, seed=13, night=True)
    # the receiver fetch is a Gaussian model; the source collapse runs the default apsf
    sets = [f"camera.fov={fov}", f"render.fetch={fetch}"] + (["render.psf=gaussian"] if fetch == "receiver" else
                                                              ["render.halo_depth=none"])
    ref = apply(rgb, z, make_config("fog", sets=sets + ["render.method=reference"]))
    off, a = apply(rgb, z, make_config("fog", sets=sets), aovs=("scattered",), return_aovs=True)
    on, b = apply(rgb, z, make_config("fog", sets=sets + ["render.separation.enabled=true"]),
                  aovs=("scattered",), return_aovs=True)
    assert not np.allclose(off, on)
    if fetch == "source":
        tot = lambda p: sum(p[f"scattered.{c}"].astype(np.float64).sum() for c in "RGB")  # noqa: E731
        assert abs(tot(b) / tot(a) - 1) < 0.02
        assert rel_l1(on, ref) < 1.02 * rel_l1(off, ref)
    else:
        assert rel_l1(on, ref) < 0.8 * rel_l1(off, ref)


@pytest.mark.parametrize("method", ["pyramid", "naive", "reference"])
def test_medium_light_same_with_and_without_aovs(method):
    """Emission and ambient ride in `direct` unless an AOV needs them apart: the picture
    must not depend on which AOVs were asked for."""
    rgb, z, _ = scene(48, 32, seed=5, night=True)
    cfg = make_config("fog", sets=["medium.emission=[0.01, 0.02, 0.03]", "medium.ambient=[0.1, 0.1, 0.2]",
                                   f"render.method={method}"])
    plain = apply(rgb, z, cfg)
    split, planes = apply(rgb, z, cfg, aovs=("emission", "direct"), return_aovs=True)
    np.testing.assert_allclose(split, plain, rtol=1e-6, atol=1e-7)
    assert planes["emission.G"].mean() > 0.01
