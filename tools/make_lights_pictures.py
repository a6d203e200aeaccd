"""Pictures of docs/lights.md: the bundled sample in fog without and with lights
(samples/harbour-lights.yaml), and the same lights in smoke; a colonnade with a lamp and the
sun behind it, without and with shadows (render.lights.shadows: screen), and lights in the
places that are awkward for screen shadows; a spot through a
column of smoke (a noise primitive) that shadows itself.

    python tools/make_lights_pictures.py
"""
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import fogcli  # noqa: E402
from fogcli.io.colour import linear_to_srgb  # noqa: E402
from fogcli.config.yaml_source import load_yaml  # noqa: E402
from make_pictures import save  # noqa: E402  (docs/: the pictures' PNG writer)

OUT = ROOT / "docs" / "images"


def write_png(img: np.ndarray, name: str) -> None:
    save(OUT / name, img)
    print("wrote", OUT / name)


def colonnade(h: int = 180, w: int = 320) -> tuple[np.ndarray, np.ndarray]:
    """z-depth and colour of a dark colonnade against the sky: five pillars 1 m wide and 7 m
    high at 12 m under a lintel, a floor; camera at 1.6 m looking along -z (camera.fov 60)."""
    f = (w / 2) / np.tan(np.radians(30.0))
    jj, ii = np.mgrid[0:h, 0:w]
    dx, dy = (ii + 0.5 - w / 2) / f, -(jj + 0.5 - h / 2) / f
    floor = dy < 0
    z = np.where(floor, 1.6 / np.where(floor, -dy, 1.0), np.inf)       # the floor, 1.6 m below
    rgb = np.full((h, w, 3), 0.02)
    x12, y12 = dx * 12.0, dy * 12.0
    pillar = (np.abs(((x12 + 1.25) % 2.5) - 1.25) < 0.5) & (np.abs(x12) < 6.5) & (y12 > -1.6) & (y12 < 5.4)
    lintel = (np.abs(x12) < 6.5) & (y12 >= 4.6) & (y12 < 5.6)
    z[(pillar | lintel) & (12.0 < z)] = 12.0
    rgb[pillar | lintel] = 0.05
    return z.astype(np.float32), rgb.astype(np.float32)


def room(h: int = 180, w: int = 320) -> tuple[np.ndarray, np.ndarray]:
    """z-depth and colour of a dark room: a floor 1.6 m below the camera, a wall at 16 m."""
    f = (w / 2) / np.tan(np.radians(30.0))
    dy = -((np.arange(h)[:, None] + 0.5 - h / 2) / f) * np.ones((1, w))
    z = np.minimum(np.where(dy < 0, 1.6 / np.where(dy < 0, -dy, 1.0), np.inf), 16.0)
    return z.astype(np.float32), np.full((h, w, 3), 0.02, np.float32)


SMOKE_COLUMN = ("{type: noise, factor: 25, scale: 1.2, octaves: 5, offset: 0.0, amplitude: 3, shape: box, "
                "center: [0.0, 0.6, -9], size: [2, 4.4, 2], seed: 4, edge: 0.6}")
SPOT = "{type: spot, position: [-5, 2.8, -8.5], direction: [1, -0.35, -0.1], angle: 22, intensity: 4000}"


def main() -> int:
    fr = fogcli.read_image(ROOT / "samples" / "harbour.exr")
    lights = load_yaml(ROOT / "samples" / "harbour-lights.yaml", {})["lights"]
    import yaml

    sets = [f"lights={yaml.safe_dump(lights, default_flow_style=True).strip()}"]
    row = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for medium, extra in (("fog", []), ("fog", sets), ("smoke", sets)):
            out = fogcli.apply(fr.rgb, fr.depth, fogcli.make_config(medium, sets=extra))
            row.append(linear_to_srgb(np.clip(out * 2.0, 0, None))[::2, ::2])
    write_png(np.concatenate(row, axis=1), "lights-harbour.png")

    z, rgb = colonnade()
    rows = []
    for light in ("{type: directional, direction: [-0.2, 0.1, -0.97], irradiance: 0.15}",      # the sun
                  "{type: point, position: [0.3, 1.5, -16], intensity: 60, radius: 0.1}"):       # a lamp
        row = []
        for shadows in ("none", "screen"):
            out = fogcli.apply(rgb, z, fogcli.make_config("fog", sets=[f"lights=[{light}]", "medium.visibility=80",
                                                                       f"render.lights.shadows={shadows}"]))
            row.append(linear_to_srgb(np.clip(out, 0, None)))
        rows.append(np.concatenate(row, axis=1))
    row = rows
    write_png(np.concatenate(row, axis=0), "lights-shadows.png")

    # the awkward places of a light for screen shadows, each with shadows: behind the camera,
    # the sun in the image plane (parallel epipolar lines), on the frame's left edge, on a pillar
    f = (320 / 2) / np.tan(np.radians(30.0))
    awkward = ["{type: point, position: [1.5, 2.5, 4], intensity: 3000, radius: 0.1}",
               "{type: directional, direction: [-1, 0.15, 0], irradiance: 1}",
               f"{{type: point, position: [{-160 / f * 14:.4f}, 1.0, -14], intensity: 60, radius: 0.1}}",
               "{type: point, position: [2.5, 1.0, -11.95], intensity: 60, radius: 0.1}"]
    tiles = []
    for light in awkward:
        out = fogcli.apply(rgb, z, fogcli.make_config("fog", sets=[f"lights=[{light}]", "medium.visibility=80",
                                                                   "render.lights.shadows=screen"]))
        tiles.append(linear_to_srgb(np.clip(out, 0, None)))
    write_png(np.concatenate([np.concatenate(tiles[:2], axis=1), np.concatenate(tiles[2:], axis=1)], axis=0),
              "lights-awkward.png")

    z, rgb = room()
    row = []
    for density in ("[{type: homogeneous}]", f"[{{type: homogeneous}}, {SMOKE_COLUMN}]"):
        out = fogcli.apply(rgb, z, fogcli.make_config("fog", sets=[f"lights=[{SPOT}]", "medium.visibility=60",
                                                                   f"medium.density={density}"]))
        row.append(linear_to_srgb(np.clip(out, 0, None)))
    write_png(np.concatenate(row, axis=1), "lights-smoke.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
