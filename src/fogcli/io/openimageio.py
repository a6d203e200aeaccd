"""OpenImageIO, imported at the first file a command reads or writes (`fogcli check` and
`media` never load it). A Ctrl-C that lands while its extension module initialises aborts
the process: SIGABRT from inside the module's init, nothing on stderr (a core's backtrace;
tests/test_one_process.py's Ctrl-C test on `apply` hit it about one run in ten on a 2-core
AMD EPYC family 25 model 17). The interrupt is held until the import is done, as
pyopencl's is (device/runtime.py)."""
from __future__ import annotations

from fogcli.errors import interrupt_held


def load():
    """The OpenImageIO module."""
    with interrupt_held():
        import OpenImageIO

    return OpenImageIO
