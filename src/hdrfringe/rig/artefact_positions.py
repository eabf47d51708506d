"""The measuring volume of the virtual rig and the acceptance artefacts' positions in it
(VDI/VDE 2634 Part 2, issue 25; the artefacts themselves are scenes: :class:`AcceptanceSphere`,
:class:`BallBar`, :class:`FlatPlane` in :mod:`hdrfringe.rig.scenes`).

The measuring volume (:func:`measuring_volume`) is a box in world millimetres: its depth is
the range the calibration covers (given: e.g. the plate calibration's 2..50 mm, or
:func:`board_depth_range` of the stereo calibration's board poses); across, it is the camera's
field of view at the *near* end of that range (the narrowest section of the viewing frustum),
less a margin (2 % of the image on each side), centred on the camera axis, and shrunk (same
aspect) until its eight corners also project inside the projector's image: every point of the box
is then seen by the camera and lit by the projector (both fields of view are convex). ``L0`` is
its body diagonal.

:func:`acceptance_positions` places, in that box, the same three artefacts the guideline moves
around: a sphere at 10 positions, a ball bar at 7, a flat plane at 6 (see its docstring for
each position). Every position carries the scene and its calibrated values (:class:`SphereTruth`,
:class:`BallBarTruth`, :class:`PlaneTruth`, world mm; ``to_frame`` moves them into the camera
frame of a stereo measurement). A sphere counts as inside the volume when the part the camera
measures (its upper hemisphere, ``zc .. zc + R``) is; its lower half, never seen from above,
may reach below.

Examples
--------
>>> from hdrfringe.rig.board_poses import calibration_rig
>>> from hdrfringe.rig.scenes import white_plate
>>> rig = calibration_rig(white_plate(), camera_size=(64, 48))
>>> vol = measuring_volume(rig, (-60.0, 60.0))
>>> [round(v) for v in vol.size_mm], round(vol.l0_mm)
([346, 259, 120], 448)
>>> plan = acceptance_positions(vol)
>>> len(plan.spheres), len(plan.ball_bars), len(plan.planes)
(10, 7, 6)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.errors import InputError
from hdrfringe.rig.scenes import (
    GLOSSY_SHININESS,
    MAX_PLANE_TILT_DEG,
    AcceptanceSphere,
    BallBar,
    BallBarTruth,
    CalibrationBoard,
    FlatPlane,
    PlaneTruth,
    SphereTruth,
    ball_bar,
    flat_plane,
    sphere,
)
from hdrfringe.rig.simulated import SimulatedRig

__all__ = [
    "AcceptancePlan",
    "ArtefactPosition",
    "MeasuringVolume",
    "acceptance_positions",
    "board_depth_range",
    "in_view",
    "measuring_volume",
]

#: Guideline ratios to L0 used for the default artefact sizes (VDI/VDE 2634 Part 2 as commonly
#: summarised: sphere 0.1-0.2 L0, ball bar >= 0.3 L0, plane >= 0.5 L0).
SPHERE_FRACTION = 0.15
BALL_FRACTION = 0.10
PLANE_LENGTH_FRACTION = 0.5
PLANE_WIDTH_FRACTION = 0.15
BAR_DISTANCE_MIN_FRACTION = 0.3
#: Largest tilt given to the tilted plane positions (degrees from horizontal).
PLANE_TILT_CAP_DEG = 45.0


@dataclass(frozen=True)
class MeasuringVolume:
    """An axis-aligned box in world mm (:func:`measuring_volume`).

    Parameters
    ----------
    x_mm, y_mm, z_mm : tuple of float
        ``(low, high)`` along each world axis (``z``: height above the reference plane).

    Examples
    --------
    >>> vol = MeasuringVolume((-150.0, 150.0), (-100.0, 100.0), (0.0, 60.0))
    >>> vol.size_mm, round(vol.l0_mm, 3), vol.centre_mm
    ((300.0, 200.0, 60.0), 365.513, (0.0, 0.0, 30.0))
    >>> vol.contains([[0.0, 0.0, 10.0], [0.0, 0.0, 70.0]]).tolist()
    [True, False]
    """

    x_mm: tuple[float, float]
    y_mm: tuple[float, float]
    z_mm: tuple[float, float]

    def __post_init__(self) -> None:
        for key in ("x_mm", "y_mm", "z_mm"):
            lo, hi = (float(v) for v in getattr(self, key))
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise InputError(f"measuring volume {key} must be (low, high), low < high")
            object.__setattr__(self, key, (lo, hi))

    @property
    def size_mm(self) -> tuple[float, float, float]:
        """Edge lengths along x, y and z."""
        return (
            self.x_mm[1] - self.x_mm[0],
            self.y_mm[1] - self.y_mm[0],
            self.z_mm[1] - self.z_mm[0],
        )

    @property
    def centre_mm(self) -> tuple[float, float, float]:
        """The box's centre."""
        return (
            (self.x_mm[0] + self.x_mm[1]) / 2,
            (self.y_mm[0] + self.y_mm[1]) / 2,
            (self.z_mm[0] + self.z_mm[1]) / 2,
        )

    @property
    def l0_mm(self) -> float:
        """``L0``: the body diagonal."""
        return math.hypot(*self.size_mm)

    def corners(self) -> NDArray[np.float64]:
        """The eight corners.

        Returns
        -------
        ndarray, shape (8, 3)
        """
        return np.array(
            [[x, y, z] for x in self.x_mm for y in self.y_mm for z in self.z_mm], dtype=float
        )

    def contains(self, points: ArrayLike, tol_mm: float = 1e-6) -> NDArray[np.bool_]:
        """Whether points lie inside the box (within ``tol_mm``).

        Parameters
        ----------
        points : array_like, shape (..., 3)
            World points in mm.
        tol_mm : float
            Allowance on every face.

        Returns
        -------
        ndarray of bool, shape (...)
        """
        p = np.asarray(points, dtype=float)
        out = np.ones(p.shape[:-1], dtype=bool)
        for k, (lo, hi) in enumerate((self.x_mm, self.y_mm, self.z_mm)):
            out &= (p[..., k] >= lo - tol_mm) & (p[..., k] <= hi + tol_mm)
        return out


def in_view(rig: SimulatedRig, points: ArrayLike, margin: float = 0.0) -> NDArray[np.bool_]:
    """Whether world points project inside both the camera's and the projector's image.

    Through the rig's true pinhole geometry (:meth:`SimulatedRig.stereo_calibration`).

    Parameters
    ----------
    rig : SimulatedRig
        The rig.
    points : array_like, shape (..., 3)
        World points in mm.
    margin : float
        Keep this fraction of each image's width (height) from its left and right (top and
        bottom) edges.

    Returns
    -------
    ndarray of bool, shape (...)

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=64, height=48))
    >>> in_view(rig, [[0.0, 0.0, 0.0], [400.0, 0.0, 0.0]]).tolist()
    [True, False]
    """
    calib = rig.stereo_calibration()
    rot, t = rig.geometry.world_to_camera()
    cam = np.asarray(points, dtype=float) @ rot.T + t
    proj = cam @ calib.rotation.T + calib.translation_mm
    ok = np.ones(cam.shape[:-1], dtype=bool)
    for lens, xyz in ((calib.camera, cam), (calib.projector, proj)):
        u, v = lens.project(xyz)
        w, h = lens.size
        mu, mv = margin * w, margin * h
        ok &= np.isfinite(u) & (u >= mu - 0.5) & (u <= w - 0.5 - mu)
        ok &= np.isfinite(v) & (v >= mv - 0.5) & (v <= h - 0.5 - mv)
    return ok


def measuring_volume(
    rig: SimulatedRig, depth_range_mm: Sequence[float], *, margin: float = 0.02
) -> MeasuringVolume:
    """The rig's measuring volume over a depth range (see the module docstring).

    Parameters
    ----------
    rig : SimulatedRig
        The rig (its geometry, camera and projector sizes; the scene does not matter).
    depth_range_mm : sequence of float
        ``(low, high)`` heights above the reference plane the calibration covers.
    margin : float
        Fraction of each image's width and height kept free at its edges (both images), so
        the volume does not depend on the resolution.

    Returns
    -------
    MeasuringVolume

    Raises
    ------
    InputError
        A depth range that is not ``low < high`` below the camera, or no box seen by both.

    Examples
    --------
    The thesis rig (1.9 m, 320 mm field) over the plate calibration's 2..50 mm:

    >>> from hdrfringe.rig.scenes import THESIS_CALIBRATION_DEPTHS_MM, white_plate
    >>> rig = SimulatedRig(white_plate())
    >>> d = THESIS_CALIBRATION_DEPTHS_MM
    >>> vol = measuring_volume(rig, (d[0], d[-1]))
    >>> [round(v, 1) for v in vol.size_mm], round(vol.l0_mm, 1)
    ([299.1, 228.0, 48.0], 379.2)
    """
    try:
        lo, hi = (float(v) for v in depth_range_mm)
    except (TypeError, ValueError):
        raise InputError(f"depth range must be (low, high) in mm, got {depth_range_mm!r}") from None
    geo, cam = rig.geometry, rig.camera
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi < geo.standoff_mm):
        raise InputError(
            f"depth range ({lo}, {hi}) mm: give low < high below the camera "
            f"({geo.standoff_mm:g} mm)"
        )
    if not (math.isfinite(margin) and 0 <= margin < 0.25):
        raise InputError(f"margin must be a fraction in [0, 0.25), got {margin}")
    f = geo.camera_focal_px(cam.width)
    near = geo.standoff_mm - hi
    hx = cam.width * (0.5 - margin) * near / f
    hy = cam.height * (0.5 - margin) * near / f

    def box(scale: float) -> MeasuringVolume:
        return MeasuringVolume((-scale * hx, scale * hx), (-scale * hy, scale * hy), (lo, hi))

    def fits(scale: float) -> bool:
        # the tolerance keeps corners on the camera's edge (scale 1) from rounding out
        return bool(in_view(rig, box(scale).corners(), margin - 1e-9).all())

    if fits(1.0):
        return box(1.0)
    if not fits(1e-3):
        raise InputError(
            f"no measuring volume over depths {lo:g}..{hi:g} mm: the projector does not light "
            "the camera's axis there; choose a depth range nearer the reference plane"
        )
    low, high = 1e-3, 1.0
    for _ in range(50):
        mid = (low + high) / 2
        low, high = (mid, high) if fits(mid) else (low, mid)
    return box(low)


def board_depth_range(boards: Sequence[CalibrationBoard]) -> tuple[float, float]:
    """The heights the pattern points of calibration board poses span (world mm).

    The depth range a stereo calibration from these poses covers, for :func:`measuring_volume`.

    Parameters
    ----------
    boards : sequence of CalibrationBoard
        The poses (e.g. :func:`hdrfringe.rig.board_poses.default_board_poses`).

    Returns
    -------
    tuple of float
        ``(lowest, highest)`` ``z`` of the board corners.

    Examples
    --------
    >>> from hdrfringe.rig.board_poses import default_board_poses
    >>> [round(v, 1) for v in board_depth_range(default_board_poses(10))]
    [-117.9, 116.2]
    """
    if not boards:
        raise InputError("board poses: give at least one")
    z = np.concatenate([b.corners_world()[:, 2] for b in boards])
    return float(z.min()), float(z.max())


Kind = Literal["sphere", "ball_bar", "plane"]


@dataclass(frozen=True)
class ArtefactPosition:
    """One artefact at one position: the scene to capture and what it should measure.

    Parameters
    ----------
    kind : {"sphere", "ball_bar", "plane"}
        Which artefact.
    index : int
        Position number within its kind, from 1.
    label : str
        Short name, e.g. ``"sphere_03"``.
    description : str
        Where it is, in words.
    scene : AcceptanceSphere or BallBar or FlatPlane
        The scene (registered: its ``to_manifest`` rebuilds it).
    truth : SphereTruth or BallBarTruth or PlaneTruth
        Calibrated values in world mm (``truth.to_frame(*geometry.world_to_camera())`` for
        the camera frame of a stereo measurement).

    Examples
    --------
    >>> pos = acceptance_positions(MeasuringVolume((-150, 150), (-100, 100), (0, 60))).spheres[0]
    >>> pos.label, pos.truth.diameter_mm
    ('sphere_01', 55.0)
    """

    kind: Kind
    index: int
    label: str
    description: str
    scene: AcceptanceSphere | BallBar | FlatPlane
    truth: SphereTruth | BallBarTruth | PlaneTruth


@dataclass(frozen=True)
class AcceptancePlan:
    """The guideline's positions in one measuring volume (:func:`acceptance_positions`).

    Parameters
    ----------
    volume : MeasuringVolume
        The volume.
    spheres, ball_bars, planes : tuple of ArtefactPosition
        10, 7 and 6 positions.
    sphere_diameter_mm, ball_diameter_mm, ball_distance_mm : float
        The artefacts' calibrated sizes (the same artefact at every position).
    plane_length_mm, plane_width_mm : float
        The plane's size.
    notes : tuple of str
        Where the plan departs from the guideline's ratios (empty when it does not).

    Examples
    --------
    >>> plan = acceptance_positions(MeasuringVolume((-150, 150), (-100, 100), (0, 60)))
    >>> len(plan.positions), plan.notes
    (23, ())
    """

    volume: MeasuringVolume
    spheres: tuple[ArtefactPosition, ...]
    ball_bars: tuple[ArtefactPosition, ...]
    planes: tuple[ArtefactPosition, ...]
    sphere_diameter_mm: float
    ball_diameter_mm: float
    ball_distance_mm: float
    plane_length_mm: float
    plane_width_mm: float
    notes: tuple[str, ...] = ()

    @property
    def positions(self) -> tuple[ArtefactPosition, ...]:
        """All positions: spheres, ball bars, planes."""
        return self.spheres + self.ball_bars + self.planes


def _check_size(name: str, value: float | None, default: float) -> float:
    if value is None:
        return default
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{name} must be a finite number > 0 mm, got {value!r}")
    return v


def _fit_half_length(half: NDArray[np.float64], u: NDArray[np.float64]) -> float:
    """Largest ``s`` with ``|s u_k| <= half_k`` on every axis."""
    return min(h / abs(c) for h, c in zip(half, u, strict=True) if abs(c) > 1e-12)


def acceptance_positions(
    volume: MeasuringVolume,
    *,
    sphere_diameter_mm: float | None = None,
    ball_diameter_mm: float | None = None,
    ball_distance_mm: float | None = None,
    bar_diameter_mm: float | None = None,
    plane_length_mm: float | None = None,
    plane_width_mm: float | None = None,
    base_mm: float | None = None,
    specular: float = 0.0,
    shininess: float = GLOSSY_SHININESS,
) -> AcceptancePlan:
    """The guideline's 10 sphere, 7 ball-bar and 6 plane positions in a measuring volume.

    Default sizes (rounded to whole mm): sphere diameter ``0.15 L0``; ball-bar spheres
    ``0.1 L0``, rod ``0.3`` of that, centre distance the longest one that fits all seven
    bar positions (at least ``0.3 L0``, else an error); plane ``0.5 L0`` (rounded up) by
    ``0.15 L0``. The base plane lies ``0.05 L0`` below the volume (outside it).

    Positions (``R`` the sphere radius; the box the centres may take is the volume shrunk by
    ``R`` across and by ``R`` at the top, so the measured upper hemispheres stay inside):

    * spheres 1-8: the eight corners of that box; 9: its centre; 10: the top of its axis.
    * ball bars 1-4: along the four space diagonals of that box (axis rising from the
      first to the second sphere), centred in it; 5: along X, 6: along Y, both level at
      mid-depth; 7: in the XZ plane along the box's face diagonal (the steepest direction a
      view from above allows here; a bar along Z, one sphere over the other, cannot be seen).
    * planes 1-2: level, along X at the bottom of the volume and along the XY diagonal at its
      top; 3-4: rising along +X and -X; 5-6: rising along the two XY diagonals; the tilted ones
      centred in the volume at the largest tilt up to 45 degrees that keeps them inside it.

    Parameters
    ----------
    volume : MeasuringVolume
        The volume (:func:`measuring_volume`).
    sphere_diameter_mm, ball_diameter_mm, ball_distance_mm, bar_diameter_mm : float, optional
        The artefacts' calibrated sizes (None: the defaults above).
    plane_length_mm, plane_width_mm : float, optional
        The plane's size.
    base_mm : float, optional
        Height of the dark base plane; must be below the volume.
    specular, shininess : float
        Blinn-Phong lobe of every artefact (0: matte, the guideline's artefacts; e.g.
        :data:`~hdrfringe.rig.scenes.GLOSSY_SPECULAR` for the glossy variants).

    Returns
    -------
    AcceptancePlan

    Raises
    ------
    InputError
        An artefact that does not fit the volume at a position, a bad size or base.

    Examples
    --------
    >>> vol = MeasuringVolume((-160.0, 160.0), (-120.0, 120.0), (2.0, 50.0))
    >>> plan = acceptance_positions(vol)
    >>> plan.sphere_diameter_mm, plan.ball_distance_mm, plan.plane_length_mm
    (60.0, 200.0, 202.0)
    >>> [p.label for p in plan.ball_bars][:2]
    ['ball_bar_01', 'ball_bar_02']
    """
    l0 = volume.l0_mm
    (x0, x1), (y0, y1), (z0, z1) = volume.x_mm, volume.y_mm, volume.z_mm
    ds = _check_size("sphere_diameter_mm", sphere_diameter_mm, float(round(SPHERE_FRACTION * l0)))
    db = _check_size("ball_diameter_mm", ball_diameter_mm, float(round(BALL_FRACTION * l0)))
    rod = _check_size("bar_diameter_mm", bar_diameter_mm, float(round(0.3 * db)))
    length = _check_size(
        "plane_length_mm", plane_length_mm, float(math.ceil(PLANE_LENGTH_FRACTION * l0))
    )
    width = _check_size("plane_width_mm", plane_width_mm, float(round(PLANE_WIDTH_FRACTION * l0)))
    base = float(round(z0 - 0.05 * l0)) if base_mm is None else float(base_mm)
    if not (math.isfinite(base) and base < z0):
        raise InputError(f"base_mm = {base_mm} must lie below the measuring volume (z < {z0:g} mm)")
    gloss = {"base_mm": base, "specular": specular, "shininess": shininess}

    def inner(radius: float, what: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        lo = np.array([x0 + radius, y0 + radius, z0])
        hi = np.array([x1 - radius, y1 - radius, z1 - radius])
        if np.any(hi < lo):
            raise InputError(
                f"{what} of diameter {2 * radius:g} mm does not fit the measuring volume "
                f"{' x '.join(f'{v:.0f}' for v in volume.size_mm)} mm; use a smaller one"
            )
        return lo, hi

    # spheres
    lo, hi = inner(ds / 2, "sphere")
    mid = (lo + hi) / 2
    spheres = []
    names = {0: "low", 1: "high"}
    for ix, iy, iz in ((ix, iy, iz) for iz in (0, 1) for iy in (0, 1) for ix in (0, 1)):
        c = (lo[0], hi[0])[ix], (lo[1], hi[1])[iy], (lo[2], hi[2])[iz]
        desc = f"corner x {names[ix]}, y {names[iy]}, z {names[iz]}"
        spheres.append((c, desc))
    spheres.append(((mid[0], mid[1], mid[2]), "centre of the volume"))
    spheres.append(((mid[0], mid[1], hi[2]), "on the axis, top of the volume"))
    sphere_pos = tuple(
        _position("sphere", k + 1, desc, sphere(ds, c, **gloss))
        for k, (c, desc) in enumerate(spheres)
    )

    # ball bars
    lo, hi = inner(db / 2, "ball bar sphere")
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    a, b, c = half
    dirs = [
        ((a, b, c), "space diagonal x-y- to x+y+"),
        ((-a, b, c), "space diagonal x+y- to x-y+"),
        ((a, -b, c), "space diagonal x-y+ to x+y-"),
        ((-a, -b, c), "space diagonal x+y+ to x-y-"),
        ((1.0, 0.0, 0.0), "along X, level at mid-depth"),
        ((0.0, 1.0, 0.0), "along Y, level at mid-depth"),
        ((a, 0.0, c), "XZ face diagonal (steepest seen from above)"),
    ]
    units = [np.asarray(d, dtype=float) / np.linalg.norm(d) for d, _ in dirs]
    fit = 2 * min(_fit_half_length(half, u) for u in units)
    dist = _check_size("ball_distance_mm", ball_distance_mm, float(math.floor(fit)))
    if dist > fit + 1e-9:
        raise InputError(
            f"a ball bar of {dist:g} mm does not fit all seven positions in the measuring "
            f"volume (at most {fit:.1f} mm); use a shorter one"
        )
    bar_pos = []
    for k, (u, (_, desc)) in enumerate(zip(units, dirs, strict=True)):
        pa, pb = mid - dist / 2 * u, mid + dist / 2 * u
        bar = ball_bar(db, tuple(pa), tuple(pb), bar_diameter_mm=rod, **gloss)
        bar_pos.append(_position("ball_bar", k + 1, desc, bar))

    # planes
    centre = np.asarray(volume.centre_mm)
    diag = math.degrees(math.atan2(y1 - y0, x1 - x0))
    layouts = [
        (0.0, False, (centre[0], centre[1], z0), "level along X, bottom of the volume"),
        (diag, False, (centre[0], centre[1], z1), "level along the XY diagonal, top"),
        (0.0, True, tuple(centre), "rising along +X"),
        (180.0, True, tuple(centre), "rising along -X"),
        (diag, True, tuple(centre), "rising along the XY diagonal x-y- to x+y+"),
        (180.0 - diag, True, tuple(centre), "rising along the XY diagonal x+y- to x-y+"),
    ]
    plane_pos = []
    for k, (azimuth, tilted, where, desc) in enumerate(layouts):
        tilt = _largest_tilt(volume, length, width, azimuth, where) if tilted else 0.0
        scene = flat_plane(length, width, where, azimuth, tilt, 0.0, **gloss)
        if not volume.contains(scene.corners(), 1e-6).all():
            raise InputError(
                f"a plane of {length:g} x {width:g} mm does not fit the measuring volume "
                f"{' x '.join(f'{v:.0f}' for v in volume.size_mm)} mm {desc}; use a smaller one"
            )
        text = f"{desc}, tilted {tilt:.1f} deg" if tilted else desc
        plane_pos.append(_position("plane", k + 1, text, scene))

    notes = []
    if not 0.1 <= ds / l0 <= 0.2:
        notes.append(f"sphere diameter {ds:g} mm is {ds / l0:.3f} L0 (guideline 0.1-0.2 L0)")
    if dist < BAR_DISTANCE_MIN_FRACTION * l0:
        notes.append(f"ball-bar distance {dist:g} mm is {dist / l0:.3f} L0 (guideline >= 0.3)")
    if length < PLANE_LENGTH_FRACTION * l0:
        notes.append(f"plane length {length:g} mm is {length / l0:.3f} L0 (guideline >= 0.5)")
    return AcceptancePlan(
        volume,
        sphere_pos,
        tuple(bar_pos),
        tuple(plane_pos),
        ds,
        db,
        dist,
        length,
        width,
        tuple(notes),
    )


def _position(
    kind: Kind, index: int, description: str, scene: AcceptanceSphere | BallBar | FlatPlane
) -> ArtefactPosition:
    return ArtefactPosition(kind, index, f"{kind}_{index:02d}", description, scene, scene.truth())


def _largest_tilt(
    volume: MeasuringVolume,
    length: float,
    width: float,
    azimuth: float,
    centre: Sequence[float],
) -> float:
    """Largest tilt up to :data:`PLANE_TILT_CAP_DEG` keeping the plane's corners inside."""
    cap = min(PLANE_TILT_CAP_DEG, MAX_PLANE_TILT_DEG)

    def inside(tilt: float) -> bool:
        where = (centre[0], centre[1], centre[2])
        plane = FlatPlane(length, width, where, azimuth, tilt, base_mm=-500.0)
        return bool(volume.contains(plane.corners(), 1e-9).all())

    if inside(cap):
        return cap
    if not inside(0.0):
        return 0.0  # the caller reports that the plane does not fit
    low, high = 0.0, cap
    for _ in range(50):
        mid = (low + high) / 2
        low, high = (mid, high) if inside(mid) else (low, mid)
    return round(low - 0.005, 2)  # rounded down: inside
