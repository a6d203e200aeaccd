"""An EXR's data window inside its display window. The camera (field of view, principal
point) describes the display window, and a render's data window is often a part of it (an
element's bounding box) or reaches past it (overscan). fogcli pads the frame with empty
pixels (colour 0, alpha 0: they look at camera.empty_depth, as a compositor's empty pixels)
to the union of the two windows, so that the light a medium scatters past the data window
lands in the display window, where a compositor would grow a blur's bounding box; and it
takes the camera's rays from the display window wherever the frame lies in it (camera_for).
Not less than the whole display window: in thick fog a small element's glow spreads over most
of the frame (tools/data_window.py: half the element's size around it held 11 % of it). The
output's data window is the grown one, or the input's with --keep-data-window (the same
pixels, cropped)."""
from __future__ import annotations

import dataclasses

import numpy as np

from fogcli.errors import UserError
from fogcli.io import pixels
from fogcli.io.images import MAX_PIXELS


def display_of(frame) -> tuple[int, int, int, int] | None:
    """The display window (x, y, width, height) the camera describes, or None: not an EXR,
    or a display window that cannot be the frame's (empty, or less than half the data
    window's width or height: a writer's placeholder)."""
    if not frame.is_exr:
        return None
    h, w = frame.shape
    fx, fy, fw, fh = frame.display
    if fw <= 0 or fh <= 0 or 2 * fw < w or 2 * fh < h:
        return None
    return fx, fy, fw, fh


def union(frame) -> tuple[int, int, int, int] | None:
    """(x, y, width, height) the data window grows to: its union with the display window;
    None where there is nothing to grow."""
    disp = display_of(frame)
    if disp is None:
        return None
    x, y = frame.window
    h, w = frame.shape
    fx, fy, fw, fh = disp
    x0, y0, x1, y1 = min(x, fx), min(y, fy), max(x + w, fx + fw), max(y + h, fy + fh)
    if (x0, y0, x1, y1) == (x, y, x + w, y + h):
        return None
    if (x1 - x0) * (y1 - y0) > MAX_PIXELS:
        raise UserError(f"{frame.path}: data window {w}x{h} at ({x}, {y}) grown to hold the display window {fw}x{fh} "
                        f"at ({fx}, {fy}) spans {x1 - x0}x{y1 - y0}, beyond fogcli's limit of {MAX_PIXELS / 1e6:.0f} MPx")
    return x0, y0, x1 - x0, y1 - y0


def camera_for(cam, frame, display: tuple | None = None):
    """The camera in the frame's own pixels: the focal length and principal point are the
    display window's (cx, cy given count from its top-left corner; intrinsics calibrated for
    another size are scaled to it), moved by where the frame's (grown) data window lies.
    The camera as given where the frame is its display window, or has none."""
    disp = display or display_of(frame)
    if disp is None:
        return cam
    fx, fy, fw, fh = disp
    ox, oy = frame.window
    c = cam.for_size(fw, fh)
    if (ox, oy) == (fx, fy) and tuple(frame.shape) == (fh, fw):
        return c
    cx, cy = c.centre(fw, fh)
    return c.model_copy(update=dict(focal_px=c.focal(fw), focal_px_y=c.focal_y(fw), cx=cx + fx - ox, cy=cy + fy - oy,
                                    calibrated_size=None))


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

    # the colour alone, in float32 (the part's other channels are copied from the file by
    # the writer): padding every channel of a many-channel part cost 6x the colour's memory
    rgb = frame._rgb if frame._rgb is not None else pixels.take(frame.source, frame.rgb_cols)
    grown = dataclasses.replace(
        frame, _rgb=pad(rgb, at, size), source=None, alpha=pad(alpha, at, size),
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
