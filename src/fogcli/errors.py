"""Errors that the command line reports as one line with a fixed exit code, and Ctrl-C held
where Python cannot take it cleanly."""
from __future__ import annotations

import contextlib
import signal
import threading


class UserError(ValueError):
    """Bad usage, config or input: exit 2, one line, no traceback. A ValueError for the
    Python API."""

    exit_code = 2


class ProcessingError(Exception):
    """The input was fine but processing failed (device, out of memory): exit 1."""

    exit_code = 1


@contextlib.contextmanager
def interrupt_held():
    """A Ctrl-C that lands inside the block is raised as KeyboardInterrupt after it. For code
    where it cannot be taken: an extension's import (pyopencl's aborts the process), or an
    object's __del__ (numpy's NpzFile: Python prints the interrupt as 'Exception ignored' and
    drops it, so the command would go on). Where SIGINT is not Python's own (a worker that
    ignores it, another thread), nothing changes."""
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield
        return
    held: list = []
    old = signal.signal(signal.SIGINT, lambda *a: held.append(a))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
    if held:
        raise KeyboardInterrupt
