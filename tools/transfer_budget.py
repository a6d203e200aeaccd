"""Bytes a 2 MPx frame moves between host and device, and what that costs over PCIe 4.0 x16
(issue 39): `fogcli apply` on a 1920 x 1080 RGB + Z EXR, in this process, with pyopencl's
transfers counted: enqueue_copy (by direction), buffers made from host memory
(COPY_HOST_PTR: the plan's tables, a light's primitives), and mapped buffers (a map for
reading moves the buffer to the host, one for writing moves it to the device on unmap).
On PoCL nothing crosses a bus; on a discrete GPU each of these bytes does, while every
intermediate buffer (pyramid chains, airlight, shadow maps) stays on the device.

    python tools/transfer_budget.py      # prints the table, writes its block in docs/performance.md
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from docblock import markers, publish_performance  # noqa: E402

W, H = 1920, 1080
# PCIe 4.0: 16 GT/s a lane, 128b/130b coding; x16, one direction
PCIE4_X16 = 16e9 * 16 * 128 / 130 / 8
ACHIEVED = 0.8      # what a DMA copy of tens of MB reaches of it, commonly
CASES = {
    "fog (EXR in, EXR out)": ["--medium", "fog"],
    "fog, AOVs scattered + airlight + optical depth": ["--medium", "fog", "--aov", "scattered", "--aov", "airlight",
                                                        "--aov", "optical_depth"],
    "two lights, screen shadows": ["--medium", "fog", "--set", "render.lights.shadows=screen", "--set",
                                   "lights=[{type: spot, position: [3, 5, -14], direction: [-0.3, -1, -0.1], "
                                   "angle: 25, intensity: 300}, {type: point, position: [14, 3, -18], "
                                   "intensity: 250}]"],
}


class Tally:
    """pyopencl's transfer calls wrapped: bytes to the device (up) and to the host (down)."""

    def __init__(self):
        self.up = self.down = self.tables = 0

    def __enter__(self):
        import pyopencl as cl

        tally = self
        self._saved = (cl.enqueue_copy, cl.enqueue_map_buffer, cl.Buffer)
        copy, map_buffer, Buffer = self._saved

        def counted_copy(queue, dest, src, **kw):
            if isinstance(dest, cl.MemoryObjectHolder) and isinstance(src, np.ndarray):
                tally.up += src.nbytes
            elif isinstance(src, cl.MemoryObjectHolder) and isinstance(dest, np.ndarray):
                tally.down += dest.nbytes
            return copy(queue, dest, src, **kw)

        def counted_map(queue, buf, flags, offset, shape, dtype, **kw):
            n = int(np.prod(shape)) * np.dtype(dtype).itemsize
            if flags & cl.map_flags.READ:
                tally.down += n
            if flags & (cl.map_flags.WRITE | cl.map_flags.WRITE_INVALIDATE_REGION):
                tally.up += n
            return map_buffer(queue, buf, flags, offset, shape, dtype, **kw)

        class CountedBuffer(Buffer):
            def __init__(self, ctx, flags, size=0, hostbuf=None):
                super().__init__(ctx, flags, size, hostbuf)
                if hostbuf is not None and flags & cl.mem_flags.COPY_HOST_PTR:
                    tally.tables += np.asarray(hostbuf).nbytes

        cl.enqueue_copy, cl.enqueue_map_buffer, cl.Buffer = counted_copy, counted_map, CountedBuffer
        return self

    def __exit__(self, *exc):
        import pyopencl as cl

        cl.enqueue_copy, cl.enqueue_map_buffer, cl.Buffer = self._saved


def sample_exr(folder: Path, w: int = W, h: int = H) -> Path:
    """A w x h RGB + Z EXR of random colour and depth."""
    import OpenImageIO as oiio

    rng = np.random.default_rng(5)
    px = np.empty((h, w, 4), np.float32)
    px[:, :, :3] = rng.uniform(0, 2, (h, w, 3))
    px[:, :, 3] = rng.uniform(1, 200, (h, w))
    spec = oiio.ImageSpec(w, h, 4, "float")
    spec.channelnames = ("R", "G", "B", "Z")
    path = folder / "frame.exr"
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), spec)
    out.write_image(px)
    out.close()
    return path


def measure(args: list[str], src: Path, folder: Path, frames: int = 2) -> list[Tally]:
    """The counts of `frames` runs of one command in this process: the first makes the plan
    and sends its tables, the next ones move only what every frame moves."""
    from fogcli.cli import main

    out = []
    for _ in range(frames):
        with Tally() as t:
            try:
                main(["apply", str(src), "-o", str(folder / "out.exr"), *args], standalone_mode=False)
            except SystemExit as exc:
                if exc.code:
                    raise
        out.append(t)
    return out


def main() -> int:
    rows = []
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        src = sample_exr(folder)
        for name, args in CASES.items():
            first, t = measure(args, src, folder)
            tables = first.tables + first.up - t.up
            ms = [1e3 * b / PCIE4_X16 for b in (t.up, t.down)]
            rows.append(f"| {name} | {t.up / 1e6:.1f} | {t.down / 1e6:.1f} | {tables / 1e3:.0f} | "
                        f"{ms[0]:.2f} / {ms[1]:.2f} | {ms[0] / ACHIEVED:.2f} / {ms[1] / ACHIEVED:.2f} |")
    begin, end = markers("transfers")
    lines = [begin, "## Transfers, as on a discrete GPU", "",
             f"Host <-> device traffic of one {W} x {H} frame (`fogcli apply`, RGB + Z EXR in, EXR out; counted by "
             "`python tools/transfer_budget.py`). The time is the bytes over PCIe 4.0 x16 "
             f"({PCIE4_X16 / 1e9:.1f} GB/s a direction at the link rate, and at {ACHIEVED:.0%} of it), "
             "by calculation: no discrete GPU here. The columns to device and to host are what every "
             "frame moves (the second of two in one process); tables are what the first frame sends besides: "
             "constant buffers (level offsets, border tables, the point spread's lookup table, the airlight "
             "tables of the medium, the lights' primitives), sent again only when the frame size, the medium "
             "or the camera changes.",
             "",
             "| frame | to device, MB | to host, MB | tables, kB | ms up / down at link rate | ms at "
             f"{ACHIEVED:.0%} |",
             "|---|---|---|---|---|---|",
             *rows,
             "",
             "Everything between the upload and the download (the pyramid's chains, the airlight, the shadow "
             "maps, the AOV planes until their download) stays in device buffers.",
             end]
    return publish_performance(lines)


if __name__ == "__main__":
    sys.exit(main())
