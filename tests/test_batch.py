"""fogcli batch: discovery (depth patterns, sequences, sub-folders), bad files reported
without stopping the batch, atomic outputs, resume after SIGKILL, spawn workers and a
Dask LocalCluster writing the same pixels."""
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from hdr_scenes import scene
from helpers import kill_once_written, outputs_in, read, write_img

ROOT = Path(__file__).resolve().parents[1]


def fogcli(*args, timeout=600):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "fogcli", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env)


def frame(path, seed, w=48, h=32, z_in_file=True):
    rgb, z, _ = scene(w, h, seed=seed)
    if z_in_file:
        write_img(path, np.dstack([rgb, z]), ["R", "G", "B", "Z"])
    else:
        write_img(path, rgb, ["R", "G", "B"])
    return rgb, z


def png16(path, z, scale=1000):
    """Sensor-style 16-bit depth: 0 where there is none (sky), clipped at the largest code."""
    code = np.clip(np.round(np.where(np.isfinite(z), z, 0) * scale), 0, 65535)
    write_img(path, code.astype(np.uint16)[:, :, None], ["Y"], fmt="uint16")


def test_bad_files_are_reported_and_the_rest_written(tmp_path):
    src, out = tmp_path / "in", tmp_path / "out"
    (src / "depth").mkdir(parents=True)
    for i in range(12):
        _, z = frame(src / f"f{i:02d}.exr", 10 + i, z_in_file=False)
        png16(src / "depth" / f"f{i:02d}.png", z)
    _, z = frame(src / "trunc.exr", 40, z_in_file=False)
    png16(src / "depth" / "trunc.png", z)
    data = (src / "trunc.exr").read_bytes()
    (src / "trunc.exr").write_bytes(data[: len(data) // 2])
    frame(src / "wrongsize.exr", 41, z_in_file=False)
    png16(src / "depth" / "wrongsize.png", np.ones((30, 30), np.float32))
    frame(src / "nodepth.exr", 42, z_in_file=False)
    report = tmp_path / "report.json"
    r = fogcli("batch", src, out, "--depth-pattern", "depth/{stem}.png", "--set", "camera.depth_scale=0.001",
               "--jobs", "2", "--report", report, "--save-depth", tmp_path / "clean")
    assert r.returncode == 3, r.stderr
    assert "Traceback" not in r.stderr
    assert sorted(p.name for p in out.iterdir()) == [f"f{i:02d}.exr" for i in range(12)]
    for p in out.iterdir():
        assert np.isfinite(read(p)[1]).all()
    rep = json.loads(report.read_text())
    assert rep["counts"] == {"done": 12, "skipped": 0, "failed": 3}
    why = {Path(f["input"]).name: f["reason"] for f in rep["failed"]}
    assert "truncated or corrupt" in why["trunc.exr"]
    assert "30x30" in why["wrongsize.exr"] and "aspect" in why["wrongsize.exr"]
    assert "no depth" in why["nodepth.exr"]
    for name in why:
        assert f"failed: {src / name}" in r.stderr
    assert "12 done, 0 skipped, 3 failed" in r.stderr
    # the cleaned metric depth of each written frame: millimetres decoded, sky holes filled
    assert sorted(p.name for p in (tmp_path / "clean").iterdir()) == [f"f{i:02d}.exr" for i in range(12)]
    _, z0, _ = scene(48, 32, seed=10)
    d0 = read(tmp_path / "clean" / "f00.exr")[1][:, :, 0]
    fin = np.isfinite(z0)
    np.testing.assert_allclose(d0[fin], np.minimum(np.round(z0[fin] * 1000), 65535) / 1000, rtol=1e-6, atol=1e-6)
    assert np.isfinite(d0).all()


def test_sequences_subfolders_format_and_skip_existing(tmp_path):
    src, out = tmp_path / "in", tmp_path / "out"
    (src / "cam2").mkdir(parents=True)
    for k in (1, 2, 3):
        _, z = frame(src / f"shot.{k:04d}.exr", k, z_in_file=False)
        write_img(src / f"depth.{k:04d}.exr", z[:, :, None], ["Z"])
        _, z = frame(src / "cam2" / f"shot.{k:04d}.exr", 20 + k, z_in_file=False)
        write_img(src / "cam2" / f"depth.{k:04d}.exr", z[:, :, None], ["Z"])
    r = fogcli("batch", src, out, "--depth-pattern", "depth.####.exr", "--format", "png")
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in out.iterdir()) == ["shot.0001.png", "shot.0002.png", "shot.0003.png"]
    assert "[3/3] done" in r.stderr                           # plain progress lines off a terminal
    r = fogcli("batch", src, out, "--depth-pattern", "depth.####.exr", "--format", "png", "--recursive",
               "--skip-existing", "--quiet")
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*")) == [
        "cam2", "cam2/shot.0001.png", "cam2/shot.0002.png", "cam2/shot.0003.png",
        "shot.0001.png", "shot.0002.png", "shot.0003.png"]
    # a broken output is redone, whole ones are skipped, a stale temporary file is removed
    (out / "shot.0002.png").write_bytes((out / "shot.0002.png").read_bytes()[:100])
    (out / ".shot.0003.abcd1234.tmp.png").write_bytes(b"partial")
    report = tmp_path / "r.json"
    r = fogcli("batch", src, out, "--depth-pattern", "depth.####.exr", "--format", "png", "--recursive",
               "--skip-existing", "--report", report)
    assert r.returncode == 0, r.stderr
    assert "libpng" not in r.stderr, r.stderr           # the check of the broken output is quiet
    rep = json.loads(report.read_text())
    assert rep["counts"] == {"done": 1, "skipped": 5, "failed": 0}
    assert Path(rep["done"][0]["output"]).name == "shot.0002.png"
    assert not (out / ".shot.0003.abcd1234.tmp.png").exists()
    assert read(out / "shot.0002.png")[0].width == 48


def test_killed_batch_resumes_with_skip_existing(tmp_path):
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    for i in range(40):
        frame(src / f"k{i:02d}.exr", 100 + i, w=384, h=256)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    err = open(tmp_path / "stderr.txt", "w")          # a file: the resource tracker outlives the batch
    p = subprocess.Popen([sys.executable, "-m", "fogcli", "batch", str(src), str(out), "--jobs", "2", "-q"],
                         stdout=subprocess.DEVNULL, stderr=err, env=env)
    kill_once_written(p, out, 4)
    time.sleep(1.0)                      # workers die with their parent (PR_SET_PDEATHSIG)
    err.close()
    assert "Warning" not in (tmp_path / "stderr.txt").read_text()    # no leaked-semaphore warning
    written = outputs_in(out)
    assert 4 <= len(written) < 40
    for name in written:                 # whatever carries an output's name is whole
        assert read(out / name)[1].shape == (256, 384, 4)   # R, G, B and the copied Z
    report = tmp_path / "r.json"
    r = fogcli("batch", src, out, "--jobs", "2", "--skip-existing", "--report", report)
    assert r.returncode == 0, r.stderr
    rep = json.loads(report.read_text())
    assert rep["counts"]["skipped"] >= len(written) and rep["counts"]["failed"] == 0
    assert rep["counts"]["done"] + rep["counts"]["skipped"] == 40
    assert sorted(f.name for f in out.iterdir()) == [f"k{i:02d}.exr" for i in range(40)]
    assert sorted(f.name for f in tmp_path.iterdir()) == ["in", "out", "r.json", "stderr.txt"]


def test_local_cluster_writes_the_same_pixels(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    for i in range(4):
        frame(src / f"c{i}.exr", 200 + i, w=64, h=40)
    a = fogcli("batch", src, tmp_path / "local", "-q")
    b = fogcli("batch", src, tmp_path / "dask", "--scheduler", "local:2", "--report", tmp_path / "r.json")
    assert a.returncode == 0 and b.returncode == 0, a.stderr + b.stderr
    assert json.loads((tmp_path / "r.json").read_text())["counts"]["done"] == 4
    for i in range(4):
        np.testing.assert_array_equal(read(tmp_path / "local" / f"c{i}.exr")[1], read(tmp_path / "dask" / f"c{i}.exr")[1])
    assert sorted(p.name for p in (tmp_path / "dask").iterdir()) == [f"c{i}.exr" for i in range(4)]


def test_batch_usage_errors_exit_2(tmp_path):
    r = fogcli("batch", tmp_path / "missing", tmp_path / "out")
    assert r.returncode == 2 and "not a folder (INPUT_DIR)" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    (tmp_path / "in").mkdir()
    r = fogcli("batch", tmp_path / "in", tmp_path / "in")
    assert r.returncode == 2 and "must differ" in r.stderr
    r = fogcli("batch", tmp_path / "in", tmp_path / "out", "--format", "bmp")
    assert r.returncode == 2 and "--format bmp" in r.stderr
    (tmp_path / "in" / "notes.txt").write_text("not an image")
    r = fogcli("batch", tmp_path / "in", tmp_path / "out")
    assert r.returncode == 2 and "no images found" in r.stderr and "--recursive" in r.stderr


def test_a_worker_that_dies_costs_only_its_frame(tmp_path, monkeypatch):
    """A frame that kills its worker process (as a decoder segfault would) is reported;
    every other frame is written."""
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    for i in range(8):
        frame(src / f"w{i}.exr", 300 + i)
    monkeypatch.setenv("FOGCLI_TEST_KILL_WORKER", "w3.exr")
    report = tmp_path / "r.json"
    r = fogcli("batch", src, out, "--jobs", "2", "--report", report)
    assert r.returncode == 3, r.stderr
    rep = json.loads(report.read_text())
    assert rep["counts"] == {"done": 7, "skipped": 0, "failed": 1}
    assert Path(rep["failed"][0]["input"]).name == "w3.exr" and "worker process died" in rep["failed"][0]["reason"]
    assert sorted(p.name for p in out.iterdir()) == [f"w{i}.exr" for i in range(8) if i != 3]


def test_jobs_1_writes_two_frames_at_once_within_the_pixel_budget(tmp_path, monkeypatch):
    """--jobs 1 keeps up to WRITES_IN_FLIGHT writes running (the EXR write is most of a
    frame's core time), one at a time once the frames exceed the pixel budget, and reports
    the frames in input order either way (earlier frames' writes are made the slower ones,
    so that completion order is the reverse)."""
    import threading

    from fogcli.batch import runners as batch
    from fogcli.frame import job
    from fogcli.config.presets import assemble

    src = tmp_path / "in"
    src.mkdir()
    for i in range(6):
        frame(src / f"f{i}.exr", 80 + i, w=40, h=30)
    real, lock, live, peak = job.store, threading.Lock(), [0], [0]

    def slow_store(st, cfg):
        with lock:
            live[0] += 1
            peak[0] = max(peak[0], live[0])
        time.sleep(0.9 - 0.1 * int(Path(st.job.input).stem[1:]))   # each longer than a 40 x 30 frame's run
        try:
            return real(st, cfg)
        finally:
            with lock:
                live[0] -= 1

    monkeypatch.setattr(job, "store", slow_store)
    assert batch.WRITES_IN_FLIGHT == 2
    for budget, want in ((8_000_000, 2), (2 * 40 * 30 - 1, 1)):
        monkeypatch.setattr(batch, "WRITE_BUDGET_PIXELS", budget)
        peak[0] = 0
        s = batch.run_batch(src, tmp_path / f"out{budget}", assemble("fog"), quiet=True)
        assert peak[0] == want
        assert [Path(d["input"]).name for d in s.done] == [f"f{i}.exr" for i in range(6)]


def test_jobs_1_overlaps_io_and_keeps_every_frame_apart(tmp_path):
    """--jobs 1 reads frame n + 1 and writes frame n - 1 while frame n runs on the device: the
    pixels are those of `fogcli apply` frame by frame, a frame that fails to read or to write
    is reported alone, and the order of the frames does not mix their results."""
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    for i in range(7):
        frame(src / f"f{i}.exr", 60 + i, w=40 + 4 * i, h=30)      # every frame its own size
    data = (src / "f2.exr").read_bytes()
    (src / "f2.exr").write_bytes(data[: len(data) // 2])        # fails to read
    (out / "f4.exr").mkdir(parents=True)                          # fails to write: a folder in the way
    report = tmp_path / "report.json"
    r = fogcli("batch", src, out, "--jobs", "1", "--report", report)
    assert r.returncode == 3, r.stderr
    assert "Traceback" not in r.stderr
    rep = json.loads(report.read_text())
    assert rep["counts"] == {"done": 5, "skipped": 0, "failed": 2}
    assert {Path(f["input"]).name for f in rep["failed"]} == {"f2.exr", "f4.exr"}
    assert [Path(d["input"]).name for d in rep["done"]] == ["f0.exr", "f1.exr", "f3.exr", "f5.exr", "f6.exr"]
    for i in (0, 1, 3, 5, 6):
        single = tmp_path / f"single{i}.exr"
        assert fogcli("apply", src / f"f{i}.exr", "-o", single).returncode == 0
        got, want = read(out / f"f{i}.exr")[1], read(single)[1]
        assert got.shape == want.shape == (30, 40 + 4 * i, want.shape[2])
        np.testing.assert_array_equal(got, want)


def test_a_pool_broken_before_a_submit_is_a_crash_not_an_error(monkeypatch):
    """A worker can die between the pool's last wait and the next submit: the submit then
    raises BrokenProcessPool itself. That is the crash the reruns handle (the job whose
    submit failed goes back to the source), not 'processing failed' for the whole batch
    (seen once on CI). Deterministic here: submits after the third raise."""
    from concurrent.futures import Future, ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    from fogcli.batch import runners
    from fogcli.frame.job import Job

    calls = []

    def fake_submit(self, fn, job):
        calls.append(job.input)
        if len(calls) > 3:
            raise BrokenProcessPool("a child process terminated abruptly")
        f = Future()
        f.set_result({"ok": True, "input": job.input})
        return f

    monkeypatch.setattr(ProcessPoolExecutor, "submit", fake_submit)
    jobs = [Job(input=f"f{i}.exr", output=f"o{i}.exr") for i in range(6)]
    source = runners.Source(jobs)
    got = []
    crashed, suspects = runners._pool(source, 2, None, None, None, 1, None,
                                      lambda r, p: got.append(r["input"]))
    assert crashed and suspects == [] and got == ["f0.exr", "f1.exr", "f2.exr"]
    rest = [source.get(block=False) for _ in range(3)]     # and each of the others once
    assert [j.input for j in rest] == ["f3.exr", "f4.exr", "f5.exr"]
    assert source.get(block=False) is runners.END


def test_jobs_auto_starts_workers_only_where_they_pay():
    """--jobs auto (issue 41): one process on 2 cores (it keeps both busy; workers were
    slower there, tools/jobs_auto.py), and on a small batch or a stream anywhere; one
    worker per 4 cores for a long batch."""
    from fogcli.batch.worker_count import auto_jobs

    assert auto_jobs(1000, 2_000_000, cores=2) == 1
    assert auto_jobs(10, 230_400, cores=16) == 1                 # ten small frames: start-up dominates
    assert auto_jobs(None, 2_000_000, cores=16) == 1             # a stream of unknown length
    assert auto_jobs(1000, 2_000_000, cores=16) == 4
    assert auto_jobs(1000, 2_000_000, cores=6) == 1
    assert auto_jobs(48, 50_000_000, cores=64) == 12             # at least 4 frames a worker


def test_jobs_option_takes_auto_or_a_count(tmp_path):
    from helpers import assert_one_line_error, run

    for bad in ("0", "x", "257", ""):
        assert_one_line_error(*run("batch", tmp_path, tmp_path / "o", "--jobs", bad)[:2],
                              "expected auto or a whole number from 1 to 256")
