"""The Python API that the command line uses."""
from __future__ import annotations

import numpy as np

from . import depth as depth_mod
from .config import Config
from .media import assemble
from .pipeline import Timings, run


def make_config(medium: str | None = None, config: str | None = None, sets=(), **overrides) -> Config:
    """Build a validated Config; ``overrides`` are dotted keys with '.' written as '__'."""
    sets = tuple(sets) + tuple(f"{k.replace('__', '.')}={v}" for k, v in overrides.items())
    return assemble(medium, config, sets)


def apply(image: np.ndarray, depth: np.ndarray, config: Config | str | None = None, *,
          alpha: np.ndarray | None = None, aovs=(), device: str | None = None,
          timings: Timings | None = None, return_aovs: bool = False):
    """Add the medium to a scene-linear image.

    image: (h, w, 3) float, scene-linear; depth: raw depth values as stored (decoded by the
    config's camera section: depth_scale, encoding, z / distance / disparity / inverse; +inf
    is sky; NaN, <= 0 and zero disparity are holes), at the image's size or a smaller one of
    the same aspect; holes are filled and the size matched edge-aware (depth.prepare).
    config: a Config, a preset name or None (the default preset). Returns (h, w, 3) float32,
    or (image, aov planes) with return_aovs.
    """
    cfg = config if isinstance(config, Config) else assemble(config)
    img = np.ascontiguousarray(image, dtype=np.float32)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ValueError(f"image must be (h, w, 3), got {img.shape}")
    d, _ = depth_mod.metric_depth(np.asarray(depth), img, cfg.camera, "depth")
    out, planes = run(img, d, cfg, alpha=alpha, aovs=aovs, device=device, timings=timings)
    return (out, planes) if return_aovs else out
