"""``hdrfringe measure``: height map, point cloud, phase maps and metrics."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_bar
from hdrfringe.cli._measure_options import (
    CalibrationOpt,
    ForceOpt,
    MeasureFolderArg,
    MeasureMiglOpt,
    MeasurePitchOpt,
    MethodOpt,
    OutputOpt,
    live_fringes,
    strategy_params,
)
from hdrfringe.cli._options import (
    LIVE_OPTIONS,
    LiveAmbientOpt,
    LiveApertureOpt,
    LiveCenterlineOpt,
    LiveDepthOpt,
    LiveGammaOpt,
    LiveIminOpt,
    LiveNoiseOpt,
    LivePatternOpt,
    LiveSceneOpt,
    LiveSeedOpt,
    LiveStepsOpt,
    RigOpt,
    check_source,
)
from hdrfringe.cli._strategy_options import with_strategy_options
from hdrfringe.errors import InputError

__all__ = ["measure", "print_summary"]


@app.command()
@handle_errors
@with_strategy_options
def measure(
    ctx: typer.Context,
    folder: MeasureFolderArg = None,
    output: OutputOpt = None,
    calibration: CalibrationOpt = None,
    method: MethodOpt = None,
    rig: RigOpt = None,
    scene: LiveSceneOpt = "white_plate",
    depth_mm: LiveDepthOpt = None,
    ambient_lux: LiveAmbientOpt = 0.0,
    noise: LiveNoiseOpt = 1.0,
    aperture: LiveApertureOpt = "auto",
    gamma: LiveGammaOpt = 2.812,
    seed: LiveSeedOpt = 0,
    pattern: LivePatternOpt = "sinusoidal",
    steps: LiveStepsOpt = 4,
    pitch: MeasurePitchOpt = "1024,64,8",
    imin: LiveIminOpt = 40.0,
    migl: MeasureMiglOpt = 255.0,
    centerline: LiveCenterlineOpt = True,
    force: ForceOpt = False,
    stereo_directions: Annotated[
        str,
        typer.Option(
            "--stereo-directions",
            help="With a stereo calibration: auto (every fringe orientation with an absolute "
            "phase; ray against ray with both), u (vertical fringes only) or v (horizontal "
            "fringes only), e.g. the direction that carries the depth (docs/stereo.md).",
        ),
    ] = "auto",
    **strategy_options: Any,
) -> None:
    """Height map, point cloud, phase maps and metrics of a capture folder or the live rig.

    The source is a capture FOLDER (replay) or --rig sim with scene and fringe options (the
    live virtual rig). With --method, a FOLDER is a MIGL sweep (hdrfringe simulate --migl-sweep)
    replayed by the strategy; the live rig captures what the strategy asks for. The composite
    images are then measured; OUT also gets the MIGL index map and pie chart, and for DPA the
    estimated-versus-actual CDF (dpa_cdf.png, thesis Fig. 6.3).
    """
    import json

    from hdrfringe import pipeline
    from hdrfringe.io.calibration_file import load_calibration
    from hdrfringe.io.captures import read_capture_folder
    from hdrfringe.io.measurement_outputs import write_measurement
    from hdrfringe.io.results import check_output_against_inputs, check_output_dir
    from hdrfringe.io.stereo_file import calibration_kind, load_stereo_calibration

    live = check_source(ctx, folder, rig, LIVE_OPTIONS)
    if output is None:
        raise InputError("no output folder: give -o/--output OUT")
    if live and method is None:
        method = "conventional"
    params, sources = strategy_params(ctx, method, strategy_options)
    check_output_against_inputs(output, [folder, calibration, *sources.values()])
    output = check_output_dir(output, force)
    cal: Any = None
    if calibration is not None and calibration_kind(calibration) == "stereo":
        cal = load_stereo_calibration(calibration)  # triangulation (docs/stereo.md)
    elif calibration is not None:
        cal = load_calibration(calibration)
    kwargs: dict[str, Any] = {
        "method": method,
        "params": params,
        "param_sources": sources,
        "calibration_source": None if calibration is None else str(calibration),
        "stereo_directions": stereo_directions,
    }
    if live:
        from hdrfringe.rig.factory import virtual_rig  # the simulator loads only when used

        sim = virtual_rig(
            scene, depth_mm=depth_mm, ambient_lux=ambient_lux, noise=noise, aperture=aperture,
            gamma=gamma, seed=seed,
        )  # fmt: skip
        specs, line = live_fringes(sim.projector, pattern, steps, pitch, imin, migl, centerline)
        label = f"live virtual rig: {json.dumps(sim.scene.to_manifest())}, {ambient_lux:g} lx"
        with progress_bar() as prog:
            prog.add_task(f"{method} on the virtual rig ({scene})", total=None)
            result = pipeline.measure(sim, cal, specs=specs, centerline=line, label=label, **kwargs)
    else:
        assert folder is not None
        result = pipeline.measure(read_capture_folder(folder), cal, label=str(folder), **kwargs)
    write_measurement(result, output, force=force)
    print_summary(result, output)


def print_summary(result: Any, output: Path) -> None:
    """The lines ``measure`` prints: sets captured, DPA's CDF gap, height error, notes.

    Parameters
    ----------
    result : MeasurementResult
        What :func:`hdrfringe.pipeline.measure` returned.
    output : Path
        The result folder written.
    """
    m = result.metrics
    if m.strategy is not None:
        s = m.strategy
        console.print(f"{s.method}: {s.sets_captured} sets, {s.images_captured} images captured")
    for entry in m.dpa.sets if m.dpa is not None else ():
        if entry.max_abs_difference_initial_vs_actual is not None:
            extra = ""
            if entry.max_abs_difference_initial_vs_exact is not None:
                extra = f", vs exact {entry.max_abs_difference_initial_vs_exact:.3f}"
            console.print(
                f"DPA {entry.set}: max |estimated CDF (first set) - actual| "
                f"{entry.max_abs_difference_initial_vs_actual:.3f} at captured MIGLs" + extra
            )
    if m.truth is not None:
        console.print(
            f"height vs {m.truth}: RMSE {m.rmse_mm:.4f} mm, bias {m.bias_mm:+.4f} mm, "
            f"std {m.std_mm:.4f} mm over {m.n_pixels} pixels"
        )
    if m.valid_fraction is not None:
        console.print(f"valid {100 * m.valid_fraction:.1f} % of measurement pixels")
    if m.stereo is not None:
        st = m.stereo
        line = f"triangulated {st['n_points']} points ({st['directions']})"
        if "reference_plane" in st:
            line += f", reference plane RMS {st['reference_plane']['rms_mm']:.3f} mm"
        if "triangulation_residual_mm" in st:
            line += f", ray-ray residual median {st['triangulation_residual_mm']['median']:.3f} mm"
        console.print(line)
    for sk in m.skipped:
        console.print(f"skipped: {sk}")
    for note in m.notes:
        console.print(f"note: {note}")
    console.print(f"wrote {output}")
