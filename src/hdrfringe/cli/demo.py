"""``hdrfringe demo``: the end-to-end run on the virtual rig."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors

__all__ = ["demo"]


@app.command()
@handle_errors
def demo(
    output: Annotated[Path, typer.Option("-o", "--output", help="Demo output folder.")] = Path(
        "hdrfringe-demo"
    ),
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Simulate scenes on the virtual rig, decode them, write maps and plots, print a summary."""
    from hdrfringe.demo import run_demo

    run_demo(output, seed=seed, force=force, console=console)
