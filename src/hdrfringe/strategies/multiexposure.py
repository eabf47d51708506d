"""Multi-exposure fusion (Zhang & Yau 2009): fringe sets at several exposure times, MIGL fixed.

Every set is projected at the highest MIGL; only the camera's exposure time changes. Each
pixel's composite intensities are the N shifts of the *longest* exposure at which none of them
is saturated (the brightest unsaturated, hence the highest modulation); a pixel saturated at
every exposure takes the shortest one's and is reported in ``never_unsaturated``. The phase is
unchanged by the exposure (it scales every shift of a pixel alike), so the composite decodes as
one set. The index map holds each pixel's exposure (``index_quantity = "exposure_ms"``).

Automatic exposures (``exposures="auto"``, the default), on the geometric grid
``t0 * ratio^k`` around the rig's exposure ``t0``:

1. the set at ``t0``; if no pixel saturates it is the result (the thesis's requirement 4: the
   conventional measurement, bit for bit, after one set);
2. **down**: while some pixel is saturated in the shortest set so far, the next shorter
   exposure ``t / ratio`` (down to ``min_exposure_ms``): the first exposure that leaves the
   brightest pixels unclipped is found from the sets themselves, and each of them serves the
   pixels of intermediate brightness;
3. **up**: while the darkest valid modulation at the longest exposure so far
   (:func:`~hdrfringe.strategies.exposure.darkest_modulation`: the 1st percentile of I' over
   the lit pixels unsaturated there; the pixels saturated there already have their exposure)
   is below the target (:func:`~hdrfringe.strategies.exposure.default_target_modulation`,
   53 DN for N = 4 at 8 bits), the next longer exposure ``t * ratio``, the last one clipped to
   ``max_exposure_ms``;
4. at most ``max_sets`` sets in all.

An explicit list captures exactly those exposures, in the order given, and fuses them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core._validation import unsaturated_mask
from hdrfringe.core.captures import CameraSettings
from hdrfringe.core.frames import Frame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.rig.base import Rig
from hdrfringe.rig.replay import ReplayRig
from hdrfringe.strategies.base import (
    CapturedSet,
    FunctionStrategy,
    StrategyResult,
    check_fringe_spec,
    register,
)
from hdrfringe.strategies.exposure import (
    darkest_modulation,
    default_target_modulation,
    rig_exposure,
)

__all__ = [
    "MultiExposure",
    "MultiExposureParams",
    "fuse_exposures",
    "multiexposure",
    "parse_exposures",
]


def parse_exposures(exposures: str | Sequence[float]) -> tuple[float, ...] | None:
    """``"auto"`` (None) or the exposure times of a list: ``"2.5,5,10"`` or a sequence.

    Parameters
    ----------
    exposures : str or sequence of float
        ``"auto"``, comma-separated milliseconds, or numbers.

    Returns
    -------
    tuple of float or None
        The exposures in the order given; None for ``"auto"``.

    Raises
    ------
    InputError
        An empty list, a value that is not a positive number, or a repeated exposure.

    Examples
    --------
    >>> parse_exposures("auto") is None, parse_exposures("2.5, 10,5")
    (True, (2.5, 10.0, 5.0))
    """
    if isinstance(exposures, str):
        text = exposures.strip()
        if text.lower() == "auto":
            return None
        parts = [p.strip() for p in text.split(",")]
        try:
            values = [float(p) for p in parts]
        except ValueError:
            raise InputError(
                f"--exposures {exposures!r}: give 'auto' or comma-separated milliseconds, "
                "e.g. 2.5,5,10,20"
            ) from None
    else:
        values = [float(v) for v in exposures]
    if not values or any(not (math.isfinite(v) and v > 0) for v in values):
        raise InputError(f"exposures must be positive milliseconds, got {exposures!r}")
    if len(set(values)) != len(values):
        raise InputError(f"exposures {exposures!r} repeat a value; give each exposure once")
    return tuple(values)


def fuse_exposures(
    stacks: Sequence[NDArray], exposures_ms: Sequence[float], bit_depth: int
) -> tuple[NDArray, NDArray[np.float32], NDArray[np.bool_], NDArray[np.intp]]:
    """Per pixel the set of the longest exposure where none of its shifts is saturated.

    Parameters
    ----------
    stacks : sequence of ndarray (N, H, W)
        One phase-shifted set per exposure.
    exposures_ms : sequence of float
        Their exposure times (distinct).
    bit_depth : int
        Camera bit depth B (saturated: ``2^B - 1``,
        :func:`hdrfringe.core._validation.is_saturated`).

    Returns
    -------
    composite : ndarray (N, H, W)
        The fused set, in the stacks' dtype.
    index_map : ndarray (H, W) float32
        Each pixel's exposure.
    never_unsaturated : ndarray (H, W) bool
        Pixels saturated at every exposure (they take the shortest).
    chosen : ndarray (H, W) intp
        Each pixel's set, an index into ``stacks``.

    References
    ----------
    Zhang & Yau 2009 (high dynamic range scanning by multiple exposures); thesis Eq. 5.1 is the
    same rule over MIGLs.

    Examples
    --------
    >>> short = np.array([[[100, 60]], [[120, 80]], [[90, 70]]], np.uint8)
    >>> long = np.array([[[200, 120]], [[255, 160]], [[180, 140]]], np.uint8)
    >>> comp, idx, never, chosen = fuse_exposures([short, long], [5.0, 10.0], 8)
    >>> comp[:, 0].tolist(), idx.tolist(), chosen.tolist()
    ([[100, 120], [120, 160], [90, 140]], [[5.0, 10.0]], [[0, 1]])
    """
    if len(stacks) != len(exposures_ms) or not stacks:
        raise InputError(
            f"fuse_exposures: {len(stacks)} sets for {len(exposures_ms)} exposures; give one "
            "exposure per set"
        )
    times = [float(t) for t in exposures_ms]
    if len(set(times)) != len(times):
        raise InputError("fuse_exposures: exposures repeat; give each exposure once")
    shape = stacks[0].shape
    for s in stacks:
        if s.shape != shape:
            raise InputError(f"fuse_exposures: set shapes {s.shape} and {shape} differ")
    order = sorted(range(len(times)), key=lambda k: times[k], reverse=True)  # longest first
    chosen = np.full(shape[1:], -1, dtype=np.intp)
    for k in order:
        take = (chosen < 0) & unsaturated_mask(stacks[k], bit_depth)
        chosen[take] = k
    never = chosen < 0
    chosen[never] = order[-1]  # the shortest exposure: the least saturated
    composite = np.empty_like(stacks[0])
    for k, s in enumerate(stacks):
        here = chosen == k
        composite[:, here] = s[:, here]
    index = np.asarray(times, dtype=np.float32)[chosen]
    return composite, index, never, chosen


def multiexposure(
    rig: Rig,
    spec: FringeSpec,
    *,
    exposures: str | Sequence[float] = "auto",
    ratio: float = 2.0,
    min_exposure_ms: float | None = None,
    max_exposure_ms: float | None = None,
    target_modulation_dn: float | None = None,
    max_sets: int = 12,
) -> StrategyResult:
    """Multi-exposure fusion (Zhang & Yau 2009), automatic exposures by default.

    See the module docstring for the rule (:mod:`hdrfringe.strategies.multiexposure`).

    Parameters
    ----------
    rig : Rig
        Any rig whose exposure time can be set; ``"auto"`` needs its current exposure.
    spec : FringeSpec
        The set, at its (fixed) highest MIGL.
    exposures : str or sequence of float
        ``"auto"``, or the exposure times in ms (a sequence or comma-separated text).
    ratio : float
        Automatic exposures: the factor between neighbours (> 1).
    min_exposure_ms, max_exposure_ms : float, optional
        Automatic exposures: the limits (default 1/256 and 16 times the rig's exposure).
    target_modulation_dn : float, optional
        Automatic exposures: the modulation the darkest valid pixels should reach (default
        :func:`~hdrfringe.strategies.exposure.default_target_modulation`).
    max_sets : int
        Automatic exposures: the most sets captured.

    Returns
    -------
    StrategyResult
        ``index_quantity`` ``"exposure_ms"``, ``index_map`` each pixel's exposure; every
        :class:`~hdrfringe.strategies.CapturedSet` records its exposure and the MIGL;
        ``details`` holds ``exposures_ms`` (capture order), ``ratio``,
        ``target_modulation_dn``, ``darkest_modulation_dn`` (at the longest exposure, None
        when no pixel was valid there) and ``stop`` (why the automatic search stopped).

    Raises
    ------
    InputError
        Bad parameters, or ``"auto"`` on a replayed folder (it cannot change the exposure)
        or on a rig that reports no exposure time.

    References
    ----------
    Zhang & Yau 2009; thesis Sec. 3.2 (their method) and Sec. 7.3.

    Examples
    --------
    >>> from hdrfringe.rig.factory import virtual_rig
    >>> rig = virtual_rig("specular_part", resolution=(64, 48))
    >>> res = multiexposure(rig, FringeSpec("sinusoidal", 4, 64.0))
    >>> res.details["exposures_ms"]
    [10.0, 5.0, 2.5, 1.25, 20.0, 40.0, 80.0]
    >>> bool(res.never_unsaturated.any()), res.index_quantity
    (False, 'exposure_ms')
    """
    check_fringe_spec(spec, rig)
    if not (math.isfinite(ratio) and ratio > 1):
        raise InputError(f"exposure ratio must be a number > 1, got {ratio}")
    if isinstance(max_sets, bool) or not isinstance(max_sets, int) or max_sets < 1:
        raise InputError(f"max_sets must be a whole number >= 1, got {max_sets!r}")
    for name, v in (("min", min_exposure_ms), ("max", max_exposure_ms)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(f"{name} exposure must be a positive number of ms, got {v}")
    bits = rig.camera_bit_depth
    target = (
        default_target_modulation(spec.steps, bits)
        if target_modulation_dn is None
        else float(target_modulation_dn)
    )
    if not (math.isfinite(target) and target > 0):
        raise InputError(f"target modulation must be a positive number of DN, got {target}")
    frames = spec.frames()
    listed = parse_exposures(exposures)
    stacks: list[NDArray] = []
    times: list[float] = []
    stop = "list"
    dark: float | None = None
    if listed is not None:
        for t in listed:
            stacks.append(rig.capture(frames, CameraSettings(exposure_ms=t)))
            times.append(t)
    else:
        if isinstance(rig, ReplayRig):
            raise InputError(
                "multiexposure with exposures 'auto' captures at exposures it chooses, which a "
                "replayed folder cannot; measure on a live rig (--rig sim or --rig hardware), "
                "or give the exposures the folder holds (--exposures 2.5,10,40)"
            )
        t0 = rig_exposure(rig, "multiexposure with exposures 'auto'")
        lo = t0 / 256.0 if min_exposure_ms is None else float(min_exposure_ms)
        hi = t0 * 16.0 if max_exposure_ms is None else float(max_exposure_ms)
        if lo > hi:
            raise InputError(f"min exposure {lo:g} ms exceeds max exposure {hi:g} ms")
        stacks.append(rig.capture(frames))  # the rig's own settings: the conventional set
        times.append(t0)
        stop = "nothing saturated"
        if not unsaturated_mask(stacks[0], bits).all():
            stop = _walk_down(rig, frames, stacks, times, bits, ratio, lo, max_sets)
            stop, dark = _walk_up(rig, spec, stacks, times, bits, ratio, hi, max_sets, target)
    composite, index, never, chosen = fuse_exposures(stacks, times, bits)
    # per set, the pixels whose composite comes from it unsaturated
    newly = [int(((chosen == k) & ~never).sum()) for k in range(len(stacks))]
    return StrategyResult(
        images=composite,
        spec=spec,
        captured=[CapturedSet(migl=float(spec.migl), exposure_ms=t) for t in times],
        index_map=index,
        newly_unsaturated=newly,
        never_unsaturated=never,
        strategy="multiexposure",
        index_quantity="exposure_ms",
        details={
            "exposures_ms": times,
            "ratio": ratio,
            "target_modulation_dn": target,
            "darkest_modulation_dn": dark,
            "stop": stop,
        },
    )


def _walk_down(
    rig: Rig,
    frames: Sequence[Frame],
    stacks: list[NDArray],
    times: list[float],
    bits: int,
    ratio: float,
    lo: float,
    max_sets: int,
) -> str:
    """Shorter exposures until nothing saturates in the shortest (step 2 of the rule)."""
    t = times[0]
    while True:
        if unsaturated_mask(stacks[-1], bits).all():
            return "unclipped"
        if len(stacks) >= max_sets:
            return "max_sets"
        if t / ratio < lo * (1 - 1e-9):
            return "min_exposure"
        t = t / ratio
        stacks.append(rig.capture(frames, CameraSettings(exposure_ms=t)))
        times.append(t)


def _walk_up(
    rig: Rig,
    spec: FringeSpec,
    stacks: list[NDArray],
    times: list[float],
    bits: int,
    ratio: float,
    hi: float,
    max_sets: int,
    target: float,
) -> tuple[str, float | None]:
    """Longer exposures until the darkest valid pixels reach the target (step 3 of the rule)."""
    frames = spec.frames()
    longest = max(range(len(times)), key=lambda k: times[k])
    t = times[longest]
    dark = darkest_modulation(stacks[longest], spec, bits)
    while True:
        if dark is None:
            return "no valid pixel at the longest exposure", dark
        if dark >= target:
            return "target reached", dark
        if len(stacks) >= max_sets:
            return "max_sets", dark
        if t >= hi * (1 - 1e-9):
            return "max_exposure", dark
        t = min(t * ratio, hi)
        stacks.append(rig.capture(frames, CameraSettings(exposure_ms=t)))
        times.append(t)
        dark = darkest_modulation(stacks[-1], spec, bits)


@dataclass(frozen=True)
class MultiExposureParams:
    """Parameters of :func:`multiexposure`.

    Parameters
    ----------
    exposures : str
        ``"auto"`` or comma-separated exposure times in ms (``--exposures``).
    ratio : float
        Factor between automatic exposures, > 1 (``--exposure-ratio``).
    max_exposure_ms : float, optional
        Longest automatic exposure (``--max-exposure-ms``; default 16x the rig's).
    min_exposure_ms : float, optional
        Shortest automatic exposure (default 1/256 of the rig's).
    target_modulation_dn : float, optional
        Modulation the darkest valid pixels should reach (``--target-modulation``; default
        from the noise model, 53 DN for 4 steps at 8 bits).
    max_sets : int
        Most sets of an automatic run (``--max-sets``).

    References
    ----------
    Zhang & Yau 2009.

    Examples
    --------
    >>> MultiExposureParams(exposures="5,10,20").ratio
    2.0
    >>> MultiExposureParams(exposures="5,x")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --exposures '5,x': give 'auto' or comma-separated ...
    """

    exposures: str = field(
        default="auto",
        metadata={
            "help": "'auto' or comma-separated exposure times in ms.",
            "cli": "--exposures",
        },
    )
    ratio: float = field(
        default=2.0,
        metadata={"help": "factor between automatic exposures (> 1).", "cli": "--exposure-ratio"},
    )
    max_exposure_ms: float | None = field(
        default=None,
        metadata={
            "help": "longest automatic exposure in ms (default: 16x the rig's).",
            "cli": "--max-exposure-ms",
        },
    )
    min_exposure_ms: float | None = field(
        default=None, metadata={"help": "shortest automatic exposure in ms (default: 1/256x)."}
    )
    target_modulation_dn: float | None = field(
        default=None,
        metadata={
            "help": "modulation in DN the darkest valid pixels should reach (default: from "
            "the noise model, 53 DN for 4 steps at 8 bits).",
            "cli": "--target-modulation",
        },
    )
    max_sets: int = field(
        default=12, metadata={"help": "most sets of an automatic run.", "cli": "--max-sets"}
    )

    def __post_init__(self) -> None:
        """Refuse an exposure list that does not parse (:func:`parse_exposures`)."""
        parse_exposures(self.exposures)


@register
class MultiExposure(FunctionStrategy):
    """The registry's ``multiexposure``: :func:`multiexposure`.

    Examples
    --------
    >>> MultiExposure().describe(MultiExposureParams())
    'multi-exposure auto x2'
    """

    name = "multiexposure"
    title = "Multi-exposure"
    help = "sets at several exposure times, MIGL fixed (Zhang & Yau 2009)"
    Params = MultiExposureParams
    function = staticmethod(multiexposure)

    def describe(self, params: MultiExposureParams) -> str:
        """Label of a run: ``"multi-exposure auto x<ratio>"`` or the exposures given.

        Parameters
        ----------
        params : MultiExposureParams
            The parameters.

        Returns
        -------
        str

        Examples
        --------
        >>> MultiExposure().describe(MultiExposureParams(exposures="5,10,20"))
        'multi-exposure 5,10,20 ms'
        """
        listed = parse_exposures(params.exposures)
        if listed is None:
            return f"multi-exposure auto x{params.ratio:g}"
        return f"multi-exposure {','.join(f'{t:g}' for t in listed)} ms"
