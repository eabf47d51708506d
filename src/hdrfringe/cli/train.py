"""``hdrfringe train-correction``: DPA's error-correction polynomial
(:func:`hdrfringe.tasks.train.train_correction`)."""

from __future__ import annotations

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_stage
from hdrfringe.cli._measure_options import (
    MarginOpt,
    OrderOpt,
    TrainAmbientOpt,
    TrainFolderArg,
    TrainForceOpt,
    TrainOutputOpt,
    TrainPitchOpt,
    TrainStepsOpt,
    TruthOpt,
)
from hdrfringe.cli._options import (
    LIVE_OPTIONS,
    LiveApertureOpt,
    LiveDepthOpt,
    LiveGammaOpt,
    LiveIminOpt,
    LiveMiglOpt,
    LiveNoiseOpt,
    LiveSceneOpt,
    LiveSeedOpt,
    RigOpt,
    check_source,
)
from hdrfringe.errors import InputError

__all__ = ["train_correction"]


@app.command("train-correction")
@handle_errors
def train_correction(
    ctx: typer.Context,
    folder: TrainFolderArg = None,
    output: TrainOutputOpt = None,
    rig: RigOpt = None,
    scene: LiveSceneOpt = "white_plate",
    depth_mm: LiveDepthOpt = None,
    ambient_lux: TrainAmbientOpt = 600.0,
    noise: LiveNoiseOpt = 1.0,
    aperture: LiveApertureOpt = "auto",
    gamma: LiveGammaOpt = 2.812,
    seed: LiveSeedOpt = 0,
    steps: TrainStepsOpt = 4,
    pitch: TrainPitchOpt = None,
    imin: LiveIminOpt = 40.0,
    migl: LiveMiglOpt = 255.0,
    order: OrderOpt = 2,
    truth: TruthOpt = "scaled",
    margin: MarginOpt = 10,
    force: TrainForceOpt = False,
) -> None:
    """Train DPA's error-correction polynomial (thesis Sec. 6.1.2, Eq. 6.3-6.4) and save it.

    LPA with a step of one gray level on a white plate at a large pitch (thesis: 20 px) gives
    every saturated pixel's true peak; a polynomial in the Eq. 6.2 estimate is fitted to the
    estimate's error. Live (--rig sim; white plate under 600 lx by default) or from a step-1
    MIGL sweep FOLDER. Use the file with measure --strategy dpa --correction FILE.
    """
    from hdrfringe.strategies.dpa_training import THESIS_CORRECTION_RMSE
    from hdrfringe.tasks.train import train_correction as task

    live_only = tuple(n for n in LIVE_OPTIONS if n not in ("pitch", "pattern", "centerline"))
    live = check_source(ctx, folder, rig, live_only)  # --pitch also picks a folder's set
    if output is None:
        raise InputError("no output file: give -o/--output FILE.json")
    sim = {
        "scene": scene, "depth_mm": depth_mm, "ambient_lux": ambient_lux, "noise": noise,
        "aperture": aperture, "gamma": gamma, "seed": seed,
    }  # fmt: skip
    done = task(
        output, folder=folder, sim=sim if live else None, steps=steps, pitch=pitch, imin=imin,
        migl=migl, order=order, truth=truth, margin=margin, force=force,
        progress=progress_stage,
    )  # fmt: skip
    poly = done.polynomial
    before, after = THESIS_CORRECTION_RMSE
    console.print(
        f"trained on {poly.n_samples} saturated pixels of {done.label} "
        f"({done.sets_captured} sets, truth {truth}, order {order})"
    )
    console.print(
        f"estimate RMSE (Eq. 6.4): before correction {poly.rmse_before:.2f} DN (thesis "
        f"{before:g} gray levels), after {poly.rmse_after:.2f} DN (thesis {after:g})"
    )
    console.print(f"wrote {done.output}")
