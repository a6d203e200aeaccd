"""What the border costs: fogcli's default on a path-traced scene's frame (its border guesses
what lies past the edge) against the same on a frame K times wider (the vacuum image and ray
lengths rendered again by Mitsuba at the same focal length, so fogcli sees the world past the
edge), cropped back; each against the path tracer (relative L1 / scattered energy). Where
the wide frame matches the path tracer, what is left on the frame is the border's guess.

    python tools/border_truth.py [--scenes edges,cuts1,cuts2,cuts3,cuts4,panel] [--k 2] [--doc docs/physics.md]   # needs mitsuba; ~20 s

Only for scenes whose world ends within the wider frustum (edges, panel: black beyond their
surfaces): past the wide frame fogcli's border is open.
"""
from __future__ import annotations

import argparse
import math
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "groundtruth"))
from groundtruth.load import comparison  # noqa: E402
from docblock import cpu_name, markers, write_block  # noqa: E402

from fogcli import apply  # noqa: E402
from fogcli.api import make_config  # noqa: E402
from metrics import rel_l1  # noqa: E402

G = comparison()
BEGIN, END = markers("border-truth")


def wide_frame(name: str, k: int) -> tuple[np.ndarray, np.ndarray, float]:
    """(L, ray length, horizontal fov) of scene `name` k times wider and taller, same focal."""
    import render as R
    import scenes as S

    mi, _ = R._setup("scalar_rgb")
    w, h = S.WIDTH * k, S.HEIGHT * k
    fov = 2 * math.degrees(math.atan(S.TAN_X * k))
    return R.render_L(mi, name, width=w, height=h, fov=fov), R.render_depth(mi, name, width=w, height=h, fov=fov), fov


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="edges,cuts1,cuts2,cuts3,cuts4,panel")
    ap.add_argument("--k", type=int, default=2)
    ap.add_argument("--doc", help="write the block into this markdown file (docs/physics.md)")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    rows = []
    for name in args.scenes.split(","):
        L2, z2, fov = wide_frame(name, args.k)
        for case in G.gt_load.cases(scene=name):
            m, gt = case["meta"], case["medium"]
            direct = G.blend(case)
            gsc = float((gt - direct).sum())
            h, w = gt.shape[:2]
            y0, x0 = (z2.shape[0] - h) // 2, (z2.shape[1] - w) // 2
            sets = G.case_sets(m)
            wide = [s for s in sets if not s.startswith("camera.fov")] + [f"camera.fov={fov}"]
            cells = []
            for img in (apply(case["L"], case["depth"], make_config(None, sets=sets)),
                        apply(case["L"], case["depth"], make_config(None, sets=sets + ["render.border=open"])),
                        apply(L2, z2, make_config(None, sets=wide))[y0:y0 + h, x0:x0 + w]):
                cells.append(f"{rel_l1(img, gt):.3f} / {float((img - direct).sum()) / gsc:.2f}")
            rows.append(f"| {case['name']} | " + " | ".join(cells) + " |")
            print(rows[-1], flush=True)
    block = "\n".join([BEGIN, f"Written by `python tools/border_truth.py --doc docs/physics.md` on {cpu_name()}. "
                        "Relative L1 to the path tracer / scattered energy over the path tracer's.\n",
                        f"| case | default | default, border open | default on the frame {args.k}x wider, cropped |",
                        "|---|---|---|---|", *rows, END])
    if args.doc:
        write_block(Path(args.doc), BEGIN, END, block)
    return 0


if __name__ == "__main__":
    sys.exit(main())
