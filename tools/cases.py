"""The scene set for calibration and fidelity measurements: synthetic HDR scenes (night
lamps and lit windows, day sky, slanted ground) under several media, both spread models
and several spread scales. World scale per medium keeps optical depths ~0.5-8."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from hdr_scenes import scene  # noqa: E402

WORLD_SCALE = {"fog": 1.0, "haze": 8.0, "sea": 0.15, "harbour": 0.02, "smoke": 0.12}
SPREADS = {"angular": (0.5, 1.0), "paper": (0.5, 2.0, 8.0)}


def cases(seeds, media=("fog", "haze", "sea"), size=(256, 192)):
    """Yields (label, rgb, z, sets); sets are --set items for make_config(medium)."""
    for seed in seeds:
        night = seed % 2 == 1
        for medium in media:
            rgb, z, fov = scene(size[0], size[1], seed=seed, night=night, scale=WORLD_SCALE[medium])
            for model, scales in SPREADS.items():
                for s in scales:
                    label = f"{medium}/{'night' if night else 'day'}{seed}/{model}x{s:g}"
                    yield label, medium, rgb, z, [f"camera.fov={fov}", f"render.spread_model={model}",
                                                  f"render.spread_scale={s}"]


def constant_depth_cases(sigmas=(2.0, 5.0, 12.0), size=(192, 160)):
    """One depth everywhere, so the reference is a plain Gaussian of sigma px."""
    w, h = size
    rng = np.random.default_rng(5)
    rgb = rng.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32)
    rgb[40:44, 60:64] = 200.0
    rgb[100, 150] = 900.0
    z = np.full((h, w), 20.0, np.float32)
    sa, ss, g = 0.01, 0.08, 0.8
    W = np.sqrt(0.5 / (2 * sa / (3 * 20.0) + 4 / (20.0 ** 3 * ss * (1 - g))))
    for sg in sigmas:
        yield f"constant/sigma{sg:g}", "fog", rgb, z, [
            f"medium.absorption={sa}", f"medium.scattering={ss}", f"medium.asymmetry={g}",
            "render.psf=gaussian", "render.border=closed", "render.spread_model=paper", f"render.spread_scale={sg / (W * w / 1280)}",
            "camera.depth=distance"]
