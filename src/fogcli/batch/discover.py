"""The frames of a folder and what a batch will write: inputs matched with their depth files,
outputs named, existing outputs skipped, stale temporaries of a killed run removed, and the
side outputs (report, saved depth) checked before any frame runs."""
from __future__ import annotations

import os
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from fogcli.errors import UserError
from fogcli.frame.job import Job
from fogcli.io.outputs import DISPLAY_EXT, LINEAR_EXT, default_ext, is_partial, output_is_whole


def _image_ext() -> set[str]:
    """What a batch takes as a frame: every format fogcli writes, and camera RAW."""
    from fogcli.io.images import RAW_EXT

    return DISPLAY_EXT | LINEAR_EXT | RAW_EXT


def _frame_number(stem: str) -> str | None:
    m = re.search(r"(\d+)(?!.*\d)", stem)
    return m.group(1) if m else None


def depth_for(rel: Path, pattern: str) -> Path:
    """The depth path (relative to INPUT_DIR) of the input at `rel` (relative to INPUT_DIR):
    the pattern is relative to the input's own folder; {stem} is the input's stem, a run of
    # (or %0Nd) its frame number (the last digits of the stem), padded."""
    stem = rel.stem
    out = pattern.replace("{stem}", stem)
    frame = _frame_number(stem)
    if re.search(r"#+|%0?\d*d", out):
        if frame is None:
            raise UserError(f"{rel}: --depth-pattern {pattern} needs a frame number, the name has none")
        out = re.sub(r"#+", lambda m: frame.zfill(len(m.group(0))), out)
        out = re.sub(r"%0?(\d*)d", lambda m: frame.zfill(int(m.group(1) or 0)), out)
    return rel.parent / out


def _pattern_regex(pattern: str) -> re.Pattern:
    """Matches the file names a depth pattern produces (to leave depth files out of the inputs)."""
    parts = re.split(r"(\{stem\}|#+|%0?\d*d)", pattern)
    rx = "".join(".+" if p == "{stem}" else r"\d+" if (p.startswith("#") or p.startswith("%")) else re.escape(p)
                 for p in parts)
    return re.compile(f"^(.*/)?{rx}$")


@dataclass
class Plan:
    jobs: list = field(default_factory=list)          # Job
    skipped: list = field(default_factory=list)       # (input, output)
    failed: list = field(default_factory=list)        # (input, reason)


def _is_file(p: Path) -> bool:
    """is_file that says no to names the system refuses (too long, a loop of links)."""
    try:
        return p.is_file()
    except OSError:
        return False


def discover(input_dir: Path, output_dir: Path, depth_pattern: str | None, recursive: bool,
             fmt: str | None, skip_existing: bool, layer: str | None = None, view: str | None = None,
             depth_dir: Path | None = None, drop_channels: bool = False) -> Plan:
    if not input_dir.is_dir():
        raise UserError(f"{input_dir}: not a folder (INPUT_DIR)")
    if output_dir.exists() and not output_dir.is_dir():
        raise UserError(f"{output_dir}: exists and is not a folder (OUTPUT_DIR)")
    if output_dir.resolve() == input_dir.resolve():
        raise UserError(f"{output_dir}: OUTPUT_DIR must differ from INPUT_DIR (inputs are never overwritten)")
    if fmt is not None:
        fmt = fmt.lower().lstrip(".")
        if f".{fmt}" not in DISPLAY_EXT | LINEAR_EXT:
            raise UserError(f"--format {fmt}: expected one of exr, hdr, png, tif, jpg")
    exts = _image_ext()
    files = sorted(p for p in (input_dir.rglob("*") if recursive else input_dir.glob("*"))
                   if p.is_file() and p.suffix.lower() in exts and not p.name.startswith("."))
    out_res = output_dir.resolve()
    files = [p for p in files if out_res not in p.resolve().parents]   # OUTPUT_DIR inside INPUT_DIR
    rels = [p.relative_to(input_dir) for p in files]
    depth_rx = _pattern_regex(depth_pattern) if depth_pattern else None
    plan = Plan()
    depths: dict[Path, Path | None] = {}
    for rel in rels:
        if depth_pattern:
            try:
                depths[rel] = depth_for(rel, depth_pattern)
            except UserError as exc:
                plan.failed.append((str(input_dir / rel), str(exc)))
                continue
        else:
            depths[rel] = None
    depth_files = {d for d in depths.values() if d is not None}
    for rel, drel in depths.items():
        if rel in depth_files or (depth_rx and depth_rx.match(rel.as_posix())):
            continue                      # a depth map, not a frame
        ext = f".{fmt}" if fmt else default_ext(rel)
        out = output_dir / rel.parent / f"{rel.stem}{ext}"
        src = input_dir / rel
        if skip_existing and output_is_whole(out):
            plan.skipped.append((str(src), str(out)))
            continue
        depth = None
        if drel is not None:
            dpath = input_dir / drel
            depth = str(dpath) if _is_file(dpath) else None   # missing: try the embedded Z
        saved = str(depth_dir / rel.parent / f"{rel.stem}.exr") if depth_dir else None
        plan.jobs.append(Job(str(src), str(out), depth, layer, view, saved, drop_channels))
    if not (plan.jobs or plan.skipped or plan.failed):
        hint = "" if recursive else "; --recursive looks in sub-folders"
        raise UserError(f"{input_dir}: no images found (EXR, HDR, TIFF, PNG, JPEG, camera RAW){hint}")
    names = {}
    for j in plan.jobs:
        if j.output in names:
            raise UserError(f"{j.input} and {names[j.output]} would both write {j.output}; use --format or rename")
        names[j.output] = j.input
    return plan


def remove_stale_temporaries(output_dir: Path) -> int:
    """The temporary files a killed run left in output_dir and its sub-folders."""
    n = 0
    if output_dir.is_dir():
        for p in output_dir.rglob(".*"):
            if p.is_file() and is_partial(p.name):
                p.unlink(missing_ok=True)
                n += 1
    return n


class _StaleByFolder:
    """A jobs file's outputs are anywhere: the temporary files a killed run left beside an
    output are removed before it is written. Each folder is listed once, when this process
    first writes into it (so the listing holds none of this run's own temporaries, and a
    folder of thousands of outputs is not read again for each of them)."""

    def __init__(self):
        self._folders: dict = {}

    def remove_for(self, output: Path) -> None:
        folder = os.path.abspath(output.parent)
        found = self._folders.get(folder)
        if found is None:
            found = self._folders[folder] = {}
            try:
                with os.scandir(folder) as it:
                    for e in it:
                        if is_partial(e.name):       # atomic_write's: .<stem[:60]>.<random>.tmp<suffix>
                            found.setdefault(e.name.rsplit(".tmp", 1)[0].rsplit(".", 1)[0], []).append(e.path)
            except OSError:
                return
        paths = found.get(f".{output.stem[:60]}", [])
        for p in [p for p in paths if p.endswith(f".tmp{output.suffix[:16]}")]:
            paths.remove(p)
            try:
                os.unlink(p)
            except OSError:
                pass


STALE = _StaleByFolder()


def check_side_outputs(plan, report: Path | None, input_dir: Path, recursive: bool, output_dir: Path) -> None:
    """--report and --save-depth never replace an input, and fail before any frame is done."""
    inputs = {Path(j.input).resolve() for j in plan.jobs} | {Path(j.depth).resolve() for j in plan.jobs if j.depth}
    exts = _image_ext()
    inputs |= {p.resolve() for p in (input_dir.rglob("*") if recursive else input_dir.glob("*"))
               if p.is_file() and p.suffix.lower() in exts | {".npy", ".yaml", ".json"}}
    if report is not None:
        if os.path.realpath(report) == os.path.realpath(output_dir):
            raise UserError(f"--report {report}: is OUTPUT_DIR; expected a JSON file name")
        check_report(report, inputs)
    for j in plan.jobs:
        if j.save_depth and Path(j.save_depth).resolve() in inputs:
            raise UserError(f"--save-depth {Path(j.save_depth).parent}: {Path(j.save_depth).name} would overwrite "
                            "an input; use another folder")


def check_report(report: Path, inputs: set) -> None:
    """--report is a new or replaceable JSON file in a writable folder, checked before any
    frame is done."""
    if report.resolve() in inputs:
        raise UserError(f"--report {report}: refusing to overwrite an input file")
    if report.is_dir():
        raise UserError(f"--report {report}: is a folder, expected a JSON file name")
    if not report.parent.is_dir():
        raise UserError(f"--report {report}: folder {report.parent} does not exist")
    try:                # writable? (asked before any frame is done, not after)
        tempfile.TemporaryFile(dir=report.parent).close()
    except OSError as exc:
        raise UserError(f"--report {report}: cannot write into {report.parent} ({exc.strerror})") from None
