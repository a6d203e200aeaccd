"""Rec.709 luminance (docs/conventions.md, The reference and the pyramid): the host's weights;
the kernels' are common.h's LUMA_R, LUMA_G, LUMA_B (tests/test_luminance.py holds them together)."""
from __future__ import annotations

import numpy as np

LUMA = (0.2126, 0.7152, 0.0722)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Y of (..., >= 3) colour, elementwise: a matmul would call BLAS, whose threads then spin
    beside the OpenCL device's on the same cores."""
    return LUMA[0] * rgb[..., 0] + LUMA[1] * rgb[..., 1] + LUMA[2] * rgb[..., 2]
