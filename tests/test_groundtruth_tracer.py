"""The equiangular path tracer of tools/groundtruth (the reference of the night scenes with
point lights) against exact answers: a furnace, single scattering by quadrature, and the vacuum
image Mitsuba rendered of the same scene."""
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

GT = Path(__file__).resolve().parents[1] / "tools" / "groundtruth"


@pytest.fixture(scope="module")
def eq():
    sys.path.insert(0, str(GT))
    try:
        spec = importlib.util.spec_from_file_location("gt_equiangular", GT / "equiangular.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        yield mod
    finally:
        sys.path.remove(str(GT))


@pytest.mark.parametrize("analog", [False, True])
def test_furnace_is_exactly_one(eq, analog):
    """A closed sphere emitting 1 inward, filled with a medium that only scatters: every
    pixel sees exactly 1 whatever the optical depth (forced scattering, RR and HG sampling
    all enter), with either roulette (--analog: survival = the walk's weight)."""
    dome = dict(kind="sphere", pos=[0, 0, 0], scale=10.0, radiance=[1.0, 1.0, 1.0], flip=True)
    tr = eq.Tracer("yard", shapes=[dome], lights=[])
    for ss, g in [(0.2, 0.85), (0.05, 0.0)]:
        img = tr.render(16, 3, ss, ss, g, **eq.roulette(analog)) / 16
        assert abs(img.mean() - 1.0) < 5e-3, (ss, g, img.mean())


def test_a_disc_is_seen_as_mitsuba_places_it(eq):
    """A disc (scenes.py's `disk`: radius 1 in its z = 0 plane, emitting towards +z) of
    radius 2 at 10 m facing the camera covers pi (2 f / 10)^2 pixels of radiance 1, and
    nothing shows from behind."""
    S = eq.S
    disc = dict(kind="disk", pos=[0.0, 0.0, -10.0], scale=2.0, radiance=[1.0, 1.0, 1.0])
    img = eq.Tracer("yard", shapes=[disc], lights=[]).render(64, 5, 0.0, 0.0, 0.0) / 64
    want = np.pi * (2.0 * S.FOCAL / 10.0) ** 2
    assert abs(img[..., 0].sum() / want - 1) < 0.01, (img[..., 0].sum(), want)
    back = dict(disc, rot=[("y", 180)])
    assert eq.Tracer("yard", shapes=[back], lights=[]).render(4, 5, 0.0, 0.0, 0.0).max() == 0.0


def test_single_scattering_matches_quadrature(eq):
    """Equiangular + HG sampling of one light's single scattering (max_depth 1, pixel centres)
    against a midpoint rule of 20000 nodes in the angle seen from the light."""
    S = eq.S
    lp, I = np.array([0.5, 1.2, -7.0]), np.array([10.0, 6.2, 3.0])
    ss, st, g = 0.12, 0.12012, 0.85
    tr = eq.Tracer("yard", shapes=[], lights=[(tuple(lp), list(I))])
    img = tr.render(1024, 3, ss, st, g, max_depth=1, jitter=False) / 1024
    rng = np.random.default_rng(0)
    dirs = S.camera_directions()
    ratios = []
    for _ in range(60):
        j, i = rng.integers(0, S.HEIGHT), rng.integers(0, S.WIDTH)
        w = dirs[j, i] / np.linalg.norm(dirs[j, i])
        d1, R = w @ lp, np.linalg.norm(np.cross(w, lp))
        th = np.linspace(np.arctan2(-d1, R), np.pi / 2, 20001)
        th, dth = (th[1:] + th[:-1]) / 2, th[1] - th[0]
        s = d1 + R * np.tan(th)
        v = lp - s[:, None] * w
        r = np.linalg.norm(v, axis=1)
        mu = (v @ w) / r
        p = (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * mu) ** 1.5)
        ref = np.sum(ss * p * np.exp(-st * (s + r)) / R) * dth * I
        ratios.append(img[j, i] / ref)
    ratios = np.asarray(ratios)
    assert abs(ratios.mean() - 1) < 0.01, ratios.mean()
    assert abs(np.median(ratios) - 1) < 0.01, np.median(ratios)


def test_vacuum_image_matches_mitsubas(eq):
    """Shapes, transforms, uv maps and textures as Mitsuba has them: the yard's vacuum image
    within the anti-aliasing noise of 256 + 256 samples."""
    tr = eq.Tracer("yard")
    img = tr.render(64, 9, 0.0, 0.0, 0.0) / 64
    with np.load(GT / "renders-lights" / "yard-fog.npz") as z:
        L = z["L"].astype(np.float64)
    assert abs(img.sum() / L.sum() - 1) < 2e-3
    assert eq.rel_l1(img, L) < 0.05


def test_a_small_lamps_single_scattering_is_a_point_lights(eq):
    """Next-event estimation of an emissive sphere (a point along the segment, a direction in
    its cone): a sphere of 2 cm emitting I / (pi r^2) scatters what a point light of
    intensity I does, away from the pixels that see the sphere itself."""
    S = eq.S
    lp, I, r = np.array([0.5, 1.2, -7.0]), np.array([10.0, 6.2, 3.0]), 0.02
    ss, st, g = 0.12, 0.12012, 0.85
    lamp = dict(kind="sphere", pos=list(lp), scale=r, radiance=list(I / (np.pi * r * r)))
    a = eq.Tracer("yard", shapes=[lamp], lights=[]).render(256, 3, ss, st, g, max_depth=1, jitter=False)
    b = eq.Tracer("yard", shapes=[], lights=[(tuple(lp), list(I))]).render(256, 3, ss, st, g, max_depth=1, jitter=False)
    p = lp / -lp[2]
    jj, ii = np.mgrid[0:S.HEIGHT, 0:S.WIDTH]
    away = np.hypot(ii + 0.5 - (p[0] * S.FOCAL + S.WIDTH / 2), jj + 0.5 - (-p[1] * S.FOCAL + S.HEIGHT / 2)) > 4
    ratio = a[away].sum(0) / b[away].sum(0)
    assert np.all(np.abs(ratio - 1) < 0.01), ratio


def test_next_event_counts_every_path_once(eq):
    """A lamp and a sign in haze inside a black sphere (it ends the walks), whole walks: with
    next-event estimation of the lamp (its points and the walk's own hits weighted by the
    balance heuristic; the sign is the walk's alone) the scattered light is the walks' alone
    within 1 % (measured 0.1-0.25 %); counting both in full adds it again (measured 1.8x)."""
    lamp = dict(kind="sphere", pos=[1.0, 0.5, -6.0], scale=0.6, radiance=[4.0, 3.0, 2.0])
    sign = dict(kind="rectangle", pos=[-2.0, -0.5, -9.0], scale=[1.5, 0.8, 1], radiance=[1.0, 2.0, 3.0])
    wall = dict(kind="sphere", pos=[0, 0, 0], scale=15.0, radiance=None, flip=True)
    tr = eq.Tracer("yard", shapes=[lamp, sign, wall], lights=[])
    assert tr.nn == 1
    ss, st, g = 0.1, 0.111, 0.7
    a = tr.render(64, 5, ss, st, g, **eq.roulette(True), nee=True) / 64
    b = tr.render(512, 6, ss, st, g, **eq.roulette(True), nee=False) / 512
    direct = tr.render(16, 7, 0.0, st, g, nee=False) / 16
    ratio = (a - direct).sum((0, 1)) / (b - direct).sum((0, 1))
    assert np.all(np.abs(ratio - 1) < 0.01), ratio


def test_more_samples_for_an_image_without_halves_fill_the_second_half_first():
    """load.alternate_halves, as render.py --resume and equiangular.py --resume use it: an
    earlier image of 64 spp without halves is half A; the new passes (seeds counted on from
    the old ones) go to B until it has as many, then alternate, and the noise is only asked
    for when B has caught up."""
    sys.path.insert(0, str(GT))
    try:
        spec = importlib.util.spec_from_file_location("gt_load_halves", GT / "load.py")
        load = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(load)
    finally:
        sys.path.remove(str(GT))
    passes, asked = [], []

    def render_pass(k):
        passes.append(k)
        assert len(passes) < 20, "half B never caught up with A"
        return np.full((2, 2, 3), float(k))

    def stop(na, nb, noise, el):
        asked.append((na, nb))
        return na + nb >= 160

    sa, sb, na, nb, _, _ = load.alternate_halves(render_pass, 16, stop, lambda s: None, k0=4,
                                                 acc=(np.ones((2, 2, 3)) * 64, 0.0), n=(64, 0))
    assert passes == [4, 5, 6, 7, 8, 9]                  # 4 passes into B, then A and B once
    assert (na, nb) == (80, 80) and asked == [(64, 64), (80, 80)]
    assert sb[0, 0, 0] == 4 + 5 + 6 + 7 + 9 and sa[0, 0, 0] == 64 + 8
