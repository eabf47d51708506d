"""HDF5 files written so that a failing disk or a signal cannot crash or fool the process.

HDF5's own file driver does not survive a failing write: with the file size limit reached
(``ulimit -f``, EFBIG) or a full disk, ``calibrate`` died with SIGSEGV (once SIGBUS) while h5py
closed the half-written file, and a ``SystemExit`` raised by SIGTERM inside h5py's callbacks
was reported as "ignored" and lost (issue 31). So the file is built in memory (HDF5's ``core``
driver without a backing store: no file I/O in C at all), closed, and its bytes are then
written by Python into the staged temporary file (:func:`hdrfringe.io.results.
staged_output_file`), where a full disk is an ordinary ``OSError``; SIGINT, SIGTERM and SIGHUP
are held back for the whole save and honoured after it (:func:`hdrfringe.io.results.
deferred_signals`), the temporary file removed. The price is memory for the file's bytes,
twice for an instant (HDF5's image and its copy), on top of the arrays being saved.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from hdrfringe.errors import ResourceError

__all__ = ["hdf5_memory_fault", "save_hdf5"]


def hdf5_memory_fault(exc: BaseException, path: str | Path) -> ResourceError | None:
    """The one-line error for an HDF5 read that failed for want of memory, else None.

    h5py turns every HDF5 failure into an ``OSError``; one that says HDF5 could not allocate
    is memory, not a damaged file. A decompression filter's failure is memory or damage: under
    an address-space limit (``ulimit -v``) the message names both, the limit first (issue 31:
    ``measure`` under ``ulimit -v 500000`` called a sound calibration "damaged").

    Parameters
    ----------
    exc : BaseException
        What reading raised.
    path : str or Path
        The file read.

    Returns
    -------
    ResourceError or None

    Examples
    --------
    >>> err = hdf5_memory_fault(OSError("Can't read data (unable to allocate memory)"), "c.h5")
    >>> print(err)  # doctest: +ELLIPSIS
    c.h5: out of memory while reading it (...); free memory, raise the limit or ...
    >>> hdf5_memory_fault(OSError("bad symbol table"), "c.h5") is None
    True
    """
    import resource

    from hdrfringe.errors import memory_note

    if isinstance(exc, MemoryError) or (isinstance(exc, OSError) and "allocate" in str(exc)):
        return ResourceError(
            f"{path}: out of memory while reading it ({memory_note()}); free memory, raise the "
            "limit or use a smaller calibration"
        )
    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    if isinstance(exc, OSError) and "filter returned failure" in str(exc):
        if soft != resource.RLIM_INFINITY:
            reason = str(exc).splitlines()[0]
            return ResourceError(
                f"{path}: cannot decompress it ({reason}) under the address-space limit of "
                f"{soft / 2**20:.0f} MiB (ulimit -v): raise the limit; if it still fails the "
                "file is damaged, recalibrate"
            )
    return None


def _image(fill: Callable[[Any], None]) -> bytes:
    """The bytes of an HDF5 file that ``fill`` wrote, built in memory and closed."""
    import h5py

    # the name only labels the in-memory file: nothing is opened or created under it
    f = h5py.File("in-memory.h5", "w", driver="core", backing_store=False, track_order=True)
    try:
        fill(f)
        f.flush()
        return bytes(f.id.get_file_image())
    except OSError as exc:  # HDF5 says "unable to allocate memory block": a MemoryError
        if "allocate" in str(exc):
            raise MemoryError(str(exc).splitlines()[0]) from None
        raise
    finally:
        f.close()


def save_hdf5(path: str | Path, fill: Callable[[Any], None], force: bool = False) -> Path:
    """Write an HDF5 file atomically: ``fill(file)`` writes its contents.

    Parameters
    ----------
    path : str, Path or CheckedOutput
        The file to write (:func:`~hdrfringe.io.results.staged_output_file`).
    fill : callable
        Called with the open, empty :class:`h5py.File`; writes groups, datasets, attributes.
    force : bool
        Replace an existing file.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ResourceError
        The disk, the file size limit or a quota refused the write, or memory ran out; nothing
        is left behind.
    KeyboardInterrupt, SystemExit
        SIGINT (130), SIGTERM (143) or SIGHUP (129) received during the save: the temporary
        file is removed and the signal honoured after the HDF5 file was closed.

    Examples
    --------
    >>> import tempfile, h5py
    >>> out = Path(tempfile.mkdtemp()) / "x.h5"
    >>> _ = save_hdf5(out, lambda f: f.create_dataset("a", data=[1.0, 2.0]))
    >>> with h5py.File(out) as f:
    ...     f["a"][()].tolist()
    [1.0, 2.0]
    """
    from hdrfringe.errors import environment_fault
    from hdrfringe.io.results import deferred_signals, honour_signal, staged_output_file

    # the staging first, the deferral inside it: the staging's own handlers (which raise at
    # once) would otherwise replace the deferral's for the whole save
    with staged_output_file(path, force=force) as tmp, deferred_signals() as stopped:
        try:
            image = _image(fill)
        except MemoryError as exc:  # one line naming the file (docs/safety.md)
            raise (environment_fault(exc, path) or exc) from None
        honour_signal(stopped())  # before writing; the staging file is then removed
        with open(tmp, "wb") as fh:
            fh.write(image)
        del image
    return Path(path)
