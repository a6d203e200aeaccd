"""Batch throughput (images/s) of `fogcli batch` on 1 MPx EXR frames with an embedded Z:
a folder with --jobs 1, the same frames as a jobs file (--jobs-file, one process), --jobs 2
and a 2-worker Dask LocalCluster, all in one run (the machine is noisy), against the
ceiling that a frame's core time allows, measured in every round. Prints a table and writes
its section of docs/performance.md.

    python tools/throughput.py [--frames 24] [--rounds 2]

Each mode runs as a fresh `fogcli batch` process, as a user runs it: the time includes
discovery, worker start-up (spawn, pyopencl import, kernels from PoCL's cache) and the
report. The steady rate leaves out everything before the first image is written.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tests"), str(ROOT / "tools")]

from docblock import cpu_kind, cpu_name, markers, publish_performance  # noqa: E402

BEGIN, END = markers(f"batch-throughput-{cpu_kind()}")


def make_frames(folder: Path, n: int, w: int, h: int) -> None:
    from hdr_scenes import scene
    from helpers import write_img

    for i in range(n):
        rgb, z, _ = scene(w, h, seed=900 + i)
        write_img(folder / f"frame.{i:04d}.exr", np.dstack([rgb, z]), ["R", "G", "B", "Z"])


def run_mode(src: Path, out: Path, extra: list[str]) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    env.pop("PYTHONDONTWRITEBYTECODE", None)    # as installed: fogcli's bytecode compiled once, not per worker
    if extra and extra[0] == "one-thread":         # PoCL and OpenImageIO on one thread per process
        extra = extra[1:]
        env.update(POCL_MAX_PTHREAD_COUNT="1", OPENIMAGEIO_THREADS="1")
    report = out.with_suffix(".json")
    if extra and extra[0] == "jobs-file":          # the same frames, a line each
        jobs = out.with_suffix(".jsonl")
        out.mkdir(parents=True, exist_ok=True)
        jobs.write_text("".join(json.dumps({"input": str(f), "output": str(out / f.name)}) + "\n"
                                for f in sorted(src.glob("frame.*.exr"))))
        args = ["--jobs-file", str(jobs), *extra[1:]]
    else:
        args = [str(src), str(out), *extra]
    ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "fogcli", "batch", *args, "-q", "--report", str(report)],
                       capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = ru1.ru_utime + ru1.ru_stime - ru0.ru_utime - ru0.ru_stime     # the command and its workers
    if r.returncode != 0:
        raise SystemExit(f"batch {extra} failed: {r.stderr}")
    rep = json.loads(report.read_text())
    done = len(rep["done"])
    mtimes = sorted(Path(d["output"]).stat().st_mtime for d in rep["done"])
    steady = (done - 1) / (mtimes[-1] - mtimes[0]) if done > 1 and mtimes[-1] > mtimes[0] else float("nan")
    return {"wall": wall, "rate": done / wall, "steady": steady, "done": done, "out": out.name,
            "cpu_ms": cpu / done * 1e3, "busy": cpu / wall / (os.cpu_count() or 1)}


PROFILE_FRAMES = 6


def profile(src: Path, single: bool) -> dict:
    """Per-stage wall times (ms) of a frame in this process, through the stages a batch runs
    (fogcli.frame.job: load = read and depth, compute = upload, kernels, download; store = the EXR
    write): the median over PROFILE_FRAMES of the batch's frames, after one to warm up; with
    single=True PoCL and OpenImageIO run one thread each, which makes the sum the core time.
    Medians over several frames, like the batch's rates (an average over its frames): the
    best of each stage summed stages that no one frame had together, and at a moment when
    the VM ran fast (363 ms against a 535 ms median, same frame, same minute, on an AMD EPYC)."""
    import OpenImageIO as oiio

    from fogcli.frame.job import Job, compute, load, store
    from fogcli.config.presets import assemble

    if single:
        oiio.attribute("threads", 1)
        oiio.attribute("exr_threads", 1)
    cfg = assemble("fog")
    frames = sorted(src.glob("frame.*.exr"))[:PROFILE_FRAMES + 1]
    times: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k, frame in enumerate(frames):
            t = [time.perf_counter()]
            st = load(Job(str(frame), str(Path(tmp) / "out.exr")), cfg)
            t.append(time.perf_counter())
            st = compute(st, cfg)
            t.append(time.perf_counter())
            store(st, cfg)
            t.append(time.perf_counter())
            for name, a, b in zip(("read and depth", "device", "write"), t, t[1:]):
                if k:
                    times.setdefault(name, []).append((b - a) * 1e3)
    return {name: float(np.median(v)) for name, v in times.items()}


def profile_in_subprocess(src: Path, single: bool) -> dict:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), str(ROOT / "tests")]))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if single:
        env["POCL_MAX_PTHREAD_COUNT"] = "1"
    r = subprocess.run([sys.executable, __file__, "--profile", str(src)] + (["--single"] if single else []),
                       capture_output=True, text=True, env=env, check=True)
    return json.loads(r.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--profile", help=argparse.SUPPRESS)
    ap.add_argument("--single", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    args = ap.parse_args()
    if args.profile:
        print(json.dumps(profile(Path(args.profile), args.single)))
        return
    w, h = 1336, 748          # 1.0 MPx
    modes = {"--jobs 1": ["--jobs", "1"], "--jobs-file (one process)": ["jobs-file"], "--jobs 2": ["--jobs", "2"],
             "Dask LocalCluster, 2 workers": ["--scheduler", "local:2"],
             "--jobs 1, one thread per process": ["one-thread", "--jobs", "1"],
             "--jobs 2, one thread per process": ["one-thread", "--jobs", "2"]}
    best: dict[str, dict] = {}
    prof: dict[str, dict] = {}
    of: dict[str, list] = {}        # (whole, steady, cores busy) / the ceiling measured before it, per round
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "in"
        src.mkdir()
        make_frames(src, args.frames, w, h)
        if True:
            ncpu = os.cpu_count() or 1
            for k in range(args.rounds):               # modes interleaved, best of the rounds
                this = {"all threads": profile_in_subprocess(src, False)}
                for i, (name, extra) in enumerate(modes.items()):
                    # the ceiling's core time right before each mode (this VM's speed drifts within
                    # a round): each mode against its own; the fastest profile is shown
                    one = profile_in_subprocess(src, True)
                    if "one thread" not in this or sum(one.values()) < sum(this["one thread"].values()):
                        this["one thread"] = one
                    res = run_mode(src, Path(tmp) / f"out{k}_{i}", extra)
                    ceil = ncpu / sum(one.values()) * 1e3
                    if name not in best or res["rate"] > best[name]["rate"]:
                        best[name] = res
                    of.setdefault(name, []).append((res["rate"] / ceil, res["steady"] / ceil, res["busy"]))
                if not prof or sum(this["one thread"].values()) < sum(prof["one thread"].values()):
                    prof = this
    base = best["--jobs 1"]
    core, wall1 = sum(prof["one thread"].values()), sum(prof["all threads"].values())
    ceiling = ncpu / core * 1e3
    from fogcli.device.runtime import get_runtime

    cpu = get_runtime(None).info.label()
    lines = [BEGIN, f"## Batch throughput on {cpu_name()}", "",
             f"`python tools/throughput.py` on {cpu}, {ncpu} cores ({args.frames} frames of {w}x{h} = "
             f"{w * h / 1e6:.2f} MPx, EXR with embedded Z, default fog; best of {args.rounds} interleaved rounds). "
             "Images/s over the whole `fogcli batch` command (start-up, worker spawn and report included) and in "
             "the steady state (first to last output written). `of the ceiling`: against the rate that a frame's "
             "core time alone allows (cores / the one-thread sum below, measured right before the mode's run; "
             f"median of the rounds; at the fastest profile {ncpu} cores / {core:.0f} ms = {ceiling:.2f} "
             "images/s). "
             "`cores busy` (median of the rounds): the same against the core time a frame costs in the batch "
             "itself (`core ms a frame`, of the fastest round), which needs no second measurement.", "",
             "| mode | images/s | of the ceiling | steady images/s | of the ceiling | vs --jobs 1 | wall s | "
             "core ms a frame | cores busy |",
             "|---|---|---|---|---|---|---|---|---|"]
    med = {name: [float(np.median([x[i] for x in v])) for i in range(3)] for name, v in of.items()}
    for name, r in best.items():
        lines.append(f"| {name} | {r['rate']:.2f} | {100 * med[name][0]:.0f} % | {r['steady']:.2f} | "
                     f"{100 * med[name][1]:.0f} % | {r['rate'] / base['rate']:.2f}x | {r['wall']:.1f} | "
                     f"{r['cpu_ms']:.0f} | {100 * med[name][2]:.0f} % |")
    lines += ["", "The last two rows hold every process to one thread (POCL_MAX_PTHREAD_COUNT=1, "
              "OPENIMAGEIO_THREADS=1): they show how the worker processes themselves scale, "
              f"{best['--jobs 2, one thread per process']['rate'] / best['--jobs 1, one thread per process']['rate']:.2f}x "
              "for two, where the default `--jobs 1` already uses both cores."]
    lines += ["", "`--jobs-file`: the same frames listed in a jobs file (docs/distributed.md), one process as "
              "`--jobs 1`.",
              "", "`core ms a frame`: the command's user + system time (its workers') "
              "over the frames; `cores busy`: that time over wall time x cores. Of the ceiling = cores busy x "
              "(the one-thread core time below / core ms a frame): what keeps a mode below the ceiling is idle "
              "cores, or frames that cost more core time in a batch (start-up, frames competing for caches and "
              "memory bandwidth) than alone."]
    lines += ["", f"Where the time of a frame goes (ms, one process, the stages of fogcli.frame.job as a batch runs them, median of {PROFILE_FRAMES} of the batch's frames, the fastest of the run's profiles): "
              "with PoCL and OpenImageIO on "
              "all cores, as `--jobs 1` runs, and on one thread each, whose sum is the core time a frame costs.",
              "", "| threads | read and depth | device (upload, kernels, download) | write EXR (zip) | sum |",
              "|---|---|---|---|---|"]
    for name, p in prof.items():
        lines.append(f"| {name} | {p['read and depth']:.0f} | {p['device']:.0f} | {p['write']:.0f} | "
                     f"{sum(p.values()):.0f} |")
    # against --jobs 1's own steady rate: one process overlaps reads and writes with the
    # device, so the sum of its stages (wall1) is not what a batch frame takes
    lines += ["", f"With {ncpu} cores, any number of workers can at best finish a frame every {core:.0f} / {ncpu} = "
              f"{core / ncpu:.0f} ms of core time ({ceiling:.2f} images/s), {ceiling / base['steady']:.2f}x the "
              f"{base['steady']:.2f} images/s that `--jobs 1` reaches in the steady state (its stages one after "
              f"the other: {wall1:.0f} ms a frame; it overlaps reads and writes with the device): that is the "
              "ceiling of `--jobs 2` over `--jobs 1` here, with no start-up and no frame costing more in company "
              "than alone, because `--jobs 1` already keeps both cores busy in the kernels (PoCL threads) and in "
              "the EXR compression (OpenEXR threads)."]
    lines.append(END)
    publish_performance(lines, Path(args.out))


if __name__ == "__main__":
    main()
