"""One exception hierarchy for the whole package.

Every message says what is wrong, where, and how to fix it, on one line. The command-line
interface prints the message of any :class:`HdrFringeError` and exits with status 2.
"""

from __future__ import annotations


class HdrFringeError(Exception):
    """Base class of every error hdrfringe raises on purpose."""


class InputError(HdrFringeError, ValueError):
    """An argument or an array given to a function is unusable."""


class CaptureFormatError(HdrFringeError):
    """A capture folder breaks the capture-folder contract (manifest, files, values)."""


class OutputExistsError(HdrFringeError):
    """An output would overwrite something already on disk and ``--force`` was not given."""
