"""Fidelity measures of docs/conventions.md, Measures (numpy; used by tests, calibration and benchmarks)."""
from __future__ import annotations

import numpy as np


def rel_l1(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> float:
    """sum|a - b| / sum|b| (over a pixel mask if given)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if mask is not None:
        a, b = a[mask], b[mask]
    return float(np.abs(a - b).sum() / max(np.abs(b).sum(), 1e-30))


def _blur(img: np.ndarray) -> np.ndarray:
    """Gaussian window sigma 1.5, 11 taps, reflect-101 borders."""
    import cv2

    return cv2.GaussianBlur(img, (11, 11), 1.5, borderType=cv2.BORDER_REFLECT_101)


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Mean SSIM over RGB of tone-mapped 1 - exp(-x): Gaussian window sigma 1.5 (radius 5),
    C1 = 0.01^2, C2 = 0.03^2, data range 1, reflect-101 padding."""
    ta = 1.0 - np.exp(-np.asarray(a, np.float64))
    tb = 1.0 - np.exp(-np.asarray(b, np.float64))
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    vals = []
    for ch in range(ta.shape[2]):
        x, y = ta[:, :, ch], tb[:, :, ch]
        mx, my = _blur(x), _blur(y)
        sxx = _blur(x * x) - mx * mx
        syy = _blur(y * y) - my * my
        sxy = _blur(x * y) - mx * my
        s = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
        vals.append(s.mean())
    return float(np.mean(vals))
