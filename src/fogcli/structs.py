"""What the host and the kernels share, declared once on the host: the structs the host
fills (numpy dtypes of the kernels' C structs), the codes of enumerations, and constants
both sides use. tests/test_structs.py measures every struct's size and member offsets on
the device and reads every constant and code from the kernels' headers: a change on one
side fails there instead of shifting or misreading values."""
from __future__ import annotations

import numpy as np

# -- structs (their C declarations: density.h camera_t, medium.h medium_t, lights.h
# lmedium_t and light_t, noise.h noise_t and tfm_t)
CAMERA_T = np.dtype([
    ("pos", np.float32, 4), ("rot", np.float32, (3, 4)), ("focal_px", np.float32),
    ("focal_y", np.float32), ("cx", np.float32), ("cy", np.float32), ("max_depth", np.float32),
    ("depth_is_z", np.int32), ("_pad", np.int32, 2),   # OpenCL rounds up to float4 alignment
], align=True)
MEDIUM_T = np.dtype([
    ("sa", np.float32, 4), ("ss", np.float32, 4), ("emission", np.float32, 4),
    ("ambient", np.float32, 4), ("cam", CAMERA_T), ("g", np.float32), ("spread_scale", np.float32),
    ("homogeneous", np.float32), ("has_medium_light", np.int32), ("has_p", np.int32),
    ("_pad", np.int32, 3),   # OpenCL rounds the struct up to its float4 alignment
], align=True)
LIGHT_T = np.dtype({"names": ["pos", "axis", "intensity", "radius", "cos_outer", "cos_inner", "type", "gain"],
                    "formats": [(np.float32, 4)] * 3 + [np.float32] * 3 + [np.int32] + [(np.float32, 4)],
                    "offsets": [0, 16, 32, 48, 52, 56, 60, 64], "itemsize": 80})
LMEDIUM_T = np.dtype({"names": ["sa", "ss", "g", "homogeneous", "nprims", "nodes"],
                      "formats": [(np.float32, 4)] * 2 + [np.float32] * 2 + [np.int32] * 2,
                      "offsets": [0, 16, 32, 36, 40, 44], "itemsize": 48})
NOISE_T = np.dtype({"names": ["center", "hsize", "factor", "inv_scale", "amplitude", "offset", "edge", "step",
                              "norm", "octaves", "seed", "shape"],
                    "formats": [(np.float32, 4)] * 2 + [np.float32] * 7 + [np.int32, np.uint32, np.int32],
                    "offsets": [0, 16, 32, 36, 40, 44, 48, 52, 56, 60, 64, 68], "itemsize": 80})
TFM_T = np.dtype({"names": ["origin", "e1", "e2", "e3", "extent", "kind", "size", "ncoef"],
                  "formats": [(np.float32, 4)] * 4 + [np.float32] + [np.int32] * 3,
                  "offsets": [0, 16, 32, 48, 64, 68, 72, 76], "itemsize": 80})

# -- codes and constants; C_NAMES says what each is called in the kernels' headers
LIGHT_TYPES = {"point": 0, "spot": 1, "directional": 2}                 # light_t.type
PRIM_TYPES = {"exponential": 1, "sphere": 2}                              # lights.h prims[3k].x
TFM_KINDS = {"octahedral": 0, "perspective": 1, "orthographic": 2}       # tfm_t.kind
NOISE_SHAPES = {"box": 0, "sphere": 1}                                    # noise_t.shape
NOISE_MAX_STEPS = 512       # steps of a noise march at most (noise.h, and the float64 oracle)
SH_BINS = 2048              # shadow map bins per epipolar slice: passed to shadows.cl (-D), which has no other

C_NAMES = {
    **{f"LIGHT_{k.upper()}": v for k, v in LIGHT_TYPES.items()},
    **{f"PRIM_{k.upper()}": v for k, v in PRIM_TYPES.items()},
    **{f"TFM_{k.upper()}": v for k, v in TFM_KINDS.items()},
    **{f"NOISE_{k.upper()}": v for k, v in NOISE_SHAPES.items()},
    "NOISE_MAX_STEPS": NOISE_MAX_STEPS,
}
