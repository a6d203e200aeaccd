"""The `noise` density primitive on the host: its device structs (kernels/noise.h), the
layout of each light's transmittance function map, and the same noise in float64 numpy
(the oracle of tests/test_noise.py and of tools/shadows.py's double march)."""
from __future__ import annotations

import math

import numpy as np

from fogcli.config.model import Config
from fogcli.device.geometry import light_image, placed
from fogcli.device.plan import Timings, defines
from fogcli.device.runtime import get_runtime
from fogcli.device.structs import NOISE_SHAPES, NOISE_T, TFM_KINDS, TFM_T


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
    farthest from the camera, 1 to 8 (tools/smoke.py measures the error per stride)."""
    s = cfg.render.noise_stride
    if s != "auto":
        return int(s)
    centre, rb = bounding_sphere(cfg)
    far = min(float(np.linalg.norm(centre - np.array(cfg.camera.position))) + rb, cfg.camera.max_depth)
    return int(min(max(cfg.camera.focal(width) * feature_size(cfg) / far / 3.0, 1.0), 8.0))


# ----------------------------------------------------------------------------- float64 oracle


def probe_map(cfg: Config, light, points: np.ndarray, device=None) -> np.ndarray:
    """The optical depth that the light's transmittance function map (kernels/tfm.cl) gives
    at world points (n, 3): built and read on the device, for tests and benchmarks."""

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
    k.tfm_build(q, *rt.nd(r.tfm_size, r.tfm_size), coef=coef, span=span, tm=tm, nz=nz, count=count)
    pts = np.zeros((len(points), 4), np.float32)
    pts[:, :3] = points
    xb = cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=pts)
    out = np.empty(len(points), np.float32)
    ob = cl.Buffer(rt.ctx, mf.WRITE_ONLY, max(out.nbytes, 4))
    k.tfm_probe(q, *rt.nd(len(points)), x=xb, tau=ob, n=np.int32(len(points)), tm=tm, coef=coef, span=span, nz=nz,
                count=count)
    cl.enqueue_copy(q, out, ob)
    return out


# -- on a plan (kernels/density.cl p_noise, tfm.cl)

def noise_args(plan):
    """The noise primitives of the current cfg (a plan outlives its cfg: get_plan) as the
    kernels' nz (a device noise_t array) and count, or None without noise."""
    if not primitives(plan.cfg):
        return None
    ns = structs(plan.cfg)
    if plan._noise is None or plan._noise[0] != ns.tobytes():
        mf = plan.rt.cl.mem_flags
        plan._noise = (ns.tobytes(), dict(nz=plan.rt.cl.Buffer(plan.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=ns),
                                          count=np.int32(len(primitives(plan.cfg)))))
    return plan._noise[1]


def noise_grid(plan) -> tuple[int, int, int]:
    """(stride, samples per row, rows of samples) of the noise's marched rays."""
    st = stride(plan.cfg, plan.w, plan.h)
    return st, (plan.w - 1 + st - 1) // st + 1, (plan.h - 1 + st - 1) // st + 1


def p_samples(plan, n: int):
    if plan._p_samples is None or plan._p_samples[0] < n:
        plan._p_samples = (n, plan.rt.cl.Buffer(plan.rt.ctx, plan.rt.cl.mem_flags.READ_WRITE, 4 * max(n, 1)))
    return plan._p_samples[1]


def airlight_noise(plan, t: Timings, dst, cam, lm, prims, ls, light):
    """kernels/tfm.cl: the light's transmittance function map, then the airlight; returns
    the airlight's event."""

    cl, q = plan.rt.cl, plan.rt.queue
    r = plan.cfg.render.lights
    pos, axis = placed(plan.cfg, light)
    tm = tfm_layout(plan.cfg, pos, axis, light.type)
    texels = r.tfm_size ** 2
    floats = texels * (r.coefficients + 2)      # the coefficients and q(x)'s two (tfm.cl)
    if plan._tfm is None or plan._tfm[0] != floats:
        mf = cl.mem_flags
        plan._tfm = (floats, cl.Buffer(plan.rt.ctx, mf.READ_WRITE, 4 * floats),
                     cl.Buffer(plan.rt.ctx, mf.READ_WRITE, 16 * texels))
    _, coef, span = plan._tfm
    k = plan.rt.program("tfm", **defines(plan.cfg))
    noise = noise_args(plan)
    t.add("tfm", k.tfm_build(q, *plan.rt.nd(r.tfm_size, r.tfm_size), coef=coef, span=span, tm=tm, **noise))
    st, cw, ch = noise_grid(plan)
    args = dict(depth=plan.depth, width=np.int32(plan.w), height=np.int32(plan.h), cam=cam, m=lm, prims=prims, L=ls,
                **noise, tm=tm, coef=coef, span=span, sub=np.int32(r.nodes), stride=np.int32(st), cw=np.int32(cw),
                ch=np.int32(ch))
    if st == 1:
        return k.airlight_noise(q, *plan.rt.nd(cw, ch), **dst, **args)
    if plan._noise_samples is None or plan._noise_samples[0] != cw * ch:
        mf = cl.mem_flags
        plan._noise_samples = (cw * ch, *(cl.Buffer(plan.rt.ctx, mf.READ_WRITE, 16 * cw * ch) for _ in range(2)))
    s_dir, s_sc = plan._noise_samples[1:]
    t.add("lights", k.airlight_noise(q, *plan.rt.nd(cw, ch), a_dir=s_dir, a_sc=s_sc, **args))
    lx, ly = light_image(plan.cfg, light, plan.w, plan.h)
    return k.airlight_fill(q, *plan.rt.nd(plan.w, plan.h), **dst, s_dir=s_dir, s_sc=s_sc, **args, lx=np.float32(lx),
                           ly=np.float32(ly))
