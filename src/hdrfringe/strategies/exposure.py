"""Exposure time chosen from the fringes (thesis Sec. 7.3): the darkest surface's modulation.

The MIGL strategies (thesis Ch. 4-6) only ever *lower* the light, so they need the camera's
exposure set beforehand such that the darkest surface of the part still has a good fringe
modulation; the bright surfaces are then tamed by the MIGL (Sec. 7.3: "adjustment of the
aperture or exposure time would serve as a rough adjustment, while the MIGL can be used for
fine adjustment"). :func:`choose_exposure` automates that rough adjustment:

1. capture the set at its highest MIGL at the rig's exposure ``t``;
2. the *darkest valid modulation* ``B_dark``: the ``percentile`` (default 1 %) of the
   intensity modulation I' (Eq. 3.4) over the pixels that are unsaturated and carry a fringe
   (I' at least :func:`detection_modulation`, twice the decoder's validity threshold: about 5
   sigma of the modulation of pure noise, so shadows and unlit background never count), I'
   averaged over the valid pixels of each 3 x 3 neighbourhood (without it the noise spread of
   I' pulls a low percentile down by about 2.3 of its sigma: 20 % at 7 DN);
3. every term of the signal scales with the exposure time (docs/virtual_rig.md), so the
   exposure that brings ``B_dark`` to the target is ``t * target / B_dark``; clip it to
   ``[min_exposure_ms, max_exposure_ms]``;
4. if that is within ``tolerance`` (15 %) of ``t``, ``t`` is the choice; otherwise capture
   there and repeat from 2 (newly lit dark pixels can lower ``B_dark``), at most
   ``max_captures`` sets. A first capture with no valid pixel (everything saturated, or nothing
   lit) divides or multiplies ``t`` by 4 and tries again.

The target (:func:`default_target_modulation`) comes from the noise model: the N-step phase
noise is ``sqrt(2/N) sigma / I'`` (sigma the intensity noise in DN), so the modulation that
keeps it at ``phase_std_rad`` is ``sqrt(2/N) sigma / phase_std_rad``. With sigma = 1.5 DN at
8 bits (the virtual rig's 1 DN read noise, 0.3 DN quantisation and about 1 DN of shot noise at
mid-scale for its 20 000 e- full well) and 0.02 rad, that is 53 DN for N = 4 (61 DN for N = 3,
38 DN for N = 8), a fifth of full scale; it scales with the full scale at other bit depths.

:func:`run_at_exposure` runs any registered strategy at a chosen exposure (reusing the choice's
last set, which was captured at exactly that exposure and the highest MIGL), which is the
"exposure + MIGL" combination; the multi-exposure strategy
(:mod:`hdrfringe.strategies.multiexposure`) uses the same target and darkest-modulation rule.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe._renamed import renamed_keyword
from hdrfringe.core._validation import full_scale, unsaturated_mask
from hdrfringe.core.captures import CameraSettings, ProjectorInfo
from hdrfringe.core.frames import Frame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set, default_min_modulation
from hdrfringe.errors import InputError
from hdrfringe.rig.base import Rig, RigBase
from hdrfringe.strategies.base import (
    StrategyResult,
    check_fringe_spec,
    get_strategy,
    make_params,
)

__all__ = [
    "DEFAULT_NOISE_DN8",
    "DEFAULT_PHASE_STD_RAD",
    "ExposureChoice",
    "FixedExposureRig",
    "choose_exposure",
    "darkest_modulation",
    "default_target_modulation",
    "detection_modulation",
    "rig_exposure",
    "run_at_exposure",
]

#: Intensity noise sigma in 8-bit DN of the target rule: read noise 1 DN, quantisation
#: 1/sqrt(12) DN and shot noise about 1 DN at mid-scale (the virtual rig's defaults).
DEFAULT_NOISE_DN8 = 1.5
#: Phase noise (rad) the target modulation keeps the darkest surface at.
DEFAULT_PHASE_STD_RAD = 0.02


def default_target_modulation(
    steps: int,
    bit_depth: int,
    *,
    noise_dn8: float = DEFAULT_NOISE_DN8,
    phase_std_rad: float = DEFAULT_PHASE_STD_RAD,
) -> float:
    """The modulation I' (DN) at which N-step decoding has the phase noise ``phase_std_rad``.

    ``I' = sqrt(2 / N) * sigma / phase_std_rad`` with ``sigma = noise_dn8 * (2^B - 1) / 255``:
    the phase noise of the N-step decoder is ``sqrt(2/N) sigma / I'`` for Gaussian intensity
    noise of standard deviation sigma.

    Parameters
    ----------
    steps : int
        Number of phase shifts N (>= 2; the sinusoidal formula serves triangular sets too).
    bit_depth : int
        Camera bit depth B.
    noise_dn8 : float
        Intensity noise sigma in 8-bit DN (scaled to B bits by the full scale).
    phase_std_rad : float
        The phase noise wanted on the darkest surface.

    Returns
    -------
    float
        The target modulation in DN at bit depth B.

    References
    ----------
    Thesis Sec. 3.3 (intensity modulation, Eq. 3.4, and the SNR) and Sec. 7.3.

    Examples
    --------
    >>> round(default_target_modulation(4, 8), 1), round(default_target_modulation(8, 8), 1)
    (53.0, 37.5)
    >>> round(default_target_modulation(4, 12) / default_target_modulation(4, 8), 3)
    16.059
    """
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 2:
        raise InputError(f"target modulation needs N >= 2 phase shifts, got {steps!r}")
    for name, value in (("noise_dn8", noise_dn8), ("phase_std_rad", phase_std_rad)):
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"target modulation: {name} must be a positive number, got {value}")
    sigma = noise_dn8 * full_scale(bit_depth) / 255.0
    return math.sqrt(2.0 / steps) * sigma / phase_std_rad


def detection_modulation(bit_depth: int) -> float:
    """Modulation (DN) above which a pixel counts as a lit surface: twice the decoder's default.

    Pure noise of 1 DN gives a 4-step modulation of about 0.7 DN (Rayleigh); 4 DN at 8 bits is
    more than five times that, so shadows and unlit background never count as the darkest
    surface.

    Parameters
    ----------
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    float
        ``2 * default_min_modulation(B)``: 4 DN at 8 bits.

    Examples
    --------
    >>> detection_modulation(8)
    4.0
    """
    return 2.0 * default_min_modulation(bit_depth)


def darkest_modulation(
    images: NDArray,
    spec: FringeSpec,
    bit_depth: int,
    *,
    percentile: float = 1.0,
    mask: NDArray[np.bool_] | None = None,
) -> float | None:
    """The darkest valid modulation of a set: a low percentile of I' over lit unsaturated pixels.

    I' is averaged over the valid pixels of each 3 x 3 neighbourhood before the percentile
    (a third of the noise spread, which would otherwise bias a low percentile downward).

    Parameters
    ----------
    images : ndarray (N, H, W)
        One phase-shifted set.
    spec : FringeSpec
        What was projected.
    bit_depth : int
        Camera bit depth B.
    percentile : float
        Which percentile of the modulation (0..100; 1: the darkest 1 % of the lit pixels).
    mask : ndarray of bool, optional
        Only these pixels count.

    Returns
    -------
    float or None
        The modulation in DN; None when no pixel is unsaturated with a modulation of at least
        :func:`detection_modulation`.

    References
    ----------
    Thesis Eq. 3.4 (intensity modulation I').

    Examples
    --------
    >>> from hdrfringe.core.patterns import fringe_gray
    >>> spec = FringeSpec("sinusoidal", 4, 8.0, imin=0)
    >>> x = np.arange(16.0)
    >>> gain = np.array([[0.2], [1.5]])  # a dark row and a row that saturates
    >>> imgs = np.stack([np.minimum(255, np.rint(gain * fringe_gray(x, spec, k)))
    ...                  for k in range(4)]).astype(np.uint8)
    >>> abs(darkest_modulation(imgs, spec, 8) - 0.2 * 127.5) < 0.5  # the dark row, rounded
    True
    """
    if not 0.0 <= percentile <= 100.0:
        raise InputError(f"darkest-modulation percentile must be in 0..100, got {percentile}")
    res = decode_set(images, spec, bit_depth, min_modulation=detection_modulation(bit_depth))
    valid = res.valid if mask is None else res.valid & np.asarray(mask, dtype=bool)
    if not valid.any():
        return None
    # the mean over the valid pixels of each 3 x 3 neighbourhood: a third of the noise spread,
    # which would otherwise pull a low percentile down by about 2.3 sigma of I'
    from scipy import ndimage  # here: measure imports this module (cold start, issue 16)

    weight = ndimage.uniform_filter(valid.astype(np.float64), 3, mode="nearest")
    total = ndimage.uniform_filter(np.where(valid, res.modulation, 0.0), 3, mode="nearest")
    smooth = total[valid] / weight[valid]
    return float(np.percentile(smooth, percentile))


def rig_exposure(rig: Rig, what: str) -> float:
    """The rig's current exposure time in ms; an error naming ``what`` when the rig has none.

    Parameters
    ----------
    rig : Rig
        Any rig.
    what : str
        Who needs it, for the message.

    Returns
    -------
    float

    Examples
    --------
    >>> from hdrfringe.rig.simulated import SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> rig_exposure(SimulatedRig(white_plate()), "example")
    10.0
    """
    t = rig.camera_settings.exposure_ms
    if t is None or not (math.isfinite(t) and t > 0):
        raise InputError(
            f"{what} scales the rig's exposure time, but the rig reports none (a replayed "
            "folder without exposure times?); set the rig's exposure or give the exposures "
            "explicitly (--exposures 2.5,10,40)"
        )
    return float(t)


def _check_positive(name: str, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a positive number of milliseconds, got {value}")


@dataclass(frozen=True)
class ExposureChoice:
    """What :func:`choose_exposure` chose, and the sets it captured to choose it.

    Parameters
    ----------
    exposure_ms : float
        The chosen exposure time.
    target_modulation_dn : float
        The modulation the darkest valid surface was brought to.
    darkest_modulation_dn : float or None
        The darkest valid modulation of the last set, scaled to ``exposure_ms`` (None when no
        pixel was valid).
    spec : FringeSpec
        The set captured (at its highest MIGL).
    captures : tuple of (float, ndarray)
        ``(exposure_ms, images)`` of every set captured, in capture order.
    limited : str or None
        ``"max_exposure"`` or ``"min_exposure"`` when the choice was clipped, ``"captures"``
        when ``max_captures`` ran out before the exposure settled; None otherwise.

    Examples
    --------
    >>> spec = FringeSpec("sinusoidal", 4, 8.0)
    >>> c = ExposureChoice(20.0, 53.0, 53.5, spec, ((10.0, np.zeros((4, 2, 2), np.uint8)),))
    >>> c.sets_captured, c.images_captured, c.last_at_choice is None
    (1, 4, True)
    """

    exposure_ms: float
    target_modulation_dn: float
    darkest_modulation_dn: float | None
    spec: FringeSpec
    captures: tuple[tuple[float, NDArray], ...] = dataclasses.field(compare=False)
    limited: str | None = None

    @property
    def sets_captured(self) -> int:
        """Number of sets captured to choose."""
        return len(self.captures)

    @property
    def images_captured(self) -> int:
        """Number of images captured to choose: ``spec.steps`` per set."""
        return len(self.captures) * self.spec.steps

    @property
    def last_at_choice(self) -> NDArray | None:
        """The last set's images when it was captured at the chosen exposure, else None."""
        if self.captures and self.captures[-1][0] == self.exposure_ms:
            return self.captures[-1][1]
        return None


def choose_exposure(
    rig: Rig,
    spec: FringeSpec,
    *,
    target_modulation_dn: float | None = None,
    percentile: float = 1.0,
    start_ms: float | None = None,
    min_exposure_ms: float | None = None,
    max_exposure_ms: float | None = None,
    tolerance: float = 0.15,
    max_captures: int = 4,
    keep_if_unsaturated: bool = False,
) -> ExposureChoice:
    """Choose the exposure time at which the darkest valid surface reaches the target modulation.

    The rule is the module's (:mod:`hdrfringe.strategies.exposure`): capture at the highest MIGL,
    take the ``percentile`` of the modulation over the lit unsaturated pixels, scale the
    exposure by ``target / B_dark`` (the signal is proportional to the exposure), repeat until
    the change is within ``tolerance``.

    Parameters
    ----------
    rig : Rig
        Any rig whose exposure time can be set (``CameraSettings.exposure_ms``).
    spec : FringeSpec
        The set, at its highest MIGL.
    target_modulation_dn : float, optional
        Target I' in DN; default :func:`default_target_modulation` for ``spec.steps``.
    percentile : float
        Percentile of the modulation that stands for the darkest surface (0..100).
    start_ms : float, optional
        First exposure; default the rig's current one.
    min_exposure_ms, max_exposure_ms : float, optional
        Limits of the choice; default 1/256 and 16 times the first exposure.
    tolerance : float
        Relative change below which the exposure has settled (and no more sets are captured).
    max_captures : int
        Most sets captured (>= 1).
    keep_if_unsaturated : bool
        Keep the first exposure when the first set has no saturated pixel (one set captured):
        what a strategy that must give the conventional result on an unsaturated scene
        (Requirement 4) asks for.

    Returns
    -------
    ExposureChoice

    Raises
    ------
    InputError
        A rig without an exposure time (and no ``start_ms``), or a bad parameter.

    References
    ----------
    Thesis Sec. 7.3 (exposure as the rough adjustment, MIGL as the fine one), Eq. 3.4.

    Examples
    --------
    A dark plate (reflectivity 0.15) reads a modulation of about 9 DN at the reference 10 ms;
    the choice brings it to the 4-step target of 53 DN (a small camera: a coarse pitch):

    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> from hdrfringe.rig.scenes import plate
    >>> rig = SimulatedRig(plate(0.0, 0.15), camera=CameraModel(width=64, height=48))
    >>> choice = choose_exposure(rig, FringeSpec("sinusoidal", 4, 64.0))
    >>> 50 < choice.exposure_ms < 60, choice.sets_captured
    (True, 2)
    >>> abs(choice.darkest_modulation_dn / choice.target_modulation_dn - 1) < 0.15
    True
    """
    check_fringe_spec(spec, rig)
    bits = rig.camera_bit_depth
    target = (
        default_target_modulation(spec.steps, bits)
        if target_modulation_dn is None
        else float(target_modulation_dn)
    )
    if not (math.isfinite(target) and target > 0):
        raise InputError(f"target modulation must be a positive number of DN, got {target}")
    _check_positive("start exposure", start_ms)
    _check_positive("min exposure", min_exposure_ms)
    _check_positive("max exposure", max_exposure_ms)
    if not (math.isfinite(tolerance) and 0 <= tolerance < 1):
        raise InputError(f"exposure tolerance must be in 0..1, got {tolerance}")
    if isinstance(max_captures, bool) or not isinstance(max_captures, int) or max_captures < 1:
        raise InputError(f"max_captures must be a whole number >= 1, got {max_captures!r}")
    t = rig_exposure(rig, "choose_exposure") if start_ms is None else float(start_ms)
    lo = t / 256.0 if min_exposure_ms is None else float(min_exposure_ms)
    hi = t * 16.0 if max_exposure_ms is None else float(max_exposure_ms)
    if lo > hi:
        raise InputError(f"min exposure {lo:g} ms exceeds max exposure {hi:g} ms")
    frames = spec.frames()
    captures: list[tuple[float, NDArray]] = []
    dark: float | None = None
    limited: str | None = None
    for _ in range(max_captures):
        imgs = rig.capture(frames, CameraSettings(exposure_ms=t))
        captures.append((t, imgs))
        dark = darkest_modulation(imgs, spec, bits, percentile=percentile)
        if keep_if_unsaturated and len(captures) == 1 and unsaturated_mask(imgs, bits).all():
            break
        if dark is None:
            clipped = not unsaturated_mask(imgs, bits).any()
            wanted = t / 4.0 if clipped else t * 4.0
        else:
            wanted = t * target / dark
        new = min(max(wanted, lo), hi)
        limited = "max_exposure" if wanted > hi else "min_exposure" if wanted < lo else None
        if abs(new / t - 1.0) <= tolerance:
            break
        t = _round_ms(new)
    else:
        limited = limited or "captures"
    last_t = captures[-1][0]
    scaled = None if dark is None else dark * t / last_t
    return ExposureChoice(t, target, scaled, spec, tuple(captures), limited)


def _round_ms(t: float) -> float:
    """An exposure to 4 significant digits (cameras set whole microseconds at best)."""
    return float(f"{t:.4g}")


def _frame_key(frame: Frame) -> str:
    """A frame's identity: its manifest entry without the file name, numbers as floats (as
    :class:`~hdrfringe.rig.replay.ReplayRig` keys frames)."""
    entry: dict[str, Any] = frame.manifest_entry("")
    entry.pop("file", None)
    norm = {
        k: float(v) if isinstance(v, int | float) and not isinstance(v, bool) else v
        for k, v in entry.items()
    }
    return json.dumps(norm, sort_keys=True, default=str)


class FixedExposureRig(RigBase):
    """A rig that captures at one exposure time; optionally serves held images once.

    Wraps any rig so that a strategy which knows nothing of exposure (the MIGL strategies)
    runs at ``exposure_ms``; ``held`` images of frames already captured at that exposure (the
    last set of :func:`choose_exposure`) are returned for the first request of those frames
    instead of capturing them again.

    Parameters
    ----------
    rig : Rig
        The rig that captures.
    exposure_ms : float
        Exposure of every capture.
    held : sequence of (Frame, ndarray), optional
        Images already captured at ``exposure_ms``.

    Attributes
    ----------
    fresh_images : int
        Images captured on ``rig`` (held images served are not counted).

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> base = SimulatedRig(white_plate(), camera=CameraModel(width=8, height=6))
    >>> frames = FringeSpec("sinusoidal", 4, 8.0).frames()
    >>> held = base.capture(frames, CameraSettings(exposure_ms=5.0))
    >>> rig = FixedExposureRig(base, 5.0, zip(frames, held))
    >>> bool(np.array_equal(rig.capture(frames), held)), rig.fresh_images
    (True, 0)
    >>> _ = rig.capture(frames); rig.fresh_images, rig.camera_settings.exposure_ms
    (4, 5.0)
    """

    def __init__(
        self,
        rig: Rig,
        exposure_ms: float,
        held: Sequence[tuple[Frame, NDArray]] | Any = (),
    ) -> None:
        _check_positive("exposure", exposure_ms)
        self.rig = rig
        self.exposure_ms = float(exposure_ms)
        self._held = {_frame_key(f): img for f, img in held}
        self.fresh_images = 0

    @property
    def camera_bit_depth(self) -> int:
        """The wrapped rig's bit depth."""
        return self.rig.camera_bit_depth

    @property
    def image_shape(self) -> tuple[int, int]:
        """The wrapped rig's image shape."""
        return self.rig.image_shape

    @property
    def projector(self) -> ProjectorInfo:
        """The wrapped rig's projector."""
        return self.rig.projector

    @property
    def camera_settings(self) -> CameraSettings:  # type: ignore[override]
        """The wrapped rig's settings with this exposure."""
        return CameraSettings(self.exposure_ms, self.rig.camera_settings.gain_db)

    def capture(
        self, frames: Sequence[Frame], settings: CameraSettings | None = None
    ) -> NDArray[np.integer]:
        """Images of ``frames`` at the fixed exposure (held ones served once).

        Parameters
        ----------
        frames : sequence of Frame
            What the projector shows.
        settings : CameraSettings, optional
            Its exposure, if any, must be the fixed one; a gain is passed on.

        Returns
        -------
        ndarray (n, H, W)
        """
        frames = list(frames)
        gain = None if settings is None else settings.gain_db
        if settings is not None and settings.exposure_ms not in (None, self.exposure_ms):
            raise InputError(
                f"this rig captures at {self.exposure_ms:g} ms only, asked for "
                f"{settings.exposure_ms:g} ms; capture on the wrapped rig instead"
            )
        keys = [_frame_key(f) for f in frames]
        if keys and gain is None and all(k in self._held for k in keys):
            return np.stack([self._held.pop(k) for k in keys])
        self.fresh_images += len(frames)
        return self.rig.capture(frames, CameraSettings(self.exposure_ms, gain))


def run_at_exposure(
    rig: Rig,
    spec: FringeSpec,
    strategy: str | None = None,
    params: Any = None,
    *,
    choice: ExposureChoice | None = None,
    method: str | None = None,
    **choose: Any,
) -> tuple[ExposureChoice, StrategyResult, int]:
    """A registered strategy run at an automatically chosen exposure (thesis Sec. 7.3).

    :func:`choose_exposure` (or the ``choice`` given) sets the exposure; the strategy then runs
    on a :class:`FixedExposureRig` that serves the choice's last set (captured at that
    exposure and the highest MIGL) instead of capturing it again.

    Parameters
    ----------
    rig : Rig
        Any rig whose exposure time can be set.
    spec : FringeSpec
        The set, at its highest MIGL.
    strategy : str
        A registered strategy (e.g. ``"uniform"``, ``"lpa"``); required.
    params : Params or mapping, optional
        Its parameters (a mapping goes through :func:`~hdrfringe.strategies.make_params`).
    choice : ExposureChoice, optional
        An exposure already chosen; None: choose one now.
    method : str, optional
        Deprecated spelling of ``strategy`` (a :class:`DeprecationWarning`).
    **choose
        Keyword arguments of :func:`choose_exposure`.

    Returns
    -------
    choice : ExposureChoice
        The exposure and the sets captured to choose it.
    result : StrategyResult
        The strategy's result; every captured set records the exposure.
    images_captured : int
        Every image captured: the choice's plus the strategy's fresh ones.

    References
    ----------
    Thesis Sec. 7.3 (exposure and MIGL together).

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> from hdrfringe.rig.scenes import plate
    >>> rig = SimulatedRig(plate(0.0, 0.15), camera=CameraModel(width=64, height=48))
    >>> choice, res, n = run_at_exposure(rig, FringeSpec("sinusoidal", 4, 64.0), "uniform")
    >>> res.captured[0].exposure_ms == choice.exposure_ms, n == choice.images_captured
    (True, True)
    """
    name = renamed_keyword("run_at_exposure", "strategy", strategy, "method", method)
    if name is None:
        raise InputError("run_at_exposure needs a strategy: give strategy=NAME, e.g. 'uniform'")
    chosen = get_strategy(name)
    if params is None:
        p = make_params(name)
    elif isinstance(params, chosen.Params):
        p = params
    else:
        p = make_params(name, **dict(params))
    if choice is None:
        choice = choose_exposure(rig, spec, **choose)
    elif choose:
        raise InputError("give either an exposure choice or choose_exposure's options, not both")
    last = choice.last_at_choice
    frames = spec.frames()
    held = list(zip(frames, last, strict=True)) if last is not None else []
    fixed = FixedExposureRig(rig, choice.exposure_ms, held)
    res = chosen.run(fixed, spec, p)
    res.captured = [dataclasses.replace(s, exposure_ms=choice.exposure_ms) for s in res.captured]
    res.details = {**res.details, "exposure_ms": choice.exposure_ms}
    return choice, res, choice.images_captured + fixed.fresh_images
