"""``hdrfringe train-correction``: DPA's error-correction polynomial."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_bar
from hdrfringe.cli._options import (
    LIVE_OPTIONS,
    LIVE_PANEL,
    LiveApertureOpt,
    LiveDepthOpt,
    LiveGammaOpt,
    LiveIminOpt,
    LiveNoiseOpt,
    LiveSceneOpt,
    LiveSeedOpt,
    RigOpt,
    check_source,
    simulated_rig,
)
from hdrfringe.errors import InputError

__all__ = ["train_correction"]


@app.command("train-correction")
@handle_errors
def train_correction(
    ctx: typer.Context,
    folder: Annotated[
        Path | None,
        typer.Argument(help="A step-1 MIGL sweep folder (simulate --migl-sweep 255:60:1)."),
    ] = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Correction polynomial file (.json).")
    ] = None,
    rig: RigOpt = None,
    scene: LiveSceneOpt = "white_plate",
    depth_mm: LiveDepthOpt = None,
    ambient_lux: Annotated[
        float,
        typer.Option(
            help="Added ambient light in lux (saturates the white plate).",
            rich_help_panel=LIVE_PANEL,
        ),
    ] = 600.0,
    noise: LiveNoiseOpt = 1.0,
    aperture: LiveApertureOpt = "auto",
    gamma: LiveGammaOpt = 2.812,
    seed: LiveSeedOpt = 0,
    steps: Annotated[
        int, typer.Option(help="Number of phase shifts N (>= 4).", rich_help_panel=LIVE_PANEL)
    ] = 4,
    pitch: Annotated[
        float | None,
        typer.Option(
            help="Pitch in projector px (live default 20, the thesis's; a folder: pick "
            "one of its pitches)."
        ),
    ] = None,
    imin: LiveIminOpt = 40.0,
    migl: Annotated[
        float, typer.Option(help="Top MIGL of the sweep.", rich_help_panel=LIVE_PANEL)
    ] = 255.0,
    order: Annotated[int, typer.Option(help="Polynomial degree (thesis: low order).")] = 2,
    truth: Annotated[
        str,
        typer.Option(help="Training truth: scaled (the pixel's own response) or thesis (Eq. 6.3)."),
    ] = "scaled",
    margin: Annotated[
        int, typer.Option(help="Gray levels below N(x, y) of each pixel's reference set.")
    ] = 10,
    force: Annotated[bool, typer.Option(help="Replace an existing file.")] = False,
) -> None:
    """Train DPA's error-correction polynomial (thesis Sec. 6.1.2, Eq. 6.3-6.4) and save it.

    LPA with a step of one gray level on a white plate at a large pitch (thesis: 20 px) gives
    every saturated pixel's true peak; a polynomial in the Eq. 6.2 estimate is fitted to the
    estimate's error. Live (--rig sim; white plate under 600 lx by default) or from a step-1
    MIGL sweep FOLDER. Use the file with measure --method dpa --correction FILE.
    """
    from hdrfringe.errors import OutputExistsError
    from hdrfringe.measurement import THESIS_CORRECTION_RMSE
    from hdrfringe.patterns import FringeSpec
    from hdrfringe.saturation.estimate import TRUTH_MODELS, training_data_from_rig

    live_only = tuple(n for n in LIVE_OPTIONS if n not in ("pitch", "pattern", "centerline"))
    live = check_source(ctx, folder, rig, live_only)  # --pitch also picks a folder's set
    if output is None:
        raise InputError("no output file: give -o/--output FILE.json")
    if truth not in TRUTH_MODELS:
        raise InputError(f"unknown truth {truth!r}; use one of {', '.join(TRUTH_MODELS)}")
    if output.exists() and not force:
        raise OutputExistsError(f"{output}: exists; pass --force to replace it")
    if output.is_dir():
        raise OutputExistsError(f"{output}: is a folder; give a file name such as corr.json")
    if live:
        sim = simulated_rig(
            scene,
            depth_mm=depth_mm,
            ambient_lux=ambient_lux,
            noise=noise,
            aperture=aperture,
            gamma=gamma,
            seed=seed,
        )
        if steps < 4:
            raise InputError(
                f"the saturated-intensity estimate needs at least 4 steps (Eq. 6.2), got {steps}"
            )
        spec = FringeSpec(
            "sinusoidal", steps, 20.0 if pitch is None else pitch, "vertical", imin, migl
        )
        source = f"live virtual rig: {sim.scene.to_manifest()}, {ambient_lux:g} lx, seed {seed}"
        with progress_bar() as prog:
            prog.add_task("LPA step-1 sweep on the virtual rig", total=None)
            data = training_data_from_rig(sim, spec, margin=margin)
    else:
        from hdrfringe.io.captures import read_capture_folder
        from hdrfringe.measurement import training_data_from_folder

        assert folder is not None
        source = str(folder)
        data = training_data_from_folder(read_capture_folder(folder), pitch, margin=margin)
    poly = data.train(order, truth=truth, metadata={"source": source})  # type: ignore[arg-type]
    poly.save(output, force=force)
    before, after = THESIS_CORRECTION_RMSE
    console.print(
        f"trained on {poly.n_samples} saturated pixels of {data.spec.label()} "
        f"({data.sets_captured} sets, truth {truth}, order {order})"
    )
    console.print(
        f"estimate RMSE (Eq. 6.4): before correction {poly.rmse_before:.2f} DN (thesis "
        f"{before:g} gray levels), after {poly.rmse_after:.2f} DN (thesis {after:g})"
    )
    console.print(f"wrote {output}")
