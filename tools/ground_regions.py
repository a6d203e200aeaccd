"""Where the scattered light of a ground to the horizon goes (issue 40): the path-traced
`ground` cases split into bands of rows (the sky above the horizon, the far, middle and
near ground), and in each band fogcli's scattered light (the image minus the attenuated
direct light L exp(-sigma_t d)) over the path tracer's, per border policy without the
ground's slab and for the default (with it); and the share of the path tracer's band that
is direct light. A point spread that is the same in every direction keeps a grazing
ground's light on the ground; the path tracer puts much of it in the sky (the ground emits
upwards, and beyond the frame's bottom edge it goes on under the camera): the slab of
`render.ground` does the same.

    python tools/ground_regions.py [--doc docs/physics.md]
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

from fogcli import apply
from fogcli.api import make_config
from groundtruth.load import cases, comparison

# (column, --set values): the border policies without the ground's slab, then the default
VARIANTS = (("open, no ground", ["render.border=open", "render.ground=none"]),
            ("extend, no ground", ["render.border=extend", "render.ground=none"]),
            ("open, ground", ["render.border=open"]),
            ("default (extend, ground)", []))
BANDS = (("sky", 0, None), ("far ground (20 rows)", 0, 20), ("middle ground (40 rows)", 20, 60), ("near ground", 60, None))


def measure() -> list[tuple]:
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for case in cases(scene="ground"):
            sets = comparison().case_sets(case["meta"])
            gt, direct = case["medium"], comparison().blend(case)
            outs = {b: apply(case["L"], case["depth"], make_config(None, sets=sets + extra))
                    for b, extra in VARIANTS}
            col = case["depth"][:, case["depth"].shape[1] // 2]
            hz = int(np.argmax(col < 0.99 * col.max()))       # the first row of ground
            for name, a, b in BANDS:
                sl = slice(0, hz) if name == "sky" else slice(hz + a, None if b is None else hz + b)
                want = float((gt - direct)[sl].sum())
                rows.append((case["name"], name, *(float((o - direct)[sl].sum()) / want for o in outs.values()),
                             float(direct[sl].sum() / gt[sl].sum())))
    return rows


def table(rows) -> str:
    out = ["| case | band | " + " | ".join(f"{b}: scattered / path tracer's" for b, _ in VARIANTS)
           + " | direct share (path tracer) |", "|---|---|" + "---|" * (len(VARIANTS) + 1)]
    out += [f"| {r[0]} | {r[1]} | " + " | ".join(f"{v:.2f}" for v in r[2:]) + " |" for r in rows]
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--doc", help="write the table into this markdown file's ground-regions block")
    args = ap.parse_args(argv)
    text = table(measure())
    print(text)
    if args.doc:
        from docblock import cpu_name, markers, write_block
        begin, end = markers("ground-regions")
        head = (f"Written by `python tools/ground_regions.py --doc {args.doc}` on {cpu_name()}. The default "
                "pipeline with two border policies without the ground's slab (`render.ground: none`), the open border "
                "with it, and the default (border extend, the ground's slab) on the `ground` renders, per band of "
                "rows.\n\n")
        write_block(Path(args.doc), begin, end, f"{begin}\n{head}{text}\n{end}", new_doc="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
