"""What a rig saw: projector and camera descriptions, and (issue 10, in progress) the in-memory
``Captures`` type that the I/O layer reads and writes and the pipeline consumes.

This module is core: it holds data, not paths, and imports nothing above the core layer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from hdrfringe.errors import InputError

__all__ = ["CameraSettings", "ProjectorInfo"]


@dataclass(frozen=True)
class ProjectorInfo:
    """Projector input as recorded in a capture manifest's ``projector`` entry.

    Parameters
    ----------
    width, height : int
        Projector resolution in pixels.
    bit_depth : int
        Projector input bit depth Bp.
    gamma_precompensation : float
        Exponent gamma-hat used when the patterns were generated (thesis Eq. 2.17; 1.0: none).

    Examples
    --------
    >>> ProjectorInfo().to_manifest()["width"]
    1024
    """

    width: int = 1024
    height: int = 768
    bit_depth: int = 8
    gamma_precompensation: float = 1.0

    def to_manifest(self) -> dict[str, Any]:
        """The manifest's ``projector`` entry.

        Returns
        -------
        dict
        """
        return {
            "width": int(self.width),
            "height": int(self.height),
            "bit_depth": int(self.bit_depth),
            "gamma_precompensation": float(self.gamma_precompensation),
        }


@dataclass(frozen=True)
class CameraSettings:
    """Camera settings a capture is taken with (None: leave the rig's current setting).

    Parameters
    ----------
    exposure_ms : float, optional
        Exposure time in milliseconds. On the virtual rig the signal of thesis Eq. 3.3 scales
        linearly with it (noise and clipping follow).
    gain_db : float, optional
        Analogue gain in dB (signal and read noise scale by ``10**(gain_db/20)``).

    Examples
    --------
    >>> CameraSettings(exposure_ms=8.0).exposure_ms
    8.0
    """

    exposure_ms: float | None = None
    gain_db: float | None = None

    def __post_init__(self) -> None:
        if self.exposure_ms is not None and not (
            math.isfinite(self.exposure_ms) and self.exposure_ms > 0
        ):
            raise InputError(
                f"exposure time must be a positive number of milliseconds, got {self.exposure_ms}"
            )
        if self.gain_db is not None and not (
            math.isfinite(self.gain_db) and -20.0 <= self.gain_db <= 48.0
        ):
            raise InputError(f"camera gain must be -20..48 dB, got {self.gain_db}")
