"""The virtual rig: a physically modelled camera-projector pair observing a scene.

Modelled after the thesis rig (Sec. 3.4.3): a 648 x 494 8-bit camera 1.9 m above the reference
plane looking straight at it, and a 1024 x 768 8-bit projector whose optical axis makes 15 degrees
with the camera's, both pinholes. For every camera pixel the ray is intersected with the scene's
heightfield and the surface point is projected through the projector pinhole to get the continuous
projector coordinates ``(u, v)`` (column, row; pixel centres at integers). This geometry is
computed once per rig and cached; :meth:`SimulatedRig.capture` only evaluates radiometry.

Radiometry follows thesis Eq. 3.3 with each term parameterised physically::

    I = alpha * [ S * (r + k_s * (n.h)^m) * L_proj(u, v) + r * a1 ] + alpha * a2

- ``L_proj``: projected light, 1 at full-white input. The input gray of the frame is what
  :func:`hdrfringe.core.patterns.render_frame` sends (gamma pre-compensation with the rig's
  ``gamma_precompensation``, rounding at the projector bit depth); the projector's true gamma
  (Eq. 2.16) and black level turn it into light, ``L = b + (1 - b) * (g / (2^Bp - 1)) ** gamma``,
  which is then blurred by the projector defocus (a Gaussian acting on light, as optics do).
- ``S``: irradiance factor ``cos(incidence) / cos(15 deg) * (D / distance)^2`` (1 at the
  reference-plane centre); ``r``: scene reflectivity; ``k_s (n.h)^m``: optional Blinn-Phong lobe.
- ``alpha``: camera sensitivity, ``white_level * (2^B - 1)`` DN for a white (r = 1) surface at the
  reference-plane centre under full-white input, ambient excluded.
- ``a1``, ``a2``: reflected and direct ambient light, given in lux and converted with the thesis's
  0.17 gray level/lux (Fig. 4.14, 8-bit, at the reference sensitivity), scaled to B bits and to the
  camera's sensitivity.

The camera then blurs (Gaussian PSF), optionally integrates each pixel's area (supersampling),
scales by the camera settings (exposure time ``t`` against the camera's reference exposure
``t_ref``, gain ``G = 10^(gain_db / 20)``: ``I -> G (t / t_ref) I``), adds read noise (times
``G``) and shot noise, rounds and clips to ``[0, 2^B - 1]``
(:func:`hdrfringe.rig.sensor.sensor_readout`).

Line frames (which vary along one projector axis) are sampled from one projector line; frames
that vary along both axes (:class:`~hdrfringe.core.frames.PixelwiseFringeFrame`,
:class:`~hdrfringe.core.frames.ImageFrame`) are looked up in the full projector image at each
sample's ``(u, v)``, with the same projector models (docs/virtual_rig.md, "Projector images").

Noise is seeded per frame from ``(seed, scene, frame identity, camera settings, repeat count)``
through a SHA-256 hash, so a frame's image does not depend on the capture order.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import gaussian_filter, gaussian_filter1d
from scipy.special import erf

from hdrfringe.core._validation import full_scale
from hdrfringe.core.captures import CameraSettings, Captures, ProjectorInfo
from hdrfringe.core.frames import (
    IMAGE_FRAMES,
    LINE_FRAMES,
    Frame,
    FringeFrame,
    ImageFrame,
    LineFrame,
    PixelwiseFringeFrame,
    frame_axis,
    render_frame,
)
from hdrfringe.core.patterns import precompensate_gamma
from hdrfringe.errors import InputError
from hdrfringe.rig.base import RigBase
from hdrfringe.rig.scenes import Scene
from hdrfringe.rig.sensor import sensor_readout

if TYPE_CHECKING:
    from hdrfringe.core.stereo import StereoCalibration

__all__ = [
    "REFERENCE_EXPOSURE_MS",
    "REFERENCE_WHITE_LEVEL",
    "THESIS_DN_PER_LUX",
    "THESIS_GAMMA",
    "CameraModel",
    "GroundTruth",
    "Lighting",
    "ProjectorModel",
    "RigGeometry",
    "SimulatedRig",
    "simulate_frames",
]

#: Projector gamma estimated in the thesis (Sec. 2.6); default true gamma and pre-compensation.
THESIS_GAMMA = 2.812
#: Camera gray level per lux of added ambient light on the white plate, 8-bit (Fig. 4.14c).
THESIS_DN_PER_LUX = 0.17
#: Default camera sensitivity: a white plate at the reference-plane centre under full-white
#: projector input reads this fraction of full scale (204 of 255 at 8 bits).
REFERENCE_WHITE_LEVEL = 0.8
#: Default reference exposure time of the camera (ms): the exposure at which ``white_level`` and
#: the ambient coefficients hold; other exposures scale the signal by ``t / t_ref``.
REFERENCE_EXPOSURE_MS = 10.0

_FINE = 16  # samples per projector pixel of the line on which defocus blur is evaluated
# Defocus taps of the 2-D path reach this many Gaussian sigmas (plus the pixel half-width): the
# light left out is below 0.5 erfc(7.5 / sqrt 2) = 3e-14 of the total on each side.
_TAP_REACH = 7.5
_TAP_CHUNK = 8192  # samples per block in the 2-D defocus path (bounds its temporaries)
_BIT_DEPTHS = (8, 10, 12, 16)


def _check_positive(name: str, value: float, allow_zero: bool = False) -> None:
    ok = math.isfinite(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        bound = ">= 0" if allow_zero else "> 0"
        raise InputError(f"{name} must be a finite number {bound}, got {value}")


@dataclass(frozen=True)
class CameraModel:
    """Camera sensor, sensitivity, optics and noise.

    Parameters
    ----------
    width, height : int
        Resolution in pixels (thesis: Sony XCHR50, 648 x 494).
    bit_depth : int
        Sensor bit depth B, one of 8, 10, 12, 16. Saturation at ``2^B - 1``.
    white_level : float
        Sensitivity alpha (aperture and exposure) as the fraction of full scale a white plate
        (r = 1) at the reference-plane centre gives under full-white projector input, without
        ambient light. May exceed 1 (a more open aperture); see :meth:`with_aperture_for`.
    read_noise_dn8 : float
        Gaussian read-noise standard deviation in 8-bit gray levels (scaled by
        ``(2^B - 1) / 255`` for other B, i.e. the same sensor at another bit depth). 0: off.
    full_well_e : float or None
        Electrons at full scale, setting the shot noise: variance ``I * (2^B - 1) / full_well``
        DN^2 for a signal of ``I`` DN. None: no shot noise.
    blur_px : float
        Gaussian PSF standard deviation in camera pixels (0: none).
    supersample : int
        Each pixel's area is integrated over ``supersample x supersample`` sub-pixel samples.
    exposure_ms : float
        Reference exposure time t_ref in ms (default :data:`REFERENCE_EXPOSURE_MS`, 10 ms): the
        exposure at which ``white_level`` and the ambient coefficients hold. A capture at
        exposure ``t`` scales the signal by ``t / t_ref`` (:class:`SimulatedRig`,
        :class:`~hdrfringe.core.captures.CameraSettings`).
    vignetting : float
        Lens vignetting: the fraction of light lost at the image corners, falling off as
        ``1 - vignetting (r / r_corner)^2`` with ``r`` the distance from the image centre
        (projected and ambient light alike). 0 (default): none. In [0, 1).

    Examples
    --------
    >>> CameraModel(bit_depth=12).full_scale
    4095
    >>> CameraModel(width=5, height=3, vignetting=0.2).vignetting_map().round(2)[[0, 1], [0, 2]]
    array([0.8, 1. ])
    """

    width: int = 648
    height: int = 494
    bit_depth: int = 8
    white_level: float = REFERENCE_WHITE_LEVEL
    read_noise_dn8: float = 1.0
    full_well_e: float | None = 20000.0
    blur_px: float = 0.5
    supersample: int = 1
    exposure_ms: float = REFERENCE_EXPOSURE_MS
    vignetting: float = 0.0

    def __post_init__(self) -> None:
        if (
            int(self.width) != self.width
            or int(self.height) != self.height
            or min(self.width, self.height) < 1
        ):
            raise InputError(
                f"camera resolution must be positive integers, got {self.width}x{self.height}"
            )
        if self.bit_depth not in _BIT_DEPTHS:
            raise InputError(f"camera bit depth must be one of {_BIT_DEPTHS}, got {self.bit_depth}")
        _check_positive("camera white_level", self.white_level, allow_zero=True)
        _check_positive("camera read_noise_dn8", self.read_noise_dn8, allow_zero=True)
        if self.full_well_e is not None:
            _check_positive("camera full_well_e (None disables shot noise)", self.full_well_e)
        _check_positive("camera blur_px", self.blur_px, allow_zero=True)
        if int(self.supersample) != self.supersample or not (1 <= self.supersample <= 8):
            raise InputError(f"camera supersample must be an integer 1..8, got {self.supersample}")
        _check_positive("camera reference exposure_ms", self.exposure_ms)
        if not (math.isfinite(self.vignetting) and 0.0 <= self.vignetting < 1.0):
            raise InputError(
                f"camera vignetting must be in [0, 1) (light lost at the corners), "
                f"got {self.vignetting}"
            )

    def vignetting_map(self, supersample: int = 1) -> NDArray[np.float64]:
        """Relative light reaching each pixel (or sub-pixel sample) through the lens.

        Parameters
        ----------
        supersample : int
            Samples per pixel along each axis (the sample grid of :class:`SimulatedRig`).

        Returns
        -------
        ndarray, shape (height * supersample, width * supersample)
            ``1 - vignetting (r / r_corner)^2``: 1 at the centre, ``1 - vignetting`` at the
            corner pixel centres; all ones without vignetting.
        """
        s = int(supersample)
        # sample centres in pixel units, pixel centres at integers (as the tracing does)
        x = (np.arange(self.width * s) + 0.5) / s - 0.5 - (self.width - 1) / 2.0
        y = (np.arange(self.height * s) + 0.5) / s - 0.5 - (self.height - 1) / 2.0
        corner = ((self.width - 1) / 2.0) ** 2 + ((self.height - 1) / 2.0) ** 2
        r2 = (x[None, :] ** 2 + y[:, None] ** 2) / max(corner, 1e-12)
        return np.clip(1.0 - self.vignetting * r2, 0.0, 1.0)

    @property
    def full_scale(self) -> int:
        """Saturation value ``2^B - 1``."""
        return full_scale(self.bit_depth)

    @property
    def dtype(self) -> type[np.unsignedinteger]:
        """uint8 for B <= 8, otherwise uint16."""
        return np.uint8 if self.bit_depth <= 8 else np.uint16

    @property
    def white_dn(self) -> float:
        """alpha in DN: a white plate at the reference centre under full-white input."""
        return self.white_level * self.full_scale

    @property
    def read_noise_dn(self) -> float:
        """Read-noise standard deviation in DN at this bit depth."""
        return self.read_noise_dn8 * self.full_scale / 255.0

    @property
    def gain_dn_per_e(self) -> float:
        """Shot-noise gain in DN per electron, ``(2^B - 1) / full_well_e`` (0 without shot
        noise): a signal of ``I`` DN holds ``I / g`` electrons, so its shot-noise variance is
        ``g I`` DN^2."""
        return self.full_scale / self.full_well_e if self.full_well_e is not None else 0.0

    def noise_manifest(self, gain: float = 1.0) -> dict[str, float]:
        """The camera's noise model as a capture manifest records it (``camera.read_noise_dn``,
        ``camera.gain_dn_per_e``; :func:`hdrfringe.core.uncertainty.noise_from_manifest`).

        The images' variance at a signal of ``I`` DN is ``read_noise_dn^2 + gain_dn_per_e * I``
        with ``read_noise_dn^2 = (G sigma_r)^2 + 1/12`` (the read noise and the rounding to
        integers, the uniform quantisation error's variance) and ``gain_dn_per_e = G g``, at
        the analogue gain ``G`` (:func:`~hdrfringe.rig.sensor.sensor_readout`). A camera
        without read and shot noise records nothing (its images repeat exactly).

        Parameters
        ----------
        gain : float
            Linear analogue gain ``G`` of the captures (1.0: 0 dB).

        Returns
        -------
        dict
            ``{"read_noise_dn": ..., "gain_dn_per_e": ...}``, or empty without noise.

        References
        ----------
        Thesis Eq. 3.3 (the signal); docs/uncertainty.md (the noise model).

        Examples
        --------
        >>> m = CameraModel().noise_manifest()
        >>> round(m["read_noise_dn"], 4), m["gain_dn_per_e"]
        (1.0408, 0.01275)
        >>> CameraModel(read_noise_dn8=0.0, full_well_e=None).noise_manifest()
        {}
        """
        read, shot = self.read_noise_dn * gain, self.gain_dn_per_e * gain
        if read <= 0 and shot <= 0:
            return {}
        return {"read_noise_dn": math.sqrt(read * read + 1.0 / 12.0), "gain_dn_per_e": shot}

    def with_aperture_for(self, reflectivity: float, peak_fraction: float = 0.85) -> CameraModel:
        """The same camera with the aperture opened until ``reflectivity`` peaks at a fraction.

        The thesis calibrated on a black plate "with the aperture adjusted for a high intensity
        modulation without camera sensor saturation" (Sec. 5.2.2): a surface of reflectivity
        ``reflectivity`` at the reference-plane centre then reads ``peak_fraction`` of full scale
        under full-white input. Keep a margin below 1: the irradiance varies by about +-10 %
        over the field and the 2..50 mm calibration depths (projector distance and incidence).

        Examples
        --------
        >>> round(CameraModel().with_aperture_for(0.25).white_level, 3)
        3.4
        """
        _check_positive("reflectivity", reflectivity)
        _check_positive("peak_fraction", peak_fraction)
        return dataclasses.replace(self, white_level=peak_fraction / reflectivity)


@dataclass(frozen=True)
class ProjectorModel:
    """Projector: resolution, input bit depth, true gamma, black level, defocus, pixel model.

    Parameters
    ----------
    width, height : int
        Resolution in pixels (thesis: InFocus LP600, 1024 x 768).
    bit_depth : int
        Input bit depth Bp (1..16); gray levels of the frames are in these units.
    gamma : float
        True projector gamma of Eq. 2.16, ``w = u^gamma`` (thesis estimate 2.812).
    black_level : float
        Light at input 0 as a fraction of full white (DLP leakage).
    defocus_px : float
        Gaussian defocus blur standard deviation in projector pixels (0: sharp).
    model : {"pixelated", "continuous"}
        "pixelated": real projector pixels, piecewise constant, exactly the image of
        :func:`~hdrfringe.core.patterns.render_frame`. "continuous": the pattern is evaluated
        analytically at the continuous projector coordinate (then gamma-pre-compensated and
        rounded at Bp bits), i.e. a projector with infinitely many pixels.

    References
    ----------
    Thesis Eq. 2.16 (the projector's gamma) and Sec. 3.4.3 (the InFocus LP600 of the rig).

    Examples
    --------
    >>> proj = ProjectorModel(gamma=2.0, black_level=0.0)
    >>> proj.light(np.array([0, 128, 255])).round(4).tolist()
    [0.0, 0.252, 1.0]
    """

    width: int = 1024
    height: int = 768
    bit_depth: int = 8
    gamma: float = THESIS_GAMMA
    black_level: float = 0.005
    defocus_px: float = 0.6
    model: Literal["pixelated", "continuous"] = "pixelated"

    def __post_init__(self) -> None:
        if (
            int(self.width) != self.width
            or int(self.height) != self.height
            or min(self.width, self.height) < 2
        ):
            raise InputError(
                f"projector resolution must be integers >= 2, got {self.width}x{self.height}"
            )
        if self.bit_depth not in range(1, 17):
            raise InputError(f"projector bit depth must be 1..16, got {self.bit_depth}")
        _check_positive("projector gamma", self.gamma)
        if not (0.0 <= self.black_level < 1.0):
            raise InputError(f"projector black_level must be in [0, 1), got {self.black_level}")
        _check_positive("projector defocus_px", self.defocus_px, allow_zero=True)
        if self.model not in ("pixelated", "continuous"):
            raise InputError(
                f"projector model must be 'pixelated' or 'continuous', got {self.model!r}"
            )

    @property
    def full_scale(self) -> int:
        """Maximum input gray ``2^Bp - 1``."""
        return full_scale(self.bit_depth, "projector bit depth")

    def light(self, sent: NDArray[Any]) -> NDArray[np.float64]:
        """Projected light (1 = full white) for integer input grays ``sent`` (Eq. 2.16).

        Parameters
        ----------
        sent : ndarray
            Input grays sent to the projector, ``0..2^Bp - 1``.

        Returns
        -------
        ndarray of float64
            ``b + (1 - b) * (sent / (2^Bp - 1)) ** gamma`` with ``b`` the black level, same
            shape as ``sent``.
        """
        w = np.asarray(sent, dtype=np.float64) / self.full_scale
        return self.black_level + (1.0 - self.black_level) * w**self.gamma


@dataclass(frozen=True)
class RigGeometry:
    """Placement of the camera and projector (thesis Sec. 3.4.3).

    The camera centre is at ``(0, 0, standoff_mm)`` looking straight down at the reference plane
    ``z = 0`` (image columns along +X, rows along -Y). The projector centre is at
    ``D * (-sin(angle), 0, cos(angle))`` aimed at the origin, so its optical axis makes
    ``angle_deg`` with the camera's and the triangulation baseline is along X: vertical fringes
    (varying along projector columns) carry depth. With a positive angle the projector is on the
    camera image's left and the projector column ``u`` seen by a pixel grows with height.

    Parameters
    ----------
    standoff_mm : float
        Camera distance to the reference plane (thesis: 1.9 m).
    angle_deg : float
        Projector-camera angle (thesis: about 15 degrees); negative mirrors the projector to +X.
    projector_distance_mm : float or None
        Projector centre to origin; None: ``standoff / cos(angle)``, i.e. the projector lens at
        the camera's height, the classic crossed-axes layout.
    camera_field_mm : float
        Width of the camera's field of view on the reference plane (sets its focal length).
    projector_field_mm : float
        Width of the projected image at the origin, perpendicular to the projector axis (sets its
        focal length); larger than the camera field so every depth stays lit.
    lambertian_shading : bool
        Irradiance ``S = cos(incidence) / cos(angle) * (D / distance)^2``; False: ``S = 1``.

    References
    ----------
    Thesis Sec. 3.4.3 (1.9 m standoff, projector-camera angle about 15 degrees).

    Examples
    --------
    >>> geo = RigGeometry()
    >>> round(geo.projector_distance, 1), geo.camera_focal_px(648)
    (1967.0, 3847.5)
    """

    standoff_mm: float = 1900.0
    angle_deg: float = 15.0
    projector_distance_mm: float | None = None
    camera_field_mm: float = 320.0
    projector_field_mm: float = 400.0
    lambertian_shading: bool = True

    def __post_init__(self) -> None:
        _check_positive("standoff_mm", self.standoff_mm)
        if not (math.isfinite(self.angle_deg) and 1.0 <= abs(self.angle_deg) <= 45.0):
            raise InputError(
                f"projector-camera angle must be 1..45 degrees in magnitude, got {self.angle_deg}"
            )
        if self.projector_distance_mm is not None:
            _check_positive("projector_distance_mm", self.projector_distance_mm)
        _check_positive("camera_field_mm", self.camera_field_mm)
        _check_positive("projector_field_mm", self.projector_field_mm)

    @property
    def angle_rad(self) -> float:
        """Projector-camera angle in radians."""
        return math.radians(self.angle_deg)

    @property
    def projector_distance(self) -> float:
        """Projector centre to the origin in mm (resolved default)."""
        if self.projector_distance_mm is not None:
            return float(self.projector_distance_mm)
        return self.standoff_mm / math.cos(self.angle_rad)

    @property
    def camera_center(self) -> NDArray[np.float64]:
        """Camera centre in world coordinates (mm), shape (3,)."""
        return np.array([0.0, 0.0, self.standoff_mm])

    @property
    def projector_center(self) -> NDArray[np.float64]:
        """Projector centre in world coordinates (mm), shape (3,)."""
        t = self.angle_rad
        return self.projector_distance * np.array([-math.sin(t), 0.0, math.cos(t)])

    @property
    def projector_axes(self) -> NDArray[np.float64]:
        """Rows: projector x (columns), y (rows) and z (optical axis) in world coordinates."""
        s, c = math.sin(self.angle_rad), math.cos(self.angle_rad)
        return np.array([[c, 0.0, s], [0.0, -1.0, 0.0], [s, 0.0, -c]])

    def camera_focal_px(self, width: int) -> float:
        """Camera focal length in pixels for an image ``width`` pixels wide.

        Parameters
        ----------
        width : int
            Camera image width in pixels.

        Returns
        -------
        float
            ``width * standoff_mm / camera_field_mm``.
        """
        return width * self.standoff_mm / self.camera_field_mm

    def projector_focal_px(self, width: int) -> float:
        """Projector focal length in pixels for an image ``width`` pixels wide.

        Parameters
        ----------
        width : int
            Projector image width in pixels.

        Returns
        -------
        float
            ``width * projector_distance / projector_field_mm``.
        """
        return width * self.projector_distance / self.projector_field_mm

    def world_to_camera(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The rigid motion from world to camera coordinates (OpenCV camera frame).

        The camera frame has ``x`` along the image columns, ``y`` along the rows (down the
        image) and ``z`` along the viewing direction, origin at the camera centre: the frame of
        :class:`hdrfringe.core.stereo.StereoCalibration`. The camera looks straight down, columns
        along +X and rows along -Y, so ``X_cam = diag(1, -1, -1) @ (X_world - C)``.

        Returns
        -------
        rotation : ndarray, shape (3, 3)
            ``R_c`` of ``X_cam = R_c @ X_world + t_c``.
        translation : ndarray, shape (3,)
            ``t_c`` in mm.

        Examples
        --------
        >>> rot, t = RigGeometry().world_to_camera()
        >>> (rot @ np.array([0.0, 0.0, 0.0]) + t).tolist()  # the world origin, 1.9 m ahead
        [0.0, 0.0, 1900.0]
        """
        rot = np.diag([1.0, -1.0, -1.0])
        return rot, -rot @ self.camera_center

    def stereo_calibration(
        self, camera_size: tuple[int, int], projector_size: tuple[int, int]
    ) -> StereoCalibration:
        """The rig's true camera-projector geometry as a stereo calibration.

        Exactly the pinhole mapping the simulator traces with (:func:`_trace`, :func:`_shade`):
        the camera ray of pixel ``(c, r)`` has ``X/(z_c - z) = (c - (W - 1)/2) / f`` and
        ``Y/(z_c - z) = -(r - (H - 1)/2) / f``, so in the camera frame
        (:meth:`world_to_camera`) the principal point is ``((W - 1)/2, (H - 1)/2)`` with pixel
        centres at integers, OpenCV's convention; the projector maps a point ``P`` to
        ``u = (Wp - 1)/2 + f_p x_p / z_p``, ``v = (Hp - 1)/2 + f_p y_p / z_p`` with
        ``(x_p, y_p, z_p) = A (P - C_p)`` and ``A`` = :attr:`projector_axes`. No distortion.

        Parameters
        ----------
        camera_size : tuple of int
            Camera image ``(width, height)`` in pixels (``CameraModel.width, height``).
        projector_size : tuple of int
            Projector image ``(width, height)`` in pixels (``ProjectorModel.width, height``).

        Returns
        -------
        StereoCalibration
            ``X_proj = R @ X_cam + t`` with the camera frame as the world frame;
            ``source`` names the geometry.

        References
        ----------
        Zhang & Huang 2006 (the projector as an inverse camera); thesis Sec. 3.4.3 (the rig).

        Examples
        --------
        >>> calib = RigGeometry().stereo_calibration((648, 494), (1024, 768))
        >>> float(calib.camera.matrix[0, 0]), calib.camera.matrix[:2, 2].tolist()
        (3847.5, [323.5, 246.5])
        >>> round(calib.baseline_mm, 1)  # 1967 mm * sin(15 deg) along X at the camera's height
        509.1
        """
        from hdrfringe.core.stereo import LensModel, StereoCalibration

        (cw, ch), (pw, ph) = (_size(camera_size, "camera"), _size(projector_size, "projector"))
        fc = self.camera_focal_px(cw)
        fp = self.projector_focal_px(pw)
        k_cam = np.array([[fc, 0.0, (cw - 1) / 2.0], [0.0, fc, (ch - 1) / 2.0], [0.0, 0.0, 1.0]])
        k_proj = np.array([[fp, 0.0, (pw - 1) / 2.0], [0.0, fp, (ph - 1) / 2.0], [0.0, 0.0, 1.0]])
        rot_c, t_c = self.world_to_camera()
        # X_world = R_c^T (X_cam - t_c); X_proj = A (X_world - C_p)
        axes = self.projector_axes
        rotation = axes @ rot_c.T
        translation = axes @ (-rot_c.T @ t_c - self.projector_center)
        return StereoCalibration(
            LensModel(k_cam, np.zeros(5), (cw, ch)),
            LensModel(k_proj, np.zeros(5), (pw, ph)),
            rotation,
            translation,
            source=f"virtual rig geometry (true): {self!r}",
        )


def _size(size: tuple[int, int], what: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in size)
    except (TypeError, ValueError):
        raise InputError(f"{what} size must be (width, height) in pixels, got {size!r}") from None
    if w < 1 or h < 1 or (w, h) != tuple(size):
        raise InputError(f"{what} size must be (width, height) in pixels >= 1, got {size!r}")
    return w, h


@dataclass(frozen=True)
class Lighting:
    """Ambient light (thesis Sec. 3.3 ``a1``, ``a2``; Sec. 4.2 adds about 600 lx).

    Parameters
    ----------
    ambient_lux : float
        Illuminance of uniform ambient light on the scene, reflected with the scene's
        reflectivity (``a1``).
    direct_ambient_lux : float
        Ambient light entering the camera directly (``a2``), in lux-equivalent.
    dn_per_lux : float
        8-bit gray levels per lux on a white (r = 1) surface at the reference sensitivity
        :data:`REFERENCE_WHITE_LEVEL` (thesis Fig. 4.14c: 0.17). Scaled by ``(2^B - 1) / 255``
        and by ``white_level / REFERENCE_WHITE_LEVEL`` (a more open aperture sees more ambient).
    direct_dn_per_lux : float
        The same coefficient for the direct ambient light.

    References
    ----------
    Thesis Eq. 3.3 (``a1``, ``a2``), Sec. 4.2 (about 600 lx added) and Fig. 4.14c
    (0.17 gray level/lux).

    Examples
    --------
    600 lx on the white plate adds ``600 * 0.17 = 102`` gray levels at 8 bits:

    >>> from hdrfringe.rig.scenes import white_plate
    >>> cam = CameraModel(width=8, height=6)
    >>> rig = SimulatedRig(white_plate(), camera=cam, lighting=Lighting(ambient_lux=600))
    >>> round(float(rig.ambient_signal().mean()), 6)
    102.0
    """

    ambient_lux: float = 0.0
    direct_ambient_lux: float = 0.0
    dn_per_lux: float = THESIS_DN_PER_LUX
    direct_dn_per_lux: float = THESIS_DN_PER_LUX

    def __post_init__(self) -> None:
        for key in ("ambient_lux", "direct_ambient_lux", "dn_per_lux", "direct_dn_per_lux"):
            _check_positive(key, getattr(self, key), allow_zero=True)


@dataclass(frozen=True)
class GroundTruth:
    """What the virtual rig knows per camera pixel (arrays of shape (height, width)).

    Made by :meth:`SimulatedRig.truth` (read-only arrays).

    Parameters
    ----------
    height_mm : ndarray of float64
        Surface height above the reference plane where the pixel's ray hits the scene.
    u, v : ndarray of float64
        Continuous projector column and row seen by the pixel (pixel centres at integers).
    reflectivity : ndarray of float64
        Diffuse reflectivity ``r`` there (thesis Eq. 3.2).
    shading : ndarray of float64
        Irradiance factor ``S`` (cosine of incidence and inverse-square falloff).
    specular : ndarray of float64
        Blinn-Phong gain ``k_s (n.h)^m`` there (0 for matte scenes).
    x_mm, y_mm : ndarray of float64
        World coordinates of the surface point.
    valid : ndarray of bool
        The ray hit the surface, the point faces camera and projector, is not in the
        projector's shadow, and lies inside the projector image.

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> rig = SimulatedRig(white_plate(12.0), camera=CameraModel(width=8, height=6))
    >>> truth = rig.truth()
    >>> truth.height_mm.shape, float(truth.height_mm.max()), bool(truth.valid.all())
    ((6, 8), 12.0, True)
    """

    height_mm: NDArray[np.float64]
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    reflectivity: NDArray[np.float64]
    shading: NDArray[np.float64]
    specular: NDArray[np.float64]
    x_mm: NDArray[np.float64]
    y_mm: NDArray[np.float64]
    valid: NDArray[np.bool_]


_CHUNK = 1 << 16  # samples per block when tracing (keeps temporaries in cache-sized pieces)


def _trace(
    scene: Scene,
    geometry: RigGeometry,
    camera: CameraModel,
    projector: ProjectorModel,
    sub: int,
) -> GroundTruth:
    """Ray-cast the camera pixels (``sub`` x ``sub`` samples each) into the scene.

    Works on blocks of rows: a first pass intersects every ray with the surface, a second
    (which needs the highest traced point for the shadow test) projects into the projector and
    evaluates shading.
    """
    w, h = camera.width * sub, camera.height * sub
    f = geometry.camera_focal_px(camera.width)
    ax = ((np.arange(w) + 0.5) / sub - 0.5 - (camera.width - 1) / 2.0) / f
    ay = -((np.arange(h) + 0.5) / sub - 0.5 - (camera.height - 1) / 2.0) / f
    step = max(1, _CHUNK // w)
    blocks = [slice(r, min(r + step, h)) for r in range(0, h, step)]

    z = np.empty((h, w))
    converged = np.empty((h, w), dtype=bool)
    for rows in blocks:
        z[rows], converged[rows] = _intersect(scene, geometry, ax[None, :], ay[rows, None])
    zmax = float(z[converged].max()) + 0.5 if converged.any() else 0.0
    # a scene offering ``shadowed`` (the acceptance artefacts) casts its shadows in closed form
    exact = hasattr(scene, "shadowed")
    march = not exact and _shadow_possible(scene, geometry, ax, ay, z, converged, zmax)

    names = ("height_mm", "u", "v", "reflectivity", "shading", "specular", "x_mm", "y_mm")
    out: dict[str, NDArray[Any]] = {k: np.empty((h, w)) for k in names}
    out["height_mm"] = z
    out["valid"] = np.empty((h, w), dtype=bool)
    for rows in blocks:
        part = _shade(
            scene,
            geometry,
            projector,
            ax[None, :],
            ay[rows, None],
            z[rows],
            converged[rows],
            zmax if march else None,
        )
        for k, a in part.items():
            out[k][rows] = a
    for a in out.values():
        a.setflags(write=False)
    return GroundTruth(**out)


def _intersect(
    scene: Scene, geometry: RigGeometry, ax: NDArray[np.float64], ay: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Heights where the rays ``X = ax (zc - z), Y = ay (zc - z)`` meet ``z = h(X, Y)``.

    Fixed-point iteration ``z <- h(X(z), Y(z))``: it contracts by ``|grad h| * |a|``, with
    ``|a| < 0.1`` for these near-vertical rays, so it converges in a few steps for any slope
    below about 10. A scene that offers ``ray_heights(ax, ay, standoff_mm)`` (the acceptance
    artefacts, whose floating solids are no such heightfield) answers in closed form instead.
    """
    exact = getattr(scene, "ray_heights", None)
    if exact is not None:
        z, hit = exact(ax, ay, geometry.standoff_mm)
        return np.asarray(z, dtype=np.float64), np.asarray(hit, dtype=bool)
    zc = geometry.standoff_mm
    ax, ay = np.broadcast_arrays(ax, ay)
    axf, ayf = ax.reshape(-1), ay.reshape(-1)
    zf = scene.height(axf * zc, ayf * zc)
    converged = np.zeros(zf.size, dtype=bool)
    active = np.arange(zf.size)
    for _ in range(200):
        t = zc - zf[active]
        znew = scene.height(axf[active] * t, ayf[active] * t)
        done = np.abs(znew - zf[active]) <= 1e-10 * (1.0 + np.abs(znew))
        zf[active] = znew
        converged[active[done]] = True
        active = active[~done]
        if active.size == 0:
            break
    return zf.reshape(ax.shape), converged.reshape(ax.shape)


def _shadow_possible(
    scene: Scene,
    geometry: RigGeometry,
    ax: NDArray[np.float64],
    ay: NDArray[np.float64],
    z: NDArray[np.float64],
    converged: NDArray[np.bool_],
    zmax: float,
) -> bool:
    """Whether any point can lie in the projector's shadow.

    Flat scenes cannot. Otherwise a segment toward the projector rises by at least
    ``min_rise`` per mm travelled sideways; when every surface slope is well below that, no
    point can shadow another and the march is skipped.
    """
    if scene.is_flat or not converged.any():
        return False
    zc = geometry.standoff_mm
    x = ax[None, :] * (zc - z)
    y = ay[:, None] * (zc - z)
    gx, gy = scene.gradient(x, y)
    max_slope = float(np.sqrt(gx * gx + gy * gy)[converged].max())
    pc = geometry.projector_center
    low = converged & (z < zmax - 1e-9)
    if not low.any():
        return False
    horiz = np.hypot(pc[0] - x[low], pc[1] - y[low])
    min_rise = float(np.min((pc[2] - z[low]) / np.maximum(horiz, 1e-9)))
    return max_slope >= 0.8 * min_rise


def _dot(a: tuple[NDArray, ...], b: tuple[NDArray, ...]) -> NDArray[np.float64]:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _unit(a: tuple[NDArray, ...]) -> tuple[tuple[NDArray, ...], NDArray[np.float64]]:
    norm = np.sqrt(_dot(a, a))
    return (a[0] / norm, a[1] / norm, a[2] / norm), norm


def _shade(
    scene: Scene,
    geometry: RigGeometry,
    projector: ProjectorModel,
    ax: NDArray[np.float64],
    ay: NDArray[np.float64],
    z: NDArray[np.float64],
    converged: NDArray[np.bool_],
    shadow_zmax: float | None,
) -> dict[str, NDArray[Any]]:
    """Projector coordinates, shading, specular gain and validity of traced surface points."""
    zc = geometry.standoff_mm
    x = ax * (zc - z)
    y = ay * (zc - z)
    gx, gy = scene.gradient(x, y)
    n, _ = _unit((-gx, -gy, np.ones_like(gx)))

    pc = geometry.projector_center
    lvec, dist = _unit((pc[0] - x, pc[1] - y, pc[2] - z))
    cvec, _ = _unit((-x, -y, zc - z))
    cos_i = _dot(n, lvec)
    cos_v = _dot(n, cvec)

    rel = (x - pc[0], y - pc[1], z - pc[2])
    axes = geometry.projector_axes
    xp, yp, zp = (_dot(tuple(axes[k]), rel) for k in range(3))
    fp = geometry.projector_focal_px(projector.width)
    safe = np.where(zp > 0, zp, 1.0)
    u = (projector.width - 1) / 2.0 + fp * xp / safe
    v = (projector.height - 1) / 2.0 + fp * yp / safe

    lit = converged & (zp > 0) & (cos_i > 0) & (cos_v > 0)
    exact = getattr(scene, "shadowed", None)
    if exact is not None:
        lit &= ~np.asarray(exact(x, y, z, pc), dtype=bool)
    elif shadow_zmax is not None:
        lit &= ~_projector_shadow(scene, np.stack([x, y, z]), pc, lit, shadow_zmax)
    inside = (u >= -0.5) & (u <= projector.width - 0.5)
    inside &= (v >= -0.5) & (v <= projector.height - 0.5)

    if geometry.lambertian_shading:
        d0 = geometry.projector_distance
        shading = cos_i / math.cos(geometry.angle_rad) * (d0 / dist) ** 2
    else:
        shading = np.ones_like(cos_i)

    if scene.specular > 0:
        half, _ = _unit((lvec[0] + cvec[0], lvec[1] + cvec[1], lvec[2] + cvec[2]))
        ndh = np.clip(_dot(n, half), 0.0, 1.0)
        spec = scene.specular_strength(x, y) * ndh**scene.shininess
    else:
        spec = np.zeros_like(z)

    return {
        "u": u,
        "v": v,
        "reflectivity": np.broadcast_to(scene.reflectivity(x, y), z.shape),
        "shading": np.where(lit, shading, 0.0),
        "specular": np.where(lit, spec, 0.0),
        "x_mm": x,
        "y_mm": y,
        "valid": lit & inside,
    }


def _projector_shadow(
    scene: Scene,
    q: NDArray[np.float64],
    pc: NDArray[np.float64],
    candidates: NDArray[np.bool_],
    zmax: float,
) -> NDArray[np.bool_]:
    """True where the segment from the surface point to the projector passes under the surface.

    Each segment is marched (about every 0.25 mm sideways) up to height ``zmax``, the highest
    traced point plus a margin.
    """
    shadow = np.zeros(q.shape[1:], dtype=bool)
    z = q[2]
    cand = np.flatnonzero((z < zmax - 1e-9).reshape(-1) & candidates.reshape(-1))
    if cand.size == 0:
        return shadow
    qx, qy, qz = (q[k].reshape(-1)[cand] for k in range(3))
    horiz = np.hypot(pc[0] - qx, pc[1] - qy)
    frac = (zmax - qz) / (pc[2] - qz)  # segment fraction at which the ray reaches zmax
    travel = float(np.max(frac * horiz))
    steps = int(min(400, max(8, math.ceil(travel / 0.25))))
    hit = np.zeros(cand.size, dtype=bool)
    idx = np.arange(cand.size)
    for k in range(1, steps + 1):
        if idx.size == 0:
            break
        s = frac[idx] * (k / steps)
        px = qx[idx] + s * (pc[0] - qx[idx])
        py = qy[idx] + s * (pc[1] - qy[idx])
        pz = qz[idx] + s * (pc[2] - qz[idx])
        blocked = scene.height(px, py) > pz + 1e-6
        hit[idx[blocked]] = True
        idx = idx[~blocked]
    shadow.reshape(-1)[cand] = hit
    return shadow


@dataclass(frozen=True)
class _Radiometry:
    """Per-sample constants of Eq. 3.3 at the (supersampled) camera grid."""

    gain: NDArray[np.float64]  # DN per unit projected light
    offset: NDArray[np.float64]  # ambient DN
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    edge_u: NDArray[np.float64]  # projector-field edge factors (1 inside, blurred edges)
    edge_v: NDArray[np.float64]
    fine_u: _FineLine | None  # samplers of defocused lines (None without defocus)
    fine_v: _FineLine | None


class _FineLine:
    """A projector line sampled ``_FINE`` times per pixel with margins, and a cached linear
    interpolation from it to fixed coordinates (the samples' ``u`` or ``v``)."""

    def __init__(self, n: int, sigma: float, coord: NDArray[np.float64]) -> None:
        self.n = n
        self.sigma = sigma
        pad = math.ceil(5 * sigma) + 1
        size = (n + 2 * pad) * _FINE
        start = 0.5 / _FINE - 0.5 - pad
        self.coords = start + np.arange(size) / _FINE
        pix = np.floor(self.coords + 0.5)
        self.inside = (pix >= 0) & (pix <= n - 1)
        self.pixel = np.clip(pix, 0, n - 1).astype(np.intp)
        pos = (coord - start) * _FINE
        i0 = np.floor(pos)
        outside = (pos < 0) | (pos > size - 1)
        self.i0 = np.clip(i0, 0, size - 2).astype(np.intp)
        self.w1 = np.where(outside, 0.0, pos - self.i0)
        self.w0 = np.where(outside, 0.0, 1.0 - self.w1)

    def sample(self, values: NDArray[np.float64]) -> NDArray[np.float64]:
        """Blur ``values`` (light on the fine line, 0 off the projector) and interpolate."""
        blurred = gaussian_filter1d(values, self.sigma * _FINE, mode="constant", cval=0.0)
        return blurred[self.i0] * self.w0 + blurred[self.i0 + 1] * self.w1


def _box_edge(coord: NDArray[np.float64], n: int, sigma: float) -> NDArray[np.float64]:
    """A box of ones over ``[-0.5, n - 0.5]`` blurred by a Gaussian, sampled at ``coord``."""
    if sigma == 0:
        return ((coord >= -0.5) & (coord <= n - 0.5)).astype(np.float64)
    k = 1.0 / (sigma * math.sqrt(2.0))
    return 0.5 * (erf((coord + 0.5) * k) - erf((coord - (n - 0.5)) * k))


def _exposure(settings: CameraSettings, camera: CameraModel) -> float:
    """Exposure time (ms) of resolved settings; the camera's reference when unset."""
    return float(settings.exposure_ms if settings.exposure_ms is not None else camera.exposure_ms)


def _gain_db(settings: CameraSettings) -> float:
    return float(settings.gain_db) if settings.gain_db is not None else 0.0


def _gain_factor(settings: CameraSettings) -> float:
    """Amplitude factor ``10^(gain_db / 20)`` (exactly 1.0 at 0 dB)."""
    return float(10.0 ** (_gain_db(settings) / 20.0))


def _tap_weights(
    coord: NDArray[np.float64], n: int, sigma: float
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Exact weights of a window of projector pixels around each coordinate along one axis.

    Pixel ``c`` is the box ``[c - 1/2, c + 1/2]`` blurred by a Gaussian of ``sigma`` pixels; its
    weight at ``x`` is ``(erf((x - c + 1/2) k) - erf((x - c - 1/2) k)) / 2`` with
    ``k = 1 / (sigma sqrt 2)``. The window holds ``T = 2 R + 1`` pixels (``R`` reaching
    ``_TAP_REACH`` sigmas), all on the projector: it covers every projector pixel within ``R``
    of the nearest one, so the light left out is below 3e-14 of the total on each side.

    Returns
    -------
    weights : ndarray, shape (m, T)
    start : ndarray of intp, shape (m,)
        First pixel of each window (pixels ``start .. start + T - 1``).
    """
    reach = max(1, math.ceil(_TAP_REACH * sigma))
    taps = min(2 * reach + 1, n)
    nearest = np.floor(coord + 0.5)
    start = np.clip(nearest - reach, 0, n - taps)
    bounds = start[:, None] + (np.arange(taps + 1) - 0.5)[None, :]
    e = erf((coord[:, None] - bounds) / (sigma * math.sqrt(2.0)))
    return 0.5 * (e[:, :-1] - e[:, 1:]), start.astype(np.intp)


class _PixelTaps:
    """The defocus weights (:func:`_tap_weights`) of every block of samples of
    :func:`_sample_pixels` and the first projector row and column of each window, for fixed
    sample coordinates: computed once per rig, not once per frame (they depend on ``u``, ``v``
    and the projector alone; at the loop camera's 162x123 they were a quarter of a 2-D frame's
    sampling). About ``2 (2 ceil(7.5 sigma) + 1) + 2`` numbers per sample (24 at sigma 0.6)."""

    def __init__(
        self, u: NDArray[np.float64], v: NDArray[np.float64], w: int, h: int, sigma: float
    ) -> None:
        uf, vf = u.reshape(-1), v.reshape(-1)
        self.window = (0, 0)  # rows, columns
        self.blocks: list[tuple[slice, NDArray[np.float64], NDArray[np.float64], Any, Any]] = []
        for first in range(0, uf.size, _TAP_CHUNK):
            part = slice(first, first + _TAP_CHUNK)
            wx, col0 = _tap_weights(uf[part], w, sigma)
            wy, row0 = _tap_weights(vf[part], h, sigma)
            self.window = (wy.shape[1], wx.shape[1])
            self.blocks.append((part, wx, wy, row0, col0))


def _sample_pixels(
    light: NDArray[np.float64],
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    sigma: float,
    taps: _PixelTaps | None = None,
) -> NDArray[np.float64]:
    """Light at ``(u, v)`` from a projector image of uniform square pixels, blurred by a Gaussian
    of ``sigma`` pixels (0: sharp), with no light outside the projector. ``taps``: the weights
    for these ``u``, ``v``, ``sigma`` and the image's shape, computed before (the same numbers)."""
    h, w = light.shape
    if sigma == 0:
        inside = (u >= -0.5) & (u <= w - 0.5) & (v >= -0.5) & (v <= h - 0.5)
        col = np.clip(np.floor(u + 0.5), 0, w - 1).astype(np.intp)
        row = np.clip(np.floor(v + 0.5), 0, h - 1).astype(np.intp)
        return np.where(inside, light[row, col], 0.0)
    if taps is None:
        taps = _PixelTaps(u, v, w, h, sigma)
    # every window of the image as a view (no copy): a block's windows are gathered by their
    # first row and column, 2.5x faster than through an index array of every tap
    windows = np.lib.stride_tricks.sliding_window_view(light, taps.window)
    out = np.empty(u.size)
    for part, wx, wy, row0, col0 in taps.blocks:
        patch = windows[row0, col0]  # (m, rows, columns)
        out[part] = (np.matmul(patch, wx[:, :, None])[:, :, 0] * wy).sum(axis=1)
    return out.reshape(u.shape)


def _frame_identity(frame: Frame, settings: dict[str, float] | None = None) -> dict[str, Any]:
    """What seeds a frame's noise: its manifest entry without file names (a 2-D frame's data
    enters through its ``content_sha256``), plus the camera settings when they are not the
    reference ones (so reference captures keep the seeds they always had)."""
    if isinstance(frame, IMAGE_FRAMES):
        # a placeholder side file: the default's name costs a pass over the image (a whole
        # projector image checked for integer levels), for a field dropped here
        entry = frame.manifest_entry("", "")
        entry.pop(frame.DATA_FIELD, None)
    else:
        entry = frame.manifest_entry("")
    entry.pop("file", None)
    if settings is not None:
        entry["camera_settings"] = settings
    return entry


class SimulatedRig(RigBase):
    """A virtual PSFPP rig implementing the :class:`~hdrfringe.rig.base.Rig` protocol.

    Parameters
    ----------
    scene : Scene
        What the rig looks at (see :mod:`hdrfringe.rig.scenes`).
    camera : CameraModel
    projector_model : ProjectorModel
    geometry : RigGeometry
    lighting : Lighting
    gamma_precompensation : float
        Exponent gamma-hat used to pre-compensate the patterns (Eq. 2.17), recorded in
        :attr:`projector`; 1.0: none.
    seed : int
        Non-negative noise seed.
    camera_settings : CameraSettings, optional
        Settings for captures given none; a field left None follows the camera: its reference
        exposure ``camera.exposure_ms`` and 0 dB gain. See :attr:`camera_settings`.

    Examples
    --------
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> from hdrfringe.rig.scenes import white_plate
    >>> rig = SimulatedRig(white_plate(12.0), camera=CameraModel(width=64, height=48))
    >>> rig.capture(FringeSpec(steps=3).frames()).shape
    (3, 48, 64)
    """

    def __init__(
        self,
        scene: Scene,
        camera: CameraModel | None = None,
        projector_model: ProjectorModel | None = None,
        geometry: RigGeometry | None = None,
        lighting: Lighting | None = None,
        gamma_precompensation: float = THESIS_GAMMA,
        seed: int = 0,
        camera_settings: CameraSettings | None = None,
    ) -> None:
        if not isinstance(scene, Scene):
            raise InputError(
                f"scene must be a hdrfringe.rig.scenes.Scene, got {type(scene).__name__}"
            )
        _check_positive("gamma_precompensation", gamma_precompensation)
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise InputError(f"seed must be a non-negative integer, got {seed!r}")
        self.scene = scene
        self.camera = camera if camera is not None else CameraModel()
        self.projector_model = projector_model if projector_model is not None else ProjectorModel()
        self.geometry = geometry if geometry is not None else RigGeometry()
        self.lighting = lighting if lighting is not None else Lighting()
        self.gamma_precompensation = float(gamma_precompensation)
        self.seed = int(seed)
        self._counts: dict[str, int] = {}
        self._truth: GroundTruth | None = None
        self._radiometry: _Radiometry | None = None
        # made at the first 2-D frame: its defocus weights and the light of every input gray
        self._taps: _PixelTaps | None = None
        self._light_table: NDArray[np.float64] | None = None
        self._scene_key = json.dumps(scene.to_manifest(), sort_keys=True)
        self._settings = CameraSettings()
        if camera_settings is not None:
            self.camera_settings = camera_settings

    # --- the Rig protocol -------------------------------------------------------------------
    @property
    def camera_bit_depth(self) -> int:
        """Sensor bit depth B."""
        return self.camera.bit_depth

    @property
    def image_shape(self) -> tuple[int, int]:
        """Camera image (height, width)."""
        return (self.camera.height, self.camera.width)

    @property
    def projector(self) -> ProjectorInfo:
        """Projector input description, with the gamma pre-compensation in use."""
        p = self.projector_model
        return ProjectorInfo(p.width, p.height, p.bit_depth, self.gamma_precompensation)

    @property
    def camera_settings(self) -> CameraSettings:
        """Settings of captures given none: exposure (default the camera's reference exposure
        ``camera.exposure_ms``) and gain (default 0 dB). Assigning a
        :class:`~hdrfringe.core.captures.CameraSettings` changes the fields it gives."""
        s = self._settings
        return CameraSettings(
            exposure_ms=s.exposure_ms if s.exposure_ms is not None else self.camera.exposure_ms,
            gain_db=s.gain_db if s.gain_db is not None else 0.0,
        )

    @camera_settings.setter
    def camera_settings(self, settings: CameraSettings) -> None:
        if not isinstance(settings, CameraSettings):
            raise InputError(
                f"camera settings must be a hdrfringe.core.captures.CameraSettings, got "
                f"{type(settings).__name__}"
            )
        old = self._settings
        self._settings = CameraSettings(
            exposure_ms=(
                settings.exposure_ms if settings.exposure_ms is not None else old.exposure_ms
            ),
            gain_db=settings.gain_db if settings.gain_db is not None else old.gain_db,
        )

    def capture(
        self, frames: Sequence[Frame], settings: CameraSettings | None = None
    ) -> NDArray[np.integer]:
        """Project each frame and return the camera images, shape (n, height, width).

        dtype uint8 for B <= 8, else uint16; values in ``[0, 2^B - 1]``. Each frame's noise
        depends only on the seed, the scene, the frame, the camera settings and how many times
        this rig captured that same frame with those settings before (not on the order or
        grouping of the calls).

        Parameters
        ----------
        frames : sequence of Frame
        settings : CameraSettings, optional
            Exposure time and gain for every frame of the call; a field left None (or
            ``settings`` None) takes :attr:`camera_settings`. The signal scales by
            ``G t / t_ref``, the read noise by ``G`` (module docstring).

        Returns
        -------
        ndarray, shape (n, height, width)
        """
        frames = list(frames)
        cam = self.camera
        settings = self.resolve_settings(settings)
        gain = _gain_factor(settings)
        out = np.empty((len(frames), cam.height, cam.width), dtype=cam.dtype)
        for k, frame in enumerate(frames):
            signal = self._signal(frame, settings)
            out[k] = sensor_readout(signal, cam, self._frame_rng(frame, settings), gain=gain)
        return out

    # --- extras ----------------------------------------------------------------------------
    def expected_signal(
        self, frames: Sequence[Frame], settings: CameraSettings | None = None
    ) -> NDArray[np.float64]:
        """Noise-free camera signal in DN, before quantisation and clipping, (n, H, W).

        Values above ``2^B - 1`` are the true intensities a saturated pixel would have had.

        Parameters
        ----------
        frames : sequence of Frame
        settings : CameraSettings, optional
            As for :meth:`capture`.

        Returns
        -------
        ndarray, shape (n, H, W)
        """
        frames = list(frames)
        settings = self.resolve_settings(settings)
        out = np.empty((len(frames), self.camera.height, self.camera.width))
        for k, frame in enumerate(frames):
            out[k] = self._signal(frame, settings)
        return out

    def capture_folder(self, frames: Sequence[Frame]) -> Captures:
        """Capture ``frames`` into an in-memory :class:`~hdrfringe.core.captures.Captures`, as
        ``simulate`` would write it.

        The captures carry the scene, the camera geometry (``focal_px``, ``standoff_mm``) and
        the ground-truth height map (``truth_height_mm``), so they can be calibrated on or
        measured directly; their ``name`` is the scene's.

        Parameters
        ----------
        frames : sequence of Frame
            What the projector shows, in order.

        Returns
        -------
        Captures
        """
        frames = list(frames)
        return Captures(
            frames,
            self.capture(frames),
            self.camera_bit_depth,
            projector=self.projector,
            scene=self.scene.to_manifest(),
            camera=self.camera_manifest(),
            maps={"truth_height_mm": self.truth().height_mm},
            name=self.scene.name,
        )

    def camera_manifest(self) -> dict[str, float]:
        """The camera a capture manifest records: its geometry (``focal_px``, ``standoff_mm``),
        from which measurements place their points in millimetres, and its true noise model at
        the rig's gain (``read_noise_dn``, ``gain_dn_per_e``; :meth:`CameraModel.noise_manifest`),
        which ``phase`` and ``measure`` predict their std from."""
        g = self.geometry
        return {
            "focal_px": g.camera_focal_px(self.image_shape[1]),
            "standoff_mm": g.standoff_mm,
            **self.camera.noise_manifest(_gain_factor(self.camera_settings)),
        }

    def truth(self) -> GroundTruth:
        """Ground truth per camera pixel, evaluated at the pixel centres (cached, read-only)."""
        if self._truth is None:
            self._truth = _trace(self.scene, self.geometry, self.camera, self.projector_model, 1)
        return self._truth

    def stereo_calibration(self) -> StereoCalibration:
        """The rig's true camera-projector geometry (:meth:`RigGeometry.stereo_calibration`).

        Returns
        -------
        StereoCalibration
            For this rig's camera and projector sizes; no distortion.

        Examples
        --------
        >>> from hdrfringe.rig.scenes import white_plate
        >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=64, height=48))
        >>> rig.stereo_calibration().camera.size, rig.stereo_calibration().projector.size
        ((64, 48), (1024, 768))
        """
        cam, proj = self.camera, self.projector_model
        return self.geometry.stereo_calibration((cam.width, cam.height), (proj.width, proj.height))

    def reset_noise(self) -> None:
        """Forget how often each frame was captured: the next captures repeat the first ones."""
        self._counts.clear()

    def replace(self, **changes: Any) -> SimulatedRig:
        """A new rig with some constructor arguments changed (e.g. ``scene=white_plate(4)``)."""
        args: dict[str, Any] = {
            "scene": self.scene,
            "camera": self.camera,
            "projector_model": self.projector_model,
            "geometry": self.geometry,
            "lighting": self.lighting,
            "gamma_precompensation": self.gamma_precompensation,
            "seed": self.seed,
            "camera_settings": self._settings,
        }
        unknown = set(changes) - set(args)
        if unknown:
            raise InputError(
                f"unknown SimulatedRig argument(s) {sorted(unknown)}; use {', '.join(args)}"
            )
        args.update(changes)
        return SimulatedRig(**args)

    @classmethod
    def ideal(cls, scene: Scene, **changes: Any) -> SimulatedRig:
        """A rig for exact round trips: no noise, no blur, 16-bit camera and projector.

        Continuous projector model, gamma pre-compensation equal to the true gamma, camera
        B = 16, supersample 1; ``changes`` override any constructor argument. With it, the
        N-step phase equals ``2*pi*u/p`` to about 1e-5 rad. Gray levels of the frames are then
        16-bit projector units (full white 65535).
        """
        camera = CameraModel(bit_depth=16, read_noise_dn8=0.0, full_well_e=None, blur_px=0.0)
        projector = ProjectorModel(bit_depth=16, defocus_px=0.0, model="continuous")
        args: dict[str, Any] = {
            "camera": camera,
            "projector_model": projector,
            "gamma_precompensation": projector.gamma,
        }
        args.update(changes)
        return cls(scene, **args)

    def to_manifest(self) -> dict[str, Any]:
        """Every simulation parameter, JSON-friendly (for provenance in capture folders)."""
        return {
            "camera": dataclasses.asdict(self.camera),
            "projector_model": dataclasses.asdict(self.projector_model),
            "geometry": dataclasses.asdict(self.geometry),
            "lighting": dataclasses.asdict(self.lighting),
            "gamma_precompensation": self.gamma_precompensation,
            "seed": self.seed,
        }

    def __repr__(self) -> str:
        return (
            f"SimulatedRig(scene={self.scene!r}, camera={self.camera!r}, "
            f"projector_model={self.projector_model!r}, geometry={self.geometry!r}, "
            f"lighting={self.lighting!r}, gamma_precompensation={self.gamma_precompensation!r}, "
            f"seed={self.seed!r})"
        )

    # --- internals -------------------------------------------------------------------------
    def _frame_rng(self, frame: Frame, settings: CameraSettings) -> np.random.Generator:
        reference = CameraSettings(self.camera.exposure_ms, 0.0)
        tag = None
        if settings != reference:
            tag = {"exposure_ms": _exposure(settings, self.camera), "gain_db": _gain_db(settings)}
        ident = json.dumps(_frame_identity(frame, tag), sort_keys=True)
        count = self._counts.get(ident, 0)
        self._counts[ident] = count + 1
        digest = hashlib.sha256(f"{self._scene_key}|{ident}".encode()).digest()
        words = [int.from_bytes(digest[i : i + 4], "little") for i in range(0, 32, 4)]
        sequence = np.random.SeedSequence([self.seed, *words, count])
        return np.random.Generator(np.random.PCG64(sequence))

    def _get_radiometry(self) -> _Radiometry:
        if self._radiometry is not None:
            return self._radiometry
        cam, proj, light = self.camera, self.projector_model, self.lighting
        sub = cam.supersample
        geo = self.truth() if sub == 1 else _trace(self.scene, self.geometry, cam, proj, sub)
        alpha = cam.white_dn
        scale8 = cam.full_scale / 255.0 * cam.white_level / REFERENCE_WHITE_LEVEL
        a1 = light.ambient_lux * light.dn_per_lux * scale8
        a2 = light.direct_ambient_lux * light.direct_dn_per_lux * scale8
        gain = alpha * geo.shading * (geo.reflectivity + geo.specular)
        offset = geo.reflectivity * a1 + a2
        if cam.vignetting > 0:
            lens = cam.vignetting_map(sub)
            gain, offset = gain * lens, offset * lens
        sigma = proj.defocus_px
        self._radiometry = _Radiometry(
            gain=gain,
            offset=np.broadcast_to(offset, gain.shape).copy(),
            u=geo.u,
            v=geo.v,
            edge_u=_box_edge(geo.u, proj.width, sigma),
            edge_v=_box_edge(geo.v, proj.height, sigma),
            fine_u=_FineLine(proj.width, sigma, geo.u) if sigma > 0 else None,
            fine_v=_FineLine(proj.height, sigma, geo.v) if sigma > 0 else None,
        )
        return self._radiometry

    def _line_light(self, frame: Frame, n: int) -> NDArray[np.float64]:
        """Projected light of each projector pixel along the frame's varying axis."""
        proj = self.projector_model
        vertical = frame_axis(frame) == "vertical"
        # the pattern only varies along its axis: render one line, not the whole frame
        w, h = (proj.width, 1) if vertical else (1, proj.height)
        img = render_frame(frame, w, h, self.gamma_precompensation, proj.bit_depth)
        line = img[0, :] if vertical else img[:, 0]
        assert line.size == n
        return proj.light(line)

    def _sample_line(
        self, values: NDArray[np.float64], vertical: bool, rad: _Radiometry
    ) -> NDArray[np.float64]:
        """Light reaching each sample from projector-pixel light ``values`` along one axis
        (pixelated model: each projector pixel is a uniform square, blurred by defocus)."""
        proj = self.projector_model
        coord, n = (rad.u, proj.width) if vertical else (rad.v, proj.height)
        across = rad.edge_v if vertical else rad.edge_u
        if proj.defocus_px == 0:
            inside = (coord >= -0.5) & (coord <= n - 0.5)
            idx = np.clip(np.floor(coord + 0.5), 0, n - 1).astype(np.intp)
            return np.where(inside, values[idx], 0.0) * across
        line = rad.fine_u if vertical else rad.fine_v
        assert line is not None
        return line.sample(np.where(line.inside, values[line.pixel], 0.0)) * across

    def _integrate(self, signal: NDArray[np.float64]) -> NDArray[np.float64]:
        """Pixel integration (supersampling) and camera blur of a signal at the sample grid."""
        cam = self.camera
        s = cam.supersample
        if s > 1:
            signal = signal.reshape(cam.height, s, cam.width, s).mean(axis=(1, 3))
        if cam.blur_px > 0:
            signal = gaussian_filter(signal, cam.blur_px, mode="nearest")
        return signal

    def ambient_signal(self) -> NDArray[np.float64]:
        """Noise-free signal (DN) from ambient light alone: the ``a1``, ``a2`` terms of Eq. 3.3
        after pixel integration and camera blur. ``expected_signal`` minus this is linear in the
        projected light."""
        return self._integrate(self._get_radiometry().offset.copy())

    def periodic_basis(self, period: int, orientation: str = "vertical") -> NDArray[np.float64]:
        """Response images for patterns that repeat every ``period`` projector pixels.

        Image ``j`` is the noise-free signal (DN, ambient excluded) when the projector emits
        unit light (full white) from the columns (``"vertical"`` fringes) or rows
        (``"horizontal"``) whose index is ``j`` modulo ``period`` and no light elsewhere;
        defocus, field edges, pixel integration and camera blur included. Every step from
        projected light to signal is linear, so a frame whose light repeats every ``period``
        pixels has the signal ``ambient_signal() + sum_j light[j] * basis[j]`` with ``light``
        from :meth:`periodic_light`: a MIGL sweep then costs one weighted sum per frame instead
        of a full simulation (the sweeps of ``hdrfringe reproduce``). Pixelated projector only.

        Returns
        -------
        ndarray, shape (period, H, W)
        """
        if self.projector_model.model != "pixelated":
            raise InputError("periodic_basis needs the pixelated projector model")
        if orientation not in ("vertical", "horizontal"):
            raise InputError(f"orientation must be vertical or horizontal, got {orientation!r}")
        if isinstance(period, bool) or not isinstance(period, (int, np.integer)) or period < 1:
            raise InputError(f"period must be a positive whole number of pixels, got {period!r}")
        rad = self._get_radiometry()
        vertical = orientation == "vertical"
        n = self.projector_model.width if vertical else self.projector_model.height
        residue = np.arange(n) % period
        out = np.empty((period, self.camera.height, self.camera.width))
        for j in range(period):
            comb = (residue == j).astype(np.float64)
            out[j] = self._integrate(rad.gain * self._sample_line(comb, vertical, rad))
        return out

    def periodic_light(self, frame: Frame, period: int) -> NDArray[np.float64]:
        """Projected light of one period of ``frame`` (see :meth:`periodic_basis`), shape
        ``(period,)``; refuses a frame whose light does not repeat every ``period`` pixels."""
        vertical = frame_axis(frame) == "vertical"
        n = self.projector_model.width if vertical else self.projector_model.height
        line = self._line_light(frame, n)
        light = line[:period]
        if not np.array_equal(np.resize(light, n), line):
            raise InputError(
                f"the frame's projected light does not repeat every {period} projector pixels "
                "(use a whole-pixel pitch, or expected_signal)"
            )
        return light

    def _continuous_light(
        self, frame: LineFrame, coord: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        proj = self.projector_model
        sent = precompensate_gamma(frame.gray(coord), self.gamma_precompensation, proj.bit_depth)
        return proj.light(sent)

    def _light(self, frame: Frame, rad: _Radiometry) -> NDArray[np.float64]:
        """Projected light reaching each sample: pattern along its axis times field edges
        (line frames), or the projector image at ``(u, v)`` (frames varying along both axes)."""
        proj = self.projector_model
        if isinstance(frame, IMAGE_FRAMES):
            return self._image_light(frame, rad)
        if not isinstance(frame, LINE_FRAMES):
            raise InputError(
                f"cannot project a {type(frame).__name__}; use a frame of hdrfringe.core.frames "
                "(FringeFrame, CenterlineFrame, UniformFrame, PixelwiseFringeFrame, ImageFrame)"
            )
        if isinstance(frame, FringeFrame) and frame.spec.migl > proj.full_scale:
            raise InputError(
                f"migl {frame.spec.migl:g} exceeds the projector's maximum {proj.full_scale} at "
                f"{proj.bit_depth} bits; lower migl or raise the projector bit depth"
            )
        vertical = frame_axis(frame) == "vertical"
        n = proj.width if vertical else proj.height
        if proj.model == "pixelated":
            return self._sample_line(self._line_light(frame, n), vertical, rad)
        coord = rad.u if vertical else rad.v
        across = rad.edge_v if vertical else rad.edge_u
        if proj.defocus_px == 0:
            inside = (coord >= -0.5) & (coord <= n - 0.5)
            return np.where(inside, self._continuous_light(frame, coord), 0.0) * across
        # Defocus: blur the light of the whole line on a fine grid, then interpolate.
        line = rad.fine_u if vertical else rad.fine_v
        assert line is not None
        values = np.where(line.inside, self._continuous_light(frame, line.coords), 0.0)
        return line.sample(values) * across

    def _image_light(
        self, frame: PixelwiseFringeFrame | ImageFrame, rad: _Radiometry
    ) -> NDArray[np.float64]:
        """Projected light reaching each sample from a full projector image (any frame).

        Pixelated model: each projector pixel is a uniform square of light; with defocus the
        light at ``(u, v)`` is ``sum_rc L[r, c] w_c(u) w_r(v)`` with the exact box*Gaussian
        weights of :func:`_tap_weights`. Continuous model: the frame's gray at ``(u, v)``
        (:meth:`gray_at`: analytic fringes, bilinear per-pixel data), pre-compensated, rounded
        and turned into light, without defocus.
        """
        proj = self.projector_model
        w, h = proj.width, proj.height
        u, v = rad.u, rad.v
        if proj.model == "pixelated":
            img = frame.render(w, h, self.gamma_precompensation, proj.bit_depth)
            if self._light_table is None:  # the light of every input gray, once per rig
                self._light_table = proj.light(np.arange(proj.full_scale + 1))
            if proj.defocus_px > 0 and self._taps is None:
                self._taps = _PixelTaps(u, v, w, h, proj.defocus_px)
            # img: the integer grays 0..2^Bp - 1 sent (precompensate_gamma); the table holds
            # proj.light of each, the same numbers as proj.light(img) at a third of its cost
            return _sample_pixels(self._light_table[img], u, v, proj.defocus_px, self._taps)
        frame.check_projector(w, h, proj.bit_depth)
        if proj.defocus_px > 0:
            # The continuous light is a staircase (rounding at Bp bits) over two axes: blurring
            # it needs a fine 2-D grid (too large) or a quadrature (about 0.4 % off, 6 s/frame).
            raise InputError(
                f"the continuous projector model with defocus renders line frames only, not a "
                f"{type(frame).__name__}; use model='pixelated' (exact defocus) or defocus_px=0"
            )
        inside = (u >= -0.5) & (u <= w - 0.5) & (v >= -0.5) & (v <= h - 0.5)
        return np.where(inside, self._continuous_light_at(frame, u, v), 0.0)

    def _continuous_light_at(
        self, frame: Frame, u: NDArray[np.float64], v: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        proj = self.projector_model
        gray = frame.gray_at(u, v)
        return proj.light(precompensate_gamma(gray, self.gamma_precompensation, proj.bit_depth))

    def _signal(self, frame: Frame, settings: CameraSettings | None = None) -> NDArray[np.float64]:
        """Noise-free signal (DN) of one frame: Eq. 3.3, pixel integration, camera blur, then
        exposure and gain (``settings`` resolved; None: the reference, a factor of exactly 1)."""
        rad = self._get_radiometry()
        signal = self._integrate(rad.gain * self._light(frame, rad) + rad.offset)
        if settings is not None:
            factor = _exposure(settings, self.camera) / self.camera.exposure_ms
            factor *= _gain_factor(settings)
            if factor != 1.0:
                signal *= factor
        return signal


def simulate_frames(rig: SimulatedRig, frames: Sequence[Frame]) -> NDArray[np.integer]:
    """Capture ``frames`` with ``rig`` (the same as ``rig.capture(frames)``).

    Parameters
    ----------
    rig : SimulatedRig
        The virtual rig, at its own camera settings.
    frames : sequence of Frame
        What the projector shows, in order.

    Returns
    -------
    ndarray, shape (n, height, width)
        uint8 for B <= 8, else uint16; values in ``[0, 2^B - 1]``.

    References
    ----------
    Thesis Eq. 3.3 (the signal), then the sensor readout (Sec. 3.1: clipping at ``2^B - 1``).

    Examples
    --------
    >>> from hdrfringe.core.frames import UniformFrame
    >>> from hdrfringe.rig.scenes import white_plate
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=8, height=6))
    >>> imgs = simulate_frames(rig, [UniformFrame(0.0), UniformFrame(255.0)])
    >>> imgs.shape, imgs.dtype.name, bool(imgs[1].mean() > imgs[0].mean())
    ((2, 6, 8), 'uint8', True)
    """
    return rig.capture(frames)
