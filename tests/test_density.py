"""Optical depth P of the density primitives (docs/conventions.md, Geometry) against numerical quadrature
over random cameras, through the optical_depth AOV of the full pipeline."""
import math

import numpy as np
import pytest

from fogcli import apply
from oracles import optical_depth_quadrature
from fogcli.api import make_config

def _rot(yaw, pitch, roll):
    y, p, r = np.radians([yaw, pitch, roll])
    ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    rx = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    rz = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
    return ry @ rx @ rz


def _case(rng, depth_kind, inside_sphere=False):
    w, h = 24, 18
    fov = rng.uniform(40, 100)
    pos = rng.uniform([-20, 0.5, -20], [20, 12, 20])
    yaw, pitch, roll = rng.uniform(-180, 180), rng.uniform(-25, 25), rng.uniform(-15, 15)
    d = rng.normal(size=3)
    prims = [
        {"type": "homogeneous", "factor": float(rng.uniform(0, 0.2))},
        {"type": "exponential", "factor": float(rng.uniform(0.3, 2)), "falloff": float(rng.uniform(0.01, 0.4)),
         "direction": [0.0, 1.0, 0.0], "offset": [0.0, float(rng.uniform(-2, 2)), 0.0]},
        {"type": "exponential", "factor": float(rng.uniform(0.1, 1)), "falloff": float(rng.uniform(0.01, 0.1)),
         "direction": [float(v) for v in d], "offset": [float(v) for v in rng.uniform(-30, 30, 3)]},
        {"type": "sphere", "factor": float(rng.uniform(0.5, 3)), "radius": float(rng.uniform(3, 25)),
         "center": [float(v) for v in (pos if inside_sphere else pos + rng.uniform(-40, 40, 3))]},
    ]
    depth = rng.uniform(0.5, 150, (h, w)).astype(np.float32)
    depth[:3] = np.inf                       # sky rows, clamped at max_depth
    depth[5, 5] = 0.01
    sets = [f"camera.fov={fov}", f"camera.position={list(map(float, pos))}", f"camera.yaw={yaw}",
            f"camera.pitch={pitch}", f"camera.roll={roll}", f"camera.depth={depth_kind}",
            "camera.max_depth=400", "medium.density=" + str(prims).replace("'", '"')]
    return w, h, fov, pos, _rot(yaw, pitch, roll), depth, prims, sets


@pytest.mark.parametrize("seed,depth_kind,inside", [(1, "z", False), (2, "distance", False), (3, "z", True),
                                                    (4, "distance", True), (5, "z", False)])
def test_optical_depth_matchesoptical_depth_quadrature(seed, depth_kind, inside):
    rng = np.random.default_rng(seed)
    w, h, fov, pos, R, depth, prims, sets = _case(rng, depth_kind, inside)
    cfg = make_config("fog", sets=sets)
    _, aov = apply(np.ones((h, w, 3), np.float32), depth, cfg, aovs=("optical_depth",), return_aovs=True)
    P = aov["optical_depth"]
    f = (w / 2) / math.tan(math.radians(fov) / 2)
    worst = 0.0
    for j in range(h):
        for i in range(w):
            dc = np.array([(i + 0.5 - w / 2) / f, -(j + 0.5 - h / 2) / f, -1.0])
            D = float(depth[j, i]) * (np.linalg.norm(dc) if depth_kind == "z" else 1.0)
            D = min(D, 400.0)
            want = optical_depth_quadrature(pos, R @ (dc / np.linalg.norm(dc)), D, prims)
            err = abs(P[j, i] - want) / max(want, 1e-3)
            worst = max(worst, err)
    assert P.max() > 1.0 and (P[3:] > 0).all()
    assert worst < 1e-4, worst


def test_grazing_exponential_rays_are_stable():
    """Height fog seen level: <w, n> ~ 0 on the horizon rows; P must follow rho' D there."""
    h, w = 41, 8
    depth = np.full((h, w), 1000.0, np.float32)
    cfg = make_config("fog", sets=["camera.depth=distance", "camera.max_depth=1000", "camera.fov=2",
                                   'medium.density=[{"type": "exponential", "factor": 1, "falloff": 0.5, '
                                   '"direction": [0, 1, 0]}]'])
    _, aov = apply(np.ones((h, w, 3), np.float32), depth, cfg, aovs=("optical_depth",), return_aovs=True)
    P = aov["optical_depth"][:, 0].astype(np.float64)
    f = (w / 2) / math.tan(math.radians(2) / 2)
    for j in range(h):
        dy = -(j + 0.5 - h / 2) / f
        dc = np.array([(0.5 - w / 2) / f, dy, -1.0])
        k = dc[1] / np.linalg.norm(dc)           # <w, n>, |k| < 1.3e-3 here
        x = -0.5 * 1000 * k
        want = 1000 * (math.expm1(x) / x if x else 1.0)
        assert abs(P[j] - want) / want < 1e-4, (j, P[j], want)


def test_camera_rotation_convention():
    """Positive pitch looks up, positive yaw turns left (docs/conventions.md, Geometry): with height fog the
    centre ray that looks up sees less; a sphere to the left is seen after yawing left."""
    depth = np.full((9, 9), 100.0, np.float32)
    fog = 'medium.density=[{"type": "exponential", "factor": 1, "falloff": 0.2, "direction": [0, 1, 0]}]'
    ball = 'medium.density=[{"type": "sphere", "factor": 1, "radius": 5, "center": [-30, 0, 0]}]'

    def centre(*sets):
        cfg = make_config("fog", sets=["camera.depth=distance", *sets])
        _, aov = apply(np.ones((9, 9, 3), np.float32), depth, cfg, aovs=("optical_depth",), return_aovs=True)
        return float(aov["optical_depth"][4, 4])

    assert centre(fog, "camera.pitch=10") < centre(fog) < centre(fog, "camera.pitch=-10")
    assert centre(ball) == 0.0 and centre(ball, "camera.yaw=-90") == 0.0
    assert centre(ball, "camera.yaw=90") == pytest.approx(4 / 3 * 5, rel=1e-4)   # full chord: 4R/3
