"""``hdrfringe measure``: a measurement of a capture folder or a live rig, and its outputs.

:func:`measure` is the command's work: the output checked, the calibration loaded
(:func:`load_measure_calibration`), :func:`hdrfringe.pipeline.measure` on a capture folder, the
live virtual rig or a hardware rig, and the result folder written. :func:`logged_strategy`
reads the strategy a folder written by ``capture`` records.

:func:`write_measurement` writes everything of a :class:`~hdrfringe.pipeline.MeasurementResult`
into a folder, staged (:func:`hdrfringe.io.results.staged_output_dir`): the ``measure`` command
and the demo call it. Its parts: the phase maps (:func:`hdrfringe.io.phase_maps.write_phase_maps`),
:func:`write_height_outputs` (height map and PLY), :func:`write_strategy_outputs` (index map and
pie chart), DPA's CDF figure and ``metrics.json``. The figures are drawn by
:mod:`hdrfringe.io.plots`, the point cloud by :mod:`hdrfringe.io.point_cloud`.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe._renamed import renamed_fields
from hdrfringe.core import strict_json
from hdrfringe.errors import InputError
from hdrfringe.io.point_cloud import OUTLIERS_MAP
from hdrfringe.io.results import (
    MAP_COMPRESSION,
    read_map_tiff,
    staged_output_dir,
    write_map_tiff,
    write_preview_png,
)
from hdrfringe.tasks._progress import Progress, Say, quiet, silent
from hdrfringe.tasks.capture import (
    CAPTURE_LOG,
    LiveFringes,
    announce_line,
    hardware_rig,
    live_record,
    write_capture_output,
)

if TYPE_CHECKING:
    from hdrfringe.core.reconstruct import CameraGeometry
    from hdrfringe.core.stereo import StereoMaps
    from hdrfringe.io.report import ReportContent
    from hdrfringe.pipeline import MeasurementResult
    from hdrfringe.strategies.base import StrategyResult

__all__ = [
    "CAPTURES",
    "MESH_CHOICES",
    "OUTLIERS_MAP",
    "PIE_SLICES",
    "CloudOptions",
    "MeasureOptions",
    "MeasureReport",
    "check_noise_sigma",
    "load_measure_calibration",
    "logged_camera_settings",
    "logged_fringes",
    "logged_strategy",
    "measure",
    "replayed_strategy",
    "write_cloud",
    "write_height_outputs",
    "write_measurement",
    "write_migl_maps",
    "write_stereo_outputs",
    "write_strategy_outputs",
    "write_uncertainty_outputs",
]


def plot_migl_pie(*args: Any, **kwargs: Any) -> None:
    """:func:`hdrfringe.io.plots.plot_migl_pie`, imported on first use: ``io.plots`` imports
    ``hdrfringe.core.gamma`` and with it scipy.stats, which ``measure`` without a strategy does not
    need (cold start, issue 16)."""
    from hdrfringe.io import plots

    plots.plot_migl_pie(*args, **kwargs)


def plot_dpa_cdfs(*args: Any, **kwargs: Any) -> None:
    """:func:`hdrfringe.io.plots.plot_dpa_cdfs`, imported on first use (see
    :func:`plot_migl_pie`)."""
    from hdrfringe.io import plots

    plots.plot_dpa_cdfs(*args, **kwargs)


#: Most slices of the pie chart of an index map (every MIGL of an 8-bit projector: the
#: thesis's strategies keep their pies); a map with more distinct values (the adaptive
#: projection's per-pixel MIGL) is shown in bins of 10 gray levels (labelled by the lower edge).
PIE_SLICES = 256


def write_height_outputs(
    out: Path,
    height_mm: NDArray[np.float64],
    geometry: CameraGeometry | None,
    *,
    previews: bool = True,
    colour: NDArray[np.uint8] | None = None,
    cloud: CloudOptions | None = None,
) -> list[str]:
    """Write ``height.tiff``, ``height.png`` and ``points.ply`` into ``out``; return notes.

    ``points.ply`` holds x, y, z in mm, the unit normals ``nx, ny, nz`` from the pixel grid
    (toward the camera; :func:`~hdrfringe.io.point_cloud.grid_normals`) and, with ``colour``,
    ``red, green, blue``; ``cloud`` adds outlier removal and a mesh (:func:`write_cloud`).

    Parameters
    ----------
    out : Path
        Output folder (e.g. the staging folder of ``measure``).
    height_mm : ndarray, shape (H, W)
        Height map in mm (NaN = invalid; invalid pixels are not in the point cloud).
    geometry : CameraGeometry or None
        Camera geometry of the calibration, for x and y in mm. None: x and y are in pixels
        (column, minus row) and a note says so.
    previews : bool
        Write the PNG preview of every map (default); False: ``--no-previews``.
    colour : ndarray of uint8, shape (H, W), optional
        The points' gray (the mean intensity, as ``measure`` writes it); None: no colour.
    cloud : CloudOptions, optional
        Outlier removal and mesh; default none of either.

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
    write_map_tiff(out / "height.tiff", height_mm)
    if previews:
        write_preview_png(out / "height.png", height_mm, title="height", cmap="viridis", label="mm")
    from hdrfringe.pipeline import NO_GEOMETRY, height_points

    write_cloud(out, *height_points(height_mm, geometry), colour=colour, cloud=cloud)
    return [NO_GEOMETRY] if geometry is None else []


#: The meshes ``measure --mesh`` writes (``mesh.ply`` or ``mesh.stl``), and ``none``.
MESH_CHOICES = ("none", "ply", "stl")


@dataclass(frozen=True)
class CloudOptions:
    """What ``measure`` writes besides ``points.ply`` (:func:`write_cloud`).

    Parameters
    ----------
    mesh : str
        ``none`` (default), ``ply`` or ``stl``: the organised-grid mesh
        (:func:`hdrfringe.core.cloud.grid_mesh`) as ``mesh.ply`` or ``mesh.stl``.
    remove_outliers : bool
        Leave the statistical outliers (:func:`hdrfringe.core.cloud.statistical_outliers`)
        out of ``points.ply`` and the mesh and write their map, ``outliers.tiff``.

    Raises
    ------
    InputError
        An unknown mesh format.

    Examples
    --------
    >>> CloudOptions(mesh="stl").mesh
    'stl'
    """

    mesh: str = "none"
    remove_outliers: bool = False

    def __post_init__(self) -> None:
        if self.mesh not in MESH_CHOICES:
            raise InputError(
                f"--mesh {self.mesh!r}: give one of {', '.join(MESH_CHOICES)} (docs/measurement.md)"
            )


def write_cloud(
    out: Path,
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    z: NDArray[np.float64],
    *,
    intensity: NDArray[np.float64] | None = None,
    colour: NDArray[np.uint8] | None = None,
    cloud: CloudOptions | None = None,
) -> list[str]:
    """Write ``points.ply`` (with normals) and, as ``cloud`` asks, ``outliers.tiff`` and the
    mesh; return the files written.

    With ``remove_outliers`` the statistical outliers of the valid points are set invalid
    before anything is written (the normals and the mesh then never use them) and their map
    ``outliers.tiff`` (uint8, 1 = left out) is written; the height and coordinate maps keep
    every point. The mesh's vertices are ``points.ply``'s, in the same order.

    Parameters
    ----------
    out : Path
        Output folder.
    x, y, z : ndarray, shape (H, W)
        The points on the camera's pixel grid, mm (NaN = invalid).
    intensity : ndarray, shape (H, W), optional
        A per-point value (the stereo quality).
    colour : ndarray of uint8, shape (H, W), optional
        The points' gray.
    cloud : CloudOptions, optional
        Default: ``points.ply`` only.

    Returns
    -------
    list of str

    Examples
    --------
    >>> import tempfile
    >>> x, y = np.meshgrid(np.arange(4.0), -np.arange(3.0))
    >>> write_cloud(Path(tempfile.mkdtemp()), x, y, np.zeros((3, 4)),
    ...             cloud=CloudOptions(mesh="ply", remove_outliers=True))
    ['outliers.tiff', 'points.ply', 'mesh.ply']
    """
    from hdrfringe.io.point_cloud import write_mesh, write_ply

    cloud = cloud or CloudOptions()
    files = []
    if cloud.remove_outliers:
        from hdrfringe.core.cloud import statistical_outliers

        ok = np.isfinite(x) & np.isfinite(y) & np.isfinite(z)
        removed = np.zeros(ok.shape, dtype=bool)
        removed[ok] = statistical_outliers(np.stack([x[ok], y[ok], z[ok]], axis=-1))
        write_map_tiff(out / OUTLIERS_MAP, removed.astype(np.uint8))
        files.append(OUTLIERS_MAP)
        x, y, z = (np.where(removed, np.nan, a) for a in (x, y, z))
    write_ply(out / "points.ply", x, y, z, intensity=intensity, colour=colour, normals=True)
    files.append("points.ply")
    if cloud.mesh != "none":
        from hdrfringe.core.cloud import grid_mesh

        name = f"mesh.{cloud.mesh}"
        write_mesh(out / name, x, y, z, grid_mesh(x, y, z), colour=colour, normals=True)
        files.append(name)
    return files


def _point_colour(result: MeasurementResult) -> NDArray[np.uint8] | None:
    """The point cloud's gray: the mean intensity of the primary family's finest set (thesis
    Eq. 3.5, the fringes averaged over their shifts: the scene as lit by a uniform mid-gray),
    scaled to 8 bits by the camera's full scale
    (:func:`~hdrfringe.io.point_cloud.intensity_colour`).

    Parameters
    ----------
    result : MeasurementResult
        From :func:`hdrfringe.pipeline.measure`.

    Returns
    -------
    ndarray of uint8, shape (H, W), or None
        None when no family was decoded.
    """
    from hdrfringe.io.point_cloud import intensity_colour

    primary = result.decoded.primary
    if primary is None:
        return None
    finest = result.decoded.set_results[primary.sets[-1].label]
    return intensity_colour(finest.mean_intensity, result.captures.camera_bit_depth)


def write_uncertainty_outputs(
    out: Path, height_std_mm: NDArray[np.float64], *, previews: bool = True
) -> list[str]:
    """Write the predicted height std: ``height_std.tiff`` (float32 mm, NaN where not
    predicted) and its preview ``height_std.png``.

    Parameters
    ----------
    out : Path
        Output folder.
    height_std_mm : ndarray, shape (H, W)
        :attr:`Uncertainty.height_std_mm <hdrfringe.core.uncertainty.Uncertainty.height_std_mm>`.
    previews : bool
        Write the PNG preview (default); False: ``--no-previews``.

    Returns
    -------
    list of str
        The files written.

    References
    ----------
    Thesis Eq. 2.15 (``dh/dphi = K``); docs/uncertainty.md.

    Examples
    --------
    >>> import tempfile
    >>> write_uncertainty_outputs(Path(tempfile.mkdtemp()), np.full((4, 5), 0.01))
    ['height_std.tiff', 'height_std.png']
    """
    write_map_tiff(out / "height_std.tiff", height_std_mm)
    if not previews:
        return ["height_std.tiff"]
    write_preview_png(
        out / "height_std.png", height_std_mm, title="predicted height std", cmap="magma",
        label="mm",
    )  # fmt: skip
    return ["height_std.tiff", "height_std.png"]


def write_stereo_outputs(
    out: Path,
    maps: StereoMaps,
    *,
    previews: bool = True,
    colour: NDArray[np.uint8] | None = None,
    cloud: CloudOptions | None = None,
) -> list[str]:
    """The outputs of a triangulated measurement (docs/stereo.md); returns the files written.

    ``xyz.tiff`` (H x W x 3 float32, mm, camera frame, NaN invalid), ``depth.tiff`` (Z),
    ``height.tiff`` and ``height.png`` (over the fitted reference plane, positive toward the
    camera), ``points.ply`` (mm; ``intensity`` holds the per-point quality, the data
    modulation in DN; normals from the pixel grid, toward the camera; with ``colour`` its
    gray as ``red, green, blue``) and, where both projector coordinates were decoded,
    ``triangulation_residual.tiff`` (ray-ray distance, mm).

    Parameters
    ----------
    out : Path
        Output folder.
    maps : StereoMaps
        From :func:`hdrfringe.core.stereo.triangulate_maps`.
    previews : bool
        Write the PNG preview of every map (default); False: ``--no-previews``.
    colour : ndarray of uint8, shape (H, W), optional
        The points' gray (the mean intensity, as ``measure`` writes it); None: no colour.
    cloud : CloudOptions, optional
        Outlier removal and mesh (:func:`write_cloud`); default none of either.

    Returns
    -------
    list of str
        The files written.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.stereo import StereoMaps, fit_plane
    >>> xyz = np.dstack([*np.mgrid[0:3, 0:4].astype(float), np.full((3, 4), 500.0)])
    >>> maps = StereoMaps(xyz, None, fit_plane(xyz), ("u",), np.ones((3, 4)))
    >>> write_stereo_outputs(Path(tempfile.mkdtemp()), maps)
    ['xyz.tiff', 'depth.tiff', 'height.tiff', 'height.png', 'points.ply']
    """
    import tifffile

    xyz = np.asarray(maps.xyz, dtype=np.float32)
    tifffile.imwrite(
        out / "xyz.tiff",
        xyz,
        photometric="minisblack",
        planarconfig="contig",
        compression=MAP_COMPRESSION,
    )
    write_map_tiff(out / "depth.tiff", maps.depth_mm)
    write_map_tiff(out / "height.tiff", maps.height_mm)
    if previews:
        write_preview_png(
            out / "height.png", maps.height_mm, title="height over the reference plane",
            cmap="viridis", label="mm",
        )  # fmt: skip
    cloud_files = write_cloud(
        out, maps.xyz[..., 0], maps.xyz[..., 1], maps.xyz[..., 2],
        intensity=maps.quality, colour=colour, cloud=cloud,
    )  # fmt: skip
    files = ["xyz.tiff", "depth.tiff", "height.tiff", "height.png", *cloud_files]
    if not previews:
        files.remove("height.png")
    if maps.residual_mm is not None:
        write_map_tiff(out / "triangulation_residual.tiff", maps.residual_mm)
        files.append("triangulation_residual.tiff")
    return files


def write_strategy_outputs(
    out: Path, results: Sequence[StrategyResult], *, previews: bool = True
) -> list[str]:
    """The index map and the pie chart of pixels per index value (thesis Fig. 5.6).

    Files are named by what varied between the sets (:attr:`StrategyResult.index_quantity
    <hdrfringe.strategies.StrategyResult>`): ``migl_index.tiff``, ``migl_index.png`` and
    ``migl_pie.png`` for the MIGL (every strategy of the thesis), ``exposure_ms_index.*`` and
    ``exposure_ms_pie.png`` for the exposure time. An index map with more than
    :data:`PIE_SLICES` values (the adaptive projection's per-pixel MIGL) is shown in the pie
    in bins of 10 gray levels, each labelled by its lower edge.

    Parameters
    ----------
    out : Path
        Output folder.
    results : sequence of StrategyResult
        One per pitch of the measured family. The index map and pie chart are those of the
        finest pitch, whose phase the height comes from (the coarser sets only unwrap it).
    previews : bool
        Write the index map's PNG preview (default); False: ``--no-previews`` (the pie chart
        is a figure, not a preview: it is drawn either way).

    Returns
    -------
    list of str
        The files written.

    References
    ----------
    Thesis Sec. 5.1 (the LPA composite and its MIGL index, Fig. 5.2c) and Fig. 5.6.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> from hdrfringe.strategies.base import CapturedSet, StrategyResult
    >>> index = np.array([[255, 240], [255, 225]], dtype=np.float32)
    >>> res = StrategyResult(
    ...     images=np.zeros((4, 2, 2), np.uint8),
    ...     spec=FringeSpec("sinusoidal", 4, 8.0),
    ...     captured=[CapturedSet(migl=m) for m in (255.0, 240.0, 225.0)],
    ...     index_map=index,
    ...     newly_unsaturated=[2, 1, 1],
    ...     never_unsaturated=np.zeros((2, 2), bool),
    ...     strategy="lpa",
    ... )
    >>> write_strategy_outputs(Path(tempfile.mkdtemp()), [res])
    ['migl_index.tiff', 'migl_index.png', 'migl_pie.png']
    """
    fine = min(results, key=lambda r: r.spec.pitch_px)
    q = fine.index_quantity
    pitch = f"pitch {fine.spec.pitch_px:g} px"
    if q == "migl":
        title, unit, per = f"MIGL index N(x, y), {pitch}", "MIGL", "MIGL"
    else:
        title, unit, per = f"{q} index, {pitch}", q, q
    files = [f"{q}_index.tiff", f"{q}_index.png", f"{q}_pie.png"]
    write_map_tiff(out / files[0], fine.index_map)
    if previews:
        write_preview_png(out / files[1], fine.index_map, title=title, cmap="viridis", label=unit)
    else:
        del files[1]
    pie, step = fine.index_map, ""
    if np.unique(pie).size > PIE_SLICES:  # a per-pixel map (adaptive): slices of 10 levels
        # lower edges (250 holds 250..255): rounding labelled a 255 slice "260", above any MIGL
        pie, step = np.floor(pie / 10.0) * 10.0, ", bins of 10 from the label"
    plot_migl_pie(out / files[-1], pie, title=f"pixels per {per}{step} ({fine.strategy}, {pitch})")
    return files


def write_migl_maps(
    out: Path, results: Sequence[StrategyResult], *, previews: bool = True
) -> list[str]:
    """The per-pixel MIGL maps of a strategy that projects one (the adaptive projection):
    projector side and camera side.

    Per set with a :attr:`~hdrfringe.strategies.StrategyResult.projector_migl_map` (the
    adaptive projection: one per orientation; the file names carry the orientation when there
    are two): ``projector_migl_map.tiff`` (float32, projector pixels: the map of its last
    pass) and ``camera_migl.tiff`` (float32, camera pixels: the levels it was built from),
    each with a PNG preview.

    Parameters
    ----------
    out : Path
        Output folder.
    results : sequence of StrategyResult
        One per set of the measurement; those without the maps are skipped.
    previews : bool
        Write the PNG preview of every map (default); False: ``--no-previews``.

    Returns
    -------
    list of str
        The files written (none for the other strategies).

    References
    ----------
    Thesis Sec. 7.2 (future work: per-pixel adaptive projection); docs/adaptive.md.

    Examples
    --------
    >>> import tempfile
    >>> write_migl_maps(Path(tempfile.mkdtemp()), [])
    []
    """
    adapted = [r for r in results if r.projector_migl_map is not None]
    files: list[str] = []
    for r in adapted:
        tag = f"_{r.spec.orientation}" if len(adapted) > 1 else ""
        pitch = f"{r.spec.orientation} {r.spec.pitch_px:g} px"
        maps = (("projector_migl_map", r.projector_migl_map, "projector"),
                ("camera_migl", r.camera_migl, "camera"))  # fmt: skip
        for key, value, where in maps:
            if value is None:
                continue
            data = np.asarray(value, dtype=np.float32)
            name = f"{key}{tag}"
            write_map_tiff(out / f"{name}.tiff", data)
            files.append(f"{name}.tiff")
            if not previews:
                continue
            write_preview_png(
                out / f"{name}.png",
                data,
                title=f"adaptive MIGL per {where} pixel ({pitch})",
                cmap="viridis",
                label="MIGL",
            )
            files.append(f"{name}.png")
    return files


def write_measurement(
    result: MeasurementResult,
    out: str | Path,
    *,
    force: bool = False,
    extra_metrics: Mapping[str, Any] | None = None,
    phase_maps: bool = True,
    extra_files: Callable[[Path], None] | None = None,
    previews: bool = True,
    cloud: CloudOptions | None = None,
    report: bool = True,
    settings: Mapping[str, Any] | None = None,
) -> list[str]:
    """Write a measurement's result folder, staged: complete or not at all.

    Writes the phase maps and ``phase_summary.json`` (docs/phase.md), with the predicted
    ``phase_std.tiff`` of the primary family's finest set when the result has its
    uncertainty; with a height,
    ``height.tiff``, ``height.png`` and ``points.ply`` (:meth:`MeasurementResult.points
    <hdrfringe.pipeline.MeasurementResult.points>`) and the predicted ``height_std.tiff``
    (:func:`write_uncertainty_outputs`); with a stereo calibration, the
    triangulated outputs instead (:func:`write_stereo_outputs`); with a strategy, its index
    map and pie chart (:func:`write_strategy_outputs`); for DPA, ``dpa_cdf.png`` (thesis
    Fig. 6.3); for the adaptive projection, its MIGL maps (:func:`write_migl_maps`); and
    ``metrics.json`` (:meth:`MeasurementMetrics.to_dict
    <hdrfringe.pipeline.MeasurementMetrics.to_dict>`).

    Parameters
    ----------
    result : MeasurementResult
        From :func:`hdrfringe.pipeline.measure`.
    out : str or Path
        The result folder; an existing non-empty one is replaced only with ``force``.
    force : bool
        Replace an existing result folder.
    extra_metrics : mapping, optional
        Entries added at the end of ``metrics.json`` (the demo adds its strategy parameters);
        JSON-friendly values.
    phase_maps : bool
        Write the phase maps and ``phase_summary.json`` (False: the demo's strategy study,
        ten measurements compared by their height and index maps).
    extra_files : callable, optional
        Called with the staging folder after the measurement is written, to add files that
        must appear with it, or not at all (``measure --rig hardware``: the capture folder).
    previews : bool
        Write a PNG preview beside every map (default). False (``measure --no-previews``): the
        maps, point cloud, figures and metrics only.
    cloud : CloudOptions, optional
        ``--mesh`` and ``--remove-outliers`` (:func:`write_cloud`); default neither.
    report : bool
        Write ``report.html`` and ``report.md`` (:func:`hdrfringe.io.report.write_report`,
        docs/report.md) last, in the same staged folder (default); False: ``--no-report``.
    settings : mapping, optional
        The inputs and settings the report lists (default: the source and the calibration).

    Returns
    -------
    list of str
        The files written, sorted.

    Raises
    ------
    OutputExistsError
        ``out`` exists and is not empty (without ``force``), or is a file.

    References
    ----------
    Thesis Sec. 2.4 (height), 4.1 (metrics), 5.1 and 6.1.3 (strategy outputs).

    Examples
    --------
    >>> import json, tempfile
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> from hdrfringe.pipeline import measure
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=81, height=62))
    >>> frames = [f for p in (1024.0, 64.0) for f in FringeSpec("sinusoidal", 4, p).frames()]
    >>> res = measure(rig.capture_folder(frames))
    >>> out = Path(tempfile.mkdtemp()) / "result"
    >>> files = write_measurement(res, out)
    >>> written = json.loads((out / "metrics.json").read_text())
    >>> "metrics.json" in files, written == res.metrics.to_dict()
    (True, True)
    """
    from hdrfringe.io.phase_maps import write_phase_maps

    unc = result.uncertainty
    sets: list[dict[str, Any]] = []
    with staged_output_dir(out, force=force) as tmp:
        if phase_maps:
            sets = write_phase_maps(
                tmp,
                result.decoded,
                result.metrics.source,
                previews=previews,
                uncertainty=unc,
                std_per_set=False,
            )["sets"]
        if result.stereo is not None:
            colour = _point_colour(result)
            write_stereo_outputs(tmp, result.stereo, previews=previews, colour=colour, cloud=cloud)
        elif result.height_mm is not None:  # its note is in the metrics already
            write_height_outputs(
                tmp, result.height_mm, result.geometry, previews=previews,
                colour=_point_colour(result), cloud=cloud,
            )  # fmt: skip
            if unc is not None and unc.height_std_mm is not None:
                write_uncertainty_outputs(tmp, unc.height_std_mm, previews=previews)
        if result.strategy_results:
            write_strategy_outputs(tmp, result.strategy_results, previews=previews)
            write_migl_maps(tmp, result.strategy_results, previews=previews)
        if result.dpa is not None and result.metrics.dpa is not None:
            plot_dpa_cdfs(tmp / "dpa_cdf.png", result.dpa, threshold=result.metrics.dpa.threshold)
        metrics = result.metrics.to_dict()
        metrics.update(extra_metrics or {})
        (tmp / "metrics.json").write_text(strict_json.dumps(metrics) + "\n", encoding="utf-8")
        if extra_files is not None:
            extra_files(tmp)
        if report:  # last: it lists and embeds what the folder holds
            from hdrfringe.io.report import write_report

            left_out = None  # --remove-outliers: the view shows the points of points.ply
            if cloud is not None and cloud.remove_outliers and (tmp / OUTLIERS_MAP).is_file():
                left_out = read_map_tiff(tmp / OUTLIERS_MAP).astype(bool)
            write_report(tmp, _report_content(result, metrics, sets, settings, left_out))
        files = sorted(p.name for p in tmp.iterdir())
    return files


def _pixel_points(height_mm: NDArray[np.float64]) -> tuple[Any, Any, NDArray[np.float64]]:
    """:func:`hdrfringe.pipeline.height_points` without a geometry (x the column, y minus the
    row), the pixel coordinates as broadcast views: the report takes a few of the points, and
    a full-size copy of each coordinate would not be needed."""
    h, w = height_mm.shape
    cols = np.broadcast_to(np.arange(w, dtype=np.float64), (h, w))
    rows = np.broadcast_to(-np.arange(h, dtype=np.float64)[:, None], (h, w))
    return cols, rows, height_mm


def _report_content(
    result: MeasurementResult,
    metrics: Mapping[str, Any],
    sets: Sequence[Mapping[str, Any]],
    settings: Mapping[str, Any] | None,
    left_out: NDArray[np.bool_] | None = None,
) -> ReportContent:
    """What a measurement's report says (:func:`hdrfringe.io.report.write_report`): the
    settings, ``metrics.json``, the sets decoded and the point cloud, coloured by height, mean
    intensity and the predicted height std where the result has them (stereo: height over
    the reference plane, depth and the data modulation); without a height, the phase cloud of
    ``phase`` (:func:`hdrfringe.tasks.phase.phase_cloud`). ``left_out``: the outliers
    ``--remove-outliers`` left out of ``points.ply``, left out of the view too."""
    from hdrfringe.io.report import CloudView, ReportContent
    from hdrfringe.tasks.phase import phase_cloud

    if not sets:  # the demo's strategy study writes no phase maps: the sets from the result
        sets = [
            {"label": s.label, "pitch_px": s.spec.pitch_px, "orientation": s.spec.orientation,
             "migl": s.spec.migl}
            for s in result.decoded.sets
        ]  # fmt: skip
    if settings is None:
        settings = {"input": result.metrics.source}
    primary = result.decoded.primary
    intensity = None
    if primary is not None:
        intensity = result.decoded.set_results[primary.sets[-1].label].mean_intensity
    colours: dict[str, Any] = {}
    unc = result.uncertainty
    cloud = None
    if result.stereo is not None:
        st = result.stereo
        colours = {"height over the reference plane (mm)": st.height_mm, "depth (mm)": st.depth_mm}
        if st.quality is not None:
            colours["data modulation (DN)"] = st.quality
        if intensity is not None:
            colours["mean intensity (DN)"] = intensity
        x, y, z = result.points()
        z = z if left_out is None else np.where(left_out, np.nan, z)
        cloud = CloudView(x, y, z, colours, ("X (mm)", "Y (mm)", "Z (mm)"), True,
                          "triangulated points in the camera frame")  # fmt: skip
    elif result.height_mm is not None:
        colours = {"height (mm)": result.height_mm}
        if intensity is not None:
            colours["mean intensity (DN)"] = intensity
        if unc is not None and unc.height_std_mm is not None:
            colours["predicted height std (mm)"] = unc.height_std_mm
        mm = result.geometry is not None
        x, y, z = result.points() if mm else _pixel_points(result.height_mm)
        z = z if left_out is None else np.where(left_out, np.nan, z)
        titles = ("x (mm)", "y (mm)", "height (mm)") if mm else ("column (px)", "-row (px)",
                                                                  "height (mm)")  # fmt: skip
        cloud = CloudView(x, y, z, colours, titles, mm, "the points of points.ply")
    elif primary is not None:
        cloud = phase_cloud(result.decoded, unc)
    title = f"hdrfringe measure: {result.metrics.source}"
    return ReportContent(title, settings, metrics, sets, cloud)


# --- the command's work ------------------------------------------------------------------------

#: The capture folder ``measure --rig hardware`` writes inside OUT.
CAPTURES = "captures"


def check_noise_sigma(noise_sigma: float | None, uncertainty: bool) -> None:
    """Refuse a ``--noise-sigma`` that is no finite number >= 0, or given without the
    predicted std.

    Parameters
    ----------
    noise_sigma : float or None
        The camera noise given, in DN.
    uncertainty : bool
        Whether the predicted std is computed.

    Raises
    ------
    InputError
        Either refusal.

    Examples
    --------
    >>> check_noise_sigma(None, False), check_noise_sigma(1.5, True)
    (None, None)
    """
    import math

    if noise_sigma is not None and not (math.isfinite(noise_sigma) and noise_sigma >= 0):
        raise InputError(f"--noise-sigma must be a finite number of DN >= 0, got {noise_sigma:g}")
    if noise_sigma is not None and not uncertainty:
        raise InputError("--noise-sigma is for the predicted std; drop --no-uncertainty")


def logged_strategy(
    folder: Path, strategy: str | None
) -> tuple[str | None, dict[str, Any] | None]:
    """The strategy a folder written by ``capture`` was captured with (its ``capture_log.json``).

    Parameters
    ----------
    folder : Path
        The capture folder measured.
    strategy : str or None
        ``--strategy`` as given.

    Returns
    -------
    strategy : str or None
        The logged strategy (``strategy`` when the folder has no log or the log none).
    recorded : dict or None
        The logged strategy options by option name (``strategy_options``), None without a log.

    Raises
    ------
    InputError
        A ``--strategy`` other than the logged one, or an unreadable log.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> log = '{"method": "lpa", "strategy_options": {"--step": 9}}'
    >>> _ = (folder / CAPTURE_LOG).write_text(log)
    >>> logged_strategy(folder, None)
    ('lpa', {'--step': 9})
    """
    path = Path(folder) / CAPTURE_LOG
    if not path.is_file():
        return strategy, None
    try:
        log = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a readable capture log ({exc}); fix or remove it") from None
    logged = log.get("method") if isinstance(log, dict) else None
    if not isinstance(logged, str):
        return strategy, None
    if strategy is not None and strategy != logged:
        raise InputError(
            f"{folder} was captured with --strategy {logged} ({CAPTURE_LOG}), not {strategy}; "
            f"drop --strategy or give --strategy {logged}"
        )
    options = log.get("strategy_options") or {}
    if not isinstance(options, dict):
        raise InputError(f"{path}: strategy_options is not a mapping; fix or remove it")
    return logged, options


def logged_fringes(folder: Path) -> LiveFringes | None:
    """The fringe sets a folder written by a live run measured (its ``capture_log.json``'s
    ``fringes``, :meth:`~hdrfringe.tasks.capture.LiveFringes.to_record`).

    Parameters
    ----------
    folder : Path
        The capture folder measured.

    Returns
    -------
    LiveFringes or None
        None without a log or without the entry (a folder from before it was recorded: the
        replay takes the folder's sets).

    Raises
    ------
    InputError
        An unreadable log or entry.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> logged_fringes(folder) is None
    True
    >>> _ = (folder / CAPTURE_LOG).write_text('{"fringes": {"pattern": "sinusoidal"}}')
    >>> logged_fringes(folder)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: .../capture_log.json: fringes is not a record of pattern, ...
    """
    path = Path(folder) / CAPTURE_LOG
    if not path.is_file():
        return None
    try:
        log = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a readable capture log ({exc}); fix or remove it") from None
    if not isinstance(log, dict) or "fringes" not in log:
        return None
    return LiveFringes.from_record(log["fringes"], str(path))


def logged_camera_settings(folder: Path) -> Any:
    """The live rig's own camera settings a folder's ``capture_log.json`` records (its
    ``rig.camera`` exposure and gain), which a replayed strategy starts from.

    Parameters
    ----------
    folder : Path
        The capture folder measured.

    Returns
    -------
    CameraSettings
        Exposure and gain, each None where not recorded (or no ``rig.camera`` entry).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / CAPTURE_LOG).write_text('{"rig": {"camera": {"exposure_ms": 10}}}')
    >>> logged_camera_settings(folder)
    CameraSettings(exposure_ms=10.0, gain_db=None)
    """
    from hdrfringe.core.captures import CameraSettings

    path = Path(folder) / CAPTURE_LOG
    try:
        camera = json.loads(path.read_text(encoding="utf-8")).get("rig", {}).get("camera", {})
        exposure, gain = camera.get("exposure_ms"), camera.get("gain_db")
        return CameraSettings(
            exposure_ms=None if exposure is None else float(exposure),
            gain_db=None if gain is None else float(gain),
        )
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError, AttributeError):
        raise InputError(
            f"{path}: rig.camera is not a record of the camera settings; fix or remove it"
        ) from None


def replayed_strategy(
    folder: Path | None, strategy: str | None
) -> tuple[str | None, dict[str, Any] | None, str]:
    """:func:`logged_strategy` of a folder measured (none for a live rig), with the note that
    says the logged strategy is replayed when ``--strategy`` was not given.

    Parameters
    ----------
    folder : Path or None
        The capture folder; None for a live rig.
    strategy : str or None
        ``--strategy`` as given.

    Returns
    -------
    strategy : str or None
    recorded : dict or None
    note : str
        Empty unless the folder's logged strategy is replayed without ``--strategy``.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / CAPTURE_LOG).write_text('{"method": "lpa"}')
    >>> strategy, recorded, note = replayed_strategy(folder, None)
    >>> strategy, recorded, note.endswith("with --strategy lpa (capture_log.json), replayed")
    ('lpa', {}, True)
    """
    if folder is None:
        return strategy, None, ""
    given = strategy
    strategy, recorded = logged_strategy(folder, strategy)
    replayed = recorded is not None and given is None
    note = f"{folder}: captured with --strategy {strategy} ({CAPTURE_LOG}), replayed"
    return strategy, recorded, note if replayed else ""


def load_measure_calibration(path: Path | None) -> Any:
    """The calibration a measurement uses: a stereo calibration (triangulation,
    docs/stereo.md) or a phase-to-height one, by the file's kind; None without a file.

    Parameters
    ----------
    path : Path or None
        ``-c``.

    Returns
    -------
    MeasurementCalibration or None
        A :class:`~hdrfringe.core.calibration.Calibration` or a
        :class:`~hdrfringe.core.stereo.StereoCalibration`.

    Examples
    --------
    >>> load_measure_calibration(None) is None
    True
    """
    from hdrfringe.io.stereo_file import load_any_calibration

    return None if path is None else load_any_calibration(path)


@renamed_fields(method="strategy")
@dataclass(frozen=True)
class MeasureOptions:
    """How ``measure`` decodes and what it computes (:func:`hdrfringe.pipeline.measure`).

    Parameters
    ----------
    strategy : str or None
        The strategy (None: the folder's images as they are); ``method`` before issue 29 (a
        deprecated alias).
    params : Params, optional
        The strategy's parameters.
    sources : mapping
        Field -> the file a strategy option named (recorded; not to be overwritten).
    strategy_options : mapping
        The strategy options given, by option name (recorded with a hardware capture).
    stereo_directions : str
        ``auto``, ``u`` or ``v``.
    uncertainty : bool
        Predict the per-pixel std.
    depth_range_mm : tuple of float, optional
        ``(zmin, zmax)`` for fringe orders from a stereo calibration.
    keep_saturated : bool
        Keep saturated pixels.
    saturated : str
        ``flag`` or ``exclude``.
    min_shifts : int
        Least unsaturated shifts per pixel.
    harmonics : str
        ``off`` or a harmonics mode.
    noise_sigma : float, optional
        The camera noise in DN (else estimated).
    previews : bool
        PNG previews beside the maps.
    cloud : CloudOptions
        Outlier removal and mesh of the point cloud (default: neither).
    report : bool
        Write ``report.html`` and ``report.md`` (docs/report.md); False: ``--no-report``.

    Examples
    --------
    >>> options = MeasureOptions(strategy="lpa", saturated="exclude", min_shifts=4)
    >>> kwargs = options.pipeline_kwargs(None)
    >>> kwargs["strategy"], kwargs["reject_saturated"], kwargs["min_shifts"]
    ('lpa', True, 4)
    """

    strategy: str | None = None
    params: Any = None
    sources: Mapping[str, str] = field(default_factory=dict)
    strategy_options: Mapping[str, Any] = field(default_factory=dict)
    stereo_directions: str = "auto"
    uncertainty: bool = True
    depth_range_mm: tuple[float, float] | None = None
    keep_saturated: bool = False
    saturated: str = "flag"
    min_shifts: int = 3
    harmonics: str = "off"
    noise_sigma: float | None = None
    previews: bool = True
    cloud: CloudOptions = field(default_factory=CloudOptions)
    report: bool = True

    def settings(self) -> dict[str, Any]:
        """The options as the report lists them (docs/report.md), by option name.

        Returns
        -------
        dict
            Each option's value; the strategy's options as given (its parameters' sources
            with them).

        Examples
        --------
        >>> MeasureOptions(strategy="lpa").settings()["strategy"]
        'lpa'
        """
        skip = ("params", "sources", "strategy_options", "report", "cloud")
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in skip}
        out |= {"mesh": self.cloud.mesh, "remove_outliers": self.cloud.remove_outliers}
        if self.strategy_options:
            out["strategy_options"] = dict(self.strategy_options)
        if self.sources:
            out["sources"] = dict(self.sources)
        return out

    def pipeline_kwargs(self, calibration: Path | None) -> dict[str, Any]:
        """The keyword arguments of :func:`hdrfringe.pipeline.measure`.

        Parameters
        ----------
        calibration : Path or None
            The calibration file (recorded as the source).

        Returns
        -------
        dict
        """
        kwargs: dict[str, Any] = {
            "strategy": self.strategy,
            "params": self.params,
            "param_sources": dict(self.sources),
            "calibration_source": None if calibration is None else str(calibration),
            "stereo_directions": self.stereo_directions,
            "uncertainty": self.uncertainty,
            "depth_range_mm": self.depth_range_mm,
            "reject_saturated": not self.keep_saturated,
            "saturated": self.saturated,
            "min_shifts": self.min_shifts,
        }
        if self.harmonics != "off":
            kwargs["harmonics"] = self.harmonics
        if self.noise_sigma is not None:
            from hdrfringe.core.uncertainty import NoiseModel

            kwargs["noise"] = NoiseModel(self.noise_sigma, source="given (--noise-sigma)")
        return kwargs


@dataclass(frozen=True)
class MeasureReport:
    """What ``measure`` wrote.

    Parameters
    ----------
    output : Path
        The result folder.
    result : MeasurementResult
        The measurement (its metrics are what the command prints).
    captured : int or None
        Images captured live on a hardware rig (None otherwise).
    rejected : int or None
        Stale grabs rejected on a hardware rig.

    Examples
    --------
    >>> MeasureReport(Path("out"), None).captured is None
    True
    """

    output: Path
    result: Any
    captured: int | None = None
    rejected: int | None = None


def measure(
    output: Path,
    options: MeasureOptions,
    *,
    folder: Path | None = None,
    calibration: Path | None = None,
    sim: Mapping[str, Any] | None = None,
    hardware: Mapping[str, Any] | None = None,
    rig_config: Path | None = None,
    given: Collection[str] = (),
    fringes: LiveFringes | None = None,
    replayed: str = "",
    force: bool = False,
    say: Say = silent,
    note: Say = silent,
    progress: Progress = quiet,
) -> MeasureReport:
    """Measure a capture folder, the live virtual rig or a hardware rig; write the result.

    The output is checked (not an input, new or empty, or ``force``) before any work. With a
    hardware rig OUT also holds the capture folder (``OUT/captures``); Ctrl-C writes nothing.

    Parameters
    ----------
    output : Path
        The result folder.
    options : MeasureOptions
        Decoding and what is computed.
    folder : Path, optional
        A capture folder (replay).
    calibration : Path, optional
        A phase-to-height or stereo calibration file.
    sim : mapping, optional
        The live virtual rig: keyword arguments of :func:`hdrfringe.rig.factory.virtual_rig`
        (``scene`` among them).
    hardware : mapping, optional
        A hardware rig: its options by Python name
        (:data:`~hdrfringe.tasks.capture.RIG_OPTION_KEYS`).
    rig_config : Path, optional
        The hardware rig's configuration file.
    given : collection of str
        The hardware options given explicitly.
    fringes : LiveFringes, optional
        What a live rig projects.
    replayed : str
        A note said once the output is checked (:func:`replayed_strategy`).
    force : bool
        Replace an existing output folder.
    say : callable
        Called with the line saying a hardware rig is open.
    note : callable
        Called with ``replayed`` (a long line).
    progress : callable
        The live virtual rig's run, as one stage.

    Returns
    -------
    MeasureReport

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.tasks.simulate import simulate
    >>> tmp = Path(tempfile.mkdtemp())
    >>> _ = simulate(tmp / "caps", "white_plate", rig_options={"resolution": (64, 48)},
    ...              pitches=[1024.0, 64.0, 8.0])
    >>> report = measure(tmp / "out", MeasureOptions(previews=False), folder=tmp / "caps")
    >>> (tmp / "out" / "metrics.json").is_file(), report.captured
    (True, None)
    """
    from hdrfringe.io.results import check_output_against_inputs, check_output_dir

    inputs: list[Path | str | None] = [folder, calibration, *options.sources.values()]
    rig: Any = None
    if hardware is not None:
        rig, config = hardware_rig(rig_config, given, **hardware)
        inputs += [rig_config, config.gamma_file]
    check_output_against_inputs(output, inputs)
    output = check_output_dir(output, force)
    if replayed:
        note(replayed)
    # imported once the options are known good: a refused command does not pay for the
    # pipeline's decoders, unwrapping, calibration and HDF5
    from hdrfringe import pipeline
    from hdrfringe.io.captures import DECODE_BYTES_PER_PIXEL, read_capture_folder

    cal = load_measure_calibration(calibration)
    kwargs = options.pipeline_kwargs(calibration)
    if rig is not None:
        assert fringes is not None and options.strategy is not None
        return _measure_hardware(rig, config, cal, output, force, options, fringes, kwargs, say)
    if sim is not None:
        from hdrfringe.rig.factory import virtual_rig  # the simulator loads only when used

        assert fringes is not None
        live = virtual_rig(**sim)
        specs, line = fringes.build(live.projector)
        label = f"live virtual rig: {json.dumps(live.scene.to_manifest())}, "
        label += f"{sim.get('ambient_lux', 0.0):g} lx"
        with progress(f"{options.strategy} on the virtual rig ({sim['scene']})", None):
            result = pipeline.measure(
                live, cal, specs=specs, centerline=line, label=label, **kwargs
            )
    else:
        assert folder is not None
        caps = read_capture_folder(folder, work_bytes_per_pixel=DECODE_BYTES_PER_PIXEL)
        logged = logged_fringes(folder) if options.strategy is not None else None
        if logged is not None:  # the sets the run measured, not every set the folder holds
            from hdrfringe.core.captures import ProjectorInfo

            kwargs["specs"] = logged.build(caps.projector or ProjectorInfo())[0]
            kwargs["replay_settings"] = logged_camera_settings(folder)
        result = pipeline.measure(caps, cal, label=str(folder), **kwargs)
    source: dict[str, Any] = {"input": str(folder) if sim is None else result.metrics.source}
    if sim is not None and fringes is not None:
        source |= {"virtual_rig": dict(sim), "fringes": asdict(fringes)}
    write_measurement(
        result, output, force=force, previews=options.previews, cloud=options.cloud,
        report=options.report,
        settings=_settings(source, calibration, output, options),
    )  # fmt: skip
    return MeasureReport(output, result)


def _settings(
    source: Mapping[str, Any], calibration: Path | None, output: Path, options: MeasureOptions
) -> dict[str, Any]:
    """The report's inputs and settings: the source, the calibration, the output and the
    options."""
    cal = "none (phase maps only)" if calibration is None else str(calibration)
    return {**source, "calibration": cal, "output": str(output), **options.settings()}


def _measure_hardware(
    rig: Any,
    config: Any,
    cal: Any,
    output: Path,
    force: bool,
    options: MeasureOptions,
    fringes: LiveFringes,
    kwargs: dict[str, Any],
    say: Say,
) -> MeasureReport:
    """``measure --rig hardware``: the strategy live as ``capture`` runs it, then the composite
    measured; OUT holds the measurement and the capture folder (staged together)."""
    from hdrfringe import pipeline
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.tasks.capture import strategy_record

    strategy = options.strategy
    assert strategy is not None
    recorder = Recorder(rig)
    with rig:  # Ctrl-C: the rig closes, nothing is written (the CLI: exit 130)
        specs, line = fringes.build(rig.projector)
        say(announce_line(strategy, rig, config))
        label = f"live hardware rig: projector {config.projector.spec}, camera {config.camera.spec}"
        result = pipeline.measure(
            recorder, cal, specs=specs, centerline=line, label=label, **kwargs
        )
    record = strategy_record(options.strategy_options) | fringes.to_record()
    caps, state, log = live_record(recorder, rig, config, strategy, CAPTURES, entries=record)

    def captures(tmp: Path) -> None:
        write_capture_output(tmp / CAPTURES, caps, state, log)

    settings = _settings({"input": label, "captures": f"{output}/{CAPTURES}"}, None, output,
                         options)  # fmt: skip
    settings["calibration"] = kwargs["calibration_source"]
    write_measurement(result, output, force=force, extra_metrics={"capture": state},
                      extra_files=captures, previews=options.previews, cloud=options.cloud,
                      report=options.report,
                      settings=settings)  # fmt: skip
    rejected = sum(t.rejected for t in rig.log)
    return MeasureReport(output, result, captured=len(caps.frames), rejected=rejected)
