"""The values of a config that depend on the frame's image, made concrete before the device
sees it: lamps found (`lights: [{type: auto}]`), a visibility given as a share of the scene's
median depth, the ambient light `auto`."""
from __future__ import annotations

import numpy as np

from fogcli.config.model import Config, Medium
from fogcli.device.lights import optical_distance
from fogcli.errors import UserError
from fogcli.frame.lamps import detect_lamps
from fogcli.physics.ambient import estimate
from fogcli.physics.apsf import single_share


def for_image(rgb: np.ndarray, depth: np.ndarray, cfg: Config, report: list | None = None,
              lamps: list | None = None) -> tuple[Config, tuple | None]:
    """(the config for this frame, the lamps' pixels with the share of their scattered light
    they keep (share_lamps), or None). depth: metric, at the image's size; `report` collects
    notes (lamps found), `lamps` the point lights that `{type: auto}` made of them, as found
    (their whole intensity: a config to reuse, where the pixels are not shared)."""
    lamp_pixels = None
    if any(x.type == "auto" for x in cfg.lights):     # lamps of the image become point lights
        found, labels, notes = [], None, []
        for spec in [x for x in cfg.lights if x.type == "auto"]:
            got, lab, more = detect_lamps(np.asarray(rgb, np.float32), depth, cfg, spec)
            lab = np.where(lab > 0, lab + len(found), 0)
            found += got
            notes += more
            labels = lab if labels is None else np.where(lab > 0, lab, labels)
        for x in found:
            notes.append(f"lamp found at ({', '.join(f'{v:.3g}' for v in x.position)}) m (camera), "
                         f"intensity ({', '.join(f'{v:.3g}' for v in x.intensity)})")
        if report is not None:
            report.extend(notes)
        if lamps is not None:
            lamps.extend(found)
        shared, lamp_pixels = share_lamps(cfg, found, labels)
        cfg = cfg.model_copy(update={"lights": [x for x in cfg.lights if x.type != "auto"] + shared})
        lamp_pixels = lamp_pixels if cfg.lights and lamp_pixels[0].size else None
    medium = concrete_medium(rgb, depth, cfg)
    if medium is not cfg.medium:
        cfg = cfg.model_copy(update={"medium": medium})
    return cfg, lamp_pixels


def concrete_medium(rgb: np.ndarray, depth: np.ndarray, cfg: Config) -> Medium:
    """The medium with its values of the image made concrete: a visibility given as a share
    of the frame's median depth, the ambient light `auto` (the views of a stereo pair take
    the first view's: one medium for both eyes)."""
    m = cfg.medium
    if isinstance(m.visibility, str):
        m = m.for_depth(median_depth(depth, cfg.camera.max_depth))
    if m.ambient == "auto":
        m = m.model_copy(update={"ambient": estimate(np.asarray(rgb, np.float32), depth, cfg.camera.max_depth)})
    return m


def share_lamps(cfg: Config, found: list, labels) -> tuple[list, tuple]:
    """A lamp the image shows is carried once, by two models: the light model's single
    scattering is exact in three dimensions (its light reaches the medium all around the
    lamp, beside and behind the camera too), the point spread of the lamp's pixels is the
    exact multiple scattering of a point source in a homogeneous medium. Each carries the
    share of the lamp's scattered light it is best at: the light the singly scattered share
    (physics.apsf.single_share at the lamp's optical distance, per channel), the pixels
    the rest. Measured against the path-traced lamp scenes (docs/lights.md): all to the
    light model was up to 0.035 worse in sea water, up to 0.02 better in haze. Returns (the
    lights, their intensities scaled; (flat pixel indices, float32 (n, 4) share of their
    scattered light the pixels keep))."""
    ss = np.asarray(cfg.medium.scattering, np.float64)
    keep, shared = np.ones((len(found) + 1, 4), np.float32), []
    for k, light in enumerate(found):
        w = single_share(ss * optical_distance(cfg, light))
        keep[k + 1, :3] = 1.0 - w
        shared.append(light.model_copy(update={"intensity": tuple(float(v) for v in np.asarray(light.intensity) * w)}))
    idx = np.flatnonzero(labels) if labels is not None else np.zeros(0, np.int64)
    return shared, (idx.astype(np.int32), np.ascontiguousarray(keep[labels.ravel()[idx]] if idx.size else keep[:0]))


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
