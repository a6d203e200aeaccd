"""Hashes of fogcli's outputs (colour, alpha and every AOV plane, as float32 bytes) for every
preset and for each psf, border, fetch, method, separation, lights, shadows, noise and alpha
option, on the bundled sample and two synthetic scenes: a change that must not change the
pixels (a refactoring, a memory layout) is checked by running this at the commit before and
after it and comparing the two files.

    python tools/output_hashes.py out.json                 # this tree
    python tools/output_hashes.py --compare a.json b.json  # exit 1 on any difference

To hash another commit: `git worktree add /tmp/old <commit>` and run its copy of fogcli with
this script: `PYTHONPATH=/tmp/old/src python tools/output_hashes.py old.json`.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

LIGHTS = ["lights=[{type: spot, position: [3, 5, -14], direction: [-0.3, -1, -0.1], angle: 25, blend: 0.3, "
          "intensity: [300, 280, 240]}, {type: point, position: [14, 3, -18], intensity: [250, 180, 120], "
          "radius: 0.2}]"]
CASES = {
    "fog": ("fog", []), "haze": ("haze", []), "sea": ("sea", []), "harbour": ("harbour", []),
    "smoke": ("smoke", []), "valley-fog": ("valley-fog", []), "sandstorm": ("sandstorm", []),
    "smoke-ball": ("smoke-ball", []),
    "gaussian": ("fog", ["render.psf=gaussian"]),
    "closed": ("fog", ["render.border=closed"]),
    "extend": ("fog", ["render.border=extend"]),
    "open": ("fog", ["render.border=open"]),
    "receiver": ("fog", ["render.fetch=receiver", "render.psf=gaussian"]),
    "naive": ("fog", ["render.method=naive", "render.psf=gaussian"]),
    "separation": ("fog", ["render.separation.enabled=true"]),
    "separation-receiver": ("fog", ["render.separation.enabled=true", "render.fetch=receiver",
                                    "render.psf=gaussian"]),
    "lambertian": ("fog", ["render.emission_profile=lambertian"]),
    "lights": ("fog", LIGHTS),
    "lights-shadows": ("fog", LIGHTS + ["render.lights.shadows=screen"]),
    "lights-march": ("fog", LIGHTS + ["render.lights.shadows=screen", "render.lights.method=march"]),
    "lights-sea": ("sea", LIGHTS),
    "visibility-share": ("fog", ["medium.visibility=150%"]),
    "ambient-auto": ("haze", ["medium.ambient=auto"]),
}
AOVS = ("optical_depth", "transmittance", "spread", "level", "direct", "scattered", "emission", "airlight",
        "airlight_scattered")


def digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        if a is not None:
            h.update(np.ascontiguousarray(a, np.float32).tobytes())
    return h.hexdigest()[:16]


def inputs():
    import fogcli
    from hdr_scenes import scene

    f = fogcli.read_image(ROOT / "samples" / "harbour.exr")
    yield "sample", f.rgb, f.depth, None
    rgb, z, _ = scene(333, 211, seed=7)
    yield "scene", rgb, z, None
    rgb, z, _ = scene(160, 120, seed=8)
    alpha = np.clip(np.linspace(-0.2, 1.2, 160, dtype=np.float32)[None, :].repeat(120, 0), 0, 1)
    yield "alpha", rgb * alpha[:, :, None], z, alpha


def files(tmp: Path):
    """Files as users bring them, through `fogcli apply`'s own path (reading, the upload,
    the output with what it keeps): (name, input, extra args)."""
    import OpenImageIO as oiio

    from hdr_scenes import scene

    def exr(path, data, names, fmt):
        spec = oiio.ImageSpec(data.shape[1], data.shape[0], data.shape[2], fmt)
        spec.channelnames = tuple(names)
        spec.attribute("compression", "zip")
        out = oiio.ImageOutput.create(str(path))
        assert out.open(str(path), spec) and out.write_image(np.ascontiguousarray(data, np.float32))
        out.close()

    rgb, z, _ = scene(301, 187, seed=3)
    exr(tmp / "rgbz_half.exr", np.dstack([rgb, z]), ["R", "G", "B", "Z"], "half")
    yield "rgbz_half", tmp / "rgbz_half.exr", [], ".exr"
    a = np.clip(np.linspace(-0.3, 1.3, 301, dtype=np.float32)[None, :].repeat(187, 0), 0, 1)
    exr(tmp / "rgbaz_float.exr", np.dstack([rgb * a[:, :, None], a, z]), ["R", "G", "B", "A", "Z"], "float")
    yield "rgbaz_float", tmp / "rgbaz_float.exr", [], ".exr"
    exr(tmp / "bgrz.exr", np.dstack([z, rgb[:, :, 2], rgb[:, :, 1], rgb[:, :, 0]]), ["Z", "B", "G", "R"], "half")
    yield "bgrz", tmp / "bgrz.exr", [], ".exr"
    yield "rgbz_png", tmp / "rgbz_half.exr", [], ".png"
    holes = z.copy()
    holes[40:60, 100:140] = np.nan
    exr(tmp / "holes.exr", np.dstack([rgb, holes]), ["R", "G", "B", "Z"], "half")
    yield "holes", tmp / "holes.exr", [], ".exr"
    yield "lamps", tmp / "rgbz_half.exr", ["lights=[{type: auto}]"], ".exr"


def run_files() -> dict:
    import tempfile

    import OpenImageIO as oiio

    from fogcli.frame.job import Job, run_job
    from fogcli.config.presets import assemble

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, src, sets, ext in files(tmp):
            dst = tmp / f"out_{name}{ext}"
            run_job(Job(str(src), str(dst)), assemble("fog", None, sets))
            inp = oiio.ImageInput.open(str(dst))
            px = inp.read_image(0, 0, 0, inp.spec().nchannels, "float")
            names = ",".join(inp.spec().channelnames)
            inp.close()
            out[f"file/{name}"] = f"{digest(px)} {names}"
    return out


def run() -> dict:
    from fogcli.api import apply, make_config

    out = {}
    for name, rgb, z, alpha in inputs():
        for case, (medium, sets) in CASES.items():
            cfg = make_config(medium, sets=sets)
            res = apply(rgb, z, cfg, alpha=alpha)
            out[f"{name}/{case}"] = digest(res)
        cfg = make_config("fog", sets=LIGHTS)
        res, planes = apply(rgb, z, cfg, alpha=alpha, aovs=AOVS, return_aovs=True)
        out[f"{name}/aovs"] = digest(res, *(planes[k] for k in sorted(planes)))
        if rgb.shape[0] * rgb.shape[1] < 30000:       # the exact reference is slow: small frames only
            out[f"{name}/reference"] = digest(apply(rgb, z, make_config("fog", sets=["render.method=reference"]),
                                                    alpha=alpha))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+")
    ap.add_argument("--compare", action="store_true")
    args = ap.parse_args()
    if args.compare:
        a, b = (json.loads(Path(f).read_text()) for f in args.files[:2])
        bad = sorted(k for k in a.keys() | b.keys() if a.get(k) != b.get(k))
        for k in bad:
            print(f"differs: {k}: {a.get(k)} {b.get(k)}")
        print(f"{len(a.keys() & b.keys()) - len([k for k in bad if k in a and k in b])} of "
              f"{len(a.keys() | b.keys())} identical")
        return 1 if bad else 0
    got = {**run(), **run_files()}
    Path(args.files[0]).write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
    print(f"{len(got)} outputs hashed into {args.files[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
