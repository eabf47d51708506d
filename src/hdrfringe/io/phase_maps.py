"""Writing the phase stage's maps into a result folder (names in docs/phase.md)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hdrfringe.core import strict_json
from hdrfringe.core.decode import FamilyResult, FolderPhase
from hdrfringe.core.phase import PhaseResult
from hdrfringe.core.saturation.tolerant import TolerantPhaseResult
from hdrfringe.io._colormaps import LABEL_COLOURS, LABEL_LUT, label_colour_index
from hdrfringe.io.results import MAP_COMPRESSION, write_map_tiff, write_preview_png

if TYPE_CHECKING:
    from hdrfringe.core.uncertainty import Uncertainty

__all__ = ["SET_MAPS", "write_phase_maps"]

#: (file stem, attribute of PhaseResult, colour map, unit label)
SET_MAPS: tuple[tuple[str, str, str, str], ...] = (
    ("wrapped_phase", "wrapped_phase", "twilight", "rad"),
    ("modulation", "modulation", "magma", "DN"),
    ("mean_intensity", "mean_intensity", "gray", "DN"),
    ("data_modulation", "data_modulation", "viridis", "I'/I''"),
    ("saturation_count", "saturation_count", "inferno", "saturated shifts"),
)


#: A file write deferred to the writer threads (:func:`_run_writes`).
Job = Callable[[], None]


def _run_writes(jobs: list[Job]) -> None:
    """Run the file writes on a few threads; the first failure is raised once all have ended.

    tifffile's writes and Pillow's PNG encoder release the GIL (and so do numpy's conversions
    to float32 before a write), so two threads keep two cores or a disk busy: at 12 Mpx the
    maps and previews of ``phase`` took about half the time written one after the other
    (benchmarks/README.md, "Real camera sizes"). Threads, not processes: the maps are shared,
    not copied. At most :func:`hdrfringe.core._blockdecode.decode_threads` threads (the CPUs, or
    ``HDRFRINGE_DECODE_THREADS``).
    """
    from hdrfringe.core._blockdecode import decode_threads

    threads = decode_threads(len(jobs))
    if threads <= 1:
        for job in jobs:
            job()
        return
    with ThreadPoolExecutor(max_workers=threads, thread_name_prefix="hdrfringe-write") as pool:
        for future in [pool.submit(job) for job in jobs]:
            future.result()


def _tiff(jobs: list[Job], files: list[str], path: Path, data: Any) -> None:
    """A float32 map (:func:`~hdrfringe.io.results.write_map_tiff`), queued, and its name."""
    jobs.append(partial(write_map_tiff, path, data))
    files.append(path.name)


def _preview(
    files: list[str] | None, path: Path, data: Any, jobs: list[Job] | None = None, **kw: Any
) -> None:
    """A map's PNG preview (queued on ``jobs``, else written now), and its name in ``files``;
    ``files`` None: previews are off (nothing)."""
    if files is not None:
        if jobs is None:
            write_preview_png(path, data, **kw)
        else:
            jobs.append(partial(write_preview_png, path, data, **kw))
        files.append(path.name)


def _write_set(
    out: Path,
    res: PhaseResult,
    suffix: str,
    files: list[str],
    jobs: list[Job],
    *,
    previews: bool = True,
    phase_std: Mapping[str, np.ndarray] | None = None,
    label: str = "",
) -> None:
    shown = files if previews else None
    for stem, attr, cmap, unit in SET_MAPS:
        data = getattr(res, attr)
        name = f"{stem}{suffix}"
        _tiff(jobs, files, out / f"{name}.tiff", data)
        kw: dict[str, Any] = {}
        if stem == "wrapped_phase":
            kw = {"vmin": 0.0, "vmax": 2 * np.pi}
        elif stem == "saturation_count":
            kw = {"vmin": 0.0, "vmax": float(max(1, res.spec.steps if res.spec else 1))}
        _preview(shown, out / f"{name}.png", data, jobs, title=name, cmap=cmap, label=unit, **kw)
    if isinstance(res, TolerantPhaseResult):  # --saturated exclude: the shifts each fit used
        name = f"shifts_used{suffix}"
        used = res.shifts_used.astype(np.float32)
        _tiff(jobs, files, out / f"{name}.tiff", used)
        images = (2 if res.inverted else 1) * (res.spec.steps if res.spec else 1)
        _preview(
            shown,
            out / f"{name}.png",
            used,
            jobs,
            title=name,
            cmap="viridis",
            label="shifts used",
            vmin=0.0,
            vmax=float(images),
        )
    if phase_std is not None and label in phase_std:  # the predicted std (docs/uncertainty.md)
        name = f"phase_std{suffix}"
        _tiff(jobs, files, out / f"{name}.tiff", phase_std[label])
        _preview(
            shown, out / f"{name}.png", phase_std[label], jobs, title=name, cmap="magma",
            label="rad",
        )  # fmt: skip


def _write_float64_tiff(path: Path, data: np.ndarray) -> None:
    """An unwrapped or absolute phase map as float64 TIFF: it grows as ``2 pi x / p``, and
    float32 (24-bit mantissa) would quantise it to ~0.008 rad at projector column 150000 with
    pitch 8 (temporal or one-period unwrapping gives the absolute phase itself)."""
    import tifffile

    tifffile.imwrite(path, np.asarray(data, dtype=np.float64), compression=MAP_COMPRESSION)


def _write_regions(out: Path, fam: FamilyResult, name: str, previews: bool = True) -> list[str]:
    """The region-label map of a family with islands: uint16 TIFF (int32 beyond 65535 regions),
    0 = invalid, 1, 2, ... regions by decreasing size; and its preview."""
    import tifffile

    assert fam.regions is not None
    labels = fam.regions.labels
    dtype = np.uint16 if labels.max(initial=0) <= np.iinfo(np.uint16).max else np.int32
    tifffile.imwrite(out / f"{name}.tiff", labels.astype(dtype), compression="zlib")
    files = [f"{name}.tiff"]
    # the label colours (tab10 without its gray: no region in the invalid colour), in turn
    shown = label_colour_index(np.minimum(labels, fam.regions.significant + 1))
    _preview(
        files if previews else None,
        out / f"{name}.png",
        shown,
        title=f"{name} (relative fringe order unknown)",
        cmap=LABEL_LUT,
        label="region",
        vmin=1.0,
        vmax=float(len(LABEL_COLOURS)),
    )
    return files


def _family_maps(
    out: Path, fam: FamilyResult, suffix: str, files: list[str], jobs: list[Job], previews: bool
) -> dict[str, Any]:
    """Queue a family's unwrapped and absolute phases (and its region map) as
    ``unwrapped_phase{suffix}.tiff``, ...; return its summary entry."""
    shown = files if previews else None
    name = f"unwrapped_phase{suffix}"
    jobs.append(partial(_write_float64_tiff, out / f"{name}.tiff", fam.unwrapped_phase))
    files.append(f"{name}.tiff")
    _preview(shown, out / f"{name}.png", fam.unwrapped_phase, jobs, title=name, label="rad")
    entry: dict[str, Any] = {
        "orientation": fam.orientation,
        "sets": [s.label for s in fam.sets],
        "pitch_px": fam.pitch_px,
        "unwrapping": fam.method,
        "order_from": fam.unwrapping,
        "unwrapped_phase": f"{name}.tiff",
    }
    if fam.regions is not None:
        entry["regions"] = fam.regions_summary()
    if fam.islands:
        files += _write_regions(out, fam, f"regions{suffix}", previews)
        entry["regions_map"] = f"regions{suffix}.tiff"
    if fam.absolute_phase is not None:
        aname = f"absolute_phase{suffix}"
        jobs.append(partial(_write_float64_tiff, out / f"{aname}.tiff", fam.absolute_phase))
        files.append(f"{aname}.tiff")
        _preview(shown, out / f"{aname}.png", fam.absolute_phase, jobs, title=aname, label="rad")
        entry["absolute_phase"] = f"{aname}.tiff"
        entry["absolute_method"] = fam.absolute_method
    return entry


def write_phase_maps(
    out: Path,
    decoded: FolderPhase,
    source: str,
    *,
    previews: bool = True,
    uncertainty: Uncertainty | None = None,
    std_per_set: bool = True,
    per_set: bool = True,
) -> dict[str, Any]:
    """Write every map of a decoded folder into ``out`` (an existing, empty staging folder).

    One set: ``wrapped_phase.tiff``, ``modulation.tiff``, ``mean_intensity.tiff``,
    ``data_modulation.tiff``, ``saturation_count.tiff`` (+ PNG previews). Several sets: the same
    names with ``__<set label>`` appended for every set (unless ``per_set`` is False), and the
    unsuffixed names for the finest set of the primary family. A family's maps name its
    orientation: ``unwrapped_phase_vertical.tiff``, ``absolute_phase_vertical.tiff`` (and
    ``regions_vertical.tiff``), ``_horizontal`` for the horizontal family (issue 27: before,
    the primary family's names had no suffix); a family that differs from its orientation's
    only in its gamma pre-compensation (a gamma capture, :attr:`FolderPhase.gamma_families
    <hdrfringe.core.decode.FolderPhase.gamma_families>`) also gets ``__<its finest set's
    label>``, e.g. ``unwrapped_phase_vertical__<label>.tiff``.
    Maps are uncompressed float32 TIFF (unwrapped and absolute phase:
    float64, which keeps its fraction of a fringe at any projector coordinate) with NaN where
    invalid (:func:`~hdrfringe.io.results.write_map_tiff`); docs/phase.md describes each. The
    files are written on a few threads once every name is known (the encoders release the
    GIL).

    Parameters
    ----------
    out : Path
        Folder to write into, existing and empty (e.g. the staging folder of
        :func:`~hdrfringe.io.results.staged_output_dir`).
    decoded : FolderPhase
        From :func:`hdrfringe.core.decode.decode_captures`.
    source : str
        Where the captures came from (e.g. the capture folder), recorded in the summary.
    previews : bool
        Write a PNG preview beside every map (default). False: the maps and the summary only
        (``--no-previews``; the previews cost about as much as the maps).
    uncertainty : Uncertainty, optional
        The predicted phase std (:func:`hdrfringe.core.uncertainty.predict_uncertainty`): every set
        also gets ``phase_std.tiff`` (float32 rad, NaN where not predicted) and its preview,
        and the summary an ``uncertainty`` block (:meth:`Uncertainty.summary
        <hdrfringe.core.uncertainty.Uncertainty.summary>`). Without it the folder is what it was.
    std_per_set : bool
        With ``uncertainty`` and several sets: also ``phase_std__<set label>.tiff`` for every
        set predicted (False: only the unsuffixed ``phase_std.tiff`` of the primary family's
        finest set, what ``measure`` writes).
    per_set : bool
        With several sets: write every set's maps with ``__<set label>`` appended (default;
        ``phase --per-set-maps``). False: only the final maps (the unsuffixed maps of the
        primary family's finest set, the unwrapped and absolute phases), what ``phase`` writes
        by default; the summary still describes every set.

    Returns
    -------
    dict
        The summary also written to ``phase_summary.json``: ``source``; ``sets`` (per set its
        pattern, steps, pitch, orientation, gray range, valid and saturated fractions);
        ``families`` (per family its sets, unwrapping and absolute-phase method and files,
    ``order_from`` (``one-period``, ``graycode`` or ``spatial``) and, with spatial unwrapping,
    ``regions``; a family whose valid area falls into separate regions (islands) also gets
    ``regions_<orientation>.tiff``, a label map, 0 = invalid, ``regions_map`` naming it); with a
    gamma capture ``gamma_families``, the same per such family and its ``gamma_precompensation``;
        ``notes``; ``files`` (every map and preview written, sorted). Decoded with
        ``saturated="exclude"`` (docs/tolerant.md): ``saturated``, and per set
        ``shifts_used_histogram`` (pixels whose fit used k images, k = 0, 1, ...) and
        ``inverted_set`` (the label of the inverted set decoded with it, if any); every set
        also gets ``shifts_used.tiff`` (float32, the images each pixel's fit used) and its
        preview.
        Decoded with harmonic compensation (docs/harmonics.md): ``harmonics``, the mode and
        per set its estimate and whether it was applied.

    References
    ----------
    Thesis Eq. 2.2 and 2.4 (wrapped phase), Eq. 2.8 and 2.9 (triangular intensity ratio),
    Eq. 3.4-3.6 (modulation, mean intensity, data modulation), Eq. 2.12-2.13 (absolute phase).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.captures import Captures, ProjectorInfo
    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> from hdrfringe.core.decode import decode_captures
    >>> spec = FringeSpec("sinusoidal", 4, 1024.0, migl=200.0)
    >>> x = np.tile(np.arange(16.0), (4, 1))
    >>> images = np.stack([np.rint(fringe_gray(x, spec, k)) for k in range(4)]).astype(np.uint8)
    >>> decoded = decode_captures(Captures(spec.frames(), images, 8, projector=ProjectorInfo()))
    >>> out = Path(tempfile.mkdtemp())
    >>> summary = write_phase_maps(out, decoded, "in memory")
    >>> [f for f in summary["files"] if f.endswith(".tiff")]  # doctest: +NORMALIZE_WHITESPACE
    ['absolute_phase_vertical.tiff', 'data_modulation.tiff', 'mean_intensity.tiff',
     'modulation.tiff', 'saturation_count.tiff', 'unwrapped_phase_vertical.tiff',
     'wrapped_phase.tiff']
    >>> summary["sets"][0]["valid_fraction"], (out / "phase_summary.json").is_file()
    (1.0, True)
    """
    files: list[str] = []
    jobs: list[Job] = []  # the writes, run on a few threads at the end (_run_writes)
    primary = decoded.primary
    std = None if uncertainty is None else uncertainty.set_phase_std
    if len(decoded.sets) == 1:
        label = decoded.sets[0].label
        _write_set(
            out,
            decoded.set_results[label],
            "",
            files,
            jobs,
            previews=previews,
            phase_std=std,
            label=label,
        )
    else:
        for s in decoded.sets if per_set else ():
            each = std if std_per_set else None
            _write_set(
                out,
                decoded.set_results[s.label],
                f"__{s.label}",
                files,
                jobs,
                previews=previews,
                phase_std=each,
                label=s.label,
            )
        if primary is not None:
            label = primary.sets[-1].label
            _write_set(
                out,
                decoded.set_results[label],
                "",
                files,
                jobs,
                previews=previews,
                phase_std=std,
                label=label,
            )
    # every family's maps name its orientation (one family per orientation)
    families = [
        _family_maps(out, fam, f"_{fam.orientation}", files, jobs, previews)
        for fam in decoded.families
    ]
    gamma_families = []  # a gamma capture's other exponents: also named by their finest set
    for fam in decoded.gamma_families:
        suffix = f"_{fam.orientation}__{fam.sets[-1].label}"
        entry = _family_maps(out, fam, suffix, files, jobs, previews)
        entry["gamma_precompensation"] = fam.sets[0].gamma_precompensation
        gamma_families.append(entry)
    _run_writes(jobs)
    sets = []
    for s in decoded.sets:
        r = decoded.set_results[s.label]
        sets.append(
            {
                "label": s.label,
                "pattern": s.spec.pattern,
                "steps": s.spec.steps,
                "pitch_px": s.spec.pitch_px,
                "orientation": s.spec.orientation,
                "imin": s.spec.imin,
                "migl": s.spec.migl,
                "valid_fraction": float(np.mean(r.valid)),
                "saturated_fraction": float(np.mean(r.saturation_count > 0)),
            }
        )
        if isinstance(r, TolerantPhaseResult):
            sets[-1]["shifts_used_histogram"] = np.bincount(r.shifts_used.ravel()).tolist()
            if s.label in decoded.inverted_sets:
                sets[-1]["inverted_set"] = decoded.inverted_sets[s.label]
    summary: dict[str, Any] = {"source": source}
    if decoded.saturated != "flag":  # absent by default: today's summary, byte for byte
        summary["saturated"] = decoded.saturated
    summary |= {
        "sets": sets,
        "families": families,
    }
    if gamma_families:  # absent without a gamma capture: today's summary, byte for byte
        summary["gamma_families"] = gamma_families
    summary["notes"] = decoded.notes
    if uncertainty is not None:
        summary["uncertainty"] = uncertainty.summary()
    if decoded.harmonics is not None:  # absent when off: today's summary, byte for byte
        summary["harmonics"] = decoded.harmonics
    summary["files"] = sorted(files)
    (out / "phase_summary.json").write_text(strict_json.dumps(summary) + "\n", encoding="utf-8")
    return summary
