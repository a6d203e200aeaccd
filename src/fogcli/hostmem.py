"""Host memory of a fogcli process (glibc; elsewhere nothing here does anything).

A process that runs many frames (`fogcli serve`) keeps the pages of one frame for the next
(keep_freed_memory). A command that runs here (`apply`, `batch` on this process) also has
the heap its previous run needed faulted in ahead (warm_heap): on this machine a page
faulted in costs microseconds (a 2 MPx frame touches ~330 MiB: 85,000 faults), and while
Python imports the modules, for ~200 ms, the other cores are idle. The size comes from a
record the previous run left (record_heap)."""
from __future__ import annotations

import os

MAX_PREFAULT = 1 << 30         # bytes; and at most a quarter of the memory available
_state: dict = {}


def _libc():
    import ctypes

    libc = ctypes.CDLL("libc.so.6")
    return ctypes, libc


def keep_freed_memory() -> None:
    """glibc hands freed blocks of 32 MB and more back to the system, so every frame's
    arrays fault in fresh zeroed pages; a process that runs many frames keeps them for the
    next one (A/B of two servers at 2 MPx: median 410 -> 381 ms a frame). What the largest
    frame needed stays with the process until it ends."""
    try:
        _, libc = _libc()
        libc.mallopt(-3, 1 << 30)          # M_MMAP_THRESHOLD: blocks below 1 GiB from the heap
        libc.mallopt(-1, (1 << 31) - 1)    # M_TRIM_THRESHOLD: keep up to 2 GiB of freed heap
    except (OSError, AttributeError):      # not glibc: nothing to tune
        pass


def record_path() -> str:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "fogcli", "heap")


def warm_heap() -> None:
    """keep_freed_memory, then the recorded heap allocated here (the main thread: glibc's
    main heap, which numpy's arrays and PoCL's buffers come from) and touched by a thread
    of its own (join_warm frees it): the first frame reuses its pages instead of faulting
    them in. FOGCLI_PREFAULT=0 turns both off."""
    if os.environ.get("FOGCLI_PREFAULT") == "0":
        return
    keep_freed_memory()           # also on a first run: the heap then holds what it needed
    try:
        with open(record_path()) as f:
            want = int(f.read(32).split()[0])
        ctypes, libc = _libc()
        avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError, AttributeError):
        return
    n = min(want, MAX_PREFAULT, avail // 4)
    if n < (16 << 20):
        return
    import threading

    libc.malloc.restype, libc.malloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    libc.memset.restype, libc.memset.argtypes = ctypes.c_void_p, [ctypes.c_void_p, ctypes.c_int, ctypes.c_size_t]
    p = libc.malloc(n)
    if not p:
        return
    # ctypes releases the GIL for the call: the imports go on beside it
    th = threading.Thread(target=libc.memset, args=(p, 0, n), name="fogcli-prefault", daemon=True)
    th.start()
    _state.update(thread=th, block=p, free=libc.free)


def join_warm(timeout: float = 2.0) -> None:
    """Free the prefaulted block before the frame allocates: its arrays and buffers then
    come out of those pages (freed while the imports still held it, the heap would grow
    past it instead). The rest of the touching is waited for: it is faults the frame would
    take itself."""
    th = _state.pop("thread", None)
    if th is not None:
        th.join(timeout)
        if not th.is_alive():
            _state.pop("free")(_state.pop("block"))


def _in_use() -> int:
    """Bytes malloc has handed out and not had back (glibc's mallinfo2): the frame's
    arrays and PoCL's buffers."""
    fn = _state.get("mallinfo2")
    if fn is None:
        ctypes, libc = _libc()

        class MallInfo2(ctypes.Structure):
            _fields_ = [(name, ctypes.c_size_t) for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd",
                                                             "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]

        fn = _state["mallinfo2"] = libc.mallinfo2
        fn.restype = MallInfo2
    m = fn()
    return int(m.uordblks + m.hblkhd)


def note_in_use() -> None:
    """Called where a frame holds the most (its arrays, the output, the device buffers):
    the largest such figure is what record_heap leaves for the next run."""
    if "thread" in _state or os.environ.get("FOGCLI_PREFAULT") == "0":
        return        # the prefaulted block still counts as in use
    try:
        _state["peak"] = max(_state.get("peak", 0), _in_use())
    except (OSError, AttributeError):
        pass


def record_heap() -> None:
    """What this run's frames held at most, for the next run's warm_heap."""
    peak = _state.get("peak", 0)
    if not peak:
        return
    path = record_path()
    tmp = f"{path}.{os.getpid()}"
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(tmp, "w") as f:
            f.write(f"{int(1.1 * peak)}\n")
        os.replace(tmp, path)
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
