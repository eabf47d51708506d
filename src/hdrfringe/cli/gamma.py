"""``hdrfringe gamma``: projector gamma from uniform-gray or fringe captures."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors

__all__ = ["gamma"]


@app.command()
@handle_errors
def gamma(
    folder: Annotated[Path, typer.Argument(help="Capture folder with uniform grays or fringes.")],
    output: Annotated[
        Path | None,
        typer.Option(
            "-o",
            "--output",
            help="Folder for gamma.json and the plots (mapping, nonlinearity).",
        ),
    ] = None,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Estimate the projector gamma (Eq. 2.16) and the nonlinearity left after pre-compensation.

    Uniform-gray frames (at least 4 unsaturated levels) give a direct fit of captured intensity
    against input gray; sinusoidal sets pre-distorted with known exponents give a fit of the
    fringe shape. Both are reported when the folder allows, each with its mapping plot and its
    residual nonlinearity plot; a fit that is degenerate or leaves a large residual (over 2 %
    of its signal range) is reported with a warning line, also listed in gamma.json.
    """
    from hdrfringe.tasks.gamma import gamma as task

    task(folder, output, force=force, say=console.print)
    if output is not None:
        console.print(f"wrote {output}")
