"""Issue 4 acceptance on inputs the tests never use (other seeds, sizes, formats), each
through the installed command line as a user runs it. Prints a table.

    python benchmarks/real_inputs.py          (~1 min; batch throughput: benchmarks/throughput.py)
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tests")]

from fogcli.scenes import scene  # noqa: E402
from test_cli import read, write_img  # noqa: E402

ENV = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
ROWS = []


def fogcli(*args):
    return subprocess.run([sys.executable, "-m", "fogcli", *map(str, args)], capture_output=True, text=True, env=ENV)


def row(what, value, target, ok):
    ROWS.append((what, value, target, "yes" if ok else "NO"))


def listing(folder: Path):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def bad_files(tmp: Path):
    src, out = tmp / "in", tmp / "out"
    src.mkdir()
    for i in range(12):           # JPEG photos with millimetre PNG depth beside them
        rgb, z, _ = scene(200, 150, seed=3000 + i, night=i % 3 == 0)
        write_img(src / f"img{i:03d}.jpg", (np.clip(rgb / max(rgb.max(), 1e-6), 0, 1) ** (1 / 2.2) * 255).astype(np.uint8),
                  ["R", "G", "B"], fmt="uint8")
        write_img(src / f"img{i:03d}_depth.png", np.round(np.where(np.isfinite(z), np.minimum(z, 65), 0) * 1000)
                  .astype(np.uint16)[:, :, None], ["Y"], fmt="uint16")
    rgb, z, _ = scene(200, 150, seed=3100)
    write_img(src / "render.exr", np.dstack([rgb, z]), ["R", "G", "B", "Z"])
    write_img(src / "render_depth.png", np.ones((150, 200, 1), np.uint16) * 5000, ["Y"], fmt="uint16")
    data = (src / "render.exr").read_bytes()
    (src / "render.exr").write_bytes(data[: int(len(data) * 0.6)])
    write_img(src / "wide.jpg", np.full((150, 200, 3), 128, np.uint8), ["R", "G", "B"], fmt="uint8")
    write_img(src / "wide_depth.png", np.full((100, 300, 1), 4000, np.uint16), ["Y"], fmt="uint16")
    write_img(src / "orphan.jpg", np.full((150, 200, 3), 90, np.uint8), ["R", "G", "B"], fmt="uint8")
    r = fogcli("batch", src, out, "--depth-pattern", "{stem}_depth.png", "--set", "camera.depth_scale=0.001",
               "--jobs", "2", "--format", "exr", "--report", tmp / "report.json")
    rep = json.loads((tmp / "report.json").read_text())
    named = sorted(Path(f["input"]).name for f in rep["failed"])
    whole = all(np.isfinite(read(out / n)[1]).all() for n in listing(out))
    ok = (r.returncode == 3 and named == ["orphan.jpg", "render.exr", "wide.jpg"]
          and listing(out) == [f"img{i:03d}.exr" for i in range(12)] and whole)
    reasons = "; ".join(f"{Path(f['input']).name}: {f['reason'].split(': ', 1)[-1][:60]}" for f in rep["failed"])
    row("12 good + truncated EXR + wrong-size depth + no depth", f"exit {r.returncode}; {len(listing(out))} whole "
        f"outputs, nothing else: {listing(out) == [f'img{i:03d}.exr' for i in range(12)]}; failed: {reasons}",
        "exit 3, the three named, 12 outputs only", ok)


def kill_resume(tmp: Path):
    src, out = tmp / "k_in", tmp / "k_out"
    src.mkdir()
    for i in range(40):
        rgb, z, _ = scene(400, 300, seed=3200 + i)
        write_img(src / f"seq.{i + 1:04d}.exr", rgb, ["R", "G", "B"])
        write_img(src / f"z.{i + 1:04d}.exr", z[:, :, None], ["Z"])
    args = ["batch", str(src), str(out), "--depth-pattern", "z.####.exr", "--jobs", "2", "-q"]
    p = subprocess.Popen([sys.executable, "-m", "fogcli", *args], env=ENV, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    while p.poll() is None and not (out.is_dir() and len([f for f in out.iterdir() if not f.name.startswith(".")]) >= 10):
        time.sleep(0.005)
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    time.sleep(0.5)
    at_kill = len([f for f in out.iterdir() if not f.name.startswith(".")])
    temps = len([f for f in out.iterdir() if f.name.startswith(".")])
    r = fogcli(*args[:-1], "--skip-existing", "--report", tmp / "k.json")
    rep = json.loads((tmp / "k.json").read_text())
    names = listing(out)
    whole = all(read(out / n)[1].shape == (300, 400, 3) for n in names)
    ok = r.returncode == 0 and names == [f"seq.{i + 1:04d}.exr" for i in range(40)] and whole and at_kill < 40
    row("40 frames, --jobs 2, SIGKILL mid-run, rerun --skip-existing",
        f"{at_kill} outputs + {temps} temporary at the kill; rerun exit {r.returncode}, skipped "
        f"{rep['counts']['skipped']}, done {rep['counts']['done']}; {len(names)} whole outputs, nothing else",
        "exit 0, exactly 40 whole outputs", ok)


def rgbd(tmp: Path):
    """A Kinect-like frame: a room (floor, wall, a box, a person-sized cylinder), 16-bit mm
    depth with the holes such sensors leave: shadows beside near edges, dark/shiny
    patches, the far wall beyond range, speckle; ~13 % in all."""
    h, w, f = 480, 640, 525.0
    jj, ii = np.mgrid[0:h, 0:w]
    x, y = (ii + 0.5 - w / 2) / f, -(jj + 0.5 - h / 2) / f
    z = np.full((h, w), 4.5)                                   # back wall
    floor = y < -0.02
    z = np.where(floor, np.minimum(z, 1.2 / np.maximum(-y, 1e-3)), z)
    box = (ii > 120) & (ii < 300) & (jj > 250) & (jj < 420)
    z[box] = 1.6
    cyl = (ii - 460) ** 2 / 60 ** 2 < 1
    z[cyl & (jj > 60)] = 2.2 + 0.2 * (1 - np.sqrt(np.clip(1 - (ii[cyl & (jj > 60)] - 460) ** 2 / 60 ** 2, 0, 1)))
    rng = np.random.default_rng(77)
    rgb = np.empty((h, w, 3))
    rgb[:] = [0.55, 0.5, 0.45]
    rgb[floor] = [0.35, 0.3, 0.25]
    rgb[box] = [0.7, 0.2, 0.15]
    rgb[cyl & (jj > 60)] = [0.2, 0.25, 0.6]
    rgb = np.clip(rgb * (0.8 + 0.2 * np.sin(ii / 17.0)[..., None]) + rng.normal(0, 0.02, rgb.shape), 0, 1)
    holes = np.zeros((h, w), bool)
    holes[250:420, 300:318] = True                            # IR shadow right of the box
    holes[60:480, 520:532] = True                             # and of the cylinder
    holes |= (z > 4.4) & (rng.random((h, w)) < 0.08)          # far wall at the edge of range
    holes[300:340, 160:230] = True                            # a shiny patch on the box
    holes |= rng.random((h, w)) < 0.04                        # speckle
    mm = np.round(z * 1000).astype(np.uint16)
    mm[holes] = 0
    write_img(tmp / "frame.jpg", (rgb ** (1 / 2.2) * 255 + 0.5).astype(np.uint8), ["R", "G", "B"], fmt="uint8")
    write_img(tmp / "frame_depth.png", mm[:, :, None], ["Y"], fmt="uint16")
    sets = ["--depth", tmp / "frame_depth.png", "--set", "camera.depth_scale=0.001", "--set", "camera.focal_px=525",
            "--medium", "fog", "--set", "medium.visibility=6"]
    r = fogcli("apply", tmp / "frame.jpg", *sets, "-o", tmp / "frame_fog.exr", "--aov", "transmittance",
               "--save-depth", tmp / "clean.exr")
    spec, out = read(tmp / "frame_fog.exr")
    names = list(spec.channelnames)
    t = out[:, :, names.index("transmittance.G")]
    clean = read(tmp / "clean.exr")[1][:, :, 0]
    true_t = np.exp(-3.912 / 6 * z * np.sqrt(x ** 2 + y ** 2 + 1))
    err_holes = float(np.median(np.abs(t[holes] - true_t[holes])))
    depth_err = float(np.median(np.abs(np.log(clean[holes] / z[holes]))))
    wrong = float((np.abs(np.log(clean[holes] / z[holes])) > 0.1).mean())
    from fogcli.depth import _nearest_fill
    nf = _nearest_fill(mm.astype(np.float32) / 1000, mm > 0)
    wrong_nearest = float((np.abs(np.log(nf[holes] / z[holes])) > 0.1).mean())
    r2 = fogcli("apply", tmp / "frame.jpg", *sets, "-o", tmp / "frame_fog.png")
    png = read(tmp / "frame_fog.png")[1]
    ok = (r.returncode == 0 and r2.returncode == 0 and np.isfinite(out).all() and t[holes].max() < 0.99
          and err_holes < 0.02 and png.shape == (480, 640, 3))
    row("RGB-D frame 640x480 JPEG + mm PNG, focal 525", f"holes {holes.mean() * 100:.1f} %; output finite "
        f"{bool(np.isfinite(out).all())}; in the holes: filled depth median |log error| {depth_err:.3f}, "
        f"{wrong * 100:.1f} % off by > 10 % (nearest-pixel fill {wrong_nearest * 100:.1f} %), transmittance median error {err_holes:.4f} (max t {t[holes].max():.2f}); "
        f"PNG {png.shape[1]}x{png.shape[0]}", "finite, holes filled not dark, PNG works", ok)


def windows(tmp: Path):
    rgb, z, _ = scene(90, 70, seed=3300)
    a = np.random.default_rng(5).uniform(0.2, 1, (70, 90, 1))
    p = tmp / "win.exr"
    write_img(p, np.dstack([rgb, a, z]), ["R", "G", "B", "A", "Z"], window=(17, 23), display=(0, 0, 200, 150),
              attrs=[("camera:lens", "35mm")])
    r = fogcli("apply", p, "-o", tmp / "win_out.exr", "--set", "output.type=half", "--set", "camera.empty_depth=0")
    spec, px = read(tmp / "win_out.exr")
    kept = ((spec.x, spec.y, spec.width, spec.height) == (17, 23, 90, 70)
            and (spec.full_x, spec.full_y, spec.full_width, spec.full_height) == (0, 0, 200, 150)
            and np.allclose(px[:, :, list(spec.channelnames).index("A")], a[:, :, 0], atol=1e-3)
            and spec.getattribute("camera:lens") == "35mm")
    row("EXR, data window inside display window, alpha, Z", f"exit {r.returncode}; data (17, 23) 90x70 and display "
        f"200x150 kept, alpha equal to 1e-3, metadata kept: {kept}; {spec.format}", "both windows and alpha kept",
        r.returncode == 0 and kept)


def check(tmp: Path):
    c = tmp / "broken.yaml"
    c.write_text("medium:\n  scattering: [0.1, 0.1, 0.1]\n  absorption: 0.01\n  asymmetry: 1.3\ncamera:\n  fov: wide\n")
    r = fogcli("check", c)
    ok = r.returncode == 2 and "broken.yaml:4" in r.stderr and "broken.yaml:6" in r.stderr and "Traceback" not in r.stderr
    row("fogcli check on a broken config", f"exit {r.returncode}; {r.stderr.strip()!r}", "exit 2, names the line", ok)


def cluster(tmp: Path):
    src = tmp / "c_in"
    src.mkdir()
    for i in range(6):
        rgb, z, _ = scene(160, 100, seed=3400 + i, night=i % 2 == 0)
        write_img(src / f"c{i}.exr", np.dstack([rgb, z]), ["R", "G", "B", "Z"])
    a = fogcli("batch", src, tmp / "c_local", "-q")
    b = fogcli("batch", src, tmp / "c_dask", "-q", "--scheduler", "local:2")
    same = all(np.array_equal(read(tmp / "c_local" / f"c{i}.exr")[1], read(tmp / "c_dask" / f"c{i}.exr")[1])
               for i in range(6))
    row("LocalCluster (2 workers) vs local batch, 6 frames", f"exit {a.returncode} / {b.returncode}; identical "
        f"pixels: {same}", "same pixels", a.returncode == 0 and b.returncode == 0 and same)


def main():
    with tempfile.TemporaryDirectory() as d:
        for fn in (bad_files, kill_resume, rgbd, windows, check, cluster):
            sub = Path(d) / fn.__name__
            sub.mkdir()
            fn(sub)
    print("| acceptance | measured | target | met |\n|---|---|---|---|")
    for r in ROWS:
        print("| " + " | ".join(r) + " |")


if __name__ == "__main__":
    main()
