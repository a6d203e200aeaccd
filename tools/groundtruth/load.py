"""Read the ground-truth renders (numpy only; Mitsuba is not needed).

    from groundtruth.load import cases
    for c in cases(heldout=False, outside=False):
        c["name"], c["scene"], c["medium_name"], c["L"], c["depth"], c["medium"], c["meta"]

L: (H, W, 3) float32, scene-linear radiance in vacuum (pixel-averaged, box filter).
depth: (H, W) float32, ray length at the pixel centre in metres (+inf where nothing is hit;
    every scene here is closed, so there is none). depth_mean: the pixel-averaged ray length.
medium: (H, W, 3) float32, the path-traced image in the medium (same pixel footprint as L).
meta: dict (fov = horizontal degrees, width, height, sigma_a, sigma_s, g, outside, heldout, spp,
    noise, ...). Camera: origin, looking down -Z, +Y up, +X right; pixel (i, j) (column, row from
    the top) looks along ((i+0.5-W/2)/f, -(j+0.5-H/2)/f, -1), f = (W/2)/tan(fov/2).
"""
import functools
import glob
import json
import os
import time

import numpy as np

RENDERS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "renders")
NOISE_DEF = ("noise = sum|A-B| / sum(A+B) over all pixels and channels, A and B two independent "
             "halves (different seeds) of the medium render; estimates the relative L1 error of "
             "the stored image (A+B)/2 against the converged image")


def halves_noise(A, B):
    """The renders' `noise` (NOISE_DEF) of two independent halves A and B."""
    return float(np.abs(A - B).sum() / max((A + B).sum(), 1e-30))


def alternate_halves(render_pass, pass_spp, stop, log, k0=0, acc=(0.0, 0.0), n=(0, 0)):
    """Passes of pass_spp samples go to whichever of two independent halves A and B has fewer
    (A on a tie, so from nothing they alternate A, B, A, ...) until stop(spp A, spp B, noise,
    seconds), asked after each pass that leaves B with at least A's samples. render_pass(k) is
    the sum of pass k's samples; k counts on from k0 (an earlier run's passes). acc, n: the
    halves' sums and spp so far (an earlier image without halves is a half A of its own: the new
    passes fill B up to it, then alternate). Returns (sum A, sum B, spp A, spp B, noise, seconds)."""
    acc, n = list(acc), list(n)
    t0, k = time.time(), k0
    while True:
        h = 1 if n[1] < n[0] else 0
        acc[h] = acc[h] + render_pass(k)
        n[h] += pass_spp
        k += 1
        if n[1] >= n[0]:
            noise = halves_noise(acc[0] / n[0], acc[1] / n[1])
            el = time.time() - t0
            if stop(n[0], n[1], noise, el):
                log(f"    {n[0] + n[1]} spp, noise {noise:.4f}, {el:.0f} s")
                return acc[0], acc[1], n[0], n[1], noise, el


def load(path):
    with np.load(path) as z:
        meta = json.loads(str(z["meta"]))
        return {"name": os.path.splitext(os.path.basename(path))[0],
                "scene": meta["scene"], "medium_name": meta["medium"],
                "L": z["L"].astype(np.float32), "depth": z["depth"].astype(np.float32),
                "depth_mean": z["depth_mean"].astype(np.float32) if "depth_mean" in z else None,
                "medium": z["medium"].astype(np.float32), "noise": float(z["noise"]), "meta": meta}


def cases(heldout=None, outside=None, medium=None, scene=None, directory=RENDERS):
    """Yield every case (sorted by name), optionally filtered by the flags / names."""
    for p in sorted(glob.glob(os.path.join(directory, "*.npz"))):
        c = load(p)
        m = c["meta"]
        if heldout is not None and bool(m["heldout"]) != bool(heldout):
            continue
        if outside is not None and bool(m["outside"]) != bool(outside):
            continue
        if medium is not None and c["medium_name"] != medium:
            continue
        if scene is not None and c["scene"] != scene:
            continue
        yield c


@functools.lru_cache(maxsize=1)
def comparison():
    """tools/groundtruth.py, the comparison against these renders (case_sets, blend, blocks,
    run_case, gt_load), as a module: its name is this package's, so it cannot be imported
    by name. Loaded once."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "gt_bench", os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "groundtruth.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


if __name__ == "__main__":
    for c in cases():
        m = c["meta"]
        print(f'{c["name"]:18s} outside={m["outside"]!s:5s} heldout={m["heldout"]!s:5s} '
              f'spp={m["spp"]:5d} noise={c["noise"]:.3f} L.max={c["L"].max():8.2f} '
              f'medium.mean={c["medium"].mean():.4f} depth={np.nanmin(c["depth"]):.1f}..{np.nanmax(c["depth"]):.0f}')
