"""``hdrfringe capture``: run a strategy live on a projector and camera, write a capture folder."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors
from hdrfringe.cli._measure_options import (
    ForceOpt,
    MeasureMiglOpt,
    MethodOpt,
    live_fringes,
    strategy_params,
)
from hdrfringe.cli._options import (
    HARDWARE_PANEL,
    CameraOpt,
    CenterlineOpt,
    DiscardOpt,
    ExposureOpt,
    GainOpt,
    GammaOpt,
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
    IminOpt,
    MaxGrabsOpt,
    PatternOpt,
    PitchOpt,
    PixelFormatOpt,
    ProjectorOpt,
    RigConfigOpt,
    SettleOpt,
    StepsOpt,
    SyncOpt,
    given_options,
)
from hdrfringe.cli._strategy_options import with_strategy_options
from hdrfringe.errors import HdrFringeError, InputError

__all__ = [
    "CAPTURE_LOG",
    "HARDWARE_PANEL",
    "RIG_OPTION_KEYS",
    "CameraOpt",
    "DiscardOpt",
    "ExposureOpt",
    "GainOpt",
    "HwCameraOpt",
    "HwDiscardOpt",
    "HwExposureOpt",
    "HwGainOpt",
    "HwMaxGrabsOpt",
    "HwPixelFormatOpt",
    "HwProjectorOpt",
    "HwRigConfigOpt",
    "HwSettleOpt",
    "HwSyncOpt",
    "HwViewCheckOpt",
    "MaxGrabsOpt",
    "PixelFormatOpt",
    "ProjectorOpt",
    "RigConfigOpt",
    "SettleOpt",
    "SyncOpt",
    "ViewCheckOpt",
    "announce_live",
    "capture",
    "hardware_options",
    "hardware_rig",
    "live_record",
    "resolve_rig_config",
    "strategy_record",
    "write_capture_output",
]

#: The timing log ``capture`` writes beside the manifest.
CAPTURE_LOG = "capture_log.json"
#: The hardware options (Python names) and the rig configuration key each one sets.
RIG_OPTION_KEYS: dict[str, str] = {
    "projector": "projector.spec",
    "camera": "camera.spec",
    "sync": "sync.mode",
    "settle": "sync.settle_s",
    "discard": "sync.discard",
    "max_grabs": "sync.max_grabs",
    "gamma": "gamma",
    "exposure_ms": "camera.exposure_ms",
    "gain_db": "camera.gain_db",
    "pixel_format": "camera.pixel_format",
    "view_check": "sync.view_check",
}
_VIEW_CHECK_HELP = (
    "Before capturing, check that the camera sees the projector (its image follows white, "
    "black, white) and refuse if not; --no-view-check for a rig whose camera is not meant to "
    "see it (docs/hardware.md)."
)
ViewCheckOpt = Annotated[bool, typer.Option("--view-check/--no-view-check", help=_VIEW_CHECK_HELP)]
HwViewCheckOpt = Annotated[
    bool,
    typer.Option(
        "--view-check/--no-view-check", help=_VIEW_CHECK_HELP, rich_help_panel=HARDWARE_PANEL
    ),
]
#: How messages name a key set from an option.
_OPTION_LABELS = {key: "--" + name.replace("_", "-") for name, key in RIG_OPTION_KEYS.items()}


def _config_value(config: Any, key: str) -> Any:
    table, _, name = key.rpartition(".")
    return getattr(getattr(config, table) if table else config, name)


def resolve_rig_config(ctx: typer.Context, config_path: Path | None, **options: Any) -> Any:
    """The rig configuration a command runs with: the file's values, options given override.

    For each option (Python names of :data:`RIG_OPTION_KEYS`): a value given on the command
    line (click's parameter source) wins; else the file's value; else, when the file leaves
    the key unset (or there is no file), the option's default (a ``[sync]`` key the file
    leaves out has :class:`~hdrfringe.hardware.rig.SyncSettings`' default, which is the
    options' default too). Options a command does not have are simply not passed: the file's
    value, or the configuration's "not set", applies.

    Parameters
    ----------
    ctx : typer.Context
        The command's context (which options were given).
    config_path : Path or None
        ``--rig-config``.
    **options
        The command's hardware options by Python name (``projector=...``, ``settle=...``).

    Returns
    -------
    RigConfig
        The resolved configuration (with the file's path and SHA-256 when one was read).
    """
    from hdrfringe.hardware.config import RigConfig
    from hdrfringe.io.rig_config import load_rig_config

    base = RigConfig() if config_path is None else load_rig_config(config_path)
    values = {}
    for name, value in options.items():
        key = RIG_OPTION_KEYS[name]
        unset = config_path is None or _config_value(base, key) is None
        if unset or given_options(ctx, (name,)):
            values[key] = value
    return base.replace(values, _OPTION_LABELS)


def hardware_options(
    projector: str | None,
    camera: str | None,
    sync: str,
    settle: float,
    discard: int,
    max_grabs: int,
    gamma: float | None,
    exposure_ms: float | None,
    gain_db: float | None,
    pixel_format: str | None,
    config: Any = None,
) -> Any:
    """The (not yet open) :class:`~hdrfringe.hardware.rig.HardwareRig` the options describe.

    ``config`` (a :class:`~hdrfringe.hardware.config.RigConfig`) supplies what the options do
    not: the projector size check, the trigger line, sync fields without an option.
    """
    from hdrfringe.hardware.config import RigConfig

    if projector is None or camera is None:
        raise InputError(
            "give both --projector SPEC and --camera SPEC, or a --rig-config file that names "
            "them (docs/hardware.md)"
        )
    values = {
        RIG_OPTION_KEYS[name]: value
        for name, value in (
            ("projector", projector), ("camera", camera), ("sync", sync), ("settle", settle),
            ("discard", discard), ("max_grabs", max_grabs), ("gamma", gamma),
            ("exposure_ms", exposure_ms), ("gain_db", gain_db), ("pixel_format", pixel_format),
        )
    }  # fmt: skip
    resolved = (RigConfig() if config is None else config).replace(values, _OPTION_LABELS)
    return resolved.rig()


def hardware_rig(ctx: typer.Context, config_path: Path | None, **options: Any) -> tuple[Any, Any]:
    """The rig a hardware command runs on, from ``--rig-config`` and its options.

    The one entry point of ``capture``, ``measure --rig hardware`` and every command that
    captures on hardware: :func:`resolve_rig_config`, then :func:`hardware_options` (the rig
    is not opened).

    Parameters
    ----------
    ctx : typer.Context
        The command's context.
    config_path : Path or None
        ``--rig-config``.
    **options
        The command's hardware options by Python name (keys of :data:`RIG_OPTION_KEYS`).

    Returns
    -------
    rig : HardwareRig
        Not yet open.
    config : RigConfig
        The resolved configuration (record it: :func:`live_record`).
    """
    config = resolve_rig_config(ctx, config_path, **options)
    rig = hardware_options(
        config.projector.spec, config.camera.spec, config.sync.mode, config.sync.settle_s,
        config.sync.discard, config.sync.max_grabs, config.gamma, config.camera.exposure_ms,
        config.camera.gain_db, config.camera.pixel_format, config,
    )  # fmt: skip
    return rig, config


def announce_live(method: str, rig: Any, config: Any) -> None:
    """The line a live hardware command prints once the rig is open."""
    name = f" ({config.name})" if config.name else ""
    console.print(
        f"{method} live{name}: projector {config.projector.spec} ({rig.projector.width}x"
        f"{rig.projector.height}), camera {config.camera.spec} ({rig.image_shape[1]}x"
        f"{rig.image_shape[0]}, {rig.camera_bit_depth} bit)"
    )


def live_record(
    recorder: Any,
    rig: Any,
    config: Any,
    method: str | None,
    name: str,
    stopped: str | None = None,
    *,
    entries: Mapping[str, Any] | None = None,
    start: int = 0,
) -> tuple[Any, dict[str, Any], dict[str, Any]]:
    """What a live run writes: its captures, the manifest's ``capture`` entry, the timing log.

    Parameters
    ----------
    recorder : Recorder
        What the run captured.
    rig : HardwareRig
        The rig it ran on (its noise variance and timing log).
    config : RigConfig
        The resolved configuration (:func:`hardware_rig`).
    method : str or None
        The strategy; None for a fixed program (``capture-gamma``, ``capture-poses``), which
        says what it was in ``entries``.
    name : str
        The captures' name.
    stopped : str, optional
        Why the run stopped before the end (the record is then incomplete).
    entries : mapping, optional
        A program's own entries of the record, after ``method`` (its name, levels, pose).
    start : int
        The first entry of ``rig.log`` that belongs to this record (``capture-poses`` writes
        one record per pose).

    Returns
    -------
    captures : Captures
        Every complete set recorded, in capture order.
    state : dict
        Method, completeness, devices, sync settings and the resolved rig configuration
        (``rig``, with ``config_file``: path and SHA-256 when a file was read).
    log : dict
        ``state`` plus the noise variance, the view check's change ratio (``view_change``,
        None when it was off) and the per-frame timing.
    """
    camera: dict[str, Any] = {"spec": config.camera.spec}
    if config.camera.read_noise_dn is not None:  # rig check's, for the predicted std
        camera["read_noise_dn"] = config.camera.read_noise_dn
    caps = recorder.captures(name=name, camera=camera)
    sync = config.sync
    state: dict[str, Any] = {} if method is None else {"method": method}
    state.update(entries or {})
    state.update(
        {
            "complete": stopped is None,
            "projector": config.projector.spec,
            "camera": config.camera.spec,
            "sync": {
                "mode": sync.mode,
                "settle_s": sync.settle_s,
                "discard": sync.discard,
                "max_grabs": sync.max_grabs,
            },
            "rig": config.to_record(),
        }
    )
    if stopped is not None:
        state["stopped"] = stopped
    frames = [t.to_dict() for t in rig.log[start:]]
    log = {
        **state,
        "noise_variance": rig.noise_var,
        "view_change": getattr(rig, "view_ratio", None),
        "frames": frames,
    }
    return caps, state, log


def strategy_record(ctx: typer.Context, strategy_options: dict[str, Any]) -> dict[str, Any]:
    """The capture record's ``strategy_options``: the strategy options given on the command
    line by option name (a file as its absolute path), which ``measure FOLDER`` replays with.

    Parameters
    ----------
    ctx : typer.Context
        The command's context.
    strategy_options : dict
        The command's strategy options by Python name.

    Returns
    -------
    dict
        ``{"strategy_options": {option: value}}``.
    """
    from hdrfringe.cli._measure_options import given_strategy_options

    given = given_strategy_options(ctx, strategy_options)
    return {
        "strategy_options": {
            k: str(v.resolve()) if isinstance(v, Path) else v for k, v in given.items()
        }
    }


def write_capture_output(
    folder: Path, captures: Any, state: dict[str, Any], log: dict[str, Any]
) -> None:
    """Write a live run's capture folder and its ``capture_log.json`` into ``folder``
    (inside a staged output: a new or empty folder)."""
    from hdrfringe.io.captures import write_capture_folder

    write_capture_folder(folder, captures, extra={"capture": state}, force=True)
    (folder / CAPTURE_LOG).write_text(json.dumps(log, indent=1) + "\n", encoding="utf-8")


@app.command()
@handle_errors
@with_strategy_options
def capture(
    ctx: typer.Context,
    rig_config: RigConfigOpt = None,
    projector: ProjectorOpt = None,
    camera: CameraOpt = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Capture folder to write (required).")
    ] = None,
    method: MethodOpt = "conventional",
    pattern: PatternOpt = "sinusoidal",
    steps: StepsOpt = 4,
    pitch: PitchOpt = "1024,64,8",
    imin: IminOpt = 40.0,
    migl: MeasureMiglOpt = 255.0,
    centerline: CenterlineOpt = True,
    gamma: GammaOpt = 2.812,
    sync: SyncOpt = "software",
    settle: SettleOpt = 0.1,
    discard: DiscardOpt = 0,
    max_grabs: MaxGrabsOpt = 5,
    exposure_ms: ExposureOpt = None,
    gain_db: GainOpt = None,
    pixel_format: PixelFormatOpt = None,
    view_check: ViewCheckOpt = True,
    force: ForceOpt = False,
    **strategy_options: Any,
) -> None:
    """Run a strategy live on a projector and camera and write the capture folder.

    The rig comes from --rig-config FILE and/or the options (an option given overrides the
    file). Every set the strategy captured is written (a MIGL sweep of exactly those MIGLs, plus the
    centerline), with capture_log.json (per-frame timing and synchronisation). `measure FOLDER
    --method M` with the same strategy options replays it and measures the composite. Ctrl-C
    mid-capture writes the complete sets captured so far, marks the folder incomplete
    (manifest "capture": {"complete": false}) and exits with code 2 (before the first set, or
    a second Ctrl-C while writing: nothing written, code 130). Any other error (sync, camera
    timeout, window closed) writes nothing. Before the first pattern the rig checks that the
    camera sees the projector (white, black, white) and refuses if not (--no-view-check: off).
    """
    from hdrfringe import pipeline
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_dir,
        staged_output_dir,
    )

    if output is None:
        raise InputError("no output folder: give -o/--output CAPTURES")
    method = method or "conventional"
    params, sources = strategy_params(ctx, method, strategy_options)
    rig, config = hardware_rig(
        ctx, rig_config, projector=projector, camera=camera, sync=sync, settle=settle,
        discard=discard, max_grabs=max_grabs, gamma=gamma, exposure_ms=exposure_ms,
        gain_db=gain_db, pixel_format=pixel_format, view_check=view_check,
    )  # fmt: skip
    check_output_against_inputs(output, [*sources.values(), rig_config, config.gamma_file])
    checked = check_output_dir(output, force)
    recorder = Recorder(rig)
    stopped: str | None = None
    with rig:
        specs, line = live_fringes(rig.projector, pattern, steps, pitch, imin, migl, centerline)
        announce_live(method, rig, config)
        try:
            pipeline.composite_captures(
                recorder, specs, method, params, centerline=line,
                description=pipeline.RigDescription("capture", {}, {}),
            )  # fmt: skip
        except KeyboardInterrupt:
            if not recorder.calls:
                raise
            stopped = "interrupted (Ctrl-C)"
    caps, state, log = live_record(
        recorder, rig, config, method, output.name, stopped,
        entries=strategy_record(ctx, strategy_options),
    )  # fmt: skip
    with staged_output_dir(checked, force=force) as tmp:
        write_capture_output(tmp, caps, state, log)
    sets = len(caps.sets)
    if stopped is not None:
        raise HdrFringeError(
            f"capture {stopped} after {sets} complete sets; {output} holds those sets only "
            '(manifest "capture": {"complete": false}); capture again for a complete folder'
        )
    rejected = sum(t.rejected for t in rig.log)
    console.print(
        f"captured {len(caps.frames)} images ({sets} sets), {rejected} stale grabs rejected"
    )
    console.print(f"wrote {output}")
