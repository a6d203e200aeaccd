"""What light_share_depth (kernels/light_share.h: a pixel at a depth edge whose light is
mostly the nearer, brighter surface's takes that surface's depth) does on the path-traced
cases (tools/groundtruth): the default pipeline's relative L1 to the path tracer with the
pass left out and with it, and with `lights: [{type: auto}]` the change it makes against
no lights (issue 40 item 4: never worse by more than 0.01). Prints a table; with --doc
writes the block between the light-share markers of docs/physics.md.

    python tools/light_share_effect.py [--doc docs/physics.md]     # about 10 s
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "tools" / "groundtruth"))

import fogcli  # noqa: E402
import fogcli.device.preprocess as dpre  # noqa: E402
from docblock import cpu_name, markers, write_block  # noqa: E402
from groundtruth.load import comparison  # noqa: E402
from metrics import rel_l1  # noqa: E402

BEGIN, END = markers("light-share")
AUTO = "lights=[{type: auto}]"


def measure() -> list[tuple]:
    """(case, held out, [off, on] x [no lights, auto]) per case."""
    g = comparison()
    share = dpre.light_share
    rows = []
    try:
        for case in g.gt_load.cases():
            sets, gt = g.case_sets(case["meta"]), case["medium"]
            got = []
            for on in (False, True):
                dpre.light_share = share if on else (lambda plan, t: None)
                for extra in ([], [AUTO]):
                    out = fogcli.apply(case["L"], case["depth"], fogcli.make_config(None, sets=sets + extra))
                    got.append(rel_l1(out, gt))
            rows.append((case["name"], bool(case["meta"]["heldout"]), got))
    finally:
        dpre.light_share = share
    return rows


def table(rows) -> list[str]:
    lines = ["| case | held out | without | with | change | auto - no lights, without | auto - no lights, with |",
             "|---|---|---|---|---|---|---|"]
    for name, held, (off, off_auto, on, on_auto) in rows:
        lines.append(f"| {name} | {'yes' if held else ''} | {off:.4f} | {on:.4f} | {on - off:+.4f} | "
                     f"{off_auto - off:+.4f} | {on_auto - on:+.4f} |")
    n = len(rows)
    mean = [sum(r[2][k] for r in rows) / n for k in range(4)]
    lines.append(f"| mean | | {mean[0]:.4f} | {mean[2]:.4f} | {mean[2] - mean[0]:+.4f} | | |")
    worst = max(rows, key=lambda r: r[2][2] - r[2][0])
    lit = [r for r in rows if abs(r[2][3] - r[2][2]) > 0 or abs(r[2][1] - r[2][0]) > 0]
    worst_auto = max(lit, key=lambda r: r[2][3] - r[2][2]) if lit else None
    lines += ["", f"Largest (worst) change by the pass: {worst[0]} {worst[2][2] - worst[2][0]:+.4f}. "
              + (f"With lamps found (`{{type: auto}}`, the {len(lit)} cases with lamps): largest change against "
                 f"no lights {worst_auto[0]} {worst_auto[2][3] - worst_auto[2][2]:+.4f}, mean "
                 f"{sum(r[2][3] - r[2][2] for r in lit) / len(lit):+.4f} (negative: closer)." if lit else "")]
    return lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--doc")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    lines = table(measure())
    print("\n".join(lines))
    if args.doc:
        head = (f"Written by `python tools/light_share_effect.py --doc docs/physics.md` on {cpu_name()}. Relative "
                "L1 to the path tracer of the default pipeline without the pass and with it; and with "
                "`lights: [{type: auto}]` less without lights, each way.")
        write_block(Path(args.doc), BEGIN, END, "\n".join([BEGIN, head, "", *lines, END]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
