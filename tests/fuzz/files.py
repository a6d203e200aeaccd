"""Inputs the fuzz cases are made of: tiny images of every kind, depth files, and the
corruptions and crafted headers that break them."""
from __future__ import annotations

import random
import struct
import tempfile
import zlib
from pathlib import Path

import numpy as np

TIMEOUT = 30.0
RSS_LIMIT_MB = 4096            # flagged above this
RSS_KILL_MB = 10240            # a runaway case is killed (and flagged) above this
H, W = 24, 32                  # the default frame: tiny, 4:3

from helpers import write_img  # the test suite's OpenImageIO writer

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
