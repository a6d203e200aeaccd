"""What the float32 kernels can carry: input radiance beyond it is refused with a
UserError, before any device work (io checks a frame it decodes, device what it uploads)."""
from __future__ import annotations

import numpy as np

from fogcli.errors import UserError

# Scene-linear radiance beyond this is refused: brighter than any scene (the sun is about
# 1e9 cd/m^2), and beyond it the kernels' float sums over a frame could overflow.
MAX_RADIANCE = 1e20


def check_radiance(px: np.ndarray, label: str) -> None:
    """UserError for NaN, infinite or implausibly large colour (px: float32, contiguous for
    speed; every channel counts, so pass colour and alpha at most)."""
    # max and min propagate NaN and keep inf: two passes without temporaries tell both
    hi, lo = float(px.max(initial=0.0)), float(px.min(initial=0.0))
    if np.isfinite(hi) and np.isfinite(lo) and max(hi, -lo) <= MAX_RADIANCE:
        return
    if not (np.isfinite(hi) and np.isfinite(lo)):
        bad = int((~np.isfinite(px)).any(axis=2).sum()) if px.ndim == 3 else int((~np.isfinite(px)).sum())
        raise UserError(f"{label}: {bad} pixel(s) hold NaN or infinite colour values")
    raise UserError(f"{label}: colour values up to {max(hi, -lo):.3g}; scene-linear radiance above "
                    f"{MAX_RADIANCE:.0e} is not supported (would overflow the float sums)")
