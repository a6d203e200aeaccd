"""A fuzz case: its inputs (a setup writing them into its folder) and its command line."""
from __future__ import annotations

import os
import random
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from fuzz.files import H, W, make_depth, make_image, zplane

# ============================================================================ cases


@dataclass
class Case:
    cls: str
    variant: str
    args: list
    setup: Callable | None = None     # setup(folder: Path) writes the inputs
    outputs: tuple | None = None      # files an exit 0 must leave; None: derived from the args
    out_dirs: tuple = ()              # batch: folders whose new files are outputs (exit 0 or 3)
    mutable: tuple = ()               # inputs a run may replace or remove (stale outputs)
    expect: str = ""                  # "refuse": exit 0 is a defect; "ok": a refusal is a defect
    env: dict = field(default_factory=dict)
    id: str = ""


def _files(**named):
    """A setup writing bytes / text / callables into the case folder."""
    def setup(d: Path):
        for rel, content in named.items():
            rel = rel.replace("__", "/").replace("_DOT_", ".")
            p = d / rel
            p.parent.mkdir(parents=True, exist_ok=True)
            if callable(content):
                content(p)
            elif isinstance(content, bytes):
                p.write_bytes(content)
            else:
                p.write_text(content)
    return setup


def _chain(*setups):
    def setup(d: Path):
        for s in setups:
            if s is not None:
                s(d)
    return setup


def _mkfifo(p: Path):
    os.mkfifo(p)


def _mkdir(p: Path):
    p.mkdir(parents=True, exist_ok=True)


def _chmod(rel: str, mode: int):
    def setup(d: Path):
        os.chmod(d / rel, mode)
    return setup


def _symlink(rel: str, target: str):
    def setup(d: Path):
        os.symlink(target, d / rel)
    return setup


def valid_exr(nr, h=H, w=W, kind="exr"):
    return lambda p: make_image(p, kind, nr, h, w)


def valid_depth(nr, kind="npy", h=H, w=W):
    z = zplane(nr, h, w)
    return lambda p: make_depth(p, kind, z)


MEDIA = ["fog", "haze", "sea", "harbour", "smoke", "valley-fog", "sandstorm", "smoke-ball"]
OUT_EXT = [".exr", ".png", ".tif", ".jpg", ".hdr"]


def spread(i: int, n_variants: int, n_modes: int) -> int:
    """The second dimension of case i (the first is i % n_variants): every mode appears
    within the first n_variants cases, and all pairs within n_variants * n_modes."""
    return (i + i // n_variants) % n_modes


def out_name(r: random.Random, stem="out") -> str:
    return stem + r.choice(OUT_EXT)


def extra_opts(r: random.Random, p=0.3) -> list:
    """A random subset of harmless options."""
    out = []
    if r.random() < p:
        out += ["--medium", r.choice(MEDIA)]
    if r.random() < p * 0.5:
        out += ["--set", r.choice(["render.method=naive", "render.kernel=6", "render.psf=gaussian",
                                    "camera.fov=90", "render.border=closed", "output.exposure=1"])]
    if r.random() < p * 0.3:
        out += ["--timings"]
    return out


# ---------------------------------------------------------------- class: valid images
