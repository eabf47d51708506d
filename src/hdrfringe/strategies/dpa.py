"""DPA: pixel-wise MIGL in dynamic steps (thesis Ch. 6, its "dynamic pixel-wise adaptive
method"; not the per-pixel adaptive projection, :mod:`hdrfringe.strategies.adaptive`).

The loop of docs/dpa.md: capture at the highest MIGL; estimate each saturated pixel's true
highest intensity (Eq. 6.2 / least squares on the sinusoid,
:mod:`hdrfringe.core.saturation.estimate`), correct it with the trained polynomial (Sec. 6.1.2),
turn the estimates into a CDF over the MIGL at which pixels become unsaturated (Sec. 6.1.3); then
scan the MIGL down one gray level at a time and capture only where the threshold rule or the 0.01 %
rule (:mod:`hdrfringe.core.saturation.dpa_rules`) asks; after each capture the composite grows as in
LPA (Eq. 5.1) and the CDF gets both of its updates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from hdrfringe.core._validation import saturation_count
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.saturation.dpa_rules import (
    SaturationCDF,
    capture_rule,
    initial_dpa_state,
    next_capture_migl,
    update_dpa_state,
)
from hdrfringe.core.saturation.estimate import (
    CorrectionPolynomial,
    peak_and_trough,
    saturated_peak_lower_bound,
    unsaturation_migl,
)
from hdrfringe.errors import InputError
from hdrfringe.rig.base import Rig
from hdrfringe.strategies.base import (
    CapturedSet,
    FunctionStrategy,
    MetricsContext,
    StrategyMetrics,
    StrategyResult,
    default_min_migl,
    merge_into_composite,
    register,
)

__all__ = ["BOUND_MARGIN_DN", "DPA", "DPAParams", "bounded_cdf", "dpa"]

#: DN taken off the peak bound before it becomes a MIGL: the bound is exact up to the
#: rounding of the unsaturated samples (at most 1.5 DN: 2 x 0.5 through the mean, 0.5 through
#: the lowest sample).
BOUND_MARGIN_DN = 1.5


def bounded_cdf(
    cdf: SaturationCDF,
    pending: np.ndarray,
    images: np.ndarray,
    n_saturated: np.ndarray,
    capture_migl: float,
    imin: float,
    bit_depth: int,
) -> SaturationCDF:
    """The CDF with each pending pixel at the highest MIGL it could unsaturate at (provisional).

    Beyond the thesis's Sec. 6.1.3: a pending pixel (too many shifts saturated for the
    estimate) has a lower bound on its peak
    (:func:`~hdrfringe.core.saturation.estimate.saturated_peak_lower_bound`); under the MIGL scaling
    with the smallest possible offset (0) that bound becomes an upper bound on the MIGL at which
    the pixel stops saturating. Nothing is learnt about it by capturing above that MIGL, so the
    capture rules may skip there. The entries are provisional: recomputed from every capture,
    never stored in the state's CDF (the thesis's updates move pixels into it when they become
    estimable or unsaturated).

    Parameters
    ----------
    cdf : SaturationCDF
        The state's CDF.
    pending : ndarray (H, W) bool
        Pixels saturated at the top whose estimate is still pending.
    images : ndarray (N, H, W)
        The last set captured, at ``capture_migl``.
    n_saturated : ndarray (H, W)
        Saturated shifts per pixel in ``images``.
    capture_migl : float
        MIGL of ``images``.
    imin : float
        Minimum input gray level of the set.
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    SaturationCDF
        ``cdf`` with the bounded pending pixels added below ``capture_migl`` (``cdf`` itself
        when no pending pixel has a bound).

    References
    ----------
    Thesis Sec. 6.1.3 (the CDF); the bound is docs/dpa.md's "pending pixels".

    Examples
    --------
    >>> from hdrfringe.core.saturation.dpa_rules import SaturationCDF
    >>> cdf = SaturationCDF(np.zeros(256, np.int64), total=1, migl0=255, lowest_migl=60)
    >>> imgs = np.array([[[255]], [[255]], [[255]], [[100]]], np.uint8)  # 3 of 4 saturated
    >>> out = bounded_cdf(cdf, np.array([[True]]), imgs, np.array([[3]]), 255.0, 40.0, 8)
    >>> out.accounted, int(np.flatnonzero(out.counts)[0])
    (1, 174)

    The peak is at least ``2 * 255 - 100 - 1.5 = 408.5`` DN, which stops saturating at MIGL
    ``40 + 215 * 254.5 / 408.5 = 173.95`` (Eq. 6.3's scaled variant), rounded up.
    """
    bound = saturated_peak_lower_bound(images, bit_depth) - BOUND_MARGIN_DN
    use = pending & (n_saturated > 0) & np.isfinite(bound)
    if not use.any():
        return cdf
    m_up = unsaturation_migl(bound[use], capture_migl, imin, bit_depth, model="scaled", offset=0.0)
    return cdf.add(np.ceil(m_up), ceiling=capture_migl - 1)


def dpa(
    rig: Rig,
    spec: FringeSpec,
    *,
    threshold: float = 0.1,
    correction: CorrectionPolynomial | None = None,
    min_migl: float | None = None,
    bound_pending: bool = False,
) -> StrategyResult:
    """Run DPA on ``rig`` for the sinusoidal set ``spec`` (N >= 4; thesis Ch. 6).

    Parameters
    ----------
    rig : Rig
        Any rig (virtual, replay, hardware).
    spec : FringeSpec
        A sinusoidal set of at least 4 steps, at its highest MIGL.
    threshold : float
        CDF gain since the last capture that triggers the next one (0.1 and 0.2 in the thesis).
    correction : CorrectionPolynomial, optional
        The trained error correction (Sec. 6.1.2); None: no correction (identity).
    min_migl : float, optional
        Lowest MIGL (default ``imin + 20``).
    bound_pending : bool
        Beyond the thesis: where the lowest-MIGL rule would capture at the next gray level (no
        estimated pixel left below: the CDF is flat), place the pixels that cannot be estimated
        yet at the highest MIGL they could become unsaturated (:func:`bounded_cdf`) and apply
        the rules to that CDF instead (rule ``"bound"``). On a board whose white squares
        saturate in three of four shifts the thesis's rule captures at every gray level while
        they wait; the bound skips those sets. Off by default: the thesis's method as written.

    Returns
    -------
    StrategyResult
        ``details`` holds the capture rules that fired (``rules``), the CDF estimated from the
        first set (``initial_cdf``) and after the last update (``final_cdf``), both
        :class:`~hdrfringe.core.saturation.dpa_rules.SaturationCDF`, and the pixels saturated in the
        first set (``saturated_at_top``; thesis Fig. 6.3 compares the CDFs with the actual one).

    Raises
    ------
    InputError
        When ``spec`` is not a sinusoidal set of at least 4 steps.

    References
    ----------
    Thesis Ch. 6 (Sec. 6.1.1-6.1.3, Fig. 6.2); docs/dpa.md.

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> cam = CameraModel(width=64, height=48)  # a small camera keeps the example fast
    >>> rig = SimulatedRig(white_plate(), camera=cam, lighting=Lighting(ambient_lux=600))
    >>> res = dpa(rig, FringeSpec("sinusoidal", 4, 8.0), threshold=0.2)
    >>> res.details["rules"][0], res.migls[0], bool(res.never_unsaturated.any())
    ('initial', 255.0, False)
    """
    if spec.pattern != "sinusoidal" or spec.steps < 4:
        raise InputError(
            f"DPA needs a sinusoidal set of at least 4 steps (an extra shift to estimate a "
            f"saturated one, Eq. 6.2); got {spec.pattern} {spec.steps}-step"
        )
    corr = CorrectionPolynomial.identity() if correction is None else correction
    bits = rig.camera_bit_depth
    floor = default_min_migl(spec) if min_migl is None else float(min_migl)
    imgs = rig.capture(spec.frames())
    n_sat = saturation_count(imgs, bits)
    remaining = n_sat > 0
    composite = imgs.copy()
    index = np.full(imgs.shape[1:], spec.migl, dtype=np.float32)
    migls = [float(spec.migl)]
    newly = [int((~remaining).sum())]
    if not remaining.any():  # requirement 4: the conventional result after one set
        return StrategyResult(
            images=composite,
            spec=spec,
            captured=[CapturedSet(migl=m) for m in migls],
            index_map=index,
            newly_unsaturated=newly,
            never_unsaturated=remaining,
            strategy="dpa",
            details={"threshold": threshold, "rules": ["initial"]},
        )
    saturated_at_top = remaining.copy()
    peak, trough = peak_and_trough(imgs, bits, remaining)
    state = initial_dpa_state(
        corr.apply(peak),
        n_sat,
        spec.migl,
        spec.imin,
        bit_depth=bits,
        model=corr.truth,
        offset=trough,
        lowest_migl=floor,
    )
    initial_cdf = state.cdf
    rules = ["initial"]
    m = float(spec.migl)

    bounds_from = (imgs, n_sat, m)  # the capture the pending pixels' bounds come from
    while remaining.any():
        nxt = next_capture_migl(state.cdf, m, state.last_captured_cdf_value, threshold)
        if nxt is None or nxt < floor:
            break
        rule = capture_rule(state.cdf, nxt, state.last_captured_cdf_value, threshold) or "lowest"
        if bound_pending and rule == "lowest":
            # the thesis would step one gray level into a flat CDF: jump instead to where the
            # pending pixels could first become unsaturated (the rules on the bounded CDF)
            bounded = bounded_cdf(state.cdf, state.pending, *bounds_from, spec.imin, bits)
            alt = next_capture_migl(bounded, m, state.last_captured_cdf_value, threshold)
            if alt is not None and floor <= alt < nxt:
                nxt, rule = alt, "bound"
        imgs = rig.capture(spec.with_migl(float(nxt)).frames())
        n_sat = saturation_count(imgs, bits)
        n_new = merge_into_composite(composite, index, remaining, imgs, n_sat == 0, nxt)
        # the CDF updates only read the pixels still pending: fit those alone
        peak, trough = peak_and_trough(imgs, bits, state.pending & (n_sat > 0))
        state = update_dpa_state(
            state,
            corr.apply(peak),
            n_sat,
            nxt,
            spec.imin,
            rule=rule,
            bit_depth=bits,
            model=corr.truth,
            offset=trough,
        )
        migls.append(float(nxt))
        newly.append(n_new)
        rules.append(rule)
        m = float(nxt)
        bounds_from = (imgs, n_sat, m)
    return StrategyResult(
        images=composite,
        spec=spec,
        captured=[CapturedSet(migl=m) for m in migls],
        index_map=index,
        newly_unsaturated=newly,
        never_unsaturated=remaining,
        strategy="dpa",
        details={
            "threshold": threshold,
            "rules": rules,
            "min_migl": floor,
            "bound_pending": bound_pending,
            "initial_cdf": initial_cdf,
            "final_cdf": state.cdf,
            "saturated_at_top": saturated_at_top,
        },
    )


@dataclass(frozen=True)
class DPAParams:
    """Parameters of :func:`dpa`.

    Parameters
    ----------
    threshold : float
        CDF gain since the last capture that triggers the next one (``--threshold``; 0.1 and
        0.2 in the thesis).
    correction : CorrectionPolynomial, optional
        The trained error correction (``--correction``, Sec. 6.1.2); None: the identity.
    min_migl : float, optional
        Lowest MIGL (default ``imin + 20``).
    bound_pending : bool
        Beyond the thesis: where the CDF is flat, jump to the highest MIGL at which the pixels
        too saturated to estimate could unsaturate (``--bound-pending``; see :func:`dpa`).

    References
    ----------
    Thesis Ch. 6 (Sec. 6.1.2-6.1.3).

    Examples
    --------
    >>> DPAParams(threshold=0.2).bound_pending
    False
    """

    threshold: float = field(
        default=0.1,
        metadata={"help": "CDF gain that triggers a capture (0.1 = 10 %).", "cli": "--threshold"},
    )
    correction: CorrectionPolynomial | None = field(
        default=None,
        metadata={
            "help": "trained correction polynomial (Sec. 6.1.2; default: none, identity).",
            "cli": "--correction",
        },
    )
    min_migl: float | None = field(
        default=None, metadata={"help": "lowest MIGL (default: imin + 20)."}
    )
    bound_pending: bool = field(
        default=False,
        metadata={
            "help": "beyond the thesis: where the CDF is flat, jump to the highest MIGL at "
            "which the pixels too saturated to estimate could unsaturate (fewer sets).",
            "cli": "--bound-pending",
            "exclusive": True,
        },
    )


@register
class DPA(FunctionStrategy):
    """The registry's ``dpa``: :func:`dpa`.

    Examples
    --------
    >>> DPA().describe(DPAParams(threshold=0.1, bound_pending=True))
    'DPA 10 % + bound'
    """

    name = "dpa"
    title = "DPA"
    help = (
        "pixel-wise MIGL, dynamic steps (Ch. 6): sets where the estimated CDF says pixels "
        "unsaturate"
    )
    Params = DPAParams
    function = staticmethod(dpa)

    def describe(self, params: DPAParams) -> str:
        """Label of a run: ``"DPA <threshold> %"``, with ``" + bound"`` for ``bound_pending``.

        Parameters
        ----------
        params : DPAParams
            The parameters.

        Returns
        -------
        str

        Examples
        --------
        >>> DPA().describe(DPAParams(threshold=0.2))
        'DPA 20 %'
        """
        bound = " + bound" if params.bound_pending else ""
        return f"DPA {100 * params.threshold:g} %{bound}"

    def metrics(
        self, results: Sequence[StrategyResult], context: MetricsContext
    ) -> StrategyMetrics:
        """The ``dpa`` block (thesis Fig. 6.3): the estimated and actual CDFs per pitch.

        On a replayed sweep that holds the set at every integer MIGL down to DPA's lowest
        capture, the exact actual CDF comes from LPA with step 1 on it
        (:func:`~hdrfringe.strategies.dpa_analysis.dpa_cdfs`): DPA captured only some of
        those MIGLs, so its own sets give the CDF quantised to them (``actual``), not that.

        Parameters
        ----------
        results : sequence of StrategyResult
            One per pitch, coarsest first.
        context : MetricsContext
            The parameters, the replayed sweep (None on a live rig) and where the correction
            was read from (``param_sources["correction"]``).

        Returns
        -------
        StrategyMetrics
            ``metrics["dpa"]``: :class:`~hdrfringe.strategies.dpa_analysis.DPAMetrics`;
            ``result["dpa"]``: one :class:`~hdrfringe.strategies.dpa_analysis.DPACDFs` per
            pitch.

        Examples
        --------
        >>> out = DPA().metrics([], MetricsContext(DPAParams()))
        >>> out.metrics["dpa"].correction, out.result["dpa"]
        ('none (identity)', ())
        """
        from hdrfringe.strategies.dpa_analysis import DPAMetrics, dpa_cdfs

        p = context.params
        cdfs = tuple(dpa_cdfs(r, context.replay) for r in results)
        if "correction" in context.param_sources:
            correction = str(context.param_sources["correction"])
        else:
            correction = "none (identity)" if p.correction is None else "given (not from a file)"
        block = DPAMetrics.of(
            cdfs, threshold=p.threshold, correction=correction, bound_pending=p.bound_pending
        )
        return StrategyMetrics(metrics={"dpa": block}, result={"dpa": cdfs})
