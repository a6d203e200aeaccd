"""One frame on the device: start (the plan of its size, the upload) and finish (the stages
in order, the result read back)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fogcli.config.model import Config
from fogcli.device import composite, lights, preprocess, pyramid
from fogcli.device.border import extend
from fogcli.device.plan import Plan, Timings, get_plan
from fogcli.device.reference import reference_into
from fogcli.device.runtime import get_runtime
from fogcli.errors import UserError


def run(rgb: np.ndarray, depth: np.ndarray, cfg: Config, alpha=None, aovs=(), device=None,
        timings: Timings | None = None, lamp_pixels: tuple | None = None,
        mapped: bool = False) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """Process one frame on the device. depth: metric (depth.decode / depth.prepare), at the
    image's size, holes filled; alpha: premultiplied coverage or None; cfg: made concrete
    for the image (frame.scene.for_image), with lamp_pixels the pixels of the lamps it found and the share of their scattered light they keep.
    Returns (rgb out (h, w, 3), alpha out (h, w) or None, aov planes). mapped: the rgb out is the
    device's result buffer mapped (a CPU device's own memory: no copy), to be released with
    unmap() before the next frame; otherwise a copy. The same as finish(start(...)), between
    which a caller may drop its rgb: it is not read after the upload."""
    return finish(start(rgb, depth, cfg, alpha, aovs, device, timings, lamp_pixels), mapped)


@dataclass
class Started:
    """A frame uploaded to its plan (start), to be run and read back (finish)."""
    plan: Plan
    cfg: Config
    t: Timings
    has_alpha: bool
    lamp_pixels: tuple | None


def start(rgb: np.ndarray, depth: np.ndarray, cfg: Config, alpha=None, aovs=(), device=None,
          timings: Timings | None = None, lamp_pixels: tuple | None = None) -> Started:
    """What run() does up to the frame's upload: the plan and the upload."""
    if any(x.type == "auto" for x in cfg.lights) or isinstance(cfg.medium.visibility, str) \
            or cfg.medium.ambient == "auto":
        raise ValueError("the config holds values of the image (auto lights, visibility share, ambient auto): "
                         "frame.scene.for_image makes them concrete")
    h, w = depth.shape
    if rgb.shape[:2] != (h, w):
        raise ValueError(f"image {rgb.shape[:2]} and depth {depth.shape} differ in size")
    cfg = cfg.model_copy(update={"camera": cfg.camera.for_size(w, h)})
    t = timings if timings is not None else Timings()
    rt = get_runtime(device)
    plan = get_plan(rt, w, h, cfg, aovs)
    preprocess.upload_rgb(plan, rgb, alpha, depth, t)
    return Started(plan, cfg, t, alpha is not None, lamp_pixels)


def finish(st: Started, mapped: bool = False) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """The device stages of a started frame, and its result (run)."""
    plan, cfg, t, lamp_pixels, rt = st.plan, st.cfg, st.t, st.lamp_pixels, st.plan.rt
    h = plan.h
    preprocess.preprocess(plan, t)
    if st.has_alpha and cfg.camera.empty_depth > 0:   # at 0 the alpha is the input's
        preprocess.coverage(plan, t, cfg.camera.empty_depth)
    if cfg.lights:
        if lamp_pixels is not None:     # the lamps' scattered light is shared with the light model
            lights.keep_sources(plan, t, lamp_pixels)
        lights.airlight(plan, t)
    method = cfg.render.method
    if method == "reference":
        reference_into(plan, t)
    else:
        pyramid.reduce(plan, t, masked=(method == "pyramid"))
        if method == "pyramid" and cfg.render.fetch == "source":
            pyramid.collapse(plan, t, ext=extend(plan, t))
            composite.composite_source(plan, t)
            if plan.sep:
                pyramid.reduce(plan, t, masked=True, second=True)
                pyramid.collapse(plan, t, second=True)
                composite.composite_source(plan, t, second=True)
        else:
            composite.composite(plan, t, depth_blur=(method == "pyramid"))
            if plan.sep:
                pyramid.reduce(plan, t, masked=False, second=True)   # eq. 4.27: no masking
                composite.composite_separated(plan, t)
    if cfg.lights:
        lights.add_airlight(plan, t)
    out = composite.map_out(plan, t) if mapped and rt.info.kind == "cpu" else plan.download(plan.out, 4, t)
    try:
        if not all(np.isfinite(out[y:y + 256]).all() for y in range(0, h, 256)):     # in strips: no frame-sized mask
            raise UserError("the result holds non-finite values: a medium, light or camera value is too large for "
                            "32-bit floats (fogcli config --show lists them)")
        planes = composite.aov_planes(plan, t)
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
        plan.k_prep0(q, *plan.rt.nd(plan.w * plan.h), chain=plan.chain, prep=plan.prep, n=np.int32(plan.w * plan.h),
                     thresh1=np.float32(plan.threshold(1)), eps=np.float32(eps))
    q.finish()