"""sRGB transfer functions (IEC 61966-2-1) for 8/16-bit inputs and display outputs, and the
highlights a display-referred frame clipped."""
from __future__ import annotations

import numpy as np


def srgb_to_linear(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=np.float32)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4).astype(np.float32)


def linear_to_srgb(v: np.ndarray) -> np.ndarray:
    v = np.clip(np.asarray(v, dtype=np.float32), 0.0, 1.0)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * np.power(v, 1 / 2.4) - 0.055).astype(np.float32)


def codes(v: np.ndarray, top: int = 255) -> np.ndarray:
    """Values in [0, 1] as a file's integer codes, rounded (top 255: 8 bits, 65535: 16)."""
    return np.clip(np.rint(np.asarray(v, np.float32) * top), 0, top).astype(np.uint8 if top <= 255 else np.uint16)


def srgb_codes(linear: np.ndarray, top: int = 255) -> np.ndarray:
    """Linear light as the sRGB codes a display file holds (clipped at white)."""
    return codes(linear_to_srgb(linear), top)


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
    one per pixel (frame.lamps.recover)."""
    if np.isscalar(gain) and gain == 1.0:
        return rgb
    m = np.asarray(rgb, np.float32).max(axis=-1)
    t = np.clip((m - KNEE) / (1.0 - KNEE), 0.0, 1.0)
    scale = 1.0 + (np.asarray(gain, np.float32) - 1.0) * (t * t * (3.0 - 2.0 * t))
    return (rgb * scale[..., None]).astype(np.float32)


# CIE XYZ -> linear sRGB (D65), IEC 61966-2-1
XYZ_TO_SRGB = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]])


def kelvin_rgb(kelvin: float) -> np.ndarray:
    """A black body's colour at `kelvin` (1667 to 25000 K) in linear sRGB, its largest channel
    1: the Planckian locus's chromaticity by Kim et al.'s cubic splines (2002; within 1e-3 of
    the CIE tables), then XYZ at Y = 1 to sRGB. A tungsten lamp at 2700 K is (1, 0.42, 0.10)
    in an sRGB file balanced for daylight."""
    t = float(kelvin)
    if t <= 4000:
        x = -0.2661239e9 / t ** 3 - 0.2343589e6 / t ** 2 + 0.8776956e3 / t + 0.179910
    else:
        x = -3.0258469e9 / t ** 3 + 2.1070379e6 / t ** 2 + 0.2226347e3 / t + 0.240390
    if t <= 2222:
        y = -1.1063814 * x ** 3 - 1.34811020 * x ** 2 + 2.18555832 * x - 0.20219683
    elif t <= 4000:
        y = -0.9549476 * x ** 3 - 1.37418593 * x ** 2 + 2.09137015 * x - 0.16748867
    else:
        y = 3.0817580 * x ** 3 - 5.87338670 * x ** 2 + 3.75112997 * x - 0.37001483
    rgb = XYZ_TO_SRGB @ np.array([x / y, 1.0, (1.0 - x - y) / y])
    return (np.clip(rgb, 0.0, None) / rgb.max()).astype(np.float32)
