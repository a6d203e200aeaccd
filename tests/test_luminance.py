"""One definition of the luminance weights: the kernels' (common.h) are the host's."""
import re

import numpy as np

from fogcli.physics.luminance import LUMA, luminance
from helpers import ROOT


def test_the_kernels_luminance_weights_are_the_hosts():
    src = (ROOT / "src" / "fogcli" / "device" / "kernels" / "common.h").read_text()
    got = [float(re.search(rf"#define LUMA_{c} ([0-9.]+)f", src).group(1)) for c in "RGB"]
    assert got == list(LUMA)
    kernels = (ROOT / "src" / "fogcli" / "device" / "kernels").glob("*")
    assert not [k.name for k in kernels if k.name != "common.h" and "0.2126" in k.read_text()]


def test_luminance_weighs_each_channel():
    rgb = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]], np.float32)
    np.testing.assert_allclose(luminance(rgb), [0.2126, 0.7152, 0.0722, 1.0], rtol=1e-6)
