"""Cases of depth files, YAML configs, --set values and camera files."""
from __future__ import annotations

import random
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np

from fuzz.case import MEDIA, Case, _files, out_name, spread, valid_exr
from fuzz.files import (CORRUPTIONS, DEPTH_KINDS, IMAGE_KINDS, REFUSE_CORRUPTIONS, H, W, colour, corrupt, craft_npy,
                        make_depth, make_image, zplane)
from helpers import write_img

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


VECTOR_PASSES = {"exr-N.X": ["N.X"], "exr-Normal.Z": ["Normal.Z"], "exr-P.XZ": ["P.X", "P.Z"],
                 "exr-N.XYZ": ["N.X", "N.Y", "N.Z"]}


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
        dk = r.choice(list(DEPTH_KINDS) + ["jpg", "png8", "exr-rgb", "tif3", *VECTOR_PASSES])
        how = r.choice(CORRUPTIONS + ["none", "none", "mode"])
        with tempfile.TemporaryDirectory() as d:
            ext = DEPTH_KINDS.get(dk, {"jpg": ".jpg", "png8": ".png", "exr-rgb": ".exr", "tif3": ".tif"}.get(dk, ".exr"))
            p = Path(d) / ("d" + ext)
            z = zplane(nr)
            if dk in DEPTH_KINDS:
                make_depth(p, dk, z)
            elif dk == "jpg" or dk == "png8":
                write_img(p, np.clip(z / 4, 0, 255).astype(np.uint8)[:, :, None], ["Y"], fmt="uint8")
            elif dk == "exr-rgb":
                write_img(p, colour(nr), ["R", "G", "B"])
            elif dk in VECTOR_PASSES:         # a normal or position pass alone is never depth (issue 41)
                names = VECTOR_PASSES[dk]
                write_img(p, np.dstack([z] * len(names)), names)
            else:
                write_img(p, np.dstack([z, z * 2, z * 3]), ["R", "G", "B"])
            data = p.read_bytes()
        expect = "refuse" if how in REFUSE_CORRUPTIONS or dk in ("exr-rgb", "tif3", *VECTOR_PASSES) else ""
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
