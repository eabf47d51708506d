"""Pattern folders: the PNGs a projector program plays, with a manifest in play order.

The manifest has the same frame entries as a capture manifest (``format``
``"hdrfringe-patterns"``), so a capture program can copy it, add ``camera`` and the captured
files, and produce a capture folder. Frames with 2-D data (per-pixel fringes, projector images)
make it version 2: their side files are written beside the rendered PNGs, under ``projector/``,
exactly as a capture folder holds them (docs/capture_format.md). Gray-code frames and fringe
sets with shift angles or a phase offset make it version 3; ``hdrfringe patterns`` plays none
of those (it has no option for them), but this writer takes any frames, and such a folder
reads back through ``hdrfringe import`` (tests/test_pattern_folder_v3.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.core import strict_json
from hdrfringe.core.captures import ProjectorInfo, frames_format_version
from hdrfringe.core.frames import Frame, render_frame
from hdrfringe.io.captures import write_side_files
from hdrfringe.io.results import staged_output_dir

__all__ = ["PATTERN_FORMAT", "write_pattern_folder"]

#: The pattern manifest's ``format`` field.
PATTERN_FORMAT = "hdrfringe-patterns"


def write_pattern_folder(
    path: str | Path,
    frames: Sequence[Frame],
    projector: ProjectorInfo,
    *,
    force: bool = False,
    progress: Any = None,
) -> dict[str, Any]:
    """Render every frame for the projector and write PNGs plus ``manifest.json``.

    Each frame's ``file`` is the rendered projector image (gamma pre-compensated, at the
    projector's bit depth), ``NNN_<stem>.png`` in play order. The manifest is of the lowest
    version that describes the frames (:func:`hdrfringe.core.captures.frames_format_version`: 1
    unless a frame has 2-D data, 2 then, 3 for shift angles, a phase offset or Gray-code
    frames); with 2-D data each
    such entry also names its side file (the MIGL map or the linear image), written once per
    distinct content (:func:`hdrfringe.io.captures.write_side_files`).

    Parameters
    ----------
    path : str or Path
        Output folder (refused if it exists and is not empty, unless ``force``).
    frames : sequence of Frame
        In play order.
    projector : ProjectorInfo
        Resolution, bit depth and gamma pre-compensation.
    force : bool
        Replace an existing non-empty folder.
    progress : callable, optional
        Called once per written frame (for progress bars).

    Returns
    -------
    dict
        The manifest written.

    Raises
    ------
    InputError
        A frame that does not fit the projector (e.g. a MIGL map of another size).

    Notes
    -----
    Gamma pre-compensation: thesis Eq. 2.17 (:func:`hdrfringe.core.frames.render_frame`).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.frames import PixelwiseFringeFrame
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> spec = FringeSpec(steps=3)
    >>> frames = [PixelwiseFringeFrame(spec, i, np.full((4, 8), 200.0)) for i in range(3)]
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     m = write_pattern_folder(Path(tmp) / "p", frames, ProjectorInfo(8, 4, 8))
    ...     files = [p.relative_to(Path(tmp) / "p").as_posix() for p in Path(tmp).rglob("*.*")]
    >>> m["version"], len(files), m["frames"][2]["migl_map"] in files  # 3 PNGs, 1 map
    (2, 5, True)
    """
    import imageio.v3 as iio

    frames = list(frames)
    names: list[str] = []
    for i, f in enumerate(frames):
        stem = f"{i:03d}_{f.default_name()}"
        names.append(f"{stem}.png")
    entries = [f.manifest_entry(n) for f, n in zip(frames, names, strict=True)]
    manifest: dict[str, Any] = {
        "format": PATTERN_FORMAT,
        "version": frames_format_version(frames),
        "projector": projector.to_manifest(),
        "frames": entries,
    }
    with staged_output_dir(path, force=force) as tmp:
        for f, name in zip(frames, names, strict=True):
            img = render_frame(
                f,
                projector.width,
                projector.height,
                projector.gamma_precompensation,
                projector.bit_depth,
            )
            iio.imwrite(tmp / name, np.asarray(img))
            if progress is not None:
                progress()
        write_side_files(tmp, frames, entries, projector)
        text = strict_json.dumps(manifest, nonfinite="error") + "\n"
        (tmp / "manifest.json").write_text(text, encoding="utf-8")
    return manifest
