"""The ``hdrfringe`` command line: one thin module per command, each calling the library.

Every command validates its input fully before writing anything; any
:class:`~hdrfringe.errors.HdrFringeError` is printed as one line on stderr with exit code 2, and
no partial output is left behind (outputs are staged and moved into place when complete).

A command's module is imported when the command runs (``cli._app.COMMAND_MODULES``), so that
``hdrfringe phase`` does not pay for the modules (and their imports) of the other commands.

Another installed package adds commands through the entry-point group :data:`PLUGIN_GROUP`
(``hdrfringe.commands``; the research package's ``reproduce``): the entry point names a typer
command function, run under the same error handling; it prints with :data:`console`.
"""

from __future__ import annotations

import os
import sys


def _prepare_process() -> None:
    """Make the process's streams and libraries safe for any environment; call it first.

    - A closed standard output or error (``sys.stdout`` is None) is replaced by ``/dev/null``:
      what the command would print is dropped, its work and exit code stay.
    - Text that the streams' encoding cannot show (a non-ASCII path under
      ``PYTHONIOENCODING=ascii``) is written with backslash escapes, not refused.
    - Under an address-space limit (``ulimit -v``, RLIMIT_AS) OpenBLAS runs one thread unless
      ``OPENBLAS_NUM_THREADS`` is set: the thread server of the OpenBLAS that OpenCV bundles
      dereferences the NULL of a failed buffer allocation (SIGSEGV when ``measure`` imports
      OpenCV under ``ulimit -v 460000``), and each thread's buffer costs address space. The C
      library is also asked for at most two malloc arenas (each thread's arena reserves 64 MiB
      of address space on glibc).

    Examples
    --------
    >>> _prepare_process()
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
        import contextlib
        import ctypes

        with contextlib.suppress(OSError, AttributeError):  # glibc only: M_ARENA_MAX = -8
            ctypes.CDLL(None).mallopt(-8, 2)


_prepare_process()  # before numpy and OpenCV load (their BLAS reads its thread count once)

from hdrfringe.cli._app import PLUGIN_GROUP, app, console  # noqa: E402

__all__ = ["PLUGIN_GROUP", "app", "console"]
