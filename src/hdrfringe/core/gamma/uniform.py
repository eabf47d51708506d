"""Projector gamma from captures of uniform gray frames (thesis Sec. 2.6, Eq. 2.16, Fig. 2.6 b).

:func:`fit_gamma_uniform` fits ``DN = c0 + c1 * (sent/full)^gamma`` to the captured intensity of
uniform grays by robust nonlinear least squares (``scipy.optimize.least_squares``).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize, special

from hdrfringe.core._validation import check_bit_depth, full_scale, is_saturated
from hdrfringe.core.gamma.model import CLIP_MARGIN_FRACTION, MAX_CLIPPED_FRACTION, GammaFit
from hdrfringe.core.gamma.selection import _region
from hdrfringe.core.patterns import precompensate_gamma
from hdrfringe.errors import InputError

__all__ = ["fit_gamma_uniform"]

F64 = NDArray[np.float64]


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

    Raises
    ------
    InputError
        Bad bit depths, shapes, levels, region or reducer, values above ``2^B - 1``, or fewer
        than 4 usable levels (3 distinct non-zero).

    References
    ----------
    Thesis Sec. 2.6: Eq. 2.16 (the power law) and Fig. 2.6 b (input gray -> captured
    intensity), Eq. 2.17 (the pre-compensation the captures may have been sent with).

    Examples
    --------
    >>> g = np.arange(0, 256, 16.0)
    >>> fit = fit_gamma_uniform(g, 12 + 200 * (g / 255) ** 2.2, camera_bit_depth=8)
    >>> round(fit.gamma, 3)
    2.2
    """
    check_bit_depth(camera_bit_depth, "camera bit depth")
    full_p = float(full_scale(projector_bit_depth, "projector bit depth"))
    full_c = float(full_scale(camera_bit_depth))
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
            frac[i] = np.mean((vals <= 0) | is_saturated(vals, camera_bit_depth))
            y[i] = np.median(vals) if reducer == "median" else np.mean(vals)
        clipped = frac > max_clipped_fraction
    else:
        raise InputError(
            f"gamma fit: captures of shape {data.shape}; give images (L, H, W) or means (L,)"
        )
    if np.any((lv < 0) | (lv > full_p)):
        raise InputError(
            f"gamma fit: levels must lie in 0..{full_p:g} for a {projector_bit_depth}-bit projector"
        )
    sent = precompensate_gamma(lv, gamma_precompensation, projector_bit_depth).astype(np.float64)
    x = sent / full_p
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
    p: F64 = sol.x
    r = resid(p)
    dof = x.size - 3
    cov: F64 | None = None
    if dof > 0:
        j = _power_law_jac(p, x)
        try:
            cov = np.asarray(np.linalg.inv(j.T @ j) * float(np.sum(r * r) / dof), np.float64)
        except np.linalg.LinAlgError:
            cov = None
    return p, cov, r
