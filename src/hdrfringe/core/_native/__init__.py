"""Native kernels: C functions on raw buffers, opened with :mod:`ctypes`.

Each ``<name>.c`` in this folder is compiled by ``setup.py`` into a shared library next to it
(``<name>.cpython-311-x86_64-linux-gnu.so`` and the like). A kernel is an optional accelerator:
:func:`load` returns ``None`` when its library is absent (a source tree that was not built, an
install without a C compiler) or when ``HDRFRINGE_NATIVE=0`` asks for the numpy paths, and every
caller then runs its numpy implementation, which gives the same results (tests compare both).
:mod:`ctypes` releases the GIL for the duration of each call, so a kernel called from a thread
pool runs on several cores.
"""

from __future__ import annotations

import ctypes
import os
import sysconfig
from functools import cache
from pathlib import Path

__all__ = ["library_path", "load", "native_enabled"]

_HERE = Path(__file__).resolve().parent


def native_enabled() -> bool:
    """Whether native kernels may be used (``HDRFRINGE_NATIVE`` is not ``0``).

    Returns
    -------
    bool
        ``False`` when the environment variable ``HDRFRINGE_NATIVE`` is ``"0"``.

    Examples
    --------
    >>> isinstance(native_enabled(), bool)
    True
    """
    return os.environ.get("HDRFRINGE_NATIVE", "1") != "0"


def library_path(name: str) -> Path:
    """Path of the compiled library of kernel ``name`` (which may not exist).

    Parameters
    ----------
    name : str
        Stem of the C source in this folder, e.g. ``"decode"``.

    Returns
    -------
    pathlib.Path
        ``<this folder>/<name><EXT_SUFFIX>``.

    Examples
    --------
    >>> library_path("decode").name.startswith("decode")
    True
    """
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    return _HERE / f"{name}{suffix}"


@cache
def _open(name: str) -> ctypes.CDLL | None:
    path = library_path(name)
    if not path.is_file():
        return None
    try:
        return ctypes.CDLL(str(path))
    except OSError:
        return None


def load(name: str) -> ctypes.CDLL | None:
    """Open the compiled kernel library ``name``, or ``None`` to use the numpy path.

    Parameters
    ----------
    name : str
        Stem of the C source in this folder.

    Returns
    -------
    ctypes.CDLL or None
        The library (opened once per process), or ``None`` when it was not built, cannot be
        loaded, or ``HDRFRINGE_NATIVE=0`` is set.

    Examples
    --------
    >>> load("no-such-kernel") is None
    True
    """
    if not native_enabled():
        return None
    return _open(name)
