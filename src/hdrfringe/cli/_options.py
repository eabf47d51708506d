"""Options of the virtual rig and its fringes shared by simulate, measure and train-correction."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.errors import InputError

__all__ = [
    "LIVE_OPTIONS",
    "LIVE_PANEL",
    "SCENES_HELP",
    "AmbientOpt",
    "ApertureOpt",
    "CenterlineOpt",
    "DepthOpt",
    "GammaOpt",
    "IminOpt",
    "LiveAmbientOpt",
    "LiveApertureOpt",
    "LiveCenterlineOpt",
    "LiveDepthOpt",
    "LiveGammaOpt",
    "LiveIminOpt",
    "LiveNoiseOpt",
    "LivePatternOpt",
    "LiveSceneOpt",
    "LiveSeedOpt",
    "LiveStepsOpt",
    "NoiseOpt",
    "PatternOpt",
    "PitchOpt",
    "RigOpt",
    "SeedOpt",
    "StepsOpt",
    "check_source",
    "given_options",
    "option_pair",
    "parse_orientations",
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
IminOpt, LiveIminOpt = option_pair(float, "Minimum input gray level.")
CenterlineOpt, LiveCenterlineOpt = option_pair(bool, "Add a centerline frame.")
LiveSceneOpt = Annotated[str, typer.Option(help=SCENES_HELP, rich_help_panel=LIVE_PANEL)]
RigOpt = Annotated[
    str | None,
    typer.Option(help="Live source instead of FOLDER: 'sim', the virtual rig (scene options)."),
]

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


def check_source(
    ctx: typer.Context, folder: Path | None, rig: str | None, live_only: tuple[str, ...]
) -> bool:
    """Exactly one of FOLDER and ``--rig sim``; live-only options only with the rig.

    Returns True for the live rig.
    """

    if rig is not None and rig != "sim":
        raise InputError(f"unknown rig {rig!r}; use --rig sim (the virtual rig)")
    if (folder is None) == (rig is None):
        raise InputError(
            "give exactly one source: a capture FOLDER (replay) or --rig sim (live virtual rig)"
            if folder is not None
            else "no source: give a capture FOLDER or --rig sim (live virtual rig)"
        )
    if rig is None:
        given = given_options(ctx, live_only)
        if given:
            raise InputError(
                f"{', '.join(given)} only appl{'ies' if len(given) == 1 else 'y'} to the live "
                "virtual rig; add --rig sim instead of the folder, or drop "
                f"{'it' if len(given) == 1 else 'them'} (a capture folder fixes scene and fringes)"
            )
    return rig is not None
