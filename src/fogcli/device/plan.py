"""The per-image plan: the device buffers of one image size, declared once (BUFFERS: name,
element, extent over the frame or the pyramid, the features it exists for; allocation, the
memory estimate and the plan cache key follow from it) and
allocated once per size (silx style), with the kernels its options build. The stages
(preprocess, pyramid, composite, lights, shadows, noise, reference) are modules that run
on a plan; run.py orders them. Kernel times come from OpenCL profiling events, per stage."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from fogcli.config.model import Config
from fogcli.errors import ProcessingError
from fogcli.physics.airlight_table import DEFINES
from fogcli.physics.apsf import NP, conservation_tables, edge_tables, load_table, warp_cap, warp_scale
from fogcli.physics.apsf_lut import lut_offsets
from fogcli.physics.emission import COS_MIN, NC
from fogcli.physics.glow_depth import NU
from fogcli.physics.calibration import FILTERS
from fogcli.device.runtime import Runtime
from fogcli.device.border_size import EXT_LEVEL, edge_band_bytes, ext_level, open_border, uses_apsf

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
        d["PSF_APSF"] = 1
        d["APSF_NP"] = NP
        d.update(APSF_NC=NC, APSF_J=len(load_table()["sigma_u"]))     # the table's layout
        if cfg.render.emission_profile == "lambertian":
            d.update(EMISSION_LAMBERT=1, APSF_COS_MIN=f"{COS_MIN!r}f")
        if halo_depth(cfg):
            d.update(RECEIVER_DEPTH=1, APSF_NU=NU)
    if open_border(cfg):
        d["BORDER_OPEN"] = 1
    m = cfg.medium
    if len(set(m.absorption)) == 1 and len(set(m.scattering)) == 1:
        d["MEDIUM_GREY"] = 1      # fog, haze, smoke: one channel's table reads and exponentials serve all three
    return d


def half_step(c: float) -> float:
    """a of the (a, 1 - 2a, a) half-octave blur of level spacing c: variance 2a = c^2 level-k
    pixels (at most 2/3: beyond, the middle weight would vanish)."""
    return min(c * c / 2.0, 1.0 / 3.0)


WARP_LEVEL = EXT_LEVEL   # render.spread_space: angles from here up; the extension joins at or below it


def warp_geometry(cfg: Config, width: int, height: int, levels: int) -> tuple | None:
    """render.spread_space: angles: (K, s, cx, cy, fx, fy) of the plane of angles the source
    collapse's levels K = WARP_LEVEL and up run in (kernels/warp.cl; s: apsf.warp_scale), or
    None: pixels throughout (spread_space: pixels, psf: gaussian, the reference, the closed
    border, which would keep what the plane moves past the frame, or too few levels)."""
    r = cfg.render
    if not (uses_apsf(cfg) and r.method == "pyramid" and r.spread_space == "angles" and open_border(cfg)
            and levels >= WARP_LEVEL + 1):
        return None
    (cx, cy), fx, fy = cfg.camera.centre(width, height), cfg.camera.focal(width), cfg.camera.focal_y(width)
    cap = warp_cap(r.resolved()[0], 2.0 * half_step(r.resolved()[0]), WARP_LEVEL)
    return WARP_LEVEL, warp_scale(width, height, fx, fy, cx, cy, cap), cx, cy, fx, fy


def halo_depth(cfg: Config) -> bool:
    """render.halo_depth: receiver weights the source collapse's levels by the receivers' depth."""
    r = cfg.render
    return uses_apsf(cfg) and r.method == "pyramid" and r.halo_depth == "receiver"


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
    recv: bool = False    # render.halo_depth: receiver: the receivers' log depth per level


@dataclass(frozen=True)
class Buffer:
    """One device buffer of a plan, declared once: its element (bytes: 16 a float4, 4 a float,
    1 a flag), its extent (FRAME: a pixel of level 0; PYRAMID: a pixel of every level), and
    the features it exists for (otherwise a 16-byte placeholder, or the buffer of ALIASES).
    Plan allocates these, check_memory and memory.estimate sum them, and the plan cache keys
    on the Features they depend on (get_plan)."""
    name: str
    element: int
    extent: str
    when: Callable[[Features], bool] = lambda f: True
    size: Callable | None = None        # bytes(n, t, f, rows) where the extent does not say

    def bytes(self, n: int, t: int, f: Features, rows: int) -> int:
        if not self.when(f):
            return 0
        if self.size is not None:
            return int(self.size(n, t, f, rows))
        return self.element * (n if self.extent == FRAME else t)


FRAME, PYRAMID = "frame", "pyramid"
F4, F1, U1 = 16, 4, 1

BUFFERS = (
    Buffer("image", F4, FRAME),                                      # RGBA in; scratch after preprocess
    # metric depth, read up to the lights; then (the source collapse) level k+1 up-sampled
    # along y to level k's rows, as colour planes (up_planes: the pair kernels, up_rows):
    # 12 h ceil(w / 2) <= 6 n + 6 h bytes at level 0, the largest
    Buffer("depth", F1, FRAME, size=lambda n, t, f, r: max(4 * n, (6 * n + 6 * r) * f.source)),
    Buffer("direct", F4, FRAME),                                     # L exp(-st P) (+ L_em + L_amb)
    Buffer("medium", F4, FRAME, lambda f: f.split_medium),           # L_em + L_amb, P in .w
    Buffer("chain", F4, PYRAMID),                                    # the colour chain
    Buffer("spread", F1, PYRAMID, size=lambda n, t, f, r: 4 * (n * f.spread0 if f.source else t)),
    Buffer("prep", F4, PYRAMID, lambda f: f.source),
    Buffer("rdepth", F1, PYRAMID, lambda f: f.recv),                 # mean log P of each level's receivers
    Buffer("up_planes", F1, FRAME, lambda f: False),                 # in `depth`, free by then
    Buffer("chain2", F4, PYRAMID, lambda f: f.sep),
    Buffer("prep2", F4, PYRAMID, lambda f: f.sep),
    Buffer("half2", F4, FRAME, lambda f: f.sep),
    Buffer("spread2", F1, PYRAMID, lambda f: f.sep),                 # unused output of reduce_level
    # the result, written over `direct` (every stage that writes it reads direct at its own
    # pixel only, first) unless the direct AOV must keep it
    Buffer("out", F4, FRAME, lambda f: "direct" in f.aovs),
    Buffer("a_dir", F4, FRAME, lambda f: f.lights),                  # airlight reaching the camera directly
    Buffer("a_sc", F4, FRAME, lambda f: f.lights),                   # ... and scattered again on the way
    Buffer("trans", F4, FRAME, lambda f: "transmittance" in f.aovs),
    Buffer("level_aov", F1, FRAME, lambda f: bool(f.aovs)),
    Buffer("scat_aov", F4, FRAME, lambda f: bool(f.aovs)),
    Buffer("cosines", F1, FRAME, lambda f: f.lambert),
    Buffer("epi_flags", U1, FRAME, lambda f: f.epipolar),            # pixels the epipolar unwarp leaves to the march
)
# Buffers declared with 0 bytes that are another one: up_planes is made after the last read
# of the depth; out is written over direct (see above)
ALIASES = {"up_planes": "depth", "out": "direct"}

# light_share_depth (kernels/light_share.h, built in: its loops unrolled): how far a pixel
# looks for a nearer surface (pixels), what depth is nearer (below this share of its own;
# farther: this share of it is above the own), what is its own surface's (within this
# share); how far it looks for a farther surface, and how much of the pixel that must cover
LIGHT_SHARE = {"radius": 2, "nearer": 0.9, "same": 0.05, "far_radius": 1, "far_cover": 0.25}

# the reference's planes (reference.py), allocated when it runs
REFERENCE_BUFFERS = (Buffer("src", F4, FRAME), Buffer("tmp", F4, FRAME), Buffer("acc", F4, FRAME))


def plan_features(cfg: Config, aovs=()) -> Features:
    r = cfg.render
    source = r.method == "pyramid" and r.fetch == "source"
    return Features(source, r.method == "pyramid" and r.separation.enabled,
                    bool({"optical_depth", "emission", "direct"} & set(aovs)), bool(cfg.lights),
                    uses_apsf(cfg) and r.emission_profile == "lambertian", tuple(aovs), r.method == "reference",
                    bool(cfg.lights) and r.lights.shadows == "screen" and r.lights.method == "epipolar",
                    not uses_apsf(cfg) or bool(aovs) or cfg.medium.heterogeneous, halo_depth(cfg))


def buffer_bytes(n: int, t: int, f: Features, rows: int) -> dict:
    return {b.name: b.bytes(n, t, f, rows) for b in BUFFERS}


def planned_bytes(n: int, t: int, f: Features, cfg: Config, rows: int) -> int:
    """Everything one frame may allocate: the declared buffers, the reference's planes, the
    airlight of a second light (two planes), and the extension plan of `border: extend`
    (the padded frame at 1/2^ext_level: about (1 + 2 margin)^2 / 64 of a plan at level 3, and
    the edge's bands)."""
    total = sum(buffer_bytes(n, t, f, rows).values())
    if f.reference:
        total += sum(b.bytes(n, t, f, rows) for b in REFERENCE_BUFFERS)
        if cfg.render.border == "extend" and uses_apsf(cfg):
            total += edge_band_bytes(n // rows, rows)     # its continued edge (reference._Blur.prof)
    if f.lights and len(cfg.lights) > 1:
        total += 32 * n
    if cfg.render.border == "extend" and f.source and uses_apsf(cfg):
        total += int(total * (1 + 2 * cfg.render.border_margin) ** 2 / 4 ** ext_level(cfg, n // rows, rows))
        total += edge_band_bytes(n // rows, rows)
    return total


def check_memory(rt: Runtime, width: int, height: int, sizes: dict, need: int) -> None:
    """Refuse before allocating: the device's memory and its largest single allocation, each
    in one line with the estimate, the device's figure and what to do instead."""
    dev = rt.device
    instead = "choose a device with more memory (--device; fogcli devices lists them) or a smaller image"
    if need > dev.global_mem_size:
        raise ProcessingError(f"image of {width}x{height} needs {need / 2**20:.0f} MiB, "
                              f"device {rt.info.name} has {dev.global_mem_size / 2**20:.0f} MiB: {instead}")
    name, big = max(sizes.items(), key=lambda kv: kv[1])
    if big > dev.max_mem_alloc_size:
        raise ProcessingError(f"image of {width}x{height}: its {name} buffer needs {big / 2**20:.0f} MiB in one "
                              f"piece, device {rt.info.name} allocates at most {dev.max_mem_alloc_size / 2**20:.0f} MiB: "
                              f"{instead}")


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


class Plan:
    """Device buffers for one image size and one set of compile-time options."""

    def __init__(self, rt: Runtime, width: int, height: int, cfg: Config, aovs=()):
        self.rt, self.w, self.h, self.cfg = rt, width, height, cfg
        self.aovs = tuple(aovs)
        self.features = f = plan_features(cfg, aovs)
        # L_em + L_amb ride in `direct` unless an AOV needs them (or P) on their own
        self.split_medium, self.source, self.sep, self.lambert = f.split_medium, f.source, f.sep, f.lambert
        self.sizes = level_sizes(width, height, cfg.render.levels)
        offs = np.cumsum([0] + [w * h for w, h in self.sizes])
        self.lv = np.array([[o, w, h, 0] for o, (w, h) in zip(offs[:-1], self.sizes)], np.int32)
        self.apsf = uses_apsf(cfg)
        self._allocate(int(offs[-1]))
        self._build_kernels(defines(cfg))
        self._al_tables = None     # (key, device buffer) of airlight_table.tables
        self._noise = None         # (the noise_t array's bytes, its device copy, count): noise_args
        self._light_tmp = None     # (t_dir, t_sc): the airlight of the second and later lights
        self._tfm = None           # (floats, coefficients, spans): a light's transmittance function map
        self._noise_samples = None  # (count, A_dir, A_sc) at the samples of render.noise_stride
        self._p_samples = None     # (count, buffer): the noise's optical depth at the same samples
        self._epi = None           # (samples, slices, buffers ...) of render.lights.method: epipolar
        self._ext = None           # the extension plan of render.border: extend (extend)
        self._edge_bands = None    # what the edge continues as, for the extension (border.extend)

    def _allocate(self, total: int) -> None:
        """The declared buffers (BUFFERS; `total` pixels in all levels), after the device's
        memory was checked, and the tables of the tabulated point spread."""
        rt, cfg, width, height, f = self.rt, self.cfg, self.w, self.h, self.features
        cl = rt.cl
        n = width * height
        mf = cl.mem_flags
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
            self.steps = (1, 1)          # the depth's staircase (preprocess.staircase), set at upload
            self.smoothing = None        # the view cosines' depth smoothing (preprocess.depth_smoothing), likewise
            self.grid = None             # a staircase's block grid (preprocess.block_grid): realign_blocks
            self.ground = None           # the frame's ground (device/ground.find), set at upload
            self.ground_table = None     # its slab's light and u nodes (device/ground.table), made on first use
            self.edge_off = [0] * len(self.sizes)
            self.edge = B(16)
            self.cons_off = [0] * (len(self.sizes) + 1)
            self.cons = B(16)
            if self.apsf and self.source:
                tab, offs = conservation_tables(self.sizes, FILTERS[cfg.render.kernel],
                                                cfg.render.interpolation != "linear-bilinear",
                                                open_border(cfg))
                self.cons_off = offs + [0]
                self.cons = cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tab)
            if self.apsf and open_border(cfg):
                tab, self.edge_off = edge_tables(self.sizes, cfg.render.resolved()[0], 2.0 * self.half_step())
                self.edge = cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tab)
        except cl.Error as exc:
            raise ProcessingError(f"cannot allocate device buffers for {width}x{height}: {exc}") from exc

    def _build_kernels(self, d: dict) -> None:
        """The kernels of this plan's options, built once per process (runtime.program)."""
        rt, cfg = self.rt, self.cfg
        pre = dict(d, PRE_SOURCE=int(self.source), PRE_SEP=int(self.sep), PRE_SPLIT_MEDIUM=int(self.split_medium),
                   PRE_TRANSMITTANCE=int("transmittance" in self.aovs),
                   PRE_SPREAD=int(not (self.apsf and self.source) or bool(self.aovs)),
                   CAM_Z=int(cfg.camera.depth != "distance"))   # planar depth: view_cosines_inner without roots
        pre.update(SHARE_RADIUS=LIGHT_SHARE["radius"], SHARE_NEARER=f"{LIGHT_SHARE['nearer']!r}f",
                   SHARE_SAME=f"{LIGHT_SHARE['same']!r}f", SHARE_FAR_RADIUS=LIGHT_SHARE["far_radius"],
                   SHARE_FAR_COVER=f"{LIGHT_SHARE['far_cover']!r}f")
        self.k_pre_prog = rt.program("preprocess", **pre)
        self.k_pre_whole = rt.program("preprocess", WHOLE_GROUPS=1, **pre)
        self.pre_defines = pre         # device/ground.py builds its variant (PRE_GROUND) from them
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
        if self.features.recv:
            self.k_recv_depth = (whole.receiver_depth, pyr.receiver_depth)
            self.k_recv_top = (whole.receiver_weight_top, pyr.receiver_weight_top)
            self.k_recv_ext = (whole.receiver_depth_ext, pyr.receiver_depth_ext)
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
        if warp_geometry(cfg, self.w, self.h, len(self.sizes) - 1) is not None:
            wp, wpw = rt.program("warp", **d), rt.program("warp", WHOLE_GROUPS=1, **d)
            self.k_warp = {k: (getattr(wpw, k), getattr(wp, k))
                           for k in ("warp_level", "warp_store", "warp_receivers", "unwarp_level")}
        self.k_border_src = pyr.border_sources if self.apsf else None
        self.k_edge_bands = pyr.edge_bands if self.apsf else None
        self.k_border_inject = pyr.border_inject if self.apsf else None
        # pixels of a row per work-item (LANES, kernels/lanes.h: the light tables, the apsf
        # reduce's interior) and the pyramid's choice of interior kernel follow it: read once, here
        self.lanes = rt.lanes
        self.k_reduce_lanes = rt.program("reduce_lanes", **d, LANES=8).reduce_source_lanes \
            if self.lanes == 8 and self.apsf and self.source else None
        self.k_lights = rt.program("lights", **d, **DEFINES, LANES=self.lanes) if cfg.lights else None

    @property
    def warp(self) -> tuple | None:
        """warp_geometry of this frame's config, worked out once per config."""
        if getattr(self, "_warp_for", (None,))[0] is not self.cfg:
            self._warp_for = (self.cfg, warp_geometry(self.cfg, self.w, self.h, len(self.sizes) - 1))
        return self._warp_for[1]

    def threshold(self, k: int) -> float:
        """Masking threshold of level k (Elek eq. 7, scaled): threshold * c * 2^(k-1)."""
        c, _, thr = self.cfg.render.resolved()
        return thr * c * 2.0 ** (k - 1)

    def lut_floats(self) -> int:
        return lut_offsets(len(self.sizes) - 1, len(load_table()["sigma_u"]))["end"]

    def sep_params(self) -> np.ndarray:
        s = self.cfg.render.separation
        return np.array([s.luminance, s.luminance_width, s.depth, s.depth_width], np.float32)

    def half_step(self) -> float:
        return half_step(self.cfg.render.resolved()[0])

    def source_bufs(self, second: bool) -> tuple:
        """(colour chain, half-octave scratch, prep chain) of the main or the separated
        source collapse; the main one's scratch is the input buffer, free after preprocess."""
        if second:
            return self.chain2, self.half2, self.prep2
        return self.chain, self.image, self.prep

    def launch_pairs(self, t: Timings, region, pairs, kernels, w: int, h: int, args: dict, chain, up: int) -> None:
        """A w x h level through its two-pixel kernel (`pairs`, pairs.h) on `region`, the
        per-pixel kernel around it (_launch_inner). The pair kernels read level `up` of
        `chain` up-sampled along y to this level's rows, as colour planes (up_rows, made
        here), and take the region's corner as arguments (pairs.h, Addressing)."""
        if region is not None:
            o, uw, uh, _ = (int(v) for v in self.lv[up])
            t.add("composite",
                  self.rt.launch2d(self.k_up_rows, uw, h, chain=chain, off=np.int32(o), uw=np.int32(uw),
                                   uh=np.int32(uh), h=np.int32(h), planes=self.up_planes))
        self.launch_inner(t, "composite", region, pairs, kernels, w, h, args, per=2, corner_args=True,
                          extra={"up_planes": self.up_planes})

    def launch_inner(self, t: Timings, stage: str, region, inner, kernels, w: int, h: int, args: dict,
                     per: int = 1, corner_args: bool = False, extra: dict | None = None) -> None:
        """A w x h kernel through `inner` on `region` [x0, x1) x [y0, y1) (whole work-groups,
        `per` pixels of a row per work-item; its corner as a global offset, or with
        corner_args as two more arguments, x0 / per and y0) and the checked per-pixel kernel
        (kernels[1]) on the four strips around it; without a region, the per-pixel kernels
        alone (launch2d)."""
        if region is None:
            t.add(stage, self.rt.launch2d(kernels, w, h, **args))
            return
        (x0, x1, y0, y1), q = region, self.rt.queue
        size = ((x1 - x0) // per, y1 - y0)
        if corner_args:
            t.add(stage, inner(q, size, self.rt.local2d, **args, **(extra or {}), px0=np.int32(x0 // per),
                               py0=np.int32(y0)))
        else:
            t.add(stage, inner(q, size, self.rt.local2d, **args, global_offset=(x0 // per, y0)))
        t.add(stage, self.rt.launch_strips(kernels[1], w, h, region, **args))

    def download(self, buf, channels: int, t: Timings) -> np.ndarray:
        arr = np.empty((self.h, self.w, channels) if channels > 1 else (self.h, self.w), np.float32)
        t.add("download", self.rt.cl.enqueue_copy(self.rt.queue, arr, buf))
        return arr


_PLANS: dict = {}


def get_plan(rt: Runtime, width: int, height: int, cfg: Config, aovs=()) -> Plan:
    """Reuse buffers across images of one size and one compile-time configuration."""
    key = (id(rt), width, height, tuple(sorted(defines(cfg).items())), cfg.render.levels,
           plan_features(cfg, aovs),            # what its buffers are (BUFFERS)
           cfg.camera.depth == "distance",      # its preprocess build (CAM_Z)
           cfg.render.border, cfg.render.border_margin,   # its edge tables and extension plan
           cfg.render.spread_space)             # its warp kernels
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


