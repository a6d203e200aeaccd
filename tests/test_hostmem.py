"""keep_freed_memory: a process that runs many frames reuses the pages of the last frame's
arrays instead of faulting in fresh ones (measured in a child: the setting is process-wide)."""
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
