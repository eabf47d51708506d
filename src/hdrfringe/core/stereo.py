"""Projector-camera (stereo) geometry: lens models, the stereo calibration, triangulation.

The projector is treated as an inverse camera (Zhang & Huang 2006, Opt. Eng. 45:083601): a
pinhole with intrinsics and lens distortion, related to the camera by a rigid motion. A camera
pixel whose absolute phase gives the projector column ``u_proj`` (vertical fringes) and/or row
``v_proj`` (horizontal fringes) is triangulated as the camera ray against the projector plane of
that coordinate, or against the projector ray when both are known.

Conventions (``docs/stereo.md``):

* pixel coordinates are OpenCV's: ``(0, 0)`` is the centre of the top-left pixel, ``u`` runs
  along the columns (right), ``v`` along the rows (down);
* the camera frame is the world frame, in millimetres: ``X_proj = R @ X_cam + t``;
* projector coordinates come from the absolute phase ``Phi`` of fringes of pitch ``p``
  (``phi = 2*pi*x/p``, :mod:`hdrfringe.core.patterns`): ``u_proj = p * Phi / (2*pi)`` from vertical
  fringes, ``v_proj`` likewise from horizontal ones, pixel centres at integers;
* lens distortion is OpenCV's model, coefficients ``(k1, k2, p1, p2[, k3[, k4, k5, k6]])``;
  projection and undistortion evaluate it in numpy (they agree with ``cv2.projectPoints`` and
  ``cv2.undistortPoints``, tests/test_stereo.py); a camera's rays are computed once per
  calibration (:func:`ray_table`).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from hdrfringe.errors import InputError

if TYPE_CHECKING:
    from hdrfringe.core.calibration import Calibration
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.core.reconstruct import CameraGeometry

__all__ = [
    "DIRECTION_BLAME_RATIO",
    "DIRECTION_CHECK_FACTOR",
    "DIRECTION_SIGMA_FLOOR_PX",
    "DISTORTION_LENGTHS",
    "HEIGHT_STD_NOTE",
    "DirectionCheck",
    "LensModel",
    "PlaneFit",
    "SphereFit",
    "StereoCalibration",
    "StereoMaps",
    "Triangulation",
    "check_directions",
    "coordinate_noise_px",
    "fit_dominant_plane",
    "fit_plane",
    "fit_sphere",
    "projector_coordinate",
    "ray_table",
    "triangulate",
    "triangulate_maps",
]

F64 = NDArray[np.float64]

#: What a predicted uncertainty with a stereo calibration lacks (``metrics.uncertainty.notes``).
HEIGHT_STD_NOTE = "no height std: triangulation's is not modelled"

#: Accepted lengths of an OpenCV distortion vector: none, (k1, k2, p1, p2), + k3, + k4..k6.
DISTORTION_LENGTHS = (0, 4, 5, 8)

#: A point whose undistortion does not reproject onto its pixel within this many pixels (the
#: distortion model folds over there, far outside the calibrated field) becomes NaN.
UNDISTORT_TOLERANCE_PX = 1e-4


def _finite_array(value: ArrayLike, name: str, shape: tuple[int, ...] | None = None) -> F64:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f"{name}: not a numeric array ({err}); give numbers") from None
    if shape is not None and arr.shape != shape:
        raise InputError(f"{name}: shape {arr.shape}, expected {shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: contains NaN or infinite values; give finite numbers")
    arr.setflags(write=False)
    return arr


#: Points per block of the numpy lens kernels below: a block's temporaries stay in the CPU
#: cache and off the page-fault path (on a whole 3 Mpx image the same kernels run several
#: times slower unblocked).
_LENS_BLOCK = 1 << 14

#: Undistortion: Newton's method on the OpenCV model stops when the point reprojects onto its
#: pixel within this many pixels (or after :data:`_UNDISTORT_ITERATIONS` steps).
_UNDISTORT_STOP_PX = 1e-10
#: Newton steps at most (a few suffice inside a lens's field; the rest are for points near the
#: edge of a strong lens).
_UNDISTORT_ITERATIONS = 50


def _coefficients8(distortion: F64) -> tuple[float, ...]:
    """``(k1, k2, p1, p2, k3, k4, k5, k6)`` of an OpenCV distortion vector (zeros appended)."""
    d = np.zeros(8)
    d[: distortion.size] = distortion
    return tuple(float(c) for c in d)


def _distort(x: F64, y: F64, d8: tuple[float, ...], *, jacobian: bool = False) -> tuple[F64, ...]:
    """OpenCV's lens distortion of normalised coordinates ``(x, y)``: ``(xd, yd)`` and, with
    ``jacobian``, the symmetric Jacobian's entries ``d xd/dx, d xd/dy (= d yd/dx), d yd/dy``.

    The model of ``cv2.projectPoints`` (radial rational ``k1..k6``, tangential ``p1, p2``)::

        r2 = x^2 + y^2,  c = (1 + k1 r2 + k2 r2^2 + k3 r2^3) / (1 + k4 r2 + k5 r2^2 + k6 r2^3)
        xd = x c + 2 p1 x y + p2 (r2 + 2 x^2),  yd = y c + p1 (r2 + 2 y^2) + 2 p2 x y
    """
    k1, k2, p1, p2, k3, k4, k5, k6 = d8
    r2 = x * x + y * y
    c = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    rational = k4 != 0.0 or k5 != 0.0 or k6 != 0.0
    if rational:
        den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        c = c / den
    xy = x * y
    xd = x * c + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x * x)
    yd = y * c + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * xy
    if not jacobian:
        return xd, yd
    dc = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # d c / d r2 (numerator's, then the quotient's)
    if rational:
        dc = (dc - c * (k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2))) / den
    dc2 = 2.0 * dc
    jxx = c + dc2 * x * x + 2.0 * p1 * y + 6.0 * p2 * x
    jxy = dc2 * xy + 2.0 * p1 * x + 2.0 * p2 * y
    jyy = c + dc2 * y * y + 6.0 * p1 * y + 2.0 * p2 * x
    return xd, yd, jxx, jxy, jyy


def _undistort_block(xd: F64, yd: F64, d8: tuple[float, ...], stop: float) -> tuple[F64, ...]:
    """Newton's method for ``_distort(x, y) = (xd, yd)`` from ``(xd, yd)``, one block of finite
    points: ``x, y``, the final residual (normalised units) and the Jacobian's determinant."""
    x, y = xd.copy(), yd.copy()
    err = np.full(x.shape, np.inf)
    det = np.zeros(x.shape)
    act = np.arange(x.size)
    for step in range(_UNDISTORT_ITERATIONS + 1):
        xa, ya = x[act], y[act]
        fx, fy, a, b, c = _distort(xa, ya, d8, jacobian=True)
        rx, ry = xd[act] - fx, yd[act] - fy
        e = np.hypot(rx, ry)
        err[act] = e
        det[act] = da = a * c - b * b
        more = ~(e <= stop)
        if step == _UNDISTORT_ITERATIONS or not more.any():
            break
        act = act[more]
        xa, ya, a, b, c, rx, ry, da = (v[more] for v in (xa, ya, a, b, c, rx, ry, da))
        x[act] = xa + (c * rx - b * ry) / da
        y[act] = ya + (a * ry - b * rx) / da
    return x, y, err, det


@dataclass(frozen=True, eq=False)
class LensModel:
    """A pinhole lens with OpenCV distortion: a camera, or a projector as an inverse camera.

    Parameters
    ----------
    matrix : array_like, shape (3, 3)
        Intrinsics ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` in pixels; ``fx, fy > 0``, skew
        ``s`` allowed.
    distortion : array_like, shape (n,)
        OpenCV distortion coefficients ``(k1, k2, p1, p2[, k3[, k4, k5, k6]])``, ``n`` in 0, 4,
        5 or 8 (0: no distortion).
    size : tuple of int
        ``(width, height)`` of the image (camera) or of the pattern (projector), pixels.

    Notes
    -----
    Pixel convention: OpenCV's, ``(0, 0)`` the centre of the top-left pixel, ``u`` along the
    columns, ``v`` along the rows. A point ``(X, Y, Z)`` in the lens frame has normalised
    coordinates ``(X/Z, Y/Z)``, distorted by the OpenCV model to ``(xd, yd)``, and pixel
    coordinates ``u = fx*xd + s*yd + cx``, ``v = fy*yd + cy`` (OpenCV's functions ignore the
    skew ``s``; this class evaluates the model itself, so a skewed matrix is exact too).

    Examples
    --------
    >>> lens = LensModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], [0.1, 0, 0, 0], (640, 480))
    >>> u, v = lens.project([[10.0, -5.0, 500.0]])
    >>> round(float(u[0]), 4), round(float(v[0]), 4)
    (340.001, 229.9995)
    >>> x, y = lens.undistort(u, v)
    >>> round(float(x[0]) * 500, 6), round(float(y[0]) * 500, 6)
    (10.0, -5.0)
    """

    matrix: F64
    distortion: F64
    size: tuple[int, int]

    def __post_init__(self) -> None:
        k = _finite_array(self.matrix, "lens matrix", (3, 3))
        if not (k[0, 0] > 0 and k[1, 1] > 0):
            raise InputError(
                f"lens matrix: focal lengths fx={k[0, 0]:g}, fy={k[1, 1]:g} must be positive"
            )
        if not np.array_equal(k[2], [0.0, 0.0, 1.0]) or k[1, 0] != 0.0:
            raise InputError(
                f"lens matrix: must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]], got {k.tolist()}"
            )
        d = _finite_array(self.distortion, "lens distortion").reshape(-1)
        if d.size not in DISTORTION_LENGTHS:
            raise InputError(
                f"lens distortion: {d.size} coefficients; give 0, 4, 5 or 8 "
                "(k1, k2, p1, p2[, k3[, k4, k5, k6]])"
            )
        d.setflags(write=False)
        try:
            size = tuple(int(s) for s in self.size)
            ok = len(size) == 2 and all(s == t for s, t in zip(size, self.size, strict=True))
        except (TypeError, ValueError):
            ok = False
        if not ok or min(size) < 1:
            raise InputError(f"lens size: must be (width, height) in pixels >= 1, got {self.size}")
        object.__setattr__(self, "matrix", k)
        object.__setattr__(self, "distortion", d)
        object.__setattr__(self, "size", (size[0], size[1]))

    @property
    def skew(self) -> float:
        """The skew ``s = K[0, 1]`` (0 for OpenCV calibrations)."""
        return float(self.matrix[0, 1])

    def project(self, points_xyz: ArrayLike) -> tuple[F64, F64]:
        """Pixel coordinates of points given in the lens frame (OpenCV's model).

        Parameters
        ----------
        points_xyz : array_like, shape (..., 3)
            Points in the lens's own frame (mm or any unit).

        Returns
        -------
        u, v : ndarray, shape (...)
            Pixel coordinates; NaN for non-finite points and points not in front of the lens
            (``Z <= 0``).

        Notes
        -----
        OpenCV's distortion model evaluated in numpy, in blocks (``cv2.projectPoints`` also
        computes a 15-column Jacobian per point, which made it the largest cost of a
        measurement); it agrees with ``cv2.projectPoints`` within 1e-9 px
        (tests/test_stereo.py, tests/test_geometric_order.py).

        Examples
        --------
        >>> lens = LensModel([[800, 0, 400], [0, 800, 300], [0, 0, 1]], [], (800, 600))
        >>> lens.project([[0.0, 0.0, 100.0], [1.0, 2.0, -3.0]])
        (array([400.,  nan]), array([300.,  nan]))
        """
        pts = np.asarray(points_xyz, dtype=np.float64)
        if pts.ndim < 1 or pts.shape[-1] != 3:
            raise InputError(f"points: shape {pts.shape}, expected (..., 3)")
        flat = pts.reshape(-1, 3)
        u = np.full(flat.shape[0], np.nan)
        v = np.full(flat.shape[0], np.nan)
        k, d8 = self.matrix, _coefficients8(self.distortion)
        distorted = bool(np.any(self.distortion))
        idx = np.flatnonzero(np.all(np.isfinite(flat), axis=1) & (flat[:, 2] > 0))
        for i in range(0, idx.size, _LENS_BLOCK):
            sel = idx[i : i + _LENS_BLOCK]
            block = flat[sel]
            x, y = block[:, 0] / block[:, 2], block[:, 1] / block[:, 2]
            if distorted:
                x, y = _distort(x, y, d8)
            u[sel] = k[0, 0] * x + k[0, 1] * y + k[0, 2]
            v[sel] = k[1, 1] * y + k[1, 2]
        return u.reshape(pts.shape[:-1]), v.reshape(pts.shape[:-1])

    def undistort(self, u: ArrayLike, v: ArrayLike) -> tuple[F64, F64]:
        """Normalised ideal coordinates ``(x, y)`` of pixels (OpenCV's model inverted).

        The ray of pixel ``(u, v)`` is ``(x, y, 1)`` in the lens frame.

        Parameters
        ----------
        u, v : array_like
            Pixel coordinates (broadcast together).

        Returns
        -------
        x, y : ndarray
            Normalised coordinates; NaN where ``u`` or ``v`` is NaN, where the inversion does
            not reproject onto the pixel within ``UNDISTORT_TOLERANCE_PX`` (1e-4 px), and where
            it lands beyond a fold of the model (the distortion's Jacobian not positive: far
            outside the calibrated field).

        Notes
        -----
        Newton's method on the OpenCV model (its analytic Jacobian), started at the distorted
        point, in numpy blocks, until the point reprojects onto its pixel within 1e-10 px (a few
        steps inside a lens's field, at most 50). OpenCV's ``undistortPoints`` iterates
        ``x <- (x_d - delta(x)) / radial(x)`` instead, whose default 5 iterations leave tens of
        millipixels on a strong lens; run to the same 1e-10 px it agrees with this within
        1e-6 px (tests/test_ray_table.py).

        Examples
        --------
        >>> lens = LensModel([[800, 0, 400], [0, 800, 300], [0, 0, 1]], [], (800, 600))
        >>> lens.undistort([400.0, 480.0], [300.0, 300.0])
        (array([0. , 0.1]), array([0., 0.]))
        """
        uu, vv = np.broadcast_arrays(np.asarray(u, np.float64), np.asarray(v, np.float64))
        shape = uu.shape
        fu, fv = uu.reshape(-1), vv.reshape(-1)
        x = np.full(fu.shape, np.nan)
        y = np.full(fu.shape, np.nan)
        k, d8 = self.matrix, _coefficients8(self.distortion)
        distorted = bool(np.any(self.distortion))
        scale = max(k[0, 0], k[1, 1])  # normalised units -> px (the larger focal length)
        idx = np.flatnonzero(np.isfinite(fu) & np.isfinite(fv))
        with np.errstate(all="ignore"):  # points beyond a fold diverge: NaN below
            for i in range(0, idx.size, _LENS_BLOCK):
                sel = idx[i : i + _LENS_BLOCK]
                yd = (fv[sel] - k[1, 2]) / k[1, 1]
                xd = (fu[sel] - k[0, 2] - k[0, 1] * yd) / k[0, 0]
                if distorted:
                    xd, yd, err, det = _undistort_block(xd, yd, d8, _UNDISTORT_STOP_PX / scale)
                    bad = ~((err * scale <= UNDISTORT_TOLERANCE_PX) & (det > 0))
                    xd[bad] = np.nan
                    yd[bad] = np.nan
                x[sel], y[sel] = xd, yd
        return x.reshape(shape), y.reshape(shape)

    def to_dict(self) -> dict[str, Any]:
        """Plain lists and numbers (for reports and JSON)."""
        return {
            "matrix": self.matrix.tolist(),
            "distortion": self.distortion.tolist(),
            "size": list(self.size),
        }


#: Camera ray tables kept in memory (:func:`ray_table`): 16 bytes a pixel in float64 (45 MB at
#: 1936x1464, 400 MB at 25 Mpx), so only the most recent calibrations.
RAY_TABLE_CACHE_SIZE = 2


def ray_table(lens: LensModel, dtype: DTypeLike = np.float64) -> F64:
    """The undistorted ray of every pixel of a lens's image, computed once per lens model.

    Parameters
    ----------
    lens : LensModel
        The camera (its ``size`` is the image's).
    dtype : dtype, optional
        ``float64`` (default: what :func:`triangulate_maps` uses) or ``float32`` (half the
        memory; rounding moves a ray by at most 3e-8 in normalised units, about 1e-4 px at a
        4000 px focal length, far below any decoded coordinate's noise).

    Returns
    -------
    ndarray, shape (2, H, W)
        ``x`` and ``y`` of :meth:`LensModel.undistort` at every pixel centre ``(col, row)``:
        the pixel's ray is ``(x, y, 1)`` in the lens frame; NaN where the lens model does not
        invert. Read-only.

    Notes
    -----
    Cached in memory (the :data:`RAY_TABLE_CACHE_SIZE` most recent) by the lens's matrix,
    distortion and size and the dtype, so any lens object with the same numbers (e.g. a
    calibration read again from its file) finds the table computed before; a different
    calibration or image size computes its own. ``ray_table.cache_info()`` reports hits and
    misses, ``ray_table.cache_clear()`` empties it.

    Examples
    --------
    >>> lens = LensModel([[100, 0, 1.5], [0, 100, 0.5], [0, 0, 1]], [], (4, 2))
    >>> table = ray_table(lens)
    >>> table.shape, table[:, 1, 3].tolist()
    ((2, 2, 4), [0.015, 0.005])
    >>> ray_table(LensModel(lens.matrix, [], (4, 2))) is table  # same numbers: cached
    True
    """
    if not isinstance(lens, LensModel):
        raise InputError("ray_table: give a LensModel (e.g. calibration.camera)")
    kind = np.dtype(dtype)
    if kind not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise InputError(f"ray_table: dtype {kind} is not float32 or float64")
    return _ray_table(lens.matrix.tobytes(), lens.distortion.tobytes(), lens.size, kind.str)


#: Rows of a ray table undistorted at a time (bounds the temporaries).
_RAY_TABLE_ROWS = 64


@functools.lru_cache(maxsize=RAY_TABLE_CACHE_SIZE)
def _ray_table(matrix: bytes, distortion: bytes, size: tuple[int, int], dtype: str) -> F64:
    """:func:`ray_table` of the lens given by its numbers (the cache's key)."""
    lens = LensModel(np.frombuffer(matrix).reshape(3, 3), np.frombuffer(distortion), size)
    width, height = size
    table = np.empty((2, height, width), dtype=np.dtype(dtype))
    cols = np.arange(width, dtype=np.float64)
    for r0 in range(0, height, _RAY_TABLE_ROWS):
        rows = np.arange(r0, min(r0 + _RAY_TABLE_ROWS, height), dtype=np.float64)
        x, y = lens.undistort(cols[None, :], rows[:, None])
        table[0, r0 : r0 + rows.size] = x
        table[1, r0 : r0 + rows.size] = y
    table.setflags(write=False)
    return table


ray_table.cache_info = _ray_table.cache_info  # type: ignore[attr-defined]
ray_table.cache_clear = _ray_table.cache_clear  # type: ignore[attr-defined]


@dataclass(frozen=True, eq=False)
class StereoCalibration:
    """A calibrated camera-projector pair: both lenses and the rigid motion between them.

    Parameters
    ----------
    camera, projector : LensModel
        The camera and the projector (as an inverse camera; its ``size`` is the pattern size).
    rotation : array_like, shape (3, 3)
        ``R`` of ``X_proj = R @ X_cam + t``: a rotation (orthonormal, det +1, within 1e-6).
    translation_mm : array_like, shape (3,)
        ``t`` of the same equation, mm. The camera frame is the world frame.
    reprojection_px : mapping of str to float, optional
        RMS reprojection errors of the calibration by name (e.g. ``"camera"``, ``"projector"``,
        ``"stereo"``), pixels, when known.
    source : str
        Where the calibration came from (a file, a tool), for reports.

    References
    ----------
    Zhang & Huang 2006 (Opt. Eng. 45:083601): the projector as an inverse camera. The thesis's
    own calibration is the phase-to-height map (Sec. 2.5, :mod:`hdrfringe.core.calibration`).

    Examples
    --------
    >>> cam = LensModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], [], (640, 480))
    >>> proj = LensModel([[1500, 0, 456], [0, 1500, 570], [0, 0, 1]], [], (912, 1140))
    >>> calib = StereoCalibration(cam, proj, np.eye(3), [-200.0, 0.0, 0.0])
    >>> calib.baseline_mm, calib.projector_center_mm.tolist()
    (200.0, [200.0, 0.0, 0.0])
    """

    camera: LensModel
    projector: LensModel
    rotation: F64
    translation_mm: F64
    reprojection_px: Mapping[str, float] | None = None
    source: str = ""

    def __post_init__(self) -> None:
        for name in ("camera", "projector"):
            if not isinstance(getattr(self, name), LensModel):
                raise InputError(f"stereo calibration: {name} must be a LensModel")
        r = _finite_array(self.rotation, "stereo rotation R", (3, 3))
        if np.abs(r @ r.T - np.eye(3)).max() > 1e-6 or abs(np.linalg.det(r) - 1.0) > 1e-6:
            raise InputError(
                "stereo rotation R: not a rotation (R @ R.T != I or det != +1 within 1e-6); "
                "give an orthonormal matrix with determinant +1"
            )
        t = _finite_array(self.translation_mm, "stereo translation T", (3,))
        if not np.linalg.norm(t) > 0:
            raise InputError("stereo translation T: zero baseline; the projector must be apart")
        errors: dict[str, float] = {}
        for key, value in dict(self.reprojection_px or {}).items():
            val = float(value)
            if not (np.isfinite(val) and val >= 0):
                raise InputError(f"reprojection error {key!r}: must be >= 0 px, got {value}")
            errors[str(key)] = val
        object.__setattr__(self, "rotation", r)
        object.__setattr__(self, "translation_mm", t)
        frozen = MappingProxyType(errors) if self.reprojection_px is not None else None
        object.__setattr__(self, "reprojection_px", frozen)
        object.__setattr__(self, "source", str(self.source))

    @property
    def projector_center_mm(self) -> F64:
        """The projector's centre of projection in the camera frame, ``-R.T @ t`` (mm)."""
        return np.asarray(-self.rotation.T @ self.translation_mm, dtype=np.float64)

    @property
    def baseline_mm(self) -> float:
        """Distance between the camera's and the projector's centres, mm."""
        return float(np.linalg.norm(self.translation_mm))

    def to_dict(self) -> dict[str, Any]:
        """Plain lists and numbers (for reports and JSON)."""
        return {
            "camera": self.camera.to_dict(),
            "projector": self.projector.to_dict(),
            "rotation": self.rotation.tolist(),
            "translation_mm": self.translation_mm.tolist(),
            "baseline_mm": self.baseline_mm,
            "reprojection_px": dict(self.reprojection_px or {}),
            "source": self.source,
        }

    #: The file's kind (:class:`~hdrfringe.core.calibration.MeasurementCalibration`).
    kind: ClassVar[str] = "stereo"
    #: What a measurement makes of the phase with it: triangulated points.
    output: ClassVar[str] = "points"

    def check_fits(
        self,
        spec: FringeSpec | None,
        image_shape: tuple[int, int],
        camera_bit_depth: int,
        *,
        source: str | None = None,
        projector_size: tuple[int, int] | None = None,
    ) -> None:
        """The camera image (and the projector, when known) are the calibrated sizes.

        Parameters
        ----------
        spec : FringeSpec or None
            Unused: any fringes triangulate.
        image_shape : (int, int)
            Camera image (height, width).
        camera_bit_depth : int
            Unused.
        source : str, optional
            Where the calibration came from, for the message.
        projector_size : (int, int), optional
            The projector (width, height) the captures record.

        Raises
        ------
        CalibrationMismatchError
            One line listing the sizes that differ (W x H).

        Examples
        --------
        >>> cam = LensModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], [], (640, 480))
        >>> proj = LensModel([[1500, 0, 456], [0, 1500, 570], [0, 0, 1]], [], (912, 1140))
        >>> calib = StereoCalibration(cam, proj, np.eye(3), [-200.0, 0.0, 0.0])
        >>> calib.check_fits(None, (480, 640), 8)
        >>> calib.check_fits(None, (480, 600), 8)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        hdrfringe.core.calibration.CalibrationMismatchError: stereo calibration does not fit ...
        """
        from hdrfringe.core.calibration import CalibrationMismatchError

        problems = []
        cam = (image_shape[1], image_shape[0])
        if self.camera.size != cam:
            problems.append(f"camera image {cam[0]}x{cam[1]} vs calibrated {self.camera.size}")
        if projector_size is not None and self.projector.size != projector_size:
            problems.append(
                f"projector {projector_size[0]}x{projector_size[1]} vs calibrated "
                f"{self.projector.size}"
            )
        if problems:
            where = f"{source}: " if source else ""
            raise CalibrationMismatchError(
                f"{where}stereo calibration does not fit this measurement: "
                f"{'; '.join(problems)} (W x H); use the calibration of this camera and projector"
            )

    def camera_geometry(self) -> CameraGeometry | None:
        """None: the points are triangulated, not placed from a height map.

        Returns
        -------
        None
        """
        return None

    def notes(self) -> tuple[str, ...]:
        """Nothing: the points are in mm in the camera frame.

        Returns
        -------
        tuple of str
        """
        return ()

    def height_model(self) -> Calibration | None:
        """None: the height std through triangulation is not modelled.

        Returns
        -------
        None
        """
        return None

    def uncertainty_notes(self) -> tuple[str, ...]:
        """:data:`HEIGHT_STD_NOTE`: only the phase std is predicted.

        Returns
        -------
        tuple of str
        """
        return (HEIGHT_STD_NOTE,)

    def projector_geometry(self) -> StereoCalibration:
        """The calibration itself: the projector-camera geometry (e.g. for epipolar rows).

        Returns
        -------
        StereoCalibration
        """
        return self


# --- triangulation ----------------------------------------------------------------------------


def projector_coordinate(absolute_phase: ArrayLike, pitch_px: float) -> F64:
    """Projector pixel coordinate of an absolute phase: ``x = p * Phi / (2*pi)``.

    Parameters
    ----------
    absolute_phase : array_like
        Absolute phase ``Phi`` (radians) of fringes of pitch ``pitch_px``, in hdrfringe's
        convention ``phi = 2*pi*x/p`` (:mod:`hdrfringe.core.patterns`).
    pitch_px : float
        Fringe pitch in projector pixels.

    Returns
    -------
    ndarray
        The projector column (vertical fringes) or row (horizontal fringes), pixel centres at
        integers (OpenCV's convention); NaN where the phase is NaN.

    Examples
    --------
    >>> projector_coordinate([0.0, np.pi, 2 * np.pi], 16.0).tolist()
    [0.0, 8.0, 16.0]
    """
    p = float(pitch_px)
    if not (np.isfinite(p) and p > 0):
        raise InputError(f"pitch must be a positive number of projector pixels, got {pitch_px}")
    return np.asarray(absolute_phase, dtype=np.float64) * (p / (2.0 * np.pi))


class Triangulation(NamedTuple):
    """Triangulated points of :func:`triangulate`.

    Parameters
    ----------
    xyz : ndarray, shape (..., 3)
        Points in the camera frame, mm; NaN where a pixel could not be triangulated.
    residual_mm : ndarray, shape (...)
        Distance between the camera ray and the projector ray, mm, where both projector
        coordinates were given; NaN otherwise.

    Examples
    --------
    >>> t = Triangulation(np.zeros((2, 3)), np.full(2, np.nan))
    >>> t.xyz.shape, t.residual_mm.shape
    ((2, 3), (2,))
    """

    xyz: F64
    residual_mm: F64


#: :func:`triangulate`'s defaults: the tolerance (px) and the Newton steps of one direction.
_TOLERANCE_PX = 1e-4
_MAX_ITERATIONS = 50
#: Pixels per block of a triangulation: bounds its temporaries (a few dozen arrays of a
#: block) whatever the image size, and keeps them in the CPU cache (blocks of 2**16 pixels
#: took longer on the kimthyung sphere).
_TRIANGULATE_BLOCK = 1 << 14
#: One direction: Newton's method along the epipolar line stops when the point's projector
#: coordinate is within this many pixels of the given one.
_SURFACE_STOP_PX = 1e-9


def triangulate(
    calibration: StereoCalibration,
    u_cam: ArrayLike,
    v_cam: ArrayLike,
    *,
    u_proj: ArrayLike | None = None,
    v_proj: ArrayLike | None = None,
    tolerance_px: float = 1e-4,
    max_iterations: int = 50,
) -> Triangulation:
    """3D points (camera frame, mm) of camera pixels from their projector coordinates.

    Parameters
    ----------
    calibration : StereoCalibration
        The projector-camera calibration.
    u_cam, v_cam : array_like
        Camera pixel coordinates (OpenCV convention), broadcast with the projector
        coordinates.
    u_proj, v_proj : array_like, optional
        Projector column (from vertical fringes) and/or row (from horizontal fringes), e.g.
        from :func:`projector_coordinate`; at least one. NaN marks an invalid pixel.
    tolerance_px : float
        One direction only: the point must project onto the given projector coordinate within
        this (pixels), else it is NaN.
    max_iterations : int
        One direction only: Newton steps at most (a few suffice with a calibrated lens).

    Returns
    -------
    Triangulation
        ``xyz`` of shape ``(..., 3)`` (NaN where invalid: a NaN input, a ray parallel to the
        plane, a point behind the camera or the projector, no convergence) and
        ``residual_mm`` (ray-ray distance; NaN unless both projector coordinates are given).

    Notes
    -----
    The camera ray of a pixel is ``X = lambda * (x, y, 1)`` with ``(x, y)`` its undistorted
    normalised coordinates.

    *Both coordinates*: the projector ray through the undistorted ``(u_proj, v_proj)`` starts
    at the projector centre ``C = -R.T t`` with direction ``R.T (x_p, y_p, 1)``; the point is
    the midpoint of the shortest segment between the two rays (the least-squares point of the
    two lines), and ``residual_mm`` its length.

    *One coordinate* (say ``u_proj``): with lens distortion, the projector pixels of one
    column do not map to a plane of rays but to a curved surface. The camera ray seen from
    the projector is a straight line in the projector's undistorted normalised plane (the
    epipolar line: the plane through both centres and the ray, normal ``t x R d``). The
    point of that line whose distorted projection has the column ``u_proj`` is found by
    Newton's method along the line (the distortion's analytic Jacobian), started where the
    line meets the column's pinhole line ``fx x + s y + cx = u_proj`` (without distortion the
    answer); it stops within 1e-9 px (typically a few steps), and the projector ray through
    that point meets the camera ray: the point lies on the camera ray and projects exactly
    onto ``u_proj``, not a linearisation. ``v_proj`` alone is the same with the roles
    swapped.

    References
    ----------
    Zhang & Huang 2006 (Opt. Eng. 45:083601): triangulation of a camera ray against the
    projector as an inverse camera; docs/stereo.md.

    Examples
    --------
    A distortion-free pair 200 mm apart and a point 500 mm in front of the camera:

    >>> cam = LensModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], [], (640, 480))
    >>> proj = LensModel([[1500, 0, 456], [0, 1500, 570], [0, 0, 1]], [], (912, 1140))
    >>> calib = StereoCalibration(cam, proj, np.eye(3), [-200.0, 0.0, 0.0])
    >>> point = np.array([10.0, 20.0, 500.0])
    >>> uc, vc = cam.project(point)
    >>> up, vp = proj.project(point + calib.translation_mm)
    >>> triangulate(calib, uc, vc, u_proj=up).xyz.round(9).tolist()
    [10.0, 20.0, 500.0]
    >>> res = triangulate(calib, uc, vc, u_proj=up, v_proj=vp)
    >>> res.xyz.round(9).tolist(), float(res.residual_mm) < 1e-9
    ([10.0, 20.0, 500.0], True)
    """
    if not isinstance(calibration, StereoCalibration):
        raise InputError("triangulate: calibration must be a StereoCalibration")
    if u_proj is None and v_proj is None:
        raise InputError("triangulate: give u_proj and/or v_proj (projector coordinates)")
    tol = float(tolerance_px)
    if not (np.isfinite(tol) and tol > 0):
        raise InputError(f"tolerance_px must be a positive number, got {tolerance_px}")
    if int(max_iterations) != max_iterations or max_iterations < 1:
        raise InputError(f"max_iterations must be an integer >= 1, got {max_iterations}")
    arrays = [np.asarray(u_cam, np.float64), np.asarray(v_cam, np.float64)]
    arrays += [np.asarray(a, np.float64) for a in (u_proj, v_proj) if a is not None]
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrays))
    except ValueError:
        raise InputError(
            "triangulate: camera and projector coordinates have shapes "
            f"{[a.shape for a in arrays]} that do not broadcast; give arrays of one shape"
        ) from None
    uc = np.broadcast_to(arrays[0], shape).reshape(-1)
    vc = np.broadcast_to(arrays[1], shape).reshape(-1)
    up = None if u_proj is None else np.broadcast_to(np.asarray(u_proj, np.float64), shape)
    vp = None if v_proj is None else np.broadcast_to(np.asarray(v_proj, np.float64), shape)

    xc, yc = calibration.camera.undistort(uc, vc)
    up_flat = None if up is None else up.reshape(-1)
    vp_flat = None if vp is None else vp.reshape(-1)
    xyz, residual = _triangulate_rays(
        calibration, xc, yc, up_flat, vp_flat, tol, int(max_iterations)
    )
    return Triangulation(xyz.reshape(*shape, 3), residual.reshape(shape))


def _triangulate_rays(
    calibration: StereoCalibration,
    xc: F64,
    yc: F64,
    up: F64 | None,
    vp: F64 | None,
    tolerance_px: float,
    max_iterations: int,
) -> tuple[F64, F64]:
    """:func:`triangulate` of flat camera rays ``(xc, yc, 1)`` (n,) and projector coordinates
    (n,), block by block over the pixels where every input is finite: ``xyz`` (n, 3) and the
    ray-ray residual (n,), NaN elsewhere."""
    n = xc.shape[0]
    xyz = np.full((n, 3), np.nan)
    residual = np.full(n, np.nan)
    for start in range(0, n, _TRIANGULATE_BLOCK):
        part = slice(start, start + _TRIANGULATE_BLOCK)
        coords = [c[part] for c in (up, vp) if c is not None]
        ok = np.isfinite(xc[part]) & np.isfinite(yc[part])
        for c in coords:
            ok &= np.isfinite(c)
        sel = np.flatnonzero(ok) + start
        if sel.size == 0:
            continue
        ray = np.stack([xc[sel], yc[sel], np.ones(sel.size)], axis=-1)
        if up is not None and vp is not None:
            xyz[sel], residual[sel] = _ray_ray(calibration, ray, up[sel], vp[sel])
        else:
            axis = 0 if up is not None else 1
            known = (up if up is not None else vp)[sel]  # type: ignore[index]
            xyz[sel] = _ray_surface(calibration, ray, known, axis, tolerance_px, max_iterations)
    return xyz, residual


def _to_projector(calibration: StereoCalibration, xyz: F64) -> F64:
    """Camera-frame points (n, 3) in the projector frame."""
    return np.asarray(xyz @ calibration.rotation.T + calibration.translation_mm)


def _ray_ray(calibration: StereoCalibration, ray: F64, up: F64, vp: F64) -> tuple[F64, F64]:
    """Midpoint and length of the shortest segment between camera and projector rays."""
    r = calibration.rotation
    xp, yp = calibration.projector.undistort(up, vp)
    dp = np.stack([xp, yp, np.ones_like(xp)], axis=-1) @ r  # R.T @ d for each row
    c = calibration.projector_center_mm
    # camera line a*d, projector line c + b*e: minimise |a d - c - b e|^2
    dd = np.einsum("ij,ij->i", ray, ray)
    ee = np.einsum("ij,ij->i", dp, dp)
    de = np.einsum("ij,ij->i", ray, dp)
    dc = ray @ c
    ec = dp @ c
    det = dd * ee - de * de
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (dc * ee - de * ec) / det
        b = (de * dc - dd * ec) / det
    p_cam = a[:, None] * ray
    p_proj = c + b[:, None] * dp
    xyz = 0.5 * (p_cam + p_proj)
    residual = np.linalg.norm(p_cam - p_proj, axis=-1)
    bad = ~((a > 0) & (b > 0) & (det > 1e-12 * dd * ee))
    xyz[bad] = np.nan
    residual[bad] = np.nan
    return xyz, residual


def _ray_surface(
    calibration: StereoCalibration,
    ray: F64,
    known: F64,
    axis: int,
    tolerance_px: float,
    max_iterations: int,
) -> F64:
    """Camera rays (n, 3) against the (curved) projector surface of one projector coordinate
    (:func:`triangulate`, "one coordinate"): points (n, 3), NaN where there is none.

    ``axis`` 0: ``known`` is the projector column; 1: the row.
    """
    proj = calibration.projector
    k, d8 = proj.matrix, _coefficients8(proj.distortion)
    t = calibration.translation_mm
    a = ray @ calibration.rotation.T  # the camera rays' directions in the projector frame
    # the epipolar plane through both centres and the ray; its line m . (x, y, 1) = 0
    m = np.cross(t, a)
    # the known coordinate's pinhole line q . (x, y, 1) = 0 and where the two meet
    q = np.zeros_like(a)
    if axis == 0:
        q[:, 0], q[:, 1], q[:, 2] = k[0, 0], k[0, 1], k[0, 2] - known
    else:
        q[:, 1], q[:, 2] = k[1, 1], k[1, 2] - known
    with np.errstate(divide="ignore", invalid="ignore"):
        meet = np.cross(m, q)
        x0, y0 = meet[:, 0] / meet[:, 2], meet[:, 1] / meet[:, 2]
        length = np.hypot(m[:, 0], m[:, 1])
        ex, ey = m[:, 1] / length, -m[:, 0] / length  # the line's unit direction
        s, g = _surface_newton(k, d8, axis, known, x0, y0, ex, ey, max_iterations)
        b = np.stack([x0 + s * ex, y0 + s * ey, np.ones_like(s)], axis=-1)  # projector ray
        # lambda a + t = mu b (coplanar lines): lambda (a x b) = -(t x b)
        ab = np.cross(a, b)
        sin2 = np.einsum("ij,ij->i", ab, ab)  # |a|^2 |b|^2 sin^2 of the rays' angle
        lam = -np.einsum("ij,ij->i", np.cross(t, b), ab) / sin2
        depth = lam * a[:, 2] + t[2]  # mu: in front of the projector
        # (nearly) parallel rays, as in _ray_ray: no point
        apart = sin2 > 1e-12 * np.einsum("ij,ij->i", a, a) * np.einsum("ij,ij->i", b, b)
    xyz = lam[:, None] * ray
    xyz[~((np.abs(g) < tolerance_px) & (lam > 0) & (depth > 0) & apart)] = np.nan
    return xyz


def _surface_newton(
    k: F64,
    d8: tuple[float, ...],
    axis: int,
    known: F64,
    x0: F64,
    y0: F64,
    ex: F64,
    ey: F64,
    max_iterations: int,
) -> tuple[F64, F64]:
    """Newton's method for the step ``s`` along the line ``(x0, y0) + s (ex, ey)`` (projector
    normalised coordinates) whose distorted pixel coordinate ``axis`` is ``known``: ``s`` and
    the remaining miss (px; NaN where it failed)."""
    s = np.zeros_like(x0)
    miss = np.full_like(x0, np.nan)
    act = np.flatnonzero(np.isfinite(x0) & np.isfinite(y0) & np.isfinite(ex))
    for step in range(max_iterations + 1):
        sa = s[act]
        xd, yd, jxx, jxy, jyy = _distort(x0[act] + sa * ex[act], y0[act] + sa * ey[act], d8,
                                         jacobian=True)  # fmt: skip
        dx = jxx * ex[act] + jxy * ey[act]  # d(xd, yd) / ds
        dy = jxy * ex[act] + jyy * ey[act]
        if axis == 0:
            g = k[0, 0] * xd + k[0, 1] * yd + k[0, 2] - known[act]
            slope = k[0, 0] * dx + k[0, 1] * dy
        else:
            g = k[1, 1] * yd + k[1, 2] - known[act]
            slope = k[1, 1] * dy
        miss[act] = g
        more = ~(np.abs(g) < _SURFACE_STOP_PX)
        if step == max_iterations or not more.any():
            break
        act, g, slope, sa = act[more], g[more], slope[more], sa[more]
        s[act] = sa - g / slope
    return s, miss


# --- shape fits -------------------------------------------------------------------------------


def _finite_points(xyz: ArrayLike, name: str, minimum: int) -> tuple[F64, NDArray[np.bool_]]:
    """(n, 3) finite points of ``xyz`` (shape (..., 3)) and the mask of them over ``...``."""
    pts = np.asarray(xyz, dtype=np.float64)
    if pts.ndim < 1 or pts.shape[-1] != 3:
        raise InputError(f"{name}: points of shape {pts.shape}; give an array of shape (..., 3)")
    valid = np.all(np.isfinite(pts), axis=-1)
    if int(valid.sum()) < minimum:
        raise InputError(
            f"{name}: {int(valid.sum())} finite points, at least {minimum} needed; "
            "check the triangulation's valid pixels"
        )
    return pts[valid], valid


class PlaneFit(NamedTuple):
    """A plane ``normal . x = offset`` fitted by :func:`fit_plane`.

    Parameters
    ----------
    normal : ndarray, shape (3,)
        Unit normal, oriented toward the camera (the origin): ``offset <= 0``.
    offset : float
        ``normal . x`` on the plane, mm (minus the origin's distance to the plane).
    residuals : ndarray, shape (...)
        Signed distance of every point to the plane, ``normal . x - offset``, mm (positive
        toward the camera); NaN for non-finite points only (outliers keep their residual).
    inliers : ndarray of bool, shape (...)
        The points the final fit used.

    Examples
    --------
    >>> fit = fit_plane([[0, 0, 10.0], [1, 0, 10.0], [0, 1, 10.0], [1, 1, 10.0]])
    >>> fit.normal.tolist(), fit.offset, fit.rms_mm
    ([0.0, 0.0, -1.0], -10.0, 0.0)
    """

    normal: F64
    offset: float
    residuals: F64
    inliers: NDArray[np.bool_]

    @property
    def rms_mm(self) -> float:
        """RMS of the residuals of the inliers, mm."""
        return float(np.sqrt(np.mean(self.residuals[self.inliers] ** 2)))


def _plane_moments(pts: np.ndarray, use: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroid, total-least-squares normal and singular values of the points ``pts[use]``.

    The normal is the eigenvector of the 3 x 3 scatter matrix of the centred points with the
    smallest eigenvalue, the singular values the square roots of its eigenvalues (descending):
    the right singular vectors of the (N, 3) centred matrix without its SVD, which at a
    camera's millions of points costs most of a plane fit. The points are centred on a first
    centroid before the scatter is summed, so that a plane hundreds of mm from the origin keeps
    its digits (the scatter of uncentred points would cancel them). The eigenvalues square the
    singular values' ratio, so near a line (second singular value below 1e-6 of the first) the
    SVD decides, which resolves that ratio down to the 1e-12 that :func:`fit_plane` calls
    collinear.
    """
    sel = pts[use]
    centroid = sel.mean(axis=0)
    sel -= centroid
    evals, evecs = np.linalg.eigh(sel.T @ sel)
    sing = np.sqrt(np.clip(evals[::-1], 0.0, None))
    if sing[1] <= 1e-6 * sing[0]:
        _, sing, vt = np.linalg.svd(sel, full_matrices=False)
        return centroid, vt[2], sing
    return centroid, evecs[:, 0].copy(), sing


def fit_plane(
    xyz: ArrayLike,
    *,
    robust: bool = False,
    max_rounds: int = 10,
    initial: ArrayLike | None = None,
) -> PlaneFit:
    """Least-squares plane through points (orthogonal distances).

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        Points, mm; non-finite rows are ignored.
    robust : bool
        False: one fit through every finite point. True: refit on the points whose residual
        is within 3 robust standard deviations (``1.4826 * MAD``, at least 1e-6 mm) of the
        median residual, until the set stops changing (at most ``max_rounds`` rounds): the
        plane of the majority, e.g. the background around an object.
    max_rounds : int
        Refits at most, with ``robust``.
    initial : array_like of bool, shape (...), optional
        The points of the first fit (default: every finite point), e.g. the inliers of a
        RANSAC hypothesis (:func:`fit_dominant_plane`); the robust refits start from there.

    Returns
    -------
    PlaneFit
        ``normal`` (unit, toward the origin), ``offset``, ``residuals`` (signed distances,
        shape ``xyz.shape[:-1]``, NaN for non-finite points), ``inliers``.

    Notes
    -----
    The plane minimising the sum of squared orthogonal distances passes through the centroid,
    and its normal is the right singular vector of the centred points with the smallest
    singular value (total least squares).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(-50, 50, (500, 2))
    >>> pts = np.c_[xy, 800 + 0.1 * xy[:, 0]]
    >>> pts[:20, 2] += 30  # an object on the plane
    >>> round(fit_plane(pts, robust=True).rms_mm, 9)
    0.0
    >>> fit_plane(pts).rms_mm > 1
    True
    """
    if int(max_rounds) != max_rounds or max_rounds < 1:
        raise InputError(f"max_rounds must be an integer >= 1, got {max_rounds}")
    pts, valid = _finite_points(xyz, "plane fit", 3)
    use = np.ones(pts.shape[0], dtype=bool)
    if initial is not None:
        start = np.asarray(initial, dtype=bool)
        if start.shape != valid.shape:
            raise InputError(
                f"plane fit: initial mask of shape {start.shape} for points of shape "
                f"{valid.shape}; give one flag per point"
            )
        use = start[valid]
        if int(use.sum()) < 3:
            raise InputError("plane fit: fewer than 3 finite points in the initial set")
    for _ in range(int(max_rounds) if robust else 1):
        centroid, normal, sing = _plane_moments(pts, use)
        if sing[1] <= 1e-12 * max(sing[0], 1e-300):
            raise InputError("plane fit: the points are collinear; no plane is defined")
        offset = float(normal @ centroid)
        if offset > 0:
            normal, offset = -normal, -offset
        dist = pts @ normal - offset
        if not robust:
            break
        centre = float(np.median(dist[use]))
        mad = float(np.median(np.abs(dist[use] - centre)))
        keep = np.abs(dist - centre) <= max(3.0 * 1.4826 * mad, 1e-6)
        if keep.sum() < 3 or np.array_equal(keep, use):
            break
        use = keep
    residuals = np.full(valid.shape, np.nan)
    residuals[valid] = dist
    inliers = np.zeros(valid.shape, dtype=bool)
    inliers[valid] = use
    return PlaneFit(normal + 0.0, offset + 0.0, residuals, inliers)


#: :func:`fit_dominant_plane`: random plane hypotheses, points scoring them, the quantile scored.
RANSAC_HYPOTHESES = 500
RANSAC_SAMPLE = 5000
RANSAC_QUANTILE = 0.3


def fit_dominant_plane(
    xyz: ArrayLike,
    *,
    quantile: float = RANSAC_QUANTILE,
    hypotheses: int = RANSAC_HYPOTHESES,
    sample: int = RANSAC_SAMPLE,
    seed: int = 0,
) -> PlaneFit:
    """The dominant plane of a point cloud: RANSAC, then the robust least-squares refits.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        Points, mm; non-finite rows are ignored.
    quantile : float
        A hypothesis scores the ``quantile`` of its points' absolute distances (least
        quantile of distances, LMedS at 0.5): the dominant plane must hold at least this
        fraction of the finite points.
    hypotheses : int
        Planes through three random points tried.
    sample : int
        Points (a fixed random subset) that score the hypotheses.
    seed : int
        Seed of the random choices (the result is deterministic).

    Returns
    -------
    PlaneFit
        :func:`fit_plane` with ``robust=True``, started from the points of the best hypothesis
        within its score (the closest ``quantile`` of them); ``inliers`` is the final set.

    Notes
    -----
    A least-squares plane, even refitted on the points within 3 MADs of it, starts from every
    point: when an object fills much of the view, the first plane runs through the object's
    bulk, tilted, and the MAD band around it keeps everything. Scoring random 3-point planes
    by a low quantile of the distances (Rousseeuw 1984, least median of squares; Fischler and
    Bolles 1981, RANSAC) needs no distance threshold: only a plane that carries a
    ``quantile`` of the points close to it scores low. The refits then grow the seed set to
    the plane's 3-MAD band. Every hypothesis is scored at once (a ``hypotheses x sample``
    distance matrix).

    Examples
    --------
    A plane at 800 mm, a third of its points under a hemisphere of radius 70 mm:

    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(-100, 100, (4000, 2))
    >>> z = 800 - np.sqrt(np.clip(70**2 - (xy**2).sum(axis=1), 0, None))
    >>> fit = fit_dominant_plane(np.c_[xy, z])
    >>> np.round(fit.normal, 9).tolist(), round(fit.offset, 9), round(fit.rms_mm, 9)
    ([0.0, 0.0, -1.0], -800.0, 0.0)
    """
    q = float(quantile)
    if not 0 < q <= 1:
        raise InputError(f"quantile must be in (0, 1], got {quantile}")
    for name, value in (("hypotheses", hypotheses), ("sample", sample)):
        if int(value) != value or value < 1:
            raise InputError(f"{name} must be an integer >= 1, got {value}")
    pts, valid = _finite_points(xyz, "plane fit", 3)
    rng = np.random.default_rng(seed)
    centre = pts.mean(axis=0)
    local = pts - centre  # conditioning
    scoring = local[rng.choice(len(local), min(int(sample), len(local)), replace=False)]
    tri = local[rng.integers(0, len(local), (int(hypotheses), 3))]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(normals, axis=1)
    ok = norm > 1e-9 * max(float(np.abs(local).max()), 1e-300) ** 2
    if not ok.any():
        raise InputError("plane fit: the points are collinear; no plane is defined")
    normals, tri = normals[ok] / norm[ok, None], tri[ok]
    offsets = np.einsum("ij,ij->i", normals, tri[:, 0])
    dist = np.abs(scoring @ normals.T - offsets)  # (sample, hypotheses)
    score = np.quantile(dist, q, axis=0)
    best = int(np.argmin(score))
    seed_set = np.abs(local @ normals[best] - offsets[best]) <= score[best]
    initial = np.zeros(valid.shape, dtype=bool)
    initial[valid] = seed_set
    return fit_plane(xyz, robust=True, initial=initial)


class SphereFit(NamedTuple):
    """A sphere fitted by :func:`fit_sphere`.

    Parameters
    ----------
    centre : ndarray, shape (3,)
        Centre, mm.
    radius : float
        Radius, mm.
    residuals : ndarray, shape (...)
        Signed distance of every point to the sphere, ``|x - centre| - radius``, mm (positive
        outside); NaN for non-finite points.

    Examples
    --------
    >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
    >>> fit = fit_sphere(5.0 * d + [0, 0, 700.0])
    >>> fit.centre.round(9).tolist(), round(fit.radius, 9), fit.rms_mm < 1e-9
    ([0.0, 0.0, 700.0], 5.0, True)
    """

    centre: F64
    radius: float
    residuals: F64

    @property
    def rms_mm(self) -> float:
        """RMS of the finite residuals, mm."""
        r = self.residuals[np.isfinite(self.residuals)]
        return float(np.sqrt(np.mean(r**2)))


def fit_sphere(xyz: ArrayLike) -> SphereFit:
    """Least-squares sphere through points (geometric distances).

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        Points, mm; non-finite rows are ignored; at least 4 not on one plane.

    Returns
    -------
    SphereFit
        ``centre``, ``radius`` and the signed ``residuals`` (shape ``xyz.shape[:-1]``).

    Notes
    -----
    Start: the algebraic fit, linear in ``(c, k)`` from ``|x|^2 = 2 c . x + k`` with
    ``k = r^2 - |c|^2``; then ``scipy.optimize.least_squares`` minimises the sum of squared
    geometric residuals ``|x - c| - r`` (the maximum-likelihood fit for noise along the
    surface normal).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> d = rng.normal(size=(400, 3))
    >>> d[:, 2] = -np.abs(d[:, 2])  # the half facing a camera at the origin
    >>> d /= np.linalg.norm(d, axis=1, keepdims=True)
    >>> fit = fit_sphere(12.5 * d + [3.0, -4.0, 650.0])
    >>> fit.centre.round(6).tolist(), round(fit.radius, 6)
    ([3.0, -4.0, 650.0], 12.5)
    """
    from scipy.optimize import least_squares

    pts, valid = _finite_points(xyz, "sphere fit", 4)
    shift = pts.mean(axis=0)
    p = pts - shift  # conditioning: centred coordinates
    a = np.c_[2.0 * p, np.ones(p.shape[0])]
    sol, _, rank, _ = np.linalg.lstsq(a, np.einsum("ij,ij->i", p, p), rcond=None)
    if rank < 4:
        raise InputError("sphere fit: the points lie on one plane; no sphere is defined")
    c0 = sol[:3]
    r0 = float(np.sqrt(max(sol[3] + c0 @ c0, 0.0)))

    def distances(params: F64) -> F64:
        return np.asarray(np.linalg.norm(p - params[:3], axis=1) - params[3])

    fit = least_squares(distances, np.r_[c0, r0], method="lm", xtol=1e-15, ftol=1e-15)
    centre = np.asarray(fit.x[:3] + shift, dtype=np.float64)
    radius = float(abs(fit.x[3]))
    residuals = np.full(valid.shape, np.nan)
    residuals[valid] = np.linalg.norm(pts - centre, axis=1) - radius
    return SphereFit(centre, radius, residuals)


# --- whole images -----------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class StereoMaps:
    """A camera image triangulated pixel by pixel (:func:`triangulate_maps`).

    Parameters
    ----------
    xyz : ndarray, shape (H, W, 3)
        Organised point cloud in the camera frame, mm; NaN where invalid.
    residual_mm : ndarray, shape (H, W), or None
        Camera-ray to projector-ray distance where both projector coordinates were decoded;
        None when only one was.
    plane : PlaneFit or None
        The reference plane: :func:`fit_dominant_plane` of the valid points; None with fewer
        than 3 valid points or collinear ones.
    directions : tuple of str
        The projector coordinates used: ``("u",)``, ``("v",)`` or ``("u", "v")``.
    quality : ndarray, shape (H, W), or None
        A per-pixel quality carried to the point cloud (the measurement puts the data
        modulation there, in camera DN).

    Examples
    --------
    >>> maps = StereoMaps(np.zeros((2, 2, 3)), None, None, ("u",))
    >>> maps.depth_mm.shape, bool(maps.valid.all())
    ((2, 2), True)
    """

    xyz: F64
    residual_mm: F64 | None
    plane: PlaneFit | None
    directions: tuple[str, ...]
    quality: F64 | None = None

    @property
    def valid(self) -> NDArray[np.bool_]:
        """Pixels with a point."""
        return np.asarray(np.all(np.isfinite(self.xyz), axis=-1))

    @property
    def depth_mm(self) -> F64:
        """``Z`` of every pixel's point (camera frame), mm; NaN where invalid."""
        return np.asarray(self.xyz[..., 2])

    @property
    def height_mm(self) -> F64:
        """Signed distance to the reference plane, positive toward the camera, mm."""
        if self.plane is None:
            return np.full(self.xyz.shape[:-1], np.nan)
        return self.plane.residuals

    def summary(self) -> dict[str, Any]:
        """Figures for ``metrics.json``: counts, depth range, the plane, the residual.

        Returns
        -------
        dict
            JSON-friendly numbers (NaN where nothing is valid).
        """
        valid = self.valid
        depth = self.depth_mm[valid]
        out: dict[str, Any] = {
            "directions": "+".join(self.directions),
            "n_points": int(valid.sum()),
            "valid_fraction": float(valid.mean()),
            "depth_mm": {
                "min": float(depth.min()) if depth.size else float("nan"),
                "median": float(np.median(depth)) if depth.size else float("nan"),
                "max": float(depth.max()) if depth.size else float("nan"),
            },
        }
        if self.plane is not None:
            heights = self.plane.residuals[valid]
            out["reference_plane"] = {
                "fit": f"dominant plane: RANSAC (least {RANSAC_QUANTILE:g}-quantile of "
                "distances), then total least squares with 3 x 1.4826 MAD refits",
                "normal": self.plane.normal.tolist(),
                "offset_mm": self.plane.offset,
                "inlier_fraction": float(self.plane.inliers[valid].mean()),
                "rms_mm": self.plane.rms_mm,
                "height_mm": {
                    "p01": float(np.percentile(heights, 1)),
                    "median": float(np.median(heights)),
                    "p99": float(np.percentile(heights, 99)),
                },
            }
        if self.residual_mm is not None:
            r = self.residual_mm[np.isfinite(self.residual_mm)]
            out["triangulation_residual_mm"] = {
                "median": float(np.median(r)) if r.size else float("nan"),
                "p95": float(np.percentile(r, 95)) if r.size else float("nan"),
                "rms": float(np.sqrt(np.mean(r**2))) if r.size else float("nan"),
                "max": float(r.max()) if r.size else float("nan"),
            }
        return out


def triangulate_maps(
    calibration: StereoCalibration,
    *,
    u_proj: ArrayLike | None = None,
    v_proj: ArrayLike | None = None,
) -> StereoMaps:
    """Triangulate every pixel of a camera image from projector-coordinate maps.

    Parameters
    ----------
    calibration : StereoCalibration
        The projector-camera calibration; its camera size must be the maps' size.
    u_proj, v_proj : array_like, shape (H, W), optional
        Projector column (vertical fringes) and/or row (horizontal fringes) seen by each camera
        pixel (:func:`projector_coordinate` of the absolute phase); NaN where invalid.

    Returns
    -------
    StereoMaps
        The organised point cloud, the ray-ray residual (both maps given), and the reference
        plane fitted to the valid points.

    Notes
    -----
    Pixel ``(row, col)`` is the camera point ``u = col, v = row`` (pixel centres at integers,
    OpenCV's convention); see :func:`triangulate` for the geometry.

    Examples
    --------
    A flat wall 600 mm in front of a distortion-free pair:

    >>> cam = LensModel([[400, 0, 15.5], [0, 400, 11.5], [0, 0, 1]], [], (32, 24))
    >>> proj = LensModel([[800, 0, 50], [0, 800, 40], [0, 0, 1]], [], (100, 80))
    >>> calib = StereoCalibration(cam, proj, np.eye(3), [-100.0, 0, 0])
    >>> rows, cols = np.mgrid[0:24, 0:32]
    >>> x = (cols - 15.5) / 400 * 600  # where each camera ray meets the wall
    >>> u = 800 * (x - 100) / 600 + 50  # the projector column lighting that point
    >>> maps = triangulate_maps(calib, u_proj=u)
    >>> float(np.nanmax(np.abs(maps.depth_mm - 600))) < 1e-9, round(maps.plane.rms_mm, 9)
    (True, 0.0)
    """
    if not isinstance(calibration, StereoCalibration):
        raise InputError("triangulate_maps: calibration must be a StereoCalibration")
    maps = {
        k: None if a is None else np.asarray(a, np.float64)
        for k, a in (("u", u_proj), ("v", v_proj))
    }
    given = [k for k, a in maps.items() if a is not None]
    if not given:
        raise InputError("triangulate_maps: give u_proj and/or v_proj maps")
    width, height = calibration.camera.size
    for key in given:
        arr = maps[key]
        assert arr is not None
        if arr.shape != (height, width):
            raise InputError(
                f"{key}_proj map: shape {arr.shape}, but the calibration's camera is "
                f"{width}x{height} (W x H); give maps of the calibrated camera's size"
            )
    rays = ray_table(calibration.camera)  # undistorted once per calibration (cached)
    up, vp = (None if (a := maps[k]) is None else a.reshape(-1) for k in ("u", "v"))
    xyz, residual_mm = _triangulate_rays(
        calibration, rays[0].reshape(-1), rays[1].reshape(-1), up, vp, _TOLERANCE_PX,
        _MAX_ITERATIONS,
    )  # fmt: skip
    tri = Triangulation(xyz.reshape(height, width, 3), residual_mm.reshape(height, width))
    valid = np.all(np.isfinite(tri.xyz), axis=-1)
    plane = None
    if valid.sum() >= 3:
        try:
            plane = fit_dominant_plane(tri.xyz)
        except InputError:  # collinear points: no reference plane
            plane = None
    residual = tri.residual_mm if len(given) == 2 else None
    return StereoMaps(tri.xyz, residual, plane, tuple(given))


# --- which projector coordinates to trust ------------------------------------------------------

#: :func:`check_directions`: "far above" the phase noise: the median normalised miss (about 1
#: for noise alone) beyond this many times.
DIRECTION_CHECK_FACTOR = 10.0
#: :func:`check_directions`: one direction is blamed when explaining the miss by the other
#: would need at least this many times the error (each in units of its predicted std).
DIRECTION_BLAME_RATIO = 3.0
#: :func:`check_directions`: pixels checked at most (a regular subsample of the image).
DIRECTION_CHECK_POINTS = 20000
#: :func:`check_directions`: the least std of a projector coordinate, px (ten times the
#: one-direction triangulation's tolerance): noise-free synthetic fringes predict ~1e-10 px.
DIRECTION_SIGMA_FLOOR_PX = 1e-3
#: Median of |z| for a standard normal z: a median of normalised errors over this is about 1.
_MEDIAN_ABS_NORMAL = 0.6744897501960817


class DirectionCheck(NamedTuple):
    """Whether the two projector coordinates agree with each other (:func:`check_directions`).

    Parameters
    ----------
    directions : tuple of str
        The projector coordinates to triangulate with: ``("u", "v")``, ``("u",)`` or
        ``("v",)``.
    verdict : str
        ``"consistent"`` (u+v kept), ``"u dropped"``, ``"v dropped"``, ``"suspect"`` (far
        above the noise and neither direction explains it alone: u+v kept, the calibration
        named as suspect) or ``"unchecked"`` (too few pixels, or no pair of rays to compare).
    n_pixels : int
        Pixels checked.
    sigma_px : dict
        Median std of ``u`` and ``v`` the check used, projector px (the phase noise and the
        calibration's reprojection error in quadrature, at least
        :data:`DIRECTION_SIGMA_FLOOR_PX`).
    sigma_source : str
        Where the phase noise came from.
    miss_px : float
        Median distance, projector px, of the decoded ``(u, v)`` from the camera pixel's
        epipolar line (what the ray-ray residual is in the projector image).
    miss_ratio : float
        ``median(|miss| / predicted std of the miss) / 0.6745``: about 1 when the noise
        explains the miss.
    disagreement_mm : float
        Median distance between the ``u``-only and the ``v``-only point of a pixel, mm (NaN
        when too few pixels have both).
    disagreement_ratio : float
        The same normalised by the std the phase noise predicts for it (about 1 for noise).
    error_needed_px : dict
        Median error of ``u`` alone, or of ``v`` alone, that would put the decoded point on
        the epipolar line, projector px.
    error_needed_sigma : dict
        The same in units of that coordinate's std.
    reason : str
        One line: which directions and why.

    Examples
    --------
    >>> c = DirectionCheck(("u", "v"), "unchecked", 0, {}, "", *([float("nan")] * 4), {}, {},
    ...                    "too few pixels")
    >>> c.to_dict()["verdict"]
    'unchecked'
    """

    directions: tuple[str, ...]
    verdict: str
    n_pixels: int
    sigma_px: dict[str, float]
    sigma_source: str
    miss_px: float
    miss_ratio: float
    disagreement_mm: float
    disagreement_ratio: float
    error_needed_px: dict[str, float]
    error_needed_sigma: dict[str, float]
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly fields (``metrics.json``'s ``stereo.direction_check``).

        Returns
        -------
        dict
            Every field, ``directions`` joined by ``+``; NaN as None.
        """

        def num(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        out = self._asdict()
        out["directions"] = "+".join(self.directions)
        for key in ("miss_px", "miss_ratio", "disagreement_mm", "disagreement_ratio"):
            out[key] = num(out[key])
        for key in ("sigma_px", "error_needed_px", "error_needed_sigma"):
            out[key] = {k: num(v) for k, v in out[key].items()}
        out["thresholds"] = {"factor": DIRECTION_CHECK_FACTOR, "blame_ratio": DIRECTION_BLAME_RATIO}
        return out


def coordinate_noise_px(coordinate: ArrayLike) -> float:
    """Random noise of a projector-coordinate map estimated from its pixel-to-pixel roughness.

    Parameters
    ----------
    coordinate : array_like, shape (H, W)
        Projector column or row map, px; NaN where invalid.

    Returns
    -------
    float
        ``1.4826 * MAD(d2) / sqrt(6)`` of the second differences ``d2`` along the image axis
        where it is smaller (for white noise of std ``s``, ``var(d2) = 6 s^2``; a smooth
        surface adds little); NaN without three valid pixels in a line. Systematic errors that
        vary from pixel to pixel (a fringe-harmonic ripple) count as noise.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ramp = np.add.outer(np.arange(200.0), 0.5 * np.arange(300.0))
    >>> round(coordinate_noise_px(ramp + rng.normal(0, 0.1, ramp.shape)), 2)
    0.1
    """
    c = np.asarray(coordinate, dtype=np.float64)
    if c.ndim != 2:
        raise InputError(f"coordinate map must be 2-D, got shape {c.shape}")
    best = np.nan
    for axis in (0, 1):
        if c.shape[axis] < 3:
            continue
        d2 = np.diff(c, 2, axis=axis)
        d2 = d2[np.isfinite(d2)]
        if d2.size:
            s = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6.0)
            best = s if not np.isfinite(best) else min(best, s)
    return float(best)


def _median(values: F64) -> float:
    v = values[np.isfinite(values)]
    return float(np.median(v)) if v.size else float("nan")


def check_directions(
    calibration: StereoCalibration,
    u_proj: ArrayLike,
    v_proj: ArrayLike,
    sigma_u: ArrayLike,
    sigma_v: ArrayLike,
    *,
    sigma_source: str = "given",
    max_points: int = DIRECTION_CHECK_POINTS,
) -> DirectionCheck:
    """Do the projector column and row of each pixel agree, within the phase noise?

    Parameters
    ----------
    calibration : StereoCalibration
        The projector-camera calibration (camera size = the maps' size).
    u_proj, v_proj : array_like, shape (H, W)
        Projector column and row maps (:func:`projector_coordinate`), NaN where invalid.
    sigma_u, sigma_v : array_like, broadcast to (H, W)
        Their predicted std, projector px (e.g. the phase std of
        :func:`hdrfringe.core.uncertainty.predict_uncertainty` times ``pitch / (2 pi)``).
    sigma_source : str
        Where the std came from (recorded).
    max_points : int
        Pixels checked at most: a regular subsample of the valid ones.

    Returns
    -------
    DirectionCheck

    Notes
    -----
    For each checked pixel (every ``s``-th row and column):

    * *the miss*: the camera ray at the ray-ray point's depth (+-2 %) projected into the
      projector gives the pixel's epipolar line; the decoded ``(u, v)`` lies a signed distance
      ``m`` (px) from it, along the line's unit normal ``(n_u, n_v)``. The noise predicts
      ``std(m) = hypot(s_u n_u, s_v n_v)``, with ``s_u, s_v`` the coordinates' std and the
      calibration's reprojection error (``reprojection_px``: ``stereo``, else ``projector``)
      in quadrature. ``miss_ratio`` is the median of ``|m| / std(m)`` over 0.6745.
    * *the disagreement*: the ``u``-only and the ``v``-only points (:func:`triangulate`); their
      distance against ``hypot(S_u s_u, S_v s_v)``, ``S`` the distance a point moves for one
      px of its coordinate (triangulated again at ``+1`` px).

    When either ratio exceeds :data:`DIRECTION_CHECK_FACTOR`, the directions are not
    consistent. One pixel's miss is one number: an error of ``m / n_u`` px in ``u`` or of
    ``m / n_v`` px in ``v`` explains it, not both, and which one cannot be told from that pixel
    (the two points' disagreement carries the same information). The check blames the
    direction that explains the miss with the smaller error, in units of its std, when the
    other would need :data:`DIRECTION_BLAME_RATIO` times more: that is the coordinate whose
    lines run nearly along the epipolar lines, the one that carries little depth; the other
    one is kept. When neither is clearly smaller, ``u+v`` is kept and the verdict is
    ``"suspect"``.

    Examples
    --------
    A flat wall 600 mm in front of a distortion-free pair with a vertical baseline; the rows
    carry the depth. Columns 20 px off: the miss is the columns' and they are dropped.

    >>> cam = LensModel([[400, 0, 31.5], [0, 400, 23.5], [0, 0, 1]], [], (64, 48))
    >>> proj = LensModel([[800, 0, 50], [0, 800, 40], [0, 0, 1]], [], (100, 80))
    >>> calib = StereoCalibration(cam, proj, np.eye(3), [0.0, -100.0, 0])
    >>> rows, cols = np.mgrid[0:48, 0:64].astype(float)
    >>> pts = np.dstack([(cols - 31.5) / 400 * 600, (rows - 23.5) / 400 * 600,
    ...                  np.full(rows.shape, 600.0)])
    >>> u, v = proj.project(pts + calib.translation_mm)
    >>> check_directions(calib, u, v, 0.05, 0.05).directions
    ('u', 'v')
    >>> bad = check_directions(calib, u + 20, v, 0.05, 0.05)
    >>> bad.directions, bad.verdict
    (('v',), 'u dropped')
    """
    if not isinstance(calibration, StereoCalibration):
        raise InputError("check_directions: calibration must be a StereoCalibration")
    u = np.asarray(u_proj, dtype=np.float64)
    v = np.asarray(v_proj, dtype=np.float64)
    if u.ndim != 2 or u.shape != v.shape:
        raise InputError(
            f"check_directions: u_proj {u.shape} and v_proj {v.shape}; give two maps of one "
            "2-D shape"
        )
    su = np.broadcast_to(np.asarray(sigma_u, dtype=np.float64), u.shape)
    sv = np.broadcast_to(np.asarray(sigma_v, dtype=np.float64), u.shape)
    rep = dict(calibration.reprojection_px or {})
    rep_px = float(rep.get("stereo", rep.get("projector", 0.0)))
    ok = np.isfinite(u) & np.isfinite(v) & (su > 0) & (sv > 0)
    step = max(1, int(np.ceil(np.sqrt(ok.sum() / max(int(max_points), 1)))))
    rows, cols = np.mgrid[0 : u.shape[0] : step, 0 : u.shape[1] : step]
    pick = ok[rows, cols]
    r, c = rows[pick].astype(np.float64), cols[pick].astype(np.float64)
    uu, vv = u[rows, cols][pick], v[rows, cols][pick]
    s_u = np.maximum(np.hypot(su[rows, cols][pick], rep_px), DIRECTION_SIGMA_FLOOR_PX)
    s_v = np.maximum(np.hypot(sv[rows, cols][pick], rep_px), DIRECTION_SIGMA_FLOOR_PX)
    sigma = {"u": _median(s_u), "v": _median(s_v)}
    nan = float("nan")
    if r.size < 10:
        return DirectionCheck(
            ("u", "v"), "unchecked", int(r.size), sigma, sigma_source, nan, nan, nan, nan, {},
            {}, f"u+v: only {r.size} pixels with both coordinates, nothing checked",
        )  # fmt: skip
    both = triangulate(calibration, c, r, u_proj=uu, v_proj=vv).xyz
    xc, yc = calibration.camera.undistort(c, r)
    ray = np.stack([xc, yc, np.ones_like(xc)], axis=-1)
    depth = np.einsum("ij,ij->i", both, ray) / np.einsum("ij,ij->i", ray, ray)
    ua, va = calibration.projector.project(
        _to_projector(calibration, ray * (0.98 * depth)[:, None])
    )
    ub, vb = calibration.projector.project(
        _to_projector(calibration, ray * (1.02 * depth)[:, None])
    )
    eu, ev = ub - ua, vb - va
    length = np.hypot(eu, ev)
    with np.errstate(divide="ignore", invalid="ignore"):
        nu, nv = -ev / length, eu / length
        miss = (uu - ua) * nu + (vv - va) * nv
        miss_sigma = np.hypot(s_u * nu, s_v * nv)
        z_miss = np.abs(miss) / miss_sigma
        need = {"u": np.abs(miss / nu), "v": np.abs(miss / nv)}
    xu = triangulate(calibration, c, r, u_proj=uu).xyz
    xv = triangulate(calibration, c, r, v_proj=vv).xyz
    sens_u = np.linalg.norm(triangulate(calibration, c, r, u_proj=uu + 1).xyz - xu, axis=1)
    sens_v = np.linalg.norm(triangulate(calibration, c, r, v_proj=vv + 1).xyz - xv, axis=1)
    apart = np.linalg.norm(xu - xv, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        z_apart = apart / np.hypot(sens_u * s_u, sens_v * s_v)
    enough = int(np.isfinite(z_apart).sum()) >= 10
    miss_ratio = _median(z_miss) / _MEDIAN_ABS_NORMAL
    apart_ratio = _median(z_apart) / _MEDIAN_ABS_NORMAL if enough else nan
    need_px = {k: _median(a) for k, a in need.items()}
    need_sigma = {"u": _median(need["u"] / s_u), "v": _median(need["v"] / s_v)}
    miss_px = _median(np.abs(miss))
    far = miss_ratio > DIRECTION_CHECK_FACTOR or (enough and apart_ratio > DIRECTION_CHECK_FACTOR)
    said = (
        f"rays miss by {miss_px:.3g} projector px, {miss_ratio:.3g}x the phase noise; u-only vs "
        "v-only " + (f"{apart_ratio:.3g}x" if enough else "not compared")
    )
    kept: tuple[str, ...]
    if not np.isfinite(miss_ratio):
        verdict, kept = "unchecked", ("u", "v")
        reason = "u+v (no pixel's rays could be compared)"
    elif not far:
        verdict, kept = "consistent", ("u", "v")
        reason = f"u+v ({said})"
    else:
        cost_u, cost_v = need_sigma["u"], need_sigma["v"]
        if cost_v >= DIRECTION_BLAME_RATIO * cost_u:
            verdict, kept = "u dropped", ("v",)
            reason = (
                f"v ({said}; a u error of {cost_u:.3g} std explains it, a v error would need "
                f"{cost_v:.3g}: u dropped)"
            )
        elif cost_u >= DIRECTION_BLAME_RATIO * cost_v:
            verdict, kept = "v dropped", ("u",)
            reason = (
                f"u ({said}; a v error of {cost_v:.3g} std explains it, a u error would need "
                f"{cost_u:.3g}: v dropped)"
            )
        else:
            verdict, kept = "suspect", ("u", "v")
            reason = (
                f"the stereo calibration is suspect: {said}; a u error of {cost_u:.3g} std or a v "
                f"error of {cost_v:.3g} explains it, neither clearly; triangulated with u+v"
            )
    return DirectionCheck(
        kept, verdict, int(r.size), sigma, sigma_source, miss_px, miss_ratio,
        _median(apart), apart_ratio, need_px, need_sigma, reason,
    )  # fmt: skip
