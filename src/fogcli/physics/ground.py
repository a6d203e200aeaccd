"""The ground plane and the sky of a frame, found in a sample of its depth.

The slab of physics/slab.py needs a ground (a plane below the camera, facing up) and, when
there is one, a sky (the farthest pixels above the ground's horizon). Both are found on a
regular sample of the frame (about SAMPLES pixels): RANSAC with a fixed seed over planes
within MAX_TILT of the camera's up (camera.pitch and roll say where up is; a photo's
unknown few degrees are within it), then a least-squares refinement on the inliers.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fogcli.physics import pixel_rays

SAMPLES = 2048
MAX_TILT = np.radians(35.0)
MIN_GROUND = 0.10        # share of the valid samples on the plane
MIN_REACH = 5.0          # the ground's inliers reach this many camera heights away
MIN_SKY = 0.02           # share of the samples that is sky, else there is none
SKY_NEAR = 0.95          # sky: ray length at least this share of the frame's far end
SKY_FAR = 99.0           # the frame's far end: this percentile of the ray lengths (a noisy
                         # depth's largest value is a few noise widths past the sky's)
TOL_HEIGHT = 0.05         # plane_tolerance's share of the camera's height
TOL_DIST = 0.002          # and of the distance
TOL_PIXELS = 1.5          # and of the height one pixel's angle spans there (preprocess.cl gets all three)
HORIZON_PX = 3.0          # rows this close to the horizon do not count in the ground's colour
DOME_SPAN = 1.25          # a finite sky whose samples' elevation sines span this factor is a dome:
                          # a plane sky's samples, within SKY_NEAR of the farthest, span 1 / SKY_NEAR
ITERATIONS = 96
SCORED = 1024


def fit_tolerance(height, dist):
    """The tolerance the plane is fitted with: plane_tolerance without its pixel term (which
    lets the sky just above a far horizon in, and tilts the fit)."""
    return TOL_HEIGHT * height + TOL_DIST * dist


def plane_tolerance(height, dist, focal):
    """How far (m) a point may lie off the plane and count as ground: 5 % of the camera's
    height (a depth error of a few % along a grazing ray moves a ground point by a few % of
    the height; a wall's foot within it is taken as ground), 0.2 % of the distance (a far
    ground's unevenness, but not the sky just above the horizon) and the height 1.5 pixels
    span at that distance (a depth map enlarged by nearest neighbour gives a pixel its
    neighbour's depth: on a grazing ground a row's)."""
    return TOL_HEIGHT * height + (TOL_DIST + TOL_PIXELS / focal) * dist


@dataclass(frozen=True)
class Ground:
    normal: tuple          # unit, world orientation (camera rotation applied), pointing up
    height: float          # the camera's height above the plane (m)
    colour: tuple          # the mean radiance of the ground's samples
    sky_colour: tuple      # the mean radiance of the sky's samples (0 without a sky)
    sky_distance: float    # the sky's median ray length: the slab's top is this high (m)
    sky_from: float        # rays at least this long above the horizon are sky (m; inf: none)
    share: float           # share of the valid samples on the ground
    dome: bool = False     # the sky is a dome around the camera at sky_distance (DOME_SPAN)


def _dot(a, v):
    """a (..., 3) . v (3,) elementwise: numpy's matmul calls BLAS, whose threads then spin
    beside the OpenCL device's on the same cores (measured: every kernel of the frame after
    it ran up to 2x slower on 2 cores)."""
    return a[..., 0] * v[0] + a[..., 1] * v[1] + a[..., 2] * v[2]


def sample_grid(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel centres (column, row index arrays) of a regular sample of about SAMPLES."""
    step = max(1, int(np.ceil(np.sqrt(width * height / SAMPLES))))
    cols = np.arange(step // 2, width, step)
    rows = np.arange(step // 2, height, step)
    return np.meshgrid(cols, rows)


def rays(cols, rows, focal, focal_y, cx, cy, rot) -> np.ndarray:
    """Unit ray directions in world orientation (docs/conventions.md, Geometry), (..., 3)."""
    d = pixel_rays.directions(cols, rows, focal, focal_y, cx, cy)
    d = d / pixel_rays.length(d)[..., None]
    rot = np.asarray(rot, np.float64)
    return np.stack([_dot(d, rot[0]), _dot(d, rot[1]), _dot(d, rot[2])], -1)


def _fit(points):
    """Least-squares plane: the normal is the 3 x 3 scatter matrix's smallest eigenvector."""
    c = points.mean(0)
    x = points - c
    cov = np.array([[(x[:, a] * x[:, b]).sum() for b in range(3)] for a in range(3)])
    n = np.linalg.eigh(cov)[1][:, 0]
    return n, -float(_dot(c, n))


def _plane(P, dlen, cand, up):
    """RANSAC over planes through three of the candidates (below the camera), scored on
    SCORED samples with the tight tolerance, then least squares on the inliers of all,
    twice: (unit normal facing up, camera height) or None."""
    rng = np.random.default_rng(0)
    sub = rng.choice(P.shape[0], SCORED, replace=False) if P.shape[0] > SCORED else slice(None)
    Ps, ds = P[sub], dlen[sub]
    tri = P[cand[rng.integers(0, cand.size, (ITERATIONS, 3))]]          # (I, 3 points, xyz)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    ln = np.linalg.norm(n, axis=1)
    ok = ln > 1e-12
    n = n[ok] / ln[ok, None]
    n = np.where((_dot(n, up) < 0)[:, None], -n, n)
    h = -(n * tri[ok, 0]).sum(-1)
    ok = (np.arccos(np.clip(_dot(n, up), -1, 1)) <= MAX_TILT) & (h > 0)
    n, h = n[ok], h[ok]
    if not h.size:
        return None
    heights = Ps[:, 0:1] * n[:, 0] + Ps[:, 1:2] * n[:, 1] + Ps[:, 2:3] * n[:, 2] + h
    k = int(np.argmax((np.abs(heights) < fit_tolerance(h[None, :], ds[:, None])).sum(0)))
    n, h = n[k], float(h[k])
    for _ in range(2):
        inl = np.abs(_dot(P, n) + h) < fit_tolerance(h, dlen)
        if inl.sum() < 3:
            return None
        n2, h2 = _fit(P[inl])
        if _dot(n2, up) < 0:
            n2, h2 = -n2, -h2
        if h2 <= 0 or np.arccos(np.clip(_dot(n2, up), -1, 1)) > MAX_TILT:
            break
        n, h = n2, h2
    return n, h


def find(dist: np.ndarray, dirs: np.ndarray, colour: np.ndarray, max_depth: float, focal: float,
         extinction: float = 0.0, up=(0.0, 1.0, 0.0)) -> Ground | None:
    """dist: ray lengths of the samples (m; +inf or >= max_depth is sky), dirs their unit
    world directions, colour their RGB, focal the focal length (px), extinction the medium's
    (1/m, the mean over RGB).
    None when no plane below the camera holds MIN_GROUND of the valid samples and reaches
    MIN_REACH camera heights.

    The ground's colour is the mean over its samples weighted by the ground area each
    covers (d^2 / cos of its incidence) and by exp(-extinction d): the light the slab needs
    is the ground's near the camera, in the medium's reach, not the image's (a street's
    bright lane markings fill the bottom of the frame and little of the street)."""
    dist = np.asarray(dist, np.float64).ravel()
    dirs = np.asarray(dirs, np.float64).reshape(-1, 3)
    colour = np.asarray(colour, np.float64).reshape(-1, 3)
    up = np.asarray(up, np.float64) / np.linalg.norm(up)
    valid = np.isfinite(dist) & (dist > 0) & (dist < max_depth)
    if valid.sum() < 64:
        return None
    P = dist[valid, None] * dirs[valid]
    below = _dot(P, up) < 0
    cand = np.flatnonzero(below)
    if cand.size < 16:
        return None
    dlen = dist[valid]
    plane = _plane(P, dlen, cand, up)
    if plane is None:
        return None
    n, h = plane
    off, mu = np.abs(_dot(P, n) + h), _dot(dirs[valid], n)
    # ground pixels: near the plane and below the horizon (the sky just above a far horizon
    # is within the pixel term of the tolerance)
    inl = (off < plane_tolerance(h, dlen, focal)) & (mu < 0)
    # the share with the fit's tight tolerance: the pixel term of a small frame would let a
    # plane through random depths collect a tenth of them
    share = float(((off < fit_tolerance(h, dlen)) & (mu < 0)).mean())
    q = P[inl] - _dot(P[inl], n)[:, None] * n
    reach = np.sqrt((q * q).sum(1)).max() if inl.any() else 0.0
    if share < MIN_GROUND or reach < MIN_REACH * h:
        return None
    # the colour leaves out the rows within HORIZON_PX of the horizon: their area weight is
    # the largest, and a far surface standing there (a sky dome past the ground's end) is
    # within the tolerance's pixel term
    cos_in = -mu
    col = inl & (cos_in > HORIZON_PX / focal)
    if not col.any():
        col = inl
    dg = dlen[col]
    area = dg * dg / cos_in[col]
    wgt = area * np.exp(-extinction * (dg - dg.min()))      # relative to the nearest: no underflow
    ground_colour = (colour[valid][col] * wgt[:, None]).sum(0) / wgt.sum()
    # the sky: the farthest samples above the ground's horizon (clamped depth included)
    far = np.where(np.isfinite(dist), np.minimum(dist, max_depth), max_depth)
    sky_from = SKY_NEAR * np.percentile(far, SKY_FAR)
    sky = (far >= sky_from) & (_dot(dirs, n) > 0)
    dome = False
    if sky.mean() >= MIN_SKY:
        sky_colour, sky_distance = colour[sky].mean(0), float(np.median(far[sky]))
        dome = _is_dome(dist[sky], _dot(dirs[sky], n), max_depth)
    else:
        sky_colour, sky_distance, sky_from = np.zeros(3), float(max_depth), np.inf
    return Ground(tuple(map(float, n)), float(h), tuple(map(float, ground_colour)),
                  tuple(map(float, sky_colour)), max(sky_distance, 2.0 * float(h)), float(sky_from), share,
                  dome)


def _is_dome(dist, sin_elev, max_depth) -> bool:
    """Whether the sky's samples (their ray lengths and elevation sines) are a dome around the
    camera: nearly all at a finite distance short of max_depth (an infinite or clamped sky is
    the open sky above a medium, which the slab's plane is), at elevations whose sines span
    DOME_SPAN: all at one distance though some look up far more steeply than others."""
    finite = np.isfinite(dist) & (dist < max_depth)
    if finite.mean() < 0.9:
        return False
    s = sin_elev[finite]
    lo = max(float(np.percentile(s, 5)), 1e-3)
    return float(np.percentile(s, 95)) >= DOME_SPAN * lo
