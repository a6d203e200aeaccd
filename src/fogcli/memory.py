"""Host memory of a fogcli process (glibc; elsewhere nothing here does anything).

A process that runs many frames (`fogcli serve`) keeps the pages of one frame for the next
(keep_freed_memory). `fogcli apply` in a process of its own also has the heap its previous
run held faulted in ahead (warm_heap): on these machines a page faulted in costs
microseconds (a 2 MPx frame touches ~330 MiB: 85,000 faults), and while Python imports the
modules, for ~200 ms, the other cores are idle. The size comes from a record the previous
run left (record_heap). A batch gains nothing from it (its frames are read and written on
threads, whose memory comes from other arenas) and does not use it."""
from __future__ import annotations

import os
import threading

# bytes, below M_MMAP_THRESHOLD (a block of that size would be mapped and unmapped, not kept),
# and at most a quarter of the memory available
MAX_PREFAULT = (1 << 30) - (16 << 20)
_state: dict = {}
_lock = threading.Lock()


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
    from .launch import cache_dir

    return os.path.join(cache_dir(), "heap")


def available_bytes() -> int:
    """Memory this process may still take: MemAvailable, and below a cgroup's (v2) limit."""
    with open("/proc/meminfo") as f:
        avail = next(int(ln.split()[1]) * 1024 for ln in f if ln.startswith("MemAvailable:"))
    try:
        with open("/sys/fs/cgroup/memory.max") as f:
            top = f.read().strip()
        if top != "max":
            with open("/sys/fs/cgroup/memory.current") as f:
                avail = min(avail, int(top) - int(f.read()))
    except (OSError, ValueError):
        pass
    return avail


def _mallinfo2(ctypes, libc):
    class MallInfo2(ctypes.Structure):
        _fields_ = [(name, ctypes.c_size_t) for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd",
                                                         "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]

    fn = libc.mallinfo2
    fn.restype = MallInfo2          # before anyone may call it: a c_int return would be a wrong call
    return fn


def warm_heap() -> None:
    """keep_freed_memory, then the recorded heap allocated here (the main thread: glibc's
    main heap, which numpy's arrays and PoCL's buffers come from) and touched by a thread
    of its own (join_warm frees it): the frame reuses its pages instead of faulting them
    in. Also turns on the count that record_heap leaves. FOGCLI_PREFAULT=0: none of it."""
    if os.environ.get("FOGCLI_PREFAULT") == "0" or "mallinfo2" in _state:
        return
    try:
        ctypes, libc = _libc()
        _state["mallinfo2"] = _mallinfo2(ctypes, libc)
    except (OSError, AttributeError):      # not glibc, or older than 2.33
        return
    keep_freed_memory()           # also on a first run: the heap then holds what it needed
    try:
        with open(record_path()) as f:
            want = int(f.read(32).split()[0])
        n = min(want, MAX_PREFAULT, available_bytes() // 4)
    except (OSError, ValueError, IndexError, StopIteration):
        return
    if n < (16 << 20):
        return
    libc.malloc.restype, libc.malloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    libc.memset.restype, libc.memset.argtypes = ctypes.c_void_p, [ctypes.c_void_p, ctypes.c_int, ctypes.c_size_t]
    p = libc.malloc(n)
    if not p:
        return
    # ctypes releases the GIL for the call: the imports go on beside it
    th = threading.Thread(target=libc.memset, args=(p, 0, n), name="fogcli-prefault", daemon=True)
    try:
        th.start()
    except RuntimeError:           # no thread to be had (a process limit): go without
        libc.free(p)
        return
    _state.update(thread=th, block=p, free=libc.free)


def join_warm(timeout: float = 2.0) -> None:
    """Free the prefaulted block before the frame allocates: its arrays and buffers then
    come out of those pages (freed while the imports still held it, the heap would grow
    past it instead). The rest of the touching is waited for: it is faults the frame would
    take itself. After the timeout the block stays the thread's (and this run records
    nothing: the block would count as the frame's)."""
    th = _state.get("thread")
    if th is None:
        return
    th.join(timeout)
    if not th.is_alive():
        _state.pop("thread")
        _state.pop("free")(_state.pop("block"))


def note_in_use() -> None:
    """Called where a frame holds the most (its arrays, the output, the device buffers):
    the largest figure is what record_heap leaves for the next run. Only counts in a
    process that warm_heap set up (`fogcli apply` by itself, and a server that it started
    until its first command is done; not workers or the API)."""
    fn = _state.get("mallinfo2")
    if fn is None or "thread" in _state:
        return
    m = fn()
    with _lock:
        _state["peak"] = max(_state.get("peak", 0), int(m.uordblks + m.hblkhd))


def forget() -> None:
    """No more counting, and nothing left to record (a server after its first command: what
    it keeps of earlier frame sizes is not what a frame needs)."""
    with _lock:
        _state.pop("mallinfo2", None)
        _state.pop("peak", None)


def record_heap() -> None:
    """What this run held at most (the frame's memory and the process's own), for the next
    run's warm_heap."""
    peak = _state.get("peak", 0)
    if not peak or "thread" in _state:
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
