"""The ``hdrfringe`` command line.

Every command validates its input fully before writing anything; any
:class:`~hdrfringe.errors.HdrFringeError` is printed as one line on stderr with exit code 2, and
no partial output is left behind (outputs are staged and moved into place when complete).
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import numpy as np
import typer
from rich.console import Console

from hdrfringe import __version__
from hdrfringe.errors import HdrFringeError, InputError

app = typer.Typer(
    name="hdrfringe",
    help="3D surface measurement by phase-shifting fringe projection that copes with saturation.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
console = Console()
err_console = Console(stderr=True, soft_wrap=True)

F = TypeVar("F", bound=Callable[..., Any])


def handle_errors(func: F) -> F:
    """Turn an HdrFringeError into a one-line message and exit code 2."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except HdrFringeError as exc:
            msg = " ".join(str(exc).split())
            err_console.print(f"[bold red]error:[/] {msg}", markup=True, highlight=False)
            raise typer.Exit(code=2) from None

    return wrapper  # type: ignore[return-value]


def _version_callback(value: bool) -> None:
    if value:
        console.print(f"hdrfringe {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[
        bool,
        typer.Option(
            "--version",
            callback=_version_callback,
            is_eager=True,
            help="Print the version and exit.",
        ),
    ] = False,
) -> None:
    """hdrfringe: fringe patterns, virtual rig, phase, unwrapping and saturation avoidance."""


def progress_bar() -> Any:
    """A rich progress bar for long work (quiet when stderr is not a terminal)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err_console,
        transient=True,
        disable=not sys.stderr.isatty(),
    )


def _parse_floats(text: str, what: str) -> list[float]:
    from hdrfringe.errors import InputError

    try:
        vals = [float(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError:
        raise InputError(
            f"{what}: cannot read {text!r} as numbers; give a comma-separated list such as 8,64"
        ) from None
    if not vals:
        raise InputError(f"{what}: empty list; give at least one value")
    return vals


# ---------------------------------------------------------------------------------------------
# patterns
# ---------------------------------------------------------------------------------------------


@app.command()
@handle_errors
def patterns(
    output: Annotated[
        Path, typer.Option("-o", "--output", help="Output folder for PNGs + manifest.")
    ],
    pattern: Annotated[str, typer.Option(help="sinusoidal or triangular.")] = "sinusoidal",
    steps: Annotated[int, typer.Option(help="Number of phase shifts N.")] = 3,
    pitch: Annotated[str, typer.Option(help="Pitch(es) in projector px, comma-separated.")] = "6",
    orientation: Annotated[str, typer.Option(help="vertical or horizontal.")] = "vertical",
    imin: Annotated[float, typer.Option(help="Minimum input gray level.")] = 40.0,
    migl: Annotated[float, typer.Option(help="Maximum input gray level (MIGL).")] = 255.0,
    width: Annotated[int, typer.Option(help="Projector width in px.")] = 1024,
    height: Annotated[int, typer.Option(help="Projector height in px.")] = 768,
    bit_depth: Annotated[int, typer.Option(help="Projector input bit depth.")] = 8,
    gamma: Annotated[
        float, typer.Option(help="Gamma pre-compensation exponent (1 = none).")
    ] = 2.812,
    centerline: Annotated[bool, typer.Option(help="Add the centerline image.")] = True,
    centerline_position: Annotated[
        float | None, typer.Option(help="Centerline projector coordinate (default: middle).")
    ] = None,
    gray: Annotated[str, typer.Option(help="Uniform gray levels to add, comma-separated.")] = "",
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Generate fringe patterns (and centerline/uniform images) for a projector."""
    from hdrfringe.captures import ProjectorInfo
    from hdrfringe.frames import CenterlineFrame, Frame, UniformFrame, render_frame
    from hdrfringe.io.pattern_folder import write_pattern_folder
    from hdrfringe.patterns import FringeSpec

    projector = ProjectorInfo(width, height, bit_depth, gamma)
    frames: list[Frame] = []
    for p in _parse_floats(pitch, "--pitch"):
        spec = FringeSpec(pattern, steps, p, orientation, imin, migl)  # type: ignore[arg-type]
        frames += spec.frames()
    if centerline:
        extent = width if orientation == "vertical" else height
        pos = extent // 2 if centerline_position is None else centerline_position
        frames.append(CenterlineFrame(pos, orientation, migl))  # type: ignore[arg-type]
    if gray:
        frames += [UniformFrame(g) for g in _parse_floats(gray, "--gray")]
    for f in frames:  # validate everything (levels vs bit depth) before writing
        render_frame(f, 1, 1, gamma, bit_depth)
    with progress_bar() as prog:
        task = prog.add_task("writing patterns", total=len(frames))
        write_pattern_folder(
            output, frames, projector, force=force, progress=lambda: prog.advance(task)
        )
    console.print(f"wrote {len(frames)} pattern images and manifest.json to {output}")


# ---------------------------------------------------------------------------------------------
# phase
# ---------------------------------------------------------------------------------------------


@app.command()
@handle_errors
def phase(
    folder: Annotated[Path, typer.Argument(help="Capture folder (manifest.json + images).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Output folder for the maps.")],
    min_modulation: Annotated[
        float | None, typer.Option(help="Minimum intensity modulation I' in DN for a valid pixel.")
    ] = None,
    keep_saturated: Annotated[
        bool, typer.Option(help="Keep the (biased) phase of pixels with saturated shifts.")
    ] = False,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Decode a capture folder: wrapped, unwrapped and absolute phase with quality maps."""
    from hdrfringe.io.captures import read_capture_folder
    from hdrfringe.io.phase_maps import write_phase_maps
    from hdrfringe.io.results import check_output_dir, staged_output_dir
    from hdrfringe.process import decode_captures

    check_output_dir(output, force)
    captures = read_capture_folder(folder)
    if not captures.sets:
        from hdrfringe.errors import CaptureFormatError

        raise CaptureFormatError(
            f"{folder}: no fringe frames in the manifest; add a complete phase-shifted set"
        )
    decoded = decode_captures(
        captures, min_modulation=min_modulation, reject_saturated=not keep_saturated
    )
    with staged_output_dir(output, force=force) as tmp:
        summary = write_phase_maps(tmp, decoded, str(folder))
    for s in summary["sets"]:
        console.print(
            f"set {s['label']}: valid {100 * s['valid_fraction']:.1f} %, "
            f"saturated {100 * s['saturated_fraction']:.1f} %"
        )
    for fam in summary["families"]:
        extra = f", absolute by {fam['absolute_method']}" if "absolute_method" in fam else ""
        console.print(f"{fam['orientation']}: unwrapped by {fam['unwrapping']}{extra}")
    for note in summary["notes"]:
        console.print(f"note: {note}")
    console.print(f"wrote {len(summary['files'])} files to {output}")


# ---------------------------------------------------------------------------------------------
# gamma
# ---------------------------------------------------------------------------------------------


@app.command()
@handle_errors
def gamma(
    folder: Annotated[Path, typer.Argument(help="Capture folder with uniform grays or fringes.")],
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Folder for gamma.json and the plot.")
    ] = None,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Estimate the projector gamma (Eq. 2.16) and the nonlinearity left after pre-compensation.

    Uniform-gray frames (at least 4 unsaturated levels) give a direct fit of captured intensity
    against input gray; sinusoidal sets pre-distorted with known exponents give a fit of the
    fringe shape. Both are reported when the folder allows.
    """
    import json

    from hdrfringe.errors import CaptureFormatError
    from hdrfringe.gamma import (
        fit_gamma_fringes,
        fit_gamma_uniform,
        predicted_nonlinearity,
        select_gamma_sets,
    )
    from hdrfringe.io.captures import read_capture_folder
    from hdrfringe.io.plots import plot_gamma_mapping
    from hdrfringe.io.results import check_output_dir, staged_output_dir

    if output is not None:
        check_output_dir(output, force)
    caps = read_capture_folder(folder)
    proj_bits = caps.projector.bit_depth if caps.projector else 8
    gh0 = caps.projector.gamma_precompensation if caps.projector else 1.0
    report: dict[str, Any] = {"source": str(folder)}
    uniform_fit = None
    uniforms = caps.uniforms()
    if len({f.level for f, _ in uniforms}) >= 4:
        h, w = caps.image_shape
        roi = (slice(h // 4, 3 * h // 4), slice(w // 4, 3 * w // 4))
        levels = np.array([f.level for f, _ in uniforms])
        means = np.array([float(np.mean(img[roi])) for _, img in uniforms])
        uniform_fit = fit_gamma_uniform(
            levels,
            means,
            camera_bit_depth=caps.camera_bit_depth,
            projector_bit_depth=proj_bits,
            gamma_precompensation=gh0,
        )
        mx_fit, rms_fit = predicted_nonlinearity(uniform_fit, uniform_fit.gamma)
        mx_cur, _ = predicted_nonlinearity(uniform_fit, gh0)
        mx_none, _ = predicted_nonlinearity(uniform_fit, 1.0)
        report["uniform"] = {
            "gamma": uniform_fit.gamma,
            "stderr": uniform_fit.stderr,
            "offset_dn": uniform_fit.offset,
            "scale_dn": uniform_fit.scale,
            "rms_residual_dn": uniform_fit.rms_residual,
            "levels_used": uniform_fit.n_samples,
            "residual_nonlinearity_percent": {
                "precompensated_with_fit": mx_fit,
                "precompensated_with_fit_rms": rms_fit,
                f"precompensated_with_{gh0:g}": mx_cur,
                "no_precompensation": mx_none,
            },
        }
        console.print(
            f"uniform grays: gamma = {uniform_fit.gamma:.4f} +- {uniform_fit.stderr:.4f} "
            f"(rms residual {uniform_fit.rms_residual:.2f} DN, {uniform_fit.n_samples} levels)"
        )
        console.print(
            f"residual nonlinearity (max, % of range): {mx_fit:.2f} % pre-compensated with the "
            f"fit, {mx_cur:.2f} % with {gh0:g}, {mx_none:.2f} % without"
        )
    # Wide sinusoidal sets only: narrow fringes are reshaped by projector pixels and blur, which
    # the shape fit would read as gamma (hdrfringe.gamma.select_gamma_sets has the rule).
    chosen = select_gamma_sets([(s.spec, s.gamma_precompensation or gh0) for s in caps.sets])
    if chosen.too_narrow:
        console.print(
            f"note: fringe sets narrower than {chosen.min_pitch_px:g} px not used for gamma: "
            + ", ".join(caps.sets[i].label for i in chosen.too_narrow)
        )
    if chosen.fittable:
        used = [caps.sets[i] for i in chosen.used]
        fit = fit_gamma_fringes(
            [(s.spec, s.gamma_precompensation or gh0, caps.set_images(s)) for s in used],
            camera_bit_depth=caps.camera_bit_depth,
            projector_bit_depth=proj_bits,
        )
        report["fringes"] = {
            "gamma": fit.gamma,
            "stderr": fit.stderr,
            "rms_residual_dn": fit.rms_residual,
            "pixels_used": fit.n_samples,
            "sets": [s.label for s in used],
        }
        console.print(
            f"fringe shape: gamma = {fit.gamma:.4f} +- {fit.stderr:.4f} "
            f"(rms residual {fit.rms_residual:.2f} DN over {fit.n_samples} pixels)"
        )
    if len(report) == 1:
        raise CaptureFormatError(
            f"{folder}: nothing to fit: give uniform frames at >= 4 gray levels, or sinusoidal "
            "sets at two pre-compensation exponents (frame field gamma_precompensation) or with "
            ">= 4 steps"
        )
    if output is not None:
        with staged_output_dir(output, force=force) as tmp:
            (tmp / "gamma.json").write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")
            if uniform_fit is not None:
                plot_gamma_mapping(uniform_fit, tmp / "gamma_mapping.png")
        console.print(f"wrote {output}")


# ---------------------------------------------------------------------------------------------
# simulate / modify
# ---------------------------------------------------------------------------------------------


def _scene_params(scene: str, depth_mm: float | None) -> dict[str, Any]:
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


def _option_pair(kind: Any, help_text: str) -> tuple[Any, Any]:
    """``Annotated`` option types for ``kind``: plain, and in the live-rig help panel."""
    return (
        Annotated[kind, typer.Option(help=help_text)],
        Annotated[kind, typer.Option(help=help_text, rich_help_panel=LIVE_PANEL)],
    )


DepthOpt, LiveDepthOpt = _option_pair(
    float | None, "Plate/board depth (mask, glossy: base height) in mm."
)
AmbientOpt, LiveAmbientOpt = _option_pair(float, "Added ambient light in lux.")
NoiseOpt, LiveNoiseOpt = _option_pair(float, "Read noise sigma in 8-bit gray levels.")
ApertureOpt, LiveApertureOpt = _option_pair(
    str, "white (white plate peaks at 80 %), black (Sec. 5.2.2) or auto."
)
GammaOpt, LiveGammaOpt = _option_pair(float, "Gamma pre-compensation of the patterns.")
SeedOpt, LiveSeedOpt = _option_pair(int, "Random seed (noise).")
PatternOpt, LivePatternOpt = _option_pair(str, "sinusoidal or triangular.")
StepsOpt, LiveStepsOpt = _option_pair(int, "Number of phase shifts N.")
PitchOpt = Annotated[str, typer.Option(help="Pitch(es) in projector px, comma-separated.")]
IminOpt, LiveIminOpt = _option_pair(float, "Minimum input gray level.")
CenterlineOpt, LiveCenterlineOpt = _option_pair(bool, "Add a centerline frame.")
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

    from hdrfringe.errors import InputError
    from hdrfringe.rig.scenes import BLACK_PLATE_REFLECTIVITY, make_scene
    from hdrfringe.rig.simulated import Lighting, SimulatedRig

    if aperture not in ("auto", "white", "black"):
        raise InputError(f"unknown aperture {aperture!r}; use auto, white or black")
    lighting = Lighting(ambient_lux=ambient_lux)
    sc = make_scene(scene, **_scene_params(scene, depth_mm))
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


def _given(ctx: typer.Context, names: tuple[str, ...]) -> list[str]:
    """The options among ``names`` given on the command line (not left at their default)."""
    out = []
    for name in names:
        src = ctx.get_parameter_source(name)
        if src is not None and src.name not in ("DEFAULT", "DEFAULT_MAP"):
            out.append("--" + name.replace("_", "-"))
    return out


def _check_source(
    ctx: typer.Context, folder: Path | None, rig: str | None, live_only: tuple[str, ...]
) -> bool:
    """Exactly one of FOLDER and ``--rig sim``; live-only options only with the rig.

    Returns True for the live rig.
    """
    from hdrfringe.errors import InputError

    if rig is not None and rig != "sim":
        raise InputError(f"unknown rig {rig!r}; use --rig sim (the virtual rig)")
    if (folder is None) == (rig is None):
        raise InputError(
            "give exactly one source: a capture FOLDER (replay) or --rig sim (live virtual rig)"
            if folder is not None
            else "no source: give a capture FOLDER or --rig sim (live virtual rig)"
        )
    if rig is None:
        given = _given(ctx, live_only)
        if given:
            raise InputError(
                f"{', '.join(given)} only appl{'ies' if len(given) == 1 else 'y'} to the live "
                "virtual rig; add --rig sim instead of the folder, or drop "
                f"{'it' if len(given) == 1 else 'them'} (a capture folder fixes scene and fringes)"
            )
    return rig is not None


@app.command()
@handle_errors
def simulate(
    scene: Annotated[str, typer.Argument(help=SCENES_HELP)],
    output: Annotated[Path, typer.Option("-o", "--output", help="Capture folder to write.")],
    depth_mm: DepthOpt = None,
    pattern: PatternOpt = "sinusoidal",
    steps: StepsOpt = 4,
    pitch: PitchOpt = "8",
    orientation: Annotated[str, typer.Option(help="vertical, horizontal or both.")] = "vertical",
    imin: IminOpt = 40.0,
    migl: Annotated[str, typer.Option(help="MIGL(s): comma-separated or start:stop:step.")] = "255",
    migl_sweep: Annotated[
        str | None,
        typer.Option(help="A MIGL sweep start:stop:step (e.g. 255:60:1) for offline strategies."),
    ] = None,
    bit_depth: Annotated[int, typer.Option(help="Camera bit depth B (8, 10, 12, 16).")] = 8,
    ambient_lux: AmbientOpt = 0.0,
    noise: NoiseOpt = 1.0,
    shot_noise: Annotated[bool, typer.Option(help="Photon shot noise.")] = True,
    aperture: ApertureOpt = "auto",
    gamma: GammaOpt = 2.812,
    ideal: Annotated[
        bool, typer.Option(help="Ideal rig: no noise/blur, 16-bit camera and projector.")
    ] = False,
    centerline: CenterlineOpt = True,
    gray: Annotated[str, typer.Option(help="Uniform gray levels to add, comma-separated.")] = "",
    add_lux: Annotated[
        float, typer.Option(help="Eq. 4.1: add uniform light (lux) to the captures.")
    ] = 0.0,
    add_dn: Annotated[float, typer.Option(help="Eq. 4.1: add uniform DN to the captures.")] = 0.0,
    add_noise: Annotated[
        float, typer.Option(help="Eq. 4.1: add Gaussian noise (sigma, DN) to the captures.")
    ] = 0.0,
    series: Annotated[
        str | None,
        typer.Option(
            help="Depths start:stop:step or a list (mm): one capture folder per depth, "
            "e.g. 2:50:2 for the thesis's calibration positions."
        ),
    ] = None,
    reference: Annotated[
        bool, typer.Option(help="With --series, add the reference plane (depth 0).")
    ] = True,
    seed: SeedOpt = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Capture fringe sets of a scene on the virtual rig and write a capture folder.

    Every folder also holds the scene's true height map (truth_height_mm.tiff) and the camera
    geometry, so measurements can report their error. With --series, DIR holds one folder per
    depth (a calibration series: reference plane + positions).
    """
    from hdrfringe.captures import Captures
    from hdrfringe.errors import InputError
    from hdrfringe.frames import CenterlineFrame, Frame, UniformFrame
    from hdrfringe.io.captures import write_capture_folder
    from hdrfringe.io.results import check_output_dir, staged_output_dir
    from hdrfringe.patterns import FringeSpec
    from hdrfringe.rig.modify import modify_captures

    check_output_dir(output, force)
    if orientation not in ("vertical", "horizontal", "both"):
        raise InputError(f"unknown orientation {orientation!r}; use vertical, horizontal or both")
    if series is not None:
        depths = _parse_range(series, "--series")
        if reference and 0.0 not in depths:
            depths = [0.0, *depths]
    else:
        depths = [depth_mm]
    rigs = [  # validates every scene before anything is captured
        simulated_rig(
            scene,
            depth_mm=d,
            ambient_lux=ambient_lux,
            noise=noise,
            shot_noise=shot_noise,
            aperture=aperture,
            gamma=gamma,
            bit_depth=bit_depth,
            ideal=ideal,
            seed=seed,
        )
        for d in depths
    ]
    rig0 = rigs[0]
    full = 2**rig0.projector.bit_depth - 1
    orients = ["vertical", "horizontal"] if orientation == "both" else [orientation]
    frames: list[Frame] = []
    for o in orients:
        for m in _parse_range(migl_sweep or migl, "--migl"):
            m_proj = m * full / 255.0 if ideal else m
            i_proj = imin * full / 255.0 if ideal else imin
            for p in _parse_floats(pitch, "--pitch"):
                frames += FringeSpec(pattern, steps, p, o, i_proj, m_proj).frames()  # type: ignore[arg-type]
        if centerline:
            extent = rig0.projector.width if o == "vertical" else rig0.projector.height
            frames.append(CenterlineFrame(extent // 2, o, full))  # type: ignore[arg-type]
    if gray:
        frames += [
            UniformFrame(g * full / 255.0 if ideal else g) for g in _parse_floats(gray, "--gray")
        ]
    modified = None
    if add_lux or add_dn or add_noise:
        modified = {
            "add_lux": add_lux,
            "add_dn": add_dn,
            "noise_sigma": add_noise,
            "equation": "thesis Eq. 4.1",
        }
    sat_fractions = []
    with staged_output_dir(output, force=force) as tmp, progress_bar() as prog:
        task = prog.add_task(f"simulating {scene}", total=len(frames) * len(rigs))
        for d, rig in zip(depths, rigs, strict=True):
            images = []
            for f in frames:
                images.append(rig.capture([f])[0])
                prog.advance(task)
            stack = np.stack(images)
            if modified:
                stack = modify_captures(
                    stack,
                    rig.camera_bit_depth,
                    add_dn=add_dn,
                    add_lux=add_lux or None,
                    noise_sigma=add_noise,
                    seed=seed,
                )
            extra: dict[str, Any] = {"simulator": rig.to_manifest()}
            if modified:
                extra["modification"] = modified
            target = tmp if series is None else tmp / f"{scene}_{(d or 0.0):06.2f}mm"
            captures = Captures(
                frames,
                stack,
                rig.camera_bit_depth,
                projector=rig.projector,
                scene=rig.scene.to_manifest(),
                camera=rig.camera_manifest(),
                maps={"truth_height_mm": rig.truth().height_mm},
            )
            write_capture_folder(target, captures, extra=extra, force=True)
            sat_fractions.append(float(np.mean((stack == 2**rig.camera_bit_depth - 1).any(axis=0))))
    what = f"{len(rigs)} capture folders" if series is not None else "a capture folder"
    console.print(
        f"wrote {what} of {scene} ({len(frames)} images each) to {output}; "
        f"{100 * max(sat_fractions):.1f} % of pixels saturated in at least one image"
    )


def _parse_range(text: str, what: str) -> list[float]:
    """``start:stop:step`` (stop included) or a comma-separated list."""
    from hdrfringe.errors import InputError

    if ":" not in text:
        return _parse_floats(text, what)
    try:
        start, stop, step = (float(v) for v in text.split(":"))
    except ValueError:
        raise InputError(
            f"{what}: cannot read {text!r}; use start:stop:step, e.g. 2:50:2"
        ) from None
    if step != 0 and (stop - start) * step < 0:
        step = -step  # 255:60:1 means downwards
    if step == 0:
        raise InputError(f"{what}: {text!r} is an empty range; use e.g. 2:50:2 or 255:60:-5")
    n = int(np.floor((stop - start) / step + 1e-9)) + 1
    return [round(start + i * step, 9) for i in range(n)]


@app.command()
@handle_errors
def modify(
    folder: Annotated[Path, typer.Argument(help="Capture folder to modify.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Modified capture folder.")],
    add_lux: Annotated[float, typer.Option(help="Uniform light to add, in lux.")] = 0.0,
    add_dn: Annotated[float, typer.Option(help="Uniform intensity to add, in DN.")] = 0.0,
    noise: Annotated[float, typer.Option(help="Gaussian noise sigma to add, in DN.")] = 0.0,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Add light and noise to existing captures with clipping at 2^B - 1 (thesis Eq. 4.1)."""
    import dataclasses

    from hdrfringe.io.captures import read_capture_folder, read_manifest, write_capture_folder
    from hdrfringe.io.results import check_output_dir
    from hdrfringe.rig.modify import modify_captures

    check_output_dir(output, force)
    caps = read_capture_folder(folder)
    manifest = read_manifest(folder)  # the fields Captures does not keep: file names, extras
    out = modify_captures(
        caps.images,
        caps.camera_bit_depth,
        add_dn=add_dn,
        add_lux=add_lux or None,
        noise_sigma=noise,
        seed=seed,
    )
    extra = {
        k: v
        for k, v in manifest.items()
        if k not in ("format", "version", "camera", "projector", "scene", "frames", "maps")
    }
    extra["modification"] = {
        "source": str(folder),
        "add_lux": add_lux,
        "add_dn": add_dn,
        "noise_sigma": noise,
        "seed": seed,
        "equation": "thesis Eq. 4.1",
    }
    names = [Path(e["file"]).stem for e in manifest["frames"]]
    write_capture_folder(
        output, dataclasses.replace(caps, images=out), names=names, extra=extra, force=force
    )
    sat = float(np.mean((out == 2**caps.camera_bit_depth - 1).any(axis=0)))
    console.print(f"wrote {len(names)} modified captures to {output} ({100 * sat:.1f} % saturated)")


@app.command()
@handle_errors
def demo(
    output: Annotated[Path, typer.Option("-o", "--output", help="Demo output folder.")] = Path(
        "hdrfringe-demo"
    ),
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Simulate scenes on the virtual rig, decode them, write maps and plots, print a summary."""
    from hdrfringe.demo import run_demo

    run_demo(output, seed=seed, force=force, console=console)


@app.command()
@handle_errors
def reproduce(
    chapter: Annotated[
        str, typer.Argument(help="ch4, ch5, ch6, several joined by commas (ch5,ch6), or all.")
    ],
    output: Annotated[Path, typer.Option("-o", "--output", help="Reproduction folder.")] = Path(
        "hdrfringe-reproduction"
    ),
    quick: Annotated[
        bool, typer.Option(help="Reduced grid (quarter-size view, fewer pitches/MIGLs/depths).")
    ] = False,
    scheduler: Annotated[
        str | None, typer.Option(help="Dask scheduler address (default: a local cluster).")
    ] = None,
    workers: Annotated[
        int | None, typer.Option(help="Local cluster worker processes (default: CPU count).")
    ] = None,
    force: Annotated[
        bool, typer.Option(help="Write into a non-empty folder that is not a reproduction.")
    ] = False,
) -> None:
    """Run the thesis's experiments on the virtual rig as resumable sweeps (Dask, Zarr) and
    write tables beside the thesis's, figures and a report. Rerun to resume."""
    from hdrfringe.reproduce.runner import CHAPTERS
    from hdrfringe.reproduce.runner import reproduce as run

    chapters = list(CHAPTERS) if chapter == "all" else [c.strip() for c in chapter.split(",")]
    if not console.is_terminal:  # no progress bar: progress lines on stderr instead
        import logging
        import sys

        logger = logging.getLogger("hdrfringe.reproduce")
        if not logger.handlers:
            handler = logging.StreamHandler(sys.stderr)
            handler.setFormatter(logging.Formatter("%(asctime)s %(message)s", "%H:%M:%S"))
            logger.addHandler(handler)
        logger.setLevel(logging.INFO)
    if workers is not None and workers < 1:
        raise InputError(f"--workers must be at least 1, got {workers}")
    res = run(
        chapters,
        output,
        quick=quick,
        scheduler=scheduler,
        n_workers=workers,
        progress=console.is_terminal,
        force=force,
    )
    for name, secs in res["timings_s"].items():
        console.print(f"{name}: {secs:.1f} s")
    console.print(f"report: {output / 'report.md'} and report.html")


# ---------------------------------------------------------------------------------------------
# calibrate / measure
# ---------------------------------------------------------------------------------------------


@app.command()
@handle_errors
def calibrate(
    folders: Annotated[
        list[Path],
        typer.Argument(
            help="Flat-plate capture folders (scene.depth_mm; one at 0), or a folder of them."
        ),
    ],
    output: Annotated[Path, typer.Option("-o", "--output", help="Calibration file (.h5).")],
    model: Annotated[
        str, typer.Option(help="linear (Eq. 2.15), rational (1/h form), poly2 or poly3.")
    ] = "linear",
    window: Annotated[int, typer.Option(help="Median and mean filter window, px.")] = 21,
    border: Annotated[int, typer.Option(help="Unfiltered border excluded from metrics, px.")] = 10,
    force: Annotated[bool, typer.Option(help="Replace an existing calibration file.")] = False,
) -> None:
    """Per-pixel phase-to-height calibration from a plate at known depths (Sec. 2.5, 4.1)."""
    from hdrfringe.calibration import MODELS
    from hdrfringe.errors import InputError, OutputExistsError
    from hdrfringe.io.calibration_file import save_calibration
    from hdrfringe.measurement import calibrate_folders, expand_capture_dirs

    if model not in MODELS:
        raise InputError(f"unknown model {model!r}; use one of {', '.join(MODELS)}")
    if output.exists() and not force:
        raise OutputExistsError(f"{output}: exists; pass --force to replace it")
    n = len(expand_capture_dirs(folders))
    with progress_bar() as prog:
        task = prog.add_task("decoding plate positions", total=n)
        cal = calibrate_folders(
            folders,
            model=model,
            window_px=window,
            border_px=border,
            progress=lambda: prog.advance(task),
        )
    save_calibration(output, cal, force=force)
    console.print(
        f"calibrated {len(cal.depths_mm)} positions ({cal.depths_mm.min():g}..."
        f"{cal.depths_mm.max():g} mm) + reference with {cal.spec.label() if cal.spec else '?'}"
    )
    console.print(f"fit residual (median RMS over measurement pixels): {cal.describe_residuals()}")
    console.print(f"wrote {output}")


def method_help() -> str:
    """``measure --method``'s help: the registered strategies, read when the CLI is imported.

    Returns
    -------
    str

    Examples
    --------
    >>> method_help()[:56]
    'Saturation avoidance: conventional, uniform, lpa or dpa '
    """
    from hdrfringe.strategies import available_strategies

    names = available_strategies()
    listed = f"{', '.join(names[:-1])} or {names[-1]}" if len(names) > 1 else "".join(names)
    return (
        f"Saturation avoidance: {listed} (a FOLDER must then be a MIGL sweep; --rig sim "
        "without it: conventional)."
    )


def strategy_file_readers() -> dict[type, tuple[Callable[[Any], Any], str]]:
    """Strategy parameter types the command line takes as a file: type -> (reader, what file).

    Strategies read no files; the front end turns the path into the parameter.

    Returns
    -------
    dict

    Examples
    --------
    >>> [t.__name__ for t in strategy_file_readers()]
    ['CorrectionPolynomial']
    """
    from hdrfringe.saturation.estimate import CorrectionPolynomial

    return {CorrectionPolynomial: (CorrectionPolynomial.load, "JSON from train-correction")}


def _strategy_option_type(opt: Any) -> tuple[Any, str]:
    """The command-line type of a strategy option (bool, int, float, str, or a file as a
    Path) and, for a file, what it holds."""
    import types
    import typing

    hint = opt.hint
    union = typing.get_origin(hint) in (typing.Union, types.UnionType)
    args = typing.get_args(hint) if union else (hint,)
    base = [a for a in args if a is not type(None)]
    files = strategy_file_readers()
    if len(base) == 1 and base[0] in (bool, int, float, str):
        return (base[0] | None if type(None) in args else base[0]), ""
    if len(base) == 1 and base[0] in files and opt.default is None:
        return Path | None, files[base[0]][1]
    raise InputError(
        f"strategy option {opt.option} ({', '.join(opt.titles())}): the command line gives "
        f"bool, int, float, str or a file read into "
        f"{', '.join(t.__name__ for t in files)} (default None), not {hint}; change the Params "
        "field or drop its 'cli' name"
    )


def with_strategy_options(func: F) -> F:
    """Give a command one option per strategy parameter on the command line, after --method.

    The options come from the registry (:func:`hdrfringe.strategies.cli_options`) when this
    module is imported: a strategy registered before that has its options here. The command
    receives them in ``**strategy_options`` by Python name (``bound_pending``).

    Parameters
    ----------
    func : callable
        A command with a ``method`` parameter and ``**strategy_options``.

    Returns
    -------
    The command, with a ``__signature__`` that typer reads.

    Examples
    --------
    >>> import inspect
    >>> "bound_pending" in inspect.signature(measure).parameters
    True
    """
    import inspect

    from hdrfringe.strategies import cli_options

    sig = inspect.signature(func, eval_str=True)
    own = [p for p in sig.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
    at = [p.name for p in own].index("method") + 1
    extra = []
    for opt in cli_options():
        if opt.dest in sig.parameters:
            raise InputError(
                f"strategy option {opt.option} ({', '.join(opt.titles())}) is also an option of "
                f"{func.__name__}; give the Params field another 'cli' name"
            )
        kind, file = _strategy_option_type(opt)
        decl = f"{opt.option}/--no-{opt.option[2:]}" if kind is bool else opt.option
        text = f"{opt.help} File: {file}." if file else opt.help
        extra.append(
            inspect.Parameter(
                opt.dest,
                inspect.Parameter.POSITIONAL_OR_KEYWORD,
                default=opt.default,
                annotation=Annotated[kind, typer.Option(decl, help=text)],
            )
        )
    func.__signature__ = sig.replace(parameters=[*own[:at], *extra, *own[at:]])  # type: ignore[attr-defined]
    return func


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
    from hdrfringe.errors import InputError
    from hdrfringe.io.calibration_file import load_calibration
    from hdrfringe.io.measurement_outputs import write_height_outputs
    from hdrfringe.io.phase_maps import write_phase_maps
    from hdrfringe.io.results import check_output_dir, staged_output_dir
    from hdrfringe.measurement import calibration_geometry, measure_folder
    from hdrfringe.strategies import cli_options, param_values, params_from_options

    live = _check_source(ctx, folder, rig, LIVE_OPTIONS)
    if output is None:
        raise InputError("no output folder: give -o/--output OUT")
    if live and method is None:
        method = "conventional"
    given = {  # the strategy options on the command line (this command's: built at import)
        o.option: strategy_options[o.dest]
        for o in cli_options()
        if o.dest in strategy_options and _given(ctx, (o.dest,))
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
        pitches = sorted(set(_parse_floats(pitch, "--pitch")), reverse=True)
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


@app.command("train-correction")
@handle_errors
def train_correction(
    ctx: typer.Context,
    folder: Annotated[
        Path | None,
        typer.Argument(help="A step-1 MIGL sweep folder (simulate --migl-sweep 255:60:1)."),
    ] = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Correction polynomial file (.json).")
    ] = None,
    rig: RigOpt = None,
    scene: LiveSceneOpt = "white_plate",
    depth_mm: LiveDepthOpt = None,
    ambient_lux: Annotated[
        float,
        typer.Option(
            help="Added ambient light in lux (saturates the white plate).",
            rich_help_panel=LIVE_PANEL,
        ),
    ] = 600.0,
    noise: LiveNoiseOpt = 1.0,
    aperture: LiveApertureOpt = "auto",
    gamma: LiveGammaOpt = 2.812,
    seed: LiveSeedOpt = 0,
    steps: Annotated[
        int, typer.Option(help="Number of phase shifts N (>= 4).", rich_help_panel=LIVE_PANEL)
    ] = 4,
    pitch: Annotated[
        float | None,
        typer.Option(
            help="Pitch in projector px (live default 20, the thesis's; a folder: pick "
            "one of its pitches)."
        ),
    ] = None,
    imin: LiveIminOpt = 40.0,
    migl: Annotated[
        float, typer.Option(help="Top MIGL of the sweep.", rich_help_panel=LIVE_PANEL)
    ] = 255.0,
    order: Annotated[int, typer.Option(help="Polynomial degree (thesis: low order).")] = 2,
    truth: Annotated[
        str,
        typer.Option(help="Training truth: scaled (the pixel's own response) or thesis (Eq. 6.3)."),
    ] = "scaled",
    margin: Annotated[
        int, typer.Option(help="Gray levels below N(x, y) of each pixel's reference set.")
    ] = 10,
    force: Annotated[bool, typer.Option(help="Replace an existing file.")] = False,
) -> None:
    """Train DPA's error-correction polynomial (thesis Sec. 6.1.2, Eq. 6.3-6.4) and save it.

    LPA with a step of one gray level on a white plate at a large pitch (thesis: 20 px) gives
    every saturated pixel's true peak; a polynomial in the Eq. 6.2 estimate is fitted to the
    estimate's error. Live (--rig sim; white plate under 600 lx by default) or from a step-1
    MIGL sweep FOLDER. Use the file with measure --method dpa --correction FILE.
    """
    from hdrfringe.errors import InputError, OutputExistsError
    from hdrfringe.measurement import THESIS_CORRECTION_RMSE
    from hdrfringe.patterns import FringeSpec
    from hdrfringe.saturation.estimate import TRUTH_MODELS, training_data_from_rig

    live_only = tuple(n for n in LIVE_OPTIONS if n not in ("pitch", "pattern", "centerline"))
    live = _check_source(ctx, folder, rig, live_only)  # --pitch also picks a folder's set
    if output is None:
        raise InputError("no output file: give -o/--output FILE.json")
    if truth not in TRUTH_MODELS:
        raise InputError(f"unknown truth {truth!r}; use one of {', '.join(TRUTH_MODELS)}")
    if output.exists() and not force:
        raise OutputExistsError(f"{output}: exists; pass --force to replace it")
    if output.is_dir():
        raise OutputExistsError(f"{output}: is a folder; give a file name such as corr.json")
    if live:
        sim = simulated_rig(
            scene,
            depth_mm=depth_mm,
            ambient_lux=ambient_lux,
            noise=noise,
            aperture=aperture,
            gamma=gamma,
            seed=seed,
        )
        if steps < 4:
            raise InputError(
                f"the saturated-intensity estimate needs at least 4 steps (Eq. 6.2), got {steps}"
            )
        spec = FringeSpec(
            "sinusoidal", steps, 20.0 if pitch is None else pitch, "vertical", imin, migl
        )
        source = f"live virtual rig: {sim.scene.to_manifest()}, {ambient_lux:g} lx, seed {seed}"
        with progress_bar() as prog:
            prog.add_task("LPA step-1 sweep on the virtual rig", total=None)
            data = training_data_from_rig(sim, spec, margin=margin)
    else:
        from hdrfringe.io.captures import read_capture_folder
        from hdrfringe.measurement import training_data_from_folder

        assert folder is not None
        source = str(folder)
        data = training_data_from_folder(read_capture_folder(folder), pitch, margin=margin)
    poly = data.train(order, truth=truth, metadata={"source": source})  # type: ignore[arg-type]
    poly.save(output, force=force)
    before, after = THESIS_CORRECTION_RMSE
    console.print(
        f"trained on {poly.n_samples} saturated pixels of {data.spec.label()} "
        f"({data.sets_captured} sets, truth {truth}, order {order})"
    )
    console.print(
        f"estimate RMSE (Eq. 6.4): before correction {poly.rmse_before:.2f} DN (thesis "
        f"{before:g} gray levels), after {poly.rmse_after:.2f} DN (thesis {after:g})"
    )
    console.print(f"wrote {output}")


if __name__ == "__main__":  # pragma: no cover
    app()
