"""fogcli against path tracing (issue 8): every committed render of
tools/groundtruth/renders (Mitsuba 3, made by tools/groundtruth/render.py),
through exp(-beta d) blending, `psf: gaussian` (the Gaussian model) and `psf: apsf` with
each border policy and emission profile; relative L1 and SSIM (tools/metrics.py) per case,
the scattered energy against the path tracer's, and means per group.

    python tools/groundtruth.py [--pictures] [--doc docs/physics.md]

Needs only numpy and fogcli (the renders are committed); about 2 minutes on 2 cores.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import platform
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent


def _groundtruth_module(name: str):
    """tools/groundtruth/<name>.py by path: `groundtruth` here is this file, not that folder."""
    spec = importlib.util.spec_from_file_location(f"gt_{name}", ROOT / "groundtruth" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


gt_load = _groundtruth_module("load")
gt_scenes = _groundtruth_module("scenes")

from fogcli import apply  # noqa: E402
from fogcli.api import make_config  # noqa: E402
from metrics import rel_l1, ssim  # noqa: E402

VARIANTS = {
    "gaussian": ["render.psf=gaussian", "render.border=closed"],
    "apsf open": ["render.psf=apsf", "render.border=open", "render.emission_profile=isotropic"],
    "apsf closed": ["render.psf=apsf", "render.border=closed", "render.emission_profile=isotropic"],
    "apsf open lamb": ["render.psf=apsf", "render.border=open", "render.emission_profile=lambertian"],
    "apsf closed lamb": ["render.psf=apsf", "render.border=closed", "render.emission_profile=lambertian"],
    "apsf extend lamb": ["render.psf=apsf", "render.border=extend", "render.emission_profile=lambertian"],
    "apsf extend lamb, no ground": ["render.psf=apsf", "render.border=extend", "render.emission_profile=lambertian",
                                    "render.ground=none"],
    "apsf extend lamb, halo none": ["render.psf=apsf", "render.border=extend", "render.emission_profile=lambertian",
                                    "render.halo_depth=none"],
    "apsf extend lamb, pixels": ["render.psf=apsf", "render.border=extend", "render.emission_profile=lambertian",
                                 "render.spread_space=pixels"],
}
BORDERS = ("open", "closed", "extend")


def case_sets(meta: dict) -> list[str]:
    """The path tracer's medium and camera as fogcli config keys. Depth is ray length; the
    sky dome is at a finite distance, so max_depth must not clamp it."""
    return [f"medium.absorption={list(map(float, meta['sigma_a']))}",
            f"medium.scattering={list(map(float, meta['sigma_s']))}",
            f"medium.asymmetry={float(meta['g'])}", f"camera.fov={float(meta['fov'])}",
            "camera.depth=distance", "camera.max_depth=100000"]


def blend(case) -> np.ndarray:
    st = np.asarray(case["meta"]["sigma_a"]) + np.asarray(case["meta"]["sigma_s"])
    return case["L"] * np.exp(-st * case["depth"][..., None])


def blocks(img: np.ndarray, n: int = 4) -> np.ndarray:
    """n x n box averages: the path tracer's noise drops by about n, the fog's structure
    (glows of several pixels and more) stays."""
    h, w = img.shape[0] // n * n, img.shape[1] // n * n
    return img[:h, :w].reshape(h // n, n, w // n, n, -1).mean(axis=(1, 3))


def run_case(case, variants=VARIANTS, reference=True, profile="lambertian") -> dict:
    """Every variant on one case; the references (apsf, each border) with the emission
    `profile` of the default, and the pyramid of that profile against them."""
    L, depth, gt = case["L"], case["depth"], case["medium"]
    sets = case_sets(case["meta"])
    direct = blend(case)
    out = {"blend": direct}
    for name, extra in variants.items():
        out[name] = apply(L, depth, make_config(None, sets=sets + extra))
    if reference:
        for border in BORDERS:
            out[f"reference {border}"] = apply(L, depth, make_config(None, sets=sets + [
                "render.psf=apsf", f"render.border={border}", "render.method=reference",
                f"render.emission_profile={profile}"]))
    gt_sc = float((gt - direct).sum())
    res = {}
    gt4 = blocks(gt)
    for name, img in out.items():
        sc = float((img - direct).sum())
        res[name] = {"rel_l1": rel_l1(img, gt), "ssim": ssim(img, gt),
                     "rel_l1_b4": rel_l1(blocks(img), gt4), "ssim_b4": ssim(blocks(img), gt4),
                     "energy": sc / gt_sc if abs(gt_sc) > 1e-12 else float("nan")}
    for border in BORDERS:
        if f"reference {border}" in out:
            ref = out[f"reference {border}"]
            # the reference spreads every pixel alike whatever the receiver's depth, over the
            # image's pixels: the pyramid against it without its receiver weight
            # (render.halo_depth) and in its space (render.spread_space)
            pyr = apply(L, depth, make_config(None, sets=sets + [
                "render.psf=apsf", f"render.border={border}", f"render.emission_profile={profile}",
                "render.halo_depth=none", "render.spread_space=pixels"]))
            res[f"reference {border}"]["vs_ref"] = (rel_l1(pyr, ref), ssim(pyr, ref))
    return res, out


def unseen_lamps(scene: str) -> list[dict]:
    """The lamps (emissive spheres) of a scene whose centre the frame does not show, outside
    it or behind the camera, as fogcli point lights of the same intensity (radiance x pi r^2,
    a sphere's in every direction): what a user who knows them gives as `lights:`."""
    S = gt_scenes
    out = []
    for sh in S.SCENES[scene]["build"]():
        if sh.get("kind") != "sphere" or not isinstance(sh.get("radiance"), list):
            continue
        x, y, z = sh["pos"]
        r = float(sh["scale"])
        if x * x + y * y + z * z <= r * r:        # the sky dome, around the camera
            continue
        if z < 0 and abs(x / -z) <= S.TAN_X and abs(y / -z) <= S.TAN_Y:
            continue
        out.append({"type": "point", "position": [float(x), float(y), float(z)], "radius": r,
                    "intensity": [float(v) * np.pi * r * r for v in sh["radiance"]]})
    return out


def unseen_rows(rows, default_imgs) -> list[str]:
    """The cases with lamps the frame cannot show: the default without and with them given as
    lights (relative L1 / SSIM, energy), and the held-out mean either way."""
    out, means = [], []
    for case, res in rows:
        lamps = unseen_lamps(case["scene"])
        base = (res[default_imgs]["rel_l1"], res[default_imgs]["ssim"])
        if not lamps:
            if case["meta"]["heldout"]:
                means.append((base, base))
            continue
        img = apply(case["L"], case["depth"], make_config(None, sets=case_sets(case["meta"]) + [
            f"lights={json.dumps(lamps)}"]))
        gt, direct = case["medium"], blend(case)
        lit = (rel_l1(img, gt), ssim(img, gt))
        if case["meta"]["heldout"]:
            means.append((base, lit))
        out.append(f"| {case['name']} | {'yes' if case['meta']['heldout'] else ''} | {len(lamps)} | {base[0]:.3f} / {base[1]:.3f} | {lit[0]:.3f} / {lit[1]:.3f} | "
                   f"{res[default_imgs]['energy']:.2f} | {float((img - direct).sum() / (gt - direct).sum()):.2f} |")
    if not out:
        return []
    m = np.mean([[b[0], b[1], w[0], w[1]] for b, w in means], axis=0)
    return ["### What the frame cannot show, given as lights\n",
            "Cases with lamps whose centre is outside the frame or behind the camera: the default, "
            "and the default with those lamps given as `lights:` (point lights of the lamp's position, "
            "intensity radiance x pi r^2 and radius r), as a user who knows them would.\n",
            "| case | held out | lamps given | default | with them | energy | energy with them |",
            "|---|---|---|---|---|---|---|",
            *out, "",
            f"Held-out mean (all {len(means)} cases, the others as they are): {m[0]:.3f} / {m[1]:.3f} without, "
            f"{m[2]:.3f} / {m[3]:.3f} with the unseen lamps given.", ""]


def _png(path: Path, row: list[np.ndarray]) -> None:
    import cv2

    tiles = []
    for img in row:
        t = 1.0 - np.exp(-np.maximum(img, 0.0) * 2.0)           # the SSIM tone map, brighter
        tiles.append(np.clip(t, 0, 1) ** (1 / 2.2))
        tiles.append(np.ones((img.shape[0], 4, 3)))
    im = (np.concatenate(tiles[:-1], axis=1) * 255 + 0.5).astype(np.uint8)
    cv2.imwrite(str(path), im[:, :, ::-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--doc", help="write this markdown file (docs/physics.md)")
    ap.add_argument("--pictures", nargs="*", default=None,
                    help="case names for picture rows in docs/images (default: three)")
    ap.add_argument("--only", help="regular expression: only the cases whose name matches")
    ap.add_argument("--default", default=None, help="variant that is fogcli's default (from the config)")
    args = ap.parse_args()
    from fogcli.config.model import Render

    r = Render()
    default = args.default or (f"apsf {r.border}" + (" lamb" if r.emission_profile == "lambertian" else ""))
    t0 = time.time()
    rows = []
    pics = {}
    want_pics = set(args.pictures) if args.pictures else {"lamps-fog", "ground-haze", "street-sea"}
    import re

    for case in gt_load.cases():
        if args.only and not re.search(args.only, case["name"]):
            continue
        res, imgs = run_case(case, profile=r.emission_profile)
        rows.append((case, res))
        if case["name"] in want_pics:
            pics[case["name"]] = (case["medium"], imgs[default], imgs["blend"])
        print(f"{case['name']:<22} " + "  ".join(
            f"{k}: {v['rel_l1']:.3f}/{v['ssim']:.3f}" for k, v in res.items()), flush=True)
    names = ["blend", *VARIANTS, *(f"reference {b}" for b in BORDERS)]
    groups = {
        "nothing outside the frame": lambda c: not c["meta"]["outside"],
        "continues past the frame": lambda c: c["meta"]["outside"],
        "calibration scenes": lambda c: not c["meta"]["heldout"],
        "held-out scenes": lambda c: c["meta"]["heldout"],
        "held out, nothing outside": lambda c: c["meta"]["heldout"] and not c["meta"]["outside"],
        "held out, continues": lambda c: c["meta"]["heldout"] and c["meta"]["outside"],
        "all": lambda c: True,
    }
    cpu = _cpu()
    lines = [f"Measured {time.strftime('%Y-%m-%d')} on {cpu}, {time.time() - t0:.0f} s, by "
             "`python tools/groundtruth.py --doc docs/physics.md`. Each cell: relative L1 / "
             "SSIM against the path-traced image (lower / higher is closer). Default: "
             f"`{default}`; the references use the default's emission profile. energy: the default's scattered light (image minus the attenuated "
             "direct light L exp(-sigma_t d)) over the path tracer's.\n"]
    summary = {}
    for suffix, title in (("", "full resolution (256 x 192)"),
                          ("_b4", "4 x 4 pixel blocks (the path tracer's noise about 4x lower)")):
        lines.append(f"### Per case, {title}\n")
        lines.append("| case | outside | held out | noise | " + " | ".join(names) + " | energy |")
        lines.append("|---|---|---|---|" + "---|" * len(names) + "---|")
        for case, res in rows:
            m = case["meta"]
            noise = case["noise"] / (4 if suffix else 1)
            lines.append(f"| {case['name']} | {'yes' if m['outside'] else 'no'} | {'yes' if m['heldout'] else ''} | "
                         f"{noise:.3f} | " + " | ".join(f"{res[n]['rel_l1' + suffix]:.3f} / {res[n]['ssim' + suffix]:.3f}"
                                                        for n in names)
                         + f" | {res[default]['energy']:.2f} |")
        lines.append("")
        lines.append(f"Means per group, {title}:\n")
        lines.append("| group | cases | " + " | ".join(names) + " |")
        lines.append("|---|---|" + "---|" * len(names))
        for gname, pred in groups.items():
            sel = [res for case, res in rows if pred(case)]
            if not sel:
                continue
            cells = []
            for n in names:
                l1 = float(np.mean([r[n]["rel_l1" + suffix] for r in sel]))
                sm = float(np.mean([r[n]["ssim" + suffix] for r in sel]))
                summary[(gname + suffix, n)] = (l1, sm)
                cells.append(f"{l1:.3f} / {sm:.3f}")
            lines.append(f"| {gname} | {len(sel)} | " + " | ".join(cells) + " |")
        lines.append("")
    lines.append(f"### Pyramid against its own reference (`psf: apsf`, emission profile {r.emission_profile}, "
                 "same border, `halo_depth: none` and `spread_space: pixels`: the reference has no receiver "
                 "weight and spreads over the image's pixels), relative L1 / SSIM\n")
    lines.append("| group | " + " | ".join(BORDERS) + " |\n|---|" + "---|" * len(BORDERS))
    for gname, pred in groups.items():
        sel = [res for case, res in rows if pred(case)]
        if not sel:
            continue
        cells = []
        for b in BORDERS:
            cells.append(f"{np.mean([r[f'reference {b}']['vs_ref'][0] for r in sel]):.3f} / "
                         f"{np.mean([r[f'reference {b}']['vs_ref'][1] for r in sel]):.3f}")
        lines.append(f"| {gname} | " + " | ".join(cells) + " |")
    lam = " lamb" if r.emission_profile == "lambertian" else ""
    lines.append("")
    lines.append("### Scattered energy over the path tracer's, per border policy (scenes that continue past the frame)\n")
    lines.append("| case | " + " | ".join(BORDERS) + " |\n|---|" + "---|" * len(BORDERS))
    for case, res in rows:
        if case["meta"]["outside"]:
            lines.append(f"| {case['name']} | " + " | ".join(f"{res[f'apsf {b}{lam}']['energy']:.2f}" for b in BORDERS)
                         + " |")
    worse = [case["name"] for case, res in rows if res[default]["rel_l1"] >= res["blend"]["rel_l1"]]
    lines.append("")
    lines += unseen_rows(rows, default)
    lines.append(f"Default (`{default}`) cases not closer than blending in relative L1: "
                 f"{', '.join(worse) if worse else 'none'}.")
    text = "\n".join(lines)
    print(text)
    if args.doc:
        img_dir = Path(args.doc).parent / "images"
        img_dir.mkdir(parents=True, exist_ok=True)
        pic_lines = []
        for name, (gt, ours, bl) in sorted(pics.items()):
            p = img_dir / f"physics-{name}.png"
            _png(p, [gt, ours, bl, np.abs(ours - gt) * 4])
            pic_lines.append(f"![{name}](images/{p.name})\n\n*{name}: path traced | fogcli default | "
                             f"exp(-beta d) blending | 4x |fogcli - path traced|*\n")
        doc = Path(args.doc)
        from docblock import markers, write_block

        begin, end = markers("groundtruth")
        write_block(doc, begin, end, "\n".join([begin, text, "", *pic_lines, end]), new_doc="# Physics\n\n")
    per_case = {case["name"]: res for case, res in rows}
    out_json = Path(args.doc).with_suffix(".json") if args.doc else None
    if out_json:
        out_json.write_text(json.dumps({"summary": {f"{g}|{n}": v for (g, n), v in summary.items()},
                                        "cases": per_case, "default": default}, indent=1, default=float))


def _cpu() -> str:
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip() + f" ({__import__('os').cpu_count()} cores)"
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


if __name__ == "__main__":
    main()
