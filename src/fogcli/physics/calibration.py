"""The pyramid's filters and what was calibrated for them (docs/calibration.md)."""
from __future__ import annotations

import math

# Burt-style filters: binomial rows; 4 taps is Elek's {0.13, 0.37, 0.37, 0.13} unrounded.
FILTERS = {
    2: (0.5, 0.5),
    4: (0.125, 0.375, 0.375, 0.125),
    6: (0.03125, 0.15625, 0.3125, 0.3125, 0.15625, 0.03125),
}
# Calibrated against the reference per filter size: (epsilon, threshold factor); the
# threshold of level k is threshold * c * 2^(k-1) (Elek eq. 7 has 1). docs/calibration.md.
CALIBRATED = {
    "source": {2: (1.5, 1.0), 4: (1.5, 1.0), 6: (1.0, 1.1)},
    "receiver": {2: (2.0, 1.0), 4: (2.0, 1.0), 6: (2.0, 1.0)},
}
_INTERP_VAR = {"linear-bilinear": 1.0 / 6.0, "linear-bicubic": 1.0 / 3.0, "cubic-bicubic": 1.0 / 3.0}


def c_theory(kernel: int, interpolation: str, fetch: str) -> float:
    """Blur of level k in level-0 pixels is c 2^k. Each reduce adds the filter's variance at
    the level's pixel size (sum -> 4^k var_h / 3); a fetch adds the variance of the
    interpolation kernel at level k (tent 1/6, cubic B-spline 1/3); the source collapse
    interpolates once per level on the way up (sum -> 4^k 4 v / 3)."""
    taps = FILTERS[kernel]
    x = [i - (len(taps) - 1) / 2 for i in range(len(taps))]
    var_h = sum(t * xi * xi for t, xi in zip(taps, x))
    v = _INTERP_VAR[interpolation]
    return math.sqrt(var_h / 3 + (4 * v / 3 if fetch == "source" else v))
