"""Depth cleaning before upload: invalid pixels (NaN, <= 0) are filled from the nearest
valid pixel; +inf stays (it is sky, clamped to max_depth in the preprocess kernel)."""
from __future__ import annotations

import numpy as np

from .errors import UserError


def clean(depth: np.ndarray, source: str) -> tuple[np.ndarray, int]:
    """Returns (depth with holes filled, number of filled pixels)."""
    d = np.asarray(depth, dtype=np.float32)
    valid = (d > 0) & ~np.isnan(d)          # +inf counts as valid (sky)
    n_bad = int(d.size - np.count_nonzero(valid))
    if n_bad == 0:
        return d, 0
    if n_bad == d.size:
        raise UserError(f"{source}: depth has no valid pixel (all NaN or <= 0)")
    import cv2

    # distance transform with labels: each hole pixel learns its nearest valid pixel
    _, labels = cv2.distanceTransformWithLabels((~valid).astype(np.uint8), cv2.DIST_L2, 5,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    vy, vx = np.nonzero(valid)
    # labels of valid (zero) pixels are numbered in raster order, starting at 1
    lut = np.empty(len(vy) + 1, dtype=np.float32)
    lut[0] = 0.0
    lut[1:] = d[vy, vx]
    out = d.copy()
    out[~valid] = lut[labels[~valid]]
    return out, n_bad
