"""The DPA step rules: CDF of saturated intensities, capture decisions, CDF updates (thesis 6.1.3).

Pure functions over arrays; the strategy loop that drives a rig lives elsewhere (see
``docs/dpa.md`` for the call order).

The CDF is kept as a histogram over integer MIGLs: ``counts[m]`` is the number of pixels
(saturated at the initial MIGL ``migl0``) expected to become unsaturated at MIGL ``m``, i.e.
``m`` is the highest MIGL at which all of their shifts are unsaturated. The CDF over decreasing
MIGL is ``F(m) = sum(counts[m:]) / total``: the fraction of the initially saturated pixels
expected unsaturated at or above ``m``. It grows as the MIGL falls. ``total`` counts every
pixel saturated at ``migl0``, also those not (yet) in the histogram because their intensity
could not be estimated, so ``F`` reaches 1 only once every saturated pixel is accounted for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core.saturation.estimate import TRUTH_MODELS, TruthModel, unsaturation_migl
from hdrfringe.errors import InputError

__all__ = [
    "LOWEST_MIGL_TOLERANCE",
    "DPAState",
    "SaturationCDF",
    "capture_rule",
    "index_image_cdf",
    "initial_dpa_state",
    "lowest_migl_rule",
    "next_capture_migl",
    "saturated_intensity_cdf",
    "threshold_rule",
    "update_cdf_with_newly_estimable",
    "update_cdf_with_newly_unsaturated",
    "update_dpa_state",
]

F64 = NDArray[np.float64]

#: The thesis's lowest-MIGL rule tolerance: 0.01 % (Sec. 6.1.3), as a fraction.
LOWEST_MIGL_TOLERANCE = 1e-4


@dataclass(frozen=True)
class SaturationCDF:
    """Histogram of unsaturation MIGLs and its CDF over decreasing MIGL (thesis Sec. 6.1.3).

    Parameters
    ----------
    counts : ndarray of int64, length ``migl0 + 1``
        ``counts[m]``: pixels expected to become unsaturated at MIGL ``m``. Only
        ``lowest_migl <= m < migl0`` are ever filled.
    total : int
        Pixels saturated at ``migl0`` (the denominator).
    migl0 : int
        Initial (highest) MIGL.
    lowest_migl : int
        Lowest MIGL the strategy may use.
    beyond : int
        Pixels expected to stay saturated even at ``lowest_migl`` (in ``total`` only).

    References
    ----------
    Thesis Sec. 6.1 and 6.1.3 (the CDF of the saturated intensities over the MIGL).

    Examples
    --------
    Four pixels saturated at MIGL 255; three unsaturate at 250, 240 and 230, one is unknown:

    >>> counts = np.zeros(256, dtype=np.int64)
    >>> counts[[230, 240, 250]] = 1
    >>> cdf = SaturationCDF(counts, total=4, migl0=255, lowest_migl=41)
    >>> cdf.at(255), cdf.at(245), cdf.at(230), cdf.accounted
    (0.0, 0.25, 0.75, 3)
    >>> more = cdf.add([236.4])  # the unknown one, unsaturated at MIGL 236.4
    >>> more.at(236), more.at(230), cdf.add([-np.inf]).beyond  # or never (below lowest_migl)
    (0.75, 1.0, 1)
    """

    counts: NDArray[np.int64]
    total: int
    migl0: int
    lowest_migl: int
    beyond: int = 0

    @property
    def values(self) -> F64:
        """``F(m)`` for ``m = 0..migl0`` (index = MIGL); constant below ``lowest_migl``."""
        if self.total == 0:
            return np.ones(self.migl0 + 1)
        tail = np.cumsum(self.counts[::-1])[::-1]
        return tail / float(self.total)

    def at(self, migl: float) -> float:
        """``F(migl)``: fraction of the initially saturated pixels unsaturated at or above it."""
        m = min(max(math.floor(migl + 1e-9), 0), self.migl0)
        if self.total == 0:
            return 1.0
        return float(self.counts[m:].sum()) / float(self.total)

    @property
    def accounted(self) -> int:
        """Pixels in the histogram."""
        return int(self.counts.sum())

    def add(self, migls: ArrayLike, ceiling: float | None = None) -> SaturationCDF:
        """A new CDF with pixels added at unsaturation MIGLs ``migls`` (continuous values).

        Each pixel goes to bin ``floor(m)``, clipped above to ``ceiling`` (default
        ``migl0 - 1``: a pixel saturated at a MIGL is unsaturated only below it); ``m`` below
        ``lowest_migl`` (including ``-inf``) counts in ``beyond``. NaN entries are ignored.
        """
        m = np.asarray(migls, dtype=np.float64).ravel()
        m = m[~np.isnan(m)]
        top = self.migl0 - 1 if ceiling is None else min(math.floor(ceiling), self.migl0)
        with np.errstate(invalid="ignore"):
            bins = np.floor(np.minimum(m, top) + 1e-9)
        below = bins < self.lowest_migl
        hist = np.bincount(bins[~below].astype(np.int64), minlength=self.migl0 + 1)
        return replace(
            self,
            counts=self.counts + hist[: self.migl0 + 1],
            beyond=self.beyond + int(below.sum()),
        )


def _empty_cdf(total: int, migl0: float, lowest_migl: float) -> SaturationCDF:
    top = round(migl0)
    if top != migl0 or top < 1:
        raise InputError(f"the initial MIGL must be a positive integer gray level, got {migl0}")
    low = math.ceil(lowest_migl)
    if not 0 <= low < top:
        raise InputError(
            f"lowest MIGL {lowest_migl} must be in 0..{top - 1} (below the initial MIGL {top})"
        )
    return SaturationCDF(np.zeros(top + 1, dtype=np.int64), int(total), top, low)


def saturated_intensity_cdf(
    estimates: ArrayLike,
    migl0: float,
    imin: float,
    *,
    bit_depth: int = 8,
    saturated: ArrayLike | None = None,
    offset: ArrayLike | None = None,
    model: TruthModel = "scaled",
    lowest_migl: float | None = None,
) -> SaturationCDF:
    """CDF of the saturated pixels' estimated true intensities, over decreasing MIGL (Sec. 6.1.3).

    Thesis Sec. 6.1.3: after correcting the estimates (Eq. 6.2 and the polynomial of Sec.
    6.1.2), a histogram is built and summed over the bins as the MIGL decreases, and divided by
    the number of saturated pixels. Here each estimate (the highest true intensity among the
    shifts at ``migl0``) is first converted to the MIGL at which the pixel becomes unsaturated,
    with the same model the correction was trained with
    (:func:`~hdrfringe.core.saturation.estimate.unsaturation_migl`): ``"thesis"``,
    ``m = migl0 - (I - (2^B - 1))`` (one DN per gray level, the inverse of Eq. 6.3), or
    ``"scaled"``, the pixel's own linear response with offset ``A`` (``offset``, required).

    Parameters
    ----------
    estimates : array_like
        Corrected peak estimates (DN), NaN where not estimable (e.g. two or more saturated
        shifts for N = 4).
    migl0 : float
        The MIGL the estimates refer to (the initial MIGL, an integer).
    imin : float
        The pattern's minimum input gray.
    bit_depth : int
        Camera bit depth B.
    saturated : array_like of bool, optional
        Pixels saturated at ``migl0`` (the denominator); default: every entry of ``estimates``.
        Only estimates inside it enter the histogram.
    offset : array_like, optional
        ``A`` per pixel for the scaled model (e.g. ``sinusoid_trough`` of the same images).
    model : {"scaled", "thesis"}
        Conversion of intensities to MIGL, the one the correction was trained with.
    lowest_migl : float, optional
        Lowest MIGL the strategy may use; default ``imin + 1``.

    Returns
    -------
    SaturationCDF
        The initial CDF; ``total`` counts every saturated pixel, estimable or not.

    Raises
    ------
    InputError
        Mismatched shapes, an unknown model, a non-integer ``migl0`` or a bad ``lowest_migl``.

    References
    ----------
    Thesis Sec. 6.1.3 (and Eq. 6.3 for the ``"thesis"`` conversion).

    Examples
    --------
    Four saturated pixels, one not estimable; under Eq. 6.3 a peak of 260 DN at MIGL 255
    unsaturates at MIGL 250:

    >>> cdf = saturated_intensity_cdf([260.0, 270.0, 280.0, np.nan], 255, 40, model="thesis")
    >>> cdf.total, np.flatnonzero(cdf.counts).tolist(), cdf.at(240)
    (4, [230, 240, 250], 0.5)
    """
    est = np.asarray(estimates, dtype=np.float64)
    sat = np.ones(est.shape, dtype=bool) if saturated is None else np.asarray(saturated, bool)
    if sat.shape != est.shape:
        raise InputError(
            f"saturated mask shape {sat.shape} does not match the estimates' {est.shape}"
        )
    low = math.floor(imin) + 1 if lowest_migl is None else lowest_migl
    cdf = _empty_cdf(int(sat.sum()), migl0, low)
    use = sat & np.isfinite(est)
    if model not in TRUTH_MODELS:
        raise InputError(f"unknown MIGL model {model!r}; use one of {', '.join(TRUTH_MODELS)}")
    off = None if offset is None else np.broadcast_to(np.asarray(offset, np.float64), est.shape)
    m = unsaturation_migl(
        est[use],
        cdf.migl0,
        imin,
        bit_depth,
        model=model,
        offset=None if off is None else off[use],
    )
    return cdf.add(m)


def index_image_cdf(
    index_image: ArrayLike,
    saturated: ArrayLike,
    migl0: float,
    lowest_migl: float,
) -> SaturationCDF:
    """The "actual" CDF (thesis Fig. 6.3a,c) from an LPA index image ``N(x, y)``.

    Each pixel saturated at ``migl0`` counts at its ``N``; negative or non-finite ``N`` (never
    unsaturated) count in ``beyond``.

    Parameters
    ----------
    index_image : array_like (H, W)
        ``N(x, y)`` from LPA with step 1 (negative or non-finite: never unsaturated).
    saturated : array_like of bool (H, W)
        Pixels saturated at ``migl0``.
    migl0 : float
        Initial MIGL (an integer).
    lowest_migl : float
        Lowest MIGL of the CDF.

    Returns
    -------
    SaturationCDF
        The CDF of the pixels' actual unsaturation MIGLs.

    References
    ----------
    Thesis Sec. 6.3, Fig. 6.3 (actual and estimated CDF); Sec. 5.1 (the index image).

    Examples
    --------
    >>> cdf = index_image_cdf([[250, 240, -1, 255]], [[True, True, True, False]], 255, 41)
    >>> cdf.total, cdf.beyond, round(cdf.at(240), 9)
    (3, 1, 0.666666667)
    """
    idx = np.asarray(index_image, dtype=np.float64)
    sat = np.asarray(saturated, dtype=bool)
    if idx.shape != sat.shape:
        raise InputError(f"index image shape {idx.shape} does not match the mask's {sat.shape}")
    cdf = _empty_cdf(int(sat.sum()), migl0, lowest_migl)
    n = idx[sat]
    n = np.where(np.isfinite(n) & (n >= 0), n, -np.inf)
    return cdf.add(n)


# --------------------------------------------------------------------------------------------
# capture rules
# --------------------------------------------------------------------------------------------
def _check_fraction(name: str, value: float) -> float:
    v = float(value)
    if not (math.isfinite(v) and 0.0 <= v <= 1.0):
        hint = f"; give {v / 100:g} for {v:g} %" if 1.0 < v <= 100.0 else ""
        raise InputError(f"{name} must be a fraction in [0, 1], got {value}{hint}")
    return v


def threshold_rule(
    cdf: SaturationCDF, migl: float, last_captured_cdf_value: float, threshold: float
) -> bool:
    """Thesis Sec. 6.1.3, threshold percentage: capture at ``migl`` when the CDF has grown by
    more than ``threshold`` (a fraction: 0.1 for 10 %) since the last captured MIGL.

    Parameters
    ----------
    cdf : SaturationCDF
        The current CDF.
    migl : float
        Candidate MIGL.
    last_captured_cdf_value : float
        CDF value at the last captured MIGL.
    threshold : float
        Fraction in [0, 1].

    Returns
    -------
    bool
        True when the rule asks for a capture at ``migl``.

    References
    ----------
    Thesis Sec. 6.1 and 6.1.3.

    Examples
    --------
    >>> cdf = saturated_intensity_cdf([260.0, 270.0, 280.0, np.nan], 255, 40, model="thesis")
    >>> threshold_rule(cdf, 250, 0.0, 0.2), threshold_rule(cdf, 250, 0.0, 0.3)
    (True, False)
    """
    t = _check_fraction("threshold", threshold)
    return cdf.at(migl) - float(last_captured_cdf_value) > t


def lowest_migl_rule(
    cdf: SaturationCDF, migl: float, tolerance: float = LOWEST_MIGL_TOLERANCE
) -> bool:
    """Thesis Sec. 6.1.3, lowest-MIGL rule: capture at ``migl`` when the CDF there is within
    ``tolerance`` (0.01 % = 1e-4) of the CDF at the lowest MIGL.

    No estimated pixel becomes unsaturated below ``migl`` then, so the threshold rule would never
    fire again and the MIGL would stop falling; capturing here lets the CDF updates add the
    pixels that could not be estimated so far.

    Parameters
    ----------
    cdf : SaturationCDF
        The current CDF.
    migl : float
        Candidate MIGL.
    tolerance : float
        Fraction in [0, 1]; the thesis uses 0.01 %.

    Returns
    -------
    bool
        True when the rule asks for a capture at ``migl``.

    References
    ----------
    Thesis Sec. 6.1.3.

    Examples
    --------
    Estimated pixels unsaturate at 250, 240 and 230: below 231 none is left to come.

    >>> cdf = saturated_intensity_cdf([260.0, 270.0, 280.0, np.nan], 255, 40, model="thesis")
    >>> lowest_migl_rule(cdf, 231), lowest_migl_rule(cdf, 230)
    (False, True)
    """
    tol = _check_fraction("tolerance", tolerance)
    return cdf.at(cdf.lowest_migl) - cdf.at(migl) < tol


def capture_rule(
    cdf: SaturationCDF,
    migl: float,
    last_captured_cdf_value: float,
    threshold: float,
    lowest_tolerance: float | None = LOWEST_MIGL_TOLERANCE,
) -> str | None:
    """Which rule asks for a capture at ``migl``: ``"threshold"``, ``"lowest"`` or None.

    Parameters
    ----------
    cdf : SaturationCDF
        The current CDF.
    migl : float
        Candidate MIGL.
    last_captured_cdf_value : float
        CDF value at the last captured MIGL.
    threshold : float
        Fraction for :func:`threshold_rule`.
    lowest_tolerance : float or None
        Tolerance for :func:`lowest_migl_rule`; None turns that rule off.

    Returns
    -------
    str or None
        ``"threshold"`` (checked first), ``"lowest"``, or None for no capture.

    References
    ----------
    Thesis Sec. 6.1.3.

    Examples
    --------
    >>> cdf = saturated_intensity_cdf([260.0, 270.0, 280.0, np.nan], 255, 40, model="thesis")
    >>> capture_rule(cdf, 240, 0.25, 0.2), capture_rule(cdf, 230, 0.5, 0.3)
    ('threshold', 'lowest')
    >>> capture_rule(cdf, 230, 0.5, 0.3, lowest_tolerance=None) is None
    True
    """
    if threshold_rule(cdf, migl, last_captured_cdf_value, threshold):
        return "threshold"
    if lowest_tolerance is not None and lowest_migl_rule(cdf, migl, lowest_tolerance):
        return "lowest"
    return None


def next_capture_migl(
    cdf: SaturationCDF,
    current_migl: float,
    last_captured_cdf_value: float | None = None,
    threshold: float = 0.1,
    *,
    lowest_tolerance: float | None = LOWEST_MIGL_TOLERANCE,
) -> int | None:
    """The next MIGL to capture at (thesis Sec. 6.1.3), scanning down from ``current_migl - 1``.

    The MIGL is decremented one gray level at a time, without capturing, until the CDF has grown
    by more than ``threshold`` since the last capture (:func:`threshold_rule`) or, unless
    ``lowest_tolerance`` is None, until the CDF is within ``lowest_tolerance`` of its value at
    the lowest MIGL (:func:`lowest_migl_rule`, which always fires at the lowest MIGL itself).

    Parameters
    ----------
    cdf : SaturationCDF
        The current (updated) CDF.
    current_migl : float
        The last MIGL captured.
    last_captured_cdf_value : float, optional
        CDF value at the last capture; default ``cdf.at(current_migl)``.
    threshold : float
        Fraction (0.1 and 0.2 in the thesis's experiments).
    lowest_tolerance : float or None
        Tolerance of the lowest-MIGL rule (thesis: 0.01 %); None turns the rule off.

    Returns
    -------
    int or None
        The MIGL, or None when ``current_migl`` is already at the lowest MIGL (or, with the
        lowest-MIGL rule off, when no MIGL down to the lowest satisfies the threshold rule).

    References
    ----------
    Thesis Sec. 6.1 and 6.1.3.

    Examples
    --------
    Estimated pixels unsaturate at 250, 240 and 230 (a quarter each); threshold 20 %:

    >>> cdf = saturated_intensity_cdf([260.0, 270.0, 280.0, np.nan], 255, 40, model="thesis")
    >>> [next_capture_migl(cdf, m, threshold=0.2) for m in (255, 250, 240)]
    [250, 240, 230]
    >>> next_capture_migl(cdf, 230, threshold=0.2), next_capture_migl(cdf, 41, threshold=0.2)
    (229, None)
    """
    _check_fraction("threshold", threshold)
    last = cdf.at(current_migl) if last_captured_cdf_value is None else last_captured_cdf_value
    start = math.ceil(current_migl - 1e-9) - 1
    for m in range(min(start, cdf.migl0), cdf.lowest_migl - 1, -1):
        if capture_rule(cdf, m, last, threshold, lowest_tolerance) is not None:
            return m
    return None


# --------------------------------------------------------------------------------------------
# CDF updates after a capture
# --------------------------------------------------------------------------------------------
def _masks(pending: ArrayLike, n_saturated: ArrayLike) -> tuple[NDArray[np.bool_], NDArray]:
    pend = np.asarray(pending, dtype=bool)
    nsat = np.asarray(n_saturated)
    if pend.shape != nsat.shape:
        raise InputError(
            f"pending mask shape {pend.shape} does not match the saturation count's {nsat.shape}"
        )
    return pend, nsat


def update_cdf_with_newly_estimable(
    cdf: SaturationCDF,
    pending: ArrayLike,
    estimates: ArrayLike,
    n_saturated: ArrayLike,
    capture_migl: float,
    imin: float,
    *,
    bit_depth: int = 8,
    offset: ArrayLike | None = None,
    model: TruthModel = "scaled",
) -> tuple[SaturationCDF, NDArray[np.bool_]]:
    """First CDF update of thesis Sec. 6.1.3: pixels that can now be estimated.

    Pixels still ``pending`` (saturated at ``migl0`` but not yet in the histogram, because more
    shifts were saturated than the estimate can handle) that are still saturated at
    ``capture_migl`` but now estimable (finite ``estimates``: exactly one saturated shift for
    Eq. 6.2) are converted to their unsaturation MIGL from ``capture_migl`` (at most
    ``capture_migl - 1``) and added to the histogram.

    Parameters
    ----------
    cdf : SaturationCDF
        The CDF before the update.
    pending : array_like of bool (H, W)
        Pixels saturated at ``migl0`` and not yet in the histogram.
    estimates : array_like (H, W)
        Corrected peak estimates from the set at ``capture_migl``; NaN where not estimable.
    n_saturated : array_like (H, W)
        Saturated shifts per pixel at ``capture_migl``.
    capture_migl, imin : float
        The MIGL just captured and the pattern's minimum input gray.
    bit_depth, offset, model
        As for :func:`saturated_intensity_cdf` (``offset`` from the same set).

    Returns
    -------
    (SaturationCDF, ndarray of bool)
        The updated CDF and the pixels still pending.

    References
    ----------
    Thesis Sec. 6.1.3 (the first of the two updates).

    Examples
    --------
    Pixel 2 had two saturated shifts at 255; at MIGL 240 it has one and its peak estimate is
    262 DN, so (Eq. 6.3) it unsaturates at 233:

    >>> cdf = saturated_intensity_cdf([260.0, 270.0, np.nan], 255, 40, model="thesis")
    >>> new, pending = update_cdf_with_newly_estimable(
    ...     cdf, [False, False, True], [np.nan, np.nan, 262.0], [0, 0, 1], 240, 40,
    ...     model="thesis")
    >>> np.flatnonzero(new.counts).tolist(), pending.tolist()
    ([233, 240, 250], [False, False, False])
    """
    pend, nsat = _masks(pending, n_saturated)
    est = np.asarray(estimates, dtype=np.float64)
    if est.shape != pend.shape:
        raise InputError(f"estimates shape {est.shape} does not match the mask's {pend.shape}")
    new = pend & (nsat >= 1) & np.isfinite(est)
    off = None
    if offset is not None:
        off = np.broadcast_to(np.asarray(offset, dtype=np.float64), est.shape)[new]
    m = unsaturation_migl(est[new], capture_migl, imin, bit_depth, model=model, offset=off)
    return cdf.add(m, ceiling=capture_migl - 1), pend & ~new


def update_cdf_with_newly_unsaturated(
    cdf: SaturationCDF,
    pending: ArrayLike,
    n_saturated: ArrayLike,
    capture_migl: float,
) -> tuple[SaturationCDF, NDArray[np.bool_]]:
    """Second CDF update of thesis Sec. 6.1.3: pending pixels that are now unsaturated.

    Pixels still ``pending`` (never estimated) with no saturated shift at ``capture_migl`` are
    added to the histogram at ``capture_migl``.

    Parameters
    ----------
    cdf : SaturationCDF
        The CDF before the update.
    pending : array_like of bool (H, W)
        Pixels saturated at ``migl0`` and not yet in the histogram.
    n_saturated : array_like (H, W)
        Saturated shifts per pixel at ``capture_migl``.
    capture_migl : float
        The MIGL just captured.

    Returns
    -------
    (SaturationCDF, ndarray of bool)
        The updated CDF and the pixels still pending.

    References
    ----------
    Thesis Sec. 6.1.3 (the second of the two updates).

    Examples
    --------
    >>> cdf = saturated_intensity_cdf([260.0, 270.0, np.nan], 255, 40, model="thesis")
    >>> new, pending = update_cdf_with_newly_unsaturated(cdf, [False, False, True], [0, 0, 0], 230)
    >>> np.flatnonzero(new.counts).tolist(), new.at(230), pending.tolist()
    ([230, 240, 250], 1.0, [False, False, False])
    """
    pend, nsat = _masks(pending, n_saturated)
    new = pend & (nsat == 0)
    m = np.full(int(new.sum()), float(capture_migl))
    return cdf.add(m, ceiling=capture_migl), pend & ~new


# --------------------------------------------------------------------------------------------
# a small state for the strategy loop
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DPAState:
    """What the DPA loop carries between captures.

    Parameters
    ----------
    cdf : SaturationCDF
        The CDF after the last capture's updates.
    pending : ndarray of bool (H, W)
        Saturated at ``migl0``, not yet in the histogram.
    last_captured_migl : int
        The MIGL of the last capture.
    captures : tuple of (int, str)
        MIGLs captured so far with the rule that asked for them (``"initial"`` first).

    References
    ----------
    Thesis Sec. 6.1 and 6.1.3.

    Examples
    --------
    >>> state = initial_dpa_state([[260.0, 270.0, np.nan, 100.0]], [[1, 1, 2, 0]], 255, 40,
    ...                           model="thesis")
    >>> state.pending.tolist(), state.captures, state.last_captured_cdf_value
    ([[False, False, True, False]], ((255, 'initial'),), 0.0)
    """

    cdf: SaturationCDF
    pending: NDArray[np.bool_]
    last_captured_migl: int
    captures: tuple[tuple[int, str], ...] = ()

    @property
    def last_captured_cdf_value(self) -> float:
        """CDF at the last captured MIGL (after that capture's updates)."""
        return self.cdf.at(self.last_captured_migl)


def initial_dpa_state(
    estimates: ArrayLike,
    n_saturated: ArrayLike,
    migl0: float,
    imin: float,
    *,
    bit_depth: int = 8,
    offset: ArrayLike | None = None,
    model: TruthModel = "scaled",
    lowest_migl: float | None = None,
) -> DPAState:
    """State after the set at ``migl0``: the initial CDF (:func:`saturated_intensity_cdf`) over
    the pixels with ``n_saturated > 0``; those without a finite estimate are pending.

    Parameters
    ----------
    estimates : array_like (H, W)
        Corrected peak estimates at ``migl0``; NaN where not estimable.
    n_saturated : array_like (H, W)
        Saturated shifts per pixel at ``migl0``.
    migl0 : float
        Initial MIGL (an integer).
    imin : float
        The pattern's minimum input gray.
    bit_depth, offset, model, lowest_migl
        As for :func:`saturated_intensity_cdf`.

    Returns
    -------
    DPAState
        The initial CDF, the pending pixels, and ``migl0`` as the first capture.

    References
    ----------
    Thesis Sec. 6.1.3 (the initial estimate of the CDF).

    Examples
    --------
    Three of four pixels saturated, one of them with too many saturated shifts to estimate:

    >>> state = initial_dpa_state([[260.0, 270.0, np.nan, 100.0]], [[1, 1, 2, 0]], 255, 40,
    ...                           model="thesis")
    >>> state.cdf.total, state.cdf.accounted, state.pending.tolist()
    (3, 2, [[False, False, True, False]])
    """
    nsat = np.asarray(n_saturated)
    est = np.asarray(estimates, dtype=np.float64)
    sat = nsat > 0
    cdf = saturated_intensity_cdf(
        est,
        migl0,
        imin,
        bit_depth=bit_depth,
        saturated=sat,
        offset=offset,
        model=model,
        lowest_migl=lowest_migl,
    )
    return DPAState(cdf, sat & ~np.isfinite(est), cdf.migl0, ((cdf.migl0, "initial"),))


def update_dpa_state(
    state: DPAState,
    estimates: ArrayLike,
    n_saturated: ArrayLike,
    capture_migl: float,
    imin: float,
    *,
    rule: str = "",
    bit_depth: int = 8,
    offset: ArrayLike | None = None,
    model: TruthModel = "scaled",
) -> DPAState:
    """Both CDF updates after a capture at ``capture_migl``, in the thesis's order.

    :func:`update_cdf_with_newly_estimable`, then :func:`update_cdf_with_newly_unsaturated`.

    Parameters
    ----------
    state : DPAState
        The state before the capture.
    estimates : array_like (H, W)
        Corrected peak estimates from the set at ``capture_migl``; NaN where not estimable.
    n_saturated : array_like (H, W)
        Saturated shifts per pixel at ``capture_migl``.
    capture_migl : float
        The MIGL just captured.
    imin : float
        The pattern's minimum input gray.
    rule : str
        The rule that asked for the capture (recorded in ``captures``).
    bit_depth, offset, model
        As for :func:`saturated_intensity_cdf`.

    Returns
    -------
    DPAState
        The updated state, with ``capture_migl`` as the last capture.

    References
    ----------
    Thesis Sec. 6.1.3.

    Examples
    --------
    >>> state = initial_dpa_state([[260.0, 270.0, np.nan, 100.0]], [[1, 1, 2, 0]], 255, 40,
    ...                           model="thesis")
    >>> state = update_dpa_state(state, [[np.nan, np.nan, 262.0, np.nan]], [[0, 0, 1, 0]],
    ...                          240, 40, rule="threshold", model="thesis")
    >>> state.captures, state.pending.tolist(), round(state.last_captured_cdf_value, 3)
    (((255, 'initial'), (240, 'threshold')), [[False, False, False, False]], 0.667)
    """
    cdf, pending = update_cdf_with_newly_estimable(
        state.cdf,
        state.pending,
        estimates,
        n_saturated,
        capture_migl,
        imin,
        bit_depth=bit_depth,
        offset=offset,
        model=model,
    )
    cdf, pending = update_cdf_with_newly_unsaturated(cdf, pending, n_saturated, capture_migl)
    m = math.floor(capture_migl + 1e-9)
    return DPAState(cdf, pending, m, (*state.captures, (m, rule)))
