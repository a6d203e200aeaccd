"""The C libraries under OpenImageIO (libpng, libtiff, libjpeg) print their complaints on
stderr themselves (fd 2), beside the one line fogcli reports about the same file."""
from __future__ import annotations

import contextlib
import os
import sys
import tempfile


@contextlib.contextmanager
def quiet_stderr():
    """Catch what they print while a file is decoded or checked."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):      # no fd 2 (embedded): nothing to protect
        yield
        return
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
