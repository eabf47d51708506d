"""Commands another installed package adds through the entry-point group ``hdrfringe.commands``
(issue 29: ``reproduce`` from the research package ``hdrfringe-thesis``).

A throw-away plug-in (a module and its ``.dist-info`` with ``entry_points.txt``, on the path)
stands for any such package, so these tests hold whether or not the research package is
installed: ``--help`` lists the plug-in from its source without importing it, running it
imports it and applies the product's error handling; without the research package,
``reproduce`` says in one line how to install it (exit code 2).
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from hdrfringe.cli import _app
from tests.conftest import run_cli_in_process

PLUGIN = '''
"""A command added by another package."""
from typing import Annotated

import typer

from hdrfringe.cli import console
from hdrfringe.errors import InputError


def hello(name: Annotated[str, typer.Option(help="Who.")] = "world") -> None:
    """Say hello to NAME (a plug-in command)."""
    if not name:
        raise InputError("--name: empty; give a name")
    console.print(f"hello {name}")
'''


@pytest.fixture
def plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """The plug-in ``hello`` installed on the path (module ``r29_hello_plugin``)."""
    (tmp_path / "r29_hello_plugin.py").write_text(PLUGIN)
    info = tmp_path / "r29_hello_plugin-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: r29-hello-plugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(
        "[hdrfringe.commands]\nhello = r29_hello_plugin:hello\nphase = r29_hello_plugin:hello\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    _app.plugin_commands.cache_clear()
    yield "r29_hello_plugin"
    _app.plugin_commands.cache_clear()
    sys.modules.pop("r29_hello_plugin", None)


def test_help_lists_a_plugin_without_importing_it(plugin: str) -> None:
    res = run_cli_in_process("--help")
    assert res.returncode == 0, res.stderr
    assert " hello " in res.stdout and "Say hello to NAME (a plug-in command)." in res.stdout
    assert plugin not in sys.modules  # listed from its source
    assert _app.plugin_commands()["hello"] == "r29_hello_plugin:hello"
    assert "phase" not in _app.plugin_commands()  # a product command is not taken over


def test_a_plugin_runs_under_the_product_error_handling(plugin: str) -> None:
    res = run_cli_in_process("hello", "--name", "fringe")
    assert (res.returncode, res.stdout.strip()) == (0, "hello fringe"), res.stderr
    res = run_cli_in_process("hello", "--name", "")
    assert res.returncode == 2 and res.stderr.strip() == "error: --name: empty; give a name"
    assert "Traceback" not in res.stderr
    res = run_cli_in_process("phase", "--help")  # still the product's phase
    assert "capture folder" in res.stdout.lower() and "--name" not in res.stdout


def test_reproduce_without_the_research_package_says_how_to_install_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(_app, "plugin_commands", dict)  # no package adds a command
    for args in (["reproduce", "ch4", "--quick", "-o", "x"], ["reproduce", "--help"]):
        res = run_cli_in_process(*args)
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        assert res.returncode == 2 and len(lines) == 1, res.stderr
        assert lines[0].startswith("error: `hdrfringe reproduce` is not installed")
        assert "hdrfringe-thesis" in lines[0] and "pip install -e research" in lines[0]
    res = run_cli_in_process("--help")
    assert " reproduce " in res.stdout and "not installed" in res.stdout
    res = run_cli_in_process("reproduces")
    assert res.returncode == 2 and "No such command" in res.stderr  # only known plug-ins


def test_a_broken_plugin_is_one_line_and_leaves_the_help_working(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An entry point whose module is gone (a package removed by hand, half an install): the
    listing still works and running it says so in one line, no traceback."""
    info = tmp_path / "r29_gone-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: r29-gone\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[hdrfringe.commands]\ngone = r29_gone_module:run\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    _app.plugin_commands.cache_clear()
    try:
        res = run_cli_in_process("--help")
        assert res.returncode == 0 and " gone " in res.stdout, res.stderr
        res = run_cli_in_process("gone", "--x")
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        assert res.returncode == 2 and len(lines) == 1, res.stderr
        assert "`hdrfringe gone` cannot be loaded" in lines[0] and "r29_gone_module" in lines[0]
    finally:
        _app.plugin_commands.cache_clear()
