"""Options of the virtual rig and its fringes shared by simulate, measure and train-correction."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.core.programs import DEFAULT_PITCHES_PX
from hdrfringe.errors import InputError

__all__ = [
    "DEFAULT_PITCHES",
    "HARDWARE_PANEL",
    "LIVE_OPTIONS",
    "LIVE_PANEL",
    "SCENES_HELP",
    "SIM_OPTIONS",
    "AmbientOpt",
    "ApertureOpt",
    "CameraOpt",
    "CenterlineOpt",
    "DepthOpt",
    "DiscardOpt",
    "ExposureOpt",
    "GainOpt",
    "GammaOpt",
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
    "IminOpt",
    "LiveAmbientOpt",
    "LiveApertureOpt",
    "LiveCenterlineOpt",
    "LiveDepthOpt",
    "LiveGammaOpt",
    "LiveIminOpt",
    "LiveMiglOpt",
    "LiveNoiseOpt",
    "LivePatternOpt",
    "LiveSceneOpt",
    "LiveSeedOpt",
    "LiveStepsOpt",
    "MaxGrabsOpt",
    "MiglOpt",
    "MiglsOpt",
    "NoiseOpt",
    "PatternOpt",
    "PitchOpt",
    "PixelFormatOpt",
    "ProjectorOpt",
    "RigConfigOpt",
    "RigOpt",
    "SeedOpt",
    "SettleOpt",
    "StepsOpt",
    "SyncOpt",
    "check_source",
    "given_names",
    "given_options",
    "option_pair",
    "parse_orientations",
    "renamed_option",
]


# Options of the virtual rig and its fringes, declared once for simulate, measure --rig sim and
# train-correction --rig sim (each command gives its own default). The Live* twins put them in
# a help panel of their own where they only apply to the live rig.
SCENES_HELP = "white_plate, black_plate, plate, checkerboard, mask, glossy or specular_part."
LIVE_PANEL = "Live virtual rig (--rig sim)"


def option_pair(kind: Any, help_text: str) -> tuple[Any, Any]:
    """``Annotated`` option types for ``kind``: plain, and in the live-rig help panel."""
    return (
        Annotated[kind, typer.Option(help=help_text)],
        Annotated[kind, typer.Option(help=help_text, rich_help_panel=LIVE_PANEL)],
    )


DepthOpt, LiveDepthOpt = option_pair(
    float | None, "Plate/board depth (mask, glossy, specular_part: base height) in mm."
)
AmbientOpt, LiveAmbientOpt = option_pair(float, "Added ambient light in lux.")
NoiseOpt, LiveNoiseOpt = option_pair(float, "Read noise sigma in 8-bit gray levels.")
ApertureOpt, LiveApertureOpt = option_pair(
    str, "white (white plate peaks at 80 %), black (Sec. 5.2.2) or auto."
)
GammaOpt, LiveGammaOpt = option_pair(float, "Gamma pre-compensation of the patterns.")
SeedOpt, LiveSeedOpt = option_pair(int, "Random seed (noise).")
PatternOpt, LivePatternOpt = option_pair(str, "sinusoidal or triangular.")
StepsOpt, LiveStepsOpt = option_pair(int, "Number of phase shifts N.")
PitchOpt = Annotated[str, typer.Option(help="Pitch(es) in projector px, comma-separated.")]
#: The default pitch ladder as an option value (core.programs.DEFAULT_PITCHES_PX).
DEFAULT_PITCHES = ",".join(f"{p:g}" for p in DEFAULT_PITCHES_PX)
IminOpt, LiveIminOpt = option_pair(float, "Minimum input gray level.")
# the MIGL (thesis Sec. 4.1): one level; simulate also takes several (a sweep)
MiglOpt, LiveMiglOpt = option_pair(float, "Maximum input gray level (MIGL) of the fringes.")
MiglsOpt = Annotated[
    str, typer.Option("--migl", help="MIGL(s) of the fringes: comma-separated or start:stop:step.")
]
CenterlineOpt, LiveCenterlineOpt = option_pair(bool, "Add a centerline frame.")
LiveSceneOpt = Annotated[str, typer.Option(help=SCENES_HELP, rich_help_panel=LIVE_PANEL)]
RigOpt = Annotated[
    str | None,
    typer.Option(help="Live source instead of FOLDER: 'sim', the virtual rig (scene options)."),
]

#: Of :data:`LIVE_OPTIONS`, those of the virtual rig only (an error with ``--rig hardware``).
SIM_OPTIONS = ("scene", "depth_mm", "ambient_lux", "noise", "aperture", "seed")

#: measure's options that only a live rig uses (an error with a FOLDER: they would be ignored).
LIVE_OPTIONS = (
    "scene",
    "depth_mm",
    "ambient_lux",
    "noise",
    "aperture",
    "gamma",
    "seed",
    "pattern",
    "steps",
    "pitch",
    "imin",
    "migl",
    "centerline",
)


# Options of a real projector-camera rig, declared once for capture, rig check and measure
# --rig hardware (cli/capture.py re-exports them for the other hardware commands); the Hw*
# twins put them in a help panel of their own where a command also has other sources.
#: The help panel of the hardware options where a command also has other sources (measure).
HARDWARE_PANEL = "Hardware rig (--rig hardware)"


def _hardware_option(kind: Any, *names: str, help: str) -> tuple[Any, Any]:
    """``Annotated`` option types: plain (capture, rig check) and in the hardware help panel."""
    return (
        Annotated[kind, typer.Option(*names, help=help)],
        Annotated[kind, typer.Option(*names, help=help, rich_help_panel=HARDWARE_PANEL)],
    )


RigConfigOpt, HwRigConfigOpt = _hardware_option(
    Path | None,
    "--rig-config",
    help="Rig configuration file (TOML: projector, camera, sync, gamma; docs/hardware.md, "
    "'Rig configuration'); an option given on the command line overrides its value.",
)
ProjectorOpt, HwProjectorOpt = _hardware_option(
    str | None,
    "--projector",
    help="screen:N\\[@DISPLAY] (full-screen window) or folder:PATH\\[@WxH].",
)
CameraOpt, HwCameraOpt = _hardware_option(
    str | None,
    "--camera",
    help="pylon:SERIAL|emu, opencv:N, genicam:CTI[:SERIAL] or loop:SCENE[?...] (no hardware).",
)
SyncOpt, HwSyncOpt = _hardware_option(str, "--sync", help="software or hardware (camera trigger).")
SettleOpt, HwSettleOpt = _hardware_option(
    float, "--settle", help="Seconds to wait after each frame."
)
DiscardOpt, HwDiscardOpt = _hardware_option(
    int, "--discard", help="Images dropped after the settle (the latency)."
)
MaxGrabsOpt, HwMaxGrabsOpt = _hardware_option(
    int, "--max-grabs", help="Grabs per frame before a sync error."
)
ExposureOpt, HwExposureOpt = _hardware_option(
    float | None, "--exposure-ms", help="Exposure time in ms."
)
GainOpt, HwGainOpt = _hardware_option(float | None, "--gain-db", help="Camera gain in dB.")
PixelFormatOpt, HwPixelFormatOpt = _hardware_option(
    str | None, "--pixel-format", help="Mono8, Mono10, Mono12 or Mono16."
)


def parse_orientations(text: str) -> list[str]:
    """``--orientation``: vertical, horizontal, or both (vertical, then horizontal)."""
    if text not in ("vertical", "horizontal", "both"):
        raise InputError(f"unknown orientation {text!r}; use vertical, horizontal or both")
    return ["vertical", "horizontal"] if text == "both" else [text]


def given_options(ctx: typer.Context, names: tuple[str, ...]) -> list[str]:
    """The options among ``names`` given on the command line (not left at their default)."""
    out = []
    for name in names:
        src = ctx.get_parameter_source(name)
        if src is not None and src.name not in ("DEFAULT", "DEFAULT_MAP"):
            out.append("--" + name.replace("_", "-"))
    return out


def renamed_option(
    ctx: typer.Context, new: str, value: Any, old: str, old_value: Any
) -> Any:
    """The value of option ``new``, or of its deprecated hidden spelling ``old`` (issue 29).

    The old spelling, when given, says on stderr in one line that it is deprecated; given
    together with the new one and another value, the command is refused.

    Parameters
    ----------
    ctx : typer.Context
        The command's context (was ``new`` given, or left at its default?).
    new, old : str
        The two options' Python names (``"strategy"``, ``"method"``).
    value, old_value : object
        Their values; ``old_value`` None: not given.

    Returns
    -------
    object
        ``old_value`` when only the old spelling was given, else ``value``.

    Raises
    ------
    InputError
        Both spellings given, with different values.
    """
    if old_value is None:
        return value
    new_opt, old_opt = f"--{new.replace('_', '-')}", f"--{old.replace('_', '-')}"
    print(f"note: {old_opt} is deprecated; use {new_opt}", file=sys.stderr)
    if given_options(ctx, (new,)) and value != old_value:
        raise InputError(
            f"{new_opt} {value} and the deprecated {old_opt} {old_value} disagree; give "
            f"{new_opt} only"
        )
    return old_value


def given_names(ctx: typer.Context, names: tuple[str, ...]) -> set[str]:
    """The options among ``names`` (Python names) given on the command line, by Python name:
    what :func:`hdrfringe.tasks.capture.resolve_rig_config` lets override the file."""
    return {name for name in names if given_options(ctx, (name,))}


def check_source(
    ctx: typer.Context,
    folder: Path | None,
    rig: str | None,
    live_only: tuple[str, ...],
    *,
    hardware_only: tuple[str, ...] = (),
    sim_only: tuple[str, ...] = (),
) -> bool:
    """Exactly one of FOLDER and ``--rig``; live-only options only with a live rig.

    Without ``hardware_only`` the one live rig is ``sim`` (the virtual rig); with it,
    ``--rig hardware`` (a projector and camera) is a source too: its options
    (``hardware_only``) only apply to it, and ``sim_only`` options only to ``--rig sim``.

    Returns True for a live rig.
    """

    rigs = ("sim", "hardware") if hardware_only else ("sim",)
    named = "--rig sim (live virtual rig)" + (
        " or --rig hardware (projector and camera)" if hardware_only else ""
    )
    if rig is not None and rig not in rigs:
        raise InputError(
            f"unknown rig {rig!r}; use --rig sim (the virtual rig)"
            + (
                " or --rig hardware (a projector and camera, docs/hardware.md)"
                if hardware_only
                else ""
            )
        )
    if (folder is None) == (rig is None):
        raise InputError(
            f"give exactly one source: a capture FOLDER (replay) or {named}"
            if folder is not None
            else f"no source: give a capture FOLDER or {named}"
        )
    if rig is None:
        given = given_options(ctx, live_only)
        if given:
            raise InputError(
                f"{', '.join(given)} only appl{'ies' if len(given) == 1 else 'y'} to the live "
                "virtual rig; add --rig sim instead of the folder, or drop "
                f"{'it' if len(given) == 1 else 'them'} (a capture folder fixes scene and fringes)"
            )
    if rig != "hardware":
        given = given_options(ctx, hardware_only)
        if given:
            raise InputError(
                f"{', '.join(given)} only appl{'ies' if len(given) == 1 else 'y'} to --rig "
                f"hardware (a projector and camera); use --rig hardware or drop "
                f"{'it' if len(given) == 1 else 'them'}"
            )
    if rig == "hardware":
        given = given_options(ctx, sim_only)
        if given:
            raise InputError(
                f"{', '.join(given)} only appl{'ies' if len(given) == 1 else 'y'} to the live "
                "virtual rig (--rig sim); with --rig hardware the scene, light and camera are "
                f"real: drop {'it' if len(given) == 1 else 'them'}"
            )
    return rig is not None
