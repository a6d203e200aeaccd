"""Regenerate samples/harbour.exr: a night harbour (lamps near and far, lit quay, sky),
RGB half + Z float (planar depth, +inf sky), ZIP-compressed, 640x360, fov 60.

    python samples/make_sample.py
"""
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
from fogcli.scenes import harbour_sample  # noqa: E402

rgb, z, fov = harbour_sample()
h, w = z.shape
spec = oiio.ImageSpec(w, h, 4, "half")
spec.channelnames = ("R", "G", "B", "Z")
spec.channelformats = (oiio.HALF, oiio.HALF, oiio.HALF, oiio.FLOAT)
spec.attribute("compression", "zip")
spec.attribute("fogcli:fov", float(fov))
spec.attribute("Software", "fogcli samples/make_sample.py")
path = Path(__file__).resolve().parent / "harbour.exr"
out = oiio.ImageOutput.create(str(path))
out.open(str(path), spec)
out.write_image(np.ascontiguousarray(np.dstack([rgb, z]), np.float32))
out.close()
print(path, path.stat().st_size, "bytes")
