"""``hdrfringe fit plane|sphere RESULT --roi ...``: a plane or a sphere fitted to a region of a
measurement (docs/fit.md).

The work is :func:`hdrfringe.tasks.fit.fit`; this module declares the options and prints the
fit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors
from hdrfringe.errors import InputError

__all__ = ["fit", "print_fit"]


@app.command()
@handle_errors
def fit(
    shape: Annotated[str, typer.Argument(help="plane or sphere.")],
    result: Annotated[Path, typer.Argument(help="A result folder of `hdrfringe measure -c`.")],
    roi: Annotated[
        str,
        typer.Option(
            help="Region of interest in camera pixels: x0,y0,x1,y1 (a rectangle, columns x0 to "
            "x1-1, rows y0 to y1-1), a polygon file (.json: a list of [x, y]; .csv: x,y per "
            "line), or auto (the largest connected region of valid pixels)."
        ),
    ] = "auto",
    output: Annotated[
        Path | None,
        typer.Option(
            "-o", "--output", help="Folder for residual.tiff, residual.png and fit.json (required)."
        ),
    ] = None,
    diameter: Annotated[
        float | None,
        typer.Option(help="A sphere's calibrated diameter in mm: also print the size error PS."),
    ] = None,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Fit a plane (flatness F) or a sphere (form PF, diameter) to a region of a measurement,
    with the acceptance test's fits and its 0.3 % trimming rule; write the residual map
    (residual.tiff, NaN outside the region), its preview and fit.json (docs/fit.md)."""
    from hdrfringe.tasks.fit import fit as run_fit

    if output is None:
        raise InputError("no output folder: give -o/--output OUT")
    report = run_fit(result, shape, roi, output, diameter_mm=diameter, force=force)
    print_fit(report.values, report.output)


def _vector(v: list[float]) -> str:
    return "(" + ", ".join(f"{c + 0.0:.6g}" for c in v) + ")"  # + 0.0: no "-0"


def print_fit(values: dict[str, Any], output: Path) -> None:
    """The lines ``fit`` prints: the region, the fit, RMS and F or PF (and PS), notes.

    Parameters
    ----------
    values : dict
        ``fit.json``'s content (:attr:`hdrfringe.tasks.fit.FitReport.values`).
    output : Path
        The folder written.
    """
    roi = values["roi"]
    console.print(
        f"{values['shape']} fit over {values['n_points']} points of the {roi['rule']} region "
        f"({roi['points']} valid, {values['n_dropped']} left out by the 0.3 % rule)"
    )
    if values["shape"] == "plane":
        console.print(f"normal {_vector(values['normal'])}, offset {values['offset_mm']:.6g} mm")
        console.print(f"RMS {values['rms_mm']:.4g} mm, flatness F {values['f_mm']:.4g} mm")
    else:
        console.print(
            f"centre {_vector(values['centre_mm'])} mm, radius {values['radius_mm']:.6g} mm "
            f"(diameter {values['diameter_mm']:.6g} mm)"
        )
        line = f"RMS {values['rms_mm']:.4g} mm, form PF {values['pf_mm']:.4g} mm"
        if "ps_mm" in values:
            line += (
                f", size PS {values['ps_mm']:+.4g} mm "
                f"(calibrated {values['calibrated_diameter_mm']:g} mm)"
            )
        console.print(line)
    for note in values["notes"]:
        console.print(f"note: {note}", soft_wrap=True)
    console.print(f"wrote {output} (residual.tiff, residual.png, fit.json)")
