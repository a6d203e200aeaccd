"""An EXR's data window inside its display window. The camera (field of view, principal
point) describes the display window, and a render's data window is often a part of it (an
element's bounding box) or reaches past it (overscan). fogcli works on the union of the two:
the frame is padded with empty pixels (colour 0, alpha 0: they look at camera.empty_depth,
as a compositor's empty pixels), so that the camera's rays are the display window's and the
light a medium scatters past the data window lands in the display window, where a
compositor would grow a blur's bounding box. The output's data window is that union, or the
input's with --keep-data-window (the same pixels, cropped)."""
from __future__ import annotations

import dataclasses

import numpy as np

from fogcli.errors import UserError
from fogcli.io.images import MAX_PIXELS


def union(frame) -> tuple[int, int, int, int] | None:
    """(x, y, width, height) of the data window grown to hold the display window, or None
    where the display window is within the data window (nothing to grow)."""
    if not frame.is_exr:
        return None
    x, y = frame.window
    h, w = frame.shape
    fx, fy, fw, fh = frame.display
    if fw <= 0 or fh <= 0:
        return None
    x0, y0, x1, y1 = min(x, fx), min(y, fy), max(x + w, fx + fw), max(y + h, fy + fh)
    if (x0, y0, x1, y1) == (x, y, x + w, y + h):
        return None
    if (x1 - x0) * (y1 - y0) > MAX_PIXELS:
        raise UserError(f"{frame.path}: data window {w}x{h} at ({x}, {y}) and display window {fw}x{fh} at ({fx}, {fy}) "
                        f"span {x1 - x0}x{y1 - y0}, beyond fogcli's limit of {MAX_PIXELS / 1e6:.0f} MPx; "
                        "--keep-data-window does not help: the camera is the display window's")
    return x0, y0, x1 - x0, y1 - y0


def pad(a: np.ndarray | None, at: tuple, size: tuple, value=0.0) -> np.ndarray | None:
    """a (h, w[, c]) placed at (column, row) `at` of an array of `size` (height, width)
    filled with value."""
    if a is None:
        return None
    out = np.full(size + a.shape[2:], value, a.dtype)
    out[at[1]:at[1] + a.shape[0], at[0]:at[0] + a.shape[1]] = a
    return out


def grow(frame, depth: np.ndarray | None = None):
    """(the frame on the union of its data and display windows, depth padded alike when it
    has the data window's size, else as given). The frame keeps the window it was read with
    (read_window) and an alpha (ones where it had none: the padding is empty, not a black
    wall at the depth of its neighbours; alpha_added says not to write it)."""
    box = union(frame)
    if box is None:
        return frame, depth
    ux, uy, uw, uh = box
    x, y = frame.window
    h, w = frame.shape
    at, size = (x - ux, y - uy), (uh, uw)
    alpha = frame.alpha if frame.alpha is not None else np.ones((h, w), np.float32)

    def pad_depth(d):       # 0: no measurement, as a file's own padding (alpha 0 makes it empty)
        return d if d is None or d.shape[:2] != (h, w) else pad(d, at, size)

    grown = dataclasses.replace(
        frame, _rgb=pad(frame._rgb, at, size), source=pad(frame.source, at, size), alpha=pad(alpha, at, size),
        depth=pad_depth(frame.depth), window=(ux, uy), pixels=None,
        read_window=(x, y, w, h), alpha_added=frame.alpha is None)
    return grown, pad_depth(depth)


def crop(a: np.ndarray | None, frame) -> np.ndarray | None:
    """Of a result (h, w[, c]) on the grown frame, the pixels of the data window it was read with."""
    if a is None or not frame.read_window:
        return a
    x, y, w, h = frame.read_window
    ox, oy = frame.window
    return a[y - oy:y - oy + h, x - ox:x - ox + w]


def as_read(frame):
    """The frame with the data window it was read with (--keep-data-window)."""
    if not frame.read_window:
        return frame
    x, y, _, _ = frame.read_window
    return dataclasses.replace(frame, window=(x, y), read_window=(), depth=crop(frame.depth, frame))
