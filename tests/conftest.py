"""Shared fixtures: synthetic capture folders (analytic fringes, no rig) and the real-data path."""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import signal
import subprocess
import sys
import traceback
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.frames import CenterlineFrame
from hdrfringe.core.patterns import FringeSpec, fringe_gray
from hdrfringe.io.captures import write_capture_folder

REALDATA = Path(__file__).resolve().parents[2] / "shared" / "realdata"
#: ``measure --depth-range`` of the thomriiii board, mm: it stands 611-711 mm from the camera
#: (tests/test_geometric_order_realdata.py measures it); the range leaves room.
THOMRIIII_DEPTH_RANGE = "550:800"


def realdata_path(*parts: str) -> Path:
    """Path inside ../shared/realdata; skips the test cleanly when it is absent."""
    p = REALDATA.joinpath(*parts)
    if not p.exists():
        pytest.skip(f"real data not available: {p}")
    return p


def synthetic_set(
    spec: FringeSpec,
    shape: tuple[int, int] = (48, 64),
    *,
    x0: float = 3.3,
    slope: float = 0.71,
    offset: float = 20.0,
    gain: float = 0.8,
    bit_depth: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """Images of a set seen by an ideal camera: projector x = x0 + slope*col (+ small row term)."""
    h, w = shape
    rows, cols = np.mgrid[0:h, 0:w]
    x = x0 + slope * cols + 0.05 * rows
    imgs = np.stack([offset + gain * fringe_gray(x, spec, k) for k in range(spec.steps)])
    full = 2**bit_depth - 1
    return np.clip(np.rint(imgs), 0, full).astype(np.uint8 if bit_depth <= 8 else np.uint16), x


@pytest.fixture
def capture_folder(tmp_path: Path) -> Path:
    """A valid 4-step capture folder with a centerline frame."""
    spec = FringeSpec("sinusoidal", 4, 8.0, "vertical", 40, 255)
    imgs, x = synthetic_set(spec)
    # centerline at projector x = 20: a bright column where x is nearest 20
    line = np.where(np.abs(x - 20.0) < 0.5, 230, 10).astype(np.uint8)
    frames = [*spec.frames(), CenterlineFrame(20.0, "vertical", 255)]
    path = tmp_path / "caps"
    write_capture_folder(
        path,
        Captures(
            frames,
            np.concatenate([imgs, line[None]]),
            8,
            projector=ProjectorInfo(1024, 768, 8, 2.812),
            scene={"depth_mm": 0.0},
        ),
    )
    return path


def run_cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run the command line through its entry point in this process and return what the
    process would have given (:func:`run_cli_in_process`: exit code, stdout, stderr, a
    traceback as the interpreter prints it, warnings under a fresh interpreter's filters).

    A new interpreter per call pays the imports again: ``make test``'s first run took 7:26
    with a subprocess per call and 6:33 in process on the 2-core machine, every test passing
    both ways. ``timeout`` is accepted for the callers and not applied (a command
    that hangs hangs the test). Tests of the process itself (signals, a terminal, the
    environment, concurrent runs, privileges, lazy imports) start their own processes, or use
    :func:`run_cli_subprocess`.
    """
    del timeout
    return run_cli_in_process(*args)


def run_cli_subprocess(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run the installed command line in a new interpreter (as a user would)."""
    return subprocess.run(
        [sys.executable, "-m", "hdrfringe.cli", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


#: A fresh interpreter's warning filters (``python -W`` not given): what a user's process shows.
_PYTHON_DEFAULT_FILTERS = (
    ("default", DeprecationWarning, "__main__"),
    ("ignore", DeprecationWarning, ""),
    ("ignore", PendingDeprecationWarning, ""),
    ("ignore", ImportWarning, ""),
    ("ignore", ResourceWarning, ""),
)


def _child_console_width(pipe_width: int) -> int:
    """The width ``hdrfringe.cli._app.console`` takes in a child process of this one, whose
    standard output is a pipe: ``COLUMNS`` as the C library's environment holds it, else
    ``pipe_width``."""
    import ctypes

    getenv = ctypes.CDLL(None).getenv
    getenv.restype = ctypes.c_char_p
    value = getenv(b"COLUMNS")
    return int(value) if value else pipe_width


#: The click commands typer built from ``hdrfringe.cli.app``'s registered commands, by the
#: registration (id -> (CommandInfo, typer's options, command)): see :func:`_built_command`.
_BUILT_COMMANDS: dict[int, tuple[object, tuple[tuple[str, object], ...], object]] = {}


def _built_command(build: object) -> object:
    """``typer.main.get_command_from_info`` that builds each of the app's registered commands
    once per test process and returns that command after.

    ``app()`` (typer's ``Typer.__call__``) builds the click group and, in it, a click command
    from every registered command's signature, on every call; a process of the CLI does it
    once. Once a test process has imported every command's module that is about 30 ms per
    :func:`run_cli_in_process` call (874 calls in 21 of the CLI test modules: 15 s of CPU).
    The group is still made anew on every call (its lazily loaded commands, the plug-ins', are
    loaded anew); only the product's registered commands are reused, click commands being
    reusable (a context holds an invocation's state). A registration replaced or added (a
    command module imported later) is built on first use, as before. tests/test_cli_runner.py
    compares the output of both calls (built, reused) with a real process's."""

    def get_command_from_info(command_info: object, **options: object) -> object:
        from hdrfringe.cli import app

        key = tuple(sorted(options.items()))
        entry = _BUILT_COMMANDS.get(id(command_info))
        if entry is not None and entry[0] is command_info and entry[1] == key:
            return entry[2]
        command = build(command_info, **options)  # type: ignore[operator]
        if any(command_info is registered for registered in app.registered_commands):
            _BUILT_COMMANDS[id(command_info)] = (command_info, key, command)
        return command

    return get_command_from_info


def run_cli_in_process(*args: str) -> subprocess.CompletedProcess:
    """Run the command line in this process, through the entry point ``python -m hdrfringe.cli``
    calls (``hdrfringe.cli.app()``: typer's ``Typer.__call__``, click's standalone ``main``
    and its ``sys.exit``), and return what the process would have given.

    For tests of many bad inputs (the fuzz suite), where a new interpreter per case costs far more
    than the case: ``returncode`` is the ``SystemExit`` code, ``stdout``/``stderr`` what the
    command wrote there; an exception escaping the command is written to ``stderr`` as the
    interpreter would print it (``Traceback (most recent call last): ...``) with return code 1;
    warnings are shown on ``stderr`` under a fresh interpreter's filters (pytest's own capture
    would otherwise swallow them). Keep :func:`run_cli` for tests of signals, a real terminal
    or the process itself.
    """
    from unittest import mock

    import typer.main

    from hdrfringe.cli import _app, app

    out, err = io.StringIO(), io.StringIO()
    code: int = 0
    build = typer.main.get_command_from_info
    with (
        # each registered command's click command built once (_built_command)
        mock.patch.object(typer.main, "get_command_from_info", _built_command(build)),
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(err),
        warnings.catch_warnings(record=True) as shown,
        # rich picks a console's colours when it is made (here: when the test process imported
        # the CLI, maybe on a terminal under `pytest -s`); run_cli's process writes to pipes
        mock.patch.object(_app.console, "_color_system", None),
        mock.patch.object(_app.err_console, "_color_system", None),
        # and its width from its own environment: GNU readline, once imported here (pytest's
        # debugger support does), exports COLUMNS at the C level, which os.environ does not
        # show but a child process inherits (the console then takes it; else PIPE_WIDTH)
        mock.patch.object(_app.console, "_width", _child_console_width(_app.PIPE_WIDTH)),
    ):
        warnings.resetwarnings()
        for action, category, module in reversed(_PYTHON_DEFAULT_FILTERS):
            warnings.filterwarnings(action, category=category, module=module)  # type: ignore[arg-type]
        try:
            app(args=list(args), prog_name="python -m hdrfringe.cli")
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            if exc.code is not None and not isinstance(exc.code, int):
                print(exc.code, file=sys.stderr)  # as the interpreter does with sys.exit("text")
        except Exception as exc:  # what the interpreter prints for an uncaught exception
            err.write("".join(traceback.format_exception(exc)))
            code = 1
    for w in shown:
        err.write(warnings.formatwarning(w.message, w.category, w.filename, w.lineno, w.line))
    return subprocess.CompletedProcess(
        ["python", "-m", "hdrfringe.cli", *args], code, out.getvalue(), err.getvalue()
    )


@pytest.fixture(scope="session")  # once per xdist worker
def white_plate_series(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``hdrfringe simulate white_plate --series 0,4,8 --steps 3 --pitch 6``: three plate
    positions (a calibration series), simulated once and shared read-only by the modules
    that calibrate or measure from it (copy it before changing anything)."""
    root = tmp_path_factory.mktemp("plates") / "series"
    res = run_cli(
        "simulate", "white_plate", "-o", str(root), "--series", "0,4,8", "--steps", "3",
        "--pitch", "6",
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    return root


@pytest.fixture(scope="session")
def kimthyung_stereo(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The kimthyung sphere imported (docs/examples/import/kimthyung_sphere.toml) and its stereo
    calibration converted (``import`` -> ``calibrate-stereo --from``), once per worker. The
    modules that use it share the xdist group ``sphere-realdata``, so it is made once."""
    root = realdata_path("kimthyung_sphere")
    tmp = tmp_path_factory.mktemp("kimthyung")
    caps, cal = tmp / "caps", tmp / "s.h5"
    description = Path(__file__).resolve().parents[1] / "docs" / "examples" / "import"
    res = run_cli("import", str(root), "-d", str(description / "kimthyung_sphere.toml"), "-o",
                  str(caps))  # fmt: skip
    assert res.returncode == 0, res.stderr
    res = run_cli(
        "calibrate-stereo", "--from", str(root / "CalibrationDataDistortion"), "-o", str(cal)
    )
    assert res.returncode == 0, res.stderr
    return {"root": root, "caps": caps, "cal": cal, "tmp": tmp}


@pytest.fixture(scope="session")
def kimthyung_rows(kimthyung_stereo: dict) -> dict:
    """``measure --stereo-directions v`` of the kimthyung sphere (the rows carry its depth),
    once: the measurement the sphere, harmonics and direction-check tests compare with. No PNG
    previews and no report (none of them reads one; tests/test_report.py tests the report): at
    the sphere's 2.8 Mpx they cost about 2 s of the run."""
    out = kimthyung_stereo["tmp"] / "rows"
    res = run_cli(
        "measure", str(kimthyung_stereo["caps"]), "-c", str(kimthyung_stereo["cal"]),
        "--stereo-directions", "v", "--no-previews", "--no-report", "-o", str(out), timeout=600,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    return {**kimthyung_stereo, "out": out, "stdout": res.stdout}


@pytest.fixture(scope="session")
def kimthyung_sphere(kimthyung_rows: dict) -> dict:
    """The cloud of :func:`kimthyung_rows` (``xyz``), its wall (``plane``, ``far``:
    :func:`tests.test_sphere_realdata.wall_plane`) and the reference sphere (``fit``,
    ``n_region``, ``n_kept``: :func:`tests.test_sphere_realdata.sphere_fit`), once: the sphere
    test asserts them, tests/test_acceptance_realdata.py compares the acceptance quantities
    with them (xdist group ``sphere-realdata``)."""
    import tifffile

    from tests.test_sphere_realdata import sphere_fit, wall_plane

    xyz = tifffile.imread(kimthyung_rows["out"] / "xyz.tiff").astype(np.float64)
    plane, far = wall_plane(xyz)
    fit, n_region, n_kept = sphere_fit(xyz, plane)
    return {"xyz": xyz, "plane": plane, "far": far, "fit": fit, "n_region": n_region,
            "n_kept": n_kept}  # fmt: skip


def shared_once(
    tmp_path_factory: pytest.TempPathFactory, name: str, make: Callable[[Path], None]
) -> Path:
    """A folder ``make(folder)`` fills once for the whole run: under xdist the first worker to
    ask fills it in the run's shared temporary folder, holding a file lock, and the other
    worker waits for it and reuses it (pytest-xdist's documented pattern). Read-only for the
    callers (copy it before changing anything)."""
    import fcntl

    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):  # the workers' temporary folders share a parent
        base = base.parent
    shared = base / name
    shared.mkdir(exist_ok=True)
    with open(base / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed
        if not (base / f"{name}.done").exists():
            make(shared)
            (base / f"{name}.done").touch()
    return shared


@pytest.fixture(scope="session")
def kamino410_object1(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """kamino410 object1 imported (``import`` with docs/examples/import/kamino410_object1.toml),
    once for the whole run (:func:`shared_once`). Read-only for the tests: they measure and
    decode it into folders of their own (copy it before changing anything).
    tests/test_import_realdata.py imports it itself: that test is of the import."""
    root = realdata_path("kamino410", "object1")

    def make(shared: Path) -> None:
        description = Path(__file__).resolve().parents[1] / "docs" / "examples" / "import"
        res = run_cli("import", str(root), "-d", str(description / "kamino410_object1.toml"),
                      "-o", str(shared / "caps"), "--force")  # fmt: skip
        assert res.returncode == 0, res.stderr

    return shared_once(tmp_path_factory, "kamino410_object1", make) / "caps"


@pytest.fixture(scope="session")
def thomriiii_geometric(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The thomriiii checkerboard through the command line, the fringe order from the geometry
    (``import`` -> ``calibrate-stereo --from`` -> ``measure -c --depth-range 550:800
    --keep-saturated``), once per worker. The modules that use it
    (tests/test_geometric_order_realdata.py, the board of tests/test_acceptance_realdata.py)
    share the xdist group ``geometric-realdata``, so it is made once."""
    data = realdata_path("thomriiii", "dec2025_checkerboard_saturated_4step")
    calib = realdata_path("thomriiii", "calibration_dec2025")
    description = Path(__file__).resolve().parents[1] / "docs" / "examples" / "import"
    tmp = tmp_path_factory.mktemp("thomriiii")
    caps, cal, out = tmp / "caps", tmp / "s.h5", tmp / "out"
    for args in (
        ["import", str(data), "-d", str(description / "thomriiii_checkerboard.toml"), "-o",
         str(caps)],
        ["calibrate-stereo", "--from", str(calib), "-o", str(cal)],
    ):  # fmt: skip
        res = run_cli(*args)
        assert res.returncode == 0, res.stderr
    res = run_cli(
        "measure", str(caps), "-c", str(cal), "--depth-range", THOMRIIII_DEPTH_RANGE,
        "--keep-saturated", "--no-previews", "--no-uncertainty", "-o", str(out), timeout=600,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    return {"caps": caps, "calibration": cal, "out": out, "stdout": res.stdout}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Run a module whose tests share a module- or class-scoped fixture (a simulated
    measurement, a decoded real capture) on one xdist worker, so that the fixture is built once,
    not once on each worker (test_tradeoff's took 14.5 s on both). Tests that choose their group
    keep it; the quick reproduction's tests are grouped by research/tests/conftest.py."""
    for item in items:
        if item.get_closest_marker("xdist_group") is not None:
            continue
        if "quick_run" in getattr(item, "fixturenames", ()):
            continue
        if _uses_module_fixture(item):
            item.add_marker(pytest.mark.xdist_group(f"module:{item.nodeid.split('::')[0]}"))


def _uses_module_fixture(item: pytest.Item) -> bool:
    """Whether ``item`` uses a fixture of module, class or package scope."""
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return False
    return any(
        d.scope in ("module", "class", "package")
        for defs in info.name2fixturedefs.values()
        for d in defs
    )


_NO_TCP = ("-nolisten", "tcp")


@contextlib.contextmanager
def xvfb_display(width: int, height: int) -> Iterator[str]:
    """A private Xvfb server of one ``width`` x ``height`` screen (a free display number chosen
    by Xvfb itself); yields ``":N"`` and kills the server at the end. The hardware tests
    (projector window, loop camera, hardware rig) use it; without Xvfb they fail, not skip."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.fail(
            "Xvfb not found: these tests need an X server; run `make install` "
            "(or `apt-get install -y xvfb`)"
        )
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen(
        [xvfb, "-displayfd", str(write_fd), "-screen", "0", f"{width}x{height}x24", *_NO_TCP],
        pass_fds=(write_fd,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write_fd)
    try:
        with os.fdopen(read_fd) as pipe:
            number = pipe.readline().strip()
        if not number:
            pytest.fail(f"Xvfb exited with status {proc.wait(5)} before opening a display")
        yield f":{number}"
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


#: Root writes into read-only folders through the capabilities CAP_DAC_OVERRIDE and
#: CAP_DAC_READ_SEARCH; the child drops them (from its bounding and inheritable sets, so the
#: exec of the interpreter does not regain them) and stays root otherwise. Unlike switching to
#: an unprivileged user, the child can still read the clone, the virtual environment and the
#: interpreter wherever they live (a clone in a 0700 folder, an interpreter under /root).
DROP_DAC = ["setpriv", "--inh-caps=-dac_override,-dac_read_search",
            "--bounding-set=-dac_override,-dac_read_search", "--"]


def without_dac_override() -> list[str]:
    """Command prefix under which permission bits bind: none for a normal user; for root,
    setpriv dropping the DAC override capabilities (skips, naming them, where the container
    does not let root drop them)."""
    if os.geteuid() != 0:
        return []
    if shutil.which("setpriv") is None:
        pytest.skip("needs setpriv (util-linux) to run the child without CAP_DAC_OVERRIDE as root")
    probe = subprocess.run(
        [*DROP_DAC, "sh", "-c", "grep CapEff /proc/self/status"],
        capture_output=True,
        text=True,
    )
    if probe.returncode != 0:
        pytest.skip(f"root cannot drop CAP_DAC_OVERRIDE here (setpriv: {probe.stderr.strip()})")
    if int(probe.stdout.split()[-1], 16) & (1 << 1):  # bit 1: CAP_DAC_OVERRIDE
        pytest.skip("setpriv ran but CAP_DAC_OVERRIDE stayed in the effective set")
    return DROP_DAC


def default_stop_signals() -> None:
    """SIGINT, SIGTERM and SIGHUP back to their default action (a ``preexec_fn`` for a child
    that a test stops with them).

    A process started in the background by a shell inherits SIGINT ignored, one started under
    ``nohup`` SIGHUP ignored (CI may run either way); a test that stands for Ctrl-C, a kill or
    a closed terminal would then see nothing happen.
    """
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


@pytest.fixture
def stop_signals_not_ignored() -> Iterator[None]:
    """In this process, for the test: SIGINT raises ``KeyboardInterrupt`` (Python's own
    handler), SIGTERM and SIGHUP have their default action (see :func:`default_stop_signals`;
    pytest-xdist's workers may also inherit them ignored)."""
    previous = {
        signal.SIGINT: signal.signal(signal.SIGINT, signal.default_int_handler),
        signal.SIGTERM: signal.signal(signal.SIGTERM, signal.SIG_DFL),
        signal.SIGHUP: signal.signal(signal.SIGHUP, signal.SIG_DFL),
    }
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
