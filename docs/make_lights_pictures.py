"""Pictures of docs/lights.md: the bundled sample in fog without and with lights
(samples/harbour-lights.yaml), and the same lights in smoke.

    python docs/make_lights_pictures.py
"""
import sys
import warnings
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import fogcli  # noqa: E402
from fogcli.colour import linear_to_srgb  # noqa: E402
from fogcli.config_source import load_yaml  # noqa: E402

OUT = ROOT / "docs" / "images"


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
    img = np.concatenate(row, axis=1)
    path = OUT / "lights-harbour.png"
    spec = oiio.ImageSpec(img.shape[1], img.shape[0], 3, "uint8")
    o = oiio.ImageOutput.create(str(path))
    o.open(str(path), spec)
    o.write_image(np.ascontiguousarray(img, np.float32))
    o.close()
    print("wrote", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
