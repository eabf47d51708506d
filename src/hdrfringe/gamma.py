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
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize, stats

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

Normalization = Literal["shape", "black_white"]


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

    def predict_precompensated(
        self, levels: ArrayLike, gamma_hat: float | None = None
    ) -> F64:
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
    data = np.asarray(images_or_means, dtype=np.float64)
    n_px = 0
    if data.ndim == 1:
        if data.shape[0] != lv.size:
            raise InputError(
                f"gamma fit: {lv.size} levels but {data.shape[0]} means; give one mean per level"
            )
        y = data
        margin = CLIP_MARGIN_FRACTION * full_c if clip_margin is None else float(clip_margin)
        clipped = (y <= margin) | (y >= full_c - margin)
    elif data.ndim == 3:
        if data.shape[0] != lv.size:
            raise InputError(
                f"gamma fit: {lv.size} levels but {data.shape[0]} images; give one image per level"
            )
        if np.nanmax(data) > full_c:
            raise InputError(
                f"gamma fit: image values up to {np.nanmax(data):g} exceed 2^{camera_bit_depth}-1;"
                " give the sensor's true bit depth"
            )
        sel = _region(data.shape[1:], roi, mask)
        vals = data[:, sel]
        n_px = int(vals.shape[1])
        frac = np.mean((vals <= 0) | (vals >= full_c), axis=1)
        y = np.median(vals, axis=1) if reducer == "median" else np.mean(vals, axis=1)
        if reducer not in ("mean", "median"):
            raise InputError(f"gamma fit: reducer {reducer!r} unknown; use 'mean' or 'median'")
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
    tq = float(stats.t.ppf(0.975, dof)) if dof > 0 else math.inf
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
    """Sets sharing the per-pixel phase: their samples at the chosen pixels, and the model."""

    y: F64  # (K, M) captured DN
    w: F64  # (K, M) sample weights (0: clipped)
    delta: F64  # (K,) phase shift of each sample: pattern cos(phi + delta)
    lo: F64  # (K,) imin / full
    amp: F64  # (K,) (migl - imin) / full
    inv_gh: F64  # (K,) 1 / gamma-hat of each sample's set
    pattern: list[str]  # (K,)
    set_of: NDArray[np.intp]  # (K,) index of each sample's set within the group
    n_sets: int
    share: bool = True  # one offset and scale per pixel for all sets (else per set)
    black: F64 | None = None  # (M,) black_white mode
    span: F64 | None = None  # (M,) white - black

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
            else:  # triangular: 1 - 4|t - round(t)|, slope -4 sign(t - round(t)) per period
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


def _offset_scale(grp: _Group, params: F64) -> tuple[F64, F64]:
    """Per-sample offset and scale (K, M) from the per-pixel parameters."""
    if grp.black is not None and grp.span is not None:
        k = grp.y.shape[0]
        return np.broadcast_to(grp.black, (k, grp.black.size)), np.broadcast_to(
            grp.span, (k, grp.span.size)
        )
    nb = (params.shape[0] - 1) // 2
    idx = grp.set_of if nb > 1 else np.zeros_like(grp.set_of)
    return params[1 + 2 * idx], params[2 + 2 * idx]


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
        nb = (p - 1) // 2
        idx = grp.set_of if nb > 1 else np.zeros_like(grp.set_of)
        for kk in range(k):
            jac[:, kk, 1 + 2 * idx[kk]] = sw[kk]
            jac[:, kk, 2 + 2 * idx[kk]] = f[kk] * sw[kk]
    jg = sc * f_gamma * sw
    return e, jac, jg


def _cost(groups: list[_Group], params: list[F64], gamma: float) -> float:
    total = 0.0
    for grp, prm in zip(groups, params, strict=True):
        f = _basis(grp, prm[0], gamma)[0]
        off, sc = _offset_scale(grp, prm)
        total += float(np.sum(grp.w * (off + sc * f - grp.y) ** 2))
    return total


def _lm_step(
    groups: list[_Group], params: list[F64], gamma: float, lam: float, fix_gamma: bool
) -> tuple[list[F64], float, float, float]:
    """One damped Gauss-Newton step; the per-pixel blocks are eliminated by the Schur complement.

    Returns the new parameters, gamma, the Schur complement (gamma's normal-equation entry with
    the per-pixel parameters eliminated, undamped part not available when damped) and the
    undamped Schur complement at the current point.
    """
    blocks = []
    s_damped = 0.0
    s_plain = 0.0
    rhs = 0.0
    for grp, prm in zip(groups, params, strict=True):
        e, jac, jg = _jacobians(grp, prm, gamma)
        u = np.einsum("mki,mkj->mij", jac, jac)
        wv = np.einsum("mki,km->mi", jac, jg)
        gl = np.einsum("mki,km->mi", jac, e)
        diag = np.einsum("mii->mi", u)
        ud = u + lam * np.einsum("mi,ij->mij", np.maximum(diag, 1e-12), np.eye(u.shape[1]))
        ud += 1e-12 * np.eye(u.shape[1])
        sol = np.linalg.solve(ud, np.stack([wv, gl], axis=2))  # (M, P, 2)
        uw, ug = sol[..., 0], sol[..., 1]
        v = float(np.sum(jg * jg))
        s_damped += v * (1 + lam) - float(np.sum(wv * uw))
        rhs += float(np.sum(jg * e)) - float(np.sum(wv * ug))
        sol0 = np.linalg.solve(u + 1e-12 * np.eye(u.shape[1]), wv[..., None])[..., 0]
        s_plain += v - float(np.sum(wv * sol0))
        blocks.append((uw, ug))
    dg = 0.0 if fix_gamma or s_damped <= 0 else -rhs / s_damped
    new = []
    for (uw, ug), prm in zip(blocks, params, strict=True):
        d = -(ug + uw * dg)
        step = d.T.copy()
        step[0] = np.clip(step[0], -0.5, 0.5)  # phase steps of at most ~30 degrees
        new.append(prm + step)
    return new, gamma + dg, s_damped, s_plain


def _levenberg_marquardt(
    groups: list[_Group], params: list[F64], gamma: float, *, fix_gamma: bool, max_iter: int
) -> tuple[list[F64], float, float]:
    lam = 1e-3
    cost = _cost(groups, params, gamma)
    for _ in range(max_iter):
        new, g_new, _, _ = _lm_step(groups, params, gamma, lam, fix_gamma)
        g_new = float(np.clip(g_new, 0.05, 20.0))
        c_new = _cost(groups, new, g_new)
        if np.isfinite(c_new) and c_new <= cost:
            done = abs(g_new - gamma) < 1e-7 and cost - c_new <= 1e-10 * cost
            params, gamma, cost = new, g_new, c_new
            lam = max(lam / 5, 1e-9)
            if done:
                break
        else:
            lam *= 10
            if lam > 1e8:
                break
    return params, gamma, cost


def _init_params(grp: _Group, gamma: float) -> F64:
    """Phase from the samples' first Fourier component; offset and scale by linear LS."""
    c = np.sum(grp.w * grp.y * np.cos(grp.delta)[:, None], axis=0)
    s = -np.sum(grp.w * grp.y * np.sin(grp.delta)[:, None], axis=0)
    phi = np.arctan2(s, c)
    if grp.black is not None:
        return phi[None, :]
    f = _basis(grp, phi, gamma)[0]
    nb = 1 if grp.n_sets == 1 or grp.share else grp.n_sets
    rows = [phi]
    for b in range(nb):
        sel = (grp.set_of == b) if nb > 1 else np.ones(grp.y.shape[0], dtype=bool)
        w, y, ff = grp.w[sel], grp.y[sel], f[sel]
        sw = np.sum(w, axis=0)
        mf = np.sum(w * ff, axis=0) / sw
        my = np.sum(w * y, axis=0) / sw
        sxx = np.sum(w * (ff - mf) ** 2, axis=0)
        sxy = np.sum(w * (ff - mf) * (y - my), axis=0)
        a = np.where(sxx > 0, sxy / np.maximum(sxx, 1e-30), 0.0)
        rows += [my - a * mf, a]
    return np.stack(rows)


def fit_gamma_fringes(
    sets: Sequence[tuple[FringeSpec, float, ArrayLike]],
    *,
    camera_bit_depth: int,
    projector_bit_depth: int = 8,
    normalization: Normalization = "shape",
    black: ArrayLike | None = None,
    white: ArrayLike | None = None,
    share_offset_scale: bool = True,
    mask: ArrayLike | None = None,
    max_pixels: int = 20000,
    min_modulation: float | None = None,
    gamma_init: float = 2.0,
    seed: int = 0,
) -> GammaFit:
    """Fit the projector gamma to phase-shifted fringes pre-distorted with known exponents.

    A pattern value ``g_k = imin + (migl - imin) * (1 + P(phi + delta_k)) / 2`` (the contract's
    convention; ``P`` the sinusoidal or triangular profile) is sent as
    ``full * (g_k/full)^(1/gamma-hat)`` and reaches the camera as

        ``I_k = o + s * (g_k/full)^(gamma / gamma-hat)``     (Eq. 2.16-2.17)

    with, per pixel, the phase ``phi`` and the offset ``o`` (ambient light, black level) and
    scale ``s`` (reflectivity, illumination, sensitivity). Sets with the same pitch and
    orientation see the same ``phi`` at a pixel. The single global ``gamma`` and all per-pixel
    parameters are fitted jointly by Levenberg-Marquardt least squares on the captured DN over a
    random subsample of pixels; the per-pixel blocks are eliminated by the Schur complement, so
    each iteration costs O(pixels). Pixels whose RMS residual is an outlier (more than the
    median plus 5 robust standard deviations: edges, specular spots) are dropped once and the
    fit is repeated.

    ``normalization``:

    * "shape" (default): ``o`` and ``s`` are free per pixel (shared by the sets of a group when
      ``share_offset_scale``, i.e. same exposure and lighting; else per set). Only the distorted
      wave's shape enters, so offsets and contrast loss cannot bias gamma. Each pixel needs more
      samples than unknowns: two pre-distortions of a 3-step set, or one set of N >= 4.
    * "black_white": ``o = black`` and ``s = white - black`` from captures of full black and
      full white (the projector's maximum input level); only ``phi`` is free, so one 3-step set
      suffices. Biased when the fringes' contrast differs from white/black (scattered light).

    Pixel selection: inside ``mask``; samples at 0 or ``2^B - 1`` are given zero weight (and in
    "black_white" mode, pixels with a clipped black or white are dropped); a pixel needs a
    peak-to-peak of its usable samples of at least ``min_modulation`` DN (default 10 % of full
    scale) and more usable samples than unknowns.

    Parameters
    ----------
    sets : sequence of (FringeSpec, gamma_hat, images)
        Each set's pattern (shift ``k`` of ``spec`` at ``images[k]``), the pre-compensation
        exponent it was generated with, and its captures ``(N, H, W)``.
    camera_bit_depth, projector_bit_depth : int
    normalization : {"shape", "black_white"}
    black, white : array_like (H, W), optional
        Captures of full black and full white; required for "black_white".
    share_offset_scale : bool
        "shape" mode: one offset and scale per pixel for all sets of a group (default) or one
        per set (when exposures differ; needs more samples per set).
    mask : array_like of bool (H, W), optional
    max_pixels : int
        Random subsample of usable pixels per group (deterministic with ``seed``).
    min_modulation : float, optional
    gamma_init : float
        Starting value; a coarse scan of 1..4 picks a better one when the fit allows.
    seed : int

    Returns
    -------
    GammaFit
        ``method = "fringes"``; ``offset`` and ``scale`` are medians of the per-pixel values;
        ``levels``, ``sent``, ``dn`` a subsample of the samples for plotting (see
        :class:`GammaFit`); ``n_samples`` and ``n_pixels`` the pixels used over all groups.
    """
    _check_bits("camera", camera_bit_depth)
    _check_bits("projector", projector_bit_depth)
    if normalization not in ("shape", "black_white"):
        raise InputError(
            f"fringe gamma fit: normalization {normalization!r} unknown; use 'shape' or "
            "'black_white'"
        )
    if not sets:
        raise InputError("fringe gamma fit: give at least one pre-distorted fringe set")
    full_c = _full(camera_bit_depth)
    full_p = _full(projector_bit_depth)
    thr = MIN_MODULATION_FRACTION * full_c if min_modulation is None else float(min_modulation)

    by_group: dict[tuple[float, str], list[tuple[FringeSpec, float, F64]]] = {}
    shape: tuple[int, ...] | None = None
    for item in sets:
        if len(item) != 3:
            raise InputError("fringe gamma fit: give each set as (FringeSpec, gamma_hat, images)")
        spec, gh, imgs = item
        arr = np.asarray(imgs, dtype=np.float64)
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
        by_group.setdefault((spec.pitch_px, spec.orientation), []).append((spec, float(gh), arr))
    assert shape is not None
    sel = np.ones(shape, dtype=bool) if mask is None else _region(shape, None, mask)
    bw: tuple[F64, F64] | None = None
    if normalization == "black_white":
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
                f"the fringe images {shape}"
            )
        sel &= (w_img < full_c) & (b_img > 0) & (w_img - b_img >= thr)
        bw = (b_img, w_img)

    rng = np.random.default_rng(seed)
    groups: list[_Group] = []
    n_free_base = 1 if normalization == "black_white" else None
    for members in by_group.values():
        y_full = np.concatenate([m[2].reshape(m[2].shape[0], -1) for m in members])
        if np.nanmax(y_full) > full_c:
            raise InputError(
                f"fringe gamma fit: image values up to {np.nanmax(y_full):g} exceed "
                f"2^{camera_bit_depth}-1; give the sensor's true bit depth"
            )
        n_sets = len(members)
        if n_free_base is not None:
            n_par = 1
        elif share_offset_scale or n_sets == 1:
            n_par = 3
        else:
            n_par = 1 + 2 * n_sets
        valid = (y_full > 0) & (y_full < full_c) & np.isfinite(y_full)
        nvalid = valid.sum(axis=0)
        yv = np.where(valid, y_full, np.nan)
        with np.errstate(invalid="ignore"):
            ptp = np.nanmax(yv, axis=0) - np.nanmin(yv, axis=0)
        ok = sel.ravel() & (nvalid > n_par) & (np.nan_to_num(ptp) >= thr)
        if not share_offset_scale and n_free_base is None and n_sets > 1:
            # each set needs more than its own offset and scale
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
        grp = _Group(
            y=y_full[:, idx],
            w=valid[:, idx].astype(np.float64),
            delta=np.concatenate([s.shifts for s in specs]),
            lo=np.concatenate([np.full(s.steps, s.imin / full_p) for s in specs]),
            amp=np.concatenate([np.full(s.steps, (s.migl - s.imin) / full_p) for s in specs]),
            inv_gh=np.concatenate([np.full(s.steps, 1.0 / m[1]) for s, m in zip(specs, members,
                                                                             strict=True)]),
            pattern=[s.pattern for s in specs for _ in range(s.steps)],
            set_of=np.concatenate([np.full(s.steps, i) for i, s in enumerate(specs)]),
            n_sets=n_sets,
            share=share_offset_scale,
        )
        if bw is not None:
            grp.black = bw[0].ravel()[idx]
            grp.span = bw[1].ravel()[idx] - grp.black
        groups.append(grp)
    if not groups:
        need = "one set" if normalization == "black_white" else (
            "two pre-distortions of a set (or N >= 4 steps)"
        )
        raise InputError(
            "fringe gamma fit: no pixel has enough unclipped, modulated samples; give " + need
            + f" captured without saturation and with a peak-to-peak above {thr:g} DN"
        )

    # start: a coarse scan of gamma on a small subsample, per-pixel parameters refined each time
    scan_groups = [_subsample(g, 1500, rng) for g in groups]
    best = (math.inf, float(gamma_init))
    for g0 in sorted({float(gamma_init), 1.0, 1.5, 2.0, 2.5, 3.0, 4.0}):
        prm = [_init_params(g, g0) for g in scan_groups]
        prm, _, c = _levenberg_marquardt(scan_groups, prm, g0, fix_gamma=True, max_iter=15)
        if c < best[0]:
            best = (c, g0)
    gamma = best[1]
    params = [_init_params(g, gamma) for g in groups]
    params, _, _ = _levenberg_marquardt(groups, params, gamma, fix_gamma=True, max_iter=20)
    params, gamma, _ = _levenberg_marquardt(groups, params, gamma, fix_gamma=False, max_iter=100)

    # drop outlier pixels once and refit
    keep_any = False
    for i, (grp, prm) in enumerate(zip(groups, params, strict=True)):
        f = _basis(grp, prm[0], gamma)[0]
        off, sc = _offset_scale(grp, prm)
        rms_px = np.sqrt(np.sum(grp.w * (off + sc * f - grp.y) ** 2, 0) / np.sum(grp.w, 0))
        med = float(np.median(rms_px))
        mad = 1.4826 * float(np.median(np.abs(rms_px - med)))
        keep = (rms_px <= med + 5 * max(mad, 1e-6 * max(med, 1e-9))) & (sc.min(axis=0) > 0)
        if not keep.all():
            keep_any = True
            groups[i] = _take(grp, keep)
            params[i] = prm[:, keep]
    if keep_any:
        params, gamma, _ = _levenberg_marquardt(
            groups, params, gamma, fix_gamma=False, max_iter=100
        )

    cost = _cost(groups, params, gamma)
    n_res = sum(float(g.w.sum()) for g in groups)
    n_par = 1 + sum(p.size for p in params)
    _, _, _, s_plain = _lm_step(groups, params, gamma, 0.0, True)
    s2 = cost / max(n_res - n_par, 1.0)
    stderr = float(np.sqrt(s2 / s_plain)) if s_plain > 0 else math.nan

    # samples for plotting, mapped to the median offset and scale
    offs, scs, lv, st, dn = [], [], [], [], []
    for grp, prm in zip(groups, params, strict=True):
        off, sc = _offset_scale(grp, prm)
        offs.append(np.asarray(off)[0] if grp.black is not None else prm[1])
        scs.append(np.asarray(sc)[0] if grp.black is not None else prm[2])
    offset = float(np.median(np.concatenate(offs)))
    scale = float(np.median(np.concatenate(scs)))
    n_pix = sum(g.y.shape[1] for g in groups)
    per = max(1, 5000 // max(len(groups), 1))
    for grp, prm in zip(groups, params, strict=True):
        m = grp.y.shape[1]
        take = np.arange(m) if m <= per else np.sort(rng.choice(m, per, replace=False))
        h, _ = grp.pattern_value(prm[0, take])
        _, _, _, x = _basis(grp, prm[0, take], gamma)
        off, sc = _offset_scale(grp, prm[:, take])
        good = grp.w[:, take] > 0
        lv.append((full_p * h)[good])
        st.append((full_p * x)[good])
        dn.append((offset + scale * (grp.y[:, take] - off) / sc)[good])
    levels = np.concatenate(lv)
    return GammaFit(
        gamma=float(gamma),
        stderr=stderr,
        ci95=(float(gamma - 1.96 * stderr), float(gamma + 1.96 * stderr)),
        offset=offset,
        scale=scale,
        rms_residual=float(np.sqrt(cost / n_res)),
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


def _take(grp: _Group, keep: NDArray[np.bool_]) -> _Group:
    new = _Group(
        y=grp.y[:, keep], w=grp.w[:, keep], delta=grp.delta, lo=grp.lo, amp=grp.amp,
        inv_gh=grp.inv_gh, pattern=grp.pattern, set_of=grp.set_of, n_sets=grp.n_sets,
        share=grp.share,
        black=None if grp.black is None else grp.black[keep],
        span=None if grp.span is None else grp.span[keep],
    )
    return new


def _subsample(grp: _Group, n: int, rng: np.random.Generator) -> _Group:
    m = grp.y.shape[1]
    if m <= n:
        return grp
    keep = np.zeros(m, dtype=bool)
    keep[rng.choice(m, n, replace=False)] = True
    return _take(grp, keep)


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
