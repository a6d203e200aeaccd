"""The per-image plan: buffers of every level allocated once per image size (silx style),
then preprocess -> pyramid -> composite, or preprocess -> reference. Kernel times come
from OpenCL profiling events, grouped per stage."""
from __future__ import annotations

from dataclasses import dataclass, field

import math

import numpy as np

from . import pixels
from .config import FILTERS, Config
from .errors import ProcessingError
from .runtime import Runtime, get_runtime
from .structs import CAMERA_T, MEDIUM_T, SH_BINS

INTERP = {"linear-bilinear": 0, "linear-bicubic": 1, "cubic-bicubic": 2}


def level_sizes(width: int, height: int, levels: int | str) -> list[tuple[int, int]]:
    """Level 0 and every halving (rounded up) down to 1x1, or `levels` levels above 0."""
    sizes = [(width, height)]
    while sizes[-1] != (1, 1) and (levels == "auto" or len(sizes) <= int(levels)):
        w, h = sizes[-1]
        sizes.append(((w + 1) // 2, (h + 1) // 2))
    return sizes


@dataclass
class Timings:
    stages: dict = field(default_factory=dict)

    def add(self, stage: str, event) -> None:
        """One event, or the list of a split launch (Runtime.launch2d / launch1d)."""
        self.stages.setdefault(stage, []).extend(event if isinstance(event, list) else [event])

    def add_copy(self, stage: str, event) -> None:
        """A copy from host memory: waited for and kept as its time. The event itself would
        keep the host array alive until the end of the frame (pyopencl's NannyEvent)."""
        event.wait()
        self.stages.setdefault(stage, []).append((event.profile.end - event.profile.start) * 1e-6)

    def resolve(self) -> dict[str, float]:
        out = {}
        for stage, events in self.stages.items():
            out[stage] = sum(e if isinstance(e, float) else (e.profile.end - e.profile.start) * 1e-6 for e in events)
        return out


def defines(cfg: Config) -> dict:
    taps = FILTERS[cfg.render.kernel]
    d = {"FILTER_TAPS": len(taps), "FILTER_WEIGHTS": ",".join(f"{t!r}f" for t in taps),
         "INTERP": INTERP[cfg.render.interpolation]}
    if cfg.render.spread_model == "paper":
        d["SPREAD_PAPER"] = 1
    if uses_apsf(cfg):
        from .apsf import COS_MIN, NC, NP, load_table

        d["PSF_APSF"] = 1
        d["APSF_NP"] = NP
        if cfg.render.emission_profile == "lambertian":
            d.update(EMISSION_LAMBERT=1, APSF_NC=NC, APSF_COS_MIN=f"{COS_MIN!r}f",
                     APSF_J=len(load_table()["sigma_u"]))
    if open_border(cfg):
        d["BORDER_OPEN"] = 1
    m = cfg.medium
    if len(set(m.absorption)) == 1 and len(set(m.scattering)) == 1:
        d["MEDIUM_GREY"] = 1      # fog, haze, smoke: one channel's table reads and exponentials serve all three
    return d


EXT_LEVEL = 3   # render.border: extend spreads the continued edge at level 3's resolution (1/8)


def open_border(cfg: Config) -> bool:
    """Light that crosses the frame's edge (or the edge continued, `extend`) leaves. `extend`
    needs the tabulated point spread; with the Gaussian one it continues the edge without
    limit, which is the closed border."""
    return cfg.render.border == "open" or (cfg.render.border == "extend" and uses_apsf(cfg))


def border_margin(cfg: Config, width: int, height: int) -> tuple[int, int]:
    """`render.border: extend`: pixels the frame's edge is continued by on each side (x, y)."""
    if cfg.render.border != "extend" or not uses_apsf(cfg):
        return 0, 0
    f = cfg.render.border_margin
    return int(round(f * width)), int(round(f * height))


def uses_apsf(cfg: Config) -> bool:
    """The tabulated point spread runs in the source collapse and in the reference."""
    r = cfg.render
    return r.psf == "apsf" and (r.method == "reference" or (r.method == "pyramid" and r.fetch == "source"))


def rotation(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """R = Ry(yaw) Rx(pitch) Rz(roll), right-handed, degrees (docs/conventions.md, Geometry)."""
    y, p, r = np.radians([yaw, pitch, roll])
    ry = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]])
    rx = np.array([[1, 0, 0], [0, np.cos(p), -np.sin(p)], [0, np.sin(p), np.cos(p)]])
    rz = np.array([[np.cos(r), -np.sin(r), 0], [np.sin(r), np.cos(r), 0], [0, 0, 1]])
    return ry @ rx @ rz


def camera_struct(cfg: Config, width: int, height: int) -> np.ndarray:
    """The kernels take metric depth (depth.decode): z for z, disparity and inverse."""
    cam = cfg.camera
    s = np.zeros((), CAMERA_T)
    s["pos"] = [*cam.position, 0.0]
    s["rot"][:, :3] = rotation(cam.yaw, cam.pitch, cam.roll)
    s["focal_px"] = cam.focal(width)
    s["focal_y"] = cam.focal_y(width)
    s["cx"], s["cy"] = cam.centre(width, height)
    s["max_depth"] = cam.max_depth
    s["depth_is_z"] = 0 if cam.depth == "distance" else 1
    return s


def medium_struct(cfg: Config, width: int, height: int) -> np.ndarray:
    m = cfg.medium
    s = np.zeros((), MEDIUM_T)
    sa, ss = np.array(m.absorption, np.float32), np.array(m.scattering, np.float32)
    s["sa"] = [*sa, sa.mean()]
    s["ss"] = [*ss, ss.mean()]
    s["emission"] = [*m.emission, 0.0]
    s["ambient"] = [*m.ambient, 0.0]
    s["cam"] = camera_struct(cfg, width, height)
    s["g"] = m.asymmetry
    s["spread_scale"] = cfg.render.spread_scale
    s["homogeneous"] = m.homogeneous
    s["has_medium_light"] = int(any(m.emission) or any(m.ambient))
    s["has_p"] = int(m.heterogeneous)
    return s


def light_image(cfg: Config, light, width: int, height: int) -> tuple[float, float]:
    """Where a point or spot light appears in the image, pixels from the top-left corner
    (far outside for a directional light or one behind the camera)."""
    from .lights import placed

    if light.type == "directional":
        return -1e9, -1e9
    cam = cfg.camera.for_size(width, height)
    pos, _ = placed(cfg, light)
    c = cfg.camera
    x, y, z = rotation(c.yaw, c.pitch, c.roll).T @ (np.asarray(pos, float) - np.asarray(cfg.camera.position, float))
    if z >= 0:
        return -1e9, -1e9
    cx, cy = cam.centre(width, height)
    return cx + cam.focal(width) * x / -z, cy - cam.focal_y(width) * y / -z


def primitive_launches(cfg: Config) -> list[tuple[str, tuple]]:
    """(kernel, its primitive arguments) per non-homogeneous density primitive. For an
    exponential, factor * exp(-b <c - o, n>) (c the camera position) is the same for every
    pixel and is computed here in float64."""
    out = []
    cam = np.array(cfg.camera.position, np.float64)
    for d in cfg.medium.density:
        if d.type == "exponential":
            n = np.array(d.direction, np.float64)
            n /= np.linalg.norm(n)
            pre = d.factor * math.exp(min(-d.falloff * float((cam - np.array(d.offset)) @ n), 87.0))
            out.append(("p_exponential", (np.float32(pre), np.float32(d.falloff),
                                          np.array([*n, 0.0], np.float32))))
        elif d.type == "sphere":
            out.append(("p_sphere", (np.float32(d.factor), np.float32(d.radius),
                                     np.array([*d.center, 0.0], np.float32))))
    return out


@dataclass(frozen=True)
class Features:
    """What a plan computes, as far as its device memory goes."""
    source: bool          # the source collapse: a prep chain
    sep: bool             # pixel separation: a second chain
    split_medium: bool    # emission + ambient in a buffer of their own (AOVs)
    lights: bool
    lambert: bool         # emission_profile lambertian: view cosines
    aovs: tuple
    reference: bool       # method reference: three more full-size planes
    epipolar: bool        # lights with screen shadows, method epipolar: a flag per pixel
    spread0: bool         # the source collapse reads level 0 of the spread chain (a Gaussian
                          # spread, the AOVs, or the P of a heterogeneous medium); no level above


# The per-frame device buffers, declared once: name -> bytes for n pixels in r rows, a pyramid
# of t pixels in all (every level) and the plan's features. Plan allocates them (0: a 16-byte
# placeholder, or the buffer ALIASES names), check_memory sums them, and the reference's
# planes are declared the same way.
BUFFERS = {
    "image": lambda n, t, f, r: 16 * n,                       # RGBA in; scratch after preprocess
    # metric depth, read up to the lights; then (the source collapse) level k+1 up-sampled
    # along y to level k's rows, as colour planes (up_planes: the pair kernels, up_rows):
    # 12 h ceil(w / 2) <= 6 n + 6 h bytes at level 0, the largest
    "depth": lambda n, t, f, r: max(4 * n, (6 * n + 6 * r) * f.source),
    "direct": lambda n, t, f, r: 16 * n,                      # L exp(-st P) (+ L_em + L_amb)
    "medium": lambda n, t, f, r: 16 * n * f.split_medium,
    "chain": lambda n, t, f, r: 16 * t,                       # colour chain, every level
    "spread": lambda n, t, f, r: 4 * (n * f.spread0 if f.source else t),
    "prep": lambda n, t, f, r: 16 * t * f.source,
    "up_planes": lambda n, t, f, r: 0,                     # in `depth`, free by then
    "chain2": lambda n, t, f, r: 16 * t * f.sep,
    "prep2": lambda n, t, f, r: 16 * t * f.sep,
    "half2": lambda n, t, f, r: 16 * n * f.sep,
    "spread2": lambda n, t, f, r: 4 * t * f.sep,             # unused output of reduce_level
    # the result, written over `direct` (every stage that writes it reads direct at its own
    # pixel only, first) unless the direct AOV must keep it
    "out": lambda n, t, f, r: 16 * n * ("direct" in f.aovs),
    "a_dir": lambda n, t, f, r: 16 * n * f.lights,            # airlight reaching the camera directly
    "a_sc": lambda n, t, f, r: 16 * n * f.lights,             # ... and scattered again on the way
    "trans": lambda n, t, f, r: 16 * n * ("transmittance" in f.aovs),
    "level_aov": lambda n, t, f, r: 4 * n * bool(f.aovs),
    "scat_aov": lambda n, t, f, r: 16 * n * bool(f.aovs),
    "cosines": lambda n, t, f, r: 4 * n * f.lambert,
    "epi_flags": lambda n, t, f, r: n * f.epipolar,           # pixels the epipolar unwarp leaves to the march
}
# Buffers declared with 0 bytes that are another one: up_planes is made after the last read
# of the depth; out is written over direct (see above)
ALIASES = {"up_planes": "depth", "out": "direct"}


REFERENCE_BUFFERS = {"src": lambda n: 16 * n, "tmp": lambda n: 16 * n, "acc": lambda n: 16 * n}


def pair_region(sizes: list, nt: int, local: tuple) -> tuple | None:
    """The pixels of level sizes[0] the two-pixel kernels take (kernels/pairs.h), (x0, x1, y0, y1),
    on whole work-groups of pairs: where the taps of the level above, sizes[1] (nt + 1 columns
    about x / 2, nt rows), and the half image's x - 1 .. x + 2
    need no clamp and the apsf conservation factors are 1 (up2_cons: 2 texels from the upper
    level's edges). None when the levels are too few or the image too small for one work-group."""
    if len(sizes) < 2:
        return None
    (w, h), (w1, h1) = sizes[0], sizes[1]
    xs = [i2 for i2 in range(w // 2) if i2 - nt // 2 >= 2 and i2 + nt // 2 + 1 <= w1 - 2 and 2 * i2 + 2 <= w - 1]
    ys = [j for j in range(h) if (j >> 1) - nt // 2 + (j & 1) >= 2 and (j >> 1) + nt // 2 + (j & 1) <= h1 - 2]
    if not xs or not ys:
        return None
    nx, ny = (xs[-1] + 1 - xs[0]) // local[0] * local[0], (ys[-1] + 1 - ys[0]) // local[1] * local[1]
    if nx == 0 or ny == 0:
        return None
    return 2 * xs[0], 2 * (xs[0] + nx), ys[0], ys[0] + ny


def reduce_region(sw: int, sh: int, dw: int, dh: int, taps: int, margin: int, local: tuple) -> tuple | None:
    """The destination pixels (x0, x1, y0, y1) of a reduce from a sw x sh level to dw x dh that
    reduce_source_inner takes, on whole work-groups: every tap inside the source level and at
    least `margin` pixels from its edges (apsf: where the conservation factors are 1)."""
    out = []
    for s, d, l in ((sw, dw, local[0]), (sh, dh, local[1])):
        lo = -(-(margin + taps // 2 - 1) // 2)                  # 2 x - taps / 2 + 1 >= margin
        hi = min(d - 1, (s - margin - taps + taps // 2 - 1) // 2)   # 2 x - taps / 2 + 1 + taps <= s - margin
        n = (hi + 1 - lo) // l * l
        if n <= 0:
            return None
        out += [lo, lo + n]
    return tuple(out)


def plan_features(cfg: Config, aovs=()) -> Features:
    r = cfg.render
    source = r.method == "pyramid" and r.fetch == "source"
    return Features(source, r.method == "pyramid" and r.separation.enabled,
                    bool({"optical_depth", "emission", "direct"} & set(aovs)), bool(cfg.lights),
                    uses_apsf(cfg) and r.emission_profile == "lambertian", tuple(aovs), r.method == "reference",
                    bool(cfg.lights) and r.lights.shadows == "screen" and r.lights.method == "epipolar",
                    not uses_apsf(cfg) or bool(aovs) or cfg.medium.heterogeneous)


def buffer_bytes(n: int, t: int, f: Features, rows: int) -> dict:
    return {name: int(size(n, t, f, rows)) for name, size in BUFFERS.items()}


def planned_bytes(n: int, t: int, f: Features, cfg: Config, rows: int) -> int:
    """Everything one frame may allocate: the declared buffers, the reference's planes, the
    airlight of a second light (two planes), and the extension plan of `border: extend`
    (the padded frame at 1/2^EXT_LEVEL: about (1 + 2 margin)^2 / 64 of a plan)."""
    total = sum(buffer_bytes(n, t, f, rows).values())
    if f.reference:
        total += sum(size(n) for size in REFERENCE_BUFFERS.values())
    if f.lights and len(cfg.lights) > 1:
        total += 32 * n
    if cfg.render.border == "extend" and f.source and uses_apsf(cfg):
        total += int(total * (1 + 2 * cfg.render.border_margin) ** 2 / 4 ** EXT_LEVEL)
    return total


def check_memory(rt: Runtime, width: int, height: int, sizes: dict, need: int) -> None:
    """Refuse before allocating: the device's memory and its largest single allocation."""
    dev = rt.device
    if need > dev.global_mem_size:
        raise ProcessingError(f"image of {width}x{height} needs {need / 2**20:.0f} MiB, "
                              f"device {rt.info.name} has {dev.global_mem_size / 2**20:.0f} MiB")
    name, big = max(sizes.items(), key=lambda kv: kv[1])
    if big > dev.max_mem_alloc_size:
        raise ProcessingError(f"image of {width}x{height}: its {name} buffer needs {big / 2**20:.0f} MiB in one "
                              f"piece, device {rt.info.name} allocates at most {dev.max_mem_alloc_size / 2**20:.0f} MiB")


class Plan:
    """Device buffers for one image size and one set of compile-time options."""

    def __init__(self, rt: Runtime, width: int, height: int, cfg: Config, aovs=()):
        self.rt, self.w, self.h, self.cfg = rt, width, height, cfg
        cl = rt.cl
        self.aovs = tuple(aovs)
        self.features = f = plan_features(cfg, aovs)
        # L_em + L_amb ride in `direct` unless an AOV needs them (or P) on their own
        self.split_medium, self.source, self.sep, self.lambert = f.split_medium, f.source, f.sep, f.lambert
        self.sizes = level_sizes(width, height, cfg.render.levels)
        offs = np.cumsum([0] + [w * h for w, h in self.sizes])
        self.lv = np.array([[o, w, h, 0] for o, (w, h) in zip(offs[:-1], self.sizes)], np.int32)
        total = int(offs[-1])
        n = width * height
        mf = cl.mem_flags
        self.apsf = uses_apsf(cfg)
        sizes = buffer_bytes(n, total, f, height)
        check_memory(rt, width, height, sizes, planned_bytes(n, total, f, cfg, height))
        try:
            for name, nbytes in sizes.items():      # a feature that is off keeps a 16-byte placeholder
                setattr(self, name, cl.Buffer(rt.ctx, mf.READ_WRITE, max(int(nbytes), 16)))
            for name, other in ALIASES.items():
                if not sizes[name]:
                    setattr(self, name, getattr(self, other))
            self.lv_buf = cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=self.lv)
            B = lambda nbytes: cl.Buffer(rt.ctx, mf.READ_WRITE, max(int(nbytes), 16))  # noqa: E731
            self.lut = B(4 * self.lut_floats()) if self.apsf else B(16)
            self._lut_key = None
            self.edge_off = [0] * len(self.sizes)
            self.edge = B(16)
            self.cons_off = [0] * (len(self.sizes) + 1)
            self.cons = B(16)
            if self.apsf and self.source:
                from .apsf import conservation_tables

                tab, offs = conservation_tables(self.sizes, FILTERS[cfg.render.kernel],
                                                cfg.render.interpolation != "linear-bilinear",
                                                open_border(cfg))
                self.cons_off = offs + [0]
                self.cons = cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tab)
            if self.apsf and open_border(cfg):
                from .apsf import edge_tables

                tab, self.edge_off = edge_tables(self.sizes, cfg.render.resolved()[0], 2.0 * self.half_step())
                self.edge = cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tab)
        except cl.Error as exc:
            raise ProcessingError(f"cannot allocate device buffers for {width}x{height}: {exc}") from exc
        d = defines(cfg)
        pre = dict(d, PRE_SOURCE=int(self.source), PRE_SEP=int(self.sep), PRE_SPLIT_MEDIUM=int(self.split_medium),
                   PRE_TRANSMITTANCE=int("transmittance" in self.aovs),
                   PRE_SPREAD=int(not (self.apsf and self.source) or bool(self.aovs)),
                   CAM_Z=int(cfg.camera.depth != "distance"))   # planar depth: view_cosines_inner without roots
        self.k_pre_prog = rt.program("preprocess", **pre)
        self.k_pre_whole = rt.program("preprocess", WHOLE_GROUPS=1, **pre)
        self.k_density = rt.program("density", **d)
        pyr = rt.program("pyramid", **d)
        self.k_reduce, self.k_reduce_src = pyr.reduce_level, pyr.reduce_level_source
        self.k_reduce_inner = pyr.reduce_source_inner
        self.k_prep0 = pyr.prep_level0
        whole = rt.program("pyramid", WHOLE_GROUPS=1, **d)     # launch2d / launch1d: no bounds check
        self.k_collapse = (whole.collapse_level, pyr.collapse_level)
        self.k_collapse_pairs = whole.collapse_pairs
        self.k_split = (whole.split_level, pyr.split_level)
        self.k_up_rows = (whole.up_rows, pyr.up_rows)
        self.k_comp = rt.program("composite", **d).composite
        # composite_source: what it writes fixed at build time, on whole work-groups (as preprocess);
        # [True]: the separated chain's pass, which adds its light
        # and composite_source_pairs, two pixels a work-item, on the part away from the edges
        self.k_comp_src, self.k_comp_pairs = {}, {}
        for second in (False, True) if self.sep else (False,):
            comp = dict(d, COMP_AOV=int(bool(self.aovs)), COMP_SPLIT_MEDIUM=int(self.split_medium),
                        COMP_ACCUMULATE=int(second))
            whole = rt.program("composite", WHOLE_GROUPS=1, **comp)
            self.k_comp_src[second] = (whole.composite_source, rt.program("composite", **comp).composite_source)
            self.k_comp_pairs[second] = whole.composite_source_pairs
        # per level k: the rectangle its two-pixel kernels take (level 0: composite_source_pairs)
        self._pairs = [pair_region(self.sizes[k:], 2 if d["INTERP"] == 0 else 4, rt.local2d)
                       for k in range(len(self.sizes))]
        self.k_comp_sep = rt.program("composite", **d).composite_separated
        self.k_border_src = pyr.border_sources if self.apsf else None
        self.k_border_inject = pyr.border_inject if self.apsf else None
        if cfg.lights:
            from .airlight_table import DEFINES

            self.lanes = rt.lanes      # pixels of a row per work-item of the table kernels (LANES, kernels/lanes.h)
            self.k_lights = rt.program("lights", **d, **DEFINES, LANES=self.lanes)
        else:
            self.k_lights = None
        self._al_tables = None     # (key, device buffer) of airlight_table.tables
        self._noise = None         # (the noise_t array's bytes, its device copy, count): noise_args
        self._light_tmp = None     # (t_dir, t_sc): the airlight of the second and later lights
        self._tfm = None           # (floats, coefficients, spans): a light's transmittance function map
        self._noise_samples = None  # (count, A_dir, A_sc) at the samples of render.noise_stride
        self._p_samples = None     # (count, buffer): the noise's optical depth at the same samples
        self._epi = None           # (samples, slices, buffers ...) of render.lights.method: epipolar
        self._ext = None           # the extension plan of render.border: extend (extend)

    # -- stages --------------------------------------------------------------------
    def upload(self, rgba: np.ndarray, depth: np.ndarray, t: Timings) -> None:
        cl = self.rt.cl
        t.add_copy("upload", cl.enqueue_copy(self.rt.queue, self.image, np.ascontiguousarray(rgba, np.float32)))
        t.add_copy("upload", cl.enqueue_copy(self.rt.queue, self.depth, np.ascontiguousarray(depth, np.float32)))

    def upload_rgb(self, rgb: np.ndarray, alpha, depth: np.ndarray, t: Timings) -> None:
        """The frame's RGBA assembled straight in the image buffer, mapped (on a CPU device
        its own memory: no copy after the assembly, which a host array and upload() needed;
        upload 8.3-9.1 -> 1.7 ms at 2 MPx), and the depth copied."""
        cl, q = self.rt.cl, self.rt.queue
        rgba, ev = cl.enqueue_map_buffer(q, self.image, cl.map_flags.WRITE_INVALIDATE_REGION, 0,
                                         (self.h, self.w, 4), np.float32)
        t.add("upload", ev)
        ev.wait()
        pixels.pack_rgba(rgba, rgb, alpha)
        try:       # here, where the colour is float32 and in one block (a half EXR's is not before)
            pixels.check_radiance(rgba, "colour")
        finally:
            t.add("upload", rgba.base.release(q))
        del rgba
        t.add_copy("upload", cl.enqueue_copy(q, self.depth, np.ascontiguousarray(depth, np.float32)))

    def optical_depth(self, t: Timings, depth=None, out=None) -> None:
        """P of the non-homogeneous primitives, summed into the spread buffer (level 0),
        which preprocess reads before it writes the spread there."""
        cam = camera_struct(self.cfg, self.w, self.h)
        launches = primitive_launches(self.cfg)
        noise = self.noise_args()
        if noise is not None:          # the samples of render.noise_stride first, then every pixel
            st, cw, ch = self.noise_grid()
            samples = self._noise_p_samples(cw * ch)
            t.add("preprocess", self.k_density.p_noise_samples(
                self.rt.queue, *self.rt.nd(cw, ch), self.depth if depth is None else depth, samples, np.int32(self.w),
                np.int32(self.h), cam, *noise, np.int32(st), np.int32(cw), np.int32(ch)))
            launches.append(("p_noise", (*noise, samples, np.int32(st), np.int32(cw), np.int32(ch))))
        for k, (name, args) in enumerate(launches):
            t.add("preprocess", getattr(self.k_density, name)(
                self.rt.queue, *self.rt.nd(self.w, self.h), self.depth if depth is None else depth,
                self.spread if out is None else out, np.int32(self.w), np.int32(self.h), cam, *args,
                np.int32(k > 0)))

    def noise_args(self):
        """(device noise_t array, count) of the noise primitives of the current cfg (a plan
        outlives its cfg: get_plan), or None without noise."""
        from .noise import primitives, structs

        if not primitives(self.cfg):
            return None
        ns = structs(self.cfg)
        if self._noise is None or self._noise[0] != ns.tobytes():
            mf = self.rt.cl.mem_flags
            self._noise = (ns.tobytes(), self.rt.cl.Buffer(self.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=ns),
                           np.int32(len(primitives(self.cfg))))
        return self._noise[1:]

    def noise_grid(self) -> tuple[int, int, int]:
        """(stride, samples per row, rows of samples) of the noise's marched rays."""
        from .noise import stride

        st = stride(self.cfg, self.w, self.h)
        return st, (self.w - 1 + st - 1) // st + 1, (self.h - 1 + st - 1) // st + 1

    def _noise_p_samples(self, n: int):
        if self._p_samples is None or self._p_samples[0] < n:
            self._p_samples = (n, self.rt.cl.Buffer(self.rt.ctx, self.rt.cl.mem_flags.READ_WRITE, 4 * max(n, 1)))
        return self._p_samples[1]

    def coverage(self, t: Timings, empty_depth: float) -> None:
        """Output alpha of an input with alpha: the medium in front of each pixel's uncovered
        part (kernel `coverage`). Two planes more, only for heterogeneous media."""
        cl, q, n = self.rt.cl, self.rt.queue, self.w * self.h
        ms = medium_struct(self.cfg, self.w, self.h)
        p_empty = self.spread        # not read unless has_p
        if int(ms["has_p"]):
            mf = cl.mem_flags
            d_empty = cl.Buffer(self.rt.ctx, mf.READ_WRITE, 4 * n)
            p_empty = cl.Buffer(self.rt.ctx, mf.READ_WRITE, 4 * n)
            cl.enqueue_fill_buffer(q, d_empty, np.float32(empty_depth), 0, 4 * n)
            self.optical_depth(t, d_empty, p_empty)
        t.add("preprocess", self.k_pre_prog.coverage(
            q, *self.rt.nd(self.w, self.h), self.direct, p_empty, ms["has_p"], np.int32(self.w),
            np.int32(self.h), ms, np.float32(min(empty_depth, 3e38)), self.lut))

    def threshold(self, k: int) -> float:
        """Masking threshold of level k (Elek eq. 7, scaled): threshold * c * 2^(k-1)."""
        c, _, thr = self.cfg.render.resolved()
        return thr * c * 2.0 ** (k - 1)

    def lut_floats(self) -> int:
        from .apsf import load_table, lut_offsets

        return lut_offsets(len(self.sizes) - 1, len(load_table()["sigma_u"]))["end"]

    def upload_lut(self, t: Timings, table: dict | None = None) -> np.ndarray | None:
        """The apsf lookup table of this medium, focal length and pyramid (apsf.build_lut);
        rebuilt only when one of them changes."""
        if not self.apsf:
            return None
        from .apsf import build_lut

        m, r = self.cfg.medium, self.cfg.render
        frame = (self.w, self.h) if open_border(self.cfg) else None
        focal, c = self.cfg.camera.focal(self.w), r.resolved()[0]
        key = (m.absorption, m.scattering, m.asymmetry, focal, r.spread_scale, c, id(table), frame)
        if key != self._lut_key:
            self.lut_host = build_lut(m.absorption, m.scattering, m.asymmetry, focal, r.spread_scale,
                                      len(self.sizes) - 1, c, 2.0 * self.half_step(), table, frame)
            t.add("upload", self.rt.cl.enqueue_copy(self.rt.queue, self.lut, self.lut_host))
            self._lut_key = key
        return self.lut_host

    def preprocess(self, t: Timings) -> None:
        eps = self.cfg.render.resolved()[1]
        self.upload_lut(t)
        self.optical_depth(t)
        whole, checked = self.k_pre_whole, self.k_pre_prog
        if self.lambert:
            lx, ly = self.rt.local2d         # the interior: pixels whose four neighbours are in the image
            nx, ny = (self.w - 2) // lx * lx, (self.h - 2) // ly * ly
            self._launch_inner(t, "preprocess", (1, 1 + nx, 1, 1 + ny) if nx > 0 and ny > 0 else None,
                               whole.view_cosines_inner, (whole.view_cosines, checked.view_cosines), self.w, self.h,
                               (self.depth, self.cosines, np.int32(self.w), np.int32(self.h),
                                camera_struct(self.cfg, self.w, self.h)))
        t.add("preprocess", self.rt.launch2d(
            (whole.preprocess, checked.preprocess), self.w, self.h, self.image, self.depth, self.direct,
            self.chain, self.spread, self.medium, self.trans, np.int32(self.w), np.int32(self.h),
            medium_struct(self.cfg, self.w, self.h), self.prep, np.float32(self.threshold(1)), np.float32(eps),
            self.chain2, self.prep2, self.sep_params(), self.lut, self.cosines))

    def lights(self, t: Timings) -> None:
        """Every light's airlight (kernels/lights.cl): a_dir kept for after the pyramid, a_sc
        into level 0 of the colour chain (merged with the image's scattered light)."""
        from .lights import gauss_legendre, light_struct, medium_struct

        cl, q, n = self.rt.cl, self.rt.queue, self.w * self.h
        lm, prims = medium_struct(self.cfg)
        mf = cl.mem_flags
        quad = []           # (primitives, Gauss-Legendre nodes) on the device, made when a kernel needs them

        def device_quad():
            if not quad:
                quad.extend((cl.Buffer(self.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=prims),
                             cl.Buffer(self.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                                       hostbuf=gauss_legendre(int(lm["nodes"])))))
            return quad
        cam = camera_struct(self.cfg, self.w, self.h)
        pk = self.cfg.render.lights.airlight == "pk"
        homogeneous = int(lm["nprims"]) == 0
        lights = [x for x in self.cfg.lights if x.type != "auto"]
        if len(lights) > 1 and self._light_tmp is None:     # the second light on: summed after
            self._light_tmp = (cl.Buffer(self.rt.ctx, mf.READ_WRITE, 16 * n), cl.Buffer(self.rt.ctx, mf.READ_WRITE, 16 * n))
        size = self.rt.nd(self.w, self.h)
        for k, light in enumerate(lights):
            dst = (self.a_dir, self.a_sc) if k == 0 else self._light_tmp
            ls = light_struct(self.cfg, light)
            if pk and light.type == "point":        # Pradhan & Kumar's closed form
                ev = self.k_lights.airlight_pk(q, *size, self.depth, *dst, np.int32(self.w), np.int32(self.h), cam, lm, ls)
            elif self.noise_args() is not None:     # the light leg from a map, the camera leg marched
                ev = self._airlight_noise(t, dst, cam, lm, device_quad()[0], ls, light)
            elif homogeneous and light.type == "point":    # tables instead of quadrature
                tab, grey, per_channel, common = self._table_args(ls)
                tsize = self.rt.nd(-(-self.w // self.lanes), self.h)
                if grey:        # ln(ss I) per channel as its largest and exp(each - largest)
                    lk = [float(x) for x in common[2:5]]
                    lkm = max(lk)
                    scale = [np.float32(math.exp(x - lkm)) for x in lk]
                    ev = self.k_lights.airlight_table_grey(q, *tsize, self.depth, *dst, np.int32(self.w),
                                                           np.int32(self.h), cam, tab, *common[:2], *per_channel[0],
                                                           np.float32(lkm), *scale, *common[5:])
                else:
                    ev = self.k_lights.airlight_table(q, *tsize, self.depth, *dst, np.int32(self.w), np.int32(self.h),
                                                      cam, tab, *common[:2], *[x for c in per_channel for x in c],
                                                      *common[2:])
            elif homogeneous and light.type == "directional":     # closed form
                ev = self.k_lights.airlight_sun(q, *size, self.depth, *dst, np.int32(self.w), np.int32(self.h), cam, lm, ls)
            else:
                ev = self.k_lights.airlight(q, *size, self.depth, *dst, np.int32(self.w), np.int32(self.h), cam, lm,
                                            *device_quad(), ls)
            t.add("lights", ev)
            if self.cfg.render.lights.shadows == "screen":      # built once per process (runtime.program)
                k_shadows = self.rt.program("shadows", **defines(self.cfg), SH_BINS=SH_BINS, LANES=self.lanes)
                sh = self.cfg.render.lights
                sh_args = (cam, lm, device_quad()[0], ls, np.float32(sh.thickness), np.int32(sh.offscreen == "shadowed"))
                if sh.method == "march":
                    t.add("shadows", k_shadows.shadow_march(q, *size, self.depth, *dst, np.int32(self.w),
                                                            np.int32(self.h), *sh_args))
                else:
                    self._epipolar(t, k_shadows, dst, sh_args, light)
            if k > 0:
                t.add("lights", self.k_lights.add_light(q, *self.rt.nd(n), self.a_dir, dst[0], self.a_sc, dst[1],
                                                        np.int32(n)))
        t.add("lights", self.k_lights.airlight_to_chain(
            q, *self.rt.nd(n), self.a_sc, self.chain, self.prep, self.lut, np.int32(n)))

    def _airlight_noise(self, t: Timings, dst, cam, lm, prims, ls, light):
        """kernels/tfm.cl: the light's transmittance function map, then the airlight; returns
        the airlight's event."""
        from .lights import placed
        from .noise import tfm_layout

        cl, q = self.rt.cl, self.rt.queue
        r = self.cfg.render.lights
        pos, axis = placed(self.cfg, light)
        tm = tfm_layout(self.cfg, pos, axis, light.type)
        texels = r.tfm_size ** 2
        floats = texels * (r.coefficients + 2)      # the coefficients and q(x)'s two (tfm.cl)
        if self._tfm is None or self._tfm[0] != floats:
            mf = cl.mem_flags
            self._tfm = (floats, cl.Buffer(self.rt.ctx, mf.READ_WRITE, 4 * floats),
                         cl.Buffer(self.rt.ctx, mf.READ_WRITE, 16 * texels))
        _, coef, span = self._tfm
        k = self.rt.program("tfm", **defines(self.cfg))
        noise = self.noise_args()
        t.add("tfm", k.tfm_build(q, *self.rt.nd(r.tfm_size, r.tfm_size), coef, span, tm, *noise))
        args = (cam, lm, prims, ls, *noise, tm, coef, span, np.int32(r.nodes))
        st, cw, ch = self.noise_grid()
        if st == 1:
            return k.airlight_noise(q, *self.rt.nd(cw, ch), self.depth, *dst, np.int32(self.w), np.int32(self.h), *args,
                                    np.int32(st), np.int32(cw), np.int32(ch))
        if self._noise_samples is None or self._noise_samples[0] != cw * ch:
            mf = cl.mem_flags
            self._noise_samples = (cw * ch, *(cl.Buffer(self.rt.ctx, mf.READ_WRITE, 16 * cw * ch) for _ in range(2)))
        s_dir, s_sc = self._noise_samples[1:]
        t.add("lights", k.airlight_noise(q, *self.rt.nd(cw, ch), self.depth, s_dir, s_sc, np.int32(self.w),
                                         np.int32(self.h), *args, np.int32(st), np.int32(cw), np.int32(ch)))
        lx, ly = light_image(self.cfg, light, self.w, self.h)
        return k.airlight_fill(q, *self.rt.nd(self.w, self.h), self.depth, *dst, s_dir, s_sc, np.int32(self.w),
                               np.int32(self.h), *args, np.int32(st), np.int32(cw), np.int32(ch), np.float32(lx),
                               np.float32(ly))

    def _epipolar(self, t: Timings, k, dst, sh_args, light) -> None:
        """render.lights.method: epipolar (kernels/shadows.cl): each slice through the light's
        image walked once into a 1D shadow map with min/max trees (epi_maps), the shares at
        samples on the slices read from them (epi_samples), then every pixel from its four
        samples (epi_unwarp), or marched (epi_march: the pixels epi_unwarp flagged).
        self.epi_marched[0]: how many pixels were marched themselves (benchmarks/shadows.py)."""
        from .lights import epipolar_layout

        cl, q = self.rt.cl, self.rt.queue
        sh = self.cfg.render.lights
        ex, ey, a0, da, r0, rb, h1, h2, m1, nm, ns, full, front = epipolar_layout(self.cfg, light, self.w, self.h,
                                                                                  sh.slices, sh.step)
        # the samples' shares, the slices' maps (min and max trees) and ranges, the marched-pixel
        # counter: kept while big enough (fresh buffers cost their pages' zeroing every frame)
        if self._epi is None or self._epi[0] < nm * ns or self._epi[1] < ns:
            mf = cl.mem_flags
            B = lambda nbytes: cl.Buffer(self.rt.ctx, mf.READ_WRITE, nbytes)  # noqa: E731
            self._epi = (nm * ns, ns, B(16 * nm * ns), B(16 * nm * ns), B(16 * SH_BINS * ns), B(16 * ns), B(4))
        sh_a, sh_t, maps, ranges, counter = self._epi[2:]
        self.epi_marched = np.zeros(1, np.int32)
        cl.enqueue_fill_buffer(q, counter, np.int32(0), 0, 4)
        lay = (*(np.float32(x) for x in (ex, ey, a0, da, r0, rb, h1, h2)), np.int32(m1), np.int32(nm), np.int32(ns))
        cam_, _, _, ls, thick, _ = sh_args
        inside = front and full         # the lines reach the light's image inside the frame
        t.add("shadows", k.epi_maps(q, *self.rt.nd(ns), self.depth, maps, ranges, np.int32(self.w), np.int32(self.h),
                                    cam_, ls, thick, *lay[:4], np.int32(ns), np.int32(not inside)))
        t.add("shadows", k.epi_samples(q, *self.rt.nd(nm, ns), self.depth, sh_a, sh_t, np.int32(self.w),
                                       np.int32(self.h), *sh_args, *lay, maps, ranges))
        t.add("shadows", k.epi_unwarp(q, *self.rt.nd(-(-self.w // self.lanes), self.h), self.depth, *dst, sh_a, sh_t, np.int32(self.w),
                                      np.int32(self.h), cam_, *lay, np.int32(full), self.epi_flags))
        t.add("shadows", k.epi_march(q, *self.rt.nd(self.w, self.h), self.depth, *dst, np.int32(self.w),
                                     np.int32(self.h), *sh_args, self.epi_flags, counter))
        cl.enqueue_copy(q, self.epi_marched, counter, is_blocking=False)     # read with the download

    def _airlight_tables(self):
        """(the medium's airlight tables on the device (fogcli/airlight_table.py), kept while
        g and the channels' sa / st stay the same: r = 1, then one table per distinct r;
        each channel's r = sa / st; each channel's table)."""
        from .airlight_table import tables

        m = self.cfg.medium
        st = [a + s for a, s in zip(m.absorption, m.scattering)]
        r = [round(a / t, 6) if t > 0 else 1.0 for a, t in zip(m.absorption, st)]
        distinct = tuple(dict.fromkeys(x for x in r if x < 1.0))
        key = (float(m.asymmetry), distinct)
        if self._al_tables is None or self._al_tables[0] != key:
            host = tables(*key)
            buf = self.rt.cl.Buffer(self.rt.ctx, self.rt.cl.mem_flags.READ_ONLY | self.rt.cl.mem_flags.COPY_HOST_PTR,
                                    hostbuf=host)
            self._al_tables = (key, buf)
        kind = [1 + distinct.index(x) if x < 1.0 else 0 for x in r]
        return self._al_tables[1], r, kind

    def _table_args(self, ls):
        """The airlight tables on the device and the uniform values of airlight_table(_grey)
        as scalars (a float4 argument's lanes worked on the same way get paired by LLVM and
        stop PoCL's vectoriser): (tables, grey, per channel (st, ln st, sa, r, xm, em, table
        offset), (g, hf, ln(ss I) x 3, gain x 3, camera-to-light x 3, radius^2))."""
        import math

        from .airlight_table import NB, NX

        tab, rs, kind = self._airlight_tables()
        m = self.cfg.medium
        hf = m.homogeneous
        f = np.float32
        per = []
        for c in range(3):
            r = rs[c]
            xm, em = (-math.atanh(r), math.sqrt(1.0 - r * r)) if r < 1.0 else (-1e30, 0.0)
            st = hf * (m.absorption[c] + m.scattering[c])
            per.append((f(st), f(math.log(st)) if st > 0 else f(-1e30), f(hf * m.absorption[c]), f(r), f(xm), f(em),
                        np.int32(kind[c] * 2 * NB * NX)))
        k = [hf * m.scattering[c] * float(ls["intensity"][c]) for c in range(3)]
        v = np.array(ls["pos"][:3], np.float64) - np.array(self.cfg.camera.position, np.float64)
        common = ([f(m.asymmetry), f(hf)] + [f(math.log(x)) if x > 0 else f(-1e30) for x in k]
                  + [f(x) for x in ls["gain"][:3]] + [f(x) for x in v] + [f(float(ls["radius"]) ** 2)])
        grey = len(set(m.absorption)) == 1 and len(set(m.scattering)) == 1
        return tab, grey, per, common

    def clear_sources(self, t: Timings, mask: np.ndarray) -> None:
        cl, n = self.rt.cl, self.w * self.h
        buf = cl.Buffer(self.rt.ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                        hostbuf=np.ascontiguousarray(mask, np.uint8))
        t.add("lights", self.k_lights.clear_sources(self.rt.queue, *self.rt.nd(n), self.chain, self.prep, buf,
                                                     np.int32(n)))

    def add_airlight(self, t: Timings) -> None:
        n = self.w * self.h
        t.add("lights", self.k_lights.add_airlight(self.rt.queue, *self.rt.nd(n), self.out, self.a_dir, np.int32(n)))

    def sep_params(self) -> np.ndarray:
        s = self.cfg.render.separation
        return np.array([s.luminance, s.luminance_width, s.depth, s.depth_width], np.float32)

    def pyramid(self, t: Timings, masked: bool, second: bool = False) -> None:
        eps = self.cfg.render.resolved()[1]
        q = self.rt.queue
        chain, _, prep = self.source_bufs(second)
        if self.source:
            taps = len(FILTERS[self.cfg.render.kernel])
            for k in range(1, len(self.sizes)):
                (so, sw, sh, _), (do, dw, dh, _) = self.lv[k - 1], self.lv[k]
                args = (chain, prep, np.int32(so), np.int32(sw), np.int32(sh), np.int32(do), np.int32(dw),
                        np.int32(dh), np.float32(self.threshold(k + 1)), np.float32(eps), self.lut, np.int32(k),
                        self.edge, np.int32(self.edge_off[k]), self.cons, np.int32(self.cons_off[k]))
                # on an 8-wide CPU without AVX-512 LLVM leaves the interior kernel scalar (its
                # table reads would be gathers, which it does not emit there), and the
                # per-pixel kernel is the faster scalar code (benchmarks/avx2/run.sh)
                region = reduce_region(int(sw), int(sh), int(dw), int(dh), taps, taps // 2 if self.apsf else 0,
                                       self.rt.local2d) if self.rt.lanes == 1 else None
                self._launch_inner(t, "pyramid", region, self.k_reduce_inner, (self.k_reduce_src,) * 2,
                                   int(dw), int(dh), args, corner_args=True)
            return
        spread = self.spread2 if second else self.spread
        for k in range(1, len(self.sizes)):
            (so, sw, sh, _), (do, dw, dh, _) = self.lv[k - 1], self.lv[k]
            t.add("pyramid", self.k_reduce(
                q, *self.rt.nd(dw, dh), chain, spread,
                np.int32(so), np.int32(sw), np.int32(sh), np.int32(do), np.int32(dw), np.int32(dh),
                np.float32(self.threshold(k)), np.float32(eps), np.int32(masked)))

    def half_step(self) -> float:
        """a of the (a, 1 - 2a, a) half-octave blur: variance 2a = c^2 level-k pixels
        (at most 2/3: beyond, the middle weight would vanish)."""
        c = self.cfg.render.resolved()[0]
        return min(c * c / 2.0, 1.0 / 3.0)

    def split(self, t: Timings, k: int, chain, out) -> None:
        """Half-octave shares of level k of `chain` into `out` (level-0 sized scratch)."""
        o, w, h, _ = (int(v) for v in self.lv[k])
        t.add("composite", self.rt.launch2d(
            self.k_split, w, h, chain, np.int32(o), np.int32(h), out, np.float32(self.threshold(k + 1)),
            np.float32(self.cfg.render.resolved()[1]), self.lut, np.int32(k), np.int32(w), self.edge,
            np.int32(self.edge_off[k])))

    def source_bufs(self, second: bool) -> tuple:
        """(colour chain, half-octave scratch, prep chain) of the main or the separated
        source collapse; the main one's scratch is the input buffer, free after preprocess."""
        if second:
            return self.chain2, self.half2, self.prep2
        return self.chain, self.image, self.prep

    def collapse(self, t: Timings, second: bool = False, ext: bool = False) -> None:
        """Source collapse of levels K-1 .. 1, in place over the colour chain (level 0 is
        fused into composite_source). The input buffer, free after preprocess, is the
        scratch for the half-octave shares. ext: the extension plan's light (`extend`, run
        first) joins at its level."""
        a = self.half_step()
        chain, half, prep = self.source_bufs(second)
        top = len(self.sizes) - 1
        if ext and self._ext_level == top:
            self._inject(t)
        for k in range(top - 1, 0, -1):
            (o, w, h, _), (uo, uw, uh, _) = self.lv[k], self.lv[k + 1]
            self.split(t, k, chain, half)
            args = (chain, np.int32(o), np.int32(w), np.int32(h), half, np.int32(uo), np.int32(uw), np.int32(uh),
                    np.float32(a), prep, self.edge, np.int32(self.edge_off[k]), self.cons, np.int32(self.cons_off[k + 1]))
            self._launch_pairs(t, self._pairs[k], self.k_collapse_pairs, self.k_collapse, w, h, args, chain, k + 1)
            if ext and k == self._ext_level:
                self._inject(t)

    def _inject(self, t: Timings) -> None:
        o, w, h, _ = (int(v) for v in self.lv[self._ext_level])
        pw, ox, oy = self._ext_geom
        t.add("composite", self.k_border_inject(self.rt.queue, *self.rt.nd(w, h), self.chain, np.int32(o),
                                                np.int32(w), np.int32(h), self._ext.out, pw, ox, oy))

    def composite_source(self, t: Timings, second: bool = False) -> None:
        top = len(self.sizes) - 1
        chain, half, prep = self.source_bufs(second)
        if top > 0:
            self.split(t, 0, chain, half)
        args = (self.direct, self.medium, chain, half, self.lv_buf, np.int32(top),
                np.float32(self.cfg.render.resolved()[0]), np.float32(self.half_step()), self.out, self.level_aov,
                self.scat_aov, prep, self.spread, self.edge, self.cons, np.int32(self.cons_off[1]))
        self._launch_pairs(t, self._pairs[0], self.k_comp_pairs[second], self.k_comp_src[second], self.w, self.h,
                           args, chain, 1)

    def _launch_pairs(self, t: Timings, region, pairs, kernels, w: int, h: int, args: tuple, chain, up: int) -> None:
        """A w x h level through its two-pixel kernel (`pairs`, pairs.h) on `region`, the
        per-pixel kernel around it (_launch_inner). The pair kernels read level `up` of
        `chain` up-sampled along y to this level's rows, as colour planes (up_rows, made
        here), and take the region's corner as arguments (pairs.h, Addressing)."""
        if region is not None:
            o, uw, uh, _ = (int(v) for v in self.lv[up])
            t.add("composite", self.rt.launch2d(self.k_up_rows, uw, h, chain, np.int32(o), np.int32(uw), np.int32(uh),
                                                np.int32(h), self.up_planes))
        self._launch_inner(t, "composite", region, pairs, kernels, w, h, args, per=2, corner_args=True,
                           extra=(self.up_planes,))

    def _launch_inner(self, t: Timings, stage: str, region, inner, kernels, w: int, h: int, args: tuple,
                      per: int = 1, corner_args: bool = False, extra: tuple = ()) -> None:
        """A w x h kernel through `inner` on `region` [x0, x1) x [y0, y1) (whole work-groups,
        `per` pixels of a row per work-item; its corner as a global offset, or with
        corner_args as two more arguments, x0 / per and y0) and the checked per-pixel kernel
        (kernels[1]) on the four strips around it; without a region, the per-pixel kernels
        alone (launch2d)."""
        if region is None:
            t.add(stage, self.rt.launch2d(kernels, w, h, *args))
            return
        (x0, x1, y0, y1), q = region, self.rt.queue
        size = ((x1 - x0) // per, y1 - y0)
        if corner_args:
            t.add(stage, inner(q, size, self.rt.local2d, *args, *extra, np.int32(x0 // per), np.int32(y0)))
        else:
            t.add(stage, inner(q, size, self.rt.local2d, *args, global_offset=(x0 // per, y0)))
        for gx, gy, ox, oy in ((w, y0, 0, 0), (w, h - y1, 0, y1), (x0, y1 - y0, 0, y0), (w - x1, y1 - y0, x1, y0)):
            if gx > 0 and gy > 0:     # exact sizes: no pixel twice (the separated chain's pass adds)
                t.add(stage, kernels[1](q, (gx, gy), None, *args, global_offset=(ox, oy)))

    def extend(self, t: Timings) -> bool:
        """render.border: extend. The frame's edge continued `border_margin` past each side:
        those sources' light is spread by a second apsf chain on the padded frame at the
        resolution of level EXT_LEVEL (their light reaches the frame only through blurs of
        several pixels and more; the open main chain has the frame's own); collapse(ext=True)
        adds it to that level. About 1/16 of the main chain's pixels at margin 0.5. Returns
        whether there is one."""
        mx, my = border_margin(self.cfg, self.w, self.h)
        self._ext_level = min(EXT_LEVEL, len(self.sizes) - 1)
        if not (mx or my) or self._ext_level == 0:
            return False
        s = 2 ** self._ext_level
        ox, oy = -(-mx // s) * s, -(-my // s) * s
        pw, ph = -(-(self.w + 2 * ox) // s), -(-(self.h + 2 * oy) // s)
        cam = self.cfg.camera.model_copy(update=dict(focal_px=self.cfg.camera.focal(self.w) / s, focal_px_y=None,
                                                     calibrated_size=None))
        render = self.cfg.render.model_copy(update=dict(border="open", levels="auto",
                                                        separation=self.cfg.render.separation.model_copy(
                                                            update=dict(enabled=False))))
        cfg = self.cfg.model_copy(update=dict(camera=cam, render=render, lights=[]))
        if self._ext is None:
            self._ext = Plan(self.rt, pw, ph, cfg)
        ext = self._ext
        # no direct light of its own: zeros, every frame (its result is written over them)
        for buf in (ext.direct, ext.medium):
            t.add("composite", self.rt.cl.enqueue_fill_buffer(self.rt.queue, buf, np.float32(0), 0, buf.size))
        ext.cfg = cfg
        ext.upload_lut(t)
        q, i32 = self.rt.queue, np.int32
        t.add("pyramid", ext.k_border_src(q, *self.rt.nd(pw, ph), self.chain, i32(self.w), i32(self.h), ext.chain,
                                          ext.prep, i32(pw), i32(ph), i32(ox), i32(oy), i32(mx), i32(my), i32(s),
                                          ext.lut))
        ext.pyramid(t, masked=True)
        ext.collapse(t)
        ext.composite_source(t)
        self._ext_geom = (np.int32(pw), np.int32(ox // s), np.int32(oy // s))
        return True

    def composite_separated(self, t: Timings) -> None:
        """Iser eq. 4.26-4.28 on the receiver fetch: level k_ssc = separation.level * K."""
        kmax = len(self.sizes) - 1
        t.add("composite", self.k_comp_sep(
            self.rt.queue, *self.rt.nd(self.w, self.h), self.chain2, self.lv_buf, np.int32(kmax),
            np.float32(self.cfg.render.resolved()[0]), np.float32(self.cfg.render.separation.level * kmax),
            self.out, np.int32(bool(self.aovs)), self.scat_aov))

    def composite(self, t: Timings, depth_blur: bool) -> None:
        c, _, _ = self.cfg.render.resolved()
        t.add("composite", self.k_comp(
            self.rt.queue, *self.rt.nd(self.w, self.h), self.direct, self.medium, self.chain,
            self.spread, self.lv_buf, np.int32(len(self.sizes) - 1), np.float32(c),
            np.int32(depth_blur), np.int32(self.split_medium), self.out, np.int32(bool(self.aovs)),
            self.level_aov, self.scat_aov))

    def map_out(self, t: Timings) -> np.ndarray:
        """The result buffer mapped for reading (run(mapped=True); unmap releases it)."""
        cl, q = self.rt.cl, self.rt.queue
        arr, ev = cl.enqueue_map_buffer(q, self.out, cl.map_flags.READ, 0, (self.h, self.w, 4), np.float32)
        t.add("download", ev)
        ev.wait()
        arr.base._fogcli_queue = q
        return arr

    def download(self, buf, channels: int, t: Timings) -> np.ndarray:
        arr = np.empty((self.h, self.w, channels) if channels > 1 else (self.h, self.w), np.float32)
        t.add("download", self.rt.cl.enqueue_copy(self.rt.queue, arr, buf))
        return arr

    def aov_planes(self, t: Timings) -> dict:
        if not self.aovs:
            return {}
        out = {}
        # optical_depth and emission share the medium buffer (P in .w): download it once
        medium = self.download(self.medium, 4, t) if {"optical_depth", "emission"} & set(self.aovs) else None
        rgb_bufs = {"transmittance": self.trans, "direct": self.direct, "scattered": self.scat_aov,
                    "airlight": self.a_dir, "airlight_scattered": self.a_sc}
        for name in self.aovs:
            if name == "optical_depth":
                out[name] = medium[:, :, 3]
            elif name == "spread":
                out[name] = self.download(self.spread, 1, t)   # level 0 of the spread chain
            elif name == "level":
                out[name] = self.download(self.level_aov, 1, t)
            elif name.startswith("airlight") and not self.cfg.lights:
                out.update({f"{name}.{ch}": np.zeros((self.h, self.w), np.float32) for ch in "RGB"})
            else:
                src = medium if name == "emission" else self.download(rgb_bufs[name], 4, t)
                for i, ch in enumerate("RGB"):
                    out[f"{name}.{ch}"] = src[:, :, i]
        return out


_PLANS: dict = {}


def get_plan(rt: Runtime, width: int, height: int, cfg: Config, aovs=()) -> Plan:
    """Reuse buffers across images of one size and one compile-time configuration."""
    key = (id(rt), width, height, tuple(sorted(defines(cfg).items())), cfg.render.levels,
           plan_features(cfg, aovs),            # what its buffers are (BUFFERS)
           cfg.camera.depth == "distance",      # its preprocess build (CAM_Z)
           cfg.render.border, cfg.render.border_margin)   # its edge tables and extension plan
    plan = _PLANS.get(key)
    if plan is None:
        # what a process holds stays what one frame needs: the plans of another size go (a
        # batch of mixed sizes would keep a frame's buffers of each), and of one size at most
        # two (a medium per frame that changes the build, e.g. fog and sea, alternating)
        if len(_PLANS) >= 2 or any(k[1:3] != (width, height) for k in _PLANS):
            _PLANS.clear()
        plan = _PLANS[key] = Plan(rt, width, height, cfg, aovs)
    plan.cfg = cfg
    return plan


def depth_grid(depth: np.ndarray) -> np.ndarray:
    """The pixels median_depth looks at (about 256 x 256 of them; of a grid, all)."""
    return depth[:: max(1, depth.shape[0] // 256), :: max(1, depth.shape[1] // 256)]


def median_depth(depth: np.ndarray, max_depth: float) -> float:
    """The median metric depth of the surfaces (sky and beyond max_depth left out)."""
    d = depth_grid(depth)
    d = d[np.isfinite(d) & (d < max_depth) & (d > 0)]
    if d.size == 0:
        from .errors import UserError

        raise UserError("medium.visibility: a share of the median depth needs surfaces in the frame (all sky here)")
    return float(np.median(d))


def run(rgb: np.ndarray, depth: np.ndarray, cfg: Config, alpha=None, aovs=(), device=None,
        timings: Timings | None = None, report: list | None = None,
        lamps: list | None = None, mapped: bool = False) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """Process one frame on the device. depth: metric (depth.decode / depth.prepare), at the
    image's size, holes filled; alpha: premultiplied coverage or None. Returns (rgb out
    (h, w, 3), alpha out (h, w) or None, aov planes); `report` collects notes (lamps found),
    `lamps` the point lights that `{type: auto}` made of them. mapped: the rgb out is the
    device's result buffer mapped (a CPU device's own memory: no copy), to be released with
    unmap() before the next frame; otherwise a copy. The same as finish(start(...)), between
    which a caller may drop its rgb: it is not read after the upload."""
    return finish(start(rgb, depth, cfg, alpha, aovs, device, timings, report, lamps), mapped)


@dataclass
class Started:
    """A frame uploaded to its plan (start), to be run and read back (finish)."""
    plan: Plan
    cfg: Config
    t: Timings
    has_alpha: bool
    lamp_mask: np.ndarray | None


def start(rgb: np.ndarray, depth: np.ndarray, cfg: Config, alpha=None, aovs=(), device=None,
          timings: Timings | None = None, report: list | None = None, lamps: list | None = None) -> Started:
    """What run() does up to the frame's upload: the values that depend on the image (lamps
    found, a visibility relative to the scene, the ambient light), the plan, the upload."""

    h, w = depth.shape
    if rgb.shape[:2] != (h, w):
        raise ValueError(f"image {rgb.shape[:2]} and depth {depth.shape} differ in size")
    cfg = cfg.model_copy(update={"camera": cfg.camera.for_size(w, h)})
    lamp_mask = None
    if any(x.type == "auto" for x in cfg.lights):     # lamps of the image become point lights
        from .lights import detect_lamps

        found, lamp_mask, notes = [], None, []
        for spec in [x for x in cfg.lights if x.type == "auto"]:
            got, mask, more = detect_lamps(np.asarray(rgb, np.float32), depth, cfg, spec)
            found += got
            notes += more
            lamp_mask = mask if lamp_mask is None else (lamp_mask | mask)
        for x in found:
            notes.append(f"lamp found at ({', '.join(f'{v:.3g}' for v in x.position)}) m (camera), "
                         f"intensity ({', '.join(f'{v:.3g}' for v in x.intensity)})")
        if report is not None:
            report.extend(notes)
        if lamps is not None:
            lamps.extend(found)
        cfg = cfg.model_copy(update={"lights": [x for x in cfg.lights if x.type != "auto"] + found})
        lamp_mask = lamp_mask if cfg.lights and lamp_mask is not None and lamp_mask.any() else None
    if isinstance(cfg.medium.visibility, str):        # a share of this frame's median depth
        cfg = cfg.model_copy(update={"medium": cfg.medium.for_depth(median_depth(depth, cfg.camera.max_depth))})
    if cfg.medium.ambient == "auto":
        from .ambient import estimate

        la = estimate(np.asarray(rgb, np.float32), depth, cfg.camera.max_depth)
        cfg = cfg.model_copy(update={"medium": cfg.medium.model_copy(update={"ambient": la})})
    t = timings if timings is not None else Timings()
    rt = get_runtime(device)
    plan = get_plan(rt, w, h, cfg, aovs)
    plan.upload_rgb(rgb, alpha, depth, t)
    return Started(plan, cfg, t, alpha is not None, lamp_mask)


def finish(st: Started, mapped: bool = False) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """The device stages of a started frame, and its result (run)."""
    plan, cfg, t, lamp_mask, rt = st.plan, st.cfg, st.t, st.lamp_mask, st.plan.rt
    h = plan.h
    plan.preprocess(t)
    if st.has_alpha and cfg.camera.empty_depth > 0:   # at 0 the alpha is the input's
        plan.coverage(t, cfg.camera.empty_depth)
    if cfg.lights:
        if lamp_mask is not None:       # the lamps' scattered light is now the light model's
            plan.clear_sources(t, lamp_mask)
        plan.lights(t)
    method = cfg.render.method
    if method == "reference":
        from .reference import reference_into

        reference_into(plan, t)
    else:
        plan.pyramid(t, masked=(method == "pyramid"))
        if method == "pyramid" and cfg.render.fetch == "source":
            plan.collapse(t, ext=plan.extend(t))
            plan.composite_source(t)
            if plan.sep:
                plan.pyramid(t, masked=True, second=True)
                plan.collapse(t, second=True)
                plan.composite_source(t, second=True)
        else:
            plan.composite(t, depth_blur=(method == "pyramid"))
            if plan.sep:
                plan.pyramid(t, masked=False, second=True)   # eq. 4.27: no masking
                plan.composite_separated(t)
    if cfg.lights:
        plan.add_airlight(t)
    out = plan.map_out(t) if mapped and rt.info.kind == "cpu" else plan.download(plan.out, 4, t)
    try:
        if not all(np.isfinite(out[y:y + 256]).all() for y in range(0, h, 256)):     # in strips: no frame-sized mask
            from .errors import UserError

            raise UserError("the result holds non-finite values: a medium, light or camera value is too large for "
                            "32-bit floats (fogcli config --show lists them)")
        planes = plan.aov_planes(t)
        rt.queue.finish()
    except BaseException:           # a mapped result is the plan's: handed back before the next frame
        unmap(out)
        raise
    return out[:, :, :3], (np.ascontiguousarray(out[:, :, 3]) if st.has_alpha else None), planes


def unmap(arr: np.ndarray | None) -> None:
    """Release a result that run(mapped=True) handed out (anything else: nothing to do)."""
    base = arr
    while isinstance(base, np.ndarray):
        base = base.base
    release = getattr(base, "release", None)
    if release is not None and getattr(base, "_fogcli_queue", None) is not None:
        release(base._fogcli_queue).wait()
        base._fogcli_queue = None


def kernel_ms(t: Timings) -> tuple[dict, float]:
    stages = t.resolve()
    return stages, float(sum(stages.values()))


def read_chain(plan: Plan) -> tuple[list, list]:
    """Every level of the colour chain (h, w, 4) and of the spread chain (h, w; None for the
    levels a plan does not keep): for tests and inspection."""
    total = int(plan.lv[-1, 0] + plan.lv[-1, 1] * plan.lv[-1, 2])
    c = np.empty((total, 4), np.float32)
    s = np.empty(min(total, plan.spread.size // 4), np.float32)     # the source collapse: level 0 at most
    cl, q = plan.rt.cl, plan.rt.queue
    cl.enqueue_copy(q, c, plan.chain)
    cl.enqueue_copy(q, s, plan.spread)
    q.finish()
    cols, spreads = [], []
    for o, w, h, _ in plan.lv:
        cols.append(c[o:o + w * h].reshape(h, w, 4))
        spreads.append(s[o:o + w * h].reshape(h, w) if o + w * h <= s.size else None)
    return cols, spreads


def write_level0(plan: Plan, scat: np.ndarray, spread: np.ndarray) -> None:
    """Set level 0 of both chains (tests drive the pyramid from chosen inputs)."""
    cl, q = plan.rt.cl, plan.rt.queue
    cl.enqueue_copy(q, plan.chain, np.ascontiguousarray(scat, np.float32))
    cl.enqueue_copy(q, plan.spread, np.ascontiguousarray(spread, np.float32))
    if plan.source:
        if plan.apsf:
            raise NotImplementedError("write_level0 drives the Gaussian chain only")
        eps = plan.cfg.render.resolved()[1]
        plan.k_prep0(q, *plan.rt.nd(plan.w * plan.h), plan.chain, plan.prep, np.int32(plan.w * plan.h),
                     np.float32(plan.threshold(1)), np.float32(eps))
    q.finish()
