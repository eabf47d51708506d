"""Thin commands (issue 29): no CLI command body over :data:`MAX_BODY_LINES` code lines, and
tasks that print nothing and import no front-end library (typer, click, rich).

Every module of ``src/hdrfringe/cli`` is parsed with :mod:`ast` (nothing is imported); a command
is a function decorated with ``<app>.command(...)``. Its body's code lines are counted: the
docstring, blank lines and comment-only lines are left out, the signature (the options) too.
A command's workflow lives in its task (``hdrfringe.tasks``); the command declares options,
calls the task and prints its report.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

CLI = Path(__file__).resolve().parents[1] / "src" / "hdrfringe" / "cli"
MAX_BODY_LINES = 40


def _is_command(decorator: ast.expr) -> bool:
    """``@app.command()``, ``@app.command("name")``, ``@rig_app.command()``."""
    func = decorator.func if isinstance(decorator, ast.Call) else decorator
    return isinstance(func, ast.Attribute) and func.attr == "command"


def body_code_lines(function: ast.FunctionDef | ast.AsyncFunctionDef, source: str) -> int:
    """Code lines of a function's body: no docstring, blank or comment-only lines.

    Parameters
    ----------
    function : ast.FunctionDef
        The function, parsed from ``source``.
    source : str
        The module's source.

    Returns
    -------
    int
    """
    body = list(function.body)
    skip: set[int] = set()
    first = body[0]
    if (
        isinstance(first, ast.Expr)
        and isinstance(first.value, ast.Constant)
        and isinstance(first.value.value, str)
    ):
        skip = set(range(first.lineno, (first.end_lineno or first.lineno) + 1))
        body = body[1:]
    if not body:
        return 0
    lines = source.splitlines()
    end = function.end_lineno or body[-1].lineno
    return sum(
        1
        for number in range(body[0].lineno, end + 1)
        if number not in skip
        and (text := lines[number - 1].strip())
        and not text.startswith("#")
    )


def command_bodies(source: str) -> dict[str, int]:
    """Command function name -> its body's code lines, for one module's source."""
    return {
        node.name: body_code_lines(node, source)
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and any(_is_command(d) for d in node.decorator_list)
    }


def _all_commands() -> dict[str, int]:
    out: dict[str, int] = {}
    for path in sorted(CLI.glob("*.py")):
        for name, lines in command_bodies(path.read_text(encoding="utf-8")).items():
            out[f"{path.name}:{name}"] = lines
    return out


def test_no_command_body_over_the_limit() -> None:
    long = {name: n for name, n in _all_commands().items() if n > MAX_BODY_LINES}
    assert not long, (
        f"CLI command bodies over {MAX_BODY_LINES} code lines (move the workflow into its "
        "task, hdrfringe.tasks): " + ", ".join(f"{k} ({v})" for k, v in sorted(long.items()))
    )


def test_the_commands_are_found() -> None:
    """Guards against a vacuous pass: every command module's command is seen."""
    found = {name.split(":")[1] for name in _all_commands()}
    assert {"measure", "phase", "calibrate_stereo", "capture", "check", "simulate"} <= found
    assert len(found) >= 16  # reproduce is the research package's (an entry point)


def _command(body: str, decorator: str = '@app.command("x")') -> str:
    return f'{decorator}\n@handle_errors\ndef x(a: int = 1) -> None:\n{body}'


_DOC = '    """Help.\n\n    More help, several lines.\n    """\n'


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        (_command(_DOC + "    y = 1\n" * 40), {"x": 40}),
        (_command(_DOC + "    y = 1\n" * 41), {"x": 41}),
        # blank and comment lines do not count; a multi-line call counts each line
        (_command(_DOC + "\n    # why\n    y = f(\n        1,\n    )\n\n    # done\n"), {"x": 3}),
        (_command("    y = 1\n    return y\n", "@rig_app.command()"), {"x": 2}),
        (_command("    pass\n", "@app.command"), {"x": 1}),
        # helpers and other decorators are not commands
        ("def helper():\n" + "    y = 1\n" * 60, {}),
        ("@functools.cache\ndef helper():\n" + "    y = 1\n" * 60, {}),
    ],
)
def test_counter(source: str, expected: dict[str, int]) -> None:
    assert command_bodies(source) == expected


def test_the_limit_rejects_a_long_body() -> None:
    """A 41-line body fails the rule the package is held to; 40 passes."""
    assert command_bodies(_command(_DOC + "    y = 1\n" * 41))["x"] > MAX_BODY_LINES
    assert command_bodies(_command(_DOC + "    y = 1\n" * 40))["x"] <= MAX_BODY_LINES


# --- tasks print nothing and know no command line ---------------------------------------------

TASKS = CLI.parent / "tasks"
#: What a task may not use: the front end's libraries, and printing (a task says things
#: through the callbacks the front end gives it: hdrfringe.tasks._progress).
FRONT_END_LIBRARIES = ("typer", "click", "rich")


def front_end_uses(source: str) -> list[str]:
    """The front-end libraries a module imports and the ``print`` calls it makes."""
    found = []
    for node in ast.walk(ast.parse(source)):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names = [node.module or ""]
        found += [f"import {n}" for n in names if n.split(".")[0] in FRONT_END_LIBRARIES]
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            if node.func.id == "print":
                found.append(f"print (line {node.lineno})")
    return found


def test_tasks_print_nothing_and_import_no_front_end() -> None:
    modules = sorted(TASKS.glob("*.py"))
    assert len(modules) >= 15  # guards against a vacuous pass
    bad = {p.name: u for p in modules if (u := front_end_uses(p.read_text(encoding="utf-8")))}
    assert not bad, f"tasks using the front end: {bad}"


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("import typer\n", ["import typer"]),
        ("from rich.console import Console\n", ["import rich.console"]),
        ("def f():\n    import click\n    print('x')\n", ["import click", "print (line 3)"]),
        ("from . import _progress\nimport numpy\nsay('x')\n", []),
    ],
)
def test_front_end_check(source: str, expected: list[str]) -> None:
    assert front_end_uses(source) == expected
