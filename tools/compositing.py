"""Alpha and compositing: fogcli on a render with alpha, composited over a plate afterwards,
against fogcli on the render already composited over the plate, with the plate at
camera.empty_depth (the disc render of tests/test_alpha.py; a smooth plate). Relative L1 per
medium, border and empty_depth; writes the generated table of docs/config.md.

    python tools/compositing.py
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "tools"))

import fogcli  # noqa: E402
from docblock import markers, write_block  # noqa: E402

DOC = ROOT / "docs" / "config.md"
BEGIN, END = markers("compositing")


def rel_l1(depth_label: float, medium: str, border: str) -> float:
    from test_alpha import _render

    rgb, a, z, plate = _render()
    d = float(depth_label)
    cfg = fogcli.make_config(medium, sets=[f"camera.empty_depth={'inf' if d == np.inf else d}",
                                           f"render.border={border}"])
    out = fogcli.apply(rgb, z, cfg, alpha=a)
    after = out[:, :, :3] + (1 - out[:, :, 3:]) * plate
    behind = np.where(a > 0, z, d if d > 0 else 1e-4).astype(np.float32)    # depth 0 is a hole: 0.1 mm
    before = fogcli.apply(rgb + (1 - a[:, :, None]) * plate, behind, cfg)
    return float(np.abs(after - before).sum() / np.abs(before).sum())


def main() -> int:
    rows = ["| camera.empty_depth | border | fog | haze | sea |", "|---|---|---|---|---|"]
    for d in (0.0, 30.0, np.inf):
        for border in ("open", "closed", "extend"):
            vals = [rel_l1(d, m, border) for m in ("fog", "haze", "sea")]
            rows.append(f"| {'inf' if d == np.inf else f'{d:g}'} | {border} | " + " | ".join(f"{v:.4f}" for v in vals) + " |")
    text = "\n".join([BEGIN, "", "Relative L1 of fogcli-then-composite against composite-then-fogcli (plate at",
                      "`empty_depth`), measured by `python tools/compositing.py` on the disc render of",
                      "`tests/test_alpha.py` over a smooth plate:", "", *rows, "", END])
    print(text)
    write_block(DOC, BEGIN, END, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
