"""Shadows (render.lights.shadows: screen): screen-space shadows against exact geometric
shadows of facade quads in a scene built analytically, and the cost of the per-pixel march at
1920 x 1080 against numpy copies of the image, measured in one run. Prints a table and writes
the generated part of docs/lights.md (section Shadows); then tools/smoke.py (lights
through noise: the transmittance function maps, section Smoke). `--only shadows` or
`--only smoke` runs one of them.

    python tools/shadows.py [--only shadows|smoke]
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "tools"))

import fogcli  # noqa: E402
from docblock import cpu_name, markers, write_block  # noqa: E402
from fogcli.config.model import LightsRender  # noqa: E402
from fogcli.device.plan import Timings  # noqa: E402
from performance import copy_ms  # noqa: E402

DOC = ROOT / "docs" / "lights.md"
BEGIN, END = markers("shadows")

SA, SS, G = 0.005, 0.03, 0.85
MEDIUM = [f"medium.scattering={SS}", f"medium.absorption={SA}", f"medium.asymmetry={G}"]
MAX_DEPTH = 1000.0      # camera.max_depth: the sky's ray length
# facade quads facing the camera: (z, x0, x1, y0, y1), camera frame (looking down -z); snapped to
# pixel edges (quads(h, w)), so that the depth map holds the scene exactly and what differs is
# the screen-space model
QUADS = [(-15.0, -3.1, 2.3, -1.9, 2.2), (-8.0, 2.9, 3.7, -4.0, 4.0), (-22.0, -7.0, -4.4, -1.0, 6.0)]
CASES = {  # name: (light entry, camera-frame position or direction towards the light, directional)
    "point behind a quad": ("{type: point, position: [0.8, 0.4, -21], intensity: 800, radius: 0.05}",
                            (0.8, 0.4, -21.0), False),
    "point beside the quads": ("{type: point, position: [6, 1, -12], intensity: 800, radius: 0.05}",
                               (6.0, 1.0, -12.0), False),
    "point behind the camera": ("{type: point, position: [0.5, 4, 2], intensity: 800, radius: 0.05}",
                                (0.5, 4.0, 2.0), False),
    "sun behind the camera": ("{type: directional, direction: [0.3, 0.5, 0.8], irradiance: 1}",
                              (0.3, 0.5, 0.8), True),
    "sun from the side": ("{type: directional, direction: [0.9, 0.3, -0.3], irradiance: 1}", (0.9, 0.3, -0.3), True),
}


def focal(w: int) -> float:
    return (w / 2) / math.tan(math.radians(30.0))          # camera.fov 60


def rays(h: int, w: int) -> np.ndarray:
    f = focal(w)
    jj, ii = np.mgrid[0:h, 0:w]
    d = np.dstack([(ii + 0.5 - w / 2) / f, -(jj + 0.5 - h / 2) / f, -np.ones((h, w))])
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def quads(h: int, w: int) -> list:
    f = focal(w)
    col = lambda x, z: round(w / 2 + f * x / -z) - w / 2       # noqa: E731  (pixel edge, from the centre)
    row = lambda y, z: h / 2 - round(h / 2 - f * y / -z)       # noqa: E731
    return [(z, col(x0, z) * -z / f, col(x1, z) * -z / f, row(y0, z) * -z / f, row(y1, z) * -z / f)
            for z, x0, x1, y0, y1 in QUADS]


def facade_scene(h: int, w: int) -> np.ndarray:
    """z-depth of the first quad each pixel's centre ray meets, else the sky (inf): everything
    that casts a shadow is in the frame and seen, as the screen-space model assumes."""
    d = rays(h, w)
    z = np.full((h, w), np.inf)
    for qz, x0, x1, y0, y1 in quads(h, w):
        t = qz / d[..., 2]
        x, y = t * d[..., 0], t * d[..., 1]
        hit = (x > x0) & (x < x1) & (y > y0) & (y < y1) & (-qz < z)
        z[hit] = -qz
    return z.astype(np.float32)


def geometric_share(z: np.ndarray, light, directional: bool, n: int = 2048, radius: float = 0.05) -> np.ndarray:
    """Lit share of each pixel's single-scattering integrand with exact visibility: a point of
    the ray is lit unless its straight segment to the light crosses a quad. n cells (uniform in
    phi for points, in s for the sun), float64; 8 rows at a time."""
    h, w = z.shape
    return np.concatenate([_share_rows(z, r, min(r + 8, h), light, directional, n, radius) for r in range(0, h, 8)])


def _share_rows(z, r0, r1, light, directional, n, radius):
    h, w = z.shape
    d = rays(h, w)[r0:r1]
    D = np.minimum(z[r0:r1] / -d[..., 2], MAX_DEPTH)
    L = np.asarray(light, float)
    st = SA + SS
    k = (np.arange(n) + 0.5) / n
    if directional:
        L = L / np.linalg.norm(L)
        s = D[..., None] * k
        wgt = np.exp(-st * s)
    else:
        d1 = d @ L
        R = np.hypot(np.linalg.norm(L - d1[..., None] * d, axis=-1), radius)
        a0, a1 = np.arctan2(-d1, R), np.arctan2(D - d1, R)
        phi = a0[..., None] + k * (a1 - a0)[..., None]
        s = d1[..., None] + R[..., None] * np.tan(phi)
        wgt = (1 - G * G) / (1 + G * G + 2 * G * np.sin(phi)) ** 1.5 * np.exp(-st * s - st * R[..., None] / np.cos(phi))
    y = s[..., None] * d[:, :, None, :]                      # h x w x n x 3
    lit = np.ones(s.shape, bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        for qz, x0, x1, y0, y1 in quads(h, w):
            if directional:
                v = (qz - y[..., 2]) / L[2]
                ok = v > 0
                x, yy = y[..., 0] + v * L[0], y[..., 1] + v * L[1]
            else:
                u = (qz - y[..., 2]) / (L[2] - y[..., 2])
                ok = (u > 0) & (u < 1)
                x, yy = y[..., 0] + u * (L[0] - y[..., 0]), y[..., 1] + u * (L[1] - y[..., 1])
            lit &= ~(ok & (x > x0) & (x < x1) & (yy > y0) & (yy < y1))
    return (wgt * lit).sum(-1) / wgt.sum(-1)


def airlight(z: np.ndarray, light: str, *sets: str) -> np.ndarray:
    _, planes = fogcli.apply(np.zeros(z.shape + (3,), np.float32), z, fogcli.make_config(None, sets=[
        *MEDIUM, f"lights=[{light}]", *sets]), aovs=("airlight",), return_aovs=True)
    return planes["airlight.G"].astype(np.float64)


def shadowed(name: str, thickness: float = 0.05, *sets: str):
    """The config of the facade scene's medium with light CASES[name], its screen shadows at
    `thickness` and any further settings."""
    return fogcli.make_config(None, sets=[*MEDIUM, f"lights=[{CASES[name][0]}]", "render.lights.shadows=screen",
                                          f"render.lights.thickness={thickness}", *sets])


def against_geometry(h: int, w: int, names=tuple(CASES), thicknesses=(1.0,)) -> dict:
    """Per case: (share of the unshadowed airlight the exact shadows remove, relative L1 of
    the airlight with screen-space shadows against the exact geometric ones per thickness)."""
    z = facade_scene(h, w)
    out = {}
    for name in names:
        spec, light, directional = CASES[name]
        free = airlight(z, spec)
        want = geometric_share(z, light, directional) * free
        errs = []
        for th in thicknesses:
            got = airlight(z, spec, "render.lights.shadows=screen", f"render.lights.thickness={th}",
                           "render.lights.method=march")
            errs.append(float(np.abs(got - want).sum() / want.sum()))
        out[name] = (float(1.0 - want.sum() / free.sum()), errs)
    return out


def epipolar_vs_march(h: int, w: int, names=tuple(CASES), thickness: float = 0.05, slices=()) -> dict:
    """Per case: (relative L1 of the epipolar airlight against the march's, the march's shadow
    stage ms, the epipolar one's, the share of pixels the epipolar method marched itself,
    {other slice count: (relative L1, shadow stage ms)})."""
    from fogcli.device.plan import get_plan
    from fogcli.device.runtime import get_runtime

    z = facade_scene(h, w)
    rgb = np.zeros((h, w, 3), np.float32)
    ms = lambda e: (e.profile.end - e.profile.start) * 1e-6  # noqa: E731
    out = {}
    for name in names:
        res = {}
        for method, sl in (("march", None), ("epipolar", None), *(("epipolar", s) for s in slices)):
            cfg = shadowed(name, thickness, f"render.lights.method={method}",
                           *([f"render.lights.slices={sl}"] if sl else []))
            best = None
            for _ in range(1 if method == "march" else 2):     # the first epipolar run builds its kernels
                t = Timings()
                _, planes = fogcli.apply(rgb, z, cfg, timings=t, aovs=("airlight",), return_aovs=True)
                tm = sum(ms(e) for e in t.stages["shadows"])
                best = tm if best is None else min(best, tm)
            res[method, sl] = (planes["airlight.G"].astype(np.float64), best)
            if method == "epipolar" and sl is None:
                marched = int(get_plan(get_runtime(None), w, h, cfg, ("airlight",)).epi_marched[0]) / (w * h)
        (a, ta), (b, tb) = res["march", None], res["epipolar", None]
        l1 = lambda x: float(np.abs(x - a).sum() / a.sum())  # noqa: E731
        out[name] = (l1(b), ta, tb, marched, {s: (l1(res["epipolar", s][0]), res["epipolar", s][1]) for s in slices})
    return out


def epipolar_kernels(h: int, w: int, name: str) -> dict:
    """Kernel ms of the epipolar method's stages (its slices' maps, the samples, the unwarp,
    the march of the pixels the unwarp left) and of the unshadowed airlight, best of 3 runs."""
    z = facade_scene(h, w)
    cfg = shadowed(name)
    best = None
    for _ in range(3):
        t = Timings()
        fogcli.apply(np.zeros((h, w, 3), np.float32), z, cfg, timings=t)
        ms = [(e.profile.end - e.profile.start) * 1e-6 for e in t.stages["shadows"]]
        got = {"airlight": t.resolve()["lights"], "maps": ms[0], "samples": ms[1], "unwarp": ms[2], "march": ms[3]}
        best = got if best is None or sum(got.values()) < sum(best.values()) else best
    return best


def visibility_agreement(h: int, w: int, names=tuple(CASES), thickness: float = 0.05, tol: float = 0.01) -> dict:
    """Per case, the epipolar samples' visibility from their slices' shadow maps (min/max
    trees) against each sample walking its own line pixel by pixel as the march does (the
    same kernel built with SH_WALK): (samples in the frame, share of them with the same
    verdict, something in shadow or not; share whose lit share differs by at most `tol`;
    mean difference of the lit share)."""
    import pyopencl as cl

    from fogcli.device.plan import get_plan
    from fogcli.device.runtime import Runtime, get_runtime

    z = facade_scene(h, w)
    rgb = np.zeros((h, w, 3), np.float32)
    program = Runtime.program
    out = {}
    for name in names:
        cfg = shadowed(name, thickness)
        got = []
        for walk in (False, True):
            Runtime.program = (lambda self, n, **d: program(self, n, **d, SH_WALK=1) if n == "shadows"  # noqa: E731
                               else program(self, n, **d)) if walk else program
            try:
                fogcli.apply(rgb, z, cfg)
            finally:
                Runtime.program = program
            rt = get_runtime(None)
            plan = get_plan(rt, w, h, cfg, ())
            n = plan._epi[0]
            a, t = np.empty((n, 4), np.float32), np.empty((n, 4), np.float32)
            cl.enqueue_copy(rt.queue, a, plan._epi[2])
            cl.enqueue_copy(rt.queue, t, plan._epi[3]).wait()
            got.append((a, t))
        (a0, t0), (a1, t1) = got
        inside = t0[:, 3] > 0
        d = np.abs(a0[inside, 1] - a1[inside, 1])
        out[name] = (int(inside.sum()), float((t0[inside, 3] == t1[inside, 3]).mean()), float((d <= tol).mean()),
                     float(d.mean()))
    return out


def on_top(h: int, w: int, name: str, reps: int = 3) -> tuple[float, float, float]:
    """Kernel ms of the whole pipeline (every stage) on the facade scene with the medium alone
    and with the one shadowed light `name` (thickness 0.05 m), best of `reps` runs taken
    alternately (the machine's speed drifts between minutes), and the copy unit of
    docs/performance.md measured between them (the least of its rounds)."""
    z = facade_scene(h, w)
    rgb = np.zeros((h, w, 3), np.float32)
    cfgs = [fogcli.make_config(None, sets=MEDIUM), shadowed(name)]
    best = [math.inf, math.inf, math.inf]
    for _ in range(reps + 1):                   # the first round builds the kernels
        for i, cfg in enumerate(cfgs):
            t = Timings()
            fogcli.apply(rgb, z, cfg, timings=t)
            best[i] = min(best[i], sum(t.resolve().values()))
        best[2] = min(best[2], copy_ms((h, w, 4)))
    return best[0], best[1], best[2]


def copies(h: int, w: int) -> tuple[float, float]:
    """The copy units of tools/lights.py at h x w: (docs/performance.md's, warm), best of 3."""
    rgb = np.random.default_rng(0).uniform(0, 1, (h, w, 3)).astype(np.float32)
    cold, warm = 1e9, 1e9
    for _ in range(3):
        cold = min(cold, copy_ms((h, w, 4)))
        t0 = time.perf_counter()
        for _ in range(10):
            rgb.copy()
        warm = min(warm, (time.perf_counter() - t0) / 10 * 1e3)
    return cold, warm


THICKNESSES = (0.01, 0.05, 1.0)


def main() -> int:
    geo = against_geometry(192, 256, thicknesses=THICKNESSES)
    small = epipolar_vs_march(192, 256)
    big = epipolar_vs_march(1080, 1920, names=("point behind a quad", "sun from the side"), slices=(256, 1024))
    stage_ms = epipolar_kernels(1080, 1920, "point behind a quad")
    plain, lit, unit = on_top(1080, 1920, "point behind a quad")
    agree = {**visibility_agreement(192, 256),
             **{f"{n}, 1920 x 1080": v for n, v in
                visibility_agreement(1080, 1920, names=("point behind a quad", "sun from the side")).items()}}
    cold, warm = copies(1080, 1920)
    row = lambda n, v: (f"| {n} | {v[0]:.2%} | {v[1]:.0f} | {v[2]:.0f} | {v[1] / v[2]:.1f}x | "  # noqa: E731
                        f"{v[3]:.2%} |")
    lines = [BEGIN, "",
             f"Measured by `python tools/shadows.py` on {cpu_name()} ({__import__('os').cpu_count()} cores), PoCL.", "",
             "Screen-space shadows against exact geometric shadows: three thin facade quads facing the",
             "camera (at 8, 15 and 22 m) against the sky, all in the frame and seen, 256 x 192, the depth",
             f"map sampled at pixel centres; medium sigma_s {SS}, sigma_a {SA}, g {G}. The reference integrates each pixel's ray",
             "in 2048 cells with exact segment-quad visibility (float64); fogcli marches the depth map",
             "(`method: march`). Relative L1 of the `airlight` AOV per `thickness`, and how much of the",
             "unshadowed airlight the exact shadows remove:", "",
             "| light | shadowed share | " + " | ".join(f"thickness {t:g} m" for t in THICKNESSES) + " |",
             "|---|---|" + "---|" * len(THICKNESSES),
             *[f"| {n} | {a:.1%} | " + " | ".join(f"{e:.2%}" for e in errs) + " |" for n, (a, errs) in geo.items()], "",
             "Thin facades are what a thin `thickness` models. Thicker, a line that passes beside a",
             "facade's edge and then behind it counts as blocked, so the shadows of thin facades grow:",
             "most where a light close behind a facade sends its lines past the edges, or where a ray",
             "passes a facade's edge at the facade's depth.", "",
             f"`method: epipolar` (the default: {LightsRender().slices} slices, step {LightsRender().step}, capped for small images) against `method: march` on the same",
             "scene (thickness 0.05 m): relative L1 of the airlight, the shadow stage's kernel time of",
             "each, and the share of pixels the epipolar method marched itself (near the light's image,",
             "or where no sample sees their surface):", "",
             "| light, 256 x 192 | relative L1 | march ms | epipolar ms | faster | pixels marched |",
             "|---|---|---|---|---|---|",
             *[row(n, v) for n, v in small.items()],
             *[row(f"{n}, 1920 x 1080", v) for n, v in big.items()], "",
             "The samples read each slice's shadow map, made of the same occluders as the march; the",
             "error is mostly the interpolation along the slices, where a shadow's edge falls between",
             "two samples (a smaller `step` reduces it).", "",
             "Other `slices` at 1920 x 1080 (relative L1 against the march / shadow stage ms):", "",
             "| light | " + " | ".join(f"{s} slices" for s in sorted([LightsRender().slices, 256, 1024])) + " |",
             "|---|---|---|---|",
             *[f"| {n} | " + " | ".join(f"{e:.2%} / {t:.0f}" for _, (e, t) in sorted(
                 {**v[4], LightsRender().slices: (v[0], v[2])}.items())) + " |" for n, v in big.items()], "",
             "Visibility at the samples: from their slices' shadow maps (the default) against each sample",
             "walking its own line pixel by pixel as the march does, at the same samples (the kernel built",
             "with SH_WALK): the share of samples in the frame with the same verdict (something in shadow",
             "or not), and with lit shares within 0.01 of each other:", "",
             "| light | samples | same verdict | share within 0.01 | mean difference |",
             "|---|---|---|---|---|",
             *[f"| {n}{'' if '1920' in n else ' (256 x 192)'} | {v[0]} | {v[1]:.2%} | {v[2]:.2%} | {v[3]:.1e} |"
               for n, v in agree.items()], "",
             f"Cost at 1920 x 1080 of one shadowed point light: epipolar {big['point behind a quad'][2]:.0f} ms = "
             f"{big['point behind a quad'][2] / cold:.0f} numpy copies of the image ({cold:.1f} ms, as "
             f"docs/performance.md counts them; {big['point behind a quad'][2] / warm:.0f} warm copies of {warm:.1f} ms), "
             f"the march {big['point behind a quad'][1] / 1e3:.0f} s; per kernel: "
             + ", ".join(f"{k} {v:.0f} ms" for k, v in stage_ms.items()) + ".", "",
             "On top of the default pipeline (every stage's kernel time, the same scene with and without the",
             f"shadowed light, best of 3 taken alternately): {plain:.0f} ms -> {lit:.0f} ms, the light with its shadows "
             f"{lit - plain:.0f} ms = {(lit - plain) / unit:.0f} numpy copies ({unit:.1f} ms, measured between those runs) "
             f"= {(lit - plain) / plain:.1f}x the pipeline without it.", "", END]
    text = "\n".join(lines)
    print(text)
    write_block(DOC, BEGIN, END, text)
    return 0


def run_all(argv: list[str]) -> int:
    only = argv[argv.index("--only") + 1] if "--only" in argv else None
    if only not in (None, "shadows", "smoke"):
        print("usage: python tools/shadows.py [--only shadows|smoke]", file=sys.stderr)
        return 2
    if only != "smoke":
        main()
    if only != "shadows":
        import smoke

        smoke.main()
    return 0


if __name__ == "__main__":
    sys.exit(run_all(sys.argv[1:]))
