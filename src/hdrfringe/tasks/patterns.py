"""``hdrfringe patterns``: fringe, centerline and uniform frames as projector images."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from hdrfringe.tasks._progress import Progress, quiet

__all__ = ["PatternsReport", "patterns"]


@dataclass(frozen=True)
class PatternsReport:
    """What ``patterns`` wrote.

    Parameters
    ----------
    output : Path
        The pattern folder.
    images : int
        Pattern images written (besides ``manifest.json``).

    Examples
    --------
    >>> PatternsReport(Path("patterns"), 4).images
    4
    """

    output: Path
    images: int


def patterns(
    output: Path,
    *,
    pattern: str = "sinusoidal",
    steps: int = 3,
    pitches: Sequence[float] = (6.0,),
    orientation: str = "vertical",
    imin: float = 40.0,
    migl: float = 255.0,
    width: int = 1024,
    height: int = 768,
    bit_depth: int = 8,
    gamma: float = 2.812,
    centerline: bool = True,
    centerline_position: float | None = None,
    grays: Sequence[float] = (),
    force: bool = False,
    progress: Progress = quiet,
) -> PatternsReport:
    """Write a projector program as a pattern folder
    (:func:`hdrfringe.io.pattern_folder.write_pattern_folder`).

    Every level is checked against the projector before anything is written; the folder is
    staged (new or empty, or ``force``).

    Parameters
    ----------
    output : Path
        The pattern folder.
    pattern, steps, pitches, orientation, imin, migl, centerline, centerline_position, grays
        The program (:func:`hdrfringe.core.programs.fringe_program`; the centerline at ``migl``).
    width, height, bit_depth, gamma
        The projector.
    force : bool
        Replace an existing output folder.
    progress : callable
        The images written, one unit each.

    Returns
    -------
    PatternsReport

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp()) / "patterns"
    >>> patterns(out, pitches=[8.0], width=64, height=48).images
    4
    """
    from hdrfringe.core.captures import ProjectorInfo
    from hdrfringe.core.programs import check_projector_size, fringe_program
    from hdrfringe.io.pattern_folder import write_pattern_folder

    projector = check_projector_size(ProjectorInfo(width, height, bit_depth, gamma))
    frames = fringe_program(  # every level checked against the projector before writing
        pattern,
        steps,
        list(pitches),
        [orientation],
        imin,
        [migl],
        projector=projector,
        centerline=centerline,
        centerline_position=centerline_position,
        centerline_level=migl,
        grays=grays,
    )
    with progress("writing patterns", len(frames)) as advance:
        write_pattern_folder(output, frames, projector, force=force, progress=advance)
    return PatternsReport(output, len(frames))
