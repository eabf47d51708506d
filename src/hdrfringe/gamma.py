"""Projector gamma: estimation from uniform-gray or fringe captures, and the residual nonlinearity.

The projector maps a normalised input ``u`` to light ``w = u^gamma`` (thesis Eq. 2.16); patterns
are pre-compensated with an estimate gamma-hat, ``sent = round(full * (g/full)^(1/gamma-hat))``
(Eq. 2.17 and the capture contract), so that the requested gray ``g`` and the light are
proportional. The thesis chose gamma-hat = 2.812 by hand from the input-to-captured mapping
(Fig. 2.6 b/c); here it is fitted. Everything is a function of arrays: reading capture folders
is the caller's business.

* :func:`fit_gamma_uniform`: uniform grays and their captures (images or means),
  ``DN = c0 + c1 * (sent/full)^gamma`` by robust nonlinear least squares.
* :func:`fit_gamma_fringes`: phase-shifted fringes pre-distorted with known exponents; gamma is
  the exponent that makes every pixel's samples follow the distorted wave. Per pixel the phase
  and (by default) the offset and scale are free, so ambient light, reflectivity and contrast
  loss do not bias it; no Gray code is needed (docs/gamma.md has the derivation).
* :func:`residual_nonlinearity`, :func:`measure_nonlinearity`, :func:`predicted_nonlinearity`:
  how far input -> captured is from a straight line after pre-compensation, in percent of the
  captured range: measured from captures, or predicted from a fit.
* :func:`plot_gamma_mapping`: thesis Fig. 2.6 b/c as a PNG.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize, special

from hdrfringe.errors import InputError
from hdrfringe.patterns import FringeSpec, fringe_profile, precompensate_gamma

F64 = NDArray[np.float64]

#: Default for uniform fits from means: samples within this fraction of the camera's full scale
#: of 0 or of ``2^B - 1`` are treated as clipped (a mean near a clipping limit is biased).
CLIP_MARGIN_FRACTION = 0.02
#: Default for uniform fits from images: a level is dropped when more than this fraction of the
#: region's pixels sit at 0 or at ``2^B - 1``.
MAX_CLIPPED_FRACTION = 0.01
#: Default minimum peak-to-peak DN of a pixel's fringe samples, as a fraction of full scale.
MIN_MODULATION_FRACTION = 0.1
#: Fringe fits warn below this pitch (projector pixels): projector pixels and blur reshape
#: narrow fringes, which biases a fit of the wave's shape (virtual rig: +0.9 % at 32 px,
#: +4 % at 16 px, far off at 8 px; docs/gamma.md).
MIN_FRINGE_PITCH_PX = 32.0

Normalization = Literal["shape", "black_white"]
Weighting = Literal["levels", "samples"]


# ---------------------------------------------------------------------------------------------
# result
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class GammaFit:
    """Result of a gamma fit: ``DN = offset + scale * (sent/full)^gamma``.

    Attributes
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
    ci95 : (float, float)
        95 % confidence interval of ``gamma`` (Student t for uniform fits, normal for fringes).
    offset, scale : float
        ``c0`` (ambient light and black level) and ``c1`` (reflectivity and sensitivity) in DN.
        Fringe fits: medians of the per-pixel values.
    offset_stderr, scale_stderr : float
        Standard errors of ``offset`` and ``scale`` (uniform fits; NaN for fringes).
    rms_residual : float
        RMS of the residual over the samples used, in DN.
    method : str
        "uniform" or "fringes".
    normalization : str
        Fringe fits: "shape" (offset and scale fitted per pixel) or "black_white"; "" otherwise.
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
    projector_bit_depth, camera_bit_depth : int
    n_samples : int
        Uniform fits: number of levels used. Fringe fits: number of pixels used.
    n_pixels : int
        Fringe fits: pixels used (as ``n_samples``); uniform fits: pixels per level reduced
        (0 when means were given).
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
        """Captured DN the fit predicts for gray levels ``sent`` actually sent to the projector."""
        x = np.clip(np.asarray(sent, dtype=np.float64) / _full(self.projector_bit_depth), 0, 1)
        return self.offset + self.scale * x**self.gamma

    def predict_precompensated(self, levels: ArrayLike, gamma_hat: float | None = None) -> F64:
        """Captured DN for linear levels sent with pre-compensation ``gamma_hat`` (Eq. 2.17).

        ``gamma_hat`` defaults to the fitted gamma. The rounding of the sent gray to the
        projector's integer levels is included.
        """
        gh = self.gamma if gamma_hat is None else float(gamma_hat)
        return self.predict(precompensate_gamma(levels, gh, self.projector_bit_depth))


def _full(bits: int) -> float:
    return float(2**bits - 1)


def _check_bits(name: str, bits: int) -> None:
    if int(bits) != bits or not 1 <= bits <= 16:
        raise InputError(f"{name} bit depth must be an integer 1..16, got {bits}")


# ---------------------------------------------------------------------------------------------
# uniform grays
# ---------------------------------------------------------------------------------------------


def _region(shape: tuple[int, int], roi: object, mask: ArrayLike | None) -> NDArray[np.bool_]:
    """Boolean selection of the pixels to reduce, from a mask and/or a region of interest."""
    sel = np.ones(shape, dtype=bool)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != shape:
            raise InputError(
                f"gamma fit: mask has shape {m.shape} but the images are {shape}; give a mask of "
                "the image size"
            )
        sel &= m
    if roi is not None:
        if isinstance(roi, tuple) and len(roi) == 2 and all(isinstance(s, slice) for s in roi):
            box = np.zeros(shape, dtype=bool)
            box[roi] = True
        elif isinstance(roi, Sequence) and len(roi) == 4:
            y0, y1, x0, x1 = (int(v) for v in roi)
            box = np.zeros(shape, dtype=bool)
            box[y0:y1, x0:x1] = True
        else:
            raise InputError(
                f"gamma fit: roi {roi!r} is not understood; give (row_slice, col_slice) or "
                "(y0, y1, x0, x1)"
            )
        sel &= box
    if not sel.any():
        raise InputError("gamma fit: the mask/roi selects no pixel; widen the region of interest")
    return sel


def fit_gamma_uniform(
    levels: ArrayLike,
    images_or_means: ArrayLike,
    *,
    camera_bit_depth: int,
    projector_bit_depth: int = 8,
    gamma_precompensation: float = 1.0,
    roi: object = None,
    mask: ArrayLike | None = None,
    reducer: Literal["mean", "median"] = "mean",
    clip_margin: float | None = None,
    max_clipped_fraction: float = MAX_CLIPPED_FRACTION,
) -> GammaFit:
    """Fit the projector gamma to captures of uniform gray frames (Eq. 2.16, Fig. 2.6 b).

    Model: ``DN = c0 + c1 * (sent/full)^gamma`` with ``sent = precompensate_gamma(level,
    gamma_precompensation)`` the integer gray actually sent and ``full = 2^Bp - 1``; ``c0``
    absorbs ambient light and the projector's black level, ``c1`` reflectivity, illumination
    and camera sensitivity. Fitted by ``scipy.optimize.least_squares``: a plain least-squares
    pass, then a soft-L1 pass with the loss scale set to 2.5 robust standard deviations of the
    first pass's residuals (a single bad capture cannot pull the fit).

    Exclusion rules (a clipped sample does not follow the model):

    * images ``(L, H, W)``: each image is reduced over the pixels selected by ``mask`` and
      ``roi``; a level is dropped when more than ``max_clipped_fraction`` of those pixels are
      at 0 or at ``2^B - 1``.
    * means ``(L,)``: a level is dropped when its mean lies within ``clip_margin`` DN of 0 or of
      ``2^B - 1`` (default 2 % of full scale: with noise, a mean closer than that to a clipping
      limit is biased, and near-zero levels sit in the camera's black clipping).

    Parameters
    ----------
    levels : array_like, shape (L,)
        Linear (requested) gray levels of the uniform frames.
    images_or_means : array_like, shape (L, H, W) or (L,)
        The captures, or their mean intensities in DN.
    camera_bit_depth : int
        Sensor bit depth B; saturation is ``2^B - 1``.
    projector_bit_depth : int
        Projector input bit depth Bp.
    gamma_precompensation : float
        The gamma-hat the frames were sent with (1.0: none). The fit uses the gray actually
        sent, so the result is the projector's own gamma either way.
    roi : (slice, slice) or (y0, y1, x0, x1), optional
        Region reduced per image (images only).
    mask : array_like of bool, shape (H, W), optional
        Pixels reduced per image (images only); combined with ``roi``.
    reducer : {"mean", "median"}
        Per-image reduction. The mean is unbiased for quantised, noisy DN; the median resists
        defects but is quantised to the camera's integer levels.
    clip_margin : float, optional
        Means only; see above.
    max_clipped_fraction : float
        Images only; see above.

    Returns
    -------
    GammaFit
        ``levels``, ``sent``, ``dn`` hold every level given and ``used`` flags those fitted.

    Examples
    --------
    >>> g = np.arange(0, 256, 16.0)
    >>> fit = fit_gamma_uniform(g, 12 + 200 * (g / 255) ** 2.2, camera_bit_depth=8)
    >>> round(fit.gamma, 3)
    2.2
    """
    _check_bits("camera", camera_bit_depth)
    _check_bits("projector", projector_bit_depth)
    full_c = _full(camera_bit_depth)
    lv = np.asarray(levels, dtype=np.float64).ravel()
    data = np.asarray(images_or_means)
    if reducer not in ("mean", "median"):
        raise InputError(f"gamma fit: reducer {reducer!r} unknown; use 'mean' or 'median'")
    n_px = 0
    if data.ndim == 1:
        if data.shape[0] != lv.size:
            raise InputError(
                f"gamma fit: {lv.size} levels but {data.shape[0]} means; give one mean per level"
            )
        y = data.astype(np.float64)
        margin = CLIP_MARGIN_FRACTION * full_c if clip_margin is None else float(clip_margin)
        clipped = (y <= margin) | (y >= full_c - margin)
    elif data.ndim == 3:
        if data.shape[0] != lv.size:
            raise InputError(
                f"gamma fit: {lv.size} levels but {data.shape[0]} images; give one image per level"
            )
        sel = _region(data.shape[1:], roi, mask)
        n_px = int(np.count_nonzero(sel))
        y = np.empty(lv.size)
        frac = np.empty(lv.size)
        for i, img in enumerate(data):
            vals = img[sel].astype(np.float64)
            top = float(np.nanmax(vals))
            if top > full_c:
                raise InputError(
                    f"gamma fit: image {i} has values up to {top:g}, above "
                    f"2^{camera_bit_depth}-1; give the sensor's true bit depth"
                )
            frac[i] = np.mean((vals <= 0) | (vals >= full_c))
            y[i] = np.median(vals) if reducer == "median" else np.mean(vals)
        clipped = frac > max_clipped_fraction
    else:
        raise InputError(
            f"gamma fit: captures of shape {data.shape}; give images (L, H, W) or means (L,)"
        )
    if np.any((lv < 0) | (lv > _full(projector_bit_depth))):
        raise InputError(
            f"gamma fit: levels must lie in 0..{_full(projector_bit_depth):g} for a "
            f"{projector_bit_depth}-bit projector"
        )
    sent = precompensate_gamma(lv, gamma_precompensation, projector_bit_depth).astype(np.float64)
    x = sent / _full(projector_bit_depth)
    used = np.isfinite(y) & ~clipped
    n_pos = np.unique(x[used & (x > 0)]).size
    if np.count_nonzero(used) < 4 or n_pos < 3:
        raise InputError(
            f"gamma fit: only {np.count_nonzero(used)} usable levels ({n_pos} distinct non-zero); "
            "capture at least 4 uniform grays between the camera's black and saturation "
            "(e.g. 0, 16, ..., 255 with a smaller aperture or exposure)"
        )
    xs, ys = x[used], y[used]
    p, cov, r = _fit_power_law(xs, ys)
    dof = xs.size - 3
    se = np.sqrt(np.clip(np.diag(cov), 0, None)) if cov is not None else np.full(3, np.nan)
    tq = float(special.stdtrit(dof, 0.975)) if dof > 0 else math.inf
    gamma = float(p[2])
    return GammaFit(
        gamma=gamma,
        stderr=float(se[2]),
        ci95=(gamma - tq * float(se[2]), gamma + tq * float(se[2])),
        offset=float(p[0]),
        scale=float(p[1]),
        offset_stderr=float(se[0]),
        scale_stderr=float(se[1]),
        rms_residual=float(np.sqrt(np.mean(r * r))),
        method="uniform",
        levels=lv,
        sent=sent,
        dn=y,
        used=used,
        projector_bit_depth=int(projector_bit_depth),
        camera_bit_depth=int(camera_bit_depth),
        n_samples=int(xs.size),
        n_pixels=n_px,
    )


def _power_law_jac(p: F64, x: F64) -> F64:
    xg = np.power(x, p[2])
    lnx = np.log(np.where(x > 0, x, 1.0))
    return np.column_stack([np.ones_like(x), xg, p[1] * xg * lnx])


def _fit_power_law(x: F64, y: F64) -> tuple[F64, F64 | None, F64]:
    """``y = c0 + c1 x^gamma``: LS then soft-L1; covariance ``s^2 (J^T J)^-1`` at the solution."""
    # start: c0 from the darkest sample, gamma from a log-log line through the rest
    c0 = float(y[np.argmin(x)]) if np.any(x == 0) else float(y.min()) * 0.5
    pos = (x > 0) & (y - c0 > 0)
    g0 = 2.2
    if np.count_nonzero(pos) >= 2:
        g0 = float(np.clip(np.polyfit(np.log(x[pos]), np.log(y[pos] - c0), 1)[0], 0.3, 6.0))
    c1 = float(max(y.max() - c0, 1e-9))

    def resid(p: F64) -> F64:
        return p[0] + p[1] * np.power(x, p[2]) - y

    def jac(p: F64) -> F64:
        return _power_law_jac(p, x)

    bounds = ([-np.inf, 0.0, 0.05], [np.inf, np.inf, 20.0])
    sol = optimize.least_squares(resid, [c0, c1, g0], jac=jac, bounds=bounds, x_scale="jac")
    r = resid(sol.x)
    sigma = 1.4826 * float(np.median(np.abs(r - np.median(r))))
    f_scale = max(2.5 * sigma, 1e-9 * max(abs(c1), 1.0))
    sol = optimize.least_squares(
        resid, sol.x, jac=jac, bounds=bounds, loss="soft_l1", f_scale=f_scale, x_scale="jac"
    )
    p = sol.x
    r = resid(p)
    dof = x.size - 3
    cov = None
    if dof > 0:
        j = _power_law_jac(p, x)
        try:
            cov = np.linalg.inv(j.T @ j) * float(np.sum(r * r) / dof)
        except np.linalg.LinAlgError:
            cov = None
    return p, cov, r


# ---------------------------------------------------------------------------------------------
# residual nonlinearity
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Nonlinearity:
    """Deviation of a mapping from its least-squares straight line ``dn = slope * g + intercept``.

    ``max_percent`` and ``rms_percent`` are in percent of the captured range, the line's span
    over the levels given (``|slope| * (g_max - g_min)``).
    """

    max_percent: float
    rms_percent: float
    slope: float
    intercept: float
    n: int


def line_deviation(levels: ArrayLike, dn: ArrayLike, *, bins: int | None = None) -> Nonlinearity:
    """Straight-line fit of ``dn`` against ``levels`` and the deviation from it.

    ``bins``: group the samples into that many equal-width bins of ``levels`` and use each bin's
    median (for many noisy samples, e.g. from fringes, whose individual noise would otherwise
    dominate the maximum). Non-finite samples are ignored.
    """
    x = np.asarray(levels, dtype=np.float64).ravel()
    y = np.asarray(dn, dtype=np.float64).ravel()
    if x.shape != y.shape:
        raise InputError(f"nonlinearity: {x.size} levels but {y.size} intensities; give one each")
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if bins is not None and x.size:
        edges = np.linspace(x.min(), x.max(), int(bins) + 1)
        idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, int(bins) - 1)
        bx, by = [], []
        for b in range(int(bins)):
            m = idx == b
            if np.count_nonzero(m) >= 3:
                bx.append(np.median(x[m]))
                by.append(np.median(y[m]))
        x, y = np.asarray(bx), np.asarray(by)
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
    * predicted: ``dn`` is a :class:`GammaFit`; the captured DN are predicted by the fit for the
      ``levels`` pre-compensated with ``gamma_hat`` (rounding included): what the fit says
      would remain.
    """
    _check_bits("projector", projector_bit_depth)
    if not (math.isfinite(gamma_hat) and gamma_hat > 0):
        raise InputError(f"nonlinearity: gamma_hat must be a positive number, got {gamma_hat}")
    full = _full(projector_bit_depth)
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

    See :func:`measure_nonlinearity` (same arguments) for the measured and predicted uses; it
    also returns the RMS deviation and the line.

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

    The requested levels (every projector level from ``imin`` to ``migl``, default the full
    range) are pre-compensated with ``gamma_hat`` and rounded (Eq. 2.17), then mapped through
    the fitted ``c0 + c1 (sent/full)^gamma``.
    """
    full = _full(fit.projector_bit_depth)
    top = full if migl is None else float(migl)
    g = np.linspace(imin, top, 256)
    nl = measure_nonlinearity(g, fit, gamma_hat, fit.projector_bit_depth)
    return nl.max_percent, nl.rms_percent


# ---------------------------------------------------------------------------------------------
# fringes
# ---------------------------------------------------------------------------------------------


@dataclass
class _Group:
    """Sets sharing the per-pixel phase: their samples at the chosen pixels, and the model.

    Per-pixel parameters (rows of a (P, M) array): phase, then, unless black/white are given,
    scale and one offset per set (``offset_per_set``) or a single offset.
    """

    y: F64  # (K, M) captured DN
    valid: F64  # (K, M) 1 for a usable sample, 0 for a clipped one
    delta: F64  # (K,) phase shift of each sample: pattern P(phi + delta)
    lo: F64  # (K,) imin / full
    amp: F64  # (K,) (migl - imin) / full
    inv_gh: F64  # (K,) 1 / gamma-hat of each sample's set
    pattern: list[str]  # (K,)
    set_of: NDArray[np.intp]  # (K,) index of each sample's set within the group
    offset_per_set: bool = True
    black: F64 | None = None  # (M,) black_white mode
    span: F64 | None = None  # (M,) white - black
    w: F64 = field(default_factory=lambda: np.zeros((0, 0)))  # (K, M) fit weights

    def __post_init__(self) -> None:
        if self.w.shape != self.y.shape:
            self.w = self.valid.copy()

    def take(self, keep: NDArray[np.bool_] | NDArray[np.intp]) -> _Group:
        return _Group(
            y=self.y[:, keep],
            valid=self.valid[:, keep],
            delta=self.delta,
            lo=self.lo,
            amp=self.amp,
            inv_gh=self.inv_gh,
            pattern=self.pattern,
            set_of=self.set_of,
            offset_per_set=self.offset_per_set,
            black=None if self.black is None else self.black[keep],
            span=None if self.span is None else self.span[keep],
            w=self.w[:, keep],
        )

    def pattern_value(self, phi: F64) -> tuple[F64, F64]:
        """Normalised linear pattern value h = g/full and dh/dphi, shape (K, M)."""
        arg = phi[None, :] + self.delta[:, None]
        h = np.empty_like(arg)
        dh = np.empty_like(arg)
        for kind in set(self.pattern):
            rows = np.array([p == kind for p in self.pattern])
            t = arg[rows] / (2 * np.pi)
            h[rows] = fringe_profile(t, kind)
            if kind == "sinusoidal":
                dh[rows] = -np.sin(arg[rows])
            else:  # triangular: 1 - 4|t - round(t)| has slope -4 sign(t - round(t)) per period
                dh[rows] = -4.0 * np.sign(t - np.round(t)) / (2 * np.pi)
        h = self.lo[:, None] + self.amp[:, None] * (1.0 + h) / 2.0
        dh = self.amp[:, None] * dh / 2.0
        return h, dh


def _basis(grp: _Group, phi: F64, gamma: float) -> tuple[F64, F64, F64, F64]:
    """f = x^gamma with x = h^(1/gamma-hat) the sent fraction; df/dphi, df/dgamma; and x."""
    h, dh = grp.pattern_value(phi)
    h = np.clip(h, 1e-9, 1.0)
    lnx = np.log(h) * grp.inv_gh[:, None]
    f = np.exp(gamma * lnx)
    f_phi = f * gamma * grp.inv_gh[:, None] * dh / h
    f_gamma = f * lnx
    return f, f_phi, f_gamma, np.exp(lnx)


def _offset_index(grp: _Group) -> NDArray[np.intp]:
    """Row of each sample's offset in the per-pixel parameters."""
    return 2 + (grp.set_of if grp.offset_per_set else np.zeros_like(grp.set_of))


def _offset_scale(grp: _Group, params: F64) -> tuple[F64, F64]:
    """Per-sample offset and scale (K, M) from the per-pixel parameters."""
    k = grp.y.shape[0]
    if grp.black is not None and grp.span is not None:
        m = grp.black.size
        return np.broadcast_to(grp.black, (k, m)), np.broadcast_to(grp.span, (k, m))
    return params[_offset_index(grp)], np.broadcast_to(params[1], (k, params.shape[1]))


def _residual(grp: _Group, params: F64, gamma: float) -> F64:
    """Model minus captured DN, (K, M)."""
    f = _basis(grp, params[0], gamma)[0]
    off, sc = _offset_scale(grp, params)
    return off + sc * f - grp.y


def _jacobians(grp: _Group, params: F64, gamma: float) -> tuple[F64, F64, F64]:
    """Weighted residual e (K, M), per-pixel Jacobian (M, K, P) and gamma column (K, M)."""
    f, f_phi, f_gamma, _ = _basis(grp, params[0], gamma)
    off, sc = _offset_scale(grp, params)
    sw = np.sqrt(grp.w)
    e = (off + sc * f - grp.y) * sw
    k, m = grp.y.shape
    p = params.shape[0]
    jac = np.zeros((m, k, p))
    jac[:, :, 0] = (sc * f_phi * sw).T
    if p > 1:
        jac[:, :, 1] = (f * sw).T
        for kk, row in enumerate(_offset_index(grp)):
            jac[:, kk, row] = sw[kk]
    return e, jac, sc * f_gamma * sw


def _cost(groups: list[_Group], params: list[F64], gamma: float) -> float:
    pairs = zip(groups, params, strict=True)
    return sum(float(np.sum(g.w * _residual(g, p, gamma) ** 2)) for g, p in pairs)


def _normal_blocks(grp: _Group, prm: F64, gamma: float) -> tuple[F64, F64, F64, F64, F64, F64]:
    """Per-pixel normal matrices U (M,P,P), couplings to gamma (M,P), gradients (M,P), etc."""
    e, jac, jg = _jacobians(grp, prm, gamma)
    u = np.einsum("mki,mkj->mij", jac, jac)
    wv = np.einsum("mki,km->mi", jac, jg)
    gl = np.einsum("mki,km->mi", jac, e)
    return e, jac, jg, u, wv, gl


def _lm_step(
    groups: list[_Group], params: list[F64], gamma: float, lam: float, fix_gamma: bool
) -> tuple[list[F64], float]:
    """One damped Gauss-Newton step; the per-pixel blocks are eliminated by the Schur complement.

    With ``J_p`` the per-pixel Jacobian and ``j`` the gamma column, the step solves
    ``[[U, w], [w^T, v]] [dp; dg] = -[g_p; g_g]`` with ``U = J_p^T J_p``, ``w = J_p^T j`` pixel
    by pixel: ``dg = -(g_g - sum w^T U^-1 g_p) / (v - sum w^T U^-1 w)``, then
    ``dp = -U^-1 (g_p + w dg)``. Marquardt damping scales the diagonals by ``1 + lam``.
    """
    blocks = []
    schur = 0.0
    rhs = 0.0
    for grp, prm in zip(groups, params, strict=True):
        e, _, jg, u, wv, gl = _normal_blocks(grp, prm, gamma)
        p = u.shape[1]
        diag = np.maximum(np.einsum("mii->mi", u), 1e-12)
        ud = u + lam * diag[:, :, None] * np.eye(p) + 1e-12 * np.eye(p)
        sol = np.linalg.solve(ud, np.stack([wv, gl], axis=2))  # (M, P, 2)
        uw, ug = sol[..., 0], sol[..., 1]
        schur += float(np.sum(jg * jg)) * (1 + lam) - float(np.sum(wv * uw))
        rhs += float(np.sum(jg * e)) - float(np.sum(wv * ug))
        blocks.append((uw, ug))
    dg = 0.0 if fix_gamma or schur <= 0 else -rhs / schur
    new = []
    for (uw, ug), prm in zip(blocks, params, strict=True):
        step = -(ug + uw * dg).T
        step[0] = np.clip(step[0], -0.5, 0.5)  # phase steps of at most ~30 degrees
        new.append(prm + step)
    return new, gamma + dg


def _levenberg_marquardt(
    groups: list[_Group], params: list[F64], gamma: float, *, fix_gamma: bool, max_iter: int
) -> tuple[list[F64], float, float]:
    lam = 1e-3
    cost = _cost(groups, params, gamma)
    for _ in range(max_iter):
        new, g_new = _lm_step(groups, params, gamma, lam, fix_gamma)
        g_new = float(np.clip(g_new, 0.05, 20.0))
        c_new = _cost(groups, new, g_new)
        if np.isfinite(c_new) and c_new <= cost:
            done = abs(g_new - gamma) < 1e-6 and cost - c_new <= 1e-9 * cost
            params, gamma, cost = new, g_new, c_new
            lam = max(lam / 5, 1e-9)
            if done:
                break
        else:
            lam *= 10
            if lam > 1e8:
                break
    return params, gamma, cost


def _gamma_stderr(groups: list[_Group], params: list[F64], gamma: float) -> float:
    """Standard error of gamma: sandwich estimate, clustered by pixel, per-pixel blocks profiled.

    The gamma column with the per-pixel parameters projected out, ``j~ = j - J_p U^-1 w``, gives
    the Schur complement ``S = sum j~^2`` and, at the solution, ``gamma - gamma_true ~ -(1/S)
    sum_px sum_k j~ e``; summing the squared per-pixel terms allows for weights, noise that
    varies between pixels and errors correlated within a pixel.
    """
    s = 0.0
    meat = 0.0
    n_px = 0
    for grp, prm in zip(groups, params, strict=True):
        e, jac, jg, u, wv, _ = _normal_blocks(grp, prm, gamma)
        p = u.shape[1]
        uw = np.linalg.solve(u + 1e-12 * np.eye(p), wv[..., None])[..., 0]
        jt = jg - np.einsum("mkp,mp->km", jac, uw)
        s += float(np.sum(jt * jt))
        meat += float(np.sum(np.sum(jt * e, axis=0) ** 2))
        n_px += e.shape[1]
    if s <= 0 or n_px < 2:
        return math.nan
    return math.sqrt(meat * n_px / (n_px - 1)) / s


def _level_weights(groups: list[_Group], params: list[F64], gamma: float) -> None:
    """Weights making the samples uniform over the linear level ``u = (sent/full)^gamma``.

    ``u`` is the requested level (as a fraction of full scale) that pre-compensation with this
    gamma would send as the sample's gray. 32 equal bins; weight = 1/count, normalised to mean 1
    over the usable samples and capped at 20.
    """
    us = [_basis(g, p[0], gamma)[0] for g, p in zip(groups, params, strict=True)]
    edges = np.linspace(0.0, 1.0, 33)
    counts = np.zeros(32)
    for grp, u in zip(groups, us, strict=True):
        counts += np.histogram(u[grp.valid > 0], bins=edges)[0]
    dens = np.maximum(counts, 1.0)
    raw = []
    for grp, u in zip(groups, us, strict=True):
        b = np.clip(np.searchsorted(edges, u, side="right") - 1, 0, 31)
        raw.append(grp.valid / dens[b])
    n_valid = sum(float(g.valid.sum()) for g in groups)
    mean = sum(float(r.sum()) for r in raw) / max(n_valid, 1.0)
    for grp, r in zip(groups, raw, strict=True):
        grp.w = np.minimum(r / mean, 20.0)


def _init_params(grp: _Group, gamma: float) -> F64:
    """Phase from the samples' first Fourier component; scale and offsets by linear LS."""
    c = np.sum(grp.valid * grp.y * np.cos(grp.delta)[:, None], axis=0)
    s = -np.sum(grp.valid * grp.y * np.sin(grp.delta)[:, None], axis=0)
    phi = np.arctan2(s, c)
    if grp.black is not None:
        return phi[None, :]
    f = _basis(grp, phi, gamma)[0]
    oidx = _offset_index(grp)
    fc = np.zeros_like(f)
    yc = np.zeros_like(f)
    means = {}
    for row in np.unique(oidx):
        sel = oidx == row
        w = grp.valid[sel]
        sw = np.maximum(np.sum(w, axis=0), 1e-12)
        mf = np.sum(w * f[sel], axis=0) / sw
        my = np.sum(w * grp.y[sel], axis=0) / sw
        fc[sel] = f[sel] - mf
        yc[sel] = grp.y[sel] - my
        means[int(row)] = (mf, my)
    sxx = np.sum(grp.valid * fc * fc, axis=0)
    a = np.where(sxx > 0, np.sum(grp.valid * fc * yc, axis=0) / np.maximum(sxx, 1e-30), 0.0)
    rows = [phi, a] + [means[r][1] - a * means[r][0] for r in sorted(means)]
    return np.stack(rows)


def fit_gamma_fringes(
    sets: Sequence[tuple[FringeSpec, float, ArrayLike]],
    *,
    camera_bit_depth: int,
    projector_bit_depth: int = 8,
    normalization: Normalization = "shape",
    black: ArrayLike | None = None,
    white: ArrayLike | None = None,
    offset_per_set: bool = True,
    weighting: Weighting = "levels",
    mask: ArrayLike | None = None,
    max_pixels: int = 10000,
    min_modulation: float | None = None,
    gamma_init: float = 2.0,
    seed: int = 0,
) -> GammaFit:
    """Fit the projector gamma to phase-shifted fringes pre-distorted with known exponents.

    A pattern value ``g_k = imin + (migl - imin) * (1 + P(phi + delta_k)) / 2`` (the contract's
    convention; ``P`` the sinusoidal or triangular profile, ``delta_k`` the set's shifts) is sent
    as ``full * (g_k/full)^(1/gamma-hat)`` (Eq. 2.17) and reaches the camera as

        ``I_k = o + s * (g_k/full)^(gamma / gamma-hat)``     (Eq. 2.16)

    with, per pixel, the phase ``phi``, the scale ``s`` (reflectivity, illumination,
    sensitivity) and the offset ``o`` (ambient light, black level, light scattered from the
    rest of the scene). Sets with the same pitch and orientation see the same ``phi`` and ``s``
    at a pixel. The global ``gamma`` and all per-pixel parameters are fitted jointly by
    Levenberg-Marquardt least squares on the captured DN over a random subsample of pixels, the
    per-pixel blocks eliminated by the Schur complement (each iteration costs O(pixels)); a
    coarse scan of gamma in 1..4 picks the start. Pixels whose RMS residual is an outlier (above
    the median plus 5 robust standard deviations: edges, specular spots, defects) are dropped
    once. docs/gamma.md has the derivation and the evidence for each modelling choice.

    ``normalization``:

    * "shape" (default): ``o`` and ``s`` free per pixel; only the distorted wave's shape
      enters, so ambient light, reflectivity and contrast loss cannot bias gamma, and no white
      or black frame is needed. ``offset_per_set`` (default) gives each set its own offset:
      scattered light grows with the mean light a pattern projects, which differs between
      pre-distortions. Each pixel needs more usable samples than unknowns: two pre-distortions
      of a 3-step set (6 samples, 4 unknowns), or one set of N >= 4 steps.
    * "black_white": ``o = black``, ``s = white - black`` from captures of full black and full
      white (gray ``2^Bp - 1``); only ``phi`` is free, so one 3-step set suffices. Biased when
      the fringes' offset and contrast differ from black/white (scattered light).

    ``weighting``: "levels" (default) weights the samples so that they are uniform over the
    linear level ``u = (sent/full)^gamma`` they represent (iterated three times), so the fit
    approximates the response evenly over the requested range, the range a pre-compensated
    pattern uses, whatever pre-distortion the captures happened to use; "samples" weights every
    sample equally. For a projector that follows the power law both give the same gamma.

    The model evaluates the pattern at a continuous phase: fringes must be wide enough that
    projector pixels and optical blur do not reshape them (a ``RuntimeWarning`` below
    ``MIN_FRINGE_PITCH_PX`` = 32 projector pixels).

    Pixel selection: inside ``mask``; samples at 0 or ``2^B - 1`` are clipped and get zero
    weight (and in "black_white" mode, pixels with a clipped black or white are dropped); a
    pixel needs a peak-to-peak of its usable samples of at least ``min_modulation`` DN (default
    10 % of full scale), more usable samples than unknowns, and two usable samples per set when
    each set has its own offset.

    Parameters
    ----------
    sets : sequence of (FringeSpec, gamma_hat, images)
        Each set's pattern (shift ``k`` of ``spec`` at ``images[k]``), the pre-compensation
        exponent it was generated with, and its captures ``(N, H, W)``. The sets share the
        exposure.
    camera_bit_depth, projector_bit_depth : int
    normalization : {"shape", "black_white"}
    black, white : array_like (H, W), optional
        Captures of full black and full white; required for "black_white".
    offset_per_set : bool
        "shape" mode: one offset per set at each pixel (default) or one for all sets.
    weighting : {"levels", "samples"}
    mask : array_like of bool (H, W), optional
    max_pixels : int
        Random subsample of usable pixels per group (deterministic with ``seed``).
    min_modulation : float, optional
    gamma_init : float
        Added to the coarse scan of starting values.
    seed : int

    Returns
    -------
    GammaFit
        ``method = "fringes"``; ``stderr`` a sandwich estimate clustered by pixel (it allows
        for the weights and for noise that varies between pixels, not for model error shared
        by all pixels); ``offset``, ``scale`` medians of the per-pixel values;
        ``rms_residual`` unweighted, in DN; ``levels``, ``sent``, ``dn`` a subsample of the
        samples for plotting (see :class:`GammaFit`); ``n_samples`` and ``n_pixels`` the pixels
        used over all groups.
    """
    _check_bits("camera", camera_bit_depth)
    _check_bits("projector", projector_bit_depth)
    if normalization not in ("shape", "black_white"):
        raise InputError(
            f"fringe gamma fit: normalization {normalization!r} unknown; use 'shape' or "
            "'black_white'"
        )
    if weighting not in ("levels", "samples"):
        raise InputError(
            f"fringe gamma fit: weighting {weighting!r} unknown; use 'levels' or 'samples'"
        )
    if not sets:
        raise InputError("fringe gamma fit: give at least one pre-distorted fringe set")
    full_c = _full(camera_bit_depth)
    full_p = _full(projector_bit_depth)
    thr = MIN_MODULATION_FRACTION * full_c if min_modulation is None else float(min_modulation)
    bw_mode = normalization == "black_white"

    by_group: dict[tuple[float, str], list[tuple[FringeSpec, float, NDArray]]] = {}
    shape: tuple[int, ...] | None = None
    for item in sets:
        if len(item) != 3:
            raise InputError("fringe gamma fit: give each set as (FringeSpec, gamma_hat, images)")
        spec, gh, imgs = item
        arr = np.asarray(imgs)
        if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has images of type {arr.dtype}; give "
                "numeric camera images"
            )
        shape = arr.shape[1:] if shape is None else shape
        if arr.ndim != 3 or arr.shape[0] != spec.steps or arr.shape[1:] != shape:
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has images of shape {arr.shape}; expected "
                f"({spec.steps}, *{shape}), one image per shift, all the same size"
            )
        if not (math.isfinite(gh) and gh > 0):
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has gamma_hat {gh}; give its positive "
                "pre-compensation exponent"
            )
        if spec.migl > full_p:
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has migl {spec.migl:g} above the "
                f"projector's maximum {full_p:g}; check projector_bit_depth"
            )
        if np.nanmax(arr) > full_c:
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has values up to {np.nanmax(arr):g}, above "
                f"2^{camera_bit_depth}-1; give the sensor's true bit depth"
            )
        if spec.pitch_px < MIN_FRINGE_PITCH_PX:
            warnings.warn(
                f"fringe gamma fit: set {spec.label()} has a pitch of {spec.pitch_px:g} projector "
                f"px; below {MIN_FRINGE_PITCH_PX:g} px projector pixels and blur reshape the "
                "fringes and bias gamma; use wide fringes (or uniform grays)",
                RuntimeWarning,
                stacklevel=2,
            )
        by_group.setdefault((spec.pitch_px, spec.orientation), []).append((spec, float(gh), arr))
    assert shape is not None
    sel = np.ones(shape, dtype=bool) if mask is None else _region(shape, None, mask)
    b_img = w_img = None
    if bw_mode:
        if black is None or white is None:
            raise InputError(
                "fringe gamma fit: normalization 'black_white' needs the black and white "
                "captures; pass black= and white= or use normalization='shape'"
            )
        b_img = np.asarray(black, dtype=np.float64)
        w_img = np.asarray(white, dtype=np.float64)
        if b_img.shape != shape or w_img.shape != shape:
            raise InputError(
                f"fringe gamma fit: black/white shapes {b_img.shape}/{w_img.shape} differ from "
                f"the fringe images {shape}; give captures of the same camera"
            )
        sel &= (w_img < full_c) & (b_img > 0) & (w_img - b_img >= thr)

    rng = np.random.default_rng(seed)
    groups: list[_Group] = []
    for members in by_group.values():
        y_all = np.concatenate([m[2].reshape(m[2].shape[0], -1) for m in members])
        n_sets = len(members)
        n_par = 1 if bw_mode else 2 + (n_sets if offset_per_set else 1)
        valid = (y_all > 0) & (y_all < full_c)
        if np.issubdtype(y_all.dtype, np.floating):
            valid &= np.isfinite(y_all)
        # peak-to-peak of the usable samples, without a float copy of the full images
        hi = np.max(np.where(valid, y_all, 0), axis=0).astype(np.float64)
        top = np.iinfo(y_all.dtype).max if np.issubdtype(y_all.dtype, np.integer) else full_c
        lo = np.min(np.where(valid, y_all, y_all.dtype.type(top)), axis=0).astype(np.float64)
        ok = sel.ravel() & (valid.sum(axis=0) > n_par) & (hi - lo >= thr)
        if offset_per_set and not bw_mode and n_sets > 1:
            start = 0
            for spec, _, _ in members:
                ok &= valid[start : start + spec.steps].sum(axis=0) >= 2
                start += spec.steps
        idx = np.flatnonzero(ok)
        if idx.size > max_pixels:
            idx = np.sort(rng.choice(idx, max_pixels, replace=False))
        if idx.size == 0:
            continue
        specs = [m[0] for m in members]
        groups.append(
            _Group(
                y=y_all[:, idx].astype(np.float64),
                valid=valid[:, idx].astype(np.float64),
                delta=np.concatenate([s.shifts for s in specs]),
                lo=np.concatenate([np.full(s.steps, s.imin / full_p) for s in specs]),
                amp=np.concatenate([np.full(s.steps, (s.migl - s.imin) / full_p) for s in specs]),
                inv_gh=np.concatenate([np.full(m[0].steps, 1.0 / m[1]) for m in members]),
                pattern=[s.pattern for s in specs for _ in range(s.steps)],
                set_of=np.concatenate([np.full(s.steps, i) for i, s in enumerate(specs)]),
                offset_per_set=offset_per_set,
                black=None if b_img is None else b_img.ravel()[idx],
                span=None if w_img is None or b_img is None else (w_img - b_img).ravel()[idx],
            )
        )
    if not groups:
        need = "one set" if bw_mode else "two pre-distortions of a set (or N >= 4 steps)"
        raise InputError(
            f"fringe gamma fit: no pixel has enough unclipped, modulated samples; give {need} "
            f"captured without saturation and with a peak-to-peak above {thr:g} DN"
        )

    # start: a coarse scan of gamma on a small subsample, per-pixel parameters refined each time
    scan = [g.take(np.sort(rng.permutation(g.y.shape[1])[:1500])) for g in groups]
    best = (math.inf, float(gamma_init))
    for g0 in sorted({float(gamma_init), 1.0, 1.5, 2.0, 2.5, 3.0, 4.0}):
        prm = [_init_params(g, g0) for g in scan]
        c = _levenberg_marquardt(scan, prm, g0, fix_gamma=True, max_iter=15)[2]
        if c < best[0]:
            best = (c, g0)
    gamma = best[1]
    params = [_init_params(g, gamma) for g in groups]
    params, _, _ = _levenberg_marquardt(groups, params, gamma, fix_gamma=True, max_iter=20)
    params, gamma, _ = _levenberg_marquardt(groups, params, gamma, fix_gamma=False, max_iter=100)

    # drop outlier pixels once and refit
    for i, (grp, prm) in enumerate(zip(groups, params, strict=True)):
        r = _residual(grp, prm, gamma)
        rms_px = np.sqrt(np.sum(grp.valid * r * r, 0) / np.sum(grp.valid, 0))
        med = float(np.median(rms_px))
        mad = 1.4826 * float(np.median(np.abs(rms_px - med)))
        keep = rms_px <= med + 5 * max(mad, 1e-6 * max(med, 1e-9))
        if not bw_mode:
            keep &= prm[1] > 0
        groups[i] = grp.take(keep)
        params[i] = prm[:, keep]
    if weighting == "levels":
        for _ in range(3):
            _level_weights(groups, params, gamma)
            params, gamma, _ = _levenberg_marquardt(
                groups, params, gamma, fix_gamma=False, max_iter=100
            )
    else:
        params, gamma, _ = _levenberg_marquardt(
            groups, params, gamma, fix_gamma=False, max_iter=100
        )
    stderr = _gamma_stderr(groups, params, gamma)

    # summary and samples for plotting, mapped to the median offset and scale
    n_valid = sum(float(g.valid.sum()) for g in groups)
    ssr = sum(
        float(np.sum(g.valid * _residual(g, p, gamma) ** 2))
        for g, p in zip(groups, params, strict=True)
    )
    offs, scs = [], []
    for grp, prm in zip(groups, params, strict=True):
        off, sc = _offset_scale(grp, prm)
        offs.append(np.asarray(off).mean(axis=0))
        scs.append(np.asarray(sc)[0])
    offset = float(np.median(np.concatenate(offs)))
    scale = float(np.median(np.concatenate(scs)))
    lv, st, dn = [], [], []
    per = max(1, 5000 // len(groups))
    for grp, prm in zip(groups, params, strict=True):
        m = grp.y.shape[1]
        take = np.arange(m) if m <= per else np.sort(rng.choice(m, per, replace=False))
        sub, sp = grp.take(take), prm[:, take]
        h, _ = sub.pattern_value(sp[0])
        x = _basis(sub, sp[0], gamma)[3]
        off, sc = _offset_scale(sub, sp)
        good = sub.valid > 0
        lv.append((full_p * h)[good])
        st.append((full_p * x)[good])
        dn.append((offset + scale * (sub.y - off) / sc)[good])
    levels = np.concatenate(lv)
    n_pix = sum(g.y.shape[1] for g in groups)
    return GammaFit(
        gamma=float(gamma),
        stderr=stderr,
        ci95=(float(gamma - 1.96 * stderr), float(gamma + 1.96 * stderr)),
        offset=offset,
        scale=scale,
        rms_residual=float(np.sqrt(ssr / max(n_valid, 1.0))),
        method="fringes",
        normalization=normalization,
        levels=levels,
        sent=np.concatenate(st),
        dn=np.concatenate(dn),
        used=np.ones(levels.size, dtype=bool),
        projector_bit_depth=int(projector_bit_depth),
        camera_bit_depth=int(camera_bit_depth),
        n_samples=int(n_pix),
        n_pixels=int(n_pix),
    )


# ---------------------------------------------------------------------------------------------
# plot
# ---------------------------------------------------------------------------------------------


def plot_gamma_mapping(
    fit: GammaFit,
    path: str | Path,
    gamma_hat: float | None = None,
    *,
    measured_levels: ArrayLike | None = None,
    measured_dn: ArrayLike | None = None,
    title: str | None = None,
    dpi: int = 120,
) -> Path:
    """Thesis Fig. 2.6 b/c as a PNG: input gray -> captured intensity without and with correction.

    (b) the captured samples against the gray sent to the projector, with the fitted curve
    (excluded samples as crosses). (c) requested (linear) gray -> captured intensity after
    pre-compensation with ``gamma_hat`` (default: the fitted gamma): the fit's prediction, the
    samples of (b) re-indexed by the requested level that would send their gray
    (``full * (sent/full)^gamma_hat``), captures made with that pre-compensation when given
    (``measured_levels``, ``measured_dn``), and the ideal straight line
    ``offset + scale * g/full``. Written with the Agg backend (no display needed).

    Returns
    -------
    Path
        ``path``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gh = fit.gamma if gamma_hat is None else float(gamma_hat)
    full = _full(fit.projector_bit_depth)
    g = np.arange(0.0, full + 1.0) if full <= 1023 else np.linspace(0.0, full, 1024)
    many = fit.sent.size > 300
    style = {"ms": 1, "alpha": 0.25} if many else {"ms": 4}
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.4), dpi=dpi)
    used = fit.used
    ax1.plot(fit.sent[used], fit.dn[used], "o", color="C0", label="captured", **style)
    if np.any(~used):
        ax1.plot(fit.sent[~used], fit.dn[~used], "x", color="C3", label="excluded (clipped)")
    ax1.plot(g, fit.predict(g), "-", color="C1", label=f"fit, gamma = {fit.gamma:.3f}")
    ax1.set(
        xlabel="gray level sent to the projector",
        ylabel="captured intensity (DN)",
        title="(b) without correction",
    )
    ax1.legend(loc="upper left")

    pred = fit.predict_precompensated(g, gh)
    nl = measure_nonlinearity(g, fit, gh, fit.projector_bit_depth)
    ideal = fit.offset + fit.scale * g / full
    remapped = full * (np.clip(fit.sent, 0, full) / full) ** gh
    ax2.plot(remapped[used], fit.dn[used], "o", color="C0", label="samples of (b)", **style)
    ax2.plot(g, pred, "-", color="C1", label=f"predicted, max dev. {nl.max_percent:.2f} %")
    if measured_levels is not None and measured_dn is not None:
        ml = np.asarray(measured_levels, dtype=np.float64)
        md = np.asarray(measured_dn, dtype=np.float64)
        mnl = line_deviation(ml, md)
        ax2.plot(ml, md, "s", color="C2", ms=4, label=f"measured, max dev. {mnl.max_percent:.2f} %")
    ax2.plot(g, ideal, "--", color="k", lw=1, label="ideal (linear)")
    ax2.set(
        xlabel="requested (linear) gray level",
        ylabel="captured intensity (DN)",
        title=f"(c) with pre-compensation, gamma-hat = {gh:.3f}",
    )
    ax2.legend(loc="upper left")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out)
    plt.close(fig)
    return out
