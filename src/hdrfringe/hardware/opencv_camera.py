"""UVC cameras (webcams) through OpenCV's VideoCapture (``opencv:0``, ``opencv:/dev/video0``).

OpenCV delivers 8-bit colour frames from a UVC camera; this back end converts them to gray
(``cv2.cvtColor``, BGR to gray) and offers the one pixel format ``Mono8``. A UVC camera
streams freely: the only trigger mode is ``software`` (each grab returns the next frame the
driver delivers; discarding stale frames is the synchronisation layer's job) and there is no
hardware trigger.

Exposure goes through ``CAP_PROP_EXPOSURE`` after switching auto exposure off
(``CAP_PROP_AUTO_EXPOSURE``); its unit is the driver's: on Linux's V4L2 it is 100 us, the
convention used here. Gain has no unit in UVC and cannot be set in dB here. A driver that
refuses a setting raises a one-line :class:`~hdrfringe.hardware.camera.CameraError`.

The same back end opens a video file (``opencv:clip.avi``) through OpenCV's FFmpeg reader:
that is how its grab path is tested without a device (docs/hardware.md).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.hardware.camera import (
    CameraBase,
    CameraError,
    CameraNotFoundError,
    GrabTimeoutError,
    _check_positive,
    import_optional,
)

__all__ = ["V4L2_EXPOSURE_UNIT_MS", "OpenCVCamera"]

#: V4L2's ``exposure_time_absolute`` unit (100 us), in milliseconds.
V4L2_EXPOSURE_UNIT_MS = 0.1


class OpenCVCamera(CameraBase):
    """A UVC camera, a V4L2 device path or a video file through ``cv2.VideoCapture``.

    Parameters
    ----------
    device : str or int
        A device index (``0`` or ``"0"``), a device path (``/dev/video0``) or a video file.

    Examples
    --------
    >>> cam = OpenCVCamera("7")
    >>> cam.name, cam.pixel_formats
    ('opencv:7', ('Mono8',))
    """

    def __init__(self, device: str | int) -> None:
        text = str(device)
        self.device: str | int = int(text) if text.isdigit() else text
        self.name = f"opencv:{text}"
        self._capture: Any = None

    def open(self) -> None:
        """Open the device or file.

        Raises
        ------
        CameraNotFoundError
            When OpenCV cannot open it.
        """
        if self._capture is not None:
            return
        cv2 = import_optional("cv2", "OpenCV cameras (opencv:...)")
        if isinstance(self.device, str) and not Path(self.device).exists():
            raise CameraNotFoundError(
                f"camera {self.name}: no such device or file; give a device index "
                "(opencv:0) or an existing path such as /dev/video0"
            )
        capture = cv2.VideoCapture(self.device)
        if not capture.isOpened():
            capture.release()
            raise CameraNotFoundError(
                f"camera {self.name}: OpenCV cannot open it; check that the camera is "
                "connected and not in use (ls /dev/video*)"
            )
        self._capture = capture

    def close(self) -> None:
        """Release the device (harmless when closed)."""
        capture, self._capture = self._capture, None
        if capture is not None:
            capture.release()

    @property
    def _cap(self) -> Any:
        if self._capture is None:
            raise CameraError(
                f"camera {self.name}: not open; use it in a with block or call open()"
            )
        return self._capture

    def set_exposure(self, ms: float) -> float:
        """Set a manual exposure time (V4L2 units of 100 us).

        Parameters
        ----------
        ms : float
            Exposure time in milliseconds.

        Returns
        -------
        float
            The exposure time the driver reports back, in milliseconds.

        Raises
        ------
        CameraError
            When the driver refuses manual exposure (e.g. a video file).
        """
        _check_positive("exposure time", ms, self.name)
        cv2 = import_optional("cv2", "OpenCV cameras (opencv:...)")
        cap = self._cap
        manual = cap.set(cv2.CAP_PROP_AUTO_EXPOSURE, 1)  # V4L2_EXPOSURE_MANUAL
        if not (manual and cap.set(cv2.CAP_PROP_EXPOSURE, ms / V4L2_EXPOSURE_UNIT_MS)):
            raise CameraError(
                f"camera {self.name}: the driver refuses a manual exposure time; "
                "use a camera with manual exposure (v4l2-ctl --list-ctrls shows it)"
            )
        return float(cap.get(cv2.CAP_PROP_EXPOSURE)) * V4L2_EXPOSURE_UNIT_MS

    def set_gain(self, db: float) -> float:
        """Refuse: UVC gain has no unit, so a gain in dB cannot be set.

        Parameters
        ----------
        db : float
            Gain in dB.

        Returns
        -------
        float
            Never returns.

        Raises
        ------
        CameraError
            Always.
        """
        raise CameraError(
            f"camera {self.name}: UVC gain has no unit, so {db:g} dB cannot be set; "
            "leave the gain unset (set it with v4l2-ctl) or use a pylon: or genicam: camera"
        )

    def _offered_formats(self) -> tuple[str, ...]:
        return ("Mono8",)

    def _current_format(self) -> str:
        return "Mono8"

    def _grab(self, timeout_s: float) -> NDArray[np.generic]:
        cv2 = import_optional("cv2", "OpenCV cameras (opencv:...)")
        cap = self._cap
        # V4L2 honours a read timeout; other back ends and files ignore it (set returns False).
        cap.set(cv2.CAP_PROP_READ_TIMEOUT_MSEC, timeout_s * 1000.0)
        ok, frame = cap.read()
        if not ok or frame is None:
            raise GrabTimeoutError(
                f"camera {self.name}: no frame within {timeout_s:g} s (disconnected, or the end "
                "of a video file); check the connection"
            )
        if frame.ndim == 3:
            code = cv2.COLOR_BGRA2GRAY if frame.shape[2] == 4 else cv2.COLOR_BGR2GRAY
            frame = cv2.cvtColor(frame, code)
        if frame.dtype != np.uint8:
            raise CameraError(
                f"camera {self.name}: OpenCV delivered {frame.dtype} frames; only 8-bit is read"
            )
        return np.asarray(frame)
