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
    "BLACK_PLATE_REFLECTIVITY",
    "BOARD_PATTERNS",
    "SCENES",
    "THESIS_CALIBRATION_DEPTHS_MM",
    "CalibrationBoard",
    "Checkerboard",
    "FlatPlate",
    "GlossyDome",
    "Mask",
    "Scene",
    "SpecularPart",
    "black_plate",
    "board",
    "checkerboard",
    "glossy",
    "make_scene",
    "mask",
    "plate",
    "scene_from_manifest",
    "specular_part",
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
