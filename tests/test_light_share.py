"""light_share_depth (kernels/light_share.h): a pixel at a depth edge whose light is mostly
the nearer, brighter surface's takes that surface's depth."""
import numpy as np
import pytest

import oracles
from helpers import download, plan_for
from fogcli.device.plan import LIGHT_SHARE, Timings
from fogcli.device.preprocess import upload


def _on_device(rt, img, z):
    h, w = z.shape
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = img[..., :3]
    plan, _ = plan_for(rt, w, h, "render.psf=apsf", "camera.depth=z")
    upload(plan, rgba, z.astype(np.float32), Timings())      # the depth is refined as it is uploaded
    return download(plan, plan.depth, 1).astype(np.float64)


def _oracle(img, z):
    return oracles.light_share_depth(z.astype(np.float32), img, **LIGHT_SHARE)


def _layers(rng, w=83, h=61):
    """Boxes at random depths and brightness over a textured wall, a sky band, small lamps,
    a hole (NaN) and a ground ramp: every kind of edge."""
    img = rng.uniform(0.05, 1.0, (h, w, 3)).astype(np.float32)
    z = np.full((h, w), 30.0) * (1 + 0.01 * rng.standard_normal((h, w)))
    for _ in range(25):
        y0, x0 = rng.integers(0, h - 3), rng.integers(0, w - 3)
        hh, ww = rng.integers(1, 9, 2)
        z[y0:y0 + hh, x0:x0 + ww] = rng.uniform(2, 60)
        img[y0:y0 + hh, x0:x0 + ww] = rng.uniform(0.02, 50.0) * rng.uniform(0.5, 1.0, 3)
    z[:6] = np.inf
    z[h - 12:] = 1.6 / np.linspace(0.02, 0.4, 12)[:, None]
    z[20:23, 40:44] = np.nan
    return img, z.astype(np.float32)


def test_the_kernel_is_its_oracle(rt, rng):
    """The device's depth is the float64 oracle's on 99.8 % of the pixels (a luminance at
    the decision's edge may round either way in float32), and the frame has edges the rule
    moves (more than 2 % of its pixels)."""
    img, z = _layers(rng)
    got, want = _on_device(rt, img, z), _oracle(img, z)
    same = (got == want) | (np.isnan(got) & np.isnan(want))
    moved = (want != z) & ~np.isnan(want)
    assert same.mean() >= 0.998, same.mean()
    assert moved.mean() > 0.02, moved.mean()


def _disc(w, h, cx, cy, r, n=16):
    """The share of each pixel a disc covers (n x n samples a pixel) and whether its centre
    is inside (what a centre-sampled depth takes)."""
    s = (np.arange(n) + 0.5) / n
    yy = np.arange(h)[:, None, None, None] + s[None, None, :, None]
    xx = np.arange(w)[None, :, None, None] + s[None, None, None, :]
    cover = (((xx - cx) ** 2 + (yy - cy) ** 2) <= r * r).mean(axis=(2, 3))
    x, y = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    return cover, (x - cx) ** 2 + (y - cy) ** 2 <= r * r


@pytest.mark.parametrize("lamp, wall, rims", [(40.0, 0.2, 12), (1.0, 0.5, 3)])
def test_an_anti_aliased_lamp_rim_takes_the_lamp_depth_where_most_of_its_light_is_the_lamps(rt, lamp, wall, rims):
    """A disc lamp (5 m) anti-aliased over a uniform wall (20 m), depth centre-sampled: a
    rim pixel whose light is over 55 % the lamp's (coverage c: c lamp / (c lamp + (1 - c)
    wall)) takes 5 m, one under 45 % keeps 20 m; the rest of the frame is unchanged."""
    w, h = 48, 40
    cover, inside = _disc(w, h, 20.3, 17.6, 4.4)
    img = (cover * lamp + (1 - cover) * wall)[..., None] * np.ones(3, np.float32)
    z = np.where(inside, 5.0, 20.0).astype(np.float32)
    got = _on_device(rt, img, z)
    share = cover * lamp / (cover * lamp + (1 - cover) * wall)
    assert (got[share > 0.55] == 5.0).all() and (got[share < 0.45] == 20.0).all()
    rim = (share > 0.55) & ~inside
    assert rim.sum() >= rims, rim.sum()     # the rule is what moves them


def test_a_ground_to_the_horizon_dark_near_surfaces_and_the_sky_beside_them_move_nothing(rt, rng):
    """Nothing moves on a textured ground to the horizon (its depth halves within a few
    rows, evenly), beside a dark box before a bright wall, on a far lamp brighter than the
    box beside it, or in a sky beside a building darker than it; a small lamp brighter than
    the sky does take the sky pixels it half covers."""
    w, h = 64, 48
    f = (w / 2) / np.tan(np.radians(30.0))
    down = (np.arange(h) + 0.5 - h / 2) / f
    z = np.where(down > 0, 1.6 / np.maximum(down, 1e-9), np.inf)[:, None] * np.ones((1, w))
    img = rng.uniform(0.05, 1.0, (h, w, 3)).astype(np.float32)
    img[~np.isfinite(z)] = 2.0
    z[6:20, 10:20] = 40.0                       # a building darker than the sky
    img[6:20, 10:20] = 0.3
    z[12:15, 40:43] = 25.0                      # a lamp brighter than the sky ...
    img[12:15, 40:43] = 30.0
    img[11, 40:43] = img[15, 40:43] = 16.0      # ... half over the sky rows beside it
    z = z.astype(np.float32)
    got = _on_device(rt, img, z)
    changed = got != z
    assert not changed[24:].any()                           # the ground
    assert not changed[4:22, 8:22].any()                    # the building and the sky around it
    assert (got[[11, 15], 40:43] == 25.0).all()             # the lamp's rim
    wall = np.full((h, w), 12.0, np.float32)
    wall[10:20, 10:20] = 4.0                    # a dark box before a bright wall
    img2 = np.full((h, w, 3), 1.0, np.float32)
    img2[10:20, 10:20] = 0.1
    img2[9, 10:20] = img2[20, 10:20] = 0.55     # anti-aliased: half the box
    wall[30:34, 40:44] = 4.0                    # a box brighter than the wall ...
    img2[30:34, 40:44] = 2.0
    img2[32, 45] = 5.0                          # ... beside a lamp on the wall brighter still
    assert (_on_device(rt, img2, wall) == wall).all()


def test_a_sky_pixel_on_a_buildings_depth_takes_the_skys_and_the_facade_stays(rt, rng):
    """The other way: a pixel half covered by a bright sky that carries the building's depth
    (a depth upsampled 2 x 2: edges a pixel off) takes the sky's depth, its light being
    mostly the sky's; a facade's texture beside the sky (a pixel 2.5 times its darkest
    neighbour, 0.6 % of the sky) and a lit window brighter than the sky stay on the
    building. Planted (no farther side; no cover; no 'at most the sky's brightest'): fails."""
    w, h = 48, 40
    z = np.full((h, w), 30.0, np.float32)
    img = rng.uniform(0.02, 0.05, (h, w, 3)).astype(np.float32)
    z[:15], img[:15] = 150.0, (4.0, 5.0, 6.0)           # the sky over the building
    z[15:, :10], img[15:, :10] = 150.0, (4.0, 5.0, 6.0)  # and to its left
    img[15, 12:40] = 0.5 * np.array([4.0, 5.0, 6.0]) + 0.5 * img[15, 12:40]     # half sky
    img[20:30, 10] = (0.02, 0.02, 0.02)
    img[20:30:2, 10] = (0.05, 0.05, 0.05)               # texture at the facade's edge
    img[32:34, 10] = (8.0, 8.0, 8.0)                     # a lit window brighter than the sky
    got = _on_device(rt, img, z)
    assert (got[15, 12:40] == 150.0).all(), got[15, 12:40]
    assert (got[16:, 10:] == 30.0).all()
    assert (got[:15] == 150.0).all() and (got[15:, :10] == 150.0).all()


def test_the_lamp_scene_in_haze_is_closer_to_path_tracing():
    """The path-traced lamps in haze (tools/groundtruth): the default within 0.075 relative
    L1 (0.092 with each rim pixel at the wall's depth)."""
    from fogcli import apply
    from fogcli.api import make_config
    from groundtruth.load import comparison
    from metrics import rel_l1

    g = comparison()
    (c,) = [c for c in g.gt_load.cases() if c["name"] == "lamps-haze"]
    out = apply(c["L"], c["depth"], make_config(None, sets=g.case_sets(c["meta"])))
    assert rel_l1(out, c["medium"]) < 0.075
