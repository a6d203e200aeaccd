"""Synthetic HDR scenes with planar depth, for the bundled sample, calibration, tests
and benchmarks: sky at infinity, a slanted ground plane, buildings with lit windows at
several distances, and lamps (HDR discs) near and far. Deterministic for a seed."""
from __future__ import annotations

import math

import numpy as np


def _ground(h, w, f, cam_h, horizon):
    rows = np.arange(h, dtype=np.float32)[:, None] + 0.5
    below = rows - horizon
    z = np.where(below > 0.5, cam_h * f / np.maximum(below, 1e-3), np.inf)
    return np.broadcast_to(z, (h, w)).astype(np.float32)


def scene(width=320, height=240, seed=0, night=True, fov=60.0, lamps=6, scale=1.0):
    """Returns (rgb (h, w, 3) float32 scene-linear, z depth (h, w) float32 with +inf sky,
    fov degrees). `scale` multiplies every distance (a bigger or smaller world)."""
    rng = np.random.default_rng(seed)
    h, w = height, width
    f = (w / 2) / math.tan(math.radians(fov) / 2)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32) + 0.5
    horizon = h * rng.uniform(0.40, 0.55)
    cam_h = 1.6 * scale

    # sky: a gradient, dark at night, bright by day
    t = np.clip(yy / max(horizon, 1), 0, 1)[:, :, None]
    if night:
        sky = (np.array([0.010, 0.014, 0.030]) * (1 - t) + np.array([0.035, 0.030, 0.040]) * t)
    else:
        sky = (np.array([0.60, 0.80, 1.40]) * (1 - t) + np.array([1.3, 1.3, 1.35]) * t)
    rgb = np.broadcast_to(sky, (h, w, 3)).astype(np.float32).copy()
    z = np.full((h, w), np.inf, np.float32)

    # ground plane with a texture whose scale shrinks with distance
    zg = _ground(h, w, f, cam_h, horizon)
    g = np.isfinite(zg)
    xw = (xx - w / 2) / f * zg
    tex = 0.5 + 0.5 * np.sign(np.sin(xw * 0.8 / scale) * np.sin(zg * 0.8 / scale))
    base = np.array([0.05, 0.045, 0.04]) if night else np.array([0.25, 0.22, 0.18])
    ground_rgb = base[None, None, :] * (0.6 + 0.4 * tex[:, :, None])
    rgb[g] = ground_rgb[g]
    z[g] = zg[g]

    # buildings: far to near so nearer ones overwrite
    n_b = int(rng.integers(4, 8))
    dists = np.sort(rng.uniform(8, 250, n_b))[::-1] * scale
    for d in dists:
        bw = rng.uniform(6, 30) * scale
        bh = rng.uniform(5, 40) * scale
        cx = rng.uniform(-0.9, 0.9) * d * math.tan(math.radians(fov) / 2)
        x0 = int(w / 2 + (cx - bw / 2) / d * f)
        x1 = int(w / 2 + (cx + bw / 2) / d * f)
        ybase = int(horizon + cam_h * f / d)
        ytop = int(horizon + (cam_h - bh) * f / d)
        x0c, x1c, y0c, y1c = max(x0, 0), min(x1, w), max(ytop, 0), min(ybase, h)
        if x1c <= x0c or y1c <= y0c:
            continue
        wall = np.array([0.03, 0.03, 0.035]) if night else rng.uniform(0.15, 0.5, 3)
        rgb[y0c:y1c, x0c:x1c] = wall
        z[y0c:y1c, x0c:x1c] = d
        # windows: a grid, some lit
        ww = max(1, int(1.2 * scale * f / d))
        gap = max(2, int(3.0 * scale * f / d))
        lit_val = rng.uniform(2, 12) if night else 0.1
        for wy in range(y0c + gap // 2, y1c - ww, gap):
            for wx in range(x0c + gap // 2, x1c - ww, gap):
                if rng.random() < (0.35 if night else 0.9):
                    colour = np.array([1.0, 0.8, 0.5]) * lit_val * rng.uniform(0.3, 1.0)
                    rgb[wy:wy + ww, wx:wx + ww] = colour

    # lamps: bright discs on posts, near and far
    for i in range(lamps):
        d = (rng.uniform(4, 20) if i % 2 == 0 else rng.uniform(30, 200)) * scale
        lx = rng.uniform(-0.8, 0.8) * d * math.tan(math.radians(fov) / 2)
        ly = rng.uniform(3, 6) * scale
        px = w / 2 + lx / d * f
        py = horizon + (cam_h - ly) * f / d
        r = max(0.6, 0.35 * scale * f / d)
        post = (np.abs(xx - px) < max(0.5, 0.08 * scale * f / d)) & (yy > py) & (yy < horizon + cam_h * f / d)
        post &= z > d
        rgb[post] = 0.02
        z[post] = d
        disc = ((xx - px) ** 2 + (yy - py) ** 2 < r * r) & (z > d)
        warm = rng.random() < 0.6
        colour = np.array([1.0, 0.75, 0.4]) if warm else np.array([0.8, 0.9, 1.0])
        power = rng.uniform(50, 2000) if night else rng.uniform(20, 200)
        rgb[disc] = colour * power
        z[disc] = d
    return rgb.astype(np.float32), z, fov


def harbour_sample(width=640, height=360):
    """The bundled sample: a harbour at night, lamps near and far, a lit far quay."""
    return scene(width, height, seed=7, night=True, fov=65.0, lamps=8)
