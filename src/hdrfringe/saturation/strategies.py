"""Saturation-avoidance strategies: which fringe sets to capture, and the composite they make.

A strategy drives any :class:`~hdrfringe.rig.base.Rig` (the live virtual rig, a replay of a
capture folder, hardware) and returns a :class:`StrategyResult`: the composite phase-shifted
images, the MIGL index image ``N(x, y)`` (thesis Fig. 5.2c), the MIGLs captured in order, and per
step the number of newly unsaturated pixels. The phase, unwrapping and height stages only see
the composite images; they do not know which strategy made them.

Strategies (thesis Ch. 4-6):

* :func:`conventional`: one set at the highest MIGL.
* :func:`uniform`: one MIGL for every pixel (Ch. 4): the highest MIGL if nothing saturates, else
  a given trade-off MIGL, or found automatically as the highest MIGL whose saturated fraction is
  at most a tolerance (bisection on the monotone saturated fraction).
* :func:`lpa`: linear pixel-wise adaptive (Ch. 5, Eq. 5.1): constant step S down from the highest
  MIGL; each pixel takes the highest MIGL at which none of its N shifts is saturated.

The thesis's requirement 4 holds for every strategy: when no pixel saturates at the highest
MIGL, the result is the conventional one, bit for bit, after one set.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from hdrfringe.errors import InputError
from hdrfringe.patterns import FringeSpec
from hdrfringe.rig.base import Rig


@dataclass
class StrategyResult:
    """What a strategy returns.

    Attributes
    ----------
    images : ndarray (N, H, W)
        Composite phase-shifted images (camera dtype), shift 0 first.
    spec : FringeSpec
        The set as projected at the highest MIGL (pattern, steps, pitch, orientation, imin).
    migl_index : ndarray (H, W) float32
        MIGL whose capture each pixel's composite intensities come from (Fig. 5.2c).
    migls : list of float
        MIGLs captured, in capture order.
    newly_unsaturated : list of int
        Per captured set, the pixels that became unsaturated (copied to the composite) there.
    never_unsaturated : ndarray (H, W) bool
        Pixels saturated in every set captured (their composite comes from the lowest MIGL).
    method : str
    details : dict
        Strategy-specific information (e.g. the uniform strategy's saturated fractions).
    """

    images: NDArray
    spec: FringeSpec
    migl_index: NDArray[np.float32]
    migls: list[float]
    newly_unsaturated: list[int]
    never_unsaturated: NDArray[np.bool_]
    method: str
    details: dict = field(default_factory=dict)

    @property
    def sets_captured(self) -> int:
        return len(self.migls)

    @property
    def images_captured(self) -> int:
        return len(self.migls) * self.spec.steps


def _capture_set(rig: Rig, spec: FringeSpec, migl: float) -> NDArray:
    return rig.capture(spec.with_migl(float(migl)).frames())


def _unsaturated(images: NDArray, bit_depth: int) -> NDArray[np.bool_]:
    """True where none of the N shifts is at ``2^B - 1`` (Eq. 5.1's condition)."""
    full = 2**bit_depth - 1
    out = np.ones(images.shape[1:], dtype=bool)
    for img in images:
        out &= img < full
    return out


def merge_into_composite(
    composite: NDArray,
    index: NDArray[np.float32],
    remaining: NDArray[np.bool_],
    images: NDArray,
    unsaturated: NDArray[np.bool_],
    migl: float,
) -> int:
    """One step of Eq. 5.1, in place; returns the number of newly unsaturated pixels.

    Pixels still ``remaining`` (saturated in every set so far) that are ``unsaturated`` in
    ``images`` (captured at ``migl``) take these intensities and leave ``remaining``; pixels
    still saturated carry the least-saturated (lowest-MIGL) intensities so far.
    """
    new = remaining & unsaturated
    composite[:, new] = images[:, new]
    index[new] = migl
    remaining &= ~new
    composite[:, remaining] = images[:, remaining]
    index[remaining] = migl
    return int(new.sum())


def _check(spec: FringeSpec, rig: Rig) -> None:
    if not isinstance(spec, FringeSpec):
        raise InputError(f"strategy needs a FringeSpec, got {type(spec).__name__}")
    full = 2**rig.projector.bit_depth - 1
    if spec.migl > full:
        raise InputError(f"highest MIGL {spec.migl:g} exceeds the projector's {full}")


def conventional(rig: Rig, spec: FringeSpec) -> StrategyResult:
    """One set at the highest MIGL (``spec.migl``): the conventional measurement."""
    _check(spec, rig)
    imgs = _capture_set(rig, spec, spec.migl)
    unsat = _unsaturated(imgs, rig.camera_bit_depth)
    return StrategyResult(
        images=imgs,
        spec=spec,
        migl_index=np.full(imgs.shape[1:], spec.migl, dtype=np.float32),
        migls=[float(spec.migl)],
        newly_unsaturated=[int(unsat.sum())],
        never_unsaturated=~unsat,
        method="conventional",
    )


def default_min_migl(spec: FringeSpec) -> float:
    """Lowest MIGL that still carries a fringe: ``imin + 20`` gray levels (amplitude b >= 10)."""
    return float(spec.imin + 20)


def uniform(
    rig: Rig,
    spec: FringeSpec,
    *,
    migl: float | None = None,
    tolerance: float = 0.0,
    min_migl: float | None = None,
    candidates: list[float] | None = None,
) -> StrategyResult:
    """Non-adaptive uniform adjustment of the MIGL (thesis Ch. 4).

    The set at the highest MIGL is captured first; if its saturated fraction is at most
    ``tolerance`` it is the result (requirement 4). Otherwise one MIGL is used for every pixel:
    ``migl`` when given (the trade-off MIGL from :func:`tradeoff_search`), else the highest
    MIGL whose saturated fraction is at most ``tolerance``, found by bisection over integer MIGLs
    between ``min_migl`` and the top (the saturated fraction never increases as the MIGL falls),
    which needs about log2(range) sets. ``candidates`` restricts the search to given MIGLs (a
    replayed sweep holds only its own).

    Why this automatic rule: saturation biases the phase by far more than the noise a
    moderately lower MIGL adds (thesis Fig. 4.13: the RMSE rises steeply above the trade-off and
    gently below), so the best single MIGL is close to the highest one that does not saturate;
    needing no ground truth, it works on any part.
    """
    _check(spec, rig)
    bits = rig.camera_bit_depth
    lo_limit = default_min_migl(spec) if min_migl is None else float(min_migl)
    top = _capture_set(rig, spec, spec.migl)
    captured = {float(spec.migl): top}
    order = [float(spec.migl)]
    fractions = {float(spec.migl): float(1.0 - _unsaturated(top, bits).mean())}
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
            imgs = _capture_set(rig, spec, m)
            captured[m] = imgs
            order.append(m)
            frac = float(1.0 - _unsaturated(imgs, bits).mean())
            fractions[m] = frac
            if frac <= tolerance:
                best = m
                lo = mid + 1
            else:
                hi = mid - 1
        chosen = best
    if chosen not in captured:
        captured[chosen] = _capture_set(rig, spec, chosen)
        order.append(chosen)
    imgs = captured[chosen]
    unsat = _unsaturated(imgs, bits)
    return StrategyResult(
        images=imgs,
        spec=spec,
        migl_index=np.full(imgs.shape[1:], chosen, dtype=np.float32),
        migls=order,
        newly_unsaturated=[0] * (len(order) - 1) + [int(unsat.sum())],
        never_unsaturated=~unsat,
        method="uniform",
        details={"chosen_migl": chosen, "saturated_fraction": fractions, "tolerance": tolerance},
    )


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
    """
    _check(spec, rig)
    if not step > 0:
        raise InputError(f"LPA step must be a positive number of gray levels, got {step}")
    bits = rig.camera_bit_depth
    floor = default_min_migl(spec) if min_migl is None else float(min_migl)
    imgs = _capture_set(rig, spec, spec.migl)
    composite = imgs.copy()
    unsat = _unsaturated(imgs, bits)
    remaining = ~unsat
    index = np.full(imgs.shape[1:], spec.migl, dtype=np.float32)
    migls = [float(spec.migl)]
    newly = [int(unsat.sum())]
    m = float(spec.migl)
    while remaining.any() and m - step >= floor - 1e-9:
        m = round(m - step, 9)
        imgs = _capture_set(rig, spec, m)
        newly.append(
            merge_into_composite(composite, index, remaining, imgs, _unsaturated(imgs, bits), m)
        )
        migls.append(m)
    return StrategyResult(
        images=composite,
        spec=spec,
        migl_index=index,
        migls=migls,
        newly_unsaturated=newly,
        never_unsaturated=remaining,
        method="lpa",
        details={"step": step, "min_migl": floor},
    )
