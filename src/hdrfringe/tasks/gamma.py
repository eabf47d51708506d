"""``hdrfringe gamma``: the projector's gamma fitted from a capture folder, the fits written."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hdrfringe.tasks._progress import Say, silent

__all__ = ["gamma"]


def gamma(
    folder: Path, output: Path | None = None, *, force: bool = False, say: Say = silent
) -> Any:
    """Fit the projector's gamma from a capture folder (:func:`hdrfringe.core.gamma.gamma_report`).

    The output, when given, is checked (not the input, new or empty, or ``force``) before the
    folder is read. The report's lines are said before the fits are checked, so that a folder
    that does not fit still shows what was found.

    Parameters
    ----------
    folder : Path
        The capture folder (uniform grays and/or pre-distorted fringe sets).
    output : Path, optional
        A folder for the fit files and plots.
    force : bool
        Replace an existing output folder.
    say : callable
        Called with each line of the report.

    Returns
    -------
    GammaReport

    Raises
    ------
    HdrFringeError
        Nothing in the folder to fit (after the lines are said).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.tasks.simulate import simulate
    >>> tmp = Path(tempfile.mkdtemp())
    >>> _ = simulate(tmp / "caps", "white_plate", rig_options={"resolution": (64, 48)},
    ...              pitches=[128.0], grays=list(range(0, 256, 32)))
    >>> report = gamma(tmp / "caps", tmp / "fits")
    >>> round(report.uniform_fit.gamma, 1), (tmp / "fits").is_dir()
    (2.8, True)
    """
    from hdrfringe.core.gamma import gamma_report
    from hdrfringe.io.captures import DECODE_BYTES_PER_PIXEL, read_capture_folder
    from hdrfringe.io.gamma_outputs import write_gamma_outputs
    from hdrfringe.io.results import check_output_against_inputs, check_output_dir

    if output is not None:
        check_output_against_inputs(output, [folder])
        output = check_output_dir(output, force)
    caps = read_capture_folder(folder, work_bytes_per_pixel=DECODE_BYTES_PER_PIXEL)
    report = gamma_report(caps, source=str(folder))
    for line in report.lines:
        say(line)
    report.check_fitted()
    if output is not None:
        write_gamma_outputs(output, report, force=force)
    return report
