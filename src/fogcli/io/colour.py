"""sRGB transfer functions (IEC 61966-2-1) for 8/16-bit inputs and display outputs."""
from __future__ import annotations

import numpy as np


def srgb_to_linear(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=np.float32)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4).astype(np.float32)


def linear_to_srgb(v: np.ndarray) -> np.ndarray:
    v = np.clip(np.asarray(v, dtype=np.float32), 0.0, 1.0)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * np.power(v, 1 / 2.4) - 0.055).astype(np.float32)


CLIPPED = 0.999     # linear value at or above which a display-referred pixel is taken as clipped (8-bit 255: 1.0)
KNEE = 0.8          # where camera.highlight_gain's ramp starts (linear; sRGB 231 of 255)


def clipped_pixels(rgb: np.ndarray) -> int:
    """Pixels of a display-referred frame (linear, [0, 1]) with a channel clipped at white."""
    return int(np.count_nonzero(np.asarray(rgb).max(axis=-1) >= CLIPPED))


def recover_highlights(rgb: np.ndarray, gain) -> np.ndarray:
    """A display-referred frame's highlights as the light they stand for: each pixel scaled
    by 1 + (gain - 1) s, s rising smoothly from 0 at KNEE to 1 at white (of its largest
    channel), so that a clipped core is `gain` times as bright and its anti-aliased rim
    follows without a step; the hue (channel ratios) is kept. `gain`: one for the frame, or
    one per pixel (frame.lamps.highlight_gains)."""
    if np.isscalar(gain) and gain == 1.0:
        return rgb
    m = np.asarray(rgb, np.float32).max(axis=-1)
    t = np.clip((m - KNEE) / (1.0 - KNEE), 0.0, 1.0)
    scale = 1.0 + (np.asarray(gain, np.float32) - 1.0) * (t * t * (3.0 - 2.0 * t))
    return (rgb * scale[..., None]).astype(np.float32)
