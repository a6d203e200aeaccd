"""Numpy oracles of kernels/warp.cl (render.spread_space: angles): the three resamplings
between the image's plane and the plane of angles, in float64. `geom` is the plan's warp
(K, s, cx, cy, fx, fy: device/plan.warp_geometry)."""
from __future__ import annotations

import numpy as np

from fogcli.physics.apsf import image_to_plane, plane_to_image
from fogcli.physics.luminance import LUMA


# The map itself is physics/apsf.py's (plane_to_image, image_to_plane): one definition, which
# the kernels read as tables (device/warp.map_arrays); tests/test_spread_space.py holds it to
# its properties (round trip, the frame inside the grid, a glow against the exact angular sum).


def _taps(img, u, v):
    """The four clamp-to-edge bilinear taps of img (h, w, ...) at index-space (u, v): values
    (4, ...) and weights (4, ...)."""
    h, w = img.shape[:2]
    u, v = np.clip(u, 0.0, w - 1.0), np.clip(v, 0.0, h - 1.0)
    x0, y0 = np.floor(u).astype(int), np.floor(v).astype(int)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    ax, ay = u - x0, v - y0
    vals = np.stack([img[y0, x0], img[y0, x1], img[y1, x0], img[y1, x1]])
    wts = np.stack([(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay])
    return vals, wts


def _level_points(h, w, k):
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    return (x + 0.5) * 2.0 ** k, (y + 0.5) * 2.0 ** k


def warp_level(col, lp, k, geom):
    """warp_level: level k's light (h, w, 3) and log P (h, w) into the plane of angles: the
    light bilinear times sin(rho) / rho where the image point lies on the level, else 0;
    log P weighted by the taps' luminance (their plain mean where none has light)."""
    h, w = lp.shape
    sc = 2.0 ** k
    px, py, jac, ok = plane_to_image(*_level_points(h, w, k), geom)
    u, v = np.where(ok, px / sc - 0.5, -1.0), np.where(ok, py / sc - 0.5, -1.0)
    inside = ok & (u >= -0.5) & (v >= -0.5) & (u <= w - 0.5) & (v <= h - 0.5)
    cv, wt = _taps(col, u, v)
    lv, _ = _taps(lp, u, v)
    c = (wt[..., None] * cv).sum(0)
    yl = wt * (np.abs(cv) @ np.asarray(LUMA))
    ys = yl.sum(0)
    lpw = np.where(ys > 1e-30, (yl * lv).sum(0) / np.maximum(ys, 1e-300), (wt * lv).sum(0))
    return np.where(inside[..., None], c * jac[..., None], 0.0), lpw


def warp_receivers(rd, k, geom):
    """warp_receivers: level k of the receivers' log P into the plane, bilinear, clamped."""
    h, w = rd.shape
    sc = 2.0 ** k
    px, py, _, _ = plane_to_image(*_level_points(h, w, k), geom)
    vals, wt = _taps(rd, px / sc - 0.5, py / sc - 0.5)
    return (vals * wt).sum(0)


def unwarp_level(E, k, geom):
    """unwarp_level: level k of the collapse (h, w, c) from the plane back to the image's,
    bilinear, clamped."""
    h, w = E.shape[:2]
    sc = 2.0 ** k
    qx, qy = image_to_plane(*_level_points(h, w, k), geom)
    vals, wt = _taps(E, qx / sc - 0.5, qy / sc - 0.5)
    return (vals * wt[..., None]).sum(0)
