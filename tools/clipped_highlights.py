"""8-bit photographs clip their lamps at white (issue 41): the bundled sample (HDR) against its
8-bit version (sRGB, clipped at white, as `fogcli apply ... -o x.png` or any camera writes
it), fogged by `fogcli apply` with its depth, without and with camera.highlight_gain; relative
L1 of each to the HDR original's output (both in linear light), per medium. Prints a table
and writes its block of docs/physics.md with --doc.

    python tools/clipped_highlights.py [--doc docs/physics.md]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tools"), str(ROOT / "tests")]

from docblock import cpu_name, markers, write_block  # noqa: E402
from metrics import rel_l1  # noqa: E402

SAMPLE = ROOT / "samples" / "harbour.exr"
GAINS = (1, 30, 100, 150, 200, 300, 1000)   # camera.highlight_gain (lamps)
ROWS = ((1, None), (3, None), (3, 3000), (3, 4000), (3, 5000))   # camera.highlight_area_gain, highlight_kelvin
BEGIN, END = markers("clipped-highlights")


def _read(path: Path) -> np.ndarray:
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    s = inp.spec()
    px = np.asarray(inp.read_image(0, 0, 0, 3, "float")).reshape(s.height, s.width, 3)
    inp.close()
    return px


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--doc")
    a = ap.parse_args()
    from fogcli.io.colour import srgb_codes
    from helpers import write_img

    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        hdr = _read(SAMPLE)
        import OpenImageIO as oiio

        inp = oiio.ImageInput.open(str(SAMPLE))
        spec = inp.spec()
        z = np.asarray(inp.read_image(0, 0, list(spec.channelnames).index("Z"), list(spec.channelnames).index("Z") + 1,
                                      "float")).reshape(spec.height, spec.width)
        inp.close()
        write_img(d / "z.exr", z, ["Z"])
        q = srgb_codes(hdr)
        write_img(d / "ldr.png", q, ["R", "G", "B"], fmt="uint8")
        clipped = int((q.max(-1) == 255).sum())
        rows = []
        for medium in ("fog", "haze", "sea"):
            def fog(src, *extra):
                out = d / f"out_{medium}_{len(rows)}_{'_'.join(extra)[-20:].replace('=', '')}.exr"
                subprocess.run([sys.executable, "-m", "fogcli", "apply", str(src), "--depth", str(d / "z.exr"),
                                "--medium", medium, "-o", str(out), *extra], check=True, capture_output=True)
                return _read(out)
            ref = fog(SAMPLE)
            none = rel_l1(fog(d / "ldr.png"), ref)
            for a_, k in ROWS:
                kelvin = ("--set", f"camera.highlight_kelvin={k}") if k else ()
                errs = [none if g == a_ == 1 and not k else
                        rel_l1(fog(d / "ldr.png", "--set", f"camera.highlight_gain={g}",
                                   "--set", f"camera.highlight_area_gain={a_}", *kelvin), ref) for g in GAINS]
                rows.append((medium, a_, k, none, errs))
                print(medium, a_, k, " ".join(f"{e:.3f}" for e in errs), flush=True)
    lines = [BEGIN, "", f"Written by `python tools/clipped_highlights.py --doc docs/physics.md` on {cpu_name()}. "
             f"The sample (`samples/harbour.exr`, HDR: lamps up to 400 times white, lit windows 6 times) against its "
             f"8-bit version (sRGB, clipped at white: {clipped} pixels at 255), each fogged with the sample's depth; "
             "relative L1 of the 8-bit version's output to the HDR original's, with `camera.highlight_gain` G on "
             "the lamps (compact clipped cores at most 1 m across) and `camera.highlight_area_gain` A on every "
             "other clipped region, and the lamps that clipped to white given the colour of `camera.highlight_kelvin` "
             "K (-: left white). G 1, A 1, K -: as stored, no recovery. The sample's lamps are 150, 200 and 400 "
             "times white in red, warm (red : green : blue 1 : 0.72 : 0.42, about 4300 K on this scale), its "
             "windows 6 times; an 8-bit file keeps neither the level nor the hue of a core that clipped.", "",
             "| medium | A | K | " + " | ".join(f"G {g}" for g in GAINS) + " | best over none |",
             "|---|---|---|" + "---|" * (len(GAINS) + 1)]
    for medium, a_, k, none, errs in rows:
        lines.append(f"| {medium} | {a_} | {k or '-'} | " + " | ".join(f"{e:.3f}" for e in errs)
                     + f" | {none / min(errs):.2f}x |")
    lines += ["", END]
    print("\n".join(lines))
    if a.doc:
        write_block(Path(a.doc), BEGIN, END, "\n".join(lines), new_doc="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
