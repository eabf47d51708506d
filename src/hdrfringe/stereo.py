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
  (``phi = 2*pi*x/p``, :mod:`hdrfringe.patterns`): ``u_proj = p * Phi / (2*pi)`` from vertical
  fringes, ``v_proj`` likewise from horizontal ones, pixel centres at integers;
* lens distortion is OpenCV's model, coefficients ``(k1, k2, p1, p2[, k3[, k4, k5, k6]])``;
  projection and undistortion are OpenCV's (``cv2.projectPoints``, ``cv2.undistortPoints``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.errors import InputError

__all__ = [
    "DISTORTION_LENGTHS",
    "LensModel",
    "StereoCalibration",
]

F64 = NDArray[np.float64]

#: Accepted lengths of an OpenCV distortion vector: none, (k1, k2, p1, p2), + k3, + k4..k6.
DISTORTION_LENGTHS = (0, 4, 5, 8)

#: Undistortion iterations: OpenCV's default (5 iterations) leaves tens of millipixels on a
#: strong lens; this stops when the reprojection error is below 1e-10 px (or 200 iterations).
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-10)

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
    coordinates ``u = fx*xd + s*yd + cx``, ``v = fy*yd + cy``. OpenCV's functions ignore the
    skew ``s``; this class applies it around them, so a skewed matrix is exact too.

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

    def _plain_matrix(self) -> F64:
        """The matrix without skew: what OpenCV's functions use."""
        k = self.matrix.copy()
        k[0, 1] = 0.0
        return k

    def _distortion_for_cv(self) -> F64:
        return self.distortion if self.distortion.size else np.zeros(4)

    def project(self, points_xyz: ArrayLike) -> tuple[F64, F64]:
        """Pixel coordinates of points given in the lens frame (``cv2.projectPoints``).

        Parameters
        ----------
        points_xyz : array_like, shape (..., 3)
            Points in the lens's own frame (mm or any unit).

        Returns
        -------
        u, v : ndarray, shape (...)
            Pixel coordinates; NaN for non-finite points and points not in front of the lens
            (``Z <= 0``).

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
        ok = np.all(np.isfinite(flat), axis=1) & (flat[:, 2] > 0)
        u = np.full(flat.shape[0], np.nan)
        v = np.full(flat.shape[0], np.nan)
        if np.any(ok):
            img, _ = cv2.projectPoints(
                np.ascontiguousarray(flat[ok]),
                np.zeros(3),
                np.zeros(3),
                self._plain_matrix(),
                self._distortion_for_cv(),
            )
            img = img.reshape(-1, 2)
            vv = img[:, 1]
            u[ok] = img[:, 0] + self.skew * (vv - self.matrix[1, 2]) / self.matrix[1, 1]
            v[ok] = vv
        return u.reshape(pts.shape[:-1]), v.reshape(pts.shape[:-1])

    def undistort(self, u: ArrayLike, v: ArrayLike) -> tuple[F64, F64]:
        """Normalised ideal coordinates ``(x, y)`` of pixels (``cv2.undistortPoints``).

        The ray of pixel ``(u, v)`` is ``(x, y, 1)`` in the lens frame.

        Parameters
        ----------
        u, v : array_like
            Pixel coordinates (broadcast together).

        Returns
        -------
        x, y : ndarray
            Normalised coordinates; NaN where ``u`` or ``v`` is NaN, and where the iterative
            inversion does not reproject onto the pixel within ``UNDISTORT_TOLERANCE_PX``
            (1e-4 px; only where the distortion model folds over, far outside its field).

        Notes
        -----
        OpenCV iterates ``x <- (x_d - delta(x)) / radial(x)``; its default stops after 5
        iterations, which leaves tens of millipixels on a strong lens. Here it runs to a
        reprojection error of 1e-10 px (at most 200 iterations), and the result is checked by
        projecting it back.

        Examples
        --------
        >>> lens = LensModel([[800, 0, 400], [0, 800, 300], [0, 0, 1]], [], (800, 600))
        >>> lens.undistort([400.0, 480.0], [300.0, 300.0])
        (array([0. , 0.1]), array([0., 0.]))
        """
        uu, vv = np.broadcast_arrays(np.asarray(u, np.float64), np.asarray(v, np.float64))
        shape = uu.shape
        fu, fv = uu.reshape(-1), vv.reshape(-1)
        ok = np.isfinite(fu) & np.isfinite(fv)
        x = np.full(fu.shape, np.nan)
        y = np.full(fu.shape, np.nan)
        if np.any(ok):
            # remove the skew: u' = fx*xd + cx is what OpenCV inverts
            plain_u = fu[ok] - self.skew * (fv[ok] - self.matrix[1, 2]) / self.matrix[1, 1]
            src = np.stack([plain_u, fv[ok]], axis=-1).reshape(-1, 1, 2)
            k, d = self._plain_matrix(), self._distortion_for_cv()
            out = cv2.undistortPoints(src, k, d, criteria=_UNDISTORT_CRITERIA).reshape(-1, 2)
            if self.distortion.size and np.any(self.distortion):
                back, _ = cv2.projectPoints(
                    np.concatenate([out, np.ones((out.shape[0], 1))], axis=1),
                    np.zeros(3),
                    np.zeros(3),
                    k,
                    d,
                )
                err = np.hypot(*(back.reshape(-1, 2) - src.reshape(-1, 2)).T)
                out[~(err <= UNDISTORT_TOLERANCE_PX)] = np.nan
            x[ok], y[ok] = out[:, 0], out[:, 1]
        return x.reshape(shape), y.reshape(shape)

    def to_dict(self) -> dict[str, Any]:
        """Plain lists and numbers (for reports and JSON)."""
        return {
            "matrix": self.matrix.tolist(),
            "distortion": self.distortion.tolist(),
            "size": list(self.size),
        }


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
    own calibration is the phase-to-height map (Sec. 2.5, :mod:`hdrfringe.calibration`).

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
