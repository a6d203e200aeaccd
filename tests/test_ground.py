"""render.ground: the slab of a ground and a sky (physics/slab.py), the plane found in the
depth (physics/ground.py), its table and preprocess's use of it (device/ground.py)."""
import numpy as np
import pytest

import oracles
from helpers import download, plan_for
from fogcli.device import ground as dground
from fogcli.device.plan import Timings
from fogcli.device.preprocess import preprocess, upload
from fogcli.physics import ground, slab

MU = np.array([-0.9, -0.3, -0.05, 0.0, 0.05, 0.3, 0.9])
T = np.array([0.1, 1.0, 3.0, 30.0, 100.0, 2.0, 5.0])


@pytest.mark.parametrize("g", [0.0, 0.7, 0.92])
def test_a_conservative_slab_between_boundaries_of_radiance_one_holds_one(g):
    """Enclosed by a ground and a sky of radiance 1, a medium that does not absorb holds
    radiance 1 in every direction (equilibrium): the light scattered towards the camera along
    a ray of optical length t is 1 - exp(-t), whatever the phase function. Without scattering
    there is none."""
    for tau_H in (2.0, 20.0):
        a, b = slab.inscatter(1.0, g, 0.2, tau_H, MU, T)
        want = 1.0 - np.exp(-slab.ray_length(0.2, tau_H, MU, T))
        np.testing.assert_allclose(a + b, want, atol=1e-4)
        assert (a > 0).all() and (b >= 0).all()
    a, b = slab.inscatter(0.0, g, 0.2, 20.0, MU, T)
    assert np.abs(a).max() < 1e-12 and np.abs(b).max() < 1e-12


def _single_scattering(omega, g, tau_h, mu_v, t_d, n=160):
    """Light of a unit Lambertian ground scattered once towards a camera at optical height
    tau_h (no sky): quadrature over the ray and over the upward directions of the light."""
    t_end = float(slab.ray_length(tau_h, 1e9, np.array([mu_v]), np.array([t_d]))[0])
    s = (np.arange(n) + 0.5) / n * t_end
    z = tau_h + s * mu_v
    th = (np.arange(n) + 0.5) / n * (np.pi / 2)              # light going up: polar angle < 90 deg
    ph = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    wdir = np.stack([np.sin(TH) * np.cos(PH), np.sin(TH) * np.sin(PH), np.cos(TH)], -1)
    v = np.array([np.sqrt(1 - mu_v ** 2), 0.0, mu_v])          # from the camera along the ray
    cos = wdir @ (-v)                                           # turned towards the camera
    p = (1 - g * g) / (1 + g * g - 2 * g * cos) ** 1.5 / (4 * np.pi)
    dom = np.sin(TH) * (np.pi / 2 / n) * (2 * np.pi / (2 * n))
    out = 0.0
    for k in range(n):
        out += np.exp(-s[k]) * omega * (p * np.exp(-z[k] / np.cos(TH)) * dom).sum() * (t_end / n)
    return out


def test_a_thin_slab_is_its_single_scattering():
    """At albedo 0.005 the slab's light is the ground's light scattered once (a quadrature of
    its own, not the discrete ordinates) within 1.5 % (multiple scattering adds up to 0.8 %:
    it doubles at twice the albedo), for rays up, down and along the horizon; an asymmetric
    phase function (g 0.6): the one turned around is 38-290 % off."""
    for mu_v, t_d in ((-0.5, 3.0), (-0.1, 3.0), (0.2, 3.0), (0.8, 1.0), (0.0, 4.0)):
        got = slab.inscatter(0.005, 0.6, 0.3, 1e3, np.array([mu_v]), np.array([t_d]))[0][0]
        want = _single_scattering(0.005, 0.6, 0.3, mu_v, t_d)
        assert abs(got / want - 1) < 0.015, (mu_v, got, want)


def _ground_frame(w, h, pitch=0.0, noise=0.0, rng=None):
    """Planar depth of a ground 1.6 m below a camera of 60 degrees pitched by `pitch`
    degrees (down < 0), to the horizon, and sky (inf) above; random colours."""
    f = (w / 2) / np.tan(np.radians(30.0))
    x = (np.arange(w) + 0.5 - w / 2) / f
    y = -(np.arange(h) + 0.5 - h / 2) / f
    X, Y = np.meshgrid(x, y)
    p = np.radians(pitch)
    wy = Y * np.cos(p) + np.sin(p)          # world up of the direction (x, y, -1) turned by Rx(pitch)
    with np.errstate(divide="ignore"):
        z = np.where(wy < 0, 1.6 / np.maximum(-wy, 1e-12), np.inf)
    if noise:
        z = z * (1 + noise * rng.standard_normal(z.shape))
    rng = rng or np.random.default_rng(0)
    img = np.ones((h, w, 4), np.float32)
    img[..., :3] = rng.uniform(0.1, 1.0, (h, w, 3))
    img[~np.isfinite(z), :3] = [1.5, 1.8, 2.4]
    return img, z.astype(np.float32)


def _found(img, z, *sets):
    from fogcli.api import make_config

    cfg = make_config("haze", sets=("camera.fov=60",) + sets)
    return dground.find(cfg, z.shape[1], z.shape[0], img, z)


def test_the_ground_is_found_under_a_pitched_camera_and_in_noisy_depth(rng):
    """A ground under a camera pitched 10 degrees down, with 1 % depth noise: found at
    1.6 m (within 3 %); told the pitch, its normal is world up (within 1 degree), not told,
    tilted by the pitch; its mean colour and the sky's are the frame's."""
    img, z = _ground_frame(160, 120, pitch=-10.0, noise=0.01, rng=rng)
    on = np.isfinite(z)
    img[on, :3] = [0.4, 0.5, 0.6] * (1 + 0.05 * rng.standard_normal((on.sum(), 3)))
    g = _found(img, z, "camera.pitch=-10")
    assert g is not None and abs(g.height / 1.6 - 1) < 0.03, g
    assert np.degrees(np.arccos(g.normal[1])) < 1.0, g.normal
    g2 = _found(img, z)
    assert abs(np.degrees(np.arccos(g2.normal[1])) - 10.0) < 1.0, g2.normal
    np.testing.assert_allclose(g.colour, [0.4, 0.5, 0.6], rtol=0.03)
    np.testing.assert_allclose(g.sky_colour, [1.5, 1.8, 2.4], rtol=1e-5)
    assert g.sky_distance == 1000.0


def test_a_sky_at_one_distance_all_round_is_a_dome():
    """A sky at 150 m in every direction above the horizon (a dome around the camera, as a
    render's sky sphere gives it) is a dome; a flat ceiling 150 m up (its rays the longer the
    lower they look), an infinite sky and one clamped at max_depth are not (the open sky
    above a medium, the slab's own plane)."""
    img, z = _ground_frame(160, 120)
    sky = ~np.isfinite(z)
    f = 80 / np.tan(np.radians(30.0))
    y = -(np.arange(120) + 0.5 - 60) / f
    x = (np.arange(160) + 0.5 - 80) / f
    X, Y = np.meshgrid(x, y)
    norm = np.sqrt(X * X + Y * Y + 1.0)           # ray length over z depth (the frame's depth is z)
    dome = np.where(sky, 150.0 / norm, np.minimum(z, 150.0 / norm)).astype(np.float32)   # the ground ends at it
    plane = np.where(sky, 150.0 / np.maximum(Y, 1e-3), z).astype(np.float32)
    clamped = np.where(sky, 1000.0, z).astype(np.float32)
    got = {name: _found(img, d) for name, d in [("dome", dome), ("inf", z), ("clamped", clamped)]}
    got["plane"] = _found(img, plane, "camera.max_depth=100000")    # every ray of the ceiling short of it
    assert all(g is not None for g in got.values()), got
    assert got["dome"].dome and abs(got["dome"].sky_distance - 150.0) < 1.0, got["dome"]
    assert not got["plane"].dome and not got["inf"].dome and not got["clamped"].dome, got


@pytest.mark.parametrize("tau_R", [0.5, 4.0, 30.0])
def test_the_domes_plane_lets_the_domes_unscattered_light_through(tau_R):
    """slab.dome_height: the plane sky whose unscattered light reaches the camera
    (cosine-weighted over the upper hemisphere) as a dome's of optical radius tau_R does,
    exp(-tau_R), by a midpoint sum over elevations independent of slab.py's quadrature
    (within 1e-4 of it); nearer than the dome, farther than tau_R minus ln((tau_R + 2) / 2)
    less 5 % (where 2 E_3 goes as its asymptote)."""
    h = slab.dome_height(tau_R)
    mu = (np.arange(200000) + 0.5) / 200000
    through = float(np.mean(2.0 * mu * np.exp(-h / mu)))
    assert abs(through / np.exp(-tau_R) - 1) < 1e-4, (h, through)
    assert 0.95 * (tau_R - np.log((tau_R + 2) / 2)) < h < tau_R


@pytest.mark.parametrize("tau_R,albedo,g", [(18.0, 0.999999, 0.85), (4.0, 0.9, 0.7), (60.0, 0.375, 0.92),
                                             (25.0, 0.72, 0.92)])
def test_the_domes_diffuse_light_comes_through_a_plane_a_third_nearer(tau_R, albedo, g):
    """slab.diffusion_height against the diffusion solutions written out here: kappa z /
    sinh(kappa h) under a plane at h, kappa z / (2 i_1(kappa tau_R)) at the centre of a dark-
    floored hemisphere (i_1 by a midpoint sum of its integral, 1/2 int t e^(x t) dt over [-1, 1]);
    2/3 of the dome's radius without absorption, tau_R - ln(kappa tau_R / 2) / kappa where
    kappa tau_R is large; and the slab's sky stands at the nearer of it and dome_height."""
    h = slab.diffusion_height(tau_R, albedo, g)
    k = np.sqrt(3 * (1 - albedo) * (1 - g * albedo))
    t = (np.arange(400000) + 0.5) / 400000 * 2 - 1
    i1 = float(np.mean(t * np.exp(k * tau_R * t)))      # half the integral over [-1, 1]
    assert abs(np.sinh(k * h) / (2 * i1) - 1) < 1e-4, (h, i1)
    if k * tau_R < 0.01:
        assert abs(h / tau_R - 2 / 3) < 1e-4
    if k * tau_R > 20:
        assert abs(h - (tau_R - np.log(k * tau_R / 2) / k)) < 0.1 / k
    st = 0.1
    both = slab.sky_height(st, 1.6, tau_R / st, True, albedo, g) - st * 1.6
    assert abs(both - min(h, slab.dome_height(tau_R))) < 1e-9
    assert abs(slab.sky_height(st, 1.6, tau_R / st, False, albedo, g) - st * 1.6 - tau_R) < 1e-9


def test_the_ground_colour_is_that_of_its_area_in_reach_not_of_its_pixels():
    """Bright markings on the first 10 m of a dark ground fill the bottom of the frame (the
    pixels' mean is over 0.5) but little of the ground haze reaches (~100 m): the ground's
    colour is below 0.2; the sea preset (extinction 0.17 / m) reaches ~10 m: there the markings are half of it."""
    img, z = _ground_frame(160, 120)
    f = 80 / np.tan(np.radians(30.0))
    dist = z * np.sqrt(((np.arange(160) + 0.5 - 80) / f) ** 2 + ((np.arange(120)[:, None] + 0.5 - 60) / f) ** 2 + 1)
    on = np.isfinite(z)
    img[on, :3] = np.where((dist[on] < 10.0)[:, None], 1.0, 0.1)
    assert img[on, :3].mean() > 0.5
    from fogcli.api import make_config

    got = {m: dground.find(make_config(m, sets=("camera.fov=60",)), 160, 120, img, z).colour[1]
           for m in ("haze", "sea")}
    assert got["haze"] < 0.2 and got["sea"] > 0.4, got


def test_no_ground_in_a_wall_random_depth_or_a_fog_of_primitives(rng):
    """A wall facing the camera, random depth, a ground seen from below (a ceiling) and a
    ground in a heterogeneous medium: no ground."""
    w, h = 120, 90
    img, z = _ground_frame(w, h)
    assert _found(img, z) is not None
    assert _found(img, np.full((h, w), 12.0, np.float32)) is None
    assert _found(img, np.exp(rng.uniform(0, 5, (h, w))).astype(np.float32)) is None
    assert _found(img, z[::-1].copy()) is None                      # above the camera
    assert _found(img, z, "medium.density=[{type: exponential, falloff: 0.1}]") is None
    assert _found(img, z, "render.ground=none") is None


def test_the_slab_table_kernel_matches_its_oracle(rt):
    """slab_table (float32, on the device) against the float64 sum of physics/slab.py at the
    table's nodes, chromatic sea water: within 1e-4 of the table's largest value."""
    plan, cfg = plan_for(rt, 64, 48, "camera.fov=60", "render.psf=apsf", medium="sea")
    g = ground.Ground((0.0, 1.0, 0.0), 1.6, (0.4, 0.5, 0.3), (1.5, 1.8, 2.4), 300.0, 294.0, 0.4)
    dground.table(plan, g, Timings())
    got = np.empty((dground.NU, slab.MU_GRID, 4), np.float32)
    rt.cl.enqueue_copy(rt.queue, got, plan.ground_table[0])
    rt.queue.finish()
    got = got[..., :3]
    m = cfg.medium
    want = oracles.slab_table(g, m.absorption, m.scattering, m.asymmetry, slab.MU_GRID, dground.NU)
    err = np.abs(got - want).max() / np.abs(want).max()
    assert err < 1e-4, err


@pytest.mark.parametrize("medium", ["haze", "sea"])
def test_preprocess_adds_the_slab_and_takes_the_means_out_of_the_sources(rt, rng, medium):
    """With a ground found, preprocess adds the slab's light (oracle: the oracle table read
    bilinearly at each pixel's mu_v and u) to `direct`, and each ground and sky pixel's
    source is that of its colour minus the mean (scat0 over the same frame's without a
    ground: (L - mean) / L); a box standing on the ground keeps its source."""
    w, h = 96, 64
    img, z = _ground_frame(w, h, rng=rng)
    img[30:40, 40:50, :3] = 3.0
    box_d = 6.0
    z[30:40, 40:50] = box_d
    sets = ("camera.fov=60", "render.psf=apsf", "render.emission_profile=isotropic", "camera.depth=z")
    out = {}
    for mode in ("auto", "none"):
        plan, cfg = plan_for(rt, w, h, *sets, f"render.ground={mode}", medium=medium)
        upload(plan, img, z, Timings())
        used = download(plan, plan.depth, 1)     # as light_share_depth left it (its own test)
        preprocess(plan, Timings())
        out[mode] = (download(plan, plan.direct, 4), download(plan, plan.chain, 4), plan.ground)   # chain: level 0
    z = used
    g = out["auto"][2]
    assert g is not None and out["none"][2] is None
    m = cfg.medium
    sa, ss = np.asarray(m.absorption), np.asarray(m.scattering)
    f = (w / 2) / np.tan(np.radians(30.0))
    X, Y = np.meshgrid((np.arange(w) + 0.5 - w / 2) / f, -(np.arange(h) + 0.5 - h / 2) / f)
    dlen = np.sqrt(X ** 2 + Y ** 2 + 1)
    dist = np.minimum(z * dlen, cfg.camera.max_depth)
    mu = (np.asarray(g.normal)[0] * X + np.asarray(g.normal)[1] * Y - np.asarray(g.normal)[2]) / dlen
    tab = oracles.slab_table(g, sa, ss, m.asymmetry, slab.MU_GRID, dground.NU)
    added = out["auto"][0][..., :3] - out["none"][0][..., :3]
    for c in range(3):
        u = 1 - np.exp(-(sa[c] + ss[c]) * dist)
        want = oracles.slab_lookup(tab[..., c], mu, u)
        assert np.abs(added[..., c] - want).max() < 2e-4 * np.abs(want).max() + 1e-6
    on_ground = (np.abs(dist * mu + g.height) < ground.plane_tolerance(g.height, dist, f)) & (mu < 0)
    in_sky = (dist >= g.sky_from) & (mu > 0)
    assert on_ground.mean() > 0.3 and in_sky.mean() > 0.3 and not on_ground[30:40, 40:50].any()
    mean = on_ground[..., None] * np.asarray(g.colour) + in_sky[..., None] * np.asarray(g.sky_colour)
    want = (img[..., :3] - mean) / img[..., :3]
    sc_on, sc_off = out["auto"][1][..., :3], out["none"][1][..., :3]
    big = np.abs(sc_off) > 1e-6 * np.abs(sc_off).max()
    ratio = np.where(big, sc_on / np.where(big, sc_off, 1), want)
    assert np.mean(np.abs(ratio - want) < 1e-3) > 0.999


@pytest.mark.parametrize("case, most, energy", [("ground-haze", 0.05, 0.05), ("ground-sea", 0.10, 0.05)])
def test_a_ground_to_the_horizon_against_path_tracing(case, most, energy):
    """The path-traced ground plane (tools/groundtruth): the default within `most` relative
    L1 and its scattered energy within `energy` of the path tracer's; without the ground
    (every pixel a point source in an infinite medium) it was 0.33 / 0.18 off."""
    import importlib.util

    from fogcli import apply
    from fogcli.api import make_config
    from groundtruth.load import cases
    from metrics import rel_l1
    from helpers import ROOT

    spec = importlib.util.spec_from_file_location("gt", ROOT / "tools" / "groundtruth.py")
    gt = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gt)
    (c,) = [c for c in cases() if c["name"] == case]
    direct = gt.blend(c)
    res = {}
    for mode in ("auto", "none"):
        out = apply(c["L"], c["depth"], make_config(None, sets=gt.case_sets(c["meta"]) + [f"render.ground={mode}"]))
        res[mode] = (rel_l1(out, c["medium"]), float((out - direct).sum() / (c["medium"] - direct).sum()))
    assert res["auto"][0] < most and abs(res["auto"][1] - 1) < energy, res
    assert res["none"][0] > 0.15, res


def test_a_bright_fog_slab_matches_a_random_walk():
    """Fog (albedo 0.999, g 0.85) over 120 optical depths of slab: light from the ground
    wanders hundreds of steps; the flux that comes back down through the height 0.19 (the
    camera's in the path-traced ground-fog) and the flux that goes up there, as fractions of
    what the ground emits, against a random walk of 40 000 photons of its own (1 % apart;
    the walk's own noise is about 0.4 %)."""
    om, g, tau_H, th = 0.999, 0.85, 120.0, 0.19
    rng = np.random.default_rng(1)
    n = 40000
    mu = np.sqrt(rng.uniform(0, 1, n))                  # Lambertian: cosine-weighted
    z, w, alive = np.zeros(n), np.ones(n), np.ones(n, bool)
    down = up = 0.0
    while alive.any():
        idx = np.flatnonzero(alive)
        z0 = z[idx]
        z1 = z0 - np.log(rng.uniform(0, 1, idx.size)) * mu[idx]
        down += w[idx][(z0 > th) & (z1 <= th)].sum()
        up += w[idx][(z0 < th) & (z1 >= th)].sum()
        dead = (z1 <= 0) | (z1 >= tau_H)
        z[idx] = z1
        alive[idx[dead]] = False
        live = idx[~dead]
        w[live] *= om
        xi = rng.uniform(0, 1, live.size)
        sq = (1 - g * g) / (1 - g + 2 * g * xi)
        ct = np.clip((1 + g * g - sq * sq) / (2 * g), -1, 1)
        m0 = mu[live]
        mu[live] = m0 * ct + np.sqrt(np.clip(1 - m0 * m0, 0, 1)) * np.sqrt(1 - ct * ct) * np.cos(
            rng.uniform(0, 2 * np.pi, live.size))
    mu_n, wt, I_g, _ = slab.node_radiance(om, g, tau_H, th)
    half = mu_n.size // 2
    # flux through a horizontal plane / the ground's emitted flux (pi x radiance 1)
    f_up = 2 * (I_g[:half] * mu_n[:half] * wt[:half]).sum()
    f_down = 2 * (I_g[half:] * -mu_n[half:] * wt[half:]).sum()
    assert abs(f_down / (down / n) - 1) < 0.01 and abs(f_up / (up / n) - 1) < 0.01, (f_down, down / n, f_up, up / n)
    assert f_down > 0.8           # most of it comes back: the camera sits in a bright diffuse field


def test_the_sky_scattered_along_a_view_matches_a_random_walk():
    """The slab's sky term along views of three elevations (source-function integration of
    every order) against backward walks of tools/dome_check.py under the same plane sky:
    haze's medium (albedo 0.9, g 0.7) under 3 optical units of sky. 40 000 walks a view,
    noise about 0.7 %; they agree within 2.5 %. The same walk under a dome is what says how
    short the slab is of one (docs/physics.md)."""
    from dome_check import plane_sky, walk

    albedo, g, tau_h, tau_H = 0.9, 0.7, 0.05, 3.0
    rng = np.random.default_rng(3)
    for mu_v in (0.05, 0.35, 0.9):
        want, err = walk(mu_v, albedo, g, tau_h, plane_sky(tau_H - tau_h), 40000, rng)
        got = slab.inscatter(albedo, g, tau_h, tau_H, np.array([mu_v]), np.array([np.inf]))[1][0]
        assert err < 0.01 * want and abs(got / want - 1) < 0.025, (mu_v, got, want, err)


@pytest.mark.parametrize("medium", ["haze", "sea"])
def test_a_light_takes_nothing_from_the_grounds_scattered_light(medium):
    """A light's airlight joins level 0 of the colour chain, where the ground's sources
    (colour minus the ground's mean) have either sign: a faint light far to the side
    changes the frame by its own light only (< 1e-5 of it), not by re-weighting the
    ground pixels' log P (a signed luminance did: +10 % on the path-traced street in fog)."""
    from fogcli import apply
    from fogcli.api import make_config

    img, z = _ground_frame(128, 96, rng=np.random.default_rng(3))
    img[40:60, 50:70, :3] = 4.0
    z[40:60, 50:70] = 12.0
    sets = ["camera.fov=60", "camera.depth=z"]
    base = apply(img[..., :3], z, make_config(medium, sets=sets))
    lit = apply(img[..., :3], z, make_config(medium, sets=sets + [
        "lights=[{type: point, position: [400, 0, -5], intensity: [1e-6, 1e-6, 1e-6]}]"]))
    assert np.abs(lit - base).sum() / np.abs(base).sum() < 1e-5
