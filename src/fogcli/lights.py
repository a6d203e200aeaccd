"""Lights in the medium on the host: the structs of kernels/lights.cl (lights placed in the
world, the medium with its density primitives, the Gauss-Legendre nodes) and a float64
numpy reference of the single-scattered airlight that the kernel is tested against."""
from __future__ import annotations

import math
from functools import lru_cache
from importlib import resources

import numpy as np

from .config import Config
from .structs import LIGHT_T, LIGHT_TYPES, LMEDIUM_T, PRIM_TYPES



def rotation(cfg: Config) -> np.ndarray:
    from .pipeline import rotation as rot

    c = cfg.camera
    return rot(c.yaw, c.pitch, c.roll)


def placed(cfg: Config, light) -> tuple[np.ndarray, np.ndarray]:
    """(world position, world unit axis) of a light: camera-frame values are turned by the
    camera's rotation and moved to its position (docs/conventions.md, Geometry)."""
    R = rotation(cfg)
    cam = np.array(cfg.camera.position, np.float64)
    pos = np.array(getattr(light, "position", (0.0, 0.0, 0.0)), np.float64)
    axis = np.array(getattr(light, "direction", (0.0, 0.0, -1.0)), np.float64)
    axis = axis / np.linalg.norm(axis)
    if light.frame == "camera":
        pos, axis = cam + R @ pos, R @ axis
    return pos, axis


def light_struct(cfg: Config, light) -> np.ndarray:
    s = np.zeros((), LIGHT_T)
    pos, axis = placed(cfg, light)
    s["pos"], s["axis"] = [*pos, 0.0], [*axis, 0.0]
    s["intensity"] = [*(light.irradiance if light.type == "directional" else light.intensity), 0.0]
    s["radius"] = getattr(light, "radius", 0.0)
    if light.type == "spot":
        s["cos_outer"] = math.cos(math.radians(light.angle))
        s["cos_inner"] = math.cos(math.radians(light.angle * (1.0 - light.blend)))
        if s["cos_inner"] <= s["cos_outer"]:            # blend 0: a hard edge, smoothstep needs a step
            s["cos_inner"] = np.nextafter(s["cos_outer"], np.float32(2.0))
    s["type"] = LIGHT_TYPES[light.type]
    s["gain"] = [*gain(cfg, light), 1.0]
    return s


@lru_cache(maxsize=1)
def _gain_table() -> dict:
    """The point-spread table's energy (all orders) and, on the same grid, the energy of
    single scattering as the light model carries it (benchmarks/make_light_gain.py), both
    over the thin-medium form."""
    from .apsf import load_table

    tab = load_table()
    with resources.files("fogcli").joinpath("data/light_gain.npz").open("rb") as f:
        z = np.load(f)
        carried = np.asarray(z["carried_ratio"], np.float64)
        assert np.array_equal(z["tau"], tab["tau"]) and np.array_equal(z["albedo"], tab["albedo"])
    ok = (carried > 0) & (tab["ratio"] > 0)
    return {"g": tab["g"], "albedo": tab["albedo"], "tau": tab["tau"],
            "ratio": np.where(ok, tab["ratio"] / np.where(ok, carried, 1.0), 1.0)}


def gain(cfg: Config, light) -> np.ndarray:
    """Per RGB: the energy of all orders of scattering around a point source at the light's
    optical distance from the camera over what the light model carries (single scattering,
    light leg in extinction, camera leg in absorption). A light's airlight is exact single
    scattering; the light it would get from scattering on its way to the medium (forward in
    fog: x1.1 at 1 scattering length, x1.4 at 3) is added to its scattered part, which the
    point spread spreads. 1 for directional lights (no distance) and where the medium does
    not scatter."""
    if light.type == "directional":
        return np.ones(3)
    from .apsf import _slice_ga, log_along_tau

    m = cfg.medium
    pos, _ = placed(cfg, light)
    cam = np.array(cfg.camera.position, np.float64)
    dist = float(np.linalg.norm(pos - cam))
    P = float(_tau(cam[None], ((pos - cam) / max(dist, 1e-12))[None], np.array([dist]), cfg)[0]) if dist > 0 else 0.0
    tab = _gain_table()
    out = np.ones(3)
    for c, (sa, ss) in enumerate(zip(m.absorption, m.scattering)):
        if ss > 0 and P > 0:
            ratio = _slice_ga(tab, "ratio", m.asymmetry, ss / (sa + ss))
            out[c] = float(log_along_tau(tab, ratio, np.array([ss * P]))[0])
    # all orders carry at least what single scattering does; below 1 is the table's noise
    return np.maximum(out, 1.0)


DENSE_PX = 64.0      # the epipolar samples' dense zone around the light's image, at most (pixels)


def epipolar_layout(cfg: Config, light, width: int, height: int, slices: int, step: int) -> tuple:
    """The samples of render.lights.method: epipolar (kernels/shadows.cl): (ex, ey) the light's
    image (its antipode for a light behind the camera; 1e4 pixels out along the epipolar lines
    when they are nearly parallel), the slices' angles a0 + k da, k < ns, the samples' radii
    (r0 + m h1 below rb, rb + (m - m1) h2 beyond; m < nm), whether the slices go all round
    (the image holds e) and whether e is the light's own image (in front of the camera)."""
    cam = cfg.camera.for_size(width, height)
    f, fy = cam.focal(width), cam.focal_y(width)
    cx, cy = cam.centre(width, height)
    pos, axis = placed(cfg, light)
    v = np.asarray(axis if light.type == "directional" else np.asarray(pos) - np.asarray(cfg.camera.position), float)
    x, y, z = rotation(cfg).T @ v
    g = np.array([f * x, -fy * y])          # the lines' direction where they are parallel
    far = 1e4
    if abs(z) * far > np.hypot(*g):
        e = np.array([cx + f * x / -z, cy - fy * y / -z])
    else:
        e = np.array([cx, cy]) - far * g / max(np.hypot(*g), 1e-30)
    corners = np.array([[0, 0], [width, 0], [0, height], [width, height]], float) - e
    r_max = float(np.hypot(corners[:, 0], corners[:, 1]).max())
    inside = 0 <= e[0] <= width and 0 <= e[1] <= height
    if inside:
        a0, span, r0, full = -math.pi, 2 * math.pi, 0.0, True
    else:
        mid = math.atan2(cy - e[1], cx - e[0])
        d = (np.arctan2(corners[:, 1], corners[:, 0]) - mid + math.pi) % (2 * math.pi) - math.pi
        a0, span, full = mid + float(d.min()), float(d.max() - d.min()), False
        r0 = float(np.hypot(max(0 - e[0], 0, e[0] - width), max(0 - e[1], 0, e[1] - height)))
    # at most two slices per border pixel, and `step` at most 1/16 of the longer side: small
    # images keep their accuracy (64 x 48 at step 16: up to 10 % from the march) and do not
    # get more samples than pixels
    ns = int(min(slices, 2 * (width + height)))
    step = max(2, min(step, round(max(width, height) / 16)))
    da = span / ns if full else span / max(ns - 1, 1)
    # four times as dense near the light's image, where the shares change fastest: within 15 %
    # of the image's longer side (Intel's sample: 0.3 NDC) and at most DENSE_PX (at 1920 x 1080
    # the error against the march is 0.23 % with 64 or 128 px, 0.20 % with 288 px, 1.6 % with
    # none; 64 px instead of 288 saves a third of the samples; small images need their 15 %:
    # at 256 x 192, 38 px, 0.95 %, and 13 px, 2.0 %)
    h1 = step / 4.0
    m1 = int(math.ceil(max(min(0.15 * max(width, height), DENSE_PX) - r0, 0.0) / h1))
    rb = r0 + m1 * h1
    nm = m1 + int(math.ceil(max(r_max - rb, 0.0) / step)) + 2
    front = bool(z < 0 and abs(z) * far > np.hypot(*g))      # e is the light's own image
    return float(e[0]), float(e[1]), a0, da, r0, rb, h1, float(step), m1, nm, ns, full, front


def medium_struct(cfg: Config) -> tuple[np.ndarray, np.ndarray]:
    """(lmedium_t, prims float4 array): the non-homogeneous primitives as 3 float4 each."""
    m = cfg.medium
    s = np.zeros((), LMEDIUM_T)
    s["sa"], s["ss"] = [*m.absorption, 0.0], [*m.scattering, 0.0]
    s["g"] = m.asymmetry
    s["homogeneous"] = m.homogeneous
    s["nodes"] = cfg.render.lights.nodes
    prims = []
    for d in m.density:
        if d.type == "exponential":
            n = np.array(d.direction, np.float64)
            prims += [[float(PRIM_TYPES["exponential"]), d.factor, d.falloff, 0.0], [*(n / np.linalg.norm(n)), 0.0], [*d.offset, 0.0]]
        elif d.type == "sphere":
            prims += [[float(PRIM_TYPES["sphere"]), d.factor, d.radius, 0.0], [*d.center, 0.0], [0.0] * 4]
    s["nprims"] = len(prims) // 3
    return s, np.array(prims or [[0.0] * 4] * 3, np.float32)


def gauss_legendre(n: int) -> np.ndarray:
    x, w = np.polynomial.legendre.leggauss(n)
    return np.ascontiguousarray(np.stack([x, w], axis=1), np.float32)


# ----------------------------------------------------------------------------- lamps in the image

def detect_lamps(rgb: np.ndarray, depth: np.ndarray, cfg: Config, spec) -> tuple[list, np.ndarray, list[str]]:
    """Lamps of the image as point lights (camera frame): cores brighter than the threshold
    with a depth; distance = the core's median ray length (a 2 px ring around it where the
    core has no depth); direction = its luminance-weighted centroid; intensity = t^2 sum L
    Omega_px over the core dilated 2 px (Omega_px = cos^3 / (f fy)); radius = t sqrt(n / pi) / f;
    placed at t + radius, just behind the visible surface, so that it does not sit inside its
    own pixels. A core spanning depths more than 20 % apart is split into lamps by depth (a near
    lamp in front of a far one). Returns (lights, mask of the lamps' pixels, notes)."""
    import cv2

    from .config import PointLight

    h, w = depth.shape
    cam = cfg.camera.for_size(w, h)
    f, fy = cam.focal(w), cam.focal_y(w)
    cx, cy = cam.centre(w, h)
    y = rgb @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    hdr = float(y.max()) > 1.5
    thr = spec.threshold if spec.threshold != "auto" else (10.0 * float(np.percentile(y, 99)) if hdr else 0.98)
    n, labels, stats, _ = cv2.connectedComponentsWithStats((y > thr).astype(np.uint8), connectivity=8)
    jj, ii = np.mgrid[0:h, 0:w]
    dx, dy = (ii + 0.5 - cx) / f, -(jj + 0.5 - cy) / fy
    dlen = np.sqrt(dx * dx + dy * dy + 1.0)
    ray = depth * (dlen if cam.depth == "z" else 1.0)
    lights, notes = [], []
    mask = np.zeros((h, w), bool)
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
        t = ray[core & np.isfinite(ray) & (ray < cam.max_depth)]
        if t.size == 0:         # the sensor has a hole there: a ring around the core
            ring = (cv2.dilate(core.astype(np.uint8), kernel) > 0) & ~core
            t = ray[ring & np.isfinite(ray) & (ray < cam.max_depth)]
        if t.size == 0:
            notes.append(f"a lamp at pixel ({int(ii[core].mean())}, {int(jj[core].mean())}) has no depth; left out")
            continue
        dist = float(np.median(t))
        wgt = y[core]
        px, py = float((ii[core] * wgt).sum() / wgt.sum()) + 0.5, float((jj[core] * wgt).sum() / wgt.sum()) + 0.5
        d = np.array([(px - cx) / f, -(py - cy) / fy, -1.0])
        d /= np.linalg.norm(d)
        # the core and a 2 px ring; a ring pixel two lamps share goes to the nearer one
        blob = ((cv2.dilate(core.astype(np.uint8), kernel) > 0) & ~claimed) | core
        claimed |= blob
        intensity = dist * dist * ((own[blob] * omega[blob][:, None]).sum(0) + extra)
        radius = max(dist * math.sqrt(core.sum() / math.pi) / f, 1e-3)
        pos = (dist + radius) * d
        lights.append(PointLight(type="point", position=tuple(pos), intensity=tuple(float(v) for v in intensity),
                                 radius=radius, frame="camera"))
        mask |= blob
        if not hdr and float(rgb[core].max()) >= 0.98:
            notes.append(f"lamp at {dist:.3g} m is clipped in this display-referred image: its intensity "
                         f"({float(intensity.mean()):.3g}) is a lower bound")
    return lights, mask, notes


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


# ----------------------------------------------------------------------------- reference

def _density(x: np.ndarray, cfg: Config) -> np.ndarray:
    rho = np.zeros(x.shape[:-1])
    for d in cfg.medium.density:
        if d.type == "homogeneous":
            rho += d.factor
        elif d.type == "exponential":
            n = np.array(d.direction, float) / np.linalg.norm(d.direction)
            rho += d.factor * np.exp(-d.falloff * ((x - np.array(d.offset)) @ n))
        elif d.type == "sphere":
            r2 = ((x - np.array(d.center)) ** 2).sum(-1)
            rho += d.factor * np.maximum(0.0, 1.0 - r2 / d.radius ** 2)
    return rho


def _tau(p: np.ndarray, u: np.ndarray, L: np.ndarray, cfg: Config, skip_homogeneous=False) -> np.ndarray:
    """Optical depth (density units) from points p along unit u over lengths L, in closed form
    and float64 (the analytic media; tests/test_density.py checks the same forms against
    quadrature)."""
    P = np.zeros(np.shape(L))
    for d in cfg.medium.density:
        if d.type == "homogeneous":
            P = P + (0.0 if skip_homogeneous else d.factor * L)
        elif d.type == "exponential":
            n = np.array(d.direction, float) / np.linalg.norm(d.direction)
            pre = d.factor * np.exp(np.minimum(-d.falloff * ((p - np.array(d.offset)) @ n), 700.0))
            x = -d.falloff * (u @ n) * L
            with np.errstate(over="ignore", invalid="ignore"):
                f = np.where(np.abs(x) < 1e-8, 1.0 + x / 2, np.expm1(x) / np.where(x == 0, 1.0, x))
            P = P + pre * L * f
        elif d.type == "sphere":
            co = p - np.array(d.center)
            B = (co * u).sum(-1)
            perp = co - B[..., None] * u
            s2 = d.radius ** 2 - (perp * perp).sum(-1)
            sq = np.sqrt(np.maximum(s2, 0.0))
            u1, u2 = np.maximum(B, -sq), np.minimum(L + B, sq)
            du = u2 - u1
            P = P + np.where((s2 > 0) & (du > 0), d.factor / d.radius ** 2 * du * (s2 - (u2 * u2 + u1 * u2 + u1 * u1) / 3), 0.0)
    return P


def airlight_reference(cfg: Config, light, c: np.ndarray, w: np.ndarray, D: float, nodes: int = 1024):
    """(A_dir, A_sc) in float64 for one ray from c along unit w to distance D: composite
    Gauss-Legendre in s over 64 pieces refined towards the light's foot (points, spots),
    with the light leg's optical depth by its own quadrature; A_sc with the light's gain."""
    m = cfg.medium
    sa, ss = np.array(m.absorption), np.array(m.scattering)
    st = sa + ss
    g = m.asymmetry
    pos, axis = placed(cfg, light)
    x_gl, w_gl = np.polynomial.legendre.leggauss(32)
    if light.type == "directional":
        edges = np.concatenate([[0.0], np.geomspace(1e-3, D, nodes // 32)]) if D > 1e-3 else np.array([0.0, D])
    else:
        d1 = float(w @ (pos - c))
        R = math.sqrt(float(np.sum(np.cross(w, pos - c) ** 2)) + light.radius ** 2)
        phi = np.linspace(math.atan2(-d1, R), math.atan2(D - d1, R), nodes // 32 + 1)
        edges = np.clip(d1 + R * np.tan(phi), 0.0, D)
    for d in m.density:     # kinks: sphere boundaries, and where the light leg grazes a sphere
        if d.type == "sphere":
            co = c - np.array(d.center)
            B = float(w @ co)
            s2 = d.radius ** 2 - float(np.sum((co - B * w) ** 2))
            if s2 > 0:
                edges = np.concatenate([edges, [t for t in (-B - math.sqrt(s2), -B + math.sqrt(s2)) if 0 < t < D]])
            if light.type == "directional":
                qp, wp = co - (co @ axis) * axis, w - (w @ axis) * axis
                A, B, C = wp @ wp, qp @ wp, qp @ qp - d.radius ** 2
            else:
                v0, a = c - pos, np.array(d.center) - pos
                aa = a @ a - d.radius ** 2
                A, B, C = aa - (w @ a) ** 2, aa * (v0 @ w) - (v0 @ a) * (w @ a), aa * (v0 @ v0) - (v0 @ a) ** 2
            disc = B * B - A * C
            if disc >= 0 and abs(A) > 1e-15:
                edges = np.concatenate([edges, [t for t in ((-B - math.sqrt(disc)) / A, (-B + math.sqrt(disc)) / A)
                                                if 0 < t < D]])
    if light.type == "spot":
        v = c - pos
        for cc in (math.cos(math.radians(light.angle)), math.cos(math.radians(light.angle * (1 - light.blend)))):
            wa, va = float(w @ axis), float(v @ axis)
            A, B, C = wa * wa - cc * cc, wa * va - cc * cc * float(w @ v), va * va - cc * cc * float(v @ v)
            disc = B * B - A * C
            if disc >= 0 and abs(A) > 1e-15:
                edges = np.concatenate([edges, [t for t in ((-B - math.sqrt(disc)) / A, (-B + math.sqrt(disc)) / A)
                                                if 0 < t < D]])
    edges = np.unique(edges)
    a, b = edges[:-1], edges[1:]
    s = ((a + b)[:, None] / 2 + (b - a)[:, None] / 2 * x_gl[None, :]).ravel()
    ws = ((b - a)[:, None] / 2 * w_gl[None, :]).ravel()
    x = c + s[:, None] * w
    P = _tau(np.broadcast_to(c, x.shape), np.broadcast_to(w, x.shape), s, cfg)
    rho = _density(x, cfg)
    if light.type == "directional":
        cosa = float(axis @ w)
        I = np.array(light.irradiance)
        Pl = _tau(x, np.broadcast_to(axis, x.shape), np.full(len(s), 1e7), cfg, skip_homogeneous=True)
        geo = np.ones_like(s)
    else:
        to = pos - x
        tl = np.linalg.norm(to, axis=1)
        R2 = float(np.sum(np.cross(w, pos - c) ** 2)) + light.radius ** 2
        d1 = float(w @ (pos - c))
        teff2 = (s - d1) ** 2 + R2
        cosa = -(s - d1) / np.sqrt(teff2)
        I = np.array(light.intensity)[None, :] * np.ones((len(s), 1))
        if light.type == "spot":
            cc_o = math.cos(math.radians(light.angle))
            cc_i = math.cos(math.radians(light.angle * (1 - light.blend)))
            ct = (-to / tl[:, None]) @ axis
            tt = np.clip((ct - cc_o) / max(cc_i - cc_o, 1e-12), 0, 1)
            I = I * (tt * tt * (3 - 2 * tt))[:, None]
        Pl = _tau(x, to / tl[:, None], tl, cfg) + m.homogeneous * (np.sqrt(teff2) - tl)   # widened like 1 / t^2
        geo = 1.0 / teff2
    phase = (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * cosa) ** 1.5)
    src = (ws * rho * phase * geo)[:, None] * ss[None, :] * I * np.exp(-st[None, :] * Pl[:, None])
    tdir = np.exp(-st[None, :] * P[:, None])
    tsc = np.exp(-sa[None, :] * P[:, None]) - tdir
    a_dir, a_sc = (src * tdir).sum(0), (src * tsc).sum(0)
    return a_dir, a_sc + (gain(cfg, light) - 1.0) * (a_dir + a_sc)
