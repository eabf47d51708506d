"""From height maps to 3D points and error figures.

* :class:`CameraGeometry`: a pinhole camera looking perpendicular to the reference plane from a
  standoff ``l`` (the thesis rig: 1.9 m), focal length ``f`` in pixels, principal point at the
  image centre unless given. A pixel ``(row, col)`` whose surface point has height ``h`` lies at
  ``X = (col - cx) * (l - h) / f`` and ``Y = -(row - cy) * (l - h) / f`` mm (Y toward the top of
  the image): its lateral position on the reference plane (``h = 0``) scaled by the perspective
  factor ``(l - h)/l``.
* :func:`points_from_height`: X, Y, Z maps of every pixel (written as a point cloud by
  :func:`hdrfringe.io.point_cloud.write_ply`).
* :func:`height_errors`: bias, standard deviation and RMSE of a height map against a known
  depth or a ground-truth map, over the measurement pixels (thesis Sec. 4.1).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.errors import InputError

__all__ = ["CameraGeometry", "height_errors", "points_from_height"]

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class CameraGeometry:
    """Pinhole camera perpendicular to the reference plane.

    Parameters
    ----------
    focal_px : float
        Focal length in pixels (``width * standoff / field width`` for a known field of view).
    standoff_mm : float
        Distance from the camera's centre of projection to the reference plane.
    cx, cy : float or None
        Principal point in pixels; None: the image centre ``((W-1)/2, (H-1)/2)``.

    References
    ----------
    Thesis Sec. 2.1 (the measurement setup, Fig. 2.1) and Sec. 3.4.3 (the rig's camera, 1.9 m
    from the reference plane).

    Examples
    --------
    >>> geo = CameraGeometry(focal_px=3800.0, standoff_mm=1900.0)
    >>> geo.pixel_mm
    0.5
    """

    focal_px: float
    standoff_mm: float
    cx: float | None = None
    cy: float | None = None

    def __post_init__(self) -> None:
        for name in ("focal_px", "standoff_mm"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"camera geometry: {name} must be a positive number, got {v}")

    @property
    def pixel_mm(self) -> float:
        """Pixel footprint on the reference plane, mm."""
        return self.standoff_mm / self.focal_px

    def to_manifest(self) -> dict[str, Any]:
        """The manifest's ``camera`` entry (inverse of :meth:`from_manifest`)."""
        out: dict[str, Any] = {"focal_px": self.focal_px, "standoff_mm": self.standoff_mm}
        if self.cx is not None:
            out["cx"] = self.cx
        if self.cy is not None:
            out["cy"] = self.cy
        return out

    @classmethod
    def from_manifest(cls, entry: dict[str, Any] | None) -> CameraGeometry | None:
        """From a manifest's ``camera`` entry (optional fields ``focal_px``, ``standoff_mm``)."""
        if not entry or "focal_px" not in entry or "standoff_mm" not in entry:
            return None
        return cls(
            float(entry["focal_px"]),
            float(entry["standoff_mm"]),
            None if entry.get("cx") is None else float(entry["cx"]),
            None if entry.get("cy") is None else float(entry["cy"]),
        )


def points_from_height(height_mm: ArrayLike, geometry: CameraGeometry) -> tuple[F64, F64, F64]:
    """X, Y, Z maps (mm) of every pixel from its height and the camera geometry.

    Parameters
    ----------
    height_mm : array_like, shape (H, W)
        Height map in mm (NaN = invalid).
    geometry : CameraGeometry
        The camera's pinhole geometry.

    Returns
    -------
    x, y, z : ndarray, shape (H, W)
        ``x = (col - cx) * (l - h) / f``, ``y = -(row - cy) * (l - h) / f`` and ``z`` the
        height; NaN where the height is NaN.

    References
    ----------
    Thesis Sec. 2.4, Eq. 2.11 (the height map).

    Examples
    --------
    >>> geo = CameraGeometry(focal_px=100.0, standoff_mm=1000.0)
    >>> x, y, z = points_from_height(np.array([[0.0, 0.0, 500.0]]), geo)
    >>> x.tolist()  # 10 mm per pixel on the plate, 5 mm at half the standoff
    [[-10.0, 0.0, 5.0]]
    """
    h = np.asarray(height_mm, dtype=np.float64)
    if h.ndim != 2:
        raise InputError(f"height map must be 2-D, got shape {h.shape}")
    rows, cols = np.indices(h.shape, dtype=np.float64)
    cx = (h.shape[1] - 1) / 2.0 if geometry.cx is None else geometry.cx
    cy = (h.shape[0] - 1) / 2.0 if geometry.cy is None else geometry.cy
    scale = (geometry.standoff_mm - h) / geometry.focal_px
    return (cols - cx) * scale, -(rows - cy) * scale, h.copy()


def height_errors(
    height_mm: ArrayLike,
    truth_mm: ArrayLike | float,
    measurement_mask: ArrayLike | None = None,
) -> dict[str, float]:
    """Bias, standard deviation and RMSE of a height map over the measurement pixels.

    Parameters
    ----------
    height_mm : array_like
        Measured heights (NaN = invalid).
    truth_mm : array_like or float
        Known plate depth or a ground-truth height map.
    measurement_mask : array_like of bool, optional
        Measurement pixels (thesis Sec. 4.1: the image without its 10-pixel border).

    Returns
    -------
    dict
        ``bias_mm`` (mean error), ``std_mm``, ``rmse_mm``, ``max_abs_mm``, ``n_pixels`` (valid
        measurement pixels) and ``valid_fraction`` (of the measurement pixels). Invalid pixels
        are excluded and reported through ``valid_fraction``, never counted as zero error.

    References
    ----------
    Thesis Sec. 4.1 (RMSE over the measurement pixels).

    Examples
    --------
    >>> err = height_errors(np.array([[1.0, 3.0], [np.nan, 2.0]]), 2.0)
    >>> err["bias_mm"], round(err["rmse_mm"], 9), err["n_pixels"], err["valid_fraction"]
    (0.0, 0.816496581, 3, 0.75)
    """
    h = np.asarray(height_mm, dtype=np.float64)
    t = np.broadcast_to(np.asarray(truth_mm, dtype=np.float64), h.shape)
    m = np.ones(h.shape, bool) if measurement_mask is None else np.asarray(measurement_mask, bool)
    err = (h - t)[m]
    ok = np.isfinite(err)
    n = int(ok.sum())
    if n == 0:
        nan = float("nan")
        return {
            "bias_mm": nan,
            "std_mm": nan,
            "rmse_mm": nan,
            "max_abs_mm": nan,
            "n_pixels": 0,
            "valid_fraction": 0.0,
        }
    e = err[ok]
    return {
        "bias_mm": float(e.mean()),
        "std_mm": float(e.std()),
        "rmse_mm": float(np.sqrt(np.mean(e * e))),
        "max_abs_mm": float(np.abs(e).max()),
        "n_pixels": n,
        "valid_fraction": float(n / max(1, int(m.sum()))),
    }
