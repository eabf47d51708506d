"""``hdrfringe capture-gamma``: project the gamma-estimation program live, write a capture folder.

The program is the one ``hdrfringe gamma FOLDER`` fits (:func:`hdrfringe.core.gamma.gamma_report`):
uniform grays (the same builder as ``simulate --gray``,
:func:`hdrfringe.core.programs.fringe_program`) and one wide sinusoidal set shown at each of
several pre-distortion exponents (kamino410's design, docs/gamma.md "From fringes").
docs/hardware.md ("capture-gamma") describes it.

The work is :func:`hdrfringe.tasks.capture_gamma.capture_gamma`. The rig comes from
``--rig-config`` and the hardware options as for ``capture``
(:func:`hdrfringe.tasks.capture.hardware_rig`), with one exception: the grays are always sent
with the command's own ``--gamma`` (default 1, the projector's raw response), never with the
configuration's gamma, so that the capture is taken with a known pre-compensation whatever
the file says; the configuration's gamma is recorded and judged against the fit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors, parse_floats, parse_range
from hdrfringe.cli._options import StepsOpt, given_names
from hdrfringe.cli.capture import (
    CameraOpt,
    DiscardOpt,
    ExposureOpt,
    GainOpt,
    MaxGrabsOpt,
    PixelFormatOpt,
    ProjectorOpt,
    RigConfigOpt,
    SettleOpt,
    SyncOpt,
    ViewCheckOpt,
)
from hdrfringe.errors import InputError

__all__ = ["capture_gamma"]

@app.command("capture-gamma")
@handle_errors
def capture_gamma(
    ctx: typer.Context,
    rig_config: RigConfigOpt = None,
    projector: ProjectorOpt = None,
    camera: CameraOpt = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Capture folder to write (required).")
    ] = None,
    grays: Annotated[
        bool, typer.Option(help="Project the uniform grays (a direct fit of the response).")
    ] = True,
    gray: Annotated[
        str, typer.Option(help="Gray levels: start:stop:step or comma-separated.")
    ] = "0:255:15",
    gamma: Annotated[
        float,
        typer.Option(
            help="Pre-compensation the grays are sent with (1: none); give the rig's gamma to "
            "check it. The --rig-config gamma is not sent (it is judged against the fit)."
        ),
    ] = 1.0,
    fringes: Annotated[
        bool, typer.Option(help="Project the sinusoidal set at each --fringe-gamma (shape fit).")
    ] = True,
    fringe_gamma: Annotated[
        str, typer.Option(help="Pre-distortion exponents of the fringe set, comma-separated.")
    ] = "0.75,1.25",
    fringe_pitch: Annotated[
        float, typer.Option(help="Fringe pitch in projector px (>= 32: wide fringes).")
    ] = 128.0,
    steps: StepsOpt = 4,
    sync: SyncOpt = "software",
    settle: SettleOpt = 0.1,
    discard: DiscardOpt = 0,
    max_grabs: MaxGrabsOpt = 5,
    exposure_ms: ExposureOpt = None,
    gain_db: GainOpt = None,
    pixel_format: PixelFormatOpt = None,
    view_check: ViewCheckOpt = True,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Project the gamma-estimation program live and write the capture folder `gamma` reads.

    Uniform grays (sent with --gamma) and one wide sinusoidal set (imin 0, full scale) sent
    at each --fringe-gamma exponent, with capture_log.json beside the manifest; then the fits
    of `hdrfringe gamma` are printed with a verdict on the pre-compensation in use (--gamma).
    The rig comes from --rig-config FILE and/or the options (an option given overrides the
    file), except the gamma: the grays are sent with --gamma (default 1) whatever the file
    says; the file's gamma is recorded and gets a verdict of its own. Ctrl-C keeps the
    complete groups (the grays, each fringe set) and marks the folder incomplete (exit 2;
    before the first group: nothing written, exit 130). Any other error writes nothing.
    """
    from hdrfringe.tasks.capture_gamma import capture_gamma as task

    if output is None:
        raise InputError("no output folder: give -o/--output CAPTURES")
    if not (grays or fringes):
        raise InputError("nothing to project: leave --grays or --fringes on")
    hardware = {
        "projector": projector, "camera": camera, "sync": sync, "settle": settle,
        "discard": discard, "max_grabs": max_grabs, "exposure_ms": exposure_ms,
        "gain_db": gain_db, "pixel_format": pixel_format, "view_check": view_check,
    }  # fmt: skip
    report = task(
        output, rig_config, hardware, given=given_names(ctx, tuple(hardware)),
        levels=parse_range(gray, "--gray") if grays else [], gray_text=gray, gamma=gamma,
        exponents=parse_floats(fringe_gamma, "--fringe-gamma") if fringes else [],
        exponents_text=fringe_gamma, fringe_pitch=fringe_pitch, steps=steps, force=force,
        say=console.print,
    )  # fmt: skip
    console.print(f"captured {report.images} images; wrote {output}")
    if report.warning is not None:
        console.print(f"warning: {report.warning}", highlight=False)
        return
    for line in report.lines:
        console.print(line, highlight=False)
    console.print(f"hdrfringe gamma {output} -o OUT writes the fits and plots", highlight=False)
