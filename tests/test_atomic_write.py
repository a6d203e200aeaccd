"""outputs.atomic_write: the new file replaces the old in one rename, and the old file's
blocks are freed off the caller's path (held open across the rename, closed by a thread)."""
import os
import threading
import time

from fogcli.io import outputs


def _fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def _settle():
    for t in threading.enumerate():
        if t is not threading.current_thread() and t.daemon and t.name.startswith("Thread"):
            t.join(5)


def test_replacing_an_output_keeps_no_descriptor(tmp_path):
    out = tmp_path / "o.exr"
    out.write_bytes(b"old" * 100000)
    before = _fds()
    for k in range(5):
        outputs.atomic_write(out, lambda tmp, k=k: open(tmp, "wb").write(b"new%d" % k * 1000))
    _settle()
    time.sleep(0.05)
    assert out.read_bytes() == b"new4" * 1000
    assert _fds() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.exr"]


def test_hold_takes_regular_files_only(tmp_path):
    """What sits at the output path is held open only if it is a regular file: not through a
    symlink (the rename replaces the link), not a FIFO (opening it could block), not a folder."""
    target = tmp_path / "target.exr"
    target.write_bytes(b"x")
    link = tmp_path / "link.exr"
    link.symlink_to(target)
    fifo = tmp_path / "fifo.exr"
    os.mkfifo(fifo)
    fd = outputs._hold(target)
    assert fd is not None
    os.close(fd)
    assert outputs._hold(link) is None
    assert outputs._hold(fifo) is None
    assert outputs._hold(tmp_path) is None
    assert outputs._hold(tmp_path / "missing.exr") is None


def test_a_failed_rename_leaks_no_descriptor(tmp_path, monkeypatch):
    out = tmp_path / "o.exr"
    out.write_bytes(b"old")
    before = _fds()

    def fail(*a):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)
    try:
        outputs.atomic_write(out, lambda tmp: open(tmp, "wb").write(b"new"))
    except Exception as exc:       # ProcessingError naming the file
        assert "o.exr" in str(exc)
    else:
        raise AssertionError("the failed rename was not reported")
    _settle()
    time.sleep(0.05)
    assert _fds() == before and out.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.exr"]
