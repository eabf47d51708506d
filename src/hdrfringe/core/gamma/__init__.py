"""Projector gamma: estimation from uniform-gray or fringe captures, and the residual nonlinearity.

The projector maps a normalised input ``u`` to light ``w = u^gamma`` (thesis Sec. 2.6,
Eq. 2.16); patterns are pre-compensated with an estimate gamma-hat,
``sent = round(full * (g/full)^(1/gamma-hat))`` (Eq. 2.17 and the capture contract), so that the
requested gray ``g`` and the light are proportional. The thesis chose gamma-hat = 2.812 by hand
from the input-to-captured mapping (Fig. 2.6 b/c); here it is fitted. Everything is a function
of arrays: reading capture folders is the caller's business, and the plot of the mapping
(Fig. 2.6 b/c) is :func:`hdrfringe.io.plots.plot_gamma_mapping`.

* :func:`fit_gamma_uniform` (:mod:`~hdrfringe.core.gamma.uniform`): uniform grays and their
  captures (images or means), ``DN = c0 + c1 * (sent/full)^gamma`` by robust nonlinear least
  squares.
* :func:`fit_gamma_fringes` (:mod:`~hdrfringe.core.gamma.fringes`): phase-shifted fringes
  pre-distorted with known exponents; gamma is the exponent that makes every pixel's samples
  follow the distorted wave. Per pixel the phase and (by default) the offset and scale are
  free, so ambient light, reflectivity and contrast loss do not bias it; no Gray code is needed
  (docs/gamma.md has the derivation). Its Levenberg-Marquardt solver is private
  (:mod:`~hdrfringe.core.gamma._solver`).
* :func:`select_gamma_sets` (:mod:`~hdrfringe.core.gamma.selection`): which fringe sets of a capture
  a shape fit can use.
* :func:`residual_nonlinearity`, :func:`measure_nonlinearity`, :func:`predicted_nonlinearity`,
  :func:`line_deviation` (:mod:`~hdrfringe.core.gamma.nonlinearity`): how far input -> captured is
  from a straight line after pre-compensation, in percent of the captured range: measured from
  captures, or predicted from a fit.
* :func:`gamma_report` (:mod:`~hdrfringe.core.gamma.report`): every fit a set of captures allows,
  as the ``hdrfringe gamma`` command reports it (:class:`GammaReport`; the uniform-gray rule is
  :func:`uniform_gray_means`).
* :class:`GammaFit` and the defaults (:mod:`~hdrfringe.core.gamma.model`).

Examples
--------
>>> import numpy as np
>>> from hdrfringe.core.gamma import fit_gamma_uniform, residual_nonlinearity
>>> g = np.arange(0, 256, 16.0)
>>> fit = fit_gamma_uniform(g, 12 + 200 * (g / 255) ** 2.812, camera_bit_depth=8)
>>> round(fit.gamma, 3), residual_nonlinearity(np.arange(256.0), fit, fit.gamma) < 1.0
(2.812, True)
"""

from hdrfringe.core.gamma.fringes import fit_gamma_fringes
from hdrfringe.core.gamma.model import (
    CLIP_MARGIN_FRACTION,
    MAX_CLIPPED_FRACTION,
    MIN_FRINGE_PITCH_PX,
    MIN_MODULATION_FRACTION,
    GammaFit,
)
from hdrfringe.core.gamma.nonlinearity import (
    Nonlinearity,
    line_deviation,
    measure_nonlinearity,
    predicted_nonlinearity,
    residual_nonlinearity,
)
from hdrfringe.core.gamma.report import (
    MIN_UNIFORM_LEVELS,
    GammaReport,
    gamma_report,
    uniform_gray_means,
)
from hdrfringe.core.gamma.selection import GammaSetSelection, select_gamma_sets
from hdrfringe.core.gamma.uniform import fit_gamma_uniform

__all__ = [
    "CLIP_MARGIN_FRACTION",
    "MAX_CLIPPED_FRACTION",
    "MIN_FRINGE_PITCH_PX",
    "MIN_MODULATION_FRACTION",
    "MIN_UNIFORM_LEVELS",
    "GammaFit",
    "GammaReport",
    "GammaSetSelection",
    "Nonlinearity",
    "fit_gamma_fringes",
    "fit_gamma_uniform",
    "gamma_report",
    "line_deviation",
    "measure_nonlinearity",
    "predicted_nonlinearity",
    "residual_nonlinearity",
    "select_gamma_sets",
    "uniform_gray_means",
]
