"""Lights through noise (issue 11, the `noise` primitive and transmittance function maps):
the map's transmittance against marched transmittance, what projecting the optical depth
instead of the transmittance buys (numpy, along texel rays), the airlight image against a
float64 double march, and the cost at 1920 x 1080. Prints a table and writes the generated
part of docs/lights.md (section Smoke). tools/shadows.py runs it too.

    python tools/smoke.py
"""
from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "tools"))

import fogcli  # noqa: E402
import light_oracles
from docblock import cpu_name, markers, write_block  # noqa: E402
from fogcli.device import noise  # noqa: E402
from fogcli.device.lights import placed  # noqa: E402
from metrics import ssim  # noqa: E402
from fogcli.device.plan import Timings  # noqa: E402

DOC = ROOT / "docs" / "lights.md"
BEGIN, END = markers("smoke")

SMOKE = ("{type: noise, factor: 4.3, scale: 1.5, octaves: 6, shape: %s, center: [0, 0, -8], radius: 2, "
         "size: [3, 4, 3], seed: 3, edge: %s}")
LIGHTS = {"point outside (perspective map)": "{type: point, position: [-4, 3, -5], intensity: 1}",
          "point inside (octahedral map)": "{type: point, position: [0.3, 0.2, -8.1], intensity: 1}",
          "spot (perspective map)": "{type: spot, position: [-4, 3, -6], direction: [1, -0.75, -0.5], angle: 30, intensity: 1}",
          "directional (orthographic map)": "{type: directional, direction: [0.3, 1, 0.2], irradiance: 1}"}
SHAPES = {"sphere, soft edge": ("sphere", "auto"), "box, hard edge": ("box", 0)}


def _cfg(light: str, shape: str, edge, *sets: str):
    return fogcli.make_config(None, sets=["medium.absorption=0", "medium.scattering=1",
                                          f"medium.density=[{SMOKE % (shape, edge)}]", f"lights=[{light}]", *sets])


def _exact(cfg, light, pts: np.ndarray, steps: int = 2048) -> np.ndarray:
    pos, axis = placed(cfg, light)
    out = []
    for p in pts:
        if light.type == "directional":
            out.append(light_oracles.march(p + 50 * axis, -axis, 50.0, cfg, steps=steps))
        else:
            v = p - pos
            out.append(light_oracles.march(pos, v / np.linalg.norm(v), float(np.linalg.norm(v)), cfg, steps=steps))
    return np.array(out)


def map_accuracy(n: int = 3000, coefficients=(16,)) -> dict:
    """(light, shape, N) -> (largest optical depth, mean |dT|, max |dT|) at n random points in
    and around the noise."""
    pts = np.array([0, 0, -8.0]) + np.random.default_rng(5).uniform(-2.4, 2.4, (n, 3))
    out = {}
    for sname, (shape, edge) in SHAPES.items():
        for lname, light in LIGHTS.items():
            cfg = _cfg(light, shape, edge)
            ex = _exact(cfg, cfg.lights[0], pts)
            for N in coefficients:
                c = _cfg(light, shape, edge, f"render.lights.coefficients={N}")
                dT = np.abs(np.exp(-noise.probe_map(c, c.lights[0], pts).astype(float)) - np.exp(-ex))
                out[(lname, sname, N)] = (float(ex.max()), float(dT.mean()), float(dT.max()))
    return out


def _dct(f: np.ndarray, N: int, x: np.ndarray) -> np.ndarray:
    """DCT-II coefficients (N) of samples f (..., M) at their centres, the series at x."""
    M = f.shape[-1]
    k = (np.arange(M) + 0.5) / M
    B = np.cos(np.pi * np.arange(N)[:, None] * k[None, :])
    c = f @ B.T * (2.0 / M)
    c[..., 0] *= 0.5
    return c @ np.cos(np.pi * np.arange(N)[:, None] * x[None, :])


def projections(N: int = 16, rays: int = 400, M: int = 512) -> dict:
    """What a texel stores, compared along 400 random rays of the point light (outside)
    through the hard-edged box, optical depth to ~10, M samples, float64 numpy: mean and
    max |dT| of the transmittance projected (Delalandre), of the optical depth projected,
    and of the optical depth less q(x) = a x + b x^2 (kernels/tfm.cl)."""
    cfg = _cfg(LIGHTS["point outside (perspective map)"], "box", 0)
    pos, _ = placed(cfg, cfg.lights[0])
    rng = np.random.default_rng(8)
    tgt = np.array([0, 0, -8.0]) + rng.uniform(-1.4, 1.4, (rays, 3))
    x = (np.arange(M) + 0.5) / M
    errs = {"transmittance": [], "optical depth": [], "optical depth less q(x)": []}
    for p in tgt:
        u = (p - pos) / np.linalg.norm(p - pos)
        t0, t1 = (float(v[0]) for v in light_oracles._span(pos[None, :], u[None, :], cfg, 0.0, np.inf))
        dt = (t1 - t0) / M
        rho = light_oracles.density_sum(pos + (t0 + x[:, None] * (t1 - t0)) * u, cfg) * dt
        tau = np.cumsum(rho) - 0.5 * rho
        T = np.exp(-tau)
        a, b = rho[0] * M, 0.5 * (rho[-1] - rho[0]) * M
        q = x * (a + b * x)
        errs["transmittance"].append(np.abs(np.clip(_dct(T, N, x), 0, 1) - T))
        errs["optical depth"].append(np.abs(np.exp(-np.clip(_dct(tau, N, x), 0, None)) - T))
        errs["optical depth less q(x)"].append(np.abs(np.exp(-np.clip(_dct(tau - q, N, x) + q, 0, None)) - T))
    return {k: (float(np.mean(v)), float(np.max(v))) for k, v in errs.items()}


IMAGE_LIGHTS = {
    "spot": "{type: spot, position: [-3, 3, -6], direction: [1, -1, -0.6], angle: 30, intensity: [300, 300, 300]}",
    "point": "{type: point, position: [-2.5, 2, -5], intensity: [100, 100, 100]}",
    "directional": "{type: directional, direction: [-0.4, 1, 0.3], irradiance: [3, 3, 3]}"}
IMAGE_SETS = ["medium.asymmetry=0.6", "medium.absorption=0.01", "medium.scattering=0.04", "camera.max_depth=100",
              "medium.density=[{type: homogeneous}, {type: noise, factor: 40, scale: 1.2, octaves: 5, shape: box, "
              "center: [0, 0, -8], size: [2, 6, 2], seed: 3}]"]


def _scene(w: int, h: int, floor: bool = False) -> np.ndarray:
    """A wall at 14 m, a nearer strip at 6 m on the left, and (floor) a floor 1.6 m below."""
    depth = np.full((h, w), 14.0)
    depth[:, : w // 5] = 6.0
    if floor:
        dy = (np.arange(h)[:, None] + 0.5 - h / 2) / ((w / 2) / math.tan(math.radians(30)))
        depth = np.minimum(depth, np.where(dy > 0.05, 1.6 / np.maximum(dy, 1e-6), np.inf))
    return depth.astype(np.float32)


def image_vs_double_march(w: int = 48, h: int = 36) -> dict:
    """light -> (relative L1, SSIM) of the airlight AOV against light_oracles.airlight_double_march
    (512 phi steps, 8 per march step in the noise, 256 light steps), both scaled by the
    reference's 99th percentile before SSIM (tools/metrics.py ssim tone-maps 1 - exp(-x))."""
    depth = _scene(w, h)
    out = {}
    for name, light in IMAGE_LIGHTS.items():
        cfg = fogcli.make_config(None, sets=[*IMAGE_SETS, f"lights=[{light}]"])
        _, planes = fogcli.apply(np.zeros((h, w, 3), np.float32), depth, cfg, aovs=("airlight",), return_aovs=True)
        got = np.dstack([planes[f"airlight.{c}"] for c in "RGB"]).astype(np.float64)
        ref = light_oracles.double_march_image(cfg, depth)
        s = np.percentile(ref, 99)
        out[name] = (float(np.abs(got - ref).sum() / ref.sum()), ssim(got / s, ref / s))
    return out


def cost(w: int = 1920, h: int = 1080, strides=("1", "auto", "4", "6")) -> tuple[dict, float, float]:
    """Per render.noise_stride: (kernel ms per stage, relative L1 of the airlight and its
    scattered part against stride 1) with the spot through the column, the frame with a
    floor; the kernel ms of the same frame in plain fog; the copy unit. Best of 2."""
    from performance import copy_ms

    from fogcli.device.noise import stride as noise_stride

    depth = _scene(w, h, floor=True)
    rgb = np.random.default_rng(0).uniform(0, 1, (h, w, 3)).astype(np.float32)

    def run(sets, aovs=()):
        best, planes = None, None
        for _ in range(2):
            t = Timings()
            _, planes = fogcli.apply(rgb, depth, fogcli.make_config(None, sets=sets), timings=t, aovs=aovs,
                                     return_aovs=True)
            r = t.resolve()
            best = r if best is None or sum(r.values()) < sum(best.values()) else best
        return best, planes
    out, ref = {}, None
    for st in strides:
        sets = [*IMAGE_SETS, f"lights=[{IMAGE_LIGHTS['spot']}]", f"render.noise_stride={st}"]
        stages, planes = run(sets, ("airlight", "airlight_scattered"))
        a = np.dstack([planes[f"{n}.{c}"] for n in ("airlight", "airlight_scattered") for c in "RGB"]).astype(float)
        ref = a if ref is None else ref
        used = noise_stride(fogcli.make_config(None, sets=sets), w, h)
        out[st if st != "auto" else f"auto ({used})"] = (stages, float(np.abs(a - ref).sum() / ref.sum()))
    plain, _ = run(IMAGE_SETS[:4])
    return out, sum(plain.values()), min(copy_ms((h, w, 4)) for _ in range(3))


def block() -> str:
    acc = map_accuracy(coefficients=(8, 16))
    proj = projections()
    img = image_vs_double_march()
    strides, plain, unit = cost()
    auto = next(k for k in strides if k.startswith("auto"))
    stages = strides[auto][0]
    total = sum(stages.values())
    extra = total - plain
    lines = [BEGIN, "",
             f"Measured by `python tools/smoke.py` on {cpu_name()} ({os.cpu_count()} cores), PoCL.", "",
             "The map against the transmittance marched in float64 (2048 steps), at 3000 random points in",
             "and around a noise primitive (6 octaves, scale 1.5 m, 4 m across, optical depth up to the",
             "value shown), 256 x 256 texels; N DCT coefficients of the optical depth per texel:", "",
             "| light | bounds | largest optical depth | mean dT, N 8 | max dT, N 8 | mean dT, N 16 | max dT, N 16 |",
             "|---|---|---|---|---|---|---|",
             *[f"| {ln} | {sn} | {acc[(ln, sn, 16)][0]:.1f} | {acc[(ln, sn, 8)][1]:.1e} | {acc[(ln, sn, 8)][2]:.3f} | "
               f"{acc[(ln, sn, 16)][1]:.1e} | {acc[(ln, sn, 16)][2]:.3f} |" for sn in SHAPES for ln in LIGHTS], "",
             "What each texel stores, along 400 rays through the hard-edged box (the worst case for a",
             "cosine series: the optical depth has a slope at both ends of the span), 16 coefficients,",
             "float64:", "",
             "| projected | mean dT | max dT |", "|---|---|---|",
             *[f"| {k} | {m:.1e} | {x:.3f} |" for k, (m, x) in proj.items()], "",
             "The airlight (`airlight` AOV) of a smoke column (a 2 x 6 x 2 m box of noise, optical depth",
             "up to ~8 across) in thin fog, 48 x 36, against a float64 double march (512 steps of phi",
             "and 8 per march step of the noise on each camera ray, each point's light leg marched in",
             "256 steps):", "",
             "| light | relative L1 | SSIM |", "|---|---|---|",
             *[f"| {n} | {r:.2%} | {s:.4f} |" for n, (r, s) in img.items()], "",
             "At 1920 x 1080 (the column before a wall, a nearer strip and a floor), per `noise_stride`:",
             "kernel time of the noise's stages and the relative L1 of the airlight and its scattered part",
             "against every pixel marched:", "",
             "| noise_stride | preprocess ms | tfm ms | lights ms | relative L1 |", "|---|---|---|---|---|",
             *[f"| {k} | {v[0].get('preprocess', 0):.0f} | {v[0].get('tfm', 0):.0f} | {v[0].get('lights', 0):.0f} | "
               f"{v[1]:.3%} |" for k, v in strides.items()], "",
             f"The default (`{auto}`): kernels {total:.0f} ms "
             f"({', '.join(f'{k} {v:.0f}' for k, v in stages.items())}), of which {extra:.0f} ms "
             f"= {extra / unit:.0f} numpy copies ({unit:.1f} ms a copy) on top of the same frame in "
             f"plain fog ({plain:.0f} ms).", "", END]
    return "\n".join(lines)


def main() -> int:
    text = block()
    print(text)
    write_block(DOC, BEGIN, END, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
