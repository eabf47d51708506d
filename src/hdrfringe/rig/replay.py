"""Replay captures as a rig: strategies run offline on captured MIGL sweeps.

The thesis captured every MIGL from 255 to 60 in steps of 1 and ran its strategies offline;
:class:`ReplayRig` does the same with any :class:`~hdrfringe.core.captures.Captures` (read from a
capture folder, which ``hdrfringe simulate --migl-sweep`` writes, or made in memory).
``capture(frames)`` returns, for each frame, the image the captures hold for exactly that frame
(same pattern, steps, shift, pitch, orientation, imin and MIGL; or the same centerline or
uniform frame), and refuses frames they do not hold. A frame the captures hold as the projector
image it showed (an ``image`` frame of the same content: how a live run records a fringe frame of
no complete set) is answered with that image.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.captures import CameraSettings, Captures, ProjectorInfo
from hdrfringe.core.frames import Frame, FringeFrame, ImageFrame, as_image_frame
from hdrfringe.errors import CaptureFormatError
from hdrfringe.rig.base import RigBase

__all__ = ["ReplayRig"]


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
    """A rig whose captures come from a :class:`~hdrfringe.core.captures.Captures`.

    ``capture(frames, settings)`` with an exposure time returns the frame captured at exactly
    that exposure (the per-frame ``exposure_ms``) and refuses an exposure the captures do not
    hold; the same for a gain (format version 2 records one per frame).

    Parameters
    ----------
    captures : Captures
        The images to replay, e.g. a MIGL sweep read with
        :func:`hdrfringe.io.captures.read_capture_folder`.

    Attributes
    ----------
    camera_bit_depth, image_shape, projector
        As the :class:`~hdrfringe.rig.base.Rig` protocol asks (the projector defaults to
        :class:`~hdrfringe.core.captures.ProjectorInfo` when the captures record none).
    captured : int
        Number of images returned so far.

    Notes
    -----
    Thesis Sec. 5.2: the strategies were evaluated offline on a sweep of every MIGL.

    Examples
    --------
    >>> import numpy as np
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> frames = FringeSpec(steps=3).frames()
    >>> rig = ReplayRig(Captures(frames, np.arange(3).reshape(3, 1, 1).astype(np.uint8), 8))
    >>> rig.capture(frames[::-1])[:, 0, 0].tolist()
    [2, 1, 0]

    A frame held as the projector image it showed (how a live run records a frame of no
    complete set) is answered with that image:

    >>> from hdrfringe.core.frames import as_image_frame
    >>> shown = [as_image_frame(frames[0], 16, 2)]
    >>> held = Captures(shown, np.full((1, 1, 1), 7, np.uint8), 8, projector=ProjectorInfo(16, 2))
    >>> ReplayRig(held).capture(frames[:1])[:, 0, 0].tolist()
    [7]
    """

    def __init__(self, captures: Captures) -> None:
        unknown = [
            f
            for f in captures.frames
            if isinstance(f, FringeFrame) and not f.spec.gray_levels_given
        ]
        if unknown:  # a MIGL sweep is indexed by the sets' gray levels (capture format v3)
            raise CaptureFormatError(
                f"{captures.name}: fringe set {unknown[0].spec.label()} gives no imin/migl, but "
                "replaying captures for a MIGL strategy needs each set's gray levels; add imin "
                "and migl to its manifest frames"
            )
        self.captures = captures
        self.camera_bit_depth = captures.camera_bit_depth
        self.image_shape = captures.image_shape
        self.projector = captures.projector or ProjectorInfo()
        self._index = {_key(f): i for i, f in enumerate(captures.frames)}
        # image frames by content: a live run's record holds a fringe frame of no complete
        # set as the projector image it showed (Recorder.captures)
        self._images: dict[str, list[int]] = {}
        for i, f in enumerate(captures.frames):
            if isinstance(f, ImageFrame):
                self._images.setdefault(f.content_sha256, []).append(i)
        self.captured = 0

    def capture(
        self, frames: Sequence[Frame], settings: CameraSettings | None = None
    ) -> NDArray[Any]:
        """The held image of each frame, shape (n, H, W).

        Parameters
        ----------
        frames : sequence of Frame
        settings : CameraSettings, optional
            An exposure time (a gain) selects the frame captured at exactly that exposure
            (gain), as recorded per frame in the captures.

        Returns
        -------
        ndarray

        Raises
        ------
        CaptureFormatError
            A frame, exposure or gain the captures do not hold.
        """
        settings = self.resolve_settings(settings)
        idx = []
        for f in frames:
            i = self._index.get(_key(f))
            if i is None and (shown := self._shown(f)):
                i = shown[-1]
            if i is not None and settings.exposure_ms is not None:
                i = self._at_exposure(f, settings.exposure_ms)
            if i is not None and settings.gain_db is not None:
                i = self._at_gain(f, settings)
            if i is None:
                what = f.manifest_entry("")
                what.pop("file")
                raise CaptureFormatError(
                    f"{self.captures.name}: the replay folder holds no capture of frame {what}; "
                    "capture a MIGL sweep that covers it (hdrfringe simulate --migl-sweep)"
                )
            idx.append(i)
        self.captured += len(idx)
        return np.stack([self.captures.images[i] for i in idx])

    def _held(self, frame: Frame) -> list[int]:
        key = _key(frame)
        return [i for i, f in enumerate(self.captures.frames) if _key(f) == key] or self._shown(
            frame
        )

    def _shown(self, frame: Frame) -> list[int]:
        """The image frames holding exactly the projector image ``frame`` shows."""
        if not self._images or isinstance(frame, ImageFrame):
            return []
        image = as_image_frame(frame, self.projector.width, self.projector.height)
        return self._images.get(image.content_sha256, [])

    def _at_exposure(self, frame: Frame, exposure_ms: float) -> int:
        """Index of ``frame`` captured at ``exposure_ms``; refuses an exposure not held."""
        c = self.captures
        held = {float(e): i for i in self._held(frame) if (e := c.exposure_ms[i]) is not None}
        if float(exposure_ms) not in held:
            have = ", ".join(f"{e:g} ms" for e in sorted(held)) or "no recorded exposure"
            raise CaptureFormatError(
                f"{c.name}: the replay folder holds frame {json.loads(_key(frame))} at {have}, "
                f"not at {exposure_ms:g} ms; ask for a held exposure or capture that one"
            )
        return held[float(exposure_ms)]

    def _at_gain(self, frame: Frame, settings: CameraSettings) -> int:
        """Index of ``frame`` captured at the settings' gain (and exposure, when given)."""
        c = self.captures
        held = {
            float(g): i
            for i in self._held(frame)
            if (g := c.gain_db[i]) is not None
            and (settings.exposure_ms is None or c.exposure_ms[i] == settings.exposure_ms)
        }
        assert settings.gain_db is not None
        if not held:
            raise CaptureFormatError(
                f"{c.name}: the captures record no camera gain for frame "
                f"{json.loads(_key(frame))}, so a replay cannot apply {settings.gain_db:g} dB; "
                "leave gain_db None"
            )
        if float(settings.gain_db) not in held:
            have = ", ".join(f"{g:g} dB" for g in sorted(held))
            raise CaptureFormatError(
                f"{c.name}: the replay folder holds frame {json.loads(_key(frame))} at gain "
                f"{have}, not at {settings.gain_db:g} dB; ask for a held gain or capture that one"
            )
        return held[float(settings.gain_db)]

    def available_migls(self) -> list[float]:
        """MIGLs of the fringe frames the captures hold, highest first.

        Returns
        -------
        list of float
        """
        return sorted(
            {float(f.spec.migl) for f in self.captures.frames if isinstance(f, FringeFrame)},
            reverse=True,
        )
