"""`fogcli serve`: `fogcli apply` handed to a running server gives the same file, the same
errors and exit codes as a run of its own; a client whose environment differs, or that comes
while the server is busy, runs by itself; a client that goes away interrupts its run and
leaves no file; an idle server stops and removes its socket. Real processes throughout."""
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from fogcli import launch

ROOT = Path(__file__).resolve().parents[1]


def _env(run_dir: Path, **extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("FOGCLI_SERVER", "FOGCLI_DEBUG")}
    env.update(FOGCLI_RUN_DIR=str(run_dir), **extra)
    return env


def _fogcli(args, cwd, env, **kw):
    return subprocess.run([sys.executable, "-m", "fogcli", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300, **kw)


def start_server(run_dir: Path, log: Path, idle: int = 300, env: dict | None = None) -> subprocess.Popen:
    """`fogcli serve` in the background, its log in `log`, once it is ready (also the
    benchmarks' server: benchmarks/end_to_end.py)."""
    proc = subprocess.Popen([sys.executable, "-m", "fogcli", "serve", "--idle", str(idle)],
                            env=env if env is not None else _env(run_dir),
                            stdout=subprocess.DEVNULL, stderr=open(log, "w"), stdin=subprocess.DEVNULL)
    t = time.monotonic()
    while "ready on" not in log.read_text():
        assert proc.poll() is None, log.read_text()
        assert time.monotonic() - t < 240, "the server did not come up"
        time.sleep(0.2)
    return proc


def _write(path: Path, w: int, h: int, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    rgb = rng.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32)
    z = np.tile(np.linspace(2.0, 300.0, w, dtype=np.float32), (h, 1))
    spec = oiio.ImageSpec(w, h, 4, "half")
    spec.channelnames = ("R", "G", "B", "Z")
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(np.dstack([rgb, z]))
    out.close()


def _pixels(path: Path) -> np.ndarray:
    inp = oiio.ImageInput.open(str(path))
    px = np.asarray(inp.read_image(0, 0, 0, inp.spec().nchannels, "half"))
    inp.close()
    return px.view(np.uint16)


def _wait_for(log: Path, text: str, limit: float = 120.0) -> None:
    t = time.monotonic()
    while text not in log.read_text():
        assert time.monotonic() - t < limit, log.read_text()
        time.sleep(0.1)


def _timings(stderr: str) -> dict:
    return json.loads([ln for ln in stderr.splitlines() if ln.startswith("{")][-1])


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    d = tmp_path_factory.mktemp("serve")
    run_dir, log = d / "run", d / "serve.log"
    proc = start_server(run_dir, log)
    yield run_dir, log, d
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=60) == 0, log.read_text()
    assert not list(run_dir.glob("*.sock*")), "the server left its socket behind"


def test_served_apply_matches_a_run_of_its_own(server):
    run_dir, log, d = server
    _write(d / "in.exr", 96, 64)
    served = _fogcli(["apply", "in.exr", "-o", "served.exr", "--timings"], d, _env(run_dir))
    alone = _fogcli(["apply", "in.exr", "-o", "alone.exr", "--timings"], d, _env(run_dir, FOGCLI_SERVER="0"))
    assert served.returncode == 0 and alone.returncode == 0, served.stderr + alone.stderr
    assert _timings(served.stderr)["served"] is True
    assert _timings(alone.stderr)["served"] is False
    assert np.array_equal(_pixels(d / "served.exr"), _pixels(d / "alone.exr"))
    assert "apply in.exr -o served.exr --timings: exit 0" in log.read_text()
    # the client's folder and umask: a relative output lands there with the client's mode
    os.makedirs(d / "sub", exist_ok=True)
    r = subprocess.run(["sh", "-c", f"umask 077 && exec '{sys.executable}' -m fogcli apply ../in.exr -o rel.exr"],
                       cwd=d / "sub", env=_env(run_dir), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert (d / "sub" / "rel.exr").stat().st_mode & 0o777 == 0o600


def test_served_errors_are_the_same_one_line_exit_2(server):
    run_dir, _, d = server
    (d / "bad.exr").write_bytes(b"not an exr at all")
    before = (d / "bad.exr").read_bytes()
    for args in (["apply", "missing.exr"], ["apply", "bad.exr", "-o", "x.exr"],
                 ["apply", "bad.exr", "--set", "render.kernel=5"]):
        served = _fogcli(args, d, _env(run_dir))
        alone = _fogcli(args, d, _env(run_dir, FOGCLI_SERVER="0"))
        assert (served.returncode, served.stderr, served.stdout) == (alone.returncode, alone.stderr, alone.stdout)
        assert served.returncode == 2 and len(served.stderr.splitlines()) == 1, served.stderr
        assert "Traceback" not in served.stderr
    assert (d / "bad.exr").read_bytes() == before
    assert not (d / "x.exr").exists()


def test_served_batch_matches_a_batch_of_its_own(server):
    """`fogcli batch` (--jobs 1) runs in the server: the same files, report and messages as
    a batch by itself, and a progress bar where the client's stderr is a terminal.
    --jobs 2 (worker processes) runs by itself."""
    import fcntl
    import pty
    import struct
    import termios

    run_dir, log, d = server
    src = d / "frames"
    src.mkdir()
    for i in range(4):
        _write(src / f"f{i}.exr", 40 + 8 * i, 24, seed=10 + i)
    (src / "f9.exr").write_bytes(b"truncated")
    runs = {}
    for name, extra in (("served", {}), ("alone", {"FOGCLI_SERVER": "0"})):
        r = _fogcli(["batch", "frames", f"out_{name}", "--report", f"{name}.json"], d, _env(run_dir, **extra))
        assert r.returncode == 3, r.stderr
        runs[name] = r
    assert "batch frames out_served --report served.json: exit 3" in log.read_text()
    def clean(err: str) -> list[str]:      # the messages without timings, the two output folders alike
        return [ln.split(" (")[0].replace("out_served", "out_alone") for ln in err.splitlines()
                if "done in" not in ln and " done, " not in ln]

    assert clean(runs["served"].stderr) == clean(runs["alone"].stderr)
    assert "[5/5]" in runs["served"].stderr and "f9.exr" in runs["served"].stderr
    rep = {n: json.loads((d / f"{n}.json").read_text()) for n in runs}
    assert rep["served"]["counts"] == rep["alone"]["counts"] == {"done": 4, "skipped": 0, "failed": 1}
    for i in range(4):
        assert np.array_equal(_pixels(d / "out_served" / f"f{i}.exr"), _pixels(d / "out_alone" / f"f{i}.exr"))
    # a terminal on the client's stderr: tqdm's bar, drawn with carriage returns, as by itself
    bars = {}
    for name, extra in (("tty_served", {}), ("tty_alone", {"FOGCLI_SERVER": "0"})):
        master, slave = pty.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 120, 0, 0))    # rows, columns
        p = subprocess.Popen([sys.executable, "-m", "fogcli", "batch", "frames", f"out_{name}"], cwd=d,
                             env=_env(run_dir, **extra), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                             stderr=slave)
        os.close(slave)
        seen = b""
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:         # EIO: the client closed its side
                break
            if not chunk:
                break
            seen += chunk
        os.close(master)
        assert p.wait(timeout=300) == 3
        assert b"\r" in seen and b"img/s" in seen and b"[1/5]" not in seen, (name, seen[-400:])
        text = seen.decode("utf-8", "replace").replace("\n", "\r")
        bars[name] = max(len(seg) for seg in text.split("\r") if "img/s" in seg)
    assert bars["tty_served"] == bars["tty_alone"] == 120      # the client's terminal width
    assert "batch frames out_tty_served: exit 3" in log.read_text()
    before = log.read_text()
    r = _fogcli(["batch", "frames", "out_jobs2", "--jobs", "2", "-q"], d, _env(run_dir))
    assert r.returncode == 3 and len(list((d / "out_jobs2").glob("*.exr"))) == 4, r.stderr
    assert log.read_text() == before       # never reached the server


def test_a_served_batch_whose_client_goes_away_stops_with_whole_files(server):
    """Killing a served batch's client interrupts it as Ctrl-C would a batch of its own: the
    frames written are whole, no temporary file is left, the rest are not started."""
    run_dir, log, d = server
    src = d / "slow"
    src.mkdir()
    for i in range(12):         # the exact reference: ~0.5 s a frame served here; the run stops after ~3
        _write(src / f"s{i}.exr", 200, 150, seed=20 + i)
    args = ["batch", "slow", "slow_out", "--set", "render.method=reference", "-q"]
    a = subprocess.Popen([sys.executable, "-m", "fogcli", *args], cwd=d, env=_env(run_dir),
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t = time.monotonic()
    while not list((d / "slow_out").glob("s*.exr")):
        assert a.poll() is None and time.monotonic() - t < 240, "no frame was written"
        time.sleep(0.05)
    a.kill()
    a.wait()
    _wait_for(log, f"{' '.join(args)}: exit 130")
    names = sorted(p.name for p in (d / "slow_out").iterdir())
    assert 1 <= len(names) < 12 and set(names) <= {f"s{i}.exr" for i in range(12)}, names
    for n in names:
        assert _pixels(d / "slow_out" / n).shape == (150, 200, 4)


def test_a_gone_client_interrupts_a_run_waiting_on_a_thread(monkeypatch):
    """The watcher's signal reaches a run blocked on a lock (a batch waiting for its read or
    write) at once, not when the wait ends."""
    from concurrent.futures import ThreadPoolExecutor

    from fogcli import server as srv

    def gone(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(srv.INTERRUPT, gone)
    s = srv.Server(60, lambda m: None)
    ours, theirs = socket.socketpair()
    try:
        s.running = ours
        threading.Thread(target=s._watch, args=(ours,), daemon=True).start()
        threading.Timer(0.2, theirs.close).start()
        t = time.monotonic()
        with ThreadPoolExecutor(1) as ex:
            fut = ex.submit(time.sleep, 3)
            with pytest.raises(KeyboardInterrupt):
                fut.result()
            waited = time.monotonic() - t
        assert waited < 2.0, waited
    finally:
        signal.signal(srv.INTERRUPT, old)
        ours.close()


def test_one_server_for_fogcli_and_python_m_fogcli():
    """The console script runs as the venv's python3, `python -m fogcli` as its python: the
    same interpreter, the same socket."""
    other = Path(sys.executable).with_name("python3" if Path(sys.executable).name != "python3" else "python")
    assert other.exists() and other.name != Path(sys.executable).name
    r = subprocess.run([str(other), "-c", "from fogcli import launch; print(launch.install_key())"],
                       capture_output=True, text=True, timeout=60, env=_env(Path("/nonexistent")))
    assert r.returncode == 0 and r.stdout.strip() == launch.install_key(), r.stderr


def test_terminal_without_streams_and_with_columns(monkeypatch):
    monkeypatch.setattr(sys, "stdout", None)
    monkeypatch.setattr(sys, "stderr", None)
    monkeypatch.delenv("COLUMNS", raising=False)
    assert launch.terminal() == (False, False, 0)
    monkeypatch.setenv("COLUMNS", "132")
    assert launch.terminal() == (False, False, 132)


def test_a_different_environment_runs_by_itself(server):
    run_dir, _, d = server
    _write(d / "env.exr", 32, 24)
    r = _fogcli(["apply", "env.exr", "-o", "env_out.exr", "--timings"], d, _env(run_dir, FOGCLI_DEBUG="1"))
    assert r.returncode == 0, r.stderr
    assert _timings(r.stderr)["served"] is False
    assert launch.relevant_env({"FOGCLI_DEBUG": "1", "PATH": "/x", "FOGCLI_SERVER": "1"}) == {"FOGCLI_DEBUG": "1"}


def test_a_client_that_goes_away_interrupts_its_run(server):
    """A long run (the exact reference) is interrupted when its client is killed: no output,
    no temporary file. While it runs, another client is told to run by itself."""
    run_dir, log, d = server
    _write(d / "long.exr", 640, 480, seed=1)      # the exact reference: ~14 s here, seconds on a fast CI machine
    _write(d / "small.exr", 32, 24, seed=2)
    env = _env(run_dir)
    a = subprocess.Popen([sys.executable, "-m", "fogcli", "apply", "long.exr", "-o", "long_out.exr",
                          "--set", "render.method=reference"], cwd=d, env=env,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.5)
    b = subprocess.Popen([sys.executable, "-m", "fogcli", "apply", "small.exr", "-o", "small_out.exr", "--timings"],
                         cwd=d, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    _wait_for(log, "a client runs by itself: busy")
    assert a.poll() is None, "the long run ended before the test could interrupt it"
    a.kill()
    a.wait()
    _wait_for(log, "long.exr -o long_out.exr --set render.method=reference: exit 130")
    _, err = b.communicate(timeout=300)
    assert b.returncode == 0 and _timings(err)["served"] is False, err
    assert not (d / "long_out.exr").exists()
    assert not [p.name for p in d.iterdir() if ".tmp" in p.name]
    after = _fogcli(["apply", "small.exr", "-o", "small_again.exr", "--timings"], d, env)
    assert after.returncode == 0 and _timings(after.stderr)["served"] is True, after.stderr


def test_an_idle_server_stops_and_removes_its_socket(tmp_path):
    run_dir, log = tmp_path / "run", tmp_path / "serve.log"
    proc = start_server(run_dir, log, idle=1)
    assert proc.wait(timeout=60) == 0, log.read_text()
    assert "idle for 1 s: stopping" in log.read_text()
    assert not list(run_dir.glob("*.sock*"))
    # no server: the command runs by itself
    _write(tmp_path / "in.exr", 16, 12)
    r = _fogcli(["apply", "in.exr", "--timings"], tmp_path, _env(run_dir))
    assert r.returncode == 0 and _timings(r.stderr)["served"] is False, r.stderr


def test_a_second_server_is_refused_and_requests_round_trip(server):
    run_dir, _, d = server
    r = _fogcli(["serve"], d, _env(run_dir))
    assert r.returncode == 2 and "is running already" in r.stderr and len(r.stderr.splitlines()) == 1, r.stderr
    argv = ["apply", "a b.exr", "--set", "medium.ambient=[1,2,3]", "ünï=cödé", ""]
    env = {"FOGCLI_DEVICE": "0:0", "POCL_X": "a=b", "HOME": "/h ome"}
    got = launch.decode_request(launch.encode_request(argv, "/tmp/x y", 0o027, env, (False, True, 132)))
    assert got == {"argv": argv, "cwd": "/tmp/x y", "umask": 0o027, "env": env, "tty": (False, True, 132)}
    served = [["apply", "x.exr"], ["batch", "a", "b"], ["batch", "a", "b", "--jobs", "1"], ["batch", "--jobs=1", "a", "b"]]
    alone = [["batch", "a", "b", "--jobs", "2"], ["batch", "--jobs=3", "a", "b"], ["batch", "a", "b", "--jobs"],
             ["batch", "a", "b", "--scheduler", "local:2"], ["batch", "--scheduler=tcp://h:8786", "a", "b"],
             ["batch", "a", "b", "--jobs", "x"]]
    assert [launch.served_here(a) for a in served + alone] == [True] * len(served) + [False] * len(alone)
    good = launch.encode_request(["apply"], "/", 0o022, {}, (True, False, 80)).split(b"\0")
    for field, bad in ((2, b"11:-80"), (2, b"21:80"), (2, b"11:"), (3, b"-1")):
        with pytest.raises(ValueError):
            launch.decode_request(b"\0".join(good[:field] + [bad] + good[field + 1:]))
    deep = d / ("x" * 90)
    r = _fogcli(["serve"], d, _env(deep))
    assert r.returncode == 2 and "FOGCLI_RUN_DIR" in r.stderr and len(r.stderr.splitlines()) == 1, r.stderr
