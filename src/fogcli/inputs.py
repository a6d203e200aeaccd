"""Reading inputs: the image (scene-linear RGB + alpha), its depth, and what the output
must keep of it (metadata, data and display windows). Everything goes through
OpenImageIO except NPY depth. Every failure is a UserError naming the file."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .colour import srgb_to_linear
from .errors import UserError

DEPTH_NAMES = ("z", "depth", "distance")


def _oiio():
    import OpenImageIO as oiio

    return oiio


@dataclass
class Frame:
    """One input image as the pipeline needs it."""

    path: Path
    rgb: np.ndarray                 # (h, w, 3) float32, scene-linear
    alpha: np.ndarray | None        # (h, w) float32, untouched
    depth: np.ndarray | None        # (h, w) float32 raw values, embedded channel if any
    window: tuple = (0, 0)          # data window origin (x, y)
    display: tuple = (0, 0, 0, 0)   # display window (x, y, width, height)
    attributes: list = field(default_factory=list)  # (name, type, value) passed through
    is_exr: bool = False


def _open(path: Path):
    oiio = _oiio()
    if not path.exists():
        raise UserError(f"{path}: file not found")
    if path.is_dir():
        raise UserError(f"{path}: is a directory, expected an image file")
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        msg = oiio.geterror().strip().splitlines()
        raise UserError(f"{path}: cannot read image ({msg[0] if msg else 'unknown format'})")
    return inp


def _read_pixels(inp, path: Path, fmt: str):
    spec = inp.spec()
    try:
        px = inp.read_image(0, 0, 0, spec.nchannels, fmt)
    except Exception as exc:  # OIIO raises on some truncations, returns None on others
        px = None
        err = str(exc)
    else:
        err = _oiio().geterror() if px is None else ""
    if px is None or (hasattr(inp, "has_error") and inp.has_error):
        detail = (err or inp.geterror() or "read failed").strip().splitlines()
        inp.close()
        raise UserError(f"{path}: cannot read pixels, the file is truncated or corrupt ({detail[0] if detail else ''})")
    px = np.asarray(px)
    if px.ndim == 2:
        px = px[:, :, None]
    return px.reshape(spec.height, spec.width, spec.nchannels)


def _is_depth_name(name: str) -> bool:
    n = name.lower()
    last = n.rsplit(".", 1)[-1]
    return last in DEPTH_NAMES or n.endswith("depth")


def _colour_channels(names: list[str]) -> tuple[list[int], int | None]:
    """Indices of R, G, B (plain or of the first layer that has all three) and alpha."""
    low = [n.lower() for n in names]
    for prefix in [""] + sorted({n.rsplit(".", 1)[0] + "." for n in low if "." in n}):
        idx = [low.index(prefix + c) if prefix + c in low else -1 for c in "rgb"]
        if min(idx) >= 0:
            a = low.index(prefix + "a") if prefix + "a" in low else None
            return idx, a
    return [], None


def _is_linear(spec, fmt_name: str) -> bool:
    if fmt_name in ("half", "float", "double"):
        return True
    cs = str(spec.getattribute("oiio:ColorSpace") or "").lower()
    return ("lin" in cs or cs in ("scene_linear", "acescg", "aces")) and "srgb" not in cs


def read_image(path: str | Path) -> Frame:
    path = Path(path)
    if path.suffix.lower() in (".npy",):
        raise UserError(f"{path}: an image is expected here (EXR, TIFF, PNG, JPEG, HDR), not NPY")
    inp = _open(path)
    spec = inp.spec()
    fmt_name = str(spec.format)
    px = _read_pixels(inp, path, "float")
    names = list(spec.channelnames)
    attributes = [(a.name, a.type, a.value) for a in spec.extra_attribs]
    is_exr = inp.format_name() == "openexr"
    inp.close()

    rgb_idx, a_idx = _colour_channels(names)
    depth_idx = next((i for i, n in enumerate(names) if _is_depth_name(n) and i not in rgb_idx), None)
    if rgb_idx:
        rgb = px[:, :, rgb_idx]
    elif spec.nchannels in (1, 2):
        grey = [i for i in range(spec.nchannels) if i != depth_idx][:1] or [0]
        rgb = np.repeat(px[:, :, grey], 3, axis=2)
        a_idx = 1 if spec.nchannels == 2 and depth_idx is None else None
    elif spec.nchannels >= 3:
        rgb = px[:, :, :3]
        a_idx = 3 if spec.nchannels >= 4 and 3 != depth_idx else None
    else:
        raise UserError(f"{path}: no colour channels (have: {', '.join(names)})")
    rgb = np.ascontiguousarray(rgb, dtype=np.float32)
    if not _is_linear(spec, fmt_name):
        rgb = srgb_to_linear(rgb)
    if not np.isfinite(rgb).all():
        bad = int((~np.isfinite(rgb)).any(axis=2).sum())
        raise UserError(f"{path}: {bad} pixel(s) hold NaN or infinite colour values")
    alpha = np.ascontiguousarray(px[:, :, a_idx], dtype=np.float32) if a_idx is not None else None
    depth = np.ascontiguousarray(px[:, :, depth_idx], dtype=np.float32) if depth_idx is not None else None
    return Frame(path, rgb, alpha, depth, (spec.x, spec.y),
                 (spec.full_x, spec.full_y, spec.full_width, spec.full_height), attributes, is_exr)


def read_depth(path: str | Path) -> np.ndarray:
    """Raw depth values of a separate depth file (EXR, TIFF, PNG16, NPY)."""
    path = Path(path)
    if path.suffix.lower() == ".npy":
        if not path.is_file():
            raise UserError(f"{path}: file not found")
        try:
            arr = np.load(path, allow_pickle=False)
        except Exception as exc:
            raise UserError(f"{path}: cannot read NPY depth ({exc.__class__.__name__}: {exc})") from None
        if arr.ndim == 3 and arr.shape[2] == 1:
            arr = arr[:, :, 0]
        if arr.ndim != 2 or not np.issubdtype(arr.dtype, np.number):
            raise UserError(f"{path}: expected a 2-D numeric array of depths, got shape {arr.shape} {arr.dtype}")
        return np.ascontiguousarray(arr, dtype=np.float32)

    inp = _open(path)
    spec = inp.spec()
    fmt_name = str(spec.format)
    # integer files hold depth codes (mm, or depth_scale units): read them unnormalised
    read_fmt = fmt_name if fmt_name in ("uint8", "uint16", "uint32", "int16", "int32") else "float"
    px = _read_pixels(inp, path, read_fmt)
    names = list(spec.channelnames)
    inp.close()
    named = [i for i, n in enumerate(names) if _is_depth_name(n)]
    if named:
        ch = named[0]
    elif spec.nchannels == 1:
        ch = 0
    elif spec.nchannels == 2 or (spec.nchannels >= 3 and np.array_equal(px[:, :, 0], px[:, :, 1])
                                 and np.array_equal(px[:, :, 0], px[:, :, 2])):
        ch = 0  # grey + alpha, or a grey image saved as RGB(A)
    else:
        raise UserError(f"{path}: no usable depth channel (expected Z, *.Z, *depth or a single channel; have: {', '.join(names)})")
    return np.ascontiguousarray(px[:, :, ch], dtype=np.float32)
