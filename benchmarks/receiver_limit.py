"""An experiment for the next step of the point spread (issue 8), not the model fogcli runs:
light scattered behind a near surface cannot reach the camera through it. A receiver at
distance D_r collects in-scattered light only from its own ray segment; for a source at
D_s > D_r the share is about f(D_r) / f(D_s), f(D) = 1 - exp(-sigma_t D) (the in-scatter of
a diffuse field along a ray). Emulated by slicing the sources into depth bins (fogcli per
bin, its scattered light scaled by min(1, f_r / f_bin)) and, as a kernel could carry it, by
two collapsed quantities X = sum x_s and Y = sum x_s / f_s with min(X, f_r Y) per receiver.
Also the `open` border against a mirrored continuation of the frame (half the frame on each
side). Prints relative L1 / SSIM and scattered energy per path-traced case.

    python benchmarks/receiver_limit.py [bins]        # about 5 minutes on 2 cores
"""
from __future__ import annotations

import importlib.util
import math
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
_spec = importlib.util.spec_from_file_location("gt_bench", ROOT / "benchmarks" / "groundtruth.py")
G = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(G)

from fogcli import apply  # noqa: E402
from fogcli.api import make_config  # noqa: E402
from fogcli.metrics import rel_l1, ssim  # noqa: E402


def limited(L, d, sets, st, bins):
    """(plain, depth-binned receiver limit, X/Y form) images."""
    cfg = make_config(None, sets=sets)
    full = apply(L, d, cfg)
    att = L * np.exp(-st * d[..., None])
    fr = -np.expm1(-st * d[..., None])
    edges = np.geomspace(d.min() * 0.999, d.max() * 1.001, bins + 1)
    sc, X, Y = np.zeros_like(full), np.zeros_like(full), np.zeros_like(full)
    for a, b in zip(edges[:-1], edges[1:]):
        mk = (d >= a) & (d < b)
        if not mk.any():
            continue
        Lb = L * mk[..., None]
        ob = apply(Lb, d, cfg) - Lb * np.exp(-st * d[..., None])
        fs = -np.expm1(-st * math.sqrt(a * b))
        sc += ob * np.minimum(1.0, fr / fs)
        X += ob
        Y += ob / fs
    return full, att + sc, att + np.minimum(X, fr * Y)


def main() -> int:
    bins = int(sys.argv[1]) if len(sys.argv) > 1 else 8
    warnings.simplefilter("ignore")
    print("case | outside | variant: rel L1 / SSIM, energy ...")
    for c in G.gt_load.cases():
        m = c["meta"]
        st = np.asarray(m["sigma_a"]) + np.asarray(m["sigma_s"])
        direct, gt = G.blend(c), c["medium"]
        H, W = gt.shape[:2]
        gsc = (gt - direct).sum()
        row = [c["name"], "yes" if m["outside"] else ""]
        for mode in ("open", "mirror"):
            L, d, sets, py, px = c["L"], c["depth"], G.case_sets(m) + ["render.border=open"], 0, 0
            if mode == "mirror":
                py, px = H // 2, W // 2
                L = np.pad(L, ((py, py), (px, px), (0, 0)), mode="symmetric")
                d = np.pad(d, ((py, py), (px, px)), mode="symmetric")
                f = (W / 2) / math.tan(math.radians(m["fov"]) / 2)
                fov = math.degrees(2 * math.atan((W + 2 * px) / 2 / f))
                sets = [x for x in sets if not x.startswith("camera.fov")] + [f"camera.fov={fov}"]
            for name, img in zip(("", " limit", " X/Y"), limited(L, d, sets, st, bins)):
                img = img[py:py + H, px:px + W]
                row.append(f"{mode}{name} {rel_l1(img, gt):.3f}/{ssim(img, gt):.3f} e{(img - direct).sum() / gsc:.2f}")
        print(" | ".join(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
