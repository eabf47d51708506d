"""``conftest.run_cli_in_process`` reports what a real ``python -m hdrfringe.cli`` process would.

The fuzz suite runs its cases in-process; these tests keep that honest: the same exit code and
stderr as a subprocess on a bad input and on success, and the failures the fuzz suite must
catch (an escaping exception's traceback, a warning on stderr) are visible in its result.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from hdrfringe.errors import InputError
from tests.conftest import run_cli_in_process, run_cli_subprocess


def test_a_bad_input_gives_what_the_process_gives(tmp_path: Path) -> None:
    """Against a real process (run_cli runs in process too); in process twice: the second call
    reuses the click commands the first built (conftest's _built_command)."""
    cases = [
        ("phase", str(tmp_path / "missing"), "-o", str(tmp_path / "o1")),
        ("patterns", "-o", str(tmp_path / "o2"), "--pitch", "nan"),
    ]
    for args in cases:
        real = run_cli_subprocess(*args)
        for _ in range(2):
            ours = run_cli_in_process(*args)
            assert (ours.returncode, ours.stderr, ours.stdout) == (
                real.returncode,
                real.stderr,
                real.stdout,
            ), args
            assert ours.returncode == 2 and ours.stderr.startswith("error:")


def test_success_gives_what_the_process_gives(capture_folder: Path, tmp_path: Path) -> None:
    real = run_cli_subprocess("phase", str(capture_folder), "-o", str(tmp_path / "real"))
    assert real.returncode == 0, real.stderr
    # output folders named as long as "real": the console wraps a long path at its width, at
    # the same place only for paths of one length (under xdist the temporary path is long)
    for out in ("ours", "our2"):  # our2: with the commands built for ours (_built_command)
        ours = run_cli_in_process("phase", str(capture_folder), "-o", str(tmp_path / out))
        assert ours.returncode == 0, ours.stderr
        # (and a path longer than the width is broken across lines: joined before the compare)
        assert ours.stdout.replace("\n", "").replace(
            str(tmp_path / out), "OUT"
        ) == real.stdout.replace("\n", "").replace(str(tmp_path / "real"), "OUT")
        assert ours.stderr == real.stderr == ""


def test_an_escaping_exception_is_a_traceback_and_exit_1(
    capture_folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(*_: object, **__: object) -> None:
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr("hdrfringe.io.captures.read_capture_folder", broken)
    res = run_cli_in_process("phase", str(capture_folder), "-o", str(tmp_path / "out"))
    assert res.returncode == 1
    assert res.stderr.startswith("Traceback (most recent call last):")
    assert res.stderr.rstrip().endswith("ZeroDivisionError: a bug")


def test_a_warning_reaches_stderr(
    capture_folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def noisy(*_: object, **__: object) -> None:
        warnings.warn("invalid value encountered", RuntimeWarning, stacklevel=1)
        raise InputError("bad input: fix it")

    monkeypatch.setattr("hdrfringe.io.captures.read_capture_folder", noisy)
    res = run_cli_in_process("phase", str(capture_folder), "-o", str(tmp_path / "out"))
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert res.returncode == 2 and lines[0] == "error: bad input: fix it"
    assert any("RuntimeWarning: invalid value encountered" in ln for ln in lines[1:]), lines


def test_tables_are_not_cut_to_80_columns_when_stdout_is_a_pipe() -> None:
    """Piped to a file or CI log, rich would take 80 columns and cut the demo's tables to
    ellipses ("DPA 10 % + bo…"); the command line's console takes ``PIPE_WIDTH`` there, and
    ``COLUMNS`` still sets the width (a plain ``Console()`` gives 80 and fails)."""
    code = "from hdrfringe.cli._app import PIPE_WIDTH, console; print(console.width, PIPE_WIDTH)"
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
    res = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60
    )
    width, pipe_width = map(int, res.stdout.split())
    assert width == pipe_width >= 120
    env["COLUMNS"] = "100"
    res = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60
    )
    assert int(res.stdout.split()[0]) == 100
