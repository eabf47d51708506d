"""``hdrfringe measure``: height map, point cloud, phase maps and metrics.

The work is :func:`hdrfringe.tasks.measure.measure`; this module declares the options and
prints the summary.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, parse_floats, progress_stage
from hdrfringe.cli._harmonics import HarmonicsOpt, check_harmonics, print_harmonics
from hdrfringe.cli._measure_options import (
    CalibrationOpt,
    ForceOpt,
    MeasureFolderArg,
    MeasurePitchOpt,
    MeasureRigOpt,
    MeshOpt,
    MethodOpt,
    NoiseSigmaOpt,
    OutputOpt,
    RemoveOutliersOpt,
    StrategyOpt,
    UncertaintyOpt,
    given_strategy_options,
    strategy_params,
)
from hdrfringe.cli._options import (
    DEFAULT_PITCHES,
    LIVE_OPTIONS,
    SIM_OPTIONS,
    LiveAmbientOpt,
    LiveApertureOpt,
    LiveCenterlineOpt,
    LiveDepthOpt,
    LiveGammaOpt,
    LiveIminOpt,
    LiveMiglOpt,
    LiveNoiseOpt,
    LivePatternOpt,
    LiveSceneOpt,
    LiveSeedOpt,
    LiveStepsOpt,
    check_source,
    given_names,
    renamed_option,
)
from hdrfringe.cli._strategy_options import with_strategy_options
from hdrfringe.cli.capture import (
    HwCameraOpt,
    HwDiscardOpt,
    HwExposureOpt,
    HwGainOpt,
    HwMaxGrabsOpt,
    HwPixelFormatOpt,
    HwProjectorOpt,
    HwRigConfigOpt,
    HwSettleOpt,
    HwSyncOpt,
    HwViewCheckOpt,
)
from hdrfringe.cli.phase import KeepSaturatedOpt, ReportOpt, SaturatedOpt, decoder_min_shifts
from hdrfringe.errors import InputError

__all__ = ["HARDWARE_OPTIONS", "measure", "print_summary"]
#: measure's options of the hardware rig only.
HARDWARE_OPTIONS = (
    "rig_config",
    "projector",
    "camera",
    "sync",
    "settle",
    "discard",
    "max_grabs",
    "exposure_ms",
    "gain_db",
    "pixel_format",
    "view_check",
)


@app.command()
@handle_errors
@with_strategy_options
def measure(
    ctx: typer.Context,
    folder: MeasureFolderArg = None,
    output: OutputOpt = None,
    calibration: CalibrationOpt = None,
    strategy: StrategyOpt = None,
    rig: MeasureRigOpt = None,
    scene: LiveSceneOpt = "white_plate",
    depth_mm: LiveDepthOpt = None,
    ambient_lux: LiveAmbientOpt = 0.0,
    noise: LiveNoiseOpt = 1.0,
    aperture: LiveApertureOpt = "auto",
    gamma: LiveGammaOpt = 2.812,
    seed: LiveSeedOpt = 0,
    pattern: LivePatternOpt = "sinusoidal",
    steps: LiveStepsOpt = 4,
    pitch: MeasurePitchOpt = DEFAULT_PITCHES,
    imin: LiveIminOpt = 40.0,
    migl: LiveMiglOpt = 255.0,
    centerline: LiveCenterlineOpt = True,
    rig_config: HwRigConfigOpt = None,
    projector: HwProjectorOpt = None,
    camera: HwCameraOpt = None,
    sync: HwSyncOpt = "software",
    settle: HwSettleOpt = 0.1,
    discard: HwDiscardOpt = 0,
    max_grabs: HwMaxGrabsOpt = 5,
    exposure_ms: HwExposureOpt = None,
    gain_db: HwGainOpt = None,
    pixel_format: HwPixelFormatOpt = None,
    view_check: HwViewCheckOpt = True,
    force: ForceOpt = False,
    stereo_directions: Annotated[
        str,
        typer.Option(
            "--stereo-directions",
            help="With a stereo calibration: auto (every fringe orientation with an absolute "
            "phase, ray against ray with both, unless the two disagree far beyond the phase "
            "noise: then the consistent one, printed with why), u (vertical fringes only) or v "
            "(horizontal fringes only), e.g. the direction that carries the depth "
            "(docs/stereo.md).",
        ),
    ] = "auto",
    depth_range: Annotated[
        str | None,
        typer.Option(
            "--depth-range",
            help="With a stereo calibration: ZMIN:ZMAX, the scene's depths along the camera "
            "axis in mm. A fringe family without an absolute phase (no set spanning the "
            "projector, Gray code or centerline) takes its fringe order from the calibration "
            "and this range; pixels the range leaves ambiguous are invalid (docs/stereo.md).",
        ),
    ] = None,
    previews: Annotated[
        bool,
        typer.Option(
            "--previews/--no-previews",
            help="Write a PNG preview beside every map; --no-previews: the maps, point cloud, "
            "figures and metrics only (faster).",
        ),
    ] = True,
    mesh: MeshOpt = "none",
    remove_outliers: RemoveOutliersOpt = False,
    make_report: ReportOpt = True,
    uncertainty: UncertaintyOpt = True,
    noise_sigma: NoiseSigmaOpt = None,
    harmonics: HarmonicsOpt = "off",
    keep_saturated: KeepSaturatedOpt = False,
    saturated: SaturatedOpt = "flag",
    method: MethodOpt = None,
    **strategy_options: Any,
) -> None:
    """Height map, point cloud, phase maps and metrics of a capture folder or the live rig.

    The source is a capture FOLDER (replay), --rig sim with scene and fringe options (the
    live virtual rig), or --rig hardware with --rig-config and/or the projector, camera and
    sync options of `capture` (a real rig). With --strategy, a FOLDER is a MIGL sweep (hdrfringe
    simulate --migl-sweep) replayed by the strategy; a live rig captures what the strategy
    asks for. The composite images are then measured; OUT also gets the MIGL index map and pie
    chart, and for DPA the estimated-versus-actual CDF (dpa_cdf.png, thesis Fig. 6.3). With
    --rig hardware OUT also holds the capture folder (OUT/captures, with capture_log.json),
    which `measure OUT/captures` replays to the same result (a folder written by `capture`
    is replayed with the strategy and strategy options its capture_log.json records); Ctrl-C
    writes nothing (exit 130): use `capture` to keep the sets of an interrupted run.
    """
    from hdrfringe.tasks import measure as task

    live = check_source(
        ctx, folder, rig, LIVE_OPTIONS, hardware_only=HARDWARE_OPTIONS, sim_only=SIM_OPTIONS
    )
    if output is None:
        raise InputError("no output folder: give -o/--output OUT")
    task.check_noise_sigma(noise_sigma, uncertainty)
    zrange = _depth_range(depth_range, calibration)
    strategy = renamed_option(ctx, "strategy", strategy, "method", method)
    check_harmonics(harmonics, "--strategy tolerant" if strategy == "tolerant" else None)
    strategy = "conventional" if live and strategy is None else strategy
    strategy, recorded, replayed = task.replayed_strategy(None if live else folder, strategy)
    min_shifts = decoder_min_shifts(strategy, saturated, keep_saturated, strategy_options)
    params, sources = strategy_params(ctx, strategy, strategy_options, recorded)
    options = task.MeasureOptions(
        strategy, params, sources, given_strategy_options(ctx, strategy_options),
        stereo_directions, uncertainty, zrange, keep_saturated, saturated, min_shifts,
        harmonics, noise_sigma, previews, task.CloudOptions(mesh, remove_outliers), make_report,
    )  # fmt: skip
    hardware = {
        "projector": projector, "camera": camera, "sync": sync, "settle": settle,
        "discard": discard, "max_grabs": max_grabs, "gamma": gamma, "exposure_ms": exposure_ms,
        "gain_db": gain_db, "pixel_format": pixel_format, "view_check": view_check,
    }  # fmt: skip
    sim = {
        "scene": scene, "depth_mm": depth_mm, "ambient_lux": ambient_lux, "noise": noise,
        "aperture": aperture, "gamma": gamma, "seed": seed,
    }  # fmt: skip
    report = task.measure(
        output, options, folder=None if live else folder, calibration=calibration,
        sim=sim if live and rig != "hardware" else None,
        hardware=hardware if rig == "hardware" else None, rig_config=rig_config,
        given=given_names(ctx, tuple(hardware)), replayed=replayed, force=force,
        fringes=task.LiveFringes(pattern, steps, _pitches(live, pitch), imin, migl, centerline),
        say=console.print, note=lambda line: console.print(line, soft_wrap=True),
        progress=progress_stage,
    )  # fmt: skip
    if report.captured is not None:
        console.print(f"captured {report.captured} images, {report.rejected} stale grabs rejected")
    print_summary(report.result, report.output, report=options.report)


def _pitches(live: bool, pitch: str) -> list[float]:
    """``--pitch`` of a live rig, parsed (a folder's pitches are its own: not read)."""
    return parse_floats(pitch, "--pitch") if live else []


def _depth_range(text: str | None, calibration: Path | None) -> tuple[float, float] | None:
    """``--depth-range ZMIN:ZMAX`` in mm, checked (``0 < ZMIN < ZMAX``, a calibration given)."""
    if text is None:
        return None
    try:
        zmin, zmax = (float(v) for v in text.split(":"))
    except ValueError:
        raise InputError(
            f"--depth-range {text!r}: give ZMIN:ZMAX in mm along the camera axis, e.g. 550:800"
        ) from None
    if not (math.isfinite(zmin) and math.isfinite(zmax) and 0 < zmin < zmax):
        raise InputError(
            f"--depth-range {text!r}: give ZMIN:ZMAX with 0 < ZMIN < ZMAX (mm), e.g. 550:800"
        )
    if calibration is None:
        raise InputError(
            "--depth-range fixes the fringe order with a stereo calibration; give -c STEREO.h5"
        )
    return zmin, zmax


def print_summary(result: Any, output: Path, *, report: bool = False) -> None:
    """The lines ``measure`` prints: sets captured, DPA's CDF gap, height error, notes.

    Parameters
    ----------
    result : MeasurementResult
        What :func:`hdrfringe.pipeline.measure` returned.
    output : Path
        The result folder written.
    report : bool
        The folder has ``report.html``: a last line says where.
    """
    m = result.metrics
    if m.strategy is not None:
        s = m.strategy
        console.print(f"{s.name}: {s.sets_captured} sets, {s.images_captured} images captured")
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
        _print_direction_check(st.get("direction_check"))
    print_harmonics(m.harmonics)
    if m.uncertainty is not None:
        from hdrfringe.core.uncertainty import describe_uncertainty

        console.print(describe_uncertainty(m.uncertainty))
    for sk in m.skipped:
        console.print(f"skipped: {sk}")
    for note in m.notes:
        console.print(f"note: {note}")
    console.print(f"wrote {output}")
    if report:
        console.print(f"report: {output / 'report.html'} (opens in a browser)")


def _print_direction_check(check: dict[str, Any] | None) -> None:
    """The one line of ``--stereo-directions auto``: which directions and why; a warning when
    the calibration is suspect."""
    if check is None:
        return
    if check["verdict"] == "suspect":
        console.print(f"warning: {check['reason']}", soft_wrap=True)
    else:
        console.print(f"stereo directions auto: {check['reason']}", soft_wrap=True)
