"""Where things are: the camera's rotation, a light placed in the world, a light's place in
the image (docs/conventions.md, Geometry)."""
from __future__ import annotations

import numpy as np

from fogcli.config.model import Config


def rotation(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """R = Ry(yaw) Rx(pitch) Rz(roll), right-handed, degrees (docs/conventions.md, Geometry)."""
    y, p, r = np.radians([yaw, pitch, roll])
    ry = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]])
    rx = np.array([[1, 0, 0], [0, np.cos(p), -np.sin(p)], [0, np.sin(p), np.cos(p)]])
    rz = np.array([[np.cos(r), -np.sin(r), 0], [np.sin(r), np.cos(r), 0], [0, 0, 1]])
    return ry @ rx @ rz


def placed(cfg: Config, light) -> tuple[np.ndarray, np.ndarray]:
    """(world position, world unit axis) of a light: camera-frame values are turned by the
    camera's rotation and moved to its position (docs/conventions.md, Geometry)."""
    c = cfg.camera
    R = rotation(c.yaw, c.pitch, c.roll)
    cam = np.array(cfg.camera.position, np.float64)
    pos = np.array(getattr(light, "position", (0.0, 0.0, 0.0)), np.float64)
    axis = np.array(getattr(light, "direction", (0.0, 0.0, -1.0)), np.float64)
    axis = axis / np.linalg.norm(axis)
    if light.frame == "camera":
        pos, axis = cam + R @ pos, R @ axis
    return pos, axis


def light_image(cfg: Config, light, width: int, height: int) -> tuple[float, float]:
    """Where a point or spot light appears in the image, pixels from the top-left corner
    (far outside for a directional light or one behind the camera)."""
    if light.type == "directional":
        return -1e9, -1e9
    cam = cfg.camera.for_size(width, height)
    pos, _ = placed(cfg, light)
    c = cfg.camera
    x, y, z = rotation(c.yaw, c.pitch, c.roll).T @ (np.asarray(pos, float) - np.asarray(cfg.camera.position, float))
    if z >= 0:
        return -1e9, -1e9
    cx, cy = cam.centre(width, height)
    return cx + cam.focal(width) * x / -z, cy - cam.focal_y(width) * y / -z
