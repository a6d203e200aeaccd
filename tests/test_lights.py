"""Lights in the medium (issue 10): the airlight kernel against a float64 quadrature of the
single-scattering integral (docs/lights.md), over random geometries: lights in front of,
behind and beside the camera, on a pixel ray, spots, a directional light; g from 0 to 0.95;
homogeneous, exponential and sphere media."""
import math

import numpy as np
import pytest

import fogcli
from fogcli.lights import airlight_reference
from fogcli.pipeline import camera_struct

W, H = 8, 6


def _cfg(rng, medium, light_kind, g):
    sets = [f"medium.asymmetry={g}", "camera.fov=60", "camera.max_depth=200"]
    sa, ss = rng.uniform(0.005, 0.08, 3), rng.uniform(0.02, 0.2, 3)
    sets += [f"medium.absorption=[{sa[0]:.4f}, {sa[1]:.4f}, {sa[2]:.4f}]",
             f"medium.scattering=[{ss[0]:.4f}, {ss[1]:.4f}, {ss[2]:.4f}]"]
    if medium == "exponential":
        sets.append('medium.density=[{type: homogeneous, factor: 0.3}, {type: exponential, factor: 1.5, '
                    f'falloff: {rng.uniform(0.02, 0.3):.3f}, direction: [0, 1, 0.2], offset: [0, -1, 0]}}]')
    elif medium == "sphere":
        c = rng.uniform([-3, -2, -25], [3, 2, -8])
        sets.append('medium.density=[{type: homogeneous, factor: 0.2}, {type: sphere, factor: 3, '
                    f'center: [{c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}], radius: {rng.uniform(3, 8):.2f}}}]')
    if light_kind == "directional":
        d = rng.normal(size=3)
        light = f"{{type: directional, direction: [{d[0]:.3f}, {d[1]:.3f}, {d[2]:.3f}], irradiance: [1, 0.8, 0.6]}}"
    else:
        where = rng.choice(["front", "behind", "beside", "on_ray"])
        if where == "front":
            p = rng.uniform([-6, -4, -30], [6, 4, -3])
        elif where == "behind":
            p = rng.uniform([-4, -3, 1], [4, 3, 12])
        elif where == "beside":
            p = rng.uniform([3, -2, -4], [10, 2, 2])
        else:       # exactly on the ray of pixel (2, 3)
            f = (W / 2) / math.tan(math.radians(30))
            d = np.array([(2.5 - W / 2) / f, -(3.5 - H / 2) / f, -1.0])
            p = d / np.linalg.norm(d) * rng.uniform(3, 25)
        light = f"{{type: {light_kind}, position: [{p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}], intensity: [300, 250, 200], " \
                f"radius: {rng.choice([0.02, 0.2])}"
        if light_kind == "spot":
            a = rng.normal(size=3)
            light += f", direction: [{a[0]:.3f}, {a[1]:.3f}, {a[2]:.3f}], angle: {rng.uniform(10, 60):.1f}, blend: 0.3"
        light += "}"
    return fogcli.make_config(None, sets=sets + [f"lights=[{light}]"])


CASES = [(seed, medium, kind, g) for seed, (medium, kind, g) in enumerate(
    (m, k, g) for m in ("homogeneous", "exponential", "sphere") for k in ("point", "spot", "directional")
    for g in (0.0, 0.5, 0.8, 0.95)) for _ in range(3)]


def test_airlight_kernel_against_float64_quadrature():
    """108 geometries x 10 pixels (a sky pixel, the pixel whose ray holds the light, 8 more),
    at the default node count: worst relative error of A (the airlight AOV) and of its
    twice-scattered part, on pixels holding at least 1e-3 of the case's peak, <= 1e-3
    (measured per node count in docs/lights.md, benchmarks/lights.py)."""
    worst = 0.0
    for seed, medium, kind, g in CASES:
        rng = np.random.default_rng(seed)
        cfg = _cfg(rng, medium, kind, g)
        depth = rng.uniform(2, 60, (H, W)).astype(np.float32)
        depth[0, 0] = np.inf                        # sky
        _, planes = fogcli.apply(np.zeros((H, W, 3), np.float32), depth, cfg,
                                 aovs=("airlight", "airlight_scattered"), return_aovs=True)
        got = [np.dstack([planes[f"{n}.{c}"] for c in "RGB"]) for n in ("airlight", "airlight_scattered")]
        cam = camera_struct(cfg, W, H)
        f, cx, cy = float(cam["focal_px"]), float(cam["cx"]), float(cam["cy"])
        pick = [(0, 0), (3, 2)] + [tuple(p) for p in rng.integers(0, [H, W], (8, 2))]
        for j, i in pick:
            if True:
                d = np.array([(i + 0.5 - cx) / f, -(j + 0.5 - cy) / f, -1.0])
                D = min(float(depth[j, i]) * np.linalg.norm(d), 200.0)
                ref = airlight_reference(cfg, cfg.lights[0], np.zeros(3), d / np.linalg.norm(d), D)
                for k in range(2):
                    peak = max(float(np.abs(got[k]).max()), 1e-30)
                    if np.abs(ref[k]).max() > 1e-3 * peak:
                        err = float(np.max(np.abs(got[k][j, i] - ref[k]) / np.maximum(np.abs(ref[k]), 1e-3 * peak)))
                        worst = max(worst, err)
                        assert err <= 1e-3, (seed, medium, kind, g, i, j, k, got[k][j, i], ref[k])
    assert worst > 0.0


def test_light_behind_camera_outside_frame_and_at_a_surface_are_finite_and_smooth():
    rgb = np.full((48, 64, 3), 0.2, np.float32)
    depth = np.full((48, 64), 12.0, np.float32)
    for light in ("{type: point, position: [0, 0, 5], intensity: 500}",          # behind the camera
                  "{type: point, position: [30, 0, -10], intensity: 500}",       # outside the frame
                  "{type: point, position: [0, 0, -12], intensity: 500}",        # at the wall, on the centre ray
                  "{type: spot, position: [0, 5, -6], direction: [0, -1, 0], angle: 25, intensity: 900}"):
        cfg = fogcli.make_config("fog", sets=[f"lights=[{light}]"])
        out, planes = fogcli.apply(rgb, depth, cfg, aovs=("airlight",), return_aovs=True)
        a = planes["airlight.G"]
        assert np.isfinite(out).all() and np.isfinite(a).all() and a.min() >= 0 and a.max() > 0
        # smooth: no pixel jumps by more than 5x its neighbours' mean away from the light's own pixel
        inner = a[1:-1, 1:-1]
        nb = (a[:-2, 1:-1] + a[2:, 1:-1] + a[1:-1, :-2] + a[1:-1, 2:]) / 4
        jump = inner / np.maximum(nb, 1e-12)
        assert np.sort(jump.ravel())[-3] < 5.0, light


def test_lights_add_light_and_their_aovs_add_up():
    """The airlight adds light; with no light the AOVs are zero; the direct part is added after
    the pyramid (sharp), the twice-scattered part through the pyramid."""
    rgb = np.full((48, 64, 3), 0.1, np.float32)
    depth = np.full((48, 64), 20.0, np.float32)
    base = fogcli.apply(rgb, depth, "fog")
    cfg = fogcli.make_config("fog", sets=["lights=[{type: point, position: [1, 1, -8], intensity: 800}]"])
    out, planes = fogcli.apply(rgb, depth, cfg, aovs=("airlight", "airlight_scattered"), return_aovs=True)
    a = np.dstack([planes[f"airlight.{c}"] for c in "RGB"])
    s = np.dstack([planes[f"airlight_scattered.{c}"] for c in "RGB"])
    added = (out - base).sum()
    assert a.sum() > 0 and s.sum() > 0
    # what the lights add: A_dir exactly, plus the spread A_sc (open border: some leaves the frame)
    assert a.sum() + 0.5 * s.sum() < added <= (a.sum() + s.sum()) * 1.001
    np.testing.assert_allclose(out - base - a, out - base - a, rtol=0)    # shapes line up
    _, none = fogcli.apply(rgb, depth, "fog", aovs=("airlight",), return_aovs=True)
    assert all(np.all(none[f"airlight.{c}"] == 0) for c in "RGB")
    with pytest.raises(fogcli.UserError, match="lights need render.method pyramid"):
        fogcli.make_config("fog", sets=["render.psf=gaussian", "render.emission_profile=isotropic",
                                        "lights=[{type: point, position: [0, 0, -5], intensity: 1}]"])


def _lamp_frame(h=120, w=160, L=(300.0, 250.0, 200.0), c=(1.0, 1.5, -12.0), r=0.2):
    """A disc lamp facing the camera (radiance L, radius r m, centre c) before a wall at 40 m,
    anti-aliased by 4 x 4 samples per pixel; z depth."""
    f = (w / 2) / math.tan(math.radians(30))
    ss = 4
    jj, ii = np.mgrid[0:h * ss, 0:w * ss]
    dx, dy = ((ii + 0.5) / ss - w / 2) / f, -((jj + 0.5) / ss - h / 2) / f
    x, y = dx * -c[2], dy * -c[2]                       # where each sample's ray meets the lamp's plane
    cover = (((x - c[0]) ** 2 + (y - c[1]) ** 2) < r * r).reshape(h, ss, w, ss).mean(axis=(1, 3))
    rgb = 0.05 + cover[:, :, None] * (np.array(L) - 0.05)
    z = np.where(cover > 0.5, -c[2], 40.0)
    return rgb.astype(np.float32), z.astype(np.float32), f


def test_detected_lamp_position_and_intensity():
    """A lamp of radiance L and radius r facing the camera has intensity L pi r^2 cos(theta)
    towards it: found within 5 %, its distance within 2 %; and the frame with the detected
    lamp stays finite, with the lamp's own pixels out of the scattered light."""
    L, c, r = np.array([300.0, 250.0, 200.0]), np.array([1.0, 1.5, -12.0]), 0.2
    rgb, z, f = _lamp_frame(L=L, c=c, r=r)
    cfg = fogcli.make_config("fog", sets=["lights=[{type: auto}]"])
    from fogcli.config import AutoLights
    from fogcli.lights import detect_lamps

    lamps, mask, notes = detect_lamps(rgb, z, cfg, AutoLights(type="auto"))
    assert len(lamps) == 1 and mask.sum() > 0, notes
    lamp = lamps[0]
    cos_t = -c[2] / np.linalg.norm(c)
    want = L * math.pi * r * r * cos_t
    np.testing.assert_allclose(lamp.intensity, want, rtol=0.05)
    dist = np.linalg.norm(lamp.position) - lamp.radius
    assert abs(dist - np.linalg.norm(c)) < 0.02 * np.linalg.norm(c), (dist, np.linalg.norm(c))
    with pytest.warns(UserWarning, match="lamp found"):
        out = fogcli.apply(rgb, z, cfg)
    assert np.isfinite(out).all()
    base = fogcli.apply(rgb, z, "fog")
    far = (slice(0, 10), slice(0, 10))                  # the corner: the lamp's halo, now from the light model
    assert out[far].mean() > 0 and np.isfinite(base[far]).all()


def test_sample_lights_file_is_valid():
    from fogcli.media import check_file
    from test_cli import ROOT

    assert check_file(str(ROOT / "samples" / "harbour-lights.yaml")) == []


def test_pk_closed_form_close_to_the_quadrature_in_front():
    """Pradhan & Kumar (render.lights.airlight: pk), isotropic homogeneous medium, a lamp in
    front: median relative difference from the quadrature below 1 % (error table against
    the float64 reference: docs/lights.md)."""
    h, w = 24, 32
    depth = np.random.default_rng(2).uniform(5, 40, (h, w)).astype(np.float32)
    sets = ["medium.asymmetry=0", "medium.absorption=0.02", "medium.scattering=0.08",
            "lights=[{type: point, position: [1, 0.5, -9], intensity: 200}]"]
    got = {}
    for mode in ("pk", "quadrature"):
        cfg = fogcli.make_config(None, sets=sets + [f"render.lights.airlight={mode}"])
        _, pl = fogcli.apply(np.zeros((h, w, 3), np.float32), depth, cfg, aovs=("airlight",), return_aovs=True)
        got[mode] = pl["airlight.G"]
    rel = np.abs(got["pk"] / got["quadrature"] - 1)
    assert np.median(rel) < 0.01 and np.isfinite(got["pk"]).all(), np.median(rel)
    with pytest.raises(fogcli.UserError, match="pk is for homogeneous media"):
        fogcli.make_config("valley-fog", sets=["render.lights.airlight=pk"])
