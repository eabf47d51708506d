"""``hdrfringe calibrate-stereo``: projector-camera calibration from board poses, or a
conversion of another tool's calibration (docs/stereo_calibration.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors, progress_bar
from hdrfringe.errors import InputError

__all__ = ["calibrate_stereo"]


def _size(text: str | None, what: str) -> tuple[int, int] | None:
    if text is None:
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


def _truth_errors(calib: Any, truth: Any) -> dict[str, float]:
    import numpy as np

    out: dict[str, float] = {}
    for name in ("camera", "projector"):
        k, kt = getattr(calib, name).matrix, getattr(truth, name).matrix
        out[f"{name}_focal_error_percent"] = float(
            100 * np.abs(k[[0, 1], [0, 1]] / kt[[0, 1], [0, 1]] - 1).max()
        )
        out[f"{name}_principal_point_error_px"] = float(np.abs(k[:2, 2] - kt[:2, 2]).max())
    out["baseline_error_percent"] = float(100 * abs(calib.baseline_mm / truth.baseline_mm - 1))
    return out


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
    from hdrfringe.io.results import check_output_against_inputs
    from hdrfringe.stereo_calibration import DISTORTION_MODELS, MIN_POSES
    from hdrfringe.tasks.calibrate_stereo import (
        check_calibration_outputs,
        read_pose_folders,
        write_calibration_and_report,
    )

    sources = [bool(poses), from_path is not None, rig is not None]
    if sum(sources) != 1:
        raise InputError(
            "give exactly one source: POSE folders, --from PATH (conversion) or --rig sim"
        )
    if distortion not in DISTORTION_MODELS:
        raise InputError(f"--distortion {distortion!r}: use {', '.join(DISTORTION_MODELS)}")
    if not 1 <= window <= 100:
        raise InputError(f"--window {window}: give a half window of 1..100 camera pixels")
    if min_valid is not None and not 0 < min_valid <= 1:
        raise InputError(f"--min-valid {min_valid}: give a fraction in (0, 1], e.g. 0.2")
    if rig is not None and rig != "sim":
        raise InputError(f"--rig {rig!r}: only the virtual rig 'sim' can be driven here")
    inputs: list[Path | None] = [*(poses or []), from_path, save_poses]
    check_output_against_inputs(output, inputs)
    check_calibration_outputs(output, force)

    if from_path is not None:
        from hdrfringe.io.stereo_file import convert_calibration

        calib = convert_calibration(
            from_path,
            camera_size=_size(camera_size, "--camera-size"),
            projector_size=_size(projector_size, "--projector-size"),
        )
        converted = {"converted_from": str(from_path), "calibration": calib.to_dict()}
        out, rep = write_calibration_and_report(output, calib, converted, force=force)
        console.print(
            f"converted {from_path}: baseline {calib.baseline_mm:.2f} mm; wrote {out} and {rep}"
        )
        return

    if board is None:
        raise InputError("--board is required: e.g. --board checkerboard:9x6:25")
    from hdrfringe.stereo_calibration import BoardSpec, calibrate_stereo, observe_pose

    spec = BoardSpec.parse(board)
    truth = None
    if poses:
        if len(poses) < MIN_POSES:
            raise InputError(
                f"{len(poses)} pose folder(s) given; stereo calibration needs at least "
                f"{MIN_POSES} (10 or more recommended)"
            )
        captures = read_pose_folders(poses)
        names = [str(p) for p in poses]
    else:
        from hdrfringe.rig.board_poses import (
            calibration_rig,
            capture_board_poses,
            default_board_poses,
        )

        if pose_count < MIN_POSES:
            raise InputError(f"--poses {pose_count}: give at least {MIN_POSES}")
        boards = default_board_poses(
            pose_count,
            pattern=spec.pattern,
            cols=spec.cols,
            rows=spec.rows,
            spacing_mm=spec.spacing_mm,
        )
        options: dict[str, Any] = {"noise": noise, "seed": seed}
        truth = calibration_rig(boards[0], **options).stereo_calibration()
        with progress_bar() as prog:
            task = prog.add_task("simulating board poses", total=len(boards))
            if save_poses is not None:
                from hdrfringe.tasks.calibrate_stereo import write_board_pose_folders

                folders = write_board_pose_folders(save_poses, boards, force=force, **options)
                captures = read_pose_folders(folders)
                names = [str(f) for f in folders]
            else:
                captures = capture_board_poses(
                    boards, progress=lambda: prog.advance(task), **options
                )
                names = [f"pose_{k:02d}" for k in range(len(boards))]
    sizes = {c.image_shape for c in captures}
    if len(sizes) > 1:
        raise InputError(f"pose folders have different image sizes {sorted(sizes)}; use one camera")
    projectors = {(c.projector.width, c.projector.height) for c in captures if c.projector}
    if len(projectors) != 1:
        raise InputError("pose folders must record one projector size (manifest 'projector' entry)")
    h, w = captures[0].image_shape
    observed = [
        observe_pose(c, spec, name=n, half_window=window, min_valid_fraction=min_valid)
        for c, n in zip(captures, names, strict=True)
    ]
    if not any(p.camera_points is not None for p in observed):
        raise InputError(
            f"board {spec} not found in any of the {len(observed)} poses; check --board "
            "(COLSxROWS counts inner corners for a checkerboard) and the white frames"
        )
    result = calibrate_stereo(
        observed,
        spec,
        (w, h),
        projectors.pop(),
        distortion=distortion,
        refine_intrinsics=not fix_intrinsics,
        source=f"hdrfringe calibrate-stereo {spec}",
    )
    report: dict[str, Any] = result.to_dict()
    if truth is not None:
        report["virtual_rig_truth"] = truth.to_dict()
        report["errors_vs_truth"] = _truth_errors(result.calibration, truth)
    _print_report(result)
    if truth is not None:
        errs = report["errors_vs_truth"]
        console.print(
            "against the virtual rig's true geometry: "
            + ", ".join(f"{k} {v:.3g}" for k, v in errs.items()),
            highlight=False,
        )
    out, rep = write_calibration_and_report(output, result.calibration, report, force=force)
    console.print(f"wrote {out} and {rep}")
