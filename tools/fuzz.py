"""Fuzz the command line with malformed inputs and check fogcli's contract on every case.

    python tools/fuzz.py [--cases N] [--seed S] [--out DIR] [--work DIR] [--classes a,b]

Each case is a tiny folder of inputs (written by a seeded, deterministic generator) and one
`fogcli` command run in it as a subprocess (30 s timeout, its own process group). The
contract checked per case:

* exit 0, or 2 with exactly one stderr line starting with "fogcli: " or a file name (check:
  every line names its file); 3 only for `batch` (every stderr line "fogcli: ...", progress
  lines "[i/N] ..." tolerated); 1 is a defect for bad input (a device failure is not
  expected from these tiny inputs); anything else (signals) is a crash;
* no "Traceback", no Python / library warning lines (the word "warning" only in
  "fogcli: warning: ..."), no stray stderr lines on success;
* no hang (timeout), peak RSS (wait4's ru_maxrss of the child) at most 4 GB;
* nothing left behind: the folder holds the inputs plus, after exit 0, the expected outputs
  (batch: the output / save-depth folders and the report, also after exit 3); never a
  temporary file (".*.tmp*");
* inputs byte-identical afterwards;
* outputs of a success read back (OpenImageIO / NPY / JSON) and their colour is finite;
* obviously invalid inputs (missing, empty, truncated, ...) are refused, obviously valid
  ones are not.

Prints a table of counts per generator class and writes every defect (case id, class,
command, exit code, first stderr lines) to OUT/defects.json, with a grouping by signature
in OUT/signatures.json. tests/test_fuzz.py runs a fixed fast subset (fast_cases()).

As root, the commands run without CAP_DAC_OVERRIDE (setpriv), so that read-only folders and
unreadable files behave as they do for a user.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import random
import re
import shlex
import shutil
import signal
import stat
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

TIMEOUT = 30.0
RSS_LIMIT_MB = 4096            # flagged above this
RSS_KILL_MB = 10240            # a runaway case is killed (and flagged) above this
H, W = 24, 32                  # the default frame: tiny, 4:3

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from helpers import write_img  # noqa: E402  (the test suite's OpenImageIO writer)

# ============================================================================ files


def _oiio():
    import OpenImageIO as oiio

    return oiio


def colour(nr, h=H, w=W, c=3, hdr=True):
    rgb = nr.uniform(0.0, 1.0, (h, w, c)).astype(np.float32)
    if hdr and h > 2 and w > 2:
        rgb[nr.integers(0, h), nr.integers(0, w), :3] = 50.0       # a lamp
    return rgb


def zplane(nr, h=H, w=W):
    z = nr.uniform(2.0, 200.0, (h, w)).astype(np.float32)
    if h > 4:
        z[:2] = np.inf                                              # sky
    return z


# image kinds: (extension, has an embedded depth)
IMAGE_KINDS = {
    "exr": ".exr", "exr-half": ".exr", "exr-rgbaz": ".exr", "exr-tiled": ".exr", "exr-multipart": ".exr",
    "exr-multiview": ".exr", "exr-layers": ".exr", "png8": ".png", "png16": ".png", "png8-rgba": ".png",
    "png-grey": ".png", "tif8": ".tif", "tif16": ".tif", "tif-float": ".tif", "tif-rgba": ".tif",
    "tif-cmyk": ".tif", "jpg": ".jpg", "hdr": ".hdr",
}
EMBEDDED_Z = {"exr", "exr-half", "exr-rgbaz", "exr-tiled", "exr-multipart", "exr-multiview", "exr-layers"}


def make_image(path: Path, kind: str, nr, h=H, w=W) -> None:
    rgb = colour(nr, h, w)
    z = zplane(nr, h, w)
    disp = np.clip(rgb, 0, 1)
    if kind == "exr":
        write_img(path, np.dstack([rgb, z]), ["R", "G", "B", "Z"])
    elif kind == "exr-none":          # uncompressed scanlines: offsets are predictable
        write_img(path, np.dstack([rgb, z]), ["R", "G", "B", "Z"], attrs=[("compression", "none")])
    elif kind == "exr-half":
        write_img(path, np.dstack([rgb, z]), ["R", "G", "B", "Z"], fmt="half")
    elif kind == "exr-rgbaz":
        a = nr.uniform(0, 1, (h, w)).astype(np.float32)
        a[: h // 3] = 0.0
        write_img(path, np.dstack([rgb * a[:, :, None], a, z]), ["R", "G", "B", "A", "Z"])
    elif kind == "exr-tiled":
        write_img(path, np.dstack([rgb, z]), ["R", "G", "B", "Z"], tile=(16, 16))
    elif kind == "exr-layers":
        names = ["ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B",
                 "diffuse.R", "diffuse.G", "diffuse.B", "ViewLayer.Depth.Z", "P.Z"]
        write_img(path, np.dstack([rgb, rgb * 0.5, z, z]), names)
    elif kind == "exr-multipart":
        oiio = _oiio()
        s1 = oiio.ImageSpec(w, h, 3, "float")
        s1.channelnames = ("R", "G", "B")
        s1.attribute("name", "rgba")
        s2 = oiio.ImageSpec(w, h, 1, "float")
        s2.channelnames = ("Z",)
        s2.attribute("name", "depth")
        out = oiio.ImageOutput.create(str(path))
        assert out.open(str(path), [s1, s2])
        out.write_image(np.ascontiguousarray(rgb))
        out.open(str(path), s2, "AppendSubimage")
        out.write_image(np.ascontiguousarray(z[:, :, None]))
        out.close()
    elif kind == "exr-multiview":
        oiio = _oiio()
        names = ["R", "G", "B", "Z", "right.R", "right.G", "right.B", "right.Z"]
        write_img(path, np.dstack([rgb, z, rgb[:, :, ::-1], z]), names,
                  attrs=[("multiView", oiio.TypeDesc("string[2]"), ("left", "right"))])
    elif kind == "png8":
        write_img(path, np.round(disp * 255).astype(np.uint8), ["R", "G", "B"], fmt="uint8")
    elif kind == "png16":
        write_img(path, np.round(disp * 65535).astype(np.uint16), ["R", "G", "B"], fmt="uint16")
    elif kind == "png8-rgba":
        a = nr.uniform(0, 1, (h, w, 1))
        write_img(path, np.round(np.dstack([disp, a]) * 255).astype(np.uint8), ["R", "G", "B", "A"], fmt="uint8")
    elif kind == "png-grey":
        write_img(path, np.round(disp[:, :, :1] * 255).astype(np.uint8), ["Y"], fmt="uint8")
    elif kind == "tif8":
        write_img(path, np.round(disp * 255).astype(np.uint8), ["R", "G", "B"], fmt="uint8")
    elif kind == "tif16":
        write_img(path, np.round(disp * 65535).astype(np.uint16), ["R", "G", "B"], fmt="uint16")
    elif kind == "tif-float":
        write_img(path, rgb, ["R", "G", "B"])
    elif kind == "tif-rgba":
        a = nr.uniform(0, 1, (h, w, 1))
        write_img(path, np.round(np.dstack([disp, a]) * 65535).astype(np.uint16), ["R", "G", "B", "A"], fmt="uint16")
    elif kind == "tif-cmyk":
        k = nr.uniform(0, 1, (h, w, 1))
        write_img(path, np.round(np.dstack([disp, k]) * 255).astype(np.uint8), ["C", "M", "Y", "K"], fmt="uint8",
                  attrs=[("tiff:ColorSpace", "CMYK")])
    elif kind == "jpg":
        write_img(path, np.round(disp * 255).astype(np.uint8), ["R", "G", "B"], fmt="uint8")
    elif kind == "hdr":
        write_img(path, rgb, ["R", "G", "B"])
    else:
        raise ValueError(kind)


DEPTH_KINDS = {"npy": ".npy", "exr": ".exr", "tif": ".tif", "png16": ".png"}


def make_depth(path: Path, kind: str, z: np.ndarray) -> None:
    if kind == "npy":
        np.save(path, z.astype(np.float32))
    elif kind == "exr":
        write_img(path, z[:, :, None].astype(np.float32), ["Z"])
    elif kind == "tif":
        write_img(path, z[:, :, None].astype(np.float32), ["Y"])
    elif kind == "png16":
        mm = np.where(np.isfinite(z), np.clip(z * 1000.0, 0, 65535), 0)
        write_img(path, np.round(mm)[:, :, None].astype(np.uint16), ["Y"], fmt="uint16")
    else:
        raise ValueError(kind)


def image_bytes(kind: str, nr, h=H, w=W, **kw) -> bytes:
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / ("x" + IMAGE_KINDS.get(kind, kind))
        make_image(p, kind, nr, h, w)
        return p.read_bytes()


IMAGE_KINDS["exr-none"] = ".exr"
EMBEDDED_Z.add("exr-none")


# ---------------------------------------------------------------- byte-level corruption

def truncate(b: bytes, r: random.Random) -> bytes:
    return b[: r.randint(0, max(0, int(len(b) * 0.9)))]


def flip(b: bytes, r: random.Random) -> bytes:
    a = bytearray(b)
    for _ in range(r.randint(1, 24)):
        i = r.randrange(min(len(a), 512)) if r.random() < 0.6 else r.randrange(len(a))
        a[i] ^= r.randint(1, 255)
    return bytes(a)


def zero_run(b: bytes, r: random.Random) -> bytes:
    a = bytearray(b)
    n = r.randint(1, max(1, len(a) // 4))
    i = r.randrange(max(1, len(a) - n))
    a[i:i + n] = bytes(n)
    return bytes(a)


def corrupt(b: bytes, how: str, r: random.Random) -> bytes:
    if how == "truncate":
        return truncate(b, r)
    if how == "flip":
        return flip(b, r)
    if how == "zeros":
        return zero_run(b, r)
    if how == "all-zero":
        return bytes(len(b))
    if how == "empty":
        return b""
    if how == "header-only":
        return b[:16]
    if how == "garbage":
        return bytes(r.getrandbits(8) for _ in range(r.randint(1, 4096)))
    if how == "doubled":
        return b + b
    raise ValueError(how)


CORRUPTIONS = ["truncate", "flip", "zeros", "truncate", "flip", "all-zero", "empty", "header-only", "garbage",
               "doubled"]
REFUSE_CORRUPTIONS = {"truncate", "all-zero", "empty", "header-only", "garbage"}


# ---------------------------------------------------------------- crafted headers

def png_chunk(t: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + t + data + struct.pack(">I", zlib.crc32(t + data) & 0xFFFFFFFF)


def craft_png(w, h, depth=8, ctype=2, interlace=0, idat=None, plte=False) -> bytes:
    ihdr = struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, interlace)
    body = png_chunk(b"IHDR", ihdr)
    if plte:
        body += png_chunk(b"PLTE", bytes(range(48)))
    body += png_chunk(b"IDAT", zlib.compress(b"\x00" * 64) if idat is None else idat)
    return b"\x89PNG\r\n\x1a\n" + body + png_chunk(b"IEND", b"")


def patch_exr_box(b: bytes, box, attr=b"dataWindow") -> bytes:
    key = attr + b"\x00box2i\x00"
    i = b.find(key)
    assert i >= 0
    j = i + len(key) + 4
    return b[:j] + struct.pack("<4i", *box) + b[j + 16:]


def patch_tiff_size(b: bytes, w: int, h: int) -> bytes:
    e = "<" if b[:2] == b"II" else ">"
    off = struct.unpack(e + "I", b[4:8])[0]
    n = struct.unpack(e + "H", b[off:off + 2])[0]
    a = bytearray(b)
    for k in range(n):
        p = off + 2 + 12 * k
        tag = struct.unpack(e + "H", a[p:p + 2])[0]
        if tag in (256, 257):
            struct.pack_into(e + "HHII", a, p, tag, 4, 1, w if tag == 256 else h)
    return bytes(a)


def patch_jpeg_size(b: bytes, w: int, h: int) -> bytes:
    a = bytearray(b)
    for m in (b"\xff\xc0", b"\xff\xc1", b"\xff\xc2"):
        i = a.find(m)
        if i >= 0:
            struct.pack_into(">HH", a, i + 5, h, w)
            return bytes(a)
    return bytes(a)


def craft_hdr(w: int, h: int, payload: bytes = b"\x80\x80\x80\x81" * 16) -> bytes:
    return b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {h} +X {w}\n".encode() + payload


def craft_npy(descr: str, shape, payload: bytes = b"", fortran=False, magic=b"\x93NUMPY\x01\x00",
              header: str | None = None) -> bytes:
    hdr = header if header is not None else \
        "{'descr': %r, 'fortran_order': %s, 'shape': %r, }" % (descr, fortran, tuple(shape))
    raw = hdr.encode("latin1")
    pad = 64 - ((10 + len(raw) + 1) % 64)
    raw = raw + b" " * pad + b"\n"
    return magic + struct.pack("<H", len(raw)) + raw + payload


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

def gen_valid(i, r, nr):
    """Valid small inputs of every format and some degenerate sizes: must succeed."""
    kinds = [k for k in IMAGE_KINDS if k not in ("tif-cmyk",)]
    sizes = [(H, W), (1, 1), (1, 2), (2, 1), (1, 64), (64, 1), (3, 5), (7, 3), (33, 17), (2, 2)]
    kind = kinds[i % len(kinds)]
    h, w = sizes[(i // len(kinds)) % len(sizes)] if i >= len(kinds) else (H, W)
    ext = IMAGE_KINDS[kind]
    files = {f"in{ext}".replace(".", "_DOT_"): (lambda p, k=kind: make_image(p, k, nr, h, w))}
    args = ["apply", f"in{ext}"]
    if kind not in EMBEDDED_Z or r.random() < 0.2:
        dk = r.choice(list(DEPTH_KINDS))
        files[f"d{DEPTH_KINDS[dk]}".replace(".", "_DOT_")] = valid_depth(nr, dk, h, w)
        args += ["--depth", f"d{DEPTH_KINDS[dk]}"]
    args += ["-o", out_name(r)] + extra_opts(r)
    if kind == "exr-multiview" and r.random() < 0.5:
        args += ["--view", "right"]
    if kind == "exr-layers" and r.random() < 0.5:
        args += ["--layer", r.choice(["ViewLayer.Combined", "diffuse", "Combined"])]
    return Case("valid", f"{kind}-{h}x{w}", args, _files(**files), expect="ok")


# ---------------------------------------------------------------- class: corrupt images

def gen_image_corrupt(i, r, nr):
    kinds = [k for k in IMAGE_KINDS if k not in ("exr-multiview",)]
    kind = kinds[i % len(kinds)]
    how = CORRUPTIONS[spread(i, len(kinds), len(CORRUPTIONS))]
    ext = IMAGE_KINDS[kind]
    data = corrupt(image_bytes(kind, nr), how, r)
    args = ["apply", f"in{ext}"]
    files = {f"in{ext}".replace(".", "_DOT_"): data}
    if kind not in EMBEDDED_Z:
        files["d_DOT_npy"] = valid_depth(nr)
        args += ["--depth", "d.npy"]
    args += ["-o", out_name(r)]
    expect = "refuse" if how in REFUSE_CORRUPTIONS else ""
    return Case("image-corrupt", f"{kind}/{how}", args, _files(**files), expect=expect)


# ---------------------------------------------------------------- class: crafted headers

def _header_variants(nr):
    exr = image_bytes("exr-none", nr)
    tif = image_bytes("tif8", nr)
    jpg = image_bytes("jpg", nr)
    return [
        ("png-20000x20000", ".png", craft_png(20000, 20000)),
        ("png-11000x11000-rgba16", ".png", craft_png(11000, 11000, 16, 6)),
        ("png-0x0", ".png", craft_png(0, 0)),
        ("png-1x2147483647", ".png", craft_png(1, 2**31 - 1)),
        ("png-65535x65535-rgba16", ".png", craft_png(65535, 65535, 16, 6)),
        ("png-short-idat", ".png", craft_png(W, H)),
        ("png-bitdepth-3", ".png", craft_png(W, H, 3, 2)),
        ("png-colortype-7", ".png", craft_png(W, H, 8, 7)),
        ("png-palette-no-plte", ".png", craft_png(W, H, 8, 3)),
        ("png-interlaced-short", ".png", craft_png(W, H, 8, 2, 1)),
        ("png-bad-zlib", ".png", craft_png(W, H, idat=b"\x78\x9c" + bytes(range(200)))),
        ("exr-window-20000", ".exr", patch_exr_box(exr, (0, 0, 19999, 19999))),
        ("exr-window-11000", ".exr", patch_exr_box(exr, (0, 0, 10999, 10999))),
        ("exr-window-inverted", ".exr", patch_exr_box(exr, (0, 0, -5, -5))),
        ("exr-window-extreme", ".exr", patch_exr_box(exr, (-2**31, -2**31, 2**31 - 1, 2**31 - 1))),
        ("exr-window-1x11000000", ".exr", patch_exr_box(exr, (0, 0, 0, 10_999_999))),
        ("exr-window-shifted", ".exr", patch_exr_box(exr, (1000, 1000, 1000 + W - 1, 1000 + H - 1))),
        ("exr-display-huge", ".exr", patch_exr_box(exr, (0, 0, 2**31 - 2, 2**31 - 2), b"displayWindow")),
        ("exr-display-inverted", ".exr", patch_exr_box(exr, (10, 10, 0, 0), b"displayWindow")),
        ("tif-20000x20000", ".tif", patch_tiff_size(tif, 20000, 20000)),
        ("tif-11000x11000", ".tif", patch_tiff_size(tif, 11000, 11000)),
        ("tif-0-width", ".tif", patch_tiff_size(tif, 0, H)),
        ("tif-1x4000000000", ".tif", patch_tiff_size(tif, 1, 4_000_000_000)),
        ("jpg-65535x65535", ".jpg", patch_jpeg_size(jpg, 65535, 65535)),
        ("jpg-11000x11000", ".jpg", patch_jpeg_size(jpg, 11000, 11000)),
        ("jpg-0x0", ".jpg", patch_jpeg_size(jpg, 0, 0)),
        ("hdr-20000x20000", ".hdr", craft_hdr(20000, 20000)),
        ("hdr-11000x11000", ".hdr", craft_hdr(11000, 11000)),
        ("hdr-0x0", ".hdr", craft_hdr(0, 0)),
        ("hdr-negative", ".hdr", craft_hdr(-5, -5)),
        ("hdr-bad-format", ".hdr", b"#?RADIANCE\nFORMAT=nonsense\n\n-Y 24 +X 32\n" + bytes(64)),
        ("npy-as-image", ".npy", craft_npy("<f4", (H, W), bytes(H * W * 4))),
    ]


def gen_image_header(i, r, nr):
    variants = _header_variants(nr)
    name, ext, data = variants[i % len(variants)]
    args = ["apply", f"in{ext}"]
    files = {f"in{ext}".replace(".", "_DOT_"): data}
    if ext != ".exr":
        files["d_DOT_npy"] = valid_depth(nr)
        args += ["--depth", "d.npy"]
    args += ["-o", out_name(r)]
    expect = "" if name in ("exr-window-shifted", "exr-display-huge", "exr-display-inverted") else "refuse"
    return Case("image-header", name, args, _files(**files), expect=expect)


# ---------------------------------------------------------------- class: channel layouts

CHANNEL_SETS = [
    ["Y"], ["A"], ["Z"], ["depth.Z"], ["N.X", "N.Y", "N.Z"], ["P.X", "P.Y", "P.Z"], ["Y", "Z"], ["Y", "A"],
    ["A", "Z"], ["R", "G", "Z"], ["R", "G", "B"], ["R", "G", "B", "A"], ["Y", "A", "Z"],
    ["R", "G", "B", "A", "Z"], ["R", "G", "B", "Z", "N.X", "N.Y", "N.Z"], ["a", "b", "c", "d", "e"],
    ["c0", "c1", "c2", "c3", "c4", "c5", "c6"], ["R", "R", "R"], ["", "G", "B"], ["Z", "Z", "Z", "Z", "Z"],
    ["depth", "distance", "Pz"], ["red", "green", "blue", "alpha", "Z"], ["beauty.R", "beauty.G", "beauty.B",
                                                                          "Depth.Z"],
    ["P.Z", "N.Z", "Normal.Z"], ["R", "G", "B", "A", "depth.Z"], ["x" * 200 + ".R", "G", "B", "Z"],
]


def gen_channels(i, r, nr):
    names = CHANNEL_SETS[i % len(CHANNEL_SETS)]
    mode = spread(i, len(CHANNEL_SETS), 4)        # exr float / exr half / tif / with --depth
    c = len(names)
    data = nr.uniform(0, 1, (H, W, c)).astype(np.float32)
    for k, n in enumerate(names):
        if n.lower().endswith(("z", "depth", "distance")) and n not in ("N.Z", "Normal.Z"):
            data[:, :, k] = zplane(nr)
    if "A" in names and r.random() < 0.5:
        data[:, :, names.index("A")][::3] = np.nan                      # NaN alpha
    ext = ".tif" if mode == 2 else ".exr"
    fmt = "half" if mode == 1 else "float"
    if mode == 1 and r.random() < 0.3:
        fmt = "uint"                                                     # uint32 EXR channels

    def mk(p):
        nm = [n or "unnamed" for n in names]
        if len(set(nm)) < len(nm):                                       # OIIO needs unique names
            nm = [f"{n}{k}" if nm.count(n) > 1 and k else n for k, n in enumerate(nm)]
        write_img(p, np.nan_to_num(data * 1000, nan=0, posinf=4e9).astype(np.uint32) if fmt == "uint" else data, nm, fmt=fmt)

    args = ["apply", f"in{ext}"]
    files = {f"in{ext}".replace(".", "_DOT_"): mk}
    if mode == 3 or ext == ".tif":
        files["d_DOT_exr"] = valid_depth(nr, "exr")
        args += ["--depth", "d.exr"]
    if r.random() < 0.2:
        args += ["--layer", r.choice(["N", "P", "beauty", "depth", "nope"])]
    args += ["-o", out_name(r)]
    return Case("image-channels", f"{'+'.join(names)[:40]}/{ext}/{fmt}", args, _files(**files))


# ---------------------------------------------------------------- class: pixel values

VALUE_KINDS = ["nan", "inf", "-inf", "flt-max", "-flt-max", "1e19", "1e21", "negative", "-1e19", "denormal",
               "all-zero", "nan-alpha", "alpha>1", "negative-alpha", "inf-alpha", "half-max", "z-nan-all",
               "z-negative", "z-flt-max", "z-denormal", "z-inf-all", "z-one-valid"]


def gen_values(i, r, nr):
    v = VALUE_KINDS[i % len(VALUE_KINDS)]
    fmt_kind = ["exr", "exr-half", "tif-float", "hdr"][spread(i, len(VALUE_KINDS), 4)]
    rgb = colour(nr)
    a = np.ones((H, W), np.float32)
    z = zplane(nr)
    pick = (nr.integers(0, H, 5), nr.integers(0, W, 5))
    f32max = np.finfo(np.float32).max
    special = {"nan": np.nan, "inf": np.inf, "-inf": -np.inf, "flt-max": f32max, "-flt-max": -f32max,
               "1e19": 1e19, "1e21": 1e21, "negative": -3.0, "-1e19": -1e19, "denormal": 1e-40,
               "half-max": 65504.0}
    expect = ""
    if v in special:
        rgb[pick] = special[v]
        if v in ("nan", "inf", "-inf", "flt-max", "-flt-max", "1e21"):
            expect = "refuse"
    elif v == "all-zero":
        rgb[:] = 0
    elif v == "nan-alpha":
        a[pick] = np.nan
    elif v == "alpha>1":
        a[pick] = 7.0
    elif v == "negative-alpha":
        a[pick] = -2.0
    elif v == "inf-alpha":
        a[pick] = np.inf
    elif v == "z-nan-all":
        z[:] = np.nan
        expect = "refuse"
    elif v == "z-negative":
        z[:] = -5
        expect = "refuse"
    elif v == "z-flt-max":
        z[pick] = f32max
    elif v == "z-denormal":
        z[pick] = 1e-40
    elif v == "z-inf-all":
        z[:] = np.inf
    elif v == "z-one-valid":
        z[:] = np.nan
        z[3, 4] = 10.0
    has_a = "alpha" in v
    ext = IMAGE_KINDS[fmt_kind]
    if ext == ".exr":
        names = ["R", "G", "B"] + (["A"] if has_a else []) + ["Z"]
        data = np.dstack([rgb] + ([a] if has_a else []) + [z])
        files = {"in_DOT_exr": lambda p: write_img(p, data, names, fmt="half" if fmt_kind == "exr-half" else "float")}
        args = ["apply", "in.exr"]
    else:
        names = ["R", "G", "B"] + (["A"] if has_a and ext == ".tif" else [])
        data = np.dstack([rgb] + ([a] if has_a and ext == ".tif" else []))
        files = {f"in{ext}".replace(".", "_DOT_"): lambda p: write_img(p, data, names),
                 "d_DOT_npy": lambda p: np.save(p, z)}
        args = ["apply", f"in{ext}", "--depth", "d.npy"]
    if (fmt_kind in ("exr-half", "hdr") and v in ("flt-max", "-flt-max", "1e19", "1e21", "-1e19")) or \
            (fmt_kind == "hdr" and v in ("nan", "inf", "-inf")):
        expect = ""                      # half / RGBE cannot hold them: stored as inf or clamped
    args += ["-o", out_name(r)] + extra_opts(r, 0.2)
    return Case("image-values", f"{fmt_kind}/{v}", args, _files(**files), expect=expect)


# ---------------------------------------------------------------- class: path kinds

def gen_paths(i, r, nr):
    """Directories, pipes, devices, missing files, links, wrong extensions, odd names, in
    every path position."""
    kinds = ["missing", "dir", "fifo", "dangling-link", "link-loop", "unreadable", "dev-null", "dev-zero",
             "exr-as-png", "png-as-exr", "exr-as-npy", "exr-as-txt", "exr-no-ext", "exr-upper", "garbage-dng",
             "tif-as-dng", "empty-dng", "yaml-ext", "long-name-300", "name-240", "newline-name", "unicode-name",
             "space-name", "dash-name", "link-to-dir"]
    positions = ["image", "depth", "medium", "config", "camera"]
    kind = kinds[i % len(kinds)]
    pos = positions[spread(i, len(kinds), len(positions))]
    files = {"in_DOT_exr": valid_exr(nr)}
    setups = []
    target = {"image": "x.exr", "depth": "x.npy", "medium": "x.yaml", "config": "x.yaml", "camera": "x.json"}[pos]
    stem, ext = target.split(".")
    expect = "refuse"

    def valid_target(p):
        if pos == "image":
            make_image(p, "exr", nr)
        elif pos == "depth":
            np.save(p, zplane(nr)) if p.suffix == ".npy" else make_depth(p, "exr", zplane(nr))
        elif pos in ("medium", "config"):
            p.write_text("medium:\n  visibility: 80\n")
        else:
            p.write_text('{"fx": 30, "fy": 30}')

    name = target
    if kind == "missing":
        pass
    elif kind == "dir":
        setups.append(lambda d: (d / name).mkdir())
    elif kind == "fifo":
        setups.append(lambda d: os.mkfifo(d / name))
    elif kind == "dangling-link":
        setups.append(_symlink(name, "nowhere." + ext))
    elif kind == "link-loop":
        setups.append(lambda d: (os.symlink("b." + ext, d / name), os.symlink(name, d / ("b." + ext))))
    elif kind == "link-to-dir":
        setups.append(lambda d: ((d / "sub").mkdir(), os.symlink("sub", d / name)))
    elif kind == "unreadable":
        setups.append(lambda d: (valid_target(d / name), os.chmod(d / name, 0)))
    elif kind == "dev-null":
        name = "/dev/null"
    elif kind == "dev-zero":
        name = "/dev/zero"
    elif kind in ("exr-as-png", "png-as-exr", "exr-as-npy", "exr-as-txt", "exr-no-ext", "exr-upper",
                  "tif-as-dng", "garbage-dng", "empty-dng", "yaml-ext"):
        src_kind, new_ext = {"exr-as-png": ("exr", ".png"), "png-as-exr": ("png16", ".exr"),
                             "exr-as-npy": ("exr", ".npy"), "exr-as-txt": ("exr", ".txt"),
                             "exr-no-ext": ("exr", ""), "exr-upper": ("exr", ".EXR"),
                             "tif-as-dng": ("tif16", ".dng"), "garbage-dng": (None, ".dng"),
                             "empty-dng": (None, ".DNG"), "yaml-ext": ("exr", ".yaml")}[kind]
        name = stem + new_ext
        if src_kind:
            data = image_bytes(src_kind, nr)
        else:
            data = b"" if kind == "empty-dng" else bytes(r.getrandbits(8) for _ in range(2048))
        setups.append(lambda d: (d / name).write_bytes(data))
        if pos in ("medium", "config") and kind == "empty-dng":
            expect = ""                     # an empty file is an empty config
        if pos in ("image", "depth"):       # image files are recognised by content, NPY by extension
            expect = "refuse" if kind in ("garbage-dng", "empty-dng", "exr-as-npy") else ""
            if pos == "depth" and kind == "png-as-exr":
                expect = ""
    elif kind == "long-name-300":
        name = "n" * 300 + "." + ext
    elif kind in ("name-240", "newline-name", "unicode-name", "space-name", "dash-name"):
        name = {"name-240": "n" * 240 + "." + ext, "newline-name": "a\nb." + ext,
                "unicode-name": "\u00e9\u4e2d\U0001f600\u202e." + ext, "space-name": " a b ." + ext,
                "dash-name": "-x." + ext}[kind]
        setups.append(lambda d: valid_target(d / name))
        expect = "ok" if kind != "dash-name" else ""
    args = ["apply"]
    if pos == "image":
        args += [name, "-o", "out.exr"]
        files.pop("in_DOT_exr")
    else:
        args += ["in.exr", {"depth": "--depth", "medium": "--medium", "config": "--config",
                            "camera": "--camera"}[pos], name, "-o", "out.exr"]
    if expect == "ok" and pos == "image" and kind == "dash-name":
        expect = ""
    return Case("paths", f"{pos}/{kind}", args, _chain(_files(**files), *setups), expect=expect)


# ---------------------------------------------------------------- class: depth files

NPY_VARIANTS = ["empty", "empty-1d", "3d", "hw1", "1d", "0d", "complex", "object", "bool", "structured",
                "datetime", "float16", "longdouble", "big-endian", "fortran", "int64-extremes", "uint64-max",
                "int8", "uint16-mm", "huge-shape", "shape-over-limit", "shape-under-limit", "negative-shape",
                "overflow-shape", "bad-magic", "version-3", "code-header", "short-payload", "all-nan",
                "all-zero", "all-negative", "all-inf", "one-valid", "1e38", "denormals", "mismatch-size",
                "half-size", "double-size", "transposed", "1x1", "huge-aspect", "float64-huge", "unicode-str"]


# contents whose meaning depends on camera.depth (inverse depth normalises any constant)
VALUE_VARIANTS = {"all-nan", "all-zero", "all-negative", "all-inf", "one-valid", "1e38", "denormals", "float64-huge",
                  "int64-extremes", "uint64-max", "int8", "bool"}


def npy_variant(v: str, nr) -> tuple[bytes | Callable, str]:
    """(content, expectation) of one .npy depth for an H x W image."""
    z = zplane(nr)
    e = ""

    def save(arr, **kw):
        return lambda p: np.save(p, arr, **kw)

    i64 = np.iinfo(np.int64)
    table = {
        "empty": (save(np.zeros((0, 0), np.float32)), "refuse"),
        "empty-1d": (save(np.zeros(0, np.float32)), "refuse"),
        "3d": (save(np.dstack([z, z, z])), "refuse"),
        "hw1": (save(z[:, :, None]), "ok"),
        "1d": (save(z.ravel()), "refuse"),
        "0d": (save(np.array(5.0)), "refuse"),
        "complex": (save(z.astype(np.complex64)), "refuse"),
        "object": (save(np.array([[1, "a"], [None, 2.0]], dtype=object), allow_pickle=True), "refuse"),
        "bool": (save(np.ones((H, W), bool)), ""),
        "structured": (save(np.zeros((H, W), [("a", "<f4"), ("b", "<i4")])), "refuse"),
        "datetime": (save(np.zeros((H, W), "datetime64[s]")), "refuse"),
        "float16": (save(np.nan_to_num(z, posinf=60000).astype(np.float16)), "ok"),
        "longdouble": (save(z.astype(np.longdouble)), "ok"),
        "big-endian": (save(z.astype(">f4")), "ok"),
        "fortran": (save(np.asfortranarray(z)), "ok"),
        "int64-extremes": (save(np.where(nr.uniform(size=(H, W)) < 0.5, i64.max, i64.min).astype(np.int64)), ""),
        "uint64-max": (save(np.full((H, W), np.iinfo(np.uint64).max, np.uint64)), ""),
        "int8": (save(nr.integers(-128, 127, (H, W)).astype(np.int8)), ""),
        "uint16-mm": (save(nr.integers(500, 60000, (H, W)).astype(np.uint16)), "ok"),
        "huge-shape": (craft_npy("<f4", (100000, 100000), bytes(64)), "refuse"),
        "shape-over-limit": (craft_npy("<f4", (20000, 20000), bytes(64)), "refuse"),
        "shape-under-limit": (craft_npy("<f8", (9000, 12000), bytes(64)), "refuse"),
        "negative-shape": (craft_npy("<f4", (-1, 5), bytes(64)), "refuse"),
        "overflow-shape": (craft_npy("<f4", (2**62, 4), bytes(64)), "refuse"),
        "bad-magic": (b"\x93NUMPX\x01\x00" + bytes(100), "refuse"),
        "version-3": (craft_npy("<f4", (H, W), bytes(H * W * 4), magic=b"\x93NUMPY\x03\x00"), ""),
        "code-header": (craft_npy("", (), bytes(16), header="{'descr': __import__('os').getcwd(), "
                                                             "'fortran_order': False, 'shape': (2, 2)}"),
                        "refuse"),
        "short-payload": (craft_npy("<f4", (H, W), bytes(H * W * 4 - 7)), "refuse"),
        "all-nan": (save(np.full((H, W), np.nan, np.float32)), "refuse"),
        "all-zero": (save(np.zeros((H, W), np.float32)), "refuse"),
        "all-negative": (save(-z), "refuse"),
        "all-inf": (save(np.full((H, W), np.inf, np.float32)), ""),
        "one-valid": (save(np.where(np.arange(H * W).reshape(H, W) == 77, 10.0, np.nan).astype(np.float32)), ""),
        "1e38": (save(np.full((H, W), 1e38, np.float32)), ""),
        "denormals": (save(np.full((H, W), 1e-42, np.float32)), "refuse"),
        "mismatch-size": (save(np.ones((H + 1, W), np.float32)), "refuse"),
        "half-size": (save(zplane(nr, H // 2, W // 2)), "ok"),
        "double-size": (save(zplane(nr, H * 2, W * 2)), ""),
        "transposed": (save(zplane(nr, W, H)), "refuse"),
        "1x1": (save(np.ones((1, 1), np.float32)), "refuse"),
        "huge-aspect": (save(np.ones((1, 1000), np.float32)), "refuse"),
        "float64-huge": (save(np.full((H, W), 1e300)), ""),
        "unicode-str": (save(np.full((H, W), "zz")), "refuse"),
    }
    content, e = table[v]
    return content, e


def gen_depth(i, r, nr):
    """Depth files: the NPY zoo, corrupt depth files of every format, sizes, and decoding
    modes (disparity, inverse, cityscapes) over odd contents."""
    n_npy = len(NPY_VARIANTS)
    block = i % (n_npy + 20)
    img_kind = r.choice(["exr", "png8", "tif16"])
    img = "in" + IMAGE_KINDS[img_kind]
    files = {img.replace(".", "_DOT_"): (lambda p, k=img_kind: make_image(p, k, nr))}
    args = ["apply", img]
    if block < n_npy:
        v = NPY_VARIANTS[block]
        content, expect = npy_variant(v, nr)
        files["d_DOT_npy"] = content
        args += ["--depth", "d.npy"]
        variant = f"npy/{v}"
    else:
        dk = r.choice(list(DEPTH_KINDS) + ["jpg", "png8", "exr-rgb", "tif3"])
        how = r.choice(CORRUPTIONS + ["none", "none", "mode"])
        with tempfile.TemporaryDirectory() as d:
            ext = DEPTH_KINDS.get(dk, {"jpg": ".jpg", "png8": ".png", "exr-rgb": ".exr", "tif3": ".tif"}.get(dk))
            p = Path(d) / ("d" + ext)
            z = zplane(nr)
            if dk in DEPTH_KINDS:
                make_depth(p, dk, z)
            elif dk == "jpg" or dk == "png8":
                write_img(p, np.clip(z / 4, 0, 255).astype(np.uint8)[:, :, None], ["Y"], fmt="uint8")
            elif dk == "exr-rgb":
                write_img(p, colour(nr), ["R", "G", "B"])
            else:
                write_img(p, np.dstack([z, z * 2, z * 3]), ["R", "G", "B"])
            data = p.read_bytes()
        expect = "refuse" if how in REFUSE_CORRUPTIONS or dk in ("exr-rgb", "tif3") else ""
        if how not in ("none", "mode"):
            data = corrupt(data, how, r)
        files[("d" + ext).replace(".", "_DOT_")] = data
        args += ["--depth", "d" + ext]
        variant = f"{dk}/{how}"
        if how == "mode":
            args += r.choice([["--set", "camera.depth=disparity", "--set", "camera.baseline=0.2"],
                              ["--set", "camera.depth=inverse", "--set", "camera.near=1", "--set", "camera.far=100"],
                              ["--set", "camera.encoding=cityscapes"], ["--set", "camera.depth=distance"],
                              ["--set", "camera.depth_scale=1e-300"], ["--set", "camera.depth_scale=1e300"],
                              ["--set", "camera.depth=inverse", "--set", "camera.near=1e-300",
                               "--set", "camera.far=1e300"],
                              ["--set", "camera.depth=disparity", "--set", "camera.baseline=1e300"],
                              ["--set", "camera.empty_depth=inf"], ["--set", "camera.max_depth=1e-300"]])
            variant += "/" + args[-1]
    if block < n_npy and r.random() < 0.25:          # another decoding: the values mean something else
        args += r.choice([["--set", "camera.depth=inverse", "--set", "camera.near=1", "--set", "camera.far=100"],
                          ["--set", "camera.depth=disparity", "--set", "camera.baseline=0.5"],
                          ["--set", "camera.encoding=cityscapes"]])
        if expect == "ok" or v in VALUE_VARIANTS:
            expect = ""
    args += ["-o", out_name(r)]
    return Case("depth", variant, args, _files(**files), expect=expect)


# ---------------------------------------------------------------- class: YAML configs

def _nest(n, open_, close, inner="1"):
    return open_ * n + inner + close * n


def yaml_variants(r: random.Random) -> list[tuple[str, bytes | str, str]]:
    """(name, content, expectation) of config files."""
    laughs = "a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n" + "".join(
        f"{chr(98 + k)}: &{chr(98 + k)} [{', '.join(['*' + chr(97 + k)] * 9)}]\n" for k in range(8))
    big = "x" * 60000
    quadratic = f"medium:\n  note: &s \"{big}\"\n  more: [{', '.join(['*s'] * 4000)}]\n"
    quadratic_map = "base: &b {" + ", ".join(f"k{j}: {j}" for j in range(2000)) + "}\nmedium:\n  x: [" + \
        ", ".join(["*b"] * 9) + "]\n"
    block_deep = "".join("  " * k + "a:\n" for k in range(600)) + "  " * 600 + "b: 1\n"
    bad_key = r.choice(["fov", "kernel", "levels", "visibility", "depth_scale", "exposure", "density"])
    digits400 = "1" + "0" * 400
    out = [
        ("python-tag", "medium: !!python/object/apply:os.system ['touch pwned']\n", "refuse"),
        ("python-name", "medium: {visibility: !!python/name:os.getcwd }\n", "refuse"),
        ("custom-tag", "medium: !fog {visibility: 80}\n", "refuse"),
        ("binary-tag", "medium: {visibility: !!binary aGVsbG8=}\n", "refuse"),
        ("set-tag", "medium: !!set {a, b}\n", "refuse"),
        ("explicit-std-tags", "!!map {medium: !!map {visibility: !!float 80}}\n", "ok"),
        ("nonspecific-tag", "medium: {visibility: ! 80}\n", ""),
        ("billion-laughs", laughs, "refuse"),
        ("quadratic-string", quadratic, "refuse"),
        ("quadratic-map", quadratic_map, "refuse"),
        ("recursive-alias", "medium: &a {x: *a}\n", "refuse"),
        ("recursive-list", "a: &a [*a]\n", "refuse"),
        ("undefined-alias", "medium: *nope\n", "refuse"),
        ("merge-key", "base: &b {visibility: 80}\nmedium:\n  <<: *b\n", ""),
        ("flow-list-600", "medium: {visibility: " + _nest(600, "[", "]") + "}\n", "refuse"),
        ("flow-list-5000", "medium: " + _nest(5000, "[", "]") + "\n", "refuse"),
        ("flow-map-1000", "medium: " + _nest(1000, "{a: ", "}") + "\n", "refuse"),
        ("flow-unclosed-3000", "medium: " + "[" * 3000 + "\n", "refuse"),
        ("block-600", block_deep, "refuse"),
        ("unknown-keys", "medium:\n  visibilty: 80\nrender:\n  kernal: 4\nfoo: 1\n", "refuse"),
        ("wrong-type-section", "medium: [1, 2]\ncamera: 5\nrender: text\n", "refuse"),
        ("null-sections", "medium:\ncamera: ~\nrender: null\noutput:\n", ""),
        ("null-values", "medium:\n  visibility: null\n  albedo: ~\ncamera:\n  fov:\n", ""),
        ("wrong-types", f"medium:\n  absorption: abc\n  scattering: [1, 2]\ncamera:\n  {bad_key}: [1, 2, 3]\n"
                        "render:\n  kernel: '4'\n  levels: 2.5\n  separation: 7\n", "refuse"),
        ("bool-numbers", "medium:\n  visibility: true\ncamera:\n  fov: yes\n", "refuse"),
        ("huge-float", "camera:\n  fov: 1e400\n", "refuse"),
        ("float-max", "medium:\n  visibility: 1.7976931348623157e308\ncamera:\n  max_depth: 1e308\n", ""),
        ("tiny-float", "medium:\n  visibility: 5e-324\n", ""),
        ("int-400-digits-fov", f"camera:\n  fov: {digits400}\n", "refuse"),
        ("int-400-digits-levels", f"render:\n  levels: {digits400}\n", "refuse"),
        ("int-400-digits-vis", f"medium:\n  visibility: {digits400}\n", ""),
        ("int-400-digits-size", f"camera:\n  calibrated_size: [{digits400}, 1]\n", ""),
        ("int-100000-digits", "camera:\n  fov: " + "9" * 100000 + "\n", "refuse"),
        ("many-density", "medium:\n  density:\n" + "".join(
            f"    - {{type: sphere, factor: 1, center: [0, 0, {-j}], radius: 2}}\n" for j in range(3000)), ""),
        ("density-extremes", "medium:\n  density:\n    - {type: exponential, factor: 1e300, falloff: 1e300, "
                             "direction: [1e-300, 0, 0], offset: [1e300, 0, 0]}\n"
                             "    - {type: sphere, factor: 1e308, center: [0, 0, -1e308], radius: 1e308}\n", ""),
        ("many-lights", "lights:\n" + "".join(
            f"  - {{type: point, position: [{j % 7}, 1, {-3 - j % 11}], intensity: [1, 1, 1]}}\n"
            for j in range(1500)), ""),
        ("lights-extremes", "lights:\n  - {type: spot, position: [0, 0, 0], direction: [0, 0, -1], "
                            "intensity: [1e300, 1e300, 1e300], angle: 1e-300, blend: 1}\n"
                            "  - {type: point, position: [0, 0, -1e-300], intensity: [1, 1, 1], radius: 1e300}\n"
                            "render:\n  lights:\n    nodes: 64\n", ""),
        ("visibility-share", "medium:\n  visibility: 0.0001%\n", ""),
        ("density-bad", "medium:\n  density:\n    - 5\n    - {type: cube}\n    - {type: [1]}\n    - {}\n", "refuse"),
        ("density-empty", "medium:\n  density: []\n", "refuse"),
        ("unicode-keys", "m\u00e9dium:\n  visibility: 80\n\u4e2d: 1\n", "refuse"),
        ("unicode-values", "camera:\n  depth: \"z\u200b\"\nrender:\n  method: \u202epyramid\n", "refuse"),
        ("surrogate-key", "\"\\ud800\": 1\nmedium:\n  \"\\udfff\\U0010ffff\": 2\n", "refuse"),
        ("bom", "\ufeffmedium:\n  visibility: 80\n", ""),
        ("nul-char", "medium:\n  visibility: 80\x00\n", "refuse"),
        ("empty", "", ""),
        ("whitespace", "   \n\n  \n", ""),
        ("comments", "# nothing\n# here\n", ""),
        ("doc-markers", "---\n...\n", "-"),
        ("multi-doc", "medium: {visibility: 80}\n---\nmedium: {visibility: 20}\n", "refuse"),
        ("top-list", "- medium\n- camera\n", "refuse"),
        ("top-scalar", "fog\n", "refuse"),
        ("duplicate-keys", "medium:\n  visibility: 80\n  visibility: 20\n", "refuse"),
        ("complex-key", "? [a, b]\n: 1\n", "refuse"),
        ("tabs", "medium:\n\tvisibility: 80\n", "refuse"),
        ("crlf", "medium:\r\n  visibility: 80\r\n", ""),
        ("latin1", "medium:\n  visibility: 80 # caf\xe9\n".encode("latin-1"), "refuse"),
        ("utf16", "medium:\n  visibility: 80\n".encode("utf-16"), "refuse"),
        ("binary-garbage", bytes(r.getrandbits(8) for _ in range(3000)), "refuse"),
        ("over-1mb", "# " + "x" * 1_100_000 + "\nmedium: {visibility: 80}\n", "refuse"),
        ("long-scalar", "medium:\n  note: " + "y" * 900_000 + "\n", "refuse"),
        ("timestamp", "camera:\n  fov: 2001-12-14\n", "refuse"),
        ("octal-hex", "render:\n  kernel: 0x4\n  levels: 0o3\n", ""),
        ("empty-key", "\"\": 1\nmedium:\n  \"\": 2\n", "refuse"),
        ("valid-full", (Path(__file__).resolve().parents[1] / "src" / "fogcli" / "config" / "media" / "fog.yaml").read_text()
         if (Path(__file__).resolve().parents[1] / "src" / "fogcli" / "config" / "media" / "fog.yaml").exists() else "medium: {visibility: 80}\n",
         "ok"),
    ]
    return out


def gen_config(i, r, nr):
    variants = yaml_variants(random.Random(1))
    name, content, expect = variants[i % len(variants)]
    how = ["config", "medium", "check", "check2", "config+set"][spread(i, len(variants), 5)]
    files = {"in_DOT_exr": valid_exr(nr), "c_DOT_yaml": content}
    if how == "check":
        args = ["check", "c.yaml"]
        files.pop("in_DOT_exr")
    elif how == "check2":
        files["ok_DOT_yaml"] = "medium:\n  visibility: 80\n"
        args = ["check", "ok.yaml", "c.yaml", "c.yaml"]
        files.pop("in_DOT_exr")
    elif how == "medium":
        args = ["apply", "in.exr", "--medium", "c.yaml", "-o", out_name(r)]
    else:
        args = ["apply", "in.exr", "--config", "c.yaml", "-o", out_name(r)]
        if how == "config+set":
            args += ["--set", "medium.visibility=50"]
    if name in ("empty", "whitespace", "comments", "null-sections") and how.startswith("check"):
        expect = "ok"
    expect = expect.strip("-")
    return Case("config", f"{name}/{how}", args, _files(**files), expect=expect)


# ---------------------------------------------------------------- class: --set values

SET_KEYS = ["medium.absorption", "medium.scattering", "medium.visibility", "medium.albedo", "medium.asymmetry",
            "medium.emission", "medium.ambient", "medium.density", "camera.fov", "camera.focal_px",
            "camera.focal_px_y", "camera.cx", "camera.cy", "camera.calibrated_size", "camera.depth",
            "camera.depth_scale", "camera.encoding", "camera.baseline", "camera.near", "camera.far",
            "camera.max_depth", "camera.empty_depth", "camera.position", "camera.yaw", "camera.pitch",
            "camera.roll", "render.method", "render.psf", "render.border", "render.emission_profile",
            "render.spread_model", "render.spread_scale", "render.kernel", "render.interpolation",
            "render.fetch", "render.c", "render.epsilon", "render.threshold", "render.levels",
            "render.separation.enabled", "render.separation.luminance", "render.separation.luminance_width",
            "render.separation.depth", "render.separation.depth_width", "render.separation.level",
            "output.exposure", "output.type", "output.compression", "lights", "render.lights.nodes"]
BAD_KEYS = ["medium", "camera", "render.separation", "foo", "medium.foo", "medium.density[0].type", "a..b",
            ".x", "x.", "", " ", "medium.visibility.x", "\u00e9", "render.separation.enabled.x"]
SET_VALUES = ["", "null", "~", "0", "-0", "1", "-1", "0.5", "2", "3", "6", "24", "25", "1e-300", "1e-45",
              "5e-324", "1e300", "1e308", "1.7976931348623157e308", "1e309", "-1e309", ".inf", "-.inf", ".nan",
              "nan", "inf", "true", "false", "yes", "abc", "'4'", "[]", "[1]", "[1,2,3]", "[1,2,3,4]",
              "[.nan,1,1]", "[1e308,1e308,1e308]", "[1e-300,0,0]", "[0,0,0]", "{}", "{a: 1}", "[[1,2,3]]",
              "!!python/object/apply:os.system ['true']", "!foo 1", "&a [*a]", "*a", _nest(700, "[", "]"),
              "1" + "0" * 310, "9" * 4000, "9" * 100000, "z" * 10001, "\u00e9\u4e2d\U0001f600", "0x10",
              "1_000", "2001-12-14", "!!binary aGVsbG8=", "- 1", "a: b", "{", "[", "'", '"\\ud800"', "\t",
              "auto", "sky", "[1, 1]", "[0, 5]", "[" + "1" + "0" * 400 + ", 1]", "[1e300, 1e300]",
              "[{type: sphere, radius: 1e-300}]", "[{type: exponential, falloff: 1e308}]",
              "[{type: exponential, falloff: -1e308}]", "[{type: exponential, direction: [1e-300,0,0]}]",
              "[{type: sphere, center: [0,0,-1e308], radius: 1e308}]", "[{type: homogeneous, factor: 1e308}]",
              "[{}]", "[{type: cube}]", "z", "distance", "disparity", "inverse", "cityscapes", "reference",
              "naive", "receiver", "gaussian", "closed", "isotropic", "paper", "half", "float", "dwab", "b44",
              "179.99999", "1e-10", "-1e300", "0.9999999999", "1.0", "89.9999", "1e6", "-720",
              "'40%'", "'0%'", "'1e400%'", "'-5%'", "'%'", "'nan%'", "'1e-300%'",
              "[{type: point, position: [0, 0, -5], intensity: [1e308, 1, 1]}]",
              "[{type: point, position: [0, 0, 0], intensity: [10, 10, 10], radius: 1e-300}]",
              "[{type: spot, position: [0, 1, -3], direction: [0, 0, 0], intensity: [5, 5, 5]}]",
              "[{type: spot, position: [0, 1, -3], direction: [0, -1, 0], intensity: [5, 5, 5], angle: 0}]",
              "[{type: spot, position: [0, 1, -3], direction: [0, -1, 0], intensity: [5, 5, 5], angle: 180, "
              "blend: 0}]",
              "[{type: directional, direction: [0, 0, 0], irradiance: [1, 1, 1]}]",
              "[{type: directional, direction: [0, 1e-300, 0], irradiance: [1e300, 1, 1]}]",
              "[{type: point, position: [1e308, 0, 0], intensity: [1, 1, 1], frame: world}]",
              "[{type: point}]", "[{type: laser}]", "[5]", "{type: point}",
              "[" + ", ".join(["{type: point, position: [0, 0, -5], intensity: [1, 1, 1]}"] * 150) + "]"]


def gen_set(i, r, nr):
    n = r.choice([1, 1, 1, 2, 3])
    items = []
    for _ in range(n):
        key = r.choice(BAD_KEYS) if r.random() < 0.08 else SET_KEYS[(i + len(items) * 7) % len(SET_KEYS)]
        val = SET_VALUES[r.randrange(len(SET_VALUES))]
        items.append(f"{key}={val}" if r.random() > 0.03 else key)
    args = ["apply", "in.exr"]
    for it in items:
        args += ["--set", it]
    if r.random() < 0.15:
        args += ["--aov", r.choice(["optical_depth", "transmittance", "spread", "level", "direct", "scattered",
                                    "emission"])]
        args += ["-o", "out.exr"]
    else:
        args += ["-o", out_name(r)]
    if r.random() < 0.2:
        args += ["--medium", r.choice(MEDIA)]
    label = " ".join(s[:40] for s in items)
    return Case("set", label, args, _files(in_DOT_exr=valid_exr(nr)))


# ---------------------------------------------------------------- class: --camera JSON

def camera_variants(r):
    d400 = "1" + "0" * 400
    out = [
        ("deep-list", "[" * 100000 + "]" * 100000, "refuse"),
        ("deep-map", '{"a":' * 50000 + "1" + "}" * 50000, "refuse"),
        ("deep-in-value", '{"fx": ' + "[" * 5000 + "]" * 5000 + "}", "refuse"),
        ("fx-string", '{"fx": "500"}', "refuse"),
        ("fx-bool", '{"fx": true}', "refuse"),
        ("fx-null", '{"fx": null}', "refuse"),
        ("fx-list", '{"fx": [500]}', "refuse"),
        ("fx-nan", '{"fx": NaN}', "refuse"),
        ("fx-inf", '{"fx": Infinity, "fy": -Infinity}', "refuse"),
        ("fx-1e400", '{"fx": 1e400}', "refuse"),
        ("fx-400-digits", '{"fx": %s}' % d400, "refuse"),
        ("cx-400-digits", '{"fx": 30, "cx": %s}' % d400, "refuse"),
        ("width-400-digits", '{"fx": 30, "width": %s, "height": 24}' % d400, ""),
        ("fx-5000-digits", '{"fx": %s}' % ("9" * 5000), "refuse"),
        ("fx-zero", '{"fx": 0}', "refuse"),
        ("fx-negative", '{"fx": -30, "fy": 30}', "refuse"),
        ("fx-denormal", '{"fx": 1e-320}', ""),
        ("fx-tiny", '{"fx": 1e-300, "fy": 1e-300}', ""),
        ("fx-huge", '{"fx": 1e300, "fy": 1e300}', ""),
        ("cx-huge", '{"fx": 30, "cx": 1e308, "cy": -1e308}', ""),
        ("width-zero", '{"fx": 30, "width": 0, "height": 24}', "refuse"),
        ("width-fraction", '{"fx": 30, "width": 0.4, "height": 0.4}', "refuse"),
        ("height-negative", '{"fx": 30, "width": 32, "height": -5}', "refuse"),
        ("width-only", '{"fx": 30, "width": 64}', "ok"),
        ("width-string", '{"fx": 30, "width": "32", "height": 24}', "refuse"),
        ("baseline-bad", '{"fx": 30, "baseline": "x"}', "refuse"),
        ("matrix-string", '{"intrinsic_matrix": "abc"}', "refuse"),
        ("matrix-short", '{"intrinsic_matrix": [1, 2, 3]}', "refuse"),
        ("matrix-2x3", '{"intrinsic_matrix": [[1, 0, 0], [0, 1, 0]]}', "refuse"),
        ("matrix-strings", '{"intrinsic_matrix": ["a","b","c","d","e","f","g","h","i"]}', "refuse"),
        ("matrix-zeros", '{"intrinsic_matrix": [0,0,0,0,0,0,0,0,0]}', "refuse"),
        ("matrix-nested-nan", '{"intrinsic_matrix": [[NaN,0,16],[0,30,12],[0,0,1]]}', "refuse"),
        ("open3d-valid", '{"width": 32, "height": 24, "intrinsic_matrix": [30,0,0,0,30,0,16,12,1]}', "ok"),
        ("open3d-other-size", '{"width": 640, "height": 480, "intrinsic_matrix": [525,0,0,0,525,0,320,240,1]}', "ok"),
        ("cityscapes-valid", '{"extrinsic": {"baseline": 0.2}, "intrinsic": {"fx": 30, "fy": 30, "u0": 16, '
                             '"v0": 12}}', "ok"),
        ("cityscapes-missing", '{"intrinsic": {"fx": 30}}', "refuse"),
        ("cityscapes-list", '{"intrinsic": [], "extrinsic": []}', "refuse"),
        ("cityscapes-extrinsic-list", '{"intrinsic": {"fx": 30, "fy": 30, "u0": 16, "v0": 12}, "extrinsic": [1]}',
         ""),
        ("plain-valid", '{"fx": 30, "fy": 31, "cx": 16, "cy": 12}', "ok"),
        ("empty-object", "{}", "refuse"),
        ("empty-file", "", "refuse"),
        ("null", "null", "refuse"),
        ("list", "[1, 2]", "refuse"),
        ("number", "5", "refuse"),
        ("string", '"camera"', "refuse"),
        ("garbage", bytes(r.getrandbits(8) for _ in range(500)), "refuse"),
        ("bom", "\ufeff" + '{"fx": 30}', ""),
        ("utf16", '{"fx": 30}'.encode("utf-16"), ""),
        ("duplicate-keys", '{"fx": 30, "fx": -1}', "refuse"),
        ("over-1mb", '{"fx": 30, "pad": "' + "x" * 1_100_000 + '"}', "refuse"),
        ("trailing-comma", '{"fx": 30,}', "refuse"),
        ("unicode-keys", '{"f\u0445": 30}', "refuse"),
        ("surrogate", '{"fx": 30, "\\ud800": 1}', ""),
    ]
    return out


def gen_camera(i, r, nr):
    variants = camera_variants(random.Random(2))
    name, content, expect = variants[i % len(variants)]
    args = ["apply", "in.exr", "--camera", "cam.json", "-o", out_name(r)]
    if r.random() < 0.3:
        args += ["--set", r.choice(["camera.fov=30", "camera.depth=disparity", "camera.cx=1e308",
                                    "camera.calibrated_size=[1, 1]"])]
        if expect == "ok":
            expect = ""
    return Case("camera", name, args, _files(in_DOT_exr=valid_exr(nr), cam_DOT_json=content), expect=expect)


# ---------------------------------------------------------------- class: command lines

def gen_cli(i, r, nr):
    variants = [
        "o-folder-ext", "o-folder", "o-readonly", "o-missing-folder", "o-input", "o-input-dot", "o-input-dotdot",
        "o-link-to-input", "o-depth", "o-240", "o-300", "o-ext-bmp", "o-no-ext", "o-dot-exr", "o-ext-txt",
        "o-ext-npy", "o-upper", "o-jpeg", "o-tiff", "o-hdr", "o-existing", "o-fifo", "o-empty", "o-camera-file",
        "o-config-file", "o-trailing-slash", "aov-png", "aov-jpg", "aov-all-exr", "aov-hdr", "layer-png", "view-png",
        "layer-missing", "view-missing", "device-99", "device-empty", "device-gpu", "device-bad", "env-device",
        "unknown-option", "unknown-short", "missing-input", "missing-value", "input-dash", "empty-input",
        "empty-depth", "empty-medium", "empty-config", "empty-camera", "empty-layer", "empty-save-depth",
        "save-depth-folder", "save-depth-missing", "save-depth-is-o", "save-depth-input", "save-depth-depth",
        "save-depth-png", "save-depth-npy", "save-depth-tif", "save-depth-readonly", "save-depth-300",
        "save-depth-camera", "batch-jobs-0", "batch-jobs-neg", "batch-jobs-257", "batch-jobs-abc", "media",
        "media-extra-arg", "check-none", "version", "help", "no-command", "unknown-command", "timings",
        "drop-channels", "repeat-o", "config-dir", "medium-dir", "camera-dir", "config-devnull", "camera-devnull",
        "depth-devnull", "input-devnull", "input-is-output-default", "default-output", "default-output-exists-dir",
        "set-no-equals", "set-empty", "set-many",
    ]
    v = variants[i % len(variants)]
    files = {"in_DOT_exr": valid_exr(nr)}
    setups = []
    out = "out.exr"
    args = ["apply", "in.exr", "-o", out]
    expect = "refuse"
    env = {}
    mutable = ()
    if v == "o-folder-ext":
        setups.append(lambda d: (d / "out.exr").mkdir())
    elif v == "o-folder":
        setups.append(lambda d: (d / "outdir").mkdir())
        args[-1] = "outdir"
    elif v == "o-readonly":
        setups.append(lambda d: ((d / "ro").mkdir(), os.chmod(d / "ro", 0o555)))
        args[-1] = "ro/out.exr"
    elif v == "o-missing-folder":
        args[-1] = "nope/out.exr"
    elif v == "o-input":
        args[-1] = "in.exr"
    elif v == "o-input-dot":
        args[-1] = "./in.exr"
    elif v == "o-input-dotdot":
        setups.append(lambda d: (d / "sub").mkdir())
        args[-1] = "sub/../in.exr"
    elif v == "o-link-to-input":
        setups.append(_symlink("link.exr", "in.exr"))
        args[-1] = "link.exr"
    elif v == "o-depth":
        files["d_DOT_exr"] = valid_depth(nr, "exr")
        args = ["apply", "in.exr", "--depth", "d.exr", "-o", "d.exr"]
    elif v == "o-240":
        args[-1] = "o" * 240 + ".exr"
        expect = "ok"
    elif v == "o-300":
        args[-1] = "o" * 300 + ".exr"
    elif v in ("o-ext-bmp", "o-no-ext", "o-dot-exr", "o-ext-txt", "o-ext-npy", "o-empty"):
        args[-1] = {"o-ext-bmp": "out.bmp", "o-no-ext": "out", "o-dot-exr": ".exr", "o-ext-txt": "out.exr.txt",
                    "o-ext-npy": "out.npy", "o-empty": ""}[v]
    elif v in ("o-upper", "o-jpeg", "o-tiff", "o-hdr"):
        args[-1] = {"o-upper": "OUT.EXR", "o-jpeg": "out.jpeg", "o-tiff": "out.tiff", "o-hdr": "out.hdr"}[v]
        expect = "ok"
    elif v == "o-existing":
        files["out_DOT_exr"] = b"old"
        mutable = ("out.exr",)
        expect = "ok"
    elif v == "o-fifo":
        setups.append(lambda d: os.mkfifo(d / "out.exr"))
        mutable = ("out.exr",)
        expect = ""
    elif v == "o-camera-file":
        files["cam_DOT_png"] = '{"fx": 30}'
        args = ["apply", "in.exr", "--camera", "cam.png", "-o", "cam.png"]
    elif v == "o-config-file":
        files["c_DOT_exr"] = "medium: {visibility: 80}\n"
        args = ["apply", "in.exr", "--config", "c.exr", "-o", "c.exr"]
    elif v == "o-trailing-slash":
        args[-1] = "out.exr/"
        expect = ""
    elif v in ("aov-png", "aov-jpg", "aov-hdr"):
        args[-1] = "out." + v[4:]
        args += ["--aov", "spread"]
    elif v == "aov-all-exr":
        for a in ["optical_depth", "transmittance", "spread", "level", "direct", "scattered", "emission", "spread"]:
            args += ["--aov", a]
        expect = "ok"
    elif v in ("layer-png", "view-png"):
        files = {"in_DOT_png": lambda p: make_image(p, "png8", nr), "d_DOT_npy": valid_depth(nr)}
        args = ["apply", "in.png", "--depth", "d.npy", "-o", "out.png", "--" + v[:-4], "x"]
    elif v == "layer-missing":
        args += ["--layer", "nope"]
    elif v == "view-missing":
        args += ["--view", "nope"]
    elif v.startswith("device-"):
        args += ["--device", {"device-99": "99:99", "device-empty": "", "device-gpu": "gpu",
                              "device-bad": "-1:x"}[v]]
        expect = "" if v in ("device-gpu", "device-empty") else "refuse"
    elif v == "env-device":
        env = {"FOGCLI_DEVICE": r.choice(["nope", "5:5", ""])}
        expect = ""
    elif v == "unknown-option":
        args += ["--nope"]
    elif v == "unknown-short":
        args += ["-x"]
    elif v == "missing-input":
        args = ["apply"]
    elif v == "missing-value":
        args = ["apply", "in.exr", "--depth"]
    elif v == "input-dash":
        args = ["apply", "-", "-o", "out.exr"]
    elif v.startswith("empty-") and v != "empty-save-depth":
        opt = {"empty-input": None, "empty-depth": "--depth", "empty-medium": "--medium",
               "empty-config": "--config", "empty-camera": "--camera", "empty-layer": "--layer"}[v]
        args = ["apply", "", "-o", "out.exr"] if opt is None else ["apply", "in.exr", opt, "", "-o", "out.exr"]
        expect = "" if v in ("empty-layer", "empty-config", "empty-camera") else "refuse"
    elif v.startswith("save-depth") or v == "empty-save-depth":
        sd = {"empty-save-depth": "", "save-depth-folder": "sdir", "save-depth-missing": "nope/d.exr",
              "save-depth-is-o": "out.exr", "save-depth-input": "in.exr", "save-depth-depth": "d.npy",
              "save-depth-png": "d.png", "save-depth-npy": "sd.npy", "save-depth-tif": "sd.tif",
              "save-depth-readonly": "ro/sd.exr", "save-depth-300": "s" * 300 + ".exr",
              "save-depth-camera": "cam.npy"}[v]
        if v == "save-depth-folder":
            setups.append(lambda d: (d / "sdir").mkdir())
        if v == "save-depth-readonly":
            setups.append(lambda d: ((d / "ro").mkdir(), os.chmod(d / "ro", 0o555)))
        if v == "save-depth-depth":
            files["d_DOT_npy"] = valid_depth(nr)
            args += ["--depth", "d.npy"]
        if v == "save-depth-camera":
            files["cam_DOT_npy"] = '{"fx": 30}'
            args += ["--camera", "cam.npy"]
        args += ["--save-depth", sd]
        expect = "ok" if v in ("save-depth-npy", "save-depth-tif") else ("" if v == "empty-save-depth" else "refuse")
    elif v.startswith("batch-jobs"):
        files = {"in__a_DOT_exr": valid_exr(nr)}
        args = ["batch", "in", "out", "-q", "--jobs", {"batch-jobs-0": "0", "batch-jobs-neg": "-1",
                                                        "batch-jobs-257": "257", "batch-jobs-abc": "abc"}[v]]
    elif v == "media":
        args, expect, files = ["media"], "ok", {}
    elif v == "media-extra-arg":
        args, files = ["media", "x"], {}
    elif v == "check-none":
        args, files = ["check"], {}
    elif v == "version":
        args, expect, files = ["--version"], "ok", {}
    elif v == "help":
        args, expect, files = [r.choice(["apply", "batch", "check"]), "--help"], "ok", {}
    elif v == "no-command":
        args, expect, files = [], "", {}
    elif v == "unknown-command":
        args, files = ["aply", "in.exr"], {}
    elif v == "timings":
        args += ["--timings"]
        expect = "ok"
    elif v == "drop-channels":
        args += ["--drop-channels"]
        expect = "ok"
    elif v == "repeat-o":
        args += ["-o", "second.exr", "--depth", "in.exr"]
        expect = "ok"
    elif v in ("config-dir", "medium-dir", "camera-dir"):
        args += ["--" + v.split("-")[0], "."]
    elif v in ("config-devnull", "camera-devnull", "depth-devnull"):
        args += ["--" + v.split("-")[0], "/dev/null"]
        expect = "" if v == "config-devnull" else "refuse"
    elif v == "input-devnull":
        args = ["apply", "/dev/null", "-o", "out.exr"]
    elif v == "input-is-output-default":
        files["in_DOT_fog_DOT_exr"] = b"stale"
        mutable = ("in.fog.exr",)
        args = ["apply", "in.exr"]
        expect = "ok"
    elif v == "default-output":
        files = {"in_DOT_png": lambda p: make_image(p, "png16", nr), "d_DOT_npy": valid_depth(nr)}
        args = ["apply", "in.png", "--depth", "d.npy"]
        expect = "ok"
    elif v == "default-output-exists-dir":
        setups.append(lambda d: (d / "in.fog.exr").mkdir())
        args = ["apply", "in.exr"]
    elif v == "set-no-equals":
        args += ["--set", "render.kernel"]
    elif v == "set-empty":
        args += ["--set", ""]
    elif v == "set-many":
        for k in range(300):
            args += ["--set", f"render.kernel={[2, 4, 6][k % 3]}"]
        expect = "ok"
    return Case("cli", v, args, _chain(_files(**files), *setups), expect=expect, env=env, mutable=mutable)


# ---------------------------------------------------------------- class: batch folders

FRAME_KINDS = ["exr", "exr", "png+depth", "corrupt-exr", "junk-exr", "empty-exr", "hidden", "dir-named-exr",
               "fifo-exr", "unreadable-exr", "link", "link-loop", "npy", "txt", "sub-exr", "nan-exr", "no-z-exr",
               "tif+depth", "jpg-no-depth", "numbered"]


def gen_batch(i, r, nr):
    frames = [r.choice(FRAME_KINDS) for _ in range(r.randint(1, 5))]
    if i % 4 == 0:
        frames = ["exr", "png+depth"] + frames[:2]
    setups = [lambda d: (d / "in").mkdir()]
    pattern = None
    mutable = []
    for k, fk in enumerate(frames):
        stem = f"f{k}"
        if fk == "exr":
            setups.append(lambda d, s=stem: make_image(d / "in" / f"{s}.exr", "exr", nr))
        elif fk == "numbered":
            setups.append(lambda d, k=k: make_image(d / "in" / f"shot.{k + 1:04d}.exr", "exr-half", nr))
        elif fk in ("png+depth", "tif+depth"):
            ext = ".png" if fk == "png+depth" else ".tif"
            setups.append(lambda d, s=stem, e=ext: (make_image(d / "in" / f"{s}{e}", "png8" if e == ".png" else "tif16",
                                                               nr),
                                                    (d / "in" / "depth").mkdir(exist_ok=True),
                                                    np.save(d / "in" / "depth" / f"{s}.npy", zplane(nr)),
                                                    make_depth(d / "in" / f"{s}_depth.exr", "exr", zplane(nr))))
        elif fk == "corrupt-exr":
            data = corrupt(image_bytes("exr", nr), r.choice(["truncate", "flip", "zeros"]), r)
            setups.append(lambda d, s=stem, b=data: (d / "in" / f"{s}.exr").write_bytes(b))
        elif fk == "junk-exr":
            setups.append(lambda d, s=stem: (d / "in" / f"{s}.exr").write_text("not an exr"))
        elif fk == "empty-exr":
            setups.append(lambda d, s=stem: (d / "in" / f"{s}.exr").write_bytes(b""))
        elif fk == "hidden":
            setups.append(lambda d, s=stem: make_image(d / "in" / f".{s}.exr", "exr", nr))
        elif fk == "dir-named-exr":
            setups.append(lambda d, s=stem: (d / "in" / f"{s}.exr").mkdir())
        elif fk == "fifo-exr":
            setups.append(lambda d, s=stem: os.mkfifo(d / "in" / f"{s}.exr"))
        elif fk == "unreadable-exr":
            setups.append(lambda d, s=stem: (make_image(d / "in" / f"{s}.exr", "exr", nr),
                                             os.chmod(d / "in" / f"{s}.exr", 0)))
        elif fk == "link":
            setups.append(lambda d, s=stem: (make_image(d / f"{s}_target.exr", "exr", nr),
                                             os.symlink(f"../{s}_target.exr", d / "in" / f"{s}.exr")))
        elif fk == "link-loop":
            setups.append(lambda d, s=stem: (os.symlink(f"{s}b.exr", d / "in" / f"{s}.exr"),
                                             os.symlink(f"{s}.exr", d / "in" / f"{s}b.exr")))
        elif fk == "npy":
            setups.append(lambda d, s=stem: np.save(d / "in" / f"{s}.npy", zplane(nr)))
        elif fk == "txt":
            setups.append(lambda d, s=stem: (d / "in" / f"{s}.txt").write_text("hello"))
        elif fk == "sub-exr":
            setups.append(lambda d, s=stem: ((d / "in" / "sub").mkdir(exist_ok=True),
                                             make_image(d / "in" / "sub" / f"{s}.exr", "exr", nr)))
        elif fk == "nan-exr":
            setups.append(lambda d, s=stem: write_img(d / "in" / f"{s}.exr",
                                                      np.dstack([np.full((H, W, 3), np.nan, np.float32), zplane(nr)]),
                                                      ["R", "G", "B", "Z"]))
        elif fk == "no-z-exr":
            setups.append(lambda d, s=stem: write_img(d / "in" / f"{s}.exr", colour(nr), ["R", "G", "B"]))
        elif fk == "jpg-no-depth":
            setups.append(lambda d, s=stem: make_image(d / "in" / f"{s}.jpg", "jpg", nr))
    args = ["batch", "in", "out"]
    out_dirs = ["out"]
    outputs = []
    opt = ["none", "pattern", "format", "report", "save-depth", "skip-existing", "recursive", "jobs", "out-dir",
           "aov", "quiet"][i % 11]
    opts = {opt} | {r.choice(["pattern", "format", "report", "quiet", "recursive", "skip-existing", "none"])
                    for _ in range(r.randint(0, 2))}
    variant = []
    if "pattern" in opts:
        pattern = r.choice(["depth/{stem}.npy", "{stem}_depth.exr", "depth.####.exr", "%04d.exr", "{stem}",
                            "../{stem}.npy", "/nonexistent/{stem}.exr", "", "depth/{stem}.npy/", "*",
                            "%0300d.exr", "#" * 300 + ".exr", "{stem}" * 60, "%0999999d.exr", "[a-z].exr",
                            "{stem}.EXR", "depth/../depth/{stem}.npy", "{stem}\n.exr"])
        args += ["--depth-pattern", pattern]
        variant.append(f"pattern={pattern[:30]!r}")
    if "format" in opts:
        fmt = r.choice(["exr", "png", "tif", "jpg", "hdr", "EXR", ".png", "bmp", "", "npy", "tiff", "jpeg"])
        args += ["--format", fmt]
        variant.append(f"format={fmt}")
    if "report" in opts:
        rep = r.choice(["report.json", "in/f0.exr", "nope/report.json", "in", "out/report.json", "out/f0.exr",
                        "cam.json", "c.yaml", "in/depth/f0.npy", "r" * 300 + ".json", "ro/report.json",
                        "out"])
        if rep in ("cam.json",):
            setups.append(lambda d: (d / "cam.json").write_text('{"fx": 30}'))
            args += ["--camera", "cam.json"]
        if rep == "c.yaml":
            setups.append(lambda d: (d / "c.yaml").write_text("medium: {visibility: 80}\n"))
            args += ["--config", "c.yaml"]
        if rep.startswith("ro/"):
            setups.append(lambda d: ((d / "ro").mkdir(), os.chmod(d / "ro", 0o555)))
        args += ["--report", rep]
        outputs.append(rep)
        variant.append(f"report={rep[:30]}")
    if "save-depth" in opts:
        sd = r.choice(["sd", "in", "out", "out/sd", "existing-file", "ro/sd", "in/depth", "nope/deeper/sd"])
        if sd == "existing-file":
            setups.append(lambda d: (d / "existing-file").write_text("x"))
        if sd.startswith("ro/"):
            setups.append(lambda d: ((d / "ro").mkdir(), os.chmod(d / "ro", 0o555)))
        args += ["--save-depth", sd]
        out_dirs.append(sd)
        variant.append(f"save-depth={sd}")
    if "skip-existing" in opts:
        args += ["--skip-existing"]
        pre = r.choice(["partial", "stale-tmp", "whole", "dir", "empty"])

        def prefill(d, pre=pre):
            (d / "out").mkdir(exist_ok=True)
            if pre == "partial":
                (d / "out" / "f0.exr").write_bytes(image_bytes("exr", nr)[:500])
            elif pre == "stale-tmp":
                (d / "out" / ".f0.abcd1234.tmp.exr").write_bytes(b"partial")
            elif pre == "whole":
                make_image(d / "out" / "f0.exr", "exr", nr)
            elif pre == "dir":
                (d / "out" / "f0.exr").mkdir()
            elif pre == "empty":
                (d / "out" / "f0.exr").write_bytes(b"")
        setups.append(prefill)
        mutable += ["out/f0.exr", "out/.f0.abcd1234.tmp.exr"]
        variant.append(f"skip-existing/{pre}")
    if "recursive" in opts:
        args += ["--recursive"]
        variant.append("recursive")
    if "jobs" in opts:
        args += ["--jobs", "2"]
        variant.append("jobs=2")
    if "out-dir" in opts:
        od = r.choice(["in/out", "in", "file", "ro/out", "a/b/c/out", "in/sub"])
        if od == "file":
            setups.append(lambda d: (d / "file").write_text("x"))
        if od.startswith("ro/"):
            setups.append(lambda d: ((d / "ro").mkdir(), os.chmod(d / "ro", 0o555)))
        args[2] = od
        out_dirs[0] = od
        variant.append(f"out={od}")
    if "aov" in opts:
        args += ["--aov", "spread"] + (["--format", r.choice(["png", "exr"])] if r.random() < 0.6 else [])
        variant.append("aov")
    if "quiet" in opts or r.random() < 0.5:
        args += ["-q"]
    return Case("batch", f"{'+'.join(sorted(set(frames)))}|{' '.join(variant) or 'plain'}", args, _chain(*setups),
                outputs=tuple(outputs), out_dirs=tuple(out_dirs), mutable=tuple(mutable))


# ============================================================================ registry

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


# ============================================================================ running

def fogcli_command() -> list[str]:
    cmd = [sys.executable, "-m", "fogcli"]
    if hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("setpriv"):
        caps = "-dac_override,-dac_read_search"
        cmd = [shutil.which("setpriv"), f"--bounding-set={caps}", f"--inh-caps={caps}", "--"] + cmd
    return cmd


def _snapshot(d: Path) -> dict:
    """path -> ('f', sha256) / ('d',) / ('l', target) / ('p',) for everything under d."""
    out = {}
    for root, dirs, files in os.walk(d, followlinks=False):
        for name in dirs + files:
            p = Path(root) / name
            rel = str(p.relative_to(d))
            st = os.lstat(p)
            if stat.S_ISLNK(st.st_mode):
                out[rel] = ("l", os.readlink(p))
            elif stat.S_ISDIR(st.st_mode):
                out[rel] = ("d",)
            elif stat.S_ISREG(st.st_mode):
                try:
                    out[rel] = ("f", hashlib.sha256(p.read_bytes()).hexdigest())
                except OSError:
                    out[rel] = ("f", "unreadable")
            else:
                out[rel] = ("p", st.st_mode)
    return out


def _restore_perms(d: Path) -> None:
    for root, dirs, files in os.walk(d, followlinks=False):
        for name in dirs + files:
            p = Path(root) / name
            if not p.is_symlink():
                try:
                    os.chmod(p, 0o755 if p.is_dir() else 0o644)
                except OSError:
                    pass


def _is_partial(name: str) -> bool:
    return name.startswith(".") and ".tmp" in name


def _apply_outputs(args: list) -> list:
    """The files `apply` writes on success: -o (last) or INPUT.fog.<ext>, and --save-depth."""
    out, save, inp, k, pos = None, None, None, 0, []
    takes = {"--depth", "--medium", "--config", "--camera", "--set", "--layer", "--view", "--aov", "--device",
             "-o", "--output", "--save-depth"}
    while k < len(args):
        a = args[k]
        if a in takes and k + 1 < len(args):
            if a in ("-o", "--output"):
                out = args[k + 1]
            elif a == "--save-depth":
                save = args[k + 1]
            k += 2
            continue
        if not a.startswith("-"):
            pos.append(a)
        k += 1
    inp = pos[1] if len(pos) > 1 else None
    if out is None and inp is not None:
        src = Path(inp)
        ext = src.suffix.lower()
        ext = ext if ext in (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".exr", ".hdr") else ".exr"
        out = str(src.with_name(f"{src.stem}.fog{ext}"))
    return [p for p in (out, save) if p]


def _check_output(p: Path) -> str | None:
    """None if the output reads back whole (and its colour is finite), else the problem."""
    if not p.is_file():
        return "missing"
    if p.suffix.lower() == ".npy":
        try:
            a = np.load(p, allow_pickle=False)
        except Exception as exc:
            return f"unreadable npy ({exc.__class__.__name__})"
        return "nonfinite" if np.isnan(a).any() else None
    if p.suffix.lower() == ".json":
        try:
            json.loads(p.read_text())
        except Exception as exc:
            return f"unreadable json ({exc.__class__.__name__})"
        return None
    oiio = _oiio()
    inp = oiio.ImageInput.open(str(p))
    if inp is None:
        oiio.geterror()
        return "unreadable image"
    try:
        spec = inp.spec()
        px = inp.read_image(0, 0, 0, spec.nchannels, "float")
        if px is None or (hasattr(inp, "has_error") and inp.has_error):
            return "unreadable pixels"
        px = np.asarray(px).reshape(spec.height, spec.width, spec.nchannels)
        names = list(spec.channelnames)
        cols = [k for k, n in enumerate(names) if n.rsplit(".", 1)[-1] in ("R", "G", "B", "A")]
        if not cols and spec.nchannels == 1:      # a saved depth: +inf is sky, NaN is wrong
            return "nonfinite" if np.isnan(px).any() else None
        cols = cols or list(range(min(3, len(names))))
        if not np.isfinite(px[:, :, cols]).all():
            return "nonfinite"
    except Exception as exc:
        return f"unreadable ({exc.__class__.__name__})"
    finally:
        inp.close()
    return None


def _check_report(folder: Path, rel: str) -> str | None:
    p = folder / rel
    if not p.is_file():
        return "missing"
    try:
        rep = json.loads(p.read_text())
        done = [d["output"] for d in rep["done"]]
    except Exception as exc:
        return f"unreadable report ({exc.__class__.__name__})"
    for o in done:
        prob = _check_output(folder / o)
        if prob and prob != "nonfinite":
            return f"the report lists {o} as done, but it is {prob}"
    return None


_PROGRESS = re.compile(r"^\[\d+/\d+\] ")
_PY_WARNING = re.compile(r"warning", re.I)


def judge(case: Case, rc, stderr: str, timed_out: bool, before: dict, after: dict, folder: Path,
          rss_mb: float) -> list[str]:
    """The contract's violations of one run, as defect kinds (with a detail after ':')."""
    kinds = []
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    cmd = case.args[0] if case.args else ""
    path_args = [a for a in case.args if a and not a.startswith("-")]
    if timed_out:
        kinds.append("hang")
    if "Traceback" in stderr:
        kinds.append("traceback")
    warn = [ln for ln in lines if _PY_WARNING.search(ln) and not ln.startswith(("fogcli: warning:", "fogcli: failed:"))
            and not _PROGRESS.match(ln)]
    if warn:
        kinds.append("warning")
    if rss_mb > RSS_LIMIT_MB:
        kinds.append("memory")
    if not timed_out:
        named = lambda ln: ln.startswith("fogcli: ") or any(ln.startswith(a + ":") for a in path_args)  # noqa: E731
        if rc == 0:
            stray = [ln for ln in lines if not (ln.startswith("fogcli:") or ln.startswith("{") or _PROGRESS.match(ln))]
            if stray and "traceback" not in kinds and "warning" not in kinds:
                kinds.append("stray-stderr")
        elif rc == 2:
            if cmd == "batch":
                lines = [ln for ln in lines if not _PROGRESS.match(ln)]
            if cmd == "check":
                ok = bool(lines) and all(named(ln) for ln in lines)
            else:
                ok = len(lines) == 1 and named(lines[0])
            if not ok and "traceback" not in kinds:
                kinds.append("bad-message")
        elif rc == 3 and cmd == "batch":
            if not lines or not all(ln.startswith("fogcli:") or _PROGRESS.match(ln) for ln in lines):
                kinds.append("bad-message")
        elif rc == 1:
            kinds.append("exit-1")
        else:
            kinds.append("bad-exit")
        if case.expect == "refuse" and rc == 0:
            kinds.append("accepted-bad-input")
        if case.expect == "ok" and rc == 2:
            kinds.append("refused-valid-input")
    # inputs unchanged
    for rel, sig in before.items():
        if any(rel == m or rel.startswith(m + "/") for m in case.mutable):
            continue
        if after.get(rel) != sig:
            kinds.append("changed-input:" + rel[:60])
    # nothing left behind
    if cmd == "apply":
        expected = case.outputs if case.outputs is not None else tuple(_apply_outputs(case.args))
    else:
        expected = case.outputs or ()
    ok_run = rc == 0 or (rc == 3 and cmd == "batch")
    allowed = set()
    if ok_run and not timed_out:
        for e in expected:
            e = os.path.normpath(e)
            allowed.add(e)
            parts = Path(e).parts
            for k in range(1, len(parts)):
                allowed.add(str(Path(*parts[:k])))
    new = [p for p in after if p not in before]
    for p in new:
        name = Path(p).name
        if _is_partial(name):
            kinds.append("leftover:" + p[:60])
            continue
        if p in allowed:
            continue
        if ok_run and not timed_out and any(p == os.path.normpath(od) or p.startswith(os.path.normpath(od) + "/")
                                            or os.path.normpath(od).startswith(p + "/") for od in case.out_dirs):
            continue
        kinds.append("leftover:" + p[:60])
    # what a success claims to have written reads back
    if ok_run and not timed_out:
        for e in expected:
            if rc == 3 and e not in case.outputs:
                continue
            if cmd == "batch":                 # the --report: JSON; every frame it lists as done reads back
                prob = _check_report(folder, e)
            else:
                prob = _check_output(folder / e)
            if prob == "nonfinite":
                kinds.append("nonfinite-output:" + e[:40])
            elif prob and not (rc == 0 and prob == "missing" and cmd not in ("apply", "batch")):
                kinds.append(f"bad-output:{e[:40]} {prob}")
        for od in case.out_dirs:
            for p in new:
                if (p.startswith(os.path.normpath(od) + "/") and after[p][0] == "f"
                        and not _is_partial(Path(p).name) and p not in expected):
                    prob = _check_output(folder / p)
                    if prob:
                        kinds.append(("nonfinite-output:" if prob == "nonfinite" else "bad-output:") +
                                     f"{p[:40]} {'' if prob == 'nonfinite' else prob}".rstrip())
    return kinds


@dataclass
class Result:
    case: Case
    rc: int | None
    stderr: str
    seconds: float
    rss_mb: float
    kinds: list


def _tree_rss_mb(pid: int) -> float:
    try:
        import psutil

        p = psutil.Process(pid)
        return sum(q.memory_info().rss for q in [p] + p.children(recursive=True)) / 2**20
    except Exception:
        return 0.0


def run_case(case: Case, work: Path, timeout: float = TIMEOUT, keep: bool = False) -> Result:
    folder = work / case.id
    if folder.exists():
        _restore_perms(folder)
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    if case.setup:
        try:
            case.setup(folder)
        except Exception as exc:          # a generator bug, not a fogcli defect: say so
            return Result(case, None, "", 0.0, 0.0, [f"harness-error:{exc.__class__.__name__}: {exc}"[:200]])
    before = _snapshot(folder)
    io = work / "_io"
    io.mkdir(exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k not in ("FOGCLI_DEBUG", "FOGCLI_DEVICE", "PYTHONWARNINGS")}
    env.update(case.env)
    err_path, out_path = io / f"{case.id}.err", io / f"{case.id}.out"
    t0 = time.perf_counter()
    with open(err_path, "wb") as ferr, open(out_path, "wb") as fout:
        proc = subprocess.Popen(fogcli_command() + case.args, cwd=folder, stdout=fout, stderr=ferr,
                                stdin=subprocess.DEVNULL, env=env, start_new_session=True)
    timed_out, killed_mem, status, ru = False, False, None, None
    last_poll = 0.0
    while True:
        pid, status, ru = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        now = time.perf_counter()
        if now - t0 > timeout:
            timed_out = True
        elif now - last_poll > 0.25:
            last_poll = now
            if _tree_rss_mb(proc.pid) > RSS_KILL_MB:
                killed_mem = True
        if timed_out or killed_mem:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            _, status, ru = os.wait4(proc.pid, 0)
            break
        time.sleep(0.01)
    proc.returncode = os.waitstatus_to_exitcode(status)
    try:                                   # whatever the run left in its group (batch workers)
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    seconds = time.perf_counter() - t0
    rss_mb = ru.ru_maxrss / 1024.0 if ru else 0.0
    if killed_mem:
        rss_mb = max(rss_mb, RSS_KILL_MB + 1)
    stderr = err_path.read_bytes().decode("utf-8", "replace")
    err_path.unlink()
    out_path.unlink()
    after = _snapshot(folder)
    kinds = judge(case, None if timed_out else proc.returncode, stderr, timed_out, before, after, folder, rss_mb)
    if not keep and not kinds:
        _restore_perms(folder)
        shutil.rmtree(folder, ignore_errors=True)
    else:
        _restore_perms(folder)
    return Result(case, None if timed_out else proc.returncode, stderr, seconds, rss_mb, kinds)


def command_line(case: Case) -> str:
    return "fogcli " + shlex.join(case.args)


def signature(res: Result) -> str:
    """A grouping key for distinct defects: the kinds and the gist of the first stderr line."""
    kinds = sorted({k.split(":")[0] for k in res.kinds})
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    gist = ""
    if "Traceback" in res.stderr:
        tail = [ln for ln in lines if re.match(r"^\w[\w.]*(Error|Exception|Interrupt)\b", ln)]
        gist = (tail[-1] if tail else lines[-1])[:80]
    elif lines:
        ln = next((x for x in lines if "processing failed" in x or "Warning" in x), lines[0])
        m = re.search(r"processing failed: (\w+)", ln)
        gist = m.group(0) if m else ln
    gist = re.sub(r"\d+", "N", gist)
    gist = re.sub(r"'[^']*'", "'…'", gist)[:100]
    return f"{'+'.join(kinds)} | {res.case.cls} | {gist}"


COLUMNS = ["cases", "ok", "refused", "exit3", "traceback", "hang", "leftover", "changed", "warning", "bad-exit",
           "bad-msg", "other", "rss_mb"]


def summarise(results: list[Result]) -> dict:
    table: dict[str, dict] = {}
    for res in results:
        row = table.setdefault(res.case.cls, dict.fromkeys(COLUMNS, 0))
        row["cases"] += 1
        row["ok"] += res.rc == 0
        row["refused"] += res.rc == 2
        row["exit3"] += res.rc == 3
        kinds = {k.split(":")[0] for k in res.kinds}
        row["traceback"] += "traceback" in kinds
        row["hang"] += "hang" in kinds
        row["leftover"] += "leftover" in kinds
        row["changed"] += "changed-input" in kinds
        row["warning"] += bool(kinds & {"warning", "stray-stderr"})
        row["bad-exit"] += bool(kinds & {"exit-1", "bad-exit"})
        row["bad-msg"] += "bad-message" in kinds
        row["other"] += bool(kinds - {"traceback", "hang", "leftover", "changed-input", "warning", "stray-stderr",
                                      "exit-1", "bad-exit", "bad-message"})
        row["rss_mb"] = max(row["rss_mb"], round(res.rss_mb))
    total = dict.fromkeys(COLUMNS, 0)
    for row in table.values():
        for c in COLUMNS:
            total[c] = max(total[c], row[c]) if c == "rss_mb" else total[c] + row[c]
    table["TOTAL"] = total
    return table


def print_table(table: dict, file=sys.stdout) -> None:
    w = max(len(k) for k in table) + 2
    print("class".ljust(w) + "".join(c.rjust(10) for c in COLUMNS), file=file)
    for name, row in table.items():
        print(name.ljust(w) + "".join(str(row[c]).rjust(10) for c in COLUMNS), file=file)
    print("(ok: exit 0; refused: exit 2; other: accepted-bad-input, refused-valid-input, bad/nonfinite output, "
          "memory > 4 GB; rss_mb: largest peak RSS of a case)", file=file)


def defect_record(res: Result) -> dict:
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    return {"id": res.case.id, "class": res.case.cls, "variant": res.case.variant, "kinds": res.kinds,
            "command": command_line(res.case), "exit": res.rc, "stderr": [ln[:300] for ln in lines[:6]],
            "stderr_tail": [ln[:300] for ln in lines[-3:]] if len(lines) > 6 else [],
            "seconds": round(res.seconds, 2), "rss_mb": round(res.rss_mb), "env": res.case.env,
            "signature": signature(res)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=1200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="/tmp/fuzz-out", help="folder for defects.json and signatures.json")
    ap.add_argument("--work", default=None, help="scratch folder for the case folders (default: a temporary one)")
    ap.add_argument("--classes", default="", help="comma-separated subset of: " + ", ".join(CLASSES))
    ap.add_argument("--fast", action="store_true", help="only the fixed fast subset of tests/test_fuzz.py")
    ap.add_argument("--timeout", type=float, default=TIMEOUT)
    ap.add_argument("--keep", action="store_true", help="keep every case folder (default: only defective ones)")
    ap.add_argument("--dry-run", action="store_true", help="only write every case's inputs (checks the generators)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(a.work) if a.work else Path(tempfile.mkdtemp(prefix="fogcli-fuzz-"))
    work.mkdir(parents=True, exist_ok=True)
    classes = [c for c in a.classes.split(",") if c]
    cases = fast_cases(a.seed) if a.fast else build_cases(a.cases, a.seed, classes)
    print(f"fuzz: {len(cases)} cases, seed {a.seed}, work {work}, out {out}", file=sys.stderr)
    if a.dry_run:
        for case in cases:
            folder = work / case.id
            folder.mkdir(parents=True, exist_ok=True)
            if case.setup:
                case.setup(folder)
            _restore_perms(folder)
            shutil.rmtree(folder)
        print(f"dry run: {len(cases)} cases set up", file=sys.stderr)
        return 0
    results = []
    t0 = time.perf_counter()
    for k, case in enumerate(cases, 1):
        res = run_case(case, work, a.timeout, a.keep)
        results.append(res)
        if res.kinds:
            first = next((ln for ln in res.stderr.splitlines() if ln.strip()), "")
            print(f"[{k}/{len(cases)}] {case.id} {case.variant[:50]!r} exit {res.rc}: "
                  f"{', '.join(res.kinds)[:120]} | {first[:140]}", file=sys.stderr, flush=True)
        elif k % 50 == 0:
            print(f"[{k}/{len(cases)}] {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    table = summarise(results)
    print_table(table)
    defects = [defect_record(r) for r in results if r.kinds]
    groups: dict[str, dict] = {}
    for d in defects:
        g = groups.setdefault(d["signature"], {"count": 0, "example": d, "ids": []})
        g["count"] += 1
        g["ids"].append(d["id"])
    (out / "defects.json").write_text(json.dumps(defects, indent=1, ensure_ascii=False))
    (out / "signatures.json").write_text(json.dumps(groups, indent=1, ensure_ascii=False))
    (out / "results.json").write_text(json.dumps(
        [{"id": r.case.id, "variant": r.case.variant, "exit": r.rc, "seconds": round(r.seconds, 2),
          "rss_mb": round(r.rss_mb), "kinds": r.kinds} for r in results], indent=0, ensure_ascii=False))
    top = sorted(results, key=lambda r: -r.rss_mb)[:3]
    print("largest peak RSS: " + "; ".join(f"{r.case.id} {r.case.variant[:30]} {r.rss_mb:.0f} MB" for r in top))
    (out / "summary.json").write_text(json.dumps({"seed": a.seed, "cases": len(results),
                                                  "seconds": round(time.perf_counter() - t0, 1),
                                                  "table": table}, indent=1))
    print(f"{len(defects)} defective cases, {len(groups)} signatures; {out / 'defects.json'} "
          f"({time.perf_counter() - t0:.0f} s)")
    if not a.work and not a.keep:
        _restore_perms(work)
        shutil.rmtree(work / "_io", ignore_errors=True)
        if not defects:
            shutil.rmtree(work, ignore_errors=True)
    return 1 if defects else 0


if __name__ == "__main__":
    sys.exit(main())
