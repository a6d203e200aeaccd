"""What the slab's light does where surfaces hide the ground and the sky (issue 40, `street`,
`plaza`): small scenes of black occluders over a ground under a sky dome, their scattered
light by a backward random walk (the truth) and by fogcli's default, with and without the
occluders. The slab (render.ground) sends the light of an open ground and sky to every ray;
a wall or a building between the ray and them hides it in the world, not in fogcli, where
only ground and sky pixels give up their mean colour and every other pixel keeps its whole
colour as a source.

    python tools/occlusion_check.py [--walks N] [--doc docs/physics.md]

The scenes (camera 1.6 m over the ground, 64 x 48 pixels, 60 degrees): `front`, a black wall
20 m wide and 10 m high 30 m ahead, the dome at 150 m; `canyon`, black walls 20 m high 6 m
to either side from 3 m to 80 m ahead, the dome at 150 m; `blocks`, `plaza`'s three
buildings and its box, black, the dome at 1000 m. The ground's radiance is 0.1, the sky's 1.
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

from backward_walk import scattered

WIDTH, HEIGHT, FOV = 64, 48, 60.0
CAMERA = 1.6          # above the ground
GROUND, SKY = 0.1, 1.0
MEDIA = {"fog": (0.00012012012012013073, 0.12, 0.85), "haze": (0.002777777777777779, 0.025, 0.7)}   # sa, ss, g (the renders')
Y0 = -CAMERA
# camera space: x right, y up, -z ahead; a rectangle: (axis of its normal, where on it, then
# the other two axes' ranges in order); a box: (centre, half sizes)
SCENES = {
    "front": dict(dome=150.0, rects=[(2, -30.0, (-10.0, 10.0), (Y0, 8.4))], boxes=[]),
    "canyon": dict(dome=150.0, rects=[(0, -6.0, (Y0, 18.4), (-80.0, -3.0)), (0, 6.0, (Y0, 18.4), (-80.0, -3.0))], boxes=[]),
    "blocks": dict(dome=1000.0, rects=[], boxes=[((-21.0, Y0 + 12.5, -35.0), (9.0, 12.5, 25.0)),
                                                 ((25.0, Y0 + 17.5, -35.0), (15.0, 17.5, 15.0)),
                                                 ((0.0, Y0 + 9.0, -78.0), (15.0, 9.0, 7.0)),
                                                 ((3.0, Y0 + 1.0, -10.0), (1.0, 1.0, 1.0))]),
}


def pixel_rays() -> np.ndarray:
    """(h * w, 3) unit directions through the pixels' centres, fogcli's camera."""
    f = (WIDTH / 2) / np.tan(np.radians(FOV) / 2)
    i, j = np.meshgrid(np.arange(WIDTH) + 0.5, np.arange(HEIGHT) + 0.5)
    d = np.stack([(i - WIDTH / 2) / f, -(j - HEIGHT / 2) / f, -np.ones_like(i)], -1).reshape(-1, 3)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def first_hit(p: np.ndarray, d: np.ndarray, scene: dict | None, dome: float) -> tuple[np.ndarray, np.ndarray]:
    """Distance from p along d to the first surface, and its radiance (the dome's, the
    ground's, a rectangle's fifth entry or 0, a box's 0). scene None: no occluders; a scene
    may set its own "sky" and "ground" radiance."""
    scene = scene or {}
    b = (p * d).sum(1)
    t = -b + np.sqrt(np.maximum(b * b - ((p * p).sum(1) - dome * dome), 0.0))
    rad = np.full(len(p), scene.get("sky", SKY))
    with np.errstate(divide="ignore", invalid="ignore"):
        tg = np.where(d[:, 1] < 0.0, (p[:, 1] - Y0) / -d[:, 1], np.inf)
        rad = np.where(tg < t, scene.get("ground", GROUND), rad)
        t = np.minimum(t, tg)
        for ax, at, r0, r1, *emit in scene.get("rects", []):
            o = [k for k in range(3) if k != ax]
            tw = (at - p[:, ax]) / d[:, ax]
            tw = np.where(np.isfinite(tw) & (tw > 1e-9), tw, np.inf)
            q = p + d * np.where(np.isfinite(tw), tw, 0.0)[:, None]
            inside = (q[:, o[0]] >= r0[0]) & (q[:, o[0]] <= r0[1]) & (q[:, o[1]] >= r1[0]) & (q[:, o[1]] <= r1[1])
            tw = np.where(inside, tw, np.inf)
            rad = np.where(tw < t, emit[0] if emit else 0.0, rad)
            t = np.minimum(t, tw)
        for c, h in scene.get("boxes", []):
            inv = 1.0 / np.where(d == 0.0, 1e-30, d)
            t0, t1 = (np.subtract(c, h)[None] - p) * inv, (np.add(c, h)[None] - p) * inv
            near, far = np.minimum(t0, t1).max(1), np.maximum(t0, t1).min(1)
            tb = np.where((far >= np.maximum(near, 1e-9)) & (near > 1e-9), near, np.inf)
            rad = np.where(tb < t, 0.0, rad)
            t = np.minimum(t, tb)
    return t, rad


def walk_image(medium: tuple, scene: dict | None, dome: float, n: int, rng) -> np.ndarray:
    """(h, w) scattered radiance (light that scattered at least once) by n backward walks a
    pixel (backward_walk.scattered)."""
    sa, ss, g = medium
    d = np.repeat(pixel_rays(), n, 0)
    score = scattered(np.zeros_like(d), d, sa + ss, ss / (sa + ss), g, lambda p, q: first_hit(p, q, scene, dome), rng)
    return score.reshape(-1, n).mean(1).reshape(HEIGHT, WIDTH)


def vacuum(scene: dict | None, dome: float) -> tuple[np.ndarray, np.ndarray]:
    """The frame fogcli gets: colour (h, w, 3) and ray length (h, w)."""
    d = pixel_rays()
    t, rad = first_hit(np.zeros_like(d), d, scene, dome)
    return (np.repeat(rad.reshape(HEIGHT, WIDTH, 1), 3, -1).astype(np.float32),
            t.reshape(HEIGHT, WIDTH).astype(np.float32))


def fogcli_scattered(medium: tuple, colour: np.ndarray, depth: np.ndarray, sets: tuple = ()) -> np.ndarray:
    """fogcli's default (and `sets`) on the frame: the image minus the attenuated direct light."""
    from fogcli import apply
    from fogcli.api import make_config

    sa, ss, g = medium
    sets = [f"medium.absorption={[sa] * 3}", f"medium.scattering={[ss] * 3}", f"medium.asymmetry={g}",
            f"camera.fov={FOV}", "camera.depth=distance", "camera.max_depth=100000", *sets]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        img = apply(colour, depth, make_config(None, sets=sets))
    return (img - colour * np.exp(-(sa + ss) * depth[..., None]))[..., 0]


def measure(walks: int) -> list[tuple]:
    rows = []
    for sname, scene in SCENES.items():
        for mname, medium in MEDIA.items():
            rng = np.random.default_rng(40)
            got, want = {}, {}
            for key, sc in (("open", None), ("occluded", scene)):
                want[key] = walk_image(medium, sc, scene["dome"], walks, rng).sum()
                got[key] = fogcli_scattered(medium, *vacuum(sc, scene["dome"])).sum()
            rows.append((sname, mname, want["open"], got["open"], want["occluded"], got["occluded"]))
            print(rows[-1], file=sys.stderr, flush=True)
    return rows


def table(rows) -> str:
    out = ["| scene | medium | without the occluders: walk | fogcli | fogcli / walk | with them: walk | fogcli "
           "| fogcli / walk | what the occluders take: walk | fogcli |", "|---|---|---|---|---|---|---|---|---|---|"]
    for s, m, wo, go, wc, gc in rows:
        out.append(f"| {s} | {m} | {wo:.1f} | {go:.1f} | {go / wo:.2f} | {wc:.1f} | {gc:.1f} | {gc / wc:.2f} "
                   f"| {wo - wc:.1f} | {go - gc:.1f} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walks", type=int, default=400, help="walks a pixel")
    ap.add_argument("--doc", help="write the table into this markdown file's occlusion-check block")
    args = ap.parse_args(argv)
    text = table(measure(args.walks))
    print(text)
    if args.doc:
        from docblock import cpu_name, markers, write_block
        begin, end = markers("occlusion-check")
        head = (f"Written by `python tools/occlusion_check.py --walks {args.walks} --doc {args.doc}` on {cpu_name()}. "
                "Scattered light summed over the frame (light that scattered at least once), of black occluders over "
                "a ground under a dome (the scenes in the script's docstring): a backward random walk and fogcli's "
                "default.\n\n")
        write_block(Path(args.doc), begin, end, f"{begin}\n{head}{text}\n{end}", new_doc="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
