"""Result folders and map files: staged writing, float32 TIFF maps, PNG previews.

Outputs are written into a hidden staging folder beside the target and moved into place only
when complete, so a failure never leaves a half-written result. The guarantees (see
``docs/safety.md``):

- an output that is, contains or lies inside an input is refused before any work
  (:func:`check_output_against_inputs`);
- the target is checked before the work (exists, writable) and its identity recorded in the
  :class:`CheckedOutput` the check returns (no state is kept in this module): pass that object
  on to the writer. The final move never replaces anything but what was checked: without
  ``force`` it fails if the target appeared meanwhile, with ``force`` it replaces only the same
  folder or file (device and inode) that was checked;
- SIGTERM (SIGHUP) while staging removes the staging folder and exits with code 143 (129); the
  final move and a save in C code (HDF5) hold SIGINT, SIGTERM and SIGHUP back and honour them
  after (:func:`deferred_signals`); a staging folder
  left by a killed run (its name holds a dead process's PID) is removed by the next run on the
  same target, one of a live run makes the next run refuse; the previous output that a killed
  ``force`` replace had moved aside (``.<name>.old-<PID>-*``) is moved back when the target is
  missing, removed when the replace had completed, and reported otherwise;
- a single file (:func:`staged_output_file`) is written to a temporary file beside it and moved
  into place by a rename that cannot replace a file that appeared meanwhile;
- folders and files follow the umask;
- the user's environment refusing a write (full disk, file size limit, quota, name too long,
  permission) ends in one line naming the output and the errno (:class:`ResourceError`, from
  :func:`~hdrfringe.errors.environment_fault`); a staging name stays short enough for any
  legal output name (:func:`staging_stem`).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator
from glob import escape as glob_escape
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from hdrfringe.errors import (
    InputError,
    OutputExistsError,
    ResourceError,
    environment_fault,
)

__all__ = [
    "OLD_INFIX",
    "SIGHUP_EXIT_CODE",
    "SIGTERM_EXIT_CODE",
    "STAGING_INFIX",
    "CheckedOutput",
    "InterruptedAfterWriting",
    "SignalStop",
    "StoppedAfterWriting",
    "check_name_length",
    "check_output_against_inputs",
    "check_output_dir",
    "check_output_file",
    "check_writable",
    "current_umask",
    "deferred_signals",
    "honour_signal",
    "marked_pid",
    "pid_alive",
    "read_map_tiff",
    "rename_noreplace",
    "signals_as_interrupt",
    "sigterm_cleanup",
    "staged_output_dir",
    "staged_output_file",
    "staging_stem",
    "write_map_tiff",
    "write_preview_png",
]

SIGTERM_EXIT_CODE = 143
"""Exit code of a run stopped by SIGTERM while writing (128 + 15, as a shell reports it)."""

SIGHUP_EXIT_CODE = 129
"""Exit code of a run stopped by SIGHUP (its terminal closed) while writing (128 + 1)."""

#: The signals that stop a run from outside, and the exit code each gives (SIGINT: 130, raised
#: as KeyboardInterrupt). SIGHUP is absent where the system has none.
_STOP_SIGNALS: dict[int, int] = {
    int(getattr(signal, name)): code
    for name, code in (("SIGTERM", SIGTERM_EXIT_CODE), ("SIGHUP", SIGHUP_EXIT_CODE))
    if hasattr(signal, name)
}


STAGING_INFIX = ".staging-"
"""A staging folder of ``out`` is named ``.{out.name}.staging-{PID}-{random}``: the PID of the
writing process marks it, so a later run can tell a killed run's leftovers from a live run."""

OLD_INFIX = ".old-"
"""A ``force`` replace moves the previous output aside as ``.{out.name}.old-{PID}-{random}``
for the instant between its two renames; the PID tells a later run whether the replacing
process is still alive."""

if TYPE_CHECKING:
    _PathBase = Path
else:  # the concrete class (PosixPath or WindowsPath): Path itself cannot be subclassed
    _PathBase = type(Path())  # before Python 3.12


class CheckedOutput(_PathBase):
    """An output path as checked before the work, carrying what was found there.

    Made by :func:`check_output_dir` and :func:`check_output_file`; it is a
    :class:`~pathlib.Path` (of the path given), so it can be passed wherever a path goes, and
    :func:`staged_output_dir` / :func:`staged_output_file` read from it what was checked. The
    check's result lives in this object only: two writers in one process never see each
    other's state, and nothing is left behind in a long-lived session. A path derived from it
    (``out / "x"``, ``Path(out)``) is a plain, unchecked path.

    Parameters
    ----------
    *args : str or path-like
        Path segments, as for :class:`~pathlib.Path`; made so, the object is unchecked: use
        :meth:`record` (or the check functions).
    **kwargs
        As for :class:`~pathlib.Path`.

    Attributes
    ----------
    identity : (int, int) or None
        Device and inode of what was at the path when it was checked; None if nothing was.
    checked : bool
        True for an object made by a check (False for paths derived from it).

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> out = check_output_dir(root / "result", force=False)
    >>> isinstance(out, Path), out.name, out.checked, out.identity
    (True, 'result', True, None)
    >>> (out / "sub").checked
    False
    """

    identity: tuple[int, int] | None = None
    checked: bool = False

    @classmethod
    def record(cls, path: str | os.PathLike[str]) -> CheckedOutput:
        """Check-time record of ``path``: what is there now (device and inode, or nothing).

        Parameters
        ----------
        path : str or path-like
            The output path (kept as given, not resolved).

        Returns
        -------
        CheckedOutput

        Examples
        --------
        >>> import tempfile
        >>> CheckedOutput.record(tempfile.mkdtemp()).identity is not None
        True
        """
        out = cls(os.fspath(path))
        try:
            st = os.lstat(_resolved(out))
            out.identity = (st.st_dev, st.st_ino)
        except FileNotFoundError:
            out.identity = None
        out.checked = True
        return out



#: Compression of the float maps written as TIFF: none. Float phase and quality maps are mostly
#: noise in their low bits, so zlib saves little on them and multiplies the write time: issue 30
#: found most of `phase`'s time at 12 Mpx spent compressing. Readers accept either.
MAP_COMPRESSION: str | None = None


def _resolved(path: str | Path) -> Path:
    return Path(os.path.realpath(os.path.abspath(path)))


def current_umask() -> int:
    """The process's file-mode creation mask, read without changing it where possible.

    Returns
    -------
    int
        The umask, e.g. ``0o022``.

    Examples
    --------
    >>> old = os.umask(0o027)
    >>> oct(current_umask())
    '0o27'
    >>> _ = os.umask(old)
    """
    with contextlib.suppress(OSError, ValueError):
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    mask = os.umask(0o022)  # no /proc: the classic read (briefly sets it, then restores it)
    os.umask(mask)
    return mask


def check_output_against_inputs(output: str | Path, inputs: Iterable[str | Path | None]) -> None:
    """Refuse an output that is, contains or lies inside one of the inputs.

    Paths are resolved (symbolic links, ``..``) before they are compared, so ``-o X/../X`` or a
    link to ``X`` is caught as well. This is the check each command makes before any work, so
    ``--force`` can never replace (delete) the data the command reads.

    Parameters
    ----------
    output : str or Path
        The output folder or file a command is about to write.
    inputs : iterable of str, Path or None
        Every capture folder, calibration file or correction file the command reads (None
        entries are ignored).

    Raises
    ------
    InputError
        If the output and an input overlap; the message names both paths.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> check_output_against_inputs(root / "out", [root / "captures", None])
    >>> check_output_against_inputs(root / "captures" / "sub", [root / "captures"])
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: ...sub: output is inside the input .../captures; ...
    """
    out = _resolved(output)
    for item in inputs:
        if item is None:
            continue
        src = _resolved(item)
        if out == src:
            how = "is the input"
        elif out.is_relative_to(src):
            how = "is inside the input"
        elif src.is_relative_to(out):
            how = "contains the input"
        else:
            continue
        raise InputError(
            f"{output}: output {how} {item}; choose an output path outside every input"
        )


def check_writable(path: str | Path) -> None:
    """Refuse an output path whose folder cannot be written, before any work.

    The nearest existing ancestor of ``path`` must be a folder in which a folder can be created
    (tried for real with a probe that is removed at once, so read-only and immutable folders and
    read-only file systems are caught, also for root). The working directory and its ancestors
    are refused as outputs (they cannot be replaced).

    Parameters
    ----------
    path : str or Path
        The output folder or file.

    Raises
    ------
    OutputExistsError
        If the output is the working directory or an ancestor of it, or the file system root.
    InputError
        If an ancestor is a file, or the folder is not writable.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> check_writable(root / "a" / "b")
    >>> (root / "f").write_text("x")
    1
    >>> check_writable(root / "f" / "out")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: ...out: cannot write there: ...f is a file, not a folder; ...
    """
    out = _resolved(path)
    if out.parent == out:
        raise OutputExistsError(f"{path}: the file system root cannot be an output")
    with contextlib.suppress(OSError):
        if Path.cwd().resolve().is_relative_to(out):
            raise OutputExistsError(
                f"{path}: is the working directory or contains it and cannot be replaced; "
                "give a subfolder or another path"
            )
    parent = out.parent
    while not parent.exists() and parent.parent != parent:
        if parent.is_symlink():  # dangling link: cannot create through it
            break
        parent = parent.parent
    if not parent.is_dir():
        raise InputError(
            f"{path}: cannot write there: {parent} is a file, not a folder; choose another path"
        )
    try:
        probe = tempfile.mkdtemp(prefix=".hdrfringe-probe-", dir=parent)
        os.rmdir(probe)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise InputError(
            f"{path}: cannot write in {parent} ({reason}); choose a writable output path"
        ) from None


def check_name_length(path: str | Path) -> None:
    """Refuse a path with a name longer than its file system allows, before any work.

    Every component is compared with the limit of the nearest existing folder
    (``pathconf NAME_MAX``, 255 bytes where unknown), and the whole path with ``PATH_MAX``.

    Parameters
    ----------
    path : str or Path
        An output path.

    Raises
    ------
    ResourceError
        A name or the path is too long (errno ENAMETOOLONG), in one line naming it.

    Examples
    --------
    >>> check_name_length("out/" + "x" * 255)
    >>> check_name_length("out/" + "x" * 256)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.ResourceError: out/xxx...: the name xxxxxxxx... is 256 bytes, longer ...
    """
    given = Path(path)
    absolute = Path(os.path.abspath(given))
    base = absolute
    while not os.path.isdir(base) and base.parent != base:
        base = base.parent
    name_max, path_max = 255, 4096
    with contextlib.suppress(OSError, ValueError):
        name_max = os.pathconf(base, "PC_NAME_MAX")
        path_max = os.pathconf(base, "PC_PATH_MAX")
    shown = str(given) if len(str(given)) <= 60 else f"{str(given)[:40]}...{str(given)[-12:]}"
    for part in absolute.parts:
        size = len(os.fsencode(part))
        if size > name_max:
            name = part if len(part) <= 20 else f"{part[:8]}...{part[-8:]}"
            raise ResourceError(
                f"{shown}: the name {name} is {size} bytes, longer than the {name_max} the file "
                "system allows (errno ENAMETOOLONG); use a shorter name",
                errno.ENAMETOOLONG,
            )
    size = len(os.fsencode(str(absolute)))
    if size >= path_max:
        raise ResourceError(
            f"{shown}: the path is {size} bytes, longer than the {path_max} the system allows "
            "(errno ENAMETOOLONG); use a shorter path",
            errno.ENAMETOOLONG,
        )


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` is running (one owned by another user counts as running).

    Parameters
    ----------
    pid : int
        Process ID, e.g. read from a staging folder's name by :func:`marked_pid`.

    Returns
    -------
    bool

    Examples
    --------
    >>> pid_alive(os.getpid())
    True
    """
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


#: Longest output name (bytes) whose hidden siblings carry it whole: the staging and backup
#: names add up to 36 bytes (``.``, the infix, a PID, the random part, ``.tmp``) and a name may
#: have 255 (NAME_MAX on Linux and macOS).
_STEM_BYTES = 200


def staging_stem(name: str) -> str:
    """The part of an output's name its staging and backup siblings carry.

    A name of at most 200 bytes is carried whole (``.result.staging-<PID>-<random>``); a longer
    one (still legal: up to 255 bytes) by its first characters and a hash of the whole name,
    so the hidden sibling's name stays within the 255-byte limit and still belongs to this
    output alone.

    Parameters
    ----------
    name : str
        The output's file or folder name.

    Returns
    -------
    str
        ``name``, or a shortening of it of at most 200 bytes.

    Examples
    --------
    >>> staging_stem("result")
    'result'
    >>> long = "x" * 250
    >>> stem = staging_stem(long)
    >>> len(stem.encode()), stem[:4], stem == staging_stem(long)
    (200, 'xxxx', True)
    """
    raw = os.fsencode(name)
    if len(raw) <= _STEM_BYTES:
        return name
    import hashlib

    digest = hashlib.sha256(raw).hexdigest()[:16]
    head = raw[: _STEM_BYTES - len(digest) - 1]
    while head:  # cut at a character boundary of the file-system encoding
        try:
            text = os.fsdecode(head)
            if os.fsencode(text) == head:
                break
        except UnicodeError:
            pass
        head = head[:-1]
    return f"{os.fsdecode(head)}~{digest}"


def marked_pid(entry: Path, out: Path, infix: str) -> int | None:
    """The PID in the name of ``.{out.name}{infix}{PID}-{random}``; None if not named so.

    How a run tells its own or a live run's hidden sibling of ``out`` (a staging folder,
    :data:`STAGING_INFIX`; a store being created) from one a killed run left behind
    (docs/safety.md).

    Parameters
    ----------
    entry : Path
        The sibling found beside ``out``.
    out : Path
        The output it belongs to.
    infix : str
        The marker after ``.{out.name}``, e.g. :data:`STAGING_INFIX`.

    Returns
    -------
    int or None
        The PID of the process that made ``entry``.

    Examples
    --------
    >>> marked_pid(Path(".res.staging-4242-ab12"), Path("res"), STAGING_INFIX)
    4242
    >>> marked_pid(Path(".res.staging-x"), Path("res"), STAGING_INFIX) is None
    True
    """
    try:
        return int(entry.name[len(staging_stem(out.name)) + 1 + len(infix) :].split("-")[0])
    except ValueError:
        return None


def _recover_leftovers(out: Path, path: str | Path) -> None:
    """Deal with what killed runs left beside ``out``, before ``out`` itself is checked.

    A staging folder of a dead process is removed (it never was an output); one of a live
    process makes this run refuse. A previous output moved aside by a ``force`` replace that
    was killed between its two renames (``.{name}.old-{PID}-*``, process dead) is the only copy
    of that output when ``out`` is missing: it is moved back. When ``out`` exists and the dead
    run left no staging folder, its replace completed and the old copy is removed (the user
    asked for it to be replaced); when ``out`` exists *and* that run's staging folder is still
    there, something else created ``out`` after the kill: the old copy is kept and reported.
    """
    stem = glob_escape(staging_stem(out.name))
    with contextlib.suppress(OSError):
        staging = {
            entry: marked_pid(entry, out, STAGING_INFIX)
            for entry in out.parent.glob(f".{stem}{STAGING_INFIX}*")
        }
        for entry in sorted(out.parent.glob(f".{stem}{OLD_INFIX}*")):
            pid = marked_pid(entry, out, OLD_INFIX)
            if pid is None or pid == os.getpid() or pid_alive(pid):
                continue  # not named by this version, or its run is still replacing
            if not os.path.lexists(out):
                try:
                    rename_noreplace(entry, out)  # the only copy of the previous output
                except FileExistsError:
                    pass  # appeared just now: judged below
                else:
                    continue
            if pid in staging.values():
                raise OutputExistsError(
                    f"{path}: {entry.name} beside it holds the previous output of a run killed "
                    "while replacing it, and the output was created again since; move that "
                    "folder back or remove it, then rerun"
                )
            shutil.rmtree(entry, ignore_errors=True)  # the replace had completed
        for entry, pid in staging.items():
            if pid is None or pid == os.getpid():
                continue  # not named by this version: not ours to judge
            if pid_alive(pid):
                raise OutputExistsError(
                    f"{path}: another run (PID {pid}) is writing this output ({entry.name}); "
                    "wait for it, or remove that folder if the process is not hdrfringe"
                )
            shutil.rmtree(entry, ignore_errors=True)


def check_output_dir(path: str | Path, force: bool) -> CheckedOutput:
    """Check an output folder before any work and record what was checked.

    Refuses a file in the way, an existing non-empty folder unless ``force``, an unwritable
    location (:func:`check_writable`) and a target another live run is writing; removes staging
    folders left by killed runs and moves back a previous output that a killed ``force``
    replace had moved aside. The identity of what is there (device and inode of the folder,
    or nothing) is recorded in the returned :class:`CheckedOutput`: give that object to the
    writer (:func:`staged_output_dir`), which then replaces only what was checked.

    Parameters
    ----------
    path : str or Path
        The output folder a command is about to write.
    force : bool
        Accept an existing non-empty folder (it will be replaced).

    Returns
    -------
    CheckedOutput
        ``path`` as a :class:`~pathlib.Path` that carries what was checked.

    Raises
    ------
    OutputExistsError
        If ``path`` is a file, or a non-empty folder and ``force`` is false, or is being
        written by another run.
    InputError
        If the location is not writable.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> check_output_dir(root / "new", force=False).name
    'new'
    >>> (root / "new").mkdir()
    >>> (root / "new" / "old.txt").write_text("x")
    1
    >>> check_output_dir(root / "new", force=False)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.OutputExistsError: ...new: output folder exists and is not empty; ...
    >>> check_output_dir(root / "new", force=True).name
    'new'
    """
    out = Path(path)
    check_name_length(out)
    check_writable(out)
    _recover_leftovers(_resolved(out), out)
    if out.exists() and not out.is_dir():
        raise OutputExistsError(f"{out}: exists and is not a folder; choose another output path")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise OutputExistsError(
            f"{out}: output folder exists and is not empty; pass --force to replace it "
            "or choose another path"
        )
    return CheckedOutput.record(path)


def check_output_file(path: str | Path, force: bool) -> CheckedOutput:
    """Check an output file before any work and record what was checked.

    Refuses a folder in the way, an existing file unless ``force`` and an unwritable location
    (:func:`check_writable`); removes temporary files of killed runs. Give the returned
    :class:`CheckedOutput` to :func:`staged_output_file`.

    Parameters
    ----------
    path : str or Path
        The output file a command is about to write.
    force : bool
        Accept an existing file (it will be replaced).

    Returns
    -------
    CheckedOutput
        ``path``, carrying what was there (device and inode of the file, or nothing).

    Raises
    ------
    OutputExistsError
        If ``path`` is a folder, or an existing file and ``force`` is false.
    InputError
        If the location is not writable.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> (root / "corr.json").write_text("{}")
    2
    >>> check_output_file(root / "corr.json", force=False)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.OutputExistsError: ...corr.json: exists; pass --force to replace it ...
    >>> check_output_file(root / "corr.json", force=True).identity is not None
    True
    """
    out = Path(path)
    check_name_length(out)
    if out.is_dir():
        raise OutputExistsError(f"{out}: is a folder; give a file name")
    if os.path.lexists(out) and not force:
        raise OutputExistsError(f"{out}: exists; pass --force to replace it or choose another path")
    check_writable(out)
    target = _resolved(out)
    with contextlib.suppress(OSError):
        stem = glob_escape(staging_stem(target.name))
        for entry in target.parent.glob(f".{stem}{STAGING_INFIX}*"):
            pid = marked_pid(entry, target, STAGING_INFIX)
            if pid is not None and pid != os.getpid() and not pid_alive(pid):
                entry.unlink()
    return CheckedOutput.record(path)


_RENAME_NOREPLACE = 1
_AT_FDCWD = -100


def rename_noreplace(src: str | Path, dst: str | Path) -> None:
    """Rename ``src`` to ``dst`` atomically, failing if ``dst`` exists (even an empty folder).

    ``os.rename`` of a folder onto an existing empty folder succeeds on Linux, so it cannot
    guard a target. This uses ``renameat2(..., RENAME_NOREPLACE)`` (Linux >= 3.15, one atomic
    step, the folder appears complete); where that is unavailable (other systems, file systems
    without it) it falls back to claiming ``dst`` with ``os.mkdir`` (atomic: fails if anything is
    there) and moving the entries of ``src`` into it.

    Parameters
    ----------
    src, dst : str or Path
        Source and (non-existent) destination on one file system.

    Raises
    ------
    FileExistsError
        If ``dst`` exists.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> (root / "a").mkdir(); (root / "b").mkdir()
    >>> rename_noreplace(root / "a", root / "b")
    Traceback (most recent call last):
    ...
    FileExistsError: [Errno 17] File exists: ...
    >>> rename_noreplace(root / "a", root / "c"); sorted(p.name for p in root.iterdir())
    ['b', 'c']
    """
    s, d = os.fsencode(os.fspath(src)), os.fsencode(os.fspath(dst))
    fn = None
    with contextlib.suppress(OSError, AttributeError):
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    if fn is not None:
        if fn(_AT_FDCWD, s, _AT_FDCWD, d, _RENAME_NOREPLACE) == 0:
            return
        err = ctypes.get_errno()
        if err not in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):
            raise OSError(err, os.strerror(err), os.fspath(dst))
    os.mkdir(d)  # atomic claim: FileExistsError if anything is there
    try:
        for entry in os.listdir(s):
            os.rename(os.path.join(s, entry), os.path.join(d, entry))
        os.rmdir(s)
    except BaseException:
        shutil.rmtree(d, ignore_errors=True)
        raise


def _stoppable(signum: int) -> bool:
    """Whether this process may take over signal ``signum`` (main thread, not ignored on
    purpose as ``nohup`` ignores SIGHUP or a shell's background job SIGINT)."""
    if threading.current_thread() is not threading.main_thread():
        return False
    return signal.getsignal(signum) not in (signal.SIG_IGN, None)


@contextlib.contextmanager
def sigterm_cleanup() -> Iterator[Callable[[], int | None]]:
    """Within the block, SIGTERM raises ``SystemExit(143)`` and SIGHUP ``SystemExit(129)``, so
    cleanup code runs.

    The exception is raised wherever Python is when the signal arrives; where that is a
    callback run from C (a weakref callback, a ``__del__``, h5py's object bookkeeping) Python
    reports it as "Exception ignored" and goes on (issue 31: ``calibrate`` then wrote its file
    and exited 0). So the signal is also recorded: the yielded ``stopped()`` returns it, and a
    writer asks before it publishes anything (:func:`staged_output_dir` and
    :func:`staged_output_file` do, and stop with :func:`honour_signal`).

    Only the main thread can set signal handlers; elsewhere this does nothing, and a signal the
    process ignores (``nohup``) stays ignored. The previous handlers are restored on exit.

    Yields
    ------
    callable
        ``stopped()``: the first SIGTERM or SIGHUP received in the block, or None.

    Examples
    --------
    >>> with sigterm_cleanup() as stopped:
    ...     signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL, stopped()
    (True, None)
    """
    hit: list[int] = []

    def _stop(signum: int, frame: object) -> None:
        hit.append(signum)
        raise SystemExit(_STOP_SIGNALS[signum])

    old = {sig: signal.signal(sig, _stop) for sig in _STOP_SIGNALS if _stoppable(sig)}
    if not old:
        yield lambda: None
        return
    previous_hook = sys.unraisablehook

    def _quiet(unraisable: Any) -> None:  # our SystemExit, lost in a callback: honoured later
        if not (hit and isinstance(unraisable.exc_value, SystemExit)):
            previous_hook(unraisable)

    sys.unraisablehook = _quiet
    try:
        yield lambda: hit[0] if hit else None
    finally:
        sys.unraisablehook = previous_hook
        for sig, handler in old.items():
            signal.signal(sig, handler)


class InterruptedAfterWriting(KeyboardInterrupt):
    """Ctrl-C received during an output's final move, honoured once the output was in place.

    The command stops as for Ctrl-C (exit code 130), but its output is complete: the
    message says so instead of "nothing was written" (issue 31).

    Parameters
    ----------
    written : Path
        The output (as the user named it), complete and in place.

    Attributes
    ----------
    written : Path
        As given.
    name : str
        ``"SIGINT"``.
    exit_code : int
        130.

    Examples
    --------
    >>> stop = InterruptedAfterWriting(Path("out"))
    >>> isinstance(stop, KeyboardInterrupt), stop.exit_code, str(stop.written)
    (True, 130, 'out')
    """

    def __init__(self, written: Path) -> None:
        super().__init__(str(written))
        self.written = written
        self.name = "SIGINT"
        self.exit_code = 130


class StoppedAfterWriting(SystemExit):
    """SIGTERM or SIGHUP received during an output's final move, honoured once the output
    was in place: ``SystemExit`` with the signal's exit code (143, 129), as in a staging
    block, carrying the output written (issue 31: the stop said nothing was written).

    Parameters
    ----------
    signum : int
        The signal received.
    written : Path
        The output (as the user named it), complete and in place.

    Attributes
    ----------
    written : Path
        As given.
    name : str
        The signal's name.
    exit_code : int
        The exit status (:attr:`code`).

    Examples
    --------
    >>> stop = StoppedAfterWriting(signal.SIGTERM, Path("cal.h5"))
    >>> stop.code, stop.name, str(stop.written)
    (143, 'SIGTERM', 'cal.h5')
    """

    def __init__(self, signum: int, written: Path) -> None:
        self.exit_code = _STOP_SIGNALS.get(signum, 128 + signum)
        super().__init__(self.exit_code)
        self.written = written
        self.name = signal.Signals(signum).name


def honour_signal(signum: int | None, written: Path | None = None) -> None:
    """Stop as signal ``signum`` asks, after it was held back (:func:`deferred_signals`).

    Parameters
    ----------
    signum : int or None
        The signal received, or None (nothing to do).
    written : Path, optional
        The output that is complete and in place although the run stops (the signal came
        during its final move); the exception raised carries it.

    Raises
    ------
    KeyboardInterrupt
        For SIGINT (exit code 130 from the command line); :class:`InterruptedAfterWriting`
        with ``written``.
    SystemExit
        For SIGTERM (143) and SIGHUP (129); :class:`StoppedAfterWriting` with ``written``.

    Examples
    --------
    >>> honour_signal(None)
    >>> honour_signal(signal.SIGTERM)
    Traceback (most recent call last):
    ...
    SystemExit: 143

    SIGINT raises a ``KeyboardInterrupt``, which doctest (and pytest) would not catch:

    >>> try:
    ...     honour_signal(signal.SIGINT, written=Path("out"))
    ... except InterruptedAfterWriting as stop:
    ...     print(type(stop).__name__, stop.written, stop.exit_code)
    InterruptedAfterWriting out 130
    """
    if signum is None:
        return
    if signum == signal.SIGINT:
        raise KeyboardInterrupt if written is None else InterruptedAfterWriting(written)
    if written is not None:
        raise StoppedAfterWriting(signum, written)
    raise SystemExit(_STOP_SIGNALS.get(signum, 128 + signum))


@contextlib.contextmanager
def deferred_signals(
    written: Path | None = None, *, honour: bool = True
) -> Iterator[Callable[[], int | None]]:
    """Hold SIGINT, SIGTERM and SIGHUP back within the block; honour the first one after it.

    For work that must not be cut (a final rename) or that runs in C code whose callbacks
    swallow Python exceptions (h5py: a ``SystemExit`` or ``KeyboardInterrupt`` raised there is
    reported as "ignored" and lost, so the command would end 0). A signal only sets a flag; the
    block may ask for it (the yielded function) to stop early and clean up, for example with
    :func:`honour_signal` inside a staging block so the staging is removed; otherwise, on leaving
    the block, the signal is honoured: KeyboardInterrupt (130), ``SystemExit(143)`` or
    ``SystemExit(129)``. Outside the main thread, or for a signal the process ignores, nothing
    is changed.

    Parameters
    ----------
    written : Path, optional
        What the block puts in place (a final move): a signal honoured after the block
        completed says that this output is complete (:func:`honour_signal`).
    honour : bool
        False: the signal is not honoured on leaving the block; the caller asks the yielded
        function and stops its own way (a live capture keeping the pose it just wrote).

    Yields
    ------
    callable
        ``stopped()``: the first signal received so far, or None.

    Examples
    --------
    >>> with deferred_signals() as stopped:
    ...     os.kill(os.getpid(), signal.SIGTERM)
    ...     got = signal.Signals(stopped()).name  # still running: the block ends first
    Traceback (most recent call last):
    ...
    SystemExit: 143
    >>> with deferred_signals(honour=False) as stopped:
    ...     os.kill(os.getpid(), signal.SIGTERM)
    >>> signal.Signals(stopped()).name
    'SIGTERM'
    """
    hit: list[int] = []
    held = [signal.SIGINT, *_STOP_SIGNALS]
    old = {
        sig: signal.signal(sig, lambda signum, frame: hit.append(signum))
        for sig in held
        if _stoppable(sig)
    }
    try:
        yield lambda: hit[0] if hit else None
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
    if honour:
        honour_signal(hit[0] if hit else None, written)


class SignalStop(KeyboardInterrupt):
    """SIGTERM or SIGHUP received where a run keeps what is complete, as for Ctrl-C.

    A :class:`KeyboardInterrupt`, so the code that handles Ctrl-C (a live capture keeping its
    complete sets) handles it the same way; :attr:`signum` says which signal it was.

    Parameters
    ----------
    signum : int
        The signal received.

    Attributes
    ----------
    signum : int
        As given.
    exit_code : int
        The exit status a command stopped by it gives (143, 129).

    Examples
    --------
    >>> stop = SignalStop(signal.SIGTERM)
    >>> isinstance(stop, KeyboardInterrupt), stop.exit_code, stop.name
    (True, 143, 'SIGTERM')
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum
        self.exit_code = _STOP_SIGNALS.get(signum, 128 + signum)
        self.name = signal.Signals(signum).name


@contextlib.contextmanager
def signals_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM and SIGHUP raise :class:`SignalStop` (a KeyboardInterrupt).

    For work that keeps its complete part when stopped (a live capture): the ``except
    KeyboardInterrupt`` that handles Ctrl-C then handles a supervisor's SIGTERM and a closed
    terminal's SIGHUP too. Main thread only; a signal the process ignores stays ignored.

    Yields
    ------
    None

    Examples
    --------
    >>> try:
    ...     with signals_as_interrupt():
    ...         os.kill(os.getpid(), signal.SIGTERM)
    ... except KeyboardInterrupt as stop:
    ...     print(stop.name)
    SIGTERM
    """

    def _stop(signum: int, frame: object) -> None:
        raise SignalStop(signum)

    old = {sig: signal.signal(sig, _stop) for sig in _STOP_SIGNALS if _stoppable(sig)}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


@contextlib.contextmanager
def _as_environment_fault(path: str | Path) -> Iterator[None]:
    """Within the block, an ``OSError`` of the fault policy (a permission refused, a full disk,
    ...) becomes the one-line :class:`ResourceError` naming ``path``, the output the user gave,
    instead of the hidden staging name the failing call was given."""
    try:
        yield
    except OSError as exc:
        fault = environment_fault(exc, path)
        if fault is None:
            raise
        raise fault from None


def _finish(
    tmp: Path, target: Path, path: str | Path, ident: tuple[int, int] | None, force: bool
) -> None:
    """Move the complete staging folder to ``target``, replacing only the checked folder."""
    try:
        st = os.lstat(target)
        now: tuple[int, int] | None = (st.st_dev, st.st_ino)
    except FileNotFoundError:
        now = None
    if now is None:
        try:
            rename_noreplace(tmp, target)
        except FileExistsError:
            raise OutputExistsError(
                f"{path}: appeared while this run was writing; it was left untouched and "
                "nothing was written"
            ) from None
        return
    if now != ident:
        raise OutputExistsError(
            f"{path}: was created or replaced while this run was writing; it was left "
            "untouched and nothing was written"
        )
    if not force:  # the empty folder checked at start: remove it only if still empty
        try:
            os.rmdir(target)
        except OSError:
            raise OutputExistsError(
                f"{path}: files appeared in the output folder while this run was writing; it "
                "was left untouched and nothing was written"
            ) from None
        _finish(tmp, target, path, None, force)
        return
    # the folder checked at start (force): move it aside, then claim the name
    prefix = f".{staging_stem(target.name)}{OLD_INFIX}{os.getpid()}-"
    backup = Path(tempfile.mkdtemp(prefix=prefix, dir=target.parent))
    backup.rmdir()
    os.rename(target, backup)
    try:
        rename_noreplace(tmp, target)
    except FileExistsError:
        with contextlib.suppress(OSError):
            rename_noreplace(backup, target)
        raise OutputExistsError(
            f"{path}: appeared while this run was writing; it was left untouched and nothing "
            "was written"
        ) from None
    shutil.rmtree(backup, ignore_errors=True)


@contextlib.contextmanager
def staged_output_dir(path: str | Path, force: bool = False) -> Iterator[Path]:
    """Write a folder atomically: yield a staging folder, then move it to ``path``.

    The staging folder is a hidden sibling of ``path`` (same file system, so the final move is
    a rename), named with this process's PID (:data:`STAGING_INFIX`). On any exception, and
    on SIGTERM (exit code 143), the staging folder is removed and ``path`` is left untouched.
    On success the folder is moved into place with a rename that cannot replace anything
    (:func:`rename_noreplace`); an existing ``path`` is replaced only if it is the very folder
    that was checked, so a folder created or swapped meanwhile is never touched. What was
    checked comes with ``path`` when it is the :class:`CheckedOutput` that
    :func:`check_output_dir` returned at the start of the command; a plain path is checked on
    entry here.

    Parameters
    ----------
    path : str, Path or CheckedOutput
        The output folder to create (its parents are created too).
    force : bool
        Replace an existing non-empty folder; without it one is refused
        (:func:`check_output_dir`) before anything is written.

    Yields
    ------
    Path
        The empty staging folder to write into.

    Raises
    ------
    OutputExistsError
        As :func:`check_output_dir`, or if the target changed while writing.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> with staged_output_dir(root / "result") as tmp:
    ...     _ = (tmp / "a.txt").write_text("done")
    ...     (root / "result").exists()
    False
    >>> (root / "result" / "a.txt").read_text()
    'done'
    >>> with staged_output_dir(root / "failed") as tmp:
    ...     raise RuntimeError("stopped half-way")
    Traceback (most recent call last):
    ...
    RuntimeError: stopped half-way
    >>> sorted(p.name for p in root.iterdir())
    ['result']
    """
    checked = path if isinstance(path, CheckedOutput) and path.checked else None
    if checked is None:  # not checked at the start of the command: check now
        checked = check_output_dir(path, force)
    ident = checked.identity
    target = _resolved(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    with sigterm_cleanup() as stopped:
        prefix = f".{staging_stem(target.name)}{STAGING_INFIX}{os.getpid()}-"
        with _as_environment_fault(path):  # the folder may have turned read-only since the check
            tmp = Path(tempfile.mkdtemp(prefix=prefix, dir=target.parent))
        try:
            os.chmod(tmp, 0o777 & ~current_umask())
            yield tmp
            honour_signal(stopped())  # a SystemExit swallowed in a callback: stop here
            # the renames are not cut half-way; a signal held there is honoured with the
            # output in place, and says so
            with deferred_signals(written=Path(path)):
                _finish(tmp, target, path, ident, force)
        except BaseException as exc:
            fault = environment_fault(exc, path, where=tmp)
            shutil.rmtree(tmp, ignore_errors=True)
            if fault is not None:
                raise fault from None
            raise


def _finish_file(
    tmp: Path, target: Path, path: str | Path, ident: tuple[int, int] | None, force: bool
) -> None:
    """Move the complete temporary file to ``target``, replacing only the file checked."""
    appeared = (
        f"{path}: appeared while this run was writing; it was left untouched and nothing was "
        "written"
    )
    try:
        st = os.lstat(target)
        now: tuple[int, int] | None = (st.st_dev, st.st_ino)
    except FileNotFoundError:
        now = None
    if now is None:
        try:
            os.link(tmp, target)  # a hard link cannot replace: fails if the name exists
        except FileExistsError:
            raise OutputExistsError(appeared) from None
        except OSError:  # no hard links here: claim the name exclusively, then replace the claim
            try:
                os.close(os.open(target, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
            except FileExistsError:
                raise OutputExistsError(appeared) from None
            os.replace(tmp, target)
            return
        tmp.unlink()
        return
    if now != ident or not force or os.path.isdir(target):
        raise OutputExistsError(
            f"{path}: was created or replaced while this run was writing; it was left "
            "untouched and nothing was written"
        )
    os.replace(tmp, target)  # the file checked at start (force): replaced in one step


@contextlib.contextmanager
def staged_output_file(path: str | Path, force: bool = False) -> Iterator[Path]:
    """Write a file atomically: yield a temporary file beside ``path``, then move it there.

    The temporary file ``.{name}.staging-{PID}-{random}.tmp`` is in the same folder (so the
    move is a rename) and follows the umask. On any exception, and on SIGTERM (exit code 143),
    it is removed and ``path`` is left untouched; one left by a killed run is removed by the
    next check of the same output (:func:`check_output_file`). On success it is moved into
    place: without ``force`` by a hard link that fails if a file appeared meanwhile, with
    ``force`` by ``os.replace``, only if ``path`` is still the very file that was checked.

    Parameters
    ----------
    path : str, Path or CheckedOutput
        The file to write; a :class:`CheckedOutput` from :func:`check_output_file` at the start
        of the command, or a plain path (checked on entry).
    force : bool
        Replace an existing file.

    Yields
    ------
    Path
        The temporary file (empty) to write.

    Raises
    ------
    OutputExistsError
        As :func:`check_output_file`, or if the target changed while writing.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> with staged_output_file(root / "corr.json") as tmp:
    ...     _ = tmp.write_text("{}")
    ...     (root / "corr.json").exists()
    False
    >>> (root / "corr.json").read_text(), sorted(p.name for p in root.iterdir())
    ('{}', ['corr.json'])
    """
    checked = path if isinstance(path, CheckedOutput) and path.checked else None
    if checked is None:
        checked = check_output_file(path, force)
    target = _resolved(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    with sigterm_cleanup() as stopped:
        prefix = f".{staging_stem(target.name)}{STAGING_INFIX}{os.getpid()}-"
        with _as_environment_fault(path):  # the folder may have turned read-only since the check
            fd, name = tempfile.mkstemp(prefix=prefix, suffix=".tmp", dir=target.parent)
        os.close(fd)
        tmp = Path(name)
        try:
            os.chmod(tmp, 0o666 & ~current_umask())
            yield tmp
            honour_signal(stopped())  # a SystemExit swallowed in a callback: stop here
            with deferred_signals(written=Path(path)):  # the rename is not cut half-way
                _finish_file(tmp, target, path, checked.identity, force)
        except BaseException as exc:
            fault = environment_fault(exc, path, where=tmp)
            with contextlib.suppress(OSError):
                tmp.unlink()
            if fault is not None:
                raise fault from None
            raise


def write_map_tiff(path: str | Path, data: ArrayLike) -> None:
    """Write a map as float32 TIFF (NaN = invalid), or an integer map in its own dtype.

    Float and bool maps are stored as float32 (bool as 0/1); integer maps keep their dtype.
    The file is zlib-compressed.

    Parameters
    ----------
    path : str or Path
        TIFF file to write.
    data : array_like
        The map, usually (H, W).

    See Also
    --------
    read_map_tiff : Read it back.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "height.tiff"
    >>> write_map_tiff(path, np.array([[1.5, np.nan], [0.25, 2.0]]))
    >>> m = read_map_tiff(path)
    >>> m.dtype, m.tolist()
    (dtype('float32'), [[1.5, nan], [0.25, 2.0]])
    """
    import tifffile

    arr = np.asarray(data)
    if arr.dtype.kind == "f" or arr.dtype == bool:
        arr = arr.astype(np.float32)
    tifffile.imwrite(path, arr, compression=MAP_COMPRESSION)


def read_map_tiff(path: str | Path) -> np.ndarray:
    """Read a map written by :func:`write_map_tiff`, its size checked from the header first.

    Parameters
    ----------
    path : str or Path
        TIFF file.

    Returns
    -------
    ndarray
        The map in its stored dtype (float32 for float and bool maps).

    Raises
    ------
    CaptureFormatError
        A truncated, corrupt or non-TIFF file, or a header declaring more than
        :data:`hdrfringe.core.limits.MAX_IMAGE_PIXELS` pixels (refused before decoding), in one line
        naming the file.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "count.tiff"
    >>> write_map_tiff(path, np.array([[0, 3], [1, 2]], dtype=np.uint8))
    >>> m = read_map_tiff(path)
    >>> m.dtype, m.tolist()
    (dtype('uint8'), [[0, 3], [1, 2]])
    """
    import tifffile

    from hdrfringe.errors import CaptureFormatError
    from hdrfringe.io._read_limits import probe_image, reason_of

    probe_image(path, "the map")
    try:
        return tifffile.imread(path)
    except Exception as exc:  # any decoder failure: truncated, corrupt data
        raise CaptureFormatError(
            f"{path}: cannot read the map ({reason_of(exc)}); the file is corrupt or "
            "truncated: regenerate it"
        ) from None


#: Previews: maps whose longer side exceeds this are subsampled by an integer stride (for
#: viewing: a 12 Mpx map's preview is 1024x750), narrower than the minimum enlarged by an
#: integer factor; invalid (NaN) pixels are this gray.
PREVIEW_MAX_WIDTH = 1024
PREVIEW_MIN_WIDTH = 256
PREVIEW_INVALID_GRAY = (128, 128, 128)


def write_preview_png(
    path: str | Path,
    data: ArrayLike,
    *,
    title: str = "",
    cmap: str = "viridis",
    label: str = "",
    vmin: float | None = None,
    vmax: float | None = None,
) -> None:
    """A PNG preview of a map with a colour bar; NaN (invalid) shown in gray.

    The map is coloured by a lookup in matplotlib's colour map (256 levels; the tables of the
    usual maps are stored in :mod:`hdrfringe.io._colormaps`, so matplotlib is not imported) and
    drawn with Pillow, one image pixel per map pixel (maps longer than 1024 px on either side
    are subsampled by an integer stride, maps narrower than 256 px enlarged by an integer
    factor), with the title above and a colour bar with its range and label at the right. No
    figure is laid out: a preview costs about what its TIFF costs. Without ``vmin``/``vmax``
    the colour range spans the 0.5 and 99.5 percentiles of the finite values, so a few
    outliers do not flatten the picture.

    Parameters
    ----------
    path : str or Path
        PNG file to write.
    data : array_like
        The map, (H, W); non-finite values are invalid.
    title : str
        Title above the map.
    cmap : str
        Name of a matplotlib colour map.
    label : str
        Label of the colour bar (e.g. the unit).
    vmin, vmax : float, optional
        Colour range; default the percentiles above.

    Examples
    --------
    >>> import tempfile
    >>> from PIL import Image
    >>> path = Path(tempfile.mkdtemp()) / "height.png"
    >>> write_preview_png(path, [[0.0, 1.0], [np.nan, 2.0]], title="height", label="mm")
    >>> Image.open(path).format
    'PNG'
    """
    from PIL import Image, ImageDraw, ImageFont

    from hdrfringe.io._colormaps import colormap_lut

    arr = np.asarray(data)
    if arr.ndim != 2 or arr.size == 0:
        raise InputError(f"{path}: a preview needs a non-empty 2-D map, got shape {arr.shape}")
    if max(arr.shape) > PREVIEW_MAX_WIDTH:  # subsampled first: no full-size float64 copy
        stride = -(-max(arr.shape) // PREVIEW_MAX_WIDTH)
        arr = arr[::stride, ::stride]
    arr = np.asarray(arr, dtype=np.float64)
    finite = np.isfinite(arr)
    if vmin is None:
        vmin = float(np.percentile(arr[finite], 0.5)) if finite.any() else 0.0
    if vmax is None:
        vmax = float(np.percentile(arr[finite], 99.5)) if finite.any() else 1.0
    span = vmax - vmin if vmax > vmin else 1.0
    lut = colormap_lut(cmap)
    with np.errstate(invalid="ignore"):
        level = np.clip((arr - vmin) / span, 0.0, 1.0)
    index = np.rint(np.where(finite, level, 0.0) * 255).astype(np.intp)
    rgb = lut[index]
    rgb[~finite] = PREVIEW_INVALID_GRAY
    body = Image.fromarray(rgb, "RGB")
    if body.width < PREVIEW_MIN_WIDTH:
        k = -(-PREVIEW_MIN_WIDTH // body.width)
        body = body.resize((body.width * k, body.height * k), Image.Resampling.NEAREST)
    font = ImageFont.load_default(size=12)
    bar_w, margin, top = 16, 8, 22
    texts = [f"{vmax:.4g}", f"{(vmin + vmax) / 2:.4g}", f"{vmin:.4g}", label]
    text_w = max(int(font.getlength(t)) for t in texts) if any(texts) else 0
    canvas = Image.new(
        "RGB",
        (body.width + 3 * margin + bar_w + text_w + margin, body.height + top + margin),
        "white",
    )
    canvas.paste(body, (margin, top))
    draw = ImageDraw.Draw(canvas)
    draw.text((margin, 4), title, fill="black", font=font)
    ramp = lut[np.linspace(255, 0, body.height).round().astype(np.intp)]
    bar = Image.fromarray(np.repeat(ramp[:, None, :], bar_w, axis=1), "RGB")
    x_bar = body.width + 2 * margin
    canvas.paste(bar, (x_bar, top))
    x_text = x_bar + bar_w + 4
    draw.text((x_text, top), texts[0], fill="black", font=font)
    draw.text((x_text, top + body.height // 2 - 6), texts[1], fill="black", font=font)
    draw.text((x_text, top + body.height - 14), texts[2], fill="black", font=font)
    draw.text((x_bar, 4), label, fill="black", font=font)
    canvas.save(path, format="PNG", compress_level=1)
