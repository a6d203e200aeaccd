"""Whole-frame conversions and channel moves on the host, exact to the bit, through OpenCV:
its SIMD loops are 5-10x numpy's for the 3- and 4-channel layouts of a frame (numpy walks
a 3- or 4-long innermost axis one pixel at a time, and widens half floats without F16C;
benchmarks/host_copies.py measures both). Anything OpenCV cannot take (more than 4 channels, non-contiguous views) goes through
numpy, with the same result."""
from __future__ import annotations

import numpy as np


def _cv2():
    import cv2

    return cv2


def widen(px: np.ndarray) -> np.ndarray:
    """float16 (h, w, c) as float32 (NaN, inf and subnormals kept); other types unchanged."""
    if px.dtype != np.float16:
        return px
    if px.ndim == 3 and px.flags.c_contiguous and px.size:
        return _convert(px, _cv2().CV_32F)
    return px.astype(np.float32)


def _convert(px: np.ndarray, depth: int) -> np.ndarray:
    # as one wide channel: OpenCV's single-channel loop is the vectorised one (4 ms at 2 MPx
    # RGBZ, against 12 ms through its 4-channel loop)
    h = px.shape[0]
    return _cv2().multiply(px.reshape(h, -1), 1.0, dtype=depth).reshape(px.shape)


def take(px: np.ndarray, idx) -> np.ndarray:
    """Channels idx of a (h, w, c) frame as a new contiguous float32 (h, w, len(idx))."""
    idx = [int(i) for i in idx]
    src, px = px, widen(px)
    if px.dtype == np.float32 and px.flags.c_contiguous and px.ndim == 3 and px.size:
        cv2 = _cv2()
        if idx == [0, 1, 2] and px.shape[2] == 4:
            return cv2.cvtColor(px, cv2.COLOR_RGBA2RGB)
        if idx == list(range(px.shape[2])):
            return px if px is not src else px.copy()      # never the caller's array itself
        if len(idx) <= 4:
            out = np.empty(px.shape[:2] + (len(idx),), np.float32)
            pairs = [v for k, c in enumerate(idx) for v in (c, k)]
            cv2.mixChannels([px], [out], pairs)
            return out
    return np.ascontiguousarray(px[:, :, idx], dtype=np.float32)


def plane(px: np.ndarray, i: int) -> np.ndarray:
    """Channel i of a (h, w, c) frame as a new contiguous float32 (h, w) (numpy's strided
    copy is as fast as OpenCV's here)."""
    return np.array(px[:, :, i], dtype=np.float32, copy=True)


def pack_rgba(dst: np.ndarray, rgb: np.ndarray, alpha: np.ndarray | None) -> None:
    """dst (h, w, 4) float32 = rgb and alpha (1 where None), written in place."""
    done = False
    if rgb.dtype == np.float32 and rgb.flags.c_contiguous and dst.flags.c_contiguous and rgb.size:
        cv2 = _cv2()
        got = cv2.cvtColor(rgb, cv2.COLOR_RGB2RGBA, dst=dst)
        done = got.ctypes.data == dst.ctypes.data       # OpenCV writes elsewhere if dst does not fit
    if not done:
        dst[:, :, :3] = rgb
        dst[:, :, 3] = 1.0
    if alpha is not None:
        dst[:, :, 3] = alpha


def _whole_pixels(a: np.ndarray) -> np.ndarray | None:
    """The contiguous (h, w, K) block that a (h, w, c) is the first channels of (the RGB view
    of a downloaded RGBA, or rows of it), inside the array a views; None if it is not one."""
    base = a.base if isinstance(a.base, np.ndarray) else None
    if base is None or base.dtype != a.dtype or not base.flags.c_contiguous or base.ndim != 3:
        return None
    k, item = base.shape[2], a.itemsize
    if a.strides != (base.strides[0], k * item, item) or a.shape[1] != base.shape[1]:
        return None
    off = a.ctypes.data - base.ctypes.data
    if base.strides[0] != base.shape[1] * k * item or off < 0 or off % (k * item) \
            or off + a.shape[0] * base.strides[0] > base.nbytes:
        return None
    return np.lib.stride_tricks.as_strided(a, (a.shape[0], a.shape[1], k), (base.strides[0], k * item, item))


def _frame_of(a: np.ndarray, dtype) -> np.ndarray:
    """A contiguous (h, w, c) of dtype holding a's channels first: a itself, the pixels a is
    the first channels of (_whole_pixels), or a conversion."""
    if a.ndim == 2:
        a = a[:, :, None]
    if not a.flags.c_contiguous:
        whole = _whole_pixels(a)
        a = whole if whole is not None else np.ascontiguousarray(a)
    if a.dtype == dtype:
        return a
    if a.dtype in (np.float16, np.float32) and dtype in (np.float16, np.float32) and a.size:
        return _convert(a, _cv2().CV_32F if dtype == np.float32 else _cv2().CV_16F)
    with np.errstate(over="ignore"):
        return a.astype(dtype)


def gather(picks: list[tuple[np.ndarray, int]], dtype) -> np.ndarray:
    """(h, w, k) contiguous array of dtype (float16, float32 or float64) whose channel j is
    channel picks[j][1] of frame picks[j][0] ((h, w, c) or (h, w), any float type and strides).
    float32 -> float16 rounds to nearest even, beyond 65504 to inf, as numpy's cast."""
    dtype = np.dtype(dtype)
    k = len(picks)
    h, w = picks[0][0].shape[:2]
    if not (k and h and w):
        return np.empty((h, w, k), dtype)
    frames, offsets, pairs = [], {}, []
    for j, (a, c) in enumerate(picks):
        if not 0 <= int(c) < (a.shape[2] if a.ndim == 3 else 1):
            raise IndexError(f"gather: channel {c} of an array of shape {a.shape}")
        if id(a) not in offsets:
            offsets[id(a)] = sum(x.shape[2] for x in frames)
            frames.append(_frame_of(a, dtype))    # converted first: the channel moves then carry 2 or 4 bytes
        pairs += [offsets[id(a)] + int(c), j]
    out = np.empty((h, w, k), dtype)
    _cv2().mixChannels(frames, [out], pairs)
    return out
