"""A command does its work and exits: no process of it (workers, a Dask LocalCluster) is
left after apply or batch, finished or interrupted with Ctrl-C; and the commands that
need no pixels do not load OpenCL, OpenImageIO or OpenCV."""
import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from hdr_scenes import scene

ROOT = Path(__file__).resolve().parents[1]


def marked_env(mark: str) -> dict:
    # every descendant inherits the environment: the mark finds them wherever they went
    return dict(os.environ, FOGCLI_TEST_MARK=mark,
                PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))


def marked(mark: str) -> list[int]:
    """The pids whose environment carries the mark."""
    found = []
    needle = f"FOGCLI_TEST_MARK={mark}".encode()
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if needle in (d / "environ").read_bytes().split(b"\0"):
                    found.append(int(d.name))
            except OSError:
                pass
    return found


def gone(mark: str, within: float) -> list[int]:
    deadline = time.time() + within
    while (left := marked(mark)) and time.time() < deadline:
        time.sleep(0.05)
    return left


def frames(folder: Path, n: int, w=512, h=384) -> None:
    folder.mkdir()
    for i in range(n):
        rgb, z, _ = scene(w, h, seed=i)
        spec = oiio.ImageSpec(w, h, 4, "float")
        spec.channelnames = ("R", "G", "B", "Z")
        out = oiio.ImageOutput.create(str(folder / f"f{i:02d}.exr"))
        assert out.open(str(folder / f"f{i:02d}.exr"), spec)
        assert out.write_image(np.ascontiguousarray(np.dstack([rgb, z]), np.float32))
        out.close()


COMMANDS = {
    "apply": lambda t: ["apply", t / "in" / "f00.exr", "-o", t / "o.exr"],
    "batch --jobs 1": lambda t: ["batch", t / "in", t / "out", "-q"],
    "batch --jobs 2": lambda t: ["batch", t / "in", t / "out", "-q", "--jobs", "2"],
    "batch --scheduler local:2": lambda t: ["batch", t / "in", t / "out", "-q", "--scheduler", "local:2"],
}


@pytest.mark.parametrize("name", list(COMMANDS))
def test_nothing_outlives_the_command(tmp_path, name):
    frames(tmp_path / "in", 3)
    mark = uuid.uuid4().hex
    r = subprocess.run([sys.executable, "-m", "fogcli", *map(str, COMMANDS[name](tmp_path))], env=marked_env(mark),
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert gone(mark, 10.0) == [], f"{name}: processes left after the command ended"


@pytest.mark.parametrize("name", list(COMMANDS))
def test_nothing_outlives_ctrl_c(tmp_path, name):
    frames(tmp_path / "in", 24)
    mark = uuid.uuid4().hex
    p = subprocess.Popen([sys.executable, "-m", "fogcli", *map(str, COMMANDS[name](tmp_path))], env=marked_env(mark),
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    want = 1 if name in ("apply", "batch --jobs 1") else 3      # the command and its workers are up
    deadline = time.time() + 120
    while len(marked(mark)) < want and time.time() < deadline and p.poll() is None:
        time.sleep(0.02)
    time.sleep(0.3)                            # into its work
    assert p.poll() is None, f"{name} ended before it could be interrupted"
    os.killpg(p.pid, signal.SIGINT)            # what Ctrl-C at a terminal sends: the whole group
    try:
        err = p.communicate(timeout=60)[1]
    finally:
        p.kill()
    # interrupted (130, or now and then the status of a death by SIGINT, which Python gives
    # itself at exit), or it had just finished
    assert p.returncode in (130, -signal.SIGINT, 0, 3), (p.returncode, err)
    assert "Traceback" not in err, err
    assert gone(mark, 15.0) == [], f"{name}: processes left after Ctrl-C"


def test_commands_without_pixels_load_no_device_or_image_library():
    code = ("import sys\nfrom fogcli.cli import main\n"
            "try:\n    main()\nexcept SystemExit:\n    pass\n"
            "heavy = sorted(m for m in ('pyopencl', 'OpenImageIO', 'cv2', 'dask', 'distributed', 'rawpy') "
            "if m in sys.modules)\nprint(','.join(heavy), file=sys.stderr)\n")
    cfg = ROOT / "src" / "fogcli" / "config" / "media" / "fog.yaml"
    for args in (["--help"], ["apply", "--help"], ["batch", "--help"], ["media"], ["check", str(cfg)],
                 ["config", "--show", "--medium", "sea"]):
        r = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=marked_env("x"),
                           timeout=120)
        assert r.stderr.strip().splitlines()[-1:] in ([], [""]), (args, r.stderr)


BLAS_WATCH = """
import os, sys, threading, time
import numpy
# the threads numpy's BLAS (OpenBLAS) started as it loaded (nothing else runs yet); they
# spin as they start: counted from when that is over
blas = [t for t in os.listdir("/proc/self/task") if int(t) != threading.get_native_id()]
def ticks():
    return sum(int(open(f"/proc/self/task/{t}/stat").read().rsplit(")", 1)[1].split()[11]) for t in blas)
time.sleep(0.3)
start = ticks()
from fogcli.cli import main
try:
    main()
except SystemExit as exc:
    assert not exc.code, exc.code
time.sleep(0.3)            # a spin that began at the end would still count
print(len(blas), ticks() - start)
"""


def test_numpys_blas_threads_stay_idle_through_a_frame(tmp_path):
    """numpy hands a large matrix product (129 x 154 x 64 is one) to BLAS threads that then
    spin for about 0.1 s: beside the frame's kernels, on the same cores. On 2 cores that took
    a core from the device for most of a frame (2 MPx, one PoCL thread: 281 core-ms of device
    stage for 174 ms of wall; two batch workers lost 15 % to it). The host's products in a
    frame stay on the calling thread (einsum or elementwise)."""
    frames(tmp_path / "in", 1)
    env = dict(marked_env("blas"), OPENBLAS_NUM_THREADS="2")     # a thread to watch on any machine
    r = subprocess.run([sys.executable, "-c", BLAS_WATCH, "apply", str(tmp_path / "in" / "f00.exr"),
                        "-o", str(tmp_path / "o.exr")], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    threads, ticks = map(int, r.stdout.split()[-2:])
    assert threads >= 1, "OpenBLAS started no thread: nothing was watched"
    assert ticks <= 2, f"numpy's BLAS threads ran {ticks * 10} ms in one frame"
