"""Pattern folders: the PNGs a projector program plays, with a manifest in play order.

The manifest has the same frame entries as a capture manifest (``format``
``"hdrfringe-patterns"``), so a capture program can copy it, add ``camera`` and the captured
files, and produce a capture folder.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.captures import ProjectorInfo
from hdrfringe.frames import Frame, render_frame
from hdrfringe.io.results import staged_output_dir

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

    Parameters
    ----------
    path : str or Path
        Output folder (refused if it exists and is not empty, unless ``force``).
    frames : sequence of Frame
        In play order.
    projector : ProjectorInfo
        Resolution, bit depth and gamma pre-compensation.
    progress : callable, optional
        Called once per written frame (for progress bars).

    Returns
    -------
    dict
        The manifest written.
    """
    import imageio.v3 as iio

    names: list[str] = []
    for i, f in enumerate(frames):
        stem = f"{i:03d}_{f.default_name()}"
        names.append(f"{stem}.png")
    manifest: dict[str, Any] = {
        "format": PATTERN_FORMAT,
        "version": 1,
        "projector": projector.to_manifest(),
        "frames": [f.manifest_entry(n) for f, n in zip(frames, names, strict=True)],
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
        (tmp / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")
    return manifest
