"""Halos hidden behind nearer surfaces: a measurement for issue 40 item 1 (the ground), not a
stage of fogcli.

The point spread spreads a source's scattered light over every pixel around it whatever
their depth. A receiver nearer than the source ends its ray before the medium around the
source: the part of the halo that scattering near the source makes should not reach it (a
ground's nearer rows below a far patch, a pole in front of a lamp). This script rebuilds
fogcli's reference (method `reference`: the point spread as its sum of Gaussians, each pixel
weighted by its own shares) in numpy from the device's level 0 and table, with the border
open or extended by a quarter frame, and checks it against the device's numbers; then
weights each Gaussian j (angular width a_j = sigma_j / f) from a source at depth d_s to a
receiver at d_r < d_s by

    O = exp(-(d_s - d_r) / (k a_j d_s))

(the scattering that makes that part of the halo lies within ~ k a_j d_s in front of the
source), source depths in 24 bins. `renorm`: each source's kernel scaled back to its whole
energy over the receivers it reaches (the hidden share goes to the others; not physical:
surfaces take it). Relative L1 / scattered energy against the path tracer per case and k.

    python tools/halo_occlusion.py [--cases ground-fog,ground-haze] [--k 0,1,2,4] [--border extend]
                                   [--renorm]
"""
from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

BINS = 24


def level0(case):
    """The frame on the device up to preprocess: (level 0 scattered RGB + log P, direct RGB,
    the table, focal length, config)."""
    from fogcli.api import make_config
    from fogcli.device import preprocess as pp
    from fogcli.device.plan import Timings, get_plan
    from fogcli.device.runtime import get_runtime
    from groundtruth.load import comparison

    cfg = make_config(None, sets=comparison().case_sets(case["meta"]))
    h, w = case["depth"].shape
    cfg = cfg.model_copy(update={"camera": cfg.camera.for_size(w, h)})
    rt = get_runtime(None)
    plan = get_plan(rt, w, h, cfg, ())
    rgba = np.concatenate([case["L"], np.ones((h, w, 1), np.float32)], -1)
    pp.upload(plan, rgba, case["depth"], Timings())
    pp.preprocess(plan, Timings())
    chain = np.empty(plan.chain.size // 4, np.float32)
    rt.cl.enqueue_copy(rt.queue, chain, plan.chain)
    rt.queue.finish()
    l0 = chain[:4 * w * h].reshape(h, w, 4).astype(np.float64)
    direct = plan.download(plan.direct, 4, Timings())[..., :3].astype(np.float64)
    return l0, direct, plan.lut_host.astype(np.float64), cfg.camera.focal(w), cfg


def spread(case, ks, extend: bool, renorm: bool) -> dict:
    """{k: (relative L1, scattered energy over the path tracer's)}; k = 0: no occlusion."""
    import cv2

    from fogcli.physics import apsf, apsf_lut
    from metrics import rel_l1
    from fogcli.device.border_size import border_band
    from oracles import continue_edges, lut_at

    l0, direct, lut, f, cfg = level0(case)
    h, w = l0.shape[:2]
    sig = apsf.load_table()["sigma_u"] * f * cfg.render.spread_scale
    shape0 = apsf_lut.lut_offsets(int(lut[3]) - 1, len(sig))["shape"]   # lut[3]: the levels the kernels read
    d = np.minimum(case["depth"].astype(np.float64), 1e4)
    edges = np.quantile(d, np.linspace(0, 1, BINS + 1))
    edges[-1] += 1e-6
    binid = np.clip(np.searchsorted(edges, d, side="right") - 1, 0, BINS - 1)
    dmid = np.array([d[binid == b].mean() if (binid == b).any() else 1.0 for b in range(BINS)])
    mx, my = (int(round(cfg.render.border_margin * w)), int(round(cfg.render.border_margin * h))) if extend else (0, 0)

    def pad(x):
        return cv2.copyMakeBorder(x, my, my, mx, mx, cv2.BORDER_REPLICATE)

    def blur(x, s):        # beyond the (padded) frame: nothing
        return cv2.GaussianBlur(x, (0, 0), s, borderType=cv2.BORDER_CONSTANT) if s >= 0.25 else x

    binp, dp = pad(binid.astype(np.float32)).astype(int), pad(d.astype(np.float32)).astype(np.float64)
    outs = {k: direct.copy() for k in ks}
    for j, sj in enumerate(sig):
        src = np.stack([lut_at(lut, shape0 + (j * 3 + c) * apsf.NP, l0[..., 3]) * l0[..., c] for c in range(3)], -1)
        if src.max() <= 0:
            continue
        srcp, a = continue_edges(src, mx, my, *border_band(cfg, w, h), l0[..., 3]).astype(np.float32), sj / f
        for b in range(BINS):
            m = binp == b
            if not m.any():
                continue
            for k in ks:
                src_b = np.where(m[..., None], srcp, 0.0)
                if k and renorm:
                    occ = np.exp(-np.maximum(0.0, dmid[b] - dp) / (k * a * dmid[b])).astype(np.float32)
                    reach = blur(occ, sj) / np.maximum(blur(np.ones_like(occ), sj), 1e-12)
                    src_b = src_b / np.maximum(reach, 1e-3)[..., None]
                got = blur(src_b.astype(np.float32), sj)[my:my + h, mx:mx + w].astype(np.float64)
                occ = np.exp(-np.maximum(0.0, dmid[b] - d) / (k * a * dmid[b]))[..., None] if k else 1.0
                outs[k] += occ * got
    ref = case["medium"]
    return {k: (rel_l1(out.astype(np.float32), ref), (out - direct).sum() / (ref - direct).sum())
            for k, out in outs.items()}


def main(argv=None) -> int:
    from groundtruth.load import cases

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="ground-fog,ground-haze,ground-sea", help="names, or all")
    ap.add_argument("--k", default="0,1,2,4")
    ap.add_argument("--border", choices=("open", "extend"), default="extend")
    ap.add_argument("--renorm", action="store_true")
    args = ap.parse_args(argv)
    ks = [float(x) for x in args.k.split(",")]
    names = args.cases.split(",")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for case in cases():
            if names != ["all"] and case["name"] not in names:
                continue
            r = spread(case, ks, args.border == "extend", args.renorm)
            print(case["name"], " ".join(f"k={k:g}: {v[0]:.3f} / {v[1]:.2f}" for k, v in r.items()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
