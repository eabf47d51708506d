"""``hdrfringe gamma``: projector gamma from uniform-gray or fringe captures."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from hdrfringe.cli._app import app, console, handle_errors

__all__ = ["gamma"]


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
