"""fogcli: physically based participating media for images with depth.

The Python API is :func:`apply` with the helpers :func:`read_image`, :func:`read_depth`,
:func:`read_camera`, :func:`make_config` and :func:`write_image`; the command line
(``fogcli``) is a thin layer over the same code.
"""
from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["apply", "make_config", "read_camera", "read_depth", "read_image", "write_image", "UserError",
           "__version__"]


def __getattr__(name):
    # lazy: every command imports this package, and `fogcli --help` must stay light
    if name in __all__:
        from fogcli import api, errors

        return getattr(errors if name == "UserError" else api, name)
    raise AttributeError(f"module 'fogcli' has no attribute {name!r}")
