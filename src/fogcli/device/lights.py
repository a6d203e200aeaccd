"""Lights in the medium on the host: the structs of kernels/lights.cl (lights placed in the
world, the medium with its density primitives, the Gauss-Legendre nodes) and a float64
numpy reference of the single-scattered airlight that the kernel is tested against."""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from fogcli.config.model import Config
from fogcli.device.geometry import placed
from fogcli.device.noise import airlight_noise, noise_args
from fogcli.device.plan import Timings, defines
from fogcli.device.shadows import epipolar
from fogcli.device.structs import AL_TABLE_T, LIGHT_T, LIGHT_TYPES, SH_BINS, camera_struct, lmedium_struct
from fogcli.physics.airlight_table import NB, NX, tables
from fogcli.physics.apsf import _slice_ga, load_table, log_along_tau, read_data


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
    single scattering as the light model carries it (tools/make_light_gain.py), both
    over the thin-medium form."""
    tab = load_table()
    z = read_data("light_gain")
    carried = np.asarray(z["carried_ratio"], np.float64)
    assert np.array_equal(z["tau"], tab["tau"]) and np.array_equal(z["albedo"], tab["albedo"])
    ok = (carried > 0) & (tab["ratio"] > 0)
    return {"g": tab["g"], "albedo": tab["albedo"], "tau": tab["tau"],
            "ratio": np.where(ok, tab["ratio"] / np.where(ok, carried, 1.0), 1.0)}


def optical_distance(cfg: Config, light) -> float:
    """The optical depth (density units) from the camera to a point or spot light as placed."""
    pos, _ = placed(cfg, light)
    cam = np.array(cfg.camera.position, np.float64)
    dist = float(np.linalg.norm(pos - cam))
    return float(optical_depth(cam[None], ((pos - cam) / max(dist, 1e-12))[None], np.array([dist]),
                               cfg)[0]) if dist > 0 else 0.0


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
    m = cfg.medium
    P = optical_distance(cfg, light)
    tab = _gain_table()
    out = np.ones(3)
    for c, (sa, ss) in enumerate(zip(m.absorption, m.scattering)):
        if ss > 0 and P > 0:
            ratio = _slice_ga(tab, "ratio", m.asymmetry, ss / (sa + ss))
            out[c] = float(log_along_tau(tab, ratio, np.array([ss * P]))[0])
    # all orders carry at least what single scattering does; below 1 is the table's noise
    return np.maximum(out, 1.0)


def gauss_legendre(n: int) -> np.ndarray:
    x, w = np.polynomial.legendre.leggauss(n)
    return np.ascontiguousarray(np.stack([x, w], axis=1), np.float32)


def medium_density(x: np.ndarray, cfg: Config) -> np.ndarray:
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


def optical_depth(p: np.ndarray, u: np.ndarray, L: np.ndarray, cfg: Config, skip_homogeneous=False) -> np.ndarray:
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
            P = P + np.where((s2 > 0) & (du > 0),
                             d.factor / d.radius ** 2 * du * (s2 - (u2 * u2 + u1 * u2 + u1 * u1) / 3), 0.0)
    return P


# -- on a plan (kernels/lights.cl)

def airlight(plan, t: Timings) -> None:
    """Every light's airlight (kernels/lights.cl): a_dir kept for after the pyramid, a_sc
    into level 0 of the colour chain (merged with the image's scattered light)."""
    cl, q, n = plan.rt.cl, plan.rt.queue, plan.w * plan.h
    lm, prims = lmedium_struct(plan.cfg)
    mf = cl.mem_flags
    quad = []           # (primitives, Gauss-Legendre nodes) on the device, made when a kernel needs them

    def device_quad():
        if not quad:
            quad.extend((cl.Buffer(plan.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=prims),
                         cl.Buffer(plan.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                                   hostbuf=gauss_legendre(int(lm["nodes"])))))
        return quad
    cam = camera_struct(plan.cfg, plan.w, plan.h)
    pk = plan.cfg.render.lights.airlight == "pk"
    homogeneous = int(lm["nprims"]) == 0
    lights = [x for x in plan.cfg.lights if x.type != "auto"]
    if len(lights) > 1 and plan._light_tmp is None:     # the second light on: summed after
        plan._light_tmp = (cl.Buffer(plan.rt.ctx, mf.READ_WRITE, 16 * n), cl.Buffer(plan.rt.ctx, mf.READ_WRITE, 16 * n))
    size = plan.rt.nd(plan.w, plan.h)
    frame = dict(depth=plan.depth, width=np.int32(plan.w), height=np.int32(plan.h), cam=cam)
    for k, light in enumerate(lights):
        a_dir, a_sc = (plan.a_dir, plan.a_sc) if k == 0 else plan._light_tmp
        dst = dict(a_dir=a_dir, a_sc=a_sc)
        ls = light_struct(plan.cfg, light)
        if pk and light.type == "point":        # Pradhan & Kumar's closed form
            ev = plan.k_lights.airlight_pk(q, *size, **frame, **dst, m=lm, L=ls)
        elif noise_args(plan) is not None:     # the light leg from a map, the camera leg marched
            ev = airlight_noise(plan, t, dst, cam, lm, device_quad()[0], ls, light)
        elif homogeneous and light.type == "point":    # tables instead of quadrature
            tab, grey, u = table_args(plan, ls)
            kernel = plan.k_lights.airlight_table_grey if grey else plan.k_lights.airlight_table
            ev = kernel(q, *plan.rt.nd(-(-plan.w // plan.lanes), plan.h), **frame, **dst, tab=tab, u=u)
        elif homogeneous and light.type == "directional":     # closed form
            ev = plan.k_lights.airlight_sun(q, *size, **frame, **dst, m=lm, L=ls)
        else:
            prims, gl = device_quad()
            ev = plan.k_lights.airlight(q, *size, **frame, **dst, m=lm, prims=prims, gl=gl, L=ls)
        t.add("lights", ev)
        if plan.cfg.render.lights.shadows == "screen":      # built once per process (runtime.program)
            k_shadows = plan.rt.program("shadows", **defines(plan.cfg), SH_BINS=SH_BINS, LANES=plan.lanes)
            sh = plan.cfg.render.lights
            shade = dict(cam=cam, m=lm, prims=device_quad()[0], L=ls, thickness=np.float32(sh.thickness),
                         offscreen_shadowed=np.int32(sh.offscreen == "shadowed"))
            if sh.method == "march":
                t.add("shadows", k_shadows.shadow_march(q, *size, depth=plan.depth, width=np.int32(plan.w),
                                                        height=np.int32(plan.h), **dst, **shade))
            else:
                epipolar(plan, t, k_shadows, dst, shade, light)
        if k > 0:
            t.add("lights", plan.k_lights.add_light(q, *plan.rt.nd(n), a_dir=plan.a_dir, t_dir=a_dir, a_sc=plan.a_sc,
                                                    t_sc=a_sc, n=np.int32(n)))
    t.add("lights", plan.k_lights.airlight_to_chain(
        q, *plan.rt.nd(n), a_sc=plan.a_sc, chain0=plan.chain, prep0=plan.prep, lut=plan.lut, n=np.int32(n)))


def airlight_tables(plan):
    """(the medium's airlight tables on the device (physics/airlight_table.py), kept while
    g and the channels' sa / st stay the same: r = 1, then one table per distinct r;
    each channel's r = sa / st; each channel's table)."""
    m = plan.cfg.medium
    st = [a + s for a, s in zip(m.absorption, m.scattering)]
    r = [round(a / t, 6) if t > 0 else 1.0 for a, t in zip(m.absorption, st)]
    distinct = tuple(dict.fromkeys(x for x in r if x < 1.0))
    key = (float(m.asymmetry), distinct)
    if plan._al_tables is None or plan._al_tables[0] != key:
        host = tables(*key)
        buf = plan.rt.cl.Buffer(plan.rt.ctx, plan.rt.cl.mem_flags.READ_ONLY | plan.rt.cl.mem_flags.COPY_HOST_PTR,
                                hostbuf=host)
        plan._al_tables = (key, buf)
    kind = [1 + distinct.index(x) if x < 1.0 else 0 for x in r]
    return plan._al_tables[1], r, kind


def table_args(plan, ls):
    """The airlight tables on the device, whether the medium is grey (airlight_table_grey),
    and the table kernels' uniforms (al_table_t, kernels/lights.h)."""
    tab, rs, kind = airlight_tables(plan)
    m = plan.cfg.medium
    hf = m.homogeneous
    u = np.zeros((), AL_TABLE_T)
    for c in range(3):
        r = rs[c]
        st = hf * (m.absorption[c] + m.scattering[c])
        u["st"][c], u["lst"][c], u["sa"][c], u["r"][c] = st, math.log(st) if st > 0 else -1e30, hf * m.absorption[c], r
        u["xm"][c], u["em"][c] = (-math.atanh(r), math.sqrt(1.0 - r * r)) if r < 1.0 else (-1e30, 0.0)
        u["off"][c] = kind[c] * 2 * NB * NX
        k = hf * m.scattering[c] * float(ls["intensity"][c])
        u["lk"][c] = math.log(k) if k > 0 else -1e30
    # grey media: ln(ss I) per channel as its largest and exp(each - largest)
    u["lkm"] = max(float(x) for x in u["lk"])
    u["k"] = [math.exp(float(x) - float(u["lkm"])) for x in u["lk"]]
    u["gn"] = ls["gain"][:3]
    u["g"], u["hf"] = m.asymmetry, hf
    u["vx"], u["vy"], u["vz"] = np.array(ls["pos"][:3], np.float64) - np.array(plan.cfg.camera.position, np.float64)
    u["rad2"] = float(ls["radius"]) ** 2
    return tab, len(set(m.absorption)) == 1 and len(set(m.scattering)) == 1, u


def keep_sources(plan, t: Timings, pixels: tuple) -> None:
    """The lamps' pixels keep their share of their scattered light (frame.scene.share_lamps:
    flat indices, float32 (n, 4) shares)."""
    cl, (idx, keep) = plan.rt.cl, pixels
    mf = cl.mem_flags
    b_idx = cl.Buffer(plan.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(idx, np.int32))
    b_keep = cl.Buffer(plan.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(keep, np.float32))
    t.add("lights", plan.k_lights.keep_sources(plan.rt.queue, *plan.rt.nd(len(idx)), chain0=plan.chain, prep0=plan.prep,
                                               idx=b_idx, keep=b_keep, n=np.int32(len(idx))))


def add_airlight(plan, t: Timings) -> None:
    n = plan.w * plan.h
    t.add("lights", plan.k_lights.add_airlight(plan.rt.queue, *plan.rt.nd(n), out=plan.out, a_dir=plan.a_dir, n=np.int32(n)))
