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


def write_strategy_outputs(out: Path, results: list) -> dict:
    """MIGL index map(s), the pie chart of pixels per MIGL (thesis Fig. 5.6), metrics keys.

    Returns ``method``, ``sets_captured``, ``images_captured``, ``migls`` (capture order) and
    ``never_unsaturated_fraction`` for metrics.json (summed over the pitches of the family).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    first = results[0]
    write_map_tiff(out / "migl_index.tiff", first.migl_index)
    write_preview_png(
        out / "migl_index.png",
        first.migl_index,
        title="MIGL index N(x, y)",
        cmap="viridis",
        label="MIGL",
    )
    levels, counts = np.unique(first.migl_index, return_counts=True)
    order = np.argsort(levels)[::-1]
    fig, ax = plt.subplots(figsize=(6, 6), dpi=100)
    labels = [f"{levels[i]:g}" if counts[i] / counts.sum() > 0.02 else "" for i in order]
    ax.pie(counts[order], labels=labels, startangle=90, counterclock=False)
    ax.set_title(f"pixels per MIGL ({first.method})")
    fig.savefig(out / "migl_pie.png")
    plt.close(fig)
    return {
        "method": first.method,
        "sets_captured": int(sum(r.sets_captured for r in results)),
        "images_captured": int(sum(r.images_captured for r in results)),
        "migls": [list(map(float, r.migls)) for r in results]
        if len(results) > 1
        else list(map(float, first.migls)),
        "never_unsaturated_fraction": float(first.never_unsaturated.mean()),
    }
