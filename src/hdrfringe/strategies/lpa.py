"""LPA: pixel-wise MIGL in linear steps (thesis Ch. 5, Eq. 5.1, its "linear pixel-wise
adaptive method"; not the per-pixel adaptive projection, :mod:`hdrfringe.strategies.adaptive`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hdrfringe.core._validation import unsaturated_mask
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.rig.base import Rig
from hdrfringe.strategies.base import (
    CapturedSet,
    FunctionStrategy,
    StrategyResult,
    capture_set,
    check_fringe_spec,
    default_min_migl,
    merge_into_composite,
    register,
)

__all__ = ["LPA", "LPAParams", "lpa"]


def lpa(
    rig: Rig,
    spec: FringeSpec,
    *,
    step: float = 5.0,
    min_migl: float | None = None,
) -> StrategyResult:
    """Linear pixel-wise adaptive method (thesis Ch. 5, Eq. 5.1).

    Sets are captured at ``migl, migl - S, migl - 2S, ...``; every pixel's composite intensities
    are those of the highest MIGL at which none of its N shifts is saturated. The loop stops when
    no pixel is saturated, or when the next MIGL would fall below ``min_migl`` (default
    ``imin + 20``: lower MIGLs no longer carry a usable fringe). Pixels still saturated then are
    reported in ``never_unsaturated`` and take the lowest MIGL's intensities.

    Parameters
    ----------
    rig : Rig
        Any rig (virtual, replay, hardware).
    spec : FringeSpec
        The set, at its highest MIGL.
    step : float
        The MIGL step S in gray levels (> 0).
    min_migl : float, optional
        Lowest MIGL (default ``imin + 20``).

    Returns
    -------
    StrategyResult
        ``index_map`` is the MIGL index image N(x, y) (Fig. 5.2c); ``details`` holds ``step``
        and ``min_migl``.

    References
    ----------
    Thesis Ch. 5, Eq. 5.1 and Fig. 5.2.

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> cam = CameraModel(width=64, height=48)  # a small camera keeps the example fast
    >>> rig = SimulatedRig(white_plate(), camera=cam, lighting=Lighting(ambient_lux=600))
    >>> res = lpa(rig, FringeSpec("sinusoidal", 4, 8.0), step=30)
    >>> res.migls[:3], bool(res.never_unsaturated.any())
    ([255.0, 225.0, 195.0], False)
    """
    check_fringe_spec(spec, rig)
    if not step > 0:
        raise InputError(f"LPA step must be a positive number of gray levels, got {step}")
    bits = rig.camera_bit_depth
    floor = default_min_migl(spec) if min_migl is None else float(min_migl)
    imgs = capture_set(rig, spec, spec.migl)
    composite = imgs.copy()
    unsat = unsaturated_mask(imgs, bits)
    remaining = ~unsat
    index = np.full(imgs.shape[1:], spec.migl, dtype=np.float32)
    migls = [float(spec.migl)]
    newly = [int(unsat.sum())]
    m = float(spec.migl)
    while remaining.any() and m - step >= floor - 1e-9:
        m = round(m - step, 9)
        imgs = capture_set(rig, spec, m)
        newly.append(
            merge_into_composite(composite, index, remaining, imgs, unsaturated_mask(imgs, bits), m)
        )
        migls.append(m)
    return StrategyResult(
        images=composite,
        spec=spec,
        captured=[CapturedSet(migl=x) for x in migls],
        index_map=index,
        newly_unsaturated=newly,
        never_unsaturated=remaining,
        strategy="lpa",
        details={"step": step, "min_migl": floor},
    )


@dataclass(frozen=True)
class LPAParams:
    """Parameters of :func:`lpa`.

    Parameters
    ----------
    step : float
        The MIGL step S in gray levels, > 0 (``--step``).
    min_migl : float, optional
        Lowest MIGL (default ``imin + 20``).

    References
    ----------
    Thesis Sec. 5.1 (the constant step) and Sec. 5.2.2 (steps of 1 to 45 gray levels).

    Examples
    --------
    >>> LPAParams(step=15.0)
    LPAParams(step=15.0, min_migl=None)
    """

    step: float = field(
        default=5.0, metadata={"help": "MIGL step S in gray levels.", "cli": "--step"}
    )
    min_migl: float | None = field(
        default=None, metadata={"help": "lowest MIGL (default: imin + 20)."}
    )


@register
class LPA(FunctionStrategy):
    """The registry's ``lpa``: :func:`lpa`.

    Examples
    --------
    >>> LPA().describe(LPAParams(step=5.0))
    'LPA S=5'
    """

    name = "lpa"
    title = "LPA"
    help = "pixel-wise MIGL, linear steps (Ch. 5): sets every S gray levels down from the top"
    Params = LPAParams
    function = staticmethod(lpa)

    def describe(self, params: LPAParams) -> str:
        """Label of a run: ``"LPA S=<step>"``.

        Parameters
        ----------
        params : LPAParams
            The parameters.

        Returns
        -------
        str

        Examples
        --------
        >>> LPA().describe(LPAParams(step=15.0))
        'LPA S=15'
        """
        return f"LPA S={params.step:g}"
