"""Every acceptance number of the core pipeline in one run (issue 2 with `psf: gaussian`,
issue 8's pyramid-vs-reference with `psf: apsf`), on scenes the calibration never saw
(seeds 301-306), printed as a table:

    python tools/acceptance.py [--speed-only]
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cases import cases, constant_depth_cases  # noqa: E402

from fogcli import apply  # noqa: E402
from fogcli.api import make_config  # noqa: E402
from metrics import rel_l1, ssim  # noqa: E402
from fogcli.device.plan import Timings  # noqa: E402
from fogcli.device.run import kernel_ms  # noqa: E402
from hdr_scenes import harbour_sample, scene  # noqa: E402


def fidelity(seeds):
    """psf: gaussian (issue 2): the pyramid, naive and Elek as printed against the reference."""
    rows = {"pyramid": [], "naive": [], "printed": []}
    for label, medium, rgb, z, sets in cases(seeds):
        sets = sets + ["render.psf=gaussian", "render.border=closed"]   # the issue-2 model as it was
        ref = apply(rgb, z, make_config(medium, sets=sets + ["render.method=reference"]))
        for name, extra in (("pyramid", []), ("naive", ["render.method=naive", "render.fetch=receiver"]),
                            ("printed", ["render.fetch=receiver", "render.c=0.8", "render.epsilon=2",
                                         "render.threshold=1"])):
            out = apply(rgb, z, make_config(medium, sets=sets + extra))
            rows[name].append((label, ssim(out, ref), rel_l1(out, ref)))
    return rows


def fidelity_apsf(seeds):
    """psf: apsf: the pyramid against its own reference, per border policy. The spread
    model does not apply to apsf, so only the angular cases (spread scale x0.5, x1)."""
    rows = {"open": [], "closed": [], "extend": []}
    for label, medium, rgb, z, sets in cases(seeds):
        if "/angular" not in label:
            continue
        for border in rows:
            s2 = sets + ["render.psf=apsf", f"render.border={border}"]
            ref = apply(rgb, z, make_config(medium, sets=s2 + ["render.method=reference"]))
            out = apply(rgb, z, make_config(medium, sets=s2))
            rows[border].append((label, ssim(out, ref), rel_l1(out, ref)))
    return rows


def speed(blocks: int = 4, runs: int = 4) -> None:
    """Kernel time of the default at 2 MPx, against a memory copy and against psf: gaussian.
    The two configs alternate in blocks of `runs` frames (a config's buffers stay warm within
    a block); each one's minimum over all its frames, so that a slow minute of a noisy
    machine does not fall on one side only."""
    w, h = 1888, 1062   # 2.0 MPx
    rgb, z, fov = harbour_sample(w, h)
    cfgs = {"apsf": make_config("fog"),
            "gaussian": make_config("fog", sets=["render.psf=gaussian", "render.border=closed"])}  # before issue 8
    for cfg in cfgs.values():
        apply(rgb, z, cfg)
    ms = {k: [] for k in cfgs}
    for _ in range(blocks):
        for k, cfg in cfgs.items():
            for _ in range(runs):
                t = Timings()
                apply(rgb, z, cfg, timings=t)
                ms[k].append(kernel_ms(t)[1])
    a = np.random.default_rng(0).random((h, w, 4), dtype=np.float32)
    ts = []
    for _ in range(9):
        s = time.perf_counter()
        b = a.copy()
        ts.append(time.perf_counter() - s)
        del b
    cp = float(np.min(ts) * 1e3)
    k, g = min(ms["apsf"]), min(ms["gaussian"])
    n = blocks * runs
    print(f"| speed at 2 MPx ({w}x{h}), default config | kernel_ms {k:.0f} = {k / cp:.1f} numpy copies "
          f"of the RGBA float32 image ({cp:.1f} ms, same run; min of {n} frames) | <= 45 copies |")
    print(f"| speed at 2 MPx, default (apsf) over psf: gaussian | {k:.0f} / {g:.0f} ms = {k / g:.2f}x (same run, "
          f"blocks of {runs} frames alternating, min of {n} each) | <= 1.3x |")


def main(argv=None):
    if "--speed-only" in (sys.argv[1:] if argv is None else argv):
        return speed()
    t0 = time.time()
    for border, r in fidelity_apsf((301, 302, 303, 304, 305, 306)).items():
        s = np.array([x[1] for x in r])
        l1 = np.array([x[2] for x in r])
        worst = r[int(s.argmin())][0]
        print(f"| apsf pyramid vs apsf reference, border {border}, {len(s)} held-out cases | SSIM mean {s.mean():.3f}, "
              f"worst {s.min():.3f} ({worst}), rel L1 mean {l1.mean():.3f}, worst {l1.max():.3f} | "
              f"mean SSIM >= 0.98, mean rel L1 <= 0.05 |", flush=True)
    rows = fidelity((301, 302, 303, 304, 305, 306))
    print("| measure | value | target |\n|---|---|---|")
    for name, target in (("pyramid", "mean SSIM >= 0.95, worst >= 0.88, mean rel L1 <= 0.12"),
                         ("naive", "(comparison)"), ("printed", "(comparison: Elek as printed)")):
        s = np.array([r[1] for r in rows[name]])
        l1 = np.array([r[2] for r in rows[name]])
        worst = rows[name][int(s.argmin())][0]
        print(f"| {name} vs reference, {len(s)} held-out cases | SSIM mean {s.mean():.3f}, worst {s.min():.3f} "
              f"({worst}), rel L1 mean {l1.mean():.3f}, worst {l1.max():.3f} | {target} |")
    for model in ("angular", "paper"):
        sel = [r for r in rows["pyramid"] if f"/{model}x" in r[0]]
        s = np.array([r[1] for r in sel])
        l1 = np.array([r[2] for r in sel])
        print(f"| pyramid, {model} only | SSIM mean {s.mean():.3f}, worst {s.min():.3f}, rel L1 mean {l1.mean():.3f} | |")

    for label, medium, rgb, z, sets in constant_depth_cases((2.0, 3.5, 7.0, 15.0)):
        out = apply(rgb, z, make_config(medium, sets=sets))
        ref = apply(rgb, z, make_config(medium, sets=sets + ["render.method=reference"]))
        sg = float(label.split("sigma")[1])
        m = int(math.ceil(3 * sg))
        print(f"| constant depth, {label} | rel L1 {rel_l1(out[m:-m, m:-m], ref[m:-m, m:-m]):.4f} (borders of 3 sigma cut) | <= 0.06 |")

    rgb, z, fov = scene(320, 240, seed=307)
    sa = [0.02, 0.01, 0.005]
    for method in ("pyramid", "naive", "reference"):
        out = apply(rgb, z, make_config("fog", sets=[f"medium.absorption={sa}", "medium.scattering=0",
                                                      f"render.method={method}", f"camera.fov={fov}"]))
        w = 320
        f = (w / 2) / math.tan(math.radians(fov) / 2)
        jj, ii = np.mgrid[0:240, 0:320] + 0.5
        d = np.minimum(z * np.sqrt(((ii - 160) / f) ** 2 + ((jj - 120) / f) ** 2 + 1), 1000.0)
        exact = rgb * np.exp(-np.array(sa) * d[..., None])
        print(f"| scattering 0, {method} | rel L1 to L exp(-sa D) {rel_l1(out, exact):.2e} | <= 1e-4 |")

    for psf, model, medium, scale in (("gaussian", "angular", "fog", 1.0), ("gaussian", "paper", "fog", 1.0),
                                      ("gaussian", "angular", "sea", 0.15), ("gaussian", "paper", "haze", 8.0),
                                      ("apsf", "angular", "fog", 1.0), ("apsf", "angular", "sea", 0.15),
                                      ("apsf", "angular", "haze", 8.0)):
        rgb, z, fov = scene(200, 150, seed=308, scale=scale)
        cfg = make_config(medium, sets=[f"camera.fov={fov}", f"render.spread_model={model}", "render.spread_scale=2",
                                        f"render.psf={psf}"])
        small = apply(rgb, z, cfg)
        big = apply(np.repeat(np.repeat(rgb, 2, 0), 2, 1), np.repeat(np.repeat(z, 2, 0), 2, 1), cfg)
        down = big.reshape(150, 2, 200, 2, 3).mean(axis=(1, 3))
        what = f"{psf} {model}" if psf == "gaussian" else "apsf"
        print(f"| resolution invariance, {medium} {what} x2 | rel L1 {rel_l1(down, small):.4f} | <= 0.06 |")

    speed()
    print(f"\n({time.time() - t0:.0f} s)")


if __name__ == "__main__":
    main()
