"""``hdrfringe modify``: thesis Eq. 4.1 on existing captures."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors

__all__ = ["modify"]


@app.command()
@handle_errors
def modify(
    folder: Annotated[Path, typer.Argument(help="Capture folder to modify.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Modified capture folder.")],
    add_lux: Annotated[float, typer.Option(help="Uniform light to add, in lux.")] = 0.0,
    add_dn: Annotated[float, typer.Option(help="Uniform intensity to add, in DN.")] = 0.0,
    noise: Annotated[float, typer.Option(help="Gaussian noise sigma to add, in DN.")] = 0.0,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Add light and noise to existing captures with clipping at 2^B - 1 (thesis Eq. 4.1)."""
    from hdrfringe.core._validation import describe_saturated
    from hdrfringe.tasks.modify import modify

    done = modify(folder, output, add_lux=add_lux, add_dn=add_dn, noise=noise, seed=seed,
                  force=force)  # fmt: skip
    console.print(
        f"wrote {done.n_images} modified captures to {output} "
        f"({describe_saturated(done.saturated_pixels, done.n_pixels)} saturated)"
    )
