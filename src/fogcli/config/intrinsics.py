"""`--camera FILE`: pinhole intrinsics from the JSON files datasets ship, as a `camera`
config section (merged after --config, before --set).

* Open3D `PinholeCameraIntrinsic`: {"width", "height", "intrinsic_matrix": 9 numbers,
  column-major [fx, 0, 0, 0, fy, 0, cx, cy, 1]}; a nested 3x3 (row-major) also works.
* Cityscapes: {"extrinsic": {"baseline", ...}, "intrinsic": {"fx", "fy", "u0", "v0"}}.
* Plain: {"fx", "fy", "cx", "cy", "width", "height", "baseline"} (any subset with fx).
width/height become camera.calibrated_size: an image of another size scales fx, fy, cx, cy.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from fogcli.errors import UserError


def _num(v, path: Path, key: str) -> float:
    try:
        ok = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) and abs(float(v)) < 1e15
    except OverflowError:        # an integer of hundreds of digits
        ok = False
    if not ok:
        raise UserError(f"{path}: {key}: expected a number of magnitude below 1e15, got {str(v)[:40]}")
    return float(v)


def _matrix(m, path: Path) -> tuple[float, float, float, float]:
    if isinstance(m, list) and len(m) == 3 and all(isinstance(r, list) and len(r) == 3 for r in m):
        k = [[_num(v, path, "intrinsic_matrix") for v in r] for r in m]       # row-major rows
        return k[0][0], k[1][1], k[0][2], k[1][2]
    if isinstance(m, list) and len(m) == 9:
        k = [_num(v, path, "intrinsic_matrix") for v in m]                     # Open3D: column-major
        return k[0], k[4], k[6], k[7]
    raise UserError(f"{path}: intrinsic_matrix: expected 9 numbers (Open3D, column-major) or a 3x3 list")


def load(path: str | Path) -> dict:
    """The camera section the file describes."""
    p = Path(path)
    if p.exists() and not p.is_file():
        raise UserError(f"--camera {p}: not a regular file")
    if p.is_file() and p.stat().st_size > 1_000_000:
        raise UserError(f"--camera {p}: {p.stat().st_size} bytes; expected a small JSON file")
    try:
        data = json.loads(p.read_text())
    except FileNotFoundError:
        raise UserError(f"--camera {p}: file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"--camera {p}: cannot read ({exc.__class__.__name__})") from None
    except json.JSONDecodeError as exc:
        raise UserError(f"{p}:{exc.lineno}: not valid JSON ({exc.msg})") from None
    except (RecursionError, ValueError) as exc:   # nested too deep; integers of 4300+ digits
        raise UserError(f"--camera {p}: not a camera file ({exc.__class__.__name__})") from None
    if not isinstance(data, dict):
        raise UserError(f"{p}: expected a JSON object of camera intrinsics")
    cam: dict = {}
    if "intrinsic_matrix" in data:
        fx, fy, cx, cy = _matrix(data["intrinsic_matrix"], p)
    elif isinstance(data.get("intrinsic"), dict):
        i = data["intrinsic"]
        missing = [k for k in ("fx", "fy", "u0", "v0") if k not in i]
        if missing:
            raise UserError(f"{p}: intrinsic: missing {', '.join(missing)} (Cityscapes camera JSON)")
        fx, fy, cx, cy = (_num(i[k], p, f"intrinsic.{k}") for k in ("fx", "fy", "u0", "v0"))
        ext = data.get("extrinsic")
        if isinstance(ext, dict) and "baseline" in ext:
            cam["baseline"] = _num(ext["baseline"], p, "extrinsic.baseline")
    elif "fx" in data:
        fx = _num(data["fx"], p, "fx")
        fy = _num(data.get("fy", fx), p, "fy")
        cx = _num(data["cx"], p, "cx") if "cx" in data else None
        cy = _num(data["cy"], p, "cy") if "cy" in data else None
        if "baseline" in data:
            cam["baseline"] = _num(data["baseline"], p, "baseline")
    else:
        raise UserError(f"{p}: no intrinsics found (expected intrinsic_matrix (Open3D), intrinsic.fx/fy/u0/v0 "
                        "(Cityscapes) or fx/fy/cx/cy)")
    if fx <= 0 or fy <= 0:
        raise UserError(f"{p}: focal lengths must be positive, got fx {fx:g}, fy {fy:g}")
    cam.update(focal_px=fx, focal_px_y=fy)
    if cx is not None:
        cam["cx"] = cx
    if cy is not None:
        cam["cy"] = cy
    if "width" in data and "height" in data:
        size = [_num(data[k], p, k) for k in ("width", "height")]
        if not all(v >= 1 and v == int(v) for v in size):
            raise UserError(f"{p}: width, height: expected positive whole numbers of pixels, got {size}")
        cam["calibrated_size"] = [int(v) for v in size]
    return {"camera": cam}
