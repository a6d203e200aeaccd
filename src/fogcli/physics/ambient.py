"""`medium.ambient: auto`: the scattered ambient radiance L_a estimated from the image.

Far from the camera the medium's own in-scattered light is all one sees: L_amb tends to
(ss / st) L_a as P grows. So the light of the farthest part of the scene stands for L_a:
the per-channel median of the sky pixels (depth +inf, or at least max_depth), or, when
there is no sky, of the farthest 2 % of the pixels. The median ignores lamps and the sun."""
from __future__ import annotations

import numpy as np


def estimate(rgb: np.ndarray, depth: np.ndarray, max_depth: float) -> tuple:
    """depth: metric."""
    d = depth.astype(np.float64)
    far = ~(d < max_depth)                      # +inf and beyond the clamp
    if far.sum() < max(16, d.size // 1000):
        far = d >= np.quantile(d, 0.98)
    return tuple(float(v) for v in np.median(rgb[far].reshape(-1, 3), axis=0))
