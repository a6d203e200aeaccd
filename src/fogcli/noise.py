"""The `noise` density primitive on the host: its device structs (kernels/noise.h), the
layout of each light's transmittance function map, and the same noise in float64 numpy
(the oracle of tests/test_noise.py and of benchmarks/shadows.py's double march)."""
from __future__ import annotations

import math

import numpy as np

from .config import Config
from .structs import NOISE_MAX_STEPS, NOISE_SHAPES, NOISE_T, TFM_KINDS, TFM_T



def primitives(cfg: Config) -> list:
    return [d for d in cfg.medium.density if d.type == "noise"]


def structs(cfg: Config) -> np.ndarray:
    """The noise primitives as noise_t (at least one element: OpenCL buffers are not empty)."""
    prims = primitives(cfg)
    s = np.zeros(max(len(prims), 1), NOISE_T)
    for k, d in enumerate(prims):
        s[k]["center"] = [*d.center, 0.0]
        s[k]["hsize"] = [*(0.5 * np.array(d.size)), 0.0] if d.shape == "box" else [d.radius] * 3 + [0.0]
        s[k]["factor"], s[k]["inv_scale"] = d.factor, 1.0 / d.scale
        s[k]["amplitude"], s[k]["offset"], s[k]["edge"] = d.amplitude, d.offset, d.edge_m()
        s[k]["step"] = d.march_step()
        s[k]["norm"] = 1.0 / sum(0.5 ** o for o in range(d.octaves))
        s[k]["octaves"], s[k]["seed"], s[k]["shape"] = d.octaves, d.seed, NOISE_SHAPES[d.shape]
    return s


def bounding_sphere(cfg: Config) -> tuple[np.ndarray, float]:
    """A sphere around every noise primitive's bounds (centre, radius), world."""
    balls = [(np.array(d.center, float), d.radius if d.shape == "sphere" else 0.5 * float(np.linalg.norm(d.size)))
             for d in primitives(cfg)]
    lo = np.min([c - r for c, r in balls], axis=0)
    hi = np.max([c + r for c, r in balls], axis=0)
    centre = 0.5 * (lo + hi)
    return centre, max(float(np.linalg.norm(c - centre)) + r for c, r in balls)


def _frame(e3: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.array([1.0, 0.0, 0.0]) if abs(e3[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(e3, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(e3, e1)


def tfm_layout(cfg: Config, pos: np.ndarray, axis: np.ndarray, light_type: str) -> np.ndarray:
    """tfm_t of one light (pos, axis: world, lights.placed). A directional light gets an
    orthographic map across the noise's bounding sphere; a point or spot outside that sphere
    a perspective map of the cone around it (every texel spent on rays that meet the
    noise); one inside it an octahedral map of all directions."""
    r = cfg.render.lights
    centre, rb = bounding_sphere(cfg)
    s = np.zeros((), TFM_T)
    s["size"], s["ncoef"] = r.tfm_size, r.coefficients
    if light_type == "directional":
        e3 = -np.asarray(axis, float)
        s["kind"], s["extent"] = TFM_KINDS["orthographic"], 1.01 * rb
        origin = centre - 1.01 * rb * e3
    else:
        v = centre - pos
        dist = float(np.linalg.norm(v))
        origin = pos
        if dist > 1.05 * rb:
            e3 = v / dist
            s["kind"], s["extent"] = TFM_KINDS["perspective"], 1.02 * math.tan(math.asin(rb / dist))
        else:
            e3 = np.asarray(axis, float) if light_type == "spot" else np.array([0.0, 0.0, 1.0])
            s["kind"] = TFM_KINDS["octahedral"]
    e1, e2 = _frame(e3)
    for name, v in (("origin", origin), ("e1", e1), ("e2", e2), ("e3", e3)):
        s[name] = [*v, 0.0]
    return s


def feature_size(cfg: Config) -> float:
    """m, the finest structure noise puts into the light: the finest octave's lattice spacing,
    the soft edge, or the mean free path at the densest (offset + amplitude) of a primitive."""
    st = max(a + s for a, s in zip(cfg.medium.absorption, cfg.medium.scattering))
    out = math.inf
    for d in primitives(cfg):
        peak = d.factor * max(d.offset + d.amplitude, 1e-12) * st
        out = min(out, d.scale / 2 ** (d.octaves - 1), d.edge_m() or math.inf, 1.0 / peak if peak > 0 else math.inf)
    return out


def stride(cfg: Config, width: int, height: int) -> int:
    """render.noise_stride; auto: a third of feature_size in pixels where the noise lies
    farthest from the camera, 1 to 8 (benchmarks/smoke.py measures the error per stride)."""
    s = cfg.render.noise_stride
    if s != "auto":
        return int(s)
    centre, rb = bounding_sphere(cfg)
    far = min(float(np.linalg.norm(centre - np.array(cfg.camera.position))) + rb, cfg.camera.max_depth)
    return int(min(max(cfg.camera.focal(width) * feature_size(cfg) / far / 3.0, 1.0), 8.0))


# ----------------------------------------------------------------------------- float64 oracle

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


def probe_map(cfg: Config, light, points: np.ndarray, device=None) -> np.ndarray:
    """The optical depth that the light's transmittance function map (kernels/tfm.cl) gives
    at world points (n, 3): built and read on the device, for tests and benchmarks."""
    from .lights import placed
    from .pipeline import defines
    from .runtime import get_runtime

    rt = get_runtime(device)
    cl, q, r = rt.cl, rt.queue, cfg.render.lights
    mf = cl.mem_flags
    pos, axis = placed(cfg, light)
    tm = tfm_layout(cfg, pos, axis, light.type)
    k = rt.program("tfm", **defines(cfg))
    nz = cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=structs(cfg))
    count = np.int32(len(primitives(cfg)))
    coef = cl.Buffer(rt.ctx, mf.READ_WRITE, 4 * r.tfm_size ** 2 * (r.coefficients + 2))
    span = cl.Buffer(rt.ctx, mf.READ_WRITE, 16 * r.tfm_size ** 2)
    k.tfm_build(q, *rt.nd(r.tfm_size, r.tfm_size), coef, span, tm, nz, count)
    pts = np.zeros((len(points), 4), np.float32)
    pts[:, :3] = points
    xb = cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=pts)
    out = np.empty(len(points), np.float32)
    ob = cl.Buffer(rt.ctx, mf.WRITE_ONLY, max(out.nbytes, 4))
    k.tfm_probe(q, *rt.nd(len(points)), xb, ob, np.int32(len(points)), tm, coef, span, nz, count)
    cl.enqueue_copy(q, out, ob)
    return out


def airlight_double_march(cfg: Config, light, c: np.ndarray, w: np.ndarray, D: float, nodes: int = 512,
                          light_steps: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """(A_dir, A_sc) of one ray in float64 by the dual march Delalandre et al. compare with:
    the camera ray cut at `nodes` equal steps of phi (points, spots; s for a directional
    light) and at 8 steps per march step of the noise, the midpoint rule on each piece,
    every point's light leg marched (`light_steps`); the analytic primitives in closed
    form (lights._tau). A_sc with the light's gain, like the kernels."""
    from .lights import _density, _tau, gain, placed

    m = cfg.medium
    sa, ss = np.array(m.absorption), np.array(m.scattering)
    st, g = sa + ss, m.asymmetry
    pos, axis = placed(cfg, light)
    directional = light.type == "directional"
    if directional:
        edges = np.linspace(0.0, D, nodes + 1)
    else:
        d1 = float(w @ (pos - c))
        R = math.sqrt(float(np.sum(np.cross(w, pos - c) ** 2)) + light.radius ** 2)
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
    x = c + s[:, None] * w
    rho_n = density_sum(x, cfg)
    acc = np.concatenate([[0.0], np.cumsum(rho_n * (b - a))])[:-1]
    P = _tau(np.broadcast_to(c, x.shape), np.broadcast_to(w, x.shape), s, cfg) + acc + rho_n * (s - a)
    rho = _density(x, cfg) + rho_n
    Pn = _light_leg(x, pos, axis, directional, cfg, light_steps)
    if directional:
        I = np.array(light.irradiance)[None, :]
        Pl = _tau(x, np.broadcast_to(axis, x.shape), np.full(len(s), 1e7), cfg, skip_homogeneous=True)
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
        Pl = _tau(x, to / tl[:, None], tl, cfg) + m.homogeneous * (np.sqrt(teff2) - tl)
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
