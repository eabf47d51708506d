"""``hdrfringe compare``: every saturation strategy side by side on the virtual rig."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_bar

__all__ = ["compare"]


@app.command()
@handle_errors
def compare(
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
    methods: Annotated[
        str,
        typer.Option(
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
) -> None:
    """Run every strategy (conventional, uniform, LPA S=1/5/15, DPA, DPA + bound,
    multi-exposure, tolerant, adaptive, ...) on the virtual rig's checkerboard, 600 lx white
    plate, glossy dome and specular part; write a table (markdown + JSON) of images captured,
    coverage and phase error with the thesis's numbers beside ours, and a plot of error and
    coverage against images captured (docs/compare.md)."""
    from hdrfringe.io.results import check_output_dir
    from hdrfringe.rig.factory import virtual_rig
    from hdrfringe.tasks.compare import (
        METHODS,
        SCENES,
        fringe_specs,
        parse_names,
        parse_resolution,
        write_compare,
    )
    from hdrfringe.tasks.compare import compare as run

    scene_names = parse_names(scenes, list(SCENES), "--scenes")
    method_names = parse_names(methods, [m.name for m in METHODS], "--methods")
    size = parse_resolution(resolution)
    specs = fringe_specs(pitch)
    virtual_rig("white_plate", seed=seed, resolution=size)  # refuses a bad seed before work
    output = check_output_dir(output, force)
    with progress_bar() as prog:
        task = prog.add_task("comparing", total=len(scene_names) * len(method_names))
        rows = run(
            scene_names,
            method_names,
            resolution=size,
            pitch=pitch,
            seed=seed,
            progress=lambda label: prog.update(task, advance=1, description=label),
        )
    settings = {
        "resolution": "648x494" if size is None else f"{size[0]}x{size[1]}",
        "pitches_px": [s.pitch_px for s in specs],
        "steps": specs[-1].steps,
        "seed": seed,
    }
    write_compare(output, rows, settings, force=force)
    missing = sorted({r.method for r in rows if not r.available})
    console.print(
        f"compared {len(method_names)} methods on {len(scene_names)} scenes: "
        f"{output / 'compare.md'}, compare.json, compare.png"
        + (f"; not available: {', '.join(missing)}" if missing else "")
    )
