"""The camera-space ray through a pixel (docs/conventions.md, Geometry): one definition for
every host stage that turns pixels into directions or planar depth into ray length."""
from __future__ import annotations

import numpy as np


def directions(cols, rows, focal: float, focal_y: float, cx: float, cy: float) -> np.ndarray:
    """(x / f, y / f, -1) through the centres of pixels (cols, rows), (..., 3), not normalised:
    its length is a ray's length over its planar depth. cols, rows may be fractional (a
    lamp's centroid, already at its centre: pass c - 0.5)."""
    cols, rows = np.asarray(cols, np.float64), np.asarray(rows, np.float64)
    return np.stack([(cols + 0.5 - cx) / focal, -(rows + 0.5 - cy) / focal_y, -np.ones(cols.shape)], -1)


def length(d: np.ndarray) -> np.ndarray:
    """|d| over the last axis, elementwise (no BLAS: its threads would spin beside the OpenCL
    device's on the same cores)."""
    return np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2])
