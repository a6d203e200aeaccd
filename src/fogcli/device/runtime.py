"""The OpenCL runtime: device choice, one context and queue, programs built once.

Device choice (first match wins): the explicit spec (``--device`` / ``FOGCLI_DEVICE``),
else the first GPU or accelerator of any platform, else the first CPU device (PoCL from
pip is the embedded default). A spec is ``P:D`` (platform and device index, as listed
by ``fogcli devices``, needed when two platforms share a name), ``cpu``, ``gpu`` or a
case-insensitive substring of a platform's name, else of a device's.
"""
from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

from fogcli.errors import ProcessingError, UserError, interrupt_held

KERNEL_DIR = Path(__file__).resolve().parent / "kernels"
# Work-group size on a CPU: 64 x 4, against the 32 x 4 before it on an AMD EPYC (Zen 3, AVX2),
# 2 MPx default pipeline (tools/ab_kernels.py, kernel_ms paired with a copy): 0.92x in 8
# rounds (best 68.8 against 78.2 ms), 0.80x in 6 (0.74x compiled for Zen 1); 64 x 2, 128 x 2 and
# 128 x 4 were 0.81-0.91x in 6. The gain is in the two-pixel kernels (composite_source_pairs 18.2
# -> 14.2 ms, collapse_pairs 4.6 -> 3.2; composite_source on the wider strips around them
# 1.8 -> 2.9). Other pipelines, 4 rounds: a point light 0.82x, with screen shadows 0.82x, sea
# 0.88x, smoke-ball 0.87x, psf gaussian 0.81x. On an Intel Xeon (AVX-512), against 32 x 4 and
# the kernels before this choice (ab_kernels.py fd3efff, 8 rounds, twice): best kernel_ms 0.83x
# and 0.89x, paired 1.02x and 1.01x; 32 x 4, 128 x 4 and 64 x 8 alone there: within the noise.
LOCAL_CPU = tuple(int(v) for v in os.environ.get("FOGCLI_LOCAL", "64,4").split(","))


def fit_work_group(local: tuple[int, int], most: int, per_dim: tuple) -> tuple[int, int]:
    """The preferred 2-D work-group shape, halved (rows first, then columns) until a device
    whose groups hold at most `most` work-items, and `per_dim` along each dimension, takes it
    (a GPU: often 256; PoCL told POCL_MAX_WORK_GROUP_SIZE)."""
    lx, ly = local
    while lx * ly > most or lx > per_dim[0] or ly > per_dim[1]:
        if ly > 1:
            ly //= 2
        else:
            lx //= 2
    return max(lx, 1), max(ly, 1)


def cache_dir() -> str:
    """fogcli's folder of the user's cache: PoCL's cache and the device binaries."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "fogcli")


def _user_cache_dir() -> Path:
    return Path(cache_dir())


def _prepare_environment() -> None:
    # PoCL compiles kernels into a cache; by default under $HOME/.cache/pocl, but a
    # read-only or shared HOME must not break us, so give it our own user cache dir.
    cache = _user_cache_dir() / "pocl"
    if "POCL_CACHE_DIR" not in os.environ:
        try:
            cache.mkdir(parents=True, exist_ok=True)
            os.environ["POCL_CACHE_DIR"] = str(cache)
        except OSError:
            pass


def _cl():
    _prepare_environment()
    return _import_pyopencl()


def _import_pyopencl():
    """pyopencl, imported lazily (`fogcli check` and `media` never touch OpenCL). A Ctrl-C
    that lands while its extension creates its enums aborts the process (nanobind: a
    'Critical nanobind error' and SIGABRT): the interrupt is held until the import is done,
    and that of the kernel invoker pyopencl would import at the first launch."""
    with interrupt_held():
        import pyopencl
        # imported by pyopencl at the first launch otherwise: its cache (a sqlite dict) made
        # half by a Ctrl-C printed a traceback from its __del__ (3 ms, here and not there)
        import pyopencl.invoker  # noqa: F401

    return pyopencl


@dataclass(frozen=True)
class DeviceInfo:
    platform_index: int
    device_index: int
    platform: str
    name: str
    kind: str
    version: str

    @property
    def spec(self) -> str:
        return f"{self.platform_index}:{self.device_index}"

    def label(self) -> str:
        return f"{self.name} [{self.platform}, {self.spec}]"

    @property
    def simulator(self) -> bool:
        """Oclgrind: it checks every memory access and reports itself as every kind of device
        (a GPU too), at a thousandth of a CPU's speed. Used only when named."""
        return "oclgrind" in self.platform.lower()


def list_devices() -> list[tuple[DeviceInfo, object]]:
    cl = _cl()
    try:
        platforms = cl.get_platforms()
    except Exception as exc:  # pyopencl raises LogicError with no ICD at all
        raise ProcessingError(f"no OpenCL platform found ({exc}); install pocl-binary-distribution") from exc
    out = []
    for pi, p in enumerate(platforms):
        try:
            devices = p.get_devices()
        except Exception:
            continue
        for di, d in enumerate(devices):
            # a device of every kind (Oclgrind) spells its type as a bit field: the kinds alone
            kind = " | ".join(k for k in cl.device_type.to_string(d.type).lower().split(" | ")
                              if k and k not in ("all", "default") and not k.startswith("_"))
            out.append((DeviceInfo(pi, di, p.name.strip(), d.name.strip(), kind, p.version.strip()), d))
    if not out:
        raise ProcessingError("no OpenCL device available; install pocl-binary-distribution")
    return out


def choose(devices, spec: str | None, origin: str = "--device"):
    if spec:
        s = spec.strip().lower()
        for info, dev in devices:
            if s == info.spec or (s in ("cpu", "gpu", "accelerator") and s in info.kind and not info.simulator):
                return info, dev
        # a platform's name before a device's: PoCL names its CPU device after the CPU
        # ("pthread-Intel(R) Xeon(R) ..."), and "intel" means Intel's platform
        named = [d for d in devices if s in d[0].platform.lower()] or [d for d in devices if s in d[0].name.lower()]
        if named:
            return named[0]
        known = ", ".join(i.spec + " " + i.name for i, _ in devices)
        raise UserError(f"{origin} {spec!r}: no such OpenCL device (have: {known})")
    real = [(info, dev) for info, dev in devices if not info.simulator] or devices
    for info, dev in real:
        if "gpu" in info.kind or "accelerator" in info.kind:
            return info, dev
    return real[0]


class _Kernels:
    """Kernels of one program, each retrieved once (a retrieval is a new cl.Kernel). The
    program is built when a kernel of it is first launched: a plan names every variant it
    might launch, and a frame of the default pipeline launches six of its eight (a build
    from the binary cache costs 5-15 ms of every process)."""

    def __init__(self, cl, build, source: str | None = None, options: tuple = ()):
        """build() -> (program, its kernels' parameter names; {}: ask the device); source
        (kernels/<source>.cl) and options: what it builds, for tools that build it again
        (tools/oclgrind_uninitialized.py)."""
        self._cl, self._build, self._program, self._cache = cl, build, None, {}
        self._params: dict = {}     # kernel -> parameter names, as the device said at the build
        self._source, self._options = source, tuple(options)

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        k = self._cache.get(name)
        if k is None:
            k = self._cache[name] = _Kernel(self, name)
        return k

    def build(self) -> "_Kernels":
        """The program now (the binary cache's tests; a launch does it by itself)."""
        if self._program is None:
            self._program, self._params = self._build()
        return self

    def kernel(self, name: str):
        return self._cl.Kernel(self.build()._program, name)


def kernel_params(cl, k) -> list[str]:
    """A kernel's parameter names, from the device's argument info (-cl-kernel-arg-info)."""
    return [k.get_arg_info(i, cl.kernel_arg_info.NAME) for i in range(k.get_info(cl.kernel_info.NUM_ARGS))]


def _arg_dtype(arg):
    """What pyopencl should pack an argument as: numpy scalars and structs (camera_t, ...)
    by their dtype, anything else (buffers) as it is."""
    import numpy as np

    if isinstance(arg, np.generic) or (isinstance(arg, np.ndarray) and arg.dtype.kind == "V"):
        return arg.dtype
    return None


class _Kernel:
    """One kernel, retrieved (and its program built) at its first launch, launched with its
    arguments by name: checked against the kernel's own parameter list (OpenCL's argument
    info, -cl-kernel-arg-info) and put in its order, so that a renamed, added or dropped
    parameter fails at the launch with its name instead of shifting every argument after
    it. Its scalar argument types are declared from the first launch's arguments:
    undeclared, pyopencl sets each scalar through a generic path of ~9 us (PoCL, pyopencl
    2026.1), which made an enqueue of 18 arguments ~100 us and the ~140 launches of a 2 MPx
    frame ~14 ms of host time, taken from the cores the kernels run on; declared, ~3 us
    (tools/enqueue_cost.py)."""

    __slots__ = ("_owner", "_name", "_k", "_typed", "_params")

    def __init__(self, owner: _Kernels, name: str):
        self._owner, self._name, self._k, self._typed, self._params = owner, name, None, False, None

    def _get(self):
        if self._k is None:
            self._k = self._owner.kernel(self._name)
        return self._k

    @property
    def params(self) -> tuple[str, ...]:
        """The kernel's parameter names, in order, as the device reports them."""
        if self._params is None:
            k = self._get()
            known = self._owner._params.get(self._name)
            self._params = tuple(known) if known is not None else kernel_params(self._owner._cl, k)
        return self._params

    def __call__(self, queue, global_size, local_size, /, *, global_offset=None, **named):
        params = self.params
        if named.keys() != set(params):
            missing = [p for p in params if p not in named]
            extra = sorted(set(named) - set(params))
            said = ([f"missing {', '.join(missing)}"] if missing else []) + \
                ([f"no parameter {', '.join(extra)}"] if extra else [])
            raise TypeError(f"kernel {self._name}: " + "; ".join(said))
        args = [named[p] for p in params]
        k = self._get()
        if not self._typed:
            k.set_scalar_arg_dtypes([_arg_dtype(a) for a in args])
            self._typed = True
        return k(queue, global_size, local_size, *args, global_offset=global_offset)

    def __getattr__(self, attr):
        return getattr(self._get(), attr)


def build_source(cl, ctx, src: str, opts: list[str]):
    """(program, its kernels' parameter names) built from source: not through pyopencl's own
    binary cache, whose programs may lack argument info (Intel's CPU runtime has none for a
    program made from a binary). Options should hold -cl-kernel-arg-info."""
    prog = cl.Program(ctx, src)
    prog._prg = cl._cl._Program(ctx, src)
    prog.build(options=opts)
    return prog, {k.function_name: kernel_params(cl, k) for k in prog.all_kernels()}


def lanes_for(compiled: int, reported: int, gpu: bool) -> int:
    """LANES (kernels/lanes.h): 8 where the code is 8 floats wide (AVX2 without AVX-512),
    by what the compiler emits (`compiled`, kernels/simd_width.cl; 0: it does not say)
    before what the device reports."""
    return 8 if not gpu and (compiled or reported) == 8 else 1


class Runtime:
    """One context, one profiling queue, and a cache of built programs."""

    def __init__(self, spec: str | None = None):
        cl = _cl()
        self.cl = cl
        env = os.environ.get("FOGCLI_DEVICE")
        self.info, device = choose(list_devices(), spec or env, "--device" if spec or not env else "FOGCLI_DEVICE")
        self.device = device
        self.ctx = cl.Context([device])
        self.queue = cl.CommandQueue(self.ctx, properties=cl.command_queue_properties.PROFILING_ENABLE)
        self._programs: dict[tuple, object] = {}
        self.pocl = "portable computing language" in device.platform.name.lower()
        gpu = "gpu" in self.info.kind or "accelerator" in self.info.kind
        # the preferred shapes, within what this device takes
        most = device.max_work_group_size
        self.local2d = fit_work_group((16, 8) if gpu else LOCAL_CPU, most, tuple(device.max_work_item_sizes))
        self.local1d = min(128 if gpu else LOCAL_CPU[0] * LOCAL_CPU[1], most, device.max_work_item_sizes[0])
        self._gpu = gpu

    @functools.cached_property
    def lanes(self) -> int:
        """LANES of the kernels written on float8 for CPUs whose vectoriser would leave them
        scalar: 8-wide SIMD without AVX-512 (kernels/lanes.h), as PoCL compiles. On a Zen 4
        its LLVM 14 emits AVX2 for a device that reports 16 floats wide, and the scalar code
        made a point light in fog 2.7x slower (460 against 170 ms at 2 MPx). Asked for by
        the first plan: the probe is a program of its own."""
        width = self._compiled_simd_width() if self.pocl and not self._gpu else 0
        return lanes_for(width, self.device.native_vector_width_float, self._gpu)

    def _compiled_simd_width(self) -> int:
        """Floats in a SIMD register of the code PoCL emits here (kernels/simd_width.cl; 0:
        the compiler does not say). One tiny program, from the binary cache after the first run."""
        import numpy as np

        out = np.zeros(1, np.int32)
        buf = self.cl.Buffer(self.ctx, self.cl.mem_flags.WRITE_ONLY, out.nbytes)
        self.program("simd_width").simd_width(self.queue, (1,), (1,), out=buf)
        self.cl.enqueue_copy(self.queue, out, buf)
        return int(out[0])

    def nd(self, w: int, h: int | None = None):
        """(global, local) sizes: global rounded up to whole work-groups. Left to itself
        PoCL picks a local size that divides the global one, which for widths like 2667
        is 1 or 3 and costs a factor 3-4 (kernels bound-check their ids)."""
        if h is None:
            lx = self.local1d
            return (-(-int(w) // lx) * lx,), (lx,)
        lx, ly = self.local2d
        return (-(-int(w) // lx) * lx, -(-int(h) // ly) * ly), (lx, ly)

    def launch2d(self, kernels, w: int, h: int, /, **args) -> list:
        """Run a w x h kernel as (whole, checked): `whole`, built with -D WHOLE_GROUPS, on the
        part that whole work-groups cover, without a bounds check; `checked` on the strips to
        its right and below. Under a bounds check PoCL must mask every memory access of a
        work-item, and masked RGBA and table reads vectorise on AVX-512 only
        (tools/pocl_vectorisation.py). Returns the events."""
        lx, ly = self.local2d
        w0, h0 = w // lx * lx, h // ly * ly
        q, evs = self.queue, []
        if w0 and h0:
            evs.append(kernels[0](q, (w0, h0), (lx, ly), **args))
        if w0 < w:
            evs.append(kernels[1](q, (lx, -(-h // ly) * ly), (lx, ly), global_offset=(w0, 0), **args))
        if h0 < h and w0:
            evs.append(kernels[1](q, (w0, ly), (lx, ly), global_offset=(0, h0), **args))
        return evs

    def launch_strips(self, kernel, w: int, h: int, region: tuple, /, **args) -> list:
        """A per-pixel (checked) kernel on the four strips of a w x h level around `region`
        (x0, x1, y0, y1), at their exact sizes: no pixel twice (the separated chain's pass
        adds). Returns the events."""
        x0, x1, y0, y1 = region
        strips = ((w, y0, 0, 0), (w, h - y1, 0, y1), (x0, y1 - y0, 0, y0), (w - x1, y1 - y0, x1, y0))
        return [kernel(self.queue, (gx, gy), None, **args, global_offset=(ox, oy))
                for gx, gy, ox, oy in strips if gx > 0 and gy > 0]

    def launch1d(self, kernels, n: int, /, **args) -> list:
        """launch2d for a kernel over n items: whole work-groups, then the rest checked."""
        lx = self.local1d
        n0 = n // lx * lx
        evs = [kernels[0](self.queue, (n0,), (lx,), **args)] if n0 else []
        if n0 < n:
            evs.append(kernels[1](self.queue, (lx,), (lx,), global_offset=(n0,), **args))
        return evs

    def program(self, name: str, **defines):
        """Kernels of kernels/<name>.cl built with -D defines, once per process, and once
        per machine through the binary cache (`binary_path`, `_build`)."""
        key = (name,) + tuple(sorted(defines.items()))
        prog = self._programs.get(key)
        if prog is None:
            src = (KERNEL_DIR / f"{name}.cl").read_text()
            # argument info: kernels are launched by parameter name (_Kernel)
            opts = ["-I", str(KERNEL_DIR), "-cl-kernel-arg-info"]
            if self.pocl:      # kernels/common.h: clang builtins where PoCL's library calls are slow
                opts += ["-D", "FOGCLI_POCL=1"]
            for k, v in sorted(defines.items()):
                opts += ["-D", f"{k}={v}"]
            prog = _Kernels(self.cl, lambda name=name, src=src, opts=opts: self._build(name, src, opts), name, opts)
            self._programs[key] = prog
        return prog

    def binary_path(self, name: str, src: str, opts: list[str]) -> Path | None:
        """Where the device binary of this source, these options, this device and driver
        lives (None: the cache is off, FOGCLI_KERNEL_CACHE=0). The key hashes the program's
        source, every header it can include, the options, the device, the driver, the
        OpenCL platform and the driver's settings (POCL_*, CL_CONFIG_*), so an edit, an upgrade or another
        target builds anew: PoCL's device version names the CPU it compiles for
        (tools/avx2/run.sh makes it another)."""
        if os.environ.get("FOGCLI_KERNEL_CACHE", "1") == "0":
            return None
        import hashlib

        h = hashlib.sha256()
        # the headers' folder by content, not by path: every install (a CI clone's fresh venv)
        # would otherwise build every program anew
        parts = [src, *(f.name + f.read_text() for f in sorted(KERNEL_DIR.glob("*.h"))),
                 *("<kernels>" if o == str(KERNEL_DIR) else o for o in opts)]
        d = self.device
        parts += [d.name, d.vendor, d.version, d.driver_version, d.platform.name, d.platform.version,
                  self.cl.VERSION_TEXT]
        # the drivers' own compile settings: PoCL's POCL_*, Intel's CPU runtime's CL_CONFIG_*
        parts += [f"{k}={v}" for k, v in sorted(os.environ.items())
                  if k.startswith(("POCL_", "CL_CONFIG_")) and k != "POCL_CACHE_DIR"]
        for part in parts:
            h.update(part.encode() + b"\0")
        return _user_cache_dir() / "kernels" / f"{name}-{h.hexdigest()[:40]}.bin"

    def _build(self, name: str, src: str, opts: list[str]):
        """(program, its kernels' parameter names). From the cached binary when there is one
        (a few ms against 50-150 ms from source with a warm PoCL cache), with the names the
        device gave when it built it from source (a program made from a binary may have no
        argument info: Intel's CPU runtime); a binary that does not load, or has no names, is
        rebuilt from source and replaced. Written to temporary files and renamed: concurrent
        processes never see half a binary."""
        import json
        import warnings

        cl = self.cl
        path = self.binary_path(name, src, opts)
        names_path = path.with_suffix(".json") if path is not None else None
        # a compiler's log of a successful build is not the user's business: pyopencl warns on
        # any (Intel's CPU runtime logs its vectoriser's remarks); a failed build's log is
        # in the error below
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cl.CompilerWarning)
            if path is not None and path.is_file():
                try:
                    names = json.loads(names_path.read_text())
                    return cl.Program(self.ctx, [self.device], [path.read_bytes()]).build(options=opts), names
                except (cl.Error, OSError, ValueError):
                    pass   # stale, damaged or without names: build from source below and write it again
            try:
                prog, names = build_source(cl, self.ctx, src, opts)
            except cl.RuntimeError as exc:
                raise ProcessingError(f"kernel {name}.cl failed to build: {exc}") from exc
        if path is not None:
            try:
                binary = prog.get_info(cl.program_info.BINARIES)[0]
                path.parent.mkdir(parents=True, exist_ok=True)
                for target, data in ((names_path, json.dumps(names).encode()), (path, binary)):
                    tmp = target.with_suffix(f".{os.getpid()}.tmp")
                    tmp.write_bytes(data)
                    os.replace(tmp, target)
            except (cl.Error, OSError):
                pass   # an unwritable cache only costs the next process a build
        return prog, names


_RUNTIMES: dict[str | None, Runtime] = {}


def get_runtime(spec: str | None = None) -> Runtime:
    """The process-wide runtime for a device spec (built lazily, once)."""
    rt = _RUNTIMES.get(spec)
    if rt is None:
        rt = _RUNTIMES[spec] = Runtime(spec)
    return rt
