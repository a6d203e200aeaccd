"""What a batch tells as it runs and when it ends: the progress bar, the summary, the JSON
report, and one line per failed frame."""
from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path



@dataclass
class Summary:
    done: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    failed: list = field(default_factory=list)
    seconds: float = 0.0

    def as_json(self) -> dict:
        d = asdict(self)
        d["counts"] = {"done": len(self.done), "skipped": len(self.skipped), "failed": len(self.failed)}
        d["images_per_second"] = round(len(self.done) / self.seconds, 3) if self.seconds > 0 else None
        return d


def describe_failure(f: dict) -> str:
    """`file:line: input: reason` (a jobs file's line) or `input: reason`."""
    why = f["reason"] if not f.get("input") or f["reason"].startswith(f["input"]) else f"{f['input']}: {f['reason']}"
    return f"{f['line']}: {why}" if f.get("line") else why


class Progress:
    """tqdm on a terminal; plain lines otherwise; nothing when quiet. total None: a stream."""

    def __init__(self, total: int | None, quiet: bool):
        self.quiet, self.total, self.n, self.t0 = quiet, total, 0, time.perf_counter()
        self.bar = None
        if not quiet and sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, unit="img", file=sys.stderr, desc="fogcli")

    def update(self, r: dict) -> None:
        self.n += 1
        if self.quiet:
            return
        if self.bar is not None:
            self.bar.update(1)
            if not r.get("ok", True):
                self.bar.write(f"fogcli: failed: {describe_failure(r)}", file=sys.stderr)
            return
        dt = time.perf_counter() - self.t0
        rate = self.n / dt if dt > 0 else 0.0
        if r.get("skipped"):
            what = f"skipped {r['output']} (exists)"
        else:
            what = f"done {r['output']}" if r["ok"] else f"failed: {describe_failure(r)}"
        if self.total is None:
            print(f"[{self.n}] {what} ({rate:.2f} img/s)", file=sys.stderr, flush=True)
            return
        eta = (self.total - self.n) / rate if rate > 0 else 0.0
        print(f"[{self.n}/{self.total}] {what} ({rate:.2f} img/s, ETA {eta:.0f} s)", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def write_report(report: Path | None, summary: "Summary") -> None:
    if report:
        from fogcli.io.outputs import atomic_write

        text = json.dumps(summary.as_json(), indent=2)
        atomic_write(report, lambda tmp: Path(tmp).write_text(text))
