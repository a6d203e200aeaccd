"""Every kernel under Oclgrind's uninitialised-value check (OCLGRIND_UNINITIALIZED), one at a
time (issue 39).

The plugin stops the whole process when it meets an instruction it does not model, so a
pipeline under it ends at the first such kernel. Here each kernel is replayed alone: the
cases of tools/kernel_diff.py run on Oclgrind (without the plugin), and for each kernel the
first launch's arguments are saved as they were right before it (every buffer's contents,
every scalar, the program's build options, the launch's sizes). Each saved launch is then run in
a child process with the plugin on, with buffers made from those contents (so what the
plugin calls uninitialised is what the kernel itself never wrote: a private or local value
read before it was set). A child's stderr is the plugin's report; a crash is the plugin's
limit, with its last words.

    python tools/oclgrind_uninitialized.py          # kernel: what the plugin said
    python tools/oclgrind_uninitialized.py --doc    # the same, as the block of docs/devices.md
    python tools/oclgrind_uninitialized.py --from DIR   # replay what `kernel_diff.py oclgrind
                                                    # --capture DIR` saved (no capture run)
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent))
import kernel_diff  # noqa: E402

CHILD = r"""
import pickle, sys
import pyopencl as cl
from fogcli.device.runtime import KERNEL_DIR
rec = pickle.load(open(sys.argv[1], "rb"))
p = next(p for p in cl.get_platforms() if "oclgrind" in p.name.lower())
ctx = cl.Context(p.get_devices()[:1])
q = cl.CommandQueue(ctx)
prog = cl.Program(ctx, (KERNEL_DIR / (rec["program"] + ".cl")).read_text()).build(options=rec["options"])
k = getattr(prog, rec["kernel"])
args = []
for kind, value in rec["args"]:
    if kind == "buffer":
        args.append(cl.Buffer(ctx, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR, hostbuf=value))
    else:
        args.append(value)
k(q, rec["global"], rec["local"], *args, global_offset=rec["offset"]).wait()
print("ran")
"""


def capture(folder: Path, cases=None) -> dict:
    """{kernel: path of its first launch's record}, over kernel_diff's cases on Oclgrind
    (kernel_diff.save_launch; `kernel_diff.py oclgrind --capture DIR` saves the same while it
    compares, and `--from DIR` here replays those)."""
    for name in cases or kernel_diff.cases_for("oclgrind"):
        kernel_diff.run_case(name, "oclgrind", simulated=True, capture=folder)
    return saved_launches(folder)


def saved_launches(folder: Path) -> dict:
    return {p.stem: p for p in sorted(folder.glob("*.pkl"))}


# Oclgrind's limits, each as the smallest kernel that shows it (docs/devices.md)
LIMITS = {
    "float3 arithmetic stops the plugin (segmentation fault)":
        "__kernel void k(__global const float4 *x, __global float4 *y) "
        "{ int i = get_global_id(0); float4 p = x[i]; float3 c = p.xyz / p.w; y[i].x = c.x; }",
    "__builtin_fabsf stops the plugin (Unsupported intrinsic llvm.fabs)":
        "__kernel void k(__global const float4 *x, __global float4 *y) "
        "{ int i = get_global_id(0); y[i].x = __builtin_fabsf(x[i].x - 0.5f); }",
    "a vector literal with computed lanes is reported as uninitialised":
        "__kernel void k(__global const float4 *x, __global float4 *y) "
        "{ int i = get_global_id(0); float a = x[i].x, b = 2.0f * a; y[i] = (float4)(a > b ? a : 0.0f, b, 0.0f, (float)i); }",
}
LIMIT_CHILD = r"""
import sys, numpy as np, pyopencl as cl
p = next(p for p in cl.get_platforms() if "oclgrind" in p.name.lower())
ctx = cl.Context(p.get_devices()[:1]); q = cl.CommandQueue(ctx)
k = cl.Program(ctx, sys.argv[1]).build().k
x = cl.Buffer(ctx, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR, hostbuf=np.ones(64, np.float32))
y = cl.Buffer(ctx, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR, hostbuf=np.zeros(64, np.float32))
k(q, (16,), (16,), x, y).wait()
"""


def _said(stderr: str) -> str:
    return "\n".join(ln for ln in stderr.splitlines() if ln.strip() and "Warning" not in ln
                     and "prg.build" not in ln and "warn(" not in ln)


def verdict(returncode: int, said: str) -> str:
    """clean; stops (the plugin's limit: a crash, an unsupported intrinsic); vector literal
    (only reports of a literal built on an undefined vector: the plugin's false alarm);
    reported (anything else: an uninitialised read of ours)."""
    if "Unsupported intrinsic" in said:
        return "stops: " + said.split("Unsupported intrinsic", 1)[1].split()[0]
    if returncode != 0:
        return "stops: segmentation fault" if returncode in (-11, 139) else f"stops: exit {returncode}"
    if not said:
        return "clean"
    blocks = said.split("Uninitialized value")
    if not blocks[0].strip() and all(b.startswith(" written") and "poison" in b for b in blocks[1:]):
        return "vector literal"
    return "reported"


# float8 code (kernels built with LANES 8, kernels/lanes.h): the plugin does not follow its
# lanes. On reduce_source_lanes it stopped (segmentation fault) or reported its loads,
# transposes and sums as uninitialised depending on where the kernel was cut short for the
# probe, where PoCL and Intel compute every lane from the loaded data to float rounding
# (tests/test_kernels.py against the per-pixel kernel; tools/kernel_diff.py); no small
# kernel reproduced it (session 43). Its launches are not replayed; Oclgrind still checks
# their memory accesses and races in kernel_diff's run.
NOT_REPLAYED = "float8: not replayed"


def check(path: Path) -> tuple[str, str]:
    """(verdict, the plugin's words) for one saved launch."""
    import pickle

    if "LANES=8" in pickle.loads(path.read_bytes())["options"]:
        return NOT_REPLAYED, ""
    env = dict(os.environ, OCLGRIND_UNINITIALIZED="1")
    r = subprocess.run([sys.executable, "-c", CHILD, str(path)], env=env, capture_output=True, text=True,
                       timeout=1800)
    said = _said(r.stderr)
    return verdict(r.returncode, said), said[:1500]


def limits() -> dict:
    """{limit: its kernel's verdict}: the limits still hold in the installed Oclgrind."""
    env = dict(os.environ, OCLGRIND_UNINITIALIZED="1")
    out = {}
    for name, src in LIMITS.items():
        r = subprocess.run([sys.executable, "-c", LIMIT_CHILD, src], env=env, capture_output=True, text=True,
                           timeout=300)
        out[name] = verdict(r.returncode, _said(r.stderr))
    return out


def write_doc(results: dict, lim: dict) -> None:
    from docblock import markers, write_block

    begin, end = markers("oclgrind-uninitialized")
    groups: dict[str, list] = {}
    for k, (v, _) in sorted(results.items()):
        groups.setdefault(v, []).append(k)
    lines = [begin, "Each kernel alone under `OCLGRIND_UNINITIALIZED=1` (`python tools/oclgrind_uninitialized.py "
             "--doc`), and the smallest kernel of each limit:", "",
             "| outcome | kernels |", "|---|---|",
             *(f"| {v} | {', '.join(ks)} |" for v, ks in sorted(groups.items())), "",
             "| limit | its smallest kernel, under the plugin |", "|---|---|",
             *(f"| {name} | {v}: `{LIMITS[name].split('{', 1)[1].rsplit('}', 1)[0].strip()}` |"
               for name, v in lim.items()), end]
    write_block(Path(__file__).resolve().parents[1] / "docs" / "devices.md", begin, end, "\n".join(lines))
    print("\n".join(lines))


def main() -> int:
    import warnings

    warnings.simplefilter("ignore")
    kernel_diff.source_builds()
    keep = next((a.split("=", 1)[1] for a in sys.argv if a.startswith("--keep=")), None)
    saved_in = sys.argv[sys.argv.index("--from") + 1] if "--from" in sys.argv else None
    with tempfile.TemporaryDirectory() as d:
        if saved_in:
            saved = saved_launches(Path(saved_in))
        else:
            d = keep or d
            cases = [c for c in kernel_diff.cases_for("oclgrind")
                     if any(c.startswith(a) for a in sys.argv[1:] if not a.startswith("--"))]
            saved = capture(Path(d), cases)
        results = {k: check(p) for k, p in sorted(saved.items())}
    if "--doc" in sys.argv:
        write_doc(results, limits())
    elif "--json" in sys.argv:
        print(json.dumps(results))
    else:
        for k, (v, said) in results.items():
            print(f"{k:24s} {v}")
            if v == "reported":
                print("    " + said.replace("\n", "\n    "))
    return 1 if any(v == "reported" for v, _ in results.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
