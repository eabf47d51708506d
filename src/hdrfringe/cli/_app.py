"""The typer application, its error handling and the helpers every command shares."""

from __future__ import annotations

import functools
import math
import sys
from collections.abc import Callable
from typing import Annotated, Any, TypeVar

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape

from hdrfringe import __version__
from hdrfringe.errors import HdrFringeError, InputError
from hdrfringe.limits import MAX_PROGRAM_FRAMES, check_count

__all__ = [
    "F",
    "app",
    "console",
    "err_console",
    "handle_errors",
    "main",
    "parse_floats",
    "parse_range",
    "progress_bar",
]

app = typer.Typer(
    name="hdrfringe",
    help="3D surface measurement by phase-shifting fringe projection that copes with saturation.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
console = Console()
err_console = Console(stderr=True, soft_wrap=True)

F = TypeVar("F", bound=Callable[..., Any])


def handle_errors(func: F) -> F:
    """Turn an HdrFringeError into a one-line message and exit code 2, Ctrl-C into exit code 130."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except HdrFringeError as exc:
            msg = " ".join(str(exc).split())
            # The message is user text (paths, regexes): escaped, so "[a-z]" prints verbatim.
            err_console.print(f"[bold red]error:[/] {escape(msg)}", markup=True, highlight=False)
            raise typer.Exit(code=2) from None
        except KeyboardInterrupt:  # Ctrl-C: nothing written (outputs are staged); shell's 130
            err_console.print("interrupted: nothing was written", highlight=False)
            raise typer.Exit(code=130) from None

    return wrapper  # type: ignore[return-value]


def _version_callback(value: bool) -> None:
    if value:
        console.print(f"hdrfringe {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[
        bool,
        typer.Option(
            "--version",
            callback=_version_callback,
            is_eager=True,
            help="Print the version and exit.",
        ),
    ] = False,
) -> None:
    """hdrfringe: fringe patterns, virtual rig, phase, unwrapping and saturation avoidance."""


def progress_bar() -> Any:
    """A rich progress bar for long work (quiet when stderr is not a terminal)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err_console,
        transient=True,
        disable=not sys.stderr.isatty(),
    )


def parse_floats(text: str, what: str) -> list[float]:
    """A comma-separated list of finite numbers (``8,64``) given for option ``what``."""
    try:
        vals = [float(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError:
        raise InputError(
            f"{what}: cannot read {text!r} as numbers; give a comma-separated list such as 8,64"
        ) from None
    if not vals:
        raise InputError(f"{what}: empty list; give at least one value")
    _check_finite(vals, text, what)
    return vals


def _check_finite(vals: list[float], text: str, what: str) -> None:
    bad = next((v for v in vals if not math.isfinite(v)), None)
    if bad is not None:
        shown = text if len(text) <= 40 else f"{text[:20]}...{text[-8:]}"
        raise InputError(f"{what}: {shown!r} holds {bad}; give finite numbers")


def parse_range(text: str, what: str, max_count: int = MAX_PROGRAM_FRAMES) -> list[float]:
    """``start:stop:step`` (stop included) or a comma-separated list.

    A range of more than ``max_count`` values is refused before it is built.
    """

    if ":" not in text:
        return parse_floats(text, what)
    try:
        start, stop, step = (float(v) for v in text.split(":"))
    except ValueError:
        raise InputError(
            f"{what}: cannot read {text!r}; use start:stop:step, e.g. 2:50:2"
        ) from None
    _check_finite([start, stop, step], text, what)
    if step != 0 and (stop - start) * step < 0:
        step = -step  # 255:60:1 means downwards
    if step == 0:
        raise InputError(f"{what}: {text!r} is an empty range; use e.g. 2:50:2 or 255:60:-5")
    count = float(np.floor((stop - start) / step + 1e-9)) + 1
    n = check_count(
        count, max_count, f"values in {what} {text}", fix="use a larger step or a shorter range"
    )
    return [round(start + i * step, 9) for i in range(n)]
