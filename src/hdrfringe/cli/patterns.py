"""``hdrfringe patterns``: fringe, centerline and uniform frames as projector images."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors, parse_floats, progress_stage
from hdrfringe.cli._options import MiglOpt

__all__ = ["patterns"]


@app.command()
@handle_errors
def patterns(
    output: Annotated[
        Path, typer.Option("-o", "--output", help="Output folder for PNGs + manifest.")
    ],
    pattern: Annotated[str, typer.Option(help="sinusoidal or triangular.")] = "sinusoidal",
    steps: Annotated[int, typer.Option(help="Number of phase shifts N.")] = 3,
    pitch: Annotated[str, typer.Option(help="Pitch(es) in projector px, comma-separated.")] = "6",
    orientation: Annotated[str, typer.Option(help="vertical or horizontal.")] = "vertical",
    imin: Annotated[float, typer.Option(help="Minimum input gray level.")] = 40.0,
    migl: MiglOpt = 255.0,
    width: Annotated[int, typer.Option(help="Projector width in px.")] = 1024,
    height: Annotated[int, typer.Option(help="Projector height in px.")] = 768,
    bit_depth: Annotated[int, typer.Option(help="Projector input bit depth.")] = 8,
    gamma: Annotated[
        float, typer.Option(help="Gamma pre-compensation exponent (1 = none).")
    ] = 2.812,
    centerline: Annotated[bool, typer.Option(help="Add the centerline image.")] = True,
    centerline_position: Annotated[
        float | None, typer.Option(help="Centerline projector coordinate (default: middle).")
    ] = None,
    gray: Annotated[str, typer.Option(help="Uniform gray levels to add, comma-separated.")] = "",
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Generate fringe patterns (and centerline/uniform images) for a projector."""
    from hdrfringe.tasks.patterns import patterns as task

    done = task(
        output, pattern=pattern, steps=steps, pitches=parse_floats(pitch, "--pitch"),
        orientation=orientation, imin=imin, migl=migl, width=width, height=height,
        bit_depth=bit_depth, gamma=gamma, centerline=centerline,
        centerline_position=centerline_position,
        grays=parse_floats(gray, "--gray") if gray else (), force=force, progress=progress_stage,
    )  # fmt: skip
    console.print(f"wrote {done.images} pattern images and manifest.json to {output}")
