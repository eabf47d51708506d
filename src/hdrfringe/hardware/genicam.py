"""GenICam cameras through a GenTL producer and harvesters (``genicam:CTI_PATH[:SERIAL]``).

A GenTL producer is a ``.cti`` library from the camera's vendor (or a generic one); harvesters
loads it, lists its devices and opens one as an image acquirer. Features follow GenICam SFNC:
``PixelFormat``, ``ExposureTime`` (microseconds), ``Gain`` (dB), ``TriggerSelector`` /
``TriggerMode`` / ``TriggerSource`` / ``TriggerSoftware``. A feature the device lacks raises a
one-line :class:`~hdrfringe.hardware.camera.CameraError` when it is set.

The ``genicam`` package (a dependency of harvesters) ships a small GenTL producer,
``viky.cti``, with virtual devices that offer ``Mono8`` and ``RGBa8``, a frame rate and no
exposure, gain or trigger features: the tests open it, grab Mono8 images and provoke a
timeout. Exposure, gain and triggering through this back end are written against SFNC and
harvesters' API but untested for lack of a producer that has them (docs/hardware.md).
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

__all__ = ["GenICamCamera", "bundled_producer"]

_PURPOSE = "GenICam cameras (genicam:...)"


def bundled_producer() -> Path | None:
    """The GenTL producer that the ``genicam`` package ships (virtual devices), if installed.

    Returns
    -------
    Path or None
        Path of ``viky.cti``, or None when the package or the file is missing.

    Examples
    --------
    >>> bundled_producer().name
    'viky.cti'
    """
    try:
        genicam = import_optional("genicam", _PURPOSE)
    except ImportError:
        return None
    if genicam.__file__ is None:
        return None
    path = Path(genicam.__file__).parent / "viky.cti"
    return path if path.is_file() else None


class GenICamCamera(CameraBase):
    """A GenICam camera through a GenTL producer (harvesters).

    Parameters
    ----------
    cti : str or Path
        Path of the GenTL producer (``.cti``).
    serial : str, optional
        Serial number of the device; None: the producer's first device.
    trigger_line : str, default "Line1"
        Input line of the hardware trigger.

    Examples
    --------
    >>> with GenICamCamera(bundled_producer(), serial="0") as cam:
    ...     cam.set_pixel_format("Mono8")
    ...     cam.grab(timeout_s=2.0).shape
    (400, 400)
    """

    def __init__(
        self, cti: str | Path, serial: str | None = None, trigger_line: str = "Line1"
    ) -> None:
        self.cti = Path(cti)
        self.serial = serial
        self.trigger_line = trigger_line
        self.name = f"genicam:{cti}" + (f":{serial}" if serial else "")
        self._harvester: Any = None
        self._acquirer: Any = None

    def open(self) -> None:
        """Load the producer, find the device and open it.

        Raises
        ------
        CameraNotFoundError
            When the producer file is missing or has no such device.
        """
        if self._acquirer is not None:
            return
        core = import_optional("harvesters.core", _PURPOSE)
        if not self.cti.is_file():
            raise CameraNotFoundError(
                f"camera {self.name}: no GenTL producer at {self.cti}; give the path of the "
                "vendor's .cti file"
            )
        harvester = core.Harvester()
        try:
            harvester.add_file(str(self.cti))
            harvester.update()
            devices = list(harvester.device_info_list)
            serials = [str(d.serial_number) for d in devices]
            if self.serial is None and devices:
                index = 0
            elif self.serial in serials:
                index = serials.index(str(self.serial))
            else:
                listed = ", ".join(serials) or "none (or not a GenTL producer)"
                raise CameraNotFoundError(
                    f"camera {self.name}: not found; devices of {self.cti.name}: {listed}"
                )
            self._acquirer = harvester.create(index)
        except BaseException:
            harvester.reset()
            raise
        self._harvester = harvester
        if self._trigger_mode != "software" or self._has("TriggerMode"):
            self._apply_trigger_mode(self._trigger_mode)

    def close(self) -> None:
        """Stop acquisition, release the device and unload the producer."""
        acquirer, self._acquirer = self._acquirer, None
        harvester, self._harvester = self._harvester, None
        if acquirer is not None:
            acquirer.stop()
            acquirer.destroy()
        if harvester is not None:
            harvester.reset()

    # -- features --------------------------------------------------------------------------
    @property
    def _nodes(self) -> Any:
        if self._acquirer is None:
            raise CameraError(
                f"camera {self.name}: not open; use it in a with block or call open()"
            )
        return self._acquirer.remote_device.node_map

    def _has(self, feature: str) -> bool:
        return bool(self._nodes.has_node(feature))

    def _feature(self, feature: str, what: str) -> Any:
        if not self._has(feature):
            raise CameraError(f"camera {self.name}: {what} cannot be set (no {feature} feature)")
        return getattr(self._nodes, feature)

    def _set_float(self, feature: str, value: float, unit: float, what: str) -> float:
        node = self._feature(feature, what)
        lo, hi = node.min, node.max
        if not lo <= value <= hi:
            raise CameraError(
                f"camera {self.name}: {what} {value / unit:g} is outside the camera's range "
                f"{lo / unit:g}..{hi / unit:g}; choose a value in it"
            )
        self._acquirer.stop()
        node.value = float(value)
        return float(node.value) / unit

    def set_exposure(self, ms: float) -> float:
        """Set ``ExposureTime`` (microseconds in SFNC).

        Parameters
        ----------
        ms : float
            Exposure time in milliseconds.

        Returns
        -------
        float
            The exposure time applied, in milliseconds.
        """
        _check_positive("exposure time", ms, self.name)
        return self._set_float("ExposureTime", ms * 1000.0, 1000.0, "exposure")

    def set_gain(self, db: float) -> float:
        """Set ``Gain`` (dB in SFNC).

        Parameters
        ----------
        db : float
            Gain in dB.

        Returns
        -------
        float
            The gain applied, in dB.
        """
        return self._set_float("Gain", float(db), 1.0, "gain (dB)")

    def _offered_formats(self) -> tuple[str, ...]:
        return tuple(self._feature("PixelFormat", "pixel format").symbolics)

    def _current_format(self) -> str:
        return str(self._feature("PixelFormat", "pixel format").value)

    def _apply_pixel_format(self, pixel_format: str) -> None:
        self._acquirer.stop()
        self._feature("PixelFormat", "pixel format").value = pixel_format

    def _supported_triggers(self) -> tuple[str, ...]:
        return ("software", "hardware") if self._has("TriggerMode") else ("software",)

    def _apply_trigger_mode(self, mode: str) -> None:
        if not self._has("TriggerMode"):
            return  # free-running device: "software" means the next frame it delivers
        self._acquirer.stop()
        nodes = self._nodes
        if self._has("TriggerSelector"):
            nodes.TriggerSelector.value = "FrameStart"
        nodes.TriggerSource.value = "Software" if mode == "software" else self.trigger_line
        nodes.TriggerMode.value = "On"

    # -- grabbing --------------------------------------------------------------------------
    def _grab(self, timeout_s: float) -> NDArray[np.generic]:
        gentl = import_optional("genicam.gentl", _PURPOSE)
        acquirer = self._acquirer
        if acquirer is None:
            raise CameraError(
                f"camera {self.name}: not open; use it in a with block or call open()"
            )
        if not acquirer.is_acquiring():
            acquirer.start()
        if self._trigger_mode == "software" and self._has("TriggerSoftware"):
            self._nodes.TriggerSoftware.execute()
        try:
            with acquirer.fetch(timeout=timeout_s) as buffer:
                component = buffer.payload.components[0]
                return np.array(component.data).reshape(component.height, component.width)
        except gentl.TimeoutException as err:
            raise GrabTimeoutError(
                f"camera {self.name}: no image within {timeout_s:g} s; lengthen the timeout "
                "or check the trigger and connection"
            ) from err
