"""Basler cameras through pypylon (``pylon:SERIAL``, ``pylon:emu``).

pylon ships a camera emulation (device class ``BaslerCamEmu``): the environment variable
``PYLON_CAMEMU=N`` makes pylon's transport-layer factory list N emulated cameras, which take
exposure, gain and the Mono8/10/12/16 pixel formats and deliver a fixed test pattern. pylon
reads the variable whenever it enumerates devices, so ``pylon:emu`` sets ``PYLON_CAMEMU=1``
in the process environment when it is unset or 0, and then opens the first emulated camera
(a real Basler camera connected at the same time is never picked by ``emu``).

Feature names follow GenICam SFNC 2 (``ExposureTime`` in microseconds, ``Gain`` in dB) with
the older Basler names as fallback (``ExposureTimeAbs``; ``GainRaw`` is not in dB and is not
used). In software trigger mode each grab fires a software trigger and waits for that image,
so an image never predates the grab; in hardware mode the camera exposes on an edge at
``trigger_line`` (default ``Line1``) and the grab waits for it.
"""

from __future__ import annotations

import os
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

__all__ = ["EMULATION_CLASS", "PylonCamera"]

#: pylon's device class of its emulated cameras.
EMULATION_CLASS = "BaslerCamEmu"


def _pylon() -> Any:
    return import_optional("pypylon.pylon", "Basler cameras (pylon:...)")


class PylonCamera(CameraBase):
    """A Basler camera (or pylon's emulated camera) through pypylon.

    Parameters
    ----------
    serial : str
        The camera's serial number, or ``"emu"`` for the first emulated camera.
    trigger_line : str, default "Line1"
        Input line of the hardware trigger.

    References
    ----------
    Thesis Sec. 7.4 (bit depth: Mono8, Mono10, Mono12, Mono16).

    Examples
    --------
    >>> with PylonCamera("emu") as cam:
    ...     cam.pixel_formats
    ...     cam.set_exposure(5.0)
    ...     cam.set_pixel_format("Mono12")
    ...     int(cam.grab(timeout_s=2.0).max()) > 255
    ('Mono8', 'Mono10', 'Mono12', 'Mono16')
    5.0
    True
    """

    def __init__(self, serial: str, trigger_line: str = "Line1") -> None:
        self.serial = serial
        self.trigger_line = trigger_line
        self.name = f"pylon:{serial}"
        self._camera: Any = None

    # -- open / close ----------------------------------------------------------------------
    def open(self) -> None:
        """Find the camera by serial (or the first emulated one) and open it.

        Raises
        ------
        CameraNotFoundError
            When no such camera is connected; the message lists those that are.
        """
        if self._camera is not None:
            return
        pylon = _pylon()
        if self.serial == "emu" and os.environ.get("PYLON_CAMEMU", "0").strip() in ("", "0"):
            os.environ["PYLON_CAMEMU"] = "1"
        factory = pylon.TlFactory.GetInstance()
        devices = list(factory.EnumerateDevices())
        if self.serial == "emu":
            chosen = [d for d in devices if d.GetDeviceClass() == EMULATION_CLASS]
        else:
            chosen = [d for d in devices if d.GetSerialNumber() == self.serial]
        if not chosen:
            found = ", ".join(f"{d.GetModelName()} {d.GetSerialNumber()}" for d in devices)
            raise CameraNotFoundError(
                f"camera {self.name}: not found; connected Basler cameras: {found or 'none'} "
                "(pylon:emu opens pylon's emulated camera)"
            )
        camera = pylon.InstantCamera(factory.CreateDevice(chosen[0]))
        try:
            camera.Open()
        except Exception as err:  # pylon's RuntimeException: in use, no access
            raise CameraNotFoundError(
                f"camera {self.name}: found but cannot be opened ({str(err).splitlines()[0]}); "
                "close other programs that use it"
            ) from err
        self._camera = camera
        self._apply_trigger_mode(self._trigger_mode)

    def close(self) -> None:
        """Stop grabbing and release the camera (harmless when closed)."""
        camera, self._camera = self._camera, None
        if camera is not None:
            if camera.IsGrabbing():
                camera.StopGrabbing()
            camera.Close()

    # -- features --------------------------------------------------------------------------
    @property
    def _cam(self) -> Any:
        if self._camera is None:
            raise CameraError(
                f"camera {self.name}: not open; use it in a with block or call open()"
            )
        return self._camera

    def _node(self, *names: str) -> Any:
        """The first of ``names`` that the camera has, available and writable, or None."""
        genicam = import_optional("pypylon.genicam", "Basler cameras (pylon:...)")
        nodemap = self._cam.GetNodeMap()
        for name in names:
            node = nodemap.GetNode(name)
            if node is not None and genicam.IsWritable(node):
                return node
        return None

    def _set_float(self, names: tuple[str, ...], value: float, unit: float, what: str) -> float:
        node = self._node(*names)
        if node is None:
            raise CameraError(f"camera {self.name}: {what} cannot be set (no {names[0]} feature)")
        lo, hi = node.GetMin(), node.GetMax()
        if not lo <= value <= hi:
            raise CameraError(
                f"camera {self.name}: {what} {value / unit:g} is outside the camera's range "
                f"{lo / unit:g}..{hi / unit:g}; choose a value in it"
            )
        self._stop()
        node.SetValue(float(value))
        return float(node.GetValue()) / unit

    def set_exposure(self, ms: float) -> float:
        """Set the exposure time (``ExposureTime`` or ``ExposureTimeAbs``, in microseconds).

        Parameters
        ----------
        ms : float
            Exposure time in milliseconds, within the camera's range.

        Returns
        -------
        float
            The exposure time applied, in milliseconds.
        """
        _check_positive("exposure time", ms, self.name)
        return self._set_float(("ExposureTime", "ExposureTimeAbs"), ms * 1000.0, 1000.0, "exposure")

    def set_gain(self, db: float) -> float:
        """Set the gain (``Gain`` in dB).

        Parameters
        ----------
        db : float
            Gain in dB, within the camera's range.

        Returns
        -------
        float
            The gain applied, in dB.
        """
        return self._set_float(("Gain",), float(db), 1.0, "gain (dB)")

    def _offered_formats(self) -> tuple[str, ...]:
        return tuple(self._cam.PixelFormat.Symbolics)

    def _current_format(self) -> str:
        return str(self._cam.PixelFormat.GetValue())

    def _apply_pixel_format(self, pixel_format: str) -> None:
        self._stop()
        self._cam.PixelFormat.SetValue(pixel_format)

    def _supported_triggers(self) -> tuple[str, ...]:
        return ("software", "hardware")

    def _apply_trigger_mode(self, mode: str) -> None:
        cam = self._cam
        self._stop()
        cam.TriggerSelector.SetValue("FrameStart")
        cam.TriggerSource.SetValue("Software" if mode == "software" else self.trigger_line)
        cam.TriggerMode.SetValue("On")

    # -- grabbing --------------------------------------------------------------------------
    def _stop(self) -> None:
        if self._camera is not None and self._camera.IsGrabbing():
            self._camera.StopGrabbing()

    def _grab(self, timeout_s: float) -> NDArray[np.generic]:
        pylon = _pylon()
        cam = self._cam
        if not cam.IsGrabbing():
            cam.StartGrabbing(pylon.GrabStrategy_OneByOne)
        timeout_ms = max(1, round(timeout_s * 1000))
        if self._trigger_mode == "software":
            if not cam.WaitForFrameTriggerReady(timeout_ms, pylon.TimeoutHandling_Return):
                raise GrabTimeoutError(
                    f"camera {self.name}: not ready for a trigger within {timeout_s:g} s; "
                    "lengthen the timeout or shorten the exposure"
                )
            cam.ExecuteSoftwareTrigger()
        result = cam.RetrieveResult(timeout_ms, pylon.TimeoutHandling_Return)
        if result is None or not result.IsValid():
            hint = (
                "check the trigger signal on " + self.trigger_line
                if self._trigger_mode == "hardware"
                else "lengthen the timeout or check the connection"
            )
            raise GrabTimeoutError(f"camera {self.name}: no image within {timeout_s:g} s; {hint}")
        try:
            if not result.GrabSucceeded():
                raise CameraError(
                    f"camera {self.name}: grab failed ({result.GetErrorDescription()}); "
                    "check the connection and bandwidth"
                )
            return np.array(result.GetArray())
        finally:
            result.Release()
