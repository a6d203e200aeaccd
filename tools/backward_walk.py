"""Backward random walks through a homogeneous medium with the Henyey-Greenstein phase function:
the light that reaches the camera having scattered at least once, for the checks of fogcli's
models against walks of their own (tools/dome_check.py, occlusion_check.py, glow_depth_check.py;
tests/test_ground.py)."""
from __future__ import annotations

import numpy as np

from fogcli.physics.dome import hg_cosine

ROULETTE = 1e-4      # below this weight a walk goes on with probability SURVIVE, its weight / SURVIVE
SURVIVE = 0.1


def turn(d: np.ndarray, ct: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Directions d (n, 3) turned by angles of cosine ct about them, at azimuths phi."""
    a = np.where(np.abs(d[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    u = np.cross(d, a)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(d, u)
    st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))[:, None]
    return d * ct[:, None] + st * (u * np.cos(phi)[:, None] + v * np.sin(phi)[:, None])


def scattered(p: np.ndarray, d: np.ndarray, sigma_t: float, albedo: float, g: float, hit, rng) -> np.ndarray:
    """Per walk, from points p (n, 3) along unit directions d, the radiance it brings back: the
    radiance of the surface where it ends, times albedo^k, if it scattered k >= 1 times on
    the way (the unscattered light is not counted). hit(p, d) -> (the distance to the first
    surface, its radiance), both (n,); sigma_t in the same units' inverse."""
    w = np.ones(len(d))
    score, idx = np.zeros(len(d)), np.arange(len(d))
    first = True
    while idx.size:
        s = -np.log(rng.random(idx.size)) / sigma_t
        t, rad = hit(p, d)
        out = t < s
        if not first:
            score[idx[out]] = (w * rad)[out]
        first = False
        idx, p, d, w, s = idx[~out], p[~out], d[~out], w[~out] * albedo, s[~out]
        p = p + d * s[:, None]
        d = turn(d, hg_cosine(g, rng.random(idx.size)), 2.0 * np.pi * rng.random(idx.size))
        w = np.where(w < ROULETTE, np.where(rng.random(idx.size) < SURVIVE, w / SURVIVE, 0.0), w)
        live = w > 0.0
        idx, p, d, w = idx[live], p[live], d[live], w[live]
    return score
