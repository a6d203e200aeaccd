"""Reading inputs: the image (scene-linear RGB + alpha), its depth, and what the output
must keep of it (metadata, data and display windows). Everything goes through
OpenImageIO except NPY depth. Every failure is a UserError naming the file."""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fogcli.io import openimageio
from fogcli.io import pixels
from fogcli.io.quiet import quiet_stderr
from fogcli.io.colour import srgb_to_linear
from fogcli.errors import UserError
from fogcli.physics.limits import check_radiance

DEPTH_NAMES = ("z", "depth", "distance")


@dataclass
class Frame:
    """One input image as the pipeline needs it. A float EXR's colour stays in the pixels
    as read (`source`, columns `rgb_cols`) until it is asked for (rgb) or uploaded
    (colour()): the frame is not copied on the host on its way to the device."""

    path: Path
    _rgb: np.ndarray | None         # (h, w, 3) float32, scene-linear (the rgb property)
    alpha: np.ndarray | None        # (h, w) float32, untouched
    depth: np.ndarray | None        # (h, w) float32 raw values, embedded channel if any
    window: tuple = (0, 0)          # data window origin (x, y)
    display: tuple = (0, 0, 0, 0)   # display window (x, y, width, height)
    attributes: list = field(default_factory=list)  # (name, type, value) passed through
    is_exr: bool = False
    # where the colour came from, for an EXR output that keeps everything else (exr_out)
    part: int = 0                   # subimage index
    rgb_names: tuple = ()           # the part's channel names read as R, G, B
    alpha_name: str | None = None
    view_prefix: str = ""           # "right." when a non-default view of a single-part file
    view: str = ""                  # the view read (multi-view EXR), else ""
    read_window: tuple = ()         # (x, y, w, h) as read, when grown to the display window (io/windows.py)
    alpha_added: bool = False       # the alpha is the padding's (the file has none): not written
    display_referred: bool = False  # decoded from an sRGB / gamma image: nothing above white
    pixel_type: str = "float"       # the colour channels' type in the file (half, float, uint8...)
    # the part's channels that fogcli does not replace (kept_channels, in the part's order) as
    # read (float16 where all are half, else float32; exact for half and float files of up to
    # KEEP_CHANNELS channels): the EXR output copies them from here, not from a second decode
    pixels: np.ndarray | None = None
    kept_channels: tuple = ()
    source: np.ndarray | None = None    # the part as read, while its colour is not made
    rgb_cols: tuple = ()                # the columns of source that are R, G, B

    @property
    def rgb(self) -> np.ndarray:
        """(h, w, 3) float32 scene-linear colour; a float EXR's is made (and checked) when
        first asked for."""
        if self._rgb is None and self.source is not None:
            rgb = pixels.take(self.source, self.rgb_cols)
            check_radiance(rgb, str(self.path))
            self._rgb, self.source = rgb, None
        return self._rgb

    @rgb.setter
    def rgb(self, value) -> None:
        self._rgb, self.source = value, None

    @property
    def shape(self) -> tuple:
        """(height, width)."""
        return (self._rgb if self._rgb is not None else self.source).shape[:2]

    def colour(self) -> np.ndarray:
        """The colour as held, to be read once (an upload): rgb where it is made, else the
        columns of the pixels as read (a view where they are a run; half or float; not
        checked: limits.check_radiance on what it is packed into)."""
        if self._rgb is not None or self.source is None:
            return self._rgb
        return pixels.columns(self.source, self.rgb_cols)


KEEP_CHANNELS = 8


def check_regular(path: Path, what: str = "an image file") -> None:
    """Exists and is a regular file (a FIFO or a device would block or never end)."""
    if not path.exists():
        raise UserError(f"{path}: file not found")
    if path.is_dir():
        raise UserError(f"{path}: is a directory, expected {what}")
    if not path.is_file():
        raise UserError(f"{path}: not a regular file (a pipe or a device), expected {what}")


# Frames larger than this are refused before any pixel is read (a header may claim any
# size): one float4 plane of it is 2 GiB, PoCL's largest single allocation.
MAX_PIXELS = 2**31 // 16


def _check_size(path: Path, inp, admit=None) -> None:
    """Every part within fogcli's limits; admit(path, width, height, channels, bytes a
    sample) refuses the largest part when the frame would need more memory than it may have
    (memory.admit), all before a pixel is read."""
    i, largest = 0, None
    while inp.seek_subimage(i, 0):
        s = inp.spec()
        if s.width <= 0 or s.height <= 0 or s.nchannels <= 0:
            raise UserError(f"{path}: empty image ({s.width}x{s.height}, {s.nchannels} channels)")
        if s.width * s.height > MAX_PIXELS or s.width * s.height * s.nchannels > 8 * MAX_PIXELS:
            raise UserError(f"{path}: {s.width}x{s.height} with {s.nchannels} channels is beyond fogcli's limit "
                            f"of {MAX_PIXELS / 1e6:.0f} MPx (a 2 GiB float4 device buffer) and {8 * MAX_PIXELS / 1e6:.0f} M samples")
        size = (s.width * s.height * s.nchannels, s.width, s.height, s.nchannels, 2 if str(s.format) == "half" else 4)
        largest = max(largest or size, size)
        i += 1
    inp.seek_subimage(0, 0)
    inp.geterror()
    if admit is not None and largest is not None:
        admit(str(path), *largest[1:])


def _open(path: Path, admit=None):
    oiio = openimageio.load()
    check_regular(path)
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        msg = oiio.geterror().strip().splitlines()
        raise UserError(f"{path}: cannot read image ({msg[0] if msg else 'unknown format'})")
    try:
        _check_size(path, inp, admit)
    except BaseException:
        inp.close()
        raise
    return inp


RAW_EXT = {".dng", ".cr2", ".cr3", ".nef", ".arw", ".raf", ".orf", ".rw2", ".pef", ".srw", ".raw", ".3fr",
           ".iiq", ".erf", ".kdc", ".mrw", ".nrw", ".x3f"}
# the layer a compositor calls the beauty, before any other layer with R, G, B
_BEAUTY = ("", "combined", "beauty", "rgba", "c", "main", "color", "colour")


def _read_pixels(inp, path: Path, fmt: str, subimage: int = 0):
    inp.seek_subimage(subimage, 0)      # read_image(subimage, ...) alone reads the current one
    spec = inp.spec()
    try:
        px = inp.read_image(subimage, 0, 0, spec.nchannels, fmt)
    except Exception as exc:  # OIIO raises on some truncations, returns None on others
        px = None
        err = str(exc)
    else:
        err = openimageio.load().geterror() if px is None else ""
    if px is None or (hasattr(inp, "has_error") and inp.has_error):
        detail = (err or inp.geterror() or "read failed").strip().splitlines()
        inp.close()
        raise UserError(f"{path}: cannot read pixels, the file is truncated or corrupt ({detail[0] if detail else ''})")
    px = np.asarray(px)
    if px.ndim == 2:
        px = px[:, :, None]
    return px.reshape(spec.height, spec.width, spec.nchannels)


def _is_depth_name(name: str) -> bool:
    """Z, depth, distance, Pz, and a layer's Z / depth channel (Nuke depth.Z, Blender
    ViewLayer.Depth.Z, Houdini Pz or Pz.Y), but not the Z component of normals or positions
    (Normal.Z, P.Z)."""
    n = name.lower()
    parts = n.split(".")
    last, layer = parts[-1], (parts[-2] if len(parts) > 1 else "")
    if last in ("depth", "distance", "zdepth", "pz") or n.endswith("depth"):
        return True
    if layer in ("pz", "depth", "zdepth", "distance"):     # a one-channel layer: Pz.Y, depth.V
        return last in ("z", "y", "v", "r")
    return last == "z" and layer in ("", "z")


def _is_alpha_name(name: str) -> bool:
    return name.lower().rsplit(".", 1)[-1] in ("a", "alpha")


def _colour_channels(names: list[str]) -> tuple[list[int], int | None]:
    """Indices of R, G, B (plain, else the beauty layer, else the first layer that has all
    three; full names like red/green/blue count) and alpha."""
    low = [n.lower() for n in names]
    prefixes = {n.rsplit(".", 1)[0] + "." for n in low if "." in n}
    order = sorted(prefixes, key=lambda p: (p.rstrip(".").rsplit(".", 1)[-1] not in _BEAUTY, p))
    for prefix in [""] + order:
        for rgb, a in (("rgb", "a"), (("red", "green", "blue"), "alpha")):
            idx = [low.index(prefix + c) if prefix + c in low else -1 for c in rgb]
            if min(idx) >= 0:
                ai = low.index(prefix + a) if prefix + a in low else None
                return idx, ai
    return [], None


def _is_linear(spec, fmt_name: str) -> bool:
    if fmt_name in ("half", "float", "double"):
        return True
    cs = str(spec.getattribute("oiio:ColorSpace") or "").lower()
    return ("lin" in cs or cs in ("scene_linear", "acescg", "aces")) and "srgb" not in cs


def _to_linear(rgb: np.ndarray, spec, fmt_name: str) -> np.ndarray:
    """Integer images are sRGB unless their metadata says linear or a plain gamma
    (OpenImageIO reports a PNG gAMA chunk as e.g. g22_rec709)."""
    if _is_linear(spec, fmt_name):
        return rgb
    cs = str(spec.getattribute("oiio:ColorSpace") or "").lower()
    m = re.match(r"g(\d)(\d)_", cs)
    if m:
        return np.power(np.clip(rgb, 0, None), float(f"{m.group(1)}.{m.group(2)}")).astype(np.float32)
    return srgb_to_linear(rgb)


def _parts(inp) -> list:
    """(index, spec, part name, view) of every subimage."""
    out, i = [], 0
    while inp.seek_subimage(i, 0):
        spec = inp.spec()
        name = str(spec.getattribute("oiio:subimagename") or spec.getattribute("name") or "")
        out.append((i, spec, name, str(spec.getattribute("view") or "")))
        i += 1
    inp.seek_subimage(0, 0)
    inp.geterror()      # the failed seek past the last part leaves an error set: clear it
    return out


def _multiview(spec) -> list[str]:
    views = spec.getattribute("multiView")
    return [str(v) for v in views] if views is not None and not isinstance(views, str) else ([views] if views else [])


def _view_channels(names: list[str], spec, view: str | None, path: Path) -> list[int]:
    """Channels of one view of a single-part multi-view EXR: the default (first) view's are
    unprefixed, every other view's carry the view name as their first component."""
    views = _multiview(spec)
    if not views:
        if view:
            raise UserError(f"{path}: --view {view}: the file has no views")
        return list(range(len(names)))
    view = view or views[0]
    if view not in views:
        raise UserError(f"{path}: --view {view}: no such view (have: {', '.join(views)})")
    others = [v for v in views if v != view]
    if view == views[0]:
        return [i for i, n in enumerate(names) if n.split(".", 1)[0] not in others]
    return [i for i, n in enumerate(names) if n.startswith(view + ".")]


def _decoding(fn):
    """One UserError naming the file for whatever a corrupt file makes a decoder raise
    (undecodable attribute strings, library exceptions), with the libraries kept quiet."""
    @functools.wraps(fn)
    def wrapper(path, *a, **kw):
        with quiet_stderr():
            try:
                return fn(path, *a, **kw)
            except (UserError, MemoryError):
                raise
            except Exception as exc:
                first = (str(exc).strip().splitlines() or [""])[0][:160]
                raise UserError(f"{path}: cannot read, the file is corrupt ({exc.__class__.__name__}: {first})") from None
    return wrapper


def _colour_part(inp, parts: list, path: Path, layer: str | None, view: str | None):
    """Of a multi-part file: (the parts of the chosen view, those named --layer, the part
    the colour is read from: the one named --layer, else the first with R, G, B, else the
    first)."""
    chosen = [p for p in parts if not view or p[3] in ("", view)]
    if view and len(parts) > 1 and not any(p[3] == view for p in parts):
        have = sorted({p[3] for p in parts if p[3]})
        if have:
            inp.close()
            raise UserError(f"{path}: --view {view}: no such view (have: {', '.join(have)})")
    by_name = [p for p in chosen if layer and p[2] == layer]
    with_rgb = [p for p in chosen if _colour_channels(list(p[1].channelnames))[0]]
    return chosen, by_name, (by_name or with_rgb or chosen)[0]    # a depth-only part may come first


def _channel_layer(inp, parts: list, path: Path, layer: str, cols: list, orig: list, sel_names: list):
    """--layer naming a channel layer (Blender ViewLayer.Combined, Nuke diffuse): its R, G,
    B, A and the depth, as (columns, the file's names, the names without the layer)."""
    pre = [n for n in {n.rsplit(".", 1)[0] for n in sel_names if "." in n}
           if n == layer or n.endswith("." + layer)]
    if not pre:
        layers = sorted({n.rsplit(".", 1)[0] for n in sel_names if "." in n} | {p[2] for p in parts if p[2]})
        inp.close()
        raise UserError(f"{path}: --layer {layer}: no such layer (have: {', '.join(layers) or 'none'})")
    lay = [i for i, n in enumerate(sel_names) if n.rsplit(".", 1)[0] == pre[0]]
    depth_cols = [i for i, n in enumerate(sel_names) if _is_depth_name(n)]
    pick = lay + [i for i in depth_cols if i not in lay]
    return ([cols[i] for i in pick], [orig[i] for i in pick],
            [sel_names[i].rsplit(".", 1)[-1] if i in lay else sel_names[i] for i in pick])


def _depth_part(inp, path: Path, chosen: list, sub: int, spec):
    """The depth of a part of its own (Nuke and others write the depth layer so), or None."""
    for i, ps, _, pv in chosen:
        if i == sub or (ps.width, ps.height, ps.x, ps.y) != (spec.width, spec.height, spec.x, spec.y):
            continue
        cand = [k for k, n in enumerate(ps.channelnames) if _is_depth_name(n)]
        if cand:
            return pixels.plane(_read_pixels(inp, path, "float", i), cand[0])
    return None


def _grey(path: Path, names: list, sel_names: list, depth_idx) -> tuple[list, int | None]:
    """No R, G, B: (colour channels, alpha) of a grey channel (Y, L, an unnamed one), never
    alpha, depth, or a component of a vector pass."""
    colour = [i for i, n in enumerate(sel_names)
              if i != depth_idx and not _is_depth_name(n) and not _is_alpha_name(n)]
    if not colour:
        raise UserError(f"{path}: no colour channels (have: {', '.join(names)}); expected R, G, B "
                        "(or a layer's R, G, B, or one grey channel)")
    rgb_idx = colour[:3] if len(colour) >= 3 else [colour[0]] * 3
    a_idx = next((i for i, n in enumerate(sel_names) if _is_alpha_name(n)), None)
    if a_idx is None and len(sel_names) in (2, 4) and depth_idx is None and len(colour) == len(sel_names):
        a_idx = len(sel_names) - 1      # grey + alpha, RGBA, by position when unnamed
        rgb_idx = [i if i != a_idx else rgb_idx[0] for i in rgb_idx]
    return rgb_idx, a_idx


@_decoding
def read_image(path: str | Path, layer: str | None = None, view: str | None = None, admit=None) -> Frame:
    """admit: called with the path, width, height, channels and bytes a sample from the
    header, before any pixel is read (memory.admit: refuses what would not fit)."""
    path = Path(path)
    if path.suffix.lower() in (".npy",):
        raise UserError(f"{path}: an image is expected here (EXR, TIFF, PNG, JPEG, HDR, RAW), not NPY")
    if path.suffix.lower() in RAW_EXT:
        if layer or view:
            raise UserError(f"{path}: --layer / --view apply to EXR files, not camera RAW")
        return read_raw(path, admit)
    inp = _open(path, admit)
    parts = _parts(inp)
    is_exr = inp.format_name() == "openexr"
    if (layer or view) and not is_exr:
        inp.close()
        raise UserError(f"{path}: --layer / --view apply to EXR files")
    chosen, by_name, (sub, spec, _, _) = _colour_part(inp, parts, path, layer, view)
    formats = [str(t) for t in spec.channelformats] if len(spec.channelformats) else [str(spec.format)] * spec.nchannels
    # an all-half part is read as it is stored (half the bytes; only what is used is widened)
    whole = _read_pixels(inp, path, "half" if set(formats) == {"half"} else "float", sub)
    names = list(spec.channelnames)
    keep = _view_channels(names, spec, view, path) if len(parts) == 1 else list(range(len(names)))
    sel_names = [names[i] for i in keep]
    if len(parts) == 1 and view:
        sel_names = [n[len(view) + 1:] if n.startswith(view + ".") else n for n in sel_names]
    cols = list(keep)                     # the columns of `whole` that the selected channels are
    orig = [names[i] for i in keep]       # the file's names of the selected channels
    if layer and not by_name:
        cols, orig, sel_names = _channel_layer(inp, parts, path, layer, cols, orig, sel_names)
    attributes = [(a.name, a.type, a.value) for a in spec.extra_attribs]
    fmt_name = str(spec.format)

    rgb_idx, a_idx = _colour_channels(sel_names)
    depth_idx = next((i for i, n in enumerate(sel_names) if _is_depth_name(n) and i not in rgb_idx), None)
    depth = pixels.plane(whole, cols[depth_idx]) if depth_idx is not None else None
    if depth is None and len(parts) > 1:
        depth = _depth_part(inp, path, chosen, sub, spec)
    inp.close()
    if not rgb_idx:
        rgb_idx, a_idx = _grey(path, names, sel_names, depth_idx)
    rgb_cols = tuple(cols[i] for i in rgb_idx)
    if _is_linear(spec, fmt_name):
        rgb = None          # made when asked for (Frame.rgb), or read once by the upload
    else:
        rgb = _to_linear(pixels.take(whole, rgb_cols), spec, fmt_name)
        check_radiance(rgb, str(path))
    alpha = None
    if a_idx is not None:
        # premultiplied coverage in [0, 1]; NaN (no coverage information) counts as opaque
        alpha = pixels.plane(whole, cols[a_idx])
        alpha = np.clip(np.nan_to_num(alpha, nan=1.0, posinf=1.0, neginf=0.0, copy=False), 0.0, 1.0, out=alpha)
    keep_all = is_exr and len(names) <= KEEP_CHANNELS and all(f in ("half", "float") for f in formats)
    replaced = {names.index(orig[i]) for i in rgb_idx} | ({names.index(orig[a_idx])} if a_idx is not None else set())
    kept = tuple(c for c in range(len(names)) if c not in replaced)
    prefix = view + "." if (len(parts) == 1 and view and any(n.startswith(view + ".") for n in names)) else ""
    read_view = (view or (_multiview(spec) or [""])[0]) if len(parts) == 1 else parts[sub][3]
    return Frame(path, rgb, alpha, depth, (spec.x, spec.y),
                 (spec.full_x, spec.full_y, spec.full_width, spec.full_height), attributes, is_exr,
                 part=sub, rgb_names=tuple(orig[i] for i in rgb_idx),
                 alpha_name=orig[a_idx] if a_idx is not None else None, view_prefix=prefix, view=read_view,
                 pixel_type=formats[names.index(orig[rgb_idx[0]])],
                 pixels=np.ascontiguousarray(whole[:, :, list(kept)]) if keep_all else None, kept_channels=kept,
                 source=whole if rgb is None else None, rgb_cols=rgb_cols, display_referred=rgb is not None)


@_decoding
def views(path: str | Path) -> list[str]:
    """The views of a multi-view EXR (single-part: its multiView list, the default view
    first; multi-part: the parts' `view` attributes in part order); [] for any other file."""
    if (path := Path(path)).suffix.lower() in RAW_EXT | {".npy"}:
        return []
    inp = _open(path)
    try:
        parts = _parts(inp) if inp.format_name() == "openexr" else []
        return _multiview(parts[0][1]) if len(parts) == 1 else list(dict.fromkeys(p[3] for p in parts if p[3]))
    finally:
        inp.close()


@_decoding
def read_raw(path: Path, admit=None) -> Frame:
    """Camera RAW through rawpy/LibRaw, kept linear in light: LibRaw's AHD demosaic, the
    camera's white balance, no auto-brightening, gamma 1, 16 bit, sRGB primaries, scaled to
    [0, 1] of the white level (no highlight reconstruction beyond it)."""
    import rawpy

    check_regular(path)
    try:
        with rawpy.imread(str(path)) as raw:
            if admit is not None:       # 16-bit RGB, then float
                admit(str(path), raw.sizes.width, raw.sizes.height, 3, 2)
            px = raw.postprocess(use_camera_wb=True, no_auto_bright=True, gamma=(1, 1),
                                 output_bps=16, output_color=rawpy.ColorSpace.sRGB)
    except UserError:
        raise
    except (rawpy.LibRawError, OSError, ValueError) as exc:
        raise UserError(f"{path}: cannot read camera RAW ({exc.__class__.__name__}: {exc})") from None
    rgb = np.ascontiguousarray(px.astype(np.float32) / 65535.0)
    h, w = rgb.shape[:2]
    return Frame(path, rgb, None, None, (0, 0), (0, 0, w, h), [], False)


@_decoding
def read_depth(path: str | Path, view: str | None = None) -> np.ndarray | None:
    """Raw depth values of a separate depth file (EXR, TIFF, PNG16, NPY). view: that view's
    depth of a multi-view EXR (`right.Z`), None where the file has none."""
    path = Path(path)
    if view is not None and path.suffix.lower() != ".exr":
        return None
    if path.suffix.lower() == ".npy":
        check_regular(path, "a depth file")
        try:
            arr = np.load(path, allow_pickle=False, mmap_mode="r")
            if arr.size > MAX_PIXELS:
                raise UserError(f"{path}: {arr.shape} is beyond fogcli's limit of {MAX_PIXELS / 1e6:.0f} MPx")
            arr = np.array(arr)
        except UserError:
            raise
        except Exception as exc:
            raise UserError(f"{path}: cannot read NPY depth ({exc.__class__.__name__}: {exc})") from None
        if arr.ndim == 3 and arr.shape[2] == 1:
            arr = arr[:, :, 0]
        if (arr.ndim != 2 or arr.size == 0 or not np.issubdtype(arr.dtype, np.number)
                or np.issubdtype(arr.dtype, np.complexfloating)):
            raise UserError(f"{path}: expected a non-empty 2-D real array of depths, got shape {arr.shape} {arr.dtype}")
        if np.issubdtype(arr.dtype, np.integer):
            return np.ascontiguousarray(arr)
        with np.errstate(over="ignore"):
            return np.ascontiguousarray(arr, dtype=np.float32)     # beyond float32: inf, i.e. sky

    inp = _open(path)
    parts = _parts(inp)
    sub, spec = parts[0][0], parts[0][1]
    if view is not None and len(parts) > 1:        # the view's own part
        mine = [p for p in parts if p[3] == view]
        if not mine:
            inp.close()
            return None
        sub, spec = mine[0][0], mine[0][1]
    fmt_name = str(spec.format)
    # integer files hold depth codes (mm, or depth_scale units): read them unnormalised
    read_fmt = fmt_name if fmt_name in ("uint8", "uint16", "uint32", "int16", "int32") else "float"
    px = _read_pixels(inp, path, read_fmt, sub)
    names = list(spec.channelnames)
    inp.close()
    named = [i for i, n in enumerate(names) if _is_depth_name(n)]
    if view is not None and len(parts) == 1:       # the view's channels: the default view's unprefixed
        own = _view_channels(names, spec, view, path) if view in _multiview(spec) else []
        named = [i for i in own if _is_depth_name(names[i].removeprefix(view + "."))]
    if view is not None and not named:
        return None
    vector = [n for n in names if "." in n and n.rsplit(".", 1)[1].lower() in ("x", "y", "z", "u", "v", "w")]
    if named:
        ch = named[0]
    elif vector:        # a normal, position or motion pass is never a depth, whatever its channel count
        raise UserError(f"{path}: {', '.join(names)} is a vector pass (normals, positions), not depth; expected Z, "
                        "*.Z, *depth or a single channel")
    elif spec.nchannels == 1:
        ch = 0
    elif spec.nchannels == 2 or (spec.nchannels >= 3 and np.array_equal(px[:, :, 0], px[:, :, 1])
                                 and np.array_equal(px[:, :, 0], px[:, :, 2])):
        ch = 0  # grey + alpha, or a grey image saved as RGB(A)
    else:
        raise UserError(f"{path}: no usable depth channel (expected Z, *.Z, *depth or a single channel; have: {', '.join(names)})")
    plane = px[:, :, ch]
    # integer codes keep their type (camera.depth_scale: auto reads 16-bit as millimetres)
    return np.ascontiguousarray(plane if np.issubdtype(plane.dtype, np.integer) else plane.astype(np.float32))
