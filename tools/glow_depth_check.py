"""How much of a far source's glow a nearer surface keeps (`render.halo_depth: receiver`,
physics/glow_depth.py): a wall 30 m ahead that emits radiance 1 (20 m wide, from the ground
to 8.4 m), below it a black screen 5 m ahead filling the lower rows, a black ground and no
sky (tools/occlusion_check.py's camera, 64 x 48 pixels, 60 degrees). Per band of rows, the
scattered light by a backward random walk against fogcli's default, with `halo_depth: none`
and with both `render.spread_space: pixels` and `render.border: open` (the reference's space
and border).

    python tools/glow_depth_check.py [--walks N] [--doc docs/physics.md]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from occlusion_check import MEDIA, Y0, fogcli_scattered, vacuum, walk_image

SCENE = dict(sky=0.0, ground=0.0, rects=[(2, -30.0, (-10.0, 10.0), (Y0, 8.4), 1.0),     # the wall, emitting
                                         (2, -5.0, (-20.0, 20.0), (Y0, -0.5))])          # the screen, black
DOME = 150.0
BANDS = 4          # rows a band
VARIANTS = (("default", ()), ("halo_depth none", ("render.halo_depth=none",)),
            ("pixels, open", ("render.spread_space=pixels", "render.border=open")))


def measure(walks: int) -> list[tuple]:
    rows = []
    colour, depth = vacuum(SCENE, DOME)
    for mname, medium in MEDIA.items():
        want = walk_image(medium, SCENE, DOME, walks, np.random.default_rng(41))
        got = [fogcli_scattered(medium, colour, depth, sets) for _, sets in VARIANTS]
        for r0 in range(0, want.shape[0], BANDS):
            band = slice(r0, r0 + BANDS)
            w = float(want[band].sum())
            rows.append((mname, r0, float(np.median(depth[band])), w, *(float(g[band].sum()) / w for g in got)))
            print(rows[-1], file=sys.stderr, flush=True)
    return rows


def table(rows) -> str:
    out = ["| medium | rows | depth (m) | walk | " + " | ".join(f"fogcli {v} / walk" for v, _ in VARIANTS) + " |",
           "|---|---|---|---|" + "---|" * len(VARIANTS)]
    for m, r0, dep, w, *ratios in rows:
        out.append(f"| {m} | {r0}-{r0 + BANDS - 1} | {dep:.1f} | {w:.2f} | " + " | ".join(f"{x:.2f}" for x in ratios) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walks", type=int, default=400, help="walks a pixel")
    ap.add_argument("--doc", help="write the table into this markdown file's glow-depth-check block")
    args = ap.parse_args(argv)
    text = table(measure(args.walks))
    print(text)
    if args.doc:
        from docblock import cpu_name, markers, write_block
        begin, end = markers("glow-depth-check")
        head = (f"Written by `python tools/glow_depth_check.py --walks {args.walks} --doc {args.doc}` on {cpu_name()}. "
                "A wall 30 m ahead emitting 1 above a black screen 5 m ahead (the rows at 5.3 m and less), black "
                "ground, no sky: scattered light per band of rows, a backward walk against fogcli.\n\n")
        write_block(Path(args.doc), begin, end, f"{begin}\n{head}{text}\n{end}", new_doc="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
