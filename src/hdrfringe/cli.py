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
from hdrfringe.errors import HdrFringeError

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
    from hdrfringe.io.pattern_folder import write_pattern_folder
    from hdrfringe.patterns import CenterlineFrame, Frame, FringeSpec, UniformFrame, render_frame
    from hdrfringe.rig.base import ProjectorInfo

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
    from hdrfringe.process import decode_folder

    check_output_dir(output, force)
    captures = read_capture_folder(folder)
    if not captures.sets:
        from hdrfringe.errors import CaptureFormatError

        raise CaptureFormatError(
            f"{folder}: no fringe frames in the manifest; add a complete phase-shifted set"
        )
    decoded = decode_folder(
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
        plot_gamma_mapping,
        predicted_nonlinearity,
    )
    from hdrfringe.io.captures import read_capture_folder
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
    # Narrow fringes are distorted by projector pixels and blur, which the shape fit would read
    # as gamma (on the virtual rig: 3.18 at 8 px, 2.84 at 32 px for a true 2.812).
    min_pitch = 32.0
    narrow = [
        s.label for s in caps.sets if s.spec.pattern == "sinusoidal" and s.spec.pitch_px < min_pitch
    ]
    sets = [s for s in caps.sets if s.spec.pattern == "sinusoidal" and s.spec.pitch_px >= min_pitch]
    if narrow:
        console.print(
            f"note: fringe sets narrower than {min_pitch:g} px not used for gamma: "
            + ", ".join(narrow)
        )
    if sets:
        by_gamma = {s.gamma_precompensation or gh0 for s in sets}
        if len(by_gamma) > 1 or any(s.spec.steps >= 4 for s in sets):
            fit = fit_gamma_fringes(
                [(s.spec, s.gamma_precompensation or gh0, caps.set_images(s)) for s in sets],
                camera_bit_depth=caps.camera_bit_depth,
                projector_bit_depth=proj_bits,
            )
            report["fringes"] = {
                "gamma": fit.gamma,
                "stderr": fit.stderr,
                "rms_residual_dn": fit.rms_residual,
                "pixels_used": fit.n_samples,
                "sets": [s.label for s in sets],
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


@app.command()
@handle_errors
def simulate(
    scene: Annotated[
        str,
        typer.Argument(
            help="white_plate, black_plate, plate, checkerboard, mask or glossy.",
        ),
    ],
    output: Annotated[Path, typer.Option("-o", "--output", help="Capture folder to write.")],
    depth_mm: Annotated[
        float | None, typer.Option(help="Plate/board depth (mask, glossy: base height) in mm.")
    ] = None,
    pattern: Annotated[str, typer.Option(help="sinusoidal or triangular.")] = "sinusoidal",
    steps: Annotated[int, typer.Option(help="Number of phase shifts N.")] = 4,
    pitch: Annotated[str, typer.Option(help="Pitch(es) in projector px, comma-separated.")] = "8",
    orientation: Annotated[str, typer.Option(help="vertical, horizontal or both.")] = "vertical",
    imin: Annotated[float, typer.Option(help="Minimum input gray level.")] = 40.0,
    migl: Annotated[str, typer.Option(help="MIGL(s): comma-separated or start:stop:step.")] = "255",
    migl_sweep: Annotated[
        str | None,
        typer.Option(help="A MIGL sweep start:stop:step (e.g. 255:60:1) for offline strategies."),
    ] = None,
    bit_depth: Annotated[int, typer.Option(help="Camera bit depth B (8, 10, 12, 16).")] = 8,
    ambient_lux: Annotated[float, typer.Option(help="Added ambient light in lux.")] = 0.0,
    noise: Annotated[float, typer.Option(help="Read noise sigma in 8-bit gray levels.")] = 1.0,
    shot_noise: Annotated[bool, typer.Option(help="Photon shot noise.")] = True,
    aperture: Annotated[
        str, typer.Option(help="white (white plate peaks at 80 %), black (Sec. 5.2.2) or auto.")
    ] = "auto",
    gamma: Annotated[float, typer.Option(help="Gamma pre-compensation of the patterns.")] = 2.812,
    ideal: Annotated[
        bool, typer.Option(help="Ideal rig: no noise/blur, 16-bit camera and projector.")
    ] = False,
    centerline: Annotated[bool, typer.Option(help="Add a centerline frame.")] = True,
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
    seed: Annotated[int, typer.Option(help="Random seed (noise).")] = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Capture fringe sets of a scene on the virtual rig and write a capture folder.

    Every folder also holds the scene's true height map (truth_height_mm.tiff) and the camera
    geometry, so measurements can report their error. With --series, DIR holds one folder per
    depth (a calibration series: reference plane + positions).
    """
    import dataclasses

    from hdrfringe.errors import InputError
    from hdrfringe.io.captures import write_capture_folder
    from hdrfringe.io.results import check_output_dir, staged_output_dir
    from hdrfringe.patterns import CenterlineFrame, Frame, FringeSpec, UniformFrame
    from hdrfringe.rig.modify import modify_captures
    from hdrfringe.rig.scenes import BLACK_PLATE_REFLECTIVITY, make_scene
    from hdrfringe.rig.simulated import Lighting, SimulatedRig

    check_output_dir(output, force)
    if orientation not in ("vertical", "horizontal", "both"):
        raise InputError(f"unknown orientation {orientation!r}; use vertical, horizontal or both")
    if aperture not in ("auto", "white", "black"):
        raise InputError(f"unknown aperture {aperture!r}; use auto, white or black")
    if series is not None:
        depths = _parse_range(series, "--series")
        if reference and 0.0 not in depths:
            depths = [0.0, *depths]
    else:
        depths = [depth_mm]
    lighting = Lighting(ambient_lux=ambient_lux)

    def make_rig(d: float | None) -> SimulatedRig:
        sc = make_scene(scene, **_scene_params(scene, d))
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

    rigs = [make_rig(d) for d in depths]  # validates every scene before anything is captured
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
            geom = rig.geometry
            target = tmp if series is None else tmp / f"{scene}_{(d or 0.0):06.2f}mm"
            write_capture_folder(
                target,
                frames,
                stack,
                rig.camera_bit_depth,
                projector=rig.projector,
                scene=rig.scene.to_manifest(),
                extra=extra,
                camera_extra={
                    "focal_px": geom.camera_focal_px(rig.image_shape[1]),
                    "standoff_mm": geom.standoff_mm,
                },
                maps={"truth_height_mm": rig.truth().height_mm},
                force=True,
            )
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
    from hdrfringe.io.captures import read_capture_folder, write_capture_folder
    from hdrfringe.io.results import check_output_dir
    from hdrfringe.rig.modify import modify_captures

    check_output_dir(output, force)
    caps = read_capture_folder(folder)
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
        for k, v in caps.manifest.items()
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
    names = [Path(e["file"]).stem for e in caps.entries]
    write_capture_folder(
        output,
        caps.frames,
        out,
        caps.camera_bit_depth,
        projector=caps.projector,
        scene=caps.scene,
        names=names,
        extra=extra,
        camera_extra={k: v for k, v in caps.manifest["camera"].items() if k != "bit_depth"},
        maps={key: caps.read_map(key) for key in caps.maps},
        force=force,
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


@app.command()
@handle_errors
def measure(
    folder: Annotated[Path, typer.Argument(help="Capture folder of the part.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Output folder.")],
    calibration: Annotated[
        Path | None, typer.Option("--calibration", "-c", help="Calibration file from calibrate.")
    ] = None,
    method: Annotated[
        str | None,
        typer.Option(
            help="Saturation avoidance on a MIGL-sweep folder: conventional, uniform, lpa."
        ),
    ] = None,
    step: Annotated[float, typer.Option(help="LPA: MIGL step S in gray levels.")] = 5.0,
    threshold: Annotated[
        float, typer.Option(help="DPA: CDF gain that triggers a capture (0.1 = 10 %).")
    ] = 0.1,
    correction: Annotated[
        Path | None, typer.Option(help="DPA: trained correction polynomial (JSON).")
    ] = None,
    uniform_migl: Annotated[
        float | None, typer.Option(help="Uniform: the trade-off MIGL (default: automatic).")
    ] = None,
    tolerance: Annotated[
        float, typer.Option(help="Uniform (automatic): saturated fraction allowed.")
    ] = 0.0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Height map, point cloud, phase maps and metrics of a capture folder.

    With --method, the folder is a MIGL sweep (hdrfringe simulate --migl-sweep) replayed by the
    strategy, which builds the composite images that are then measured.
    """
    import json

    from hdrfringe.io.calibration_file import load_calibration
    from hdrfringe.io.captures import read_capture_folder
    from hdrfringe.io.phase_maps import write_phase_maps
    from hdrfringe.io.results import check_output_dir, staged_output_dir
    from hdrfringe.measurement import calibration_geometry, measure_folder
    from hdrfringe.outputs import write_height_outputs

    check_output_dir(output, force)
    cal = load_calibration(calibration) if calibration is not None else None
    caps = read_capture_folder(folder)
    strategy_results = []
    if method is not None:
        from hdrfringe.measurement import composite_folder

        params: dict[str, Any] = {}
        if method == "lpa":
            params = {"step": step}
        elif method == "uniform":
            params = {"migl": uniform_migl, "tolerance": tolerance}
        elif method == "dpa":
            from hdrfringe.saturation.estimate import CorrectionPolynomial

            params = {"threshold": threshold}
            if correction is not None:
                params["correction"] = CorrectionPolynomial.load(correction)
        caps, strategy_results = composite_folder(caps, method, **params)
    result = measure_folder(
        caps, cal, calibration_source=None if calibration is None else str(calibration)
    )
    with staged_output_dir(output, force=force) as tmp:
        summary = write_phase_maps(tmp, result.decoded, str(folder))
        notes = list(summary["notes"])
        if result.height_mm is not None and cal is not None:
            notes += write_height_outputs(tmp, result.height_mm, calibration_geometry(cal))
        if strategy_results:
            from hdrfringe.outputs import write_strategy_outputs

            result.metrics.update(write_strategy_outputs(tmp, strategy_results))
        result.metrics["skipped"] = result.skipped
        result.metrics["notes"] = notes
        (tmp / "metrics.json").write_text(
            json.dumps(result.metrics, indent=1) + "\n", encoding="utf-8"
        )
    m = result.metrics
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


if __name__ == "__main__":  # pragma: no cover
    app()
