"""Low-noise reference renders: the night scenes with point lights (renders-lights/), and with
--analog the scenes of renders/ where Mitsuba's roulette leaves fog's long walks out (README.md,
"Analog walks").

Mitsuba's volpath finds a point light's in-scattering by free-flight sampling, whose variance
near the light grows as 1/R^3: after 10000-20000 spp the held-out renders still had noise
0.11-0.13. This tracer (equiangular.cl, run by fogcli's own OpenCL runtime) samples every
segment of the walk equiangularly towards each light, and is otherwise the same model as the
Mitsuba scenes: the same shapes, textures, uv maps and point lights (scenes.py), an infinite
homogeneous medium with HG phase, black emissive surfaces; Russian roulette from depth 3,
survival at most 0.7.

    python tools/groundtruth/equiangular.py --check          # against Mitsuba's renders
    python tools/groundtruth/equiangular.py --only yard --budget 900 --write
    python tools/groundtruth/equiangular.py --analog --only ground-fog --budget 360 --target 0.025 --write

--check renders every case for --budget seconds and compares with the stored Mitsuba image
(`medium_mitsuba` once --write has replaced `medium`) on 8 x 8 pixel blocks, where Mitsuba's
noise is small, and the vacuum image against Mitsuba's L. --write stores the new image as
`medium` (the Mitsuba one is kept as `medium_mitsuba`) with its noise, spp and seconds in meta.
"""
import argparse
import json
import math
import os
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1] / "src"))
sys.path.insert(0, str(HERE.parent))
import scenes as S  # noqa: E402
from docblock import write_block  # noqa: E402
from load import NOISE_DEF, alternate_halves  # noqa: E402
from metrics import rel_l1  # noqa: E402

RENDERS = HERE / "renders-lights"


def renders(scene):
    """Where a scene's renders live: renders-lights/ for the night scenes, renders/ for the rest."""
    return RENDERS if S.SCENES[scene].get("lights") else HERE / "renders"
PASS_SPP = 16
_PROGRAMS = {}      # one build of equiangular.cl per context and process


def _matrix(shape):
    """Object -> world, as scenes._transform builds it for Mitsuba: translate, rotate, scale."""
    M = np.eye(4)
    M[:3, 3] = shape["pos"]
    for axis, deg in shape.get("rot", []):
        c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        R = np.eye(4)
        R[:3, :3] = {"x": [[1, 0, 0], [0, c, -s], [0, s, c]],      # right-handed, as Mitsuba's
                     "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],      # Transform4f.rotate
                     "z": [[c, -s, 0], [s, c, 0], [0, 0, 1]]}[axis]
        M = M @ R
    sc = shape["scale"]
    M = M @ np.diag(list(sc if isinstance(sc, list) else [sc] * 3) + [1.0])
    return M


def _bitmap(r):
    """(texels (h, w, 3) in Mitsuba's row order, repeats) of a scenes.py radiance spec."""
    if isinstance(r, (int, float)):
        return np.full((1, 1, 3), float(r), np.float32), (1, 1)
    if isinstance(r, list):
        return np.asarray(r, np.float32).reshape(1, 1, 3), (1, 1)
    if r[0] == "checker":
        _, c0, c1, n = r
        return _bitmap(("bitmap", np.array([[c0, c1], [c1, c0]], np.float32), [n, n]))
    _, arr, rep = r
    return np.ascontiguousarray(np.asarray(arr, np.float32)[::-1]), tuple(rep)


KINDS = {"rectangle": 0, "sphere": 1, "cube": 2, "disk": 3}
NEE_STRIDE = 16
NEE_MAX = 32             # equiangular.cl's NEE_MAX


def nee_rows(shapes):
    """equiangular.cl's next-event rows: every emissive sphere seen from outside (a lamp):
    shape id, the weight that picks it (mean radiance times pi r^2), radius, centre."""
    rows = []
    for sid, s in enumerate(shapes):
        if s.get("radiance") is None or s["kind"] != "sphere" or s.get("flip"):
            continue
        M = _matrix(s)
        r = float(np.linalg.norm(M[:3, 0]))
        row = np.zeros(NEE_STRIDE, np.float32)
        row[0], row[2], row[3], row[4:7] = sid, float(_bitmap(s["radiance"])[0].mean()) * math.pi * r * r, r, M[:3, 3]
        rows.append(row)
    if len(rows) > NEE_MAX:
        raise SystemExit(f"equiangular.py: {len(rows)} lamps; equiangular.cl takes at most {NEE_MAX}")
    return rows


def scene_buffers(name, shapes=None, lights=None):
    shapes = S.SCENES[name]["build"]() if shapes is None else shapes
    shp, tex, texel = [], [], []
    for s in shapes:
        if s["kind"] not in KINDS:
            raise SystemExit(f"equiangular.py: shape kind {s['kind']!r} of scene {name} is not supported")
        Minv = np.linalg.inv(_matrix(s))
        row = np.zeros(16, np.float32)
        row[:12] = Minv[:3, :4].reshape(-1)
        row[12], row[13], row[14] = KINDS[s["kind"]], 1.0 if s.get("flip") else 0.0, -1.0
        if s.get("radiance") is not None:
            arr, rep = _bitmap(s["radiance"])
            row[14] = len(tex)
            off = sum(t.size for t in texel)
            tex.append([arr.shape[1], arr.shape[0], rep[0], rep[1], off, 0, 0, 0])
            texel.append(arr.reshape(-1))
        shp.append(row)
    lights = [list(p) + list(i) + [0.0, 0.0] for p, i in (S.LIGHTS.get(name, []) if lights is None else lights)]
    nee = nee_rows(shapes)
    return (np.asarray(shp or [np.zeros(16)], np.float32), np.asarray(tex or [[0] * 8], np.float32),
            np.concatenate(texel) if texel else np.zeros(3, np.float32),
            np.asarray(lights or [[0] * 8], np.float32), len(shapes), len(lights),
            np.asarray(nee or [np.zeros(NEE_STRIDE)], np.float32), len(nee))


class Tracer:
    def __init__(self, name, shapes=None, lights=None):
        from fogcli.device.runtime import get_runtime
        import pyopencl as cl
        self.cl = cl
        rt = get_runtime()
        self.ctx, self.queue = rt.ctx, rt.queue
        if self.ctx not in _PROGRAMS:
            src = (HERE / "equiangular.cl").read_text()
            _PROGRAMS[self.ctx] = cl.Program(self.ctx, src).build(options=["-cl-fast-relaxed-math"])
        self.kernel = cl.Kernel(_PROGRAMS[self.ctx], "trace")
        shp, tex, texel, lights, self.ns, self.nl, nee, self.nn = scene_buffers(name, shapes, lights)
        mf = cl.mem_flags
        self.bufs = [cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a)
                     for a in (shp, tex, texel, lights, nee)]
        self.out = cl.Buffer(self.ctx, mf.READ_WRITE, S.WIDTH * S.HEIGHT * 3 * 4)

    def render(self, spp, seed, ss, st, g, neq=1, rr_depth=3, rr_q=0.7, max_depth=-1, jitter=True, nee=True):
        """Sum of `spp` samples per pixel, (H, W, 3) float64. nee: next-event estimation of
        the lamps (nee_rows)."""
        cl = self.cl
        shp, tex, texel, lights, nee_buf = self.bufs
        self.kernel(self.queue, (S.WIDTH, S.HEIGHT), None, shp, np.int32(self.ns), tex, texel,
                       lights, np.int32(self.nl), nee_buf, np.int32(self.nn if nee else 0),
                       np.int32(S.WIDTH), np.int32(S.HEIGHT),
                       np.float32(S.FOCAL), np.int32(spp), np.uint32(seed), np.float32(ss),
                       np.float32(st), np.float32(g), np.int32(neq), np.int32(rr_depth), np.float32(rr_q),
                       np.int32(max_depth), np.int32(jitter), self.out)
        host = np.empty(S.WIDTH * S.HEIGHT * 3, np.float32)
        cl.enqueue_copy(self.queue, host, self.out)
        return host.reshape(S.HEIGHT, S.WIDTH, 3).astype(np.float64)


def roulette(analog):
    """Tracer.render's Russian roulette: from depth 3 with survival at most 0.7 (the night
    scenes' renders), or analog: survival = the walk's weight, which is then 1 again, so no
    weight ever grows. In fog (albedo 0.999) light from hundreds of metres away takes
    thousands of steps; with capped survival such a path is one in 0.7^-n with weight 0.7^-n, so
    the image is unbiased but its typical sample misses that light (Mitsuba's rr_depth 5 does
    the same at 0.95 per step: measured on ground-fog, its sky 17 % below the analog walk's)."""
    # Analog walks end at 2^20 steps: a float32 walk that once went NaN (about one in 1e8
    # paths of signs-sea) never meets the roulette again and would loop; no walk of these
    # media lives that long (fog: 0.999^(2^20) = e^-1049).
    return dict(rr_depth=1, rr_q=1.0, max_depth=1 << 20) if analog else dict(rr_depth=3, rr_q=0.7, max_depth=-1)


def grey_parts(m):
    """[(sigma_s, sigma_t, channel or None)]: one launch when the medium is grey, else one per
    channel. Stricter than render.grey_parts (grey sigma_t), since a launch takes a scalar
    sigma_s where Mitsuba takes an RGB albedo."""
    s, a = np.asarray(m["sigma_s"], float), np.asarray(m["sigma_a"], float)
    if np.allclose(s + a, (s + a)[0]) and np.allclose(s, s[0]):
        return [(s[0], s[0] + a[0], None)]
    return [(s[c], s[c] + a[c], c) for c in range(3)]


def render_medium(tr, medium, budget, target, seed0, max_spp, log=print, start=None, analog=False, nee=True):
    """Two halves A, B alternating passes; stops at the budget, the noise target or max_spp.
    start: (mean A, mean B, spp A, spp B) of an earlier run to continue (--resume); B None:
    an earlier image without halves, which becomes half A while the new passes fill half B up to
    the same spp (two independent renders are two halves as well), then both go on."""
    m = S.MEDIA[medium]
    parts = grey_parts(m)
    acc, n = (0.0, 0.0), (0, 0)
    if start is not None:
        acc = (start[0] * start[2], 0.0 if start[1] is None else start[1] * start[3])
        n = (start[2], 0 if start[1] is None else start[3])

    def one_pass(k):
        img = np.zeros((S.HEIGHT, S.WIDTH, 3))
        for ss, st, c in parts:
            part = tr.render(PASS_SPP, seed0 + 7919 * k + (c or 0) * 104729, ss, st, m["g"], nee=nee, **roulette(analog))
            if c is None:
                img = part
            else:
                img[..., c] = part[..., c]
        return img

    def stop(na, nb, noise, el):
        return el > budget or noise <= target or na + nb >= max_spp

    sa, sb, na, nb, noise, el = alternate_halves(one_pass, PASS_SPP, stop, log, (n[0] + n[1]) // PASS_SPP, acc, n)
    return (sa + sb) / (na + nb), noise, na + nb, el, (sa / na, sb / nb, na, nb)


def blocks(img, b=8):
    H, W = img.shape[:2]
    return img[:H // b * b, :W // b * b].reshape(H // b, b, W // b, b, -1).mean(axis=(1, 3))


def compare(name, medium, img, noise, log=print):
    z = np.load(renders(name) / f"{name}-{medium}.npz")
    ref = z["medium_mitsuba"] if "medium_mitsuba" in z else z["medium"]
    meta = json.loads(str(z["meta"]))
    mit_noise = meta.get("mitsuba_noise", float(z["noise"]))
    row = dict(case=f"{name}-{medium}", mitsuba_noise=mit_noise, noise=noise,
               full=rel_l1(img, ref), blocks8=rel_l1(blocks(img), blocks(ref)),
               energy=[float(img[..., c].sum() / ref[..., c].sum()) for c in range(3)])
    log(f"  {row['case']}: rel L1 full {row['full']:.3f} (noise: Mitsuba {mit_noise:.3f}, ours "
        f"{noise:.3f}), 8x8 blocks {row['blocks8']:.4f}, energy ours / Mitsuba "
        + ", ".join(f"{e:.4f}" for e in row["energy"]))
    return row


def vacuum_check(name, log=print):
    tr = Tracer(name)
    img = tr.render(256, 12345, 0.0, 0.0, 0.0) / 256
    z = np.load(renders(name) / f"{name}-fog.npz")
    L = z["L"].astype(np.float64)
    e = rel_l1(img, L)
    log(f"  {name} vacuum: rel L1 vs Mitsuba's L {e:.4f} (both 256 spp), energy "
        + ", ".join(f"{img[..., c].sum() / L[..., c].sum():.4f}" for c in range(3)))
    return e


TABLE_BEGIN, TABLE_END = "<!-- equiangular-table:start -->", "<!-- equiangular-table:end -->"


def write_table():
    """The renders' noise, spp and time, and their energy over Mitsuba's, into README.md."""
    rows = ["| case | spp | noise | seconds | Mitsuba spp | Mitsuba noise | Mitsuba seconds | energy / Mitsuba's (R, G, B) |",
            "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for path in sorted([*RENDERS.glob("*.npz"), *(HERE / "renders").glob("*.npz")]):
        with np.load(path) as z:
            meta = json.loads(str(z["meta"]))
            if "medium_mitsuba" not in z:      # Mitsuba's own: render.py's table lists it
                continue
            e = z["medium"].astype(np.float64).sum((0, 1)) / z["medium_mitsuba"].astype(np.float64).sum((0, 1))
        rows.append(f"| {path.stem} | {meta['spp']} | {meta['noise']:.3f} | {meta['seconds_medium']:.0f} | "
                    f"{meta['mitsuba_spp']} | {meta['mitsuba_noise']:.3f} | {meta['mitsuba_seconds']:.0f} | "
                    + ", ".join(f"{x:.3f}" for x in e) + " |")
    text = "\n".join([TABLE_BEGIN] + rows + [TABLE_END])
    write_block(HERE / "README.md", TABLE_BEGIN, TABLE_END, text)
    print(text)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="yard,quay", help="scene or scene-medium names, comma separated")
    ap.add_argument("--budget", type=float, default=120.0, help="seconds per case")
    ap.add_argument("--target", type=float, default=0.01)
    ap.add_argument("--max-spp", type=int, default=1 << 20)
    ap.add_argument("--check", action="store_true", help="compare with the Mitsuba renders, write nothing")
    ap.add_argument("--write", action="store_true", help="store the renders as `medium` in renders-lights/")
    ap.add_argument("--out", default=None, help="where --write stores (default: the scene's renders-lights/ or renders/)")
    ap.add_argument("--analog", action="store_true", help="Russian roulette by the walk's own weight only, which never grows (for fog's walks of thousands of steps, where roulette with weight growth is heavy-tailed)")
    ap.add_argument("--resume", action="store_true", help="add samples to the halves stored by an earlier --write")
    ap.add_argument("--no-nee", action="store_true", help="no next-event estimation of the lamps (emissive spheres), as the renders before session 39")
    ap.add_argument("--table", action="store_true", help="rewrite the README table from the renders")
    args = ap.parse_args()
    if args.table:
        return write_table()
    names = [(s, m) for s in S.SCENES for m in S.MEDIA]
    sel = [(s, m) for s, m in names for tok in args.only.split(",") if tok in (s, m, f"{s}-{m}")]
    for scene in dict.fromkeys(s for s, _ in sel):
        vacuum_check(scene)
    for scene, medium in sel:
        tr = Tracer(scene)
        seed0 = 7_000_000 + 1000 * list(S.SCENES).index(scene) + 10 * list(S.MEDIA).index(medium)
        print(f"{scene}-{medium}:")
        start, el0 = None, 0.0
        if args.resume:
            with np.load(renders(scene) / f"{scene}-{medium}.npz") as z:
                m0 = json.loads(str(z["meta"]))
                if "half_a" in z:
                    start = (z["half_a"].astype(np.float64), z["half_b"].astype(np.float64), *m0["spp_halves"])
                elif m0.get("integrator", "").startswith("equiangular"):
                    start = (z["medium"].astype(np.float64), None, m0["spp"], 0)
                if start is not None:
                    el0 = m0["seconds_medium"]
        img, noise, spp, el, halves = render_medium(tr, medium, args.budget, args.target, seed0,
                                                    args.max_spp, start=start, analog=args.analog,
                                                    nee=not args.no_nee)
        el += el0
        compare(scene, medium, img, noise)
        if args.write and not args.check:
            path = renders(scene) / f"{scene}-{medium}.npz"
            with np.load(path) as z:
                d = {k: z[k] for k in z.files}
            meta = json.loads(str(d["meta"]))
            if "medium_mitsuba" not in d:
                d["medium_mitsuba"] = d["medium"]
                meta["mitsuba_noise"], meta["mitsuba_spp"] = meta["noise"], meta["spp"]
                meta["mitsuba_seconds"] = meta.get("seconds_medium")
            meta.update(integrator="equiangular (tools/groundtruth/equiangular.py)", spp=spp,
                        nee_emitters=0 if args.no_nee else tr.nn,
                        noise=noise, noise_definition=NOISE_DEF, seconds_medium=round(el, 1),
                        seed0=seed0, **roulette(args.analog),
                        spp_halves=[int(halves[2]), int(halves[3])])
            d["medium"], d["noise"], d["meta"] = img.astype(np.float32), np.float64(noise), json.dumps(meta)
            d["half_a"], d["half_b"] = halves[0].astype(np.float32), halves[1].astype(np.float32)
            path = Path(args.out or path.parent) / path.name
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(".tmp.npz")
            np.savez_compressed(tmp, **d)
            os.replace(tmp, path)


if __name__ == "__main__":
    main()
