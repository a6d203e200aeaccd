"""EXR output that a compositing pipeline can take back: every part, view and channel of
the input EXR that fogcli does not produce is copied through with its pixel type, data and
display windows and attributes; the colour (and alpha) that fogcli read are replaced by its
result and the AOVs are added to that part. The processed part's channels come from the
pixels read for the frame when it kept them (up to inputs.KEEP_CHANNELS half/float
channels); every other part is streamed from the input in strips of scanlines (or tile
rows), so copying a many-channel file through costs no more memory than a strip."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fogcli.io import openimageio
from fogcli.io import pixels
from fogcli.errors import ProcessingError, UserError

# the old file's encoding, not the picture: dropped or rewritten by the writer
_ENCODING = ("openexr:chunkCount", "openexr:lineOrder", "oiio:subimages", "oiio:BitsPerSample",
             "tiledesc", "openexr:levelmode", "openexr:roundingmode", "textureformat", "wrapmodes")
_FLOATS = ("half", "float", "double")
STRIP = 64


def _fmt(t) -> str:
    return str(t)


def _strip_reader(inp, sub: int, spec, nch: int, fmt: str, kept: np.ndarray | None = None, out=None):
    """Yields (y0, y1, pixels (y1-y0, width, nch)) over the output window `out` (a spec;
    None: the part's data window), zero where the part has no data (io/windows.py)."""
    strips = _strips(inp, sub, spec, nch, fmt, kept)
    if out is None or (out.x, out.y, out.width, out.height) == (spec.x, spec.y, spec.width, spec.height):
        yield from strips
        return
    x0, end = spec.x - out.x, spec.y + spec.height
    zeros = lambda y0, y1, dt: np.zeros((y1 - y0, out.width, nch), dt)  # noqa: E731
    dt = np.float32 if fmt == "float" else np.float64
    for y0 in range(out.y, spec.y, STRIP):
        yield y0, min(y0 + STRIP, spec.y), zeros(y0, min(y0 + STRIP, spec.y), dt)
    for y0, y1, px in strips:
        full = zeros(y0, y1, px.dtype)
        full[:, x0:x0 + spec.width] = px
        yield y0, y1, full
    for y0 in range(end, out.y + out.height, STRIP):
        yield y0, min(y0 + STRIP, out.y + out.height), zeros(y0, min(y0 + STRIP, out.y + out.height), dt)


def _strips(inp, sub: int, spec, nch: int, fmt: str, kept: np.ndarray | None = None):
    """Yields (y0, y1, pixels (y1-y0, w, nch)) over the part's data window; tile rows for
    tiled files (OpenEXR refuses scanline access to them). kept: the part's pixels as the
    frame read them (Frame.pixels), sliced instead of decoded again."""
    ys, ye = spec.y, spec.y + spec.height
    step = spec.tile_height if spec.tile_width else STRIP
    for y0 in range(ys, ye, step):
        y1 = min(y0 + step, ye)
        if kept is not None:
            yield y0, y1, kept[y0 - ys:y1 - ys]
            continue
        if spec.tile_width:
            px = inp.read_tiles(sub, 0, spec.x, spec.x + spec.width, y0, y1, spec.z, spec.z + max(spec.depth, 1),
                                0, nch, fmt)
        else:
            inp.seek_subimage(sub, 0)
            px = inp.read_scanlines(sub, 0, y0, y1, spec.z, 0, nch, fmt)
        if px is None:
            raise UserError(f"{inp.geterror().strip().splitlines()[0] if inp.has_error else 'read failed'}")
        yield y0, y1, np.asarray(px).reshape(y1 - y0, spec.width, nch)


def _out_type(in_type: str, override: str) -> str:
    """A written channel's type: the input's, unless output.type names a float type."""
    return override if override in ("half", "float") and in_type in _FLOATS else in_type


def _part_plan(oiio, i: int, spec, views: list, out_type: str, compression: str):
    """Part i's output spec and (channels, the type it is read in, channel -> (frame or
    plane, its channel) that fogcli replaces, the AOV planes added after them). views:
    (frame, rgb, alpha, aovs) of each view fogcli made (a single-part stereo file has two
    on one part)."""
    names = list(spec.channelnames)
    in_fmts = [_fmt(t) for t in spec.channelformats] if len(spec.channelformats) else [_fmt(spec.format)] * len(names)
    o = oiio.ImageSpec(spec)
    for a in _ENCODING:
        o.erase_attribute(a)
    o.tile_width = o.tile_height = o.tile_depth = 0
    grown = [(f, rgb) for f, rgb, *_ in views if f.part == i and f.read_window]
    if grown:               # grown to the display window (io/windows.py)
        (o.x, o.y), (o.height, o.width) = grown[0][0].window, grown[0][1].shape[:2]
    replace: dict[int, tuple] = {}      # channel -> (frame or plane, its channel)
    extra_names, extra_planes = [], []
    for frame, rgb, alpha, aovs in views:
        if i != frame.part:
            continue
        for c, name in enumerate(frame.rgb_names):
            replace.setdefault(names.index(name), (rgb, c))
        if frame.alpha_name is not None and alpha is not None:
            replace[names.index(frame.alpha_name)] = (alpha, 0)
        for name, plane in aovs.items():
            full = frame.view_prefix + name
            if full in names:
                raise UserError(f"{frame.path}: has a channel {full}; --aov {name.split('.')[0]} would replace it")
            extra_names.append(full)
            extra_planes.append(plane)
    # output.type applies to what fogcli writes; copied channels keep their type exactly
    fmts = ([_out_type(f, out_type) if c in replace else f for c, f in enumerate(in_fmts)]
            + [out_type if out_type in ("half", "float") else "float"] * len(extra_names))
    o.nchannels = len(names) + len(extra_names)
    o.channelnames = tuple(names + extra_names)
    o.channelformats = tuple(oiio.TypeDesc(f) for f in fmts)
    o.attribute("compression", compression if compression != "auto" else
                str(spec.getattribute("compression") or "zip"))
    o.attribute("Software", "fogcli")
    read_fmt = "float" if all(f in _FLOATS for f in in_fmts) and not any(f == "double" for f in in_fmts) else "double"
    return o, (len(names), read_fmt, replace, extra_planes)


def _kept_columns(views: list, i: int, spec, nch: int, read_fmt: str, replace: dict):
    """(the channels the frame kept of part i, or None to read them again; the column of the
    strips each channel of the part is in: of the kept ones, only those not replaced). Two
    views on the part: each kept only its own, read again."""
    on = [v[0] for v in views if v[0].part == i]
    frame = on[0] if len(on) == 1 else None
    kept = frame.pixels if frame is not None and read_fmt == "float" else None
    if kept is not None and kept.shape != (spec.height, spec.width, len(frame.kept_channels)):
        kept = None
    if kept is not None:
        col = {c: k for k, c in enumerate(frame.kept_channels)}
        if any(c not in replace and c not in col for c in range(nch)):
            kept = None
    if kept is None:
        col = {c: c for c in range(nch)}
    return kept, col


def write_passthrough(path: Path, tmp: str, views: list, out_type: str, compression: str) -> None:
    """Write `tmp` (renamed to `path` by the caller): the input EXR with each processed
    view's colour (and alpha) replaced and its AOVs added to its part. views: (frame, rgb
    (h, w, 3), alpha or None, aovs) of each, the first the frame the file is named by."""
    oiio = openimageio.load()

    frame = views[0][0]

    inp = oiio.ImageInput.open(str(frame.path))
    if inp is None:
        raise ProcessingError(f"{frame.path}: cannot reopen the input to copy its other channels")
    try:
        specs = []
        i = 0
        while inp.seek_subimage(i, 0):
            specs.append(oiio.ImageSpec(inp.spec()))
            i += 1
        outs, plans = [], []
        for i, spec in enumerate(specs):
            o, plan = _part_plan(oiio, i, spec, views, out_type, compression)
            outs.append(o)
            plans.append(plan)
        out = oiio.ImageOutput.create(tmp)
        if out is None:
            raise ProcessingError(f"{path}: cannot write ({oiio.geterror().strip() or 'no EXR writer'})")
        if len(outs) > 1 and not out.supports("multiimage"):
            raise ProcessingError(f"{path}: this OpenImageIO cannot write multi-part EXR")
        ok = out.open(tmp, tuple(outs)) if len(outs) > 1 else out.open(tmp, outs[0])
        for i, (spec, o, (nch, read_fmt, replace, extra)) in enumerate(zip(specs, outs, plans)):
            if i > 0:
                ok = ok and out.open(tmp, o, "AppendSubimage")
            if not ok:
                break
            kept, col = _kept_columns(views, i, spec, nch, read_fmt, replace)
            # all half: handed over as half (converted faster here than by the writer)
            as_half = all(str(f) == "half" for f in o.channelformats)
            for y0, y1, px in _strip_reader(inp, i, spec, nch, read_fmt, kept, o):
                r0, r1 = y0 - o.y, y1 - o.y
                want = np.float16 if as_half else (np.float32 if px.dtype == np.float16 else px.dtype)
                if replace or extra:
                    # the strip in its written type, in one pass (OpenCV): the part's own
                    # channels, fogcli's in their place, the AOVs after them; each source
                    # sliced once (gather converts each array it is given once)
                    rows: dict = {}
                    strip = lambda a: rows.setdefault(id(a), a[r0:r1])  # noqa: E731
                    picks = [(strip(replace[c][0]), replace[c][1] if replace[c][0].ndim == 3 else 0)
                             if c in replace else (px, col[c]) for c in range(nch)]
                    px = pixels.gather(picks + [(strip(plane), 0) for plane in extra], want)
                else:
                    with np.errstate(over="ignore"):      # beyond 65504: inf, as the writer's own conversion
                        px = np.ascontiguousarray(px, dtype=want)
                if not out.write_scanlines(y0, y1, spec.z, px):
                    ok = False
                    break
        err = out.geterror()
        out.close()
        if not ok:
            raise ProcessingError(f"{path}: cannot write ({(err or 'write failed').strip().splitlines()[0]})")
    except UserError as exc:
        raise UserError(str(exc) if str(exc).startswith(str(frame.path)) else f"{frame.path}: {exc}") from None
    finally:
        inp.close()
