"""Lights: the airlight kernel's accuracy against the float64 reference over the 108
geometries of tests/test_lights.py at 16, 24 and 32 nodes, and the cost of one point light
at 1920 x 1080 against numpy copies of the image, measured in one run. Prints a table and
writes the generated part of docs/lights.md.

    python tools/lights.py
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import fogcli  # noqa: E402
from fogcli.config.model import LightsRender  # noqa: E402
from light_oracles import airlight_reference  # noqa: E402
from fogcli.device.plan import Timings  # noqa: E402
from fogcli.device.run import kernel_ms  # noqa: E402
from fogcli.device.structs import camera_struct  # noqa: E402

sys.path.insert(0, str(ROOT / "tools"))
from docblock import cpu_name, markers, write_block  # noqa: E402
from groundtruth.load import comparison  # noqa: E402
from performance import LAMP, copy_ms  # noqa: E402

DOC = ROOT / "docs" / "lights.md"
BEGIN, END = markers("measured")


W, H = 8, 6


def case_config(rng, medium, light_kind, g):
    sets = [f"medium.asymmetry={g}", "camera.fov=60", "camera.max_depth=200"]
    sa, ss = rng.uniform(0.005, 0.08, 3), rng.uniform(0.02, 0.2, 3)
    sets += [f"medium.absorption=[{sa[0]:.4f}, {sa[1]:.4f}, {sa[2]:.4f}]",
             f"medium.scattering=[{ss[0]:.4f}, {ss[1]:.4f}, {ss[2]:.4f}]"]
    if medium == "exponential":
        sets.append('medium.density=[{type: homogeneous, factor: 0.3}, {type: exponential, factor: 1.5, '
                    f'falloff: {rng.uniform(0.02, 0.3):.3f}, direction: [0, 1, 0.2], offset: [0, -1, 0]}}]')
    elif medium == "sphere":
        c = rng.uniform([-3, -2, -25], [3, 2, -8])
        sets.append('medium.density=[{type: homogeneous, factor: 0.2}, {type: sphere, factor: 3, '
                    f'center: [{c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}], radius: {rng.uniform(3, 8):.2f}}}]')
    if light_kind == "directional":
        d = rng.normal(size=3)
        light = f"{{type: directional, direction: [{d[0]:.3f}, {d[1]:.3f}, {d[2]:.3f}], irradiance: [1, 0.8, 0.6]}}"
    else:
        where = rng.choice(["front", "behind", "beside", "on_ray"])
        if where == "front":
            p = rng.uniform([-6, -4, -30], [6, 4, -3])
        elif where == "behind":
            p = rng.uniform([-4, -3, 1], [4, 3, 12])
        elif where == "beside":
            p = rng.uniform([3, -2, -4], [10, 2, 2])
        else:       # exactly on the ray of pixel (2, 3)
            f = (W / 2) / math.tan(math.radians(30))
            d = np.array([(2.5 - W / 2) / f, -(3.5 - H / 2) / f, -1.0])
            p = d / np.linalg.norm(d) * rng.uniform(3, 25)
        light = f"{{type: {light_kind}, position: [{p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}], intensity: [300, 250, 200], " \
                f"radius: {rng.choice([0.02, 0.2])}"
        if light_kind == "spot":
            a = rng.normal(size=3)
            light += f", direction: [{a[0]:.3f}, {a[1]:.3f}, {a[2]:.3f}], angle: {rng.uniform(10, 60):.1f}, blend: 0.3"
        light += "}"
    return fogcli.make_config(None, sets=sets + [f"lights=[{light}]"])


CASES = [(seed, medium, kind, g) for seed, (medium, kind, g) in enumerate(
    (m, k, g) for m in ("homogeneous", "exponential", "sphere") for k in ("point", "spot", "directional")
    for g in (0.0, 0.5, 0.8, 0.95)) for _ in range(3)]


def lamp_frame(h=120, w=160, L=(300.0, 250.0, 200.0), c=(1.0, 1.5, -12.0), r=0.2):
    """A disc lamp facing the camera (radiance L, radius r m, centre c) before a wall at 40 m,
    anti-aliased by 4 x 4 samples per pixel; z depth."""
    f = (w / 2) / math.tan(math.radians(30))
    ss = 4
    jj, ii = np.mgrid[0:h * ss, 0:w * ss]
    dx, dy = ((ii + 0.5) / ss - w / 2) / f, -((jj + 0.5) / ss - h / 2) / f
    x, y = dx * -c[2], dy * -c[2]                       # where each sample's ray meets the lamp's plane
    cover = (((x - c[0]) ** 2 + (y - c[1]) ** 2) < r * r).reshape(h, ss, w, ss).mean(axis=(1, 3))
    rgb = 0.05 + cover[:, :, None] * (np.array(L) - 0.05)
    z = np.where(cover > 0.5, -c[2], 40.0)
    return rgb.astype(np.float32), z.astype(np.float32), f


def worst_error(nodes: int | None = None, parts=(0, 1)) -> tuple[float, tuple]:
    """Worst relative error of the airlight AOV (part 0) and of its twice-scattered part
    (part 1) against the float64 reference over the 108 geometries x 10 pixels (a sky pixel,
    the pixel whose ray holds the light, 8 more), on pixels holding at least 1e-3 of the
    case's peak; with where it happened. nodes None: the default. Point lights in
    homogeneous media take the tables (nodes do not apply to them), the rest quadrature."""
    worst, where = 0.0, ()
    for seed, medium, kind, g in CASES:
        rng = np.random.default_rng(seed)
        cfg = case_config(rng, medium, kind, g)
        if nodes is not None:
            cfg = cfg.model_copy(update={"render": cfg.render.model_copy(update={
                "lights": cfg.render.lights.model_copy(update={"nodes": nodes})})})
        depth = rng.uniform(2, 60, (H, W)).astype(np.float32)
        depth[0, 0] = np.inf
        _, planes = fogcli.apply(np.zeros((H, W, 3), np.float32), depth, cfg,
                                 aovs=("airlight", "airlight_scattered"), return_aovs=True)
        got = [np.dstack([planes[f"{n}.{c}"] for c in "RGB"]) for n in ("airlight", "airlight_scattered")]
        cam = camera_struct(cfg, W, H)
        f, cx, cy = float(cam["focal_px"]), float(cam["cx"]), float(cam["cy"])
        pick = [(0, 0), (3, 2)] + [tuple(p) for p in rng.integers(0, [H, W], (8, 2))]
        for j, i in pick:
            d = np.array([(i + 0.5 - cx) / f, -(j + 0.5 - cy) / f, -1.0])
            D = min(float(depth[j, i]) * np.linalg.norm(d), 200.0)
            ref = airlight_reference(cfg, cfg.lights[0], np.zeros(3), d / np.linalg.norm(d), D)
            for k in parts:
                peak = max(float(np.abs(got[k]).max()), 1e-30)
                if np.abs(ref[k]).max() > 1e-3 * peak:
                    err = float((np.abs(got[k][j, i] - ref[k]) / np.maximum(np.abs(ref[k]), 1e-3 * peak)).max())
                    if err > worst:
                        worst, where = err, (seed, medium, kind, g, i, j, k, got[k][j, i], ref[k])
    return worst, where


def speed() -> dict:
    """At 1920 x 1080, best of 5, in one run: the kernel ms of fog without lights (`base`), the
    `lights` stage of one point light in fog (`stage`: its airlight kernel, adding its
    twice-scattered part to level 0, adding its light after the pyramid; nothing else changes
    with lights), the airlight kernel alone (`kernel`), the same kernel in sea water
    (`kernel_rgb`, chromatic), and two units of "a numpy copy of the image": `copy` as
    docs/performance.md counts it (performance.copy_ms: the RGBA float32 image copied into
    fresh memory, median of 7) and `copy_warm` (the RGB float32 image copied into memory the
    allocator reuses, best of 10: the bandwidth alone, about 2-3x less). The light's cost is
    its own stage, not the difference of two whole-pipeline times, which on these machines is
    noisier than the cost itself."""
    h, w = 1080, 1920
    rng = np.random.default_rng(0)
    rgb = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    z = rng.uniform(5, 80, (h, w)).astype(np.float32)
    cfgs = {"base": fogcli.make_config("fog"), "light": fogcli.make_config("fog", sets=[LAMP]),
            "light_rgb": fogcli.make_config("sea", sets=[LAMP])}
    best = dict.fromkeys(("base", "stage", "kernel", "kernel_rgb", "copy", "copy_warm"), 1e9)
    ms = lambda e: (e.profile.end - e.profile.start) * 1e-6  # noqa: E731
    for _ in range(5):
        for name, cfg in cfgs.items():
            t = Timings()
            fogcli.apply(rgb, z, cfg, timings=t)
            if name == "base":
                best["base"] = min(best["base"], kernel_ms(t)[1])
            elif name == "light":
                best["stage"] = min(best["stage"], sum(ms(e) for e in t.stages["lights"]))
                best["kernel"] = min(best["kernel"], ms(t.stages["lights"][0]))
            else:
                best["kernel_rgb"] = min(best["kernel_rgb"], ms(t.stages["lights"][0]))
        t0 = time.perf_counter()
        for _ in range(10):
            rgb.copy()
        best["copy_warm"] = min(best["copy_warm"], (time.perf_counter() - t0) / 10 * 1e3)
        best["copy"] = min(best["copy"], copy_ms((h, w, 4)))
    return best


def detection() -> list[tuple]:
    """(centre, radius, intensity error, distance error) of synthetic disc lamps found by
    {type: auto} (tests/test_lights.py's frame)."""
    from fogcli.config.model import AutoLights
    from fogcli.frame.lamps import detect_lamps
    out = []
    for c, r in (((1.0, 1.5, -12.0), 0.2), ((-3.0, 0.5, -25.0), 0.3), ((0.5, -0.5, -6.0), 0.1)):
        c, L = np.array(c), np.array([300.0, 250.0, 200.0])
        rgb, z, _ = lamp_frame(L=L, c=c, r=r)
        lamp = detect_lamps(rgb, z, fogcli.make_config("fog"), AutoLights(type="auto"))[0][0]
        want = L * math.pi * r * r * (-c[2] / np.linalg.norm(c))
        out.append((c, r, float(np.abs(np.array(lamp.intensity) / want - 1).max()),
                    float(abs((np.linalg.norm(lamp.position) - lamp.radius) / np.linalg.norm(c) - 1))))
    return out


def pk_errors(n_cases: int = 60) -> dict:
    """Relative error of `airlight: pk` (green channel) against the float64 reference, isotropic
    homogeneous media, point lights anywhere around the camera; binned by sigma_t R and by
    where the light is along the ray (d1 the distance to its foot, D the surface's)."""
    H, W = 12, 16
    rng = np.random.default_rng(0)
    bins: dict = {}
    for _ in range(n_cases):
        st, p = rng.choice([0.05, 0.2, 0.5]), rng.uniform([-6, -4, -30], [6, 4, 3])
        sets = ["medium.asymmetry=0", f"medium.absorption={st * 0.2:.4f}", f"medium.scattering={st * 0.8:.4f}",
                "camera.max_depth=200", "render.lights.airlight=pk",
                f"lights=[{{type: point, position: [{p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}], intensity: 100}}]"]
        cfg = fogcli.make_config(None, sets=sets)
        depth = rng.uniform(2, 60, (H, W)).astype(np.float32)
        _, pl = fogcli.apply(np.zeros((H, W, 3), np.float32), depth, cfg, aovs=("airlight",), return_aovs=True)
        cam = camera_struct(cfg, W, H)
        f, cx, cy = float(cam["focal_px"]), float(cam["cx"]), float(cam["cy"])
        for j, i in [tuple(q) for q in rng.integers(0, [H, W], (6, 2))]:
            d = np.array([(i + 0.5 - cx) / f, -(j + 0.5 - cy) / f, -1.0])
            D = min(float(depth[j, i]) * np.linalg.norm(d), 200.0)
            w = d / np.linalg.norm(d)
            ref = airlight_reference(cfg, cfg.lights[0], np.zeros(3), w, D)[0][1]
            d1, R = float(w @ p), math.sqrt(float(np.sum(np.cross(w, p) ** 2)) + 0.05 ** 2)
            where = "behind the camera" if d1 < 0 else ("beyond the surface" if d1 > D else "between")
            key = (where, "<= 0.5" if st * R <= 0.5 else ("0.5-2" if st * R <= 2 else "> 2"))
            bins.setdefault(key, []).append(abs(float(pl["airlight.G"][j, i]) / ref - 1))
    return bins


def path_traced() -> list[tuple]:
    """The path-traced scenes with lamps of tools/groundtruth (emissive discs and spheres,
    nothing else lit): the default pipeline and the same with `lights: [{type: auto}]`."""
    import warnings

    from metrics import rel_l1, ssim

    G = comparison()
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for case in G.gt_load.cases():
            if case["scene"] not in ("lamps", "street", "plaza"):
                continue
            sets, gt = G.case_sets(case["meta"]), case["medium"]
            base = fogcli.apply(case["L"], case["depth"], fogcli.make_config(None, sets=sets))
            lit = fogcli.apply(case["L"], case["depth"], fogcli.make_config(None, sets=sets + ["lights=[{type: auto}]"]))
            rows.append((case["name"], rel_l1(base, gt), ssim(base, gt), rel_l1(lit, gt), ssim(lit, gt)))
    return rows


def detection_path_traced() -> list[tuple]:
    """Lamps found by {type: auto} in the path tracer's own vacuum image of the `lamps` scene
    (emissive spheres and a disc, 3 px in radius; the image a user would give fogcli) against
    the scene's lamps: (centre, radius, distance error, intensity error per channel, worst),
    matched by direction. A sphere of radiance L and radius r sends L pi r^2 towards the
    camera; the facing disc L pi r^2 cos(theta)."""
    from fogcli.config.model import AutoLights
    from fogcli.frame.lamps import detect_lamps

    G = comparison()
    S = G.gt_scenes
    case = next(G.gt_load.cases(scene="lamps", medium="fog"))
    cfg = fogcli.make_config(None, sets=[f"camera.fov={case['meta']['fov']}", "camera.depth=distance",
                                         "camera.max_depth=100000"])
    lamps = detect_lamps(case["L"], case["depth"], cfg, AutoLights(type="auto"))[0]
    rows = []
    for shape in S.scene_lamps():
        if shape["kind"] not in ("sphere", "disk") or max(shape["radiance"]) < 10:
            continue
        c, r, L = np.array(shape["pos"]), float(shape["scale"]), np.array(shape["radiance"])
        want = L * math.pi * r * r * ((-c[2] / np.linalg.norm(c)) if shape["kind"] == "disk" else 1.0)
        u = c / np.linalg.norm(c)
        best = max(lamps, key=lambda x: float(np.dot(np.array(x.position) / np.linalg.norm(x.position), u)))
        dist = np.linalg.norm(best.position) - (best.radius if shape["kind"] == "disk" else 0.0)
        err_i = np.array(best.intensity) / want - 1
        rows.append((c, r, float(dist / np.linalg.norm(c) - 1), err_i, float(np.abs(err_i).max())))
    return rows


def known_lights() -> list[tuple]:
    """The night scenes with point lights of tools/groundtruth (renders-lights/: nothing
    reflects, so the lights show only through the medium): the default pipeline without
    lights, and with the scene's lights given as `lights:` entries (position, intensity);
    relative L1 / SSIM at full resolution and on 4 x 4 pixel blocks (the path tracer's noise
    about 4x lower)."""
    import json
    import warnings

    from metrics import rel_l1, ssim

    G = comparison()
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for case in G.gt_load.cases(directory=str(ROOT / "tools" / "groundtruth" / "renders-lights")):
            sets, gt, meta = G.case_sets(case["meta"]), case["medium"], case["meta"]
            lights = json.dumps([{"type": "point", "position": x["position"], "intensity": x["intensity"]}
                                 for x in meta["lights"]])
            row = [case["name"], bool(meta["heldout"]), case["noise"]]
            direct = G.blend(case)
            for extra in ([], [f"lights={lights}"]):
                img = fogcli.apply(case["L"], case["depth"], fogcli.make_config(None, sets=sets + extra))
                row += [rel_l1(img, gt), ssim(img, gt), rel_l1(G.blocks(img), G.blocks(gt)), ssim(G.blocks(img), G.blocks(gt))]
            row.append(float((img - direct).sum() / (gt - direct).sum()))
            rows.append(tuple(row))
    return rows


def main() -> int:
    errs = {n: worst_error(n, parts=(0,))[0] for n in (16, 24, 32)}
    errs_sc = {n: worst_error(n, parts=(1,))[0] for n in (16, 24, 32)}
    sp = speed()
    found = detection()
    found_pt = detection_path_traced()
    pk = pk_errors()
    pt = path_traced()
    kl = known_lights()
    lines = [BEGIN, "",
             f"Measured by `python tools/lights.py` on {cpu_name()} ({__import__('os').cpu_count()} cores), PoCL.", "",
             "Worst relative error of the airlight and of its twice-scattered part against the float64",
             "reference, over the 108 geometries x 10 pixels of `tests/test_lights.py`, on pixels holding at",
             "least 1e-3 of the case's peak:", "",
             "| `render.lights.nodes` | " + " | ".join(f"{n}" + (" (default)" if n == LightsRender().nodes else "")
                                                     for n in errs) + " |",
             "|---|" + "---|" * len(errs),
             "| airlight A (the `airlight` AOV) | " + " | ".join(f"{e:.1e}" for e in errs.values()) + " |",
             "| its twice-scattered part | " + " | ".join(f"{e:.1e}" for e in errs_sc.values()) + " |", "",
             "Point lights in homogeneous media do not use the nodes: their airlight comes from tables",
             "(`fogcli/physics/airlight_table.py`), directional lights in homogeneous media from a closed form.",
             "`tests/test_lights.py` also holds the table kernel against the quadrature kernel over whole",
             "frames: airlight within 1e-3, the twice-scattered part (a difference of two table values)",
             "within 3e-3.", "",
             f"Speed at 1920 x 1080 (kernel time, best of 5, one run): one point light in fog costs "
             f"{sp['stage']:.0f} ms = {sp['stage'] / sp['copy']:.0f} numpy copies of the image as "
             f"docs/performance.md counts them (the RGBA float32 image copied into fresh memory, "
             f"{sp['copy']:.1f} ms), or {sp['stage'] / sp['copy_warm']:.0f} copies of the bandwidth alone (the RGB "
             f"image copied into memory already mapped, {sp['copy_warm']:.1f} ms); the fog itself "
             f"{sp['base']:.0f} ms. Of the light's cost, its airlight kernel (`airlight_table_grey`: fog is grey, "
             f"one channel integrated) is {sp['kernel']:.0f} ms, the rest adds its twice-scattered part to level "
             "0 and its light after the pyramid. A chromatic medium (sea water) integrates three channels "
             f"(`airlight_table`): {sp['kernel_rgb']:.0f} ms = {sp['kernel_rgb'] / sp['copy']:.0f} / "
             f"{sp['kernel_rgb'] / sp['copy_warm']:.0f} copies.", "",
             "Lamps found by `{type: auto}` on synthetic disc lamps facing the camera (anti-aliased, radiance",
             "(300, 250, 200); expected intensity L pi r^2 cos(theta)):", "",
             "| lamp centre (m) | radius (m) | intensity error (worst channel) | distance error |", "|---|---|---|---|",
             *[f"| ({c[0]:g}, {c[1]:g}, {c[2]:g}) | {r:g} | {ei:.2%} | {ed:.2%} |" for c, r, ei, ed in found], "",
             "The same on the path tracer's vacuum image of the `lamps` scene (256 x 192, emissive spheres",
             "and a disc of 2.5-3.5 px radius; the lamp at (-14, -5, -36) is partly hidden behind the one at",
             "(-2, -0.8, -5), which lies in nearly the same direction: one bright blob at two depths, split",
             "by depth; where the two cores meet, each pixel is split between the lamps along the line",
             "between their colours, `lights._unmix`):", "",
             "| lamp centre (m) | radius (m) | distance error | intensity error R, G, B |", "|---|---|---|---|",
             *[f"| ({c[0]:g}, {c[1]:g}, {c[2]:g}) | {r:g} | {ed:+.2%} | "
               + ", ".join(f"{v:+.1%}" for v in ei) + " |" for c, r, ed, ei, _ in found_pt], "",
             f"Within 2 % of the distance: {sum(abs(x[2]) <= 0.02 for x in found_pt)} of {len(found_pt)}; "
             f"intensity within 5 %: {sum(x[4] <= 0.05 for x in found_pt)} of {len(found_pt)}.", "",
             "`airlight: pk` (Pradhan & Kumar's fits) against the float64 reference, isotropic homogeneous media",
             "(sigma_t 0.05-0.5), point lights around the camera, 360 pixels; relative error of the airlight:", "",
             "| light on the ray | sigma_t R | pixels | median | 90th percentile | max |", "|---|---|---|---|---|---|",
             *[f"| {k[0]} | {k[1]} | {len(v)} | {np.median(v):.1e} | {np.percentile(v, 90):.1e} | {max(v):.1e} |"
               for k, v in sorted(pk.items())], "",
             "Against the path-traced scenes with lamps (`tools/groundtruth`, lamps as emissive surfaces),",
             "relative L1 / SSIM of the default pipeline and of the same with `lights: [{type: auto}]`:", "",
             "| case | default | + lamps found |", "|---|---|---|",
             *[f"| {n} | {a:.3f} / {b:.3f} | {c:.3f} / {d:.3f} |" for n, a, b, c, d in pt], "",
             f"Better with the lamps found: {sum(c < a for _, a, _, c, _ in pt)} of {len(pt)} cases; "
             f"largest change {max(c - a for _, a, _, c, _ in pt):+.3f}, mean {np.mean([c - a for _, a, _, c, _ in pt]):+.4f} "
             "(negative: closer to the path tracer).", "",
             "Night scenes with known point lights (`tools/groundtruth/renders-lights`, rendered by",
             "`tools/groundtruth/equiangular.py`, a path tracer of the same scenes that samples each",
             "light's in-scattering equiangularly on every segment of the walk; nothing in them reflects, so",
             "the lights show only through the medium; `quay` continues past the frame with a light outside",
             "it and one behind the camera, `yard` is closed and held out): relative L1 / SSIM of the default",
             "pipeline without lights and with the scene's lights as `lights:` entries; noise: the path",
             "tracer's own relative L1 at full resolution (about 4x lower on 4 x 4 blocks).", "",
             "| case | held out | noise | no lights | with lights | no lights, 4x4 blocks | with lights, 4x4 blocks | energy |",
             "|---|---|---|---|---|---|---|---|",
             *[f"| {r[0]} | {'yes' if r[1] else ''} | {r[2]:.3f} | {r[3]:.3f} / {r[4]:.3f} | {r[7]:.3f} / {r[8]:.3f} | "
               f"{r[5]:.3f} / {r[6]:.3f} | {r[9]:.3f} / {r[10]:.3f} | {r[11]:.2f} |" for r in kl], "",
             "energy: scattered light with lights (image minus the attenuated direct light) over the path",
             "tracer's.", "",
             *([f"Means with lights: {np.mean([r[7] for r in kl]):.3f} / {np.mean([r[8] for r in kl]):.3f} (full), "
                f"{np.mean([r[9] for r in kl]):.3f} / {np.mean([r[10] for r in kl]):.3f} (blocks); held out only: "
                f"{np.mean([r[7] for r in kl if r[1]] or [np.nan]):.3f} / {np.mean([r[8] for r in kl if r[1]] or [np.nan]):.3f} (full), "
                f"{np.mean([r[9] for r in kl if r[1]] or [np.nan]):.3f} / {np.mean([r[10] for r in kl if r[1]] or [np.nan]):.3f} (blocks). "
                f"Better with lights: {sum(r[7] < r[3] for r in kl)} of {len(kl)} cases.", ""] if kl else []), END]
    text = "\n".join(lines)
    print(text)
    write_block(DOC, BEGIN, END, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
