"""Saturation-tolerant measurement: one set (plus its inverted set), decoded from the shifts
that did not clip (:mod:`hdrfringe.core.saturation.tolerant`).

No MIGL is lowered: the strategy captures the set at its MIGL and leaves the saturation to the
decoder. The result carries ``decoder`` (:class:`~hdrfringe.strategies.base.DecoderSettings`):
:func:`hdrfringe.pipeline.measure` then decodes the composite with
:func:`hdrfringe.core.saturation.tolerant.decode_set_tolerant` (through
:func:`hdrfringe.core.decode.decode_captures`, ``saturated="exclude"``) instead of invalidating
every pixel with a saturated shift.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hdrfringe.core._validation import unsaturated_mask
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.saturation.tolerant import inverted_spec
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.rig.base import Rig
from hdrfringe.rig.replay import ReplayRig
from hdrfringe.strategies.base import (
    CapturedSet,
    DecoderSettings,
    ExtraSet,
    FunctionStrategy,
    StrategyResult,
    capture_set,
    check_fringe_spec,
    register,
)

__all__ = ["Tolerant", "TolerantParams", "tolerant"]


def tolerant(
    rig: Rig,
    spec: FringeSpec,
    *,
    inverted: bool = False,
    min_shifts: int = 3,
    migl: float | None = None,
) -> StrategyResult:
    """One set at ``migl``, decoded from each pixel's unsaturated shifts.

    With ``inverted``, the inverted set (:func:`~hdrfringe.core.saturation.tolerant.inverted_spec`)
    is captured too, but only when the first set saturates somewhere: with nothing saturated
    the result is the conventional one, bit for bit (the thesis's requirement 4).

    Parameters
    ----------
    rig : Rig
        Any rig (virtual, replay, hardware).
    spec : FringeSpec
        A sinusoidal set (N >= 3), at its highest MIGL.
    inverted : bool
        Also capture the inverted set when the first one saturates.
    min_shifts : int
        Least number of unsaturated images a pixel needs (3 .. N, or 2N with an inverted set).
    migl : float, optional
        MIGL to project the set at (default ``spec.migl``).

    Returns
    -------
    StrategyResult
        ``images``: the set; ``captured``: one or two sets at ``migl``; ``decoder``: the
        saturation-tolerant one with ``min_shifts``; ``details["inverted"]``: whether the
        inverted set was captured and, when it was, ``extra_sets``: that set.

    Raises
    ------
    InputError
        A triangular set, ``min_shifts`` out of range, a MIGL the projector cannot show.

    References
    ----------
    Thesis Eq. 2.2, Ch. 3 (saturation); Jiang et al. 2016 (inverted fringes).

    Examples
    --------
    >>> from hdrfringe.rig.factory import virtual_rig
    >>> rig = virtual_rig("checkerboard", resolution=(64, 48))
    >>> res = tolerant(rig, FringeSpec("sinusoidal", 4, 8.0), inverted=True)
    >>> res.sets_captured, res.decoder.min_shifts, res.extra_sets[0].images.shape
    (2, 3, (4, 48, 64))
    """
    check_fringe_spec(spec, rig)
    if spec.pattern != "sinusoidal":
        raise InputError(
            f"the tolerant strategy needs sinusoidal fringes, got {spec.pattern}; use "
            "--pattern sinusoidal or another strategy"
        )
    top = float(spec.migl if migl is None else migl)
    if not spec.imin < top:
        raise InputError(
            f"tolerant MIGL {top:g} must be above imin {spec.imin:g}; give a higher MIGL"
        )
    most = 2 * spec.steps if inverted else spec.steps
    if isinstance(min_shifts, bool) or not isinstance(min_shifts, int | np.integer):
        raise InputError(f"min_shifts must be an integer 3..{most}, got {min_shifts!r}")
    if not 3 <= min_shifts <= most:
        raise InputError(
            f"min_shifts must be 3..{most} for a {spec.steps}-step set"
            f"{' and its inverted set' if inverted else ''}, got {min_shifts}"
        )
    set_spec = spec.with_migl(top)
    check_fringe_spec(set_spec, rig)
    imgs = capture_set(rig, spec, top)
    bits = rig.camera_bit_depth
    unsat = unsaturated_mask(imgs, bits)
    captured = [CapturedSet(migl=top)]
    newly = [int(unsat.sum())]
    never = ~unsat
    details: dict = {"inverted": False}
    extra: tuple[ExtraSet, ...] = ()
    if inverted and never.any():
        inv_spec = inverted_spec(set_spec)
        try:
            inv = rig.capture(inv_spec.frames())
        except CaptureFormatError as exc:
            if not isinstance(rig, ReplayRig):
                raise
            raise InputError(
                f"tolerant --inverted: the replayed folder holds no inverted set (phase offset "
                f"180 deg) of {set_spec.label()}, and a MIGL sweep never does; drop --inverted, "
                "or measure on a live rig (--rig sim or --rig hardware)"
            ) from exc
        inv_unsat = unsaturated_mask(inv, bits)
        captured.append(CapturedSet(migl=top))
        newly.append(int((never & inv_unsat).sum()))
        never = never & ~inv_unsat
        details.update(inverted=True)
        extra = (ExtraSet(inv_spec, inv),)
    return StrategyResult(
        images=imgs,
        spec=spec,
        captured=captured,
        index_map=np.full(imgs.shape[1:], top, dtype=np.float32),
        newly_unsaturated=newly,
        never_unsaturated=never,
        strategy="tolerant",
        details=details,
        extra_sets=extra,
        decoder=DecoderSettings(min_shifts=int(min_shifts)),
    )


@dataclass(frozen=True)
class TolerantParams:
    """Parameters of :func:`tolerant`.

    Parameters
    ----------
    inverted : bool
        Also capture the inverted set where the first saturates (``--inverted``).
    min_shifts : int
        Least number of unsaturated images per pixel (``--min-shifts``).
    migl : float, optional
        MIGL of the set (``--tolerant-migl``; default: the set's highest MIGL).

    References
    ----------
    Thesis Ch. 3; Jiang et al. 2016.

    Examples
    --------
    >>> TolerantParams(inverted=True)
    TolerantParams(inverted=True, min_shifts=3, migl=None)
    """

    inverted: bool = field(
        default=False,
        metadata={
            "help": "also capture the inverted set (180 degrees) where the first saturates.",
            "cli": "--inverted",
            "exclusive": True,
        },
    )
    min_shifts: int = field(
        default=3,
        metadata={
            "help": "least number of unsaturated shifts a pixel needs (>= 3).",
            "cli": "--min-shifts",
            "exclusive": True,
        },
    )
    migl: float | None = field(
        default=None,
        metadata={
            "help": "MIGL of the set (default: the highest MIGL).",
            "cli": "--tolerant-migl",
            "exclusive": True,
        },
    )


@register
class Tolerant(FunctionStrategy):
    """The registry's ``tolerant``: :func:`tolerant`.

    Examples
    --------
    >>> Tolerant().describe(TolerantParams(inverted=True))
    'tolerant + inverted'
    """

    name = "tolerant"
    title = "Tolerant"
    help = "one set (plus its inverted set), phase from each pixel's unsaturated shifts"
    Params = TolerantParams
    function = staticmethod(tolerant)

    def describe(self, params: TolerantParams) -> str:
        """Label of a run: ``"tolerant"``, ``"tolerant + inverted"``.

        Parameters
        ----------
        params : TolerantParams
            The parameters.

        Returns
        -------
        str

        Examples
        --------
        >>> Tolerant().describe(TolerantParams())
        'tolerant'
        """
        return "tolerant + inverted" if params.inverted else "tolerant"
