"""Lamps of the image found on the host (`lights: [{type: auto}]`): bright cores with a
depth become point lights of the config, and their pixels a map of which lamp each is, so
that a lamp's scattered light is shared between the light model and its pixels
(frame.scene.share_lamps)."""
from __future__ import annotations

import math

import numpy as np

from fogcli.config.model import Config
from fogcli.physics import pixel_rays
from fogcli.physics.luminance import lamp_threshold, luminance


def detect_lamps(rgb: np.ndarray, depth: np.ndarray, cfg: Config, spec) -> tuple[list, np.ndarray, list[str]]:
    """Lamps of the image as point lights (camera frame): cores brighter than the threshold
    with a depth; distance = the core's median ray length (a 2 px ring around it where the
    core has no depth); direction = its luminance-weighted centroid; intensity = t^2 sum L
    Omega_px over the core dilated 2 px (Omega_px = cos^3 / (f fy)); radius = t sqrt(n / pi) / f;
    placed at t + radius, just behind the visible surface, so that it does not sit inside its
    own pixels. A core spanning depths more than 20 % apart is split into lamps by depth (a near
    lamp in front of a far one). Returns (lights, the lamps' pixels as int32 labels: 0 none,
    k the k-th light, notes)."""
    import cv2

    from fogcli.config.model import PointLight

    h, w = depth.shape
    cam = cfg.camera.for_size(w, h)
    f, fy = cam.focal(w), cam.focal_y(w)
    cx, cy = cam.centre(w, h)
    y = luminance(rgb)
    hdr = float(y.max()) > 1.5
    thr = spec.threshold if spec.threshold != "auto" else lamp_threshold(y)
    n, labels, stats, _ = cv2.connectedComponentsWithStats((y > thr).astype(np.uint8), connectivity=8)
    jj, ii = np.mgrid[0:h, 0:w]
    dlen = pixel_rays.length(pixel_rays.directions(ii, jj, f, fy, cx, cy))
    ray = depth * (dlen if cam.depth == "z" else 1.0)
    lights, notes = [], []
    mask = np.zeros((h, w), np.int32)
    kernel = np.ones((5, 5), np.uint8)
    cores = []
    for k in range(1, n):
        if stats[k, cv2.CC_STAT_AREA] >= spec.min_pixels:
            cores += _split_by_depth(labels == k, ray, cam.max_depth, spec.min_pixels)
    claimed = np.logical_or.reduce(cores) if cores else np.zeros((h, w), bool)    # every core is its own
    cores = sorted(cores, key=lambda c: _core_depth(c, ray, cam.max_depth))         # nearest first
    omega = (1.0 / dlen) ** 3 / (f * fy)          # each pixel's solid angle
    own, lent = _unmix(rgb, cores, omega)
    for core, extra in zip(cores, lent):
        t = core_ray_lengths(core, ray, cam.max_depth)
        if t.size == 0:
            notes.append(f"a lamp at pixel ({int(ii[core].mean())}, {int(jj[core].mean())}) has no depth; left out")
            continue
        dist = float(np.median(t))
        wgt = y[core]
        px, py = float((ii[core] * wgt).sum() / wgt.sum()) + 0.5, float((jj[core] * wgt).sum() / wgt.sum()) + 0.5
        d = pixel_rays.directions(px - 0.5, py - 0.5, f, fy, cx, cy)
        d /= pixel_rays.length(d)
        # the core and a 2 px ring; a ring pixel two lamps share goes to the nearer one
        blob = ((cv2.dilate(core.astype(np.uint8), kernel) > 0) & ~claimed) | core
        claimed |= blob
        intensity = dist * dist * ((own[blob] * omega[blob][:, None]).sum(0) + extra)
        radius = max(dist * math.sqrt(core.sum() / math.pi) / f, 1e-3)
        pos = (dist + radius) * d
        lights.append(PointLight(type="point", position=tuple(pos), intensity=tuple(float(v) for v in intensity),
                                 radius=radius, frame="camera"))
        mask[blob] = len(lights)
        if not hdr and float(rgb[core].max()) >= 0.98:
            notes.append(f"lamp at {dist:.3g} m is clipped in this display-referred image: its intensity "
                         f"({float(intensity.mean()):.3g}) is a lower bound")
    return lights, mask, notes


def core_ray_lengths(core: np.ndarray, ray: np.ndarray, max_depth: float) -> np.ndarray:
    """The ray lengths of a lamp's core (a mask over `ray`), or where the core has none (a
    sensor blinded by the lamp) those of a 2 px ring around it; empty when neither has one."""
    import cv2

    valid = np.isfinite(ray) & (ray > 0) & (ray < max_depth)
    ok = core & valid
    if not ok.any():        # the ring only then: in detect_lamps it is a dilation of the whole frame
        ok = (cv2.dilate(core.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0) & ~core & valid
    return ray[ok]


def _unmix(rgb: np.ndarray, cores: list, omega: np.ndarray) -> tuple[np.ndarray, list]:
    """A lamp in front of another: where their cores meet, pixels are mixtures (the near lamp's
    anti-aliased edge over the far lamp) and carry one core's depth. Each pixel of a core next
    to another is split along the line between the two lamps' own colours (the median of
    their pixels away from other cores): (the radiance each pixel keeps for its own lamp, per
    core the radiance x solid angle it gets from the other cores' pixels)."""
    import cv2

    own = rgb.astype(np.float64).copy()
    lent = [np.zeros(3) for _ in cores]
    if len(cores) < 2:
        return own, lent
    near = [cv2.dilate(c.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0 for c in cores]
    pure = []
    for i, c in enumerate(cores):
        inner = c & ~np.logical_or.reduce([near[k] for k in range(len(cores)) if k != i])
        pure.append(np.median(rgb[inner if inner.any() else c], axis=0).astype(np.float64))
    for j, c in enumerate(cores):           # core j's pixels next to core i hold some of lamp i
        for i in range(len(cores)):
            edge = c & near[i]
            ab = pure[i] - pure[j]
            if i == j or not edge.any() or ab @ ab <= 0:
                continue
            alpha = np.clip(((rgb[edge] - pure[j]) @ ab) / (ab @ ab), 0.0, 1.0)
            part = np.minimum(alpha[:, None] * pure[i], own[edge])
            own[edge] -= part
            lent[i] += (part * omega[edge][:, None]).sum(0)
    return own, lent


def _core_depth(core: np.ndarray, ray: np.ndarray, max_depth: float) -> float:
    t = ray[core & np.isfinite(ray) & (ray < max_depth)]
    return float(np.median(t)) if t.size else math.inf


def _split_by_depth(core: np.ndarray, ray: np.ndarray, max_depth: float, min_pixels: int) -> list[np.ndarray]:
    """A bright core whose pixels lie at depths more than 20 % apart is several lamps, one
    in front of the other along nearly the same direction: split at each such gap (sorted
    ray lengths) into groups that have an inside. The other pixels (without depth, or an edge
    ring at the background's depth) join the group they touch, the nearer one first."""
    ok = core & np.isfinite(ray) & (ray < max_depth)
    t = np.sort(ray[ok])
    if t.size < 2 or t[-1] <= 1.2 * t[0]:
        return [core]
    cuts = t[1:][t[1:] > 1.2 * t[:-1]]
    edges = np.concatenate([[0.0], cuts, [np.inf]])
    groups = [ok & (ray >= a) & (ray < b) for a, b in zip(edges[:-1], edges[1:])]
    # a lamp of its own has an inside; the anti-aliased edge of a lamp, whose pixels carry the
    # background's depth, is a thin ring without one
    import cv2

    cross = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], np.uint8)
    groups = [g for g in groups if g.sum() >= min_pixels and cv2.erode(g.astype(np.uint8), cross).any()] or [core]
    rest = core & ~np.logical_or.reduce(groups)
    ring = np.ones((3, 3), np.uint8)
    while rest.any():       # the rest goes to the group it touches, the nearer one first
        before = rest.sum()
        for i, g in enumerate(groups):
            grow = (cv2.dilate(g.astype(np.uint8), ring) > 0) & rest
            groups[i] = g | grow
            rest &= ~grow
        if rest.sum() == before:        # not connected to any group (cannot happen in one core)
            groups[0] = groups[0] | rest
            break
    return groups


LAMP_ACROSS_M = 1.0     # a clipped core at most this wide at its depth is a lamp (a bulb, a lantern, a headlight)
STREAK = 2.0            # a core whose box is this many times longer than wide is a streak: a lamp's reflection


def recover(rgb: np.ndarray, depth: np.ndarray, cfg: Config) -> np.ndarray:
    """A display-referred frame's clipped highlights as the light the config says they stand
    for: camera.highlight_gain times white on a lamp (lamp_pixels), highlight_area_gain on
    every other clipped region; a lamp's core that clipped to white in every channel takes
    the colour of camera.highlight_kelvin. Sky, lit windows, white walls and a lamp's
    reflection on water also clip but are a few times white, where lamps are hundreds: one
    gain for both made the sample's fog 0.75 from its HDR original at best (relative L1; 0.89
    with none), lamps apart 0.40 (tools/clipped_highlights.py)."""
    from fogcli.io.colour import CLIPPED, kelvin_rgb, recover_highlights

    cam = cfg.camera
    if cam.highlight_kelvin is None and cam.highlight_gain == cam.highlight_area_gain:
        return recover_highlights(rgb, float(cam.highlight_gain))     # no lamp is told apart
    lamps = lamp_pixels(rgb, depth, cfg)
    gains = np.where(lamps, np.float32(cam.highlight_gain), np.float32(cam.highlight_area_gain))
    if cam.highlight_kelvin is not None:
        white = lamps & (np.asarray(rgb).min(axis=-1) >= CLIPPED)
        if white.any():
            rgb = np.array(rgb, np.float32)
            rgb[white] = kelvin_rgb(cam.highlight_kelvin)
    return recover_highlights(rgb, gains)


def lamp_pixels(rgb: np.ndarray, depth: np.ndarray, cfg: Config) -> np.ndarray:
    """The lamps of a display-referred frame where it clipped, and a 2 px rim: compact clipped
    regions (a box at most STREAK times longer than wide) at most LAMP_ACROSS_M across at
    their depth, or, without a depth, at most LAMP_SHARE of the frame."""
    import cv2

    from fogcli.io.colour import CLIPPED
    from fogcli.io.depth import LAMP_SHARE

    clipped = np.asarray(rgb).max(axis=-1) >= CLIPPED
    if not clipped.any():
        return clipped
    h, w = depth.shape
    cam = cfg.camera.for_size(w, h)
    f, fy = cam.focal(w), cam.focal_y(w)
    cx, cy = cam.centre(w, h)
    n, lab, st, _ = cv2.connectedComponentsWithStats(clipped.astype(np.uint8), connectivity=8)
    is_lamp = np.zeros(n, bool)
    for k in range(1, n):
        x, y, bw, bh, px = (int(v) for v in st[k])
        if max(bw, bh) > STREAK * min(bw, bh):
            continue
        box = (slice(max(y - 2, 0), min(y + bh + 2, h)), slice(max(x - 2, 0), min(x + bw + 2, w)))
        ray = depth[box]
        if cam.depth == "z":
            jj, ii = np.mgrid[box]
            ray = ray * pixel_rays.length(pixel_rays.directions(ii, jj, f, fy, cx, cy))
        t = core_ray_lengths(lab[box] == k, ray, cam.max_depth)
        if t.size == 0:
            is_lamp[k] = px <= LAMP_SHARE * h * w
            continue
        is_lamp[k] = 2.0 * float(np.median(t)) * math.sqrt(px / math.pi) / f <= LAMP_ACROSS_M
    return cv2.dilate(is_lamp[lab].astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
