"""``hdrfringe acceptance``: the VDI/VDE 2634 Part 2 acceptance test (docs/acceptance.md); the
work is :func:`hdrfringe.tasks.acceptance.acceptance_sim` (``--rig sim``),
:func:`~hdrfringe.tasks.acceptance.acceptance_hardware` (``--rig hardware``) or
:func:`~hdrfringe.tasks.acceptance.acceptance_offline` (captured position folders)."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_stage
from hdrfringe.cli._measure_options import ForceOpt, OutputOpt
from hdrfringe.cli._options import (
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
    LiveAmbientOpt,
    LiveNoiseOpt,
    LiveSeedOpt,
    given_names,
)
from hdrfringe.cli.capture import HwViewCheckOpt
from hdrfringe.errors import InputError

__all__ = ["acceptance"]

LIVE = "Live virtual rig (--rig sim)"
FoldersArg = Annotated[
    list[Path] | None,
    typer.Argument(
        help="Capture folders of positions, each with acceptance_position.json (kind, label); "
        "evaluated offline with --calibration and --file.",
        show_default=False,
    ),
]
RigOpt = Annotated[
    str | None,
    typer.Option(
        help="sim: the whole procedure on the virtual rig; hardware: live, prompting per "
        "position (--rig-config and/or --projector, --camera) instead of FOLDERs."
    ),
]
FileOpt = Annotated[
    Path | None,
    typer.Option(
        "--file",
        help="Acceptance file (TOML: MPEs, calibrated artefacts; docs/examples/acceptance.toml). "
        "Required for FOLDERs and hardware; with --rig sim the virtual artefacts are made to its "
        "sizes (default: guideline sizes and the virtual rig's MPEs).",
    ),
]
CalOpt = Annotated[
    Path | None,
    typer.Option(
        "--calibration",
        "-c",
        help="Stereo calibration (calibrate-stereo). Required for FOLDERs and hardware; with "
        "--rig sim default: calibrate the virtual rig (calibrate-stereo --rig sim), kept as "
        "OUT/calibration.h5.",
    ),
]
StrategyListOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--strategy",
        help="Strategy rows as compare names them (conventional, uniform, lpa-5, dpa-bound, "
        "multiexposure, tolerant, adaptive, ...); with --rig sim repeat it for the HDR table "
        "side by side. Default conventional.",
    ),
]
PositionsOpt = Annotated[
    str | None,
    typer.Option(
        help="Positions to run, e.g. sphere:1-3,ball_bar:1,plane (numbers from 1, as the labels "
        "sphere_01...); default all 23 (those of the artefacts the file calibrates)."
    ),
]
GlossyOpt = Annotated[bool, typer.Option(help="Glossy artefacts (saturate).", rich_help_panel=LIVE)]
SizeOpt = Annotated[
    str | None, typer.Option(help="Camera WIDTHxHEIGHT (default 640x480).", rich_help_panel=LIVE)
]
KeepOpt = Annotated[
    bool,
    typer.Option(
        help="Also write each position's capture folder under OUT/captures/STRATEGY/POSITION "
        "(what acceptance FOLDER... reads).",
        rich_help_panel=LIVE,
    ),
]
RepeatsOpt = Annotated[
    int,
    typer.Option(
        help="With --rig sim and no --calibration: calibrate N more times (the next noise "
        "seeds) and add the spread of PS and SD over the calibrations to their predicted std "
        "(0: the phase noise's only).",
        rich_help_panel=LIVE,
    ),
]
IntervalOpt = Annotated[
    float | None,
    typer.Option(
        help="With --rig hardware: seconds between positions, without asking (an automated "
        "rig); default: press Enter for each position."
    ),
]


@app.command()
@handle_errors
def acceptance(
    ctx: typer.Context,
    folders: FoldersArg = None,
    output: OutputOpt = None,
    rig: RigOpt = None,
    file: FileOpt = None,
    calibration: CalOpt = None,
    strategy: StrategyListOpt = None,
    positions: PositionsOpt = None,
    glossy: GlossyOpt = False,
    ambient_lux: LiveAmbientOpt = 0.0,
    size: SizeOpt = None,
    seed: LiveSeedOpt = 0,
    noise: LiveNoiseOpt = 1.0,
    keep_captures: KeepOpt = False,
    calibration_repeats: RepeatsOpt = 4,
    interval: IntervalOpt = None,
    rig_config: HwRigConfigOpt = None,
    projector: HwProjectorOpt = None,
    camera: HwCameraOpt = None,
    gamma: GammaOpt = 2.812,
    sync: HwSyncOpt = "software",
    settle: HwSettleOpt = 0.1,
    discard: HwDiscardOpt = 0,
    max_grabs: HwMaxGrabsOpt = 5,
    exposure_ms: HwExposureOpt = None,
    gain_db: HwGainOpt = None,
    pixel_format: HwPixelFormatOpt = None,
    view_check: HwViewCheckOpt = True,
    force: ForceOpt = False,
) -> None:
    """Acceptance test of the measuring system (VDI/VDE 2634 Part 2): probing error form and
    size (PF, PS) of a sphere at 10 positions, sphere-spacing error (SD) of a ball bar at 7,
    flatness error (F) of a plane at 6, each against its MPE. --rig sim runs it on the virtual
    rig (calibrated first unless --calibration is given), per --strategy: the HDR table.
    --rig hardware runs it live: before each position place the artefact and press Enter (q
    finishes; --interval S waits instead); Ctrl-C keeps the complete positions (exit 2). With
    FOLDERs it evaluates captured positions. Writes OUT/acceptance.json, acceptance.md,
    quantities.png and residuals/STRATEGY/POSITION.tiff + .png (docs/acceptance.md).
    """
    from hdrfringe.tasks import acceptance as task

    if output is None:
        raise InputError("no output folder: give -o/--output OUT")
    if rig is not None and folders:
        raise InputError("give either FOLDERs (captured positions) or --rig, not both")
    if rig is None:
        if calibration is None or file is None:
            raise InputError(
                "captured positions need --calibration CAL and --file acceptance.toml "
                "(or run --rig sim)"
            )
        report = task.acceptance_offline(
            folders or [], output, calibration=calibration, file=file, force=force,
            progress=progress_stage,
        )  # fmt: skip
    elif rig == "sim":
        report = task.acceptance_sim(
            output, file=file, calibration=calibration, strategies=strategy or ["conventional"],
            positions=positions, glossy=glossy, ambient_lux=ambient_lux, size=task.parse_size(size),
            seed=seed, noise=noise, keep_captures=keep_captures, force=force,
            calibration_repeats=calibration_repeats, progress=progress_stage,
        )  # fmt: skip
    elif rig == "hardware":
        hardware = {
            "rig_config": rig_config, "projector": projector, "camera": camera, "sync": sync,
            "settle": settle, "discard": discard, "max_grabs": max_grabs, "gamma": gamma,
            "exposure_ms": exposure_ms, "gain_db": gain_db, "pixel_format": pixel_format,
            "view_check": view_check,
        }  # fmt: skip
        report = _hardware(ctx, output, hardware, interval, calibration, file, strategy, positions,
                           force)  # fmt: skip
    else:
        raise InputError(f"--rig {rig!r}: use sim or hardware, or give captured position FOLDERs")
    _print_report(report)


def _hardware(
    ctx: typer.Context, output: Path, hardware: dict[str, Any], interval: float | None,
    calibration: Path | None, file: Path | None, strategy: list[str] | None,
    positions: str | None, force: bool,
) -> Any:  # fmt: skip
    """``--rig hardware``: the options checked, the task run with the prompt."""
    from hdrfringe.tasks.acceptance import acceptance_hardware

    if interval is not None and not (math.isfinite(interval) and interval >= 0):
        raise InputError(f"--interval {interval}: give a number of seconds >= 0")
    if strategy and len(strategy) > 1:
        raise InputError("--rig hardware runs one --strategy; run it again for another")
    rig_config = hardware.pop("rig_config")
    return acceptance_hardware(
        output, rig_config, hardware,
        given=given_names(ctx, tuple(hardware)),
        wait=lambda n, total, label: _wait_for_position(n, total, label, interval),
        calibration=calibration, file=file, strategy=(strategy or ["conventional"])[0],
        positions=positions, force=force, say=lambda line: console.print(line, highlight=False),
    )  # fmt: skip


def _wait_for_position(number: int, total: int, label: str, interval: float | None) -> bool:
    """Wait until the artefact stands at position ``number``; False when the user finishes.

    Interactive (``interval`` None): a prompt, then one line from stdin; ``q`` (or the end of
    the input) finishes. Otherwise: ``interval`` seconds before every position but the first.
    """
    if interval is not None:
        if number > 1:
            time.sleep(interval)
        return True
    console.print(
        f"position {number}/{total} ({label}): place the artefact, then press Enter (q and "
        "Enter: finish)",
        highlight=False,
    )
    answer = sys.stdin.readline()
    return bool(answer) and answer.strip().lower() not in ("q", "quit")


def _print_report(report: Any) -> None:
    for name, summary in report.summaries.items():
        d = summary.to_dict()
        parts = [f"{q} {c['passed']}/{c['positions']}" for q, c in d["quantities"].items()]
        verdict = "passed" if summary.all_passed else "FAILED"
        console.print(f"{name}: {verdict} ({', '.join(parts)})", highlight=False)
    console.print(
        f"wrote {report.output}: acceptance.md, acceptance.json, quantities.png", highlight=False
    )
