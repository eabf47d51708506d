"""``hdrfringe measure``: height map, point cloud, phase maps and metrics."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_bar
from hdrfringe.cli._harmonics import HarmonicsOpt, check_harmonics, print_harmonics
from hdrfringe.cli._measure_options import (
    CalibrationOpt,
    ForceOpt,
    MeasureFolderArg,
    MeasureMiglOpt,
    MeasurePitchOpt,
    MeasureRigOpt,
    MethodOpt,
    NoiseSigmaOpt,
    OutputOpt,
    UncertaintyOpt,
    live_fringes,
    strategy_params,
)
from hdrfringe.cli._options import (
    LIVE_OPTIONS,
    SIM_OPTIONS,
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
    check_source,
)
from hdrfringe.cli._strategy_options import with_strategy_options
from hdrfringe.cli.capture import (
    CAPTURE_LOG,
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
    strategy_record,
)
from hdrfringe.cli.phase import KeepSaturatedOpt, SaturatedOpt, decoder_min_shifts
from hdrfringe.errors import InputError

__all__ = ["CAPTURES", "HARDWARE_OPTIONS", "logged_strategy", "measure", "print_summary"]

#: The capture folder ``measure --rig hardware`` writes inside OUT.
CAPTURES = "captures"
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
    method: MethodOpt = None,
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
    pitch: MeasurePitchOpt = "1024,64,8",
    imin: LiveIminOpt = 40.0,
    migl: MeasureMiglOpt = 255.0,
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
    uncertainty: UncertaintyOpt = True,
    noise_sigma: NoiseSigmaOpt = None,
    harmonics: HarmonicsOpt = "off",
    keep_saturated: KeepSaturatedOpt = False,
    saturated: SaturatedOpt = "flag",
    **strategy_options: Any,
) -> None:
    """Height map, point cloud, phase maps and metrics of a capture folder or the live rig.

    The source is a capture FOLDER (replay), --rig sim with scene and fringe options (the
    live virtual rig), or --rig hardware with --rig-config and/or the projector, camera and
    sync options of `capture` (a real rig). With --method, a FOLDER is a MIGL sweep (hdrfringe
    simulate --migl-sweep) replayed by the strategy; a live rig captures what the strategy
    asks for. The composite images are then measured; OUT also gets the MIGL index map and pie
    chart, and for DPA the estimated-versus-actual CDF (dpa_cdf.png, thesis Fig. 6.3). With
    --rig hardware OUT also holds the capture folder (OUT/captures, with capture_log.json),
    which `measure OUT/captures` replays to the same result (a folder written by `capture`
    is replayed with the method and strategy options its capture_log.json records); Ctrl-C
    writes nothing (exit 130): use `capture` to keep the sets of an interrupted run.
    """
    import json

    from hdrfringe.io.results import check_output_against_inputs, check_output_dir

    live = check_source(
        ctx, folder, rig, LIVE_OPTIONS, hardware_only=HARDWARE_OPTIONS, sim_only=SIM_OPTIONS
    )
    if output is None:
        raise InputError("no output folder: give -o/--output OUT")
    if noise_sigma is not None and not (math.isfinite(noise_sigma) and noise_sigma >= 0):
        raise InputError(f"--noise-sigma must be a finite number of DN >= 0, got {noise_sigma:g}")
    if noise_sigma is not None and not uncertainty:
        raise InputError("--noise-sigma is for the predicted std; drop --no-uncertainty")
    zrange = _depth_range(depth_range, calibration)
    check_harmonics(harmonics, "--method tolerant" if method == "tolerant" else None)
    if live and method is None:
        method = "conventional"
    recorded, replayed = None, ""
    if folder is not None and not live:
        given_method = method
        method, recorded = logged_strategy(folder, method)
        if recorded is not None and given_method is None:
            replayed = f"{folder}: captured with --method {method} ({CAPTURE_LOG}), replayed"
    min_shifts = decoder_min_shifts(method, saturated, keep_saturated, strategy_options)
    params, sources = strategy_params(ctx, method, strategy_options, recorded)
    inputs = [folder, calibration, *sources.values()]
    hardware: Any = None
    if rig == "hardware":
        from hdrfringe.cli.capture import hardware_rig

        hardware = hardware_rig(
            ctx, rig_config, projector=projector, camera=camera, sync=sync, settle=settle,
            discard=discard, max_grabs=max_grabs, gamma=gamma, exposure_ms=exposure_ms,
            gain_db=gain_db, pixel_format=pixel_format, view_check=view_check,
        )  # fmt: skip
        inputs += [rig_config, hardware[1].gamma_file]
    check_output_against_inputs(output, inputs)
    output = check_output_dir(output, force)
    if replayed:
        console.print(replayed, soft_wrap=True)
    # imported once the options are known good: a refused command does not pay for the
    # pipeline's imports (the decoders, unwrapping, calibration, HDF5, the writers)
    from hdrfringe import pipeline
    from hdrfringe.io.calibration_file import load_calibration
    from hdrfringe.io.captures import read_capture_folder
    from hdrfringe.io.stereo_file import calibration_kind, load_stereo_calibration
    from hdrfringe.tasks.measure import write_measurement

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
        "uncertainty": uncertainty,
        "depth_range_mm": zrange,
        "reject_saturated": not keep_saturated,
        "saturated": saturated,
        "min_shifts": min_shifts,
    }
    if harmonics != "off":
        kwargs["harmonics"] = harmonics
    if noise_sigma is not None:
        from hdrfringe.uncertainty import NoiseModel

        kwargs["noise"] = NoiseModel(noise_sigma, source="given (--noise-sigma)")
    if hardware is not None:
        assert method is not None
        hw_rig, hw_config = hardware
        fringes = (pattern, steps, pitch, imin, migl, centerline)
        record = strategy_record(ctx, strategy_options)
        _measure_hardware(
            hw_rig, hw_config, cal, output, force, method, fringes, kwargs, previews=previews,
            record=record,
        )  # fmt: skip
        return
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
    write_measurement(result, output, force=force, previews=previews)
    print_summary(result, output)


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


def _measure_hardware(
    rig: Any,
    config: Any,
    cal: Any,
    output: Any,
    force: bool,
    method: str,
    fringes: tuple[Any, ...],
    kwargs: dict[str, Any],
    previews: bool = True,
    record: dict[str, Any] | None = None,
) -> None:
    """``measure --rig hardware``: the strategy live as ``capture`` runs it, then the composite
    measured; OUT holds the measurement and the capture folder (staged together)."""
    from hdrfringe import pipeline
    from hdrfringe.cli.capture import announce_live, live_record, write_capture_output
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.tasks.measure import write_measurement

    recorder = Recorder(rig)
    with rig:  # Ctrl-C: the rig closes, nothing is written (handle_errors: exit 130)
        specs, line = live_fringes(rig.projector, *fringes)
        announce_live(method, rig, config)
        label = f"live hardware rig: projector {config.projector.spec}, camera {config.camera.spec}"
        result = pipeline.measure(
            recorder, cal, specs=specs, centerline=line, label=label, **kwargs
        )
    caps, state, log = live_record(recorder, rig, config, method, CAPTURES, entries=record)

    def captures(tmp: Path) -> None:
        write_capture_output(tmp / CAPTURES, caps, state, log)

    write_measurement(result, output, force=force, extra_metrics={"capture": state},
                      extra_files=captures, previews=previews)  # fmt: skip
    rejected = sum(t.rejected for t in rig.log)
    console.print(f"captured {len(caps.frames)} images, {rejected} stale grabs rejected")
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
        _print_direction_check(st.get("direction_check"))
    print_harmonics(m.harmonics)
    if m.uncertainty is not None:
        from hdrfringe.uncertainty import describe_uncertainty

        console.print(describe_uncertainty(m.uncertainty))
    for sk in m.skipped:
        console.print(f"skipped: {sk}")
    for note in m.notes:
        console.print(f"note: {note}")
    console.print(f"wrote {output}")


def _print_direction_check(check: dict[str, Any] | None) -> None:
    """The one line of ``--stereo-directions auto``: which directions and why; a warning when
    the calibration is suspect."""
    if check is None:
        return
    if check["verdict"] == "suspect":
        console.print(f"warning: {check['reason']}", soft_wrap=True)
    else:
        console.print(f"stereo directions auto: {check['reason']}", soft_wrap=True)


def logged_strategy(folder: Path, method: str | None) -> tuple[str | None, dict[str, Any] | None]:
    """The strategy a folder written by ``capture`` was captured with (its ``capture_log.json``).

    Parameters
    ----------
    folder : Path
        The capture folder measured.
    method : str or None
        ``--method`` as given.

    Returns
    -------
    method : str or None
        The logged method (``method`` when the folder has no log or the log none).
    recorded : dict or None
        The logged strategy options by option name (``strategy_options``), None without a log.

    Raises
    ------
    InputError
        A ``--method`` other than the logged one, or an unreadable log.
    """
    import json

    path = Path(folder) / CAPTURE_LOG
    if not path.is_file():
        return method, None
    try:
        log = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a readable capture log ({exc}); fix or remove it") from None
    logged = log.get("method") if isinstance(log, dict) else None
    if not isinstance(logged, str):
        return method, None
    if method is not None and method != logged:
        raise InputError(
            f"{folder} was captured with --method {logged} ({CAPTURE_LOG}), not {method}; "
            f"drop --method or give --method {logged}"
        )
    options = log.get("strategy_options") or {}
    if not isinstance(options, dict):
        raise InputError(f"{path}: strategy_options is not a mapping; fix or remove it")
    return logged, options
