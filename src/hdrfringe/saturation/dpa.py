"""Dynamic pixel-wise adaptive strategy (thesis Ch. 6).

The loop of docs/dpa.md: capture at the highest MIGL; estimate each saturated pixel's true
highest intensity (Eq. 6.2 / least squares on the sinusoid, :mod:`.estimate`), correct it with
the trained polynomial (Sec. 6.1.2), turn the estimates into a CDF over the MIGL at which pixels
become unsaturated (Sec. 6.1.3); then scan the MIGL down one gray level at a time and capture only
where the threshold rule or the 0.01 % rule (:mod:`.dpa_rules`) asks; after each capture the
composite grows as in LPA (Eq. 5.1) and the CDF gets both of its updates.
"""

from __future__ import annotations

import numpy as np

from hdrfringe.errors import InputError
from hdrfringe.patterns import FringeSpec
from hdrfringe.phase import saturation_count
from hdrfringe.rig.base import Rig
from hdrfringe.saturation.dpa_rules import (
    capture_rule,
    initial_dpa_state,
    next_capture_migl,
    update_dpa_state,
)
from hdrfringe.saturation.estimate import CorrectionPolynomial, peak_and_trough
from hdrfringe.saturation.strategies import (
    StrategyResult,
    default_min_migl,
    merge_into_composite,
)


def dpa(
    rig: Rig,
    spec: FringeSpec,
    *,
    threshold: float = 0.1,
    correction: CorrectionPolynomial | None = None,
    min_migl: float | None = None,
) -> StrategyResult:
    """Run DPA on ``rig`` for the sinusoidal set ``spec`` (N >= 4; thesis Ch. 6).

    Parameters
    ----------
    threshold : float
        CDF gain since the last capture that triggers the next one (0.1 and 0.2 in the thesis).
    correction : CorrectionPolynomial, optional
        The trained error correction (Sec. 6.1.2); None: no correction (identity).
    min_migl : float, optional
        Lowest MIGL (default ``imin + 20``).

    Returns
    -------
    StrategyResult
        ``details`` holds the capture rules that fired (``rules``), the CDF estimated from the
        first set (``initial_cdf``) and after the last update (``final_cdf``), both
        :class:`~hdrfringe.saturation.dpa_rules.SaturationCDF`, and the pixels saturated in the
        first set (``saturated_at_top``; thesis Fig. 6.3 compares the CDFs with the actual one).
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
            composite,
            spec,
            index,
            migls,
            newly,
            remaining,
            "dpa",
            {"threshold": threshold, "rules": ["initial"]},
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
    while remaining.any():
        nxt = next_capture_migl(state.cdf, m, state.last_captured_cdf_value, threshold)
        if nxt is None or nxt < floor:
            break
        rule = capture_rule(state.cdf, nxt, state.last_captured_cdf_value, threshold) or "lowest"
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
    return StrategyResult(
        composite,
        spec,
        index,
        migls,
        newly,
        remaining,
        "dpa",
        {
            "threshold": threshold,
            "rules": rules,
            "min_migl": floor,
            "initial_cdf": initial_cdf,
            "final_cdf": state.cdf,
            "saturated_at_top": saturated_at_top,
        },
    )
