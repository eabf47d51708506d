"""No function of the library over :data:`MAX_FUNCTION_LINES` code lines (issue 29).

Every module under ``src/hdrfringe`` is parsed with :mod:`ast` (nothing is imported). A
function's code lines are those of its ``def``: the signature and the body, without the
docstring, blank lines and comment-only lines (decorators are not counted). The body is
counted by :func:`tests.test_cli_shape.body_code_lines`, the counter of the CLI command
bodies. A nested function counts in its own right and in the function that holds it.
"""

from __future__ import annotations

import ast
import textwrap
from pathlib import Path

import pytest

from tests.test_cli_shape import body_code_lines

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "hdrfringe"
MAX_FUNCTION_LINES = 120


def function_code_lines(function: ast.FunctionDef | ast.AsyncFunctionDef, source: str) -> int:
    """Code lines of ``function`` (parsed from ``source``): its signature's lines and its
    body's (:func:`~tests.test_cli_shape.body_code_lines`)."""
    lines = source.splitlines()
    signature = sum(
        1
        for number in range(function.lineno, function.body[0].lineno)
        if (text := lines[number - 1].strip()) and not text.startswith("#")
    )
    return signature + body_code_lines(function, source)


def function_sizes(source: str) -> dict[str, int]:
    """Function name (``outer.inner`` when nested) -> its code lines, for one module."""
    out: dict[str, int] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = prefix + child.name
                out[name] = function_code_lines(child, source)
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(source), "")
    return out


def over_the_limit(sources: dict[str, str], limit: int = MAX_FUNCTION_LINES) -> dict[str, int]:
    """``module:function`` -> code lines, for the functions of ``sources`` over ``limit``."""
    return {
        f"{module}:{name}": n
        for module, source in sources.items()
        for name, n in function_sizes(source).items()
        if n > limit
    }


def _package_sources() -> dict[str, str]:
    return {
        str(path.relative_to(PACKAGE)): path.read_text(encoding="utf-8")
        for path in sorted(PACKAGE.rglob("*.py"))
    }


def test_no_function_over_the_limit() -> None:
    long = over_the_limit(_package_sources())
    assert not long, (
        f"functions over {MAX_FUNCTION_LINES} code lines (split them into steps with names "
        "that say what each does): " + ", ".join(f"{k} ({v})" for k, v in sorted(long.items()))
    )


def test_the_package_is_counted() -> None:
    """Guards against a vacuous pass: every module is read and long functions are seen as
    long (the largest is near the limit, not a handful of lines)."""
    sizes = {
        f"{m}:{name}": n
        for m, s in _package_sources().items()
        for name, n in function_sizes(s).items()
    }
    assert len(sizes) > 1000
    assert "strategies/adaptive.py:adaptive_sets" in sizes
    assert "strategies/adaptive.py:Adaptive.run_sets" in sizes
    assert max(sizes.values()) > 90


def _function(body_lines: int, signature: str = "def f(a: int = 1) -> None:\n") -> str:
    doc = '    """Help.\n\n    More help, several lines.\n    """\n'
    return signature + doc + "    y = 1\n" * body_lines


_SIGNATURE = "def f(\n    a: int = 1,\n    b: int = 2,\n) -> None:\n"


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        # the def line counts: 1 + 119 = 120 is at the limit, 1 + 120 = 121 over it
        (_function(119), {}),
        (_function(120), {"m.py:f": 121}),
        # a signature over several lines counts each line (4 + 116 = 120)
        (_function(116, _SIGNATURE), {}),
        (_function(117, _SIGNATURE), {"m.py:f": 121}),
        # blank and comment-only lines and the docstring do not count
        (_function(119) + "\n    # why\n\n    # more\n", {}),
        # a method; a nested function, counted in the function holding it too (1 + 121)
        ("class C:\n" + textwrap.indent(_function(120), "    "), {"m.py:C.f": 121}),
        (
            "def outer():\n" + textwrap.indent(_function(120), "    "),
            {"m.py:outer": 125, "m.py:outer.f": 121},
        ),
    ],
    ids=["120", "121", "signature-120", "signature-121", "comments", "method", "nested"],
)
def test_a_121_line_function_is_rejected(source: str, expected: dict[str, int]) -> None:
    assert over_the_limit({"m.py": source}) == expected


def test_counter_matches_the_command_counter() -> None:
    """A function's count is its body's (the CLI counter) plus its signature's lines."""
    source = "@app.command()\ndef x(\n    a: int = 1,\n) -> None:\n" + "    y = 1\n" * 5
    assert function_sizes(source) == {"x": 8}
