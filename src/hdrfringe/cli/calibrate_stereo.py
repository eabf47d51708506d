"""``hdrfringe calibrate-stereo``: projector-camera calibration from board poses, or a
conversion of another tool's calibration (docs/stereo_calibration.md); the work is
:func:`hdrfringe.tasks.calibrate_stereo.calibrate_stereo`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_stage
from hdrfringe.errors import InputError

__all__ = ["calibrate_stereo"]


def _size(text: str | None, what: str, from_path: Path | None) -> tuple[int, int] | None:
    """``--camera-size``/``--projector-size`` as (width, height); read with --from only (a
    calibration from poses takes the sizes from the folders)."""
    if text is None or from_path is None:
        return None
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise InputError(
            f"{what}: give WIDTHxHEIGHT in pixels, e.g. 1024x768, got {text!r}"
        ) from None
    if w < 1 or h < 1:
        raise InputError(f"{what}: sizes must be >= 1 pixel, got {text!r}")
    return w, h


def _print_report(result: Any) -> None:
    rep = result.calibration.reprojection_px
    console.print(
        f"reprojection RMS: camera {rep['camera']:.3f} px, projector {rep['projector']:.3f} px, "
        f"stereo {rep['stereo']:.3f} px over {result.settings['poses_used']} poses"
    )
    for p in result.poses:
        if p.used:
            flag = "  FLAGGED" if p.flagged else ""
            console.print(
                f"  {p.name}: {p.mapped}/{p.points} points, camera {p.camera_rms_px:.3f}, "
                f"projector {p.projector_rms_px:.3f}, stereo {p.stereo_rms_px:.3f} px{flag}",
                highlight=False,
            )
        else:
            console.print(f"  {p.name}: not used ({'; '.join(p.notes)})", highlight=False)
    cal = result.calibration
    console.print(
        f"camera f = {cal.camera.matrix[0, 0]:.2f}, {cal.camera.matrix[1, 1]:.2f} px; projector "
        f"f = {cal.projector.matrix[0, 0]:.2f}, {cal.projector.matrix[1, 1]:.2f} px; baseline "
        f"{cal.baseline_mm:.2f} mm",
        highlight=False,
    )
    if result.flagged:
        console.print(
            f"[yellow]warning:[/] flagged poses {', '.join(result.flagged)} "
            f"({result.settings['flag_rule']}); consider leaving them out"
        )


@app.command("calibrate-stereo")
@handle_errors
def calibrate_stereo(
    output: Annotated[
        Path, typer.Option("-o", "--output", help="Stereo calibration file to write (.h5).")
    ],
    poses: Annotated[
        list[Path] | None,
        typer.Argument(
            help="Capture folders, one per board pose (white frame + fringes).",
            show_default=False,
        ),
    ] = None,
    board: Annotated[
        str | None,
        typer.Option(
            help="PATTERN:COLSxROWS:SPACING_MM, e.g. checkerboard:9x6:25 (inner corners) or "
            "circles:4x11:20 (dots)."
        ),
    ] = None,
    from_path: Annotated[
        Path | None,
        typer.Option(
            "--from",
            help="Convert this calibration (OpenCV YAML/XML, .npz, a data set's folder, .h5) "
            "instead of calibrating.",
        ),
    ] = None,
    rig: Annotated[
        str | None,
        typer.Option(help="sim: calibrate on the virtual calibration rig (simulated poses)."),
    ] = None,
    pose_count: Annotated[
        int, typer.Option("--poses", help="With --rig sim: number of board poses.")
    ] = 10,
    save_poses: Annotated[
        Path | None,
        typer.Option(help="With --rig sim: also write the pose capture folders here."),
    ] = None,
    noise: Annotated[
        float, typer.Option(help="With --rig sim: camera read noise sigma (8-bit gray levels).")
    ] = 1.0,
    seed: Annotated[int, typer.Option(help="With --rig sim: noise seed.")] = 0,
    window: Annotated[int, typer.Option(help="Local homography window half side, camera px.")] = 12,
    min_valid: Annotated[
        float | None,
        typer.Option(
            help="Least fraction of a window's pixels with projector coordinates (default 0.5 "
            "for fringes, 0.2 for a Gray code alone).",
            show_default=False,
        ),
    ] = None,
    distortion: Annotated[
        str, typer.Option(help="Lens distortion terms: standard (k1 k2 p1 p2), radial, none, full.")
    ] = "standard",
    fix_intrinsics: Annotated[
        bool, typer.Option(help="Keep the separate intrinsics in the stereo step.")
    ] = False,
    camera_size: Annotated[
        str | None, typer.Option(help="With --from: camera WIDTHxHEIGHT if the file has none.")
    ] = None,
    projector_size: Annotated[
        str | None, typer.Option(help="With --from: projector WIDTHxHEIGHT if the file has none.")
    ] = None,
    force: Annotated[
        bool, typer.Option(help="Replace an existing calibration and report.")
    ] = False,
) -> None:
    """Projector-camera (stereo) calibration from captures of a calibration board.

    Each POSE folder holds a white frame and vertical and horizontal fringes decodable to
    absolute phase; the board's points are found in the camera, mapped into the projector by
    local homographies, and OpenCV calibrates both lenses and their motion. Writes OUTPUT and
    OUTPUT's stem + _report.json (per-pose errors, flagged poses). --from converts another
    tool's calibration instead; --rig sim calibrates the virtual rig and reports the errors
    against its true geometry.
    """
    from hdrfringe.tasks.calibrate_stereo import calibrate_stereo as task

    done = task(
        output, poses or [], board=board, from_path=from_path, rig=rig, pose_count=pose_count,
        save_poses=save_poses, noise=noise, seed=seed, window=window, min_valid=min_valid,
        distortion=distortion, fix_intrinsics=fix_intrinsics,
        camera_size=_size(camera_size, "--camera-size", from_path),
        projector_size=_size(projector_size, "--projector-size", from_path), force=force,
        progress=progress_stage,
    )  # fmt: skip
    out, rep = done.calibration_file, done.report_file
    if done.converted_from is not None:
        console.print(
            f"converted {done.converted_from}: baseline {done.calibration.baseline_mm:.2f} mm; "
            f"wrote {out} and {rep}"
        )
        return
    _print_report(done.result)
    if done.errors_vs_truth is not None:
        console.print(
            "against the virtual rig's true geometry: "
            + ", ".join(f"{k} {v:.3g}" for k, v in done.errors_vs_truth.items()),
            highlight=False,
        )
    console.print(f"wrote {out} and {rep}")
