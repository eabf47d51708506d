"""``hdrfringe measure``: height map, point cloud, phase maps and metrics."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, parse_floats, progress_bar
from hdrfringe.cli._options import (
    LIVE_OPTIONS,
    LIVE_PANEL,
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
    given_options,
    simulated_rig,
)
from hdrfringe.cli._strategy_options import (
    method_help,
    strategy_file_readers,
    with_strategy_options,
)
from hdrfringe.errors import InputError

__all__ = ["measure"]


@app.command()
@handle_errors
@with_strategy_options
def measure(
    ctx: typer.Context,
    folder: Annotated[
        Path | None,
        typer.Argument(help="Capture folder of the part (or a MIGL sweep with --method)."),
    ] = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Output folder (required).")
    ] = None,
    calibration: Annotated[
        Path | None, typer.Option("--calibration", "-c", help="Calibration file from calibrate.")
    ] = None,
    method: Annotated[str | None, typer.Option(help=method_help())] = None,
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
    pitch: Annotated[
        str,
        typer.Option(
            help="Pitch(es) in projector px, comma-separated; the strategy runs per pitch and "
            "the coarse pitches unwrap the finest temporally (the demo's 1024,64,8).",
            rich_help_panel=LIVE_PANEL,
        ),
    ] = "1024,64,8",
    imin: LiveIminOpt = 40.0,
    migl: Annotated[float, typer.Option(help="Highest MIGL.", rich_help_panel=LIVE_PANEL)] = 255.0,
    centerline: LiveCenterlineOpt = True,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
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

    from hdrfringe.calibration import check_compatible
    from hdrfringe.io.calibration_file import load_calibration
    from hdrfringe.io.measurement_outputs import write_height_outputs
    from hdrfringe.io.phase_maps import write_phase_maps
    from hdrfringe.io.results import check_output_dir, staged_output_dir
    from hdrfringe.measurement import calibration_geometry, measure_folder
    from hdrfringe.strategies import cli_options, param_values, params_from_options

    live = check_source(ctx, folder, rig, LIVE_OPTIONS)
    if output is None:
        raise InputError("no output folder: give -o/--output OUT")
    if live and method is None:
        method = "conventional"
    given = {  # the strategy options on the command line (this command's: built at import)
        o.option: strategy_options[o.dest]
        for o in cli_options()
        if o.dest in strategy_options and given_options(ctx, (o.dest,))
    }
    params = params_from_options(
        method, given, readers={t: read for t, (read, _) in strategy_file_readers().items()}
    )
    check_output_dir(output, force)
    cal = load_calibration(calibration) if calibration is not None else None
    replay = None
    strategy_results: list[Any] = []
    if live:
        from hdrfringe.frames import CenterlineFrame
        from hdrfringe.measurement import simulated_composite
        from hdrfringe.patterns import FringeSpec

        sim = simulated_rig(
            scene,
            depth_mm=depth_mm,
            ambient_lux=ambient_lux,
            noise=noise,
            aperture=aperture,
            gamma=gamma,
            seed=seed,
        )
        pitches = sorted(set(parse_floats(pitch, "--pitch")), reverse=True)
        specs = [FringeSpec(pattern, steps, p, "vertical", imin, migl) for p in pitches]  # type: ignore[arg-type]
        if cal is not None:  # refuse a mismatched calibration before capturing anything
            check_compatible(
                cal, specs[-1], sim.image_shape, sim.camera_bit_depth, source=str(calibration)
            )
        full = 2**sim.projector.bit_depth - 1
        line = CenterlineFrame(sim.projector.width // 2, "vertical", full) if centerline else None
        source = f"live virtual rig: {json.dumps(sim.scene.to_manifest())}, {ambient_lux:g} lx"
        assert method is not None  # the live rig defaults to conventional
        with progress_bar() as prog:
            prog.add_task(f"{method} on the virtual rig ({scene})", total=None)
            caps, strategy_results = simulated_composite(
                sim, specs, method, centerline=line, **param_values(params)
            )
    else:
        from hdrfringe.io.captures import read_capture_folder

        assert folder is not None
        source = str(folder)
        caps = read_capture_folder(folder)
        if method is not None:
            from hdrfringe.measurement import composite_folder

            replay = caps
            caps, strategy_results = composite_folder(caps, method, **param_values(params))
    result = measure_folder(
        caps, cal, calibration_source=None if calibration is None else str(calibration)
    )
    result.metrics["source"] = source
    if live:
        result.metrics["live_rig"] = {"scene": sim.scene.to_manifest(), **sim.to_manifest()}
    with staged_output_dir(output, force=force) as tmp:
        summary = write_phase_maps(tmp, result.decoded, source)
        notes = list(summary["notes"])
        if result.height_mm is not None and cal is not None:
            notes += write_height_outputs(tmp, result.height_mm, calibration_geometry(cal))
        if strategy_results:
            from hdrfringe.io.measurement_outputs import write_strategy_outputs

            result.metrics.update(write_strategy_outputs(tmp, strategy_results))
        if method == "dpa":
            from hdrfringe.io.measurement_outputs import write_dpa_outputs
            from hdrfringe.measurement import dpa_cdfs

            correction = given.get("--correction")
            result.metrics["dpa"] = write_dpa_outputs(
                tmp,
                [dpa_cdfs(r, replay) for r in strategy_results],
                threshold=params.threshold,
                correction=str(correction) if correction is not None else "none (identity)",
            )
            result.metrics["dpa"]["bound_pending"] = params.bound_pending
        result.metrics["skipped"] = result.skipped
        result.metrics["notes"] = notes
        (tmp / "metrics.json").write_text(
            json.dumps(result.metrics, indent=1) + "\n", encoding="utf-8"
        )
    m = result.metrics
    if strategy_results:
        console.print(
            f"{m['method']}: {m['sets_captured']} sets, {m['images_captured']} images captured"
        )
    if "dpa" in m:
        for entry in m["dpa"]["sets"]:
            if "max_abs_difference_initial_vs_actual" in entry:
                extra = ""
                if "max_abs_difference_initial_vs_exact" in entry:
                    extra = f", vs exact {entry['max_abs_difference_initial_vs_exact']:.3f}"
                console.print(
                    f"DPA {entry['set']}: max |estimated CDF (first set) - actual| "
                    f"{entry['max_abs_difference_initial_vs_actual']:.3f} at captured MIGLs" + extra
                )
    if "rmse_mm" in m:
        console.print(
            f"height vs {m['truth']}: RMSE {m['rmse_mm']:.4f} mm, bias {m['bias_mm']:+.4f} mm, "
            f"std {m['std_mm']:.4f} mm over {m['n_pixels']} pixels"
        )
    if "valid_fraction" in m:
        console.print(f"valid {100 * m['valid_fraction']:.1f} % of measurement pixels")
    for sk in result.skipped:
        console.print(f"skipped: {sk}")
    for note in notes:
        console.print(f"note: {note}")
    console.print(f"wrote {output}")
