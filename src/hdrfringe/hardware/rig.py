"""A real projector and camera as a :class:`~hdrfringe.rig.base.Rig`, with synchronisation.

:class:`HardwareRig` shows each frame on a :class:`~hdrfringe.hardware.projector.Projector`
and grabs it with a :class:`~hdrfringe.hardware.camera.Camera`, so every strategy
(:mod:`hdrfringe.strategies`) runs live on hardware exactly as on the virtual rig. The hard part
is making sure that each image shows the frame that was projected, not the previous one
(:class:`SyncSettings`, docs/hardware.md "Synchronisation"):

- **software** mode: show, wait ``settle_s``, grab and drop ``discard`` images (frames the
  camera had already exposed or buffered), grab, then *verify*: the image must differ from the
  images accepted for the last ``history`` different projected frames by clearly more than the
  camera noise (:func:`change_ratio`). A stale image (the previous frame, or an older one still
  in a camera queue) differs from the image accepted for that frame by noise only, so it is
  rejected and the rig grabs again, up to ``max_grabs`` images; then it stops with a one-line
  :class:`SyncError`.
- **hardware** mode: the camera is set to its hardware trigger (the projector's sync output
  wired to the camera's trigger input); the rig shows and grabs without settle or discard, and
  still verifies each image (a failure means the trigger fired before the frame was on screen:
  a wiring or delay problem, reported at once, since another grab cannot help).

Every frame leaves a :class:`FrameTiming` in :attr:`HardwareRig.log` (show, settle and grab
times, grabs discarded and rejected, the change ratio accepted).
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core._validation import full_scale
from hdrfringe.core.captures import CameraSettings, ProjectorInfo
from hdrfringe.core.frames import Frame
from hdrfringe.errors import HdrFringeError, InputError
from hdrfringe.hardware.camera import Camera
from hdrfringe.hardware.projector import Projector, render_for_projector
from hdrfringe.rig.base import RigBase

__all__ = [
    "SETTLE_PROBES",
    "SYNC_MODES",
    "FrameTiming",
    "HardwareRig",
    "Recorder",
    "RigCheck",
    "SyncError",
    "SyncSettings",
    "change_ratio",
    "check_rig",
    "noise_variance",
    "open_projector",
    "recommend_sync",
]

#: ``software``: settle delay, discard, verify, retry; ``hardware``: the camera's trigger.
SYNC_MODES: tuple[str, ...] = ("software", "hardware")

#: Smallest noise variance used (LSB^2): the rounding of a noiseless camera (1/12), so that a
#: noiseless camera still has a threshold above zero.
MIN_NOISE_VARIANCE = 1.0 / 12.0
#: The mid-gray level the rig shows at opening, before white, to estimate the camera noise on
#: pixels that white saturates (docs/hardware.md "Synchronisation").
NOISE_GRAY_LEVEL = 128


class SyncError(HdrFringeError):
    """The camera did not show the projected frame (stale images, every grab).

    Examples
    --------
    >>> issubclass(SyncError, HdrFringeError)
    True
    """


@dataclass(frozen=True)
class SyncSettings:
    """How a :class:`HardwareRig` makes sure each image shows the projected frame.

    Parameters
    ----------
    mode : {"software", "hardware"}
        Software synchronisation (settle, discard, verify, retry) or the camera's hardware
        trigger.
    settle_s : float
        Seconds to wait after the frame is shown before grabbing (software mode).
    discard : int
        Images grabbed and dropped after the settle delay before the one that is verified: the
        camera's latency in frames (``hdrfringe rig check`` measures it).
    max_grabs : int
        Images grabbed (after the discarded ones) before giving up on a frame with a
        :class:`SyncError`; 1 means no retry.
    threshold : float
        A fresh image's mean squared difference from the image of another frame must exceed
        ``threshold`` times what noise alone gives (:func:`change_ratio`).
    history : int
        Number of previously projected (different) frames a new image is compared with: catches
        a camera queue that returns images up to ``history`` frames old.
    grab_timeout_s : float
        Timeout of each grab.
    verify : bool
        Verify each image (switch off only for a scene that does not respond to the projector;
        that also skips the view check).
    view_check : bool
        At opening, check that the camera's image follows the projector (white, black, white:
        :meth:`HardwareRig.open`) and refuse a camera that does not see it; switch off only for
        a rig whose camera is not meant to see the projector (a test with pylon's emulated
        camera).

    Raises
    ------
    InputError
        A value out of range.

    Examples
    --------
    >>> SyncSettings(settle_s=0.05, discard=2).max_grabs
    5
    >>> SyncSettings(mode="radio")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: sync mode 'radio' is unknown; use software or hardware
    """

    mode: str = "software"
    settle_s: float = 0.1
    discard: int = 0
    max_grabs: int = 5
    threshold: float = 4.0
    history: int = 2
    grab_timeout_s: float = 2.0
    verify: bool = True
    view_check: bool = True

    def __post_init__(self) -> None:
        if self.mode not in SYNC_MODES:
            raise InputError(f"sync mode {self.mode!r} is unknown; use {' or '.join(SYNC_MODES)}")
        for what, value, lo in (
            ("settle time", self.settle_s, 0.0),
            ("grab timeout", self.grab_timeout_s, 1e-6),
        ):
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= lo):
                raise InputError(f"sync {what} must be a number of seconds >= {lo:g}, got {value}")
        for what, ivalue, ilo in (
            ("discard", self.discard, 0),
            ("max_grabs", self.max_grabs, 1),
            ("history", self.history, 1),
        ):
            if isinstance(ivalue, bool) or not isinstance(ivalue, int) or ivalue < ilo:
                raise InputError(f"sync {what} must be an integer >= {ilo}, got {ivalue!r}")
        if not (math.isfinite(self.threshold) and self.threshold > 1.0):
            raise InputError(
                f"sync threshold must be a number > 1 (times the noise), got {self.threshold}"
            )


@dataclass
class FrameTiming:
    """What synchronising one frame took (one entry of :attr:`HardwareRig.log`).

    Parameters
    ----------
    index : int
        Frame index in the rig's run (0, 1, ...).
    frame : str
        The frame's name (``Frame.default_name()``).
    projector_frame : int
        The projector's frame number.
    show_s, settle_s, grab_s : float
        Seconds spent showing, waiting, and grabbing (discarded, rejected and accepted images).
    discarded : int
        Images dropped unverified after the settle delay.
    rejected : int
        Images that failed verification (stale) before the accepted one.
    change : float or None
        Smallest :func:`change_ratio` of the accepted image against the recent other frames'
        images (None: not verified, or no recent frame differs from this one).

    Examples
    --------
    >>> FrameTiming(0, "gray_128", 1, 0.01, 0.1, 0.02, 0, 1, 85.0).to_dict()["rejected"]
    1
    """

    index: int
    frame: str
    projector_frame: int
    show_s: float
    settle_s: float
    grab_s: float
    discarded: int
    rejected: int
    change: float | None

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly fields.

        Returns
        -------
        dict
        """
        return asdict(self)


def noise_variance(a: NDArray[Any], b: NDArray[Any], bit_depth: int) -> float:
    """Per-image noise variance from two images of the same static scene.

    ``mean((a - b)^2) / 2`` over the pixels saturated in neither image, at least
    :data:`MIN_NOISE_VARIANCE`.

    Parameters
    ----------
    a, b : ndarray
        Two images of the same projected frame.
    bit_depth : int
        Camera bit depth B (a pixel at ``2**B - 1`` is saturated).

    Returns
    -------
    float
        Variance in LSB^2.

    Examples
    --------
    >>> noise_variance(np.array([10, 12, 255]), np.array([12, 10, 255]), 8)
    2.0
    """
    top = full_scale(bit_depth)
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    use = (a < top) & (b < top)
    if not use.any():
        return MIN_NOISE_VARIANCE
    return max(float(np.mean((a[use] - b[use]) ** 2)) / 2.0, MIN_NOISE_VARIANCE)


def change_ratio(
    image: NDArray[Any], reference: NDArray[Any], variance: float, bit_depth: int
) -> float:
    """How much more two images differ than noise alone would make them.

    ``mean((image - reference)^2) / (2 variance)`` over the pixels not saturated in both
    (a pixel saturated in both carries no information). Two images of the same frame give
    about 1; an image of another frame gives far more wherever the scene reflects the
    projector (a 4-step fringe shift of amplitude b gives ``b^2 / (2 variance)``).

    Parameters
    ----------
    image, reference : ndarray
        Same shape.
    variance : float
        Per-image noise variance (:func:`noise_variance`).
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    float

    Examples
    --------
    >>> change_ratio(np.array([10.0, 20.0]), np.array([12.0, 18.0]), 2.0, 8)
    1.0
    >>> change_ratio(np.array([10.0, 255.0]), np.array([30.0, 255.0]), 2.0, 8)
    100.0
    """
    top = full_scale(bit_depth)
    a = np.asarray(image, np.float64)
    b = np.asarray(reference, np.float64)
    use = (a < top) | (b < top)
    if not use.any():
        return 0.0
    return float(np.mean((a[use] - b[use]) ** 2)) / (2.0 * max(variance, MIN_NOISE_VARIANCE))


@dataclass
class _Shown:
    """A projected image and the camera image accepted for it."""

    image: NDArray[np.uint8]
    capture: NDArray[Any]
    settings: CameraSettings = field(default_factory=CameraSettings)


class HardwareRig(RigBase):
    """A projector and a camera driven as a :class:`~hdrfringe.rig.base.Rig`.

    :meth:`open` opens both devices (the camera in the sync mode's trigger mode), shows a
    mid-gray and then a white frame and estimates the camera noise from images of each, over
    the pixels neither image of a pair saturates, keeping the larger (white is the brightest
    frame, so shot noise is not underestimated for any other; mid-gray measures the pixels
    that white saturates); :meth:`capture` shows, waits,
    grabs and verifies each frame as :class:`SyncSettings` says. Images are returned as the
    camera delivers them (uint8 or uint16 in ``0 .. 2^B - 1``).

    Parameters
    ----------
    projector : Projector
        A projector back end (not yet open).
    camera : Camera
        A camera back end (not yet open).
    sync : SyncSettings, optional
        Synchronisation; default ``SyncSettings()``.
    gamma_hat : float
        Gamma pre-compensation of the patterns (thesis Eq. 2.17; 1.0: none).
    settings : CameraSettings, optional
        Exposure and gain applied at :meth:`open` (the rig's :attr:`camera_settings`).
    pixel_format : str, optional
        Camera pixel format set at :meth:`open` (e.g. ``"Mono12"``); None: the camera's.
    sleep : callable, optional
        ``time.sleep`` (tests pass a fake clock).

    Attributes
    ----------
    log : list of FrameTiming
        One entry per frame captured.
    noise_var : float
        The camera noise variance (LSB^2) estimated at :meth:`open` (the larger of the
        mid-gray and white estimates).
    view_ratio : float or None
        How clearly the camera saw the projector at :meth:`open` (the smallest
        :func:`change_ratio` of the view check); None when it was not run.

    References
    ----------
    Thesis Sec. 3.4.3 (the measurement system); Eq. 2.17 (gamma pre-compensation).

    Examples
    --------
    A folder projector and Basler's emulated camera (its test image does not respond to the
    projector, so verification is off here):

    >>> import tempfile
    >>> from pathlib import Path
    >>> from hdrfringe.core.frames import UniformFrame
    >>> from hdrfringe.hardware.backends import open_camera
    >>> from hdrfringe.hardware.projector import FolderProjector
    >>> play = FolderProjector(Path(tempfile.mkdtemp()) / "play", 64, 48)
    >>> sync = SyncSettings(settle_s=0.0, verify=False)
    >>> with HardwareRig(play, open_camera("pylon:emu"), sync) as rig:
    ...     images = rig.capture([UniformFrame(128.0), UniformFrame(0.0)])
    >>> images.ndim, [t.projector_frame for t in rig.log]  # 1 and 2: mid-gray and white
    (3, [3, 4])
    """

    def __init__(
        self,
        projector: Projector,
        camera: Camera,
        sync: SyncSettings | None = None,
        *,
        gamma_hat: float = 1.0,
        settings: CameraSettings | None = None,
        pixel_format: str | None = None,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.projector_device = projector
        self.camera = camera
        self.sync = SyncSettings() if sync is None else sync
        self.gamma_hat = gamma_hat
        self.camera_settings = CameraSettings() if settings is None else settings
        self.pixel_format = pixel_format
        self._sleep = sleep
        self.log: list[FrameTiming] = []
        self.noise_var = MIN_NOISE_VARIANCE
        self.view_ratio: float | None = None
        self._history: list[_Shown] = []
        self._applied = CameraSettings()
        self._open = False
        self.image_shape: tuple[int, int] = (0, 0)
        self.camera_bit_depth = 8
        self.projector = ProjectorInfo()

    @property
    def gamma_hat(self) -> float:
        """The gamma pre-compensation of the frames captured next (thesis Eq. 2.17).

        The rig opens with the ``gamma_hat`` it was given, which is also the
        :attr:`projector`'s ``gamma_precompensation``; setting another value between captures
        pre-distorts the following frames with it (``hdrfringe capture-gamma`` projects its
        fringe sets at two exponents so). :class:`Recorder` records it per capture.

        Returns
        -------
        float
        """
        return self._gamma_hat

    @gamma_hat.setter
    def gamma_hat(self, value: float) -> None:
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise InputError(f"gamma pre-compensation must be a positive number, got {value}")
        self._gamma_hat = float(value)

    # -- devices -----------------------------------------------------------------------
    def open(self) -> None:
        """Open projector and camera, apply the settings, measure the noise on gray and white,
        and check that the camera sees the projector.

        The view check (``sync.view_check`` and ``sync.verify``, both on by default) shows
        black and then white again after the noise measurement and requires both changes to
        show in the image clearly above the camera noise (:meth:`_view_check`).

        Raises
        ------
        SyncError
            With verification on: the camera saturates every pixel of every image of both
            the mid-gray and the white frame, so the noise cannot be measured (lower the
            exposure or gain); or its image does not follow the projector (the view check).
        """
        if self._open:
            return
        self.projector_device.open()
        try:
            self.camera.open()
            if self.pixel_format is not None:
                self.camera.set_pixel_format(self.pixel_format)
            self.camera.set_trigger_mode(self.sync.mode)
            self._apply(self.camera_settings)
            width, height = self.projector_device.size
            self.projector = ProjectorInfo(width, height, 8, self.gamma_hat)
            self.camera_bit_depth = int(self.camera.bit_depth)
            self._open = True
            self.log = []
            self._history = []
            self._baseline()
            if self.sync.verify and self.sync.view_check:
                self._view_check()
        except BaseException:
            self._open = False
            self.close()
            raise

    def close(self) -> None:
        """Close camera and projector; closing twice is harmless."""
        try:
            self.camera.close()
        finally:
            self.projector_device.close()
            self._open = False

    def _apply(self, settings: CameraSettings) -> None:
        if settings.exposure_ms is not None:
            self.camera.set_exposure(settings.exposure_ms)
        if settings.gain_db is not None:
            self.camera.set_gain(settings.gain_db)
        self._applied = CameraSettings(
            settings.exposure_ms if settings.exposure_ms is not None else self._applied.exposure_ms,
            settings.gain_db if settings.gain_db is not None else self._applied.gain_db,
        )

    def _grab(self) -> NDArray[Any]:
        return np.asarray(self.camera.grab(timeout_s=self.sync.grab_timeout_s))

    def _settled(self) -> tuple[NDArray[Any], float | None]:
        """The latest image of what is on screen now and the noise variance.

        After the settle delay, ``discard + max_grabs + 2`` images are grabbed: with a latency
        the sync settings allow (at most ``discard + max_grabs - 1`` stale images) the last
        three are fresh. The noise variance is the smallest over the consecutive pairs that
        have a pixel saturated in neither image (a pair that straddles the change is far from
        the smallest); None when every pair is saturated everywhere (nothing to measure: the
        rounding floor would pass stale images as fresh).
        """
        self._sleep(self.sync.settle_s)
        grabs = [self._grab() for _ in range(self.sync.discard + self.sync.max_grabs + 2)]
        bits = self.camera_bit_depth
        top = full_scale(bits)
        variances = [
            noise_variance(a, b, bits)
            for a, b in itertools.pairwise(grabs)
            if bool(((a < top) & (b < top)).any())
        ]
        return grabs[-1], min(variances, default=None)

    def _baseline(self) -> None:
        """Estimate the noise on mid-gray and on white (the larger), remember white as shown.

        White alone is not enough: where white saturates a pixel it says nothing about that
        pixel's noise, and when it saturates every pixel the estimate would fall to the
        rounding floor (1/12 LSB^2), under which a stale image passes verification.
        """
        width, height = self.projector.width, self.projector.height
        estimates: list[float] = []
        for level in (NOISE_GRAY_LEVEL, 255):
            shown = np.full((height, width), level, np.uint8)
            self.projector_device.show(shown)
            last, variance = self._settled()
            if variance is not None:
                estimates.append(variance)
        if not estimates and self.sync.verify:
            raise SyncError(
                f"the camera saturates every pixel (at {full_scale(self.camera_bit_depth):g}) "
                f"in every image of white and of gray {NOISE_GRAY_LEVEL}, so its noise cannot be "
                "measured and stale images cannot be told from fresh ones; lower the exposure "
                "or gain (hdrfringe rig check reports white clipping)"
            )
        self.noise_var = max(estimates, default=MIN_NOISE_VARIANCE)
        self.image_shape = (int(last.shape[0]), int(last.shape[1]))
        self._history = [_Shown(shown, last, self._applied)]

    def _view_check(self) -> None:
        """Refuse a camera whose image does not follow the projector.

        White is on screen (:meth:`_baseline`); the rig shows black, then white again, and
        takes the latest image of each as :meth:`_settled` does. Both changes must show in
        the image: each of the two white images must differ from the black one by more than
        ``threshold`` times the noise, where the noise is the larger of the camera noise and
        half the mean squared difference of the two white images. The two whites are twice as
        far apart in time as each is from the black, so an image that changes by itself (a
        camera's moving test pattern, a drifting scene) differs between them at least as much
        as across the change and is refused, while a camera that sees the projector shows the
        change far above its noise. Ends with white on screen and its image as the reference.
        """
        width, height = self.projector.width, self.projector.height
        bits = self.camera_bit_depth
        first = self._history[-1].capture
        black = np.zeros((height, width), np.uint8)
        white = np.full((height, width), 255, np.uint8)
        self.projector_device.show(black)
        dark, _ = self._settled()
        self.projector_device.show(white)
        second, _ = self._settled()
        ratio = _view_change(first, dark, second, self.noise_var, bits)
        self.view_ratio = ratio
        self._history = [_Shown(white, second, self._applied)]
        if ratio <= self.sync.threshold:
            raise _not_seen(self.camera, ratio, self.sync.threshold)

    def _rebaseline(self) -> None:
        """After a change of exposure or gain: a new image of the frame on screen, and older
        images (at the old settings) forgotten."""
        if self._history:
            last, _ = self._settled()
            self._history = [_Shown(self._history[-1].image, last, self._applied)]

    def rebaseline(self) -> None:
        """The scene changed (a board moved to its next pose): take a new image of the frame
        on screen and forget the images of earlier frames.

        Verification compares each new image with the images of the recent frames; after the
        scene moves, a stale image (the previous frame, seen at the new pose) differs from
        those by the motion alone and would be accepted. After this call the reference is an
        image of the new scene, so a stale image is still rejected. Call it after every change
        of the scene during a run (``hdrfringe capture-poses`` does, before each pose).

        Raises
        ------
        InputError
            The rig is not open.

        Examples
        --------
        >>> import tempfile
        >>> from pathlib import Path
        >>> from hdrfringe.hardware.backends import open_camera
        >>> from hdrfringe.hardware.projector import FolderProjector
        >>> play = FolderProjector(Path(tempfile.mkdtemp()) / "play", 64, 48)
        >>> sync = SyncSettings(settle_s=0.0, view_check=False)  # the emulation sees no projector
        >>> with HardwareRig(play, open_camera("pylon:emu"), sync) as rig:
        ...     rig.rebaseline()
        ...     len(rig.log)
        0
        """
        if not self._open:
            raise InputError("the hardware rig is not open; use it in a with block or call open()")
        self._rebaseline()

    # -- capture -----------------------------------------------------------------------
    def capture(
        self, frames: Sequence[Frame], settings: CameraSettings | None = None
    ) -> NDArray[np.integer]:
        """Show each frame, grab it, and verify that the image shows it.

        Parameters
        ----------
        frames : sequence of Frame
            What the projector shows, in order.
        settings : CameraSettings, optional
            Exposure and gain for these frames (a field left None: the rig's).

        Returns
        -------
        ndarray, shape (n, height, width)

        Raises
        ------
        SyncError
            A frame whose every grab was stale (software mode: after ``max_grabs``; hardware
            mode: at once).
        ProjectorError, CameraError
            From the devices (window closed, grab timeout).
        """
        if not self._open:
            raise InputError("the hardware rig is not open; use it in a with block or call open()")
        resolved = self.resolve_settings(settings)
        if resolved != self._applied:
            self._apply(resolved)
            self._rebaseline()
        width, height = self.projector.width, self.projector.height
        dtype: type[np.unsignedinteger[Any]] = np.uint8 if self.camera_bit_depth <= 8 else np.uint16
        out: NDArray[np.unsignedinteger[Any]] = np.empty((len(frames), *self.image_shape), dtype)
        for i, frame in enumerate(frames):
            image = render_for_projector(frame, width, height, self.gamma_hat, 8)
            out[i] = self._one(frame, image)
        return out

    def _one(self, frame: Frame, image: NDArray[np.uint8]) -> NDArray[Any]:
        sync = self.sync
        t0 = time.perf_counter()
        number = self.projector_device.show(image)
        t1 = time.perf_counter()
        software = sync.mode == "software"
        if software:
            self._sleep(sync.settle_s)
        t2 = time.perf_counter()
        discarded = 0
        if software:
            for _ in range(sync.discard):
                self._grab()
                discarded += 1
        # The images a fresh one must differ from: those of the recent frames that differ
        # from this one (an equal frame looks the same, stale or not).
        others = [s.capture for s in self._history if not np.array_equal(s.image, image)]
        rejected = 0
        ratio: float | None = None
        tries = sync.max_grabs if software else 1
        while True:
            grabbed = self._grab()
            if not sync.verify or not others:
                break
            ratio = min(
                change_ratio(grabbed, o, self.noise_var, self.camera_bit_depth) for o in others
            )
            if ratio > sync.threshold:
                break
            rejected += 1
            if rejected >= tries:
                self._fail(frame, number, rejected, ratio)
        t3 = time.perf_counter()
        self.log.append(
            FrameTiming(
                len(self.log),
                frame.default_name(),
                int(number),
                t1 - t0,
                t2 - t1,
                t3 - t2,
                discarded,
                rejected,
                ratio,
            )
        )
        self._history.append(_Shown(image, grabbed, self._applied))
        # keep the last `history` distinct projected frames
        kept: list[_Shown] = []
        for s in reversed(self._history):
            if not any(np.array_equal(s.image, k.image) for k in kept):
                kept.append(s)
            if len(kept) == sync.history:
                break
        self._history = kept[::-1]
        return grabbed

    def _fail(self, frame: Frame, number: int, grabs: int, ratio: float) -> None:
        sync = self.sync
        if sync.mode == "hardware":
            raise SyncError(
                f"projector frame {number} ({frame.default_name()}): the hardware-triggered "
                f"image still shows an earlier frame (change {ratio:.2g}x noise, needs "
                f"{sync.threshold:g}x); check that the projector's sync output triggers the "
                "camera after the frame is on screen (trigger delay)"
            )
        raise SyncError(
            f"projector frame {number} ({frame.default_name()}): {grabs} grabs after "
            f"{sync.settle_s:g} s settle and {sync.discard} discarded still showed an earlier "
            f"frame (change {ratio:.2g}x noise, needs {sync.threshold:g}x); raise --settle or "
            "--discard (hdrfringe rig check measures the latency), or use a hardware trigger"
        )


class Recorder(RigBase):
    """A rig that passes every capture to another rig and keeps what it captured.

    Each :meth:`capture` call that returns is recorded whole (its frames, images and settings):
    a strategy captures one complete set per call (and the centerline alone), so an
    interrupted run leaves complete sets only.

    Parameters
    ----------
    rig : Rig
        The rig that captures (opened and closed by its owner, not by the recorder).

    Attributes
    ----------
    calls : list of tuple
        ``(frames, images, settings)`` per completed call, in order.
    gammas : list of float or None
        Per completed call, the wrapped rig's ``gamma_hat`` (its gamma pre-compensation at that
        call; None for a rig without one).

    Examples
    --------
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> from hdrfringe.rig.base import Rig
    >>> class Gray(RigBase):
    ...     camera_bit_depth, image_shape, projector = 8, (2, 3), ProjectorInfo()
    ...     def capture(self, frames, settings=None):
    ...         return np.full((len(frames), 2, 3), 9, np.uint8)
    >>> rec = Recorder(Gray())
    >>> _ = rec.capture(FringeSpec(steps=3).frames())
    >>> caps = rec.captures()
    >>> isinstance(rec, Rig), len(caps.frames), len(caps.sets)
    (True, 3, 1)
    >>> _ = rec.capture(FringeSpec(steps=3, migl=60.0).frames()[1:])  # no complete set
    >>> [f.kind for f in rec.captures().frames], len(rec.captures().sets)
    (['fringe', 'fringe', 'fringe', 'image', 'image'], 1)
    """

    def __init__(self, rig: Any) -> None:
        self.rig = rig
        self.calls: list[tuple[list[Frame], NDArray[Any], CameraSettings]] = []
        self.gammas: list[float | None] = []

    @property
    def camera_bit_depth(self) -> int:
        """The wrapped rig's bit depth."""
        return int(self.rig.camera_bit_depth)

    @property
    def image_shape(self) -> tuple[int, int]:
        """The wrapped rig's image shape."""
        return tuple(self.rig.image_shape)

    @property
    def projector(self) -> ProjectorInfo:
        """The wrapped rig's projector."""
        return self.rig.projector

    @property
    def camera_settings(self) -> CameraSettings:  # type: ignore[override]
        """The wrapped rig's default settings."""
        return self.rig.camera_settings

    def capture(
        self, frames: Sequence[Frame], settings: CameraSettings | None = None
    ) -> NDArray[np.integer]:
        """Capture on the wrapped rig and record the call.

        Parameters
        ----------
        frames : sequence of Frame
        settings : CameraSettings, optional

        Returns
        -------
        ndarray
        """
        images = self.rig.capture(frames, settings)
        self.calls.append((list(frames), np.array(images), self.rig.resolve_settings(settings)))
        gamma = getattr(self.rig, "gamma_hat", None)
        self.gammas.append(None if gamma is None else float(gamma))
        return images

    def captures(self, name: str = "<memory>", camera: dict[str, Any] | None = None) -> Any:
        """Everything recorded, in capture order, as :class:`~hdrfringe.core.captures.Captures`.

        A fringe frame whose set the run did not capture whole (adaptive ``--max-images``
        projects the first shift of its probe alone, docs/adaptive.md "Budget") is recorded as
        the projector image it showed (:func:`~hdrfringe.core.frames.as_image_frame`, kind
        ``image``: capture format version 2), not as a fringe frame of an incomplete set;
        :class:`~hdrfringe.rig.replay.ReplayRig` answers the fringe frame with it.

        Parameters
        ----------
        name : str
            The captures' name.
        camera : dict, optional
            Camera description for the manifest.

        Returns
        -------
        Captures
        """
        from hdrfringe.core.captures import Captures, partial_set_frames
        from hdrfringe.core.frames import as_image_frame

        frames = [f for fr, _, _ in self.calls for f in fr]
        images = np.concatenate([im for _, im, _ in self.calls])
        exposure = tuple(st.exposure_ms for fr, _, st in self.calls for _ in fr)
        gain = tuple(st.gain_db for fr, _, st in self.calls for _ in fr)
        # a frame sent with another pre-compensation than the projector's records its own
        base = self.projector.gamma_precompensation if self.projector is not None else None
        own = [None if g is None or g == base else g for g in self.gammas]
        per_frame = [g for (fr, _, _), g in zip(self.calls, own, strict=True) for _ in fr]
        # a fringe frame of no complete set (adaptive --max-images's one-shift probe) is
        # recorded as the projector image it showed, a frame kind outside the sets
        partial = partial_set_frames(
            frames, exposure_ms=exposure, gamma_precompensation=per_frame, gain_db=gain
        )
        if partial and self.projector is not None:
            width, height = self.projector.width, self.projector.height
            for i in partial:
                if per_frame[i] is None:  # (an image frame records no pre-compensation)
                    frames[i] = as_image_frame(frames[i], width, height)
        return Captures(
            frames,
            images,
            self.camera_bit_depth,
            projector=self.projector,
            camera=dict(camera or {}),
            exposure_ms=exposure,
            gain_db=gain,
            gamma_precompensation=tuple(per_frame),
            name=name,
        )


def open_projector(spec: str) -> Projector:
    """Create (not yet open) the projector a specification names.

    Parameters
    ----------
    spec : str
        ``screen:N`` or ``screen:N@DISPLAY`` (a full-screen window on screen N of the X
        display, default ``$DISPLAY``), or ``folder:PATH`` or ``folder:PATH@WIDTHxHEIGHT``
        (PNG files and a play list for an external player; default size 1024x768).

    Returns
    -------
    Projector

    Raises
    ------
    InputError
        An unknown back end or a malformed specification.

    Examples
    --------
    >>> open_projector("screen:1@:5")
    ScreenProjector(screen=1, display=':5')
    >>> open_projector("folder:frames@640x480")
    FolderProjector('frames', 640, 480)
    >>> open_projector("hdmi:1")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: projector 'hdmi:1': unknown back end; use screen:N[@DISPLAY] ...
    """
    from hdrfringe.hardware.projector import FolderProjector, ScreenProjector

    forms = "screen:N[@DISPLAY] or folder:PATH[@WIDTHxHEIGHT]"
    kind, _, rest = spec.partition(":")
    if kind == "screen" and rest:
        number, _, display = rest.partition("@")
        if not number.isdigit():
            raise InputError(f"projector {spec!r}: screen must be a number >= 0; use {forms}")
        return ScreenProjector(int(number), display or None)
    if kind == "folder" and rest:
        path, _, size = rest.rpartition("@") if "@" in rest else (rest, "", "1024x768")
        w, x, h = size.partition("x")
        if not (x and w.isdigit() and h.isdigit() and int(w) > 0 and int(h) > 0):
            raise InputError(f"projector {spec!r}: size {size!r} is not WIDTHxHEIGHT; use {forms}")
        return FolderProjector(path, int(w), int(h))
    raise InputError(f"projector {spec!r}: unknown back end; use {forms}")


@dataclass(frozen=True)
class RigCheck:
    """What ``hdrfringe rig check`` measured (:func:`check_rig`).

    Parameters
    ----------
    latencies : tuple of int
        Per display change: stale grabs before the first image that showed the change, the
        camera grabbed without delay.
    latency : int
        The largest of them.
    latency_s : float
        Seconds from showing a change to the end of the first grab that showed it (the
        largest over the changes): the latency as a time.
    latency_after_settle : int
        Stale grabs after a change when the rig first waits ``latency_s`` (the largest over
        the probes): equal to ``latency`` when waiting does not shorten it (the latency counts
        grabs: a camera queue), 0 when it ends with time (the projector's or camera's delay).
    latency_unit : {"none", "grabs", "seconds", "mixed"}
        What the latency counts: nothing (0), grabs, time, or time then grabs.
    grab_period_s : float
        Median seconds per grab.
    discard : int
        Recommended ``--discard``: the stale grabs left after the recommended settle.
    settle_s : float
        Recommended ``--settle``: ``latency_s`` when waiting shortens the latency, else 0
        (a wait cannot replace discarding grabs that the camera delivers in order).
    white_saturated_fraction : float
        Fraction of pixels saturated when the projector shows white at the chosen exposure.
    noise_std : float
        Median over pixels of the standard deviation of repeated grabs of a static mid-gray
        frame, in camera gray levels.
    noise_std_mean : float
        Mean of the same.
    bit_depth : int
        Camera bit depth B.
    image_shape : tuple of int
        Camera (height, width).
    view_change : float or None
        The view check's ratio (how far above the noise and drift the image followed the
        projector); None when it was not run.

    Examples
    --------
    >>> check = RigCheck((2, 2), 2, 0.09, 2, "grabs", 0.03, 2, 0.0, 0.0, 1.1, 1.2, 8, (4, 6))
    >>> check.to_dict()["recommended"], check.to_dict()["clips"]
    ({'settle': 0.0, 'discard': 2}, False)
    """

    latencies: tuple[int, ...]
    latency: int
    latency_s: float
    latency_after_settle: int
    latency_unit: str
    grab_period_s: float
    discard: int
    settle_s: float
    white_saturated_fraction: float
    noise_std: float
    noise_std_mean: float
    bit_depth: int
    image_shape: tuple[int, int]
    view_change: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """The JSON report (fields plus ``clips`` and the recommended sync options).

        Returns
        -------
        dict
        """
        out = asdict(self)
        out["latencies"] = list(self.latencies)
        out["image_shape"] = list(self.image_shape)
        out["clips"] = self.white_saturated_fraction > 0.0
        out["recommended"] = {"settle": self.settle_s, "discard": self.discard}
        return out


#: Display changes timed again after waiting ``latency_s`` (``rig check``): do they still show
#: stale grabs (a latency in grabs) or not (a latency in time)?
SETTLE_PROBES = 2


def recommend_sync(latency: int, latency_s: float, after_settle: int) -> tuple[float, int, str]:
    """The settle and discard that cover a measured latency, in the unit it counts.

    A latency is a number of stale grabs (grabbing at once after a change) and a time
    (``latency_s``, until the first grab that showed the change ended). Waiting ``latency_s``
    before grabbing tells which it is: when fewer grabs are stale after the wait
    (``after_settle < latency``), the latency passes with time and the settle is ``latency_s``
    (rounded up to 0.1 ms) with the grabs still stale after it discarded; when the same number
    is stale, the camera delivers its images in order whatever the wait (a queue, or the loop
    camera), so the settle is 0 and ``discard`` drops the ``latency`` stale grabs. (The old
    recommendation, a settle of ``(latency + 1)`` grab periods on top of discarding
    ``latency`` grabs, counted the latency twice and, for a latency in grabs, added seconds to
    every frame for nothing.)

    Parameters
    ----------
    latency : int
        Stale grabs without a wait.
    latency_s : float
        Seconds from the change to the end of the first fresh grab without a wait.
    after_settle : int
        Stale grabs after waiting ``latency_s``.

    Returns
    -------
    settle_s : float
    discard : int
    unit : {"none", "grabs", "seconds", "mixed"}

    Examples
    --------
    >>> recommend_sync(2, 0.7589, 2)  # the loop camera: two grabs, whatever the wait
    (0.0, 2, 'grabs')
    >>> recommend_sync(3, 0.12345, 0)  # a projector's input lag
    (0.1235, 0, 'seconds')
    >>> recommend_sync(0, 0.02, 0)
    (0.0, 0, 'none')
    """
    if latency == 0:
        return 0.0, 0, "none"
    if after_settle >= latency:
        return 0.0, latency, "grabs"
    settle = math.ceil(latency_s * 1e4) / 1e4
    return settle, after_settle, "seconds" if after_settle == 0 else "mixed"


def _view_change(
    first: NDArray[Any], dark: NDArray[Any], second: NDArray[Any], noise_var: float, bits: int
) -> float:
    """The view check's ratio (:meth:`HardwareRig._view_check`): the smaller change of the
    two white images against the black one, over the larger of the camera noise and half the
    mean squared difference of the two whites."""
    noise = max(noise_var, noise_variance(first, second, bits))
    return min(change_ratio(w, dark, noise, bits) for w in (first, second))


def _not_seen(camera: Camera, ratio: float, threshold: float) -> SyncError:
    """The view check's one-line refusal."""
    name = getattr(camera, "name", None) or "the camera"
    return SyncError(
        f"camera {name} does not see the projector: its image did not follow the "
        f"projector from white to black and back (change {ratio:.2g}x the noise and "
        f"drift, needs {threshold:g}x); point the camera at the projected "
        "area and check its exposure and aperture, or give --no-view-check "
        "(sync.view_check = false) for a rig whose camera is not meant to see the "
        "projector (docs/hardware.md)"
    )


def check_rig(
    projector: Projector,
    camera: Camera,
    *,
    settings: CameraSettings | None = None,
    pixel_format: str | None = None,
    changes: int = 6,
    max_latency: int = 10,
    noise_grabs: int = 8,
    threshold: float = 4.0,
    grab_timeout_s: float = 2.0,
    view_check: bool = True,
) -> RigCheck:
    """Measure a rig's display-to-capture latency, white clipping and camera noise.

    Latency: the projector alternates black and white ``changes`` times; after each change
    the camera is grabbed without delay until an image differs from the last image of the
    previous frame by more than ``threshold`` times the noise (:func:`change_ratio`); the
    grabs before it are the latency of that change, and the time from the change to the end
    of that grab its latency in seconds. Then :data:`SETTLE_PROBES` more changes are timed
    after waiting that many seconds: whether the wait shortens the latency says whether it
    counts time or grabs, and so whether a settle or a discard covers it
    (:func:`recommend_sync`). Clipping: the saturated fraction of an image of white at the
    given exposure. Noise: the per-pixel standard deviation of ``noise_grabs`` images of a
    static mid-gray (128) frame, over the pixels saturated in none.

    Parameters
    ----------
    projector : Projector
        Not yet open.
    camera : Camera
        Not yet open.
    settings : CameraSettings, optional
        Exposure and gain to check at.
    pixel_format : str, optional
        Camera pixel format.
    changes : int
        Display changes timed (at least 2).
    max_latency : int
        Grabs after a change before giving up with a :class:`SyncError`.
    noise_grabs : int
        Images of the static frame for the noise (at least 2).
    threshold : float
        Change ratio that counts as "the change is visible".
    grab_timeout_s : float
        Timeout of each grab.
    view_check : bool
        First check that the camera sees the projector, as the rig does when it opens
        (``HardwareRig`` view check: white, black, white again, both changes clearly above
        the noise and the drift between the whites); a camera whose image changes by itself
        (pylon's emulation) would otherwise show latency 0.

    Returns
    -------
    RigCheck

    Raises
    ------
    SyncError
        No change seen within ``max_latency`` grabs, or (``view_check``) the image does not
        follow the projector: the camera does not see the projector.

    Examples
    --------
    On a rig, see docs/hardware.md ("capture and rig check"; ``tests/test_hardware_rig.py``
    runs it on the loop rig). Arguments are checked before any device is opened:

    >>> from hdrfringe.hardware.backends import open_camera
    >>> check_rig(open_projector("screen:0@:99"), open_camera("pylon:emu"), changes=1)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: rig check needs changes >= 2, noise_grabs >= 2 and ...
    """
    if changes < 2 or noise_grabs < 2 or max_latency < 0:
        raise InputError(
            f"rig check needs changes >= 2, noise_grabs >= 2 and max_latency >= 0, got "
            f"{changes}, {noise_grabs}, {max_latency}"
        )
    with projector, camera:
        if pixel_format is not None:
            camera.set_pixel_format(pixel_format)
        camera.set_trigger_mode("software")
        if settings is not None and settings.exposure_ms is not None:
            camera.set_exposure(settings.exposure_ms)
        if settings is not None and settings.gain_db is not None:
            camera.set_gain(settings.gain_db)
        bits = int(camera.bit_depth)
        width, height = projector.size
        periods: list[float] = []

        def grab() -> NDArray[Any]:
            t = time.perf_counter()
            image = np.asarray(camera.grab(timeout_s=grab_timeout_s))
            periods.append(time.perf_counter() - t)
            return image

        def settled(level: int) -> tuple[NDArray[Any], float]:
            projector.show(np.full((height, width), level, np.uint8))
            grabs = [grab() for _ in range(max_latency + 3)]
            var = min(noise_variance(a, b, bits) for a, b in itertools.pairwise(grabs))
            return grabs[-1], var

        white, var_white = settled(255)
        reference, var_black = settled(0)
        variance = max(var_white, var_black)
        view = None
        if view_check:
            second, _ = settled(255)
            view = _view_change(white, reference, second, variance, bits)
            if view <= threshold:
                raise _not_seen(camera, view, threshold)
            reference, _ = settled(0)  # black on screen again: the first change is to white
        level = 255

        def timed_change(wait_s: float) -> tuple[int, float]:
            """Show the next level, wait, grab until the change shows: (stale grabs, seconds
            from the change to the end of the grab that showed it)."""
            nonlocal reference, level
            projector.show(np.full((height, width), level, np.uint8))
            shown = time.perf_counter()
            if wait_s > 0:
                time.sleep(wait_s)
            stale = 0
            while change_ratio(grab(), reference, variance, bits) <= threshold:
                stale += 1
                if stale > max_latency:
                    raise SyncError(
                        f"rig check: {max_latency + 1} grabs after a change from "
                        f"{255 - level} to {level} showed no change; point the camera at the "
                        "projected area, open the aperture, or raise the latency limit"
                    )
            seconds = time.perf_counter() - shown
            # the next reference: an image of this frame past its latency
            for _ in range(max_latency + 1):
                reference = grab()
            level = 255 - level
            return stale, seconds

        timed = [timed_change(0.0) for _ in range(changes)]
        latencies = tuple(stale for stale, _ in timed)
        latency = max(latencies)
        latency_s = max(seconds for _, seconds in timed)
        period = float(np.median(periods))  # before the probes' waits (grabs only anyway)
        after = 0
        if latency > 0:
            after = max(timed_change(latency_s)[0] for _ in range(SETTLE_PROBES))
        settle, discard, unit = recommend_sync(latency, latency_s, after)
        saturated = float(np.mean(white >= full_scale(bits)))
        gray, _ = settled(128)
        stack = np.stack([gray] + [grab() for _ in range(noise_grabs - 1)]).astype(np.float64)
        use = (stack < full_scale(bits)).all(axis=0)
        std = stack.std(axis=0, ddof=1)[use] if use.any() else np.zeros(1)
        return RigCheck(
            latencies,
            latency,
            round(latency_s, 4),
            after,
            unit,
            period,
            discard,
            settle,
            saturated,
            float(np.median(std)),
            float(np.mean(std)),
            bits,
            (int(gray.shape[0]), int(gray.shape[1])),
            view,
        )
