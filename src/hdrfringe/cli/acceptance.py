"""``hdrfringe acceptance``: the VDI/VDE 2634 Part 2 acceptance test (docs/acceptance.md); the
work is :func:`hdrfringe.tasks.acceptance.acceptance_sim` (``--rig sim``) or
:func:`hdrfringe.tasks.acceptance.acceptance_offline` (captured position folders)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_stage
from hdrfringe.cli._measure_options import ForceOpt, OutputOpt
from hdrfringe.cli._options import LiveAmbientOpt, LiveNoiseOpt, LiveSeedOpt
from hdrfringe.errors import InputError

__all__ = ["acceptance"]

LIVE = "Live virtual rig (--rig sim)"


@app.command()
@handle_errors
def acceptance(
    folders: Annotated[
        list[Path] | None,
        typer.Argument(
            help="Capture folders of positions, each with acceptance_position.json (kind, "
            "label); evaluated offline with --calibration and --file.",
            show_default=False,
        ),
    ] = None,
    output: OutputOpt = None,
    rig: Annotated[
        str | None,
        typer.Option(help="sim: run the whole procedure on the virtual rig instead of FOLDERs."),
    ] = None,
    file: Annotated[
        Path | None,
        typer.Option(
            "--file",
            help="Acceptance file (TOML: MPEs, calibrated artefacts; docs/examples/"
            "acceptance.toml). Required for FOLDERs; with --rig sim the virtual artefacts are "
            "made to its sizes (default: guideline sizes and the virtual rig's MPEs).",
        ),
    ] = None,
    calibration: Annotated[
        Path | None,
        typer.Option(
            "--calibration",
            "-c",
            help="Stereo calibration (calibrate-stereo). Required for FOLDERs; with --rig sim "
            "default: calibrate the virtual rig (calibrate-stereo --rig sim), kept as "
            "OUT/calibration.h5.",
        ),
    ] = None,
    strategy: Annotated[
        list[str] | None,
        typer.Option(
            "--strategy",
            help="With --rig sim: strategy rows as compare names them (conventional, uniform, "
            "lpa-5, dpa-bound, multiexposure, tolerant, adaptive, ...); repeat for the HDR "
            "table side by side. Default conventional.",
            rich_help_panel=LIVE,
        ),
    ] = None,
    positions: Annotated[
        str | None,
        typer.Option(
            help="With --rig sim: positions to run, e.g. sphere:1-3,ball_bar:1,plane (numbers "
            "from 1, as the labels sphere_01...); default all 23.",
            rich_help_panel=LIVE,
        ),
    ] = None,
    glossy: Annotated[
        bool, typer.Option(help="Glossy artefacts (saturate).", rich_help_panel=LIVE)
    ] = False,
    ambient_lux: LiveAmbientOpt = 0.0,
    size: Annotated[
        str | None,
        typer.Option(help="Camera WIDTHxHEIGHT (default 640x480).", rich_help_panel=LIVE),
    ] = None,
    seed: LiveSeedOpt = 0,
    noise: LiveNoiseOpt = 1.0,
    keep_captures: Annotated[
        bool,
        typer.Option(
            help="With --rig sim: also write each position's capture folder under "
            "OUT/captures/STRATEGY/POSITION (what acceptance FOLDER... reads).",
            rich_help_panel=LIVE,
        ),
    ] = False,
    force: ForceOpt = False,
) -> None:
    """Acceptance test of the measuring system (VDI/VDE 2634 Part 2): probing error form and
    size (PF, PS) of a sphere at 10 positions, sphere-spacing error (SD) of a ball bar at 7,
    flatness error (F) of a plane at 6, each against its MPE. --rig sim runs it on the virtual
    rig (calibrated first unless --calibration is given), per --strategy: the HDR table. With
    FOLDERs it evaluates captured positions. Writes OUT/acceptance.json, acceptance.md,
    quantities.png and residuals/STRATEGY/POSITION.tiff + .png (docs/acceptance.md).
    """
    from hdrfringe.tasks import acceptance as task

    if output is None:
        raise InputError("no output folder: give -o/--output OUT")
    if rig is not None and folders:
        raise InputError("give either FOLDERs (captured positions) or --rig sim, not both")
    if rig is None:
        if calibration is None or file is None:
            raise InputError(
                "captured positions need --calibration CAL and --file "
                "acceptance.toml (or run --rig sim)"
            )
        report = task.acceptance_offline(
            folders or [],
            output,
            calibration=calibration,
            file=file,
            force=force,
            progress=progress_stage,
        )
    elif rig == "sim":
        report = task.acceptance_sim(
            output,
            file=file,
            calibration=calibration,
            strategies=strategy or ["conventional"],
            positions=positions,
            glossy=glossy,
            ambient_lux=ambient_lux,
            size=task.parse_size(size),
            seed=seed,
            noise=noise,
            keep_captures=keep_captures,
            force=force,
            progress=progress_stage,
        )
    else:
        raise InputError(_rig_message(rig))
    _print_report(report)


def _rig_message(rig: str) -> str:
    if rig == "hardware":
        return (
            "acceptance --rig hardware is not available yet: capture each position with "
            "'hdrfringe capture', add acceptance_position.json (kind, label) to its folder "
            "and run 'hdrfringe acceptance FOLDER... -c CAL --file acceptance.toml -o OUT'"
        )
    return f"--rig {rig!r}: use sim, or give captured position FOLDERs"


def _print_report(report: Any) -> None:
    for name, summary in report.summaries.items():
        d = summary.to_dict()
        parts = [f"{q} {c['passed']}/{c['positions']}" for q, c in d["quantities"].items()]
        verdict = "passed" if summary.all_passed else "FAILED"
        console.print(f"{name}: {verdict} ({', '.join(parts)})", highlight=False)
    console.print(
        f"wrote {report.output}: acceptance.md, acceptance.json, quantities.png", highlight=False
    )
