"""``hdrfringe rig check``: latency, safe settle, white clipping and noise of a real rig.

The work is :func:`hdrfringe.tasks.rig_check.check_rig_folder`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, err_console, handle_errors
from hdrfringe.cli._options import given_names
from hdrfringe.cli.capture import (
    CameraOpt,
    ExposureOpt,
    GainOpt,
    PixelFormatOpt,
    ProjectorOpt,
    RigConfigOpt,
    ViewCheckOpt,
)

__all__ = ["check", "rig_app"]

rig_app = typer.Typer(help="Real projector-camera rigs (docs/hardware.md).", no_args_is_help=True)
app.add_typer(rig_app, name="rig")


@rig_app.command()
@handle_errors
def check(
    ctx: typer.Context,
    rig_config: RigConfigOpt = None,
    projector: ProjectorOpt = None,
    camera: CameraOpt = None,
    exposure_ms: ExposureOpt = None,
    gain_db: GainOpt = None,
    pixel_format: PixelFormatOpt = None,
    view_check: ViewCheckOpt = True,
    changes: Annotated[int, typer.Option(help="Display changes timed.")] = 6,
    max_latency: Annotated[int, typer.Option(help="Grabs after a change before giving up.")] = 10,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Also write the JSON report here.")
    ] = None,
    write_config: Annotated[
        Path | None,
        typer.Option(
            "--write-config",
            help="Write the rig configuration (TOML) with the measured settle, discard and "
            "camera noise filled in, for capture --rig-config.",
        ),
    ] = None,
    force: Annotated[
        bool, typer.Option(help="Replace an existing report or configuration file.")
    ] = False,
) -> None:
    """Measure the display-to-capture latency, pick a safe settle, check white, report noise.

    The projector alternates black and white; the grabs until each change shows are the
    latency (in grabs), the time until then its latency in seconds. Two more changes, timed
    after waiting that long, tell whether the latency passes with time (then --settle covers
    it) or counts grabs (a camera queue: only --discard covers it, and the settle is 0); the
    report (JSON on stdout, and in OUTPUT with -o) recommends --settle and --discard so, says
    whether white clips at the exposure given (saturated fraction), and gives the camera noise
    (standard deviation of repeated grabs of a static gray frame). The rig comes from --rig-config
    and/or the options (an option given overrides the file); --write-config writes it back
    with sync.settle_s and sync.discard set to the recommended values and camera.read_noise_dn
    to the noise (capture records it for the predicted std). First the view check of capture:
    a camera whose image does not follow the projector (white, black, white) is refused in one
    line (--no-view-check, or sync.view_check = false, skips it).
    """
    from hdrfringe.tasks.rig_check import check_rig_folder

    hardware = {
        "projector": projector, "camera": camera, "exposure_ms": exposure_ms,
        "gain_db": gain_db, "pixel_format": pixel_format, "view_check": view_check,
    }  # fmt: skip
    report = check_rig_folder(
        rig_config, hardware, given=given_names(ctx, tuple(hardware)), changes=changes,
        max_latency=max_latency, output=output, write_config=write_config, force=force,
    )  # fmt: skip
    typer.echo(report.text, nl=False)
    if write_config is not None:  # stdout holds the JSON report only
        err_console.print(f"wrote {write_config}", highlight=False)
