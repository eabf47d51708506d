"""``hdrfringe calibrate``: per-pixel phase-to-height calibration from plate captures."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_bar
from hdrfringe.errors import InputError

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
    from hdrfringe.calibration import MODELS
    from hdrfringe.errors import OutputExistsError
    from hdrfringe.io.calibration_file import save_calibration
    from hdrfringe.io.results import check_output_against_inputs, check_output_file
    from hdrfringe.tasks.calibrate import calibrate_folders, expand_capture_dirs

    if model not in MODELS:
        raise InputError(f"unknown model {model!r}; use one of {', '.join(MODELS)}")
    check_output_against_inputs(output, folders)
    if output.is_dir():
        raise OutputExistsError(f"{output}: is a folder; give a file path for the calibration")
    if output.exists() and not force:
        raise OutputExistsError(f"{output}: exists; pass --force to replace it")
    output = check_output_file(output, force)  # what is there now: replaced only if unchanged
    n = len(expand_capture_dirs(folders))
    with progress_bar() as prog:
        task = prog.add_task("decoding plate positions", total=n)
        cal = calibrate_folders(
            folders,
            model=model,
            window_px=window,
            border_px=border,
            progress=lambda: prog.advance(task),
        )
    save_calibration(output, cal, force=force)
    console.print(
        f"calibrated {len(cal.depths_mm)} positions ({cal.depths_mm.min():g}..."
        f"{cal.depths_mm.max():g} mm) + reference with {cal.spec.label() if cal.spec else '?'}"
    )
    console.print(f"fit residual (median RMS over measurement pixels): {cal.describe_residuals()}")
    console.print(f"wrote {output}")
