"""Errors that the command line reports as one line with a fixed exit code."""


class UserError(ValueError):
    """Bad usage, config or input: exit 2, one line, no traceback. A ValueError for the
    Python API."""

    exit_code = 2


class ProcessingError(Exception):
    """The input was fine but processing failed (device, out of memory): exit 1."""

    exit_code = 1
