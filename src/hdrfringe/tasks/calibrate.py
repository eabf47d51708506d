"""``hdrfringe calibrate``: calibration from capture folders on disk: the folders are read,
then :func:`hdrfringe.pipeline.calibrate` fits; :func:`calibrate` checks the output first and
writes the file.

A folder without a ``manifest.json`` stands for the capture folders inside it
(:func:`expand_capture_dirs`), so ``hdrfringe calibrate plates`` takes the folder ``hdrfringe
simulate --series`` writes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from hdrfringe.core.calibration import Calibration
from hdrfringe.io.captures import (
    DECODE_BYTES_PER_PIXEL,
    check_folders_memory,
    read_capture_folder,
)
from hdrfringe.pipeline import calibrate as fit_calibration
from hdrfringe.tasks._progress import Progress, quiet

__all__ = ["calibrate", "calibrate_folders", "expand_capture_dirs"]


def expand_capture_dirs(paths: Sequence[str | Path]) -> list[Path]:
    """The capture folders among ``paths``; a folder without a manifest gives its sub-folders.

    A folder without ``manifest.json`` whose sub-folders hold none either is kept as it is (the
    reader then says what is missing).

    Parameters
    ----------
    paths : sequence of str or Path
        Capture folders, or folders of them.

    Returns
    -------
    list of Path
        In the order given; the sub-folders of a folder sorted by name.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> for name in ("b", "a"):
    ...     (root / name).mkdir()
    ...     _ = (root / name / "manifest.json").write_text("{}")
    >>> [p.name for p in expand_capture_dirs([root])]
    ['a', 'b']
    """
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir() and not (p / "manifest.json").exists():
            subs = sorted(d for d in p.iterdir() if (d / "manifest.json").is_file())
            if subs:
                out += subs
                continue
        out.append(p)
    return out


def calibrate_folders(
    paths: Sequence[str | Path],
    *,
    model: str = "linear",
    window_px: int = 21,
    border_px: int = 10,
    progress: Callable[[], object] | None = None,
) -> Calibration:
    """Calibrate from flat-plate capture folders (thesis Sec. 2.5, 4.1).

    Every folder (:func:`expand_capture_dirs`) is read first, so an unreadable one is refused
    before any decoding, and they are held together: their images, the decoding of one and a
    phase map of each must fit in the available memory
    (:func:`~hdrfringe.io.captures.check_folders_memory`, before any image is decoded); then
    :func:`hdrfringe.pipeline.calibrate` checks and fits.

    Parameters
    ----------
    paths : sequence of str or Path
        Capture folders at known ``scene.depth_mm`` (one at 0), or a folder of them.
    model : {"linear", "rational", "poly2", "poly3"}
        The phase-to-height model.
    window_px, border_px : int
        Filter window and unfiltered border (Sec. 4.1: 21 and 10).
    progress : callable, optional
        Called once per folder decoded.

    Returns
    -------
    Calibration
        Its provenance records each folder's path, depth and content hash.

    References
    ----------
    Thesis Sec. 2.5 (Eq. 2.10, 2.15) and Sec. 4.1.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.io.captures import write_capture_folder
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> frames = [f for p in (1024.0, 64.0) for f in FringeSpec("sinusoidal", 4, p).frames()]
    >>> root = Path(tempfile.mkdtemp())
    >>> for d in (0.0, 10.0, 20.0):
    ...     rig = SimulatedRig(white_plate(d), camera=CameraModel(width=81, height=62))
    ...     _ = write_capture_folder(root / f"plate_{d:02.0f}", rig.capture_folder(frames))
    >>> calibrate_folders([root]).depths_mm.tolist()
    [10.0, 20.0]
    """
    dirs = expand_capture_dirs(paths)
    check_folders_memory(dirs)  # all held at once: each fitting alone is not enough
    folders = [read_capture_folder(p, work_bytes_per_pixel=DECODE_BYTES_PER_PIXEL) for p in dirs]
    return fit_calibration(
        folders, model=model, window_px=window_px, border_px=border_px, progress=progress
    )


def calibrate(
    folders: Sequence[str | Path],
    output: Path,
    *,
    model: str = "linear",
    window: int = 21,
    border: int = 10,
    force: bool = False,
    progress: Progress = quiet,
) -> Calibration:
    """Per-pixel phase-to-height calibration from a plate at known depths, written to a file.

    The model and the output (not an input, not a folder, new or ``force``) are checked
    before any folder is decoded.

    Parameters
    ----------
    folders : sequence of path
        Flat-plate capture folders (``scene.depth_mm``; one at 0), or a folder of them.
    output : Path
        The calibration file (``.h5``).
    model : str
        :data:`hdrfringe.core.calibration.MODELS`.
    window : int
        Median and mean filter window, px.
    border : int
        Unfiltered border excluded from the metrics, px.
    force : bool
        Replace an existing file.
    progress : callable
        The folders' decoding, one unit per folder.

    Returns
    -------
    Calibration
        What was written.

    Examples
    --------
    >>> calibrate(["plates"], Path("cal.h5"), model="cubic")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: unknown model 'cubic'; use one of linear, rational, poly2, poly3
    """
    from hdrfringe.core.calibration import MODELS
    from hdrfringe.errors import InputError, OutputExistsError
    from hdrfringe.io.calibration_file import save_calibration
    from hdrfringe.io.results import check_output_against_inputs, check_output_file

    if model not in MODELS:
        raise InputError(f"unknown model {model!r}; use one of {', '.join(MODELS)}")
    check_output_against_inputs(output, folders)
    if output.is_dir():
        raise OutputExistsError(f"{output}: is a folder; give a file path for the calibration")
    if output.exists() and not force:
        raise OutputExistsError(f"{output}: exists; pass --force to replace it")
    output = check_output_file(output, force)  # what is there now: replaced only if unchanged
    n = len(expand_capture_dirs(folders))
    with progress("decoding plate positions", n) as advance:
        cal = calibrate_folders(
            folders, model=model, window_px=window, border_px=border, progress=advance
        )
    save_calibration(output, cal, force=force)
    return cal
