"""``hdrfringe rig check``: latency, safe settle, white clipping and noise of a real rig."""

from __future__ import annotations

import contextlib
from collections.abc import Collection, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hdrfringe.core import strict_json
from hdrfringe.errors import InputError
from hdrfringe.tasks.capture import resolve_rig_config

__all__ = ["RigCheckReport", "check_rig_folder"]

#: How the written configuration's comment says what the latency counts.
_UNITS = {
    "none": "no latency",
    "grabs": "a latency in grabs, only discarding covers it",
    "seconds": "a latency in time, the settle covers it",
    "mixed": "a latency in time, then grabs",
}


@dataclass(frozen=True)
class RigCheckReport:
    """What ``rig check`` measured and wrote.

    Parameters
    ----------
    text : str
        The JSON report (also written to ``output`` when given).
    output : Path or None
        The report file written.
    config : Path or None
        The rig configuration written.

    Examples
    --------
    >>> RigCheckReport('{"latency": 2}', None, None).output is None
    True
    """

    text: str
    output: Path | None
    config: Path | None


def check_rig_folder(
    rig_config: Path | None,
    hardware: Mapping[str, Any],
    *,
    given: Collection[str] = (),
    changes: int = 6,
    max_latency: int = 10,
    output: Path | None = None,
    write_config: Path | None = None,
    force: bool = False,
) -> RigCheckReport:
    """Measure a real rig's latency, safe settle, white clipping and noise; write the report
    and, with ``write_config``, the rig configuration with the measured values filled in.

    Both outputs are checked (not an input, not the same file, new or ``force``) before the
    rig is driven, and written all or nothing.

    Parameters
    ----------
    rig_config : Path or None
        The rig configuration file.
    hardware : mapping
        Hardware options by Python name (:data:`~hdrfringe.tasks.capture.RIG_OPTION_KEYS`).
    given : collection of str
        The hardware options given explicitly.
    changes : int
        Display changes timed.
    max_latency : int
        Grabs after a change before giving up.
    output : Path, optional
        The JSON report's file.
    write_config : Path, optional
        The rig configuration (TOML) to write.
    force : bool
        Replace existing files.

    Returns
    -------
    RigCheckReport

    Examples
    --------
    >>> check_rig_folder(None, {"camera": "pylon:emu"}, given={"camera"})
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: give both --projector SPEC and --camera SPEC, or a ...
    """
    from hdrfringe.hardware.rig import check_rig
    from hdrfringe.io.results import check_output_against_inputs, check_output_file
    from hdrfringe.io.rig_config import rig_config_toml

    config = resolve_rig_config(rig_config, given, **hardware)
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
    text = strict_json.dumps(report) + "\n"
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
    return RigCheckReport(text, output, write_config)


@contextlib.contextmanager
def _staged(checked: Any, force: bool) -> Iterator[Path | None]:
    """:func:`~hdrfringe.io.results.staged_output_file` of a checked output, or None."""
    from hdrfringe.io.results import staged_output_file

    if checked is None:
        yield None
        return
    with staged_output_file(checked, force=force) as tmp:
        yield tmp
