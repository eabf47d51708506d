"""The conventional measurement: one set at the highest MIGL (the thesis's reference, Ch. 4)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hdrfringe.core._validation import unsaturated_mask
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.rig.base import Rig
from hdrfringe.strategies.base import (
    CapturedSet,
    FunctionStrategy,
    StrategyResult,
    capture_set,
    check_fringe_spec,
    register,
)

__all__ = ["Conventional", "ConventionalParams", "conventional"]


def conventional(rig: Rig, spec: FringeSpec) -> StrategyResult:
    """One set at the highest MIGL (``spec.migl``): the conventional measurement.

    Parameters
    ----------
    rig : Rig
        Any rig (virtual, replay, hardware).
    spec : FringeSpec
        The set, at its highest MIGL.

    Returns
    -------
    StrategyResult
        One captured set; pixels saturated in it are ``never_unsaturated``.

    References
    ----------
    Thesis Ch. 4 (the conventional measurement every strategy is compared with).

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=64, height=48))
    >>> res = conventional(rig, FringeSpec("sinusoidal", 4, 8.0))
    >>> res.migls, res.images.shape, res.newly_unsaturated  # no pixel saturates
    ([255.0], (4, 48, 64), [3072])
    """
    check_fringe_spec(spec, rig)
    imgs = capture_set(rig, spec, spec.migl)
    unsat = unsaturated_mask(imgs, rig.camera_bit_depth)
    return StrategyResult(
        images=imgs,
        spec=spec,
        captured=[CapturedSet(migl=float(spec.migl))],
        index_map=np.full(imgs.shape[1:], spec.migl, dtype=np.float32),
        newly_unsaturated=[int(unsat.sum())],
        never_unsaturated=~unsat,
        strategy="conventional",
    )


@dataclass(frozen=True)
class ConventionalParams:
    """The conventional measurement has no parameters.

    Examples
    --------
    >>> ConventionalParams()
    ConventionalParams()
    """


@register
class Conventional(FunctionStrategy):
    """The registry's ``conventional``: :func:`conventional`.

    Examples
    --------
    >>> Conventional().describe(ConventionalParams())
    'conventional'
    """

    name = "conventional"
    title = "Conventional"
    help = "one set at the highest MIGL"
    Params = ConventionalParams
    function = staticmethod(conventional)
