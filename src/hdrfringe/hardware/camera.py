"""The camera protocol every camera back end follows, and its errors.

A camera here is a monochrome machine-vision or UVC camera seen through one small protocol
(:class:`Camera`): open and close it (or use it as a context manager), set exposure, gain,
pixel format and trigger mode, and grab one image with a timeout. An image is a 2-D numpy
array, uint8 for an 8-bit pixel format and uint16 for 10, 12 and 16 bit, whose values lie in
``0 .. 2^B - 1`` (B: :attr:`Camera.bit_depth`), the convention the rest of hdrfringe reads
(a pixel is saturated at ``2^B - 1``).

Back ends (each imports its package only when a camera is opened, so the hardware packages
stay optional: ``pip install hdrfringe[hardware]``):

- ``pylon:SERIAL`` / ``pylon:emu``: Basler cameras through pypylon
  (:class:`hdrfringe.hardware.pylon.PylonCamera`);
- ``opencv:0`` / ``opencv:/dev/video0``: UVC cameras through OpenCV's VideoCapture
  (:class:`hdrfringe.hardware.opencv_camera.OpenCVCamera`);
- ``genicam:CTI_PATH[:SERIAL]``: any GenICam camera through a GenTL producer and harvesters
  (:class:`hdrfringe.hardware.genicam.GenICamCamera`).

:func:`hdrfringe.hardware.backends.open_camera` parses such a specification (it lives in its own
module because it imports the back ends, which import this one); docs/hardware.md describes the
back ends and what is tested.
"""

from __future__ import annotations

import importlib
import math
from types import ModuleType, TracebackType
from typing import Protocol, Self, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.captures import CameraSettings
from hdrfringe.errors import HdrFringeError, InputError

__all__ = [
    "HARDWARE_EXTRA",
    "MONO_FORMATS",
    "TRIGGER_MODES",
    "Camera",
    "CameraBase",
    "CameraError",
    "CameraNotFoundError",
    "GrabTimeoutError",
    "MissingPackageError",
    "PixelFormatError",
    "import_optional",
]

#: The pixel formats hdrfringe reads (GenICam SFNC names) and their bit depth B (thesis 7.4:
#: 8, 10, 12 and 16 bit sensors); unpacked, one pixel per uint8 or uint16.
MONO_FORMATS: dict[str, int] = {"Mono8": 8, "Mono10": 10, "Mono12": 12, "Mono16": 16}

#: ``software``: each :meth:`Camera.grab` takes a new image on the program's request (a software
#: trigger where the camera has one, else the next frame of a free-running stream);
#: ``hardware``: the camera exposes on an edge at its trigger input line.
TRIGGER_MODES: tuple[str, ...] = ("software", "hardware")

#: What to install for the camera and projector back ends.
HARDWARE_EXTRA = "pip install hdrfringe[hardware]"


class CameraError(HdrFringeError):
    """A camera cannot do what was asked (a feature it lacks, a device error).

    Examples
    --------
    >>> isinstance(CameraError("camera opencv:0: no gain in dB"), HdrFringeError)
    True
    """


class CameraNotFoundError(CameraError):
    """No camera answers to the given specification.

    Examples
    --------
    >>> str(CameraNotFoundError("no Basler camera with serial 123; connected: none"))
    'no Basler camera with serial 123; connected: none'
    """


class GrabTimeoutError(CameraError):
    """No image arrived within the grab's timeout.

    Examples
    --------
    >>> issubclass(GrabTimeoutError, CameraError)
    True
    """


class PixelFormatError(CameraError, InputError):
    """A pixel format that hdrfringe cannot read or the camera does not offer.

    Examples
    --------
    >>> issubclass(PixelFormatError, InputError)
    True
    """


class MissingPackageError(HdrFringeError, ImportError):
    """An optional package that a hardware back end needs is not installed.

    Examples
    --------
    >>> err = MissingPackageError("pypylon is not installed; pip install hdrfringe[hardware]")
    >>> isinstance(err, ImportError)
    True
    """


def import_optional(module: str, purpose: str) -> ModuleType:
    """Import an optional hardware package or say which extra installs it.

    Parameters
    ----------
    module : str
        Module to import, e.g. ``"pypylon.pylon"``.
    purpose : str
        What needs it, for the message (e.g. ``"Basler cameras"``).

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    MissingPackageError
        When it cannot be imported; the message names the extra to install.

    Examples
    --------
    >>> import_optional("math", "arithmetic").sqrt(4.0)
    2.0
    >>> import_optional("no_such_pkg_x", "testing")
    Traceback (most recent call last):
    ...
    hdrfringe.hardware.camera.MissingPackageError: testing need ... pip install hdrfringe[hardware]
    """
    try:
        return importlib.import_module(module)
    except ImportError as err:
        top = module.split(".")[0]
        raise MissingPackageError(
            f"{purpose} need the package {top}, which is not installed; install it with: "
            f"{HARDWARE_EXTRA}"
        ) from err


# A protocol has no constructor: numpydoc reads the (*args, **kwargs) of typing.Protocol as one.
@runtime_checkable
class Camera(Protocol):  # numpydoc ignore=PR01
    """A camera that hdrfringe can configure and grab from.

    A structural type: a back end need not inherit from it (all of hdrfringe's inherit the
    housekeeping from :class:`CameraBase`). Set-up calls return the value the camera applied
    (cameras round exposure and gain to their own steps).

    Attributes
    ----------
    name : str
        The specification it was opened with (``pylon:emu``, ``opencv:0``, ...), for messages.
    pixel_format : str
        Current pixel format, one of :data:`MONO_FORMATS`.
    bit_depth : int
        B of the current pixel format; grabbed values lie in ``0 .. 2^B - 1``.
    pixel_formats : tuple of str
        The formats of :data:`MONO_FORMATS` that this camera offers.
    trigger_mode : str
        One of :data:`TRIGGER_MODES`.

    References
    ----------
    Thesis Sec. 7.4 (camera bit depth); Sec. 3.4.3 (the camera of the measurement system).

    Examples
    --------
    >>> from hdrfringe.hardware.pylon import PylonCamera
    >>> with PylonCamera("emu") as cam:
    ...     isinstance(cam, Camera), cam.pixel_format, cam.grab(timeout_s=2.0).dtype
    (True, 'Mono8', dtype('uint8'))
    """

    name: str

    @property
    def pixel_format(self) -> str:
        """Current pixel format."""
        ...

    @property
    def bit_depth(self) -> int:
        """B of the current pixel format."""
        ...

    @property
    def pixel_formats(self) -> tuple[str, ...]:
        """The usable pixel formats this camera offers."""
        ...

    @property
    def trigger_mode(self) -> str:
        """``software`` or ``hardware``."""
        ...

    def open(self) -> None:
        """Connect to the camera; it is usable after this."""
        ...

    def close(self) -> None:
        """Release the camera; closing twice is harmless."""
        ...

    def __enter__(self) -> Self: ...

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None: ...

    def set_exposure(self, ms: float) -> float:
        """Set the exposure time in milliseconds; returns the value applied."""
        ...

    def set_gain(self, db: float) -> float:
        """Set the analogue gain in dB; returns the value applied."""
        ...

    def set_pixel_format(self, pixel_format: str) -> None:
        """Select one of :attr:`pixel_formats`."""
        ...

    def set_trigger_mode(self, mode: str) -> None:
        """Select ``software`` or ``hardware`` triggering."""
        ...

    def grab(self, timeout_s: float = 1.0) -> NDArray[np.integer]:
        """One image, (height, width), uint8 or uint16 with values in ``0 .. 2^B - 1``."""
        ...


class CameraBase:
    """Housekeeping shared by the camera back ends.

    Context-manager use (``with cam:`` opens and closes, also after an error), the pixel-format
    and trigger-mode checks with their one-line errors, :meth:`apply` for a
    :class:`~hdrfringe.core.captures.CameraSettings`, and the dtype of grabbed images. A back end
    sets :attr:`name`, implements ``open``, ``close``, ``set_exposure``, ``set_gain``,
    ``_offered_formats``, ``_apply_pixel_format``, ``_apply_trigger_mode``, ``_grab`` and
    ``_current_format``.

    Examples
    --------
    >>> class Fake(CameraBase):
    ...     name = "fake"
    ...     def _offered_formats(self): return ("Mono8", "Mono12", "RGB8")
    ...     def _current_format(self): return "Mono12"
    ...     def _grab(self, timeout_s): return np.full((2, 2), 4095)
    >>> cam = Fake()
    >>> cam.pixel_formats, cam.bit_depth, cam.grab().dtype
    (('Mono8', 'Mono12'), 12, dtype('uint16'))
    """

    name: str = "camera"
    _trigger_mode: str = "software"

    # -- context manager -------------------------------------------------------------------
    def open(self) -> None:
        """Connect to the camera (nothing by default)."""

    def close(self) -> None:
        """Release the camera (nothing by default)."""

    def __enter__(self) -> Self:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- pixel format ----------------------------------------------------------------------
    def _offered_formats(self) -> tuple[str, ...]:
        return ("Mono8",)

    def _current_format(self) -> str:
        return "Mono8"

    def _apply_pixel_format(self, pixel_format: str) -> None:
        """Set an offered, supported format on the device (nothing by default)."""

    @property
    def pixel_formats(self) -> tuple[str, ...]:
        """The formats of :data:`MONO_FORMATS` that this camera offers, in that order."""
        offered = set(self._offered_formats())
        return tuple(f for f in MONO_FORMATS if f in offered)

    @property
    def pixel_format(self) -> str:
        """Current pixel format."""
        return self._current_format()

    @property
    def bit_depth(self) -> int:
        """B of the current pixel format (thesis 7.4)."""
        fmt = self.pixel_format
        if fmt not in MONO_FORMATS:
            raise PixelFormatError(
                f"camera {self.name}: current pixel format {fmt!r} is not one hdrfringe reads; "
                f"call set_pixel_format with one of {', '.join(self.pixel_formats) or 'none'}"
            )
        return MONO_FORMATS[fmt]

    def set_pixel_format(self, pixel_format: str) -> None:
        """Select a pixel format that hdrfringe reads and the camera offers.

        Parameters
        ----------
        pixel_format : str
            E.g. ``"Mono12"``.

        Raises
        ------
        PixelFormatError
            When it is not among :attr:`pixel_formats`; the message names them.
        """
        usable = self.pixel_formats
        if pixel_format not in usable:
            raise PixelFormatError(
                f"camera {self.name}: pixel format {pixel_format!r} is not available; "
                f"use one of {', '.join(usable) or 'none'} (the mono formats this camera offers)"
            )
        self._apply_pixel_format(pixel_format)

    # -- trigger ---------------------------------------------------------------------------
    def _supported_triggers(self) -> tuple[str, ...]:
        return ("software",)

    def _apply_trigger_mode(self, mode: str) -> None:
        """Configure the device for the mode (nothing by default)."""

    @property
    def trigger_mode(self) -> str:
        """``software`` or ``hardware`` (see :data:`TRIGGER_MODES`)."""
        return self._trigger_mode

    def set_trigger_mode(self, mode: str) -> None:
        """Select software or hardware triggering.

        Parameters
        ----------
        mode : str
            One of :data:`TRIGGER_MODES` that this camera supports.

        Raises
        ------
        CameraError
            When the camera does not support it.
        """
        supported = self._supported_triggers()
        if mode not in supported:
            raise CameraError(
                f"camera {self.name}: trigger mode {mode!r} is not supported; "
                f"use {' or '.join(supported)}"
            )
        self._apply_trigger_mode(mode)
        self._trigger_mode = mode

    # -- exposure and gain -----------------------------------------------------------------
    def set_exposure(self, ms: float) -> float:
        """Set the exposure time.

        Parameters
        ----------
        ms : float
            Exposure time in milliseconds.

        Returns
        -------
        float
            The exposure time applied, in milliseconds.
        """
        raise CameraError(f"camera {self.name}: exposure cannot be set")

    def set_gain(self, db: float) -> float:
        """Set the analogue gain.

        Parameters
        ----------
        db : float
            Gain in dB.

        Returns
        -------
        float
            The gain applied, in dB.
        """
        raise CameraError(f"camera {self.name}: gain cannot be set in dB")

    def apply(self, settings: CameraSettings) -> CameraSettings:
        """Apply the fields of a capture's camera settings that are given.

        Parameters
        ----------
        settings : CameraSettings
            A field left None leaves the camera's current setting.

        Returns
        -------
        CameraSettings
            The values the camera applied (None where the field was not given).
        """
        exposure = None if settings.exposure_ms is None else self.set_exposure(settings.exposure_ms)
        gain = None if settings.gain_db is None else self.set_gain(settings.gain_db)
        return CameraSettings(exposure_ms=exposure, gain_db=gain)

    def _not_open(self) -> CameraError:
        return CameraError(f"camera {self.name}: not open; use it in a with block or call open()")

    # -- grabbing --------------------------------------------------------------------------
    def _grab(self, timeout_s: float) -> NDArray[np.generic]:
        raise NotImplementedError

    def grab(self, timeout_s: float = 1.0) -> NDArray[np.integer]:
        """Grab one image.

        Parameters
        ----------
        timeout_s : float, default 1.0
            Seconds to wait for the image.

        Returns
        -------
        ndarray, shape (height, width)
            uint8 for an 8-bit format, uint16 otherwise; values in ``0 .. 2^B - 1``.

        Raises
        ------
        GrabTimeoutError
            When no image arrives in time.
        """
        if not (math.isfinite(timeout_s) and timeout_s > 0):
            raise InputError(f"grab timeout must be a positive number of seconds, got {timeout_s}")
        image = np.asarray(self._grab(timeout_s))
        dtype = np.uint8 if self.bit_depth <= 8 else np.uint16
        return image.astype(dtype, copy=False)


def _check_positive(what: str, value: float, camera: str) -> None:
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"camera {camera}: {what} must be a positive number, got {value}")
