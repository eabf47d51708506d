"""Replay a capture folder as a rig: strategies run offline on captured MIGL sweeps.

The thesis captured every MIGL from 255 to 60 in steps of 1 and ran its strategies offline;
:class:`ReplayRig` does the same with any capture folder (``hdrfringe simulate --migl-sweep``
writes one). ``capture(frames)`` returns, for each frame, the image the folder holds for exactly
that frame (same pattern, steps, shift, pitch, orientation, imin and MIGL; or the same centerline
or uniform frame), and refuses frames the folder does not hold.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.captures import CameraSettings, ProjectorInfo
from hdrfringe.errors import CaptureFormatError
from hdrfringe.frames import Frame
from hdrfringe.io.captures import CaptureFolder
from hdrfringe.rig.base import RigBase


def _key(frame: Frame) -> str:
    entry: dict[str, Any] = frame.manifest_entry("")
    entry.pop("file")
    return json.dumps(
        {
            k: (float(v) if isinstance(v, int | float) and not isinstance(v, bool) else v)
            for k, v in entry.items()
        },
        sort_keys=True,
    )


class ReplayRig(RigBase):
    """A rig whose captures come from a capture folder (see module docstring).

    ``capture(frames, settings)`` with an exposure time returns the frame captured at exactly
    that exposure (the manifest's per-frame ``exposure_ms``) and refuses an exposure the folder
    does not hold; a gain cannot be replayed (the folder records none).
    """

    def __init__(self, folder: CaptureFolder) -> None:
        self.folder = folder
        self.camera_bit_depth = folder.camera_bit_depth
        self.image_shape = folder.image_shape
        self.projector = folder.projector or ProjectorInfo()
        self._index = {_key(f): i for i, f in enumerate(folder.frames)}
        self.captured = 0

    def capture(self, frames: Sequence[Frame], settings: CameraSettings | None = None) -> NDArray:
        settings = self.resolve_settings(settings)
        if settings.gain_db is not None:
            raise CaptureFormatError(
                f"{self.folder.path}: a capture folder records no camera gain, so a replay "
                f"cannot apply {settings.gain_db:g} dB; leave gain_db None"
            )
        idx = []
        for f in frames:
            i = self._index.get(_key(f))
            if i is not None and settings.exposure_ms is not None:
                i = self._at_exposure(f, settings.exposure_ms)
            if i is None:
                what = f.manifest_entry("")
                what.pop("file")
                raise CaptureFormatError(
                    f"{self.folder.path}: the replay folder holds no capture of frame {what}; "
                    "capture a MIGL sweep that covers it (hdrfringe simulate --migl-sweep)"
                )
            idx.append(i)
        self.captured += len(idx)
        return np.stack([self.folder.images[i] for i in idx])

    def _at_exposure(self, frame: Frame, exposure_ms: float) -> int:
        """Index of ``frame`` captured at ``exposure_ms``; refuses an exposure not held."""
        key = _key(frame)
        held = {
            float(e["exposure_ms"]): i
            for i, (f, e) in enumerate(zip(self.folder.frames, self.folder.entries, strict=True))
            if e.get("exposure_ms") is not None and _key(f) == key
        }
        if float(exposure_ms) not in held:
            have = ", ".join(f"{e:g} ms" for e in sorted(held)) or "no recorded exposure"
            raise CaptureFormatError(
                f"{self.folder.path}: the replay folder holds frame {json.loads(key)} at {have}, "
                f"not at {exposure_ms:g} ms; ask for a held exposure or capture that one"
            )
        return held[float(exposure_ms)]

    def available_migls(self) -> list[float]:
        """MIGLs of the fringe frames the folder holds, highest first."""
        return sorted(
            {float(f.spec.migl) for f in self.folder.frames if hasattr(f, "spec")}, reverse=True
        )
