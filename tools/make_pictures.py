"""Before/after pictures of the heterogeneous presets on the bundled sample, for
docs/media.md:

    python tools/make_pictures.py
"""
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "samples" / "harbour.exr"
OUT = ROOT / "docs" / "images"


def fogcli(*args):
    # this checkout's fogcli, installed or not
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    subprocess.run([sys.executable, "-m", "fogcli", *map(str, args)], check=True, env=env)


def load(path):
    return oiio.ImageBuf(str(path)).get_pixels(oiio.FLOAT)[:, :, :3]


def save(path, img):
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(img.shape[1], img.shape[0], 3, "uint8"))
    out.write_image(np.ascontiguousarray(img, np.float32))
    out.close()


def main():
    OUT.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        before = Path(tmp) / "before.png"
        fogcli("apply", SAMPLE, "--set", "medium.visibility=1e9", "-o", before)   # no medium
        for preset in ("valley-fog", "sandstorm", "smoke-ball"):
            after = Path(tmp) / f"{preset}.png"
            fogcli("apply", SAMPLE, "--medium", preset, "-o", after)
            pair = np.concatenate([load(before), load(after)], axis=1)[::2, ::2]
            save(OUT / f"{preset}.png", pair)
            print(OUT / f"{preset}.png")


if __name__ == "__main__":
    main()
