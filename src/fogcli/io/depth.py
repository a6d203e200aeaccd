"""From a depth file's values to the metric depth the kernels take, at the image's size.

decode: the file's encoding to metres (depth_scale, the Cityscapes disparity PNG code,
disparity -> z = baseline * focal_px / disparity, relative inverse depth -> z by near/far).
Holes (NaN, <= 0, a zero code, zero disparity) become NaN; +inf stays (sky, clamped to
max_depth in the kernels).
prepare: resample a depth of another resolution (same aspect) and fill holes, both edge-aware
and guided by the colour image (OpenCV ximgproc domain-transform filter as an edge-aware
normalised convolution), so that a far value never lands on a near object across a colour
edge. (ximgproc's weighted median would suit depth better, but in opencv-contrib 5.0.0 it
returns different pixels on every call, with or without a mask or threads.)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fogcli.config.model import Camera
from fogcli.errors import UserError
from fogcli.physics.luminance import lamp_threshold, luminance


# Metric depths outside this range are not measurements: below, holes; above, sky (renderers
# write 1e10 or FLT_MAX where nothing was hit).
MIN_DEPTH, MAX_METRIC = 1e-6, 1e7


def scale_of(raw: np.ndarray, cam: Camera) -> float:
    """camera.depth_scale, `auto` resolved by the file's type: integer depth of 16 bits or
    more is millimetres (Kinect, RealSense, Azure Kinect, most RGB-D datasets), else metres."""
    if cam.depth_scale != "auto":
        return float(cam.depth_scale)
    dt = np.asarray(raw).dtype
    return 0.001 if np.issubdtype(dt, np.integer) and dt.itemsize >= 2 else 1.0


def decode(raw: np.ndarray, cam: Camera, source: str, width: int) -> np.ndarray:
    """Metric depth (z for z/disparity/inverse, ray length for distance); NaN = no value."""
    raw = np.asarray(raw)
    # float32 holds every value of a half, float32 or 8/16-bit file exactly; wider types are
    # decoded in float64 so that their extremes land on the same side of the limits
    narrow = raw.dtype in (np.float16, np.float32) or (np.issubdtype(raw.dtype, np.integer) and raw.dtype.itemsize <= 2)
    v = np.array(raw, np.float32 if narrow else np.float64)     # a copy: the passes below are in place
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if cam.encoding == "cityscapes":           # (p - 1) / 256, p = 0: no measurement
            v = np.where(v > 0, (v - 1.0) / 256.0, np.nan)
        else:
            scale = scale_of(raw, cam)
            if scale != 1.0:
                v *= scale
        if cam.depth == "disparity":
            v = np.where(v > 0, cam.baseline * cam.focal(width) / v, np.nan)
        elif cam.depth == "inverse":
            ok = np.isfinite(v)
            if not ok.any():
                raise UserError(f"{source}: inverse depth has no finite value")
            lo, hi = float(v[ok].min()), float(v[ok].max())
            if not hi - lo > 1e-30 * max(abs(hi), 1e-30):
                raise UserError(f"{source}: inverse depth is constant ({lo:g}): no relative depth to map to near..far")
            t = (v - lo) / (hi - lo)
            v = 1.0 / (1.0 / cam.far + t * (1.0 / cam.near - 1.0 / cam.far))
        v = v.astype(np.float32, copy=False)
        v[~(v >= MIN_DEPTH)] = np.nan             # zero, negative, -inf, tiny, NaN: holes
        v[v > MAX_METRIC] = np.inf                # beyond 1e7 m: sky
    return v


def notes(raw: np.ndarray, cam: Camera, metric: np.ndarray, source: str) -> list[str]:
    """Warnings about a depth that decodes to an implausible scene, with the fix."""
    out = []
    raw = np.asarray(raw)
    if cam.depth_scale == "auto" and cam.encoding == "linear" and scale_of(raw, cam) != 1.0 \
            and cam.depth in ("z", "distance"):
        out.append(f"{source}: {raw.dtype} depth read as millimetres (camera.depth_scale: auto); "
                   "set camera.depth_scale if the unit differs (TUM RGB-D: 0.0002)")
    if cam.encoding != "linear" or cam.depth not in ("z", "distance"):
        return out
    sample = metric.ravel()[::max(1, metric.size // 250_000)]   # a median for a warning: 1/8 of 2 MPx will do
    ok = sample[np.isfinite(sample)]
    if ok.size:
        med = float(np.median(ok))
        # whole numbers in the thousands: millimetre codes stored as they came from a sensor
        vals = np.asarray(raw, np.float64)[np.isfinite(metric)] if med > 0.5 * cam.max_depth else None
        if vals is not None and np.array_equal(vals, np.round(vals)) and len(np.unique(vals[:4096])) >= 16:
            out.append(f"{source}: median depth {med:.4g} m (whole numbers, beyond half of camera.max_depth "
                       f"{cam.max_depth:g} m) looks like millimetres: set camera.depth_scale=0.001")
    return out


# The domain transform's colour sigma, guide in [0, 1]. Chosen on three synthetic scenes
# (a noisy near object over a far background, its holes, and a Kinect-like room with a
# sloping floor, sensor shadows and speckle; tools/real_inputs.py): wrong-by-10 %
# hole pixels in the room 2300 / 1637 / 2495 / 3879 at 0.2 / 0.3 / 0.5 / 0.7 (nearest-pixel
# fill: 3961); 0.2 also leaves object pixels wrong, 1.0 leaks across the silhouette.
SIGMA_COLOUR = 0.3
# Variance of log depth in a fill's support above which it holds two surfaces (a 10 % step
# split evenly gives 0.0023): then the heavier side fills, not the average (tools/holefill.py).
MIXED_LOG_VAR = 0.002


@dataclass
class DepthReport:
    holes: int = 0            # pixels without a measurement, filled
    resampled_from: tuple | None = None
    notes: list | None = None  # warnings about the decoded scale (depth.notes)


def _guide(rgb: np.ndarray) -> np.ndarray:
    """Colour in [0, 1] for the edge-aware filter: HDR scaled by its 99th percentile, then a
    display-like curve so that dark regions keep their edges. rgb: any float type (a half
    EXR's columns as read), taken in float32."""
    rgb = np.asarray(rgb, np.float32)
    scale = float(np.percentile(rgb[::4, ::4], 99)) or 1.0   # a 1/16 sample is plenty
    return np.ascontiguousarray(np.clip(rgb / scale, 0, 1) ** (1 / 2.2), dtype=np.float32)


def _nearest_fill(d: np.ndarray, valid: np.ndarray) -> np.ndarray:
    import cv2

    # distance transform with labels: each hole pixel learns its nearest valid pixel
    _, labels = cv2.distanceTransformWithLabels((~valid).astype(np.uint8), cv2.DIST_L2, 5,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    vy, vx = np.nonzero(valid)
    lut = np.empty(len(vy) + 1, dtype=np.float32)   # labels of valid pixels: raster order from 1
    lut[0] = 0.0
    lut[1:] = d[vy, vx]
    out = d.copy()
    out[~valid] = lut[labels[~valid]]
    return out


def _log_depth(d: np.ndarray) -> tuple[np.ndarray, float]:
    """log depth, sky (+inf) carried as 4x the farthest finite depth, NaN kept; and the
    log value above which an estimate is sky again."""
    finite = d[np.isfinite(d)]
    far = float(finite.max()) if finite.size else 1.0      # all sky and holes: any scale will do
    logd = np.log(np.where(np.isposinf(d), far * 4.0, np.maximum(d, 1e-6)))
    return logd.astype(np.float32), float(np.log(far * 2.0))


def _edge_aware(logd: np.ndarray, confident: np.ndarray, guide: np.ndarray, sigma_max: float,
                split: bool = True) -> np.ndarray:
    """Edge-aware normalised convolution of log depth: the average of the confident values
    weighted by a domain-transform filter of the colour guide (Gastal & Oliveira 2011;
    OpenCV ximgproc dtFilter). The filter's support stops at colour edges, so a hole or an
    unreliable pixel on a near object is filled from that object, not from the background
    beside it. Scales grow from 3 px, doubling: a pixel is filled at the smallest scale
    where a quarter of its support is known, so a sloping floor is filled from its nearest
    rows, not averaged over metres; filled pixels then count (at half weight) for the next
    scale. Returns log depth: confident pixels as given, the others estimated, NaN where
    nothing reached."""
    import cv2

    w = confident.astype(np.float32)
    known = np.where(confident, logd, 0.0).astype(np.float32)
    out = np.where(confident, logd, np.nan).astype(np.float32)
    done = confident.copy()
    s = 3.0
    h, wd = logd.shape
    while not done.all():
        # only the box around what is left, with a margin where the filter's weight has
        # fallen to e^-4: numerator and denominator as the two channels of one call
        ys, xs = np.nonzero(~done)
        m = int(4 * s) + 1
        y0, y1 = max(int(ys.min()) - m, 0), min(int(ys.max()) + m + 1, h)
        x0, x1 = max(int(xs.min()) - m, 0), min(int(xs.max()) + m + 1, wd)
        box = (slice(y0, y1), slice(x0, x1))
        kx, wx = known[box], w[box]
        # the guide's domain transform once per scale, for both filterings below
        dtf = cv2.ximgproc.createDTFilter(np.ascontiguousarray(guide[box]), s, SIGMA_COLOUR,
                                          mode=cv2.ximgproc.DTF_NC, numIters=3)
        nd = dtf.filter(np.ascontiguousarray(np.dstack([kx * wx, wx, kx * kx * wx])))
        num, den = nd[:, :, 0], nd[:, :, 1]
        last = s >= sigma_max
        take = ~done[box] & (den > (1e-3 if last else 0.25))
        ob, kb, wb, db = out[box], known[box], w[box], done[box]   # views into the arrays
        with np.errstate(divide="ignore", invalid="ignore"):
            mean = num / den
            spread = nd[:, :, 2] / den - mean * mean
        # Two surfaces in one colour region (depth misaligned with colour, a sliver of the
        # object's depth on the wall beside it): their average is a depth neither has, a
        # blob. Split the known values at the local mean and take the side that carries
        # more weight: the region's own surface.
        mixed = take & (spread > MIXED_LOG_VAR) & split
        if mixed.any():
            far = (kx >= np.nan_to_num(mean, nan=np.inf)).astype(np.float32) * wx
            near = wx - far
            nd2 = dtf.filter(np.ascontiguousarray(np.dstack([kx * far, far, kx * near, near])))
            pick_far = nd2[:, :, 1] >= nd2[:, :, 3]
            with np.errstate(divide="ignore", invalid="ignore"):
                side = np.where(pick_far, nd2[:, :, 0] / nd2[:, :, 1], nd2[:, :, 2] / nd2[:, :, 3])
            mean = np.where(mixed & np.isfinite(side), side, mean)
        ob[take] = mean[take]
        kb[take], wb[take] = ob[take], 0.5
        db |= take
        if last:
            break
        s = min(2 * s, sigma_max)
    return out


def prepare(metric: np.ndarray, rgb: np.ndarray, source: str, split: bool = True,
            lamps: bool = True) -> tuple[np.ndarray, DepthReport]:
    """Metric depth at the image's size with every hole filled (split: False averages two
    surfaces in one colour region as before; lamps: False leaves lamp cores to that fill;
    both for tools/holefill.py)."""
    h, w = rgb.shape[:2]
    d = np.asarray(metric, np.float32)
    rep = DepthReport()
    dh, dw = d.shape
    if (dh, dw) != (h, w):
        if abs(dw / dh - w / h) > 0.01 * (w / h):
            raise UserError(f"{source}: depth is {dw}x{dh}, the image is {w}x{h}; they must match "
                            "or have the same aspect ratio")
        rep.resampled_from = (dw, dh)
    valid = ~np.isnan(d)
    rep.holes = int(d.size - np.count_nonzero(valid))
    if rep.holes == d.size:
        raise UserError(f"{source}: depth has no valid pixel (all NaN, zero or negative)")
    if rep.holes == 0 and rep.resampled_from is None:
        return d, rep
    import cv2   # only for holes and resampling: 0.14 s of start-up a complete depth map does not pay

    if rep.resampled_from is None:
        confident = valid      # holes stay NaN: not confident, filled by the filter below
        logd, sky = _log_depth(d)
        sigma = 8.0
    else:
        # low-res samples whose 3x3 neighbourhood spans an edge are mixtures (sensors
        # average, and so would bilinear upsampling): they are refilled from the flat ones
        low, sky = _log_depth(_nearest_fill(d, valid) if rep.holes else d)
        k = np.ones((3, 3), np.uint8)
        flat = ((cv2.dilate(low, k) - cv2.erode(low, k)) < 0.05) & valid
        confident = cv2.resize(flat.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST) > 0
        logd = cv2.resize(low, (w, h), interpolation=cv2.INTER_LINEAR)
        sigma = max(8.0, 3.0 * max(w / dw, h / dh))
    if rep.holes:
        inside = cv2.distanceTransform((~valid).astype(np.uint8), cv2.DIST_L2, 3)
        sigma = max(sigma, 2.0 * float(inside.max()) * max(w / dw, h / dh))
    est = _edge_aware(logd, confident, _guide(rgb), min(sigma, 200.0), split)
    out = np.exp(est)
    out[est > sky] = np.inf
    if rep.resampled_from is None:
        out[valid] = d[valid]  # measured values kept as measured
    left = np.isnan(out)
    if left.any():             # beyond the filter's reach: the nearest value
        out = _nearest_fill(out, ~left)
    if rep.resampled_from is None and lamps:
        _lamps_in_holes(out, d, valid, rgb)
    return out.astype(np.float32), rep


LAMP_SHARE = 0.005      # a bright region larger than this share of the frame is not a lamp


def _lamps_in_holes(out: np.ndarray, d: np.ndarray, valid: np.ndarray, rgb: np.ndarray) -> None:
    """A lamp's core without depth (a sensor blinded by it, a hole over it) takes its own
    measured part's depth, or else the near side of its hole's border (the 10th percentile):
    a lamp stands in front of what surrounds it. Filled from the sky or a far wall beyond it,
    it lost its glow (issue 41: a 200 x 100 hole over the sample's lamp, relative L1 to the
    unholed output 0.48 -> 0.0001; tools/holefill.py --lamps). The core and a 2 px rim."""
    import cv2

    y = luminance(np.asarray(rgb, np.float32))
    cores = y > lamp_threshold(y)
    if not (cores & ~valid).any():
        return
    n, lab, st, _ = cv2.connectedComponentsWithStats(cores.astype(np.uint8), connectivity=8)
    _, hlab, hst, _ = cv2.connectedComponentsWithStats((~valid).astype(np.uint8), connectivity=8)
    h, w = d.shape
    near: dict = {}

    def window(stats, m):
        x, y, bw, bh = stats[:4]
        return slice(max(y - m, 0), min(y + bh + m, h)), slice(max(x - m, 0), min(x + bw + m, w))

    def near_side(j):           # the 10th percentile of hole j's border, once per hole
        if j not in near:
            box = window(hst[j], 4)
            hole = (hlab[box] == j).astype(np.uint8)
            ring = (cv2.dilate(hole, np.ones((7, 7), np.uint8)) > 0) & valid[box] & np.isfinite(d[box])
            near[j] = float(np.quantile(d[box][ring], 0.1)) if ring.any() else None
        return near[j]

    # the lamps with a depth say how large the frame's lamps are: depth x sqrt(pixels) (a
    # street's lamps are alike; a lamp at twice the distance covers a quarter of the pixels)
    todo, sizes = [], []
    largest = LAMP_SHARE * d.size
    for k in range(1, n):
        if st[k, 4] > largest:      # a clipped sky or a lit wall, not a lamp
            continue
        box = window(st[k], 2)
        core = lab[box] == k
        hole = ~valid[box]
        own = core & ~hole & np.isfinite(d[box])
        if not (core & hole).any():
            if own.sum() >= 3:
                sizes.append(float(np.median(d[box][own])) * math.sqrt(st[k, 4]))
        elif own.sum() >= 3:
            todo.append((box, core, hole, float(np.median(d[box][own]))))
        else:
            todo.append((box, core, hole, None))
    size = float(np.median(sizes)) if sizes else None
    for box, core, hole, depth in todo:
        if depth is None:
            sides = [near_side(j) for j in np.unique(hlab[box][core & hole])]
            sides = [v for v in sides if v is not None]
            if not sides:
                continue
            # the size of the frame's other lamps; without them the near side of the hole's border
            depth = size / math.sqrt(core.sum()) if size else min(sides)
        rim = (cv2.dilate(core.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0) & hole
        out[box][rim] = depth


def metric_depth(raw: np.ndarray, rgb: np.ndarray, cam: Camera, source: str,
                 alpha: np.ndarray | None = None) -> tuple[np.ndarray, DepthReport]:
    """A depth file's values to the metric depth the kernels take, at the image's size:
    intrinsics scaled to the image (calibrated_size), decoded, holes filled, resampled.
    Pixels with alpha 0 are empty, not holes: they look at camera.empty_depth."""
    h, w = rgb.shape[:2]
    metric = decode(raw, cam.for_size(w, h), source, w)
    found = notes(raw, cam, metric, source)
    if alpha is not None and metric.shape == alpha.shape:
        metric[alpha <= 0.0] = cam.empty_depth
    out, rep = prepare(metric, rgb, source)
    rep.notes = found
    return out, rep
