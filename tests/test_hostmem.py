"""hostmem: a process that runs many frames reuses the pages of the last frame's
arrays instead of faulting in fresh ones (measured in a child: the setting is process-wide)."""
import os
import subprocess
import sys

CHILD = """
import resource, sys
import numpy as np
if sys.argv[1] == "keep":
    from fogcli.hostmem import keep_freed_memory
    keep_freed_memory()
def frame():
    a = np.empty(64 << 20, np.uint8)      # a 2 MPx float RGBA frame and then some
    a[::4096] = 1                         # touch every page
    del a
frame()
f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(4):
    frame()
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
"""


def _faults(mode: str) -> int:
    r = subprocess.run([sys.executable, "-c", CHILD, mode], capture_output=True, text=True, check=True)
    return int(r.stdout.strip())


def test_freed_frames_are_reused_not_faulted_in_again():
    plain, kept = _faults("plain"), _faults("keep")
    assert plain >= 100              # four fresh 64 MB blocks: one fault a page (2 MB pages: 32 a block)
    assert kept < plain / 20, (plain, kept)


WARM = """
import os, resource, sys
import numpy as np
from fogcli import hostmem
hostmem.warm_heap()
hostmem.join_warm(timeout=30)
f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
a = np.ones(48 << 20, np.uint8)          # a frame's arrays: out of the prefaulted pages
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
"""


def _warm_faults(tmp_path, prefault: str) -> int:
    (tmp_path / "fogcli").mkdir(exist_ok=True)
    (tmp_path / "fogcli" / "heap").write_text(f"{96 << 20}\n")
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path), FOGCLI_PREFAULT=prefault)
    r = subprocess.run([sys.executable, "-c", WARM], capture_output=True, text=True, check=True, env=env)
    return int(r.stdout.strip())


def test_warm_heap_faults_the_recorded_heap_in_ahead(tmp_path):
    """warm_heap touches the recorded size on a thread; once join_warm has freed it, a
    frame's allocation takes no page faults of its own (FOGCLI_PREFAULT=0: as before)."""
    plain, warm = _warm_faults(tmp_path, "0"), _warm_faults(tmp_path, "1")
    assert plain >= 16               # 48 MB fresh: 4 KB pages, or 2 MB ones where numpy gets them
    assert warm < plain / 4, (plain, warm)


RECORD = """
import numpy as np
from fogcli import hostmem
hostmem.warm_heap()
hostmem.join_warm()
a = np.ones(80 << 20, np.uint8)
hostmem.note_in_use()
del a
hostmem.record_heap()
"""


def test_record_holds_what_the_run_held_at_most(tmp_path):
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path))
    env.pop("FOGCLI_PREFAULT", None)
    subprocess.run([sys.executable, "-c", RECORD], check=True, env=env)
    got = int((tmp_path / "fogcli" / "heap").read_text())
    assert 1.1 * (80 << 20) <= got <= 1.1 * (80 << 20) + (64 << 20), got     # the array, and Python's own


def test_apply_leaves_a_record_for_the_next_run(tmp_path):
    """The command's path (launch.main): `fogcli apply` records what it held; the next run
    prefaults that, frees it before the frame (else it would record nothing) and records
    about the same again (the prefault does not feed the record); FOGCLI_PREFAULT=0 does
    neither."""
    import numpy as np
    from test_cli import write_img

    from fogcli.runtime import _user_cache_dir

    src = tmp_path / "in.exr"
    write_img(src, np.dstack([np.full((300, 400, 3), 0.5, np.float32), np.full((300, 400), 10.0, np.float32)]),
              ["R", "G", "B", "Z"])
    pocl = os.environ.get("POCL_CACHE_DIR") or str(_user_cache_dir() / "pocl")     # compiled kernels: warm

    def apply(prefault, cache):
        env = dict(os.environ, XDG_CACHE_HOME=str(cache), FOGCLI_PREFAULT=prefault, FOGCLI_SERVER="0",
                   POCL_CACHE_DIR=pocl)
        subprocess.run([sys.executable, "-m", "fogcli", "apply", str(src), "-o", str(tmp_path / f"o{prefault}.exr")],
                       check=True, env=env, capture_output=True)

    apply("0", tmp_path / "off")
    assert not (tmp_path / "off" / "fogcli" / "heap").exists()
    record = tmp_path / "on" / "fogcli" / "heap"
    apply("1", tmp_path / "on")
    first = int(record.read_text())
    (record.parent / "heap").write_text(f"{first + (64 << 20)}\n")     # more than it needs
    ino = record.stat().st_ino
    apply("1", tmp_path / "on")
    second = int(record.read_text())
    assert record.stat().st_ino != ino                  # written again: the prefault was freed in time
    assert first > (16 << 20) and abs(second - first) < 0.25 * first, (first, second)
