"""The rig interface: project these frames, return what the camera captured.

Strategies and front ends drive any rig through this protocol: the virtual rig
(:class:`hdrfringe.rig.simulated.SimulatedRig`), a replay rig over a capture folder, or hardware.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from hdrfringe.captures import ProjectorInfo
from hdrfringe.frames import Frame


@runtime_checkable
class Rig(Protocol):
    """Anything that can project frames and return camera images.

    Attributes
    ----------
    camera_bit_depth : int
        Sensor bit depth B; a pixel is saturated at ``2**B - 1``.
    image_shape : tuple of int
        Camera image (height, width).
    projector : ProjectorInfo
        Projector input description, including the gamma pre-compensation in use.
    """

    camera_bit_depth: int
    image_shape: tuple[int, int]
    projector: ProjectorInfo

    def capture(self, frames: Sequence[Frame]) -> NDArray[np.integer]:
        """Project each frame in order and return the images, shape (n, height, width).

        dtype is uint8 for B <= 8 and uint16 otherwise; values never exceed ``2**B - 1``.
        """
        ...
