"""Files of ``hdrfringe calibrate-stereo``: pose folders in, the calibration and its report out.

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
import json
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from hdrfringe.captures import Captures
from hdrfringe.errors import InputError, OutputExistsError
from hdrfringe.io.captures import read_capture_folder
from hdrfringe.rig.board_poses import board_program, calibration_rig
from hdrfringe.rig.scenes import CalibrationBoard
from hdrfringe.stereo import StereoCalibration

__all__ = [
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
    out = []
    for f in folders:
        caps = read_capture_folder(f)
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
    >>> out.name, rep.name, json.loads(text)
    ('s.h5', 's_report.json', {'note': 'doc'})
    """
    from hdrfringe.io.results import current_umask
    from hdrfringe.io.stereo_file import save_stereo_calibration

    out, rep = check_calibration_outputs(path, force)
    out.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(report, indent=2, allow_nan=False, default=_plain) + "\n"
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


def _plain(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON-serialisable: {type(value).__name__}")


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
