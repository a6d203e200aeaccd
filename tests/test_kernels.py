"""Each kernel against its numpy oracle (tests/oracles.py), on odd sizes.
Tolerances: float32 kernels vs float64 oracles, 1e-4 relative unless stated."""
import math

import numpy as np
import pytest

import oracles
from helpers import plan_for
from fogcli.device import plan as device_plan
from fogcli.device import pyramid
from fogcli.api import make_config
from fogcli.physics.calibration import FILTERS
from fogcli.device.plan import Timings
from fogcli.physics.luminance import luminance
from fogcli.device.run import read_chain, write_level0
from fogcli.device.reference import brute_force
from fogcli.device.runtime import LOCAL_CPU
from fogcli.device.composite import composite, composite_source
from fogcli.device.preprocess import preprocess, upload
from fogcli.device.pyramid import collapse, reduce


def _whole(plan, buf):
    """A whole device buffer of floats (every level of a chain)."""
    out = np.empty(buf.size // 4, np.float32)
    plan.rt.cl.enqueue_copy(plan.rt.queue, out, buf)
    plan.rt.queue.finish()
    return out


def _download(plan, buf, ch):
    t = Timings()
    out = plan.download(buf, ch, t)
    plan.rt.queue.finish()
    return out


@pytest.mark.parametrize("model", ["angular", "paper"])
@pytest.mark.parametrize("depth_kind", ["z", "distance", "z-offcentre"])
def test_preprocess_matches_oracle(rt, rng, model, depth_kind):
    """The kernel takes metric depth (depth.decode applies depth_scale on the host); the
    oracle starts from the raw values. z-offcentre: principal point and fy of their own."""
    w, h = LOCAL_CPU[0] + 19, 23        # one whole work-group (no bounds check) and a checked strip
    offc = depth_kind == "z-offcentre"
    depth_kind = "z" if offc else depth_kind
    pp = ["camera.cx=11.5", "camera.cy=15.25", "camera.focal_px_y=31"] if offc else []
    img = rng.uniform(0, 50, (h, w, 4)).astype(np.float32)
    depth = rng.uniform(0.1, 900, (h, w)).astype(np.float32)
    depth[0, :5] = np.inf          # sky
    depth[1, :3] = 5000.0          # beyond max_depth
    sa, ss, g = [0.02, 0.05, 0.1], [0.3, 0.2, 0.25], 0.8
    sets = (f"medium.absorption={sa}", f"medium.scattering={ss}", f"medium.asymmetry={g}",
            f"render.spread_model={model}", "render.spread_scale=1.7", "camera.fov=70",
            f"camera.depth={depth_kind}", "camera.depth_scale=0.5", "camera.max_depth=300",
            "medium.emission=[0.1, 0.2, 0.3]", "medium.ambient=[1, 2, 0.5]", *pp)
    plan, cfg = plan_for(rt, w, h, *sets, aovs=("transmittance", "emission"))
    t = Timings()
    upload(plan, img, depth * np.float32(0.5), t)
    used = _download(plan, plan.depth, 1) / np.float32(0.5)      # as light_share_depth left it (its own test)
    preprocess(plan, t)
    direct = _download(plan, plan.direct, 4)
    medium = _download(plan, plan.medium, 4)
    chains, spreads = read_chain(plan)
    focal = (w / 2) / math.tan(math.radians(70) / 2)
    at, sc, sigma, med, P = oracles.preprocess(img, used, sa, ss, g, focal, scale=1.7, depth_scale=0.5,
                                               max_depth=300, z=(depth_kind == "z"), paper=(model == "paper"),
                                               emission=(0.1, 0.2, 0.3), ambient=(1, 2, 0.5),
                                               focal_y=31 if offc else None, centre=(11.5, 15.25) if offc else None)
    np.testing.assert_allclose(direct[:, :, :3], at, rtol=1e-4, atol=1e-6)
    np.testing.assert_array_equal(direct[:, :, 3], img[:, :, 3])        # alpha untouched
    np.testing.assert_allclose(chains[0][:, :, :3], sc, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(spreads[0], sigma, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(chains[0][:, :, 3], sigma, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(medium[:, :, :3], med, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(medium[:, :, 3], P, rtol=1e-5)
    trans = _download(plan, plan.trans, 4)
    np.testing.assert_allclose(trans[:, :, :3], np.exp(-(np.add(sa, ss)) * P[..., None]), rtol=1e-4, atol=1e-7)
    # without an AOV that needs it apart, the medium's own light rides in `direct`
    plan2, _ = plan_for(rt, w, h, *sets)
    assert not plan2.split_medium
    t = Timings()
    upload(plan2, img, depth * np.float32(0.5), t)
    preprocess(plan2, t)
    np.testing.assert_allclose(_download(plan2, plan2.direct, 4)[:, :, :3], at + med, rtol=1e-4, atol=1e-6)


def test_spread_w_stable_limits(rt):
    """W(0) = 0, ss = 0 gives no spread, sa = 0 keeps the s^1.5 law (no 0/0)."""
    depth = np.array([[0.0001, 1.0, 10.0, 100.0]], np.float32)
    img = np.ones((1, 4, 4), np.float32)
    for sa, ss in [(0.1, 0.0), (0.0, 0.3)]:
        plan, _ = plan_for(rt, 4, 1, f"medium.absorption={sa}", f"medium.scattering={ss}",
                           "medium.asymmetry=0.9", "camera.depth=distance",
                           "render.spread_model=paper", "render.spread_scale=1280")
        t = Timings()
        upload(plan, img, depth, t)
        preprocess(plan, t)
        _, spreads = read_chain(plan)
        s = spreads[0][0]
        assert np.isfinite(s).all()
        if ss == 0.0:
            assert (s == 0).all()
        else:
            expect = 4 * np.sqrt(depth[0].astype(np.float64) ** 3 * ss * 0.1 / 8)  # sa = 0, g = 0.9, 4/1280 px
            np.testing.assert_allclose(s, expect, rtol=1e-4)


@pytest.mark.parametrize("taps", [2, 4, 6])
@pytest.mark.parametrize("masked,fetch,size", [(True, "source", (29, 17)), (True, "receiver", (29, 17)),
                                               (False, "receiver", (29, 17)), (True, "source", (157, 37))])
def test_reduce_level_matches_oracle(rt, rng, taps, masked, fetch, size, monkeypatch):
    """One reduce against the oracle; at 157 x 37 the source fetch's level 1 runs mostly
    through reduce_source_inner (whole work-groups; taken on every CPU here, the pipeline
    leaves it to CPUs whose vectoriser emits gathers), the rest and the small sizes through
    reduce_level_source."""
    monkeypatch.setattr(rt, "lanes", 1)
    w, h = size
    src = rng.uniform(0, 3, (h, w, 4)).astype(np.float32)
    src[:, :, 3] = rng.uniform(0, 6, (h, w))
    src[5, 5, :3] = 400.0           # an HDR pixel dominates the luminance weights
    src[8:10, 2:6, :3] = 0.0        # a black patch: unweighted mean fallback
    spread = rng.uniform(0, 6, (h, w)).astype(np.float32)
    plan, cfg = plan_for(rt, w, h, f"render.kernel={taps}", "render.c=0.9", "render.epsilon=1.5",
                         "render.threshold=1.2", "render.levels=2", f"render.fetch={fetch}")
    write_level0(plan, src, spread)
    reduce(plan, Timings(), masked=masked)
    chains, spreads = read_chain(plan)
    if size[0] > 100:
        (_, sw, sh, _), (_, dw, dh, _) = plan.lv[0], plan.lv[1]
        x0, x1, y0, y1 = pyramid.reduce_region(sw, sh, dw, dh, taps, 0, rt.local2d)
        assert (x1 - x0) * (y1 - y0) >= 0.4 * dw * dh
    lvl, slvl = src.astype(np.float64), spread.astype(np.float64)
    for k in (1, 2):
        lvl, slvl = oracles.reduce_level(lvl, slvl, FILTERS[taps], 1.2 * 0.9 * 2 ** (k - 1), 1.5, masked,
                                         source_weights=(fetch == "source"))
        np.testing.assert_allclose(chains[k], lvl, rtol=1e-4, atol=1e-6)
        if fetch == "receiver":   # the Gaussian spread chain only serves Elek's eq. 11
            np.testing.assert_allclose(spreads[k], slvl, rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize("lanes", [1, 8])
@pytest.mark.parametrize("sets", [[], ["render.border=closed"], ["render.kernel=6"], ["render.kernel=2"],
                                  ["render.psf=gaussian", "render.border=closed"]])
def test_reduce_inner_matches_the_checked_one(rt, rng, sets, lanes, monkeypatch):
    """The interior kernels against reduce_level_source on every pixel: reduce_source_inner
    (lanes 1: whole work-groups, vectorised by PoCL on AVX-512) and, for apsf,
    reduce_source_lanes (lanes 8: eight pixels a work-item on float8, kernels/reduce_lanes.cl).
    The same sums in the same order, so the colour and prep chains agree to float32 rounding
    (1e-6 of each level's peak; measured 0), apsf with its conservation margin and the top
    level's kept share, and the Gaussian chain."""
    from fogcli.device.plan import get_plan

    monkeypatch.setattr(rt, "lanes", lanes)     # either interior kernel on every CPU (see pyramid.reduce)
    h, w = 97, 331
    img = (rng.uniform(0, 2, (h, w, 4)) ** 3).astype(np.float32)
    z = rng.uniform(2, 60, (h, w)).astype(np.float32)
    cfg = make_config("fog", sets=sets)
    got = {}
    for inner in (True, False):
        monkeypatch.setattr(device_plan, "_PLANS", {})
        if not inner:
            monkeypatch.setattr(pyramid, "reduce_region", lambda *a: None)
        plan = get_plan(rt, w, h, cfg)
        t = Timings()
        upload(plan, img, z, t)
        preprocess(plan, t)
        reduce(plan, t, masked=True)
        got[inner] = tuple(_whole(plan, b) for b in (plan.chain, plan.prep))
        if inner:
            (_, sw, sh, _), (_, dw, dh, _) = plan.lv[0], plan.lv[1]
            taps = len(FILTERS[cfg.render.kernel])
            assert (plan.k_reduce_lanes is not None) == (lanes == 8 and plan.apsf)
            region = pyramid.reduce_region(sw, sh, dw, dh, taps, taps // 2 if plan.apsf else 0,
                                           (8, 1) if plan.k_reduce_lanes is not None else rt.local2d)
            assert region is not None and (region[1] - region[0]) * (region[3] - region[2]) >= 0.5 * dw * dh
    for k in range(1, len(plan.sizes)):
        o, lw, lh, _ = (int(v) for v in plan.lv[k])
        for a, b in zip(got[True], got[False]):
            a, b = a[4 * o:4 * (o + lw * lh)], b[4 * o:4 * (o + lw * lh)]
            assert np.abs(a - b).max() <= 1e-6 * max(np.abs(b).max(), 1e-30), k


@pytest.mark.parametrize("interp", ["linear-bilinear", "linear-bicubic"])
@pytest.mark.parametrize("size", [(23, 13), (1, 1), (2, 1)])
def test_source_collapse_matches_oracle(rt, rng, interp, size):
    """Levels K-1..1 collapse in place, level 0 fused with the final sum."""
    w, h = size
    src = rng.uniform(0, 2, (h, w, 4)).astype(np.float32)
    src[:, :, 3] = rng.uniform(0, 8, (h, w))
    plan, cfg = plan_for(rt, w, h, f"render.interpolation={interp}", "render.c=0.8", "render.epsilon=1",
                         "render.threshold=1.1", "render.fetch=source", aovs=("scattered",))
    t = Timings()
    upload(plan, np.zeros((h, w, 4), np.float32), np.ones((h, w), np.float32), t)
    preprocess(plan, t)
    write_level0(plan, src, src[:, :, 3])
    reduce(plan, t, masked=True)
    before, _ = read_chain(plan)
    collapse(plan, t)
    composite_source(plan, t)
    out = _download(plan, plan.out, 4)
    expect = oracles.collapse(before, 0.8, 1.0, cubic=(interp != "linear-bilinear"), thr=1.1, a=plan.half_step())
    assert plan.half_step() > 0.3
    np.testing.assert_allclose(out[:, :, :3], expect[:, :, :3], rtol=1e-4, atol=1e-5)
    # the masks partition the energy and the half-octave blur conserves it; only the
    # interpolated up-sampling at the border moves a little
    if w > 2:
        assert abs(out[:, :, :3].sum() / src[:, :, :3].sum() - 1) < 0.05


@pytest.mark.parametrize("sets", [[], ["render.interpolation=linear-bilinear"], ["render.border=closed"],
                                  ["render.psf=gaussian", "render.border=closed"], ["render.separation.enabled=true"]])
def test_pair_composite_matches_the_per_pixel_one(sets, monkeypatch):
    """composite_source_pairs and collapse_pairs (two pixels a work-item, each level away from
    its edges) against composite_source and collapse_level on every pixel: the same sums, regrouped, so equal to float32
    rounding (1e-6 of the peak; measured 1.8e-8 to 6.8e-8 on these five configs), with the scattered
    AOV and the separated chain's accumulating pass; on a size whose pair rectangle leaves
    strips on all four sides."""
    import fogcli
    from fogcli.device import plan as device_plan

    rng = np.random.default_rng(5)
    h, w = 97, 331
    rgb = rng.uniform(0, 2, (h, w, 3)).astype(np.float32) ** 3
    z = rng.uniform(2, 60, (h, w)).astype(np.float32)
    cfg = fogcli.make_config("fog", sets=sets)
    got = {}
    for pairs in (True, False):
        monkeypatch.setattr(device_plan, "_PLANS", {})
        if not pairs:
            monkeypatch.setattr(device_plan, "pair_region", lambda *a: None)
        out, planes = fogcli.apply(rgb, z, cfg, aovs=("scattered",), return_aovs=True)
        got[pairs] = (out, planes["scattered.R"])
        if pairs:
            regions = next(iter(device_plan._PLANS.values()))._pairs
            x0, x1, y0, y1 = regions[0]
            assert 0 < x0 and x1 < w and 0 < y0 and y1 < h and x1 - x0 >= 64
            assert regions[1] is not None          # the level-1 collapse takes pairs too
    for a, b in zip(got[True], got[False]):
        assert np.abs(a - b).max() <= 1e-6 * np.abs(b).max()


@pytest.mark.parametrize("interp", ["linear-bilinear", "linear-bicubic", "cubic-bicubic"])
def test_receiver_composite_matches_oracle(rt, rng, interp):
    """Elek eq. 10-12: level from the spread blurred at the pixel's own level; the
    Sigg-Hadwiger 4-fetch bicubic equals the 16-tap B-spline."""
    w, h = 21, 15
    src = rng.uniform(0, 2, (h, w, 4)).astype(np.float32)
    spread = rng.uniform(0.1, 12, (h, w)).astype(np.float32)
    src[:, :, 3] = spread
    c = 0.8
    plan, cfg = plan_for(rt, w, h, f"render.interpolation={interp}", f"render.c={c}", "render.fetch=receiver",
                         aovs=("level",))
    t = Timings()
    upload(plan, np.zeros((h, w, 4), np.float32), np.ones((h, w), np.float32), t)
    preprocess(plan, t)
    write_level0(plan, src, spread)
    reduce(plan, t, masked=True)
    chains, spreads = read_chain(plan)
    direct = _download(plan, plan.direct, 4)      # before the result is written over it
    composite(plan, t, depth_blur=True)
    assert not plan.split_medium      # the medium's light is inside `direct` here
    medium = np.zeros_like(direct)
    out = _download(plan, plan.out, 4)
    level = _download(plan, plan.level_aov, 1)
    K = len(chains) - 1
    cubic = interp != "linear-bilinear"

    def fetch(levels, lv, p):
        def at(k):
            q = (p[0] / 2 ** k - 0.5, p[1] / 2 ** k - 0.5)
            return oracles.sample(levels[k], q[0], q[1], cubic)
        k = int(math.floor(lv))
        f = lv - k
        if interp == "cubic-bicubic" and levels is chains:
            wts = [0.5 * (-f**3 + 2*f**2 - f), 0.5 * (3*f**3 - 5*f**2 + 2), 0.5 * (-3*f**3 + 4*f**2 + f), 0.5 * (f**3 - f**2)]
            r = sum(wt * at(min(max(k - 1 + i, 0), K)) for i, wt in enumerate(wts))
            return np.maximum(r, 0)
        a = at(min(k, K))
        return a if (f <= 0 or k >= K) else a * (1 - f) + at(k + 1) * f

    lvl_of = lambda s: min(max(math.log2(max(s, 1e-30) / c), 0.0), K)  # noqa: E731
    for j in range(h):
        for i in range(w):
            p = (i + 0.5, j + 0.5)
            l0 = lvl_of(spread[j, i])
            l1 = lvl_of(fetch(spreads, l0, p))
            assert abs(level[j, i] - l1) < 2e-3
            sc = fetch(chains, level[j, i], p)[:3]
            np.testing.assert_allclose(out[j, i, :3], direct[j, i, :3] + medium[j, i, :3] + sc, rtol=2e-4, atol=2e-5)


def test_reference_kernels_match_brute_force_oracle(rt, rng):
    """The brute-force kernel equals the numpy definition; the binned reference stays
    within 1 % relative L1 of it (docs/conventions.md, The reference), HDR pixels at the border included."""
    w, h = 41, 27
    sc = rng.uniform(0, 1, (h, w, 4)).astype(np.float32)
    sc[0, 0, :3] = 300.0
    sc[13, 40, :3] = 80.0
    spread = np.exp(rng.uniform(np.log(0.1), np.log(30), (h, w))).astype(np.float32)
    spread[3:8, 3:8] = 0.0
    sc[:, :, 3] = spread
    plan, cfg = plan_for(rt, w, h, "render.method=reference")
    t = Timings()
    upload(plan, np.zeros((h, w, 4), np.float32), np.ones((h, w), np.float32), t)
    preprocess(plan, t)   # direct and medium terms: zero image, so zero
    write_level0(plan, sc, spread)
    want = oracles.reference(sc[:, :, :3].astype(np.float64), spread.astype(np.float64))
    brute = brute_force(plan, t)
    np.testing.assert_allclose(brute, want, rtol=2e-4, atol=1e-6)
    from fogcli.device.reference import reference_into

    reference_into(plan, t)
    binned = _download(plan, plan.out, 4)[:, :, :3]
    rel = np.abs(binned - want).sum() / want.sum()
    assert rel < 0.01, rel
    # scattered energy is conserved
    assert abs(binned.sum() / sc[:, :, :3].sum() - 1) < 1e-4


def test_separation_mask_matches_oracle(rt, rng):
    """Iser eq. 4.25: bright (input luminance) and near (D' = P) pixels go to the second
    chain; the two chains add up to L_sc."""
    w, h = 31, 19
    img = rng.uniform(0, 8, (h, w, 4)).astype(np.float32)
    depth = rng.uniform(1, 400, (h, w)).astype(np.float32)
    plan, cfg = plan_for(rt, w, h, "render.separation.enabled=true", "render.separation.luminance=2",
                         "render.separation.luminance_width=3", "render.separation.depth=150",
                         "render.separation.depth_width=100", "camera.depth=distance")
    t = Timings()
    upload(plan, img, depth, t)
    depth = _download(plan, plan.depth, 1)      # as light_share_depth left it (its own test)
    preprocess(plan, t)
    chains, _ = read_chain(plan)
    sep = np.empty((w * h, 4), np.float32)
    plan.rt.cl.enqueue_copy(plan.rt.queue, sep, plan.chain2)
    plan.rt.queue.finish()
    sep = sep[: w * h].reshape(h, w, 4)
    m = cfg.medium
    _, sc, sigma, _, P = oracles.preprocess(img, depth, m.absorption, m.scattering, m.asymmetry,
                                            cfg.camera.focal(w), z=False)
    y = luminance(img)
    ms = oracles.smoothstep(2, 5, y) * (1 - oracles.smoothstep(50, 150, P))
    assert 0.1 < ms.mean() < 0.9
    np.testing.assert_allclose(sep[:, :, :3], ms[..., None] * sc, rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(chains[0][:, :, :3], (1 - ms[..., None]) * sc, rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(sep[:, :, 3], sigma, rtol=1e-4, atol=1e-6)
