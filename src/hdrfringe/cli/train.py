"""``hdrfringe train-correction``: DPA's error-correction polynomial."""

from __future__ import annotations

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_bar
from hdrfringe.cli._measure_options import (
    MarginOpt,
    OrderOpt,
    TrainAmbientOpt,
    TrainFolderArg,
    TrainForceOpt,
    TrainMiglOpt,
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
    migl: TrainMiglOpt = 255.0,
    order: OrderOpt = 2,
    truth: TruthOpt = "scaled",
    margin: MarginOpt = 10,
    force: TrainForceOpt = False,
) -> None:
    """Train DPA's error-correction polynomial (thesis Sec. 6.1.2, Eq. 6.3-6.4) and save it.

    LPA with a step of one gray level on a white plate at a large pitch (thesis: 20 px) gives
    every saturated pixel's true peak; a polynomial in the Eq. 6.2 estimate is fitted to the
    estimate's error. Live (--rig sim; white plate under 600 lx by default) or from a step-1
    MIGL sweep FOLDER. Use the file with measure --method dpa --correction FILE.
    """
    from hdrfringe.saturation.estimate import (
        TRUTH_MODELS,
        check_correction_order,
        training_data_from_rig,
    )
    from hdrfringe.strategies.dpa_training import (
        THESIS_CORRECTION_RMSE,
        training_data_from_folder,
        training_spec,
    )

    live_only = tuple(n for n in LIVE_OPTIONS if n not in ("pitch", "pattern", "centerline"))
    live = check_source(ctx, folder, rig, live_only)  # --pitch also picks a folder's set
    if output is None:
        raise InputError("no output file: give -o/--output FILE.json")
    if truth not in TRUTH_MODELS:
        raise InputError(f"unknown truth {truth!r}; use one of {', '.join(TRUTH_MODELS)}")
    check_correction_order(order)  # before the (slow) training captures
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_file,
        staged_output_file,
    )

    check_output_against_inputs(output, [folder])
    output = check_output_file(output, force)  # before the work; the write replaces only this
    if live:
        from hdrfringe.rig.factory import virtual_rig  # the simulator loads only when used

        sim = virtual_rig(
            scene, depth_mm=depth_mm, ambient_lux=ambient_lux, noise=noise, aperture=aperture,
            gamma=gamma, seed=seed,
        )  # fmt: skip
        spec = training_spec(steps=steps, pitch=pitch, imin=imin, migl=migl)
        source = f"live virtual rig: {sim.scene.to_manifest()}, {ambient_lux:g} lx, seed {seed}"
        with progress_bar() as prog:
            prog.add_task("LPA step-1 sweep on the virtual rig", total=None)
            data = training_data_from_rig(sim, spec, margin=margin)
    else:
        from hdrfringe.io.captures import read_capture_folder

        assert folder is not None
        source = str(folder)
        data = training_data_from_folder(read_capture_folder(folder), pitch, margin=margin)
    poly = data.train(order, truth=truth, metadata={"source": source})  # type: ignore[arg-type]
    with staged_output_file(output, force=force) as tmp:  # atomic: complete or not at all
        poly.save(tmp, force=True)  # (the temporary file exists already)
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
