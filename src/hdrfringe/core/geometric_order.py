"""Fringe order from the projector-camera geometry (geometric-constraint unwrapping).

A calibrated projector-camera pair does not need a pattern spanning the projector to make a
phase absolute: every camera pixel looks along one ray, and a depth range ``[zmin, zmax]``
(along the camera axis, mm) that the scene is known to lie in cuts that ray to a segment. The
projector coordinates the segment can light span an interval ``[lo, hi]`` (the segment's image
in the projector, along the epipolar line); a wrapped phase ``phi`` of pitch ``p`` admits the
coordinates ``p * phi / (2*pi) + k*p``, and the orders ``k`` that fall in the interval are the
pixel's candidates. Exactly one candidate: the absolute phase. None (the scene leaves the
range, or the phase is wrong) or several (the range is too deep for the pitch): the pixel is
invalid, never guessed. (An, Hyun & Zhang 2016, Opt. Express 24:18445, bound the order from
one side with the phase of a virtual plane at the nearest depth; here the range's two planes
bound it from both sides, so a range too deep for the pitch shows as ambiguity, not as a wrong
order.)

* :func:`ray_coordinate_span`: ``[lo, hi]`` of every pixel (the ray's projection at depths
  spaced evenly in ``1/z``, with the projector's lens distortion; clipped to the projector's
  extent, since the light came from it).
* :func:`geometric_order`: the candidates and, where unique, the absolute phase; then the
  neighbourhood check: a pixel whose projector coordinate differs by more than half a pitch from
  every one of its 8 valid neighbours (an isolated order) is invalid too.
* :func:`family_geometric_order`: a decoded family without an absolute phase
  (:class:`~hdrfringe.core.decode.FamilyResult`): its coarsest set ordered from the geometry, the
  finer sets unwrapped temporally from it (:func:`~hdrfringe.core.unwrap.unwrap_temporal`, as from
  a Gray code).
* :func:`unambiguous_depth_mm`: how deep a range one pitch allows: from a near depth, the far
  depth at which the ray's projector coordinate has moved by one pitch (docs/stereo.md, "Fringe
  order from geometry").
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core.decode import FamilyResult, FolderPhase
from hdrfringe.core.stereo import StereoCalibration, ray_table
from hdrfringe.core.unwrap import unwrap_temporal
from hdrfringe.errors import InputError

__all__ = [
    "GeometricOrder",
    "check_depth_range",
    "family_geometric_order",
    "geometric_order",
    "ray_coordinate_span",
    "ray_projector_points",
    "unambiguous_depth_mm",
]

F64 = NDArray[np.float64]
TWO_PI = 2.0 * np.pi

#: Depths (evenly spaced in 1/z, both ends included) at which a ray is projected into the
#: projector: the ends alone for a pinhole (the coordinate is monotonic along the ray), the
#: middle one for an epipolar line that lens distortion bends.
DEFAULT_SAMPLES = 3
#: How far (a fraction of the pitch) a decoded coordinate may lie outside the range's interval
#: and still take its order there: phase noise and the calibration's disagreement with the
#: scene move it (thomriiii: the decoded rows lie some 10 px off the epipolar line, and without
#: a margin 11 % of its pixels keep an order, docs/stereo.md). A wider margin never makes a
#: pixel's order wrong, only ambiguous; it shortens the unambiguous range to ``1 - 2 * margin``
#: of a pitch.
DEFAULT_MARGIN = 0.125
#: 8-neighbourhood offsets (row, column) of the isolated-order check.
_NEIGHBOURS = tuple((dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0))


def check_depth_range(depth_range_mm: Any) -> tuple[float, float]:
    """A depth range ``(zmin, zmax)`` in mm, checked: finite, ``0 < zmin < zmax``.

    Parameters
    ----------
    depth_range_mm : sequence of two numbers
        Nearest and farthest depth along the camera axis, mm.

    Returns
    -------
    tuple of float

    Raises
    ------
    InputError
        Not two numbers, not finite, not positive, or not increasing.

    Examples
    --------
    >>> check_depth_range((500, 900))
    (500.0, 900.0)
    >>> check_depth_range((900, 500))
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: depth range 900:500 mm: give ZMIN:ZMAX with 0 < ZMIN < ZMAX ...
    """
    try:
        zmin, zmax = (float(v) for v in depth_range_mm)
    except (TypeError, ValueError):
        raise InputError(
            f"depth range {depth_range_mm!r}: give two depths ZMIN:ZMAX in mm, e.g. 500:900"
        ) from None
    if not (np.isfinite(zmin) and np.isfinite(zmax) and 0 < zmin < zmax):
        raise InputError(
            f"depth range {zmin:g}:{zmax:g} mm: give ZMIN:ZMAX with 0 < ZMIN < ZMAX (depths "
            "along the camera axis, mm), e.g. 500:900"
        )
    return zmin, zmax


def _orientation_axis(orientation: str) -> int:
    if orientation not in ("vertical", "horizontal"):
        raise InputError(f"orientation {orientation!r}: give vertical or horizontal")
    return 0 if orientation == "vertical" else 1


def _camera_rays(
    calibration: StereoCalibration, u_cam: ArrayLike | None, v_cam: ArrayLike | None
) -> tuple[F64, tuple[int, ...]]:
    """Undistorted rays ``(x, y, 1)`` (n, 3) of camera pixels (default: every pixel) and the
    shape of the pixel grid."""
    if not isinstance(calibration, StereoCalibration):
        raise InputError("calibration must be a StereoCalibration (measure -c STEREO.h5)")
    if (u_cam is None) != (v_cam is None):
        raise InputError("give both u_cam and v_cam, or neither (every camera pixel)")
    if u_cam is None:  # every pixel: the camera's ray table, computed once per calibration
        table = ray_table(calibration.camera)
        x, y = table[0].reshape(-1), table[1].reshape(-1)
        return np.stack([x, y, np.ones_like(x)], axis=-1), table.shape[1:]
    try:
        cols, rows = np.broadcast_arrays(
            np.asarray(u_cam, np.float64), np.asarray(v_cam, np.float64)
        )
    except ValueError:
        raise InputError("u_cam and v_cam do not broadcast; give arrays of one shape") from None
    x, y = calibration.camera.undistort(cols.reshape(-1), rows.reshape(-1))
    return np.stack([x, y, np.ones_like(x)], axis=-1), cols.shape


def _coordinate_at(calibration: StereoCalibration, rays: F64, depth: F64, axis: int) -> F64:
    """Projector coordinate (column for ``axis`` 0, row for 1) of ray points at depths."""
    pts = rays * np.asarray(depth, np.float64).reshape(-1, 1)
    u, v = calibration.projector.project(pts @ calibration.rotation.T + calibration.translation_mm)
    return u if axis == 0 else v


def ray_coordinate_span(
    calibration: StereoCalibration,
    orientation: str,
    depth_range_mm: tuple[float, float],
    *,
    u_cam: ArrayLike | None = None,
    v_cam: ArrayLike | None = None,
    samples: int = DEFAULT_SAMPLES,
) -> tuple[F64, F64]:
    """Projector coordinates a camera pixel can see when the scene lies in a depth range.

    Parameters
    ----------
    calibration : StereoCalibration
        The projector-camera calibration.
    orientation : {"vertical", "horizontal"}
        Vertical fringes: the projector column; horizontal: the row.
    depth_range_mm : tuple of float
        ``(zmin, zmax)`` along the camera axis, mm.
    u_cam, v_cam : array_like, optional
        Camera pixels (OpenCV convention); default every pixel of the calibrated camera,
        shape ``(H, W)``.
    samples : int
        Depths at which each ray is projected, evenly spaced in ``1/z`` from ``zmin`` to
        ``zmax`` (at least 2).

    Returns
    -------
    lo, hi : ndarray
        The smallest and largest coordinate over the samples, clipped to the projector's
        extent ``[-0.5, size - 0.5]`` (pixel centres at integers); NaN where a sample does not
        project (behind the projector, a camera pixel that does not undistort), and where the
        clipped interval is empty (the ray never meets the projector's image).

    Notes
    -----
    Without lens distortion a ray projects to a straight epipolar line, along which the
    coordinate moves monotonically with depth, so the two ends bound it; the inner samples
    follow an epipolar line that distortion bends.

    Examples
    --------
    >>> from hdrfringe.core.stereo import LensModel
    >>> cam = LensModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], [], (640, 480))
    >>> proj = LensModel([[1000, 0, 400], [0, 1000, 300], [0, 0, 1]], [], (800, 600))
    >>> calib = StereoCalibration(cam, proj, np.eye(3), [-100.0, 0, 0])
    >>> lo, hi = ray_coordinate_span(calib, "vertical", (400, 500), u_cam=320.0, v_cam=240.0)
    >>> float(lo), float(hi)  # 400 - 1000 * 100 / z at z = 400 and 500 mm
    (150.0, 200.0)
    """
    axis = _orientation_axis(orientation)
    zmin, zmax = check_depth_range(depth_range_mm)
    if int(samples) != samples or samples < 2:
        raise InputError(f"samples must be an integer >= 2, got {samples}")
    rays, shape = _camera_rays(calibration, u_cam, v_cam)
    depths = 1.0 / np.linspace(1.0 / zmin, 1.0 / zmax, int(samples))
    lo = np.full(rays.shape[0], np.inf)
    hi = np.full(rays.shape[0], -np.inf)
    lost = np.zeros(rays.shape[0], bool)  # a sample that does not project: the pixel is out
    for z in depths:
        c = _coordinate_at(calibration, rays, np.full(rays.shape[0], z), axis)
        lo = np.fmin(lo, c)
        hi = np.fmax(hi, c)
        lost |= np.isnan(c)
    extent = calibration.projector.size[axis]
    lo = np.maximum(lo, -0.5)
    hi = np.minimum(hi, extent - 0.5)
    empty = lost | ~(lo <= hi)
    lo[empty] = np.nan
    hi[empty] = np.nan
    return lo.reshape(shape), hi.reshape(shape)


def ray_projector_points(
    calibration: StereoCalibration,
    depth_range_mm: tuple[float, float],
    u_cam: ArrayLike,
    v_cam: ArrayLike,
    *,
    step_px: float = 1.0,
) -> tuple[F64, F64]:
    """Projector points a camera pixel's ray can light over a depth range: its epipolar segment.

    Parameters
    ----------
    calibration : StereoCalibration
        The projector-camera calibration.
    depth_range_mm : tuple of float
        ``(zmin, zmax)`` along the camera axis, mm.
    u_cam, v_cam : array_like
        Camera pixels (OpenCV convention), one shape.
    step_px : float
        Largest spacing of consecutive points along a segment, projector pixels (> 0).

    Returns
    -------
    u, v : ndarray, shape (samples, n)
        Projector column and row of each of ``n`` pixels' rays at ``samples`` depths evenly
        spaced in ``1/z`` from ``zmin`` to ``zmax``, as many as keep the longest segment's
        points ``step_px`` apart; NaN where a point does not project.

    Examples
    --------
    >>> from hdrfringe.core.stereo import LensModel
    >>> cam = LensModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], [], (640, 480))
    >>> proj = LensModel([[1000, 0, 400], [0, 1000, 300], [0, 0, 1]], [], (800, 600))
    >>> calib = StereoCalibration(cam, proj, np.eye(3), [-100.0, 0, 0])
    >>> u, v = ray_projector_points(calib, (400, 500), [320.0], [240.0], step_px=10)
    >>> u[:, 0].round(1).tolist(), sorted(set(v[:, 0].tolist()))  # 400 - 1000 * 100 / z
    ([150.0, 160.0, 170.0, 180.0, 190.0, 200.0], [300.0])
    """
    zmin, zmax = check_depth_range(depth_range_mm)
    if not (np.isfinite(step_px) and step_px > 0):
        raise InputError(f"step must be a positive number of projector pixels, got {step_px}")
    rays, _ = _camera_rays(calibration, u_cam, v_cam)
    if rays.shape[0] == 0:
        return np.empty((2, 0)), np.empty((2, 0))

    def at(inverse_depths: F64) -> tuple[F64, F64]:
        pts = rays[None, :, :] / inverse_depths[:, None, None]
        world = pts.reshape(-1, 3) @ calibration.rotation.T + calibration.translation_mm
        u, v = calibration.projector.project(world)
        return u.reshape(inverse_depths.size, -1), v.reshape(inverse_depths.size, -1)

    ends = np.array([1.0 / zmin, 1.0 / zmax])
    u, v = at(ends)
    length = float(np.nanmax(np.hypot(u[1] - u[0], v[1] - v[0]), initial=0.0))
    samples = max(2, int(np.ceil(length / float(step_px))) + 1)
    return at(np.linspace(ends[0], ends[1], samples))


@dataclass(frozen=True, eq=False)
class GeometricOrder:
    """The fringe order of every pixel from a depth range (:func:`geometric_order`).

    Parameters
    ----------
    absolute_phase : ndarray, shape (H, W)
        ``2*pi*x/p`` where exactly one order fits and the neighbourhood check passes; NaN
        elsewhere.
    order : ndarray, shape (H, W)
        The fringe order ``k`` (integer values, float64), NaN where ``absolute_phase`` is.
    candidates : ndarray of int, shape (H, W)
        Number of orders whose coordinate lies in the range's projector interval (0 where
        the phase or the interval is invalid).
    isolated : ndarray of bool, shape (H, W)
        Pixels with one candidate that the neighbourhood check rejected.
    decoded : ndarray of bool, shape (H, W)
        Pixels with a wrapped phase.
    pitch_px : float
        The pitch the order counts.
    orientation : str
        ``vertical`` (projector columns) or ``horizontal`` (rows).
    depth_range_mm : tuple of float
        ``(zmin, zmax)``.
    margin_px : float
        How far outside the range's interval a coordinate still took its order, projector px.

    Examples
    --------
    >>> z = np.zeros((1, 2))
    >>> g = GeometricOrder(z, z, np.array([[1, 2]]), z > 0, z == 0, 16.0, "vertical", (1, 2))
    >>> g.summary()["ambiguous_fraction"]
    0.5
    """

    absolute_phase: F64
    order: F64
    candidates: NDArray[np.int64]
    isolated: NDArray[np.bool_]
    decoded: NDArray[np.bool_]
    pitch_px: float
    orientation: str
    depth_range_mm: tuple[float, float]
    margin_px: float = 0.0

    @property
    def valid(self) -> NDArray[np.bool_]:
        """Pixels with an absolute phase."""
        return np.asarray(np.isfinite(self.absolute_phase))

    def summary(self) -> dict[str, Any]:
        """Figures for ``metrics.json``, as fractions of the decoded pixels.

        Returns
        -------
        dict
            ``method`` ("geometric"), the depth range, the pitch, the decoded pixel count and
            the fractions with no candidate, one, several (``ambiguous_fraction``), rejected
            as isolated, and kept (``valid_fraction``).
        """
        n = int(self.decoded.sum())

        def frac(mask: NDArray[np.bool_]) -> float:
            return float((mask & self.decoded).sum() / n) if n else float("nan")

        return {
            "method": "geometric",
            "depth_range_mm": [float(v) for v in self.depth_range_mm],
            "pitch_px": float(self.pitch_px),
            "margin_px": float(self.margin_px),
            "decoded_pixels": n,
            "no_candidate_fraction": frac(self.candidates == 0),
            "ambiguous_fraction": frac(self.candidates >= 2),
            "isolated_fraction": frac(self.isolated),
            "valid_fraction": frac(self.valid),
        }


def _isolated(coordinate: F64, pitch_px: float) -> NDArray[np.bool_]:
    """Valid pixels whose coordinate is within half a pitch of none of its 8 neighbours."""
    h, w = coordinate.shape
    padded = np.pad(coordinate, 1, constant_values=np.nan)
    agree = np.zeros(coordinate.shape, bool)
    for dr, dc in _NEIGHBOURS:
        nb = padded[1 + dr : 1 + dr + h, 1 + dc : 1 + dc + w]
        with np.errstate(invalid="ignore"):
            agree |= np.abs(coordinate - nb) < 0.5 * pitch_px
    return np.asarray(np.isfinite(coordinate) & ~agree)


def geometric_order(
    wrapped_phase: ArrayLike,
    pitch_px: float,
    orientation: str,
    calibration: StereoCalibration,
    depth_range_mm: tuple[float, float],
    *,
    margin: float = DEFAULT_MARGIN,
    neighbours: bool = True,
    samples: int = DEFAULT_SAMPLES,
) -> GeometricOrder:
    """Absolute phase of a wrapped phase map from a stereo calibration and a depth range.

    Parameters
    ----------
    wrapped_phase : array_like, shape (H, W)
        Wrapped phase of one fringe set, hdrfringe's convention ``2*pi*x/p (mod 2*pi)``
        (docs/phase.md), NaN invalid; the calibrated camera's size.
    pitch_px : float
        The set's pitch, projector pixels.
    orientation : {"vertical", "horizontal"}
        Vertical fringes give the projector column, horizontal ones the row.
    calibration : StereoCalibration
        The projector-camera calibration.
    depth_range_mm : tuple of float
        ``(zmin, zmax)``: the scene's depths along the camera axis, mm.
    margin : float
        The range's projector interval is widened by ``margin * pitch_px`` on each side
        (:data:`DEFAULT_MARGIN`, an eighth of a pitch), in ``[0, 0.5)``.
    neighbours : bool
        Apply the neighbourhood check (isolated orders are invalid).
    samples : int
        Depths per ray (:func:`ray_coordinate_span`).

    Returns
    -------
    GeometricOrder

    Notes
    -----
    With ``f = p * (phi mod 2*pi) / (2*pi)`` the candidate coordinates are ``f + k*p``; those
    in ``[lo - m, hi + m]`` (:func:`ray_coordinate_span`, ``m = margin * p``) are the orders
    ``ceil((lo - m - f)/p) .. floor((hi + m - f)/p)``. The range is unambiguous at a pixel
    when ``hi - lo + 2*m < p`` (:func:`unambiguous_depth_mm` with the pitch ``p - 2*m``); a
    deeper range leaves the pixels where two orders fit invalid. A coordinate more than ``m``
    outside the interval (a scene point outside the range, a calibration that misplaces it)
    gets no order, or, far enough outside, a wrong one: the range must hold the scene.

    The neighbourhood check: the projector coordinate is continuous over a surface, so a pixel
    whose coordinate differs by half a pitch or more from every valid 8-neighbour (or that
    has none) is taken as an order error, not as a surface of its own, and made invalid.

    References
    ----------
    An, Hyun & Zhang 2016, "Pixel-wise absolute phase unwrapping using geometric constraints
    of structured light system", Opt. Express 24(16):18445.

    Examples
    --------
    A plane 410 mm away, pitch 40 px: over depths 400..500 mm the column moves by 50 px along
    each ray, and the plane's column and the one a pitch further (at 493 mm) both fit; over
    400..440 mm (23 px) one order does:

    >>> from hdrfringe.core.stereo import LensModel
    >>> cam = LensModel([[1000, 0, 15.5], [0, 1000, 11.5], [0, 0, 1]], [], (32, 24))
    >>> proj = LensModel([[1000, 0, 400], [0, 1000, 300], [0, 0, 1]], [], (800, 600))
    >>> calib = StereoCalibration(cam, proj, np.eye(3), [-100.0, 0, 0])
    >>> cols = np.tile(np.arange(32.0), (24, 1))
    >>> u = (cols - 15.5) + 400 - 1000 * 100 / 410  # the column lighting each pixel
    >>> phi = np.mod(2 * np.pi * u / 40, 2 * np.pi)
    >>> g = geometric_order(phi, 40.0, "vertical", calib, (400, 500))
    >>> np.unique(g.candidates).tolist(), int(g.valid.sum())
    ([2], 0)
    >>> g = geometric_order(phi, 40.0, "vertical", calib, (400, 440))
    >>> bool(np.allclose(g.absolute_phase * 40 / (2 * np.pi), u)), g.summary()["valid_fraction"]
    (True, 1.0)
    """
    p = float(pitch_px)
    if not (np.isfinite(p) and p > 0):
        raise InputError(f"pitch must be a positive number of projector pixels, got {pitch_px}")
    zrange = check_depth_range(depth_range_mm)
    if not (np.isfinite(margin) and 0 <= margin < 0.5):
        raise InputError(f"margin must be a fraction of the pitch in [0, 0.5), got {margin}")
    phi = np.asarray(wrapped_phase, dtype=np.float64)
    if not isinstance(calibration, StereoCalibration):
        raise InputError("calibration must be a StereoCalibration (measure -c STEREO.h5)")
    width, height = calibration.camera.size
    if phi.shape != (height, width):
        raise InputError(
            f"wrapped phase: shape {phi.shape}, but the calibration's camera is {width}x{height} "
            "(W x H); give the phase of the calibrated camera"
        )
    lo, hi = ray_coordinate_span(calibration, orientation, zrange, samples=samples)
    decoded = np.isfinite(phi)
    frac = np.mod(phi, TWO_PI) * (p / TWO_PI)
    m = float(margin) * p
    with np.errstate(invalid="ignore"):
        k_lo = np.ceil((lo - m - frac) / p)
        k_hi = np.floor((hi + m - frac) / p)
    count = np.where(np.isfinite(k_lo) & np.isfinite(k_hi), k_hi - k_lo + 1, 0)
    candidates = np.maximum(count, 0).astype(np.int64)
    unique = candidates == 1
    coordinate = np.where(unique, frac + k_lo * p, np.nan)
    isolated = _isolated(coordinate, p) if neighbours else np.zeros(phi.shape, bool)
    coordinate[isolated] = np.nan
    keep = np.isfinite(coordinate)
    absolute = np.where(keep, coordinate * (TWO_PI / p), np.nan)
    order = np.where(keep, k_lo, np.nan)
    return GeometricOrder(absolute, order, candidates, isolated, decoded, p, orientation, zrange, m)


def family_geometric_order(
    decoded: FolderPhase,
    family: FamilyResult,
    calibration: StereoCalibration,
    depth_range_mm: tuple[float, float],
    *,
    margin: float = DEFAULT_MARGIN,
) -> tuple[FamilyResult, GeometricOrder]:
    """A family's absolute phase with its coarsest set's order from the geometry.

    Parameters
    ----------
    decoded : FolderPhase
        What :func:`~hdrfringe.core.decode.decode_captures` returned (the sets' wrapped phases).
    family : FamilyResult
        One of ``decoded.families``.
    calibration : StereoCalibration
        The projector-camera calibration.
    depth_range_mm : tuple of float
        ``(zmin, zmax)`` along the camera axis, mm.
    margin : float
        As for :func:`geometric_order`.

    Returns
    -------
    family : FamilyResult
        The family with ``absolute_phase`` (finest set) and ``absolute_method`` set.
    order : GeometricOrder
        The coarsest set's orders.

    Notes
    -----
    The coarsest set is ordered (:func:`geometric_order`): its pitch allows the deepest
    range. The finer sets follow it pixel by pixel (:func:`~hdrfringe.core.unwrap.unwrap_temporal`
    from an absolute coarse phase, as the Gray code path does), so a family of one set is
    ordered directly and a family of several is as absolute as its coarsest set. The
    spatially unwrapped phase is not used: its per-region constant is what the geometry
    replaces.

    Examples
    --------
    See :func:`geometric_order`; ``pipeline.measure(..., depth_range_mm=...)`` calls this.
    """
    coarse = family.sets[0]
    phi = decoded.set_results[coarse.label].wrapped_phase
    order = geometric_order(
        phi, coarse.spec.pitch_px, family.orientation, calibration, depth_range_mm, margin=margin
    )
    if len(family.sets) > 1:
        phases = [order.absolute_phase] + [
            decoded.set_results[s.label].wrapped_phase for s in family.sets[1:]
        ]
        absolute = unwrap_temporal(
            phases, [s.spec.pitch_px for s in family.sets], coarse_unwrapped=True
        )
        finer = f", temporal to {family.pitch_px:g} px"
    else:
        absolute = order.absolute_phase
        finer = ""
    zmin, zmax = order.depth_range_mm
    how = (
        f"geometric: order of the {coarse.spec.pitch_px:g} px set from the stereo calibration "
        f"and the depth range {zmin:g}..{zmax:g} mm{finer}"
    )
    return dataclasses.replace(family, absolute_phase=absolute, absolute_method=how), order


def unambiguous_depth_mm(
    calibration: StereoCalibration,
    pitch_px: float,
    orientation: str,
    near_mm: float,
    *,
    u_cam: ArrayLike | None = None,
    v_cam: ArrayLike | None = None,
    iterations: int = 60,
) -> F64:
    """The farthest depth from ``near_mm`` over which one fringe order stays unambiguous.

    Parameters
    ----------
    calibration : StereoCalibration
        The projector-camera calibration (with its lens distortion).
    pitch_px : float
        Fringe pitch, projector pixels.
    orientation : {"vertical", "horizontal"}
        Vertical fringes (projector columns) or horizontal ones (rows).
    near_mm : float
        The near end of the range along the camera axis, mm.
    u_cam, v_cam : array_like, optional
        Camera pixels; default every pixel, shape ``(H, W)``.
    iterations : int
        Bisection steps on ``1/z`` (60: to machine precision).

    Returns
    -------
    ndarray
        Per pixel the depth ``z_far > near_mm`` at which the ray's projector coordinate has
        moved by exactly one pitch from its value at ``near_mm``: every range
        ``[near_mm, z]`` with ``z < z_far`` admits one order per pixel (:func:`geometric_order`).
        ``inf`` where the coordinate never moves a pitch (the ray's vanishing point is closer
        than a pitch); NaN where the ray does not project at ``near_mm``.

    Notes
    -----
    For a parallel rig (projector axes along the camera's, baseline ``B`` along the fringes'
    normal, projector focal length ``f_p`` px, no distortion) the coordinate along a ray is
    ``c(z) = c_inf - f_p * B / z``, so one pitch from ``z1`` ends at
    ``1/z2 = 1/z1 - p / (f_p * B)``: ``z2 - z1 = p * z1**2 / (f_p * B - p * z1)``, about
    ``p * z**2 / (f_p * B)``. In general the coordinate moves monotonically along a ray, and
    the depth is found by bisection on ``1/z`` with the full lens model.

    Examples
    --------
    >>> from hdrfringe.core.stereo import LensModel
    >>> cam = LensModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], [], (640, 480))
    >>> proj = LensModel([[1000, 0, 400], [0, 1000, 300], [0, 0, 1]], [], (800, 600))
    >>> calib = StereoCalibration(cam, proj, np.eye(3), [-100.0, 0, 0])
    >>> z = unambiguous_depth_mm(calib, 20.0, "vertical", 500.0, u_cam=320.0, v_cam=240.0)
    >>> round(float(z), 6), 500 / (1 - 20 * 500 / (1000 * 100))  # the closed form
    (555.555556, 555.5555555555555)
    """
    axis = _orientation_axis(orientation)
    p = float(pitch_px)
    if not (np.isfinite(p) and p > 0):
        raise InputError(f"pitch must be a positive number of projector pixels, got {pitch_px}")
    near = float(near_mm)
    if not (np.isfinite(near) and near > 0):
        raise InputError(f"near depth must be a positive number of mm, got {near_mm}")
    rays, shape = _camera_rays(calibration, u_cam, v_cam)
    n = rays.shape[0]
    c_near = _coordinate_at(calibration, rays, np.full(n, near), axis)
    # the vanishing point of each ray (z -> infinity): the direction R d projected
    u_inf, v_inf = calibration.projector.project(rays @ calibration.rotation.T)
    c_inf = u_inf if axis == 0 else v_inf
    finite = ~(np.abs(c_inf - c_near) <= p)  # NaN (no vanishing point in front): finite too
    # bisection on w = 1/z in (0, 1/near): beyond one pitch (or not projecting) at lo_w
    lo_w = np.zeros(n)
    hi_w = np.full(n, 1.0 / near)
    for _ in range(int(iterations)):
        mid = 0.5 * (lo_w + hi_w)
        with np.errstate(divide="ignore"):
            c = _coordinate_at(calibration, rays, 1.0 / mid, axis)
        beyond = ~(np.abs(c - c_near) < p)
        lo_w = np.where(beyond, mid, lo_w)
        hi_w = np.where(beyond, hi_w, mid)
    z_far = np.where(finite, 1.0 / (0.5 * (lo_w + hi_w)), np.inf)
    z_far[np.isnan(c_near)] = np.nan
    return np.asarray(z_far.reshape(shape), dtype=np.float64)
