"""render.psf: apsf — the host's lookup table (fogcli.physics.apsf) and the kernels that read it,
against numpy oracles (tests/oracles.py). Tolerances: float32 kernels vs float64 oracles,
2e-4 relative unless stated."""
import math

import numpy as np
import pytest

import oracles
from helpers import FOG, download, random_frame
from helpers import plan_for
from fogcli.physics import apsf, apsf_lut, emission, glow_depth
from fogcli.device.plan import Timings
from fogcli.device.run import read_chain
from fogcli.device.runtime import LOCAL_CPU
from fogcli.device.composite import composite_source
from fogcli.device.preprocess import preprocess, upload
from fogcli.device.pyramid import collapse, reduce


def _natural_spline(x, y, xq):
    """Textbook natural cubic spline of y(x) at xq (x ascending): the oracle of albedo_weights."""
    n, h = len(x), np.diff(x)
    A = np.zeros((n, n))
    r = np.zeros(n)
    A[0, 0] = A[-1, -1] = 1.0
    for i in range(1, n - 1):
        A[i, i - 1:i + 2] = h[i - 1], 2 * (h[i - 1] + h[i]), h[i]
        r[i] = 6 * ((y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1])
    m = np.linalg.solve(A, r)
    k = min(max(int(np.searchsorted(x, xq)) - 1, 0), n - 2)
    a, b = (x[k + 1] - xq) / h[k], (xq - x[k]) / h[k]
    return a * y[k] + b * y[k + 1] + ((a ** 3 - a) * m[k] + (b ** 3 - b) * m[k + 1]) * h[k] ** 2 / 6


def test_albedo_weights_are_the_natural_spline_in_q(rng):
    grid = apsf.load_table()["albedo"]
    q = np.sqrt((1 - grid) / grid)[::-1]
    for a in [grid[0], grid[-1], 0.5, *rng.uniform(0.02, 1.0, 20)]:
        y = rng.normal(size=len(grid))
        w = apsf.albedo_weights(grid, a)
        assert abs(w.sum() - 1) < 1e-12
        assert w @ y == pytest.approx(_natural_spline(q, y[::-1], math.sqrt((1 - a) / a)), abs=1e-9)
    # the table's range clamps: beyond it, its end entries
    assert apsf.albedo_weights(grid, 0.001)[0] == pytest.approx(1.0)


def test_albedo_grid_follows_a_diffusion_like_law():
    """Diffusion's energy falls off like exp(-d sqrt(3 (1 - g) s + s^2)) (s: absorption per
    scattering length): its ratio to the thin medium's exp(-s d) is what the table holds. On
    the shipped grid the spline in q = sqrt(s) of its logarithm is within 0.1 % at every
    albedo midpoint out to 5 scattering lengths; linear in q it is 2.2 % off at d = 5."""
    grid = apsf.load_table()["albedo"]
    s, mids = (1 - grid) / grid, 0.5 * (grid[:-1] + grid[1:])
    for d in (1.0, 2.0, 5.0):
        for g in (0.0, 0.85):
            law = lambda s_: -d * (np.sqrt(3 * (1 - g) * s_ + s_ * s_) - s_)  # noqa: E731
            got = np.array([apsf.albedo_weights(grid, a) @ law(s) for a in mids])
            assert np.abs(np.expm1(got - law((1 - mids) / mids))).max() < 1e-3, (d, g)
    law = lambda s_: -5.0 * (np.sqrt(3 * s_ + s_ * s_) - s_)  # noqa: E731   (d 5, g 0)
    lin = np.interp(np.sqrt((1 - mids) / mids), np.sqrt(s)[::-1], law(s)[::-1])
    assert np.abs(np.expm1(lin - law((1 - mids) / mids))).max() > 0.01     # the scheme it replaced


def test_non_negative_keeps_the_total():
    w = np.array([[0.2, 0.5, -0.1, 0.3, 0.1, 0.0], [0.1, 0.2, 0.3, 0.0, 0.4, 0.0]])
    out = apsf._non_negative(w)
    assert out.min() >= 0
    np.testing.assert_allclose(out.sum(-1), w.sum(-1), atol=1e-12)
    np.testing.assert_allclose(out[1], w[1], atol=1e-12)          # nothing to fix: unchanged
    assert out[0, 2] == 0 and out[0, 1] < 0.5 and out[0, 3] < 0.3  # the dip taken from both sides


def test_slot_mapping_keeps_energy_and_variance():
    slots = apsf.slot_widths(6, 0.833, 2 / 3)
    assert np.all(np.diff(slots) > 0)
    sig = np.array([0.5, 1.3, 3.0, 7.7, 20.0, 45.0])   # inside the ladder
    shape = np.array([[0.1, 0.2, 0.3, 0.15, 0.2, 0.05]])
    v = apsf.to_slots(shape, sig, slots)
    assert abs(v.sum() - 1) < 1e-12
    assert abs((v * slots ** 2).sum() - (shape * sig ** 2).sum()) < 1e-9 * (shape * sig ** 2).sum()
    # wider than the top level: all of it at the top; narrower than nothing: sharp
    v = apsf.to_slots(np.array([[0.5, 0.5]]), np.array([0.0, 1e4]), slots)
    assert v[0, 0] == 0.5 and v[0, -1] == 0.5


def test_fractions_rebuild_the_slot_weights(rng):
    """Passing `up` on and keeping `half` and the rest, level after level, deposits
    exactly the slot weights."""
    levels = 5
    v = rng.uniform(0, 1, (7, 2 * levels + 1))
    v[3, :4] = 0.0                      # nothing narrow
    v /= v.sum(-1, keepdims=True)
    up, half = apsf.fractions(v, levels)
    carried = np.ones(7)
    got = np.zeros_like(v)
    for k in range(levels + 1):
        got[:, 2 * k] = carried * (1 - up[:, k] - half[:, k])
        if 2 * k + 1 < v.shape[1]:
            got[:, 2 * k + 1] = carried * half[:, k]
        carried = carried * up[:, k]
    np.testing.assert_allclose(got, v, atol=1e-12)
    assert np.all(carried < 1e-12)


def test_preprocess_apsf_matches_oracle(rt, rng):
    """Level 0 carries the thin-medium L_sc times the table's energy ratio, and log P."""
    w, h = 37, 23
    img, depth = random_frame(rng, w, h)
    # spread_space pixels: the ratio is the table's energy (in the plane of angles, more: theta_plane)
    plan, cfg = plan_for(rt, w, h, *FOG, "render.psf=apsf", "render.emission_profile=isotropic",
                         "render.spread_space=pixels")
    t = Timings()
    upload(plan, img, depth, t)
    depth = download(plan, plan.depth, 1)       # as light_share_depth left it (its own test)
    preprocess(plan, t)
    chains, _ = read_chain(plan)
    focal = (w / 2) / math.tan(math.radians(70) / 2)
    at, sc, _, _, P = oracles.preprocess(img, depth, cfg.medium.absorption, cfg.medium.scattering, 0.8, focal,
                                         max_depth=300, z=False)
    lut = plan.lut_host.astype(np.float64)
    off = apsf_lut.lut_offsets(len(plan.sizes) - 1, len(apsf.load_table()["sigma_u"]))
    lp = np.log(P)
    ratio = np.stack([oracles.lut_at(lut, off["ratio"] + c * apsf.NP, lp) for c in range(3)], -1)
    np.testing.assert_allclose(chains[0][:, :, 3], lp, rtol=1e-5, atol=2e-6)
    np.testing.assert_allclose(chains[0][:, :, :3], sc * ratio, rtol=2e-4, atol=1e-6)
    # the table's ratio is the Monte Carlo energy over the thin form: in thin media, where
    # light scatters once, the two agree to ~10 %
    assert ratio.min() > 0
    thin = (np.asarray(cfg.medium.scattering) * P[..., None]) < 0.05
    assert thin.sum() > 10 and np.all(np.abs(ratio[thin] - 1) < 0.15), ratio[thin].max()


@pytest.mark.parametrize("interp", ["linear-bilinear", "linear-bicubic"])
@pytest.mark.parametrize("border", ["closed", "open"])
@pytest.mark.parametrize("size,space", [((45, 29), "angles"), ((45, 29), "pixels"), ((45, 29), "angles offset"),
                                        ((3, 2), "angles"), ((1, 1), "angles")])
@pytest.mark.parametrize("halo", ["receiver", "none"])
def test_apsf_collapse_matches_oracle(rt, rng, interp, border, size, space, halo):
    """The source collapse against oracles.apsf_collapse; with spread_space angles (45 x 29,
    open border: levels 3 and up in the plane of angles) through oracles_warp, also with the
    principal point off the centre and fy < fx ("offset")."""
    w, h = size
    img, depth = random_frame(rng, max(w, 4), max(h, 4))
    img, depth = img[:h, :w].copy(), depth[:h, :w].copy()
    depth[0, 0] = 12.0
    depth[h // 2:] *= 0.05          # a near surface below the rest: receivers that keep part of the glow
    plan, cfg = plan_for(rt, w, h, *FOG, "render.psf=apsf", f"render.interpolation={interp}",
                         f"render.border={border}", f"render.halo_depth={halo}",
                         f"render.spread_space={space.split()[0]}",
                         *(("camera.cx=30", "camera.cy=11", "camera.focal_px=34", "camera.focal_px_y=27")
                           if "offset" in space else ()), aovs=("scattered",))
    assert (plan.warp is not None) == (space != "pixels" and w > 8 and border == "open")
    t = Timings()
    upload(plan, img, depth, t)
    preprocess(plan, t)
    level0 = read_chain(plan)[0][0].astype(np.float64)
    reduce(plan, t, masked=True)
    collapse(plan, t)
    composite_source(plan, t)
    got = download(plan, plan.scat_aov, 4)[:, :, :3]
    from fogcli.physics.calibration import FILTERS

    want = oracles.apsf_collapse(level0[:, :, :3], level0[:, :, 3], plan.lut_host.astype(np.float64),
                                 len(plan.sizes) - 1, FILTERS[4], interp != "linear-bilinear",
                                 plan.half_step(), border == "open",
                                 apsf.slot_widths(len(plan.sizes) - 1, cfg.render.resolved()[0], 2 * plan.half_step()),
                                 recv=(apsf_lut.lut_offsets(len(plan.sizes) - 1, len(apsf.load_table()["sigma_u"]))["recv"],
                                       glow_depth.NU) if halo == "receiver" else None, warp=plan.warp)
    np.testing.assert_allclose(got, want, rtol=2e-4, atol=2e-5 * max(1.0, float(want.max())))
    if halo == "receiver" and w > 8:      # the weights are exercised: the near half keeps less
        whole = oracles.apsf_collapse(level0[:, :, :3], level0[:, :, 3], plan.lut_host.astype(np.float64),
                                      len(plan.sizes) - 1, FILTERS[4], interp != "linear-bilinear",
                                      plan.half_step(), border == "open",
                                      apsf.slot_widths(len(plan.sizes) - 1, cfg.render.resolved()[0],
                                                       2 * plan.half_step()), warp=plan.warp)
        assert got[h // 2:].sum() < 0.97 * whole[h // 2:].sum()
    if border == "closed" and w > 2 and halo == "none" and plan.warp is None:
        # each level's shares partition what reaches it, and reduce and up-sampling hand
        # on each pixel's energy exactly, at the border too (a 900-radiance lamp 2 px
        # from a corner here; the plain filters gained 6 % on it)
        assert abs(got.sum() / level0[:, :, :3].sum() - 1) < 1e-4


def _apsf_reference(sc, lp, lut, sigmas, open_border, extend=None):
    """Brute force: every pixel spreads each table Gaussian with its own weight. extend: (mx,
    my, kx, ky) of render.border: extend: each Gaussian's sources continued past the edge
    (oracles.continue_edges), the result on the padded frame."""
    n = int(lut[2])
    nlev = int(lut[3])
    base = 4 + nlev * 6 * n + 3 * n
    h, w = (lp.shape[0] + 2 * extend[1], lp.shape[1] + 2 * extend[0]) if extend else lp.shape
    out = np.zeros((h, w, 3))
    yy, xx = np.mgrid[0:h, 0:w]
    for j, s in enumerate(sigmas):
        wt = np.stack([oracles.lut_at(lut, base + (j * 3 + c) * n, lp) for c in range(3)], -1) * sc
        if extend:
            wt = oracles.continue_edges(wt, *extend, lp)
        if not wt.any():
            continue
        if s < 0.25:
            out += wt
            continue
        R = int(math.ceil(4 * s))
        d = np.arange(-R, R + 1)
        g1 = np.exp(-d * d / (2 * s * s))
        for j0 in range(h):
            for i0 in range(w):
                if not wt[j0, i0].any():
                    continue
                k = np.exp(-((xx - i0) ** 2 + (yy - j0) ** 2) / (2 * s * s))
                k[np.abs(xx - i0) > R] = 0
                k[np.abs(yy - j0) > R] = 0
                norm = g1.sum() ** 2 if open_border else k.sum()
                out += k[..., None] * wt[j0, i0] / norm
    return out


@pytest.mark.parametrize("border", ["closed", "open", "extend"])
def test_apsf_reference_matches_brute_force(rt, rng, border):
    """extend: the open brute force with each source continued past the edge
    (border_margin of the frame on each side) as the mean of the band next to it
    (border_band) over the pixels on the end pixel's surface (oracles.continue_edges; the lamp
    2 px in front of the left edge's surface stays out), cropped."""
    w, h = 19, 13
    img, depth = random_frame(rng, w, h)
    depth[:, :5] = 12.0                       # a surface along the left edge, and a lamp nearer in front of it
    img[6, 2, :3] = 300.0
    depth[6, 2] = 2.0
    plan, cfg = plan_for(rt, w, h, *FOG, "render.psf=apsf", "render.method=reference",
                         f"render.border={border}", "camera.fov=20", "render.border_band=0.2",
                         aovs=("scattered",))
    t = Timings()
    upload(plan, img, depth, t)
    preprocess(plan, t)
    level0 = read_chain(plan)[0][0].astype(np.float64)
    from fogcli.device.border_size import border_band, border_margin
    from fogcli.device.reference import reference_into

    reference_into(plan, t)
    got = download(plan, plan.scat_aov, 4)[:, :, :3]
    sigmas = apsf.load_table()["sigma_u"] * cfg.camera.focal(w)
    lut = plan.lut_host.astype(np.float64)
    mx, my = border_margin(cfg, w, h)
    f = cfg.render.border_margin
    assert f > 0 and (mx, my) == ((round(f * w), round(f * h)) if border == "extend" else (0, 0))
    kx, ky = border_band(cfg, w, h)
    assert (kx, ky) == (4, 3)
    want = _apsf_reference(level0[:, :, :3], level0[:, :, 3], lut, sigmas, border != "closed",
                           (mx, my, kx, ky))[my:my + h, mx:mx + w]
    np.testing.assert_allclose(got, want, rtol=1e-3, atol=1e-5 * float(want.max()))
    if border == "closed":
        assert abs(got.sum() / level0[:, :, :3].sum() - 1) < 1e-4
    elif border == "open":
        assert got.sum() < level0[:, :, :3].sum()
    else:   # the continued edge sends light in: more than the open frame keeps of its own (1.026
        # here: the random depths keep most band pixels off their end pixel's surface)
        assert got.sum() > 1.015 * _apsf_reference(level0[:, :, :3], level0[:, :, 3], lut, sigmas, True).sum()


def test_lambertian_view_cosine_on_a_tilted_plane(rt, rng):
    """A plane tilted about the vertical axis: the kernel's normal from the depth map gives
    the analytic view cosine, and the scattered light is weighted by the table at it."""
    w, h = 33, 21
    fov = 70.0
    f = (w / 2) / math.tan(math.radians(fov) / 2)
    n = np.array([math.sin(0.9), 0.0, math.cos(0.9)])      # normal 52 degrees off the axis
    x = (np.arange(w) + 0.5 - w / 2) / f
    y = -(np.arange(h) + 0.5 - h / 2) / f
    d = np.stack(np.broadcast_arrays(x[None, :], y[:, None], -np.ones((h, w))), -1)
    t = 8.0 / -(d @ n)                                    # plane n . p = -8
    p = d * t[..., None]
    depth = (-p[..., 2]).astype(np.float32)               # planar z
    img = rng.uniform(0.5, 2, (h, w, 4)).astype(np.float32)
    sets = ("medium.absorption=0.02", "medium.scattering=0.3", "medium.asymmetry=0.8", f"camera.fov={fov}",
            "render.psf=apsf")
    plan_i, cfg = plan_for(rt, w, h, *sets, "render.emission_profile=isotropic")
    plan_l, _ = plan_for(rt, w, h, *sets, "render.emission_profile=lambertian")
    levels0 = []
    for plan in (plan_i, plan_l):
        tm = Timings()
        upload(plan, img, depth, tm)
        preprocess(plan, tm)
        levels0.append(read_chain(plan)[0][0].astype(np.float64))
    cos_true = np.abs((p / np.linalg.norm(p, axis=-1, keepdims=True)) @ n)
    lut = plan_l.lut_host.astype(np.float64)
    off = apsf_lut.lut_offsets(len(plan_l.sizes) - 1, len(apsf.load_table()["sigma_u"]))
    u = np.clip((cos_true - emission.COS_MIN) / (1 - emission.COS_MIN) * (emission.NC - 1), 0, emission.NC - 1.001)
    ci = np.floor(u).astype(int)
    fr = u - ci
    lp = levels0[1][..., 3]
    for c in range(3):
        # the table holds the weight times the energy ratio, which the isotropic level 0 carries
        # (its own plan's: in the plane of angles the ratio depends on the spread's shape)
        ratio = oracles.lut_at(plan_i.lut_host.astype(np.float64), off["ratio"] + c * apsf.NP, lp)
        a = oracles.lut_at(lut, off["lambert"] + (ci * 3 + c) * apsf.NP, lp)
        b = oracles.lut_at(lut, off["lambert"] + ((ci + 1) * 3 + c) * apsf.NP, lp)
        want = levels0[0][..., c] / ratio * (a + (b - a) * fr)
        np.testing.assert_allclose(levels0[1][..., c], want, rtol=2e-3)


def test_apsf_with_heterogeneous_media_separation_emission_and_every_aov():
    """The default point spread with ground fog and a smoke ball (tau = ss P), pixel
    separation, emission and ambient: every AOV comes out, the scattered AOV is what the
    image adds to the direct and medium light, and separation keeps the scattered energy."""
    from fogcli import apply
    from fogcli.api import make_config
    from fogcli.config.aovs import AOV_NAMES
    from hdr_scenes import scene

    rgb, z, fov = scene(96, 64, seed=21, night=True)
    sets = [f"camera.fov={fov}", "medium.emission=[0.002, 0.002, 0.003]", "medium.ambient=[0.05, 0.05, 0.08]",
            "medium.density=[{type: homogeneous, factor: 0.3}, {type: exponential, factor: 1.0, falloff: 0.3},"
            " {type: sphere, factor: 2.0, center: [0, 0, -15], radius: 4}]"]
    out, planes = apply(rgb, z, make_config("fog", sets=sets), aovs=AOV_NAMES, return_aovs=True)
    sep, planes2 = apply(rgb, z, make_config("fog", sets=sets + ["render.separation.enabled=true"]),
                         aovs=("scattered",), return_aovs=True)
    assert np.isfinite(out).all() and np.isfinite(sep).all()
    for name in AOV_NAMES:
        keys = [k for k in planes if k == name or k.startswith(name + ".")]
        assert keys, name
    rgb_of = lambda p, n: np.stack([p[f"{n}.{c}"] for c in "RGB"], -1)  # noqa: E731
    np.testing.assert_allclose(out, rgb_of(planes, "direct") + rgb_of(planes, "emission") + rgb_of(planes, "scattered"),
                               rtol=1e-4, atol=1e-5)
    assert rgb_of(planes, "scattered").sum() > 0.01 * out.sum()
    e1, e2 = rgb_of(planes, "scattered").sum(), rgb_of(planes2, "scattered").sum()
    assert abs(e2 / e1 - 1) < 0.02


def _view_cosines(cfg, depth, steps=(1, 1)):
    """float64 oracle of kernels/preprocess.cl view_cosines: camera-space points (from
    planar z, or from the ray length with camera.depth distance), along each axis the
    one-sided difference over `steps` pixels with the smaller depth step (the inward one at
    the image's edge); where both steps go the same way and are steeper than ISOLATED_STEEP
    times the spacing, the neighbour moved to this pixel's depth; |cos| between the normal
    and the line of sight."""
    from light_oracles import pinhole_rays

    from fogcli.device.preprocess import ISOLATED_STEEP

    h, w = depth.shape
    dirs, lengths = pinhole_rays(cfg, depth)
    if cfg.camera.depth == "distance":
        lengths = np.asarray(depth, np.float64)
    P = dirs * lengths[..., None]
    f = cfg.camera.focal(w)          # square pixels: the same along both axes
    out = np.empty((h, w))

    def side(p, a, b, k, n, at):
        fwd = at + k < n and (at < k or abs(a[2] - p[2]) < abs(p[2] - b[2]))
        dz_f, dz_b = a[2] - p[2], p[2] - b[2]
        lim = ISOLATED_STEEP * k / f * abs(p[2])
        if dz_f * dz_b < 0 and abs(dz_f) > lim and abs(dz_b) > lim:      # (neighbours clamped)
            a, b = a * p[2] / a[2], b * p[2] / b[2]
        return a - p if fwd else p - b

    sx, sy = steps
    for j in range(h):
        for i in range(w):
            p = P[j, i]
            u = side(p, P[j, min(i + sx, w - 1)], P[j, max(i - sx, 0)], sx, w, i)
            v = side(p, P[min(j + sy, h - 1), i], P[max(j - sy, 0), i], sy, h, j)
            n = np.cross(u, v)
            c = abs(n @ p) / math.sqrt((n @ n) * (p @ p)) if n @ n > 0 else float("nan")
            out[j, i] = c if c <= 1 else 1.0
    return np.nan_to_num(out, nan=1.0)


LX = LOCAL_CPU[0]     # the interior (one pixel in from each edge) of 2 LX columns holds one whole group


@pytest.mark.parametrize("w,h,kind", [(37, 19, "z"), (2 * LX, 8, "z"), (5, 40, "z"), (37, 19, "distance"),
                                      (2 * LX, 8, "distance"), (LX + 5, 19, "z")])
def test_view_cosines_match_oracle(rt, rng, w, h, kind):
    """view_cosines (view_cosines_inner on the interior's whole work-groups where the frame
    holds one, the checked per-pixel kernel on the strips around it) against the oracle on a
    depth map of tilted steps with one-pixel lamps in front, every pixel including the edges; 1e-4 absolute (float32).
    Planar depth takes the inner kernel's division-free path (CAM_Z), distance the general one."""
    yy, xx = np.mgrid[0:h, 0:w]
    depth = (5.0 + 0.05 * xx + 0.03 * yy + 2.0 * ((xx // 7 + yy // 5) % 2)
             + rng.uniform(0, 0.01, (h, w))).astype(np.float32)
    depth[2::5, 1::6] -= 3.0          # one-pixel lamps in front: isolated along both axes
    plan, cfg = plan_for(rt, w, h, "camera.fov=60", "render.psf=apsf", "render.emission_profile=lambertian",
                         f"camera.depth={kind}")
    tm = Timings()
    # one colour: light_share_depth (its own test) moves no pixel
    upload(plan, np.full((h, w, 4), 0.5, np.float32), depth, tm)
    plan.smoothing = None      # the depth as it is (its checker's and lamps' edges could read as noise)
    preprocess(plan, tm)
    got = download(plan, plan.cosines, 1)
    np.testing.assert_allclose(got, _view_cosines(cfg, depth), atol=1e-4)


def test_staircase_finds_the_blocks_of_a_nearest_neighbour_upsampling(rng):
    """Blocks of equal depth k x l (a depth map enlarged by nearest neighbour) are found
    per axis; a smooth map, a quantised one (flats of every length) and one with wide
    constant regions (sky, a fronto wall) are not staircases."""
    from fogcli.device.preprocess import staircase

    yy, xx = np.mgrid[0:120, 0:160]
    smooth = (4.0 + 0.05 * xx + 0.2 * yy + rng.uniform(0, 1e-3, (120, 160))).astype(np.float32)
    assert staircase(smooth) == (1, 1)
    for k, m in ((2, 2), (3, 2), (4, 4), (2, 1)):
        low = smooth[::m, ::k]
        big = np.repeat(np.repeat(low, m, 0), k, 1)[:120, :160]
        assert staircase(big) == (k, m), (k, m)
    assert staircase(np.round(smooth * 1000 / 7) * 7 / 1000) == (1, 1)   # 7 mm steps: flats of 1-3 px
    wall = smooth.copy()
    wall[:, 60:] = 30.0
    wall[:40] = np.inf
    assert staircase(wall) == (1, 1)


ERR = {2: 0.005, 3: 0.008}     # measured 0.0026 and 0.0052 (the staircase's own block-spanning cosines: 0.03)


@pytest.mark.parametrize("k", [2, 3])
def test_view_cosines_of_a_staircase_are_those_of_its_realigned_depth(rt, rng, k):
    """A ground plane whose depth was enlarged k x k by nearest neighbour: the view cosines
    are the oracle's on the depth realign_blocks made of it (smooth between the blocks'
    centres), and within ERR[k] of the smooth plane's on 95 % of the ground (the one-pixel
    differences of the staircase itself are flat or a whole block's rise: cosines of 1 and
    of about half the true one)."""
    from fogcli.device.preprocess import REALIGN_TOL, staircase

    w, h = 3 * LX + 7, 40
    plan, cfg = plan_for(rt, w, h, "camera.fov=60", "render.psf=apsf", "render.emission_profile=lambertian",
                         "camera.depth=z")
    f = cfg.camera.focal(w)
    ry = -(np.arange(h) + 0.5 - h / 2) / f
    z = np.broadcast_to((1.6 / (0.3 - ry))[:, None], (h, w)).astype(np.float32)  # a ground seen from 1.6 m, pitched down
    big = np.repeat(np.repeat(z[::k, ::k], k, 0), k, 1)[:h, :w]
    assert staircase(big) == (1, k)      # planar z of a level ground does not change along a row
    got = []
    img = rng.uniform(0, 1, (h, w, 4)).astype(np.float32)
    for d in (z, big):
        upload(plan, img, d, Timings())
        preprocess(plan, Timings())
        got.append(download(plan, plan.cosines, 1).astype(np.float64))
    smooth = oracles.realign_blocks(big, img, 1, k, 0, 0, REALIGN_TOL).astype(np.float32)
    np.testing.assert_allclose(got[1], _view_cosines(cfg, smooth, (1, 1)), atol=1e-4)
    err = np.abs(got[1] - got[0])[k:-k, k:-k]
    assert np.percentile(err, 95) < ERR[k], np.percentile(err, 95)


def _far(cfg, depth):
    """The depth at which each pixel's ray reaches camera.max_depth."""
    from light_oracles import pinhole_rays

    ones = np.ones(depth.shape)
    return cfg.camera.max_depth / (ones if cfg.camera.depth == "distance" else pinhole_rays(cfg, ones)[1])


@pytest.mark.parametrize("kind", ["z", "distance"])
def test_a_noisy_depth_is_smoothed_for_the_view_cosines_as_the_oracle_does(rt, rng, kind):
    """smooth_depth (along x, then y) against its oracle on a noisy depth of a tilted plane,
    a box in front of it, one-pixel lamps, sky rows and a pixel of infinite depth; then
    view_cosines on the smoothed depth against theirs. Depth: 1e-5 relative on 99.5 % of pixels (a float32 step within its
    tolerance can end a run the float64 one continues); cosines 1e-4 where the depths match,
    but for 1.5 % (a line fitted along a column leaves its two one-sided steps equal to the
    rounding: float32 may take the other one, whose chord of a curved surface gives a cosine
    off by up to 0.06)."""
    w, h = 2 * LX + 11, 23
    plan, cfg = plan_for(rt, w, h, "camera.fov=60", "render.psf=apsf", "render.emission_profile=lambertian",
                         f"camera.depth={kind}", "camera.max_depth=60")
    yy, xx = np.mgrid[0:h, 0:w]
    depth = 8.0 + 0.04 * xx + 0.2 * yy
    depth[8:14, 20:30] *= 0.8                            # a box in front: an edge of 20 %
    depth[8:20, 60:80] *= 0.945                          # and one of 5.5 %: 3 px away the step ends the run
    depth[4::6, 3::9] *= 0.5                             # one-pixel lamps
    depth[3:6] = 59.5                                    # a surface just in front of the sky ...
    depth *= 1.0 + 0.005 * rng.standard_normal((h, w))
    depth[:3] = 60.5                                     # ... (past max_depth: not its neighbour)
    depth[15, 40] = np.inf
    depth = depth.astype(np.float32)
    upload(plan, np.full((h, w, 4), 0.5, np.float32), depth, Timings())     # one colour: no light_share_depth
    assert plan.smoothing is not None
    plan.smoothing = radius, tau = 4, 0.025
    from fogcli.device.preprocess import view_cosines

    view_cosines(plan, Timings())
    got = download(plan, plan.chain, 4).reshape(-1)[: w * h].reshape(h, w).astype(np.float64)
    far = _far(cfg, depth)
    sky = ~(depth < far)
    want = oracles.smooth_depth(oracles.smooth_depth(depth, False, radius, tau, far), True, radius, tau, far)
    close = np.isclose(got, want, rtol=1e-5) | (np.isinf(got) & np.isinf(want))
    assert close.mean() >= 0.995, close.mean()
    assert (got[sky] == depth[sky]).all()                # the sky is kept
    fin = ~sky & np.isfinite(depth)
    assert np.abs(got[fin] - depth[fin]).max() > 1e-3 * 8    # and the rest smoothed
    cos = download(plan, plan.cosines, 1).astype(np.float64)
    with np.errstate(invalid="ignore"):       # the infinite pixel: NaN, a cosine of 1
        want_cos = np.where(~(got < far), 1.0, _view_cosines(cfg, got.astype(np.float32), plan.steps))
    off = np.abs(cos - want_cos)[close]
    assert (off > 1e-4).mean() < 0.015 and off.max() < 0.1, ((off > 1e-4).mean(), off.max())   # ties (docstring)


def test_the_depth_noise_is_measured_and_a_noisy_plane_keeps_its_normals(rt, rng):
    """depth_noise finds a sensor's relative noise (0.5 % and 1 %: within 15 %; the same
    noise on a 2 x 2 staircase too), none on a clean or quantised map; with the smoothing it
    sets, a noisy ground plane's view cosines are within 0.05 of the clean plane's on 90 %
    of it and a 3 x 3 box in front of a wall keeps facing the camera (without it: per-pixel
    normals of the noise)."""
    from fogcli.device.preprocess import depth_noise, staircase

    w, h = 3 * LX + 7, 60
    plan, cfg = plan_for(rt, w, h, "camera.fov=60", "render.psf=apsf", "render.emission_profile=lambertian",
                         "camera.depth=z")
    f = cfg.camera.focal(w)
    ry = -(np.arange(h) + 0.5 - h / 2) / f
    ground = np.broadcast_to((1.6 / (0.45 - ry))[:, None], (h, w)).astype(np.float64)  # pitched down: all ground
    for s in (0.005, 0.01):
        noisy = ground * (1 + s * rng.standard_normal((h, w)))
        assert abs(depth_noise(noisy) / s - 1) < 0.15, (s, depth_noise(noisy))
        big = np.repeat(np.repeat(noisy[::2, ::2], 2, 0), 2, 1)
        assert abs(depth_noise(big, staircase(big)) / s - 1) < 0.15
    assert depth_noise(ground) < 1e-4 and depth_noise(np.round(ground * 1000) / 1000) < 2e-4

    def cosines(d, smooth=True):
        upload(plan, np.ones((h, w, 4), np.float32), d.astype(np.float32), Timings())
        if not smooth:
            plan.smoothing = None
        preprocess(plan, Timings())
        return download(plan, plan.cosines, 1).astype(np.float64)

    clean = cosines(ground)
    noisy = ground * (1 + 0.005 * rng.standard_normal((h, w)))
    err = np.abs(cosines(noisy) - clean)[4:-4, 4:-4]
    assert np.percentile(err, 90) < 0.05, np.percentile(err, 90)
    assert np.percentile(np.abs(cosines(noisy, smooth=False) - clean)[4:-4, 4:-4], 90) > 0.2   # what it is for
    wall = np.full((h, w), 6.0) * (1 + 0.005 * rng.standard_normal((h, w)))
    wall[30:33, 50:53] = 4.0 * (1 + 0.005 * rng.standard_normal((3, 3)))
    assert cosines(wall)[30:33, 50:53].min() > 0.9


def _realigned_on_device(plan, img, big, grid, rtol=1e-5):
    """The depth realign_blocks makes of `big` on the device (then light_share_depth's),
    after checking block_grid finds `grid` and that the kernels match their float64
    oracles (99.9 % of pixels within rtol: float32 ties at the colour test may go either way)."""
    from fogcli.device.plan import LIGHT_SHARE
    from fogcli.device.preprocess import REALIGN_TOL, block_grid

    assert block_grid(big) == grid
    upload(plan, img, big, Timings())
    preprocess(plan, Timings())
    got = download(plan, plan.depth, 1).astype(np.float64)
    want = oracles.light_share_depth(oracles.realign_blocks(big, img, *grid, REALIGN_TOL).astype(np.float32), img,
                                     **LIGHT_SHARE)
    assert np.isclose(got, want, rtol=rtol).mean() >= 0.999
    return got


def test_realign_constants_of_the_kernel_are_the_oracles():
    """kernels/realign.h's PURE_TOL, SINGLE_TOL and PAIR_SLACK are the numbers tools/oracles.py
    uses (one is written in C, the other in Python: held to each other here)."""
    import re
    from helpers import ROOT

    src = (ROOT / "src" / "fogcli" / "device" / "kernels" / "realign.h").read_text()
    for name in ("PURE_TOL", "SINGLE_TOL", "PAIR_SLACK"):
        assert float(re.search(rf"#define {name} ([0-9.]+)f", src).group(1)) == getattr(oracles, name), name


@pytest.mark.parametrize("phase", [0, 1])
def test_a_nearest_neighbour_enlarged_depth_takes_the_edges_of_the_colour(rt, rng, phase):
    """A depth enlarged 2 x 2 by nearest neighbour (its grid starting at `phase`) of a
    textured wall with small bright lamps and a box in front, their edges off the grid:
    block_grid finds the grid, realign_blocks matches its oracle, moves the depth edges to
    the colour's (pixels more than 5 % off the true depth: at most a third of before; the
    3 x 3 lamps' pixels within 5 % on 90 % of them: a lamp of one block or less may have
    left no sample) and takes the wall's ramp smoothly between the blocks' centres."""
    w, h = 2 * LX + 13, 37
    plan, cfg = plan_for(rt, w, h, "camera.fov=60", "render.psf=apsf", "render.emission_profile=isotropic")
    yy, xx = np.mgrid[0:h, 0:w]
    true = 10.0 + 0.2 * xx + 0.01 * yy          # steep: 3 blocks span 12 %, a ramp, no edge
    img = np.ones((h, w, 4), np.float32)
    img[..., :3] = 0.3 + 0.05 * rng.uniform(0, 1, (h, w, 3))
    lamps, wide = np.zeros((h, w), bool), np.zeros((h, w), bool)
    for y, x, s in ((5, 9, 2), (12, 40, 3), (20, 71, 2), (27, 100, 3), (30, 17, 1)):
        lamps[y:y + s, x:x + s] = True
        wide[y:y + s, x:x + s] = s == 3
    true[lamps] = 6.0
    img[lamps, :3] = [50.0, 40.0, 30.0]
    box = (yy >= 9) & (yy < 24) & (xx >= 111) & (xx < 128)
    true[box] = 7.0
    img[box, :3] = [0.6, 0.1, 0.1]
    true = true.astype(np.float32)
    low = true[phase::2, phase::2]
    big = np.repeat(np.repeat(low, 2, 0), 2, 1)
    big = np.pad(big, ((phase, 0), (phase, 0)), mode="edge")[:h, :w]
    got = _realigned_on_device(plan, img, big, (2, 2, phase, phase), rtol=1e-6)
    off = lambda d: np.mean(np.abs(d - true) > 0.05 * true)    # noqa: E731
    assert off(got) <= off(big) / 3, (off(got), off(big))
    assert np.mean(np.abs(got - true)[wide] <= 0.05 * true[wide]) >= 0.9   # (one of a block or two can't)
    near = lamps | box                      # grown by 4 px (a block grid of 2 reaches 3 px)
    for _ in range(4):
        grown = near.copy()
        grown[1:] |= near[:-1]
        grown[:-1] |= near[1:]
        near = grown.copy()
        near[:, 1:] |= grown[:, :-1]
        near[:, :-1] |= grown[:, 1:]
    # the wall's ramp (0.2 a pixel along x) goes on smoothly between the blocks' centres: no
    # staircase left (its second differences are +-0.4), within half a pixel's step of the truth
    # (the samples here sit at the blocks' first pixels, not their centres)
    ramp = ~near[:, 1:-1] & ~near[:, 2:] & ~near[:, :-2]
    ramp[:, -2:] = False                    # the frame's right edge: a partial block
    if phase:
        ramp[:, :2] = False                 # phase 1: the padding's own column
    assert np.abs(big[:, 2:] - 2 * big[:, 1:-1] + big[:, :-2])[ramp].max() > 0.39
    assert np.abs(got[:, 2:] - 2 * got[:, 1:-1] + got[:, :-2])[ramp].max() < 0.02
    inner = ~near
    inner[:2] = inner[-2:] = inner[:, -2:] = False
    if phase:
        inner[:, :2] = False                # (phase 1: the padding's own column)
    assert np.abs(got - true)[inner].max() <= 0.5 * 0.2 + 0.01


def test_a_replicated_ground_is_smooth_to_the_frame_edge(rt):
    """A ground linear in 1 / depth (steep: 1 / depth from 0.02 to 0.6 over the rows, a little along x) sampled
    at its 2 x 2 blocks' centres and enlarged by nearest neighbour: realign_blocks gives back
    the plane on every row, the first and the last too, where the block past the frame is
    continued (in 1 / depth: continued in depth, the far rows read as an edge, 23 % off)."""
    w, h = 2 * LX, 48
    plan, cfg = plan_for(rt, w, h, "camera.fov=60", "render.psf=apsf", "render.emission_profile=isotropic")
    plane = lambda y, x: 1.0 / (0.02 + 0.012 * y + 0.0005 * x)    # noqa: E731
    true = plane(*np.mgrid[0:h, 0:w].astype(np.float64))
    low = plane(*(np.mgrid[0:h:2, 0:w:2] + 0.5))
    big = np.repeat(np.repeat(low, 2, 0), 2, 1).astype(np.float32)
    img = np.ones((h, w, 4), np.float32)
    got = _realigned_on_device(plan, img, big, (2, 2, 0, 0))
    assert np.abs(big / true - 1).max() > 0.1
    assert np.abs(got / true - 1).max() < 1e-3, np.abs(got / true - 1).max(1)


def test_a_replicated_anti_aliased_edge_goes_to_the_surface_covering_most_of_a_pixel(rt):
    """A dark steep face (28 m, 2.5 % deeper a pixel) against a bright sky (150 m) along a
    slanted edge, anti-aliased (a pixel's colour mixes both by how much each covers), its
    depth sampled at each pixel's centre and then enlarged 2 x 2 by nearest neighbour: a pixel
    covered at least 60 % by the sky or 80 % by the face takes that surface's depth (the
    nearest block mean put half of them on the wrong side: mixed blocks look like mixed
    pixels); one 25-40 % sky holds mostly the sky's light and takes the sky's depth
    (light_share_depth's farther side); and the face's pixels at the edge keep its slope
    (0.6 % off on average: the samples sit at the blocks' first pixels, not their centres; a
    block's depth copied: 1.25 %, every other pixel 2.5 %)."""
    w, h = 2 * LX, 40
    plan, cfg = plan_for(rt, w, h, "camera.fov=60", "render.psf=apsf", "render.emission_profile=isotropic")
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    edge = 0.45 * w + 0.37 * yy                        # the face covers x < edge
    cover = np.clip(edge - xx + 0.5, 0.0, 1.0)          # of the pixel [x - 0.5, x + 0.5]
    face = 28.0 * (1.0 + 0.025 * xx) * (1.0 + 0.002 * yy)
    true = np.where(cover >= 0.5, face, 150.0)
    dark, sky = np.array([0.02, 0.02, 0.02]), np.array([3.0, 3.8, 5.0])
    img = np.ones((h, w, 4), np.float32)
    img[..., :3] = cover[..., None] * dark + (1.0 - cover[..., None]) * sky
    big = np.repeat(np.repeat(true[::2, ::2], 2, 0), 2, 1).astype(np.float32)
    got = _realigned_on_device(plan, img, big, (2, 2, 0, 0))
    inside = (xx > 2) & (xx < w - 3) & (yy > 2) & (yy < h - 3)
    sure = inside & ((cover >= 0.8) | (cover <= 0.4)) & (np.abs(xx - edge) < 3)
    assert sure.sum() > 50
    wrong = np.abs(got - true) > 0.05 * true
    assert wrong[sure].sum() == 0, np.argwhere(wrong & sure)[:5]
    lit = inside & (cover >= 0.6) & (cover <= 0.75)
    assert lit.sum() >= 5 and (got[lit] == 150.0).all(), got[lit]
    face_edge = sure & (cover >= 0.8) & (np.abs(xx - edge) < 2)
    off = np.abs(got / true - 1)[face_edge]
    assert off.mean() < 0.009 and off.max() < 0.025, (off.mean(), off.max())


@pytest.mark.parametrize("scene", ["same colour", "at the frame's edge", "three layers and sky"])
def test_realign_keeps_edges_where_colour_cannot_tell_and_invents_no_depth(rt, scene):
    """Replicated depths (blocks of 2 x 2 on the grid) where a simpler rule goes wrong:
    a grey post in front of a grey wall (equal colours: the own block must win the tie, not
    the first block scanned); a bright awning along the frame's top over a wall (the second
    difference at the frame's edge: continued in 1 / depth it is 0 there); a lamp before a
    100 m wall beside a 300 m wall and the sky (the surface carried on from the 100 m wall
    must not take the 300 m one's or the sky's slope: it made 600 m and a finite sky)."""
    w, h = 2 * LX, 24
    plan, cfg = plan_for(rt, w, h, "camera.fov=60", "render.psf=apsf", "render.emission_profile=isotropic",
                         "camera.max_depth=1000")
    yy, xx = np.mgrid[0:h, 0:w]
    ramp = 1.0 + 0.002 * xx + 0.003 * yy                 # a gentle slope: block_grid finds the blocks
    true = 100.0 * ramp
    img = np.ones((h, w, 4), np.float32)
    img[..., :3] = 0.3
    if scene == "same colour":
        true[4:20, 20:22] = 5.0                         # one block wide, on the grid
    elif scene == "at the frame's edge":
        true[0:2] = 5.0 * ramp[0:2]                    # an awning, one block tall, along the top
        img[0:2, :, :3] = 40.0
    else:
        true[:, 40:] = 300.0 * ramp[:, 40:]
        true[:, 60:] = np.inf
        img[:, 60:, :3] = [0.5, 0.6, 0.9]
        true[10:14, 36:40] = 5.0
        img[10:14, 36:40, :3] = 40.0
    big = np.repeat(np.repeat(true[::2, ::2], 2, 0), 2, 1).astype(np.float32)
    got = _realigned_on_device(plan, img, big, (2, 2, 0, 0))
    fin = np.isfinite(true)
    assert (np.abs(got[fin] - true[fin]) <= 0.05 * true[fin]).all(), np.argwhere(np.abs(got - true) > 0.05 * true)[:5]
    assert np.isinf(got[~fin]).all()


def test_grey_media_build_matches_the_per_channel_build(monkeypatch):
    """Fog, haze and smoke have the same coefficients in R, G, B: their programs are built
    with MEDIUM_GREY (one channel's table reads and exponentials serve three). The output is
    the per-channel build's, bit for bit; a medium that differs in any channel is not grey."""
    from fogcli import apply
    from fogcli.device import plan as device_plan
    from fogcli.api import make_config
    from hdr_scenes import scene

    rgb, z, fov = scene(96, 64, seed=22, night=True)
    sets = [f"camera.fov={fov}", "medium.density=[{type: homogeneous, factor: 0.5}, "
            "{type: sphere, factor: 2.0, center: [0, 0, -15], radius: 4}]"]
    cfg = make_config("fog", sets=sets)
    assert device_plan.defines(cfg).get("MEDIUM_GREY") == 1
    for other in ("sea", make_config("fog", sets=["medium.absorption=[0.001, 0.001, 0.0010001]"])):
        assert "MEDIUM_GREY" not in device_plan.defines(make_config(other) if isinstance(other, str) else other)
    grey = apply(rgb, z, cfg, aovs=("scattered",), return_aovs=True)
    real = device_plan.defines
    monkeypatch.setattr(device_plan, "defines", lambda c: {k: v for k, v in real(c).items() if k != "MEDIUM_GREY"})
    per_channel = apply(rgb, z, cfg, aovs=("scattered",), return_aovs=True)
    assert np.array_equal(grey[0], per_channel[0])
    for k in grey[1]:
        assert np.array_equal(grey[1][k], per_channel[1][k]), k
    assert grey[0].std() > 0
