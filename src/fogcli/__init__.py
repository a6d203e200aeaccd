"""fogcli: physically based participating media for images with depth.

The Python API is :func:`apply`; the command line (``fogcli``) is a thin layer over it.
"""
from __future__ import annotations

__version__ = "0.1.0"

from .api import apply  # noqa: E402

__all__ = ["apply", "__version__"]
