"""Screen-space shadows (kernels/shadows.cl, render.lights.shadows: screen) against a brute-force
numpy march of the same occluder model, and against exact geometric shadows of a facade quad."""
import math

import numpy as np

from oracles import shadow_fraction

# the medium (thin enough that the far part of a ray still counts) and the airlight AOV helper
from shadows import CASES, SA, SS, G, against_geometry, airlight, facade_scene  # noqa: E402

H, W = 24, 32
F = (W / 2) / math.tan(math.radians(30.0))         # camera.fov 60


def panel_scene(near=15.0, far=30.0):
    """z-depths: a wall at `far` m, a panel at `near` m in the middle; and the ray lengths."""
    z = np.full((H, W), far, np.float32)
    z[7:17, 11:21] = near
    jj, ii = np.mgrid[0:H, 0:W]
    dlen = np.sqrt(((ii + 0.5 - W / 2) / F) ** 2 + ((jj + 0.5 - H / 2) / F) ** 2 + 1.0)
    return z, z * dlen


def lit_share(z, light, *sets):
    base = airlight(z, light, *sets)
    return airlight(z, light, "render.lights.shadows=screen", "render.lights.method=march", *sets) / \
        np.where(base > 0, base, np.nan)


def test_screen_shadows_match_a_brute_force_march_of_the_same_model():
    """Point lights in front (behind the panel) and behind the camera, and a directional light
    behind the camera: the kernel walks each pixel's epipolar line pixel by pixel; the oracle
    marches every cell's segment in 3-D (1000-2000 points). Lit share of the integrand on 96
    pixels: mean difference <= 2e-3, worst <= 0.02 (measured: mean 6e-5 / 1.3e-4 / 1.1e-4, worst
    0.006 / 0.006 / 0.006)."""
    rng = np.random.default_rng(3)
    pixels = [tuple(p) for p in rng.integers(0, [H, W], (96, 2))]
    cases = [((15.0, 30.0), "{type: point, position: [0.5, 0.2, -20], intensity: 800, radius: 0.05}", [0.5, 0.2, -20.0]),
             ((3.0, 10.0), "{type: point, position: [0.2, 3.0, 0.5], intensity: 800, radius: 0.05}", [0.2, 3.0, 0.5]),
             ((15.0, 30.0), "{type: directional, direction: [0.3, 0.5, 0.8], irradiance: 1}", [0.3, 0.5, 0.8])]
    for (near, far), spec, light in cases:
        z, ray_len = panel_scene(near, far)
        directional = "directional" in spec
        got = lit_share(z, spec)
        u = np.asarray(light) / (np.linalg.norm(light) if directional else 1.0)
        want = shadow_fraction(ray_len, F, u, directional=directional, sa=SA, ss=SS, g=G,
                               steps=2000 if directional else 1000, pixels=pixels)
        diff = np.array([abs(got[p] - want[p]) for p in pixels])
        assert min(want[p] for p in pixels) < 0.9, (spec, "the case has to have shadows")
        assert diff.mean() <= 2e-3 and diff.max() <= 0.02, (spec, diff.mean(), diff.max())


def test_screen_shadows_of_facade_quads_match_geometric_shadows():
    """Thin facade quads facing the camera against the sky (tools/shadows.py; edges on
    pixel edges, so the depth map holds the scene exactly), thickness 0.01 m, five lights (points
    behind a quad, beside the quads, behind the camera; the sun behind the camera and from the
    side): the airlight with screen-space shadows against exact segment-quad visibility in
    2048 cells, relative L1 <= 1 % at 64 x 48 (measured 0.03-0.72 %; at 256 x 192:
    tools/shadows.py -> docs/lights.md)."""
    geo = against_geometry(48, 64, thicknesses=(0.01,))
    assert all(share > 0.002 for share, _ in geo.values()), geo
    assert max(errs[0] for _, errs in geo.values()) <= 0.01, geo


def test_awkward_lights_give_finite_shares_and_no_false_shadows():
    """A light on the wall itself, one whose image is on the frame's edge, one exactly on a
    pixel's ray, one behind the camera, the sun in the image plane (parallel epipolar lines)
    and a spot; the sun and the spot also in height fog (their airlight from the quadrature
    kernel): in front of a flat wall nothing may be shadowed (no streaks, no self-shadowing:
    share 1 to 1e-5); with the panel in front of the wall every share is finite, in [0, 1],
    and the panel shadows something."""
    wall = np.full((H, W), 20.0, np.float32)
    panel, _ = panel_scene(8.0, 20.0)
    ray = np.array([(5 + 0.5 - W / 2) / F, -(9 + 0.5 - H / 2) / F, -1.0])     # pixel (5, 9)
    on_wall, on_ray = ray * 20.0, ray / np.linalg.norm(ray) * 12.0
    edge = np.array([-(W / 2) / F * 12.0, 0.3, -12.0])                       # the left edge, 12 m away
    lights = [f"{{type: point, position: [{p[0]:.5f}, {p[1]:.5f}, {p[2]:.5f}], intensity: 500, radius: 0.05}}"
              for p in (on_wall, on_ray, edge, (1.0, 0.5, 3.0))]
    lights.append("{type: directional, direction: [1, 0.3, 0], irradiance: 1}")
    lights.append("{type: spot, position: [0.2, 0.3, -14], direction: [0, 0.1, 1], angle: 30, intensity: 900}")
    height_fog = "medium.density=[{type: homogeneous, factor: 0.5}, {type: exponential, factor: 1, falloff: 0.2}]"
    cases = [(spec, ()) for spec in lights] + [(lights[-2], (height_fog,)), (lights[-1], (height_fog,))]
    for spec, sets in cases:
        for z in (wall, panel):
            free, got = airlight(z, spec, *sets), airlight(z, spec, "render.lights.shadows=screen", *sets)   # epipolar
            assert np.all(np.isfinite(got)) and free.max() > 0, (spec, sets)
            share = got[free > 0] / free[free > 0]
            assert share.min() >= 0.0 and share.max() <= 1.0 + 1e-5, (spec, sets)
            if z is wall:
                assert np.abs(share - 1.0).max() <= 1e-5, (spec, sets, share.min())
            else:
                assert share.min() < 0.995, (spec, sets, "the panel has to shadow something")


def test_epipolar_sampling_matches_the_march():
    """render.lights.method epipolar (the default; step 16 and 512 slices, at most 1/16 of the
    longer side and two slices per border pixel) against march on the facade scene at 256 x 192
    and 64 x 48, thickness 0.05 m, five lights: relative L1 of the airlight <= 1 % (measured
    0.02-0.94 % at both sizes: the error is along the slices, where a shadow's edge falls
    between two samples; at 64 x 48 with step 16 it was up to 10 %)."""
    for h, w in ((192, 256), (48, 64)):
        z = facade_scene(h, w)
        for name, (spec, _, _) in CASES.items():
            sets = ("render.lights.shadows=screen", "render.lights.thickness=0.05")
            ref = airlight(z, spec, *sets, "render.lights.method=march")
            got = airlight(z, spec, *sets)
            assert np.abs(got - ref).sum() / ref.sum() <= 0.01, (h, w, name)


def test_closed_form_shares_of_homogeneous_media_match_the_generic_integrand():
    """march_shares integrates the lit share in closed form, eight cells at once, when the
    medium is homogeneous (shares_homogeneous); a faint exponential primitive (factor 1e-9)
    sends the same medium through the generic integrand (al_integrand). Point in front and
    behind the camera, a spot whose cone edge crosses the panel's shadow, the sun; march and
    epipolar: the lit shares agree to 1e-4 (measured: 4e-7; without the spot's cone
    factor 1)."""
    faint = ("medium.density=[{type: homogeneous, factor: 1}, "
             "{type: exponential, factor: 1.0e-9, falloff: 0.2}]")
    z, _ = panel_scene(8.0, 20.0)
    lights = ["{type: point, position: [0.5, 0.2, -14], intensity: 800, radius: 0.05}",
              "{type: point, position: [0.2, 3.0, 0.5], intensity: 800, radius: 0.05}",
              "{type: spot, position: [0.4, 0.3, -12], direction: [0.3, 0.1, 1], angle: 25, blend: 0.5, "
              "intensity: 900}",
              "{type: directional, direction: [0.3, 0.5, 0.8], irradiance: 1}"]
    for spec in lights:
        for method in ("march", "epipolar"):
            sets = ("render.lights.shadows=screen", f"render.lights.method={method}")
            shares = []
            for medium in ((), (faint,)):
                free = airlight(z, spec, *medium)
                shares.append(np.where(free > 0, airlight(z, spec, *sets, *medium) / np.where(free > 0, free, 1), 1))
            assert shares[0].min() < 0.97, (spec, method, "the case has to have shadows")
            assert np.abs(shares[0] - shares[1]).max() <= 1e-4, (spec, method, np.abs(shares[0] - shares[1]).max())


def test_epipolar_dense_zone_is_15_percent_of_the_image_and_at_most_64_pixels():
    """The samples four times as dense around the light's image: out to 15 % of the longer
    side on small images (256 x 192: 38.4 px, which the 1 % above needs: 13 px gave 2 %), at
    most lights.DENSE_PX (64) on large ones (1920 x 1080: 0.23 % from the march, as with 128 px)."""
    from fogcli import make_config
    from fogcli.device.shadows import DENSE_PX, epipolar_layout

    for w, h, zone in ((256, 192, 0.15 * 256), (1920, 1080, DENSE_PX)):
        cfg = make_config(None, sets=["lights=[{type: point, position: [0, 0, -10], intensity: 1}]"])
        _, _, _, _, r0, rb, h1, h2, m1, nm, _, full, _ = epipolar_layout(cfg, cfg.lights[0], w, h, 512, 16)
        assert full and r0 == 0.0 and h1 == h2 / 4, (w, h)
        assert zone <= rb < zone + h1, (w, h, rb)


def test_samples_visibility_from_the_maps_agrees_with_walking_their_lines():
    """The epipolar samples read their visibility from their slices' shadow maps; built with
    SH_WALK each walks its own line pixel by pixel as the march does. At 256 x 192, five lights:
    >= 99.5 % of the samples in the frame have the same verdict and lit shares within 0.01
    (measured 99.84-100 %; the samples at the light's own image disagreed on 6 % of them
    until the light-on-the-ray case came before the maps)."""
    from shadows import visibility_agreement

    for name, (n, same, close, _) in visibility_agreement(192, 256).items():
        assert n > 5000 and same >= 0.995 and close >= 0.995, (name, n, same, close)


def test_unwarp_on_eight_lanes_matches_the_per_pixel_build(monkeypatch):
    """epi_unwarp built for AVX2 CPUs (LANES 8, kernels/lanes.h: eight pixels of a row per work-item, the
    lanes past the row's end storing nothing) against the per-pixel build, on every machine:
    facade scene 61 x 48 (a partial last vector), five lights, the airlight with shadows agrees
    to 1e-6 of its peak (measured: identical)."""
    from fogcli.device import plan as device_plan
    from fogcli.device.runtime import get_runtime

    z = facade_scene(48, 61)
    got = []
    for lanes in (1, 8):
        monkeypatch.setattr(get_runtime(), "lanes", lanes)
        monkeypatch.setattr(device_plan, "_PLANS", {})       # plans hold the kernels built for their lanes
        got.append([airlight(z, spec, "render.lights.shadows=screen", "render.lights.thickness=0.05")
                    for spec, _, _ in CASES.values()])
    for a, b in zip(*got):
        assert np.abs(a - b).max() <= 1e-6 * a.max(), np.abs(a - b).max() / a.max()
        assert a[:, -1].max() > 0
