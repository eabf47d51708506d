"""The ``hdrfringe`` command line.

Every command validates its input fully before writing anything; any
:class:`~hdrfringe.errors.HdrFringeError` is printed as one line on stderr with exit code 2, and
no partial output is left behind (outputs are staged and moved into place when complete).
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer
from rich.console import Console

from hdrfringe import __version__
from hdrfringe.errors import HdrFringeError

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
    """Turn an HdrFringeError into a one-line message and exit code 2."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except HdrFringeError as exc:
            msg = " ".join(str(exc).split())
            err_console.print(f"[bold red]error:[/] {msg}", markup=True, highlight=False)
            raise typer.Exit(code=2) from None

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


def _parse_floats(text: str, what: str) -> list[float]:
    from hdrfringe.errors import InputError

    try:
        vals = [float(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError:
        raise InputError(
            f"{what}: cannot read {text!r} as numbers; give a comma-separated list such as 8,64"
        ) from None
    if not vals:
        raise InputError(f"{what}: empty list; give at least one value")
    return vals


# ---------------------------------------------------------------------------------------------
# patterns
# ---------------------------------------------------------------------------------------------


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
    migl: Annotated[float, typer.Option(help="Maximum input gray level (MIGL).")] = 255.0,
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
    from hdrfringe.io.pattern_folder import write_pattern_folder
    from hdrfringe.patterns import CenterlineFrame, Frame, FringeSpec, UniformFrame, render_frame
    from hdrfringe.rig.base import ProjectorInfo

    projector = ProjectorInfo(width, height, bit_depth, gamma)
    frames: list[Frame] = []
    for p in _parse_floats(pitch, "--pitch"):
        spec = FringeSpec(pattern, steps, p, orientation, imin, migl)  # type: ignore[arg-type]
        frames += spec.frames()
    if centerline:
        extent = width if orientation == "vertical" else height
        pos = extent // 2 if centerline_position is None else centerline_position
        frames.append(CenterlineFrame(pos, orientation, migl))  # type: ignore[arg-type]
    if gray:
        frames += [UniformFrame(g) for g in _parse_floats(gray, "--gray")]
    for f in frames:  # validate everything (levels vs bit depth) before writing
        render_frame(f, 1, 1, gamma, bit_depth)
    with progress_bar() as prog:
        task = prog.add_task("writing patterns", total=len(frames))
        write_pattern_folder(
            output, frames, projector, force=force, progress=lambda: prog.advance(task)
        )
    console.print(f"wrote {len(frames)} pattern images and manifest.json to {output}")


# ---------------------------------------------------------------------------------------------
# phase
# ---------------------------------------------------------------------------------------------


@app.command()
@handle_errors
def phase(
    folder: Annotated[Path, typer.Argument(help="Capture folder (manifest.json + images).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Output folder for the maps.")],
    min_modulation: Annotated[
        float | None, typer.Option(help="Minimum intensity modulation I' in DN for a valid pixel.")
    ] = None,
    keep_saturated: Annotated[
        bool, typer.Option(help="Keep the (biased) phase of pixels with saturated shifts.")
    ] = False,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Decode a capture folder: wrapped, unwrapped and absolute phase with quality maps."""
    from hdrfringe.io.captures import read_capture_folder
    from hdrfringe.io.phase_maps import write_phase_maps
    from hdrfringe.io.results import check_output_dir, staged_output_dir
    from hdrfringe.process import decode_folder

    check_output_dir(output, force)
    captures = read_capture_folder(folder)
    if not captures.sets:
        from hdrfringe.errors import CaptureFormatError

        raise CaptureFormatError(
            f"{folder}: no fringe frames in the manifest; add a complete phase-shifted set"
        )
    decoded = decode_folder(
        captures, min_modulation=min_modulation, reject_saturated=not keep_saturated
    )
    with staged_output_dir(output, force=force) as tmp:
        summary = write_phase_maps(tmp, decoded, str(folder))
    for s in summary["sets"]:
        console.print(
            f"set {s['label']}: valid {100 * s['valid_fraction']:.1f} %, "
            f"saturated {100 * s['saturated_fraction']:.1f} %"
        )
    for fam in summary["families"]:
        extra = f", absolute by {fam['absolute_method']}" if "absolute_method" in fam else ""
        console.print(f"{fam['orientation']}: unwrapped by {fam['unwrapping']}{extra}")
    for note in summary["notes"]:
        console.print(f"note: {note}")
    console.print(f"wrote {len(summary['files'])} files to {output}")


if __name__ == "__main__":  # pragma: no cover
    app()
