"""One exception hierarchy for the whole package.

Every message says what is wrong, where, and how to fix it, on one line. The command-line
interface prints the message of any :class:`HdrFringeError` and exits with status 2.
"""

from __future__ import annotations

__all__ = ["CaptureFormatError", "HdrFringeError", "InputError", "OutputExistsError"]


class HdrFringeError(Exception):
    """Base class of every error hdrfringe raises on purpose.

    Catching it catches every deliberate hdrfringe error and nothing else (a bug shows as
    another exception type). The single argument is the message, one line: what is wrong,
    where, and how to fix it.

    Examples
    --------
    >>> try:
    ...     raise CaptureFormatError("captures/manifest.json: missing; write the manifest")
    ... except HdrFringeError as err:
    ...     print(type(err).__name__, "-", err)
    CaptureFormatError - captures/manifest.json: missing; write the manifest
    """


class InputError(HdrFringeError, ValueError):
    """An argument or an array given to a function is unusable.

    Also a :class:`ValueError`, so callers that catch ``ValueError`` keep working.

    Examples
    --------
    >>> from hdrfringe._validation import check_bit_depth
    >>> try:
    ...     check_bit_depth(20)
    ... except InputError as err:
    ...     print(err)
    camera bit depth must be an integer 1..16, got 20
    >>> issubclass(InputError, ValueError)
    True
    """


class CaptureFormatError(HdrFringeError):
    """A capture folder breaks the capture-folder contract (manifest, files, values).

    Examples
    --------
    >>> err = CaptureFormatError("run1/manifest.json: no 'frames' list; add one")
    >>> isinstance(err, HdrFringeError), str(err)
    (True, "run1/manifest.json: no 'frames' list; add one")
    """


class OutputExistsError(HdrFringeError):
    """An output would overwrite something already on disk and ``--force`` was not given.

    Examples
    --------
    >>> err = OutputExistsError("out/height.tiff exists; pass --force to overwrite it")
    >>> isinstance(err, HdrFringeError), isinstance(err, ValueError)
    (True, False)
    """
