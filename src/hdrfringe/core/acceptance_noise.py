"""Predicted standard deviation of the acceptance quantities PS and SD from the image noise.

The phase noise of a fringe measurement (:mod:`hdrfringe.core.uncertainty`, docs/uncertainty.md)
moves each triangulated point along its camera ray. :func:`ray_depth_std` turns a point's
projector-coordinate std into its std along that ray through the stereo calibration (the
depth change per projector pixel along the ray, by a central difference); :func:`sphere_fit_std`
propagates independent per-point displacements along the rays through the linearised
geometric least-squares sphere fit (:func:`hdrfringe.core.stereo.fit_sphere`):

    J_i = -[n_i, 1],  a_i = (n_i . d_i) sigma_i,
    Cov(c, r) = (J^T J)^-1 J^T diag(a_i^2) J (J^T J)^-1,

``n_i`` the unit normal at point ``i``, ``d_i`` the unit ray direction (from the camera
centre, the origin of the camera frame). The diameter's std is ``2 sigma_r``; a ball bar's
centre distance has ``sigma_SD^2 = u^T (Cov_A + Cov_B) u`` with ``u`` the unit vector between
the centres (:func:`spacing_std`). What it leaves out: calibration error, blur and every
other systematic error; it is the spread a repeated measurement of the same position would
show, the yardstick the acceptance compares its errors against (docs/acceptance.md).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core.stereo import StereoCalibration
from hdrfringe.errors import InputError

__all__ = ["SphereFitStd", "ray_depth_std", "spacing_std", "sphere_fit_std"]

F64 = NDArray[np.float64]


def ray_depth_std(
    xyz: ArrayLike, coordinate_std_px: ArrayLike, calibration: StereoCalibration, axis: int = 0
) -> F64:
    """Std of points along their camera rays from the std of one projector coordinate.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        Points in the camera frame, mm.
    coordinate_std_px : array_like, shape (...)
        Std of the projector coordinate the points were triangulated from, projector px.
    calibration : StereoCalibration
        The stereo calibration (projector lens and pose).
    axis : {0, 1}
        The coordinate: 0 for ``u`` (vertical fringes), 1 for ``v``.

    Returns
    -------
    ndarray, shape (...)
        ``sigma_px / |d coordinate / d s|``, ``s`` the distance along the ray, mm (NaN where
        either is not finite).

    Examples
    --------
    >>> from hdrfringe.rig.simulated import RigGeometry
    >>> cal = RigGeometry().stereo_calibration((64, 48), (800, 600))
    >>> float(ray_depth_std([[0.0, 0.0, 1900.0]], [0.0], cal)[0])
    0.0
    """
    if axis not in (0, 1):
        raise InputError(f"axis must be 0 (u) or 1 (v), got {axis!r}")
    pts = np.asarray(xyz, dtype=float)
    sig = np.asarray(coordinate_std_px, dtype=float)
    norm = np.linalg.norm(pts, axis=-1, keepdims=True)
    ray = pts / np.where(norm > 0, norm, np.nan)
    step = 0.5  # mm: the coordinate is smooth over it; a central difference

    def coordinate(p: F64) -> F64:
        q = p @ calibration.rotation.T + calibration.translation_mm
        return np.asarray(calibration.projector.project(q)[axis], dtype=float)

    slope = (coordinate(pts + step * ray) - coordinate(pts - step * ray)) / (2 * step)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(sig / np.abs(slope), dtype=float)


class SphereFitStd:
    """The covariance of a sphere fit's centre and radius (:func:`sphere_fit_std`).

    Parameters
    ----------
    covariance : ndarray, shape (4, 4)
        Of ``(cx, cy, cz, r)``, mm^2.

    Examples
    --------
    >>> s = SphereFitStd(np.diag([1.0, 1.0, 1.0, 0.25]))
    >>> s.diameter_std_mm
    1.0
    """

    def __init__(self, covariance: ArrayLike) -> None:
        self.covariance = np.asarray(covariance, dtype=float)

    @property
    def diameter_std_mm(self) -> float:
        """Std of the diameter, ``2 sigma_r``."""
        return float(2.0 * np.sqrt(self.covariance[3, 3]))

    @property
    def centre_covariance(self) -> F64:
        """Covariance of the centre, shape (3, 3)."""
        return self.covariance[:3, :3]


def sphere_fit_std(xyz: ArrayLike, centre: ArrayLike, depth_std_mm: ArrayLike) -> SphereFitStd:
    """Propagate per-point noise along the camera rays through the least-squares sphere.

    Parameters
    ----------
    xyz : array_like, shape (n, 3)
        The fitted points in the camera frame (camera centre at the origin), mm.
    centre : array_like, shape (3,)
        The fitted centre, mm.
    depth_std_mm : array_like, shape (n,)
        Each point's std along its ray (:func:`ray_depth_std`), mm.

    Returns
    -------
    SphereFitStd

    Raises
    ------
    InputError
        Fewer than 4 points with a finite std, or shapes that do not match.

    Examples
    --------
    A full sphere around the camera centre, seen along its normals with one std ``sigma``:
    the radius is the mean of ``n`` independent distances, ``sigma_r = sigma / sqrt(n)``:

    >>> u = np.random.default_rng(1).normal(size=(4000, 3))
    >>> u /= np.linalg.norm(u, axis=1, keepdims=True)
    >>> s = sphere_fit_std(10.0 * u, [0.0, 0.0, 0.0], np.full(4000, 0.1))
    >>> round(float(s.diameter_std_mm / (2 * 0.1 / np.sqrt(4000))), 2)
    1.0
    """
    pts = np.asarray(xyz, dtype=float).reshape(-1, 3)
    sig = np.asarray(depth_std_mm, dtype=float).reshape(-1)
    if sig.shape[0] != pts.shape[0]:
        raise InputError(f"{pts.shape[0]} points but {sig.shape[0]} stds; give one per point")
    ok = np.isfinite(pts).all(axis=1) & np.isfinite(sig)
    pts, sig = pts[ok], sig[ok]
    if pts.shape[0] < 4:
        raise InputError(f"sphere fit std: {pts.shape[0]} points with a std; give at least 4")
    offs = pts - np.asarray(centre, dtype=float)
    normal = offs / np.linalg.norm(offs, axis=1, keepdims=True)
    ray = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    jac = -np.hstack([normal, np.ones((pts.shape[0], 1))])
    a = np.einsum("ij,ij->i", normal, ray) * sig
    inv = np.linalg.pinv(jac.T @ jac)
    middle = (jac * (a**2)[:, None]).T @ jac
    return SphereFitStd(inv @ middle @ inv)


def spacing_std(
    centre_a: ArrayLike, centre_b: ArrayLike, std_a: SphereFitStd, std_b: SphereFitStd
) -> float:
    """Std of the distance of two independently fitted sphere centres.

    Parameters
    ----------
    centre_a, centre_b : array_like, shape (3,)
        The centres, mm.
    std_a, std_b : SphereFitStd
        Their fits' covariances.

    Returns
    -------
    float
        ``sqrt(u^T (C_a + C_b) u)``, mm.

    Examples
    --------
    >>> s = SphereFitStd(np.diag([0.01, 0.04, 0.09, 0.0]))
    >>> round(spacing_std([0, 0, 0], [0, 0, 5], s, s), 6)
    0.424264
    """
    u = np.asarray(centre_b, dtype=float) - np.asarray(centre_a, dtype=float)
    u /= np.linalg.norm(u)
    cov = std_a.centre_covariance + std_b.centre_covariance
    return float(np.sqrt(u @ cov @ u))
