"""`fogcli batch --jobs-file`: many frames, each with its own input, output and medium, in
one process. A line is one frame: JSON lines (`{"input": ..., "output": ...}`), or CSV with
a header row when the file name ends in .csv. `-` reads JSON lines from standard input as
they come. A bad line fails alone, named by its number; the others run."""
from __future__ import annotations

import csv
import json
import os
import sys
from pathlib import Path

from fogcli.errors import UserError
from fogcli.frame.job import Job
from fogcli.config.presets import assemble
from fogcli.io.outputs import output_is_whole

# What a line may say; paths are relative to the current folder, as on the command line.
KEYS = ("input", "output", "depth", "camera", "medium", "config", "set", "layer", "view", "save_depth")
MAX_LINE = 1 << 20         # bytes: a longer line is a mistake (a binary file), refused alone


class LineError(Exception):
    """One line is unusable; the batch goes on."""


def _label(source: str) -> str:
    return "<stdin>" if source == "-" else source


def _text_lines(source: str):
    """(number, text) of every non-blank line; CSV rows come back as JSON text of a dict."""
    if source == "-":
        f = sys.stdin
    else:
        try:
            f = open(source, encoding="utf-8-sig", newline="")     # a BOM (Windows editors) is not a line's
        except FileNotFoundError:
            raise UserError(f"--jobs-file {source}: file not found") from None
        except IsADirectoryError:
            raise UserError(f"--jobs-file {source}: is a folder, expected a JSON lines or CSV file") from None
    try:
        if source != "-" and source.lower().endswith(".csv"):
            yield from _csv_lines(f, source)
            return
        number = 0
        while True:
            try:
                line = f.readline()      # not `for line in f`: a pipe's lines are taken as they come
            except UnicodeDecodeError:
                raise UserError(f"--jobs-file {_label(source)}:{number + 1}: not UTF-8 text") from None
            if not line:
                return
            number += 1
            if line.strip():
                yield number, line
    finally:
        if f is not sys.stdin:
            f.close()


def _csv_lines(f, source: str):
    try:
        rows = csv.reader(f)
        header = next(rows, None)
        if header is None:
            return
        header = [h.strip() for h in header]
        unknown = [h for h in header if h not in KEYS]
        if unknown or "input" not in header or "output" not in header:
            raise UserError(f"--jobs-file {source}:1: CSV header {','.join(header)}: expected columns among "
                            f"{', '.join(KEYS)}, with input and output")
        for row in rows:
            if not any(c.strip() for c in row):
                continue
            if len(row) != len(header):
                yield rows.line_num, json.dumps({"__error__": f"{len(row)} columns, the header has {len(header)}"})
                continue
            d = {k: v for k, v in zip(header, row) if v.strip()}
            if "set" in d:          # overrides separated by ';' in one column
                d["set"] = [s.strip() for s in d["set"].split(";") if s.strip()]
            yield rows.line_num, json.dumps(d)
    except UnicodeDecodeError:
        raise UserError(f"--jobs-file {source}: not UTF-8 text") from None
    except csv.Error as exc:
        raise UserError(f"--jobs-file {source}: not CSV ({exc})") from None


def _strings(v, expected: str) -> list[str]:
    """A string or a list of strings as a list (none: empty); else LineError(expected)."""
    if v is None:
        return []
    if isinstance(v, str):
        return [v]
    if isinstance(v, list) and all(isinstance(x, str) for x in v):
        return v
    raise LineError(expected)


def _sets(v) -> list[str]:
    """`set` as a list of KEY=VALUE, or a map of dotted keys to values (any JSON value)."""
    if isinstance(v, dict):
        return [f"{k}={json.dumps(x)}" for k, x in v.items()]
    return _strings(v, "set: expected KEY=VALUE, a list of them, or a map of keys to values")


class Parser:
    """Lines to jobs: the command line's config sources with each line's own on top
    (preset or --medium < --config < the line's config < --camera or the line's camera <
    --set < the line's set), each config validated once however many lines share it."""

    def __init__(self, source: str, medium, configs, sets, camera, *, aovs=(), layer=None, view=None,
                 drop_channels=False, protected=()):
        self.source, self.label = source, _label(source)
        self.base = (medium, tuple(configs), tuple(sets), camera)
        self.layer, self.view, self.drop_channels = layer, view, drop_channels
        self.protected = tuple(protected)
        # the command's own config, validated before any line: a bad --set fails the command
        self._configs: dict = {self.base: assemble(medium, list(configs), tuple(sets), camera)}
        self._outputs: dict = {}        # output (real path) -> the line that writes it

    def config(self, medium, configs, sets, camera):
        key = (medium, tuple(configs), tuple(sets), camera)
        got = self._configs.get(key)
        if got is None:
            try:
                got = assemble(medium, list(configs), tuple(sets), camera)
            except UserError as exc:
                got = exc
            if len(self._configs) > 4096:     # a medium drawn per line: keep the cache bounded
                self._configs.clear()
            self._configs[key] = got
        if isinstance(got, UserError):
            raise LineError(str(got))
        return got

    def job(self, number: int, text: str) -> Job:
        """The line's job, or LineError."""
        if len(text) > MAX_LINE:
            raise LineError(f"line of {len(text)} bytes; expected one JSON object")
        try:
            d = json.loads(text)
        except ValueError as exc:
            raise LineError(f"not JSON ({exc.msg} at column {exc.colno}); expected "
                            '{"input": ..., "output": ...}') from None
        if not isinstance(d, dict):
            raise LineError('expected a JSON object {"input": ..., "output": ...}')
        if "__error__" in d:
            raise LineError(d["__error__"])
        unknown = sorted(set(d) - set(KEYS))
        if unknown:
            raise LineError(f"unknown key {unknown[0]!r}; expected {', '.join(KEYS)}")
        for k in ("input", "output"):
            if not isinstance(d.get(k), str) or not d[k].strip():
                raise LineError(f"{k}: missing; expected a file name")
        for k in ("depth", "camera", "medium", "layer", "view", "save_depth"):
            if d.get(k) is not None and (not isinstance(d[k], str) or not d[k].strip()):
                raise LineError(f"{k}: expected a non-empty string")
        medium, configs, sets, camera = self.base
        own = _strings(d.get("config"), "config: expected a file name or a list of them")
        cfg = self.config(d.get("medium") or medium, configs + tuple(own), sets + tuple(_sets(d.get("set"))),
                          d.get("camera") or camera)
        out = os.path.realpath(d["output"])
        if out in self._outputs:
            raise LineError(f"output {d['output']} is also written by line {self._outputs[out]}")
        self._outputs[out] = number
        given = tuple(p for p in (d.get("camera"), d.get("medium"), *own) if p and Path(p).is_file())
        return Job(d["input"], d["output"], d.get("depth"), d.get("layer") or self.layer,
                   d.get("view") or self.view, d.get("save_depth"), self.drop_channels,
                   self.protected + given, cfg=cfg, label=f"{self.label}:{number}")

    def results(self, skip_existing: bool):
        """Per line: a Job to run, or the line's result (a failure, a skipped output)."""
        for number, text in _text_lines(self.source):
            where = f"{self.label}:{number}"
            try:
                job = self.job(number, text)
            except LineError as exc:
                yield {"ok": False, "input": _input_of(text), "output": None, "reason": str(exc), "line": where}
                continue
            if skip_existing and output_is_whole(Path(job.output)):
                yield {"skipped": True, "input": job.input, "output": job.output, "line": where}
                continue
            yield job


def _input_of(text: str) -> str:
    try:
        v = json.loads(text).get("input")
        return v if isinstance(v, str) else None
    except (ValueError, AttributeError):
        return None


def count_lines(source: str) -> int | None:
    """Lines of a jobs file (the progress bar's total); None for a stream."""
    if source == "-":
        return None
    try:
        with open(source, "rb") as f:
            n = sum(1 for line in f if line.strip())
    except OSError:
        return None
    return n - 1 if source.lower().endswith(".csv") and n else n
