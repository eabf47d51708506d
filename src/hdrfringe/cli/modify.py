"""``hdrfringe modify``: thesis Eq. 4.1 on existing captures."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
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
    import dataclasses

    from hdrfringe.io.captures import read_capture_folder, read_manifest, write_capture_folder
    from hdrfringe.io.results import check_output_dir
    from hdrfringe.rig.modify import modify_captures

    check_output_dir(output, force)
    caps = read_capture_folder(folder)
    manifest = read_manifest(folder)  # the fields Captures does not keep: file names, extras
    out = modify_captures(
        caps.images,
        caps.camera_bit_depth,
        add_dn=add_dn,
        add_lux=add_lux or None,
        noise_sigma=noise,
        seed=seed,
    )
    extra = {
        k: v
        for k, v in manifest.items()
        if k not in ("format", "version", "camera", "projector", "scene", "frames", "maps")
    }
    extra["modification"] = {
        "source": str(folder),
        "add_lux": add_lux,
        "add_dn": add_dn,
        "noise_sigma": noise,
        "seed": seed,
        "equation": "thesis Eq. 4.1",
    }
    names = [Path(e["file"]).stem for e in manifest["frames"]]
    write_capture_folder(
        output, dataclasses.replace(caps, images=out), names=names, extra=extra, force=force
    )
    sat = float(np.mean((out == 2**caps.camera_bit_depth - 1).any(axis=0)))
    console.print(f"wrote {len(names)} modified captures to {output} ({100 * sat:.1f} % saturated)")
