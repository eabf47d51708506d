"""``hdrfringe compare``: every saturation strategy side by side on the virtual rig."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_stage
from hdrfringe.cli._options import renamed_option

__all__ = ["compare"]


@app.command()
@handle_errors
def compare(
    ctx: typer.Context,
    output: Annotated[
        Path, typer.Option("-o", "--output", help="Folder for compare.md, .json and .png.")
    ] = Path("hdrfringe-compare"),
    scenes: Annotated[
        str,
        typer.Option(
            help="Scenes, comma-separated, or all: checkerboard, white_plate_600lx, glossy, "
            "specular_part."
        ),
    ] = "all",
    strategies: Annotated[
        str,
        typer.Option(
            "--strategies",
            help="Rows, comma-separated, or all: conventional, uniform, lpa-1, lpa-5, lpa-15, "
            "dpa, dpa-bound, multiexposure, tolerant, tolerant-inverted, adaptive, "
            "adaptive-exposure, ... (docs/compare.md; an unknown name's error lists them all)."
        ),
    ] = "all",
    resolution: Annotated[
        str,
        typer.Option(help="Camera WIDTHxHEIGHT (default: the rig's 648x494; e.g. 160x120)."),
    ] = "default",
    pitch: Annotated[
        float, typer.Option(help="Finest pitch in projector px (sets 1024, 64 and this).")
    ] = 8.0,
    seed: Annotated[int, typer.Option(help="Random seed (noise).")] = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
    methods: Annotated[
        str | None,
        typer.Option("--methods", hidden=True, help="Deprecated: use --strategies."),
    ] = None,
) -> None:
    """Run every strategy (conventional, uniform, LPA S=1/5/15, DPA, DPA + bound,
    multi-exposure, tolerant, adaptive, ...) on the virtual rig's checkerboard, 600 lx white
    plate, glossy dome and specular part; write a table (markdown + JSON) of images captured,
    coverage and phase error with the thesis's numbers beside ours, and a plot of error and
    coverage against images captured (docs/compare.md)."""
    from hdrfringe.tasks.compare import run_compare

    strategies = renamed_option(ctx, "strategies", strategies, "methods", methods)
    report = run_compare(
        output, scenes=scenes, strategies=strategies, resolution=resolution, pitch=pitch, seed=seed,
        force=force, progress=progress_stage,
    )  # fmt: skip
    console.print(
        f"compared {len(report.strategies)} strategies on {len(report.scenes)} scenes: "
        f"{report.output / 'compare.md'}, compare.json, compare.png"
        + (f"; not available: {', '.join(report.missing)}" if report.missing else "")
    )
