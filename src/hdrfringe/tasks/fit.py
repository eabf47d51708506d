"""``hdrfringe fit plane|sphere RESULT --roi ...``: a plane or a sphere fitted to a region of a
measurement, with its residual map.

:func:`fit` reads the organised point cloud of a ``measure`` result folder
(:func:`hdrfringe.io.point_cloud.read_result_points`), selects the points of a region of
interest (:func:`roi_mask`: a rectangle, a polygon file or the largest valid region) and fits
them with the acceptance test's functions (:mod:`hdrfringe.core.acceptance`: the least-squares
plane or free-radius sphere after the 0.3 % trimming rule, giving the flatness F or the form
PF). It writes ``residual.tiff`` (float32 mm on the camera grid, NaN outside the region),
``residual.png`` (the region's bounding box) and ``fit.json`` (strict JSON) into a new folder,
staged (:func:`hdrfringe.io.results.staged_output_dir`). docs/fit.md describes the command.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.errors import InputError

__all__ = [
    "FIT_JSON",
    "MIN_POINTS",
    "RESIDUAL_MAP",
    "RESIDUAL_PNG",
    "SHAPES",
    "FitReport",
    "fit",
    "roi_mask",
]

#: The shapes ``fit`` fits.
SHAPES = ("plane", "sphere")
#: Fewest points of each shape's fit (3 not on a line, 4 not on a plane).
MIN_POINTS = {"plane": 3, "sphere": 4}
#: The files ``fit`` writes.
RESIDUAL_MAP, RESIDUAL_PNG, FIT_JSON = "residual.tiff", "residual.png", "fit.json"

_RECTANGLE = re.compile(r"^\s*[-+0-9.eE]+\s*(,\s*[-+0-9.eE]+\s*){3}$")


def roi_mask(roi: str, valid: NDArray[np.bool_]) -> tuple[NDArray[np.bool_], str]:
    """The region of interest ``--roi`` names, as a mask of the camera's pixels.

    Parameters
    ----------
    roi : str
        ``x0,y0,x1,y1`` (a rectangle in camera pixels, ``x0 <= x < x1``, ``y0 <= y < y1``:
        :func:`hdrfringe.core.roi.rectangle_mask`), ``auto`` (the largest 4-connected region of
        valid pixels: :func:`hdrfringe.core.roi.largest_region`) or a polygon file, ``.json`` or
        ``.csv`` (:func:`hdrfringe.io.roi_file.read_polygon`,
        :func:`hdrfringe.core.roi.polygon_mask`).
    valid : ndarray of bool, shape (H, W)
        The pixels with a point.

    Returns
    -------
    mask : ndarray of bool, shape (H, W)
        The region (valid or not).
    rule : str
        ``rectangle``, ``polygon`` or ``auto``.

    Raises
    ------
    InputError
        A rectangle not inside the image or not of integers, a malformed or missing polygon
        file, a polygon vertex outside the image.

    Examples
    --------
    >>> valid = np.ones((4, 6), dtype=bool)
    >>> mask, rule = roi_mask("1,0,3,2", valid)
    >>> rule, int(mask.sum())
    ('rectangle', 4)
    """
    from hdrfringe.core.roi import largest_region, polygon_mask, rectangle_mask

    text = roi.strip()
    if text == "auto":
        return largest_region(valid), "auto"
    if _RECTANGLE.match(text):
        try:
            values = [float(v) for v in text.split(",")]
        except ValueError:
            values = []
        if len(values) != 4 or not all(v.is_integer() for v in values):
            raise InputError(f"--roi {roi!r}: give the rectangle as integer pixels x0,y0,x1,y1")
        x0, y0, x1, y1 = (int(v) for v in values)
        return rectangle_mask(valid.shape, x0, y0, x1, y1), "rectangle"
    from hdrfringe.io.roi_file import read_polygon

    vertices = read_polygon(Path(roi))
    try:
        return polygon_mask(valid.shape, vertices), "polygon"
    except InputError as exc:
        raise InputError(f"{roi}: {exc}") from None


@dataclass(frozen=True)
class FitReport:
    """What ``fit`` found and wrote.

    Parameters
    ----------
    output : Path
        The folder written.
    shape : str
        ``plane`` or ``sphere``.
    values : dict
        ``fit.json``'s content (plain JSON types).
    notes : list of str
        Lines worth saying (e.g. x and y in pixels).

    Examples
    --------
    >>> FitReport(Path("out"), "plane", {"rms_mm": 0.01}).values["rms_mm"]
    0.01
    """

    output: Path
    shape: str
    values: dict[str, Any]
    notes: list[str] = field(default_factory=list)


def _pixel_note(folder: Path) -> list[str]:
    """The note of a result whose x and y are pixels (a calibration without camera geometry)."""
    from hdrfringe.core import strict_json
    from hdrfringe.core.calibration import NO_GEOMETRY

    path = folder / "metrics.json"
    try:
        metrics = strict_json.loads_strict(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    notes = metrics.get("notes", []) if isinstance(metrics, dict) else []
    if isinstance(notes, list) and NO_GEOMETRY in notes:
        return [f"{path.name}: {NO_GEOMETRY}; the fit mixes pixels (x, y) and mm (z)"]
    return []


def _fit_values(
    shape: str, pts: NDArray[np.float64], diameter_mm: float | None
) -> tuple[dict[str, Any], NDArray[np.float64], NDArray[np.bool_]]:
    """The acceptance functions on the region's points: (values, residuals, kept)."""
    from hdrfringe.core import acceptance as acc

    if shape == "plane":
        f = acc.flatness_error(pts)
        kept, res = f.kept, f.residuals
        values = f.to_dict()
        return values, res, kept
    if diameter_mm is not None:
        p = acc.probing_error(pts, diameter_mm)
        sphere, extra = p.sphere, {"ps_mm": p.size_mm, "calibrated_diameter_mm": diameter_mm}
    else:
        sphere, extra = acc.measure_sphere(pts), {}
    values = sphere.to_dict()
    values["radius_mm"] = sphere.diameter_mm / 2.0
    values["pf_mm"] = values.pop("form_mm")
    values.update(extra)
    return values, sphere.residuals, sphere.kept


def fit(
    result: Path,
    shape: str,
    roi: str,
    output: Path,
    *,
    diameter_mm: float | None = None,
    force: bool = False,
) -> FitReport:
    """Fit a plane or a sphere to a region of a ``measure`` result; write its residual map.

    Parameters
    ----------
    result : Path
        A ``measure`` result folder with a calibration (``xyz.tiff``, or ``height.tiff`` and
        ``points.ply``).
    shape : str
        ``plane``: least-squares plane, flatness F
        (:func:`hdrfringe.core.acceptance.flatness_error`).
        ``sphere``: free-radius least-squares sphere, form PF
        (:func:`~hdrfringe.core.acceptance.measure_sphere`; with ``diameter_mm`` also the size
        error PS, :func:`~hdrfringe.core.acceptance.probing_error`). Both after the trimming
        rule (the 0.3 % of the points with the largest residuals left out, then refitted).
    roi : str
        The region of interest (:func:`roi_mask`).
    output : Path
        The folder to write (``residual.tiff``, ``residual.png``, ``fit.json``).
    diameter_mm : float, optional
        A sphere's calibrated diameter, for PS.
    force : bool
        Replace an existing output folder.

    Returns
    -------
    FitReport

    Raises
    ------
    InputError
        An unknown shape, no such result folder, a bad ROI, an empty ROI, too few points for
        the shape, ``diameter_mm`` with a plane; nothing is written.
    OutputExistsError
        ``output`` exists and is not empty, without ``force``.

    Notes
    -----
    The residuals are signed distances, positive toward the camera for a plane (the normal
    is turned toward the camera: +z for a height result, toward the origin for a stereo one)
    and outside the sphere for a sphere; ``rms_mm`` is their RMS over the kept points.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.io.point_cloud import write_ply
    >>> from hdrfringe.io.results import write_map_tiff
    >>> tmp = Path(tempfile.mkdtemp())
    >>> (tmp / "m").mkdir()
    >>> x, y = np.meshgrid(np.arange(8.0), -np.arange(6.0))
    >>> z = 2.0 + 0.0 * x
    >>> write_map_tiff(tmp / "m" / "height.tiff", z)
    >>> _ = write_ply(tmp / "m" / "points.ply", x, y, z)
    >>> report = fit(tmp / "m", "plane", "0,0,8,6", tmp / "f")
    >>> report.values["f_mm"], report.values["normal"], report.values["n_points"]
    (0.0, [0.0, 0.0, 1.0], 48)
    """
    from hdrfringe.core import strict_json
    from hdrfringe.core.acceptance import GUIDELINE_TRIM
    from hdrfringe.io.point_cloud import read_result_points
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_dir,
        staged_output_dir,
        write_map_tiff,
        write_preview_png,
    )

    if shape not in SHAPES:
        raise InputError(f"fit {shape!r}: give one of {', '.join(SHAPES)}")
    if diameter_mm is not None and shape != "sphere":
        raise InputError("--diameter is a sphere's calibrated diameter; drop it for a plane")
    if diameter_mm is not None and not (np.isfinite(diameter_mm) and diameter_mm > 0):
        raise InputError(f"--diameter must be a positive number of mm, got {diameter_mm:g}")
    polygon = None if roi.strip() == "auto" or _RECTANGLE.match(roi) else Path(roi)
    check_output_against_inputs(output, [result, polygon])
    out = check_output_dir(output, force)
    xyz, kind = read_result_points(result)
    valid = np.isfinite(xyz).all(axis=-1)
    mask, rule = roi_mask(roi, valid)
    use = mask & valid
    n = int(use.sum())
    if n == 0:
        raise InputError(
            f"--roi {roi}: no valid point of {result} in the region ({int(mask.sum())} pixels); "
            "choose a region on the measured surface"
        )
    if n < MIN_POINTS[shape]:
        raise InputError(
            f"--roi {roi}: {n} valid points in the region; a {shape} needs at least "
            f"{MIN_POINTS[shape]}: enlarge the region"
        )
    pts = np.where(use[..., None], xyz, np.nan)
    values, residuals, kept = _fit_values(shape, pts, diameter_mm)
    if shape == "plane" and kind == "height" and values["normal"][2] < 0:
        # toward the camera: +z for a height result (fit_plane turns it toward the origin)
        values["normal"] = [-v for v in values["normal"]]
        values["offset_mm"] = -values["offset_mm"]
        residuals = -residuals
    rms = float(np.sqrt(np.mean(residuals[kept] ** 2)))
    notes = _pixel_note(Path(result))
    record = {
        "shape": shape,
        "result": str(result),
        "cloud": kind,
        "roi": {"rule": rule, "given": roi, "pixels": int(mask.sum()), "points": n},
        "trim_fraction": GUIDELINE_TRIM,
        **values,
        "rms_mm": rms,
        "residual_map": RESIDUAL_MAP,
        "notes": notes,
    }
    rows, cols = np.nonzero(mask)
    box = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
    residual_map = np.where(use, residuals, np.nan)
    # the colours span the points PF/F count: the few the 0.3 % rule leaves out are the largest
    # residuals (a stray point hundreds of mm off would otherwise flatten the map to one colour)
    lim = float(np.nanmax(np.abs(residuals[kept]))) or 1.0
    main = f"F {values['f_mm']:.4g} mm" if shape == "plane" else f"PF {values['pf_mm']:.4g} mm"
    with staged_output_dir(out, force=force) as tmp:
        write_map_tiff(tmp / RESIDUAL_MAP, residual_map)
        write_preview_png(
            tmp / RESIDUAL_PNG, residual_map[box], title=f"{shape} residual ({main})",
            label="mm", vmin=-lim, vmax=lim,
        )  # fmt: skip
        (tmp / FIT_JSON).write_text(strict_json.dumps(record, indent=1) + "\n", encoding="utf-8")
    return FitReport(Path(output), shape, record, notes)
