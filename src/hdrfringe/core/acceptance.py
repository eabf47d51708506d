"""Acceptance test of the measuring system: the VDI/VDE 2634 Part 2 quantities on point sets.

An optical 3D system is accepted by measuring calibrated artefacts at positions spread over its
measuring volume and comparing four quantities with maximum permissible errors (MPE,
docs/acceptance.md):

* probing error form ``PF``: the range of the radial residuals of the least-squares sphere
  with free radius through the points of a sphere (:func:`probing_error`);
* probing error size ``PS``: the diameter of that sphere minus the calibrated diameter;
* sphere-spacing error ``SD``: the distance of the centres of the two spheres of a ball bar,
  each a free-radius least-squares sphere, minus the calibrated distance
  (:func:`sphere_spacing_error`);
* flatness error ``F``: the range of the signed distances of the points of a plane to their
  least-squares plane (:func:`flatness_error`).

Before the form quantities up to 0.3 % of the points, those with the largest residuals, may be
left out (:func:`trim_count`, :data:`GUIDELINE_TRIM`). The fits are the package's one sphere
and one plane fit (:func:`hdrfringe.core.stereo.fit_sphere`,
:func:`~hdrfringe.core.stereo.fit_plane`). :func:`segment_sphere`, :func:`segment_ball_bar`
and :func:`segment_plane` find an artefact's points in a measured cloud;
:func:`check_position` and :func:`summarize` compare values with an :class:`MpeSet` into a
per-position table that turns into JSON without NaN. All lengths are in millimetres.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core.stereo import PlaneFit, SphereFit, fit_dominant_plane, fit_plane, fit_sphere
from hdrfringe.errors import InputError

__all__ = [
    "GUIDELINE_TRIM",
    "QUANTITIES",
    "AcceptanceSummary",
    "ArtefactNotFoundError",
    "FlatnessError",
    "Mpe",
    "MpeSet",
    "PlaneSegment",
    "PositionResult",
    "ProbingError",
    "SphereMeasurement",
    "SphereSegment",
    "SphereSpacingError",
    "body_diagonal",
    "check_position",
    "flatness_error",
    "grazing_points",
    "measure_sphere",
    "neck_points",
    "probing_error",
    "segment_ball_bar",
    "segment_plane",
    "segment_sphere",
    "sphere_spacing_error",
    "summarize",
    "trim_count",
]

F64 = NDArray[np.float64]
Mask = NDArray[np.bool_]

#: The share of the points that may be left out before PF and F (VDI/VDE 2634 Part 2: 0.3 %).
GUIDELINE_TRIM = 0.003
#: The quantities of the acceptance table, in the order reported.
QUANTITIES = ("PF", "PS", "SD", "F")


class ArtefactNotFoundError(InputError):
    """An acceptance artefact (sphere, ball bar, plane) is not in a measured point cloud.

    Examples
    --------
    >>> issubclass(ArtefactNotFoundError, InputError)
    True
    """


# --- the trimming rule ------------------------------------------------------------------------


def trim_count(n: int, fraction: float = GUIDELINE_TRIM) -> int:
    """How many of ``n`` points the trimming rule leaves out: ``floor(fraction * n)``.

    Parameters
    ----------
    n : int
        Points of the artefact (finite ones).
    fraction : float
        The share that may be left out, in [0, 0.5); the guideline's is :data:`GUIDELINE_TRIM`.

    Returns
    -------
    int
        Rounded down ("up to 0.3 %": never more than the share), computed so that a product
        that is an integer in exact arithmetic (0.003 * 1000) is not lost to rounding.

    Examples
    --------
    >>> trim_count(1000), trim_count(1333), trim_count(1334), trim_count(333)
    (3, 3, 4, 0)
    >>> trim_count(1000, 0.0)
    0
    """
    if isinstance(n, bool) or int(n) != n or n < 0:
        raise InputError(f"point count must be an integer >= 0, got {n}")
    f = float(fraction)
    if not 0.0 <= f < 0.5:
        raise InputError(
            f"trim fraction must be in [0, 0.5), got {fraction}; the guideline's is 0.003"
        )
    return math.floor(round(f * int(n), 9))


def _points(xyz: ArrayLike, what: str) -> tuple[F64, Mask]:
    pts = np.asarray(xyz, dtype=np.float64)
    if pts.ndim < 1 or pts.shape[-1] != 3:
        raise InputError(f"{what}: points of shape {pts.shape}; give an array of shape (..., 3)")
    return pts, np.all(np.isfinite(pts), axis=-1)


_Fit = TypeVar("_Fit", SphereFit, PlaneFit)


def _trimmed_fit(
    fit: Callable[[ArrayLike], _Fit], pts: F64, finite: Mask, fraction: float
) -> tuple[_Fit, Mask, int]:
    """The trimming rule around a fit: fit every finite point, drop the ``trim_count`` with
    the largest ``|residual|``, fit the rest again. Returns (final fit, kept points, dropped)."""
    first = fit(pts)
    kept = finite.copy()
    k = trim_count(int(finite.sum()), fraction)
    if not k:
        return first, kept, 0
    flat = np.where(finite, np.abs(first.residuals), -np.inf).ravel()
    kept.ravel()[np.argpartition(flat, flat.size - k)[flat.size - k :]] = False
    return fit(np.where(kept[..., None], pts, np.nan)), kept, k


# --- the quantities ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SphereMeasurement:
    """A free-radius least-squares sphere after the trimming rule (:func:`measure_sphere`).

    Parameters
    ----------
    centre : ndarray, shape (3,)
        Centre, mm.
    diameter_mm : float
        Diameter of the final fit, mm.
    form_mm : float
        Range (max - min) of the radial residuals of the kept points, mm.
    residuals : ndarray, shape (...)
        ``|x - centre| - diameter/2`` of every finite point (dropped ones too), NaN for
        non-finite points, mm.
    kept : ndarray of bool, shape (...)
        The points of the final fit.
    n_dropped : int
        Points left out by the trimming rule.

    Examples
    --------
    >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
    >>> m = measure_sphere(5.0 * d)
    >>> round(m.diameter_mm, 9), round(m.form_mm, 9), m.n_points, m.n_dropped
    (10.0, 0.0, 5, 0)
    """

    centre: F64
    diameter_mm: float
    form_mm: float
    residuals: F64
    kept: Mask
    n_dropped: int

    @property
    def n_points(self) -> int:
        """Points of the final fit."""
        return int(self.kept.sum())

    def to_dict(self) -> dict[str, Any]:
        """The fit as plain JSON types (the per-point arrays left out).

        Returns
        -------
        dict
            ``centre_mm``, ``diameter_mm``, ``form_mm``, ``n_points``, ``n_dropped``.

        Examples
        --------
        >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
        >>> sorted(measure_sphere(5.0 * d).to_dict())
        ['centre_mm', 'diameter_mm', 'form_mm', 'n_dropped', 'n_points']
        """
        return {
            "centre_mm": [float(v) for v in self.centre],
            "diameter_mm": float(self.diameter_mm),
            "form_mm": float(self.form_mm),
            "n_points": self.n_points,
            "n_dropped": int(self.n_dropped),
        }


def measure_sphere(xyz: ArrayLike, *, trim: float = GUIDELINE_TRIM) -> SphereMeasurement:
    """Free-radius least-squares sphere through points, with the trimming rule.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        The sphere's points, mm; non-finite rows are ignored.
    trim : float
        Share of the points that may be left out (:func:`trim_count`); 0 keeps every point.

    Returns
    -------
    SphereMeasurement

    Notes
    -----
    A first fit through every finite point ranks the points by ``|residual|``; the
    ``floor(trim * n)`` largest are dropped and the sphere is fitted again through the rest
    (:func:`~hdrfringe.core.stereo.fit_sphere`, geometric least squares). The form range is
    that of the refit's residuals of the kept points (docs/acceptance.md, "Trimming").

    Examples
    --------
    A sphere of radius 10 mm with one point 2 mm off among 400: the trimming drops it
    (``floor(0.003 * 400) = 1``), the fit without trimming keeps it.

    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(400, 3))
    >>> u /= np.linalg.norm(u, axis=1, keepdims=True)
    >>> pts = 10.0 * u
    >>> pts[0] *= 1.2
    >>> round(measure_sphere(pts).form_mm, 9), measure_sphere(pts, trim=0).form_mm > 1.9
    (0.0, True)
    """
    pts, finite = _points(xyz, "sphere")
    fit, kept, k = _trimmed_fit(fit_sphere, pts, finite, trim)
    residuals = np.linalg.norm(pts - fit.centre, axis=-1) - fit.radius
    return SphereMeasurement(
        centre=fit.centre,
        diameter_mm=2.0 * fit.radius,
        form_mm=float(np.ptp(residuals[kept])),
        residuals=residuals,
        kept=kept,
        n_dropped=k,
    )


def _positive(value: float, name: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise InputError(f"{name} must be a positive finite number of mm, got {value}")
    return v


@dataclass(frozen=True, eq=False)
class ProbingError:
    """Probing error form PF and size PS of one sphere position (:func:`probing_error`).

    Parameters
    ----------
    form_mm : float
        PF: range of the radial residuals, mm.
    size_mm : float
        PS: fitted minus calibrated diameter, mm (signed).
    calibrated_diameter_mm : float
        The sphere's calibrated diameter, mm.
    sphere : SphereMeasurement
        The fit.

    Examples
    --------
    >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
    >>> p = probing_error(5.01 * d, 10.0)
    >>> round(p.form_mm, 9), round(p.size_mm, 9)
    (0.0, 0.02)
    """

    form_mm: float
    size_mm: float
    calibrated_diameter_mm: float
    sphere: SphereMeasurement

    def rows(self, position: str, mpes: MpeSet) -> tuple[PositionResult, PositionResult]:
        """The PF and PS rows of this position (:func:`check_position`).

        Parameters
        ----------
        position : str
            The position's id.
        mpes : MpeSet
            The MPEs.

        Returns
        -------
        tuple of PositionResult
            PF, PS.

        Examples
        --------
        >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
        >>> mpes = MpeSet(Mpe(0.03), Mpe(0.01), Mpe(0.05), Mpe(0.04))
        >>> [r.passed for r in probing_error(5.01 * d, 10.0).rows("s1", mpes)]
        [True, False]
        """
        return (
            check_position(position, "PF", self.form_mm, mpes),
            check_position(position, "PS", self.size_mm, mpes),
        )

    def to_dict(self) -> dict[str, Any]:
        """PF, PS and the fit as plain JSON types.

        Returns
        -------
        dict
            ``pf_mm``, ``ps_mm``, ``calibrated_diameter_mm``, ``sphere``
            (:meth:`SphereMeasurement.to_dict`).

        Examples
        --------
        >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
        >>> round(probing_error(5.01 * d, 10.0).to_dict()["ps_mm"], 9)
        0.02
        """
        return {
            "pf_mm": float(self.form_mm),
            "ps_mm": float(self.size_mm),
            "calibrated_diameter_mm": float(self.calibrated_diameter_mm),
            "sphere": self.sphere.to_dict(),
        }


def probing_error(
    xyz: ArrayLike, calibrated_diameter_mm: float, *, trim: float = GUIDELINE_TRIM
) -> ProbingError:
    """PF and PS of the points of a calibrated sphere.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        The sphere's points, mm (one position, segmented: :func:`segment_sphere`).
    calibrated_diameter_mm : float
        The sphere's calibrated diameter, mm.
    trim : float
        Share of the points that may be left out before the fit (:func:`measure_sphere`).

    Returns
    -------
    ProbingError
        PF = range of the radial residuals of the kept points; PS = fitted diameter minus
        ``calibrated_diameter_mm``; both from the one free-radius fit.

    Examples
    --------
    >>> rng = np.random.default_rng(2)
    >>> u = rng.normal(size=(500, 3))
    >>> u[:, 2] = -np.abs(u[:, 2])
    >>> u /= np.linalg.norm(u, axis=1, keepdims=True)
    >>> p = probing_error(12.51 * u + [0, 0, 600.0], 25.0)
    >>> round(p.size_mm, 6), round(p.form_mm, 6)
    (0.02, 0.0)
    """
    cal = _positive(calibrated_diameter_mm, "calibrated sphere diameter")
    sphere = measure_sphere(xyz, trim=trim)
    return ProbingError(sphere.form_mm, sphere.diameter_mm - cal, cal, sphere)


@dataclass(frozen=True, eq=False)
class SphereSpacingError:
    """Sphere-spacing error SD of one ball-bar position (:func:`sphere_spacing_error`).

    Parameters
    ----------
    spacing_mm : float
        SD: measured minus calibrated centre distance, mm (signed).
    distance_mm : float
        Measured centre distance, mm.
    calibrated_distance_mm : float
        The ball bar's calibrated centre distance, mm.
    spheres : tuple of SphereMeasurement
        The two fits.

    Examples
    --------
    >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
    >>> s = sphere_spacing_error(5 * d, 5 * d + [100.03, 0, 0], 100.0)
    >>> round(s.spacing_mm, 9), round(s.distance_mm, 9)
    (0.03, 100.03)
    """

    spacing_mm: float
    distance_mm: float
    calibrated_distance_mm: float
    spheres: tuple[SphereMeasurement, SphereMeasurement]

    def rows(self, position: str, mpes: MpeSet) -> tuple[PositionResult]:
        """The SD row of this position, its MPE at the calibrated distance.

        Parameters
        ----------
        position : str
            The position's id.
        mpes : MpeSet
            The MPEs.

        Returns
        -------
        tuple of PositionResult
            SD.

        Examples
        --------
        >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
        >>> s = sphere_spacing_error(5 * d, 5 * d + [100.02, 0, 0], 100.0)
        >>> (row,) = s.rows("bar-1", MpeSet(Mpe(0.03), Mpe(0.03), Mpe(0.02, 10000.0), Mpe(0.04)))
        >>> row.mpe_mm, row.passed
        (0.03, True)
        """
        return (
            check_position(
                position, "SD", self.spacing_mm, mpes, length_mm=self.calibrated_distance_mm
            ),
        )

    def to_dict(self) -> dict[str, Any]:
        """SD and the two fits as plain JSON types.

        Returns
        -------
        dict
            ``sd_mm``, ``distance_mm``, ``calibrated_distance_mm``, ``spheres`` (two
            :meth:`SphereMeasurement.to_dict`).

        Examples
        --------
        >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
        >>> len(sphere_spacing_error(5 * d, 5 * d + [100, 0, 0], 100.0).to_dict()["spheres"])
        2
        """
        return {
            "sd_mm": float(self.spacing_mm),
            "distance_mm": float(self.distance_mm),
            "calibrated_distance_mm": float(self.calibrated_distance_mm),
            "spheres": [s.to_dict() for s in self.spheres],
        }


def sphere_spacing_error(
    xyz_a: ArrayLike,
    xyz_b: ArrayLike,
    calibrated_distance_mm: float,
    *,
    trim: float = GUIDELINE_TRIM,
) -> SphereSpacingError:
    """SD of a ball bar: distance of two free-radius sphere centres minus the calibrated one.

    Parameters
    ----------
    xyz_a, xyz_b : array_like, shape (..., 3)
        The points of each sphere, mm (segmented: :func:`segment_ball_bar`).
    calibrated_distance_mm : float
        The calibrated centre distance, mm.
    trim : float
        Share of each sphere's points that may be left out before its fit
        (:func:`measure_sphere`; docs/acceptance.md says why it applies here too).

    Returns
    -------
    SphereSpacingError

    Examples
    --------
    >>> rng = np.random.default_rng(3)
    >>> u = rng.normal(size=(300, 3))
    >>> u[:, 2] = -np.abs(u[:, 2])
    >>> u /= np.linalg.norm(u, axis=1, keepdims=True)
    >>> a, b = 12.0 * u + [-75, 0, 600], 12.0 * u + [75.05, 0, 600]
    >>> round(sphere_spacing_error(a, b, 150.0).spacing_mm, 6)
    0.05
    """
    cal = _positive(calibrated_distance_mm, "calibrated centre distance")
    a = measure_sphere(xyz_a, trim=trim)
    b = measure_sphere(xyz_b, trim=trim)
    distance = float(np.linalg.norm(a.centre - b.centre))
    return SphereSpacingError(distance - cal, distance, cal, (a, b))


@dataclass(frozen=True, eq=False)
class FlatnessError:
    """Flatness error F of one plane position (:func:`flatness_error`).

    Parameters
    ----------
    flatness_mm : float
        F: range of the signed distances of the kept points to their least-squares plane, mm.
    normal : ndarray, shape (3,)
        Unit normal of the plane (toward the origin).
    offset : float
        ``normal . x`` on the plane, mm.
    residuals : ndarray, shape (...)
        Signed distance of every finite point (dropped ones too), NaN for non-finite, mm.
    kept : ndarray of bool, shape (...)
        The points of the final fit.
    n_dropped : int
        Points left out by the trimming rule.

    Examples
    --------
    >>> f = flatness_error([[1, 0, 10.0], [-1, 0, 10.0], [0, 1, 10.0], [0, -1, 10.0],
    ...                     [0, 0, 10.2]])
    >>> round(f.flatness_mm, 9), f.n_points
    (0.2, 5)
    """

    flatness_mm: float
    normal: F64
    offset: float
    residuals: F64
    kept: Mask
    n_dropped: int

    @property
    def n_points(self) -> int:
        """Points of the final fit."""
        return int(self.kept.sum())

    def rows(self, position: str, mpes: MpeSet, length_mm: float) -> tuple[PositionResult]:
        """The F row of this position.

        Parameters
        ----------
        position : str
            The position's id.
        mpes : MpeSet
            The MPEs.
        length_mm : float
            The plane's length (the length of a length-dependent MPE of F), mm.

        Returns
        -------
        tuple of PositionResult
            F.

        Examples
        --------
        >>> f = flatness_error([[1, 0, 10.0], [-1, 0, 10.0], [0, 1, 10.0], [0, -1, 10.0],
        ...                     [0, 0, 10.2]])
        >>> f.rows("plane-1", MpeSet(Mpe(.03), Mpe(.03), Mpe(.05), Mpe(.04)), 200.0)[0].passed
        False
        """
        return (check_position(position, "F", self.flatness_mm, mpes, length_mm=length_mm),)

    def to_dict(self) -> dict[str, Any]:
        """F and the plane as plain JSON types (the per-point arrays left out).

        Returns
        -------
        dict
            ``f_mm``, ``normal``, ``offset_mm``, ``n_points``, ``n_dropped``.

        Examples
        --------
        >>> f = flatness_error([[1, 0, 10.0], [-1, 0, 10.0], [0, 1, 10.0], [0, -1, 10.0],
        ...                     [0, 0, 10.2]])
        >>> f.to_dict()["normal"]
        [0.0, 0.0, -1.0]
        """
        return {
            "f_mm": float(self.flatness_mm),
            "normal": [float(v) for v in self.normal],
            "offset_mm": float(self.offset),
            "n_points": self.n_points,
            "n_dropped": int(self.n_dropped),
        }


def flatness_error(xyz: ArrayLike, *, trim: float = GUIDELINE_TRIM) -> FlatnessError:
    """F of the points of a plane, with the trimming rule.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        The plane's points, mm (segmented: :func:`segment_plane`); non-finite rows ignored.
    trim : float
        Share of the points that may be left out (:func:`trim_count`); 0 keeps every point.

    Returns
    -------
    FlatnessError

    Notes
    -----
    As :func:`measure_sphere`: a first least-squares plane
    (:func:`~hdrfringe.core.stereo.fit_plane`, orthogonal distances) ranks the points, the
    ``floor(trim * n)`` with the largest ``|distance|`` are dropped and the plane is fitted
    again; F is the range of the refit's distances of the kept points.

    Examples
    --------
    A bowed plate ``z = c (x^2 + y^2)`` over a square of half-side 50 mm: by symmetry the
    least-squares plane is ``z = mean(z)``, so F = ``c * 2 * 50^2`` exactly.

    >>> x, y = np.meshgrid(np.linspace(-50, 50, 41), np.linspace(-50, 50, 41))
    >>> z = 500 + 2e-5 * (x**2 + y**2)
    >>> round(flatness_error(np.dstack([x, y, z])).flatness_mm, 9)
    0.1
    """
    pts, finite = _points(xyz, "plane")
    fit, kept, k = _trimmed_fit(fit_plane, pts, finite, trim)
    residuals = pts @ fit.normal - fit.offset
    return FlatnessError(
        flatness_mm=float(np.ptp(residuals[kept])),
        normal=fit.normal,
        offset=fit.offset,
        residuals=residuals,
        kept=kept,
        n_dropped=k,
    )


def body_diagonal(size_mm: ArrayLike) -> float:
    """L0: the body diagonal of a box-shaped measuring volume.

    Parameters
    ----------
    size_mm : array_like, shape (3,)
        The box's edge lengths, mm.

    Returns
    -------
    float
        ``sqrt(a^2 + b^2 + c^2)``, mm. The guideline sizes the artefacts from it: sphere
        diameter about 0.1-0.2 L0, ball-bar length >= 0.3 L0, plane length >= 0.5 L0.

    Examples
    --------
    >>> body_diagonal([300, 200, 150])
    390.51248379533274
    """
    size = np.asarray(size_mm, dtype=np.float64)
    if size.shape != (3,) or not np.all(np.isfinite(size)) or np.any(size <= 0):
        raise InputError(
            f"measuring volume size {np.asarray(size_mm).tolist()}: give three positive "
            "edge lengths in mm"
        )
    return float(np.linalg.norm(size))


# --- segmentation -----------------------------------------------------------------------------


class _SphereModel:
    """A free-radius sphere for :func:`skimage.measure.ransac` (:func:`fit_sphere` estimates)."""

    def __init__(self) -> None:
        self.params: F64 | None = None

    @classmethod
    def from_estimate(cls, data: F64) -> _SphereModel:
        model = cls()
        model.estimate(data)
        return model

    def estimate(self, data: F64) -> bool:
        try:
            fit = fit_sphere(data)
        except InputError:  # the sample lies on one plane
            self.params = None
            return False
        self.params = np.r_[fit.centre, fit.radius]
        return True

    def residuals(self, data: F64) -> F64:
        assert self.params is not None
        return np.abs(np.linalg.norm(data - self.params[:3], axis=1) - self.params[3])

    def __bool__(self) -> bool:
        return self.params is not None


@dataclass(frozen=True, eq=False)
class SphereSegment:
    """The points of a sphere found in a cloud (:func:`segment_sphere`).

    Parameters
    ----------
    mask : ndarray of bool, shape (...)
        The sphere's points among the cloud's.
    centre : ndarray, shape (3,)
        Centre of the sphere through them, mm.
    diameter_mm : float
        Its diameter, mm.
    band_mm : float
        The selection band: a point within ``band_mm`` of the sphere's surface is the
        sphere's.
    n_outliers : int
        Points near the sphere (within ``radius + 3 band``, not on the background plane) left
        out by the band: errors the quantities do not see; report them.
    n_edge : int
        Points within the band left out by the edge rules (:func:`grazing_points`,
        :func:`neck_points`): the sphere's rim seen at a grazing angle, a ball bar's neck.

    Examples
    --------
    >>> seg = SphereSegment(np.ones(5, bool), np.zeros(3), 25.0, 1.25, 0)
    >>> seg.n_points, seg.n_edge
    (5, 0)
    """

    mask: Mask
    centre: F64
    diameter_mm: float
    band_mm: float
    n_outliers: int
    n_edge: int = 0

    @property
    def n_points(self) -> int:
        """Points of the sphere."""
        return int(self.mask.sum())


#: :func:`segment_sphere`: points a RANSAC run scores at most, and its trials at most.
SEGMENT_SAMPLE = 2000
SEGMENT_TRIALS = 1000
#: Least points of a segmented artefact (fewer: not found).
MIN_ARTEFACT_POINTS = 50


def _background(pts: F64, use: Mask, band: float, seed: int) -> Mask:
    """The points of a dominant plane behind an object (none when there is no such plane)."""
    if int(use.sum()) < 10:
        return np.zeros(use.shape, dtype=bool)
    try:
        plane = fit_dominant_plane(np.where(use[..., None], pts, np.nan), seed=seed)
    except InputError:
        return np.zeros(use.shape, dtype=bool)
    share = plane.inliers.sum() / max(int(use.sum()), 1)
    if share < 0.2 or plane.rms_mm > band / 4:
        return np.zeros(use.shape, dtype=bool)
    return use & (np.abs(plane.residuals) <= band)


def _unit(v: F64) -> F64:
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(v / np.linalg.norm(v, axis=-1, keepdims=True), dtype=np.float64)


def grazing_points(
    xyz: ArrayLike,
    centre: ArrayLike,
    max_view_deg: float,
    viewpoint: ArrayLike = (0.0, 0.0, 0.0),
) -> Mask:
    """The points of a sphere seen at a grazing angle: its rim as the camera sees it.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        The sphere's points, mm.
    centre : array_like, shape (3,)
        The sphere's centre, mm (a fit through the points).
    max_view_deg : float
        The largest angle, degrees, between a point's outward normal ``x - centre`` and its
        line of sight to ``viewpoint`` that is not grazing.
    viewpoint : array_like, shape (3,)
        The camera centre, mm (the origin of a camera-frame cloud).

    Returns
    -------
    ndarray of bool, shape (...)
        True where the angle exceeds ``max_view_deg`` (False for non-finite points).

    Notes
    -----
    Why: near the rim a camera ray meets the surface almost tangentially. A displacement
    ``e`` along the ray then moves the point mostly along the surface, and its distance
    from the centre grows by about ``e^2 (1 - cos^2 a) / 2R`` whatever the sign of ``e``: the
    rim's phase noise (large there: the projector lights it at a grazing angle too) and the
    blur that mixes the sphere with the background behind its rim push the fitted radius
    outwards. docs/acceptance.md ("Edge rules") has the measurements.

    Examples
    --------
    A sphere of radius 10 around (0, 0, 100) seen from the origin: the point facing the
    camera is kept, the one on the silhouette (90 degrees) is grazing.

    >>> pts = [[0.0, 0.0, 90.0], [10.0, 0.0, 100.0]]
    >>> grazing_points(pts, [0.0, 0.0, 100.0], 70.0).tolist()
    [False, True]
    """
    pts = np.asarray(xyz, dtype=np.float64)
    normal = _unit(pts - np.asarray(centre, dtype=np.float64))
    sight = _unit(np.asarray(viewpoint, dtype=np.float64) - pts)
    cos = np.einsum("...i,...i->...", normal, sight)
    with np.errstate(invalid="ignore"):
        return np.asarray(cos < math.cos(math.radians(max_view_deg)))


def neck_points(xyz: ArrayLike, centre: ArrayLike, towards: ArrayLike, neck_deg: float) -> Mask:
    """The points of a ball-bar sphere around its rod: within ``neck_deg`` of the axis.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        The sphere's points, mm.
    centre : array_like, shape (3,)
        The sphere's centre, mm.
    towards : array_like, shape (3,)
        The other sphere's centre, mm: the rod leaves along this direction.
    neck_deg : float
        Half-angle of the cone around the axis, degrees; a rod of radius ``rho`` on a ball
        of radius ``R`` meets it at ``asin(rho / R)``.

    Returns
    -------
    ndarray of bool, shape (...)
        True within the cone (False for non-finite points).

    Notes
    -----
    The rod's surface where it joins the ball lies just outside the ball, within the
    segmentation band, on the side of the other sphere: fitted with the ball it pulls the
    two centres towards each other and SD negative (docs/acceptance.md, "Edge rules").

    Examples
    --------
    >>> pts = [[9.0, 1.0, 0.0], [0.0, 10.0, 0.0]]
    >>> neck_points(pts, [0.0, 0.0, 0.0], [100.0, 0.0, 0.0], 30.0).tolist()
    [True, False]
    """
    pts = np.asarray(xyz, dtype=np.float64)
    c = np.asarray(centre, dtype=np.float64)
    axis = _unit(np.asarray(towards, dtype=np.float64) - c)
    cos = np.einsum("...i,i->...", _unit(pts - c), axis)
    with np.errstate(invalid="ignore"):
        return np.asarray(cos > math.cos(math.radians(neck_deg)))


def segment_sphere(
    xyz: ArrayLike,
    nominal_diameter_mm: float,
    *,
    expected_centre: ArrayLike | None = None,
    search_radius_mm: float | None = None,
    band_mm: float | None = None,
    radius_tolerance: float = 0.1,
    exclude: ArrayLike | None = None,
    min_points: int = MIN_ARTEFACT_POINTS,
    seed: int = 0,
    max_view_deg: float | None = None,
) -> SphereSegment:
    """Find the points of a sphere of known nominal diameter in a measured cloud.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        The cloud, mm (e.g. a triangulated map: NaN where invalid); it may hold a background
        plane, other objects and noise.
    nominal_diameter_mm : float
        The sphere's diameter, mm.
    expected_centre : array_like, shape (3,), optional
        Where the sphere should be, mm: only points within ``search_radius_mm`` of it count.
    search_radius_mm : float, optional
        Default: the nominal diameter (with ``expected_centre``).
    band_mm : float, optional
        A point within this distance of the sphere's surface is the sphere's; default 5 % of
        the nominal diameter. Wider than the form error expected, or PF is clipped.
    radius_tolerance : float
        The found sphere's radius may differ from the nominal by this share.
    exclude : array_like of bool, shape (...), optional
        Points not to consider (e.g. another sphere's).
    min_points : int
        Fewer points on the sphere: not found.
    seed : int
        Seed of the random samples (the result is deterministic).
    max_view_deg : float, optional
        Leave out the points seen at a grazing angle (:func:`grazing_points` from the camera
        centre, the cloud's origin, against the final fit's normals; counted in
        ``n_edge``). None keeps them (the cloud need not be in a camera frame).

    Returns
    -------
    SphereSegment

    Raises
    ------
    ArtefactNotFoundError
        Fewer than ``min_points`` candidate points, or no sphere of that diameter among them.

    Notes
    -----
    1. Candidates: the finite points (near ``expected_centre``), not excluded, off a dominant
       background plane (:func:`~hdrfringe.core.stereo.fit_dominant_plane`, taken only when it
       holds >= 20 % of the candidates with an RMS below a quarter of the band).
    2. :func:`skimage.measure.ransac` with a free-radius sphere model (:func:`fit_sphere` on 4
       points) on up to :data:`SEGMENT_SAMPLE` candidates, hypotheses off the nominal radius
       by more than ``radius_tolerance`` rejected, inlier threshold ``band_mm``.
    3. Twice: the candidates within ``band_mm`` of the sphere, refitted.
    4. With ``max_view_deg``: the grazing points of that fit left out.

    Examples
    --------
    A cap of a 25 mm sphere in front of a plane at 620 mm, with noise:

    >>> rng = np.random.default_rng(4)
    >>> u = rng.normal(size=(1500, 3))
    >>> u[:, 2] = -np.abs(u[:, 2])
    >>> u /= np.linalg.norm(u, axis=1, keepdims=True)
    >>> xy = rng.uniform(-60, 60, (4000, 2))
    >>> cloud = np.r_[12.5 * u + [10, -5, 600], np.c_[xy, np.full(4000, 620.0)]]
    >>> cloud += rng.normal(0, 0.02, cloud.shape)
    >>> seg = segment_sphere(cloud, 25.0)
    >>> seg.centre.round(1).tolist(), round(seg.diameter_mm, 1), seg.n_points
    ([10.0, -5.0, 600.0], 25.0, 1500)
    """
    from skimage.measure import ransac

    nominal = _positive(nominal_diameter_mm, "nominal sphere diameter")
    radius = nominal / 2
    band = _positive(band_mm, "band") if band_mm is not None else 0.05 * nominal
    pts, finite = _points(xyz, "sphere segmentation")
    use = finite.copy()
    where = ""
    centre0: F64 | None = None
    if expected_centre is not None:
        centre0 = np.asarray(expected_centre, dtype=np.float64).reshape(-1)
        if centre0.shape != (3,) or not np.all(np.isfinite(centre0)):
            raise InputError(f"expected centre {expected_centre!r}: give three finite numbers")
        reach = nominal if search_radius_mm is None else _positive(search_radius_mm, "search")
        with np.errstate(invalid="ignore"):
            use &= np.linalg.norm(pts - centre0, axis=-1) <= reach
        where = f" within {reach:g} mm of {np.round(centre0, 3).tolist()}"
    if exclude is not None:
        use &= ~np.asarray(exclude, dtype=bool)
    fix = (
        "check the artefact's position and its diameter in the acceptance file, and that the "
        "measurement has valid points on it"
    )
    what = f"sphere of diameter {nominal:g} mm"
    if int(use.sum()) < min_points:
        raise ArtefactNotFoundError(
            f"{what} not found: {int(use.sum())} points{where}, at least {min_points} needed; {fix}"
        )
    use &= ~_background(pts, use, band, seed)
    candidates = pts[use]
    rng = np.random.default_rng(seed)
    sample = candidates
    if len(sample) > SEGMENT_SAMPLE:
        sample = sample[rng.choice(len(sample), SEGMENT_SAMPLE, replace=False)]

    def plausible(model: _SphereModel, *_: Any) -> bool:
        assert model.params is not None
        if abs(model.params[3] - radius) > radius_tolerance * radius:
            return False
        return centre0 is None or bool(np.linalg.norm(model.params[:3] - centre0) <= nominal)

    model = None
    if len(sample) > 4:
        with warnings.catch_warnings():  # "model is not valid": reported below as not found
            warnings.simplefilter("ignore", UserWarning)
            model, _ = ransac(
                sample,
                _SphereModel,
                min_samples=4,
                residual_threshold=band,
                is_model_valid=plausible,
                max_trials=SEGMENT_TRIALS,
                stop_probability=0.999,
                rng=rng,
            )
    if not model:
        raise ArtefactNotFoundError(
            f"{what} not found among {len(candidates)} points{where}; {fix}"
        )
    centre, r = model.params[:3], float(model.params[3])
    mask = np.zeros(finite.shape, dtype=bool)
    for _ in range(2):
        with np.errstate(invalid="ignore"):
            mask = use & (np.abs(np.linalg.norm(pts - centre, axis=-1) - r) <= band)
        if int(mask.sum()) < min_points:
            break
        fit = fit_sphere(np.where(mask[..., None], pts, np.nan))
        centre, r = fit.centre, fit.radius
    if int(mask.sum()) < min_points or abs(r - radius) > radius_tolerance * radius:
        raise ArtefactNotFoundError(
            f"{what} not found{where}: the best sphere has {int(mask.sum())} points and "
            f"diameter {2 * r:.3f} mm; {fix}"
        )
    with np.errstate(invalid="ignore"):
        near = use & (np.linalg.norm(pts - centre, axis=-1) <= r + 3 * band)
    outliers = int((near & ~mask).sum())
    edge = np.zeros(mask.shape, dtype=bool)
    if max_view_deg is not None:
        edge = mask & grazing_points(pts, centre, max_view_deg)
        mask = mask & ~edge
        if int(mask.sum()) < min_points:
            raise ArtefactNotFoundError(
                f"{what} not found{where}: {int(mask.sum())} points seen within "
                f"{max_view_deg:g} degrees of their normal, at least {min_points} needed; {fix}"
            )
    return SphereSegment(mask, np.asarray(centre), 2 * r, band, outliers, int(edge.sum()))


def segment_ball_bar(
    xyz: ArrayLike,
    nominal_diameters_mm: tuple[float, float],
    nominal_distance_mm: float,
    *,
    expected_centres: tuple[ArrayLike, ArrayLike] | None = None,
    band_mm: float | None = None,
    distance_tolerance: float = 0.1,
    min_points: int = MIN_ARTEFACT_POINTS,
    seed: int = 0,
    max_view_deg: float | None = None,
    neck_deg: float | None = None,
) -> tuple[SphereSegment, SphereSegment]:
    """Find the two spheres of a ball bar in a measured cloud.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        The cloud, mm.
    nominal_diameters_mm : tuple of float
        The diameters of sphere A and sphere B, mm.
    nominal_distance_mm : float
        Their centre distance, mm.
    expected_centres : tuple of array_like, optional
        Where A and B should be, mm (each searched within its diameter).
    band_mm : float, optional
        Selection band of each sphere (:func:`segment_sphere`).
    distance_tolerance : float
        The found centres' distance may differ from the nominal by this share.
    min_points : int
        Fewer points on a sphere: not found.
    seed : int
        Seed of the random samples.
    max_view_deg : float, optional
        Leave out each sphere's grazing points (:func:`segment_sphere`).
    neck_deg : float, optional
        Leave out each sphere's points within this angle of the axis to the other centre
        (:func:`neck_points`: where the rod joins it; counted in ``n_edge``). None keeps them.

    Returns
    -------
    tuple of SphereSegment
        Sphere A, sphere B.

    Raises
    ------
    ArtefactNotFoundError
        A sphere not found, or the two found at a distance off the nominal.

    Notes
    -----
    Sphere A is found first (:func:`segment_sphere`); B among the other points whose distance
    to A's centre is within ``nominal_distance +- (B's radius + band)``, where B's surface
    must lie.

    Examples
    --------
    >>> rng = np.random.default_rng(5)
    >>> u = rng.normal(size=(2000, 3))
    >>> u[:, 2] = -np.abs(u[:, 2])
    >>> u /= np.linalg.norm(u, axis=1, keepdims=True)
    >>> cloud = np.r_[12.5 * u[:1000] + [-75, 0, 600], 12.5 * u[1000:] + [75, 0, 600]]
    >>> a, b = segment_ball_bar(cloud, (25.0, 25.0), 150.0)
    >>> round(float(np.linalg.norm(a.centre - b.centre)), 6), a.n_points + b.n_points
    (150.0, 2000)
    """
    length = _positive(nominal_distance_mm, "nominal centre distance")
    d_a, d_b = (_positive(d, "nominal sphere diameter") for d in nominal_diameters_mm)
    e_a, e_b = expected_centres if expected_centres is not None else (None, None)
    kw: dict[str, Any] = {
        "band_mm": band_mm,
        "min_points": min_points,
        "seed": seed,
        "max_view_deg": max_view_deg,
    }
    a = segment_sphere(xyz, d_a, expected_centre=e_a, **kw)
    pts = np.asarray(xyz, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        off_shell = np.abs(np.linalg.norm(pts - a.centre, axis=-1) - length) > d_b / 2 + a.band_mm
    try:
        b = segment_sphere(xyz, d_b, expected_centre=e_b, exclude=a.mask | off_shell, **kw)
    except ArtefactNotFoundError as err:
        raise ArtefactNotFoundError(f"ball bar, sphere B: {err}") from None
    distance = float(np.linalg.norm(a.centre - b.centre))
    if abs(distance - length) > distance_tolerance * length:
        raise ArtefactNotFoundError(
            f"ball bar not found: the two spheres found are {distance:.3f} mm apart, the "
            f"nominal distance is {length:g} mm; check the ball bar's distance in the "
            "acceptance file and that both spheres are measured"
        )
    if neck_deg is None:
        return a, b
    return _without_neck(pts, a, b.centre, neck_deg), _without_neck(pts, b, a.centre, neck_deg)


def _without_neck(pts: F64, seg: SphereSegment, towards: F64, neck_deg: float) -> SphereSegment:
    """``seg`` without its points around the rod towards the other centre."""
    neck = seg.mask & neck_points(pts, seg.centre, towards, neck_deg)
    return dataclasses.replace(seg, mask=seg.mask & ~neck, n_edge=seg.n_edge + int(neck.sum()))


@dataclass(frozen=True, eq=False)
class PlaneSegment:
    """The points of a plane artefact found in a cloud (:func:`segment_plane`).

    Parameters
    ----------
    mask : ndarray of bool, shape (...)
        The plane's points among the cloud's.
    normal : ndarray, shape (3,)
        Unit normal of the dominant plane (toward the origin).
    offset : float
        ``normal . x`` on it, mm.
    band_mm : float
        The selection band: a point within ``band_mm`` of the plane is the plane's.
    n_outliers : int
        Points over the plane's extent left out by the band (errors F does not see).

    Examples
    --------
    >>> seg = PlaneSegment(np.ones(4, bool), np.array([0, 0, -1.0]), -500.0, 1.0, 0)
    >>> seg.n_points
    4
    """

    mask: Mask
    normal: F64
    offset: float
    band_mm: float
    n_outliers: int

    @property
    def n_points(self) -> int:
        """Points of the plane."""
        return int(self.mask.sum())


def segment_plane(
    xyz: ArrayLike,
    *,
    size_mm: tuple[float, float] | None = None,
    band_mm: float = 1.0,
    min_points: int = MIN_ARTEFACT_POINTS,
    seed: int = 0,
) -> PlaneSegment:
    """Find the points of a plane artefact (the dominant plane) in a measured cloud.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        The cloud, mm.
    size_mm : tuple of float, optional
        The plane's length and width, mm: only points within half its diagonal (plus the
        band) of the plane's inlier centroid count.
    band_mm : float
        A point within this distance of the dominant plane is the plane's; wider than the
        flatness error expected, or F is clipped.
    min_points : int
        Fewer points on the plane: not found.
    seed : int
        Seed of the RANSAC of :func:`~hdrfringe.core.stereo.fit_dominant_plane`.

    Returns
    -------
    PlaneSegment

    Raises
    ------
    ArtefactNotFoundError
        Fewer than ``min_points`` points, or fewer than that within the band.

    Examples
    --------
    >>> rng = np.random.default_rng(6)
    >>> xy = rng.uniform(-100, 100, (3000, 2))
    >>> cloud = np.c_[xy, 500 + 0.1 * xy[:, 0]]
    >>> cloud[:100, 2] += 40  # an object in front of it
    >>> seg = segment_plane(cloud, size_mm=(200, 200))
    >>> seg.n_points, seg.n_outliers
    (2900, 100)
    """
    band = _positive(band_mm, "band")
    pts, finite = _points(xyz, "plane segmentation")
    fix = "check that the plane is in view and measured, and its size in the acceptance file"
    if int(finite.sum()) < min_points:
        raise ArtefactNotFoundError(
            f"plane not found: {int(finite.sum())} finite points, at least {min_points} "
            f"needed; {fix}"
        )
    plane = fit_dominant_plane(pts, seed=seed)
    region = finite.copy()
    if size_mm is not None:
        half = 0.5 * math.hypot(*(_positive(s, "plane size") for s in size_mm)) + band
        centroid = pts[plane.inliers].mean(axis=0)
        lateral = pts - centroid - plane.residuals[..., None] * plane.normal
        with np.errstate(invalid="ignore"):
            region &= np.linalg.norm(lateral, axis=-1) <= half
    with np.errstate(invalid="ignore"):
        mask = region & (np.abs(plane.residuals) <= band)
    if int(mask.sum()) < min_points:
        raise ArtefactNotFoundError(
            f"plane not found: {int(mask.sum())} points within {band:g} mm of the dominant "
            f"plane, at least {min_points} needed; {fix}"
        )
    return PlaneSegment(mask, plane.normal, plane.offset, band, int((region & ~mask).sum()))


# --- MPEs and the table -----------------------------------------------------------------------


@dataclass(frozen=True)
class Mpe:
    """A maximum permissible error ``a + L / k`` (mm), as data sheets state them.

    Parameters
    ----------
    a_mm : float
        The constant part, mm (>= 0).
    k : float or None
        The length divisor: ``L / k`` mm for a length ``L`` mm (dimensionless, > 0); None
        for a constant MPE.

    Examples
    --------
    >>> Mpe(0.02).at(), Mpe(0.02, 10000.0).at(150.0)
    (0.02, 0.035)
    """

    a_mm: float
    k: float | None = None

    def __post_init__(self) -> None:
        if not math.isfinite(self.a_mm) or self.a_mm < 0:
            raise InputError(f"MPE constant must be a finite number >= 0 mm, got {self.a_mm}")
        if self.k is not None and (not math.isfinite(self.k) or self.k <= 0):
            raise InputError(f"MPE length divisor k must be a finite number > 0, got {self.k}")

    def at(self, length_mm: float | None = None) -> float:
        """The MPE for a length.

        Parameters
        ----------
        length_mm : float, optional
            The length ``L``, mm; needed when ``k`` is set.

        Returns
        -------
        float
            ``a + L / k`` mm (``a`` when constant).

        Examples
        --------
        >>> Mpe(0.01, 5000.0).at(100.0)
        0.03
        """
        if self.k is None:
            return float(self.a_mm)
        if length_mm is None or not math.isfinite(length_mm) or length_mm < 0:
            raise InputError(f"a length-dependent MPE needs a length >= 0 mm, got {length_mm}")
        return float(self.a_mm + length_mm / self.k)

    def to_dict(self) -> dict[str, float | None]:
        """``{"a_mm": ..., "k": ...}`` (``k`` None when constant).

        Returns
        -------
        dict

        Examples
        --------
        >>> Mpe(0.02, 20000.0).to_dict()
        {'a_mm': 0.02, 'k': 20000.0}
        """
        return {"a_mm": float(self.a_mm), "k": None if self.k is None else float(self.k)}


@dataclass(frozen=True)
class MpeSet:
    """The MPEs of the four quantities (PF and PS constant; SD and F may depend on length).

    Parameters
    ----------
    pf, ps, sd, f : Mpe
        Probing error form and size, sphere-spacing error, flatness error. The length of SD
        is the calibrated centre distance, that of F the plane's length.

    Examples
    --------
    >>> mpes = MpeSet(Mpe(0.03), Mpe(0.03), Mpe(0.02, 20000.0), Mpe(0.04))
    >>> mpes.of("SD").at(200.0)
    0.03
    """

    pf: Mpe
    ps: Mpe
    sd: Mpe
    f: Mpe

    #: Quantities whose MPE must be a constant.
    CONSTANT: ClassVar[tuple[str, ...]] = ("PF", "PS")

    def __post_init__(self) -> None:
        for q in self.CONSTANT:
            if self.of(q).k is not None:
                raise InputError(f"the MPE of {q} is a constant; give no length divisor k")

    def of(self, quantity: str) -> Mpe:
        """The MPE of a quantity.

        Parameters
        ----------
        quantity : str
            One of :data:`QUANTITIES`.

        Returns
        -------
        Mpe

        Examples
        --------
        >>> MpeSet(Mpe(0.03), Mpe(0.02), Mpe(0.05), Mpe(0.04)).of("PS").a_mm
        0.02
        """
        if quantity not in QUANTITIES:
            raise InputError(f"unknown quantity {quantity!r}; use one of {', '.join(QUANTITIES)}")
        mpe: Mpe = getattr(self, quantity.lower())
        return mpe

    def to_dict(self) -> dict[str, dict[str, float | None]]:
        """Each quantity's :meth:`Mpe.to_dict`.

        Returns
        -------
        dict

        Examples
        --------
        >>> sorted(MpeSet(Mpe(0.03), Mpe(0.03), Mpe(0.05), Mpe(0.04)).to_dict())
        ['F', 'PF', 'PS', 'SD']
        """
        return {q: self.of(q).to_dict() for q in QUANTITIES}


@dataclass(frozen=True)
class PositionResult:
    """One row of the acceptance table: a quantity at a position against its MPE.

    Parameters
    ----------
    position : str
        The position's id (e.g. ``"sphere-03"``).
    quantity : str
        One of :data:`QUANTITIES`.
    value_mm : float or None
        The value, mm (PS and SD signed); None when the position could not be evaluated.
    mpe_mm : float
        The MPE at this position, mm.
    passed : bool
        ``|value| <= MPE``; False when not evaluated.
    length_mm : float or None
        The length the MPE was taken at (SD, F), mm.
    note : str
        Why the position was not evaluated ("" when it was).

    Examples
    --------
    >>> mpes = MpeSet(Mpe(0.03), Mpe(0.01), Mpe(0.05), Mpe(0.04))
    >>> r = check_position("sphere-01", "PS", -0.012, mpes)
    >>> r.passed, r.to_dict()["value_mm"]
    (False, -0.012)
    """

    position: str
    quantity: str
    value_mm: float | None
    mpe_mm: float
    passed: bool
    length_mm: float | None = None
    note: str = ""

    @property
    def evaluated(self) -> bool:
        """Whether the position has a value."""
        return self.value_mm is not None

    def to_dict(self) -> dict[str, Any]:
        """The row as plain JSON types (no NaN: an unevaluated value is None).

        Returns
        -------
        dict
            ``position, quantity, value_mm, mpe_mm, passed, length_mm, note``.

        Examples
        --------
        >>> mpes = MpeSet(Mpe(.03), Mpe(.03), Mpe(.05), Mpe(.04))
        >>> check_position("plane-2", "F", None, mpes, length_mm=200, note="no points").to_dict()
        ... # doctest: +NORMALIZE_WHITESPACE
        {'position': 'plane-2', 'quantity': 'F', 'value_mm': None, 'mpe_mm': 0.04,
         'passed': False, 'length_mm': 200.0, 'note': 'no points'}
        """
        return {
            "position": self.position,
            "quantity": self.quantity,
            "value_mm": self.value_mm,
            "mpe_mm": self.mpe_mm,
            "passed": self.passed,
            "length_mm": self.length_mm,
            "note": self.note,
        }


def check_position(
    position: str,
    quantity: str,
    value_mm: float | None,
    mpes: MpeSet,
    *,
    length_mm: float | None = None,
    note: str = "",
) -> PositionResult:
    """Compare one value with its MPE.

    Parameters
    ----------
    position : str
        The position's id.
    quantity : str
        ``"PF"``, ``"PS"``, ``"SD"`` or ``"F"``.
    value_mm : float or None
        The value, mm; None or NaN: the position could not be evaluated (recorded as None,
        failed, with ``note``).
    mpes : MpeSet
        The MPEs.
    length_mm : float, optional
        The length of a length-dependent MPE (SD: calibrated centre distance, F: plane length).
    note : str
        Why it was not evaluated; required then (default "not evaluated").

    Returns
    -------
    PositionResult
        ``passed`` = ``|value| <= MPE`` (PS and SD are signed, PF and F >= 0).

    Examples
    --------
    >>> mpes = MpeSet(Mpe(0.03), Mpe(0.03), Mpe(0.02, 20000.0), Mpe(0.04))
    >>> r = check_position("ballbar-1", "SD", -0.025, mpes, length_mm=200.0)
    >>> r.mpe_mm, r.passed
    (0.03, True)
    >>> check_position("ballbar-2", "SD", float("nan"), mpes, length_mm=200.0).value_mm is None
    True
    """
    mpe = mpes.of(quantity).at(None if length_mm is None else float(length_mm))
    length = None if length_mm is None else float(length_mm)
    if value_mm is None or not math.isfinite(float(value_mm)):
        return PositionResult(
            str(position), quantity, None, mpe, False, length, note or "not evaluated"
        )
    value = float(value_mm)
    return PositionResult(str(position), quantity, value, mpe, abs(value) <= mpe, length, note)


@dataclass(frozen=True)
class AcceptanceSummary:
    """The acceptance table and its verdict (:func:`summarize`).

    Parameters
    ----------
    records : tuple of PositionResult
        Every row, in the order given.

    Examples
    --------
    >>> mpes = MpeSet(Mpe(0.03), Mpe(0.03), Mpe(0.05), Mpe(0.04))
    >>> s = summarize([check_position("s1", "PF", 0.01, mpes),
    ...                check_position("s1", "PS", 0.04, mpes)])
    >>> s.all_passed, [(r.position, r.quantity) for r in s.failed]
    (False, [('s1', 'PS')])
    """

    records: tuple[PositionResult, ...]

    @property
    def all_passed(self) -> bool:
        """Whether every row passed (an empty table does not pass)."""
        return bool(self.records) and all(r.passed for r in self.records)

    @property
    def failed(self) -> tuple[PositionResult, ...]:
        """The rows that failed, unevaluated ones included."""
        return tuple(r for r in self.records if not r.passed)

    @property
    def not_evaluated(self) -> tuple[PositionResult, ...]:
        """The rows without a value."""
        return tuple(r for r in self.records if not r.evaluated)

    def to_dict(self) -> dict[str, Any]:
        """The table as plain JSON types (no NaN).

        Returns
        -------
        dict
            ``all_passed``; per quantity the positions, passes, the largest ``|value|`` and
            its MPE ratio; ``failed`` (``"position/quantity"``); ``records``.

        Examples
        --------
        >>> mpes = MpeSet(Mpe(0.03), Mpe(0.03), Mpe(0.05), Mpe(0.04))
        >>> d = summarize([check_position("s1", "PF", 0.015, mpes)]).to_dict()
        >>> d["all_passed"], d["quantities"]["PF"]
        (True, {'positions': 1, 'passed': 1, 'max_abs_mm': 0.015, 'max_ratio': 0.5})
        """
        quantities: dict[str, Any] = {}
        for q in QUANTITIES:
            rows = [r for r in self.records if r.quantity == q]
            if not rows:
                continue
            pairs = [(abs(r.value_mm), r.mpe_mm) for r in rows if r.value_mm is not None]
            ratios = [v / m for v, m in pairs if m > 0]
            quantities[q] = {
                "positions": len(rows),
                "passed": sum(r.passed for r in rows),
                "max_abs_mm": max((v for v, _ in pairs), default=None),
                "max_ratio": round(max(ratios), 12) if ratios else None,
            }
        return {
            "all_passed": self.all_passed,
            "quantities": quantities,
            "failed": [f"{r.position}/{r.quantity}" for r in self.failed],
            "records": [r.to_dict() for r in self.records],
        }


def summarize(records: Sequence[PositionResult]) -> AcceptanceSummary:
    """The acceptance table of a list of rows.

    Parameters
    ----------
    records : sequence of PositionResult
        From :func:`check_position`.

    Returns
    -------
    AcceptanceSummary

    Examples
    --------
    >>> mpes = MpeSet(Mpe(0.03), Mpe(0.03), Mpe(0.05), Mpe(0.04))
    >>> summarize([check_position("p1", "F", 0.02, mpes)]).all_passed
    True
    >>> summarize([]).all_passed
    False
    """
    return AcceptanceSummary(tuple(records))
