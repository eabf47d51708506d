"""Height outputs of a measurement: height map, preview with colour bar, PLY point cloud."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from hdrfringe.io.results import write_map_tiff, write_preview_png
from hdrfringe.reconstruct import CameraGeometry, points_from_height, write_ply


def write_height_outputs(
    out: Path, height_mm: NDArray[np.float64], geometry: CameraGeometry | None
) -> list[str]:
    """Write ``height.tiff``, ``height.png`` and ``points.ply`` into ``out``; return notes.

    Without camera geometry in the calibration, x and y are in pixels (a note says so).
    """
    notes: list[str] = []
    write_map_tiff(out / "height.tiff", height_mm)
    write_preview_png(out / "height.png", height_mm, title="height", cmap="viridis", label="mm")
    if geometry is None:
        notes.append(
            "the calibration records no camera geometry (focal_px, standoff_mm): points.ply has "
            "x and y in pixels"
        )
        rows, cols = np.indices(height_mm.shape, dtype=np.float64)
        x, y, z = cols, -rows, height_mm
    else:
        x, y, z = points_from_height(height_mm, geometry)
    write_ply(out / "points.ply", x, y, z)
    return notes
