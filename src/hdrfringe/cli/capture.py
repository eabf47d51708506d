"""``hdrfringe capture``: run a strategy live on a projector and camera, write a capture folder."""

from __future__ import annotations

import json
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
from hdrfringe.cli._options import CenterlineOpt, GammaOpt, IminOpt, PatternOpt, PitchOpt, StepsOpt
from hdrfringe.cli._strategy_options import with_strategy_options
from hdrfringe.errors import HdrFringeError, InputError

__all__ = ["CAPTURE_LOG", "capture", "hardware_options"]

#: The timing log ``capture`` writes beside the manifest.
CAPTURE_LOG = "capture_log.json"

ProjectorOpt = Annotated[
    str | None,
    typer.Option(
        "--projector", help="screen:N[@DISPLAY] (full-screen window) or folder:PATH[@WxH]."
    ),
]
CameraOpt = Annotated[
    str | None,
    typer.Option(
        "--camera",
        help="pylon:SERIAL|emu, opencv:N, genicam:CTI[:SERIAL] or loop:SCENE[?...] (no hardware).",
    ),
]
SyncOpt = Annotated[str, typer.Option("--sync", help="software or hardware (camera trigger).")]
SettleOpt = Annotated[float, typer.Option("--settle", help="Seconds to wait after each frame.")]
DiscardOpt = Annotated[
    int, typer.Option("--discard", help="Images dropped after the settle (the latency).")
]
MaxGrabsOpt = Annotated[
    int, typer.Option("--max-grabs", help="Grabs per frame before a sync error.")
]
ExposureOpt = Annotated[float | None, typer.Option("--exposure-ms", help="Exposure time in ms.")]
GainOpt = Annotated[float | None, typer.Option("--gain-db", help="Camera gain in dB.")]
PixelFormatOpt = Annotated[
    str | None, typer.Option("--pixel-format", help="Mono8, Mono10, Mono12 or Mono16.")
]


def hardware_options(
    projector: str | None,
    camera: str | None,
    sync: str,
    settle: float,
    discard: int,
    max_grabs: int,
    gamma: float,
    exposure_ms: float | None,
    gain_db: float | None,
    pixel_format: str | None,
) -> Any:
    """The (not yet open) :class:`~hdrfringe.hardware.rig.HardwareRig` the options describe."""
    from hdrfringe.captures import CameraSettings
    from hdrfringe.hardware.camera import open_camera
    from hdrfringe.hardware.rig import HardwareRig, SyncSettings, open_projector

    if projector is None or camera is None:
        raise InputError("give both --projector SPEC and --camera SPEC (docs/hardware.md)")
    sync_settings = SyncSettings(mode=sync, settle_s=settle, discard=discard, max_grabs=max_grabs)
    return HardwareRig(
        open_projector(projector),
        open_camera(camera),
        sync_settings,
        gamma_hat=gamma,
        settings=CameraSettings(exposure_ms=exposure_ms, gain_db=gain_db),
        pixel_format=pixel_format,
    )


@app.command()
@handle_errors
@with_strategy_options
def capture(
    ctx: typer.Context,
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
    force: ForceOpt = False,
    **strategy_options: Any,
) -> None:
    """Run a strategy live on a projector and camera and write the capture folder.

    Every set the strategy captured is written (a MIGL sweep of exactly those MIGLs, plus the
    centerline), with capture_log.json (per-frame timing and synchronisation). `measure FOLDER
    --method M` with the same strategy options replays it and measures the composite. Ctrl-C
    mid-capture writes the complete sets captured so far, marks the folder incomplete
    (manifest "capture": {"complete": false}) and exits with code 2 (before the first set, or
    a second Ctrl-C while writing: nothing written, code 130). Any other error (sync, camera
    timeout, window closed) writes nothing.
    """
    from hdrfringe import pipeline
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.io.captures import write_capture_folder
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_dir,
        staged_output_dir,
    )

    if output is None:
        raise InputError("no output folder: give -o/--output CAPTURES")
    method = method or "conventional"
    params, sources = strategy_params(ctx, method, strategy_options)
    check_output_against_inputs(output, list(sources.values()))
    checked = check_output_dir(output, force)
    rig = hardware_options(
        projector, camera, sync, settle, discard, max_grabs, gamma, exposure_ms, gain_db,
        pixel_format,
    )  # fmt: skip
    recorder = Recorder(rig)
    stopped: str | None = None
    with rig:
        specs, line = live_fringes(rig.projector, pattern, steps, pitch, imin, migl, centerline)
        console.print(
            f"{method} live: projector {projector} ({rig.projector.width}x"
            f"{rig.projector.height}), camera {camera} ({rig.image_shape[1]}x"
            f"{rig.image_shape[0]}, {rig.camera_bit_depth} bit)"
        )
        try:
            pipeline.composite_captures(
                recorder, specs, method, params, centerline=line,
                description=pipeline.RigDescription("capture", {}, {}),
            )  # fmt: skip
        except KeyboardInterrupt:
            if not recorder.calls:
                raise
            stopped = "interrupted (Ctrl-C)"
    caps = recorder.captures(name=output.name, camera={"spec": camera})
    state: dict[str, Any] = {
        "method": method,
        "complete": stopped is None,
        "projector": projector,
        "camera": camera,
        "sync": {"mode": sync, "settle_s": settle, "discard": discard, "max_grabs": max_grabs},
    }
    if stopped is not None:
        state["stopped"] = stopped
    log = {
        **state,
        "noise_variance": rig.noise_var,
        "frames": [t.to_dict() for t in rig.log],
    }
    with staged_output_dir(checked, force=force) as tmp:
        write_capture_folder(tmp, caps, extra={"capture": state}, force=True)
        (tmp / CAPTURE_LOG).write_text(json.dumps(log, indent=1) + "\n", encoding="utf-8")
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
