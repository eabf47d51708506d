"""``hdrfringe calibrate``: per-pixel phase-to-height calibration from plate captures."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_stage

__all__ = ["calibrate"]


@app.command()
@handle_errors
def calibrate(
    folders: Annotated[
        list[Path],
        typer.Argument(
            help="Flat-plate capture folders (scene.depth_mm; one at 0), or a folder of them."
        ),
    ],
    output: Annotated[Path, typer.Option("-o", "--output", help="Calibration file (.h5).")],
    model: Annotated[
        str, typer.Option(help="linear (Eq. 2.15), rational (1/h form), poly2 or poly3.")
    ] = "linear",
    window: Annotated[int, typer.Option(help="Median and mean filter window, px.")] = 21,
    border: Annotated[int, typer.Option(help="Unfiltered border excluded from metrics, px.")] = 10,
    force: Annotated[bool, typer.Option(help="Replace an existing calibration file.")] = False,
) -> None:
    """Per-pixel phase-to-height calibration from a plate at known depths (Sec. 2.5, 4.1)."""
    from hdrfringe.tasks.calibrate import calibrate as task

    cal = task(folders, output, model=model, window=window, border=border, force=force,
               progress=progress_stage)  # fmt: skip
    console.print(
        f"calibrated {len(cal.depths_mm)} positions ({cal.depths_mm.min():g}..."
        f"{cal.depths_mm.max():g} mm) + reference with {cal.spec.label() if cal.spec else '?'}"
    )
    console.print(f"fit residual (median RMS over measurement pixels): {cal.describe_residuals()}")
    console.print(f"wrote {output}")
