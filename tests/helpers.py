"""What several test files use: paths, the command line run in-process, image files written
and read through OpenImageIO, a plan for the kernel tests and a random frame for them."""
import os
import signal
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
from click.testing import CliRunner

from fogcli.api import make_config
from fogcli.cli import main
from fogcli.device.plan import Timings, get_plan

ROOT = Path(__file__).resolve().parents[1]


SAMPLE = ROOT / "samples" / "harbour.exr"

# What the path-traced renders can tell apart: a mean relative L1 (or a mean distance of the
# scattered energy from the path tracer's) over a dozen renders whose own noise is 0.02-0.26
# cannot rank border policies or margins closer than this. The defaults' tests
# (test_border_extend, test_docs) take choices within it as equal.
BORDER_TIE = 0.002


def write_img(path, data, names, fmt="float", window=None, display=None, attrs=(), tile=None):
    """data (h, w, c) or (h, w) -> an image file through OpenImageIO (format from the
    extension); attrs: (name, value) or (name, TypeDesc, value) items. Also the fuzz
    harness's writer (tools/fuzz.py)."""
    data = np.ascontiguousarray(data, np.float32 if fmt in ("float", "half") else None)
    if data.ndim == 2:
        data = data[:, :, None]
    h, w, c = data.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    spec.channelnames = tuple(names)
    if "A" in names:
        spec.alpha_channel = list(names).index("A")
    if tile:
        spec.tile_width, spec.tile_height = tile
    if window:
        spec.x, spec.y = window
    if display:
        spec.full_x, spec.full_y, spec.full_width, spec.full_height = display
    for a in attrs:
        spec.attribute(*a)
    out = oiio.ImageOutput.create(str(path))
    assert out is not None and out.open(str(path), spec), oiio.geterror()
    assert out.write_image(data), out.geterror()
    out.close()


def read(path):
    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    px = inp.read_image(0, 0, 0, spec.nchannels, "float")
    inp.close()
    return spec, np.asarray(px).reshape(spec.height, spec.width, spec.nchannels)


def run(*args):
    r = CliRunner().invoke(main, [str(a) for a in args])
    return r.exit_code, r.output, getattr(r, "stderr", r.output)


def assert_one_line_error(code, out, needle):
    assert code == 2, out
    assert "Traceback" not in out
    lines = [ln for ln in out.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, out
    assert needle in lines[0], lines[0]


def plan_for(rt, w, h, *sets, medium="fog", aovs=()):
    """Kernel tests drive the Gaussian chain with the closed border unless they name
    render.psf or render.border."""
    if not any(s.startswith("render.psf=") for s in sets):
        sets = ("render.psf=gaussian",) + tuple(sets)
    if not any(s.startswith("render.border=") for s in sets):
        sets = ("render.border=closed",) + tuple(sets)
    cfg = make_config(medium, sets=sets)
    return get_plan(rt, w, h, cfg, aovs), cfg


FOG = ("medium.absorption=[0.02, 0.05, 0.1]", "medium.scattering=[0.3, 0.2, 0.25]", "medium.asymmetry=0.8",
       "camera.fov=70", "camera.depth=distance", "camera.max_depth=300")


def download(plan, buf, ch):
    out = plan.download(buf, ch, Timings())
    plan.rt.queue.finish()
    return out


def random_frame(rng, w, h):
    img = rng.uniform(0, 2, (h, w, 4)).astype(np.float32)
    img[h // 3, w // 4, :3] = 400.0             # a lamp
    img[h - 2, w - 3, :3] = [900.0, 300.0, 50.0]  # a warm lamp by the border
    depth = np.exp(rng.uniform(np.log(0.5), np.log(250), (h, w))).astype(np.float32)
    depth[: h // 5] = np.inf                    # sky
    depth[h // 2, :] = 0.05                     # a near row: thin medium
    return img, depth


def outputs_in(folder: Path) -> list[str]:
    """Names in an output folder, without the hidden temporaries of writes under way."""
    return [f.name for f in folder.iterdir() if not f.name.startswith(".")] if folder.is_dir() else []


def kill_once_written(p, out: Path, n: int, within: float = 300.0) -> list[str]:
    """SIGKILL the command `p` once `out` holds n outputs (it must still be running then);
    the names written by then."""
    deadline = time.time() + within
    while time.time() < deadline and p.poll() is None and len(outputs_in(out)) < n:
        time.sleep(0.01)
    assert p.poll() is None, "the batch ended before it could be killed"
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    return outputs_in(out)
