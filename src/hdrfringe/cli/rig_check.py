"""``hdrfringe rig check``: latency, safe settle, white clipping and noise of a real rig."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, err_console, handle_errors
from hdrfringe.cli.capture import (
    CameraOpt,
    ExposureOpt,
    GainOpt,
    PixelFormatOpt,
    ProjectorOpt,
    RigConfigOpt,
    ViewCheckOpt,
    resolve_rig_config,
)
from hdrfringe.errors import InputError

__all__ = ["check", "rig_app"]

#: How the written configuration's comment says what the latency counts.
_UNITS = {
    "none": "no latency",
    "grabs": "a latency in grabs, only discarding covers it",
    "seconds": "a latency in time, the settle covers it",
    "mixed": "a latency in time, then grabs",
}

rig_app = typer.Typer(help="Real projector-camera rigs (docs/hardware.md).", no_args_is_help=True)
app.add_typer(rig_app, name="rig")


@rig_app.command()
@handle_errors
def check(
    ctx: typer.Context,
    rig_config: RigConfigOpt = None,
    projector: ProjectorOpt = None,
    camera: CameraOpt = None,
    exposure_ms: ExposureOpt = None,
    gain_db: GainOpt = None,
    pixel_format: PixelFormatOpt = None,
    view_check: ViewCheckOpt = True,
    changes: Annotated[int, typer.Option(help="Display changes timed.")] = 6,
    max_latency: Annotated[int, typer.Option(help="Grabs after a change before giving up.")] = 10,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Also write the JSON report here.")
    ] = None,
    write_config: Annotated[
        Path | None,
        typer.Option(
            "--write-config",
            help="Write the rig configuration (TOML) with the measured settle, discard and "
            "camera noise filled in, for capture --rig-config.",
        ),
    ] = None,
    force: Annotated[
        bool, typer.Option(help="Replace an existing report or configuration file.")
    ] = False,
) -> None:
    """Measure the display-to-capture latency, pick a safe settle, check white, report noise.

    The projector alternates black and white; the grabs until each change shows are the
    latency (in grabs), the time until then its latency in seconds. Two more changes, timed
    after waiting that long, tell whether the latency passes with time (then --settle covers
    it) or counts grabs (a camera queue: only --discard covers it, and the settle is 0); the
    report (JSON on stdout, and in OUTPUT with -o) recommends --settle and --discard so, says
    whether white clips at the exposure given (saturated fraction), and gives the camera noise
    (standard deviation of repeated grabs of a static gray frame). The rig comes from --rig-config
    and/or the options (an option given overrides the file); --write-config writes it back
    with sync.settle_s and sync.discard set to the recommended values and camera.read_noise_dn
    to the noise (capture records it for the predicted std). First the view check of capture:
    a camera whose image does not follow the projector (white, black, white) is refused in one
    line (--no-view-check, or sync.view_check = false, skips it).
    """
    from hdrfringe.hardware.rig import check_rig
    from hdrfringe.io.results import check_output_against_inputs, check_output_file
    from hdrfringe.io.rig_config import rig_config_toml

    config = resolve_rig_config(
        ctx, rig_config, projector=projector, camera=camera, exposure_ms=exposure_ms,
        gain_db=gain_db, pixel_format=pixel_format, view_check=view_check,
    )  # fmt: skip
    if config.projector.spec is None or config.camera.spec is None:
        raise InputError(
            "give both --projector SPEC and --camera SPEC, or a --rig-config file that names "
            "them (docs/hardware.md)"
        )
    outputs = [p for p in (output, write_config) if p is not None]
    for path in outputs:
        check_output_against_inputs(path, [rig_config, config.gamma_file])
    if len({p.resolve() for p in outputs}) < len(outputs):
        raise InputError(f"-o and --write-config both name {output}; give two different files")
    checked = None if output is None else check_output_file(output, force)
    checked_config = None if write_config is None else check_output_file(write_config, force)
    result = check_rig(
        config.projector_device(),
        config.camera_device(),
        settings=config.camera.settings(),
        pixel_format=config.camera.pixel_format,
        changes=changes,
        max_latency=max_latency,
        view_check=config.sync.view_check,
    )
    report = {
        "projector": config.projector.spec,
        "camera": config.camera.spec,
        **result.to_dict(),
        "rig": config.to_record(),
    }
    text = json.dumps(report, indent=1) + "\n"
    toml = None
    if write_config is not None:
        measured = {
            "sync.settle_s": result.settle_s,
            "sync.discard": result.discard,
            "camera.read_noise_dn": round(result.noise_std, 4),
        }
        source = f", from {config.source}" if config.source else ""
        header = (
            f"Rig configuration written by hdrfringe rig check{source} (docs/hardware.md).\n"
            f"sync.settle_s and sync.discard: measured (latency {result.latency} grabs or "
            f"{result.latency_s:.4f} s, {result.latency_after_settle} grabs after waiting that "
            f"long: {_UNITS[result.latency_unit]}; {result.grab_period_s:.4f} s per grab); "
            "white saturated fraction "
            f"{result.white_saturated_fraction:.4f}; camera.read_noise_dn: the noise std "
            f"of repeated grabs of mid-gray, {result.noise_std:.3f} DN (capture records it)."
        )
        toml = rig_config_toml(config.replace(measured), header=header, base=write_config.parent)
    with _staged(checked, force) as tmp_report, _staged(checked_config, force) as tmp_config:
        if tmp_report is not None:
            tmp_report.write_text(text, encoding="utf-8")
        if tmp_config is not None and toml is not None:
            tmp_config.write_text(toml, encoding="utf-8")
    typer.echo(text, nl=False)
    if write_config is not None:  # stdout holds the JSON report only
        err_console.print(f"wrote {write_config}", highlight=False)


@contextlib.contextmanager
def _staged(checked: Any, force: bool) -> Iterator[Path | None]:
    """:func:`~hdrfringe.io.results.staged_output_file` of a checked output, or None."""
    from hdrfringe.io.results import staged_output_file

    if checked is None:
        yield None
        return
    with staged_output_file(checked, force=force) as tmp:
        yield tmp
