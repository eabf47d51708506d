"""Outputs of a measurement: height map and PLY, strategy maps and charts, DPA's CDF figure."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.io.results import write_map_tiff, write_preview_png
from hdrfringe.reconstruct import CameraGeometry, points_from_height, write_ply

if TYPE_CHECKING:
    from hdrfringe.measurement import DPACDFs
    from hdrfringe.saturation.dpa_rules import SaturationCDF
    from hdrfringe.strategies.base import StrategyResult


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


def _finest(results: list[StrategyResult]) -> StrategyResult:
    """The result of the finest pitch: its composite carries the measured phase."""
    return min(results, key=lambda r: r.spec.pitch_px)


def write_strategy_outputs(out: Path, results: list[StrategyResult]) -> dict[str, Any]:
    """MIGL index map, the pie chart of pixels per MIGL (thesis Fig. 5.6), metrics keys.

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
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fine = _finest(results)
    write_map_tiff(out / "migl_index.tiff", fine.migl_index)
    write_preview_png(
        out / "migl_index.png",
        fine.migl_index,
        title=f"MIGL index N(x, y), pitch {fine.spec.pitch_px:g} px",
        cmap="viridis",
        label="MIGL",
    )
    levels, counts = np.unique(fine.migl_index, return_counts=True)
    order = np.argsort(levels)[::-1]
    fig, ax = plt.subplots(figsize=(6, 6), dpi=100)
    labels = [f"{levels[i]:g}" if counts[i] / counts.sum() > 0.02 else "" for i in order]
    ax.pie(counts[order], labels=labels, startangle=90, counterclock=False)
    ax.set_title(f"pixels per MIGL ({fine.method}, pitch {fine.spec.pitch_px:g} px)")
    fig.savefig(out / "migl_pie.png")
    plt.close(fig)
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


def _cdf_curve(cdf: SaturationCDF, lo: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(MIGL, F(MIGL))`` for the integer MIGLs ``lo..migl0`` of a SaturationCDF."""
    ms = np.arange(lo, cdf.migl0 + 1)
    return ms.astype(np.float64), np.asarray(cdf.values[lo:], dtype=np.float64)


def _lowest_bin(cdf: SaturationCDF) -> int:
    """Lowest MIGL holding a pixel of the CDF (``migl0`` when it is empty)."""
    nz = np.flatnonzero(cdf.counts)
    return int(nz[0]) if nz.size else int(cdf.migl0)


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

    Each panel shows, over decreasing MIGL, the CDF estimated from the first set, the CDF after
    the last update, the actual CDF from the DPA index image over the pixels saturated at the
    top MIGL (quantised to the captured MIGLs, which are marked), and the exact actual CDF when
    a step-1 sweep gave one.

    Returns
    -------
    dict
        ``threshold``, ``correction`` and ``sets`` (one :func:`dpa_metrics` entry per pitch,
        coarsest first).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(all_cdfs)
    fig, axes = plt.subplots(1, n, figsize=(6.4 * n, 4.8), dpi=100, squeeze=False)
    for ax, c in zip(axes[0], all_cdfs, strict=True):
        title = f"{c.spec.label()}: DPA {100 * threshold:g} %"
        if c.initial is None:
            ax.text(
                0.5,
                0.5,
                f"no pixel saturated at MIGL {c.spec.migl:g}:\none set, no CDF",
                ha="center",
                va="center",
                transform=ax.transAxes,
            )
            ax.set_title(title, fontsize=10)
            ax.set_axis_off()
            continue
        assert c.final is not None and c.actual is not None  # set together with initial
        cands = [min(c.migls), _lowest_bin(c.initial), _lowest_bin(c.final)]
        lo = max(int(c.initial.lowest_migl), int(min(cands)) - 5)
        if c.exact is not None:
            x, y = _cdf_curve(c.exact, lo)
            ax.step(x, y, where="pre", color="black", lw=1.2, label="actual, exact (LPA step 1)")
        x, y = _cdf_curve(c.actual, lo)
        ax.step(
            x,
            y,
            where="pre",
            color="tab:green",
            lw=1.6,
            label=f"actual, DPA index image (quantised to the {len(c.migls)} captured MIGLs)",
        )
        at = [c.actual.at(m) for m in c.migls]
        ax.plot(c.migls, at, "o", color="tab:green", ms=4)
        x, y = _cdf_curve(c.initial, lo)
        ax.step(x, y, where="pre", color="tab:blue", ls="--", label="estimated, first set")
        x, y = _cdf_curve(c.final, lo)
        ax.step(x, y, where="pre", color="tab:orange", label="estimated, after last update")
        diff = c.max_abs_difference("actual") or 0.0
        ax.set_title(
            f"{title}; {c.saturated_at_top} px saturated at {c.spec.migl:g}\n"
            f"max |first estimate - actual| at captured MIGLs: {diff:.3f}",
            fontsize=10,
        )
        ax.set_xlim(c.initial.migl0 + 1, lo)  # the MIGL falls to the right (thesis Sec. 6.1.3)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("MIGL")
        ax.set_ylabel("fraction of the pixels saturated at the top MIGL")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    fig.savefig(out / "dpa_cdf.png")
    plt.close(fig)
    return {
        "threshold": float(threshold),
        "correction": correction,
        "sets": [dpa_metrics(c) for c in all_cdfs],
    }
