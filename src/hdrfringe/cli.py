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
    migl: Annotated[str, typer.Option(help="MIGL(s), comma-separated.")] = "255",
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
    seed: Annotated[int, typer.Option(help="Random seed (noise).")] = 0,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
) -> None:
    """Capture fringe sets of a scene on the virtual rig and write a capture folder."""
    import dataclasses

    from hdrfringe.errors import InputError
    from hdrfringe.io.captures import write_capture_folder
    from hdrfringe.io.results import check_output_dir
    from hdrfringe.patterns import CenterlineFrame, Frame, FringeSpec, UniformFrame
    from hdrfringe.rig.modify import modify_captures
    from hdrfringe.rig.scenes import BLACK_PLATE_REFLECTIVITY, make_scene
    from hdrfringe.rig.simulated import Lighting, SimulatedRig

    check_output_dir(output, force)
    if orientation not in ("vertical", "horizontal", "both"):
        raise InputError(f"unknown orientation {orientation!r}; use vertical, horizontal or both")
    if aperture not in ("auto", "white", "black"):
        raise InputError(f"unknown aperture {aperture!r}; use auto, white or black")
    sc = make_scene(scene, **_scene_params(scene, depth_mm))
    lighting = Lighting(ambient_lux=ambient_lux)
    if ideal:
        rig = SimulatedRig.ideal(sc, lighting=lighting, seed=seed)
    else:
        rig = SimulatedRig(sc, lighting=lighting, gamma_precompensation=gamma, seed=seed)
        cam = dataclasses.replace(
            rig.camera,
            bit_depth=bit_depth,
            read_noise_dn8=noise,
            full_well_e=rig.camera.full_well_e if shot_noise else None,
        )
        if aperture == "black" or (aperture == "auto" and scene in ("checkerboard", "black_plate")):
            cam = cam.with_aperture_for(BLACK_PLATE_REFLECTIVITY)
        rig = rig.replace(camera=cam)
    full = 2**rig.projector.bit_depth - 1
    orients = ["vertical", "horizontal"] if orientation == "both" else [orientation]
    frames: list[Frame] = []
    for o in orients:
        for m in _parse_floats(migl, "--migl"):
            m_proj = m * full / 255.0 if ideal else m
            i_proj = imin * full / 255.0 if ideal else imin
            for p in _parse_floats(pitch, "--pitch"):
                frames += FringeSpec(pattern, steps, p, o, i_proj, m_proj).frames()  # type: ignore[arg-type]
        if centerline:
            extent = rig.projector.width if o == "vertical" else rig.projector.height
            frames.append(CenterlineFrame(extent // 2, o, full))  # type: ignore[arg-type]
    if gray:
        frames += [
            UniformFrame(g * full / 255.0 if ideal else g) for g in _parse_floats(gray, "--gray")
        ]
    with progress_bar() as prog:
        task = prog.add_task(f"simulating {scene}", total=len(frames))
        images = []
        for f in frames:
            images.append(rig.capture([f])[0])
            prog.advance(task)
    stack = np.stack(images)
    modified = None
    if add_lux or add_dn or add_noise:
        stack = modify_captures(
            stack,
            rig.camera_bit_depth,
            add_dn=add_dn,
            add_lux=add_lux or None,
            noise_sigma=add_noise,
            seed=seed,
        )
        modified = {
            "add_lux": add_lux,
            "add_dn": add_dn,
            "noise_sigma": add_noise,
            "equation": "thesis Eq. 4.1",
        }
    extra: dict[str, Any] = {"simulator": rig.to_manifest()}
    if modified:
        extra["modification"] = modified
    write_capture_folder(
        output,
        frames,
        stack,
        rig.camera_bit_depth,
        projector=rig.projector,
        scene=sc.to_manifest(),
        extra=extra,
        force=force,
    )
    sat = float(np.mean((stack == 2**rig.camera_bit_depth - 1).any(axis=0)))
    console.print(
        f"wrote {len(frames)} captures of {scene} to {output} "
        f"({100 * sat:.1f} % of pixels saturated in at least one image)"
    )


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
        if k not in ("format", "version", "camera", "projector", "scene", "frames")
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


if __name__ == "__main__":  # pragma: no cover
    app()
