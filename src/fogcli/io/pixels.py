"""Whole-frame conversions and channel moves on the host, exact to the bit (numpy's casts:
half widening keeps NaN, inf and subnormals; float32 -> float16 rounds to nearest even,
beyond 65504 to inf). Runs of channels move in one assignment each: numpy's loops over a
3- or 4-long innermost axis are the slow part, so the fewer the better. No OpenCV here: its
import alone was 18 MB and 20 ms of every command that reads an image."""
from __future__ import annotations

import numpy as np

def widen(px: np.ndarray) -> np.ndarray:
    """float16 (h, w, c) as float32; other types unchanged."""
    return px.astype(np.float32) if px.dtype == np.float16 else px


def take(px: np.ndarray, idx) -> np.ndarray:
    """Channels idx of a (h, w, c) frame as a new contiguous float32 (h, w, len(idx))."""
    idx = [int(i) for i in idx]
    if idx and not 0 <= min(idx) <= max(idx) < px.shape[2]:
        raise IndexError(f"take: channels {idx} of an array of shape {px.shape}")
    out = np.empty(px.shape[:2] + (len(idx),), np.float32)
    _move(out, 0, px, idx)
    return out


def plane(px: np.ndarray, i: int) -> np.ndarray:
    """Channel i of a (h, w, c) frame as a new contiguous float32 (h, w)."""
    return np.array(px[:, :, i], dtype=np.float32, copy=True)


def columns(px: np.ndarray, idx) -> np.ndarray:
    """Channels idx of a frame without a copy where they are a run (a view: read it once);
    else take()."""
    idx = [int(i) for i in idx]
    if idx == list(range(idx[0], idx[0] + len(idx))):
        return px[:, :, idx[0]:idx[0] + len(idx)]
    return take(px, idx)


def gather(picks: list[tuple[np.ndarray, int]], dtype) -> np.ndarray:
    """(h, w, k) contiguous array of dtype whose channel j is channel picks[j][1] of frame
    picks[j][0] ((h, w, c) or (h, w), any float type and strides)."""
    h, w = picks[0][0].shape[:2]
    out = np.empty((h, w, len(picks)), np.dtype(dtype))
    j = 0
    while j < len(picks):       # the next picks of the same frame move together (_move's runs)
        a = picks[j][0]
        k = j + 1
        while k < len(picks) and picks[k][0] is a:
            k += 1
        idx = [int(c) if a.ndim == 3 else 0 for _, c in picks[j:k]]
        src = a if a.ndim == 3 else a[:, :, None]
        if not 0 <= min(idx) <= max(idx) < src.shape[2]:
            raise IndexError(f"gather: channels {idx} of an array of shape {a.shape}")
        with np.errstate(over="ignore"):        # beyond a half's range: inf, as numpy's cast
            _move(out, j, src, idx)
        j = k
    return out


def _move(out: np.ndarray, j0: int, px: np.ndarray, idx: list) -> None:
    """out[:, :, j0 + k] = px[:, :, idx[k]], runs of consecutive channels at once."""
    k = 0
    while k < len(idx):
        run = 1
        while k + run < len(idx) and idx[k + run] == idx[k] + run:
            run += 1
        out[:, :, j0 + k:j0 + k + run] = px[:, :, idx[k]:idx[k] + run]
        k += run
