"""``hdrfringe simulate``: the virtual rig writes a capture folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from hdrfringe.cli._app import app, console, handle_errors, parse_floats, parse_range, progress_bar
from hdrfringe.cli._options import (
    SCENES_HELP,
    AmbientOpt,
    ApertureOpt,
    CenterlineOpt,
    DepthOpt,
    GammaOpt,
    IminOpt,
    NoiseOpt,
    PatternOpt,
    PitchOpt,
    SeedOpt,
    StepsOpt,
    simulated_rig,
)
from hdrfringe.errors import InputError

__all__ = ["simulate"]


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
    from hdrfringe.frames import CenterlineFrame, Frame, UniformFrame
    from hdrfringe.io.captures import write_capture_folder
    from hdrfringe.io.results import check_output_dir, staged_output_dir
    from hdrfringe.patterns import FringeSpec
    from hdrfringe.rig.modify import modify_captures

    check_output_dir(output, force)
    if orientation not in ("vertical", "horizontal", "both"):
        raise InputError(f"unknown orientation {orientation!r}; use vertical, horizontal or both")
    if series is not None:
        depths = parse_range(series, "--series")
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
        for m in parse_range(migl_sweep or migl, "--migl"):
            m_proj = m * full / 255.0 if ideal else m
            i_proj = imin * full / 255.0 if ideal else imin
            for p in parse_floats(pitch, "--pitch"):
                frames += FringeSpec(pattern, steps, p, o, i_proj, m_proj).frames()  # type: ignore[arg-type]
        if centerline:
            extent = rig0.projector.width if o == "vertical" else rig0.projector.height
            frames.append(CenterlineFrame(extent // 2, o, full))  # type: ignore[arg-type]
    if gray:
        frames += [
            UniformFrame(g * full / 255.0 if ideal else g) for g in parse_floats(gray, "--gray")
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
