"""Outputs of a measurement: height map and PLY, strategy maps and charts, DPA's CDFs.

Writers of a result folder's files (the ``measure`` command and the demo call them); the
figures are drawn by :mod:`hdrfringe.io.plots`, the point cloud by
:mod:`hdrfringe.io.point_cloud`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.io.plots import plot_dpa_cdfs, plot_migl_pie
from hdrfringe.io.point_cloud import write_ply
from hdrfringe.io.results import write_map_tiff, write_preview_png
from hdrfringe.reconstruct import CameraGeometry, points_from_height

if TYPE_CHECKING:
    from hdrfringe.measurement import DPACDFs
    from hdrfringe.strategies.base import StrategyResult

__all__ = ["dpa_metrics", "write_dpa_outputs", "write_height_outputs", "write_strategy_outputs"]


def write_height_outputs(
    out: Path, height_mm: NDArray[np.float64], geometry: CameraGeometry | None
) -> list[str]:
    """Write ``height.tiff``, ``height.png`` and ``points.ply`` into ``out``; return notes.

    Parameters
    ----------
    out : Path
        Output folder (e.g. the staging folder of ``measure``).
    height_mm : ndarray, shape (H, W)
        Height map in mm (NaN = invalid; invalid pixels are not in the point cloud).
    geometry : CameraGeometry or None
        Camera geometry of the calibration, for x and y in mm. None: x and y are in pixels
        (column, minus row) and a note says so.

    Returns
    -------
    list of str
        Notes for the report (empty when nothing needs saying).

    References
    ----------
    Thesis Sec. 2.4, Eq. 2.11 (the height map).

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp())
    >>> notes = write_height_outputs(out, np.zeros((4, 5)), None)
    >>> sorted(p.name for p in out.iterdir()), len(notes)
    (['height.png', 'height.tiff', 'points.ply'], 1)
    """
    notes: list[str] = []
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    z: NDArray[np.float64]
    write_map_tiff(out / "height.tiff", height_mm)
    write_preview_png(out / "height.png", height_mm, title="height", cmap="viridis", label="mm")
    if geometry is None:
        notes.append(
            "the calibration records no camera geometry (focal_px, standoff_mm): points.ply has "
            "x and y in pixels"
        )
        rows_cols = np.indices(height_mm.shape, dtype=np.float64)
        x, y, z = rows_cols[1], -rows_cols[0], height_mm
    else:
        x, y, z = points_from_height(height_mm, geometry)
    write_ply(out / "points.ply", x, y, z)
    return notes


def _finest(results: list[StrategyResult]) -> StrategyResult:
    """The result of the finest pitch: its composite carries the measured phase."""
    return min(results, key=lambda r: r.spec.pitch_px)


def write_strategy_outputs(out: Path, results: list[StrategyResult]) -> dict[str, Any]:
    """MIGL index map, the pie chart of pixels per MIGL (thesis Fig. 5.6), metrics keys.

    Writes ``migl_index.tiff``, ``migl_index.png`` and ``migl_pie.png``
    (:func:`~hdrfringe.io.plots.plot_migl_pie`).

    Parameters
    ----------
    out : Path
        Output folder (staging folder of ``measure``).
    results : list of StrategyResult
        One per pitch of the measured family. The index map and pie chart are those of the
        finest pitch, whose phase the height comes from (the coarser sets only unwrap it).

    Returns
    -------
    dict
        ``method``, ``sets_captured`` and ``images_captured`` (summed over the pitches),
        ``migls`` (capture order; one list per pitch, coarsest first, when there are several)
        and ``never_unsaturated_fraction`` (finest pitch) for metrics.json.

    References
    ----------
    Thesis Sec. 5.1 (the LPA composite and its MIGL index) and Fig. 5.6.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.patterns import FringeSpec
    >>> from hdrfringe.strategies.base import CapturedSet, StrategyResult
    >>> index = np.array([[255, 240], [255, 225]], dtype=np.float32)
    >>> res = StrategyResult(
    ...     images=np.zeros((4, 2, 2), np.uint8),
    ...     spec=FringeSpec("sinusoidal", 4, 8.0),
    ...     captured=[CapturedSet(migl=m) for m in (255.0, 240.0, 225.0)],
    ...     index_map=index,
    ...     newly_unsaturated=[2, 1, 1],
    ...     never_unsaturated=np.zeros((2, 2), bool),
    ...     method="lpa",
    ... )
    >>> keys = write_strategy_outputs(Path(tempfile.mkdtemp()), [res])
    >>> keys["images_captured"], keys["migls"]
    (12, [255.0, 240.0, 225.0])
    """
    fine = _finest(results)
    write_map_tiff(out / "migl_index.tiff", fine.migl_index)
    write_preview_png(
        out / "migl_index.png",
        fine.migl_index,
        title=f"MIGL index N(x, y), pitch {fine.spec.pitch_px:g} px",
        cmap="viridis",
        label="MIGL",
    )
    plot_migl_pie(
        out / "migl_pie.png",
        fine.migl_index,
        title=f"pixels per MIGL ({fine.method}, pitch {fine.spec.pitch_px:g} px)",
    )
    return {
        "method": fine.method,
        "sets_captured": int(sum(r.sets_captured for r in results)),
        "images_captured": int(sum(r.images_captured for r in results)),
        "migls": [list(map(float, r.migls)) for r in results]
        if len(results) > 1
        else list(map(float, fine.migls)),
        "never_unsaturated_fraction": float(fine.never_unsaturated.mean()),
    }


def dpa_metrics(cdfs: DPACDFs) -> dict[str, Any]:
    """The metrics.json entry of one DPA set: rules and CDFs at each captured MIGL.

    Parameters
    ----------
    cdfs : DPACDFs
        From :func:`hdrfringe.measurement.dpa_cdfs`.

    Returns
    -------
    dict
        ``set``, ``pitch_px``, ``saturated_at_top``, ``rules``, ``captures`` and, when a pixel
        saturated at the top, ``lowest_migl``, ``estimable_at_top`` and the differences below.

    Notes
    -----
    ``captures`` lists, in capture order, the MIGL, the rule that asked for it, and the CDF
    there: estimated from the first set (``estimated_initial``), after the last update
    (``estimated_final``), actual from the DPA index image (``actual``, quantised to the captured
    MIGLs) and, for a full step-1 sweep, exact from LPA with step 1 (``actual_exact``).
    ``estimable_at_top`` is the fraction of the saturated pixels the first set could estimate
    (the rest, more saturated shifts than the estimate handles, join the CDF only through its
    updates); ``max_abs_difference_initial_vs_actual`` is the largest ``|initial - actual|``
    over the captured MIGLs; ``max_abs_difference_initial_vs_exact`` the same against the exact
    CDF over every integer MIGL down to DPA's lowest capture.

    References
    ----------
    Thesis Sec. 6.1.3 (the CDF of the saturated intensities) and Fig. 6.3.

    Examples
    --------
    >>> from hdrfringe.measurement import DPACDFs
    >>> from hdrfringe.patterns import FringeSpec
    >>> nothing = DPACDFs(FringeSpec("sinusoidal", 4, 8.0), [255.0], ["initial"], 0)
    >>> entry = dpa_metrics(nothing)  # no pixel saturated at the top: one set, no CDF
    >>> entry["set"], entry["captures"]
    ('s4_p8_v_i40_g255', [{'migl': 255.0, 'rule': 'initial'}])
    """
    entry: dict[str, Any] = {
        "set": cdfs.spec.label(),
        "pitch_px": float(cdfs.spec.pitch_px),
        "saturated_at_top": cdfs.saturated_at_top,
        "rules": list(cdfs.rules),
    }
    captures = []
    for m, rule in zip(cdfs.migls, cdfs.rules, strict=True):
        row: dict[str, Any] = {"migl": float(m), "rule": rule}
        for key, cdf in (
            ("estimated_initial", cdfs.initial),
            ("estimated_final", cdfs.final),
            ("actual", cdfs.actual),
            ("actual_exact", cdfs.exact),
        ):
            if cdf is not None:
                row[key] = round(cdf.at(m), 6)
        captures.append(row)
    entry["captures"] = captures
    if cdfs.initial is not None:
        ini = cdfs.initial
        entry["lowest_migl"] = int(ini.lowest_migl)
        entry["estimable_at_top"] = (ini.accounted + ini.beyond) / ini.total if ini.total else 1.0
        entry["max_abs_difference_initial_vs_actual"] = cdfs.max_abs_difference("actual")
        entry["actual_is"] = "DPA index image, quantised to the captured MIGLs"
    if cdfs.exact is not None:
        entry["max_abs_difference_initial_vs_exact"] = cdfs.max_abs_difference("exact")
        entry["actual_exact_is"] = "LPA with step 1 on the replayed sweep"
    return entry


def write_dpa_outputs(
    out: Path, all_cdfs: list[DPACDFs], *, threshold: float, correction: str
) -> dict[str, Any]:
    """``dpa_cdf.png`` (thesis Fig. 6.3, one panel per pitch) and the metrics ``dpa`` block.

    Parameters
    ----------
    out : Path
        Output folder.
    all_cdfs : list of DPACDFs
        One per pitch, coarsest first (:func:`hdrfringe.measurement.dpa_cdfs`).
    threshold : float
        DPA's threshold (a fraction), for the titles and the block.
    correction : str
        What correction DPA used (a file name or ``"none (identity)"``).

    Returns
    -------
    dict
        ``threshold``, ``correction`` and ``sets`` (one :func:`dpa_metrics` entry per pitch,
        coarsest first).

    Notes
    -----
    The figure is :func:`~hdrfringe.io.plots.plot_dpa_cdfs`.

    References
    ----------
    Thesis Sec. 6.1.3 and Fig. 6.3.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.measurement import DPACDFs
    >>> from hdrfringe.patterns import FringeSpec
    >>> nothing = DPACDFs(FringeSpec("sinusoidal", 4, 8.0), [255.0], ["initial"], 0)
    >>> out = Path(tempfile.mkdtemp())
    >>> block = write_dpa_outputs(out, [nothing], threshold=0.1, correction="none (identity)")
    >>> block["threshold"], len(block["sets"]), (out / "dpa_cdf.png").is_file()
    (0.1, 1, True)
    """
    plot_dpa_cdfs(out / "dpa_cdf.png", all_cdfs, threshold=threshold)
    return {
        "threshold": float(threshold),
        "correction": correction,
        "sets": [dpa_metrics(c) for c in all_cdfs],
    }
