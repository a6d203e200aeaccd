"""Kernel times per stage at 0.5-8 MPx, as multiples of one numpy copy of the RGBA float32
image measured in the same run, on this CPU and, through tools/avx2/run.sh, as the
kernels compile for an AVX2-only AMD EPYC (Zen 1, LLVM znver1); the reference at 0.25 MPx;
fidelity of pyramid and naive against the reference on held-out scenes. Prints a table and
writes docs/performance.md.

    python tools/performance.py [--quick] [--all]

--all first runs the scripts that own the doc's other blocks (end to end, batch throughput,
vectorisation, host copies, the huge image; ~20 minutes): every number of the doc for this
kind of CPU.
"""
from __future__ import annotations

import argparse
import functools
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cases import cases  # noqa: E402
from docblock import cpu_kind, cpu_name, markers  # noqa: E402

from fogcli import apply  # noqa: E402
from fogcli.api import make_config  # noqa: E402
from metrics import rel_l1, ssim  # noqa: E402
from fogcli.device.plan import Timings  # noqa: E402
from fogcli.device.run import kernel_ms  # noqa: E402
from fogcli.device.runtime import get_runtime  # noqa: E402
from hdr_scenes import harbour_sample  # noqa: E402
from fogcli.config.model import Render  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def copy_ms(shape, reps=7):
    """A numpy copy of the image into new memory (a.copy()), median of reps: the unit the issues'
    targets were set in. It counts the new memory's page faults when glibc hands out fresh pages,
    and not when it reuses freed ones (below its 32 MB mmap limit, after the first copy): the
    same 2 MPx copy took 3.3 ms in one process and 7-8.6 ms in the next on an AMD EPYC, and
    up to 130 ms while the VM compacted huge pages. copy_in_place_ms is the stable unit."""
    a = np.random.default_rng(0).random(shape, dtype=np.float32)
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        b = a.copy()
        ts.append(time.perf_counter() - t)
    del b
    return float(np.median(ts) * 1e3)


@functools.lru_cache(maxsize=2)
def _copy_pair(shape):
    """Source and destination of copy_in_place_ms, made once per shape: it is called after
    every kernel run to pair with it."""
    a = np.random.default_rng(0).random(shape, dtype=np.float32)
    return a, np.ones_like(a)


def copy_in_place_ms(shape, reps=15):
    """A numpy copy of the image into an array that exists already (its pages faulted in),
    median of reps: no page faults, as the kernels write into buffers kept from frame to frame.
    3.0-3.9 ms at 2 MPx on the same AMD EPYC across processes."""
    a, b = _copy_pair(tuple(shape))
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        np.copyto(b, a)
        ts.append(time.perf_counter() - t)
    return float(np.median(ts) * 1e3)


def size_for(mpx):
    h = int(round(math.sqrt(mpx * 1e6 * 9 / 16)))
    return int(round(h * 16 / 9)), h


def stage_table(mpxs, reps):
    rows = []
    cfg = make_config("fog")
    for mpx in mpxs:
        w, h = size_for(mpx)
        rgb, z, fov = harbour_sample(w, h)
        apply(rgb, z, cfg)   # build programs and buffers
        best, paired = None, []
        for _ in range(reps):
            t = Timings()
            apply(rgb, z, cfg, timings=t)
            stages, total = kernel_ms(t)
            if best is None or total < best[1]:
                best = (stages, total)
            # each run against an in-place copy taken right after it: the VM's speed drifts by
            # 30 % between processes and minutes, much less within a second
            paired.append(total / copy_in_place_ms((h, w, 4), reps=5))
        cp, cpi = copy_ms((h, w, 4)), copy_in_place_ms((h, w, 4))
        rows.append((mpx, w, h, best[0], best[1], cp, cpi, float(np.median(paired))))
        print(f"{mpx:>4} MPx {w}x{h}: kernel {best[1]:.1f} ms = {best[1] / cp:.1f} copies into new memory, "
              f"{best[1] / cpi:.1f} in place; paired median {np.median(paired):.1f}; "
              + " ".join(f"{k} {v:.1f}" for k, v in best[0].items()), flush=True)
    return rows


LAMP = "lights=[{type: point, position: [2, 3, -15], intensity: 400}]"    # also tools/lights.py's

# The scripts that write the other blocks of docs/performance.md, run by --all (enqueue_cost.py,
# huge_image.py and transfer_budget.py write docs/performance.md itself, whatever --out says)
OTHERS = [("end_to_end.py", "--rounds", "7", "--out", "{out}"), ("throughput.py", "--rounds", "3", "--out", "{out}"),
          ("pocl_vectorisation.py", "--doc", "{out}"), ("enqueue_cost.py",), ("huge_image.py",),
          ("transfer_budget.py",)]


def light_stage(reps):
    """The `lights` stage of one point light in fog at 2 MPx (its airlight kernel and the two
    that add its light), best of reps, and the copy it is counted in."""
    w, h = size_for(2)
    rgb, z, fov = harbour_sample(w, h)
    cfg = make_config("fog", sets=[LAMP])
    apply(rgb, z, cfg)
    best = 1e9
    for _ in range(reps):
        t = Timings()
        apply(rgb, z, cfg, timings=t)
        best = min(best, sum((e.profile.end - e.profile.start) * 1e-6 for e in t.stages["lights"]))
    return best, copy_ms((h, w, 4)), copy_in_place_ms((h, w, 4))


def reference_time():
    w, h = size_for(0.25)
    rgb, z, fov = harbour_sample(w, h)
    cfg = make_config("fog", sets=["render.method=reference"])
    apply(rgb, z, cfg)
    t = Timings()
    t0 = time.perf_counter()
    apply(rgb, z, cfg, timings=t)
    wall = (time.perf_counter() - t0) * 1e3
    cp = copy_ms((h, w, 4))
    pyr = Timings()
    apply(rgb, z, make_config("fog"), timings=pyr)
    return w, h, kernel_ms(t)[1], wall, cp, kernel_ms(pyr)[1]


def fidelity(seeds):
    """Each model against its own reference: the default (psf apsf) on the angular cases
    (the spread model does not apply to it), the Gaussian model (border closed, as it was
    calibrated) with its three composites on every case."""
    out = {"apsf": [], "pyramid": [], "naive": [], "receiver": []}
    gauss = ["render.psf=gaussian", "render.border=closed"]
    for label, medium, rgb, z, sets in cases(seeds):
        if "/angular" in label:
            ref = apply(rgb, z, make_config(medium, sets=sets + ["render.method=reference"]))
            # in the reference's model: no receiver weight, the image's pixels throughout
            o = apply(rgb, z, make_config(medium, sets=sets + ["render.halo_depth=none", "render.spread_space=pixels"]))
            out["apsf"].append((ssim(o, ref), rel_l1(o, ref)))
        ref = apply(rgb, z, make_config(medium, sets=sets + gauss + ["render.method=reference"]))
        for name, extra in (("pyramid", []), ("naive", ["render.method=naive"]),
                            ("receiver", ["render.fetch=receiver"])):
            o = apply(rgb, z, make_config(medium, sets=sets + gauss + extra))
            out[name].append((ssim(o, ref), rel_l1(o, ref)))
    return {k: np.array(v) for k, v in out.items()}


def avx2_rows(mpxs, reps):
    """The stage table in a child process that PoCL takes for an AMD EPYC Zen 1 (run before
    this process touches OpenCL: a child is never forked after that). None where this
    machine cannot emulate it (no CPUID faulting)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "rows.json"
        cmd = [str(ROOT / "tools" / "avx2" / "run.sh"), "znver1", sys.executable, __file__,
               "--stages-json", str(out), "--sizes", ",".join(map(str, mpxs)), "--reps", str(reps)]
        r = subprocess.run(cmd, env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
        return json.loads(out.read_text()) if r.returncode == 0 and out.exists() else None


def stage_md(rows) -> list[str]:
    stages = sorted({s for r in rows for s in r[3]}, key=["upload", "preprocess", "pyramid", "composite", "download"].index)
    md = ["| MPx | size | " + " | ".join(f"{s} ms" for s in stages) + " | kernel_ms | copy ms, new memory | "
          "kernel_ms in those copies | copy ms, in place | kernel_ms in those copies | each run in the copy "
          "after it (median) |",
          "|---" * (len(stages) + 8) + "|"]
    for mpx, w, h, st, tot, cp, cpi, paired in rows:
        md.append(f"| {mpx} | {w}x{h} | " + " | ".join(f"{st.get(s, 0):.1f}" for s in stages)
                  + f" | {tot:.1f} | {cp:.2f} | {tot / cp:.1f} | {cpi:.2f} | {tot / cpi:.1f} | {paired:.1f} |")
    return md


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    ap.add_argument("--all", action="store_true",
                    help="first run every script that owns a block of the doc (OTHERS), for this CPU's kind")
    ap.add_argument("--stages-json", help=argparse.SUPPRESS)      # the child of avx2_rows
    ap.add_argument("--sizes", help=argparse.SUPPRESS)
    ap.add_argument("--reps", type=int, default=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.stages_json:
        rows = stage_table([float(x) if "." in x else int(x) for x in args.sizes.split(",")], args.reps)
        Path(args.stages_json).write_text(json.dumps(dict(device=get_runtime(None).device.version, rows=rows,
                                                          light=light_stage(args.reps))))
        return
    if args.all:          # before this process touches OpenCL: nothing forks after it
        for script, *rest in OTHERS:
            rest = [args.out if a == "{out}" else a for a in rest]
            print("+", script, *rest, flush=True)
            subprocess.run([sys.executable, str(ROOT / "tools" / script), *rest], check=True)
    reps = 2 if args.quick else 5
    amd = avx2_rows((1, 2) if args.quick else (1, 2, 8), reps)
    dev = get_runtime(None).info.label()
    mpxs = (0.5, 1, 2) if args.quick else (0.5, 1, 2, 4, 8)
    rows = stage_table(mpxs, reps=reps)
    light = light_stage(reps)
    ref = reference_time()
    print(f"reference at {ref[0]}x{ref[1]}: kernel {ref[2]:.0f} ms, wall {ref[3]:.0f} ms "
          f"({ref[2] / ref[5]:.0f}x the pyramid)", flush=True)
    fid = fidelity((201, 202) if args.quick else (201, 202, 203, 204))
    for k, a in fid.items():
        print(f"{k}: SSIM mean {a[:, 0].mean():.3f} worst {a[:, 0].min():.3f}, rel L1 mean {a[:, 1].mean():.3f} "
              f"worst {a[:, 1].max():.3f}", flush=True)

    kind = cpu_kind()
    r0 = {r[0]: r[4] for r in rows}
    scale = f" kernel_ms at 8 MPx = {r0[8] / r0[1]:.1f}x that at 1 MPx." if 8 in r0 and 1 in r0 else ""
    begin, end = markers(f"kernels-{kind}")
    md = [begin, f"## Kernels on {cpu_name()}", "",
          f"Generated by `python tools/performance.py` on `{dev}` ({cpu_name()}, "
          f"{os.cpu_count()} cores), {time.strftime('%Y-%m-%d')}. Kernel times are OpenCL profiling-event times (upload and "
          f"download included), best of {reps} runs of the default config (`fog`, kernel 4, linear-bicubic, "
          f"source collapse, psf {Render().psf}, border {Render().border}, emission {Render().emission_profile}) on the harbour scene at each size. "
          "Copies: the time as a multiple of one numpy copy of the RGBA float32 image, measured in the same run "
          "(the machine is noisy; ratios are what to compare), in two units. New memory (`a.copy()`, median of 7): "
          "the unit the targets were set in; it includes page faults when the allocator hands out fresh pages and "
          "not when it reuses freed ones, so it is bimodal (the same 2 MPx copy took 3.3 ms in one process, "
          "7-8.6 ms in the next on an AMD EPYC). In place (`np.copyto` into an existing array, median of 15): "
          "no page faults, as the kernels write into buffers kept from frame to frame; it still moves with the "
          "VM, and an image that fits in the last-level cache (0.5 MPx here) is copied at the cache's speed. The "
          "last column pairs every run with an in-place copy taken right after it and gives the median of those "
          "ratios: the least moved by the VM's drift." + scale, ""] + stage_md(rows)
    lamp = (f"One point light in fog at 2 MPx (`{LAMP.replace('=', ': ', 1)}`; "
            "its `lights` stage: the airlight kernel and the two that add its light), on top of the above: ")
    md += ["", lamp + f"{light[0]:.1f} ms = {light[0] / light[1]:.1f} copies into new memory, "
           f"{light[0] / light[2]:.1f} in place."]
    md += ["", "### The same kernels compiled for an AVX2-only CPU", ""]
    if amd is None:
        md.append(("This CPU is AVX2-only itself: the table above is that kind of machine, measured directly. "
                   if kind == "avx2" else "")
                  + "The Zen 1 (znver1) compile of tools/avx2/run.sh was not measured: it needs CPUID faulting, "
                  "which this CPU or its hypervisor does not offer.")
    else:
        r1 = {r[0]: r[4] for r in amd["rows"]}
        md += [f"`tools/avx2/run.sh znver1` makes PoCL see an AMD EPYC of the first Zen generation (AVX2, no "
               f"AVX-512) on this {cpu_name()}: `{amd['device']}`. The code is what such a machine compiles and runs; "
               "memory, caches and clock are this machine's, so these are the AVX2 code's times here, in copies "
               "measured in its own process."
               + (f" kernel_ms at 8 MPx = {r1[8] / r1[1]:.1f}x that at 1 MPx." if 8 in r1 and 1 in r1 else ""), ""]
        md += stage_md(amd["rows"])
        al = amd["light"]
        md += ["", lamp + f"{al[0]:.1f} ms = {al[0] / al[1]:.1f} copies into new memory, {al[0] / al[2]:.1f} in place."]
    md += [end]
    # the blocks other runs and scripts own: the other CPU kind's kernels (run there), and
    # throughput.py's, end_to_end.py's, pocl_vectorisation.py's, ... (kept as they are)
    old = Path(args.out).read_text() if Path(args.out).exists() else ""
    blocks = {m.group(1): m.group(0) for m in re.finditer(r"<!-- ([\w-]+): begin -->.*?<!-- \1: end -->", old, flags=re.S)}
    blocks.pop(f"kernels-{kind}", None)
    head = ["# Performance", "", "Every number here comes from `python tools/performance.py --all` (or the "
            "script each block names) on the CPU the block names. Each kind of CPU (AVX-512, AVX2) has blocks of "
            "its own: a run replaces its kind's and keeps the others.", ""]
    kernels = {k: b for k, b in blocks.items() if k.startswith("kernels-")} | {f"kernels-{kind}": "\n".join(md)}
    md = head + ["\n\n".join(b for _, b in sorted(kernels.items()))]
    md += ["", f"Reference (default psf) at {ref[0]}x{ref[1]} on {cpu_name()}: {ref[2]:.0f} ms of kernels ({ref[3]:.0f} ms wall), "
           f"{ref[2] / ref[4]:.0f} copies, {ref[2] / ref[5]:.0f}x the pyramid at the same size.", "",
           "## Fidelity against the reference", "",
           "Held-out scenes (seeds 201-204 of `tools/cases.py`: fog, haze, sea; night and day; "
           "angular x0.5, x1 and paper x0.5, x2, x8).", "",
           "| method | SSIM mean | SSIM worst | rel. L1 mean | rel. L1 worst |", "|---|---|---|---|---|"]
    names = {"apsf": "default (psf apsf) with halo_depth none and spread_space pixels (the reference's model) vs "
                     "the apsf reference, angular cases",
             "pyramid": "psf gaussian, source collapse, vs the Gaussian reference",
             "receiver": "psf gaussian, Elek eq. 10-12 receiver fetch", "naive": "psf gaussian, naive"}
    for k, a in fid.items():
        md.append(f"| {names[k]} | {a[:, 0].mean():.3f} | {a[:, 0].min():.3f} | {a[:, 1].mean():.3f} | {a[:, 1].max():.3f} |")
    rest = [b for k, b in blocks.items() if not k.startswith("kernels-")]
    Path(args.out).write_text("\n".join(md) + "\n" + "".join("\n" + b + "\n" for b in rest))
    print("wrote", args.out)


if __name__ == "__main__":
    main()
