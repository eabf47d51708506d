"""Residual nonlinearity of requested gray -> captured intensity (thesis Sec. 2.6, Fig. 2.6 c).

After pre-compensation with an estimate gamma-hat (Eq. 2.17) the requested gray and the
captured intensity should be proportional. These functions say how far a mapping is from a
straight line, in percent of the captured range: measured from captures, measured from
captures re-indexed by the level pre-compensation would map them to, or predicted from a
:class:`~hdrfringe.core.gamma.GammaFit`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from hdrfringe.core._validation import full_scale
from hdrfringe.core.gamma.model import GammaFit
from hdrfringe.core.patterns import precompensate_gamma
from hdrfringe.errors import InputError

__all__ = [
    "Nonlinearity",
    "line_deviation",
    "measure_nonlinearity",
    "predicted_nonlinearity",
    "residual_nonlinearity",
]


@dataclass(frozen=True)
class Nonlinearity:
    """Deviation of a mapping from its least-squares straight line ``dn = slope * g + intercept``.

    Made by :func:`line_deviation` and :func:`measure_nonlinearity`.

    Parameters
    ----------
    max_percent, rms_percent : float
        Largest and RMS deviation from the line, in percent of the captured range: the line's
        span over the levels given, ``|slope| * (g_max - g_min)``.
    slope, intercept : float
        The fitted line, DN per gray level and DN.
    n : int
        Number of points the line was fitted to (bins when binned).

    References
    ----------
    Thesis Sec. 2.6, Fig. 2.6 c (the mapping after pre-compensation, Eq. 2.17).

    Examples
    --------
    >>> nl = line_deviation([0, 1, 2, 3], [0, 1, 2, 4])
    >>> round(nl.slope, 2), nl.n
    (1.3, 4)
    """

    max_percent: float
    rms_percent: float
    slope: float
    intercept: float
    n: int


def line_deviation(levels: ArrayLike, dn: ArrayLike, *, bins: int | None = None) -> Nonlinearity:
    """Straight-line fit of ``dn`` against ``levels`` and the deviation from it.

    Parameters
    ----------
    levels : array_like
        Gray levels (any shape; flattened).
    dn : array_like
        Captured intensity of each level, DN, same size as ``levels``.
    bins : int, optional
        Group the samples into that many equal-width bins of ``levels`` and fit the line to
        each bin's median level and median DN (bins with at least 3 samples): for many noisy
        samples, e.g. from fringes, whose individual noise would otherwise dominate the
        maximum.

    Returns
    -------
    Nonlinearity
        The line and the deviation from it in percent of the captured range. Non-finite
        samples are ignored.

    Raises
    ------
    InputError
        When the sizes differ, ``bins`` is below 1, or fewer than 3 points at different levels
        remain.

    References
    ----------
    Thesis Sec. 2.6, Fig. 2.6 c.

    Examples
    --------
    >>> g = np.arange(0, 256, 16.0)
    >>> round(line_deviation(g, 10 + 0.8 * g).max_percent, 6)  # a straight line: 0 %
    0.0
    >>> round(line_deviation(g, 255 * (g / 255) ** 2).max_percent, 1)  # a parabola
    15.6
    """
    x = np.asarray(levels, dtype=np.float64).ravel()
    y = np.asarray(dn, dtype=np.float64).ravel()
    if x.shape != y.shape:
        raise InputError(f"nonlinearity: {x.size} levels but {y.size} intensities; give one each")
    if bins is not None and int(bins) < 1:
        raise InputError(f"nonlinearity: bins must be at least 1, got {bins}; or give None")
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if bins is not None and x.size and np.ptp(x) > 0:
        edges = np.linspace(x.min(), x.max(), int(bins) + 1)
        med = stats.binned_statistic(x, [x, y], statistic="median", bins=edges)
        keep = np.bincount(med.binnumber - 1, minlength=int(bins)) >= 3
        x, y = med.statistic[0][keep], med.statistic[1][keep]
    if x.size < 3 or np.ptp(x) == 0:
        raise InputError(
            "nonlinearity: need at least 3 samples at different levels; capture more gray levels"
        )
    slope, intercept = np.polyfit(x, y, 1)
    dev = y - (slope * x + intercept)
    span = abs(float(slope)) * float(np.ptp(x)) or 1.0
    return Nonlinearity(
        max_percent=float(100 * np.abs(dev).max() / span),
        rms_percent=float(100 * np.sqrt(np.mean(dev**2)) / span),
        slope=float(slope),
        intercept=float(intercept),
        n=int(x.size),
    )


def measure_nonlinearity(
    levels: ArrayLike,
    dn: ArrayLike | GammaFit,
    gamma_hat: float,
    projector_bit_depth: int = 8,
    *,
    captured_with: float | None = None,
    bins: int | None = None,
) -> Nonlinearity:
    """Nonlinearity of requested gray -> captured DN after pre-compensation with ``gamma_hat``.

    Three uses:

    * measured: ``dn`` are captures of the linear ``levels`` sent WITH pre-compensation
      ``gamma_hat`` (``captured_with`` None or equal): the line is fitted to ``(levels, dn)``.
    * measured, re-indexed: ``dn`` were captured with another pre-compensation
      ``captured_with`` (1.0: none). Each sample's sent gray ``s`` is what pre-compensation with
      ``gamma_hat`` sends for the requested level ``full * (s/full)^gamma_hat``, so the samples,
      re-indexed by that level, measure the corrected mapping without any model.
    * predicted: ``dn`` is a :class:`~hdrfringe.core.gamma.GammaFit`; the captured DN are predicted
      by the fit for the ``levels`` pre-compensated with ``gamma_hat`` (rounding included):
      what the fit says would remain.

    Parameters
    ----------
    levels : array_like
        Requested (linear) gray levels, ``0..2^Bp - 1``.
    dn : array_like or GammaFit
        Captured DN of each level, or a fit to predict them.
    gamma_hat : float
        The pre-compensation exponent whose result is measured (Eq. 2.17).
    projector_bit_depth : int
        Projector input bit depth Bp.
    captured_with : float, optional
        The pre-compensation the captures were made with, when not ``gamma_hat``.
    bins : int, optional
        Binned medians, see :func:`line_deviation`.

    Returns
    -------
    Nonlinearity

    Raises
    ------
    InputError
        Bad bit depth, a ``gamma_hat`` that is not positive, or too few samples.

    References
    ----------
    Thesis Sec. 2.6: Eq. 2.17 and Fig. 2.6 c.

    Examples
    --------
    >>> g = np.arange(0, 256, 15.0)
    >>> raw = 10 + 200 * (g / 255) ** 2.2  # captured without pre-compensation
    >>> round(measure_nonlinearity(g, raw, 1.0).max_percent, 1)
    18.7
    >>> round(measure_nonlinearity(g, raw, 2.2, captured_with=1.0).max_percent, 6)
    0.0
    """
    full = float(full_scale(projector_bit_depth, "projector bit depth"))
    if not (math.isfinite(gamma_hat) and gamma_hat > 0):
        raise InputError(f"nonlinearity: gamma_hat must be a positive number, got {gamma_hat}")
    g = np.asarray(levels, dtype=np.float64).ravel()
    if isinstance(dn, GammaFit):
        return line_deviation(g, dn.predict_precompensated(g, gamma_hat), bins=bins)
    y = np.asarray(dn, dtype=np.float64).ravel()
    if captured_with is None or captured_with == gamma_hat:
        return line_deviation(g, y, bins=bins)
    if captured_with == 1.0:
        sent = np.clip(g, 0.0, full)
    else:
        sent = precompensate_gamma(g, captured_with, projector_bit_depth).astype(np.float64)
    return line_deviation(full * (sent / full) ** gamma_hat, y, bins=bins)


def residual_nonlinearity(
    levels: ArrayLike,
    dn: ArrayLike | GammaFit,
    gamma_hat: float,
    projector_bit_depth: int = 8,
    *,
    captured_with: float | None = None,
    bins: int | None = None,
) -> float:
    """Max deviation (% of range) of input -> captured from a straight line after pre-compensation.

    :func:`measure_nonlinearity`'s ``max_percent``; that function also returns the RMS
    deviation and the line.

    Parameters
    ----------
    levels, dn, gamma_hat, projector_bit_depth, captured_with, bins
        As for :func:`measure_nonlinearity`.

    Returns
    -------
    float
        Largest deviation from the straight line, percent of the captured range.

    References
    ----------
    Thesis Sec. 2.6: Eq. 2.17 and Fig. 2.6 c.

    Examples
    --------
    >>> g = np.arange(0, 256, 16.0)
    >>> round(residual_nonlinearity(g, 10 + 200 * g / 255, 2.2), 6)  # captured linear: 0 %
    0.0
    """
    return measure_nonlinearity(
        levels, dn, gamma_hat, projector_bit_depth, captured_with=captured_with, bins=bins
    ).max_percent


def predicted_nonlinearity(
    fit: GammaFit, gamma_hat: float, imin: float = 0.0, migl: float | None = None
) -> tuple[float, float]:
    """Max and RMS residual nonlinearity (%) the fit predicts over the levels ``imin..migl``.

    256 requested levels evenly spaced from ``imin`` to ``migl`` (default the full range: every
    level of an 8-bit projector) are pre-compensated with ``gamma_hat`` and rounded
    (Eq. 2.17), then mapped through the fitted ``c0 + c1 (sent/full)^gamma`` (Eq. 2.16).

    Parameters
    ----------
    fit : GammaFit
        The fitted projector response.
    gamma_hat : float
        Pre-compensation exponent.
    imin, migl : float
        Lowest and highest requested level (``migl`` None: ``2^Bp - 1``).

    Returns
    -------
    max_percent, rms_percent : float
        Percent of the captured range.

    References
    ----------
    Thesis Sec. 2.6: Eq. 2.16-2.17 and Fig. 2.6 c (the low-level nonlinearity that made the
    thesis choose imin = 40, Sec. 3.4.3).

    Examples
    --------
    >>> from hdrfringe.core.gamma import GammaFit
    >>> fit = GammaFit(2.812, 0.0, 10.0, 200.0, 0.0, "uniform", *[np.zeros(0)] * 4)
    >>> mx, rms = predicted_nonlinearity(fit, 1.0)  # no pre-compensation
    >>> round(mx, 1)
    30.0
    >>> predicted_nonlinearity(fit, 2.812)[0] < 1.0  # only the rounding of the sent gray
    True
    """
    full = float(full_scale(fit.projector_bit_depth, "projector bit depth"))
    top = full if migl is None else float(migl)
    g = np.linspace(imin, top, 256)
    nl = measure_nonlinearity(g, fit, gamma_hat, fit.projector_bit_depth)
    return nl.max_percent, nl.rms_percent
