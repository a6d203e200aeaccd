"""Fidelity measures of SPEC 4.6 (numpy; used by tests, calibration and benchmarks)."""
from __future__ import annotations

import numpy as np


def rel_l1(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> float:
    """sum|a - b| / sum|b| (over a pixel mask if given)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if mask is not None:
        a, b = a[mask], b[mask]
    return float(np.abs(a - b).sum() / max(np.abs(b).sum(), 1e-30))


def _gauss1d(sigma=1.5, radius=5):
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    k = np.exp(-x * x / (2 * sigma * sigma))
    return k / k.sum()


def _blur(img: np.ndarray, k: np.ndarray) -> np.ndarray:
    r = len(k) // 2
    h, w = img.shape
    p = np.pad(img, r, mode="reflect")
    rows = sum(k[i] * p[:, i:i + w] for i in range(len(k)))
    return sum(k[i] * rows[i:i + h, :] for i in range(len(k)))


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Mean SSIM over RGB of tone-mapped 1 - exp(-x): Gaussian window sigma 1.5 (radius 5),
    C1 = 0.01^2, C2 = 0.03^2, data range 1, reflect padding."""
    ta = 1.0 - np.exp(-np.asarray(a, np.float64))
    tb = 1.0 - np.exp(-np.asarray(b, np.float64))
    k = _gauss1d()
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    vals = []
    for ch in range(ta.shape[2]):
        x, y = ta[:, :, ch], tb[:, :, ch]
        mx, my = _blur(x, k), _blur(y, k)
        sxx = _blur(x * x, k) - mx * mx
        syy = _blur(y * y, k) - my * my
        sxy = _blur(x * y, k) - mx * my
        s = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
        vals.append(s.mean())
    return float(np.mean(vals))
