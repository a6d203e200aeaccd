"""What the host and the kernels share, declared once on the host: the structs the host
fills (numpy dtypes of the kernels' C structs), the codes of enumerations, and constants
both sides use. tests/test_structs.py measures every struct's size and member offsets on
the device and reads every constant and code from the kernels' headers: a change on one
side fails there instead of shifting or misreading values."""
from __future__ import annotations

import math

import numpy as np

from fogcli.config.model import Config
from fogcli.device.geometry import rotation

# -- structs (their C declarations: density.h camera_t, medium.h medium_t, lights.h
# lmedium_t, light_t and al_table_t, noise.h noise_t and tfm_t)
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
AL_TABLE_T = np.dtype({"names": ["st", "lst", "sa", "r", "xm", "em", "off", "lk", "k", "gn", "g", "hf", "lkm", "vx",
                                "vy", "vz", "rad2"],
                      "formats": [(np.float32, 3)] * 6 + [(np.int32, 3)] + [(np.float32, 3)] * 3 + [np.float32] * 7,
                      "offsets": [0, 12, 24, 36, 48, 60, 72, 84, 96, 108, 120, 124, 128, 132, 136, 140, 144],
                      "itemsize": 148})
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


# -- filled from a config

def camera_struct(cfg: Config, width: int, height: int) -> np.ndarray:
    """The kernels take metric depth (depth.decode): z for z, disparity and inverse."""
    cam = cfg.camera
    s = np.zeros((), CAMERA_T)
    s["pos"] = [*cam.position, 0.0]
    s["rot"][:, :3] = rotation(cam.yaw, cam.pitch, cam.roll)
    s["focal_px"] = cam.focal(width)
    s["focal_y"] = cam.focal_y(width)
    s["cx"], s["cy"] = cam.centre(width, height)
    s["max_depth"] = cam.max_depth
    s["depth_is_z"] = 0 if cam.depth == "distance" else 1
    return s


def medium_struct(cfg: Config, width: int, height: int) -> np.ndarray:
    m = cfg.medium
    s = np.zeros((), MEDIUM_T)
    sa, ss = np.array(m.absorption, np.float32), np.array(m.scattering, np.float32)
    s["sa"] = [*sa, sa.mean()]
    s["ss"] = [*ss, ss.mean()]
    s["emission"] = [*m.emission, 0.0]
    s["ambient"] = [*m.ambient, 0.0]
    s["cam"] = camera_struct(cfg, width, height)
    s["g"] = m.asymmetry
    s["spread_scale"] = cfg.render.spread_scale
    s["homogeneous"] = m.homogeneous
    s["has_medium_light"] = int(any(m.emission) or any(m.ambient))
    s["has_p"] = int(m.heterogeneous)
    return s


def density_primitives(cfg: Config) -> list[tuple[str, float, float, np.ndarray, np.ndarray]]:
    """The non-homogeneous density primitives, encoded once for both kernel families:
    (type, factor, falloff or radius, unit direction or centre, offset: zeros for a sphere),
    in float64. The density kernels take them as arguments (primitive_launches), the light
    kernels as an array (lmedium_struct)."""
    out = []
    for d in cfg.medium.density:
        if d.type == "exponential":
            n = np.array(d.direction, np.float64)
            out.append(("exponential", d.factor, d.falloff, n / np.linalg.norm(n), np.array(d.offset, np.float64)))
        elif d.type == "sphere":
            out.append(("sphere", d.factor, d.radius, np.array(d.center, np.float64), np.zeros(3)))
    return out


def primitive_launches(cfg: Config) -> list[tuple[str, dict]]:
    """(kernel, its primitive arguments by name) per density primitive. For an exponential,
    factor * exp(-b <c - o, n>) (c the camera position) is the same for every pixel and is
    computed here in float64."""
    out = []
    cam = np.array(cfg.camera.position, np.float64)
    for kind, factor, b, v, offset in density_primitives(cfg):
        if kind == "exponential":
            pre = factor * math.exp(min(-b * float((cam - offset) @ v), 87.0))
            out.append(("p_exponential", dict(pre=np.float32(pre), b=np.float32(b), n=np.array([*v, 0.0], np.float32))))
        else:
            out.append(("p_sphere", dict(factor=np.float32(factor), radius=np.float32(b),
                                         centre=np.array([*v, 0.0], np.float32))))
    return out


def lmedium_struct(cfg: Config) -> tuple[np.ndarray, np.ndarray]:
    """(lmedium_t, prims float4 array): the non-homogeneous primitives as 3 float4 each."""
    m = cfg.medium
    s = np.zeros((), LMEDIUM_T)
    s["sa"], s["ss"] = [*m.absorption, 0.0], [*m.scattering, 0.0]
    s["g"] = m.asymmetry
    s["homogeneous"] = m.homogeneous
    s["nodes"] = cfg.render.lights.nodes
    prims = []
    for kind, factor, b, v, offset in density_primitives(cfg):
        prims += [[float(PRIM_TYPES[kind]), factor, b, 0.0], [*v, 0.0], [*offset, 0.0]]
    s["nprims"] = len(prims) // 3
    return s, np.array(prims or [[0.0] * 4] * 3, np.float32)
