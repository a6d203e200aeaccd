"""The generated block of a doc: what lies between its begin and end markers (markers
included) replaced by a script's fresh output, the rest of the doc kept."""
from __future__ import annotations

from pathlib import Path


def write_block(doc: Path, begin: str, end: str, block: str, new_doc: str | None = None) -> None:
    """Replace begin..end in doc by block (which carries the markers). Without the markers
    the block is appended to the doc, or to new_doc where the doc does not exist; with
    new_doc None the markers must be there."""
    text = doc.read_text() if doc.exists() or new_doc is None else new_doc
    if begin in text or new_doc is None:
        a, b = text.index(begin), text.index(end) + len(end)
        text = text[:a] + block + text[b:]
    else:
        text = text.rstrip("\n") + "\n\n" + block + "\n"
    doc.write_text(text)


def publish_performance(lines: list[str], doc: Path | None = None) -> int:
    """A benchmark's block (lines, markers first and last) printed and written into doc
    (docs/performance.md unless given); the script's exit code."""
    block = "\n".join(lines)
    print(block)
    write_block(doc or Path(__file__).resolve().parents[1] / "docs" / "performance.md", lines[0], lines[-1], block,
                new_doc="# Performance\n")
    return 0
