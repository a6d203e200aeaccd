"""A frame as read by apply (frame.job.load), reduced for a quick look, and rendered with
a config: what the tune page's previews and AOVs and the contact sheet's tiles share."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fogcli.config.model import Camera, Config
from fogcli.device.run import run
from fogcli.frame.scene import for_image


@dataclass
class Look:
    rgb: np.ndarray                 # (h, w, 3) float32 scene-linear
    depth: np.ndarray               # (h, w) metric, cleaned
    alpha: np.ndarray | None
    camera: Camera                  # follows the frame's size (calibrated_size: the full frame's)


def reduced(rgb: np.ndarray, depth: np.ndarray, alpha, camera: Camera, width: int, height: int) -> Look:
    """The frame at width x height (area-averaged colour and alpha, nearest depth: no depth
    between a near and a far surface), or as it is at its own size."""
    import cv2

    h, w = depth.shape
    if camera.calibrated_size is None:
        camera = camera.model_copy(update={"calibrated_size": (w, h)})
    if (width, height) == (w, h):
        return Look(rgb, depth, alpha, camera)
    area = lambda a: cv2.resize(a, (width, height), interpolation=cv2.INTER_AREA)  # noqa: E731
    return Look(np.ascontiguousarray(area(rgb)),
                np.ascontiguousarray(cv2.resize(depth, (width, height), interpolation=cv2.INTER_NEAREST)),
                None if alpha is None else np.ascontiguousarray(area(alpha)), camera)


def render(look: Look, cfg: Config, aovs=(), device=None, timings=None) -> tuple[np.ndarray, dict, Config]:
    """(the frame in the medium, its AOV planes, the config made concrete for it)."""
    frame_cfg, lamp_pixels = for_image(look.rgb, look.depth, cfg.model_copy(update={"camera": look.camera}))
    out, _, planes = run(look.rgb, look.depth, frame_cfg, alpha=look.alpha, aovs=aovs, device=device,
                         lamp_pixels=lamp_pixels, timings=timings)
    return out, planes, frame_cfg
