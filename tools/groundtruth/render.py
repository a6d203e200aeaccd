"""Render the ground truth: every scene x medium with Mitsuba 3 (volpath), plus convention checks.

    python tools/groundtruth/render.py                     # all cases
    python tools/groundtruth/render.py --only lamps         # one scene, all media
    python tools/groundtruth/render.py --only lamps-fog --spp 512
    python tools/groundtruth/render.py --check              # camera/depth/absorption checks
    python tools/groundtruth/render.py --table              # rewrite the README's table

Writes tools/groundtruth/renders/<scene>-<medium>.npz (keys L, depth, depth_mean, medium,
noise, meta). The medium image is the mean of two independent halves A and B (different seeds);
noise = sum|A - B| / sum(A + B) over all pixels and channels, which for unbiased, independent
halves estimates the relative L1 error of the stored mean (A + B)/2 against the converged image
(each half alone has ~sqrt(2) times that error).

Variant: llvm_ad_rgb when Dr.Jit can load an LLVM >= 16 (Debian's LLVM 14/15 abort on an
`fminimum` instruction; `apt-get install libllvm19` works, found through DRJIT_LIBLLVM_PATH),
otherwise scalar_rgb (about as fast on 2 cores for these scenes). Threads: 2.
"""
import argparse
import glob
import json
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "renders")
OUT_LIGHTS = os.path.join(HERE, "renders-lights")     # scenes with point lights (scenes.LIGHTS)
sys.path.insert(0, HERE)
import scenes as S  # noqa: E402
from load import NOISE_DEF, alternate_halves, halves_noise  # noqa: E402

NEAR_CLIP = 1e-4            # the sensor's near plane; Mitsuba's depth AOV starts there (corrected)
L_SPP = 256                 # vacuum image (pixel-averaged emitted radiance)
DEPTH_MEAN_SPP = 64         # pixel-averaged depth
ABSORB_SPP = 256            # per half, absorption-only check
PASS_SPP = 32               # the medium image is accumulated in passes of this many spp


def _pick_variant(requested):
    import mitsuba as mi
    if requested:
        return requested
    for p in ["/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
              "/usr/lib/x86_64-linux-gnu/libLLVM-18.so", "/usr/lib/x86_64-linux-gnu/libLLVM-17.so",
              "/usr/lib/x86_64-linux-gnu/libLLVM-16.so"]:
        if os.path.exists(p) and "llvm_ad_rgb" in mi.variants():
            return "llvm_ad_rgb"
    return "scalar_rgb"


def _setup(variant):
    for p in ["/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", "/usr/lib/x86_64-linux-gnu/libLLVM-18.so",
              "/usr/lib/x86_64-linux-gnu/libLLVM-17.so", "/usr/lib/x86_64-linux-gnu/libLLVM-16.so"]:
        if os.path.exists(p):
            os.environ.setdefault("DRJIT_LIBLLVM_PATH", p)
            break
    import mitsuba as mi
    import drjit as dr
    v = _pick_variant(variant)
    mi.set_variant(v)
    dr.set_thread_count(2)
    return mi, v


def _scene(mi, name, medium=None, **kw):
    d = S.mitsuba_scene(name, medium, **kw)
    d["sensor"]["near_clip"] = NEAR_CLIP
    return mi.load_dict(d)


def render_L(mi, name, spp=L_SPP, seed=0, width=S.WIDTH, height=S.HEIGHT, fov=S.FOV):
    """Emitted radiance in vacuum, pixel-averaged (box filter). Surfaces are black: 1 bounce."""
    sc = _scene(mi, name, None, integrator={"type": "path", "max_depth": 1}, spp=spp,
                width=width, height=height, fov=fov)
    return np.array(mi.render(sc, spp=spp, seed=seed), np.float32)


def render_depth(mi, name, centre=True, spp=DEPTH_MEAN_SPP, width=S.WIDTH, height=S.HEIGHT, fov=S.FOV):
    """Ray length per pixel: at the pixel centre (stratified, 1 spp, no jitter) or pixel-averaged.
    Mitsuba's `depth` AOV is the distance from the near plane; add it back (NEAR_CLIP * |d|)."""
    if centre:
        smp = {"type": "stratified", "sample_count": 1, "jitter": False}
        spp = 1
    else:
        smp = {"type": "independent", "sample_count": spp}
    sc = _scene(mi, name, None, integrator={"type": "aov", "aovs": "dd.y:depth"}, sampler=smp,
                width=width, height=height, fov=fov)
    a = np.array(mi.render(sc, spp=spp, seed=0), np.float64)[..., 0]
    miss = a <= 0
    a = a + NEAR_CLIP * np.linalg.norm(S.camera_directions(width, height, fov), axis=-1)
    a[miss] = np.inf
    return a.astype(np.float32)


def grey_parts(m):
    """Mitsuba's volpath is biased for CHROMATIC sigma_t (absorption-only test: the transmittance
    to a wall at 80 m with sigma_t = 0.25, 0.07, 0.04 comes out x0.67 in every channel, at 45 m x0.90;
    a grey sigma_t is exact). So a chromatic medium is rendered as three GREY media, one per RGB
    channel (that channel's sigma_s, sigma_a), keeping channel c of render c. Returns [(medium, c)],
    c = None for all channels."""
    s, a = np.asarray(m["sigma_s"], float), np.asarray(m["sigma_a"], float)
    if np.allclose(s + a, (s + a)[0]):
        return [(m, None)]
    return [(dict(sigma_s=[s[c]] * 3, sigma_a=[a[c]] * 3, g=m["g"]), c) for c in range(3)]


class MediumRenderer:
    def __init__(self, mi, name, medium, max_depth=-1, rr_depth=5):
        self.mi = mi
        self.parts = [(_scene(mi, name, pm, max_depth=max_depth, rr_depth=rr_depth), c)
                      for pm, c in grey_parts(medium)]

    def render(self, spp, seed):
        out = None
        for k, (sc, c) in enumerate(self.parts):
            img = np.array(self.mi.render(sc, spp=spp, seed=seed + 7919 * k), np.float64)
            if c is None:
                return img
            out = np.zeros_like(img) if out is None else out
            out[..., c] = img[..., c]
        return out


def render_medium(mi, name, medium, spp, max_depth, rr_depth, budget_s, target, seed0, log, start=None):
    """start: (sum A, sum B, spp A, spp B) of an earlier render to add samples to (--resume)."""
    sc = MediumRenderer(mi, name, S.MEDIA[medium] if isinstance(medium, str) else medium,
                        max_depth=max_depth, rr_depth=rr_depth)
    acc, n = (start[:2], start[2:]) if start else ((0.0, 0.0), (0, 0))
    sa, sb, na, nb, noise, el = alternate_halves(
        lambda k: sc.render(PASS_SPP, seed0 + k) * PASS_SPP, PASS_SPP,
        lambda na, nb, noise, el: na + nb >= spp or el > budget_s or noise <= target, log,
        (n[0] + n[1]) // PASS_SPP, acc, n)
    return (sa + sb) / (na + nb), noise, na + nb, el, (sa / na, sb / nb, na, nb)


def resume_case(mi, variant, scene, medium, args, log):
    """More samples for a stored Mitsuba render: its halves go on, or, where only the mean was
    kept, that mean is half A and the new passes (seeds after the old ones) fill B, then both."""
    path = os.path.join(OUT, f"{scene}-{medium}.npz")
    with np.load(path) as z:
        d = {k: z[k] for k in z.files}
    meta = json.loads(str(d["meta"]))
    if meta.get("integrator") != "volpath":
        raise SystemExit(f"{path}: its medium is by {meta.get('integrator')}; resume it with that tool")
    if "half_a" in d:
        na, nb = meta["spp_halves"]
        start = (d["half_a"].astype(np.float64) * na, d["half_b"].astype(np.float64) * nb, na, nb)
    else:
        start = (d["medium"].astype(np.float64) * meta["spp"], 0.0, meta["spp"], 0)
    img, noise, spp, tm, halves = render_medium(mi, scene, medium, args.spp, args.max_depth, args.rr_depth,
                                                args.budget, args.target, meta["seed0"], log, start)
    meta.update(spp=spp, noise=noise, seconds_medium=round(meta["seconds_medium"] + tm, 1),
                spp_halves=[int(halves[2]), int(halves[3])], resumed_variant=variant)
    d.update(medium=img.astype(np.float32), noise=np.float64(noise), meta=json.dumps(meta),
             half_a=halves[0].astype(np.float32), half_b=halves[1].astype(np.float32))
    tmp = path[:-4] + ".tmp.npz"
    np.savez_compressed(tmp, **d)
    os.replace(tmp, path)
    return meta


def case_names(only, lights=False):
    names = [(s, m) for s in S.SCENES for m in S.MEDIA if bool(S.SCENES[s].get("lights")) == lights]
    if not only:
        return names
    sel = []
    for tok in only.split(","):
        sel += [(s, m) for s, m in names if tok in (s, m, f"{s}-{m}")]
    return sel


def render_case(mi, variant, scene, medium, args, log):
    t0 = time.time()
    L = render_L(mi, scene)
    depth = render_depth(mi, scene, centre=True)
    depth_mean = render_depth(mi, scene, centre=False)
    seed0 = 1000 * (list(S.SCENES).index(scene) * 10 + list(S.MEDIA).index(medium)) + 1
    img, noise, spp, tm, _ = render_medium(mi, scene, medium, args.spp, args.max_depth, args.rr_depth,
                                           args.budget, args.target, seed0, log)
    m = S.MEDIA[medium]
    meta = dict(scene=scene, medium=medium, fov=S.FOV, fov_axis="horizontal", width=S.WIDTH,
                height=S.HEIGHT, sigma_a=m["sigma_a"], sigma_s=m["sigma_s"], g=m["g"],
                outside=S.SCENES[scene]["outside"], heldout=S.SCENES[scene]["heldout"],
                spp=spp, L_spp=L_SPP, depth="ray length at the pixel centre (depth_mean: pixel-averaged, "
                f"{DEPTH_MEAN_SPP} spp)", max_depth=args.max_depth, rr_depth=args.rr_depth,
                integrator="volpath", rfilter="box",
                per_channel_grey=len(grey_parts(m)) > 1, noise=noise, noise_definition=NOISE_DEF,
                mitsuba_version=mi.__version__, variant=variant, seconds=round(time.time() - t0, 1),
                seconds_medium=round(tm, 1), seed0=seed0)
    if S.SCENES[scene].get("lights"):
        meta["lights"] = [{"position": list(p), "intensity": list(map(float, i))} for p, i in S.LIGHTS[scene]]
    out = OUT_LIGHTS if S.SCENES[scene].get("lights") else OUT
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, f"{scene}-{medium}.npz")
    np.savez_compressed(path, L=L.astype(np.float16), depth=depth, depth_mean=depth_mean,
                        medium=img.astype(np.float32), noise=np.float64(noise), meta=json.dumps(meta))
    return meta


def checks(mi, log):
    """Camera mapping, depth convention and an absorption-only energy check."""
    res = {}
    D = S.camera_directions()
    norm = np.linalg.norm(D, axis=-1)
    # 1. a plane at 10 m exactly filling the frustum + a small red sphere at pixel (200, 40).
    p = D[40, 200] * 8.0
    shapes = [S.frustum_rect(10.0, 1.0), dict(kind="sphere", pos=p.tolist(), scale=0.05, radiance=[100.0, 0, 0])]
    dep = render_depth(mi, shapes, centre=True)
    mask = np.ones_like(dep, bool)
    mask[30:52, 188:212] = False
    rel = np.abs(dep / (10.0 * norm) - 1)[mask]
    res["plane_depth_rel_err_max"] = float(rel.max())
    res["plane_depth_rel_err_mean"] = float(rel.mean())
    res["sphere_depth"] = float(dep[40, 200])
    res["sphere_depth_expected"] = float(8.0 * norm[40, 200] - 0.05)
    Lc = render_L(mi, shapes, spp=64)
    red = Lc[..., 0] - Lc[..., 1]
    jj, ii = np.nonzero(red > 1)
    w = red[jj, ii]
    res["red_sphere_centroid_col_row"] = [float((ii * w).sum() / w.sum() + 0.5), float((jj * w).sum() / w.sum() + 0.5)]
    res["red_sphere_expected_col_row"] = [200.5, 40.5]
    log(f"  camera/depth: {res}")
    # 2. nothing emissive outside the frame for outside=False scenes: render wider (fov 90, same
    #    aspect) and check that the band outside the original frustum is black.
    for name, spec in S.SCENES.items():
        if spec["outside"]:
            continue
        W2 = 384
        H2 = 288
        sc = mi.load_dict(S.mitsuba_scene(name, None, integrator={"type": "path", "max_depth": 1}, spp=16,
                                          fov=2 * math.degrees(math.atan(S.TAN_X * 1.5)), width=W2, height=H2))
        a = np.array(mi.render(sc, spp=16, seed=0))
        inner = np.zeros(a.shape[:2], bool)
        inner[H2 // 6:H2 - H2 // 6, W2 // 6:W2 - W2 // 6] = True      # the original frame, exactly
        res[f"outside_energy_{name}"] = float(a[~inner].sum() / max(a.sum(), 1e-30))
        log(f"  {name}: fraction of emitted radiance outside the frame (wider render): "
            f"{res[f'outside_energy_{name}']:.2e}")
    # 3. absorption only: medium image must equal L * exp(-sigma_t * depth). volpath estimates the
    #    transmittance by free-flight sampling (a path survives with probability ~T), so the render is
    #    noisy: report the per-pixel relative L1 together with the render's own noise (two halves),
    #    the per-channel ratio of sums, and the relative L1 after 8x8 block averaging.
    for name in ["objects", "street", "lamps"]:
        med = dict(sigma_s=[0.0, 0.0, 0.0], sigma_a=[0.25, 0.07, 0.04], g=0.0)
        st = np.asarray(med["sigma_a"])
        L = render_L(mi, name).astype(np.float64)
        dc = render_depth(mi, name, centre=True).astype(np.float64)
        dm = render_depth(mi, name, centre=False).astype(np.float64)
        sc = MediumRenderer(mi, name, med)
        A = sc.render(ABSORB_SPP, 7)
        B = sc.render(ABSORB_SPP, 8)
        img = (A + B) / 2
        r = {"spp": 2 * ABSORB_SPP, "render_noise": halves_noise(A, B)}
        for key, d in [("centre", dc), ("pixelmean", dm)]:
            pred = L * np.exp(-st * np.where(np.isfinite(d), d, 1e9)[..., None])
            r[f"relL1_{key}depth"] = float(np.abs(img - pred).sum() / pred.sum())
            r[f"ratio_of_sums_rgb_{key}depth"] = [float(x) for x in img.sum((0, 1)) / pred.sum((0, 1))]
            bi = img.reshape(24, 8, 32, 8, 3).mean((1, 3))
            bp = pred.reshape(24, 8, 32, 8, 3).mean((1, 3))
            r[f"relL1_8x8blocks_{key}depth"] = float(np.abs(bi - bp).sum() / bp.sum())
        # exact pixel footprint: L * exp(-sigma_t * depth) evaluated on a 4x4 sub-pixel grid
        # (sub-pixel centres) and averaged, instead of pixel-averaged L times centre depth.
        Ls = render_L(mi, name, spp=16, width=4 * S.WIDTH, height=4 * S.HEIGHT).astype(np.float64)
        ds = render_depth(mi, name, centre=True, width=4 * S.WIDTH, height=4 * S.HEIGHT).astype(np.float64)
        pred = (Ls * np.exp(-st * np.where(np.isfinite(ds), ds, 1e9)[..., None]))
        pred = pred.reshape(S.HEIGHT, 4, S.WIDTH, 4, 3).mean((1, 3))
        r["relL1_subpixel4x4"] = float(np.abs(img - pred).sum() / pred.sum())
        r["ratio_of_sums_rgb_subpixel4x4"] = [float(x) for x in img.sum((0, 1)) / pred.sum((0, 1))]
        bi = img.reshape(24, 8, 32, 8, 3).mean((1, 3))
        bp = pred.reshape(24, 8, 32, 8, 3).mean((1, 3))
        r["relL1_8x8blocks_subpixel4x4"] = float(np.abs(bi - bp).sum() / bp.sum())
        # interior pixels only: the pixel-averaged depth equals the centre depth within 0.1 %
        # (no depth edge inside the pixel), where the centre-depth prediction is exact
        inner = np.isfinite(dc) & (np.abs(dm / dc - 1) < 1e-3)
        pc = L * np.exp(-st * dc[..., None])
        r["interior_fraction"] = float(inner.mean())
        r["relL1_interior_centredepth"] = float(np.abs(img - pc)[inner].sum() / pc[inner].sum())
        r["ratio_of_sums_rgb_interior"] = [float(x) for x in img[inner].sum(0) / pc[inner].sum(0)]
        for lo, hi in [(0, 10), (10, 30), (30, 1e9)]:
            b = inner & (dc >= lo) & (dc < hi)
            if b.any():
                r[f"ratio_of_sums_rgb_interior_depth_{lo}_{hi:g}"] = [float(x) for x in img[b].sum(0) / pc[b].sum(0)]
        res[f"absorb_{name}"] = r
        log(f"  absorption-only {name}: {r}")
    return res


def table():
    rows = []
    for p in sorted(glob.glob(os.path.join(OUT, "*.npz"))):
        z = np.load(p)
        m = json.loads(str(z["meta"]))
        d = z["depth"]
        st = np.asarray(m["sigma_s"]) + np.asarray(m["sigma_a"])
        fin = d[np.isfinite(d)]
        ours = m.get("integrator", "").startswith("equiangular")    # README.md, Analog walks
        rows.append((m["scene"], m["medium"], m["outside"], m["heldout"], "analog walk" if ours else "Mitsuba",
                     m["spp"], m["noise"], m["seconds_medium"] if ours else m["seconds"], float(fin.min()), float(np.percentile(fin, 99)),
                     float(st.mean() * np.percentile(fin, 5)), float(st.mean() * np.median(fin))))
    order = {s: i for i, s in enumerate(S.SCENES)}
    morder = {s: i for i, s in enumerate(S.MEDIA)}
    rows.sort(key=lambda r: (order.get(r[0], 99), morder.get(r[1], 9)))
    lines = ["| case | outside | heldout | medium by | spp | noise | seconds | depth min / p99 (m) | tau p5 / median |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r[0]}-{r[1]} | {str(r[2]).lower()} | {str(r[3]).lower()} | {r[4]} | {r[5]} | {r[6]:.3f} | "
                     f"{r[7]:.0f} | {r[8]:.1f} / {r[9]:.0f} | {r[10]:.2f} / {r[11]:.1f} |")
    return "\n".join(lines)


def write_table():
    readme = os.path.join(HERE, "README.md")
    t = table()
    s = open(readme).read()
    a, b = "<!-- table:start -->", "<!-- table:end -->"
    i, j = s.index(a), s.index(b)
    s = s[:i + len(a)] + "\n" + t + "\n" + s[j:]
    cj = os.path.join(OUT, "checks.json")
    if os.path.exists(cj):
        s = _checks_md(s, json.load(open(cj)))
    open(readme, "w").write(s)
    print(t)


def _checks_md(s, c):
    f = lambda v: f"{v:.3g}" if isinstance(v, float) else "[" + ", ".join(f"{x:.3f}" for x in v) + "]"
    out = ["Camera and depth (plane exactly filling the frustum at 10 m, plus a small red sphere placed "
           "on the ray of pixel (200, 40) at 8 m):",
           f"- depth vs analytic ray length 10 |d|: max relative error {f(c['plane_depth_rel_err_max'])}, "
           f"mean {f(c['plane_depth_rel_err_mean'])};",
           f"- sphere depth {c['sphere_depth']:.4f} m, expected {c['sphere_depth_expected']:.4f} m;",
           f"- red sphere's radiance centroid at (col, row) = {f(c['red_sphere_centroid_col_row'])}, expected "
           f"(200.5, 40.5): neither flipped nor shifted.",
           "", "Nothing outside the frame (`outside: false` scenes, fraction of emitted radiance outside "
           "the frame in a 1.5x wider render): " + ", ".join(
               f"{k[len('outside_energy_'):]} {c[k]:.2g}" for k in c if k.startswith("outside_energy_")) + ".",
           "", "Absorption only (sigma_a = 0.25, 0.07, 0.04, sigma_s = 0): `medium` must equal "
           "L exp(-sigma_t depth). volpath estimates transmittance by free-flight sampling, so the "
           "render is itself noisy (`render_noise`, same definition as above). `centre` uses pixel-"
           "averaged L times exp(-sigma_t depth at the centre); `subpixel4x4` averages "
           "L exp(-sigma_t depth) over a 4x4 sub-pixel grid (the exact footprint, up to 16-sample "
           "aliasing); `8x8 blocks` compares 8x8-pixel block means (noise mostly averaged out); `interior` = "
           "pixels without a depth edge inside (pixel-averaged depth = centre depth within 0.1 %), where "
           "L exp(-sigma_t depth) is exact: there the ratio of sums must be 1 within the noise, in "
           "every depth band. Edge pixels are NOT negligible: a pixel whose centre sees a dim wall at "
           "35 m but whose corner sees a bright object at 18 m is dominated by the object.", "",
           "| scene | spp | render noise | rel L1 centre | rel L1 subpixel4x4 | rel L1 8x8 blocks (subpixel) | sum ratio RGB (subpixel) "
           "| interior fraction | rel L1 interior | sum ratio RGB interior | sum ratio RGB interior by depth |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for k, r in c.items():
        if k.startswith("absorb_"):
            out.append(f"| {k[7:]} | {r['spp']} | {r['render_noise']:.3f} | {r['relL1_centredepth']:.3f} | "
                       f"{r['relL1_subpixel4x4']:.3f} | {r['relL1_8x8blocks_subpixel4x4']:.3f} | "
                       f"{f(r['ratio_of_sums_rgb_subpixel4x4'])} | {r['interior_fraction']:.2f} | "
                       f"{r['relL1_interior_centredepth']:.3f} | {f(r['ratio_of_sums_rgb_interior'])} | "
                       + "; ".join(f"{k.split('depth_')[1].replace('_', '-')} m: {f(v)}" for k, v in r.items()
                                   if k.startswith("ratio_of_sums_rgb_interior_depth")) + " |")
    a, b = "<!-- checks:start -->", "<!-- checks:end -->"
    i, j = s.index(a), s.index(b)
    return s[:i + len(a)] + "\n" + "\n".join(out) + "\n" + s[j:]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", help="scene, medium or scene-medium names, comma separated")
    ap.add_argument("--spp", type=int, default=4096, help="max total spp of the medium image (both halves)")
    ap.add_argument("--budget", type=float, default=80.0, help="seconds per medium render (stops earlier)")
    ap.add_argument("--target", type=float, default=0.03, help="stop when noise <= this")
    ap.add_argument("--max-depth", type=int, default=-1, help="volpath max_depth (-1: unbounded, RR)")
    ap.add_argument("--rr-depth", type=int, default=5)
    ap.add_argument("--variant", default=None)
    ap.add_argument("--check", action="store_true", help="run the convention checks only")
    ap.add_argument("--table", action="store_true", help="rewrite the README table from the renders")
    ap.add_argument("--lights", action="store_true", help="the night scenes with point lights (renders-lights/)")
    ap.add_argument("--resume", action="store_true", help="add samples to the stored render (halves kept from then on)")
    args = ap.parse_args()
    if args.table:
        write_table()
        return

    def log(s):
        print(s, flush=True)

    mi, variant = _setup(args.variant)
    log(f"mitsuba {mi.__version__}, variant {variant}")
    if args.check:
        res = checks(mi, log)
        os.makedirs(OUT, exist_ok=True)
        with open(os.path.join(OUT, "checks.json"), "w") as f:
            json.dump(res, f, indent=1)
        return
    for scene, medium in case_names(args.only, args.lights):
        log(f"{scene}-{medium}")
        m = (resume_case if args.resume else render_case)(mi, variant, scene, medium, args, log)
        log(f"  done in {m['seconds']} s, noise {m['noise']:.4f}, spp {m['spp']}")


if __name__ == "__main__":
    main()
