"""render.spread_space: angles (docs/method.md, The plane the glow spreads in): the Gaussians
laid out over a plane of angles (apsf.theta_plane), the plane's scale (apsf.warp_scale), and
a glow away from the frame's centre, which a pinhole stretches along the radius."""
import math

import numpy as np
import pytest

from fogcli import apply
from fogcli.api import make_config
from fogcli.physics import apsf


def ring_energies(profile, th_edges):
    """Sum over the plane of angles (theta as distance) of a radial profile, per ring."""
    th = np.linspace(th_edges[0], th_edges[-1], 20001)
    y = profile(th) * 2 * math.pi * th
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(th))])
    return np.diff(np.interp(th_edges, th, cum))


def test_theta_plane_keeps_narrow_gaussians_and_fits_the_profile_of_the_others():
    """A Gaussian of std sigma_u in u = tan(theta) is G(tan theta) / cos^3 theta per steradian;
    theta_plane's replacement over theta matches its ring sums over the first radian closer
    than the u-Gaussian laid out over theta as it is (up to 0.5; measured 0.6 % to 14 % of
    the light there, against 0.6 % to 22 %), narrow ones unchanged to 1e-3 (the two planes
    agree there), and the widest keep their width."""
    sig = apsf.load_table()["sigma_u"]
    e, st = apsf.theta_plane(sig)
    narrow = sig < 0.05
    np.testing.assert_allclose(e[narrow], 1.0, atol=1e-3)
    np.testing.assert_allclose(st[narrow], sig[narrow], rtol=3e-3)
    for s_u, e_j, s_t in zip(sig, e, st):
        if not 0.05 <= s_u <= 0.5:
            continue
        edges = np.linspace(0.0, min(1.0, 6 * s_u), 25)
        want = ring_energies(lambda t: np.exp(-0.5 * (np.tan(t) / s_u) ** 2) / np.cos(t) ** 3 / (2 * math.pi * s_u ** 2),
                             edges)
        got = ring_energies(lambda t: e_j * np.exp(-0.5 * (t / s_t) ** 2) / (2 * math.pi * s_t ** 2), edges)
        plain = ring_energies(lambda t: np.exp(-0.5 * (t / s_u) ** 2) / (2 * math.pi * s_u ** 2), edges)
        err, err_plain = np.abs(got - want).sum() / want.sum(), np.abs(plain - want).sum() / want.sum()
        assert err <= err_plain + 1e-3 and err < 0.15, (s_u, err, err_plain)
    assert st[-1] == sig[-1] and e[-1] == 1.0


@pytest.mark.parametrize("w,h,fx,fy,cx,cy", [(256, 192, 221.7, 221.7, 128, 96), (640, 480, 300.0, 320.0, 300, 260),
                                             (100, 300, 90.0, 90.0, 50, 150), (640, 480, 400.0, 300.0, 320, 240),
                                             (256, 256, 40.0, 40.0, 128, 128)])
def test_warp_scale_keeps_the_frame_inside_and_touches_an_edge(w, h, fx, fy, cx, cy):
    """The frame's edges (sampled densely) land inside the level's grid in the plane of angles,
    and the nearest comes within a pixel of the grid's edge: s is the largest that fits (below
    1 where fy < fx), unless the slots' order caps it (a 145-degree lens), where the slots of
    levels 2 and 3 in radians still grow."""
    c = 0.833                          # the default level spacing, and its half-octave variance
    hv = 2 * min(c * c / 2, 1 / 3)
    cap = apsf.warp_cap(c, hv, 3)
    s = apsf.warp_scale(w, h, fx, fy, cx, cy, cap)
    slots = apsf.slot_widths(8, c, hv)
    slots = slots / np.where(np.arange(len(slots)) >= 6, s, 1.0)
    assert np.all(np.diff(slots) > 0), slots
    t = np.linspace(0, 1, 401)
    xs = np.concatenate([t * w, np.full_like(t, w), t * w, np.zeros_like(t)])
    ys = np.concatenate([np.zeros_like(t), t * h, np.full_like(t, h), t * h])
    qx, qy = apsf.image_to_plane(xs, ys, (3, s, cx, cy, fx, fy))
    assert qx.min() >= -1e-6 and qy.min() >= -1e-6 and qx.max() <= w + 1e-6 and qy.max() <= h + 1e-6
    gap = min(qx.min(), qy.min(), w - qx.max(), h - qy.max())
    assert gap < 1.0 or s == cap, (gap, s, cap)


def test_the_map_round_trips():
    """plane_to_image undoes image_to_plane (the one definition of the plane, whose tables the
    kernels read: device/warp.map_arrays), and sin(rho) / rho stays at most 1."""
    geom = (3, 1.2, 300.0, 200.0, 280.0, 300.0)
    x, y = np.meshgrid(np.linspace(-50, 650, 29), np.linspace(-30, 430, 23))
    qx, qy = apsf.image_to_plane(x, y, geom)
    px, py, jac, ok = apsf.plane_to_image(qx, qy, geom)
    assert ok.all() and (jac <= 1).all()
    np.testing.assert_allclose(px, x, atol=1e-6)
    np.testing.assert_allclose(py, y, atol=1e-6)


W, H, COLS = 384, 96, (192, 342)       # a 90-degree lens; 342: 150 px right of the centre, 38 degrees


def _glow(space, col):
    """The pyramid's scattered light of one lamp (3 x 3 px) at column `col`, all at 20 m."""
    img = np.zeros((H, W, 3), np.float32)
    img[H // 2 - 1:H // 2 + 2, col - 1:col + 2] = 50.0
    depth = np.full((H, W), 20.0, np.float32)
    cfg = make_config("haze", sets=["camera.fov=90", "camera.depth=distance", f"render.spread_space={space}",
                                    "render.emission_profile=isotropic", "render.border=open", "render.ground=none",
                                    "render.halo_depth=none"])
    st = np.asarray(cfg.medium.absorption) + np.asarray(cfg.medium.scattering)
    return (apply(img, depth, cfg) - img * np.exp(-st * depth[..., None])).sum(-1), cfg


def _exact(cfg, col, angular):
    """Brute force over the lamp's pixels: each spreads the table's kernel K(u) (u the tangent
    of the angle, the table's plane) to every pixel, either by pixel distance over f (the
    pinhole's pixels) or, angular, at the true angle between the two rays, as radiance per
    steradian K(tan theta) / cos^3 theta, from the source pixel's true solid angle cos^3 / f^2."""
    tab = apsf.load_table()
    sa, ss, g = np.asarray(cfg.medium.absorption), np.asarray(cfg.medium.scattering), cfg.medium.asymmetry
    f = cfg.camera.focal(W)
    y, x = np.mgrid[0:H, 0:W] + 0.5
    X, Y = (x - W / 2) / f, (y - H / 2) / f
    d = np.stack([X, Y, np.ones_like(X)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    uu = np.concatenate([[0.0], np.geomspace(1e-5, 50, 4000)])
    gj = np.exp(-uu[:, None] ** 2 / (2 * tab["sigma_u"] ** 2)) / (2 * math.pi * tab["sigma_u"] ** 2)
    out = np.zeros((H, W))
    for ch in range(3):
        a = ss[ch] / (sa[ch] + ss[ch])
        ratio, shape = apsf.spread(tab, g, a, np.array([ss[ch] * 20.0]))
        k = gj @ shape[0] * ratio[0] * apsf.thin_energy(ss[ch] * 20.0, a) * 50.0 / f ** 2
        for r in range(H // 2 - 1, H // 2 + 2):
            for c in range(col - 1, col + 2):
                if angular:
                    cth = np.clip(d @ d[r, c], -1.0, 1.0)
                    out += d[r, c, 2] ** 3 * np.interp(np.tan(np.arccos(cth)), uu, k) / cth ** 3
                else:
                    out += np.interp(np.hypot(X - X[r, c], Y - Y[r, c]), uu, k)
    return out


def test_a_glow_off_the_axis_follows_the_exact_angular_sum():
    """A pinhole stretches a degree by 1 / cos^2 along the radius and 1 / cos across it, and
    an off-axis pixel subtends less of the sphere (cos^3). Over angles the pyramid's glow of a
    lamp changes, against its glow over pixels, as the exact angular sum changes against the
    exact sum over pixels: the light in the frame (the lamp's own 3 x 3 left out) at the
    centre within 0.03 (measured 1.11 against 1.10); 38 degrees off, where over pixels it is
    1.22 times the exact one, closer by 30 % of that distance at least (0.71 against 0.82,
    0.11 where pixels are 0.18 off: levels 0-2, in the image's pixels, keep a little too much
    near the lamp and the wide part too little, which session 42 did not resolve); and how
    much more of it lies outwards, right of the lamp
    than left, within 0.06 (1.18 against 1.13; over pixels alike on both sides)."""
    y, x = np.mgrid[0:H, 0:W] + 0.5
    for col in COLS:
        (ang, cfg), (pix, _) = _glow("angles", col), _glow("pixels", col)
        ex_a, ex_p = _exact(cfg, col, True), _exact(cfg, col, False)
        out = np.hypot(x - col - 0.5, y - H // 2 - 0.5) > 1.5         # the lamp's 3 x 3 left out

        def side(img):
            return img[:, col + 5:col + 40].sum() / img[:, col - 39:col - 4].sum()

        got, want = ang[out].sum() / pix[out].sum(), ex_a[out].sum() / ex_p[out].sum()
        if col == W // 2:
            assert abs(got - want) < 0.03, (col, got, want)
        else:
            assert abs(got - want) < 0.7 * abs(1 - want) and want < 0.9, (col, got, want)
        got, want = side(ang) / side(pix), side(ex_a) / side(ex_p)
        assert abs(got - want) < 0.06, (col, got, want)
        if col != W // 2:
            assert want > 1.1 and got > 1.1
