"""The rig interface: project these frames with these camera settings, return what the camera saw.

Strategies and front ends drive any rig through the :class:`Rig` protocol: the virtual rig
(:class:`hdrfringe.rig.simulated.SimulatedRig`), a replay rig over a capture folder, or hardware.
A rig is opened before use and closed after (a hardware rig acquires its devices there), most
simply as a context manager::

    with make_rig() as rig:
        images = rig.capture(frames, CameraSettings(exposure_ms=20.0))

:class:`RigBase` gives a rig the protocol's housekeeping (``open``/``close`` that do nothing,
context-manager use, ``camera_settings`` and :meth:`RigBase.resolve_settings`), so a rig only
writes ``capture`` and whatever it really needs to open.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import TracebackType
from typing import Protocol, Self, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.captures import CameraSettings, ProjectorInfo
from hdrfringe.core.frames import Frame
from hdrfringe.errors import InputError

__all__ = ["Rig", "RigBase"]


# A protocol has no constructor: numpydoc reads the (*args, **kwargs) of typing.Protocol as one.
@runtime_checkable
class Rig(Protocol):  # numpydoc ignore=PR01
    """Anything that can project frames and return camera images.

    A structural type: a rig need not inherit from it, only have these members (most rigs
    inherit the housekeeping from :class:`RigBase`). The four descriptive members are read-only
    for the code that drives a rig: a rig may store them as plain attributes or compute them as
    properties.

    Attributes
    ----------
    camera_bit_depth : int
        Sensor bit depth B; a pixel is saturated at ``2**B - 1``.
    image_shape : tuple of int
        Camera image (height, width).
    projector : ProjectorInfo
        Projector input description, including the gamma pre-compensation in use.
    camera_settings : CameraSettings
        The settings a capture uses when it is given none (a field left None: the rig does not
        know or set it, e.g. a replayed folder that records no exposure).

    References
    ----------
    Thesis Sec. 3.4.3 (the camera-projector measurement system a rig stands for).

    Examples
    --------
    A rig whose camera sees a constant gray, built on :class:`RigBase`:

    >>> from hdrfringe.core.frames import UniformFrame
    >>> class Gray(RigBase):
    ...     camera_bit_depth, image_shape, projector = 8, (2, 3), ProjectorInfo()
    ...
    ...     def capture(self, frames, settings=None):
    ...         return np.full((len(frames), *self.image_shape), 100, np.uint8)
    >>> isinstance(Gray(), Rig)
    True
    >>> with Gray() as rig:
    ...     rig.capture([UniformFrame(128.0), UniformFrame(64.0)]).shape
    (2, 2, 3)
    """

    @property
    def camera_bit_depth(self) -> int:
        """Sensor bit depth B; a pixel is saturated at ``2**B - 1``."""
        ...

    @property
    def image_shape(self) -> tuple[int, int]:
        """Camera image (height, width)."""
        ...

    @property
    def projector(self) -> ProjectorInfo:
        """Projector input description, including the gamma pre-compensation in use."""
        ...

    @property
    def camera_settings(self) -> CameraSettings:
        """The settings a capture uses when it is given none."""
        ...

    def open(self) -> None:
        """Acquire what the rig needs (devices, windows); a rig is usable after it."""
        ...

    def close(self) -> None:
        """Release what :meth:`open` acquired; closing twice is harmless."""
        ...

    def __enter__(self) -> Self: ...

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None: ...

    def capture(
        self, frames: Sequence[Frame], settings: CameraSettings | None = None
    ) -> NDArray[np.integer]:
        """Project each frame in order and return the images.

        Parameters
        ----------
        frames : sequence of Frame
            What the projector shows, in order.
        settings : CameraSettings, optional
            Camera settings for every frame of the call; a field left None (or ``settings``
            None) takes the rig's :attr:`camera_settings`.

        Returns
        -------
        ndarray, shape (n, height, width)
            uint8 for B <= 8, uint16 otherwise; values never exceed ``2**B - 1``.
        """
        ...


class RigBase:
    """Defaults for the housekeeping of the :class:`Rig` protocol.

    ``open`` and ``close`` do nothing (a rig with nothing to acquire needs nothing more);
    ``with rig:`` opens it and closes it on leaving, also after an error (which it does not
    swallow). ``camera_settings`` defaults to ``CameraSettings()`` (nothing known);
    :meth:`resolve_settings` merges a capture's settings with it.

    Examples
    --------
    >>> class Dark(RigBase):
    ...     opened = 0
    ...
    ...     def open(self) -> None:
    ...         self.opened += 1
    >>> with Dark() as rig:
    ...     rig.opened
    1
    >>> Dark().resolve_settings(CameraSettings(gain_db=6.0))
    CameraSettings(exposure_ms=None, gain_db=6.0)
    """

    camera_settings: CameraSettings = CameraSettings()

    def open(self) -> None:
        """Acquire what the rig needs; the default has nothing to acquire."""

    def close(self) -> None:
        """Release what :meth:`open` acquired; the default has nothing to release."""

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

    def resolve_settings(self, settings: CameraSettings | None) -> CameraSettings:
        """The settings a capture uses.

        Each field of ``settings`` that is not None, else the rig's :attr:`camera_settings`.

        Parameters
        ----------
        settings : CameraSettings or None
            The settings a capture was given.

        Returns
        -------
        CameraSettings
        """
        current = self.camera_settings
        if settings is None:
            return current
        if not isinstance(settings, CameraSettings):
            raise InputError(
                f"camera settings must be a hdrfringe.core.captures.CameraSettings or None, got "
                f"{type(settings).__name__}"
            )
        return CameraSettings(
            exposure_ms=(
                settings.exposure_ms if settings.exposure_ms is not None else current.exposure_ms
            ),
            gain_db=settings.gain_db if settings.gain_db is not None else current.gain_db,
        )
