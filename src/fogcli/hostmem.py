"""Host memory of a process that runs many frames (`fogcli serve`). A batch does not set
it: benchmarks/ab_batch.py found no difference there within the noise, and it keeps memory."""
from __future__ import annotations


def keep_freed_memory() -> None:
    """glibc hands freed blocks of 32 MB and more back to the system, so every frame's
    arrays fault in fresh zeroed pages; a process that runs many frames keeps them for the
    next one (A/B of two servers at 2 MPx: median 410 -> 381 ms a frame). What the largest
    frame needed stays with the process until it ends."""
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, 1 << 30)          # M_MMAP_THRESHOLD: blocks below 1 GiB from the heap
        libc.mallopt(-1, (1 << 31) - 1)    # M_TRIM_THRESHOLD: keep up to 2 GiB of freed heap
    except (OSError, AttributeError):      # not glibc: nothing to tune
        pass
