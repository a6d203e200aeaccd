"""Rec.709 luminance (docs/conventions.md, The reference and the pyramid): the host's weights;
the kernels' are common.h's LUMA_R, LUMA_G, LUMA_B (tests/test_luminance.py holds them together)."""
from __future__ import annotations

import numpy as np

LUMA = (0.2126, 0.7152, 0.0722)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Y of (..., >= 3) colour, elementwise: a matmul would call BLAS, whose threads then spin
    beside the OpenCL device's on the same cores."""
    return LUMA[0] * rgb[..., 0] + LUMA[1] * rgb[..., 1] + LUMA[2] * rgb[..., 2]


def lamp_threshold(y: np.ndarray) -> float:
    """Luminance above which a pixel is a lamp's core (lights {type: auto}, threshold: auto):
    10x the 99th percentile of an HDR frame's, 0.98 in a display-referred one (max <= 1.5),
    whose lamps are clipped. Of the pixels with light: an element padded to its display
    window (io/windows.py) is mostly black, and 10x a black percentile made every pixel a lamp."""
    lit = y[y > 0]
    if not lit.size:
        return float("inf")
    return 10.0 * float(np.percentile(lit, 99)) if float(lit.max()) > 1.5 else 0.98
