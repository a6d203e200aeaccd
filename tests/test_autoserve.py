"""`fogcli apply` with no server running starts one and hands it its own command
(launch.autostart): that and the next commands are served, with the pixels of a run by
itself; a server whose first command failed stops; nothing is started when told not to;
the server holds no descriptor of its first client, nor its folder, nor its modules."""
from __future__ import annotations

import fcntl
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from fogcli import launch
from test_serve import _env, _fogcli, _pixels, _timings, _write


def _auto_env(run_dir: Path, idle: str = "120", **extra) -> dict:
    env = _env(run_dir, **extra)
    env["FOGCLI_AUTOSERVE"] = idle       # conftest turns it off for every other test
    return env


def _stop(run_dir: Path, env: dict) -> None:
    """`fogcli serve --stop`: back once the server has gone."""
    r = _fogcli(["serve", "--stop"], run_dir.parent, env)
    assert r.returncode == 0 and "stopped the server (pid " in r.stderr, r.stderr


def _ready(run_dir: Path) -> str:
    t = time.monotonic()
    while "ready on" not in (log := "".join(p.read_text() for p in run_dir.glob("serve-*.log"))):
        assert time.monotonic() - t < 120, (log, list(run_dir.iterdir()))
        time.sleep(0.05)
    return log


def test_apply_starts_a_server_that_serves_the_next_commands(tmp_path):
    run_dir = tmp_path / "run"
    d = tmp_path / "work"
    d.mkdir()
    _write(d / "in.exr", 96, 64, seed=3)
    env = _auto_env(run_dir)
    # a pipe that the first command holds besides its stdout: the server must not keep it
    rfd, wfd = os.pipe()
    try:
        t = time.monotonic()
        first = subprocess.run([sys.executable, "-m", "fogcli", "apply", "in.exr", "-o", "a.exr", "--timings"],
                               cwd=d, env=env, capture_output=True, text=True, timeout=300, pass_fds=(wfd,))
        took = time.monotonic() - t
        os.close(wfd)
        wfd = -1
        assert first.returncode == 0 and _timings(first.stderr)["served"] is True, first.stderr
        # its stdout and stderr reached their end when it exited, not when the server stops (120 s)
        assert took < 100, took
        os.set_blocking(rfd, False)
        assert os.read(rfd, 1) == b"", "the server holds the client's pipe"
    finally:
        os.close(rfd)
        if wfd >= 0:
            os.close(wfd)
    try:
        second = _fogcli(["apply", "in.exr", "-o", "b.exr", "--timings"], d, env)
        assert second.returncode == 0 and _timings(second.stderr)["served"] is True, second.stderr
        third = _fogcli(["apply", "in.exr", "-o", "c.exr", "--timings", "--medium", "sea"], d, env)
        assert third.returncode == 0 and _timings(third.stderr)["served"] is True, third.stderr
        alone = _fogcli(["apply", "in.exr", "-o", "z.exr"], d, dict(env, FOGCLI_SERVER="0"))
        assert alone.returncode == 0, alone.stderr
        assert np.array_equal(_pixels(d / "a.exr"), _pixels(d / "z.exr"))
        assert np.array_equal(_pixels(d / "a.exr"), _pixels(d / "b.exr"))
        assert not np.array_equal(_pixels(d / "a.exr"), _pixels(d / "c.exr"))
        pid = int(next(run_dir.glob("serve-*.lock")).read_text().split()[0])
        assert os.readlink(f"/proc/{pid}/cwd") == "/", "the server keeps its first client's folder"
        log = next(run_dir.glob("serve-*.log")).read_text()
        assert "apply in.exr -o b.exr --timings: exit 0" in log, log
        assert sorted(p.name for p in d.iterdir()) == ["a.exr", "b.exr", "c.exr", "in.exr", "z.exr"]
    finally:
        _stop(run_dir, env)
    assert not list(run_dir.glob("*.sock")), "the server left its socket behind"
    again = _fogcli(["serve", "--stop"], d, env)
    assert again.returncode == 0 and "no server was running" in again.stderr, again.stderr


def test_the_server_runs_no_module_of_the_command_folder(tmp_path):
    run_dir = tmp_path / "run"
    d = tmp_path / "work"
    d.mkdir()
    _write(d / "in.exr", 32, 24, seed=4)
    # modules named as the ones fogcli imports, in the command's folder: the server must not run them
    for name in ("fogcli", "queue", "json", "numpy"):
        (d / f"{name}.py").write_text(f"open({str(tmp_path / 'ran')!r}, 'a').write({name!r})\n")
    env = _auto_env(run_dir)
    # as a user runs it: the installed script (`python -m` would import this folder's fogcli.py itself)
    script = str(Path(sys.executable).parent / "fogcli")
    try:
        for out in ("a.png", "b.png"):
            r = subprocess.run([script, "apply", "in.exr", "-o", out, "--medium", "sea", "--timings"], cwd=d,
                               env=env, capture_output=True, text=True, timeout=300)
            assert r.returncode == 0 and _timings(r.stderr)["served"] is True, r.stderr
        assert not (tmp_path / "ran").exists(), (tmp_path / "ran").read_text()
        assert (d / "a.png").read_bytes() == (d / "b.png").read_bytes()
    finally:
        _stop(run_dir, env)


def test_a_server_whose_first_command_fails_stops(tmp_path):
    run_dir = tmp_path / "run"
    env = _auto_env(run_dir)
    r = _fogcli(["apply", "missing.exr"], tmp_path, env)
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and "missing.exr" in r.stderr, r.stderr
    t = time.monotonic()
    while list(run_dir.glob("*.sock")) or "stopping" not in next(run_dir.glob("*.log")).read_text():
        assert time.monotonic() - t < 60, list(run_dir.iterdir())
        time.sleep(0.05)
    assert "the command that started this server ended with exit 2: stopping" in next(run_dir.glob("*.log")).read_text()
    again = _fogcli(["serve", "--stop"], tmp_path, env)
    assert again.returncode == 0 and "no server was running" in again.stderr, again.stderr


def test_a_killed_server_is_replaced_and_a_relative_run_folder_works(tmp_path):
    _write(tmp_path / "in.exr", 32, 24)
    env = _auto_env(Path("run"))        # relative to the command's folder
    run_dir = tmp_path / "run"
    assert _fogcli(["apply", "in.exr", "-o", "a.exr"], tmp_path, env).returncode == 0
    _ready(run_dir)
    pid = int(next(run_dir.glob("serve-*.lock")).read_text().split()[0])
    os.kill(pid, signal.SIGKILL)
    while Path(f"/proc/{pid}").exists() and "zombie" not in Path(f"/proc/{pid}/status").read_text():
        time.sleep(0.02)
    assert list(run_dir.glob("*.sock")), "the test wants the killed server's socket left behind"
    try:
        # a new server, in spite of the old socket, runs it
        r = _fogcli(["apply", "in.exr", "-o", "b.exr", "--timings"], tmp_path, env)
        assert r.returncode == 0 and _timings(r.stderr)["served"] is True, r.stderr
        assert int(next(run_dir.glob("serve-*.lock")).read_text().split()[0]) != pid
    finally:
        _stop(run_dir, env)


def test_nothing_starts_when_told_not_to(tmp_path):
    _write(tmp_path / "in.exr", 16, 12)
    cases = [(["apply", "in.exr", "-o", "o1.exr"], {"FOGCLI_AUTOSERVE": "0"}, 0),
             (["apply", "in.exr", "-o", "o2.exr"], {"FOGCLI_SERVER": "0"}, 0), (["media"], {}, 0),
             (["apply", "--help"], {}, 0), (["apply", "-", "-o", "o3.exr"], {}, 2)]     # not a command a server runs
    for args, extra, code in cases:
        run_dir = tmp_path / f"run{len(list(tmp_path.glob('run*')))}"
        env = _auto_env(run_dir)
        env.update(extra)
        r = _fogcli(args, tmp_path, env)
        assert r.returncode == code, (args, extra, r.stderr)
        assert not run_dir.exists() or not list(run_dir.iterdir()), (args, extra, list(run_dir.iterdir()))


def test_a_bad_autoserve_value_is_one_line_exit_2(tmp_path):
    _write(tmp_path / "in.exr", 16, 12)
    for bad in ("soon", "0.5", "-3", "1e9"):
        r = _fogcli(["apply", "in.exr", "-o", "o.exr"], tmp_path, _auto_env(tmp_path / "run", bad))
        assert r.returncode == 2 and len(r.stderr.splitlines()) == 1, (bad, r.stderr)
        assert "FOGCLI_AUTOSERVE" in r.stderr and repr(bad) in r.stderr, r.stderr
        assert not (tmp_path / "o.exr").exists()


def test_no_second_server_while_one_holds_the_lock(tmp_path, monkeypatch):
    run_dir = tmp_path / "run"
    run_dir.mkdir(mode=0o700)
    monkeypatch.setenv("FOGCLI_RUN_DIR", str(run_dir))
    monkeypatch.delenv("FOGCLI_SERVER", raising=False)
    fd = os.open(launch.lock_path(), os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        assert launch.autostart(30, dict(os.environ)) is False
        # a starting server (the lock held, lately): the client waits for its socket, and
        # gives up when its lock is let go without one
        os.utime(fd)
        t = time.monotonic()
        threading.Timer(0.3, lambda: fcntl.flock(fd, fcntl.LOCK_UN)).start()
        assert launch._starting(launch.install_key(), launch.socket_path()) is False
        assert 0.25 < time.monotonic() - t < 5
    finally:
        os.close(fd)
    # ... and marks that start as failed (the lock said nothing: the server never wrote its state)
    assert sorted(p.name for p in run_dir.iterdir()) == sorted([Path(launch.lock_path()).name,
                                                                Path(launch.failed_path()).name])
    # where there is no fcntl (Windows), nothing is started and nothing fails
    monkeypatch.setitem(sys.modules, "fcntl", None)
    assert launch.autostart(30, dict(os.environ)) is False
    monkeypatch.delitem(sys.modules, "fcntl")
    for v, want in (("", float(launch.AUTOSERVE_IDLE)), ("0", 0.0), ("45", 45.0)):
        monkeypatch.setenv("FOGCLI_AUTOSERVE", v)
        assert launch.autoserve_idle() == want
    monkeypatch.setenv("FOGCLI_SERVER", "0")
    assert launch.autoserve_idle() == 0.0


def test_a_server_for_another_copy_of_fogcli_stops_at_once(tmp_path):
    """A client whose fogcli is another copy than the interpreter's would wait for a socket
    that server never makes: it refuses before taking anything."""
    t = time.monotonic()
    r = _fogcli(["serve", "--key", "0123456789abcdef", "--idle", "30"], tmp_path, _env(tmp_path / "run"))
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and "not serving" in r.stderr, r.stderr
    assert time.monotonic() - t < 60
    assert not (tmp_path / "run").exists() or not list((tmp_path / "run").glob("*.sock"))



def test_a_batch_on_one_process_starts_a_server_and_one_of_workers_does_not(tmp_path):
    src = tmp_path / "frames"
    src.mkdir()
    for i in range(2):
        _write(src / f"f{i}.exr", 32, 24, seed=i)
    env = _auto_env(tmp_path / "run2")
    r = _fogcli(["batch", "frames", "out2", "--jobs", "2", "-q"], tmp_path, env)
    assert r.returncode == 0, r.stderr
    assert not (tmp_path / "run2").exists() or not list((tmp_path / "run2").iterdir())
    run_dir = tmp_path / "run"
    env = _auto_env(run_dir)
    try:
        r = _fogcli(["batch", "frames", "out", "-q"], tmp_path, env)
        assert r.returncode == 0, r.stderr
        log = next(run_dir.glob("serve-*.log")).read_text()
        assert "batch frames out -q: exit 0" in log, log
        for i in range(2):
            assert np.array_equal(_pixels(tmp_path / "out" / f"f{i}.exr"), _pixels(tmp_path / "out2" / f"f{i}.exr"))
    finally:
        _stop(run_dir, env)


def test_a_start_that_failed_pauses_the_next_starts(tmp_path, monkeypatch):
    run_dir = tmp_path / "run"
    run_dir.mkdir(mode=0o700)
    monkeypatch.setenv("FOGCLI_RUN_DIR", str(run_dir))
    monkeypatch.delenv("FOGCLI_SERVER", raising=False)
    key = launch.install_key()
    # a server that took the lock (`starting`) and died before it listened
    fd = os.open(launch.lock_path(key), os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.pwrite(fd, b"12345 starting\n", 0)
        threading.Timer(0.2, lambda: fcntl.flock(fd, fcntl.LOCK_UN)).start()
        assert launch._starting(key, launch.socket_path(key)) is False
    finally:
        os.close(fd)
    assert Path(launch.failed_path(key)).exists()
    assert launch.autostart(30, dict(os.environ)) is False        # paused: nothing spawned
    assert sorted(p.suffix for p in run_dir.iterdir()) == [".failed", ".lock"]
    # ... for FAILED_PAUSE; then a server starts again, and removes the mark once it is ready
    old = time.time() - launch.FAILED_PAUSE - 1
    os.utime(launch.failed_path(key), (old, old))
    env = _auto_env(run_dir)
    _write(tmp_path / "in.exr", 16, 12)
    try:
        r = _fogcli(["apply", "in.exr", "-o", "o.exr", "--timings"], tmp_path, env)
        assert r.returncode == 0 and _timings(r.stderr)["served"] is True, r.stderr
        assert not Path(launch.failed_path(key)).exists()
    finally:
        _stop(run_dir, env)
    # a server that stopped as it should leaves no mark, also when a client waited on it as it went
    assert next(run_dir.glob("*.lock")).read_text() == "stopped\n"
    assert launch._starting(key, launch.socket_path(key)) is False
    fd = os.open(launch.lock_path(key), os.O_RDWR)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.utime(fd)
        threading.Timer(0.2, lambda: fcntl.flock(fd, fcntl.LOCK_UN)).start()
        assert launch._starting(key, launch.socket_path(key)) is False
    finally:
        os.close(fd)
    assert not Path(launch.failed_path(key)).exists()


def test_the_heap_record_is_the_first_commands(tmp_path):
    """The started server records what its first command needed; later frames of other sizes
    (whose buffers it keeps) do not inflate the record."""
    run_dir, cache = tmp_path / "run", tmp_path / "cache"
    env = _auto_env(run_dir, XDG_CACHE_HOME=str(cache))
    _write(tmp_path / "small.exr", 64, 48)
    _write(tmp_path / "big.exr", 512, 384)
    record = cache / "fogcli" / "heap"
    try:
        r = _fogcli(["apply", "small.exr", "-o", "a.exr", "--timings"], tmp_path, env)
        assert r.returncode == 0 and _timings(r.stderr)["served"] is True, r.stderr
        first = int(record.read_text())
        r = _fogcli(["apply", "big.exr", "-o", "b.exr"], tmp_path, env)
        assert r.returncode == 0, r.stderr
    finally:
        _stop(run_dir, env)
    assert int(record.read_text()) == first
    # a run by itself rewrites it: the record is live, not left over
    r = _fogcli(["apply", "big.exr", "-o", "c.exr"], tmp_path, dict(env, FOGCLI_SERVER="0"))
    assert r.returncode == 0, r.stderr
    assert int(record.read_text()) != first, (first, record.read_text())
