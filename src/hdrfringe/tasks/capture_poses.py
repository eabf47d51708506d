"""``hdrfringe capture-poses``: the board poses of a stereo calibration, captured live.


For each pose the user places the board and presses Enter (or, with ``--interval``, the
program waits that long: an automated rig); the rig then projects the program that
``hdrfringe calibrate-stereo POSE...`` reads (:func:`hdrfringe.rig.board_poses.board_program`:
vertical and horizontal fringe sets decodable to absolute phase, then a white frame) and each
complete pose is written as a capture folder ``OUT/pose_01``, ``OUT/pose_02``, ...
docs/hardware.md ("capture-poses") describes it. The rig comes from ``--rig-config`` and the
hardware options exactly as for ``capture`` (:func:`hdrfringe.tasks.capture.hardware_rig`).
"""

from __future__ import annotations

import shutil
import signal
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hdrfringe.core import strict_json
from hdrfringe.errors import HdrFringeError, InputError, StoppedError
from hdrfringe.tasks.capture import hardware_rig, live_record, stop_reason, write_capture_output

__all__ = ["POSES_LOG", "CapturePosesReport", "board_pitches", "capture_poses"]

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


def _poses_rig(rig_config: Path | None, given: Collection[str], **options: Any) -> Any:
    """The (not yet open) hardware rig and its resolved configuration: the one place this
    task builds it (:func:`~hdrfringe.tasks.capture.hardware_rig`, from ``--rig-config`` and
    the hardware ``options``)."""
    return hardware_rig(rig_config, given, **options)


@dataclass(frozen=True)
class CapturePosesReport:
    """What ``capture-poses`` wrote.

    Parameters
    ----------
    output : Path
        The folder of pose folders.
    names : list of str
        The complete poses written (``pose_01``, ...).
    stopped : str or None
        Why the run ended before the last pose (finished with q).
    board : str or None
        The board as ``--board`` takes it, when given.

    Examples
    --------
    >>> CapturePosesReport(Path("poses"), ["pose_01", "pose_02"], "finished with q", None).names[-1]
    'pose_02'
    """

    output: Path
    names: list[str]
    stopped: str | None
    board: str | None


def capture_poses(
    output: Path,
    rig_config: Path | None,
    hardware: Mapping[str, Any],
    *,
    wait: Callable[[int, int], bool],
    given: Collection[str] = (),
    poses: int = 10,
    steps: int = 4,
    pitches: Sequence[float] | None = None,
    imin: float = 20.0,
    board: str | None = None,
    force: bool = False,
    say: Callable[[str], Any] | None = None,
) -> CapturePosesReport:
    """Capture the board poses live, one capture folder per pose, and their summary.

    The output is checked before the rig opens and appears when the run ends, holding the
    complete poses only. Ctrl-C or an error mid-run keeps the complete poses, drops the one
    being captured and raises :class:`~hdrfringe.errors.HdrFringeError`; before the first
    pose nothing is written.

    Parameters
    ----------
    output : Path
        The folder for ``pose_01``, ``pose_02``, ...
    rig_config : Path or None
        The rig configuration file.
    hardware : mapping
        Hardware options by Python name (:data:`~hdrfringe.tasks.capture.RIG_OPTION_KEYS`).
    wait : callable
        ``wait(number, total)``: returns once pose ``number`` is in place; False finishes.
    given : collection of str
        The hardware options given explicitly.
    poses : int
        Number of poses.
    steps : int
        Phase shifts per set.
    pitches : sequence of float, optional
        Fringe pitches, coarsest first; default :func:`board_pitches`.
    imin : float
        Lowest input gray level of the fringes.
    board : str, optional
        ``PATTERN:COLSxROWS:SPACING_MM``, recorded for the calibration.
    force : bool
        Replace an existing output folder.
    say : callable, optional
        Called with the line saying the rig is open, and one line per pose captured.

    Returns
    -------
    CapturePosesReport

    Examples
    --------
    >>> capture_poses(Path("poses"), None, {}, wait=lambda number, total: True, poses=0)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --poses 0: give 1..100 (10 or more recommended)
    """
    from hdrfringe.core.stereo_calibration import BoardSpec
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.io.results import (
        SignalStop,
        check_output_against_inputs,
        check_output_dir,
        deferred_signals,
        signals_as_interrupt,
        staged_output_dir,
    )
    from hdrfringe.rig.board_poses import MAX_BOARD_POSES, board_program

    def tell(line: str) -> None:
        if say is not None:
            say(line)

    if isinstance(poses, bool) or not 1 <= poses <= MAX_BOARD_POSES:
        raise InputError(f"--poses {poses}: give 1..{MAX_BOARD_POSES} (10 or more recommended)")
    spec = None if board is None else BoardSpec.parse(board)
    rig, config = _poses_rig(rig_config, given, **hardware)
    check_output_against_inputs(output, [rig_config, config.gamma_file])
    checked = check_output_dir(output, force)
    names: list[str] = []
    stopped: str | None = None
    code = 0  # the exit code of a stop by Ctrl-C (2), SIGTERM (143) or SIGHUP (129)
    failure: HdrFringeError | None = None
    dropped = True  # a stop (signal, error) came before the pose being captured was written
    with rig, staged_output_dir(checked, force=force) as tmp:
        width, height = rig.projector.width, rig.projector.height
        used = tuple(pitches) if pitches is not None else board_pitches(width, height)
        # rig.projector: the open projector's size, 8 bit, the rig's gamma pre-compensation
        program = board_program(rig.projector, steps=steps, pitches=used, imin=imin)
        entries: dict[str, Any] = {"program": "board poses", "pitches": list(used), "steps": steps}
        state: dict[str, Any] = {}
        name = f" ({config.name})" if config.name else ""
        tell(
            f"board poses live{name}: projector {config.projector.spec} ({width}x{height}), "
            f"camera {config.camera.spec}; {len(program)} frames per pose (pitches "
            f"{', '.join(f'{p:g}' for p in used)})"
        )
        for number in range(1, poses + 1):
            folder = f"pose_{number:02d}"
            try:
                with signals_as_interrupt():  # SIGTERM, SIGHUP: kept as for Ctrl-C (issue 31)
                    if not wait(number, poses):
                        stopped = "finished with q"
                        break
                    rig.rebaseline()  # the board moved: a new reference image of the screen
                    start = len(rig.log)
                    recorder = Recorder(rig)
                    recorder.capture(program)
                    # the pose is captured: it is written whole with the signals held, then a
                    # signal stops the run keeping it (a SIGTERM here lost every pose, issue 31)
                    with deferred_signals(honour=False) as held:
                        caps, state, log = live_record(
                            recorder, rig, config, None, folder,
                            entries={**entries, "pose": number}, start=start,
                        )  # fmt: skip
                        _write_pose(tmp / folder, caps, state, log)
                        names.append(folder)
                    rejected = sum(t.rejected for t in rig.log[start:])
                    tell(f"pose {number}: {len(caps.frames)} images, {rejected} stale grabs "
                         "rejected")  # fmt: skip
                    if held() == signal.SIGINT:
                        raise KeyboardInterrupt
                    if held() is not None:
                        raise SignalStop(int(held() or 0))
            except KeyboardInterrupt as stop:
                if not names:
                    raise
                stopped, code = stop_reason(stop)
                dropped = names[-1] != folder
                break
            except HdrFringeError as err:
                if not names:
                    raise
                stopped = f"stopped by an error at pose {number}"
                failure = err
                break
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
        (tmp / POSES_LOG).write_text(strict_json.dumps(summary) + "\n", encoding="utf-8")
    what = f"{len(names)} complete poses ({names[0]} .. {names[-1]})"
    if failure is not None or code:
        why = stopped if failure is None else f"{stopped}: {' '.join(str(failure).split())}"
        raise StoppedError(
            f"capture-poses {why}; {output} holds the {what} captured before it"
            + (", the pose being captured was dropped" if dropped else ""),
            code or 2,
        )
    return CapturePosesReport(output, names, stopped, None if spec is None else _board_text(spec))


def _write_pose(folder: Path, caps: Any, state: dict[str, Any], log: dict[str, Any]) -> None:
    """Write one pose's capture folder (inside the run's staging), whole or not at all: a
    failure removes the folder, so a run that keeps its complete poses keeps no partial one."""
    folder.mkdir()
    try:
        write_capture_output(folder, caps, state, log)
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise


def _board_text(spec: Any) -> str:
    """A :class:`~hdrfringe.core.stereo_calibration.BoardSpec` as ``--board`` takes it."""
    return f"{spec.pattern}:{spec.cols}x{spec.rows}:{spec.spacing_mm:g}"
