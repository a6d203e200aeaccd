"""Depth edges that miss the colour's at strong fog (issue 41 item 6), and two ways of moving
them that were measured and not taken. The frames of tools/holefill.py (the TUM RGB-D frame
and the indoor room) with their depth filled as fogcli fills it, then shifted by 3 and 6 px
against the colour, or with structured-light edge noise (each row shifted by -2..2 px), or
left aligned; fogcli's output at `medium.visibility: 200%` against the output with the
aligned depth (relative L1, over the frame and within 2 px of the colour's edges), for the
depth as it is and after:

* band refill: every pixel within 4 px of a depth step (log depth varying by more than 0.1
  in 3 x 3) made a hole and filled edge-aware from the colour (depth.prepare);
* colour snap: every pixel within 3 px of a step takes the near or the far side's depth of
  its 7 x 7 window, whichever side's mean colour is nearer its own.

    python tools/depth_edges.py
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tools"), str(ROOT / "tests")]

from docblock import cpu_name  # noqa: E402
from metrics import rel_l1  # noqa: E402


def band_refill(d, rgb, r=4, step=0.1):
    import cv2
    from fogcli.io import depth as D

    d = d.copy()
    ld = np.log(d).astype(np.float32)
    k = np.ones((3, 3), np.uint8)
    edge = (cv2.dilate(ld, k) - cv2.erode(ld, k)) > step
    d[cv2.dilate(edge.astype(np.uint8), np.ones((2 * r + 1, 2 * r + 1), np.uint8)) > 0] = np.nan
    return D.prepare(d, rgb, "bench")[0]


def colour_snap(d, rgb, r=3, step=0.1):
    import cv2
    from fogcli.io import depth as D

    ld = np.log(d).astype(np.float32)
    k, box = np.ones((2 * r + 1, 2 * r + 1), np.uint8), (2 * r + 1, 2 * r + 1)
    lo, hi = cv2.erode(ld, k), cv2.dilate(ld, k)
    band = (hi - lo) > step
    g = D._guide(rgb)
    sides = []
    for m in ((ld < lo + 0.3 * (hi - lo)), (ld > hi - 0.3 * (hi - lo))):
        m = m.astype(np.float32)
        n = cv2.boxFilter(m, -1, box, normalize=False)
        c = cv2.boxFilter(g * m[..., None], -1, box, normalize=False) / np.maximum(n, 1e-6)[..., None]
        sides.append((((g - c) ** 2).sum(-1), cv2.boxFilter(ld * m, -1, box, normalize=False) / np.maximum(n, 1e-6), n))
    (dn, ln, nn), (df, lf, nf) = sides
    out = ld.copy()
    ok = band & (nn > 0) & (nf > 0)
    out[ok] = np.where(dn[ok] < df[ok], ln[ok], lf[ok])
    return np.exp(out).astype(np.float32)


def jagged(d, amp=2, seed=0):
    rng = np.random.default_rng(seed)
    out = d.copy()
    for y in range(d.shape[0]):
        out[y] = np.roll(d[y], rng.integers(-amp, amp + 1))
    return out


def main() -> int:
    import cv2
    import fogcli
    from fogcli.io import depth as D
    from holefill import frames

    print(f"`python tools/depth_edges.py` on {cpu_name()}; relative L1 to the output with the aligned depth, "
          "medium.visibility 200 %, whole frame / within 2 px of the colour's edges\n")
    print("| frame | depth | as it is | band refill | colour snap |")
    print("|---|---|---|---|---|")
    for name, (rgb, d) in frames().items():
        base = D.prepare(d.copy(), rgb, "bench")[0]
        cfg = fogcli.make_config("fog", sets=["medium.visibility=200%"])
        ref = fogcli.apply(rgb, base, cfg)
        grey = (np.clip(rgb, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)
        edges = cv2.dilate((cv2.Canny(grey, 50, 150) > 0).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
        for kind, dm in (("aligned", base), ("shifted 3 px", np.roll(base, 3, axis=1)),
                         ("shifted 6 px", np.roll(base, 6, axis=1)), ("edge noise 2 px", jagged(base))):
            cells = []
            for f in (dm, band_refill(dm, rgb), colour_snap(dm, rgb)):
                out = fogcli.apply(rgb, f, cfg)
                cells.append(f"{rel_l1(out, ref):.4f} / {rel_l1(out[edges], ref[edges]):.4f}")
            print(f"| {name} | {kind} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
