"""`fogcli media --sheet`: every preset (and the --config files given) on the user's own
image, reduced to tiles, labelled, in one picture: the input first."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fogcli.config.presets import assemble, presets, visibility_m
from fogcli.errors import UserError
from fogcli.frame.job import Job, load
from fogcli.io import outputs
from fogcli.io.colour import srgb_codes
from fogcli.tune.quick_look import reduced, render

COLUMNS = 3


def contact_sheet(image: str, output: str, depth: str | None = None, config_files=(), camera_file: str | None = None,
                  width: int = 480, device: str | None = None, sets=()) -> list[str]:
    """Writes the sheet; returns the warnings of reading the image. sets: --set values for
    every tile (the camera's depth_scale of an RGB-D frame, say)."""
    import cv2

    out = Path(output)
    if out.suffix.lower() not in (".png", ".jpg", ".jpeg", ".tif", ".tiff"):
        raise UserError(f"-o {output}: expected a .png, .jpg or .tif sheet")
    given = tuple(Path(p) for p in (*config_files, camera_file) if p)
    outputs.check_target(out, Path(image), Path(depth) if depth else None, *given)
    base = assemble(None, None, sets, camera_file)
    st = load(Job(image, str(out), depth), base)
    frame, cfg = st.frame, st.cfg or base
    h, w = frame.shape
    tw = min(width, w)
    th = max(1, round(h * tw / w))
    look = reduced(np.asarray(frame.rgb, np.float32), st.depth, frame.alpha, cfg.camera, tw, th)
    tiles = [(("input", ""), look.rgb)]
    sources = [(name, name, None) for name in presets()] + [(Path(f).name, None, f) for f in config_files]
    for label, medium, cfile in sources:
        res, _, frame_cfg = render(look, assemble(medium, cfile, sets, camera_file), device=device)
        m = frame_cfg.medium
        tiles.append(((label, f"visibility {visibility_m(m):.4g} m, g {m.asymmetry:g}"), res))
    sheet = _assemble(tiles, tw, th)
    ext = out.suffix.lower()
    ok, buf = cv2.imencode(".tiff" if ext == ".tif" else ext, sheet)
    if not ok:
        raise UserError(f"{out}: cannot encode the sheet")
    outputs.atomic_write(out, lambda tmp: Path(tmp).write_bytes(buf.tobytes()))
    return st.res.warnings


def _assemble(tiles: list, tw: int, th: int) -> np.ndarray:
    """The tiles in rows of COLUMNS, each with its label below it, sRGB 8-bit (BGR)."""
    import cv2

    band = 40
    cols = min(COLUMNS, len(tiles))
    rows = math.ceil(len(tiles) / cols)
    gap = 6
    sheet = np.full((rows * (th + band + gap) + gap, cols * (tw + gap) + gap, 3), 24, np.uint8)
    for i, ((name, detail), rgb) in enumerate(tiles):
        r, c = divmod(i, cols)
        y, x = gap + r * (th + band + gap), gap + c * (tw + gap)
        disp = srgb_codes(rgb)[:, :, ::-1]
        sheet[y:y + th, x:x + tw] = disp
        cv2.putText(sheet, name, (x + 4, y + th + 17), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (235, 235, 235), 1, cv2.LINE_AA)
        if detail:
            cv2.putText(sheet, detail, (x + 4, y + th + 34), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (170, 170, 170), 1,
                        cv2.LINE_AA)
    return sheet
