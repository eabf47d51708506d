"""``hdrfringe capture-poses``: the board poses of a stereo calibration, captured live.

For each pose the user places the board and presses Enter (or, with ``--interval``, the
program waits that long: an automated rig); the rig then projects the program that
``hdrfringe calibrate-stereo POSE...`` reads (:func:`hdrfringe.rig.board_poses.board_program`:
vertical and horizontal fringe sets decodable to absolute phase, then a white frame) and each
complete pose is written as a capture folder ``OUT/pose_01``, ``OUT/pose_02``, ...
docs/hardware.md ("capture-poses") describes it. The rig comes from ``--rig-config`` and the
hardware options exactly as for ``capture`` (:func:`hdrfringe.cli.capture.hardware_rig`).
"""

from __future__ import annotations

import json
import math
import shlex
import sys
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, parse_floats
from hdrfringe.cli._options import GammaOpt, StepsOpt
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
    hardware_rig,
    live_record,
    write_capture_output,
)
from hdrfringe.errors import HdrFringeError, InputError

__all__ = ["POSES_LOG", "board_pitches", "capture_poses"]

#: The summary ``capture-poses`` writes in OUT beside the pose folders.
POSES_LOG = "capture_poses.json"


def board_pitches(width: int, height: int) -> tuple[float, ...]:
    """The default fringe pitches of a board pose for a projector of this size.

    :data:`~hdrfringe.rig.board_poses.BOARD_PITCHES_PX` (1024, 96, 16) when 1024 px spans the
    projector; for a larger projector the two coarse pitches grow with it (one period over
    the projector, then the same ratio to the middle pitch), so the coarsest still gives an
    absolute phase and the ratios stay below 13 (temporal unwrapping).

    Parameters
    ----------
    width, height : int
        Projector size in pixels.

    Returns
    -------
    tuple of float
        Coarsest first.

    References
    ----------
    Thesis Sec. 2.5 (temporal phase unwrapping).

    Examples
    --------
    >>> board_pitches(800, 600)
    (1024.0, 96.0, 16.0)
    >>> board_pitches(1920, 1080)
    (1920.0, 180.0, 16.0)
    """
    from hdrfringe.rig.board_poses import BOARD_PITCHES_PX

    coarse, middle, fine = BOARD_PITCHES_PX
    span = max(width, height)
    if span <= coarse:
        return BOARD_PITCHES_PX
    return (float(span), float(round(span * middle / coarse)), fine)


def _poses_rig(ctx: typer.Context, rig_config: Path | None, **options: Any) -> Any:
    """The (not yet open) hardware rig and its resolved configuration: the one place this
    command builds it (:func:`~hdrfringe.cli.capture.hardware_rig`, from ``--rig-config`` and
    the hardware ``options``)."""
    return hardware_rig(ctx, rig_config, **options)


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
    the one being captured, and exits with code 2 (before the first pose: nothing written).
    The rig comes from --rig-config FILE and/or the options (an option given overrides the
    file), as for capture. With --board the last line is `next: hdrfringe calibrate-stereo
    ...`, a command that runs as printed; without it, how to calibrate with your board.
    """
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_dir,
        staged_output_dir,
    )
    from hdrfringe.rig.board_poses import MAX_BOARD_POSES, board_program
    from hdrfringe.stereo_calibration import MIN_POSES, BoardSpec

    if output is None:
        raise InputError("no output folder: give -o/--output POSES")
    if isinstance(poses, bool) or not 1 <= poses <= MAX_BOARD_POSES:
        raise InputError(f"--poses {poses}: give 1..{MAX_BOARD_POSES} (10 or more recommended)")
    if interval is not None and not (math.isfinite(interval) and interval >= 0):
        raise InputError(f"--interval {interval}: give a number of seconds >= 0")
    pitches = None if pitch is None else parse_floats(pitch, "--pitch")
    spec = None if board is None else BoardSpec.parse(board)
    rig, config = _poses_rig(
        ctx, rig_config, projector=projector, camera=camera, sync=sync, settle=settle,
        discard=discard, max_grabs=max_grabs, gamma=gamma, exposure_ms=exposure_ms,
        gain_db=gain_db, pixel_format=pixel_format, view_check=view_check,
    )  # fmt: skip
    check_output_against_inputs(output, [rig_config, config.gamma_file])
    checked = check_output_dir(output, force)
    names: list[str] = []
    stopped: str | None = None
    failure: HdrFringeError | None = None
    with rig, staged_output_dir(checked, force=force) as tmp:
        width, height = rig.projector.width, rig.projector.height
        used = tuple(pitches) if pitches is not None else board_pitches(width, height)
        # rig.projector: the open projector's size, 8 bit, the rig's gamma pre-compensation
        program = board_program(rig.projector, steps=steps, pitches=used, imin=imin)
        entries: dict[str, Any] = {"program": "board poses", "pitches": list(used), "steps": steps}
        state: dict[str, Any] = {}
        name = f" ({config.name})" if config.name else ""
        console.print(
            f"board poses live{name}: projector {config.projector.spec} ({width}x{height}), "
            f"camera {config.camera.spec}; {len(program)} frames per pose (pitches "
            f"{', '.join(f'{p:g}' for p in used)})",
            highlight=False,
        )
        for number in range(1, poses + 1):
            try:
                if not _wait_for_pose(number, poses, interval):
                    stopped = "finished with q"
                    break
                rig.rebaseline()  # the board moved: a new reference image of the screen
                start = len(rig.log)
                recorder = Recorder(rig)
                recorder.capture(program)
            except KeyboardInterrupt:
                if not names:
                    raise
                stopped = "interrupted (Ctrl-C)"
                break
            except HdrFringeError as err:
                if not names:
                    raise
                stopped = f"stopped by an error at pose {number}"
                failure = err
                break
            folder = f"pose_{number:02d}"
            caps, state, log = live_record(
                recorder, rig, config, None, folder, entries={**entries, "pose": number},
                start=start,
            )  # fmt: skip
            with staged_output_dir(tmp / folder) as pose_dir:
                write_capture_output(pose_dir, caps, state, log)
            names.append(folder)
            rejected = sum(t.rejected for t in rig.log[start:])
            console.print(
                f"pose {number}: {len(caps.frames)} images, {rejected} stale grabs rejected",
                highlight=False,
            )
        if not names:
            raise HdrFringeError(
                f"capture-poses {stopped or 'stopped'} before the first pose; nothing written"
            )
        # the last pose's record without its pose, for the whole run
        summary = {k: v for k, v in state.items() if k not in ("pose", "complete")}
        summary.update({"poses": names, "complete": len(names) == poses})
        if spec is not None:
            summary["board"] = _board_text(spec)
        if stopped is not None:
            summary["stopped"] = stopped
        (tmp / POSES_LOG).write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    what = f"{len(names)} complete poses ({names[0]} .. {names[-1]})"
    if failure is not None or stopped == "interrupted (Ctrl-C)":
        why = stopped if failure is None else f"{stopped}: {' '.join(str(failure).split())}"
        raise HdrFringeError(
            f"capture-poses {why}; {output} holds the {what} captured before it, the pose "
            "being captured was dropped"
        )
    console.print(
        f"wrote {output}: {what}{'' if stopped is None else f', {stopped}'}", highlight=False
    )
    if len(names) < MIN_POSES:
        console.print(
            f"warning: calibrate-stereo needs at least {MIN_POSES} poses; capture more",
            highlight=False,
        )
    if spec is None:
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
            "--board", _board_text(spec), "-o", str(output / "stereo.h5"),
        ]  # fmt: skip
        console.print(f"next: {shlex.join(command)}", highlight=False, soft_wrap=True)


def _board_text(spec: Any) -> str:
    """A :class:`~hdrfringe.stereo_calibration.BoardSpec` as ``--board`` takes it."""
    return f"{spec.pattern}:{spec.cols}x{spec.rows}:{spec.spacing_mm:g}"
