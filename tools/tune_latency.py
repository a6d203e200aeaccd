"""`fogcli tune`'s preview latency while a slider is dragged (issue 42): the command as a
user runs it on a 1920x1080 EXR (its preview 943x530, 0.5 MPx), the page in Debian's
headless Chromium, the visibility slider held and moved in small steps, back and forth.
Each frame's latency is the page's own: from its request to the new frame decoded and
shown (the server's render, the JPEG, the transfer, the browser's decode), with the
server's render alone beside it. Prints a table, writes its section of
docs/performance.md and, with --screenshot, docs/tune.png (the page as the test sees it).

    python tools/tune_latency.py [--steps 80] [--screenshot]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tests"), str(ROOT / "tools")]

from docblock import cpu_kind, cpu_name, markers, publish_performance  # noqa: E402

BEGIN, END = markers(f"tune-latency-{cpu_kind()}")


def make(path: Path, w: int = 1920, h: int = 1080) -> None:
    from hdr_scenes import scene
    from helpers import write_img

    rgb, z, _ = scene(w, h, seed=901)
    write_img(path, np.dstack([rgb, z]), ["R", "G", "B", "Z"], fmt="half")


def measure(image: Path, steps: int, screenshot: Path | None) -> dict:
    from tune_browser import Server, browser, count, drag, wait

    server = Server(image)
    drv = browser()
    try:
        drv.get(server.url)
        wait(drv, "return document.body.dataset.ready && +document.getElementById('after').dataset.full >= 1",
             timeout=120, what="the first full-size frame")
        size = drv.execute_script("return document.getElementById('status').textContent")
        drv.execute_script("window.tuneLatencies = []")
        rounds = max(1, steps // 20)
        for r in range(rounds):             # 20 moves of 4 px each way, a full frame at each release
            full = count(drv, "full")
            drag(drv, "visibility", [-4 if r % 2 == 0 else 4] * 20, pause=0.03)
            wait(drv, f"return +document.getElementById('after').dataset.full > {full}", timeout=120,
                 what="the full frame on release")
        lat = drv.execute_script("return window.tuneLatencies")
        if screenshot is not None:
            drv.execute_script("document.getElementById('split').value = 35;"
                               "document.getElementById('split').dispatchEvent(new Event('input'))")
            time.sleep(0.3)
            drv.save_screenshot(str(screenshot))
    finally:
        drv.quit()
        code, _, err = server.stop()
        if code != 0:
            raise SystemExit(f"fogcli tune ended with {code}: {err[-500:]}")
    pre = np.array([(e, s) for kind, e, s in lat if kind == "preview"])
    full = np.array([(e, s) for kind, e, s in lat if kind == "full"])
    return {"status": size, "preview": pre, "full": full}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=80)
    ap.add_argument("--screenshot", action="store_true", help="also write docs/tune.png")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        image = Path(d) / "street_1920x1080.exr"
        make(image)
        res = measure(image, a.steps, ROOT / "docs" / "tune.png" if a.screenshot else None)
    pre, full = res["preview"], res["full"]
    if len(pre) == 0:
        raise SystemExit("no preview frames while dragging")
    row = lambda name, x: (f"| {name} | {len(x)} | {np.median(x[:, 0]):.0f} | {np.percentile(x[:, 0], 90):.0f} | "  # noqa: E731
                           f"{np.median(x[:, 1]):.0f} | {np.percentile(x[:, 1], 90):.0f} |")
    lines = [BEGIN, f"## `fogcli tune`: a frame while a slider moves, on {cpu_name()}", "",
             f"`python tools/tune_latency.py --steps {a.steps}`: a 1920x1080 EXR (default fog), the page in "
             "Debian's headless Chromium, the visibility slider held and moved 4 px at a time. Latency: from the "
             "page's request to the new frame decoded and shown (render, JPEG, transfer, decode); render: the "
             "server's part of it. The preview is 943x530 (0.5 MPx); the full-size frame follows each release.", "",
             "| frames | n | latency median ms | latency p90 ms | render median ms | render p90 ms |",
             "|---|---|---|---|---|---|", row("preview, 943x530", pre)]
    if len(full):
        lines.append(row("full size, 1920x1080, on release", full))
    lines += ["", "Target (issue 42): at most 150 ms a preview frame at 0.5 MPx on these 2-core CPUs.", END]
    return publish_performance(lines)


if __name__ == "__main__":
    sys.exit(main())
