"""fogcli batch --jobs-file: a frame a line with its own files and medium, bad lines named by
number without stopping the rest, resume after SIGKILL, lines from standard input taken as
they come, CSV."""
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from hdr_scenes import scene
from helpers import kill_once_written

ROOT = Path(__file__).resolve().parents[1]


def env():
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))


def fogcli(*args, stdin=None, cwd=None):
    return subprocess.run([sys.executable, "-m", "fogcli", *map(str, args)], capture_output=True, text=True,
                          timeout=600, env=env(), input=stdin, cwd=cwd)


def write_frame(path: Path, seed: int, w=48, h=32) -> None:
    rgb, z, _ = scene(w, h, seed=seed)
    data = np.ascontiguousarray(np.dstack([rgb, z]), np.float32)
    spec = oiio.ImageSpec(w, h, 4, "float")
    spec.channelnames = ("R", "G", "B", "Z")
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(data), oiio.geterror()
    out.close()


def pixels(path: Path) -> np.ndarray:
    inp = oiio.ImageInput.open(str(path))
    px = inp.read_image("float")
    inp.close()
    return px


def lines(rows) -> str:
    return "".join(json.dumps(r) + "\n" if isinstance(r, dict) else r + "\n" for r in rows)


def test_fifty_lines_bad_ones_named_by_number_the_rest_written(tmp_path):
    for i in range(5):
        write_frame(tmp_path / f"f{i}.exr", 10 + i)
    (tmp_path / "afile").write_text("not a folder")
    rows, bad = [], {}
    for n in range(1, 51):
        row = {"input": str(tmp_path / f"f{n % 5}.exr"), "output": str(tmp_path / "out" / f"o{n:02d}.exr")}
        if n == 7:
            row["input"] = str(tmp_path / "missing.exr")
            bad[n] = "missing.exr: file not found"
        elif n == 13:
            row["colour"] = "srgb"
            bad[n] = "unknown key 'colour'"
        elif n == 21:
            row["set"] = ["medium.visibilty=30"]
            bad[n] = "medium.visibilty: unknown key"
        elif n == 29:
            row["output"] = str(tmp_path / "afile" / "o.exr")
            bad[n] = "cannot create folder"
        elif n == 33:
            row["output"] = str(tmp_path / "out" / "o.xyz")
            bad[n] = "unsupported output format .xyz"
        elif n == 41:
            row = '{"input": "f1.exr", "output": '
            bad[n] = "not JSON"
        elif n == 44:
            row["output"] = str(tmp_path / "out" / "o01.exr")
            bad[n] = "also written by line 1"
        elif n % 3 == 0:
            row["set"] = {"medium.visibility": 20 + n}      # a medium per frame
        rows.append(row)
    (tmp_path / "jobs.jsonl").write_text(lines(rows))
    report = tmp_path / "report.json"
    r = fogcli("batch", "--jobs-file", tmp_path / "jobs.jsonl", "--report", report)
    assert r.returncode == 3, r.stderr
    assert "Traceback" not in r.stderr
    failed = [ln for ln in r.stderr.splitlines() if ln.startswith("fogcli: failed: ")]
    assert len(failed) == len(bad), r.stderr
    for ln, (n, why) in zip(failed, sorted(bad.items())):      # in the file's order
        assert ln.startswith(f"fogcli: failed: {tmp_path / 'jobs.jsonl'}:{n}: "), ln
        assert why in ln, (why, ln)
    good = sorted(f"o{n:02d}.exr" for n in range(1, 51) if n not in bad)
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == good
    rep = json.loads(report.read_text())
    assert rep["counts"] == {"done": 43, "skipped": 0, "failed": 7}
    assert [f["line"] for f in rep["failed"]] == [f"{tmp_path / 'jobs.jsonl'}:{n}" for n in sorted(bad)]
    # each line's own medium: a thinner fog leaves more of the scene than a thicker one
    a, b = pixels(tmp_path / "out" / "o06.exr"), pixels(tmp_path / "out" / "o11.exr")     # both f1.exr
    assert not np.array_equal(a, b)


def test_each_line_as_apply_would_write_it(tmp_path):
    write_frame(tmp_path / "in.exr", 3, w=64, h=40)
    (tmp_path / "m.yaml").write_text("medium:\n  visibility: 35\n")
    rows = [{"input": "in.exr", "output": "a.exr", "medium": "sea"},
            {"input": "in.exr", "output": "b.exr", "config": "m.yaml", "set": ["render.kernel=6"]},
            {"input": "in.exr", "output": "c.png"}]
    (tmp_path / "jobs.jsonl").write_text(lines(rows))
    r = fogcli("batch", "--jobs-file", "jobs.jsonl", "--set", "camera.fov=50", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for name, extra in (("a.exr", ["--medium", "sea"]), ("b.exr", ["--config", "m.yaml", "--set", "render.kernel=6"]),
                        ("c.png", [])):
        ref = fogcli("apply", "in.exr", "-o", f"ref_{name}", "--set", "camera.fov=50", *extra, cwd=tmp_path)
        assert ref.returncode == 0, ref.stderr
        np.testing.assert_array_equal(pixels(tmp_path / name), pixels(tmp_path / f"ref_{name}"))


def test_csv_with_a_header_and_overrides(tmp_path):
    write_frame(tmp_path / "in.exr", 4)
    (tmp_path / "jobs.csv").write_text("input,output,set\nin.exr,a.exr,medium.visibility=30;render.kernel=6\n"
                                       "in.exr,b.exr,\nin.exr,c.exr,nokey\n")
    r = fogcli("batch", "--jobs-file", "jobs.csv", "-q", cwd=tmp_path)
    assert r.returncode == 3, r.stderr
    assert "jobs.csv:4: " in r.stderr and "expected KEY=VALUE" in r.stderr
    assert (tmp_path / "a.exr").is_file() and (tmp_path / "b.exr").is_file() and not (tmp_path / "c.exr").exists()
    assert not np.array_equal(pixels(tmp_path / "a.exr"), pixels(tmp_path / "b.exr"))
    (tmp_path / "bad.csv").write_text("input,destination\nin.exr,x.exr\n")
    r = fogcli("batch", "--jobs-file", "bad.csv", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "bad.csv:1: CSV header" in r.stderr, r.stderr


def test_killed_jobs_file_resumes_with_skip_existing(tmp_path):
    for i in range(4):
        write_frame(tmp_path / f"k{i}.exr", 100 + i, w=384, h=256)
    rows = [{"input": f"k{i % 4}.exr", "output": f"out/o{i:02d}.exr"} for i in range(30)]
    (tmp_path / "jobs.jsonl").write_text(lines(rows))
    p = subprocess.Popen([sys.executable, "-m", "fogcli", "batch", "--jobs-file", "jobs.jsonl", "-q"],
                         cwd=tmp_path, env=env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    out = tmp_path / "out"
    written = kill_once_written(p, out, 3)
    assert 3 <= len(written) < 30
    for name in written:
        assert pixels(out / name).shape == (256, 384, 4)
    r = fogcli("batch", "--jobs-file", "jobs.jsonl", "--skip-existing", "--report", "r.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["counts"]["skipped"] >= len(written) and rep["counts"]["failed"] == 0
    assert rep["counts"]["done"] + rep["counts"]["skipped"] == 30
    assert sorted(f.name for f in out.iterdir()) == [f"o{i:02d}.exr" for i in range(30)]     # no temporaries


def test_lines_from_stdin_are_taken_as_they_come(tmp_path):
    write_frame(tmp_path / "in.exr", 5)
    p = subprocess.Popen([sys.executable, "-m", "fogcli", "batch", "--jobs-file", "-"], cwd=tmp_path, env=env(),
                         stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        p.stdin.write(json.dumps({"input": "in.exr", "output": "a.exr"}) + "\n")
        p.stdin.flush()
        deadline = time.time() + 120
        while not (tmp_path / "a.exr").exists() and time.time() < deadline and p.poll() is None:
            time.sleep(0.02)
        assert (tmp_path / "a.exr").is_file(), "the first line waited for the end of the input"
        assert p.poll() is None
        p.stdin.write(json.dumps({"input": "in.exr", "output": "b.exr", "medium": "haze"}) + "\n")
        p.stdin.write("{}\n")
        p.stdin.close()
        err = p.stderr.read()
        assert p.wait(120) == 3, err
    finally:
        p.kill()
    assert (tmp_path / "b.exr").is_file()
    assert "<stdin>:3: input: missing" in err
    assert "2 done, 0 skipped, 1 failed" in err


def test_jobs_file_usage_errors_exit_2(tmp_path):
    cases = [(["batch", "--jobs-file", "nope.jsonl"], "nope.jsonl: file not found"),
             (["batch", "in", "out", "--jobs-file", "j.jsonl"], "takes no INPUT_DIR"),
             (["batch", "--jobs-file", "j.jsonl", "--format", "png"], "--format is for folders"),
             (["batch"], "expected INPUT_DIR and OUTPUT_DIR, or --jobs-file"),
             (["batch", "--jobs-file", "j.jsonl", "--set", "medium.x=1"], "medium.x")]
    (tmp_path / "j.jsonl").write_text("")
    for args, needle in cases:
        r = fogcli(*args, cwd=tmp_path)
        assert r.returncode == 2, (args, r.stderr)
        assert r.stderr.count("\n") == 1 and needle in r.stderr and "Traceback" not in r.stderr, (args, r.stderr)


def test_workers_and_a_local_cluster_take_each_lines_medium(tmp_path):
    """--jobs 2 and --scheduler local:2 run the lines with their own configs: the same
    pixels as one process; stdin lines reach the workers as they come."""
    for i in range(3):
        write_frame(tmp_path / f"f{i}.exr", 20 + i)
    rows = [{"input": f"f{i % 3}.exr", "output": f"{{d}}/o{i}.exr", "medium": ["fog", "sea", "haze"][i % 3],
             "set": {"medium.visibility": 30 + 10 * i}} for i in range(6)]

    def jobs(d):
        return lines([{**r, "output": r["output"].format(d=d)} for r in rows])

    (tmp_path / "one.jsonl").write_text(jobs("one"))
    (tmp_path / "pool.jsonl").write_text(jobs("pool"))
    (tmp_path / "dask.jsonl").write_text(jobs("dask"))
    for args in (["--jobs-file", "one.jsonl"], ["--jobs-file", "pool.jsonl", "--jobs", "2"],
                 ["--jobs-file", "dask.jsonl", "--scheduler", "local:2"]):
        r = fogcli("batch", *args, "-q", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
    r = fogcli("batch", "--jobs-file", "-", "--jobs", "2", "-q", stdin=jobs("stdin"), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for i in range(6):
        want = pixels(tmp_path / "one" / f"o{i}.exr")
        for d in ("pool", "dask", "stdin"):
            np.testing.assert_array_equal(pixels(tmp_path / d / f"o{i}.exr"), want)
    assert not np.array_equal(pixels(tmp_path / "one" / "o0.exr"), pixels(tmp_path / "one" / "o3.exr"))
