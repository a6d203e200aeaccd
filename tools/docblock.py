"""The generated block of a doc: what lies between its begin and end markers (markers
included) replaced by a script's fresh output, the rest of the doc kept. Blocks of
machine-dependent numbers carry the CPU kind in their name (``batch-throughput-avx2``), so
that a run on one kind of CPU replaces its own block and keeps the other kind's."""
from __future__ import annotations

import platform
import re
from pathlib import Path

PERFORMANCE = Path(__file__).resolve().parents[1] / "docs" / "performance.md"


def _cpuinfo() -> dict:
    try:
        block = Path("/proc/cpuinfo").read_text().split("\n\n")[0]
    except OSError:
        return {}
    return {k.strip(): v.strip() for k, _, v in (ln.partition(":") for ln in block.splitlines())}


def cpu_kind() -> str:
    """avx512, avx2 or other: the two kinds of CPU users run fogcli on, which PoCL vectorises
    differently (docs/performance.md keeps a block of numbers for each)."""
    flags = set(_cpuinfo().get("flags", "").split())
    return "avx512" if "avx512f" in flags else ("avx2" if "avx2" in flags else "other")


def cpu_name() -> str:
    """The model name, with family and model where it says little ('AMD EPYC' is every Zen)."""
    info = _cpuinfo()
    name = info.get("model name") or platform.processor() or platform.machine()
    if "cpu family" in info and "model" in info:
        simd = {"avx512": "AVX-512", "avx2": "AVX2, no AVX-512"}.get(cpu_kind(), "no AVX2")
        name += f" (family {info['cpu family']}, model {info['model']}; {simd})"
    return name


def markers(name: str) -> tuple[str, str]:
    return f"<!-- {name}: begin -->", f"<!-- {name}: end -->"


def write_block(doc: Path, begin: str, end: str, block: str, new_doc: str | None = None) -> None:
    """Replace begin..end in doc by block (which carries the markers). Without the markers
    the block goes right after the last block of the same family (its name up to the CPU
    kind), else at the end of the doc, or of new_doc where the doc does not exist; with
    new_doc None the markers must be there."""
    text = doc.read_text() if doc.exists() or new_doc is None else new_doc
    if begin in text or new_doc is None:
        a, b = text.index(begin), text.index(end) + len(end)
        text = text[:a] + block + text[b:]
    else:
        family = re.sub(r"-(avx512|avx2|other): begin -->$", "", begin).removeprefix("<!-- ")
        ends = [m.end() for m in re.finditer(rf"<!-- {re.escape(family)}-[\w]+: end -->", text)]
        at = ends[-1] if ends else len(text.rstrip("\n"))
        text = text[:at].rstrip("\n") + "\n\n" + block + "\n" + ("\n" + text[at:].lstrip("\n") if text[at:].strip() else "")
    doc.write_text(text)


def publish_performance(lines: list[str], doc: Path | None = None) -> int:
    """A benchmark's block (lines, markers first and last) printed and written into doc
    (docs/performance.md unless given); the script's exit code."""
    block = "\n".join(lines)
    print(block)
    write_block(doc or PERFORMANCE, lines[0], lines[-1], block, new_doc="# Performance\n")
    return 0
