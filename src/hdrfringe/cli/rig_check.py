"""``hdrfringe rig check``: latency, safe settle, white clipping and noise of a real rig."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, handle_errors
from hdrfringe.cli.capture import CameraOpt, ExposureOpt, GainOpt, PixelFormatOpt, ProjectorOpt
from hdrfringe.errors import InputError

__all__ = ["check", "rig_app"]

rig_app = typer.Typer(help="Real projector-camera rigs (docs/hardware.md).", no_args_is_help=True)
app.add_typer(rig_app, name="rig")


@rig_app.command()
@handle_errors
def check(
    projector: ProjectorOpt = None,
    camera: CameraOpt = None,
    exposure_ms: ExposureOpt = None,
    gain_db: GainOpt = None,
    pixel_format: PixelFormatOpt = None,
    changes: Annotated[int, typer.Option(help="Display changes timed.")] = 6,
    max_latency: Annotated[int, typer.Option(help="Grabs after a change before giving up.")] = 10,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Also write the JSON report here.")
    ] = None,
    force: Annotated[bool, typer.Option(help="Replace an existing report file.")] = False,
) -> None:
    """Measure the display-to-capture latency, pick a safe settle, check white, report noise.

    The projector alternates black and white; the grabs until each change shows are the
    latency (in frames). The report (JSON on stdout, and in OUTPUT with -o) recommends --discard
    (the latency) and --settle (one grab period beyond it) for capture, says whether white
    clips at the exposure given (saturated fraction), and gives the camera noise (standard
    deviation of repeated grabs of a static gray frame).
    """
    from hdrfringe.captures import CameraSettings
    from hdrfringe.hardware.camera import open_camera
    from hdrfringe.hardware.rig import check_rig, open_projector
    from hdrfringe.io.results import check_output_file, staged_output_file

    if projector is None or camera is None:
        raise InputError("give both --projector SPEC and --camera SPEC (docs/hardware.md)")
    checked = None if output is None else check_output_file(output, force)
    result = check_rig(
        open_projector(projector),
        open_camera(camera),
        settings=CameraSettings(exposure_ms=exposure_ms, gain_db=gain_db),
        pixel_format=pixel_format,
        changes=changes,
        max_latency=max_latency,
    )
    report = {"projector": projector, "camera": camera, **result.to_dict()}
    text = json.dumps(report, indent=1) + "\n"
    if checked is not None:
        with staged_output_file(checked, force=force) as tmp:
            tmp.write_text(text, encoding="utf-8")
    typer.echo(text, nl=False)
