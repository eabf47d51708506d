"""Output safety (issue 11): no command may destroy its inputs, a user's folder or a concurrent
run's result; unwritable targets are refused before the work; signals clean up (docs/safety.md).
"""

from __future__ import annotations

import hashlib
import os
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.frames import CenterlineFrame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError, OutputExistsError
from hdrfringe.io.captures import write_capture_folder
from hdrfringe.io.results import (
    SIGTERM_EXIT_CODE,
    InterruptedAfterWriting,
    StoppedAfterWriting,
    check_output_against_inputs,
    check_output_dir,
    check_output_file,
    rename_noreplace,
    staged_output_dir,
    staged_output_file,
)
from tests.conftest import synthetic_set, without_dac_override

CLI = [sys.executable, "-m", "hdrfringe.cli"]


def _tiny_caps(path: Path) -> Path:
    """A valid 4-step capture folder of 8 x 16 pixels with a centerline (fast to measure)."""
    spec = FringeSpec("sinusoidal", 4, 8.0, "vertical", 40, 255)
    imgs, x = synthetic_set(spec, (8, 16))
    line = np.where(np.abs(x - 10.0) < 0.5, 230, 10).astype(np.uint8)
    frames = [*spec.frames(), CenterlineFrame(10.0, "vertical", 255)]
    caps = Captures(
        frames,
        np.concatenate([imgs, line[None]]),
        8,
        projector=ProjectorInfo(1024, 768, 8, 2.812),
        scene={"depth_mm": 0.0},
    )
    write_capture_folder(path, caps)
    return path


@pytest.fixture
def caps(tmp_path: Path) -> Path:
    return _tiny_caps(tmp_path / "caps")


def _hashes(root: Path) -> dict[str, str]:
    """Every file and folder below ``root`` (relative path -> content hash or 'dir')."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = str(p.relative_to(root))
        out[rel] = "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def _run(*args: str, cwd: Path | None = None, **kw: object) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=120, cwd=cwd, **kw)  # type: ignore[call-overload]


def _one_line_error(res: subprocess.CompletedProcess, code: int = 2) -> str:
    assert res.returncode == code, (res.returncode, res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("error:"), lines[0]
    return lines[0]


def _staging_left(folder: Path) -> list[str]:
    return [p.name for p in folder.iterdir() if ".staging-" in p.name or ".old-" in p.name]


# ------------------------------------------------------------------------------------------
# 1. an output that is, contains or lies inside an input
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["phase", "measure"])
@pytest.mark.parametrize("variant", ["same", "inside", "parent", "dotdot", "symlink"])
def test_output_overlapping_the_input_is_refused(
    command: str, variant: str, caps: Path, tmp_path: Path
) -> None:
    link = tmp_path / "link"
    link.symlink_to(caps, target_is_directory=True)
    output = {
        "same": str(caps),
        "inside": str(caps / "sub"),
        "parent": str(tmp_path),
        "dotdot": str(caps / ".." / "caps"),
        "symlink": str(link),
    }[variant]
    before = _hashes(tmp_path)
    line = _one_line_error(_run(command, str(caps), "-o", output, "--force"))
    assert output in line and str(caps) in line, line
    assert _hashes(tmp_path) == before


@pytest.mark.parametrize("command", ["gamma", "modify", "train-correction", "calibrate"])
def test_other_commands_refuse_an_output_inside_the_input(
    command: str, caps: Path, tmp_path: Path
) -> None:
    output = caps / "out.json" if command in ("train-correction", "calibrate") else caps
    before = _hashes(tmp_path)
    line = _one_line_error(_run(command, str(caps), "-o", str(output), "--force"))
    assert str(caps) in line, line
    assert _hashes(tmp_path) == before


def test_measure_refuses_its_calibration_file_as_output(caps: Path, tmp_path: Path) -> None:
    cal = tmp_path / "cal.h5"
    cal.write_bytes(b"not read: refused first")
    before = _hashes(tmp_path)
    res = _run("measure", str(caps), "-o", str(cal), "--calibration", str(cal), "--force")
    line = _one_line_error(res)
    assert "is the input" in line, line
    assert _hashes(tmp_path) == before


def test_check_output_against_inputs_cases(tmp_path: Path) -> None:
    a = tmp_path / "a"
    check_output_against_inputs(tmp_path / "ab", [a, None])  # a name prefix is not inside
    check_output_against_inputs(tmp_path / "b", [a, tmp_path / "c.json"])
    for bad in (a, a / "x" / "y", tmp_path, tmp_path / "b" / ".." / "a"):
        with pytest.raises(InputError, match="output"):
            check_output_against_inputs(bad, [a])


# ------------------------------------------------------------------------------------------
# 2. the final swap replaces only what was checked
# ------------------------------------------------------------------------------------------
def test_rename_noreplace_refuses_an_empty_folder(tmp_path: Path) -> None:
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "f").write_text("new")
    (tmp_path / "dst").mkdir()  # os.rename would silently replace this empty folder
    with pytest.raises(FileExistsError):
        rename_noreplace(tmp_path / "src", tmp_path / "dst")
    assert (tmp_path / "src" / "f").read_text() == "new"


@pytest.mark.parametrize("force", [False, True])
def test_folder_appearing_while_writing_is_untouched(tmp_path: Path, force: bool) -> None:
    out = check_output_dir(tmp_path / "out", force)  # the command's check at start: nothing there
    with pytest.raises(OutputExistsError, match="while this run was writing"):
        with staged_output_dir(out, force=force) as tmp:
            (tmp / "result.txt").write_text("ours")
            out.mkdir()
            (out / "user.txt").write_text("the user's")
    assert sorted(p.name for p in out.iterdir()) == ["user.txt"]
    assert (out / "user.txt").read_text() == "the user's"
    assert _staging_left(tmp_path) == []


def test_force_replaces_only_the_folder_checked(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old result")
    out = check_output_dir(out, True)
    out.rename(tmp_path / "moved")  # swapped for another folder during the run
    out.mkdir()
    (out / "user.txt").write_text("the user's")
    with pytest.raises(OutputExistsError, match="created or replaced"):
        with staged_output_dir(out, force=True) as tmp:
            (tmp / "result.txt").write_text("ours")
    assert (out / "user.txt").read_text() == "the user's"
    assert _staging_left(tmp_path) == []
    # and the folder that was checked is replaced
    out = check_output_dir(out, True)
    with staged_output_dir(out, force=True) as tmp:
        (tmp / "result.txt").write_text("ours")
    assert sorted(p.name for p in out.iterdir()) == ["result.txt"]
    assert _staging_left(tmp_path) == []


def test_empty_folder_filled_while_writing_is_untouched(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    out = check_output_dir(out, False)  # an empty folder is accepted without --force
    with pytest.raises(OutputExistsError, match="files appeared"):
        with staged_output_dir(out, force=False) as tmp:
            (tmp / "result.txt").write_text("ours")
            (out / "user.txt").write_text("the user's")
    assert sorted(p.name for p in out.iterdir()) == ["user.txt"]


_RACE_DRIVER = textwrap.dedent(
    """
    import os, random, sys, time
    from pathlib import Path
    import hdrfringe.io.results as results
    import hdrfringe.tasks.measure, hdrfringe.io.phase_maps
    from hdrfringe.cli import app
    import matplotlib.pyplot, tifffile  # loaded once, before the forks

    caps, root, rounds = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3])
    devnull = os.open(os.devnull, os.O_WRONLY)
    checked_r, checked_w = os.pipe()
    go_r, go_w = os.pipe()
    original_check = results.check_output_dir

    def check_then_wait(path, force):  # both runs check before either goes on: they overlap
        try:
            return original_check(path, force)
        finally:
            os.write(checked_w, b"c")
            os.read(go_r, 1)

    results.check_output_dir = check_then_wait

    def small_preview(path, data, **kwargs):  # the staging logic is under test, not matplotlib
        Path(path).write_bytes(b"preview")

    for module in (sys.modules["hdrfringe.tasks.measure"],
                   sys.modules["hdrfringe.io.phase_maps"]):
        if hasattr(module, "write_preview_png"):
            module.write_preview_png = small_preview

    def child(out, force):
        os.dup2(devnull, 1); os.dup2(devnull, 2)
        args = ["measure", str(caps), "-o", str(out)] + (["--force"] if force else [])
        try:
            app(args, prog_name="hdrfringe")
            code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        os._exit(code)

    random.seed(1)
    for i in range(rounds):
        out = root / f"out{i}"
        force = i % 4 == 3
        user = i % 2 == 1  # odd rounds: a user's folder (with a file) appears mid-run
        pids = []
        for _ in range(2):
            pid = os.fork()
            if pid == 0:
                child(out, force)
            pids.append(pid)
        made = False
        assert len(os.read(checked_r, 1) + os.read(checked_r, 1)) == 2  # both checked
        os.write(go_w, b"gg")
        if user:
            time.sleep(random.uniform(0.0, 0.3))
            side = root / f"side{i}"
            side.mkdir()
            (side / "user.txt").write_text(f"user {i}")
            try:
                os.rename(side, out)  # appears whole, with its file; fails if out is there
                made = True
            except OSError:
                (side / "user.txt").unlink(); side.rmdir()
        codes = [os.waitstatus_to_exitcode(os.waitpid(p, 0)[1]) for p in pids]
        print(i, int(force), int(made), *codes, flush=True)
    """
)


def test_two_concurrent_measures_never_both_succeed(caps: Path, tmp_path: Path) -> None:
    """10 rounds of two ``measure`` runs to one output (forked from one driver started with
    Popen, so the imports are paid once); in odd rounds a user's folder appears mid-run."""
    root = tmp_path / "race"
    root.mkdir()
    driver = tmp_path / "race.py"
    driver.write_text(_RACE_DRIVER)
    proc = subprocess.Popen(
        [sys.executable, str(driver), str(caps), str(root), "10"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    stdout, stderr = proc.communicate(timeout=240)
    assert proc.returncode == 0, stderr
    rows = [list(map(int, ln.split())) for ln in stdout.splitlines()]
    assert len(rows) == 10, stdout
    for i, _force, made, a, b in rows:
        out = root / f"out{i}"
        assert {a, b} <= {0, 2}, rows
        assert not (a == 0 and b == 0), f"round {i}: both runs succeeded"
        if made:  # the user's folder was created before either run finished: untouched
            assert a == 2 and b == 2, f"round {i}: a run succeeded over the user's folder"
            assert sorted(p.name for p in out.iterdir()) == ["user.txt"]
            assert (out / "user.txt").read_text() == f"user {i}"
        else:
            assert 0 in (a, b), f"round {i}: neither run succeeded"
            assert (out / "metrics.json").is_file()
    assert _staging_left(root) == []


# ------------------------------------------------------------------------------------------
# 3. writability checked before the work
# ------------------------------------------------------------------------------------------
def test_parent_is_a_file(caps: Path, tmp_path: Path) -> None:
    (tmp_path / "afile").write_text("x")
    line = _one_line_error(_run("phase", str(caps), "-o", str(tmp_path / "afile" / "out")))
    assert "is a file" in line, line
    assert (tmp_path / "afile").read_text() == "x"


def test_working_directory_as_output(caps: Path, tmp_path: Path) -> None:
    work = tmp_path / "work"
    work.mkdir()
    (work / "keep.txt").write_text("mine")
    line = _one_line_error(_run("measure", str(caps), "-o", ".", "--force", cwd=work))
    assert "working directory" in line, line
    assert sorted(p.name for p in work.iterdir()) == ["keep.txt"]
    assert _staging_left(tmp_path) == []


@pytest.mark.parametrize("command", ["phase", "calibrate"])
def test_read_only_parent_refused_before_the_work(command: str, tmp_path: Path) -> None:
    prefix = without_dac_override()
    caps = _tiny_caps(tmp_path / "caps")
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o555)
    ro.chmod(0o555)
    out = ro / ("cal.h5" if command == "calibrate" else "out")
    try:
        # calibrate with one plate position would fail in the computation: the error must be
        # the unwritable target, found first
        res = subprocess.run(
            [*prefix, *CLI, command, str(caps), "-o", str(out)],
            capture_output=True,
            text=True,
            timeout=120,
            cwd=tmp_path,
        )
        line = _one_line_error(res)
        assert "cannot write" in line, line
        assert list(ro.iterdir()) == []
        assert _staging_left(tmp_path) == []
    finally:
        ro.chmod(0o755)  # pytest removes tmp_path afterwards


def test_immutable_parent_refused(caps: Path, tmp_path: Path) -> None:
    ro = tmp_path / "immutable"
    ro.mkdir()
    subprocess.run(["chattr", "+i", str(ro)], check=True)
    try:
        line = _one_line_error(_run("phase", str(caps), "-o", str(ro / "out")))
        assert "cannot write" in line, line
    finally:
        subprocess.run(["chattr", "-i", str(ro)], check=True)
    assert list(ro.iterdir()) == []


# ------------------------------------------------------------------------------------------
# 4. SIGTERM and SIGKILL while staging
# ------------------------------------------------------------------------------------------
_SLOW_PHASE = textwrap.dedent(
    """
    import sys, time
    import hdrfringe.io.phase_maps as pm
    from hdrfringe.cli import app

    original = pm.write_phase_maps

    def slow(*args, **kwargs):
        summary = original(*args, **kwargs)
        print("staged", flush=True)
        time.sleep(60)
        return summary

    pm.write_phase_maps = slow
    app(sys.argv[1:], prog_name="hdrfringe")
    """
)


def _start_slow_phase(caps: Path, out: Path, tmp_path: Path) -> subprocess.Popen:
    driver = tmp_path / "slow_phase.py"
    driver.write_text(_SLOW_PHASE)
    proc = subprocess.Popen(
        [sys.executable, str(driver), "phase", str(caps), "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "staged", proc.stderr.read() if proc.stderr else ""
    return proc


def test_sigterm_removes_the_staging_folder(caps: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    proc = _start_slow_phase(caps, out, tmp_path)
    assert len(_staging_left(tmp_path)) == 1
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == SIGTERM_EXIT_CODE
    assert not out.exists()
    assert _staging_left(tmp_path) == []


def test_staging_of_a_killed_run_is_removed_by_the_next_run(caps: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    proc = _start_slow_phase(caps, out, tmp_path)
    proc.kill()
    proc.wait(timeout=30)
    assert len(_staging_left(tmp_path)) == 1  # SIGKILL cannot be handled
    res = _run("phase", str(caps), "-o", str(out))
    assert res.returncode == 0, res.stderr
    assert (out / "phase_summary.json").is_file()
    assert _staging_left(tmp_path) == []


def test_staging_of_a_live_run_is_reported(caps: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    live = tmp_path / f".out.staging-{os.getpid()}-abc123"  # this test process is alive
    live.mkdir()
    line = _one_line_error(_run("phase", str(caps), "-o", str(out)))
    assert f"PID {os.getpid()}" in line, line
    assert live.is_dir() and not out.exists()


def _signal_in_the_rename(monkeypatch: pytest.MonkeyPatch, signum: int, name: str) -> None:
    """The final move's rename (``name``: ``rename_noreplace`` of a folder, ``os.link``/
    ``os.replace`` of a file) receives ``signum`` as it starts: in this process, at that very
    point (no timer), then renames."""
    import hdrfringe.io.results as results

    owner = results if name == "rename_noreplace" else os
    original = getattr(owner, name)

    def signalled(*args: object) -> None:
        os.kill(os.getpid(), signum)  # held (deferred_signals) until the move is done
        original(*args)

    monkeypatch.setattr(owner, name, signalled)


@pytest.mark.usefixtures("stop_signals_not_ignored")
@pytest.mark.parametrize(
    ("signum", "stop"), [(signal.SIGTERM, SystemExit), (signal.SIGINT, KeyboardInterrupt)]
)
@pytest.mark.parametrize(
    ("stage", "rename", "force"),
    [
        (staged_output_dir, "rename_noreplace", False),
        (staged_output_file, "link", False),
        (staged_output_file, "replace", True),
    ],
)
def test_signal_in_the_final_move_says_the_output_is_in_place(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, signum: int, stop: type, stage, rename, force
) -> None:
    """A signal during the renames is honoured after them (143, 130) with the output complete:
    the stop carries the output's path, so the command does not say "nothing was written"."""
    target = tmp_path / "out"
    if force:
        target.write_text("previous")
    _signal_in_the_rename(monkeypatch, signum, rename)
    with pytest.raises(stop) as info, stage(target, force=force) as tmp:
        if tmp.is_dir():
            (tmp / "a.txt").write_text("complete")
        else:
            tmp.write_text("complete")
    assert isinstance(info.value, (StoppedAfterWriting, InterruptedAfterWriting))
    assert info.value.written == target and info.value.exit_code == 128 + signum
    written = target / "a.txt" if stage is staged_output_dir else target
    assert written.read_text() == "complete"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging, no backup


@pytest.mark.usefixtures("stop_signals_not_ignored")
@pytest.mark.parametrize(
    ("signum", "said"), [(signal.SIGTERM, "stopped by SIGTERM"), (signal.SIGINT, "interrupted")]
)
def test_command_stopped_in_its_final_move_names_the_complete_output(
    caps: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, signum: int, said: str
) -> None:
    """``phase`` stopped by a signal in its final move: the signal's exit code and one line
    saying where the complete output is (it said "nothing was written" with the output in
    place); a signal before the move still says nothing was written."""
    from tests.conftest import run_cli_in_process

    out = tmp_path / "out"
    _signal_in_the_rename(monkeypatch, signum, "rename_noreplace")
    res = run_cli_in_process("phase", str(caps), "-o", str(out), "--no-previews")
    assert res.returncode == 128 + signum, res.stderr
    assert res.stderr.split() == (
        f"{said} once the output was in place: the complete output is at {out}"
    ).split()
    assert "Traceback" not in res.stderr
    assert (out / "phase_summary.json").is_file() and _staging_left(tmp_path) == []


# ------------------------------------------------------------------------------------------
# 5. SIGINT during calibrate's HDF5 save
# ------------------------------------------------------------------------------------------
_SLOW_SAVE = textwrap.dedent(
    """
    import signal, sys, time
    # a shell that starts jobs in the background hands them SIGINT ignored: restore the
    # terminal's default, under which Ctrl-C raises KeyboardInterrupt
    signal.signal(signal.SIGINT, signal.default_int_handler)
    import numpy as np
    import hdrfringe.tasks.calibrate as cf
    import hdrfringe.io.calibration_file as calfile
    from hdrfringe.core.calibration import Calibration
    from hdrfringe.cli import app

    cal = Calibration("linear", np.full((30, 30), 0.5), None, np.zeros((30, 30)),
                      np.array([2.0, 4.0]), provenance={"test": "sigint"})
    cf.expand_capture_dirs = lambda folders: list(folders)
    cf.calibrate_folders = lambda folders, **kwargs: cal
    original = calfile._write

    def slow(f, c):
        original(f, c)
        print("saving", flush=True)
        time.sleep(1.5)

    calfile._write = slow
    app(sys.argv[1:], prog_name="hdrfringe")
    """
)


def test_sigint_during_calibration_save(caps: Path, tmp_path: Path) -> None:
    driver = tmp_path / "slow_save.py"
    driver.write_text(_SLOW_SAVE)
    out = tmp_path / "cals" / "cal.h5"
    out.parent.mkdir()
    proc = subprocess.Popen(
        [sys.executable, str(driver), "calibrate", str(caps), "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None and proc.stderr is not None
    assert proc.stdout.readline().strip() == "saving", proc.stderr.read()
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=30) == 130, proc.stderr.read()
    assert "Traceback" not in proc.stderr.read()
    assert list(out.parent.iterdir()) == []


# ------------------------------------------------------------------------------------------
# 6. modes follow the umask
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("umask", "dir_mode", "file_mode"), [(0o022, 0o755, 0o644), (0o027, 0o750, 0o640)]
)
def test_output_modes_follow_the_umask(
    caps: Path, tmp_path: Path, umask: int, dir_mode: int, file_mode: int
) -> None:
    out = tmp_path / "out"
    res = _run("phase", str(caps), "-o", str(out), umask=umask)
    assert res.returncode == 0, res.stderr
    assert stat.S_IMODE(out.stat().st_mode) == dir_mode
    for f in out.iterdir():
        assert stat.S_IMODE(f.stat().st_mode) == file_mode, f
    from hdrfringe.core.calibration import Calibration
    from hdrfringe.io.calibration_file import save_calibration

    cal = Calibration("linear", np.full((30, 30), 0.5), None, np.zeros((30, 30)), np.array([2.0]))
    old = os.umask(umask)
    try:
        path = save_calibration(tmp_path / "cal.h5", cal)
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == file_mode


def test_sigterm_handler_is_restored(tmp_path: Path) -> None:
    before = signal.getsignal(signal.SIGTERM)
    with staged_output_dir(tmp_path / "x") as tmp:
        (tmp / "a").write_text("a")
        assert signal.getsignal(signal.SIGTERM) is not before
    assert signal.getsignal(signal.SIGTERM) is before
    time.sleep(0)


# ------------------------------------------------------------------------------------------
# 7. what was checked travels with the output path: no state shared between writers
# ------------------------------------------------------------------------------------------
def test_two_writers_in_one_process_do_not_share_state(tmp_path: Path) -> None:
    """Two ``--force`` writers checked the same folder; the first replaces it. The second
    must be refused (it would replace a result it never checked), whatever the first did.
    With a module-level record the first writer's use dropped the second's record, which was
    then re-taken on entry and the first result silently replaced."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old result")
    first, second = check_output_dir(out, True), check_output_dir(out, True)
    with staged_output_dir(first, force=True) as tmp:
        (tmp / "result.txt").write_text("first")
    with pytest.raises(OutputExistsError, match="created or replaced"):
        with staged_output_dir(second, force=True) as tmp:
            (tmp / "result.txt").write_text("second")
    assert (out / "result.txt").read_text() == "first"
    assert _staging_left(tmp_path) == []


def test_an_unused_check_leaves_nothing_behind(tmp_path: Path) -> None:
    """A check whose writer never ran (the command failed in between) must not bind a later,
    unrelated write to the same path in the same session (a stale module-level record did:
    this ``force`` write was refused because of a check made before the folder existed)."""
    out = tmp_path / "out"
    check_output_dir(out, False)  # nothing there; its writer never runs
    out.mkdir()
    (out / "old.txt").write_text("made later")
    with staged_output_dir(out, force=True) as tmp:  # a plain path: checked on entry
        (tmp / "result.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == ["result.txt"]


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def _killed_replace(tmp_path: Path, *, target: bool, staging: bool) -> tuple[Path, Path]:
    """What a ``--force`` replace killed between its two renames leaves beside ``out``."""
    pid = _dead_pid()
    out = tmp_path / "out"
    old = tmp_path / f".out.old-{pid}-abc123"
    old.mkdir()
    (old / "result.txt").write_text("previous output")
    if staging:
        stage = tmp_path / f".out.staging-{pid}-def456"
        stage.mkdir()
        (stage / "result.txt").write_text("complete new output")
    if target:
        out.mkdir()
        (out / "result.txt").write_text("in place")
    return out, old


def test_previous_output_of_a_killed_replace_is_moved_back(tmp_path: Path) -> None:
    out, _ = _killed_replace(tmp_path, target=False, staging=True)
    with pytest.raises(OutputExistsError, match="not empty"):  # restored first, then judged
        check_output_dir(out, False)
    assert (out / "result.txt").read_text() == "previous output"
    assert _staging_left(tmp_path) == []


def test_previous_output_of_a_completed_replace_is_removed(tmp_path: Path) -> None:
    out, old = _killed_replace(tmp_path, target=True, staging=False)
    assert old.is_dir()
    check_output_dir(out, True)
    assert (out / "result.txt").read_text() == "in place"
    assert _staging_left(tmp_path) == []


def test_previous_output_is_reported_when_the_output_was_made_again(tmp_path: Path) -> None:
    out, old = _killed_replace(tmp_path, target=True, staging=True)
    with pytest.raises(OutputExistsError, match=old.name):
        check_output_dir(out, True)
    assert (old / "result.txt").read_text() == "previous output"  # never the only copy
    assert (out / "result.txt").read_text() == "in place"


def test_killed_force_replace_is_recovered_by_the_next_command(caps: Path, tmp_path: Path) -> None:
    """The command line: a rerun without --force finds the old output back in place and
    refuses to replace it; with --force it replaces it and leaves nothing beside it."""
    out, _ = _killed_replace(tmp_path, target=False, staging=True)
    line = _one_line_error(_run("phase", str(caps), "-o", str(out)))
    assert "not empty" in line, line
    assert (out / "result.txt").read_text() == "previous output"
    res = _run("phase", str(caps), "-o", str(out), "--force")
    assert res.returncode == 0, res.stderr
    assert (out / "phase_summary.json").is_file() and not (out / "result.txt").exists()
    assert _staging_left(tmp_path) == []


# ------------------------------------------------------------------------------------------
# 8. single files: atomic, refused when present, replaced only as checked
# ------------------------------------------------------------------------------------------
def test_file_appearing_while_writing_is_untouched(tmp_path: Path) -> None:
    for force in (False, True):
        out = check_output_file(tmp_path / f"k{force}.json", force)
        with pytest.raises(OutputExistsError, match="while this run was writing"):
            with staged_output_file(out, force=force) as tmp:
                tmp.write_text("ours")
                Path(out).write_text("the user's")
        assert Path(out).read_text() == "the user's"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


_FAILING_WRITE = textwrap.dedent(
    """
    import pathlib, sys
    from hdrfringe.cli import app

    original = pathlib.Path.write_text

    def half_then_full_disk(self, data, *args, **kwargs):  # ENOSPC half-way through the JSON
        if self.name.endswith(".tmp") or self.suffix == ".json":
            original(self, data[: len(data) // 2], *args, **kwargs)
            raise OSError(28, "No space left on device")
        return original(self, data, *args, **kwargs)

    pathlib.Path.write_text = half_then_full_disk
    app(sys.argv[1:], prog_name="hdrfringe")
    """
)


def test_train_correction_replaces_its_file_atomically(tmp_path: Path) -> None:
    """A write that fails half-way (disk full) must leave the existing file intact (it was
    truncated and half-written when the JSON went straight to the target). The training
    folder is a small step-1 MIGL sweep (64x48 camera, the thesis's 600 lx and 20 px pitch), so
    the two trainings take about a second each."""
    sweep = tmp_path / "sweep"
    made = _run(
        "simulate", "white_plate", "--migl-sweep", "255:60:1", "--resolution", "64x48",
        "--pitch", "20", "--steps", "4", "--ambient-lux", "600", "-o", str(sweep),
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    out = tmp_path / "corr.json"
    out.write_text('{"previous": "polynomial"}\n')
    driver = tmp_path / "failing_write.py"
    driver.write_text(_FAILING_WRITE)
    res = subprocess.run(
        [sys.executable, str(driver), "train-correction", str(sweep), "-o", str(out), "--force"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode != 0
    assert out.read_text() == '{"previous": "polynomial"}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["corr.json", "failing_write.py", "sweep"]
    ok = _run("train-correction", str(sweep), "-o", str(out), "--force")
    assert ok.returncode == 0, ok.stderr
    assert '"coefficients"' in out.read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["corr.json", "failing_write.py", "sweep"]
