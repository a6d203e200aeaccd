"""Every generator class, with its share of a run, and the fixed fast subset tests/test_fuzz.py
runs."""
from __future__ import annotations

import random
import re
from typing import Callable

import numpy as np

from fuzz.case import Case, _files, valid_exr
from fuzz.gen_commands import gen_batch, gen_cli
from fuzz.gen_inputs import gen_channels, gen_image_corrupt, gen_image_header, gen_paths, gen_valid, gen_values
from fuzz.gen_settings import gen_camera, gen_config, gen_depth, gen_set

CLASSES: dict[str, tuple[Callable, float]] = {
    "valid": (gen_valid, 0.07),
    "image-corrupt": (gen_image_corrupt, 0.14),
    "image-header": (gen_image_header, 0.06),
    "image-channels": (gen_channels, 0.07),
    "image-values": (gen_values, 0.06),
    "paths": (gen_paths, 0.09),
    "depth": (gen_depth, 0.11),
    "config": (gen_config, 0.12),
    "set": (gen_set, 0.08),
    "camera": (gen_camera, 0.06),
    "cli": (gen_cli, 0.08),
    "batch": (gen_batch, 0.06),
}


def make_case(cls: str, i: int, seed: int = 0) -> Case:
    """Case i of a class, deterministic in (cls, i, seed)."""
    r = random.Random(f"{seed}:{cls}:{i}")
    nr = np.random.default_rng(r.getrandbits(64))
    case = CLASSES[cls][0](i, r, nr)
    case.id = f"{cls}-{i:04d}"
    return case


def build_cases(n: int, seed: int = 0, classes=None) -> list[Case]:
    names = [c for c in CLASSES if not classes or c in classes]
    total = sum(CLASSES[c][1] for c in names)
    counts = {c: int(n * CLASSES[c][1] / total) for c in names}
    for c in names[: n - sum(counts.values())]:
        counts[c] += 1
    return [make_case(c, i, seed) for c in names for i in range(counts[c])]


# a fixed fast subset covering every class (tests/test_fuzz.py): (class, variant prefix)
FAST = [
    ("valid", "exr-24x32"), ("valid", "png8-24x32"), ("valid", "exr-rgbaz-1x1"),
    ("image-corrupt", "exr/truncate"), ("image-corrupt", "exr-tiled/flip"), ("image-corrupt", "png8/truncate"),
    ("image-header", "png-20000x20000"), ("image-header", "exr-window-20000"), ("image-header", "png-short-idat"),
    ("image-channels", "A/.exr"), ("image-channels", "R+G+B+A+Z/.exr"),
    ("image-values", "exr/nan"), ("image-values", "exr/nan-alpha"),
    ("paths", "image/fifo"), ("paths", "depth/dir"), ("paths", "config/long-name-300"),
    ("depth", "npy/complex"), ("depth", "npy/int64-extremes"), ("depth", "npy/huge-shape"),
    ("config", "billion-laughs/config"), ("config", "quadratic-string/config"), ("config", "tiny-float/config"),
    ("config", "int-400-digits-fov/check"), ("config", "complex-key/medium"),
    ("set", "output.exposure=1e308"), ("set", "camera.depth_scale=1e-10"),
    ("camera", "deep-list"), ("camera", "fx-400-digits"), ("camera", "width-zero"),
    ("cli", "o-readonly"), ("cli", "o-240"), ("cli", "aov-png"), ("cli", "save-depth-missing"),
    ("cli", "batch-jobs-0"), ("cli", "o-camera-file"),
    ("batch", "exr+jpg-no-depth+png+depth|format=jpeg report=c.yaml"), ("batch", "save-depth=existing-file"),
    ("cli", "save-depth-300"), ("batch", "report=OUTPUT_DIR"),
]


def find_case(cls: str, variant_prefix: str, seed: int = 0, limit: int = 3000) -> Case:
    """The first case of a class whose variant starts with the prefix (contains it, for batch)."""
    for i in range(limit):
        c = make_case(cls, i, seed)
        if c.variant.startswith(variant_prefix) or (cls in ("batch", "set") and variant_prefix in c.variant):
            return c
    raise LookupError(f"no {cls} case {variant_prefix!r} in the first {limit}")


def set_case(item: str, seed: int = 0) -> Case:
    """One --set value on a valid frame."""
    nr = np.random.default_rng(seed)
    return Case("set", item, ["apply", "in.exr", "--set", item, "-o", "out.png"], _files(in_DOT_exr=valid_exr(nr)),
                id=f"set-{re.sub(r'[^a-z0-9]+', '-', item.lower())[:40]}")


def report_onto_output_dir_case(seed: int = 0) -> Case:
    """batch --report naming OUTPUT_DIR itself (it does not exist yet when the run starts)."""
    nr = np.random.default_rng(seed)
    return Case("batch", "report=OUTPUT_DIR", ["batch", "in", "out", "--report", "out", "-q"],
                _files(in__a_DOT_exr=valid_exr(nr)), outputs=("out",), out_dirs=("out",), id="batch-report-outdir")


def fast_cases(seed: int = 0) -> list[Case]:
    return [set_case(v, seed) if c == "set" else report_onto_output_dir_case(seed) if v == "report=OUTPUT_DIR"
            else find_case(c, v, seed) for c, v in FAST]
