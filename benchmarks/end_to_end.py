"""End to end (issue 12): `fogcli apply` of a 2 MPx EXR with an embedded Z, as a user runs
it (a new process by itself; and the first, second and later runs with the server that
the first one starts; kernel caches warm), against
OpenImageIO's own write + read of the same file in the same run. Per EXR compression (the
output follows the input's), with the stage times fogcli reports (`--timings`). Writes its
block of docs/performance.md.

    python benchmarks/end_to_end.py [--rounds 3]        # about 4 minutes
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "benchmarks"), str(ROOT / "tests")]

from docblock import cpu_kind, cpu_name, markers, publish_performance  # noqa: E402

BEGIN, END = markers(f"end-to-end-{cpu_kind()}")
W, H = 1888, 1062     # 2.0 MPx


def write_exr(path: Path, data: np.ndarray, names, compression: str, fmt: str = "half") -> None:
    import OpenImageIO as oiio

    spec = oiio.ImageSpec(data.shape[1], data.shape[0], data.shape[2], fmt)
    spec.channelnames = tuple(names)
    spec.attribute("compression", compression)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(data), oiio.geterror()
    out.close()


def read_exr(path: Path) -> np.ndarray:
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    px = inp.read_image("float")
    inp.close()
    return px


def oiio_ms(src: Path, tmp: Path, compression: str, rounds: int) -> float:
    """OpenImageIO writing the input's pixels to a new EXR and reading them back (best of)."""
    px = read_exr(src)
    best = 1e9
    for _ in range(rounds):
        t = time.perf_counter()
        write_exr(tmp, px, ["R", "G", "B", "Z"], compression)
        read_exr(tmp)
        best = min(best, time.perf_counter() - t)
    return best * 1e3


def user_env(**extra) -> dict:
    """fogcli's source on the path, with Python's bytecode cache on as an installed fogcli
    has it (pip compiles it): with PYTHONDONTWRITEBYTECODE set, as some sandboxes and CI
    images do, every process would compile fogcli's modules anew (~80 ms here)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), **extra)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def fogcli_once(src: Path, out: Path, **env_extra) -> tuple[float, dict]:
    """Wall ms of one `fogcli apply src -o out --timings` as a user runs it, and its timings."""
    cmd = [sys.executable, "-m", "fogcli", "apply", str(src), "-o", str(out), "--timings"]
    t = time.perf_counter()
    r = subprocess.run(cmd, check=True, capture_output=True, text=True, env=user_env(**env_extra))
    wall = time.perf_counter() - t
    line = [x for x in r.stderr.splitlines() if x.startswith("{")]
    return wall * 1e3, json.loads(line[-1]) if line else {}


def start_server(run_dir: Path, log: Path) -> subprocess.Popen:
    """`fogcli serve` as a user starts it, in the benchmark's environment (tests/test_serve.py's)."""
    from test_serve import start_server as start

    return start(run_dir, log, idle=600, env=user_env(FOGCLI_RUN_DIR=str(run_dir)))


STARTUP = """
import time
t0 = time.perf_counter()
import numpy as np
import fogcli.runtime as R
from fogcli import apply
from fogcli.api import make_config
t1 = time.perf_counter()
spent = [0.0]
real = R.Runtime._build
def timed(self, *a):
    t = time.perf_counter()
    try:
        return real(self, *a)
    finally:
        spent[0] += time.perf_counter() - t
R.Runtime._build = timed
rgb = np.ones((48, 64, 3), np.float32)
t2 = time.perf_counter()
apply(rgb, np.full((48, 64), 10.0, np.float32), make_config("fog"))
print((t1 - t0) * 1e3, spent[0] * 1e3, (time.perf_counter() - t2) * 1e3)
"""


def startup_ms(cache: bool, rounds: int) -> tuple[float, float, float]:
    """A new process: importing fogcli, building the default pipeline's programs, and the whole
    first apply of a tiny frame (best of), with fogcli's binary cache on or off (PoCL's own
    cache warm either way)."""
    env = user_env(FOGCLI_KERNEL_CACHE="1" if cache else "0")
    best = None
    for _ in range(rounds + 1):     # the first run fills the caches
        r = subprocess.run([sys.executable, "-c", STARTUP], check=True, capture_output=True, text=True, env=env)
        v = tuple(float(x) for x in r.stdout.split())
        best = v if best is None else tuple(min(a, b) for a, b in zip(best, v))
    return best


def stop_server(run_dir: Path) -> None:
    """`fogcli serve --stop` for the server that a `fogcli apply` started in run_dir: back
    once it has gone."""
    subprocess.run([sys.executable, "-m", "fogcli", "serve", "--stop"], check=True, capture_output=True,
                   env=user_env(FOGCLI_RUN_DIR=str(run_dir)))


def server_rss_mb(run_dir: Path) -> float:
    """Resident memory of the server whose pid its lock holds, MB."""
    pid = int(next(run_dir.glob("serve-*.lock")).read_text().split()[0])
    for ln in Path(f"/proc/{pid}/status").read_text().splitlines():
        if ln.startswith("VmRSS:"):
            return int(ln.split()[1]) / 1024
    return float("nan")


def auto_round(src: Path, out: Path, run_dir: Path) -> dict:
    """As a user meets it with no server running: the first `fogcli apply` starts a server and
    hands its own command to it; the second comes the moment the first ended, then a third.
    Wall ms of each, and the server's resident MB at the end."""
    env = dict(FOGCLI_RUN_DIR=str(run_dir), FOGCLI_AUTOSERVE="600")
    got, served = {}, []
    try:
        for name in ("first", "second", "third"):
            got[name], st = fogcli_once(src, out, **env)
            served.append(bool(st.get("served")))
        got["rss"] = server_rss_mb(run_dir)
    finally:
        stop_server(run_dir)
    if not all(served):
        logs = "".join(p.read_text() for p in run_dir.glob("serve-*.log"))
        raise SystemExit(f"the started server did not take the commands: {logs}")
    return got


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    args = ap.parse_args()
    from fogcli.scenes import harbour_sample
    from fogcli.runtime import get_runtime

    cpu = get_runtime(None).info.label()
    rgb, z, _ = harbour_sample(W, H)
    # grain of 2 % as renders and photographs have it: without it the synthetic sample
    # compresses 50x and every file operation is unrealistically cheap
    rng = np.random.default_rng(0)
    rgb = rgb * (1.0 + 0.02 * rng.standard_normal(rgb.shape, dtype=np.float32))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for comp in ("zip", "zips", "piz", "none"):
            src = Path(tmp) / f"in_{comp}.exr"
            write_exr(src, np.dstack([rgb, z]).astype(np.float32), ["R", "G", "B", "Z"], comp)
            out = Path(tmp) / f"out_{comp}.exr"
            alone = dict(FOGCLI_SERVER="0")
            fogcli_once(src, out, **alone)          # the first run: caches
            o, f, st, fp = 1e9, 1e9, {}, 1e9
            auto = []
            for i in range(args.rounds):             # interleaved: the machine's speed drifts
                o = min(o, oiio_ms(src, Path(tmp) / "oiio.exr", comp, 1))
                fi, sti = fogcli_once(src, out, **alone)
                f, st = (fi, sti) if fi < f else (f, st)
                fp = min(fp, fogcli_once(src, out, FOGCLI_PREFAULT="0", **alone)[0])
                auto.append(auto_round(src, out, Path(tmp) / f"run_{comp}_{i}"))

            def best(k):
                return min(r[k] for r in auto)

            row = dict(comp=comp, mb=src.stat().st_size / 1e6, oiio=o, alone=f, stages=st, noprefault=fp,
                       first=best("first"), second=best("second"),
                       second_median=float(np.median([r["second"] for r in auto])), served=best("third"),
                       rss=max(r["rss"] for r in auto))
            rows.append(row)
            print(comp, f"{o:.0f} ms oiio, by itself {f:.0f} ms = {f / o:.2f}x (FOGCLI_PREFAULT=0: {fp:.0f}); "
                  f"first {row['first']:.0f} = {row['first'] / o:.2f}x, second {row['second']:.0f} = "
                  f"{row['second'] / o:.2f}x (median {row['second_median']:.0f}), third {row['served']:.0f} = "
                  f"{row['served'] / o:.2f}x, server {row['rss']:.0f} MB", st, flush=True)
    keys = [k for k in ("kernel_ms", "io_ms", "total_ms") if k in rows[0]["stages"]]
    start = {c: startup_ms(c, args.rounds) for c in (False, True)}
    lines = [BEGIN, f"## End to end on {cpu_name()}", "",
             f"`python benchmarks/end_to_end.py` on {cpu}, {os.cpu_count()} cores: `fogcli apply in.exr -o out.exr` "
             f"of a {W}x{H} half-float EXR with R, G, B, Z (the harbour sample with 2 % grain, default fog), best of "
             f"{args.rounds} rounds, kernel caches warm; against OpenImageIO writing the same pixels to an EXR of the "
             "same compression and reading them back, in the same run (ratios are to that).", "",
             "- `by itself`: a new process with FOGCLI_SERVER=0 (no server used or started); `without prefault`: "
             "the same with FOGCLI_PREFAULT=0 (the heap the previous run needed is not touched ahead while Python "
             "imports). The stage times are this run's.",
             "- As a user meets it with no server running (docs/distributed.md): the `first` `fogcli apply` "
             "starts a server and hands its own command to it; the `second` comes the moment the first ended "
             "(median of the rounds in brackets), the `third` as every later one. `server MB`: the server's "
             "resident memory at the end (largest of the rounds), which it holds until it stops.", "",
             "| compression | file MB | OpenImageIO write + read ms | by itself ms | ratio | without prefault ms | "
             "first ms | ratio | second ms | ratio | third ms | ratio | server MB | "
             + " | ".join(f"{k} ms" for k in keys) + " |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|" + "---|" * len(keys)]
    for r in rows:
        o = r["oiio"]
        lines.append(f"| {r['comp']} | {r['mb']:.1f} | {o:.0f} | {r['alone']:.0f} | {r['alone'] / o:.2f}x | "
                     f"{r['noprefault']:.0f} | {r['first']:.0f} | {r['first'] / o:.2f}x | "
                     f"{r['second']:.0f} ({r['second_median']:.0f}) | {r['second'] / o:.2f}x | "
                     f"{r['served']:.0f} | {r['served'] / o:.2f}x | {r['rss']:.0f} | "
                     + " | ".join(f"{r['stages'].get(k, 0):.0f}" for k in keys) + " |")
    lines += ["", "Start-up of a new process (ms, best of the rounds): importing fogcli, then the first `apply` of a "
              "64 x 48 frame, of which building the default pipeline's programs; PoCL's own cache warm.", "",
              "| fogcli's binary cache | import | build programs | first apply (all) |", "|---|---|---|---|"]
    for c in (False, True):
        imp, build, first = start[c]
        lines.append(f"| {'on (default)' if c else 'off (FOGCLI_KERNEL_CACHE=0)'} | {imp:.0f} | {build:.0f} | {first:.0f} |")
    lines.append(END)
    return publish_performance(lines, Path(args.out))


if __name__ == "__main__":
    sys.exit(main())
