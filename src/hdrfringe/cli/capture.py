"""``hdrfringe capture``: run a strategy live on a projector and camera, write a capture folder.

The hardware options every live command declares live here too; the work is
:func:`hdrfringe.tasks.capture.capture`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors
from hdrfringe.cli._measure_options import (
    ForceOpt,
    MethodOpt,
    StrategyOpt,
    strategy_params,
)
from hdrfringe.cli._options import (
    DEFAULT_PITCHES,
    HARDWARE_PANEL,
    CameraOpt,
    CenterlineOpt,
    DiscardOpt,
    ExposureOpt,
    GainOpt,
    GammaOpt,
    HwCameraOpt,
    HwDiscardOpt,
    HwExposureOpt,
    HwGainOpt,
    HwMaxGrabsOpt,
    HwPixelFormatOpt,
    HwProjectorOpt,
    HwRigConfigOpt,
    HwSettleOpt,
    HwSyncOpt,
    IminOpt,
    LiveMiglOpt,
    MaxGrabsOpt,
    PatternOpt,
    PitchOpt,
    PixelFormatOpt,
    ProjectorOpt,
    RigConfigOpt,
    SettleOpt,
    StepsOpt,
    SyncOpt,
    given_names,
    renamed_option,
)
from hdrfringe.cli._strategy_options import with_strategy_options
from hdrfringe.errors import InputError

__all__ = [
    "HARDWARE_PANEL",
    "CameraOpt",
    "DiscardOpt",
    "ExposureOpt",
    "GainOpt",
    "HwCameraOpt",
    "HwDiscardOpt",
    "HwExposureOpt",
    "HwGainOpt",
    "HwMaxGrabsOpt",
    "HwPixelFormatOpt",
    "HwProjectorOpt",
    "HwRigConfigOpt",
    "HwSettleOpt",
    "HwSyncOpt",
    "HwViewCheckOpt",
    "MaxGrabsOpt",
    "PixelFormatOpt",
    "ProjectorOpt",
    "RigConfigOpt",
    "SettleOpt",
    "SyncOpt",
    "ViewCheckOpt",
    "capture",
]

_VIEW_CHECK_HELP = (
    "Before capturing, check that the camera sees the projector (its image follows white, "
    "black, white) and refuse if not; --no-view-check for a rig whose camera is not meant to "
    "see it (docs/hardware.md)."
)
ViewCheckOpt = Annotated[bool, typer.Option("--view-check/--no-view-check", help=_VIEW_CHECK_HELP)]
HwViewCheckOpt = Annotated[
    bool,
    typer.Option(
        "--view-check/--no-view-check", help=_VIEW_CHECK_HELP, rich_help_panel=HARDWARE_PANEL
    ),
]
@app.command()
@handle_errors
@with_strategy_options
def capture(
    ctx: typer.Context,
    rig_config: RigConfigOpt = None,
    projector: ProjectorOpt = None,
    camera: CameraOpt = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Capture folder to write (required).")
    ] = None,
    strategy: StrategyOpt = "conventional",
    pattern: PatternOpt = "sinusoidal",
    steps: StepsOpt = 4,
    pitch: PitchOpt = DEFAULT_PITCHES,
    imin: IminOpt = 40.0,
    migl: LiveMiglOpt = 255.0,
    centerline: CenterlineOpt = True,
    gamma: GammaOpt = 2.812,
    sync: SyncOpt = "software",
    settle: SettleOpt = 0.1,
    discard: DiscardOpt = 0,
    max_grabs: MaxGrabsOpt = 5,
    exposure_ms: ExposureOpt = None,
    gain_db: GainOpt = None,
    pixel_format: PixelFormatOpt = None,
    view_check: ViewCheckOpt = True,
    force: ForceOpt = False,
    method: MethodOpt = None,
    **strategy_options: Any,
) -> None:
    """Run a strategy live on a projector and camera and write the capture folder.

    The rig comes from --rig-config FILE and/or the options (an option given overrides the
    file). Every set the strategy captured is written (a MIGL sweep of exactly those MIGLs, plus the
    centerline), with capture_log.json (per-frame timing and synchronisation). `measure FOLDER
    --strategy S` with the same strategy options replays it and measures the composite. Ctrl-C
    mid-capture writes the complete sets captured so far, marks the folder incomplete
    (manifest "capture": {"complete": false}) and exits with code 2 (before the first set, or
    a second Ctrl-C while writing: nothing written, code 130). Any other error (sync, camera
    timeout, window closed) writes nothing. Before the first pattern the rig checks that the
    camera sees the projector (white, black, white) and refuses if not (--no-view-check: off).
    """
    from hdrfringe.cli._app import parse_floats
    from hdrfringe.cli._measure_options import given_strategy_options
    from hdrfringe.tasks import capture as task

    if output is None:
        raise InputError("no output folder: give -o/--output CAPTURES")
    strategy = renamed_option(ctx, "strategy", strategy, "method", method) or "conventional"
    params, sources = strategy_params(ctx, strategy, strategy_options)
    hardware = {
        "projector": projector, "camera": camera, "sync": sync, "settle": settle,
        "discard": discard, "max_grabs": max_grabs, "gamma": gamma, "exposure_ms": exposure_ms,
        "gain_db": gain_db, "pixel_format": pixel_format, "view_check": view_check,
    }  # fmt: skip
    pitches = parse_floats(pitch, "--pitch")
    report = task.capture(
        output, rig_config, hardware,
        task.LiveFringes(pattern, steps, pitches, imin, migl, centerline),
        given=given_names(ctx, tuple(hardware)), strategy=strategy, params=params, sources=sources,
        strategy_options=given_strategy_options(ctx, strategy_options), force=force,
        say=console.print,
    )  # fmt: skip
    console.print(
        f"captured {report.images} images ({report.sets} sets), {report.rejected} stale grabs "
        "rejected"
    )
    console.print(f"wrote {output}")
