"""The command line loads a command's module only when that command runs (issue 16, cold start).

``cli._app.COMMAND_MODULES`` names every command's module; the tests check the table against
the modules (a command missing from it would vanish from the CLI, a wrong module would fail
on first use) and that running one command imports neither the other commands nor what only
they need.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import typer.main
from typer.models import DefaultPlaceholder

from hdrfringe.cli._app import COMMAND_MODULES, app


def test_the_table_names_every_command_and_its_module() -> None:
    for module in set(COMMAND_MODULES.values()):
        importlib.import_module(f"hdrfringe.cli.{module}")
    declared = {
        (info.name or typer.main.get_command_name(info.callback.__name__)): info.callback.__module__
        for info in app.registered_commands
        if info.callback is not None
    }
    declared |= {g.name: COMMAND_MODULES.get(g.name or "", "?") for g in app.registered_groups}
    assert set(declared) == set(COMMAND_MODULES)
    for name, module in declared.items():
        if name != "rig":  # a group: its module is the one that calls add_typer (checked below)
            assert module == f"hdrfringe.cli.{COMMAND_MODULES[name]}", name
    rig = importlib.import_module(f"hdrfringe.cli.{COMMAND_MODULES['rig']}")
    assert any(g.typer_instance is rig.rig_app for g in app.registered_groups)


def test_every_command_resolves_through_the_group() -> None:
    """The product's commands in table order, then the plug-ins (tests/test_cli_plugins.py):
    ``reproduce`` whether or not the research package is installed."""
    from hdrfringe.cli._app import PLUGIN_INSTALL, plugin_commands

    group = typer.main.get_command(app)
    names = list(group.commands)  # type: ignore[attr-defined]
    assert names[: len(COMMAND_MODULES)] == list(COMMAND_MODULES)
    assert names[len(COMMAND_MODULES) :] == sorted(set(PLUGIN_INSTALL) | set(plugin_commands()))
    for name in names:
        assert group.commands[name].name == name  # type: ignore[attr-defined]


_PROBE = """
import sys
from hdrfringe.cli import app
try:
    app(["phase", "--help"])
except SystemExit as exc:
    assert exc.code == 0, exc.code
watched = ("hdrfringe.cli.", "hdrfringe.strategies", "scipy", "matplotlib", "dask", "cv2", "h5py")
watched += ("pydantic", "importlib.metadata")  # typer >= 0.29's option coercion; --version
print(" ".join(sorted(m for m in sys.modules if m.startswith(watched))))
"""


def test_one_command_imports_only_its_own_module() -> None:
    """``phase --help`` imports its own module and nothing the help does not show: not the
    other commands, not pydantic (typer 0.29 builds a pydantic TypeAdapter per option; the
    pyproject bound keeps typer < 0.29), not importlib.metadata (only ``--version`` reads it)."""
    out = (
        subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, check=True)
        .stdout.splitlines()[-1]
        .split()
    )  # after the help text: the probe's line
    assert "hdrfringe.cli.phase" in out  # the probe sees the command it ran
    assert out == ["hdrfringe.cli._app", "hdrfringe.cli.phase"], out


_HELP_PROBE = """
import contextlib, importlib, io, sys
from hdrfringe.cli import app
from hdrfringe.cli._app import COMMAND_MODULES

def help_text():
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            app(["--help"], prog_name="hdrfringe")
        except SystemExit as exc:
            assert exc.code == 0, exc.code
    return out.getvalue()

lazy = help_text()
loaded = sorted(m for m in sys.modules if m.startswith("hdrfringe.cli."))
for module in COMMAND_MODULES.values():
    importlib.import_module("hdrfringe.cli." + module)
print(repr((lazy, help_text(), loaded)))
"""


def test_help_lists_every_command_as_if_loaded_without_importing_them() -> None:
    """``--help`` reads the commands' help from their source (no import): the listing must be
    the one the imported commands give (a docstring changed, a command given a help panel or
    renamed, and the listing would differ)."""
    import ast

    probe = subprocess.run(
        [sys.executable, "-c", _HELP_PROBE],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "COLUMNS": "100"},
    )
    lazy, loaded_help, loaded = ast.literal_eval(probe.stdout)
    assert loaded == ["hdrfringe.cli._app"]  # --help imported no command module
    assert lazy == loaded_help
    assert all(f" {name} " in lazy for name in [*COMMAND_MODULES, "reproduce"])


def _unset_is_none(command: object, attr: str) -> object:
    """An attribute of a click command; typer's DefaultPlaceholder (an unset value) as its
    value."""
    value = getattr(command, attr, None)
    return value.value if isinstance(value, DefaultPlaceholder) else value


def test_the_listing_entries_match_the_commands() -> None:
    from hdrfringe.cli._app import _listed_command

    group = typer.main.get_command(app)
    for name in list(group.commands):  # type: ignore[attr-defined]  # plug-ins too
        listed, real = _listed_command(name), group.commands[name]  # type: ignore[attr-defined]
        assert listed is not None, name  # every command is in the plain form the listing reads
        for attr in ("name", "help", "short_help", "hidden", "deprecated", "rich_help_panel"):
            mine, theirs = _unset_is_none(listed, attr), _unset_is_none(real, attr)
            assert mine == theirs, (name, attr, mine, theirs)


_RUN_PROBE = """
import sys
from hdrfringe.cli import app
folder, out = sys.argv[1], sys.argv[2]
for command in ("phase", "measure"):
    try:
        app([command, folder, "-o", out + "/" + command])
    except SystemExit as exc:
        assert exc.code == 0, (command, exc.code)
heavy = ("scipy", "skimage", "matplotlib", "dask", "xarray", "h5py", "pydantic", "pydantic_core")
print("temporal:", *sorted(m for m in sys.modules if m.split(".")[0] in heavy))
try:  # one set: spatial unwrapping (scikit-image's unwrapper, labels and regions by OpenCV)
    app(["phase", sys.argv[3], "-o", out + "/spatial"])
except SystemExit as exc:
    assert exc.code == 0, ("phase spatial", exc.code)
print("spatial:", *sorted(m for m in sys.modules if m.split(".")[0] in heavy[:1] + heavy[2:]))
"""


def test_phase_and_measure_import_no_scipy_or_matplotlib(
    tmp_path: Path,
) -> None:
    """A 3-pitch folder (temporal unwrapping, no calibration) needs none of scipy, scikit-image
    or matplotlib: the commands, the pipeline, the strategy registry that builds measure's
    options and the map previews must import them only where they are used (issue 16, cold
    start: scipy.ndimage alone is about 0.3 s of CPU, matplotlib 0.2 s). A single set
    (spatial unwrapping) needs scikit-image's unwrapper but still no scipy. Neither command
    imports pydantic: typer 0.29 coerces every option through a pydantic TypeAdapter, about
    0.1 s of CPU per start (benchmarks/README.md, cold start), hence the bound typer < 0.29."""
    from hdrfringe.core.captures import Captures, ProjectorInfo
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.io.captures import write_capture_folder
    from tests.conftest import synthetic_set

    specs = [FringeSpec("sinusoidal", 4, p, "vertical", 40, 255) for p in (1024.0, 64.0, 8.0)]
    sets = [synthetic_set(s, (24, 32))[0] for s in specs]
    frames = [f for s in specs for f in s.frames()]
    folder = tmp_path / "caps"
    write_capture_folder(
        folder, Captures(frames, np.concatenate(sets), 8, projector=ProjectorInfo(1024, 768, 8))
    )
    single = tmp_path / "single"
    write_capture_folder(
        single, Captures(specs[2].frames(), sets[2], 8, projector=ProjectorInfo(1024, 768, 8))
    )
    run = subprocess.run(
        [sys.executable, "-c", _RUN_PROBE, str(folder), str(tmp_path), str(single)],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert (tmp_path / "measure" / "absolute_phase_vertical.png").is_file()  # previews were drawn
    assert (tmp_path / "spatial" / "unwrapped_phase_vertical.png").is_file()
    lines = run.stdout.splitlines()
    assert "temporal:" in lines, [ln for ln in lines if ln.startswith("temporal:")]
    assert "spatial:" in lines, [ln for ln in lines if ln.startswith("spatial:")]
