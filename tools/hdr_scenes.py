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
    zf = np.where(g, zg, 0.0)
    xw = (xx - w / 2) / f * zf
    tex = 0.5 + 0.5 * np.sign(np.sin(xw * 0.8 / scale) * np.sin(zf * 0.8 / scale))
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


def harbour_sample(width=640, height=360, fov=60.0):
    """The bundled sample: a harbour at night seen from 2 m above the water. A quay on the
    left with lamp posts every 12 m, a moored boat with a mast light, a far shore with lit
    windows at 350 m, a beacon at 500 m, lamp reflections on the water, a night sky."""
    rng = np.random.default_rng(7)
    h, w = height, width
    f = (w / 2) / math.tan(math.radians(fov) / 2)
    jj, ii = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
    dx, dy = (ii - w / 2) / f, -(jj - h / 2) / f          # ray (dx, dy, -1), camera at y = 2
    cam_y = 2.0
    t_sky = np.clip((jj / h) * 2.2, 0, 1)[:, :, None]
    rgb = (np.array([0.004, 0.006, 0.016]) * (1 - t_sky) + np.array([0.030, 0.024, 0.030]) * t_sky)
    z = np.full((h, w), np.inf)

    def put(mask, depth, colour):
        m = mask & (depth < z)
        z[m] = depth[m] if np.ndim(depth) else depth
        rgb[m] = colour[m] if np.ndim(colour) == 3 else colour

    with np.errstate(divide="ignore", invalid="ignore"):
        # far shore: a skyline plane at 350 m with lit windows
        zs = 350.0
        x_s, y_s = dx * zs, cam_y + dy * zs
        skyline = 6 + 18 * np.abs(np.sin(np.floor(x_s / 14) * 1.7)) + 8 * (np.floor(x_s / 31) % 2)
        shore = (y_s > 0) & (y_s < skyline)
        win = ((np.floor(x_s / 2.5) + np.floor(y_s / 3)) % 3 == 0) & (rng.random((h, w)) < 1.0)
        lit = win & (np.sin(np.floor(x_s / 2.5) * 12.9 + np.floor(y_s / 3) * 78.2) > 0.55)
        col = np.where(lit[:, :, None], np.array([6.0, 4.5, 2.5]), np.array([0.012, 0.012, 0.016]))
        put(shore, np.full((h, w), zs), col)
        # water: plane y = 0, dark, with a faint sky reflection
        t_w = np.where(dy < 0, cam_y / -dy, np.inf)
        put(np.isfinite(t_w), t_w, np.array([0.006, 0.009, 0.014]))
        # quay: top at y = 1 for x < -6, side wall at x = -6, from 3 m to 300 m away
        t_top = np.where(dy < 0, (cam_y - 1.0) / -dy, np.inf)
        quay_top = (dx * t_top < -6) & (t_top > 3) & (t_top < 300)
        put(quay_top, t_top, np.array([0.035, 0.032, 0.028]))
        t_wall = np.where(dx < 0, -6.0 / dx, np.inf)
        y_wall = cam_y + dy * t_wall
        put((y_wall > 0) & (y_wall < 1) & (t_wall > 3) & (t_wall < 300), t_wall, np.array([0.02, 0.019, 0.018]))
        # boat: hull box and cabin on the right at 22-30 m
        for (x0, x1, y0, y1, z0, z1, c) in [(3, 10, 0, 1.2, 22, 30, (0.05, 0.02, 0.02)),
                                            (5, 8, 1.2, 2.6, 24, 28, (0.06, 0.06, 0.06))]:
            t_f = np.full((h, w), float(z0))
            xf, yf = dx * t_f, cam_y + dy * t_f
            put((xf > x0) & (xf < x1) & (yf > y0) & (yf < y1), t_f, np.array(c))
    lights = [(-6.5, 6.2, zq, 0.22, (1.0, 0.72, 0.42), 400.0) for zq in range(8, 140, 12)]
    lights += [(6.5, 6.0, 26, 0.15, (0.2, 1.0, 0.3), 150.0), (9.5, 1.8, 22, 0.1, (1.0, 0.15, 0.1), 200.0),
               (60.0, 15.0, 500, 1.2, (1.0, 0.95, 0.85), 2000.0)]
    for lx, ly, lz, r, col, power in lights:
        px, py = w / 2 + lx / lz * f, h / 2 - (ly - cam_y) / lz * f
        rad = max(0.7, r / lz * f)
        # post from the quay top to the lamp
        if lx < 0:
            post = (np.abs(ii - px) < max(0.5, 0.06 / lz * f)) & (jj > py) & (jj < h / 2 - (1 - cam_y) / lz * f)
            put(post, np.full((h, w), float(lz)), np.array([0.015, 0.015, 0.015]))
        disc = (ii - px) ** 2 + (jj - py) ** 2 < rad * rad
        put(disc, np.full((h, w), float(lz)), np.array(col) * power)
        # reflection: a vertical streak below the mirror image, on the water only
        my = h / 2 + (ly + cam_y) / lz * f
        streak = np.exp(-((ii - px) / max(1.0, 0.6 * rad)) ** 2) * np.exp(-((jj - my) / (6 + 30 / lz * f / 50)) ** 2)
        water = (z >= cam_y / np.maximum(-dy, 1e-9) - 1e-6) & (dy < 0)
        rgb[water] += (np.array(col) * power * 0.01 * streak[:, :, None])[water]
    return rgb.astype(np.float32), z.astype(np.float32), fov


def room(width=320, height=240, seed=0, fov=70.0):
    """An indoor RGB-D-like frame: a 5 x 3 x 6 m room seen from 1.4 m, a daylight window in
    the back wall, a ceiling lamp, a table; z depth 1-6 m (no sky). Returns (rgb, z, fov)."""
    rng = np.random.default_rng(seed)
    h, w = height, width
    f = (w / 2) / math.tan(math.radians(fov) / 2)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
    d = np.stack([(xx - w / 2) / f, -(yy - h / 2) / f, -np.ones_like(xx)], axis=-1)   # z = 1 per unit
    eye = np.array([0.3, 1.4, 0.0])
    # planes: (axis, coordinate, colour); the room spans x -2.5..2.5, y 0..3, z 0..-6
    planes = [(0, -2.5, (0.45, 0.42, 0.38)), (0, 2.5, (0.40, 0.42, 0.45)), (1, 0.0, (0.30, 0.22, 0.16)),
              (1, 3.0, (0.55, 0.55, 0.55)), (2, -6.0, (0.50, 0.48, 0.44))]
    t_best = np.full((h, w), np.inf)
    rgb = np.zeros((h, w, 3))
    for axis, c, col in planes:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (c - eye[axis]) / d[..., axis]
        t = np.where(t > 1e-6, t, np.inf)
        p = eye + t[..., None] * d
        hit = t < t_best
        t_best = np.where(hit, t, t_best)
        shade = 0.75 + 0.25 * np.clip(1.0 - p[..., 2] / -6.0, 0, 1)       # lit from the window side
        rgb = np.where(hit[..., None], np.array(col) * shade[..., None], rgb)
        if axis == 2:       # the window: daylight through the back wall
            win = hit & (np.abs(p[..., 0] + 0.5) < 1.0) & (p[..., 1] > 1.0) & (p[..., 1] < 2.4)
            rgb[win] = (4.0, 4.4, 5.0)
        if axis == 1 and c == 3.0:      # a ceiling lamp
            lamp = hit & ((p[..., 0] - 0.6) ** 2 + (p[..., 2] + 3.0) ** 2 < 0.15 ** 2)
            rgb[lamp] = (60.0, 50.0, 35.0)
    # a table: a box top 0.75 m high, 1.2 x 0.8 m, 2.5 m away
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (0.75 - eye[1]) / d[..., 1]
    p = eye + t[..., None] * d
    top = (t > 0) & (t < t_best) & (np.abs(p[..., 0] - 0.2) < 0.6) & (np.abs(p[..., 2] + 2.5) < 0.4)
    t_best = np.where(top, t, t_best)
    rgb[top] = (0.35, 0.20, 0.10)
    rgb *= 1.0 + 0.05 * rng.standard_normal((h, w, 1))                  # texture
    return np.clip(rgb, 0, None).astype(np.float32), t_best.astype(np.float32), fov
