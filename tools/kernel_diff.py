"""Every kernel's output on one OpenCL implementation against PoCL's (issue 39).

Each case runs the whole pipeline on a tiny frame on PoCL and on the other device with every
kernel launch recorded: after a launch, each buffer the kernel may write (a __global
argument not declared const) is read back. A record is keyed by the kernel, its parameter
and the buffer's size, and holds the buffer as the kernel's last launch on it left it (a
stage's launches differ in number between devices: whole work-groups and strips on a CPU,
one launch on a GPU, but leave the same buffer behind). Each buffer the plan
allocates starts filled with NaN, so a value a kernel did not write, or computed from one
it should not have read, shows up as a NaN against PoCL's number (and a non-finite result
stops the frame). The difference of a record is max |a - b| / max |a| over its floats; a
NaN against a number counts as infinite.

    python tools/kernel_diff.py oclgrind     # table of the largest difference per kernel
    python tools/kernel_diff.py intel        # (with Intel's ICD set up: docs/devices.md)
    python tools/kernel_diff.py --doc        # both, as the block of docs/devices.md (sets the ICD up)
    python tools/kernel_diff.py oclgrind --capture DIR   # also save each kernel's first launch
                                             # on the device (tools/oclgrind_uninitialized.py)
    python tools/kernel_diff.py intel --save-reference DIR   # and PoCL's records of each case;
    POCL_MAX_WORK_GROUP_SIZE=64 python tools/kernel_diff.py portable --reference DIR
                                             # PoCL capped as GPUs are, against those records

tests/test_devices.py runs this for Intel's CPU runtime, Oclgrind and PoCL capped at 64
work-items a group, against TOLERANCE.
"""
from __future__ import annotations

import contextlib
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np


H, W = 36, 64
# the simulator runs ~100x slower than PoCL: cases whose kernels loop over lights, shadows,
# maps or pixel pairs run there at a quarter of the pixels (their kernels' coverage is the
# same; the two kernels only a larger frame reaches, light_share_cols_inner and
# smooth_depth_y_inner, are run by the other cases)
SMALL = {"simulator_size": (32, 18)}

LIGHT = "lights=[{type: point, position: [2, 1, -20], intensity: 300}]"
NOISE = ("medium.density=[{type: homogeneous}, {type: noise, factor: 5, scale: 4, octaves: 2, shape: box, "
         "center: [0, 0, -8], size: [2, 6, 2], seed: 3, edge: 1}]")
SPOT = ("lights=[{type: spot, position: [-3, 3, -6], direction: [1, -1, -0.6], angle: 30, intensity: 300}]")
# name: (medium, --set values, options: size (w, h), aovs, alpha, enlarged (the depth 2 x 2 by nearest
# neighbour), then: the kernels only tests
# launch, after the frame: level 0 of the chains set (run.write_level0), the brute-force
# reference (reference.brute_force), the transmittance map read at points (noise.probe_map))
CASES = {
    "fog": ("fog", [], {}),
    # the two-pixel kernels need a level 1 of whole pairs of work-groups: 320 x 180 at a CPU's
    # 64 x 4, 96 x 54 at a GPU's 16 x 8 (the simulator's; 64 x 36 runs no collapse_pairs)
    "fog, two-pixel kernels": ("fog", [], {"size": (320, 180), "simulator_size": (96, 54)}),
    "sea, separation, AOVs": ("sea", ["render.separation.enabled=true"],
                              {"aovs": ("scattered", "spread", "airlight", "optical_depth")}),
    "receiver fetch, separation": ("fog", ["render.fetch=receiver", "render.psf=gaussian",
                                           "render.separation.enabled=true"], {}),
    "receiver fetch, apsf": ("fog", ["render.fetch=receiver"], {}),
    "valley fog (exponential), alpha": ("valley-fog", ["camera.empty_depth=50"], {"alpha": True}),
    "point light, epipolar shadows": ("fog", [LIGHT, "render.lights.shadows=screen"], SMALL),
    "spot light, marched shadows": ("fog", ["lights=[{type: spot, position: [0, 2, -5], direction: [0, -0.3, -1], "
                                            "angle: 30, intensity: 300}]", "render.lights.shadows=screen",
                                            "render.lights.method=march"], SMALL),
    "point light, chromatic table": ("sea", [LIGHT], SMALL),
    "sun and point": ("haze", ["lights=[{type: directional, direction: [0.3, 1, 0.2], irradiance: 3}, "
                                          "{type: point, position: [-3, 1, -12], intensity: [300, 200, 100]}]"], {}),
    "lamps found in the image": ("fog", ["lights=[{type: auto}]"], {}),
    "point light, airlight pk": ("fog", [LIGHT, "render.lights.airlight=pk"], {}),
    "sphere medium, a light": ("smoke-ball", [LIGHT], SMALL),
    # maps of 32 x 32 texels, not 256 x 256: the same kernels, a fifth of the simulator's time
    "noise column, spot, stride 1": ("fog", [NOISE, SPOT, "render.noise_stride=1", "render.lights.tfm_size=32"], SMALL),
    "noise column, spot, stride 2, map probed": ("fog", [NOISE, SPOT, "render.noise_stride=2",
                                                         "render.lights.tfm_size=32"], {**SMALL, "then": "probe"}),
    "reference, open border": ("fog", ["render.method=reference", "render.border=open"], SMALL),
    "reference, gaussian, brute force": ("fog", ["render.method=reference", "render.psf=gaussian"],
                                         {**SMALL, "then": "brute force"}),
    "extend border": ("fog", ["render.border=extend"], {}),
    # the reference pads the frame as the pyramid's extension does (ref_edge_profiles, ref_profile_rows)
    "reference, extend border": ("fog", ["render.method=reference", "render.border=extend"], SMALL),
    "gaussian, level 0 set": ("fog", ["render.psf=gaussian"], {"then": "level 0"}),
    # a depth enlarged 2 x 2 by nearest neighbour: its edges realigned to the colour's
    "depth enlarged 2 x 2": ("fog", [], {"enlarged": True}),
    # a ground to the horizon under a sky: the slab's table and preprocess with PRE_GROUND
    "a ground and a sky": ("sea", [], {"ground": True}),
    # a sky dome near enough in haze: its first-order light (kernels/dome.cl) joins the table
    "a ground under a sky dome": ("haze", ["camera.max_depth=1000"], {"ground": True, "dome": 150.0}),
    # a CPU's SIMD width picks how many pixels of a row a work-item takes (Runtime.lanes: 8 on
    # 8-wide CPUs without AVX-512, else 1) and with it the pyramid's reduce_source_inner (whole
    # work-groups on level 1: the two-pixel kernels' size): both ways on every CPU
    "point light, a pixel a work-item": ("fog", [LIGHT], {"lanes": 1, "size": (320, 180), "simulator_size": (96, 54)}),
    # (not under Oclgrind, which never runs LANES 8: there the airlight's float8 code gives NaN
    # on ~4 % of the pixels around the light, where PoCL and Intel agree to 1e-6; not found why)
    "point light, eight pixels a work-item": ("fog", [LIGHT], {"lanes": 8, "cpu_only": True}),
    # the pyramid's float8 reduce (kernels/reduce_lanes.cl) under Oclgrind too: on levels at
    # least pyramid.LANES_MIN_WIDTH wide, so level 1 of 160 px
    "eight pixels a work-item, no light": ("fog", [], {"lanes": 8, "size": (160, 36), "simulator_size": (160, 36)}),
}

# The largest difference to PoCL each kernel may show, max |a - b| / max |a| of a buffer it
# writes (a float32 result holds ~6e-8; kernels that sum hundreds of terms or call the math
# library differ more between compilers). Measured figures: docs/devices.md.
TOLERANCE_DEFAULT = 1e-5
TOLERANCE = {
    # quadrature of the airlight: hundreds of nodes, each through exp, atan2, tan, sin/cos
    "airlight": 1e-4, "airlight_noise": 1e-4, "airlight_fill": 1e-4, "airlight_pk": 1e-4,
    "airlight_table": 1e-4, "airlight_table_grey": 1e-4, "airlight_sun": 1e-4,
    # the light leg marched through noise, and its DCT (sums of 32-512 terms)
    "tfm_build": 1e-4, "p_noise": 1e-4, "p_noise_samples": 1e-4,
    # shadows: a march whose visibility steps where a depth compare flips
    "epi_march": 1e-4, "shadow_march": 1e-4, "epi_unwarp": 1e-4, "epi_samples": 1e-4, "add_light": 1e-4,
    "add_airlight": 1e-4,
    # splits a chain level that the light's airlight (above) was added to: 1.4e-5 on Intel in
    # `point light, epipolar shadows` once the extended border fed that level too
    "split_level": 1e-4,
    # adds that light to the collapsed chain: 1.2e-5 on Intel in the same case once the
    # border margin went from 0.1 to 0.05 (session 44; 7.2e-6 before)
    "composite_source": 1e-4,
    # the reference: sums over every pixel pair of a 64 x 36 frame
    "ref_brute": 1e-4, "ref_brute_norm": 1e-4, "ref_finish": 1e-4,
}


# Kernels whose outputs hold decisions (epi_samples: whether a sample's line meets a shadow,
# and the shares that follow from it): a decision flips where a depth compare is as close as
# the float rounding, and the kernels after it (epi_march, epi_unwarp) differ by far less.
# Compared as the share of elements (float4s) that differ by more than TOLERANCE_DEFAULT.
DECISIONS = {"epi_samples": 0.02}


def tolerance(kernel: str) -> float:
    return DECISIONS.get(kernel) or TOLERANCE.get(kernel, TOLERANCE_DEFAULT)


def ground_frame(w: int = W, h: int = H, dome: float = np.inf):
    """A ground plane 1.6 m below a level camera (60 degrees) to the horizon, sky above it:
    at infinity, or a dome `dome` m round the camera (where the ground ends)."""
    rng = np.random.default_rng(2)
    rgb = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    f = (w / 2) / np.tan(np.radians(30.0))
    down = (np.arange(h) + 0.5 - h / 2) / f             # planar: z = 1.6 / down below the horizon
    X, Y = np.meshgrid((np.arange(w) + 0.5 - w / 2) / f, down)
    far = dome / np.sqrt(X * X + Y * Y + 1)            # planar depth of the dome
    z = np.minimum(np.where(Y > 0, 1.6 / np.maximum(Y, 1e-9), np.inf), far)
    rgb[z >= far] = [1.5, 1.8, 2.4]
    return rgb, z.astype(np.float32)


def frame(w: int = W, h: int = H):
    """A random scene-linear frame with a bright pixel (a lamp) and a band of sky."""
    rng = np.random.default_rng(1)
    rgb = rng.uniform(0, 2, (h, w, 3)).astype(np.float32)
    rgb[h // 4 - 1: h // 4 + 2, w // 4 - 1: w // 4 + 2] = 400.0     # a lamp (lights: auto)
    z = rng.uniform(1, 200, (h, w)).astype(np.float32)
    z[: h // 6] = np.inf
    return rgb, z


# the runtime's probe of what the device's compiler emits (runtime.Runtime.lanes): its answer
# differs between compilers by design, and PoCL alone is asked
NOT_A_FRAME_KERNEL = ("simd_width",)


class Recorder:
    """Wraps runtime._Kernel.__call__ and pyopencl.Buffer for one run; with a capture folder,
    also saves each kernel's first launch there as it was right before it (save_launch)."""

    def __init__(self, capture: Path | None = None):
        self.records: dict[tuple, np.ndarray] = {}
        self.capture = capture

    def __enter__(self):
        import pyopencl as cl

        from fogcli.device import runtime

        rec = self
        self._saved = (runtime._Kernel.__call__, cl.Buffer)
        call, Buffer = self._saved

        queues = {}         # a queue of the recorder's own per context, for the fills

        class NanBuffer(Buffer):
            def __init__(self, ctx, flags, size=0, hostbuf=None):
                super().__init__(ctx, flags, size, hostbuf)
                if hostbuf is None and size % 4 == 0:
                    q = queues.get(ctx.int_ptr)
                    if q is None:
                        q = queues[ctx.int_ptr] = cl.CommandQueue(ctx)
                    cl.enqueue_fill_buffer(q, self, np.float32(np.nan), 0, size).wait()

        def recorded(kern, queue, gsize, lsize, /, *, global_offset=None, **named):
            if kern._name in NOT_A_FRAME_KERNEL:
                return call(kern, queue, gsize, lsize, global_offset=global_offset, **named)
            if rec.capture is not None and not (rec.capture / f"{kern._name}.pkl").exists():
                save_launch(rec.capture / f"{kern._name}.pkl", kern, queue, gsize, lsize, global_offset, named)
            ev = call(kern, queue, gsize, lsize, global_offset=global_offset, **named)
            ev.wait()
            name = kern._name
            k = kern._get()
            for i, p in enumerate(kern.params):
                a = named[p]
                if not isinstance(a, cl.Buffer):
                    continue
                if k.get_arg_info(i, cl.kernel_arg_info.TYPE_QUALIFIER) & cl.kernel_arg_type_qualifier.CONST:
                    continue
                host = np.empty(a.size // 4, np.float32)
                cl.enqueue_copy(queue, host, a)
                rec.records[(name, p, a.size)] = host
            return ev

        runtime._Kernel.__call__ = recorded
        cl.Buffer = NanBuffer
        return self

    def __exit__(self, *exc):
        import pyopencl as cl

        from fogcli.device import runtime

        runtime._Kernel.__call__, cl.Buffer = self._saved


def save_launch(path: Path, kern, queue, gsize, lsize, offset, named: dict) -> None:
    """One launch as it is about to run: its program, build options, sizes, every scalar and
    every buffer's contents (tools/oclgrind_uninitialized.py replays it alone)."""
    import pickle

    import pyopencl as cl

    args = []
    for p in kern.params:
        a = named[p]
        if isinstance(a, cl.Buffer):
            host = np.empty(a.size, np.uint8)
            cl.enqueue_copy(queue, host, a)
            args.append(("buffer", host))
        else:
            args.append(("value", a))
    with open(path, "wb") as f:
        pickle.dump({"program": kern._owner._source, "options": list(kern._owner._options),
                     "kernel": kern._name, "args": args,
                     "global": tuple(gsize), "local": tuple(lsize) if lsize else None,
                     "offset": tuple(offset) if offset else None}, f)


def run_case(name: str, device: str, simulated: bool = False, capture: Path | None = None) -> dict:
    """The records of one case on one device (simulated: at the case's simulator size);
    capture: a folder for each kernel's first launch (Recorder)."""
    import fogcli
    from fogcli.device import plan

    medium, sets, opts = CASES[name]
    cfg = fogcli.make_config(medium, sets=sets)
    size = opts.get("simulator_size" if simulated else "size", opts.get("size", (W, H)))
    rgb, z = ground_frame(*size, opts.get("dome", np.inf)) if opts.get("ground") else frame(*size)
    if opts.get("enlarged"):
        z = np.repeat(np.repeat(z[::2, ::2], 2, 0), 2, 1)[: z.shape[0], : z.shape[1]]
    alpha = None
    if opts.get("alpha"):
        alpha = np.ones(z.shape, np.float32)
        alpha[:, : z.shape[1] // 5] = 0.0
    aovs = opts.get("aovs", ())
    plan._PLANS.clear()         # a plan's buffers are made inside the recorder (NaN-filled)
    with Recorder(capture) as rec, lanes(device, opts.get("lanes")):
        fogcli.apply(rgb, z, cfg, alpha=alpha, aovs=aovs, return_aovs=bool(aovs), device=device)
        if opts.get("then") == "brute force":
            from fogcli.device.plan import Timings
            from fogcli.device.reference import brute_force

            (frame_plan,) = plan._PLANS.values()
            brute_force(frame_plan, Timings())
        elif opts.get("then") == "level 0":
            from fogcli.device.run import write_level0

            (frame_plan,) = plan._PLANS.values()
            level0 = np.random.default_rng(3).uniform(0, 2, (frame_plan.h, frame_plan.w, 4)).astype(np.float32)
            write_level0(frame_plan, level0, level0[:, :, 3] * 4)
        elif opts.get("then") == "probe":
            from fogcli.device.noise import probe_map

            pts = np.random.default_rng(2).uniform([-1.5, -4, -10], [1.5, 4, -6], (97, 3))
            probe_map(cfg, cfg.lights[0], pts, device=device)
    return rec.records


@contextlib.contextmanager
def lanes(device: str, n: int | None):
    """The runtime of `device` with its pixels a work-item set to n for the while (None: its own)."""
    from fogcli.device.runtime import get_runtime

    rt = get_runtime(device)
    own = rt.lanes
    rt.lanes = own if n is None else n
    try:
        yield
    finally:
        rt.lanes = own


def partial(kernel: str) -> bool:
    """A kernel that writes a region of its buffer sized by the work-group shape (the inner
    part of Plan.launch_inner, *_inner and *_pairs, and up_rows, which feeds the pairs): the
    region differs between devices, and right after it the rest of the buffer holds what it
    held. Its work is compared in the stage's result, which the kernel launched last on the
    buffer (the strips around the region) leaves."""
    return kernel.endswith(("_inner", "_pairs")) or kernel == "up_rows"


def difference(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| / max |a| over finite values; inf where one holds a NaN or inf the other
    has not."""
    fa, fb = np.isfinite(a), np.isfinite(b)
    if (fa != fb).any() or (np.isnan(a) != np.isnan(b)).any():
        return float("inf")
    if not fa.any():
        return 0.0
    scale = np.abs(a[fa]).max()
    d = np.abs(a[fa].astype(np.float64) - b[fa])
    return float(d.max() / scale) if scale > 0 else float(d.max())


def record_difference(key: tuple, a: np.ndarray, b: np.ndarray) -> float:
    """difference(); for DECISIONS the share of float4s differing by more than
    TOLERANCE_DEFAULT of the buffer's largest value."""
    if key[0] not in DECISIONS:
        return difference(a, b)
    scale = max(float(np.abs(a[np.isfinite(a)]).max(initial=0.0)), 1e-30)
    off = ~np.isclose(a, b, rtol=0.0, atol=TOLERANCE_DEFAULT * scale, equal_nan=True)
    return float(off.reshape(-1, 4).any(axis=1).mean())


def simulated(device: str) -> bool:
    """The device spec names Oclgrind (its cases run at their simulator size, CPU-only ones not)."""
    return "oclgrind" in device.lower()


def cases_for(device: str) -> list[str]:
    """The cases a device runs: all but the CPU-only ones under the simulator."""
    return [n for n in CASES if not (simulated(device) and CASES[n][2].get("cpu_only"))]


def compare(device: str, cases=None, capture: Path | None = None, save_reference: Path | None = None,
            reference: Path | None = None) -> dict:
    """{kernel: (largest difference, its case, its parameter)} over the cases. A kernel both
    devices ran on different buffers counts as an infinite difference; one that only one
    device's plan runs (PoCL's whole-group kernels) is left out of that case. capture: a
    folder for each kernel's first launch on the device (Recorder). save_reference: a folder
    for PoCL's records of each case; reference: such a folder, read instead of running PoCL
    here (PoCL with its work-groups capped is another process's PoCL: POCL_MAX_WORK_GROUP_SIZE
    is read once)."""
    import pickle

    worst: dict[str, tuple] = {}
    sim = simulated(device)
    for i, name in enumerate(cases or cases_for(device)):
        saved = f"{i:02d}-{'sim' if sim else 'cpu'}.pkl"
        if reference is not None:
            with open(reference / saved, "rb") as f:
                case_name, ref = pickle.load(f)
            assert case_name == name, (case_name, name)
        else:
            ref = run_case(name, "portable", sim)
        if save_reference is not None:
            with open(save_reference / saved, "wb") as f:
                pickle.dump((name, ref), f)
        got = run_case(name, device, sim, capture)
        for key in ref.keys() | got.keys():
            k = key[0]
            if partial(k):
                if key in got:        # it ran on the device under test (PoCL's shapes may skip it)
                    worst.setdefault(k, (None, name, key[1]))
                continue
            if key in ref and key in got:
                d = record_difference(key, ref[key], got[key])
            elif any(r[0] == k for r in ref) and any(r[0] == k for r in got):
                d = float("inf")       # the kernel wrote other buffers on one device
            else:
                continue               # a kernel one device's plan does not use (CPU-only, two-pixel)
            if k not in worst or worst[k][0] is None or d > worst[k][0]:
                worst[k] = (d, name, key[1])
    return worst


# Intel's CPU runtime as pip installs it in this environment (intel-opencl-rt, the test
# extra), and the device spec that picks it: its platform's name
INTEL_LIB = Path(sys.prefix) / "lib" / "libintelocl.so"
INTEL_SPEC = "intel(r) opencl"


def intel_icd(folder: Path) -> bool:
    """Write into folder an ICD file naming INTEL_LIB (the package's own names its build
    machine's path), so that OCL_ICD_VENDORS=folder makes Intel's runtime a platform beside
    PoCL and Oclgrind; False where it is not installed."""
    if not INTEL_LIB.is_file():
        return False
    (folder / "intel-cpu.icd").write_text(f"{INTEL_LIB}\n")
    return True


def table(results: dict) -> list[str]:
    """Markdown rows: kernel, each device's largest difference, the tolerance."""
    names = list(results)
    rows = [f"| kernel | {' | '.join(names)} | tolerance | case of the largest |", "|---" * (len(names) + 3) + "|"]
    for k in sorted(set().union(*results.values())):
        got = [results[n].get(k) for n in names]
        cells = ["–" if d is None else "in the stage's result" if d[0] is None else f"{d[0]:.1e}" for d in got]
        measured = [d for d in got if d is not None and d[0] is not None]
        top = max(measured, key=lambda d: d[0]) if measured else None
        where = f"{top[1]} ({top[2]})" if top else ""
        tol = "share of samples " + f"{DECISIONS[k]:.0%}" if k in DECISIONS else f"{tolerance(k):.0e}"
        rows.append(f"| {k} | {' | '.join(cells)} | {tol} | {where} |")
    return rows


def write_doc() -> int:
    """Intel's CPU runtime, PoCL capped at 64 work-items a group and Oclgrind against PoCL, as
    a block of docs/devices.md."""
    from docblock import cpu_kind, cpu_name, markers, write_block

    import pyopencl as cl

    import subprocess

    results = {}
    with tempfile.TemporaryDirectory(prefix="fogcli-pocl-records-") as ref:
        intel = INTEL_SPEC in " ".join(p.name.lower() for p in cl.get_platforms())
        worst = compare(INTEL_SPEC if intel else "portable", save_reference=Path(ref))
        if intel:
            results["Intel CPU runtime"] = worst
        env = dict(os.environ, POCL_MAX_WORK_GROUP_SIZE="64")
        r = subprocess.run([sys.executable, __file__, "portable", "--json", "--reference", ref], env=env,
                           capture_output=True, text=True, check=True)
        results["PoCL, 64 a group"] = {k: tuple(v) for k, v in json.loads(r.stdout.splitlines()[-1]).items()}
    results["Oclgrind"] = compare("oclgrind")
    over = [k for r in results.values() for k, v in r.items() if v[0] is not None and v[0] > tolerance(k)]
    versions = "; ".join(f"{p.name.strip()} {p.version.strip()}" for p in cl.get_platforms())
    begin, end = markers(f"kernel-diff-{cpu_kind()}")
    block = [begin, f"Largest difference to PoCL per kernel, max |a - b| / max |a| of a buffer it writes, over "
             f"{len(CASES)} tiny frames (`python tools/kernel_diff.py --doc`; {cpu_name()}; {versions}). "
             "Over tolerance: " + (", ".join(over) if over else "none") + ".", "", *table(results), end]
    doc = Path(__file__).resolve().parents[1] / "docs" / "devices.md"
    write_block(doc, begin, end, "\n".join(block), new_doc="# OpenCL devices\n")
    print("\n".join(block))
    return 1 if over else 0


def source_builds() -> None:
    """Programs built from source in this process: they hold argument info (which parameters
    are const: Recorder), one from a binary may not (Intel's CPU runtime). For the scripts'
    own processes only: set on import it would outlive a test that imports this module, and
    every later test in that pytest process would build from source."""
    os.environ["FOGCLI_KERNEL_CACHE"] = "0"


def main(argv=None) -> int:
    import argparse
    import warnings

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("device", nargs="?", default="intel", help="device spec (runtime.choose)")
    ap.add_argument("--json", action="store_true", help="one JSON line {kernel: [difference, case, parameter]}")
    ap.add_argument("--doc", action="store_true", help="Intel's and Oclgrind's tables into docs/devices.md")
    ap.add_argument("--capture", type=Path, help="save each kernel's first launch on the device here")
    ap.add_argument("--save-reference", type=Path, help="save PoCL's records of each case here")
    ap.add_argument("--reference", type=Path, help="PoCL's records saved by --save-reference, not run here")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")     # the lamps case's note: stderr is Oclgrind's report
    source_builds()
    if args.doc:
        with tempfile.TemporaryDirectory(prefix="fogcli-icd-") as icd:
            if "OCL_ICD_VENDORS" not in os.environ and intel_icd(Path(icd)):
                os.environ["OCL_ICD_VENDORS"] = icd      # before pyopencl's first platform query
            return write_doc()
    worst = compare(args.device, capture=args.capture, save_reference=args.save_reference,
                    reference=args.reference)
    if args.json:
        print(json.dumps({k: list(v) for k, v in worst.items()}))
        return 0
    print(f"{'kernel':24s} {'largest difference':>18s} {'tolerance':>9s}  case (parameter)")
    bad = 0
    for k in sorted(worst):
        d, case, p = worst[k]
        if d is None:
            print(f"{k:24s} {'in the stage':>18s} {'':9s}  {case} ({p})")
            continue
        ok = d <= tolerance(k)
        bad += not ok
        print(f"{k:24s} {d:18.2e} {tolerance(k):9.0e}  {case} ({p}){'' if ok else '  OVER'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
