"""Normals that real depth maps carry (issue 40): the default pipeline's output on each
path-traced case with its smooth depth against the same with
  * `replicated`: every other row and column kept, each repeated 2x2 (a half-resolution
    sensor's depth upsampled by nearest neighbour: a staircase, and edges a pixel off, which
    fogcli moves to the colour's: realign_blocks);
  * `quantised`: the ray length rounded to whole millimetres (a 16-bit millimetre sensor;
    depths past its 65.535 m are kept as they are, so that only the quantisation is
    measured, not the sensor's range);
  * `noise 0.5%`, `noise 1%`: each pixel's depth times 1 + 0.005 N(0, 1) (0.01; seeded), a
    depth sensor's noise at range; fogcli measures it (preprocess.depth_noise) and smooths
    the depth the normals come from (smooth_depth).
Relative L1 of each to the smooth depth's output, with each emission profile (isotropic
does not use normals: it shows what the depth change alone costs).

    python tools/normals_robustness.py [--doc docs/physics.md]
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from pathlib import Path

from fogcli import apply
from fogcli.api import make_config
from groundtruth.load import cases as all_cases, comparison
from metrics import rel_l1

PROFILES = ("lambertian", "isotropic")


def replicated(depth: np.ndarray) -> np.ndarray:
    h, w = depth.shape
    return np.repeat(np.repeat(depth[::2, ::2], 2, 0), 2, 1)[:h, :w]


def replicated_centres(depth: np.ndarray) -> np.ndarray:
    """As `replicated`, but each block's sample is its centre's, as a half-resolution sensor's
    pixel sees it: the mean of the four in 1 / depth where they agree within 5 % (a surface;
    a plane is linear in 1 / depth), else the first pixel's (an edge: a sensor sees one side)."""
    h, w = depth.shape
    d = np.asarray(depth, np.float64)[: h - h % 2, : w - w % 2]
    q = np.stack([d[0::2, 0::2], d[0::2, 1::2], d[1::2, 0::2], d[1::2, 1::2]])
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = 4.0 / (1.0 / q).sum(0)
        same = (q.max(0) <= 1.05 * q.min(0)) & np.isfinite(mean)
    low = np.where(same, mean, q[0])
    big = np.repeat(np.repeat(low, 2, 0), 2, 1)
    out = np.asarray(depth, np.float32).copy()
    out[: big.shape[0], : big.shape[1]] = big
    return out


def quantised(depth: np.ndarray) -> np.ndarray:
    return np.where(depth < 65.535, np.round(depth * 1000.0) / 1000.0, depth).astype(np.float32)


def noisy(depth: np.ndarray, s: float = 0.005) -> np.ndarray:
    rng = np.random.default_rng(40)
    return (depth * (1.0 + s * rng.standard_normal(depth.shape))).astype(np.float32)


VARIANTS = (("replicated", replicated), ("replicated centres", replicated_centres), ("quantised", quantised), ("noise 0.5%", noisy),
            ("noise 1%", lambda d: noisy(d, 0.01)))


def measure(cases) -> list[dict]:
    rows = []
    for case in cases:
        sets = comparison().case_sets(case["meta"])
        row = {"case": case["name"]}
        for prof in PROFILES:
            cfg = make_config(None, sets=sets + [f"render.emission_profile={prof}"])
            smooth = apply(case["L"], case["depth"], cfg)
            for name, fn in VARIANTS:
                row[f"{name} {prof}"] = rel_l1(apply(case["L"], fn(case["depth"]), cfg), smooth)
        rows.append(row)
        print(" ".join(f"{k}={v:.4f}" if isinstance(v, float) else str(v) for k, v in row.items()), flush=True)
    return rows


def table(rows: list[dict]) -> str:
    cols = [f"{n} {p}" for n, _ in VARIANTS for p in PROFILES]
    out = ["| case | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for r in rows:
        out.append(f"| {r['case']} | " + " | ".join(f"{r[c]:.5f}" for c in cols) + " |")
    out.append("| largest | " + " | ".join(f"{max(r[c] for r in rows):.5f}" for c in cols) + " |")
    over = [r["case"] for r in rows if r["replicated lambertian"] > 0.02 or r["quantised lambertian"] > 0.02]
    out.append(f"\nDefault profile (lambertian) over 0.02 with replicated or quantised depth: {', '.join(over) or 'none'}. "
               f"With 0.5 % noise: {', '.join(r['case'] for r in rows if r['noise 0.5% lambertian'] > 0.02) or 'none'}; "
               f"with 1 %: {', '.join(r['case'] for r in rows if r['noise 1% lambertian'] > 0.02) or 'none'}.")
    return "\n".join(out)


def said(smoothing) -> str:
    return "none" if smoothing is None else f"radius {smoothing[0]} px, tau {100 * smoothing[1]:.2f} %"


def smoothing_table() -> str:
    """What depth_noise finds and the smoothing it sets: on the TUM RGB-D frame (a Kinect's
    quantised depth) and on a render with the noise above; what the smoothing costs in the
    whole `apply` (night scene, fog; rounds alternate the smooth and the noisy depth, median
    of 5 rounds)."""
    import cv2

    from fogcli.device.preprocess import depth_noise, depth_smoothing, staircase
    from hdr_scenes import scene

    rows = ["| depth | noise found | smoothing (radius px, tau) |", "|---|---|---|"]
    tum = Path(__file__).resolve().parents[2] / "shared" / "data" / "tum_depth.png"
    if tum.exists():
        d = cv2.imread(str(tum), cv2.IMREAD_UNCHANGED).astype(np.float32) / 5000
        d = np.where(d > 0, d, np.nan)
        n = depth_noise(d, staircase(d))
        rows.append(f"| TUM RGB-D frame, 640x480, f 525 px | {100 * n:.2f} % | {said(depth_smoothing(n, 525.0))} |")
    cost = ["| frame | apply, smooth depth (ms) | with 0.5 % noise (ms) | smoothing radius |", "|---|---|---|---|"]
    for w, h in ((640, 480), (1920, 1080)):
        rgb, z, fov = scene(w, h, seed=1, night=True)
        cfg = make_config("fog", sets=[f"camera.fov={fov}"])
        zn = noisy(z)
        n = depth_noise(zn)
        sm = depth_smoothing(n, cfg.camera.focal(w))
        rows.append(f"| night scene {w}x{h} with 0.5 % noise, f {cfg.camera.focal(w):.0f} px | {100 * n:.2f} % | "
                    f"{said(sm)} |")
        times = {"smooth": [], "noisy": []}
        apply(rgb, z, cfg), apply(rgb, zn, cfg)
        for _ in range(5):
            for key, d in (("smooth", z), ("noisy", zn)):
                t0 = time.perf_counter()
                apply(rgb, d, cfg)
                times[key].append(1000 * (time.perf_counter() - t0))
        cost.append(f"| {w}x{h} | {np.median(times['smooth']):.0f} | {np.median(times['noisy']):.0f} | {sm[0]} px |")
    return "\n".join(rows) + "\n\n" + "\n".join(cost)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--doc", help="write the table into this markdown file's normals block")
    args = ap.parse_args(argv)
    t0 = time.time()
    rows = measure(all_cases())
    text = table(rows) + "\n\n" + smoothing_table()
    print(text)
    if args.doc:
        from docblock import cpu_name, markers, write_block
        head = (f"Written by `python tools/normals_robustness.py --doc {args.doc}` on "
                f"{cpu_name()} ({time.time() - t0:.0f} s). Relative L1 of the "
                "default pipeline's output with the changed depth to its output with the path tracer's smooth "
                "depth, per emission profile.\n\n")
        begin, end = markers("normals")
        write_block(Path(args.doc), begin, end, f"{begin}\n{head}{text}\n{end}", new_doc="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
