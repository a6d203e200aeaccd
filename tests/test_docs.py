"""The docs are self-contained (issue 9): no reference to files outside the repository, and
every document or image they point at exists."""
import re

from helpers import ROOT

TEXTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "src" / "fogcli").rglob("*.py")),
         *sorted((ROOT / "src" / "fogcli" / "device" / "kernels").glob("*"))]


def test_no_reference_outside_the_repository():
    for p in TEXTS:
        text = p.read_text()
        for bad in (r"\bSPEC\b(?!\")", r"shared/", r"LIGHTS\.md", r"seeds/"):
            hits = [ln for ln in text.splitlines() if re.search(bad, ln) and 'metavar="SPEC"' not in ln
                    and "/shared/shots" not in ln]
            assert not hits, f"{p.name}: {hits[0]}"


def test_documents_and_images_referred_to_exist():
    for p in TEXTS[: 1 + len(list((ROOT / "docs").glob("*.md")))]:
        for ref in set(re.findall(r"((?:docs|tools)/[\w./-]+\.(?:md|png|jpg|py))", p.read_text())):
            assert (ROOT / ref).exists(), f"{p.name} names {ref}"
        for img in re.findall(r"\]\((images/[\w.-]+)\)", p.read_text()):
            assert (p.parent / img).exists(), f"{p.name} shows {img}"


def test_default_border_margin_is_the_calibrations_choice():
    """render.border_margin's default (the margin of `border: extend`) is the margin of the
    lowest mean relative L1 on the calibration scenes in the table tools/border_margin.py
    wrote into docs/physics.md, among margins above 0 (margin 0 is the open border: which
    policy is the default, test_border_extend.test_default_border_is_the_measured_one)."""
    from fogcli.config.model import Render

    block = (ROOT / "docs" / "physics.md").read_text().split("<!-- border-margin: begin -->")[1].split("<!-- border-margin: end -->")[0]
    head = next(ln for ln in block.splitlines() if ln.startswith("| case |"))
    margins = [float(c.split()[-1]) for c in head.strip("|").split("|") if c.strip().startswith("margin")]
    row = next(ln for ln in block.splitlines() if ln.startswith("| mean, calibration scenes"))
    means = [float(c) for c in row.strip("|").split("|")[2:]]
    assert len(means) == len(margins) >= 3
    ext = [(m, v) for m, v in zip(margins, means) if m > 0]
    assert Render().border_margin == min(ext, key=lambda mv: mv[1])[0]
