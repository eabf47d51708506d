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
    "scene_params",
    "simulated_rig",
]


def scene_params(scene: str, depth_mm: float | None) -> dict[str, Any]:
    if depth_mm is None:
        return {}
    if scene in ("mask", "glossy"):
        return {"base_mm": depth_mm}
    return {"depth_mm": depth_mm}


# Options of the virtual rig and its fringes, declared once for simulate, measure --rig sim and
# train-correction --rig sim (each command gives its own default). The Live* twins put them in
# a help panel of their own where they only apply to the live rig.
SCENES_HELP = "white_plate, black_plate, plate, checkerboard, mask or glossy."
LIVE_PANEL = "Live virtual rig (--rig sim)"


def option_pair(kind: Any, help_text: str) -> tuple[Any, Any]:
    """``Annotated`` option types for ``kind``: plain, and in the live-rig help panel."""
    return (
        Annotated[kind, typer.Option(help=help_text)],
        Annotated[kind, typer.Option(help=help_text, rich_help_panel=LIVE_PANEL)],
    )


DepthOpt, LiveDepthOpt = option_pair(
    float | None, "Plate/board depth (mask, glossy: base height) in mm."
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


def simulated_rig(
    scene: str,
    *,
    depth_mm: float | None = None,
    ambient_lux: float = 0.0,
    noise: float = 1.0,
    shot_noise: bool = True,
    aperture: str = "auto",
    gamma: float = 2.812,
    bit_depth: int = 8,
    ideal: bool = False,
    seed: int = 0,
) -> Any:
    """The virtual rig the scene options describe (simulate, measure and train-correction).

    Parameters
    ----------
    scene : str
        Scene name (:func:`hdrfringe.rig.scenes.make_scene`).
    depth_mm : float, optional
        Plate or board depth; base height for mask and glossy. None: the scene's default.
    ambient_lux, noise, shot_noise, gamma, bit_depth, seed
        Added ambient light (lux), read noise (8-bit gray levels), photon shot noise, gamma
        pre-compensation of the patterns, camera bit depth, noise seed.
    aperture : {"auto", "white", "black"}
        ``white``: the default camera (a white plate peaks at 80 %); ``black``: opened for the
        black plate (thesis Sec. 5.2.2); ``auto``: black for checkerboard and black_plate.
    ideal : bool
        :meth:`SimulatedRig.ideal` (no noise or blur, 16-bit camera and projector).

    Returns
    -------
    SimulatedRig
    """
    import dataclasses

    from hdrfringe.rig.scenes import BLACK_PLATE_REFLECTIVITY, make_scene
    from hdrfringe.rig.simulated import Lighting, SimulatedRig

    if aperture not in ("auto", "white", "black"):
        raise InputError(f"unknown aperture {aperture!r}; use auto, white or black")
    lighting = Lighting(ambient_lux=ambient_lux)
    sc = make_scene(scene, **scene_params(scene, depth_mm))
    if ideal:
        return SimulatedRig.ideal(sc, lighting=lighting, seed=seed)
    rig = SimulatedRig(sc, lighting=lighting, gamma_precompensation=gamma, seed=seed)
    cam = dataclasses.replace(
        rig.camera,
        bit_depth=bit_depth,
        read_noise_dn8=noise,
        full_well_e=rig.camera.full_well_e if shot_noise else None,
    )
    if aperture == "black" or (aperture == "auto" and scene in ("checkerboard", "black_plate")):
        cam = cam.with_aperture_for(BLACK_PLATE_REFLECTIVITY)
    return rig.replace(camera=cam)


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
