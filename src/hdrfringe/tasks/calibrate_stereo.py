"""``hdrfringe calibrate-stereo``: pose folders in, the calibration and its report out.

- :func:`calibrate_stereo`: the command's work (board poses, a conversion, or the virtual
  rig's poses; the outputs checked first).

- :func:`read_pose_folders`: one capture folder per board pose (docs/capture_format.md), read
  with :func:`hdrfringe.io.captures.read_capture_folder`.
- :func:`write_calibration_and_report`: the stereo calibration (HDF5,
  :func:`hdrfringe.io.stereo_file.save_stereo_calibration`) and the report as JSON beside it
  (``STEREO_report.json`` for ``STEREO.h5``); both targets are checked before anything is
  written, and a failure of the second write removes the first (no partial output).
- :func:`write_board_pose_folders`: simulated pose folders of the virtual rig, staged (all or
  nothing) by :func:`hdrfringe.tasks.simulate.write_simulation`.

Examples
--------
>>> report_path("out/stereo.h5").as_posix()
'out/stereo_report.json'
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hdrfringe.core import strict_json
from hdrfringe.core.captures import Captures
from hdrfringe.core.stereo import StereoCalibration
from hdrfringe.errors import InputError, OutputExistsError
from hdrfringe.io.captures import (
    DECODE_BYTES_PER_PIXEL,
    check_folders_memory,
    read_capture_folder,
)
from hdrfringe.rig.board_poses import board_program, calibration_rig
from hdrfringe.rig.scenes import CalibrationBoard
from hdrfringe.tasks._progress import Progress, quiet

__all__ = [
    "CalibrateStereoReport",
    "calibrate_stereo",
    "check_calibration_outputs",
    "read_pose_folders",
    "report_path",
    "write_board_pose_folders",
    "write_calibration_and_report",
]


def report_path(path: str | Path) -> Path:
    """The JSON report's path beside a calibration file: ``<stem>_report.json``.

    Parameters
    ----------
    path : str or Path
        The calibration file.

    Returns
    -------
    Path

    Examples
    --------
    >>> report_path("/data/rig/stereo.h5").name
    'stereo_report.json'
    """
    out = Path(path)
    return out.with_name(f"{out.stem}_report.json")


def read_pose_folders(folders: Sequence[str | Path]) -> list[Captures]:
    """Read one capture folder per board pose.

    Parameters
    ----------
    folders : sequence of path
        The pose folders, each a capture folder.

    Returns
    -------
    list of Captures
        In the given order; each named after its folder.

    Raises
    ------
    InputError
        A folder given twice.
    CaptureFormatError
        A folder that is not a valid capture folder.

    Examples
    --------
    >>> read_pose_folders(["a", "./a"])
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: pose folder ./a is given twice; give each pose once
    """
    seen: set[Path] = set()
    for f in folders:
        key = Path(f).resolve()
        if key in seen:
            raise InputError(f"pose folder {f} is given twice; give each pose once")
        seen.add(key)
    # the poses are held together: their images, one pose's decoding and two phase maps each
    check_folders_memory(folders, kept_bytes_per_pixel=16)
    out = []
    for f in folders:
        caps = read_capture_folder(f, work_bytes_per_pixel=DECODE_BYTES_PER_PIXEL)
        out.append(caps)
    return out


def check_calibration_outputs(path: str | Path, force: bool) -> tuple[Path, Path]:
    """Refuse, before any work, targets that exist (without ``force``) or cannot be written.

    Parameters
    ----------
    path : str or Path
        The calibration file to write.
    force : bool
        Allow replacing existing files.

    Returns
    -------
    tuple of Path
        The calibration file and its report.

    Raises
    ------
    OutputExistsError
        A target exists (without ``force``) or is a folder.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     paths = check_calibration_outputs(Path(tmp) / "stereo.h5", force=False)
    >>> [p.name for p in paths]
    ['stereo.h5', 'stereo_report.json']
    """
    from hdrfringe.io.results import check_writable

    out = Path(path)
    rep = report_path(out)
    for p, what in ((out, "calibration file"), (rep, "report")):
        if p.is_dir():
            raise OutputExistsError(f"{p}: is a folder; give a file path for the {what}")
        if p.exists() and not force:
            raise OutputExistsError(
                f"{p}: {what} exists; pass --force to replace it or choose another path"
            )
    check_writable(out)
    return out, rep


def write_calibration_and_report(
    path: str | Path,
    calibration: StereoCalibration,
    report: Mapping[str, Any],
    *,
    force: bool = False,
) -> tuple[Path, Path]:
    """Write the stereo calibration (HDF5) and its JSON report beside it, all or nothing.

    Parameters
    ----------
    path : str or Path
        The calibration file (``.h5``).
    calibration : StereoCalibration
        What to store.
    report : mapping
        JSON-friendly report (also recorded as the file's provenance).
    force : bool
        Replace existing files.

    Returns
    -------
    tuple of Path
        The calibration file and the report.

    Raises
    ------
    OutputExistsError
        A target exists (without ``force``).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.rig.simulated import RigGeometry
    >>> calib = RigGeometry().stereo_calibration((648, 494), (1024, 768))
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     out, rep = write_calibration_and_report(Path(tmp) / "s.h5", calib, {"note": "doc"})
    ...     text = rep.read_text()
    >>> out.name, rep.name, strict_json.loads_strict(text)
    ('s.h5', 's_report.json', {'note': 'doc'})
    """
    from hdrfringe.io.results import current_umask
    from hdrfringe.io.stereo_file import save_stereo_calibration

    out, rep = check_calibration_outputs(path, force)
    out.parent.mkdir(parents=True, exist_ok=True)
    text = strict_json.dumps(report, indent=2) + "\n"
    fd, tmp_name = tempfile.mkstemp(prefix=f".{rep.name}.", suffix=".tmp", dir=rep.parent)
    tmp = Path(tmp_name)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~current_umask())
        save_stereo_calibration(out, calibration, force=force, provenance={"report": text})
        try:
            if force:
                os.replace(tmp, rep)
            else:
                os.link(tmp, rep)
        except OSError as exc:
            with contextlib.suppress(OSError):
                out.unlink()
            raise OutputExistsError(f"{rep}: cannot write the report ({exc.strerror})") from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()
    return out, rep


def write_board_pose_folders(
    path: str | Path,
    boards: Sequence[CalibrationBoard],
    *,
    force: bool = False,
    progress: Callable[[], Any] | None = None,
    **rig_options: Any,
) -> list[Path]:
    """Simulate the board poses on the virtual calibration rig into capture folders.

    ``path/pose_00``, ``path/pose_01``, ...: each the :func:`board_program` of
    :func:`calibration_rig` at one pose, with the board scene (its pose: the truth) in the
    manifest. Staged: all folders or none.

    Parameters
    ----------
    path : str or Path
        Output folder (refused when not empty, unless ``force``).
    boards : sequence of CalibrationBoard
        The poses.
    force : bool
        Replace an existing non-empty folder.
    progress : callable, optional
        Called once per captured frame.
    **rig_options
        Keyword arguments of :func:`calibration_rig`.

    Returns
    -------
    list of Path
        The pose folders, in order.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.rig.board_poses import default_board_poses
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     folders = write_board_pose_folders(Path(tmp) / "poses", default_board_poses(1),
    ...                                        camera_size=(64, 48))
    ...     names = [f.name for f in folders]
    ...     files = len(list(folders[0].iterdir()))
    >>> names, files
    (['pose_00'], 27)
    """
    from hdrfringe.tasks.simulate import write_simulation

    rigs = [calibration_rig(b, **rig_options) for b in boards]
    names = [f"pose_{k:02d}" for k in range(len(rigs))]
    frames = board_program(rigs[0].projector)
    done = write_simulation(path, rigs, frames, folder_names=names, force=force, progress=progress)
    return [done.path / n for n in names]


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


@dataclass(frozen=True)
class CalibrateStereoReport:
    """What ``calibrate-stereo`` wrote.

    Parameters
    ----------
    calibration_file, report_file : Path
        The files written.
    calibration : StereoCalibration
        The calibration.
    result : StereoCalibrationResult or None
        The calibration from board poses (per-pose errors, flagged poses); None for a
        conversion.
    errors_vs_truth : dict or None
        The virtual rig's errors against its true geometry (``rig="sim"`` only).
    converted_from : Path or None
        The file converted (a conversion only).

    Examples
    --------
    >>> import dataclasses
    >>> [f.name for f in dataclasses.fields(CalibrateStereoReport)][:3]
    ['calibration_file', 'report_file', 'calibration']
    """

    calibration_file: Path
    report_file: Path
    calibration: StereoCalibration
    result: Any = None
    errors_vs_truth: dict[str, float] | None = None
    converted_from: Path | None = None


def calibrate_stereo(
    output: Path,
    poses: Sequence[Path] = (),
    *,
    board: str | None = None,
    from_path: Path | None = None,
    rig: str | None = None,
    pose_count: int = 10,
    save_poses: Path | None = None,
    noise: float = 1.0,
    seed: int = 0,
    window: int = 12,
    min_valid: float | None = None,
    distortion: str = "standard",
    fix_intrinsics: bool = False,
    camera_size: tuple[int, int] | None = None,
    projector_size: tuple[int, int] | None = None,
    force: bool = False,
    progress: Progress = quiet,
) -> CalibrateStereoReport:
    """Calibrate the projector and camera from board poses, or convert another calibration.

    Exactly one source: ``poses`` (capture folders, one per board pose), ``from_path`` (a
    conversion) or ``rig="sim"`` (the virtual calibration rig, its errors against the true
    geometry reported). Both outputs (the calibration and ``<stem>_report.json``) are checked
    before any work and written all or nothing.

    Parameters
    ----------
    output : Path
        The calibration file (``.h5``).
    poses : sequence of Path
        Pose folders.
    board : str, optional
        ``PATTERN:COLSxROWS:SPACING_MM`` (required unless converting).
    from_path : Path, optional
        A calibration to convert (OpenCV YAML/XML, ``.npz``, a data set's folder, ``.h5``).
    rig : str, optional
        ``"sim"``: calibrate on the virtual rig.
    pose_count : int
        Board poses of the virtual rig.
    save_poses : Path, optional
        Also write the virtual rig's pose folders here.
    noise : float
        Virtual camera read noise sigma (8-bit gray levels).
    seed : int
        Noise seed.
    window : int
        Local homography window half side, camera px.
    min_valid : float, optional
        Least fraction of a window's pixels with projector coordinates.
    distortion : str
        Lens distortion terms (:data:`~hdrfringe.core.stereo_calibration.DISTORTION_MODELS`).
    fix_intrinsics : bool
        Keep the separate intrinsics in the stereo step.
    camera_size, projector_size : tuple of int, optional
        ``(width, height)`` for a converted file that records none; with ``rig="sim"``
        ``camera_size`` is the virtual camera's (default 640 x 480).
    force : bool
        Replace existing files.
    progress : callable
        The virtual rig's poses, as one stage.

    Returns
    -------
    CalibrateStereoReport

    Examples
    --------
    >>> calibrate_stereo(Path("stereo.h5"))
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: give exactly one source: POSE folders, --from PATH ...
    """
    from hdrfringe.core.stereo_calibration import DISTORTION_MODELS, MIN_POSES
    from hdrfringe.io.results import check_output_against_inputs

    poses = list(poses)
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
    inputs: list[Path | None] = [*poses, from_path, save_poses]
    check_output_against_inputs(output, inputs)
    check_calibration_outputs(output, force)

    if from_path is not None:
        from hdrfringe.io.stereo_file import convert_calibration

        calib = convert_calibration(
            from_path, camera_size=camera_size, projector_size=projector_size
        )
        converted = {"converted_from": str(from_path), "calibration": calib.to_dict()}
        out, rep = write_calibration_and_report(output, calib, converted, force=force)
        return CalibrateStereoReport(out, rep, calib, converted_from=from_path)

    if board is None:
        raise InputError("--board is required: e.g. --board checkerboard:9x6:25")
    from hdrfringe.core.stereo_calibration import BoardSpec, observe_pose
    from hdrfringe.core.stereo_calibration import calibrate_stereo as fit_stereo

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
        from hdrfringe.rig.board_poses import capture_board_poses, default_board_poses

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
        if camera_size is not None:  # the virtual camera's size (default 640 x 480)
            options["camera_size"] = camera_size
        truth = calibration_rig(boards[0], **options).stereo_calibration()
        with progress("simulating board poses", len(boards)) as advance:
            if save_poses is not None:
                folders = write_board_pose_folders(save_poses, boards, force=force, **options)
                captures = read_pose_folders(folders)
                names = [str(f) for f in folders]
            else:
                captures = capture_board_poses(boards, progress=advance, **options)
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
    result = fit_stereo(
        observed,
        spec,
        (w, h),
        projectors.pop(),
        distortion=distortion,
        refine_intrinsics=not fix_intrinsics,
        source=f"hdrfringe calibrate-stereo {spec}",
    )
    report: dict[str, Any] = result.to_dict()
    errors = None
    if truth is not None:
        errors = _truth_errors(result.calibration, truth)
        report["virtual_rig_truth"] = truth.to_dict()
        report["errors_vs_truth"] = errors
    out, rep = write_calibration_and_report(output, result.calibration, report, force=force)
    return CalibrateStereoReport(out, rep, result.calibration, result, errors)
