"""Scenes for the virtual rig: heightfields ``z = h(X, Y)`` with a reflectivity map.

World coordinates are in millimetres: the reference plane is ``z = 0``, heights are positive
toward the camera, ``X`` grows to the right of the camera image and ``Y`` toward its top.
Reflectivities are relative to the thesis's white calibration plate (``r = 1``), the surface on
which the camera sensitivity and the 0.17 gray level/lux of thesis Fig. 4.14 are defined.

Every scene is a small frozen dataclass with

- ``height(x, y)``: surface height in mm (vectorised);
- ``reflectivity(x, y)``: diffuse reflectivity ``r(x, y)`` of thesis Eq. 3.2-3.3;
- ``specular`` and ``shininess``: an optional Blinn-Phong lobe (0 for matte scenes);
- ``to_manifest()``: a JSON-friendly dict whose keys, apart from ``name``, are the keyword
  arguments of the constructor registered under ``name`` in :data:`SCENES`.

Flat scenes (plates, the checkerboard) record their surface height as ``depth_mm``, the
capture-folder field for a flat plate's known depth; freeform scenes record ``base_mm`` instead so
that no reader mistakes them for a flat plate.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.errors import InputError

__all__ = [
    "ARTEFACT_BASE_REFLECTIVITY",
    "ARTEFACT_REFLECTIVITY",
    "BLACK_PLATE_REFLECTIVITY",
    "BOARD_PATTERNS",
    "GLOSSY_SHININESS",
    "GLOSSY_SPECULAR",
    "MAX_BAR_ELEVATION_DEG",
    "MAX_PLANE_TILT_DEG",
    "SCENES",
    "THESIS_CALIBRATION_DEPTHS_MM",
    "AcceptanceSphere",
    "BallBar",
    "BallBarTruth",
    "CalibrationBoard",
    "Checkerboard",
    "FlatPlane",
    "FlatPlate",
    "GlossyDome",
    "Mask",
    "PlaneTruth",
    "Scene",
    "SpecularPart",
    "SphereTruth",
    "ball_bar",
    "black_plate",
    "board",
    "checkerboard",
    "flat_plane",
    "glossy",
    "make_scene",
    "mask",
    "plate",
    "scene_from_manifest",
    "specular_part",
    "sphere",
    "white_plate",
]

#: Reflectivity of the black calibration plate and of the checkerboard's black squares, relative
#: to the white plate. A printed/painted black under projector light, chosen so that the white
#: checkerboard squares stop saturating around MIGL 70-80 with the black-plate aperture, as in
#: thesis Sec. 5.2.2 - 5.3 (LPA down to MIGL 70 with imin 40, trade-off MIGL 96).
BLACK_PLATE_REFLECTIVITY = 0.25

#: The thesis's calibration positions: 2 to 50 mm in 2 mm steps (Sec. 4.1).
THESIS_CALIBRATION_DEPTHS_MM: tuple[float, ...] = tuple(float(d) for d in range(2, 51, 2))

_GRAD_STEP_MM = 1e-3


def _finite(name: str, value: float) -> None:
    if not math.isfinite(value):
        raise InputError(f"scene parameter {name} must be a finite number, got {value}")


def _depth_ok(name: str, value: float) -> None:
    _finite(name, value)
    if not (-500.0 <= value <= 1000.0):
        raise InputError(
            f"scene {name} = {value} mm is outside -500..1000 mm; the camera is 1.9 m away, "
            "use a depth within the measurement volume"
        )


def _reflectivity_ok(name: str, value: float) -> None:
    _finite(name, value)
    if value < 0:
        raise InputError(f"scene {name} must be >= 0, got {value}")


class Scene:
    """Base class of the scenes (see the module docstring for the interface).

    A scene is a heightfield ``z = h(X, Y)`` in world millimetres with a diffuse reflectivity
    ``r(X, Y)`` (thesis Eq. 3.2-3.3) and an optional Blinn-Phong lobe (``specular``,
    ``shininess``; 0 for the matte scenes). Subclasses are frozen dataclasses that define
    :meth:`height`, :meth:`reflectivity`, :meth:`to_manifest` and a registry ``name``.

    Attributes
    ----------
    name : str
        Registry name, a key of :data:`SCENES` (read-only).
    specular : float
        Peak Blinn-Phong gain relative to a white diffuse surface (0: matte).
    shininess : float
        Blinn-Phong exponent of the lobe.

    References
    ----------
    Thesis Eq. 3.2-3.3: ``r(x, y)`` is the reflectivity of the captured-intensity model.

    Examples
    --------
    >>> board = checkerboard()
    >>> isinstance(board, Scene), board.name, board.is_flat
    (True, 'checkerboard', True)
    >>> board.height([10.0, 30.0], [10.0, 10.0]).tolist()
    [10.0, 10.0]
    >>> board.reflectivity([10.0, 30.0], [10.0, 10.0]).tolist()  # a white, then a black square
    [0.95, 0.25]
    """

    specular: float = 0.0
    shininess: float = 1.0

    @property
    def name(self) -> str:  # pragma: no cover - every scene defines it
        """Registry name of the scene, a key of :data:`SCENES`."""
        raise NotImplementedError

    def height(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:  # pragma: no cover
        """Surface height in mm above the reference plane at world (x, y) in mm.

        Parameters
        ----------
        x, y : array_like
            World coordinates in mm, broadcasting against each other.

        Returns
        -------
        ndarray of float64
            Heights in mm, the broadcast shape of ``x`` and ``y``.
        """
        raise NotImplementedError

    def reflectivity(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:  # pragma: no cover
        """Diffuse reflectivity at world (x, y), relative to the white plate.

        Parameters
        ----------
        x, y : array_like
            World coordinates in mm, broadcasting against each other.

        Returns
        -------
        ndarray of float64
            ``r(x, y)`` of thesis Eq. 3.2, the broadcast shape of ``x`` and ``y``.
        """
        raise NotImplementedError

    def gradient(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Surface slopes ``(dh/dx, dh/dy)``, by central differences unless overridden.

        Parameters
        ----------
        x, y : array_like
            World coordinates in mm, broadcasting against each other.

        Returns
        -------
        dh_dx, dh_dy : ndarray of float64
            The slopes, the broadcast shape of ``x`` and ``y``.
        """
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        e = _GRAD_STEP_MM
        gx = (self.height(x + e, y) - self.height(x - e, y)) / (2 * e)
        gy = (self.height(x, y + e) - self.height(x, y - e)) / (2 * e)
        return gx, gy

    def specular_strength(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Blinn-Phong gain ``k_s`` at world (x, y); ``specular`` everywhere by default.

        Parameters
        ----------
        x, y : array_like
            World coordinates in mm, broadcasting against each other.

        Returns
        -------
        ndarray of float64
            ``k_s``, the broadcast shape of ``x`` and ``y``.
        """
        return _full(x, y, self.specular)

    @property
    def is_flat(self) -> bool:
        """True for scenes whose surface is one plane parallel to the reference plane."""
        return False

    def to_manifest(self) -> dict[str, Any]:  # pragma: no cover
        """The scene as a JSON-friendly dict, :func:`scene_from_manifest`'s input.

        Returns
        -------
        dict
            ``name`` and the keyword arguments of the constructor registered under it.
        """
        raise NotImplementedError


def _full(x: ArrayLike, y: ArrayLike, value: float) -> NDArray[np.float64]:
    return np.full(np.broadcast_shapes(np.shape(x), np.shape(y)), float(value))


@dataclass(frozen=True)
class FlatPlate(Scene):
    """A flat matte plate parallel to the reference plane at ``depth_mm``.

    Parameters
    ----------
    depth_mm : float
        Plate surface height above the reference plane (0: the reference plane itself).
    reflectivity_value : float
        Uniform diffuse reflectivity (1.0: the white plate).
    name : str
        Registry name ("white_plate", "black_plate" or "plate").

    References
    ----------
    Thesis Sec. 4.1 (the flat white plate at 2..50 mm) and Sec. 5.2.2 (the black plate).

    Examples
    --------
    >>> p = FlatPlate(12.0, 0.5)
    >>> p.height([0.0, 100.0], [0.0, -50.0]).tolist(), p.reflectivity(0.0, 0.0).tolist()
    ([12.0, 12.0], 0.5)
    >>> p.to_manifest()
    {'name': 'plate', 'depth_mm': 12.0, 'reflectivity': 0.5}
    """

    depth_mm: float = 0.0
    reflectivity_value: float = 1.0
    name: str = "plate"

    def __post_init__(self) -> None:
        _depth_ok("depth_mm", self.depth_mm)
        _reflectivity_ok("reflectivity", self.reflectivity_value)

    def height(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return _full(x, y, self.depth_mm)

    def reflectivity(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return _full(x, y, self.reflectivity_value)

    def gradient(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return _full(x, y, 0.0), _full(x, y, 0.0)

    @property
    def is_flat(self) -> bool:
        return True

    def to_manifest(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "depth_mm": float(self.depth_mm),
            "reflectivity": float(self.reflectivity_value),
        }


@dataclass(frozen=True)
class Checkerboard(Scene):
    """A black-and-white checkerboard printed on a flat board (thesis Sec. 5.2.2).

    The thesis mounted it on a 1 cm thick board fixed to the reference plane, so its surface
    sits at ``depth_mm = 10`` with the stage at 0 and at 10..28 mm over its measurement positions.

    Parameters
    ----------
    depth_mm : float
        Height of the printed surface above the reference plane.
    square_mm : float
        Side of one square.
    white_reflectivity, black_reflectivity : float
        Reflectivities of the two colours (white plate = 1).

    References
    ----------
    Thesis Sec. 5.2.2 (the checkerboard on its 1 cm board, measured at 10..28 mm).

    Examples
    --------
    >>> board = Checkerboard(square_mm=10.0)
    >>> board.is_white([5.0, 15.0, 15.0], [5.0, 5.0, 15.0]).tolist()
    [True, False, True]
    >>> board.reflectivity([5.0, 15.0], [5.0, 5.0]).tolist()
    [0.95, 0.25]
    """

    depth_mm: float = 10.0
    square_mm: float = 25.0
    white_reflectivity: float = 0.95
    black_reflectivity: float = BLACK_PLATE_REFLECTIVITY

    name: ClassVar[str] = "checkerboard"

    def __post_init__(self) -> None:
        _depth_ok("depth_mm", self.depth_mm)
        _finite("square_mm", self.square_mm)
        if self.square_mm <= 0:
            raise InputError(f"checkerboard square_mm must be > 0, got {self.square_mm}")
        _reflectivity_ok("white_reflectivity", self.white_reflectivity)
        _reflectivity_ok("black_reflectivity", self.black_reflectivity)

    def height(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return _full(x, y, self.depth_mm)

    def is_white(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.bool_]:
        """True on white squares; a corner of four squares sits at the origin.

        Parameters
        ----------
        x, y : array_like
            World coordinates in mm, broadcasting against each other.

        Returns
        -------
        ndarray of bool
            The broadcast shape of ``x`` and ``y``.
        """
        ix = np.floor(np.asarray(x, dtype=np.float64) / self.square_mm).astype(np.int64)
        iy = np.floor(np.asarray(y, dtype=np.float64) / self.square_mm).astype(np.int64)
        return (ix + iy) % 2 == 0

    def reflectivity(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return np.where(
            self.is_white(x, y), float(self.white_reflectivity), float(self.black_reflectivity)
        )

    def gradient(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return _full(x, y, 0.0), _full(x, y, 0.0)

    @property
    def is_flat(self) -> bool:
        return True

    def to_manifest(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "depth_mm": float(self.depth_mm),
            "square_mm": float(self.square_mm),
            "white_reflectivity": float(self.white_reflectivity),
            "black_reflectivity": float(self.black_reflectivity),
        }


# Face-like mask: (amplitude mm, centre x, centre y, sigma x, sigma y) of Gaussian features on a
# super-Gaussian base, in mm at scale 1 (x to the viewer's right, y up).
_MASK_BASE = (34.0, 0.0, 0.0, 55.0, 75.0)  # amplitude, x0, y0, half-width x, half-height y
_MASK_FEATURES: tuple[tuple[float, float, float, float, float], ...] = (
    (16.0, 0.0, -2.0, 8.0, 26.0),  # nose ridge
    (7.0, 0.0, -24.0, 9.0, 8.0),  # nose tip
    (-9.0, -27.0, 18.0, 13.0, 9.0),  # eye sockets
    (-9.0, 27.0, 18.0, 13.0, 9.0),
    (5.0, -28.0, 33.0, 18.0, 6.0),  # brows
    (5.0, 28.0, 33.0, 18.0, 6.0),
    (6.0, -34.0, -20.0, 16.0, 16.0),  # cheeks
    (6.0, 34.0, -20.0, 16.0, 16.0),
    (4.0, 0.0, -43.0, 17.0, 4.5),  # lips
    (-2.5, 0.0, -48.0, 14.0, 2.0),  # mouth line
    (5.0, 0.0, -64.0, 18.0, 10.0),  # chin
)


@dataclass(frozen=True)
class Mask(Scene):
    """A smooth face-like freeform surface (a mask), about 54 mm high, on a base plane.

    Built from a super-Gaussian face base (110 x 150 mm at ``scale = 1``) plus Gaussian nose,
    eye sockets, brows, cheeks, lips and chin; every slope stays moderate (< about 2), so the
    surface is smooth, fully inside the default field of view and free of projector shadows
    except where a real mask would have them.

    Parameters
    ----------
    base_mm : float
        Height of the plane the mask rests on.
    scale : float
        Lateral and height scale factor.
    reflectivity_value : float
        Uniform matte reflectivity (painted plaster).

    References
    ----------
    Thesis Fig. 2.7 (a mask measured with and without gamma pre-compensation); the shape here
    is this library's own.

    Examples
    --------
    >>> face = Mask()
    >>> round(float(face.height(0.0, -24.0)), 1)  # the nose tip, near the highest point
    52.8
    >>> float(face.height(300.0, 0.0))  # far from the face: the base plane
    0.0
    """

    base_mm: float = 0.0
    scale: float = 1.0
    reflectivity_value: float = 0.7

    name: ClassVar[str] = "mask"

    def __post_init__(self) -> None:
        _depth_ok("base_mm", self.base_mm)
        _finite("scale", self.scale)
        if not (0.1 <= self.scale <= 2.0):
            raise InputError(f"mask scale must be in 0.1..2, got {self.scale}")
        _reflectivity_ok("reflectivity", self.reflectivity_value)

    def height(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        s = self.scale
        x = np.asarray(x, dtype=np.float64) / s
        y = np.asarray(y, dtype=np.float64) / s
        amp, x0, y0, wx, wy = _MASK_BASE
        rho2 = ((x - x0) / wx) ** 2 + ((y - y0) / wy) ** 2
        envelope = np.exp(-(rho2**2))
        features = np.zeros(np.broadcast_shapes(x.shape, y.shape))
        for a, cx, cy, sx, sy in _MASK_FEATURES:
            features = features + a * np.exp(-0.5 * (((x - cx) / sx) ** 2 + ((y - cy) / sy) ** 2))
        # the features ride on the face and fade out with it: far from the face the surface is
        # the base plane
        return self.base_mm + s * envelope * (amp + features)

    def reflectivity(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return _full(x, y, self.reflectivity_value)

    def to_manifest(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "base_mm": float(self.base_mm),
            "scale": float(self.scale),
            "reflectivity": float(self.reflectivity_value),
        }


@dataclass(frozen=True)
class GlossyDome(Scene):
    """A glossy spherical cap (a dome) on a matte base plane; its highlight saturates at MIGL 255.

    The cap, of sphere radius ``radius_mm`` and height ``height_mm``, is centred on the optical
    axis. Its surface reflects diffusely plus a Blinn-Phong lobe
    ``specular * max(n.h, 0) ** shininess`` with ``h`` the half vector between the real
    directions to the projector and to the camera; the highlight therefore sits where the sphere's
    normal bisects them (about ``radius * sin(angle / 2)`` from the apex, on the projector side)
    and carries the projected fringes. The base plane is matte.

    Parameters
    ----------
    base_mm : float
        Height of the plane the dome rests on.
    height_mm : float
        Cap height above its base (less than the sphere radius).
    radius_mm : float
        Sphere radius.
    reflectivity_value : float
        Diffuse reflectivity of dome and base.
    specular : float
        Peak specular gain of the dome relative to a white diffuse surface.
    shininess : float
        Blinn-Phong exponent (larger: smaller, sharper highlight).

    References
    ----------
    Thesis Sec. 3.1: a specular surface saturates where its highlight reaches the camera and
    leaves a low SNR around it.

    Examples
    --------
    >>> dome = GlossyDome()
    >>> dome.height([0.0, 200.0], [0.0, 0.0]).tolist()  # apex, then the base plane
    [30.0, 0.0]
    >>> round(dome.base_radius_mm, 2)
    71.41
    >>> dome.specular_strength([0.0, 200.0], [0.0, 0.0]).tolist()
    [2.0, 0.0]
    """

    base_mm: float = 0.0
    height_mm: float = 30.0
    radius_mm: float = 100.0
    reflectivity_value: float = 0.5
    specular: float = 2.0
    shininess: float = 200.0

    name: ClassVar[str] = "glossy"

    def __post_init__(self) -> None:
        _depth_ok("base_mm", self.base_mm)
        for key in ("height_mm", "radius_mm", "specular", "shininess"):
            _finite(key, getattr(self, key))
        if not (0 < self.height_mm < self.radius_mm):
            raise InputError(
                f"dome height_mm must be in (0, radius_mm = {self.radius_mm}), got {self.height_mm}"
            )
        if self.shininess <= 0 or self.specular < 0:
            raise InputError(
                f"dome shininess must be > 0 and specular >= 0, got {self.shininess}, "
                f"{self.specular}"
            )
        _reflectivity_ok("reflectivity", self.reflectivity_value)

    @property
    def base_radius_mm(self) -> float:
        """Radius of the cap's footprint on its base plane."""
        c = self.radius_mm - self.height_mm
        return math.sqrt(self.radius_mm**2 - c * c)

    def _r2(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        return np.minimum(x * x + y * y, self.base_radius_mm**2)

    def height(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        cap = np.sqrt(self.radius_mm**2 - self._r2(x, y)) - (self.radius_mm - self.height_mm)
        return self.base_mm + cap

    def gradient(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        r2 = x * x + y * y
        on = r2 < self.base_radius_mm**2
        root = np.sqrt(np.where(on, self.radius_mm**2 - r2, 1.0))
        return np.where(on, -x / root, 0.0), np.where(on, -y / root, 0.0)

    def specular_strength(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        return np.where(x * x + y * y < self.base_radius_mm**2, float(self.specular), 0.0)

    def reflectivity(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return _full(x, y, self.reflectivity_value)

    def to_manifest(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "base_mm": float(self.base_mm),
            "height_mm": float(self.height_mm),
            "radius_mm": float(self.radius_mm),
            "reflectivity": float(self.reflectivity_value),
            "specular": float(self.specular),
            "shininess": float(self.shininess),
        }


@dataclass(frozen=True)
class SpecularPart(Scene):
    """A machined metal part: a chamfered block with a polished capsule-shaped boss.

    A high-dynamic-range scene: the block (top ``2 half_length_mm x 2 half_width_mm``,
    ``block_mm`` thick, 45 degree chamfers all round, so the heightfield is continuous) is
    bead-blasted metal, matte with the diffuse reflectivity ``reflectivity_value``; the boss on
    its top is polished. The boss is a cylinder of radius ``boss_radius_mm`` whose axis runs
    along Y over ``boss_length_mm``, with spherical ends (a capsule), cut ``boss_mm`` above the
    block top. Its Blinn-Phong lobe ``specular * (n.h) ** shininess`` throws a highlight stripe
    along the boss where its normal bisects the directions to the projector and the camera
    (about ``boss_radius_mm * sin(7.5 deg)`` from the axis, projector side); with the defaults
    it is about 50x the diffuse level of the part (tested). The part sits on a matte plane of
    reflectivity ``base_reflectivity`` at ``base_mm``.

    Heights, with ``d = max(|x| - half_length_mm, |y| - half_width_mm)`` and
    ``rho = hypot(x, max(|y| - boss_length_mm / 2, 0))`` (the distance to the boss axis):

    * block: ``base_mm + clip(block_mm - max(d, 0), 0, block_mm)`` (the chamfers have slope 1);
    * boss: add ``max(0, sqrt(R^2 - rho^2) - (R - boss_mm))`` with ``R = boss_radius_mm``.

    Parameters
    ----------
    base_mm : float
        Height of the plane the part rests on.
    block_mm : float
        Block thickness (the chamfer width too).
    half_length_mm, half_width_mm : float
        Half sizes of the block's flat top along X and Y.
    boss_mm : float
        Boss height above the block top, below ``boss_radius_mm``.
    boss_radius_mm : float
        Radius of the boss's cylinder and end caps.
    boss_length_mm : float
        Length of the boss's straight (cylindrical) part along Y.
    reflectivity_value : float
        Diffuse reflectivity of the metal (block and boss).
    base_reflectivity : float
        Diffuse reflectivity of the plane around the part.
    specular : float
        Peak Blinn-Phong gain of the polished boss, relative to a white diffuse surface.
    shininess : float
        Blinn-Phong exponent of the boss.

    References
    ----------
    Thesis Sec. 3.1 (saturation where a highlight reaches the camera, low SNR around it);
    Zhang & Yau 2009 (multi-exposure fringe projection on such parts).

    Examples
    --------
    >>> part = SpecularPart()
    >>> part.height([0.0, 50.0, 95.0, 200.0], [0.0, 0.0, 0.0, 0.0]).tolist()
    [14.0, 8.0, 3.0, 0.0]
    >>> part.specular_strength([0.0, 50.0], [0.0, 0.0]).tolist()  # polished boss, matte block
    [12.0, 0.0]
    >>> part.reflectivity([0.0, 200.0], [0.0, 0.0]).tolist()
    [0.25, 0.5]
    """

    base_mm: float = 0.0
    block_mm: float = 8.0
    half_length_mm: float = 90.0
    half_width_mm: float = 65.0
    boss_mm: float = 6.0
    boss_radius_mm: float = 30.0
    boss_length_mm: float = 80.0
    reflectivity_value: float = 0.25
    base_reflectivity: float = 0.5
    specular: float = 12.0
    shininess: float = 100.0

    name: ClassVar[str] = "specular_part"

    def __post_init__(self) -> None:
        _depth_ok("base_mm", self.base_mm)
        for key in (
            "block_mm",
            "half_length_mm",
            "half_width_mm",
            "boss_mm",
            "boss_radius_mm",
            "boss_length_mm",
            "specular",
            "shininess",
        ):
            _finite(key, getattr(self, key))
        for key in ("block_mm", "half_length_mm", "half_width_mm", "boss_radius_mm", "shininess"):
            if getattr(self, key) <= 0:
                raise InputError(f"specular_part {key} must be > 0, got {getattr(self, key)}")
        if not 0 < self.boss_mm < self.boss_radius_mm:
            raise InputError(
                f"specular_part boss_mm must be in (0, boss_radius_mm = {self.boss_radius_mm}), "
                f"got {self.boss_mm}"
            )
        if self.boss_length_mm < 0 or self.specular < 0:
            raise InputError(
                f"specular_part boss_length_mm and specular must be >= 0, got "
                f"{self.boss_length_mm}, {self.specular}"
            )
        w = self.boss_half_width_mm
        if w > self.half_length_mm or self.boss_length_mm / 2 + w > self.half_width_mm:
            raise InputError(
                f"specular_part boss ({2 * w:.1f} x {self.boss_length_mm + 2 * w:.1f} mm) does "
                f"not fit on the block top ({2 * self.half_length_mm:g} x "
                f"{2 * self.half_width_mm:g} mm); enlarge the block or shrink the boss"
            )
        _reflectivity_ok("reflectivity", self.reflectivity_value)
        _reflectivity_ok("base_reflectivity", self.base_reflectivity)

    @property
    def boss_half_width_mm(self) -> float:
        """Half width of the boss's footprint on the block top (its cylinder's chord)."""
        c = self.boss_radius_mm - self.boss_mm
        return math.sqrt(self.boss_radius_mm**2 - c * c)

    def _boss_terms(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
        """``x``, the signed Y distance beyond the straight part, ``R^2 - rho^2``, on-boss mask."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        ey = np.sign(y) * np.maximum(np.abs(y) - self.boss_length_mm / 2, 0.0)
        w = self.boss_half_width_mm
        rho2 = x * x + ey * ey
        return x, ey, self.boss_radius_mm**2 - rho2, rho2 < w * w

    def _block_excess(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        return np.maximum(np.abs(x) - self.half_length_mm, np.abs(y) - self.half_width_mm)

    def height(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        d = self._block_excess(x, y)
        block = np.clip(self.block_mm - np.maximum(d, 0.0), 0.0, self.block_mm)
        _, _, root2, on = self._boss_terms(x, y)
        cap = self.boss_radius_mm - self.boss_mm
        boss = np.where(on, np.sqrt(np.maximum(root2, 0.0)) - cap, 0.0)
        return self.base_mm + block + np.maximum(boss, 0.0)

    def gradient(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        xa = np.asarray(x, dtype=np.float64)
        ya = np.asarray(y, dtype=np.float64)
        xa, ya = np.broadcast_arrays(xa, ya)
        # chamfers: slope 1 down and away from the top along the axis that sets d
        ex, ey_ = np.abs(xa) - self.half_length_mm, np.abs(ya) - self.half_width_mm
        d = np.maximum(ex, ey_)
        ramp = (d > 0) & (d < self.block_mm)
        along_x = ex >= ey_
        gx = np.where(ramp & along_x, -np.sign(xa), 0.0)
        gy = np.where(ramp & ~along_x, -np.sign(ya), 0.0)
        bx, by, root2, on = self._boss_terms(xa, ya)
        root = np.sqrt(np.where(on, root2, 1.0))
        gx = np.where(on, -bx / root, gx)
        gy = np.where(on, -by / root, gy)
        return gx, gy

    def specular_strength(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        on = self._boss_terms(x, y)[3]
        return np.where(on, float(self.specular), 0.0)

    def reflectivity(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        on_part = self._block_excess(x, y) < self.block_mm
        return np.where(on_part, float(self.reflectivity_value), float(self.base_reflectivity))

    def on_part(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.bool_]:
        """True where world (x, y) lies on the part (block, chamfers or boss), not the plane.

        Parameters
        ----------
        x, y : array_like
            World coordinates in mm, broadcasting against each other.

        Returns
        -------
        ndarray of bool
            The broadcast shape of ``x`` and ``y``.
        """
        return np.asarray(self._block_excess(x, y) < self.block_mm)

    def to_manifest(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "base_mm": float(self.base_mm),
            "block_mm": float(self.block_mm),
            "half_length_mm": float(self.half_length_mm),
            "half_width_mm": float(self.half_width_mm),
            "boss_mm": float(self.boss_mm),
            "boss_radius_mm": float(self.boss_radius_mm),
            "boss_length_mm": float(self.boss_length_mm),
            "reflectivity": float(self.reflectivity_value),
            "base_reflectivity": float(self.base_reflectivity),
            "specular": float(self.specular),
            "shininess": float(self.shininess),
        }


def plate(depth_mm: float = 0.0, reflectivity: float = 1.0) -> FlatPlate:
    """A flat plate of any reflectivity at ``depth_mm``.

    Parameters
    ----------
    depth_mm : float
        Plate surface height above the reference plane.
    reflectivity : float
        Uniform diffuse reflectivity (white plate = 1).

    Returns
    -------
    FlatPlate
        Registered as ``"plate"``.

    Examples
    --------
    >>> plate(4, reflectivity=0.6).to_manifest()
    {'name': 'plate', 'depth_mm': 4.0, 'reflectivity': 0.6}
    """
    return FlatPlate(float(depth_mm), float(reflectivity), "plate")


def white_plate(depth_mm: float = 0.0, reflectivity: float = 1.0) -> FlatPlate:
    """The white calibration plate (thesis Ch. 4) at ``depth_mm`` (0: the reference plane).

    Parameters
    ----------
    depth_mm : float
        Plate surface height above the reference plane.
    reflectivity : float
        Its reflectivity; 1 by definition (every other reflectivity is relative to it).

    Returns
    -------
    FlatPlate
        Registered as ``"white_plate"``.

    References
    ----------
    Thesis Sec. 4.1 (the white plate at :data:`THESIS_CALIBRATION_DEPTHS_MM`).

    Examples
    --------
    >>> white_plate(12).height(0.0, 0.0).tolist(), white_plate().name
    (12.0, 'white_plate')
    """
    return FlatPlate(float(depth_mm), float(reflectivity), "white_plate")


def black_plate(depth_mm: float = 0.0, reflectivity: float = BLACK_PLATE_REFLECTIVITY) -> FlatPlate:
    """The black calibration plate (thesis Sec. 5.2.2) at ``depth_mm``.

    Parameters
    ----------
    depth_mm : float
        Plate surface height above the reference plane.
    reflectivity : float
        Its reflectivity (default :data:`BLACK_PLATE_REFLECTIVITY`).

    Returns
    -------
    FlatPlate
        Registered as ``"black_plate"``.

    References
    ----------
    Thesis Sec. 5.2.2 (calibration on a black plate with a more open aperture).

    Examples
    --------
    >>> black_plate(2).to_manifest()
    {'name': 'black_plate', 'depth_mm': 2.0, 'reflectivity': 0.25}
    """
    return FlatPlate(float(depth_mm), float(reflectivity), "black_plate")


def checkerboard(
    depth_mm: float = 10.0,
    square_mm: float = 25.0,
    white_reflectivity: float = 0.95,
    black_reflectivity: float = BLACK_PLATE_REFLECTIVITY,
) -> Checkerboard:
    """The black-and-white checkerboard on its 10 mm board (see :class:`Checkerboard`).

    Parameters
    ----------
    depth_mm : float
        Height of the printed surface above the reference plane.
    square_mm : float
        Side of one square.
    white_reflectivity, black_reflectivity : float
        Reflectivities of the two colours (white plate = 1).

    Returns
    -------
    Checkerboard

    References
    ----------
    Thesis Sec. 5.2.2.

    Examples
    --------
    >>> checkerboard(depth_mm=12).to_manifest()["depth_mm"]
    12.0
    """
    return Checkerboard(
        float(depth_mm), float(square_mm), float(white_reflectivity), float(black_reflectivity)
    )


def mask(base_mm: float = 0.0, scale: float = 1.0, reflectivity: float = 0.7) -> Mask:
    """The face-like mask (see :class:`Mask`).

    Parameters
    ----------
    base_mm : float
        Height of the plane the mask rests on.
    scale : float
        Lateral and height scale factor, 0.1..2.
    reflectivity : float
        Uniform matte reflectivity.

    Returns
    -------
    Mask

    Examples
    --------
    >>> m = mask(base_mm=5.0, scale=0.5)
    >>> float(m.height(300.0, 0.0)), m.to_manifest()["scale"]
    (5.0, 0.5)
    """
    return Mask(float(base_mm), float(scale), float(reflectivity))


def glossy(
    base_mm: float = 0.0,
    height_mm: float = 30.0,
    radius_mm: float = 100.0,
    reflectivity: float = 0.5,
    specular: float = 2.0,
    shininess: float = 200.0,
) -> GlossyDome:
    """The glossy dome (see :class:`GlossyDome`).

    Parameters
    ----------
    base_mm : float
        Height of the plane the dome rests on.
    height_mm : float
        Cap height above its base, below ``radius_mm``.
    radius_mm : float
        Sphere radius.
    reflectivity : float
        Diffuse reflectivity of dome and base.
    specular : float
        Peak specular gain relative to a white diffuse surface.
    shininess : float
        Blinn-Phong exponent.

    Returns
    -------
    GlossyDome

    Examples
    --------
    >>> float(glossy(base_mm=10.0, height_mm=20.0).height(0.0, 0.0))
    30.0
    """
    return GlossyDome(
        float(base_mm),
        float(height_mm),
        float(radius_mm),
        float(reflectivity),
        float(specular),
        float(shininess),
    )


def specular_part(
    base_mm: float = 0.0,
    block_mm: float = 8.0,
    half_length_mm: float = 90.0,
    half_width_mm: float = 65.0,
    boss_mm: float = 6.0,
    boss_radius_mm: float = 30.0,
    boss_length_mm: float = 80.0,
    reflectivity: float = 0.25,
    base_reflectivity: float = 0.5,
    specular: float = 12.0,
    shininess: float = 100.0,
) -> SpecularPart:
    """The machined metal part with a polished boss (see :class:`SpecularPart`).

    Parameters
    ----------
    base_mm : float
        Height of the plane the part rests on.
    block_mm : float
        Block thickness (and chamfer width).
    half_length_mm, half_width_mm : float
        Half sizes of the block's flat top along X and Y.
    boss_mm : float
        Boss height above the block top.
    boss_radius_mm : float
        Radius of the boss's cylinder and end caps.
    boss_length_mm : float
        Length of the boss's straight part along Y.
    reflectivity : float
        Diffuse reflectivity of the metal.
    base_reflectivity : float
        Diffuse reflectivity of the plane around the part.
    specular : float
        Peak Blinn-Phong gain of the boss.
    shininess : float
        Blinn-Phong exponent of the boss.

    Returns
    -------
    SpecularPart
        Registered as ``"specular_part"``.

    Examples
    --------
    >>> part = specular_part(base_mm=2.0)
    >>> float(part.height(0.0, 0.0)), scene_from_manifest(part.to_manifest()) == part
    (16.0, True)
    """
    return SpecularPart(
        float(base_mm),
        float(block_mm),
        float(half_length_mm),
        float(half_width_mm),
        float(boss_mm),
        float(boss_radius_mm),
        float(boss_length_mm),
        float(reflectivity),
        float(base_reflectivity),
        float(specular),
        float(shininess),
    )


#: Board patterns of :class:`CalibrationBoard` (OpenCV's chessboard and symmetric circle grid).
BOARD_PATTERNS = ("checkerboard", "circles")


def _box_inside(s: NDArray[np.float64], lo: float, hi: float, w: float) -> NDArray[np.float64]:
    """Mean over ``[s - w/2, s + w/2]`` of the indicator of ``[lo, hi)`` (w = 0: the value)."""
    if w <= 0:
        return ((s >= lo) & (s < hi)).astype(np.float64)
    a = np.clip(s + w / 2, lo, hi) - np.clip(s - w / 2, lo, hi)
    return a / w


def _box_alternating(
    s: NDArray[np.float64], lo: float, hi: float, q: float, w: float
) -> NDArray[np.float64]:
    """Mean over ``[s - w/2, s + w/2]`` of ``(-1)^floor(u/q)`` on ``[lo, hi)``, 0 outside.

    The antiderivative of the square wave is the triangle wave ``q - |mod(u, 2q) - q|``, so the
    box mean is exact (the pixel-footprint average of the printed pattern along one axis).
    """
    if w <= 0:
        inside = (s >= lo) & (s < hi)
        return np.where(inside, 1.0 - 2.0 * (np.floor(s / q) % 2), 0.0)

    def tri(u: NDArray[np.float64]) -> NDArray[np.float64]:
        u = np.clip(u, lo, hi)
        return q - np.abs(np.mod(u, 2 * q) - q)

    return (tri(s + w / 2) - tri(s - w / 2)) / w


def _rotation_xyz(tilt_x_deg: float, tilt_y_deg: float, spin_deg: float) -> NDArray[np.float64]:
    ax, ay, az = (math.radians(v) for v in (tilt_x_deg, tilt_y_deg, spin_deg))
    rx = np.array([[1, 0, 0], [0, math.cos(ax), -math.sin(ax)], [0, math.sin(ax), math.cos(ax)]])
    ry = np.array([[math.cos(ay), 0, math.sin(ay)], [0, 1, 0], [-math.sin(ay), 0, math.cos(ay)]])
    rz = np.array([[math.cos(az), -math.sin(az), 0], [math.sin(az), math.cos(az), 0], [0, 0, 1]])
    # board frame as OpenCV's object frame: s along +X, t along -Y, z into the board (-Z)
    return ry @ rx @ np.diag([1.0, -1.0, -1.0]) @ rz


@dataclass(frozen=True)
class CalibrationBoard(Scene):
    """A planar calibration board (checkerboard or circle grid) at any pose, on a white plane.

    The printed pattern lies on an infinite white plane (the board's margin), which is a
    heightfield as long as the tilt stays below 90 degrees (limited here to 60). Board
    coordinates ``(s, t)`` in mm are OpenCV's object coordinates: the pattern point ``(i, j)``
    (inner corner of a checkerboard, centre of a circle) sits at ``(i * spacing, j * spacing,
    0)``, ``i < cols``, ``j < rows``. The board frame is placed in the world by
    ``X = centre + R @ (s - s_c, t - t_c, 0)`` with ``(s_c, t_c)`` the pattern's centre and
    ``R = R_y(tilt_y) R_x(tilt_x) diag(1, -1, -1) R_z(spin)``: untilted and unspun, ``s`` runs
    along +X (image columns), ``t`` along -Y (image rows) and the board's ``z`` into the board,
    away from the camera, as OpenCV's object frame.

    Reflectivity: ``white_reflectivity`` on the plane, ``black_reflectivity`` on the black
    squares or dots. With ``footprint_mm > 0`` it is the mean over a ``footprint_mm`` square
    around the point in board coordinates (exact for the checkerboard, whose box average is
    separable; a linear ramp across the dot edges for circles): an antialiased print, so a
    camera pixel sees a footprint average rather than a point sample and corners stay
    sub-pixel accurate. Pick about one camera pixel's size on the board.

    Parameters
    ----------
    pattern : {"checkerboard", "circles"}
        Chessboard of ``(cols + 1) x (rows + 1)`` squares (``cols x rows`` inner corners), or a
        symmetric grid of ``cols x rows`` black dots.
    cols, rows : int
        OpenCV's pattern size: inner corners (checkerboard) or dots (circles) per row and column.
    spacing_mm : float
        Square side, or distance between dot centres.
    centre_mm : tuple of float
        World position of the pattern's centre ``(x, y, z)`` in mm.
    tilt_x_deg, tilt_y_deg : float
        Rotations of the board about the world X and Y axes.
    spin_deg : float
        Rotation of the pattern in its plane (about the board normal).
    white_reflectivity, black_reflectivity : float
        Reflectivities (white plate = 1); the black must stay well above 0 so that fringes on
        it still decode.
    dot_diameter_mm : float
        Circles only: dot diameter (0: half the spacing).
    footprint_mm : float
        Side of the averaging square (antialiasing); 0: sharp point samples.

    References
    ----------
    Zhang 2000 (planar-target camera calibration); the projector as an inverse camera:
    Zhang & Huang 2006.

    Examples
    --------
    >>> board = CalibrationBoard("checkerboard", 4, 3, 20.0, centre_mm=(0.0, 0.0, 10.0))
    >>> board.corners_world()[0].round(6).tolist()  # inner corner (0, 0): left, top
    [-30.0, 20.0, 10.0]
    >>> board.reflectivity([-40.0, -20.0], [30.0, 30.0]).tolist()  # black, then white square
    [0.3, 0.9]
    >>> tilted = CalibrationBoard("checkerboard", 4, 3, 20.0, tilt_y_deg=30.0)
    >>> p = tilted.corners_world()
    >>> bool(np.allclose(tilted.height(p[:, 0], p[:, 1]), p[:, 2]))
    True
    """

    pattern: str = "checkerboard"
    cols: int = 9
    rows: int = 6
    spacing_mm: float = 20.0
    centre_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tilt_x_deg: float = 0.0
    tilt_y_deg: float = 0.0
    spin_deg: float = 0.0
    white_reflectivity: float = 0.9
    black_reflectivity: float = 0.3
    dot_diameter_mm: float = 0.0
    footprint_mm: float = 0.0

    name: ClassVar[str] = "board"

    def __post_init__(self) -> None:
        if self.pattern not in BOARD_PATTERNS:
            raise InputError(
                f"unknown board pattern {self.pattern!r}; use {' or '.join(BOARD_PATTERNS)}"
            )
        for key in ("cols", "rows"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 2 <= v <= 100:
                raise InputError(f"board {key} must be a whole number 2..100, got {v!r}")
        _finite("spacing_mm", self.spacing_mm)
        if self.spacing_mm <= 0:
            raise InputError(f"board spacing_mm must be > 0, got {self.spacing_mm}")
        centre = tuple(float(v) for v in self.centre_mm)
        if len(centre) != 3:
            raise InputError(f"board centre_mm must be (x, y, z) in mm, got {self.centre_mm!r}")
        for k, v in zip("xyz", centre, strict=True):
            _finite(f"centre_mm {k}", v)
        _depth_ok("centre_mm z", centre[2])
        object.__setattr__(self, "centre_mm", centre)
        for key in ("tilt_x_deg", "tilt_y_deg", "spin_deg"):
            _finite(key, getattr(self, key))
        if self.normal()[2] < math.cos(math.radians(60.0)):
            raise InputError(
                f"board tilt {self.tilt_x_deg}, {self.tilt_y_deg} deg leans more than 60 degrees "
                "from facing the camera; use smaller tilts"
            )
        _reflectivity_ok("white_reflectivity", self.white_reflectivity)
        _reflectivity_ok("black_reflectivity", self.black_reflectivity)
        for key in ("dot_diameter_mm", "footprint_mm"):
            _finite(key, getattr(self, key))
            if getattr(self, key) < 0:
                raise InputError(f"board {key} must be >= 0, got {getattr(self, key)}")
        if self.pattern == "circles" and self.dot_diameter >= self.spacing_mm:
            raise InputError(
                f"board dot diameter {self.dot_diameter} mm must be below the spacing "
                f"{self.spacing_mm} mm"
            )

    @property
    def dot_diameter(self) -> float:
        """Dot diameter in mm (circles; ``dot_diameter_mm`` or half the spacing)."""
        return self.dot_diameter_mm if self.dot_diameter_mm > 0 else 0.5 * self.spacing_mm

    def rotation(self) -> NDArray[np.float64]:
        """``R`` of ``X = centre + R @ (s - s_c, t - t_c, 0)``: board axes in world coordinates.

        Returns
        -------
        ndarray, shape (3, 3)
            Columns: the board's ``s``, ``t`` and ``z`` (into the board) axes.
        """
        return _rotation_xyz(self.tilt_x_deg, self.tilt_y_deg, self.spin_deg)

    def normal(self) -> NDArray[np.float64]:
        """Unit normal of the printed side (toward the camera side of the plane).

        Returns
        -------
        ndarray, shape (3,)
            ``-R[:, 2]``; its z component is positive for a board facing the camera.
        """
        return -self.rotation()[:, 2]

    def object_points(self) -> NDArray[np.float64]:
        """OpenCV object points of the pattern, row by row: ``(i * spacing, j * spacing, 0)``.

        Returns
        -------
        ndarray, shape (cols * rows, 3)
            Board coordinates in mm, ``i`` fastest (OpenCV's corner order).
        """
        j, i = np.mgrid[0 : self.rows, 0 : self.cols]
        pts = np.stack([i.ravel(), j.ravel(), np.zeros(i.size)], axis=1)
        return pts * self.spacing_mm

    def _pattern_centre(self) -> NDArray[np.float64]:
        return np.array([(self.cols - 1) / 2, (self.rows - 1) / 2, 0.0]) * self.spacing_mm

    def board_to_world(self, points: ArrayLike) -> NDArray[np.float64]:
        """World coordinates (mm) of board points ``(s, t, z)``.

        Parameters
        ----------
        points : array_like, shape (..., 3)
            Board coordinates in mm (``z = 0`` on the board).

        Returns
        -------
        ndarray, shape (..., 3)
        """
        pts = np.asarray(points, dtype=np.float64) - self._pattern_centre()
        return pts @ self.rotation().T + np.asarray(self.centre_mm)

    def corners_world(self) -> NDArray[np.float64]:
        """World coordinates of :meth:`object_points` (the truth of each pose).

        Returns
        -------
        ndarray, shape (cols * rows, 3)
        """
        return self.board_to_world(self.object_points())

    def height(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        n = self.normal()
        cx, cy, cz = self.centre_mm
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        return cz - (n[0] * (x - cx) + n[1] * (y - cy)) / n[2]

    def gradient(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        n = self.normal()
        return _full(x, y, -n[0] / n[2]), _full(x, y, -n[1] / n[2])

    def board_coordinates(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Board coordinates ``(s, t)`` in mm of the plane's point above world ``(x, y)``.

        Parameters
        ----------
        x, y : array_like
            World coordinates in mm, broadcasting against each other.

        Returns
        -------
        s, t : ndarray of float64
        """
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        z = self.height(x, y)
        rel = np.stack(np.broadcast_arrays(x, y, z), axis=-1) - np.asarray(self.centre_mm)
        local = rel @ self.rotation() + self._pattern_centre()
        return local[..., 0], local[..., 1]

    def reflectivity(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        s, t = self.board_coordinates(x, y)
        w, q = float(self.footprint_mm), float(self.spacing_mm)
        if self.pattern == "checkerboard":
            # squares (-1..cols) x (-1..rows); square (i, j) is black when i + j is even
            lo_s, hi_s = -q, self.cols * q
            lo_t, hi_t = -q, self.rows * q
            inside = _box_inside(s, lo_s, hi_s, w) * _box_inside(t, lo_t, hi_t, w)
            sign = _box_alternating(s, lo_s, hi_s, q, w) * _box_alternating(t, lo_t, hi_t, q, w)
            black = 0.5 * (inside + sign)
        else:
            i = np.clip(np.rint(s / q), 0, self.cols - 1)
            j = np.clip(np.rint(t / q), 0, self.rows - 1)
            dist = np.hypot(s - i * q, t - j * q)
            edge = self.dot_diameter / 2 - dist
            black = np.clip(edge / w + 0.5, 0.0, 1.0) if w > 0 else (edge > 0).astype(float)
        white, dark = float(self.white_reflectivity), float(self.black_reflectivity)
        return dark * black + white * (1.0 - black)

    def to_manifest(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "pattern": self.pattern,
            "cols": int(self.cols),
            "rows": int(self.rows),
            "spacing_mm": float(self.spacing_mm),
            "centre_mm": [float(v) for v in self.centre_mm],
            "tilt_x_deg": float(self.tilt_x_deg),
            "tilt_y_deg": float(self.tilt_y_deg),
            "spin_deg": float(self.spin_deg),
            "white_reflectivity": float(self.white_reflectivity),
            "black_reflectivity": float(self.black_reflectivity),
            "dot_diameter_mm": float(self.dot_diameter_mm),
            "footprint_mm": float(self.footprint_mm),
        }


def board(
    pattern: str = "checkerboard",
    cols: int = 9,
    rows: int = 6,
    spacing_mm: float = 20.0,
    centre_mm: Sequence[float] = (0.0, 0.0, 0.0),
    tilt_x_deg: float = 0.0,
    tilt_y_deg: float = 0.0,
    spin_deg: float = 0.0,
    white_reflectivity: float = 0.9,
    black_reflectivity: float = 0.3,
    dot_diameter_mm: float = 0.0,
    footprint_mm: float = 0.0,
) -> CalibrationBoard:
    """A calibration board at a pose (see :class:`CalibrationBoard`).

    Parameters
    ----------
    pattern : {"checkerboard", "circles"}
        Chessboard or symmetric circle grid.
    cols, rows : int
        Inner corners (checkerboard) or dots (circles) per row and per column.
    spacing_mm : float
        Square side or dot spacing.
    centre_mm : sequence of float
        World ``(x, y, z)`` of the pattern's centre.
    tilt_x_deg, tilt_y_deg, spin_deg : float
        The board's tilts about world X and Y and its spin in its plane.
    white_reflectivity, black_reflectivity : float
        Reflectivities of the board and of the printed squares or dots.
    dot_diameter_mm : float
        Dot diameter (circles; 0: half the spacing).
    footprint_mm : float
        Antialiasing: side of the averaging square in board mm (0: sharp).

    Returns
    -------
    CalibrationBoard
        Registered as ``"board"``.

    Examples
    --------
    >>> b = board(cols=5, rows=4, spacing_mm=15, centre_mm=(0, 0, 20), tilt_x_deg=25)
    >>> scene_from_manifest(b.to_manifest()) == b
    True
    """
    centre = [float(v) for v in centre_mm] if not isinstance(centre_mm, str) else []
    if len(centre) != 3:
        raise InputError(f"board centre_mm must be (x, y, z) in mm, got {centre_mm!r}")
    return CalibrationBoard(
        str(pattern),
        cols,
        rows,
        float(spacing_mm),
        (centre[0], centre[1], centre[2]),
        float(tilt_x_deg),
        float(tilt_y_deg),
        float(spin_deg),
        float(white_reflectivity),
        float(black_reflectivity),
        float(dot_diameter_mm),
        float(footprint_mm),
    )


# --- acceptance artefacts (VDI/VDE 2634 Part 2: sphere, ball bar, flat plane) -----------------
#
# Each artefact is a union of simple solids (balls, a rod, a thin rectangular panel) floating
# over a dark matte base plane. As a heightfield, the scene is the top surface of that union over
# the base: every solid is seen as a column from its top surface down to the base (the lower
# half of a ball, the underside of the rod and anything under a solid are hidden). The simulator
# finds where camera rays meet it in closed form (:meth:`_Artefact.ray_heights`): the first solid
# a ray enters, kept only where the entry point is that solid's top surface and no other solid is
# above it; a ray that enters a ball below its equator, or passes under a solid to the base,
# would meet the column's wall in the heightfield and is marked as not hitting the surface (the
# silhouette's rim). The fixed-point search of the other scenes cannot be used: it assumes a
# continuous heightfield of moderate slope, and a floating ball is neither.

#: Reflectivity of the acceptance artefacts' matte surface (a white-grey matte coating).
ARTEFACT_REFLECTIVITY = 0.7
#: Reflectivity of the dark matte base plane under the artefacts.
ARTEFACT_BASE_REFLECTIVITY = 0.15
#: Blinn-Phong gain and exponent of the glossy variants (``specular`` > 0): the highlight peaks
#: at ``(0.7 + 3) / 0.7``, about 5x the matte level, so the default camera saturates on it.
GLOSSY_SPECULAR = 3.0
GLOSSY_SHININESS = 150.0


def _xyz(name: str, value: Sequence[float]) -> tuple[float, float, float]:
    if isinstance(value, str):
        raise InputError(f"{name} must be (x, y, z) in mm, got {value!r}")
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be (x, y, z) in mm, got {value!r}") from None
    if len(out) != 3:
        raise InputError(f"{name} must be (x, y, z) in mm, got {value!r}")
    for k, v in zip("xyz", out, strict=True):
        _finite(f"{name} {k}", v)
    _depth_ok(f"{name} z", out[2])
    return out[0], out[1], out[2]


def _positive(what: str, key: str, value: float) -> None:
    _finite(key, value)
    if value <= 0:
        raise InputError(f"{what} {key} must be > 0 mm, got {value}")


def _gloss_ok(what: str, specular: float, shininess: float) -> None:
    _finite("specular", specular)
    _finite("shininess", shininess)
    if specular < 0 or shininess <= 0:
        raise InputError(
            f"{what} specular must be >= 0 (0: matte) and shininess > 0, got {specular}, "
            f"{shininess}"
        )


_F64 = NDArray[np.float64]
#: Segments from a surface point start this far (as a fraction) along: the point's own solid.
_SEGMENT_EPS = 1e-7


class _Ball:
    """A ball of radius ``r`` centred at ``c``: top surface and the first ray entry."""

    def __init__(self, c: tuple[float, float, float], r: float) -> None:
        self.c = np.asarray(c, dtype=np.float64)
        self.r = float(r)

    def top(self, x: _F64, y: _F64) -> tuple[_F64, _F64, _F64]:
        dx, dy = x - self.c[0], y - self.c[1]
        r2 = dx * dx + dy * dy
        on = r2 < self.r * self.r
        root = np.sqrt(np.where(on, self.r * self.r - r2, 1.0))
        h = np.where(on, self.c[2] + root, -np.inf)
        return h, np.where(on, -dx / root, 0.0), np.where(on, -dy / root, 0.0)

    def entry(self, origin: _F64, d: tuple[_F64, _F64, _F64]) -> tuple[_F64, _F64]:
        """Ray parameter ``t`` of the entry point (inf: missed) and whether it is on the top."""
        m = origin - self.c
        a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        b = d[0] * m[0] + d[1] * m[1] + d[2] * m[2]
        disc = b * b - a * (m @ m - self.r * self.r)
        t = np.where(disc >= 0, (-b - np.sqrt(np.maximum(disc, 0.0))) / a, np.inf)
        z = origin[2] + t * d[2]
        return t, z >= self.c[2]

    def crosses(self, q: tuple[_F64, _F64, _F64], d: tuple[_F64, _F64, _F64]) -> _F64:
        """Whether the segments ``q + t d``, ``0 < t <= 1``, pass through the ball."""
        m = [q[k] - self.c[k] for k in range(3)]
        a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        b = d[0] * m[0] + d[1] * m[1] + d[2] * m[2]
        disc = b * b - a * (m[0] * m[0] + m[1] * m[1] + m[2] * m[2] - self.r * self.r)
        root = np.sqrt(np.maximum(disc, 0.0))
        t1, t2 = (-b - root) / a, (-b + root) / a
        return np.asarray((disc > 0) & (t2 > _SEGMENT_EPS) & (t1 < 1.0))


class _Rod:
    """A cylinder of radius ``r`` from ``a`` to ``b`` (its ends lie inside the balls)."""

    def __init__(self, a: tuple[float, float, float], b: tuple[float, float, float], r: float):
        self.a = np.asarray(a, dtype=np.float64)
        axis = np.asarray(b, dtype=np.float64) - self.a
        self.length = float(np.linalg.norm(axis))
        self.d = axis / self.length
        self.r = float(r)

    def top(self, x: _F64, y: _F64) -> tuple[_F64, _F64, _F64]:
        dx, dy, dz = self.d
        qx, qy = x - self.a[0], y - self.a[1]
        s0 = qx * dx + qy * dy
        a = 1.0 - dz * dz  # > 0: the rod is never vertical
        disc = (s0 * dz) ** 2 - a * (qx * qx + qy * qy - s0 * s0 - self.r * self.r)
        w = (s0 * dz + np.sqrt(np.maximum(disc, 0.0))) / a  # z - a_z on the upper side
        s = s0 + w * dz
        on = (disc > 0) & (s >= 0) & (s <= self.length)
        # the normal is the component of q perpendicular to the axis: grad F = 2 p
        px, py, pz = qx - s * dx, qy - s * dy, w - s * dz
        on &= pz > 0
        pz = np.where(on, pz, 1.0)
        return (
            np.where(on, self.a[2] + w, -np.inf),
            np.where(on, -px / pz, 0.0),
            np.where(on, -py / pz, 0.0),
        )

    def entry(self, origin: _F64, d: tuple[_F64, _F64, _F64]) -> tuple[_F64, _F64]:
        m = origin - self.a
        md = m @ self.d
        dd = d[0] * self.d[0] + d[1] * self.d[1] + d[2] * self.d[2]
        mp = [m[k] - md * self.d[k] for k in range(3)]
        dp = [d[k] - dd * self.d[k] for k in range(3)]
        a = dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2]
        b = mp[0] * dp[0] + mp[1] * dp[1] + mp[2] * dp[2]
        c = mp[0] ** 2 + mp[1] ** 2 + mp[2] ** 2 - self.r * self.r
        disc = b * b - a * c
        ok = (disc >= 0) & (a > 0)
        t = np.where(ok, (-b - np.sqrt(np.maximum(disc, 0.0))) / np.where(a > 0, a, 1.0), np.inf)
        s = md + t * dd
        hit = ok & (s >= 0) & (s <= self.length)
        upper = (mp[2] + t * dp[2]) >= 0  # the entry point's offset from the axis points up
        return np.where(hit, t, np.inf), upper

    def crosses(self, q: tuple[_F64, _F64, _F64], d: tuple[_F64, _F64, _F64]) -> _F64:
        """Whether the segments ``q + t d``, ``0 < t <= 1``, pass through the rod."""
        m = [q[k] - self.a[k] for k in range(3)]
        md = m[0] * self.d[0] + m[1] * self.d[1] + m[2] * self.d[2]
        dd = d[0] * self.d[0] + d[1] * self.d[1] + d[2] * self.d[2]
        mp = [m[k] - md * self.d[k] for k in range(3)]
        dp = [d[k] - dd * self.d[k] for k in range(3)]
        a = dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2]
        b = mp[0] * dp[0] + mp[1] * dp[1] + mp[2] * dp[2]
        c = mp[0] ** 2 + mp[1] ** 2 + mp[2] ** 2 - self.r * self.r
        disc = b * b - a * c
        safe = np.where(a > 0, a, 1.0)
        root = np.sqrt(np.maximum(disc, 0.0))
        t1, t2 = (-b - root) / safe, (-b + root) / safe
        # the part of the segment between the rod's end planes (s = 0 and s = length)
        with np.errstate(divide="ignore", invalid="ignore"):
            s0, s1 = -md / dd, (self.length - md) / dd
        lo = np.where(dd != 0, np.minimum(s0, s1), np.where((md >= 0) & (md <= self.length),
                      -np.inf, np.inf))  # fmt: skip
        hi = np.where(dd != 0, np.maximum(s0, s1), np.inf)
        t1, t2 = np.maximum(t1, lo), np.minimum(t2, hi)
        return np.asarray((disc > 0) & (a > 0) & (t2 > np.maximum(t1, _SEGMENT_EPS)) & (t1 < 1.0))


class _Panel:
    """A thin rectangle: centre ``c``, axes the columns of ``rot`` (length, width, normal)."""

    def __init__(
        self, c: tuple[float, float, float], rot: _F64, length: float, width: float
    ) -> None:
        self.c = np.asarray(c, dtype=np.float64)
        self.rot = rot
        self.n = rot[:, 2]
        self.half = (0.5 * float(length), 0.5 * float(width))

    def _inside(self, x: _F64, y: _F64, z: _F64) -> NDArray[np.bool_]:
        rel = (x - self.c[0], y - self.c[1], z - self.c[2])
        s = rel[0] * self.rot[0, 0] + rel[1] * self.rot[1, 0] + rel[2] * self.rot[2, 0]
        t = rel[0] * self.rot[0, 1] + rel[1] * self.rot[1, 1] + rel[2] * self.rot[2, 1]
        return np.asarray((np.abs(s) <= self.half[0]) & (np.abs(t) <= self.half[1]))

    def plane(self, x: _F64, y: _F64) -> _F64:
        n = self.n
        return np.asarray(self.c[2] - (n[0] * (x - self.c[0]) + n[1] * (y - self.c[1])) / n[2])

    def top(self, x: _F64, y: _F64) -> tuple[_F64, _F64, _F64]:
        z = self.plane(x, y)
        on = self._inside(x, y, z)
        n = self.n
        return (
            np.where(on, z, -np.inf),
            np.where(on, -n[0] / n[2], 0.0),
            np.where(on, -n[1] / n[2], 0.0),
        )

    def entry(self, origin: _F64, d: tuple[_F64, _F64, _F64]) -> tuple[_F64, _F64]:
        n = self.n
        nd = n[0] * d[0] + n[1] * d[1] + n[2] * d[2]
        safe = np.where(nd < 0, nd, -1.0)
        t = ((self.c - origin) @ n) / safe
        p = [origin[k] + t * d[k] for k in range(3)]
        hit = (nd < 0) & self._inside(p[0], p[1], p[2])
        return np.where(hit, t, np.inf), np.ones(np.shape(t), dtype=bool)

    def crosses(self, q: tuple[_F64, _F64, _F64], d: tuple[_F64, _F64, _F64]) -> _F64:
        """Whether the segments ``q + t d``, ``0 < t <= 1``, pass through the panel."""
        n = self.n
        nd = n[0] * d[0] + n[1] * d[1] + n[2] * d[2]
        off = n[0] * (self.c[0] - q[0]) + n[1] * (self.c[1] - q[1]) + n[2] * (self.c[2] - q[2])
        safe = np.where(nd != 0, nd, 1.0)
        t = off / safe
        p = [q[k] + t * d[k] for k in range(3)]
        return np.asarray((nd != 0) & (t > _SEGMENT_EPS) & (t < 1.0) & self._inside(*p))


def _rotation_tilt(azimuth_deg: float, tilt_deg: float, roll_deg: float) -> _F64:
    """``R_z(azimuth) R_y(-tilt) R_x(roll)``: columns the length axis (rising by ``tilt`` toward
    ``azimuth``), the width axis and the normal of a panel."""
    az, tl, rl = (math.radians(v) for v in (azimuth_deg, tilt_deg, roll_deg))
    rz = np.array([[math.cos(az), -math.sin(az), 0], [math.sin(az), math.cos(az), 0], [0, 0, 1]])
    ry = np.array([[math.cos(tl), 0, -math.sin(tl)], [0, 1, 0], [math.sin(tl), 0, math.cos(tl)]])
    rx = np.array([[1, 0, 0], [0, math.cos(rl), -math.sin(rl)], [0, math.sin(rl), math.cos(rl)]])
    return np.asarray(rz @ ry @ rx, dtype=np.float64)


def _moved(point: tuple[float, ...], rotation: _F64, translation: _F64) -> tuple[float, ...]:
    return tuple(float(v) for v in rotation @ np.asarray(point) + translation)


@dataclass(frozen=True)
class SphereTruth:
    """Calibrated values of a sphere at one position (world mm unless transformed).

    Parameters
    ----------
    centre_mm : tuple of float
        Sphere centre ``(x, y, z)``.
    diameter_mm : float
        Calibrated diameter.

    Examples
    --------
    >>> t = SphereTruth((1.0, 2.0, 3.0), 50.0)
    >>> t.to_frame(np.diag([1.0, -1.0, -1.0]), np.array([0.0, 0.0, 600.0])).centre_mm
    (1.0, -2.0, 597.0)
    """

    centre_mm: tuple[float, float, float]
    diameter_mm: float

    def to_frame(self, rotation: ArrayLike, translation: ArrayLike) -> SphereTruth:
        """The same truth in another frame, ``X' = rotation @ X + translation``.

        Parameters
        ----------
        rotation : array_like, shape (3, 3)
            A rotation (e.g. ``RigGeometry.world_to_camera()[0]``).
        translation : array_like, shape (3,)
            Translation in mm.

        Returns
        -------
        SphereTruth
        """
        r, t = np.asarray(rotation, dtype=float), np.asarray(translation, dtype=float)
        c = _moved(self.centre_mm, r, t)
        return SphereTruth((c[0], c[1], c[2]), self.diameter_mm)


@dataclass(frozen=True)
class BallBarTruth:
    """Calibrated values of a ball bar at one position (world mm unless transformed).

    Parameters
    ----------
    centre_a_mm, centre_b_mm : tuple of float
        The two sphere centres.
    diameter_mm : float
        Calibrated diameter of both spheres.
    distance_mm : float
        Calibrated centre distance.

    Examples
    --------
    >>> BallBarTruth((0.0, 0.0, 0.0), (30.0, 40.0, 0.0), 20.0, 50.0).distance_mm
    50.0
    """

    centre_a_mm: tuple[float, float, float]
    centre_b_mm: tuple[float, float, float]
    diameter_mm: float
    distance_mm: float

    def to_frame(self, rotation: ArrayLike, translation: ArrayLike) -> BallBarTruth:
        """The same truth in another frame, ``X' = rotation @ X + translation``.

        Parameters
        ----------
        rotation : array_like, shape (3, 3)
            A rotation.
        translation : array_like, shape (3,)
            Translation in mm.

        Returns
        -------
        BallBarTruth
        """
        r, t = np.asarray(rotation, dtype=float), np.asarray(translation, dtype=float)
        a, b = _moved(self.centre_a_mm, r, t), _moved(self.centre_b_mm, r, t)
        return BallBarTruth((a[0], a[1], a[2]), (b[0], b[1], b[2]), self.diameter_mm,
                            self.distance_mm)  # fmt: skip


@dataclass(frozen=True)
class PlaneTruth:
    """Calibrated values of the flat plane at one position (world mm unless transformed).

    Parameters
    ----------
    centre_mm : tuple of float
        Centre of the rectangle (a point of the plane).
    normal : tuple of float
        Unit normal of the measured side (toward the camera).
    length_mm, width_mm : float
        Size of the rectangle.
    corners_mm : tuple of tuple of float
        The four corners.

    Examples
    --------
    >>> t = flat_plane(200.0, 50.0, tilt_deg=30.0).truth()
    >>> [round(v, 6) for v in t.normal]
    [-0.5, 0.0, 0.866025]
    """

    centre_mm: tuple[float, float, float]
    normal: tuple[float, float, float]
    length_mm: float
    width_mm: float
    corners_mm: tuple[tuple[float, float, float], ...]

    def to_frame(self, rotation: ArrayLike, translation: ArrayLike) -> PlaneTruth:
        """The same truth in another frame, ``X' = rotation @ X + translation``.

        Parameters
        ----------
        rotation : array_like, shape (3, 3)
            A rotation.
        translation : array_like, shape (3,)
            Translation in mm.

        Returns
        -------
        PlaneTruth
        """
        r, t = np.asarray(rotation, dtype=float), np.asarray(translation, dtype=float)
        c = _moved(self.centre_mm, r, t)
        n = _moved(self.normal, r, np.zeros(3))
        corners = tuple(_moved(p, r, t) for p in self.corners_mm)
        return PlaneTruth(
            (c[0], c[1], c[2]),
            (n[0], n[1], n[2]),
            self.length_mm,
            self.width_mm,
            tuple((p[0], p[1], p[2]) for p in corners),
        )


class _Artefact(Scene):
    """Shared machinery of the acceptance artefacts: solids over a dark matte base plane.

    Subclasses are frozen dataclasses with ``base_mm``, ``reflectivity_value``,
    ``base_reflectivity``, ``specular`` and ``shininess`` and define :meth:`_solids` (the solids
    and whether each is glossy) and :meth:`truth`.
    """

    base_mm: float
    reflectivity_value: float
    base_reflectivity: float

    def _solids(self) -> list[tuple[_Ball | _Rod | _Panel, bool]]:  # pragma: no cover
        raise NotImplementedError

    def _check_common(self, what: str) -> None:
        _depth_ok("base_mm", self.base_mm)
        _reflectivity_ok("reflectivity", self.reflectivity_value)
        _reflectivity_ok("base_reflectivity", self.base_reflectivity)
        _gloss_ok(what, self.specular, self.shininess)

    def _tops(self, x: ArrayLike, y: ArrayLike) -> tuple[_F64, _F64, _F64, NDArray[np.intp]]:
        """Height and slopes of the top surface, and which solid is on top (-1: the base)."""
        xa, ya = np.broadcast_arrays(
            np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        )
        h = np.full(xa.shape, float(self.base_mm))
        gx, gy = np.zeros(xa.shape), np.zeros(xa.shape)
        which = np.full(xa.shape, -1, dtype=np.intp)
        for k, (solid, _) in enumerate(self._solids()):
            hk, gxk, gyk = solid.top(xa, ya)
            above = hk > h
            h = np.where(above, hk, h)
            gx, gy = np.where(above, gxk, gx), np.where(above, gyk, gy)
            which = np.where(above, k, which)
        return h, gx, gy, which

    def height(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return self._tops(x, y)[0]

    def gradient(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        _, gx, gy, _ = self._tops(x, y)
        return gx, gy

    def reflectivity(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        which = self._tops(x, y)[3]
        return np.where(which >= 0, float(self.reflectivity_value), float(self.base_reflectivity))

    def specular_strength(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        which = self._tops(x, y)[3]
        glossy_ids = [k for k, (_, g) in enumerate(self._solids()) if g]
        return np.where(np.isin(which, glossy_ids), float(self.specular), 0.0)

    def on_artefact(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.bool_]:
        """True where the top surface at world ``(x, y)`` is the artefact, not the base.

        Parameters
        ----------
        x, y : array_like
            World coordinates in mm, broadcasting against each other.

        Returns
        -------
        ndarray of bool
        """
        return np.asarray(self._tops(x, y)[3] >= 0)

    def shadowed(
        self, x: ArrayLike, y: ArrayLike, z: ArrayLike, source: ArrayLike
    ) -> NDArray[np.bool_]:
        """Whether the segment from each surface point to a light source crosses a solid.

        The projector's shadow, in closed form on the real solids (light passes under a
        floating ball; the base casts no shadow on what is above it).

        Parameters
        ----------
        x, y, z : array_like
            Surface points in world mm (broadcasting against each other).
        source : array_like, shape (3,)
            The light source (the projector's centre) in world mm.

        Returns
        -------
        ndarray of bool
        """
        xa, ya, za = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
        pc = np.asarray(source, dtype=np.float64)
        d = (pc[0] - xa, pc[1] - ya, pc[2] - za)
        out = np.zeros(xa.shape, dtype=bool)
        for solid, _ in self._solids():
            out |= solid.crosses((xa, ya, za), d)
        return out

    def ray_heights(
        self, ax: ArrayLike, ay: ArrayLike, standoff_mm: float
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Where the camera rays ``X = ax (zc - z), Y = ay (zc - z)`` meet the surface.

        Closed form (see the section comment): the first solid each ray enters, or the base.

        Parameters
        ----------
        ax, ay : array_like
            Ray slopes (broadcasting against each other).
        standoff_mm : float
            Camera height ``zc`` above the reference plane.

        Returns
        -------
        z : ndarray of float64
            Height of the hit.
        hit : ndarray of bool
            False where the ray meets a part the heightfield hides (a column's wall).
        """
        axb, ayb = np.broadcast_arrays(
            np.asarray(ax, dtype=np.float64), np.asarray(ay, dtype=np.float64)
        )
        zc = float(standoff_mm)
        origin = np.array([0.0, 0.0, zc])
        d = (axb, ayb, -np.ones(axb.shape))
        t = np.full(axb.shape, zc - float(self.base_mm))
        upper = np.ones(axb.shape, dtype=bool)
        for solid, _ in self._solids():
            tk, uk = solid.entry(origin, d)
            first = tk < t
            t = np.where(first, tk, t)
            upper = np.where(first, uk, upper)
        z = zc - t
        top = self.height(axb * t, ayb * t)
        hit = upper & (top <= z + 1e-6 * (1.0 + np.abs(z)))
        return z, hit


@dataclass(frozen=True)
class AcceptanceSphere(_Artefact):
    """A sphere (the probing-error artefact of VDI/VDE 2634 Part 2) over a dark matte base.

    The camera sees the upper hemisphere, ``z = zc + sqrt(R^2 - (x - xc)^2 - (y - yc)^2)``
    for ``r < R``; elsewhere the base plane at ``base_mm`` (below the centre). The mount is not
    modelled (hidden under the sphere from above).

    Parameters
    ----------
    diameter_mm : float
        Calibrated diameter ``2 R``.
    centre_mm : tuple of float
        Centre ``(x, y, z)`` in world mm.
    base_mm : float
        Height of the base plane, at most the centre's z.
    reflectivity_value : float
        Diffuse reflectivity of the sphere.
    base_reflectivity : float
        Diffuse reflectivity of the base.
    specular : float
        Blinn-Phong gain of the sphere (0: matte, the guideline's artefact; > 0: glossy).
    shininess : float
        Blinn-Phong exponent.

    References
    ----------
    VDI/VDE 2634 Part 2 (probing error form PF and size PS on a sphere of 0.1-0.2 L0).

    Examples
    --------
    >>> s = sphere(50.0, (10.0, 0.0, 20.0), base_mm=-30.0)
    >>> s.height([10.0, 25.0, 100.0], [0.0, 0.0, 0.0]).tolist()  # apex, r = 15, the base
    [45.0, 40.0, -30.0]
    >>> s.truth()
    SphereTruth(centre_mm=(10.0, 0.0, 20.0), diameter_mm=50.0)
    """

    diameter_mm: float = 50.0
    centre_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_mm: float = -50.0
    reflectivity_value: float = ARTEFACT_REFLECTIVITY
    base_reflectivity: float = ARTEFACT_BASE_REFLECTIVITY
    specular: float = 0.0
    shininess: float = GLOSSY_SHININESS

    name: ClassVar[str] = "sphere"

    def __post_init__(self) -> None:
        _positive("sphere", "diameter_mm", self.diameter_mm)
        object.__setattr__(self, "centre_mm", _xyz("sphere centre_mm", self.centre_mm))
        self._check_common("sphere")
        if self.base_mm > self.centre_mm[2]:
            raise InputError(
                f"sphere base_mm = {self.base_mm} is above the centre z = {self.centre_mm[2]}; "
                "put the base at or below the sphere's equator"
            )

    def _solids(self) -> list[tuple[_Ball | _Rod | _Panel, bool]]:
        return [(_Ball(self.centre_mm, self.diameter_mm / 2), True)]

    def truth(self) -> SphereTruth:
        """The calibrated centre and diameter (world mm).

        Returns
        -------
        SphereTruth
        """
        return SphereTruth(self.centre_mm, float(self.diameter_mm))

    def to_manifest(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "diameter_mm": float(self.diameter_mm),
            "centre_mm": [float(v) for v in self.centre_mm],
            "base_mm": float(self.base_mm),
            "reflectivity": float(self.reflectivity_value),
            "base_reflectivity": float(self.base_reflectivity),
            "specular": float(self.specular),
            "shininess": float(self.shininess),
        }


#: Largest elevation of a ball bar's axis above the horizontal (the upper ball must not hide
#: the lower one from the camera, and the rod stays a heightfield).
MAX_BAR_ELEVATION_DEG = 60.0
#: Largest tilt of the flat plane (it stays lit and seen at a useful angle).
MAX_PLANE_TILT_DEG = 60.0


@dataclass(frozen=True)
class BallBar(_Artefact):
    """A ball bar (the sphere-spacing artefact): two equal spheres joined by a rod.

    Sphere tops as :class:`AcceptanceSphere`; the rod of diameter ``bar_diameter_mm`` joins
    the centres (its ends lie inside the spheres) and is seen from above where it is not
    covered by a sphere. The axis may rise in depth up to :data:`MAX_BAR_ELEVATION_DEG`, and
    the centres must be at least one diameter apart sideways, so both sphere tops are seen.

    Parameters
    ----------
    diameter_mm : float
        Calibrated diameter of both spheres.
    centre_a_mm, centre_b_mm : tuple of float
        The sphere centres (world mm).
    bar_diameter_mm : float
        Rod diameter, below the spheres' (0: no rod).
    base_mm : float
        Height of the base plane, at most the lower centre's z minus the rod radius.
    reflectivity_value, base_reflectivity : float
        Diffuse reflectivities of the artefact (spheres and rod) and of the base.
    specular : float
        Blinn-Phong gain of the spheres (0: matte; the rod is always matte).
    shininess : float
        Blinn-Phong exponent.

    References
    ----------
    VDI/VDE 2634 Part 2 (sphere-spacing error SD, centre distance >= 0.3 L0).

    Examples
    --------
    >>> bar = ball_bar(40.0, (-100.0, 0.0, 0.0), (100.0, 0.0, 50.0), base_mm=-60.0)
    >>> round(bar.truth().distance_mm, 3), float(bar.height(100.0, 0.0))
    (206.155, 70.0)
    """

    diameter_mm: float = 40.0
    centre_a_mm: tuple[float, float, float] = (-100.0, 0.0, 0.0)
    centre_b_mm: tuple[float, float, float] = (100.0, 0.0, 0.0)
    bar_diameter_mm: float = 12.0
    base_mm: float = -50.0
    reflectivity_value: float = ARTEFACT_REFLECTIVITY
    base_reflectivity: float = ARTEFACT_BASE_REFLECTIVITY
    specular: float = 0.0
    shininess: float = GLOSSY_SHININESS

    name: ClassVar[str] = "ball_bar"

    def __post_init__(self) -> None:
        _positive("ball_bar", "diameter_mm", self.diameter_mm)
        a = _xyz("ball_bar centre_a_mm", self.centre_a_mm)
        b = _xyz("ball_bar centre_b_mm", self.centre_b_mm)
        object.__setattr__(self, "centre_a_mm", a)
        object.__setattr__(self, "centre_b_mm", b)
        self._check_common("ball_bar")
        _finite("bar_diameter_mm", self.bar_diameter_mm)
        if not 0 <= self.bar_diameter_mm < self.diameter_mm:
            raise InputError(
                f"ball_bar bar_diameter_mm must be in [0, diameter_mm = {self.diameter_mm}), "
                f"got {self.bar_diameter_mm}"
            )
        sideways = math.hypot(b[0] - a[0], b[1] - a[1])
        if sideways <= self.diameter_mm:
            raise InputError(
                f"ball_bar centres are {sideways:.1f} mm apart sideways, not more than the "
                f"diameter {self.diameter_mm} mm: one sphere would hide the other from the "
                "camera; move them apart in x/y"
            )
        rise = math.degrees(math.atan2(abs(b[2] - a[2]), sideways))
        if rise > MAX_BAR_ELEVATION_DEG:
            raise InputError(
                f"ball_bar axis rises {rise:.1f} deg; at most {MAX_BAR_ELEVATION_DEG:g} deg "
                "(seen from above)"
            )
        low = min(a[2], b[2]) - self.bar_diameter_mm / 2
        if self.base_mm > low:
            raise InputError(
                f"ball_bar base_mm = {self.base_mm} is above the lower centre (minus the rod "
                f"radius, {low:g} mm); put the base lower"
            )

    @property
    def distance_mm(self) -> float:
        """Centre distance in mm."""
        return math.dist(self.centre_a_mm, self.centre_b_mm)

    def _solids(self) -> list[tuple[_Ball | _Rod | _Panel, bool]]:
        r = self.diameter_mm / 2
        out: list[tuple[_Ball | _Rod | _Panel, bool]] = [
            (_Ball(self.centre_a_mm, r), True),
            (_Ball(self.centre_b_mm, r), True),
        ]
        if self.bar_diameter_mm > 0:
            out.append((_Rod(self.centre_a_mm, self.centre_b_mm, self.bar_diameter_mm / 2), False))
        return out

    def on_sphere(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.intp]:
        """Which sphere's top is the surface at world ``(x, y)``: 0 (a), 1 (b), -1 (neither).

        Parameters
        ----------
        x, y : array_like
            World coordinates in mm, broadcasting against each other.

        Returns
        -------
        ndarray of intp
        """
        which = self._tops(x, y)[3]
        return np.where(which <= 1, which, -1)

    def truth(self) -> BallBarTruth:
        """The calibrated centres, diameter and centre distance (world mm).

        Returns
        -------
        BallBarTruth
        """
        return BallBarTruth(
            self.centre_a_mm, self.centre_b_mm, float(self.diameter_mm), self.distance_mm
        )

    def to_manifest(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "diameter_mm": float(self.diameter_mm),
            "centre_a_mm": [float(v) for v in self.centre_a_mm],
            "centre_b_mm": [float(v) for v in self.centre_b_mm],
            "bar_diameter_mm": float(self.bar_diameter_mm),
            "base_mm": float(self.base_mm),
            "reflectivity": float(self.reflectivity_value),
            "base_reflectivity": float(self.base_reflectivity),
            "specular": float(self.specular),
            "shininess": float(self.shininess),
        }


@dataclass(frozen=True)
class FlatPlane(_Artefact):
    """A flat rectangle (the flatness artefact) at any position and tilt, over the base.

    The rectangle's axes are the columns of ``R = R_z(azimuth) R_y(-tilt) R_x(roll)``: its
    length runs toward ``azimuth_deg`` (from +X toward +Y) rising by ``tilt_deg``; ``roll_deg``
    turns it about that axis (tilting the width). Height inside the rectangle
    ``z = zc - (n_x (x - xc) + n_y (y - yc)) / n_z`` with ``n`` the normal, elsewhere the base.
    Zero thickness; the tilt (angle of ``n`` from vertical) at most :data:`MAX_PLANE_TILT_DEG`.

    Parameters
    ----------
    length_mm, width_mm : float
        Size of the rectangle.
    centre_mm : tuple of float
        Its centre (world mm).
    azimuth_deg, tilt_deg, roll_deg : float
        Orientation (see above).
    base_mm : float
        Height of the base plane, below the rectangle's lowest corner.
    reflectivity_value, base_reflectivity : float
        Diffuse reflectivities of the plane and of the base.
    specular : float
        Blinn-Phong gain of the plane (0: matte).
    shininess : float
        Blinn-Phong exponent.

    References
    ----------
    VDI/VDE 2634 Part 2 (flatness measurement error F on a plane of length >= 0.5 L0).

    Examples
    --------
    >>> p = flat_plane(200.0, 50.0, (0.0, 0.0, 10.0), tilt_deg=30.0, base_mm=-100.0)
    >>> p.height([0.0, 50.0, 150.0], [0.0, 0.0, 0.0]).round(4).tolist()  # centre, up, off
    [10.0, 38.8675, -100.0]
    """

    length_mm: float = 200.0
    width_mm: float = 50.0
    centre_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    azimuth_deg: float = 0.0
    tilt_deg: float = 0.0
    roll_deg: float = 0.0
    base_mm: float = -50.0
    reflectivity_value: float = ARTEFACT_REFLECTIVITY
    base_reflectivity: float = ARTEFACT_BASE_REFLECTIVITY
    specular: float = 0.0
    shininess: float = GLOSSY_SHININESS

    name: ClassVar[str] = "flat_plane"

    def __post_init__(self) -> None:
        _positive("flat_plane", "length_mm", self.length_mm)
        _positive("flat_plane", "width_mm", self.width_mm)
        object.__setattr__(self, "centre_mm", _xyz("flat_plane centre_mm", self.centre_mm))
        for key in ("azimuth_deg", "tilt_deg", "roll_deg"):
            _finite(key, getattr(self, key))
        self._check_common("flat_plane")
        n = self.rotation()[:, 2]
        if n[2] < math.cos(math.radians(MAX_PLANE_TILT_DEG)) - 1e-12:
            raise InputError(
                f"flat_plane tilt {self.tilt_deg} deg, roll {self.roll_deg} deg leans "
                f"{math.degrees(math.acos(min(1.0, n[2]))):.1f} deg from facing the camera; at "
                f"most {MAX_PLANE_TILT_DEG:g}"
            )
        low = min(p[2] for p in self.corners())
        if self.base_mm > low:
            raise InputError(
                f"flat_plane base_mm = {self.base_mm} is above its lowest corner "
                f"(z = {low:.2f} mm); put the base lower"
            )

    def rotation(self) -> NDArray[np.float64]:
        """``R``: columns the length axis, the width axis and the normal (world).

        Returns
        -------
        ndarray, shape (3, 3)
        """
        return _rotation_tilt(self.azimuth_deg, self.tilt_deg, self.roll_deg)

    def corners(self) -> tuple[tuple[float, float, float], ...]:
        """The four corners in world mm.

        Returns
        -------
        tuple of (x, y, z)
        """
        rot = self.rotation()
        out = []
        for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = np.asarray(self.centre_mm) + rot @ [
                s * self.length_mm / 2,
                t * self.width_mm / 2,
                0,
            ]
            out.append((float(p[0]), float(p[1]), float(p[2])))
        return tuple(out)

    def _solids(self) -> list[tuple[_Ball | _Rod | _Panel, bool]]:
        return [(_Panel(self.centre_mm, self.rotation(), self.length_mm, self.width_mm), True)]

    def truth(self) -> PlaneTruth:
        """The calibrated plane: centre, unit normal, size and corners (world mm).

        Returns
        -------
        PlaneTruth
        """
        n = self.rotation()[:, 2]
        return PlaneTruth(
            self.centre_mm,
            (float(n[0]), float(n[1]), float(n[2])),
            float(self.length_mm),
            float(self.width_mm),
            self.corners(),
        )

    def to_manifest(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "length_mm": float(self.length_mm),
            "width_mm": float(self.width_mm),
            "centre_mm": [float(v) for v in self.centre_mm],
            "azimuth_deg": float(self.azimuth_deg),
            "tilt_deg": float(self.tilt_deg),
            "roll_deg": float(self.roll_deg),
            "base_mm": float(self.base_mm),
            "reflectivity": float(self.reflectivity_value),
            "base_reflectivity": float(self.base_reflectivity),
            "specular": float(self.specular),
            "shininess": float(self.shininess),
        }


def sphere(
    diameter_mm: float = 50.0,
    centre_mm: Sequence[float] = (0.0, 0.0, 0.0),
    base_mm: float = -50.0,
    reflectivity: float = ARTEFACT_REFLECTIVITY,
    base_reflectivity: float = ARTEFACT_BASE_REFLECTIVITY,
    specular: float = 0.0,
    shininess: float = GLOSSY_SHININESS,
) -> AcceptanceSphere:
    """The acceptance sphere (see :class:`AcceptanceSphere`).

    Parameters
    ----------
    diameter_mm : float
        Calibrated diameter.
    centre_mm : sequence of float
        Centre ``(x, y, z)`` in world mm.
    base_mm : float
        Height of the dark base plane (at most the centre's z).
    reflectivity, base_reflectivity : float
        Diffuse reflectivities of the sphere and of the base.
    specular : float
        Blinn-Phong gain (0: matte; e.g. :data:`GLOSSY_SPECULAR` for the glossy variant).
    shininess : float
        Blinn-Phong exponent.

    Returns
    -------
    AcceptanceSphere
        Registered as ``"sphere"``.

    Examples
    --------
    >>> s = sphere(40.0, (0.0, 0.0, 10.0), specular=GLOSSY_SPECULAR)
    >>> scene_from_manifest(s.to_manifest()) == s
    True
    """
    return AcceptanceSphere(
        float(diameter_mm),
        _xyz("sphere centre_mm", centre_mm),
        float(base_mm),
        float(reflectivity),
        float(base_reflectivity),
        float(specular),
        float(shininess),
    )


def ball_bar(
    diameter_mm: float = 40.0,
    centre_a_mm: Sequence[float] = (-100.0, 0.0, 0.0),
    centre_b_mm: Sequence[float] = (100.0, 0.0, 0.0),
    bar_diameter_mm: float = 12.0,
    base_mm: float = -50.0,
    reflectivity: float = ARTEFACT_REFLECTIVITY,
    base_reflectivity: float = ARTEFACT_BASE_REFLECTIVITY,
    specular: float = 0.0,
    shininess: float = GLOSSY_SHININESS,
) -> BallBar:
    """The ball bar (see :class:`BallBar`).

    Parameters
    ----------
    diameter_mm : float
        Calibrated diameter of both spheres.
    centre_a_mm, centre_b_mm : sequence of float
        The sphere centres in world mm.
    bar_diameter_mm : float
        Rod diameter (0: none).
    base_mm : float
        Height of the dark base plane.
    reflectivity, base_reflectivity : float
        Diffuse reflectivities of the artefact and of the base.
    specular : float
        Blinn-Phong gain of the spheres (0: matte).
    shininess : float
        Blinn-Phong exponent.

    Returns
    -------
    BallBar
        Registered as ``"ball_bar"``.

    Examples
    --------
    >>> b = ball_bar(30.0, (-80.0, 0.0, 0.0), (80.0, 10.0, 20.0))
    >>> scene_from_manifest(b.to_manifest()) == b
    True
    """
    return BallBar(
        float(diameter_mm),
        _xyz("ball_bar centre_a_mm", centre_a_mm),
        _xyz("ball_bar centre_b_mm", centre_b_mm),
        float(bar_diameter_mm),
        float(base_mm),
        float(reflectivity),
        float(base_reflectivity),
        float(specular),
        float(shininess),
    )


def flat_plane(
    length_mm: float = 200.0,
    width_mm: float = 50.0,
    centre_mm: Sequence[float] = (0.0, 0.0, 0.0),
    azimuth_deg: float = 0.0,
    tilt_deg: float = 0.0,
    roll_deg: float = 0.0,
    base_mm: float = -50.0,
    reflectivity: float = ARTEFACT_REFLECTIVITY,
    base_reflectivity: float = ARTEFACT_BASE_REFLECTIVITY,
    specular: float = 0.0,
    shininess: float = GLOSSY_SHININESS,
) -> FlatPlane:
    """The flat plane artefact (see :class:`FlatPlane`).

    Parameters
    ----------
    length_mm, width_mm : float
        Size of the rectangle.
    centre_mm : sequence of float
        Its centre in world mm.
    azimuth_deg, tilt_deg, roll_deg : float
        Direction of the length, its rise, and the turn about the length axis.
    base_mm : float
        Height of the dark base plane.
    reflectivity, base_reflectivity : float
        Diffuse reflectivities of the plane and of the base.
    specular : float
        Blinn-Phong gain of the plane (0: matte).
    shininess : float
        Blinn-Phong exponent.

    Returns
    -------
    FlatPlane
        Registered as ``"flat_plane"``.

    Examples
    --------
    >>> p = flat_plane(250.0, 60.0, (0.0, 0.0, 20.0), azimuth_deg=30.0, tilt_deg=20.0)
    >>> scene_from_manifest(p.to_manifest()) == p
    True
    """
    return FlatPlane(
        float(length_mm),
        float(width_mm),
        _xyz("flat_plane centre_mm", centre_mm),
        float(azimuth_deg),
        float(tilt_deg),
        float(roll_deg),
        float(base_mm),
        float(reflectivity),
        float(base_reflectivity),
        float(specular),
        float(shininess),
    )


#: Scene constructors by name, for the command line and for :func:`scene_from_manifest`.
SCENES: dict[str, Callable[..., Scene]] = {
    "white_plate": white_plate,
    "black_plate": black_plate,
    "plate": plate,
    "checkerboard": checkerboard,
    "mask": mask,
    "glossy": glossy,
    "board": board,
    "specular_part": specular_part,
    "sphere": sphere,
    "ball_bar": ball_bar,
    "flat_plane": flat_plane,
}


def make_scene(name: str, **params: Any) -> Scene:
    """Build the scene registered as ``name`` with keyword ``params``.

    Parameters
    ----------
    name : str
        A key of :data:`SCENES`.
    **params
        Keyword arguments of that constructor.

    Returns
    -------
    Scene

    Raises
    ------
    InputError
        For an unknown name, an unknown parameter or a value out of range.

    Examples
    --------
    >>> make_scene("white_plate", depth_mm=12).to_manifest()
    {'name': 'white_plate', 'depth_mm': 12.0, 'reflectivity': 1.0}
    """
    try:
        ctor = SCENES[name]
    except KeyError:
        raise InputError(
            f"unknown scene {name!r}; use one of {', '.join(sorted(SCENES))}"
        ) from None
    try:
        return ctor(**params)
    except TypeError as exc:
        raise InputError(f"bad parameters for scene {name!r}: {exc}") from None


def scene_from_manifest(entry: dict[str, Any]) -> Scene:
    """Rebuild a scene from its :meth:`Scene.to_manifest` dict (extra keys are an error).

    Parameters
    ----------
    entry : dict
        ``name`` (a key of :data:`SCENES`) and the constructor's keyword arguments, as a
        capture manifest's ``scene`` entry holds them.

    Returns
    -------
    Scene
        Equal to the scene that wrote ``entry``.

    Raises
    ------
    InputError
        When ``entry`` has no name, an unknown name or an unknown key.

    Examples
    --------
    >>> board = checkerboard(depth_mm=14)
    >>> scene_from_manifest(board.to_manifest()) == board
    True
    """
    if "name" not in entry:
        raise InputError("scene entry has no 'name'; add one of " + ", ".join(sorted(SCENES)))
    params = {k: v for k, v in entry.items() if k != "name"}
    return make_scene(str(entry["name"]), **params)
