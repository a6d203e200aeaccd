"""Cases of images: valid frames, corrupt and crafted files, channel layouts, pixel values
and paths of every kind."""
from __future__ import annotations

import os

import numpy as np

from fuzz.case import Case, _chain, _files, _symlink, extra_opts, out_name, spread, valid_depth, valid_exr
from fuzz.files import (CORRUPTIONS, DEPTH_KINDS, EMBEDDED_Z, IMAGE_KINDS, REFUSE_CORRUPTIONS, H, W, colour, corrupt,
                        craft_hdr, craft_npy, craft_png, image_bytes, make_depth, make_image, patch_exr_box,
                        patch_jpeg_size, patch_tiff_size, zplane)
from helpers import write_img


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
