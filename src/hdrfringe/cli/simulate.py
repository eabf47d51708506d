"""``hdrfringe simulate``: the virtual rig writes a capture folder
(:func:`hdrfringe.tasks.simulate.simulate`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import (
    app,
    console,
    handle_errors,
    parse_floats,
    parse_range,
    progress_stage,
)
from hdrfringe.cli._options import (
    SCENES_HELP,
    AmbientOpt,
    ApertureOpt,
    CenterlineOpt,
    DepthOpt,
    GammaOpt,
    IminOpt,
    MiglsOpt,
    NoiseOpt,
    PatternOpt,
    PitchOpt,
    SeedOpt,
    StepsOpt,
    parse_orientations,
)

__all__ = ["simulate"]


@app.command()
@handle_errors
def simulate(
    scene: Annotated[str, typer.Argument(help=SCENES_HELP)],
    output: Annotated[Path, typer.Option("-o", "--output", help="Capture folder to write.")],
    depth_mm: DepthOpt = None,
    pattern: PatternOpt = "sinusoidal",
    steps: StepsOpt = 4,
    pitch: PitchOpt = "8",
    orientation: Annotated[str, typer.Option(help="vertical, horizontal or both.")] = "vertical",
    imin: IminOpt = 40.0,
    migl: MiglsOpt = "255",
    migl_sweep: Annotated[
        str | None,
        typer.Option(help="A MIGL sweep start:stop:step (e.g. 255:60:1) for offline strategies."),
    ] = None,
    bit_depth: Annotated[int, typer.Option(help="Camera bit depth B (8, 10, 12, 16).")] = 8,
    resolution: Annotated[
        str | None,
        typer.Option(
            help="Camera WIDTHxHEIGHT over the same field of view (default: the rig's 648x494; "
            "e.g. 162x124, the loop camera's size=, for a calibration at that size)."
        ),
    ] = None,
    ambient_lux: AmbientOpt = 0.0,
    noise: NoiseOpt = 1.0,
    shot_noise: Annotated[bool, typer.Option(help="Photon shot noise.")] = True,
    aperture: ApertureOpt = "auto",
    gamma: GammaOpt = 2.812,
    ideal: Annotated[
        bool, typer.Option(help="Ideal rig: no noise/blur, 16-bit camera and projector.")
    ] = False,
    centerline: CenterlineOpt = True,
    gray: Annotated[str, typer.Option(help="Uniform gray levels to add, comma-separated.")] = "",
    add_lux: Annotated[
        float, typer.Option(help="Eq. 4.1: add uniform light (lux) to the captures.")
    ] = 0.0,
    add_dn: Annotated[float, typer.Option(help="Eq. 4.1: add uniform DN to the captures.")] = 0.0,
    add_noise: Annotated[
        float, typer.Option(help="Eq. 4.1: add Gaussian noise (sigma, DN) to the captures.")
    ] = 0.0,
    series: Annotated[
        str | None,
        typer.Option(
            help="Depths start:stop:step or a list (mm): one capture folder per depth, "
            "e.g. 2:50:2 for the thesis's calibration positions."
        ),
    ] = None,
    reference: Annotated[
        bool, typer.Option(help="With --series, add the reference plane (depth 0).")
    ] = True,
    seed: SeedOpt = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Capture fringe sets of a scene on the virtual rig and write a capture folder.

    Every folder also holds the scene's true height map (truth_height_mm.tiff) and the camera
    geometry, so measurements can report their error. With --series, DIR holds one folder per
    depth (a calibration series: reference plane + positions). --resolution sets the camera's
    pixel count over the same field of view (the loop camera's size=, so that a calibration
    of captures at that size can be made).
    """
    from hdrfringe.core._validation import describe_saturated
    from hdrfringe.core.limits import MAX_SERIES_FOLDERS
    from hdrfringe.tasks import simulate as task
    from hdrfringe.tasks.compare import parse_resolution

    size = parse_resolution(resolution)
    orients = parse_orientations(orientation)
    depths: Sequence[float | None] = [depth_mm]
    if series is not None:
        series_mm = parse_range(series, "--series", MAX_SERIES_FOLDERS)
        depths = task.series_depths(series_mm, reference=reference)
    rig_options = {"ambient_lux": ambient_lux, "noise": noise, "shot_noise": shot_noise}
    rig_options |= {"aperture": aperture, "gamma": gamma, "bit_depth": bit_depth, "ideal": ideal}
    rig_options |= {"resolution": size}
    done = task.simulate(
        output, scene, depths=depths, series=series is not None, rig_options=rig_options,
        seed=seed, add_lux=add_lux, add_dn=add_dn, add_noise=add_noise,
        pattern=pattern, steps=steps, pitches=parse_floats(pitch, "--pitch"),
        orientations=orients, imin=imin, migls=parse_range(migl_sweep or migl, "--migl"),
        centerline=centerline, grays=parse_floats(gray, "--gray") if gray else (), ideal=ideal,
        force=force, progress=progress_stage,
    )  # fmt: skip
    what = f"{done.folders} capture folders" if series is not None else "a capture folder"
    console.print(
        f"wrote {what} of {scene} ({done.images} images each) to {done.output}; "
        f"{describe_saturated(done.saturated, done.n_pixels)} saturated in at least one image"
        + (" (the folder with the most)" if series is not None else "")
    )
