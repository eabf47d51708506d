"""The fault policy of the writers (issue 31, docs/safety.md "Fault policy").

The audit's reproducers, one or more per root cause of the writing side:

1. SIGTERM during ``calibrate``'s HDF5 save was swallowed in h5py's callbacks (exit 0, file
   written); SIGHUP killed the process and left its temporary file.
2. A failing write (the file size limit, ``ulimit -f``) crashed ``calibrate`` with SIGSEGV and
   gave every other writer a traceback and exit 1.
6. Under an address-space limit (``ulimit -v``) ``measure`` segfaulted (OpenCV's OpenBLAS
   threads) or called a sound calibration "damaged".
9. Legal output names of 240-255 bytes failed: the staging name added ~25 bytes.
11. Odd environments: standard output closed, full (/dev/full) or a closed pipe; an ASCII-only
    encoding and a non-ASCII output name; ``COLUMNS=0`` (no error line at all); a deleted
    working directory.

Limits are set with ``resource.setrlimit`` in the child (``preexec_fn``: no privilege needed);
signals are sent when the child says it is saving (a line on its stdout), never after a guessed
delay. The contract checked: exit code 2 with exactly one ``error:`` line naming the path and
the errno, no traceback, nothing partial left; a signal is honoured with its shell exit code.
"""

from __future__ import annotations

import errno
import os
import resource
import signal
import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest

import hdrfringe
from hdrfringe.errors import FAULT_ERRNOS, ResourceError
from hdrfringe.io.results import (
    STAGING_INFIX,
    staged_output_dir,
    staged_output_file,
)
from tests.conftest import default_stop_signals, run_cli, without_dac_override

CLI = [sys.executable, "-m", "hdrfringe.cli"]
#: The children run in their own folders: they import the package this process imported.
_SRC = str(Path(hdrfringe.__file__).resolve().parents[1])


@pytest.fixture(scope="module")
def series(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A calibration series at 64x48 (the reproducers' S, smaller) and its calibration."""
    root = tmp_path_factory.mktemp("faults")
    res = run_cli("simulate", "white_plate", "--series", "0:20:10", "--pitch", "1024,64,8",
                  "--resolution", "64x48", "-o", str(root / "S"))  # fmt: skip
    assert res.returncode == 0, res.stderr
    res = run_cli("calibrate", str(root / "S"), "-o", str(root / "cal.h5"))
    assert res.returncode == 0, res.stderr
    return root


def _child(
    args: list[str],
    cwd: Path,
    *,
    limit: tuple[int, int] | None = None,
    env: dict[str, str] | None = None,
    setup: Callable[[], None] | None = None,
    stdout: object = subprocess.PIPE,
) -> subprocess.CompletedProcess[str]:
    """Run ``args`` in a new process, with an rlimit ``(resource, bytes)``, the environment
    updated by ``env`` (COLUMNS unset unless given) and ``setup`` run in the child first."""

    def preexec() -> None:
        if limit is not None:
            resource.setrlimit(limit[0], (limit[1], limit[1]))
        if setup is not None:
            setup()

    base = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
    return subprocess.run(
        args, cwd=cwd,
        env={**base, "PYTHONPATH": _SRC, "PYTHONDONTWRITEBYTECODE": "1", **(env or {})},
        preexec_fn=preexec, stdout=stdout, stderr=subprocess.PIPE, text=True, timeout=120,
    )  # fmt: skip


def _one_error_line(res: subprocess.CompletedProcess[str]) -> str:
    assert res.returncode == 2, (res.returncode, res.stderr)
    assert "Traceback" not in res.stderr and "Exception ignored" not in res.stderr, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    return lines[0]


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


# ------------------------------------------------------------------------------------------
# 2. a failing write: the file size limit (EFBIG), in calibrate (HDF5) and phase (TIFF/PNG)
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("command", "output", "limit_kib"),
    [("calibrate", "cal2.h5", 24), ("phase", "ph", 4)],
)
def test_file_size_limit_is_one_line_and_leaves_nothing(
    series: Path, tmp_path: Path, command: str, output: str, limit_kib: int
) -> None:
    """``ulimit -f``: calibrate died with SIGSEGV (HDF5 closing its half-written file), phase
    gave a 50-line traceback and exit 1 (numpy's short write has no errno)."""
    source = series / "S" if command == "calibrate" else series / "S" / "white_plate_010.00mm"
    res = _child(
        [*CLI, command, str(source), "-o", output],
        tmp_path,
        limit=(resource.RLIMIT_FSIZE, limit_kib * 1024),
    )
    line = _one_error_line(res)
    assert f"{output}: cannot write" in line and "errno EFBIG" in line, line
    assert "ulimit -f" in line
    assert list(tmp_path.iterdir()) == []  # no output, no staging file or folder


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.ENAMETOOLONG])
def test_every_writer_answers_a_refused_write_in_one_line(tmp_path: Path, code: int) -> None:
    """The staged writers (every command's) turn the environment's errnos into a
    ResourceError naming the output (not its hidden staging name) and the errno; a broken
    variant that let the OSError through, or named the staging path, fails here."""
    writers = ((staged_output_dir, tmp_path / "out"), (staged_output_file, tmp_path / "f"))
    for stage, target in writers:
        with pytest.raises(ResourceError) as info, stage(target) as tmp:
            raise OSError(code, os.strerror(code), str(tmp))
        text = str(info.value)
        assert text.startswith(f"{target}: cannot write: ") and STAGING_INFIX not in text
        assert f"(errno {errno.errorcode[code]})" in text and FAULT_ERRNOS[code] in text
        assert info.value.errno == code
        assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------------------
# 1. SIGTERM and SIGHUP during calibrate's HDF5 save
# ------------------------------------------------------------------------------------------
_HELD_SAVE = textwrap.dedent(
    """
    import sys
    import hdrfringe.io.calibration_file as calfile
    from hdrfringe.cli import app

    original = calfile._write

    def held(f, cal):  # the save is under way: say so, and go on when told
        original(f, cal)
        print("saving", flush=True)
        sys.stdin.readline()
        print("saved", flush=True)  # the signal did not cut the save

    calfile._write = held
    app(sys.argv[1:], prog_name="hdrfringe")
    """
)


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_signal_during_calibration_save_is_honoured_after_it(
    series: Path, tmp_path: Path, signum: int, code: int
) -> None:
    """The signal arrives while the HDF5 file is being written: it is held (not raised
    inside h5py, where it was lost; not killing the process with its temporary file left),
    the save completes, then the signal is honoured: its exit code, no file, no temporary
    file, no traceback."""
    driver = tmp_path / "held_save.py"
    driver.write_text(_HELD_SAVE)
    out = tmp_path / "cals" / "cal.h5"
    out.parent.mkdir()
    proc = subprocess.Popen(
        [sys.executable, str(driver), "calibrate", str(series / "S"), "-o", str(out)],
        env={**os.environ, "PYTHONPATH": _SRC}, preexec_fn=default_stop_signals,
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stdin is not None and proc.stdout is not None and proc.stderr is not None
    assert proc.stdout.readline().strip() == "saving", proc.stderr.read()
    proc.send_signal(signum)
    proc.stdin.close()  # the save may go on: the signal must still be honoured after it
    assert proc.wait(timeout=60) == code, proc.stderr.read()
    stderr = proc.stderr.read()
    assert "Traceback" not in stderr and "Exception ignored" not in stderr, stderr
    rest = proc.stdout.read()
    assert "saved" in rest and "wrote" not in rest  # held until the file was complete
    assert list(out.parent.iterdir()) == []


def test_signal_swallowed_in_a_callback_still_stops_the_writer(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The audit's SIGTERM in ``calibrate``: the handler's SystemExit was raised inside a
    weakref callback run from C, reported as "Exception ignored" and lost; the command wrote
    its file and exited 0. A ``__del__`` is such a callback: the writer must still stop (143)
    and publish nothing."""

    class Dropped:
        def __del__(self) -> None:
            os.kill(os.getpid(), signal.SIGTERM)  # the handler runs in here: swallowed

    reported: list[object] = []
    monkeypatch.setattr(sys, "unraisablehook", reported.append)
    out = tmp_path / "out"
    went_on = False
    with pytest.raises(SystemExit) as info, staged_output_dir(out) as tmp:
        (tmp / "a.txt").write_text("complete")
        Dropped()
        went_on = True  # the SystemExit was swallowed in __del__
    assert went_on and info.value.code == 143
    assert reported == []  # and not reported as "Exception ignored": it is honoured
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------------------
# 6. measure under an address-space limit
# ------------------------------------------------------------------------------------------
def test_measure_under_a_460_mb_address_space_limit(series: Path, tmp_path: Path) -> None:
    """``ulimit -v 460000`` (a container's limit): measure died with SIGSEGV while importing
    OpenCV (its OpenBLAS's thread server dereferences a failed allocation)."""
    res = _child(
        [*CLI, "measure", str(series / "S" / "white_plate_010.00mm"), "-c",
         str(series / "cal.h5"), "-o", "m"],
        tmp_path, limit=(resource.RLIMIT_AS, 460 * 2**20),
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "m" / "height.tiff").is_file()


def test_address_space_limit_too_small_to_start_is_one_line(tmp_path: Path) -> None:
    from hdrfringe.cli._app import MIN_ADDRESS_SPACE_MIB

    res = _child(
        [*CLI, "phase", "nothing", "-o", "x"],
        tmp_path, limit=(resource.RLIMIT_AS, (MIN_ADDRESS_SPACE_MIB - 100) * 2**20),
    )  # fmt: skip
    line = _one_error_line(res)
    assert f"address-space limit (ulimit -v) is {MIN_ADDRESS_SPACE_MIB - 100} MiB" in line


def test_calibration_read_out_of_memory_is_not_called_damaged(
    series: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """h5py turns HDF5's failed allocation into an OSError, which was reported as a damaged
    calibration ("recalibrate"): it is memory."""
    import hdrfringe.io.calibration_file as calfile

    def no_memory(f: object, where: str) -> None:
        raise OSError("Can't synchronously read data (unable to allocate memory block)")

    monkeypatch.setattr(calfile, "_read", no_memory)
    with pytest.raises(ResourceError, match="out of memory while reading it") as info:
        calfile.load_calibration(series / "cal.h5")
    assert "damaged" not in str(info.value)


# ------------------------------------------------------------------------------------------
# 9. output names of 240-255 bytes (legal) and longer (illegal)
# ------------------------------------------------------------------------------------------
def test_legal_long_output_names_work_and_illegal_ones_are_one_line(
    series: Path, tmp_path: Path
) -> None:
    folder = tmp_path / ("p" * 255)
    res = run_cli("phase", str(series / "S" / "white_plate_010.00mm"), "-o", str(folder))
    assert res.returncode == 0, res.stderr
    assert (folder / "absolute_phase_vertical.tiff").is_file()
    res = run_cli("phase", str(series / "S" / "white_plate_010.00mm"), "-o", str(folder),
                  "--force")  # fmt: skip
    assert res.returncode == 0, res.stderr  # the replace's backup name is short too
    cal = tmp_path / ("c" * 252 + ".h5")
    res = run_cli("calibrate", str(series / "S"), "-o", str(cal))
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([folder.name, cal.name])
    res = run_cli("phase", str(series / "S" / "white_plate_010.00mm"), "-o",
                  str(tmp_path / ("q" * 256)))  # fmt: skip
    line = _one_error_line(res)
    assert "is 256 bytes, longer than the 255" in line and "ENAMETOOLONG" in line


# ------------------------------------------------------------------------------------------
# 11. the environment: stdout closed, full or a closed pipe; ASCII; COLUMNS=0; no cwd
# ------------------------------------------------------------------------------------------
def _phase(series: Path, out: str) -> list[str]:
    return [*CLI, "phase", str(series / "S" / "white_plate_010.00mm"), "-o", out]


def test_stdout_closed_runs_the_command(series: Path, tmp_path: Path) -> None:
    """``>&-``: Python has no sys.stdout, and the console failed at import (traceback)."""
    res = _child(_phase(series, "out"), tmp_path, setup=lambda: os.close(1), stdout=None)
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "out" / "absolute_phase_vertical.tiff").is_file()


def test_stdout_full_is_one_line(series: Path, tmp_path: Path) -> None:
    """``> /dev/full``: the report cannot be printed (ENOSPC); the files are written."""
    with open("/dev/full", "w") as full:
        res = _child(_phase(series, "out"), tmp_path, stdout=full)
    line = _one_error_line(res)
    assert "standard output: cannot write" in line and "ENOSPC" in line
    assert (tmp_path / "out" / "absolute_phase_vertical.tiff").is_file()


def test_stdout_pipe_closed_by_its_reader_ends_quietly(series: Path, tmp_path: Path) -> None:
    """``| head -1``: the reader has gone; the command ended with exit 1 (rich's choice) after
    its work. Now the shell's code for SIGPIPE and nothing on stderr."""
    read, write = os.pipe()
    os.close(read)  # the reader has gone before the first line
    try:
        res = _child(_phase(series, "out"), tmp_path, stdout=write)
    finally:
        os.close(write)
    assert res.returncode == 141, res.stderr
    assert res.stderr == ""
    assert (tmp_path / "out" / "absolute_phase_vertical.tiff").is_file()


def test_ascii_encoding_and_a_non_ascii_output_name(series: Path, tmp_path: Path) -> None:
    res = _child(_phase(series, "résultat"), tmp_path, env={"PYTHONIOENCODING": "ascii"})
    assert res.returncode == 0, res.stderr
    assert "wrote" in res.stdout and "r\\xe9sultat" in res.stdout
    assert (tmp_path / "résultat" / "absolute_phase_vertical.tiff").is_file()


def test_columns_zero_still_prints_the_error_line(tmp_path: Path) -> None:
    """Rich took COLUMNS=0 as the width and printed nothing: exit 2 without a word."""
    res = _child([*CLI, "phase", "missing", "-o", "x"], tmp_path, env={"COLUMNS": "0"})
    line = _one_error_line(res)
    assert "missing: not a folder" in line


def test_deleted_working_directory_is_one_line(tmp_path: Path) -> None:
    gone = tmp_path / "gone"
    gone.mkdir()

    def enter_and_delete() -> None:
        os.chdir(gone)
        os.rmdir(gone)

    res = _child([*CLI, "phase", "x", "-o", "y"], tmp_path, setup=enter_and_delete)
    line = _one_error_line(res)
    assert "working directory no longer exists" in line
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------------------
# EACCES and ENOSPC met by the real writers (not an errno raised by the test)
# ------------------------------------------------------------------------------------------
_READ_ONLY_LATER = textwrap.dedent(
    """
    import importlib, os, sys
    from hdrfringe.cli import app

    module, name, folder = sys.argv[1:4]
    mod = importlib.import_module(module)
    original = getattr(mod, name)

    def then_read_only(*args, **kwargs):  # the output was checked; now its folder turns 0555
        result = original(*args, **kwargs)
        os.chmod(folder, 0o555)
        return result

    setattr(mod, name, then_read_only)
    app(sys.argv[4:], prog_name="hdrfringe")
    """
)


@pytest.mark.parametrize(
    ("command", "output", "hook"),
    [
        ("phase", "ph", "hdrfringe.core.decode:decode_captures"),
        ("calibrate", "cal.h5", "hdrfringe.tasks.calibrate:calibrate_folders"),
    ],
)
def test_permission_refused_while_writing_is_one_line(
    series: Path, tmp_path: Path, command: str, output: str, hook: str
) -> None:
    """The output's folder passes the writability check, then turns read-only while the
    command computes (as a user or a script may do during a long run): the writer itself
    meets EACCES from the kernel. Root runs the child without CAP_DAC_OVERRIDE (setpriv),
    so the permission bits bind. A writer that let the PermissionError through, or named its
    hidden staging path, fails here; the previous output (``--force``) stays as it was."""
    prefix = without_dac_override()
    source = series / "S" if command == "calibrate" else series / "S" / "white_plate_010.00mm"
    driver = tmp_path / "read_only_later.py"
    driver.write_text(_READ_ONLY_LATER)
    folder = tmp_path / "results"
    folder.mkdir()
    previous = folder / output
    if command == "phase":
        previous.mkdir()
        (previous / "mine.txt").write_text("previous result")
    else:
        previous.write_text("previous calibration")
    before = sorted(p.name for p in folder.rglob("*"))
    module, name = hook.split(":")
    try:
        res = _child(
            [*prefix, sys.executable, str(driver), module, name, str(folder), command,
             str(source), "-o", str(previous), "--force"],
            tmp_path,
        )  # fmt: skip
    finally:
        folder.chmod(0o755)
    line = _one_error_line(res)
    assert line.startswith(f"error: {previous}: cannot write: Permission denied"), line
    assert "(errno EACCES); choose a path you may write" in line, line
    assert STAGING_INFIX not in line
    assert sorted(p.name for p in folder.rglob("*")) == before  # nothing partial, no staging
    if command == "phase":
        assert (previous / "mine.txt").read_text() == "previous result"
    else:
        assert previous.read_text() == "previous calibration"


def _tiny_tmpfs_child(
    command_line: str, mount: Path, kept: Path, cwd: Path
) -> subprocess.CompletedProcess[str]:
    """Run ``command_line`` (sh) in a private mount namespace where ``mount`` is a 64 KiB
    tmpfs, then print what is left there after a ``LEFT:`` line and the file ``kept`` after
    ``KEPT:``; skips where this process may not create a mount namespace (``unshare -m``
    needs root or user namespaces)."""
    import shutil

    if shutil.which("unshare") is None:
        pytest.skip("needs unshare (util-linux) for a private 64 KiB tmpfs")
    script = (
        f"mount -t tmpfs -o size=64k tmpfs {mount} || exit 99; {command_line}; rc=$?; "
        f"echo LEFT:; ls -A {mount}; echo KEPT:; cat {kept}; exit $rc"
    )
    res = _child(["unshare", "-m", "sh", "-c", script], cwd)
    if res.returncode == 99 or "unshare failed" in res.stderr:
        pytest.skip(f"cannot mount a tmpfs in a private namespace here: {res.stderr.strip()}")
    return res


@pytest.mark.parametrize(("command", "output"), [("phase", "ph"), ("calibrate", "cal.h5")])
def test_full_disk_while_writing_is_one_line(
    series: Path, tmp_path: Path, command: str, output: str
) -> None:
    """A real full file system: a 64 KiB tmpfs (the calibration is ~80 KB, the phase maps
    ~260 KB), mounted in a private namespace. ENOSPC (the HDF5 file written by Python, the
    TIFFs by numpy's short write) is one line naming the output; nothing partial is left and
    the previous output (a small file or folder, ``--force``) is untouched."""
    source = series / "S" if command == "calibrate" else series / "S" / "white_plate_010.00mm"
    mount = tmp_path / "small"
    mount.mkdir()
    target = mount / output
    make_previous = (
        f"mkdir {target} && echo previous > {target}/mine.txt"
        if command == "phase"
        else f"echo previous > {target}"
    )
    cli = " ".join([*CLI, command, str(source), "-o", str(target), "--force"])
    kept = target / "mine.txt" if command == "phase" else target
    res = _tiny_tmpfs_child(f"{make_previous} && {cli}", mount, kept, tmp_path)
    line = _one_error_line(res)
    assert line.startswith(f"error: {target}: cannot write: No space left on device"), line
    assert "(errno ENOSPC); free space on that disk or write elsewhere" in line, line
    left, previous = res.stdout.split("LEFT:")[1].split("KEPT:")
    assert left.split() == [output]  # no staging file or folder
    assert previous.strip() == "previous"
