"""Float64 numpy oracles of the light model on the host: the single-scattered airlight by
quadrature (airlight_reference, against kernels/lights.cl) and, through procedural noise,
by a double march (airlight_double_march, against kernels/tfm.cl). Tests and the scripts
that write docs/lights.md and docs/smoke.md use them; the runtime does not."""
from __future__ import annotations

import math

import numpy as np

from fogcli.config.model import Config
from fogcli.device.geometry import placed
from fogcli.device.lights import gain, medium_density, optical_depth
from fogcli.device.noise import primitives
from fogcli.device.structs import NOISE_MAX_STEPS


def radius_gain(light, R02: float, R: float, d1: float, D: float) -> float:
    """lights.h AL_RADIUS_GAIN: within the light's radius its airlight at the radius, times
    3 - 2 (R0 / r)^2 on the share of the near field the ray covers (R02 = R0^2; R the floored
    distance; the ray from 0 to D, the light's foot at d1)."""
    share = (math.atan2(D - d1, R) - math.atan2(-d1, R)) / math.pi
    return 1.0 + 2.0 * share * max(1.0 - R02 / max(light.radius ** 2, 1e-30), 0.0)


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
        R = math.sqrt(max(float(np.sum(np.cross(w, pos - c) ** 2)), light.radius ** 2))
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
    P = optical_depth(np.broadcast_to(c, x.shape), np.broadcast_to(w, x.shape), s, cfg)
    rho = medium_density(x, cfg)
    if light.type == "directional":
        cosa = float(axis @ w)
        I = np.array(light.irradiance)
        Pl = optical_depth(x, np.broadcast_to(axis, x.shape), np.full(len(s), 1e7), cfg, skip_homogeneous=True)
        geo = np.ones_like(s)
    else:
        to = pos - x
        tl = np.linalg.norm(to, axis=1)
        R02 = float(np.sum(np.cross(w, pos - c) ** 2))
        R2 = max(R02, light.radius ** 2)     # at least the radius (lights.h: AL_RADIUS_GAIN)
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
        Pl = optical_depth(x, to / tl[:, None], tl, cfg) + m.homogeneous * (np.sqrt(teff2) - tl)   # widened like 1 / t^2
        geo = radius_gain(light, R02, math.sqrt(R2), d1, D) / teff2
    phase = (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * cosa) ** 1.5)
    src = (ws * rho * phase * geo)[:, None] * ss[None, :] * I * np.exp(-st[None, :] * Pl[:, None])
    tdir = np.exp(-st[None, :] * P[:, None])
    tsc = np.exp(-sa[None, :] * P[:, None]) - tdir
    a_dir, a_sc = (src * tdir).sum(0), (src * tsc).sum(0)
    return a_dir, a_sc + (gain(cfg, light) - 1.0) * (a_dir + a_sc)


def lattice_value(ix, iy, iz, seed) -> np.ndarray:
    """noise.h: lattice_value, in numpy's wrapping uint32 arithmetic."""
    u = lambda v: np.asarray(v, np.int64).astype(np.uint32)  # noqa: E731  (two's complement, like C's cast)
    with np.errstate(over="ignore"):
        h = (np.uint32(seed) ^ (u(ix) * np.uint32(0x8da6b343)) ^ (u(iy) * np.uint32(0xd8163841))
             ^ (u(iz) * np.uint32(0xcb1ab31f)))
        h = h ^ (h >> np.uint32(16))
        h = h * np.uint32(0x7feb352d)
        h = h ^ (h >> np.uint32(15))
        h = h * np.uint32(0x846ca68b)
        h = h ^ (h >> np.uint32(16))
    return (h >> np.uint32(8)).astype(np.float64) * (2.0 / 16777216.0) - 1.0


def value_noise(p: np.ndarray, seed: int) -> np.ndarray:
    i = np.floor(p).astype(np.int64)
    f = p - i
    u = f * f * f * (f * (f * 6 - 15) + 10)
    out = 0.0
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                wgt = ((u[..., 0] if dx else 1 - u[..., 0]) * (u[..., 1] if dy else 1 - u[..., 1])
                       * (u[..., 2] if dz else 1 - u[..., 2]))
                out = out + wgt * lattice_value(i[..., 0] + dx, i[..., 1] + dy, i[..., 2] + dz, seed)
    return out


def density(x: np.ndarray, d) -> np.ndarray:
    """One noise primitive's density at world points x (..., 3)."""
    r = x - np.array(d.center, float)
    if d.shape == "box":
        inside = np.min(0.5 * np.array(d.size, float) - np.abs(r), axis=-1)
    else:
        inside = d.radius - np.linalg.norm(r, axis=-1)
    p = r / d.scale
    f = 0.0
    for o in range(d.octaves):
        f = f + 0.5 ** o * value_noise(p * 2.0 ** o, (d.seed + o * 0x9e3779b9) & 0xFFFFFFFF)
    norm = 1.0 / sum(0.5 ** o for o in range(d.octaves))
    rho = d.factor * np.maximum(0.0, d.offset + d.amplitude * norm * f)
    if d.edge_m() > 0:
        t = np.clip(inside / d.edge_m(), 0.0, 1.0)
        rho = rho * t * t * (3 - 2 * t)
    return np.where(inside > 0, rho, 0.0)


def density_sum(x: np.ndarray, cfg: Config) -> np.ndarray:
    return sum((density(x, d) for d in primitives(cfg)), np.zeros(x.shape[:-1]))


def chords(p: np.ndarray, u: np.ndarray, d) -> tuple[np.ndarray, np.ndarray]:
    """chord for many lines at once (p, u: (n, 3)): (t0, t1), t1 <= t0 on a miss."""
    r = p - np.array(d.center, float)
    if d.shape == "box":
        half = 0.5 * np.array(d.size, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (-half - r) / u, (half - r) / u
        flat = np.abs(u) < 1e-12
        ta = np.where(flat, np.where(np.abs(r) > half, np.inf, -np.inf), ta)
        tb = np.where(flat, np.where(np.abs(r) > half, -np.inf, np.inf), tb)
        return np.minimum(ta, tb).max(-1), np.maximum(ta, tb).min(-1)
    B = (r * u).sum(-1)
    s2 = d.radius ** 2 - ((r - B[:, None] * u) ** 2).sum(-1)
    sq = np.sqrt(np.maximum(s2, 0.0))
    return np.where(s2 > 0, -B - sq, 0.0), np.where(s2 > 0, -B + sq, 0.0)


def _span(p: np.ndarray, u: np.ndarray, cfg: Config, lo, hi, step: bool = False):
    """The union of the primitives' chords clipped to [lo, hi], for lines (n, 3): (t0, t1),
    and with step the finest march step of the primitives each line meets (noise.h:
    noise_span)."""
    t0, t1, h = np.full(len(p), np.inf), np.full(len(p), -np.inf), np.full(len(p), np.inf)
    for d in primitives(cfg):
        a, b = chords(p, u, d)
        a, b = np.maximum(a, lo), np.minimum(b, hi)
        hit = b > a
        t0, t1 = np.where(hit, np.minimum(t0, a), t0), np.where(hit, np.maximum(t1, b), t1)
        h = np.where(hit, np.minimum(h, d.march_step()), h)
    return (t0, t1, h) if step else (t0, t1)


def _light_leg(x: np.ndarray, pos: np.ndarray, axis: np.ndarray, directional: bool, cfg: Config,
               steps: int) -> np.ndarray:
    """The noise's optical depth from each point x (n, 3) to the light, marched (midpoint
    rule, `steps` over each ray's span through the noise), float64."""
    if directional:
        u, L = np.broadcast_to(np.asarray(axis, float), x.shape), np.full(len(x), 1e7)
    else:
        v = pos - x
        L = np.linalg.norm(v, axis=1)
        u = v / np.maximum(L, 1e-30)[:, None]
    t0, t1 = _span(x, u, cfg, 0.0, L)
    hit = np.flatnonzero(t1 > t0)
    out = np.zeros(len(x))
    for c in np.array_split(hit, max(1, len(hit) // 256)):
        ln = t1[c] - t0[c]
        t = t0[c, None] + (np.arange(steps) + 0.5)[None, :] * (ln / steps)[:, None]
        out[c] = density_sum(x[c, None, :] + t[..., None] * u[c, None, :], cfg).sum(1) * ln / steps
    return out


def march(p: np.ndarray, u: np.ndarray, L: float, cfg: Config, steps: int | None = None) -> float:
    """The noise's optical depth from p along unit u over [0, L] by the midpoint rule: as
    noise.h (the primitives' finest march step, at most NOISE_MAX_STEPS) unless steps is given."""
    t0, t1, h = (float(v[0]) for v in _span(np.asarray(p, float)[None, :], np.asarray(u, float)[None, :], cfg, 0.0, L,
                                               step=True))
    if not t1 > t0:
        return 0.0
    n = steps or min(max(int(math.ceil((t1 - t0) / h)), 1), NOISE_MAX_STEPS)
    t = t0 + (np.arange(n) + 0.5) * (t1 - t0) / n
    return float(density_sum(np.asarray(p) + t[:, None] * np.asarray(u), cfg).sum() * (t1 - t0) / n)


def airlight_double_march(cfg: Config, light, c: np.ndarray, w: np.ndarray, D: float, nodes: int = 512,
                          light_steps: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """(A_dir, A_sc) of one ray in float64 by the dual march Delalandre et al. compare with:
    the camera ray cut at `nodes` equal steps of phi (points, spots; s for a directional
    light) and at 8 steps per march step of the noise, the midpoint rule on each piece,
    every point's light leg marched (`light_steps`); the analytic primitives in closed
    form (lights.optical_depth). A_sc with the light's gain, like the kernels."""
    m = cfg.medium
    sa, ss = np.array(m.absorption), np.array(m.scattering)
    st, g = sa + ss, m.asymmetry
    pos, axis = placed(cfg, light)
    directional = light.type == "directional"
    if directional:
        edges = np.linspace(0.0, D, nodes + 1)
    else:
        d1 = float(w @ (pos - c))
        R = math.sqrt(max(float(np.sum(np.cross(w, pos - c) ** 2)), light.radius ** 2))
        phi = np.linspace(math.atan2(-d1, R), math.atan2(D - d1, R), nodes + 1)
        edges = np.clip(d1 + R * np.tan(phi), 0.0, D)
    n0, n1 = (float(v[0]) for v in _span(c[None, :], w[None, :], cfg, 0.0, D))
    if n1 > n0:
        h = min(d.march_step() for d in primitives(cfg)) / 8
        edges = np.concatenate([edges, np.linspace(n0, n1, int(math.ceil((n1 - n0) / h)) + 1)])
    edges = np.unique(edges)
    a, b = edges[:-1], edges[1:]
    if directional:
        s, wgt = 0.5 * (a + b), b - a
    else:       # the midpoint in phi, its weight d phi / R times R^2 / t^2: 1/t^2 ds exactly
        pa, pb = np.arctan2(a - d1, R), np.arctan2(b - d1, R)
        s, wgt = d1 + R * np.tan(0.5 * (pa + pb)), (pb - pa) / R
        wgt = wgt * radius_gain(light, float(np.sum(np.cross(w, pos - c) ** 2)), R, d1, D)
    x = c + s[:, None] * w
    rho_n = density_sum(x, cfg)
    acc = np.concatenate([[0.0], np.cumsum(rho_n * (b - a))])[:-1]
    P = optical_depth(np.broadcast_to(c, x.shape), np.broadcast_to(w, x.shape), s, cfg) + acc + rho_n * (s - a)
    rho = medium_density(x, cfg) + rho_n
    Pn = _light_leg(x, pos, axis, directional, cfg, light_steps)
    if directional:
        I = np.array(light.irradiance)[None, :]
        Pl = optical_depth(x, np.broadcast_to(axis, x.shape), np.full(len(s), 1e7), cfg, skip_homogeneous=True)
        cosa = float(axis @ w)
    else:
        to = pos - x
        tl = np.linalg.norm(to, axis=1)
        teff2 = (s - d1) ** 2 + R ** 2
        cosa = -(s - d1) / np.sqrt(teff2)
        I = np.array(light.intensity)[None, :] * np.ones((len(s), 1))
        if light.type == "spot":
            cc_o = math.cos(math.radians(light.angle))
            cc_i = math.cos(math.radians(light.angle * (1 - light.blend)))
            tt = np.clip(((-to / tl[:, None]) @ axis - cc_o) / max(cc_i - cc_o, 1e-12), 0, 1)
            I = I * (tt * tt * (3 - 2 * tt))[:, None]
        Pl = optical_depth(x, to / tl[:, None], tl, cfg) + m.homogeneous * (np.sqrt(teff2) - tl)
    phase = (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * cosa) ** 1.5)
    src = (wgt * rho * phase)[:, None] * ss[None, :] * I * np.exp(-st[None, :] * (Pl + Pn)[:, None])
    tdir = np.exp(-st[None, :] * P[:, None])
    tsc = np.exp(-sa[None, :] * P[:, None]) - tdir
    a_dir, a_sc = (src * tdir).sum(0), (src * tsc).sum(0)
    return a_dir, a_sc + (gain(cfg, light) - 1.0) * (a_dir + a_sc)


def pinhole_rays(cfg: Config, depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pixel's unit ray direction (h, w, 3) and ray length (h, w) for a z-depth map,
    the camera at the origin looking down -z (the kernels' pixel_ray on the host, for the
    float64 oracles above)."""
    h, w = depth.shape
    cam = cfg.camera
    f, fy = cam.focal(w), cam.focal_y(w)
    cx, cy = cam.centre(w, h)
    jj, ii = np.mgrid[0:h, 0:w] + 0.5
    d = np.dstack([(ii - cx) / f, -(jj - cy) / fy, -np.ones((h, w))])
    n = np.linalg.norm(d, axis=-1)
    return d / n[..., None], np.asarray(depth, np.float64) * n


def double_march_image(cfg: Config, depth: np.ndarray, **kw) -> np.ndarray:
    """A_dir (h, w, 3) of the config's first light by airlight_double_march at every pixel
    (keywords: its nodes, light_steps)."""
    dirs, lengths = pinhole_rays(cfg, depth)
    out = np.zeros(dirs.shape)
    for j, i in np.ndindex(depth.shape):
        out[j, i] = airlight_double_march(cfg, cfg.lights[0], np.zeros(3), dirs[j, i], float(lengths[j, i]), **kw)[0]
    return out
