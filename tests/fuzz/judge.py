"""Running a case in a subprocess (as a user without CAP_DAC_OVERRIDE) and judging what it
did against the contract (fuzz/__init__.py)."""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import stat
import sys
from pathlib import Path

import numpy as np

from fuzz.case import Case
from fuzz.files import RSS_LIMIT_MB, _oiio

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
