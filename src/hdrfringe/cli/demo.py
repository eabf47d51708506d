"""``hdrfringe demo``: the end-to-end run on the virtual rig."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from hdrfringe.cli._app import app, console, handle_errors, progress_stage

__all__ = ["demo"]


@app.command()
@handle_errors
def demo(
    output: Annotated[Path, typer.Option("-o", "--output", help="Demo output folder.")] = Path(
        "hdrfringe-demo"
    ),
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
    report: Annotated[
        bool,
        typer.Option(
            "--report/--no-report",
            help="Write report.html and report.md beside each scene's measurement "
            "(docs/report.md); --no-report: skip them.",
        ),
    ] = True,
) -> None:
    """Simulate scenes on the virtual rig, decode them, write maps and plots, print a summary."""
    from hdrfringe.tasks.demo import ReportTable, demo_report, run_demo

    summary = run_demo(output, seed=seed, force=force, progress=progress_stage, report=report)
    for item in demo_report(summary, output):
        if not isinstance(item, ReportTable):
            console.print(item)
            continue
        table = Table(title=item.title)
        for i, col in enumerate(item.columns):
            table.add_column(col, no_wrap=True, justify="left" if i == 0 else "right")
        for row in item.rows:
            table.add_row(*row)
        console.print(table)
