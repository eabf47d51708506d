"""The result of a gamma fit and the defaults shared by the fits (thesis Sec. 2.6).

The projector maps a normalised input ``u`` to light ``w = u^gamma`` (thesis Eq. 2.16); a
capture of gray ``sent`` is modelled as ``DN = offset + scale * (sent/full)^gamma``.
:class:`GammaFit` holds a fitted model, the samples it was fitted to, and predicts captures
with and without pre-compensation (Eq. 2.17).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core._validation import full_scale
from hdrfringe.core.patterns import precompensate_gamma

__all__ = [
    "CLIP_MARGIN_FRACTION",
    "MAX_CLIPPED_FRACTION",
    "MIN_FRINGE_PITCH_PX",
    "MIN_MODULATION_FRACTION",
    "GammaFit",
]

F64 = NDArray[np.float64]

#: Default for uniform fits from means: samples within this fraction of the camera's full scale
#: of 0 or of ``2^B - 1`` are treated as clipped (a mean near a clipping limit is biased).
CLIP_MARGIN_FRACTION = 0.02
#: Default for uniform fits from images: a level is dropped when more than this fraction of the
#: region's pixels sit at 0 or at ``2^B - 1``.
MAX_CLIPPED_FRACTION = 0.01
#: Default minimum peak-to-peak DN of a pixel's fringe samples, as a fraction of full scale.
MIN_MODULATION_FRACTION = 0.1
#: Fringe fits warn below this pitch (projector pixels), and :func:`select_gamma_sets` leaves
#: narrower sets out: projector pixels and blur reshape narrow fringes, which biases a fit of
#: the wave's shape (virtual rig: +0.9 % at 32 px, +4 % at 16 px, far off at 8 px;
#: docs/gamma.md).
MIN_FRINGE_PITCH_PX = 32.0


@dataclass(frozen=True, eq=False)
class GammaFit:
    """Result of a gamma fit: ``DN = offset + scale * (sent/full)^gamma``.

    Made by :func:`~hdrfringe.core.gamma.fit_gamma_uniform` and
    :func:`~hdrfringe.core.gamma.fit_gamma_fringes`.

    Parameters
    ----------
    gamma : float
        The projector's own gamma (Eq. 2.16), independent of any pre-compensation the captures
        were made with. It is the gamma of the whole chain input gray -> camera DN, so a camera
        response that is not linear is folded into it (which is what pre-compensation needs).
    stderr : float
        Standard error of ``gamma`` from the Jacobian at the solution (residual variance times
        the inverse Gauss-Newton matrix; for fringes, the per-pixel parameters are eliminated by
        the Schur complement). It assumes independent noise: model error that is correlated
        between samples makes it optimistic.
    offset, scale : float
        ``c0`` (ambient light and black level) and ``c1`` (reflectivity and sensitivity) in DN.
        Fringe fits: medians of the per-pixel values.
    rms_residual : float
        RMS of the residual over the samples used, in DN.
    method : str
        "uniform" or "fringes".
    levels : ndarray
        Linear (requested) gray level of each sample, before any pre-compensation.
    sent : ndarray
        Gray level sent to the projector for each sample (integer-valued for uniform fits; the
        unrounded pattern value for fringe fits).
    dn : ndarray
        Captured intensity of each sample in DN. Fringe fits: a subsample of the samples, each
        pixel's values mapped to the common ``offset`` and ``scale``
        (``offset + scale * (I - o_px) / s_px``) so that all pixels share one curve.
    used : ndarray of bool
        Which samples entered the fit (uniform fits drop clipped samples).
    ci95 : (float, float)
        95 % confidence interval of ``gamma`` (Student t for uniform fits, normal for fringes).
    offset_stderr, scale_stderr : float
        Standard errors of ``offset`` and ``scale`` (uniform fits; NaN for fringes).
    normalization : str
        Fringe fits: "shape" (offset and scale fitted per pixel) or "black_white"; "" otherwise.
    projector_bit_depth, camera_bit_depth : int
        Bit depths Bp and B; ``full = 2^Bp - 1``.
    n_samples : int
        Uniform fits: number of levels used. Fringe fits: number of pixels used.
    n_pixels : int
        Fringe fits: pixels used (as ``n_samples``); uniform fits: pixels per level reduced
        (0 when means were given).

    References
    ----------
    Thesis Sec. 2.6, Eq. 2.16 (the power law) and Eq. 2.17 (pre-compensation).

    Examples
    --------
    >>> from hdrfringe.core.gamma import fit_gamma_uniform
    >>> g = np.arange(0, 256, 16.0)
    >>> fit = fit_gamma_uniform(g, 12 + 200 * (g / 255) ** 2.2, camera_bit_depth=8)
    >>> isinstance(fit, GammaFit), fit.method, fit.n_samples
    (True, 'uniform', 16)
    >>> round(float(fit.predict(255)), 3)
    212.0
    """

    gamma: float
    stderr: float
    offset: float
    scale: float
    rms_residual: float
    method: str
    levels: F64
    sent: F64
    dn: F64
    used: NDArray[np.bool_]
    ci95: tuple[float, float] = (math.nan, math.nan)
    offset_stderr: float = math.nan
    scale_stderr: float = math.nan
    normalization: str = ""
    projector_bit_depth: int = 8
    camera_bit_depth: int = 8
    n_samples: int = 0
    n_pixels: int = 0

    def predict(self, sent: ArrayLike) -> F64:
        """Captured DN the fit predicts for gray levels actually sent to the projector (Eq. 2.16).

        Parameters
        ----------
        sent : array_like
            Gray levels sent, ``0..2^Bp - 1`` (values outside are clipped to that range).

        Returns
        -------
        ndarray
            ``offset + scale * (sent/full)^gamma``, same shape as ``sent``.

        Examples
        --------
        >>> fit = GammaFit(2.0, 0.0, 10.0, 200.0, 0.0, "uniform", *[np.zeros(0)] * 4)
        >>> fit.predict([0, 255]).tolist()
        [10.0, 210.0]
        """
        full = float(full_scale(self.projector_bit_depth, "projector bit depth"))
        x = np.clip(np.asarray(sent, dtype=np.float64) / full, 0, 1)
        return self.offset + self.scale * x**self.gamma

    def predict_precompensated(self, levels: ArrayLike, gamma_hat: float | None = None) -> F64:
        """Captured DN for linear levels sent with pre-compensation ``gamma_hat`` (Eq. 2.17).

        The rounding of the sent gray to the projector's integer levels is included.

        Parameters
        ----------
        levels : array_like
            Requested (linear) gray levels, ``0..2^Bp - 1``.
        gamma_hat : float, optional
            Pre-compensation exponent; default the fitted gamma.

        Returns
        -------
        ndarray
            Predicted DN, same shape as ``levels``.

        Examples
        --------
        >>> fit = GammaFit(2.0, 0.0, 10.0, 200.0, 0.0, "uniform", *[np.zeros(0)] * 4)
        >>> fit.predict_precompensated([0, 255]).tolist()  # linear once pre-compensated
        [10.0, 210.0]
        """
        gh = self.gamma if gamma_hat is None else float(gamma_hat)
        return self.predict(precompensate_gamma(levels, gh, self.projector_bit_depth))
