"""One frame from files to file: what `fogcli apply` does and what every batch worker
repeats. Reading, depth decoding and cleaning, the device run, the atomic write."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fogcli.io import depth as depth_mod
from fogcli.io import images as inputs
from fogcli.device import memory
from fogcli.io import outputs
from fogcli.io.colour import clipped_pixels
from fogcli.io import windows
from fogcli.config.model import Config
from fogcli.physics.luminance import luminance
from fogcli.errors import UserError
from fogcli.config.presets import visibility_m
from fogcli.device.plan import Timings
from fogcli.device.run import finish, start, unmap
from fogcli.frame.lamps import recover as recover_highlights
from fogcli.frame.scene import concrete_medium, depth_grid, for_image, median_depth


@dataclass
class Job:
    input: str
    output: str
    depth: str | None = None          # a depth file; None: the input's own Z channel
    layer: str | None = None
    view: str | None = None
    save_depth: str | None = None     # write the cleaned metric depth used here
    drop_channels: bool = False       # EXR: write only what fogcli produces
    protected: tuple = ()             # other files given as input (config, camera): never written
    lamps: str | None = None          # write the lamps {type: auto} found, as a `lights:` config
    cfg: Config | None = None         # this frame's own config (a jobs file's line); None: the batch's
    label: str | None = None          # where the job came from (a jobs file's `file:line`), for messages


@dataclass
class Result:
    io_ms: float = 0.0
    pixels: int = 0
    warnings: list = field(default_factory=list)


def save_depth(path: Path, depth: np.ndarray) -> None:
    """Metric depth as a float EXR channel Z (or NPY)."""
    if path.suffix.lower() == ".npy":
        outputs.atomic_write(path, lambda tmp: np.save(open(tmp, "wb"), depth))
        return
    if path.suffix.lower() not in (".exr", ".tif", ".tiff"):
        raise UserError(f"--save-depth {path}: use .exr, .tif or .npy (metric float depth)")
    outputs.write_plane(path, depth, "Z")


@dataclass
class Staged:
    """A frame between the stages of run_job: read (load), computed (compute), written (store)."""
    job: Job
    frame: object = None
    depth: np.ndarray | None = None
    rgb: np.ndarray | None = None
    alpha: np.ndarray | None = None
    planes: dict = field(default_factory=dict)
    lamps: list = field(default_factory=list)
    res: Result = field(default_factory=Result)
    others: list = field(default_factory=list)      # the other views of a multi-view EXR (Staged each)
    cfg: Config | None = None       # the config with this frame's camera (an EXR's display window), or None


def run_job(job: Job, cfg: Config, aovs=(), device=None, timings: Timings | None = None) -> Result:
    # one frame after the other on this thread: the result is written from the device's own
    # buffer (mapped), which the next frame may then reuse
    return store(compute(load(job, cfg, aovs), cfg, aovs, device, timings, mapped=True), cfg)


def load(job: Job, cfg: Config, aovs=()) -> Staged:
    """Every check that needs no pixels, then the image, its depth, and the depth cleaned.
    No OpenCL: a batch runs this for the next frame on a thread while the device works."""
    st = Staged(job)
    res = st.res
    src = Path(job.input)
    out_path = Path(job.output)
    given = (src, Path(job.depth) if job.depth else None, *map(Path, job.protected))
    outputs.check_target(out_path, *given)
    if job.save_depth:         # before any work: no output replaces an input or the other output
        outputs.refuse_overwrite(Path(job.save_depth), "--save-depth", *given, what="an input file")
        outputs.refuse_overwrite(Path(job.save_depth), "--save-depth", out_path, what="the output (-o)")
    if job.lamps:
        outputs.refuse_overwrite(Path(job.lamps), "--lamps", *given, out_path, what="an input or the output")
        if Path(job.lamps).suffix.lower() not in (".json", ".yaml", ".yml"):
            raise UserError(f"--lamps {job.lamps}: expected a .json or .yaml file name")
        if not Path(job.lamps).parent.is_dir():
            raise UserError(f"--lamps {job.lamps}: folder {Path(job.lamps).parent} does not exist")
        if not any(x.type == "auto" for x in cfg.lights):
            raise UserError("--lamps: no `{type: auto}` entry in lights:, so no lamps are looked for")
    if aovs and out_path.suffix.lower() != ".exr":
        raise UserError(f"--aov needs an .exr output, got {out_path.name}")

    t0 = time.perf_counter()
    # every view of a multi-view EXR is fogged and held at once: admitted together
    names = inputs.views(src) if job.view is None and src.suffix.lower() == ".exr" else []
    n_views = max(1, len(names))
    frame = _read(job, cfg, aovs, job.view, n_views)
    if job.depth:       # of a multi-view depth EXR, the view's own (right.Z, or its part)
        raw, dsrc = _view_depth(job.depth, frame.view), job.depth
    elif frame.depth is not None:
        raw, dsrc = None, f"{src} (Z channel)"
    else:
        raise UserError(f"{src}: no depth channel (Z, *.Z or *depth); pass --depth FILE")
    frame, raw, st.cfg = _grow(job, cfg, aovs, frame, raw, n_views)
    res.io_ms += (time.perf_counter() - t0) * 1e3
    _clean(st, frame, frame.depth if raw is None else raw, dsrc, st.cfg)
    if job.view is None and frame.view:
        _other_views(st, cfg, aovs, names)
    return st


def _view_depth(path: str, view: str):
    """The depth of `view` in a depth file: its own where the file has views, else the file's."""
    have = inputs.views(path) if view else []
    if not have:
        return inputs.read_depth(path)
    raw = inputs.read_depth(path, view=view)
    if raw is None:
        raise UserError(f"{path}: a depth file of views {', '.join(have)}, none of them {view}; expected {view}'s depth")
    return raw


def _read(job: Job, cfg: Config, aovs, view: str | None, views: int = 1):
    return inputs.read_image(Path(job.input), job.layer, view,
                             admit=lambda *size: memory.admit(*size, cfg=cfg, aovs=aovs, views=views))


def _grow(job: Job, cfg: Config, aovs, frame, raw, views: int = 1):
    """An EXR grown to hold its display window (io/windows.py; refused before it is made
    when that would not fit), its raw depth alike, and the config with the display
    window's camera in the frame's pixels."""
    disp = windows.display_of(frame)
    box = windows.union(frame)
    if box is not None:
        memory.admit(job.input, box[2], box[3], 4, 4, cfg=cfg, aovs=aovs, views=views)
        frame, raw = windows.grow(frame, raw)
    cam = windows.camera_for(cfg.camera, frame, disp)
    return frame, raw, (cfg if cam is cfg.camera else cfg.model_copy(update={"camera": cam}))


def _highlights(st: Staged, frame, cfg: Config, depth: np.ndarray) -> None:
    """A display-referred frame clips its lamps at white: they scatter no more light than
    white paper. Said once; camera.highlight_gain and highlight_kelvin give them their light
    back, and highlight_area_gain the other clipped regions' (frame.lamps.recover)."""
    if not frame.display_referred:
        return
    cam = cfg.camera
    if cam.highlight_gain != 1.0 or cam.highlight_area_gain != 1.0 or cam.highlight_kelvin is not None:
        frame.rgb = recover_highlights(frame.rgb, depth, cfg)
    elif n := clipped_pixels(frame.rgb):
        st.res.warnings.append(
            f"{st.job.input}: {n} pixel(s) clipped at white: this display-referred image holds no light above it, so "
            "lamps there glow no more than white paper; set camera.highlight_gain (how many times white a clipped "
            "lamp is, e.g. 50) and camera.highlight_kelvin (its colour, e.g. 2700), or use an HDR or camera RAW source")


def _clean(st: Staged, frame, raw, dsrc, cfg: Config, first: bool = True) -> None:
    """The frame's depth made metric and cleaned, with what that did in the warnings."""
    job, res = st.job, st.res
    h, w = frame.shape
    clean, rep = depth_mod.metric_depth(raw, frame.colour(), cfg.camera, str(dsrc), frame.alpha)
    _highlights(st, frame, cfg, clean)
    res.warnings += rep.notes or []
    if rep.resampled_from:
        res.warnings.append(f"{dsrc}: depth {rep.resampled_from[0]}x{rep.resampled_from[1]} upsampled "
                            f"edge-aware to {w}x{h}")
    if rep.holes:
        res.warnings.append(f"{dsrc}: {rep.holes} invalid depth pixel(s) (no measurement: NaN, zero "
                            "or negative) filled edge-aware from neighbours")
    if job.save_depth and first:        # of a multi-view file, the first view's
        save_depth(Path(job.save_depth), clean)
    if not job.drop_channels:    # the raw values are not read again (an EXR output copies Z from the file)
        frame.depth = None
    st.frame, st.depth = frame, clean


def _other_views(st: Staged, cfg: Config, aovs, views: list) -> None:
    """A multi-view EXR: every view is fogged with its own depth (right.Z for the right
    view), so that a stereo pair stays a pair. A view without a depth of its own is copied
    as it is, and a warning names it; an output that holds one view (PNG, --drop-channels)
    gets the first, and a warning says so."""
    job, src = st.job, st.job.input
    names = [v for v in views if v != st.frame.view]
    if not names:
        return
    one = Path(job.output).suffix.lower() != ".exr" or job.drop_channels
    if one:
        st.res.warnings.append(f"{src}: views {', '.join([st.frame.view] + names)}: {Path(job.output).name} holds one; "
                               f"fogged {st.frame.view} (--view NAME picks another)")
        return
    for v in names:
        t0 = time.perf_counter()
        frame = _read(job, cfg, aovs, v)
        # --depth FILE: its own view's depth (right.Z of a stereo depth EXR), else the input's
        given = inputs.read_depth(job.depth, view=v) if job.depth else None
        st.res.io_ms += (time.perf_counter() - t0) * 1e3
        if frame.view != v or (given is None and frame.depth is None):
            st.res.warnings.append(f"{src}: view {v} has no depth channel of its own ({v}.Z); copied unfogged")
            continue
        frame, given, view_cfg = _grow(job, cfg, aovs, frame, given)
        other = Staged(job, res=st.res, cfg=view_cfg)
        _clean(other, frame, frame.depth if given is None else given,
               f"{job.depth} (view {v})" if given is not None else f"{src} (view {v}, Z channel)", view_cfg, first=False)
        st.others.append(other)


def compute(st: Staged, cfg: Config, aovs=(), device=None, timings: Timings | None = None,
            mapped: bool = False) -> Staged:
    """The device run (the only stage that touches OpenCL). The frame's colour is handed to
    the device and dropped here (its memory goes to the device's buffers); mapped: the
    result is the device's buffer until store() has written it (run.run). Every view of a
    multi-view frame in turn (each result a copy but the last: the next view reuses the
    buffers)."""
    if st.others:       # one medium for every eye: a share of the median depth, ambient auto, of the first view
        medium = concrete_medium(st.frame.colour(), st.depth, st.cfg or cfg)
        for view in (*st.others, st):
            view.cfg = (view.cfg or cfg).model_copy(update={"medium": medium})
    for view in st.others:
        _compute(view, view.cfg or cfg, aovs, device, timings, False)
    return _compute(st, st.cfg or cfg, aovs, device, timings, mapped)


def _compute(st: Staged, cfg: Config, aovs, device, timings: Timings | None, mapped: bool) -> Staged:
    notes: list = []
    frame, src = st.frame, st.job.input
    colour = frame.colour()         # made once (a copy where the channels are not a run)
    y_in = grid_luminance(colour)
    try:
        frame_cfg, lamp_pixels = for_image(colour, st.depth, cfg, report=notes, lamps=st.lamps)
        started = start(colour, st.depth, frame_cfg, alpha=frame.alpha, aovs=aovs, device=device,
                        timings=timings if timings is not None else Timings(), lamp_pixels=lamp_pixels)
    except UserError as exc:        # the colour is checked as it is uploaded: name the file
        raise UserError(str(exc).replace("colour: ", f"{src}: ", 1)) from None
    del colour
    # uploaded: not read again but for the median depth of a warning (of a grid, the same)
    frame.rgb, grid, st.depth = None, np.array(depth_grid(st.depth)), None
    st.rgb, st.alpha, st.planes = finish(started, mapped)
    st.res.warnings += [f"{src}: {n}" for n in notes]
    hidden = medium_warning(y_in, st.rgb, cfg, grid)
    if hidden:
        st.res.warnings.append(f"{src}: {hidden}")
    return st


def store(st: Staged, cfg: Config) -> Result:
    """The atomic write (and the lamps found). No OpenCL: a batch writes on a thread."""
    t0 = time.perf_counter()
    job = st.job
    try:
        keep = cfg.output.data_window == "keep"
        frame, rgb, alpha, planes = _as_written(st, keep)
        outputs.write(Path(job.output), rgb, alpha, planes, frame, cfg.output.type,
                      cfg.output.exposure, cfg.output.compression, job.drop_channels,
                      others=[_as_written(o, keep) for o in st.others])
    finally:
        unmap(st.rgb)
    if job.lamps:
        write_lamps(Path(job.lamps), st.lamps)
    st.res.io_ms += (time.perf_counter() - t0) * 1e3
    st.res.pixels = st.rgb.shape[0] * st.rgb.shape[1]
    return st.res


def _as_written(st: Staged, keep: bool) -> tuple:
    """(frame, rgb, alpha, AOV planes) as the output holds them: on the data window the
    frame was read with when keep, without the padding's alpha where the file had none."""
    f = st.frame
    alpha = None if f.alpha_added else st.alpha
    if not (keep and f.read_window):
        return f, st.rgb, alpha, st.planes
    return (windows.as_read(f), windows.crop(st.rgb, f), windows.crop(alpha, f),
            {k: windows.crop(p, f) for k, p in st.planes.items()})


def write_lamps(path: Path, lamps: list) -> None:
    """The lamps found as a config file (JSON is YAML): `--config` it back, edit it, reuse it
    for the frames of a sequence."""
    import json

    data = {"lights": [x.model_dump(mode="json") for x in lamps]}
    outputs.atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(data, indent=1) + "\n"))


def grid_luminance(rgb) -> np.ndarray:
    """Luminance of a grid of about 256 rows of a frame: what the warnings look at (float32:
    a half frame's sums overflow half; of the grid's luminance only, not of its colour, which
    tests/test_memory.py's peak would see)."""
    step = max(1, rgb.shape[0] // 256)
    return luminance(rgb[::step, ::step]).astype(np.float32)


FAINT = 0.03        # a frame's mean relative change in luminance below which a medium is hardly seen
SHOWN = 0.2         # the change the hint's visibility aims at: plainly there, the scene still seen


def medium_warning(y_in: np.ndarray, rgb_out, cfg: Config, depth) -> str | None:
    """One line when the medium all but hides the frame, or hardly changes it (y_in:
    grid_luminance of the input; the output's grid is made once, for both)."""
    y_out = grid_luminance(rgb_out)
    return _hidden(y_in, y_out, cfg, depth) or _faint(y_in, y_out, cfg, depth)


def _faint(y_in: np.ndarray, y_out: np.ndarray, cfg: Config, depth) -> str | None:
    """When the medium changes the frame by less than FAINT (mean |Y_out - Y_in| over mean
    Y_in, both grid_luminance), with the relative visibility that would change it by about
    SHOWN (the change grows about as 1 / visibility while thin)."""
    total = float(y_in.sum(dtype=np.float64))
    if y_out.shape != y_in.shape or not total > 0:
        return None
    change = float(np.abs(y_out - y_in).sum(dtype=np.float64) / total)
    vis = visibility_m(cfg.medium)
    if change >= FAINT or not change > 0 or not np.isfinite(vis):
        return None
    try:
        med = median_depth(depth, cfg.camera.max_depth)
    except UserError:
        return None
    share = vis * change / SHOWN / med          # the visibility that shows it, in median depths
    nice = float(f"{share:.1g}") * 100
    return (f"the medium changes the frame by {change:.1%} (visibility {vis:.3g} m against a median depth of "
            f"{med:.3g} m): hardly visible; for a visible medium set medium.visibility: {nice:g}% "
            f"({nice / 100:g} times the median depth)")


def _hidden(y_in: np.ndarray, y_out: np.ndarray, cfg: Config, depth) -> str | None:
    """When the medium all but hides the frame (output mean luminance below 5 % of the
    input's, both grid_luminance), with the numbers that say why and the relative strength
    that would not."""
    l_in, l_out = float(y_in.mean(dtype=np.float64)), float(y_out.mean(dtype=np.float64))
    if not l_in > 0 or l_out >= 0.05 * l_in:
        return None
    try:
        med = f"{median_depth(depth, cfg.camera.max_depth):.3g} m"
    except UserError:
        med = "sky only"
    vis = cfg.medium.visibility if isinstance(cfg.medium.visibility, str) else f"{visibility_m(cfg.medium):.3g} m"
    return (f"the medium hides the scene: mean luminance {l_out / l_in:.1%} of the input's (visibility {vis} "
            f"against a median depth of {med}); for a strength relative to the scene, set medium.visibility: 200% (twice the median depth)")
