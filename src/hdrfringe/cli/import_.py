"""``hdrfringe import``: camera images + a description of what was projected -> capture folder
(:func:`hdrfringe.tasks.import_.import_folder`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors
from hdrfringe.errors import InputError

__all__ = ["import_"]


@app.command("import")
@handle_errors
def import_(
    images: Annotated[Path, typer.Argument(help="Folder of camera images (searched recursively).")],
    description: Annotated[
        Path,
        typer.Option(
            "--description",
            "-d",
            help="TOML import description (docs/import.md), or the manifest.json of a pattern "
            "folder written by 'hdrfringe patterns'.",
        ),
    ],
    output: Annotated[Path, typer.Option("-o", "--output", help="Capture folder to write.")],
    bit_depth: Annotated[
        int | None,
        typer.Option(
            help="Camera bit depth, for a pattern manifest only (a TOML description gives it)."
        ),
    ] = None,
    crop_offset: Annotated[
        str | None,
        typer.Option(
            help="X0,Y0: the images are crops of the camera frame (camera.frame_size of the "
            "description) starting at this pixel; they are written as the full frame."
        ),
    ] = None,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Import camera images as a capture folder (images copied; converted only when needed)."""
    from hdrfringe.tasks.import_ import import_folder

    offset = None
    if crop_offset is not None:
        try:
            x0, y0 = (int(v) for v in crop_offset.split(","))
        except ValueError:
            raise InputError(
                f"--crop-offset {crop_offset!r}: give X0,Y0 in camera pixels, e.g. 199,157"
            ) from None
        offset = (x0, y0)
    done = import_folder(
        images, description, output, bit_depth=bit_depth, crop_offset=offset, force=force
    )
    report, hint = done.report, done.hint
    frames = report.manifest["frames"]
    kinds: dict[str, int] = {}
    for f in frames:
        kinds[f["kind"]] = kinds.get(f["kind"], 0) + 1
    counts = ", ".join(f"{n} {k}" for k, n in kinds.items())
    console.print(
        f"imported {len(frames)} frames ({counts}): {report.copied} images copied, "
        f"{report.converted} converted to PNG"
    )
    if report.ignored:
        shown = ", ".join(report.ignored[:5]) + (", ..." if len(report.ignored) > 5 else "")
        console.print(f"{len(report.ignored)} files not used by the description: {shown}")
    console.print(
        f"wrote {output} (capture format version {report.manifest['version']})"
        + (f"; next: {hint}" if hint else ""),
        soft_wrap=True,
    )
    if hint is None and "fringe" not in kinds:  # a Gray-code board pose (no phase to decode)
        console.print(
            "no fringe frames, so no phase: as a board pose it is one of the poses "
            "`hdrfringe calibrate-stereo` reads (docs/stereo_calibration.md)",
            soft_wrap=True,
        )
