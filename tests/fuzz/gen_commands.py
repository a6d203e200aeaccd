"""Cases of command lines and batch folders."""
from __future__ import annotations

import os

import numpy as np

from fuzz.case import Case, _chain, _files, _symlink, valid_depth, valid_exr
from fuzz.files import H, W, colour, corrupt, image_bytes, make_depth, make_image, zplane
from helpers import write_img


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
