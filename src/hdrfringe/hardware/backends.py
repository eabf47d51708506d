"""Choose a camera back end from a specification: :func:`open_camera`.

It lives apart from :mod:`hdrfringe.hardware.camera` (the protocol and its errors) because it
imports the back ends, and every back end imports the protocol: here the imports run one way
(issue 29). The specification forms are in docs/hardware.md.
"""

from __future__ import annotations

from hdrfringe.errors import InputError
from hdrfringe.hardware.camera import CameraBase

__all__ = ["open_camera"]


def open_camera(spec: str) -> CameraBase:
    """Create (not yet open) the camera a specification names.

    Parameters
    ----------
    spec : str
        ``pylon:SERIAL`` or ``pylon:emu`` (Basler, pypylon; ``emu``: the first of pylon's
        emulated cameras), ``opencv:INDEX`` or ``opencv:PATH`` (OpenCV VideoCapture: a device
        index, a device path such as ``/dev/video0``, or a video file),
        ``genicam:CTI_PATH`` or ``genicam:CTI_PATH:SERIAL`` (harvesters with that GenTL
        producer; without a serial, its first device), ``loop:SCENE[?key=value&...]`` (the
        projector's X screen seen through the virtual rig,
        :class:`hdrfringe.hardware.loop_camera.LoopCamera`).

    Returns
    -------
    CameraBase
        The camera; open it with ``with`` or :meth:`~CameraBase.open`.

    Raises
    ------
    InputError
        When the specification has no known back end.

    Examples
    --------
    >>> with open_camera("pylon:emu") as cam:
    ...     cam.set_pixel_format("Mono12")
    ...     cam.grab(timeout_s=2.0).dtype, cam.bit_depth
    (dtype('uint16'), 12)
    >>> open_camera("usb3:1")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: camera 'usb3:1': unknown back end 'usb3'; use pylon:SERIAL, ...
    """
    kind, sep, rest = spec.partition(":")
    if kind == "pylon" and rest:
        from hdrfringe.hardware.pylon import PylonCamera

        return PylonCamera(rest)
    if kind == "opencv" and rest:
        from hdrfringe.hardware.opencv_camera import OpenCVCamera

        return OpenCVCamera(rest)
    if kind == "genicam" and rest:
        from hdrfringe.hardware.genicam import GenICamCamera

        cti, serial = rest, None
        head, _, tail = rest.rpartition(":")
        if head and tail and not tail.lower().endswith(".cti") and "/" not in tail:
            cti, serial = head, tail
        return GenICamCamera(cti, serial)
    if kind == "loop":  # the projector's X screen through the virtual rig (docs/hardware.md)
        from hdrfringe.hardware.loop_camera import LoopCamera

        return LoopCamera(spec)
    forms = "pylon:SERIAL, pylon:emu, opencv:0, opencv:/dev/videoN or genicam:CTI_PATH[:SERIAL]"
    if not sep or not rest:
        raise InputError(f"camera {spec!r}: no back end and device given; use {forms}")
    raise InputError(f"camera {spec!r}: unknown back end {kind!r}; use {forms}")
