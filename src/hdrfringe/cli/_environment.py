"""The process the command line runs in: odd environments made ordinary (issue 31).

A command must answer in one line whatever its environment: standard output or error closed
(``>&-``: Python then has no ``sys.stdout``), an encoding that cannot show a path
(``PYTHONIOENCODING=ascii`` and an output named ``résultat``), ``COLUMNS=0`` (rich would print
the error line in zero columns, i.e. not at all), a memory limit (``ulimit -v``) under which the
BLAS threads OpenCV starts crash the process, a deleted working directory. See docs/safety.md,
"Fault policy".
"""

from __future__ import annotations

import os
import sys

__all__ = [
    "MIN_ADDRESS_SPACE_MIB",
    "columns",
    "memory_limit_problem",
    "prepare_process",
    "working_directory_problem",
]

#: The smallest address-space limit (``ulimit -v``, MiB) under which a command is started: below
#: it loading numpy, OpenCV and HDF5 fails (their libraries cannot be mapped, or OpenBLAS, out of
#: memory for its buffer, ends the process itself), so the command refuses in one line first.
#: tests/test_fault_policy.py runs ``measure`` at this limit.
MIN_ADDRESS_SPACE_MIB = 400


def columns() -> int | None:
    """``COLUMNS`` when it is a usable width (a positive integer), else None.

    Returns
    -------
    int or None

    Examples
    --------
    >>> old = os.environ.get("COLUMNS")
    >>> os.environ["COLUMNS"] = "0"
    >>> columns() is None
    True
    >>> os.environ["COLUMNS"] = "120"
    >>> columns()
    120
    >>> _ = os.environ.pop("COLUMNS") if old is None else os.environ.update(COLUMNS=old)
    """
    value = os.environ.get("COLUMNS", "").strip()
    return int(value) if value.isdigit() and int(value) > 0 else None


def prepare_process() -> None:
    """Make the process's streams and libraries safe for any environment; call it first.

    - A closed standard output or error (``sys.stdout`` is None) is replaced by ``/dev/null``:
      what the command would print is dropped, its work and exit code stay.
    - Text that the streams' encoding cannot show (a non-ASCII path under
      ``PYTHONIOENCODING=ascii``) is written with backslash escapes, not refused.
    - Under an address-space limit (``ulimit -v``, RLIMIT_AS) OpenBLAS runs one thread unless
      ``OPENBLAS_NUM_THREADS`` is set: the thread server of the OpenBLAS that OpenCV bundles
      dereferences the NULL of a failed buffer allocation (SIGSEGV when ``measure`` imports
      OpenCV under ``ulimit -v 460000``), and each thread's buffer costs address space.

    Examples
    --------
    >>> prepare_process()
    >>> sys.stdout is not None
    True
    """
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if stream is None:
            setattr(sys, name, open(os.devnull, "w", encoding="utf-8"))
        elif hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(errors="backslashreplace")
            except (ValueError, OSError):  # pragma: no cover - a detached or exotic stream
                pass
    import resource

    if resource.getrlimit(resource.RLIMIT_AS)[0] != resource.RLIM_INFINITY:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def working_directory_problem() -> str | None:
    """The one-line error for a working directory that no longer exists, else None.

    Relative paths cannot be resolved there (``os.getcwd`` fails), so a command refuses to
    start instead of failing half-way with a traceback.

    Returns
    -------
    str or None

    Examples
    --------
    >>> working_directory_problem() is None
    True
    """
    try:
        os.getcwd()
    except FileNotFoundError:
        pwd = os.environ.get("PWD", "the working directory")
        return (
            f"{pwd}: the working directory no longer exists (it was deleted or moved); cd to "
            "an existing folder and run the command again"
        )
    return None


def memory_limit_problem() -> str | None:
    """The one-line error for an address-space limit too small to start a command, else None.

    Under a limit (``ulimit -v``) the BLAS buffer is also taken now, while the process is
    small: OpenBLAS allocates it at its first use and ends the process (exit 1, no message of
    ours) when that fails, which a later, larger moment of the command would risk.

    Returns
    -------
    str or None

    Examples
    --------
    >>> memory_limit_problem() is None  # no limit, or a large one
    True
    """
    import resource

    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    if soft == resource.RLIM_INFINITY:
        return None
    if soft < MIN_ADDRESS_SPACE_MIB * 2**20:
        return (
            f"the address-space limit (ulimit -v) is {soft / 2**20:.0f} MiB, below the "
            f"{MIN_ADDRESS_SPACE_MIB} MiB hdrfringe needs to load numpy, OpenCV and HDF5; "
            "raise the limit"
        )
    import numpy as np

    np.dot(np.ones((256, 256)), np.ones((256, 256)))  # takes OpenBLAS's buffer now
    return None
