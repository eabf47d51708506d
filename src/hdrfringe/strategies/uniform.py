"""Non-adaptive uniform adjustment of the MIGL (thesis Ch. 4): one MIGL for every pixel."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from hdrfringe.core._validation import check_tolerance, unsaturated_mask
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.rig.base import Rig
from hdrfringe.strategies.base import (
    CapturedSet,
    FunctionStrategy,
    RunContext,
    StrategyResult,
    capture_set,
    check_fringe_spec,
    default_min_migl,
    register,
)

__all__ = ["Uniform", "UniformParams", "uniform"]


def uniform(
    rig: Rig,
    spec: FringeSpec,
    *,
    migl: float | None = None,
    tolerance: float = 0.0,
    min_migl: float | None = None,
    candidates: Sequence[float] | None = None,
) -> StrategyResult:
    """Non-adaptive uniform adjustment of the MIGL (thesis Ch. 4).

    The set at the highest MIGL is captured first; if its saturated fraction is at most
    ``tolerance`` it is the result (requirement 4). Otherwise one MIGL is used for every pixel:
    ``migl`` when given (the trade-off MIGL from
    :func:`~hdrfringe.pipeline.tradeoff_search`), else the highest MIGL whose saturated
    fraction is at most ``tolerance``, found by bisection over integer MIGLs between
    ``min_migl`` and the top (the saturated fraction never increases as the MIGL falls), which
    needs about log2(range) sets. ``candidates`` restricts the search to given MIGLs (a replayed
    sweep holds only its own).

    Why this automatic rule: saturation biases the phase by far more than the noise a
    moderately lower MIGL adds (thesis Fig. 4.13: the RMSE rises steeply above the trade-off and
    gently below), so the best single MIGL is close to the highest one that does not saturate;
    needing no ground truth, it works on any part.

    Parameters
    ----------
    rig : Rig
        Any rig (virtual, replay, hardware).
    spec : FringeSpec
        The set, at its highest MIGL.
    migl : float, optional
        The trade-off MIGL; None: found automatically.
    tolerance : float
        Saturated fraction allowed (0..1; anything else raises
        :class:`~hdrfringe.errors.InputError` naming ``--tolerance``).
    min_migl : float, optional
        Lowest MIGL (default ``imin + 20``).
    candidates : sequence of float, optional
        MIGLs the automatic search may use.

    Returns
    -------
    StrategyResult
        ``details`` holds ``chosen_migl``, ``saturated_fraction`` (MIGL -> fraction, for every
        set captured) and ``tolerance``.

    References
    ----------
    Thesis Ch. 4, Sec. 4.2 (the trade-off MIGL) and Fig. 4.13.

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> cam = CameraModel(width=64, height=48)  # a small camera keeps the example fast
    >>> rig = SimulatedRig(white_plate(), camera=cam, lighting=Lighting(ambient_lux=600))
    >>> res = uniform(rig, FringeSpec("sinusoidal", 4, 8.0), migl=180.0)
    >>> res.migls, res.details["chosen_migl"]
    ([255.0, 180.0], 180.0)
    """
    check_tolerance(tolerance)
    check_fringe_spec(spec, rig)
    bits = rig.camera_bit_depth
    lo_limit = default_min_migl(spec) if min_migl is None else float(min_migl)
    top = capture_set(rig, spec, spec.migl)
    captured = {float(spec.migl): top}
    order = [float(spec.migl)]
    fractions = {float(spec.migl): float(1.0 - unsaturated_mask(top, bits).mean())}
    if fractions[spec.migl] <= tolerance:
        chosen = float(spec.migl)
    elif migl is not None:
        if not lo_limit <= migl <= spec.migl:
            raise InputError(f"uniform MIGL {migl:g} outside {lo_limit:g}..{spec.migl:g}")
        chosen = float(migl)
    else:
        if candidates is None:
            grid = [float(m) for m in range(int(np.ceil(lo_limit)), int(np.floor(spec.migl)))]
        else:
            grid = sorted(float(m) for m in candidates if lo_limit <= m < spec.migl)
        if not grid:
            raise InputError(f"uniform: no MIGL to try between {lo_limit:g} and {spec.migl:g}")
        lo, hi = 0, len(grid) - 1  # bisection over grid indices (ascending MIGL)
        best = grid[0]
        while lo <= hi:
            mid = (lo + hi + 1) // 2
            m = grid[mid]
            imgs = capture_set(rig, spec, m)
            captured[m] = imgs
            order.append(m)
            frac = float(1.0 - unsaturated_mask(imgs, bits).mean())
            fractions[m] = frac
            if frac <= tolerance:
                best = m
                lo = mid + 1
            else:
                hi = mid - 1
        chosen = best
    if chosen not in captured:
        captured[chosen] = capture_set(rig, spec, chosen)
        order.append(chosen)
    imgs = captured[chosen]
    unsat = unsaturated_mask(imgs, bits)
    return StrategyResult(
        images=imgs,
        spec=spec,
        captured=[CapturedSet(migl=m) for m in order],
        index_map=np.full(imgs.shape[1:], chosen, dtype=np.float32),
        newly_unsaturated=[0] * (len(order) - 1) + [int(unsat.sum())],
        never_unsaturated=~unsat,
        strategy="uniform",
        details={"chosen_migl": chosen, "saturated_fraction": fractions, "tolerance": tolerance},
    )


@dataclass(frozen=True)
class UniformParams:
    """Parameters of :func:`uniform`.

    Parameters
    ----------
    migl : float, optional
        The trade-off MIGL (``--uniform-migl``); None: found automatically.
    tolerance : float
        Saturated fraction allowed, 0..1 (``--tolerance``).
    min_migl : float, optional
        Lowest MIGL (default ``imin + 20``).
    candidates : sequence of float, optional
        The MIGLs the automatic search may use (default every integer MIGL).

    References
    ----------
    Thesis Ch. 4, Sec. 4.2 (the trade-off MIGL).

    Examples
    --------
    >>> UniformParams(migl=180.0).tolerance
    0.0
    >>> UniformParams(tolerance=float("nan"))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --tolerance (uniform: saturated fraction allowed) must be ...
    """

    migl: float | None = field(
        default=None,
        metadata={"help": "the trade-off MIGL (default: automatic).", "cli": "--uniform-migl"},
    )
    tolerance: float = field(
        default=0.0,
        metadata={
            "help": "saturated fraction allowed (automatic MIGL).",
            "cli": "--tolerance",
        },
    )
    min_migl: float | None = field(
        default=None, metadata={"help": "lowest MIGL (default: imin + 20)."}
    )
    candidates: Sequence[float] | None = field(
        default=None,
        metadata={"help": "the MIGLs the automatic search may use (default: every integer)."},
    )

    def __post_init__(self) -> None:
        """Refuse a tolerance outside 0..1 (:func:`hdrfringe.core._validation.check_tolerance`)."""
        check_tolerance(self.tolerance)


@register
class Uniform(FunctionStrategy):
    """The registry's ``uniform``: :func:`uniform`.

    Examples
    --------
    >>> Uniform().describe(UniformParams())
    'uniform auto'
    """

    name = "uniform"
    title = "Uniform"
    help = "one MIGL for every pixel (Ch. 4): given, or the highest that does not saturate"
    Params = UniformParams
    function = staticmethod(uniform)

    def describe(self, params: UniformParams) -> str:
        """Label of a run: ``"uniform auto"``, or ``"uniform MIGL <m>"`` with a given MIGL.

        Parameters
        ----------
        params : UniformParams
            The parameters.

        Returns
        -------
        str

        Examples
        --------
        >>> Uniform().describe(UniformParams(migl=180.0))
        'uniform MIGL 180'
        """
        return "uniform auto" if params.migl is None else f"uniform MIGL {params.migl:g}"

    def prepare(self, params: UniformParams, context: RunContext) -> UniformParams:
        """On a replayed MIGL sweep, the automatic search chooses among the sweep's MIGLs.

        Parameters
        ----------
        params : UniformParams
            The parameters.
        context : RunContext
            What the measurement offers (``available_migls`` on a replay).

        Returns
        -------
        UniformParams
            ``candidates`` set to the sweep's MIGLs when neither a MIGL nor candidates were
            given; else ``params``.

        Examples
        --------
        >>> Uniform().prepare(UniformParams(), RunContext(available_migls=[180.0])).candidates
        [180.0]
        >>> Uniform().prepare(UniformParams(migl=200.0), RunContext([180.0])).candidates is None
        True
        """
        if context.available_migls is None or params.migl is not None:
            return params
        if params.candidates is not None:
            return params
        return dataclasses.replace(params, candidates=context.available_migls)
