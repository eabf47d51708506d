"""``hdrfringe run``: a project file's stages in one go (:func:`hdrfringe.tasks.run.run_project`);
this module declares the options and prints what each stage did."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from hdrfringe.cli._app import app, console, handle_errors, progress_stage

__all__ = ["run"]


@app.command()
@handle_errors
def run(
    project: Annotated[
        Path, typer.Argument(help="Project file (TOML; docs/project_file.md, docs/examples/).")
    ],
    output: Annotated[
        Path | None,
        typer.Option(
            "-o",
            "--output",
            help="The project's output folder (default: the file's project output).",
        ),
    ] = None,
    force: Annotated[
        bool,
        typer.Option(help="Run every stage again, even those whose inputs did not change."),
    ] = False,
) -> None:
    """Run import -> gamma -> phase -> calibrate or calibrate-stereo -> measure as a project
    file describes them, each stage's outputs in OUT/<stage>; a stage whose inputs, options
    and upstream outputs did not change since it last ran (content hashes,
    OUT/manifests/<stage>.json) is skipped. OUT/run_summary.json says what ran and why."""
    from hdrfringe.tasks.run import run_project

    def say(line: str) -> None:
        console.print(escape(line), highlight=False, soft_wrap=True)

    report = run_project(project, output, force=force, say=say, progress=progress_stage)
    for stage in report.stages:
        for note in stage.notes:
            console.print(f"  {stage.stage}: {escape(note)}", highlight=False, soft_wrap=True)
    ran = sum(s.status == "ran" for s in report.stages)
    console.print(
        f"{ran} of {len(report.stages)} stages ran, {len(report.stages) - ran} skipped in "
        f"{report.seconds:.1f} s; wrote {escape(str(report.summary_file))}",
        highlight=False,
        soft_wrap=True,
    )
