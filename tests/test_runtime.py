"""The program binary cache (fogcli.device.runtime): programs are built from source once per
machine and loaded from their device binary after that, keyed by everything that can
change the binary."""
import shutil

import numpy as np
import pytest

from fogcli import apply
from fogcli.device import runtime
from fogcli.api import make_config
from fogcli.device.plan import defines

D4 = defines(make_config("fog"))
D2 = defines(make_config("fog", sets=["render.kernel=2"]))


@pytest.fixture
def cache(tmp_path, monkeypatch):
    runtime._cl()           # PoCL's own cache stays where it is (warm): only ours moves
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("FOGCLI_KERNEL_CACHE", raising=False)
    return tmp_path / "fogcli" / "kernels"


def _builds(monkeypatch):
    """Count the builds from source of every Runtime made from here on."""
    seen = []
    cl = runtime._cl()
    real = cl.Program

    def program(ctx, *args):
        if len(args) == 1:          # (ctx, source); binaries come as (ctx, devices, binaries)
            seen.append(args[0][:40])
        return real(ctx, *args)
    monkeypatch.setattr(cl, "Program", program)
    return seen


def test_second_runtime_loads_the_binary(cache, monkeypatch):
    seen = _builds(monkeypatch)
    a = runtime.Runtime()
    a.program("pyramid", **D4).build()
    files = sorted(cache.glob("pyramid-*.bin"))
    assert len(files) == 1 and files[0].stat().st_size > 1000 and len(seen) == 1
    b = runtime.Runtime()                  # a new context, as in a new process
    b.program("pyramid", **D4).build()
    assert len(seen) == 1                  # no second build from source
    # other options: another binary
    b.program("pyramid", **D2).build()
    assert len(seen) == 2 and len(list(cache.glob("pyramid-*.bin"))) == 2
    # another compile target (a PoCL setting): another key, whatever the device's name says
    p = b.binary_path("pyramid", "src", ["-D", "A=1"])
    monkeypatch.setenv("POCL_LLVM_CPU_NAME", "znver1")
    assert b.binary_path("pyramid", "src", ["-D", "A=1"]) != p
    q = b.binary_path("pyramid", "src", ["-D", "A=1"])
    monkeypatch.setenv("CL_CONFIG_CPU_VECTORIZER_MODE", "1")      # Intel's CPU runtime's settings too
    assert b.binary_path("pyramid", "src", ["-D", "A=1"]) != q
    assert b.binary_path("pyramid", "src", ["-D", "A=2"]) != b.binary_path("pyramid", "src", ["-D", "A=1"])


def test_a_binary_keeps_its_kernels_parameter_names(cache, monkeypatch):
    """A program made from a binary may have no argument info (Intel's CPU runtime:
    KERNEL_ARG_INFO_NOT_AVAILABLE), so the names the device gave at the build from source are
    kept beside the binary; a binary without them is built again."""
    import json

    seen = _builds(monkeypatch)
    runtime.Runtime().program("pyramid", **D4).build()
    (names,) = cache.glob("pyramid-*.json")
    assert json.loads(names.read_text())["prep_level0"] == ["chain", "prep", "n", "thresh1", "eps"]
    progs = runtime.Runtime().program("pyramid", **D4).build()
    assert len(seen) == 1 and progs._params["prep_level0"] == ["chain", "prep", "n", "thresh1", "eps"]
    assert progs.prep_level0.params == ("chain", "prep", "n", "thresh1", "eps")
    names.unlink()
    runtime.Runtime().program("pyramid", **D4).build()
    assert len(seen) == 2 and names.is_file()


def test_the_key_follows_the_kernels_content_not_their_folder(cache, monkeypatch, tmp_path):
    """Another install of the same kernels (a fresh venv) loads the binaries already built;
    an edited header builds anew."""
    rt = runtime.Runtime()
    here = rt.binary_path("pyramid", "src", ["-I", str(runtime.KERNEL_DIR), "-D", "A=1"])
    moved = tmp_path / "elsewhere" / "kernels"
    shutil.copytree(runtime.KERNEL_DIR, moved)
    monkeypatch.setattr(runtime, "KERNEL_DIR", moved)
    assert rt.binary_path("pyramid", "src", ["-I", str(moved), "-D", "A=1"]) == here
    (moved / "common.h").write_text((moved / "common.h").read_text() + "\n// edited\n")
    assert rt.binary_path("pyramid", "src", ["-I", str(moved), "-D", "A=1"]) != here


def test_programs_are_built_at_their_first_launch(cache, monkeypatch):
    """A plan names every program variant it might launch; only those launched are built."""
    seen = _builds(monkeypatch)
    rt = runtime.Runtime()
    prog = rt.program("composite", **D4)
    k = prog.composite_source
    assert seen == [] and not list(cache.glob("*.bin"))
    assert k.function_name == "composite_source" and len(seen) == 1   # the first use builds
    rt.program("composite", **D4).composite.function_name
    assert len(seen) == 1                                             # once per program


def test_damaged_binary_is_rebuilt(cache, monkeypatch):
    seen = _builds(monkeypatch)
    runtime.Runtime().program("composite", **D4).build()
    (path,) = cache.glob("composite-*.bin")
    good = path.read_bytes()
    path.write_bytes(b"not a binary" * 10)
    runtime.Runtime().program("composite", **D4).build()
    assert len(seen) == 2 and path.read_bytes()[:64] == good[:64] and len(path.read_bytes()) > 1000
    assert not list(cache.glob("*.tmp"))


def test_cache_off_and_same_results(cache, monkeypatch, rng):
    """FOGCLI_KERNEL_CACHE=0 writes nothing; programs from binaries compute what programs
    from source do (bit for bit: the same machine code)."""
    w = runtime.LOCAL_CPU[0] + 32          # whole work-groups: their programs are built too
    img = rng.uniform(0, 2, (24, w, 3)).astype(np.float32)
    depth = rng.uniform(2, 80, (24, w)).astype(np.float32)
    cfg = make_config("fog")
    monkeypatch.setenv("FOGCLI_KERNEL_CACHE", "0")
    monkeypatch.setattr(runtime, "_RUNTIMES", {})
    from fogcli.device import plan as device_plan
    monkeypatch.setattr(device_plan, "_PLANS", {})
    plain = apply(img, depth, cfg)
    assert not cache.exists() or not list(cache.iterdir())
    monkeypatch.setenv("FOGCLI_KERNEL_CACHE", "1")
    for _ in range(2):                     # the first writes the binaries, the second loads them
        monkeypatch.setattr(runtime, "_RUNTIMES", {})
        monkeypatch.setattr(device_plan, "_PLANS", {})
        np.testing.assert_array_equal(apply(img, depth, cfg), plain)
    assert len(list(cache.glob("*.bin"))) >= 4


COUNT = r'''#include "common.h"
__kernel void count(__global int *c, const int w, const int h)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(i, j, w, h)) return;
    atomic_inc(&c[j * w + i]);
}
'''


LX = runtime.LOCAL_CPU[0]


@pytest.mark.parametrize("w,h", [(1, 1), (5, 3), (31, 7), (32, 4), (33, 5), (64, 8), (100, 37),
                                 (LX - 1, 3), (LX + 1, 9), (2 * LX, 4)])
def test_launch2d_covers_every_pixel_once(rt, w, h):
    """launch2d: the whole-groups kernel (no bounds check) stays inside the image, the
    checked one fills the strips, and no pixel is done twice."""
    cl = rt.cl
    opts = ["-I", str(runtime.KERNEL_DIR), "-cl-kernel-arg-info"] + [f"-D{k}={v}" for k, v in D4.items()]
    whole = runtime._Kernels(cl, lambda: runtime.build_source(cl, rt.ctx, COUNT, opts + ["-DWHOLE_GROUPS=1"])).count
    checked = runtime._Kernels(cl, lambda: runtime.build_source(cl, rt.ctx, COUNT, opts)).count
    guard = 4096                    # a whole-groups launch past the image would count here
    buf = cl.Buffer(rt.ctx, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR,
                    hostbuf=np.zeros(w * h + guard, np.int32))
    for ev in rt.launch2d((whole, checked), w, h, c=buf, w=np.int32(w), h=np.int32(h)):
        ev.wait()
    out = np.empty(w * h + guard, np.int32)
    cl.enqueue_copy(rt.queue, out, buf)
    assert (out[: w * h] == 1).all() and not out[w * h:].any()


def test_scalar_arguments_are_declared_at_the_first_launch(rt, rng):
    """The first launch declares the scalar types (runtime._Kernel): later launches pack plain
    Python numbers as the kernel's int and floats (pyopencl refuses them undeclared), with the
    same result."""
    cl, q = rt.cl, rt.queue
    n = 37
    chain = rng.random((n + 5, 4), dtype=np.float32) + 0.5
    chain[:, 3] = np.where(np.arange(n + 5) % 2, 4.0, 0.25)      # clear of the mask's ramp (1 .. 1.5)
    src = cl.Buffer(rt.ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=chain)
    dst = cl.Buffer(rt.ctx, cl.mem_flags.READ_WRITE, chain.nbytes)
    k = rt.program("pyramid", **D4).prep_level0
    got = []
    for count, thresh, eps in ((np.int32(n), np.float32(1.0), np.float32(0.5)), (n, 1.0, 0.5)):
        out = np.zeros_like(chain)
        cl.enqueue_copy(q, dst, out)
        k(q, (n,), None, chain=src, prep=dst, n=count, thresh1=thresh, eps=eps)
        cl.enqueue_copy(q, out, dst)
        got.append(out)
    want = np.zeros_like(chain)
    want[:n, :3] = chain[:n, :3] * (chain[:n, 3:] > 1.0)
    want[:n, 3] = np.log(chain[:n, 3])
    for g in got:
        assert np.allclose(g, want, rtol=0, atol=2e-6) and not g[n:].any()
    assert [runtime._arg_dtype(a) for a in (src, np.int32(1), np.float32(1), np.zeros((), [("a", "f4")]),
                                            np.zeros(4, np.float32), 3)] == [
        None, np.dtype(np.int32), np.dtype(np.float32), np.dtype([("a", "f4")]), None, None]


def test_kernels_are_launched_by_parameter_name_checked_against_the_device(rt):
    """A launch names each argument; the names are the kernel's own (OpenCL argument info),
    so a misspelt, missing or extra one is refused, naming it, before anything is enqueued."""
    k = rt.program("pyramid", **D4).prep_level0
    assert k.params == ("chain", "prep", "n", "thresh1", "eps")
    buf = rt.cl.Buffer(rt.ctx, rt.cl.mem_flags.READ_WRITE, 64)
    good = dict(chain=buf, prep=buf, n=np.int32(0), thresh1=np.float32(1), eps=np.float32(0.5))
    with pytest.raises(TypeError, match="prep_level0: missing eps; no parameter epsilon"):
        k(rt.queue, (1,), None, **{("epsilon" if a == "eps" else a): v for a, v in good.items()})
    with pytest.raises(TypeError, match="prep_level0: missing thresh1$"):
        k(rt.queue, (1,), None, **{a: v for a, v in good.items() if a != "thresh1"})
    with pytest.raises(TypeError):
        k(rt.queue, (1,), None, buf, buf, np.int32(0), np.float32(1), np.float32(0.5))   # positional: refused
    k(rt.queue, (1,), None, **good).wait()


def test_work_group_shapes_fit_the_device():
    """The preferred shape, halved rows first, then columns, until the device takes it."""
    assert runtime.fit_work_group((64, 4), 1024, (1024, 1024, 1024)) == (64, 4)
    assert runtime.fit_work_group((64, 4), 256, (256, 256, 256)) == (64, 4)
    assert runtime.fit_work_group((64, 4), 64, (64, 64, 64)) == (64, 1)
    assert runtime.fit_work_group((64, 4), 32, (32, 32, 32)) == (32, 1)
    assert runtime.fit_work_group((16, 8), 256, (256, 4, 1)) == (16, 4)


def test_a_name_means_a_platform_before_a_device():
    """`--device intel` picks Intel's platform although PoCL, listed first, names its CPU
    device after the CPU; a device's name still picks it when no platform has it."""
    pocl = runtime.DeviceInfo(0, 0, "Portable Computing Language", "pthread-Intel(R) Xeon(R) Processor", "cpu", "3.0")
    intel = runtime.DeviceInfo(1, 0, "Intel(R) OpenCL", "Intel(R) Xeon(R) Processor", "cpu", "3.1")
    devices = [(pocl, "p"), (intel, "i")]
    assert runtime.choose(devices, "intel")[1] == "i"
    assert runtime.choose(devices, "pthread")[1] == "p"
    assert runtime.choose(devices, "portable")[1] == "p"


def test_a_simulator_is_used_only_when_named():
    """Oclgrind (a test implementation) reports itself as every kind of device, a GPU too:
    the default, and `--device gpu` / `cpu`, pass it over; naming it picks it."""
    sim = runtime.DeviceInfo(0, 0, "Oclgrind", "Oclgrind Simulator", "accelerator | cpu | default | gpu", "1.2")
    cpu = runtime.DeviceInfo(1, 0, "Portable Computing Language", "pthread-cpu", "cpu", "3.0")
    devices = [(sim, "s"), (cpu, "c")]
    assert runtime.choose(devices, None)[1] == "c"
    assert runtime.choose(devices, "cpu")[1] == "c"
    with pytest.raises(runtime.UserError, match="--device 'gpu': no such OpenCL device"):
        runtime.choose(devices, "gpu")
    assert runtime.choose(devices, "oclgrind")[1] == "s"
    assert runtime.choose(devices, "0:0")[1] == "s"
    assert runtime.choose([(sim, "s")], None)[1] == "s"        # the only one there is


def test_lanes_follow_what_the_compiler_emits(rt):
    """LANES 8 (kernels/lanes.h) where the code is 8 floats wide. PoCL 3.0's LLVM 14 compiles
    for znver3 (AVX2) on a Zen 4, a device that reports 16 floats: the scalar LANES 1 code made
    a point light in fog 2.7x slower there. The compiler's word first, the device's where it
    gives none; GPUs never."""
    from fogcli.device.runtime import lanes_for

    assert lanes_for(8, 16, False) == 8         # a Zen 4 under LLVM 14
    assert lanes_for(16, 16, False) == 1        # AVX-512 code: the vectoriser's own
    assert lanes_for(4, 8, False) == 1          # SSE code on an AVX2 device
    assert lanes_for(0, 8, False) == 8 and lanes_for(0, 16, False) == 1
    assert lanes_for(8, 8, True) == 1
    if rt.pocl and rt.device.type & rt.cl.device_type.CPU:
        width = rt._compiled_simd_width()
        assert width in (4, 8, 16), width       # PoCL's clang says, for x86
        assert rt.lanes == lanes_for(width, rt.device.native_vector_width_float, False)
