"""``hdrfringe reproduce``: the thesis's experiments as resumable sweeps.

The command joins ``hdrfringe`` through the entry-point group ``hdrfringe.commands``
(``research/pyproject.toml``; :data:`hdrfringe.cli.PLUGIN_GROUP`): the product lists it from
this file's source and imports this module only when the command runs, under its error
handling (an :class:`~hdrfringe.errors.HdrFringeError` is one line, exit code 2).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli import console

__all__ = ["reproduce"]


def reproduce(
    chapter: Annotated[
        str, typer.Argument(help="ch4, ch5, ch6, several joined by commas (ch5,ch6), or all.")
    ],
    output: Annotated[Path, typer.Option("-o", "--output", help="Reproduction folder.")] = Path(
        "hdrfringe-reproduction"
    ),
    quick: Annotated[
        bool, typer.Option(help="Reduced grid (quarter-size view, fewer pitches/MIGLs/depths).")
    ] = False,
    scheduler: Annotated[
        str | None, typer.Option(help="Dask scheduler address (default: a local cluster).")
    ] = None,
    workers: Annotated[
        int | None, typer.Option(help="Local cluster worker processes (default: CPU count).")
    ] = None,
    force: Annotated[
        bool, typer.Option(help="Write into a non-empty folder that is not a reproduction.")
    ] = False,
    preset: Annotated[
        str,
        typer.Option(
            help="Rig preset: 'thesis' (fitted to Table 4.3 and the DSIE error) or "
            "'thesis-gamma' (projector gamma matched, fitted to Table 4.3 only)."
        ),
    ] = "",
    unwrap: Annotated[
        str,
        typer.Option(
            help="Fringe orders of the Table 4.1 added-light simulation: centerline (the "
            "thesis's pipeline: spatial unwrapping and a captured centerline) or known (the "
            "plate position)."
        ),
    ] = "centerline",
) -> None:
    """Run the thesis's experiments on the virtual rig as resumable sweeps (Dask, Zarr) and
    write tables beside the thesis's, figures and a report. Rerun to resume."""
    from hdrfringe_thesis.runner import parse_chapters
    from hdrfringe_thesis.runner import reproduce as run

    if not console.is_terminal:  # no progress bar: progress lines on stderr instead
        import logging
        import sys

        logger = logging.getLogger("hdrfringe_thesis")
        if not logger.handlers:
            handler = logging.StreamHandler(sys.stderr)
            handler.setFormatter(logging.Formatter("%(asctime)s %(message)s", "%H:%M:%S"))
            logger.addHandler(handler)
        logger.setLevel(logging.INFO)
    res = run(
        parse_chapters(chapter),
        output,
        quick=quick,
        scheduler=scheduler,
        n_workers=workers,
        progress=console.is_terminal,
        force=force,
        preset=preset,
        unwrap=unwrap,
    )
    for name, secs in res["timings_s"].items():
        console.print(f"{name}: {secs:.1f} s")
    console.print(f"report: {output / 'report.md'} and report.html")
