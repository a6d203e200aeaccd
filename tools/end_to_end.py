"""Start-up and memory (issue 37): each command a process of its own, as a user runs it.

- `fogcli --help`, `check`, `media`, `config --show`: wall time of a new process, and what
  Python imports for `check` and `apply` (`python -X importtime`, the largest);
- `fogcli apply` of a 2 MPx RGB + Z EXR (zip) in a new process against OpenImageIO's own
  write + read of that EXR (`oiiotool in.exr -o out.exr`, a new process too), alternated in
  one run, and against OpenImageIO writing and reading it inside one Python process;
- the apply's peak resident memory, and beyond the interpreter's baseline (the same command
  on a 64 x 40 frame) in bytes a pixel at 2 and 32 MPx.

Kernel caches warm (a first run fills them). Writes its block of docs/performance.md.

    python tools/end_to_end.py [--rounds 7] [--no-32]     # about 2 minutes
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tools")]

from docblock import cpu_kind, cpu_name, markers, publish_performance  # noqa: E402
from process_peak import run_measured  # noqa: E402

BEGIN, END = markers(f"end-to-end-{cpu_kind()}")
W, H = 1888, 1062          # 2.0 MPx
W32, H32 = 6928, 4618      # 32.0 MPx
TARGETS = {"--help": 0.15, "check": 0.25, "ratio": 3.0, "rss": 350, "bpp": 100}


def user_env() -> dict:
    """fogcli's source on the path, with Python's bytecode cache on as an installed fogcli
    has it (pip compiles it): with PYTHONDONTWRITEBYTECODE set, as some sandboxes and CI
    images do, every process would compile fogcli's modules anew."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


FOGCLI = [sys.executable, "-m", "fogcli"]


def write_exr(path: Path, w: int, h: int, compression: str = "zip") -> None:
    """The harbour sample at w x h with 2 % grain (renders and photographs have it; without it
    the synthetic frame compresses 50x and every file operation is unrealistically cheap),
    half float R, G, B, Z, written in strips (a 32 MPx frame at once would double the memory)."""
    import OpenImageIO as oiio

    from hdr_scenes import harbour_sample

    spec = oiio.ImageSpec(w, h, 4, "half")
    spec.channelnames = ("R", "G", "B", "Z")
    spec.attribute("compression", compression)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), oiio.geterror()
    rgb, z, _ = harbour_sample(w, h)
    rng = np.random.default_rng(0)
    for y0 in range(0, h, 512):
        y1 = min(h, y0 + 512)
        strip = rgb[y0:y1] * (1.0 + 0.02 * rng.standard_normal(rgb[y0:y1].shape, dtype=np.float32))
        assert out.write_scanlines(y0, y1, 0, np.ascontiguousarray(np.dstack([strip, z[y0:y1]]), np.float32))
    out.close()


def wall(cmd: list) -> float:
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=user_env())
    return time.perf_counter() - t


OIIO_INPROCESS = """
import sys, time, OpenImageIO as oiio
src, dst = sys.argv[1:3]
inp = oiio.ImageInput.open(src); spec = oiio.ImageSpec(inp.spec()); px = inp.read_image("float"); inp.close()
best = 1e9
for _ in range(int(sys.argv[3])):
    t = time.perf_counter()
    out = oiio.ImageOutput.create(dst); out.open(dst, spec); out.write_image(px); out.close()
    i = oiio.ImageInput.open(dst); i.read_image("float"); i.close()
    best = min(best, time.perf_counter() - t)
print(best)
"""


# what a command may import, and the heavy libraries it should import only when it needs them
WATCHED = ("click", "yaml", "numpy", "pydantic", "fogcli.config.model", "fogcli.device.plan", "OpenImageIO", "pyopencl",
           "cv2", "dask", "distributed", "rawpy", "tqdm")


def importtime(args: list) -> dict[str, float]:
    """Cumulative ms of each WATCHED module a command imports (-X importtime; absent: not
    imported), and the whole (`all`: the sum of the top-level imports)."""
    r = subprocess.run([sys.executable, "-X", "importtime", "-m", "fogcli", *args], capture_output=True, text=True,
                       env=user_env())
    got: dict[str, float] = {"all": 0.0}
    for ln in r.stderr.splitlines():
        m = re.match(r"import time:\s+\d+ \|\s+(\d+) \|( *)(\S+)", ln)
        if not m:
            continue
        ms, depth, name = int(m.group(1)) / 1e3, len(m.group(2)), m.group(3)
        if depth <= 1:
            got["all"] += ms
        if name in WATCHED:
            got[name] = max(got.get(name, 0.0), ms)
    return got


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--no-32", action="store_true", help="leave out the 32 MPx frame (a minute and 3 GB)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    args = ap.parse_args()
    from fogcli.device.runtime import get_runtime

    cpu = get_runtime(None).info.label()
    oiiotool = shutil.which("oiiotool", path=os.path.dirname(sys.executable)) or shutil.which("oiiotool")
    if oiiotool is None:
        raise SystemExit("oiiotool (OpenImageIO's command line tool, installed with its wheel) not found")
    cfg_file = ROOT / "src" / "fogcli" / "config" / "media" / "fog.yaml"
    small = {"--help": ["--help"], "check": ["check", str(cfg_file)], "media": ["media"],
             "config --show": ["config", "--show", "--medium", "sea"]}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        src, tiny = tmp / "in.exr", tmp / "tiny.exr"
        write_exr(src, W, H)
        write_exr(tiny, 64, 40)
        apply = [*FOGCLI, "apply", str(src), "-o", str(tmp / "out.exr")]
        oiio_cmd = [oiiotool, str(src), "-o", str(tmp / "oiio.exr")]
        wall(apply)                   # caches (PoCL's, fogcli's binaries, Python's bytecode)
        starts: dict = {k: [] for k in small}
        fog, tool = [], []
        for _ in range(args.rounds):  # alternated: the machine's speed drifts
            for name, a in small.items():
                starts[name].append(wall([*FOGCLI, *a]))
            tool.append(wall(oiio_cmd))
            fog.append(wall(apply))
        r = subprocess.run([sys.executable, "-c", OIIO_INPROCESS, str(src), str(tmp / "oiio2.exr"), str(args.rounds)],
                           capture_output=True, text=True, check=True)
        inproc = float(r.stdout.strip())
        imports = {name: importtime(a) for name, a in (("check", small["check"]),
                                                        ("apply", ["apply", str(src), "-o", str(tmp / "o2.exr")]))}
        peaks = {}
        for name, path in (("baseline", tiny), ("2 MPx", src)):
            peaks[name] = min(run_measured([*FOGCLI, "apply", str(path), "-o", str(tmp / f"m_{name[:4]}.exr")],
                                           user_env())["maxrss"] for _ in range(3))
        if not args.no_32:
            big = tmp / "big.exr"
            write_exr(big, W32, H32)
            peaks["32 MPx"] = run_measured([*FOGCLI, "apply", str(big), "-o", str(tmp / "big_out.exr")],
                                           user_env())["maxrss"]
        mb = src.stat().st_size / 1e6

    def best(v):
        return min(v) * 1e3

    def med(v):
        return float(np.median(v)) * 1e3

    ratio, ratio_med = best(fog) / best(tool), float(np.median(np.array(fog) / np.array(tool)))
    px = {"2 MPx": W * H, "32 MPx": W32 * H32}
    lines = [BEGIN, f"## Start-up and memory on {cpu_name()}", "",
             f"`python tools/end_to_end.py --rounds {args.rounds}` on {cpu}, {os.cpu_count()} cores. Every command "
             "is a new process, as a user runs it, with the kernel caches warm; best and median of the rounds, "
             "the commands alternated in each round. Targets (issue 37) in brackets.", "",
             "| command | best s | median s |", "|---|---|---|"]
    for name, v in starts.items():
        tgt = f" (<= {TARGETS[name]})" if name in TARGETS else ""
        lines.append(f"| `fogcli {' '.join(small[name]).replace(str(cfg_file), 'configs/fog.yaml')}`{tgt} | "
                     f"{best(v) / 1e3:.3f} | {med(v) / 1e3:.3f} |")
    lines += ["", f"`fogcli apply in.exr -o out.exr` of a {W}x{H} half-float EXR with R, G, B, Z (zip, {mb:.1f} MB; the "
              "harbour sample with 2 % grain, default fog) against OpenImageIO's own write + read of it "
              "(`oiiotool in.exr -o out.exr`, a new process as well), alternated:", "",
              "| | best ms | median ms |", "|---|---|---|",
              f"| `fogcli apply` | {best(fog):.0f} | {med(fog):.0f} |",
              f"| `oiiotool in.exr -o out.exr` | {best(tool):.0f} | {med(tool):.0f} |",
              f"| ratio (<= {TARGETS['ratio']}x) | {ratio:.2f}x | {ratio_med:.2f}x (of the rounds' ratios) |",
              f"| OpenImageIO's write + read inside one Python process | {inproc * 1e3:.0f} | |",
              "", "Peak resident memory (`ru_maxrss` of the command's own process; bytes a pixel beyond the "
              "interpreter's baseline, which is the same command on a 64 x 40 frame):", "",
              "| frame | peak MB | beyond the baseline, bytes a pixel |", "|---|---|---|",
              f"| 64 x 40 (the baseline) | {peaks['baseline'] / 2**20:.0f} | |"]
    for name in ("2 MPx", "32 MPx"):
        if name in peaks:
            tgt = f" (<= {TARGETS['rss']} MB)" if name == "2 MPx" else ""
            lines.append(f"| {name}{tgt} | {peaks[name] / 2**20:.0f} | "
                         f"{(peaks[name] - peaks['baseline']) / px[name]:.1f} (<= {TARGETS['bpp']}) |")
    lines += ["", "What Python imports (`python -X importtime -m fogcli ...`, one run): cumulative ms of each "
              "library where a command imports it (nested imports inside it included; `-`: not imported), and "
              "of all its imports:", "",
              "| module | `fogcli check` ms | `fogcli apply` ms |", "|---|---|---|"]
    for name in ("all", *WATCHED):
        a, b = imports["check"].get(name), imports["apply"].get(name)
        if a is None and b is None and name not in ("cv2", "dask"):
            continue
        lines.append(f"| {name if name != 'all' else 'all imports'} | {'-' if a is None else f'{a:.0f}'} | "
                     f"{'-' if b is None else f'{b:.0f}'} |")
    lines.append(END)
    return publish_performance(lines, Path(args.out))


if __name__ == "__main__":
    sys.exit(main())
