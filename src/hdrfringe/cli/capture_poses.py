"""``hdrfringe capture-poses``: the board poses of a stereo calibration, captured live.

For each pose the user places the board and presses Enter (or, with ``--interval``, the
program waits that long: an automated rig); the rig then projects the program that
``hdrfringe calibrate-stereo POSE...`` reads (:func:`hdrfringe.rig.board_poses.board_program`:
vertical and horizontal fringe sets decodable to absolute phase, then a white frame) and each
complete pose is written as a capture folder ``OUT/pose_01``, ``OUT/pose_02``, ...
docs/hardware.md ("capture-poses") describes it. The rig comes from ``--rig-config`` and the
hardware options exactly as for ``capture`` (:func:`hdrfringe.tasks.capture.hardware_rig`); the work
is :func:`hdrfringe.tasks.capture_poses.capture_poses`.
"""

from __future__ import annotations

import math
import shlex
import sys
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, parse_floats
from hdrfringe.cli._options import GammaOpt, StepsOpt, given_names
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

__all__ = ["capture_poses"]

def _wait_for_pose(number: int, total: int, interval: float | None) -> bool:
    """Wait until pose ``number`` is in place; False when the user asks to finish.

    Interactive (``interval`` None): a prompt, then one line from stdin; ``q`` (or the end of
    the input) finishes. Otherwise: ``interval`` seconds before every pose but the first.
    """
    if interval is not None:
        if number > 1:
            time.sleep(interval)
        return True
    console.print(
        f"pose {number}/{total}: place the board, then press Enter (q and Enter: finish)",
        highlight=False,
    )
    answer = sys.stdin.readline()
    return bool(answer) and answer.strip().lower() not in ("q", "quit")


@app.command("capture-poses")
@handle_errors
def capture_poses(
    ctx: typer.Context,
    rig_config: RigConfigOpt = None,
    projector: ProjectorOpt = None,
    camera: CameraOpt = None,
    output: Annotated[
        Path | None,
        typer.Option("-o", "--output", help="Folder for pose_01, pose_02, ... (required)."),
    ] = None,
    poses: Annotated[int, typer.Option("--poses", help="Number of board poses.")] = 10,
    interval: Annotated[
        float | None,
        typer.Option(
            help="Seconds between poses, without asking (an automated rig); default: press "
            "Enter for each pose."
        ),
    ] = None,
    steps: StepsOpt = 4,
    pitch: Annotated[
        str | None,
        typer.Option(
            help="Fringe pitches in projector px, coarsest first spanning the projector; "
            "default 1024,96,16 (scaled up for a larger projector)."
        ),
    ] = None,
    imin: Annotated[float, typer.Option(help="Minimum input gray level of the fringes.")] = 20.0,
    gamma: GammaOpt = 2.812,
    sync: SyncOpt = "software",
    settle: SettleOpt = 0.1,
    discard: DiscardOpt = 0,
    max_grabs: MaxGrabsOpt = 5,
    exposure_ms: ExposureOpt = None,
    gain_db: GainOpt = None,
    pixel_format: PixelFormatOpt = None,
    view_check: ViewCheckOpt = True,
    board: Annotated[
        str | None,
        typer.Option(
            help="The board, PATTERN:COLSxROWS:SPACING_MM as calibrate-stereo takes it (e.g. "
            "checkerboard:9x6:25): the command printed at the end then runs as printed."
        ),
    ] = None,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Capture the board poses of a stereo calibration live, one capture folder per pose.

    Before each pose: place the board and press Enter (q and Enter, or the end of the input,
    finishes early); with --interval S the program waits S seconds instead. Each pose is the
    program `calibrate-stereo OUT/pose_*` reads (vertical and horizontal fringe sets, coarsest
    pitch spanning the projector, then a white frame), written as OUT/pose_NN with
    capture_log.json; OUT/capture_poses.json lists the poses. OUT appears when the run ends,
    holding complete poses only. Ctrl-C or an error mid-run keeps the complete poses, drops
    the one being captured, and exits with code 2 (before the first pose: nothing written);
    SIGTERM and SIGHUP do the same with exit code 143 and 129.
    The rig comes from --rig-config FILE and/or the options (an option given overrides the
    file), as for capture. With --board the last line is `next: hdrfringe calibrate-stereo
    ...`, a command that runs as printed; without it, how to calibrate with your board.
    """
    from hdrfringe.tasks.capture_poses import capture_poses as task

    if output is None:
        raise InputError("no output folder: give -o/--output POSES")
    if interval is not None and not (math.isfinite(interval) and interval >= 0):
        raise InputError(f"--interval {interval}: give a number of seconds >= 0")
    hardware = {
        "projector": projector, "camera": camera, "sync": sync, "settle": settle,
        "discard": discard, "max_grabs": max_grabs, "gamma": gamma, "exposure_ms": exposure_ms,
        "gain_db": gain_db, "pixel_format": pixel_format, "view_check": view_check,
    }  # fmt: skip
    report = task(
        output, rig_config, hardware, given=given_names(ctx, tuple(hardware)), poses=poses,
        wait=lambda number, total: _wait_for_pose(number, total, interval), steps=steps,
        pitches=None if pitch is None else parse_floats(pitch, "--pitch"), imin=imin,
        board=board, force=force, say=lambda line: console.print(line, highlight=False),
    )  # fmt: skip
    _print_report(report)


def _print_report(report: Any) -> None:
    """What ``capture-poses`` prints once the poses are written: the folder, and the next
    step (the calibrate-stereo command when --board was given)."""
    from hdrfringe.core.stereo_calibration import MIN_POSES

    output, names, stopped = report.output, report.names, report.stopped
    what = f"{len(names)} complete poses ({names[0]} .. {names[-1]})"
    console.print(
        f"wrote {output}: {what}{'' if stopped is None else f', {stopped}'}", highlight=False
    )
    if len(names) < MIN_POSES:
        console.print(
            f"warning: calibrate-stereo needs at least {MIN_POSES} poses; capture more",
            highlight=False,
        )
    if report.board is None:
        console.print(
            f"to calibrate: hdrfringe calibrate-stereo {output}/pose_* --board "
            "PATTERN:COLSxROWS:SPACING_MM -o STEREO.h5, with your board's pattern, inner "
            "corners and spacing (capture-poses --board prints the command)",
            highlight=False,
            soft_wrap=True,
        )
    elif len(names) >= MIN_POSES:
        command = [
            "hdrfringe", "calibrate-stereo", *(str(output / n) for n in names),
            "--board", report.board, "-o", str(output / "stereo.h5"),
        ]  # fmt: skip
        console.print(f"next: {shlex.join(command)}", highlight=False, soft_wrap=True)
