"""One exception hierarchy for the whole package.

Every message says what is wrong, where, and how to fix it, on one line. The command-line
interface prints the message of any :class:`HdrFringeError` and exits with status 2.
"""

from __future__ import annotations

import contextlib
import errno as _errno
import os
from collections.abc import Sequence
from pathlib import Path
from typing import ClassVar

__all__ = [
    "FAULT_ERRNOS",
    "CaptureFormatError",
    "HdrFringeError",
    "InputError",
    "OutputExistsError",
    "ResourceError",
    "StoppedError",
    "environment_fault",
    "memory_note",
]


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
    >>> from hdrfringe.core._validation import check_bit_depth
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

    A check that collects several problems of one folder (the manifest's fields, its files, its
    sets) raises one error carrying them all in :attr:`problems`; its message, still one line,
    is the first problem in full followed by the others in short (:meth:`from_problems`).

    Parameters
    ----------
    message : str
        One line: what, where, how to fix it.
    problems : sequence of str, optional
        Every problem found, each a one-line message; default: the message alone.

    Attributes
    ----------
    problems : tuple of str
        Every problem found, in the order checked.

    Examples
    --------
    >>> err = CaptureFormatError("run1/manifest.json: no 'frames' list; add one")
    >>> isinstance(err, HdrFringeError), str(err), len(err.problems)
    (True, "run1/manifest.json: no 'frames' list; add one", 1)
    """

    #: Problems listed in the one-line message before "... N more" (all are in ``problems``).
    MAX_LISTED: ClassVar[int] = 8

    def __init__(self, message: str = "", *, problems: Sequence[str] = ()) -> None:
        super().__init__(message)
        self.problems: tuple[str, ...] = tuple(problems) if problems else (message,)

    @classmethod
    def from_problems(cls, problems: Sequence[str]) -> CaptureFormatError:
        """One error for several problems: the first in full, the rest in short.

        The others are shortened to ``where: what`` (their ``; how to fix`` part dropped, as the
        first shows the kind of fix) and problems with the same ``what`` are listed once with
        their places, so a manifest with one mistake repeated in 200 frames stays one short
        line; at most :attr:`MAX_LISTED` are listed, then the count of the rest.

        Parameters
        ----------
        problems : sequence of str
            One-line messages ``where: what; fix``, at least one.

        Returns
        -------
        CaptureFormatError
            With :attr:`problems` holding them all.

        Examples
        --------
        >>> err = CaptureFormatError.from_problems([
        ...     "frame 0 (a.png): no 'pitch'; add it",
        ...     "frame 1 (b.png): no 'pitch'; add it",
        ...     "frame 2 (c.png): no 'pitch'; add it",
        ...     "frame 4 (e.png): kind 'x'; use fringe"])
        >>> print(err)  # doctest: +NORMALIZE_WHITESPACE
        frame 0 (a.png): no 'pitch'; add it (and 3 more: frame 1 (b.png), frame 2 (c.png): no
        'pitch'; frame 4 (e.png): kind 'x')
        >>> len(err.problems)
        4
        """
        if not problems:
            raise ValueError("from_problems needs at least one problem")
        first, rest = problems[0], list(problems[1:])
        if not rest:
            return cls(first)
        groups: dict[str, list[str]] = {}
        for p in rest:
            short = p.rsplit("; ", 1)[0] if "; " in p else p
            where, sep, what = short.partition(": ")
            if not sep:
                where, what = "", short
            groups.setdefault(what, []).append(where)
        items = []
        for what, places in list(groups.items())[: cls.MAX_LISTED]:
            shown = ", ".join(w for w in places[:3] if w)
            extra = f" and {len(places) - 3} more" if len(places) > 3 else ""
            items.append(f"{shown}{extra}: {what}" if shown else what)
        if len(groups) > cls.MAX_LISTED:
            hidden = sum(len(v) for v in list(groups.values())[cls.MAX_LISTED :])
            items.append(f"... {hidden} more")
        return cls(f"{first} (and {len(rest)} more: {'; '.join(items)})", problems=problems)


class OutputExistsError(HdrFringeError):
    """An output would overwrite something already on disk and ``--force`` was not given.

    Examples
    --------
    >>> err = OutputExistsError("out/height.tiff exists; pass --force to overwrite it")
    >>> isinstance(err, HdrFringeError), isinstance(err, ValueError)
    (True, False)
    """


class ResourceError(HdrFringeError):
    """The environment refused what a command needed: disk space, the file size limit, a disk
    quota, a name length, a permission or memory (the fault policy of ``docs/safety.md``).

    Not a fault of the input nor a bug: the message names what was refused, where (the output
    or input path) and the errno, and the command line exits with status 2.

    Parameters
    ----------
    message : str
        One line: what, which path, the errno, what to do.
    errno : int or None
        The refused operation's errno (``errno.ENOSPC``, ...); None for memory.

    Attributes
    ----------
    errno : int or None
        As given.

    Examples
    --------
    >>> import errno
    >>> err = ResourceError("out: cannot write: No space left on device (ENOSPC)", errno.ENOSPC)
    >>> isinstance(err, HdrFringeError), err.errno == errno.ENOSPC
    (True, True)
    """

    def __init__(self, message: str = "", errno: int | None = None) -> None:
        super().__init__(message)
        self.errno = errno


class StoppedError(HdrFringeError):
    """A command stopped by a signal after keeping what was complete (a live capture's sets).

    The message says what was kept; the command line prints it in one line and exits with
    :attr:`exit_code`, the shell's code of the signal (130 SIGINT, 143 SIGTERM, 129 SIGHUP),
    so a supervisor that sent SIGTERM sees it honoured.

    Parameters
    ----------
    message : str
        One line: what stopped it and what was kept.
    exit_code : int
        The exit status the command line gives (128 + the signal's number).

    Examples
    --------
    >>> StoppedError("capture stopped by SIGTERM after 3 sets", 143).exit_code
    143
    """

    def __init__(self, message: str = "", exit_code: int = 2) -> None:
        super().__init__(message)
        self.exit_code = exit_code


FAULT_ERRNOS: dict[int, str] = {
    _errno.ENOSPC: "free space on that disk or write elsewhere",
    _errno.EFBIG: "the file size limit (ulimit -f) or the file system's largest file is "
    "exceeded; raise the limit or write elsewhere",
    _errno.EDQUOT: "free space in your disk quota or write elsewhere",
    _errno.ENAMETOOLONG: "use a shorter name",
    _errno.EACCES: "choose a path you may write",
    _errno.EROFS: "the file system is read-only; write elsewhere",
}
"""The errnos that are the user's environment, not a bug, and what to do about each: a write
refused with one of them ends in one line naming the path and the errno (exit code 2)."""


def _short_write_errno(where: Path) -> int | None:
    """The errno behind a write that stopped short without one (numpy's ``tofile`` says only
    "N requested and M written"): EFBIG if a file under ``where`` has reached the file size
    limit, ENOSPC if the disk has (almost) no space left, else None."""
    import resource

    soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    with contextlib.suppress(OSError):
        if soft != resource.RLIM_INFINITY:
            files = [where] if where.is_file() else [p for p in where.rglob("*") if p.is_file()]
            if any(p.stat().st_size >= soft - 65536 for p in files):
                return _errno.EFBIG
        st = os.statvfs(where if where.exists() else where.parent)
        if st.f_bavail * st.f_frsize < 1 << 20:
            return _errno.ENOSPC
    return None


def environment_fault(
    exc: BaseException, path: str | Path, action: str = "write", where: Path | None = None
) -> ResourceError | None:
    """The one-line error for ``exc`` if the user's environment refused the operation.

    An :class:`OSError` with one of :data:`FAULT_ERRNOS` (a full disk, the file size limit, a
    quota, a name too long, a permission, a read-only file system), or a write that stopped
    short without an errno (diagnosed from ``where``: the file size limit or a full disk), and
    a :class:`MemoryError` become a :class:`~hdrfringe.errors.ResourceError` naming ``path``
    and the errno; anything else gives None (a bug or an input fault, handled elsewhere).

    Parameters
    ----------
    exc : BaseException
        What was raised.
    path : str or Path
        The path the user named (the output, not its hidden staging name).
    action : str
        What was being done to ``path``: "write", "read", ...
    where : Path, optional
        The staging file or folder written when ``exc`` was raised (for a short write).

    Returns
    -------
    ResourceError or None

    Examples
    --------
    >>> err = environment_fault(OSError(_errno.ENOSPC, "No space left on device"), "out")
    >>> print(err)  # doctest: +NORMALIZE_WHITESPACE
    out: cannot write: No space left on device (errno ENOSPC); free space on that disk or
    write elsewhere
    >>> print(environment_fault(PermissionError(_errno.EACCES, "Permission denied"), "out"))
    out: cannot write: Permission denied (errno EACCES); choose a path you may write
    >>> print(environment_fault(PermissionError(_errno.EACCES, "Permission denied"), "c.h5",
    ...                         "read"))
    c.h5: cannot read: Permission denied (errno EACCES); give a path you may read, or change
    its permissions
    >>> environment_fault(ValueError("x"), "out") is None
    True
    """
    if isinstance(exc, MemoryError):
        return ResourceError(
            f"{path}: out of memory while making it ({memory_note()}); free memory, raise the "
            "limit or use smaller images"
        )
    if not isinstance(exc, OSError):
        return None
    code = exc.errno
    if code is None and where is not None and "written" in str(exc):
        code = _short_write_errno(where)
    if code not in FAULT_ERRNOS:
        return None
    reason = os.strerror(code) if exc.errno is None else (exc.strerror or os.strerror(code))
    fix = FAULT_ERRNOS[code]
    if code == _errno.EACCES and action != "write":  # a permission refused to read, not write
        fix = f"give a path you may {action}, or change its permissions"
    return ResourceError(
        f"{path}: cannot {action}: {reason} (errno {_errno.errorcode[code]}); {fix}", code
    )


def memory_note() -> str:
    """The memory limit in force, as a note for a MemoryError's message.

    Returns
    -------
    str
        ``"MemoryError"``, with the address-space limit (``ulimit -v``) when one is set.

    Examples
    --------
    >>> memory_note().startswith("MemoryError")
    True
    """
    import resource

    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    if soft == resource.RLIM_INFINITY:
        return "MemoryError"
    return f"MemoryError; address-space limit {soft / 2**20:.0f} MiB, ulimit -v"
