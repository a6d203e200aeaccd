"""The values of a config that depend on the frame's image, made concrete before the device
sees it: lamps found (`lights: [{type: auto}]`), a visibility given as a share of the scene's
median depth, the ambient light `auto`."""
from __future__ import annotations

import numpy as np

from fogcli.config.model import Config
from fogcli.errors import UserError
from fogcli.frame.lamps import detect_lamps
from fogcli.physics.ambient import estimate


def for_image(rgb: np.ndarray, depth: np.ndarray, cfg: Config, report: list | None = None,
              lamps: list | None = None) -> tuple[Config, np.ndarray | None]:
    """(the config for this frame, the lamps' pixels or None). depth: metric, at the
    image's size; `report` collects notes (lamps found), `lamps` the point lights that
    `{type: auto}` made of them."""
    lamp_mask = None
    if any(x.type == "auto" for x in cfg.lights):     # lamps of the image become point lights
        found, lamp_mask, notes = [], None, []
        for spec in [x for x in cfg.lights if x.type == "auto"]:
            got, mask, more = detect_lamps(np.asarray(rgb, np.float32), depth, cfg, spec)
            found += got
            notes += more
            lamp_mask = mask if lamp_mask is None else (lamp_mask | mask)
        for x in found:
            notes.append(f"lamp found at ({', '.join(f'{v:.3g}' for v in x.position)}) m (camera), "
                         f"intensity ({', '.join(f'{v:.3g}' for v in x.intensity)})")
        if report is not None:
            report.extend(notes)
        if lamps is not None:
            lamps.extend(found)
        cfg = cfg.model_copy(update={"lights": [x for x in cfg.lights if x.type != "auto"] + found})
        lamp_mask = lamp_mask if cfg.lights and lamp_mask is not None and lamp_mask.any() else None
    if isinstance(cfg.medium.visibility, str):        # a share of this frame's median depth
        cfg = cfg.model_copy(update={"medium": cfg.medium.for_depth(median_depth(depth, cfg.camera.max_depth))})
    if cfg.medium.ambient == "auto":
        la = estimate(np.asarray(rgb, np.float32), depth, cfg.camera.max_depth)
        cfg = cfg.model_copy(update={"medium": cfg.medium.model_copy(update={"ambient": la})})
    return cfg, lamp_mask


def depth_grid(depth: np.ndarray) -> np.ndarray:
    """The pixels median_depth looks at (about 256 x 256 of them; of a grid, all)."""
    return depth[:: max(1, depth.shape[0] // 256), :: max(1, depth.shape[1] // 256)]


def median_depth(depth: np.ndarray, max_depth: float) -> float:
    """The median metric depth of the surfaces (sky and beyond max_depth left out)."""
    d = depth_grid(depth)
    d = d[np.isfinite(d) & (d < max_depth) & (d > 0)]
    if d.size == 0:
        raise UserError("medium.visibility: a share of the median depth needs surfaces in the frame (all sky here)")
    return float(np.median(d))
