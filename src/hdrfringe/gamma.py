"""Projector gamma: estimation from uniform-gray or fringe captures, and the residual nonlinearity.

The projector maps a normalised input ``u`` to light ``w = u^gamma`` (thesis Eq. 2.16); patterns
are pre-compensated with an estimate gamma-hat so that ``w = (u^(1/gamma-hat))^gamma`` is close
to linear (Eq. 2.17). The thesis chose gamma-hat = 2.812 by hand from the input-to-captured
mapping (Fig. 2.6); here it is fitted.

* :func:`fit_gamma_uniform`: uniform grays ``g`` sent (after any pre-compensation in use) and
  the captured means: ``DN = c0 + c1 * (sent/full)^gamma``, nonlinear least squares with a
  robust loss; saturated and unlit samples excluded. ``c0`` absorbs ambient light and the
  projector's black level, ``c1`` reflectivity and camera sensitivity (Eq. 3.3).
* :func:`fit_gamma_fringes`: sinusoidal fringes pre-distorted with known exponents: gamma is
  the exponent that makes every pixel's samples fit the distorted wave's *shape*, with the
  pixel's offset, scale and phase free (so ambient light, reflectivity and contrast loss do not
  bias it; no white or black frame needed).
* :func:`residual_nonlinearity`, :func:`predicted_nonlinearity`: how far input-to-captured is
  from a straight line, in percent of the captured range.
* :func:`plot_gamma_mapping`: thesis Fig. 2.6 b/c.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize

from hdrfringe.errors import InputError
from hdrfringe.patterns import FringeSpec, precompensate_gamma

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class GammaFit:
    """Result of a gamma fit.

    Attributes
    ----------
    gamma : float
        The projector's own gamma (Eq. 2.16), independent of any pre-compensation used.
    stderr : float
        Standard error of ``gamma`` from the fit's Jacobian (uniform) or the curvature of the
        objective (fringes).
    offset, scale : float
        ``c0`` and ``c1`` of ``DN = c0 + c1 * (sent/full)^gamma`` (uniform fits; NaN otherwise).
    rms_residual : float
        RMS of the fit residual (DN for uniform fits; normalised units for fringe fits).
    method : str
        "uniform" or "fringes".
    levels, sent, dn : ndarray
        Data used (uniform fits): linear levels requested, grays sent, captured means.
    projector_bit_depth : int
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
    projector_bit_depth: int = 8
    n_samples: int = 0


def _full(bits: int) -> float:
    return float(2**bits - 1)


def fit_gamma_uniform(
    levels: ArrayLike,
    dn: ArrayLike,
    *,
    camera_bit_depth: int,
    projector_bit_depth: int = 8,
    gamma_precompensation: float = 1.0,
) -> GammaFit:
    """Fit the projector gamma to uniform-gray captures (Eq. 2.16).

    Parameters
    ----------
    levels : array_like
        Requested (linear) gray levels of the uniform frames.
    dn : array_like
        Captured mean intensity of each frame in DN (e.g. the mean over a region of interest).
    camera_bit_depth : int
        Samples at or within 0.5 DN of ``2^B - 1`` are saturated and excluded.
    projector_bit_depth : int
    gamma_precompensation : float
        The gamma-hat the frames were sent with; the sent gray is
        ``precompensate_gamma(level, gamma_hat)``, so the fitted gamma is the projector's own.

    Returns
    -------
    GammaFit
    """
    lv = np.asarray(levels, dtype=np.float64).ravel()
    y = np.asarray(dn, dtype=np.float64).ravel()
    if lv.shape != y.shape:
        raise InputError(f"gamma fit: {lv.size} levels but {y.size} intensities; give one each")
    full = _full(projector_bit_depth)
    sent = precompensate_gamma(lv, gamma_precompensation, projector_bit_depth).astype(np.float64)
    x = sent / full
    keep = np.isfinite(y) & (y < _full(camera_bit_depth) - 0.5)
    if np.count_nonzero(keep & (x > 0)) < 4:
        raise InputError(
            f"gamma fit: only {np.count_nonzero(keep & (x > 0))} unsaturated non-zero gray levels; "
            "capture at least 4 uniform grays below saturation (e.g. 0, 32, ..., 255 with a "
            "smaller aperture)"
        )
    xs, ys = x[keep], y[keep]
    # start: c0 from the darkest sample, gamma from a log-log line through the rest
    c0 = float(ys[np.argmin(xs)]) if np.any(xs == 0) else float(ys.min()) * 0.5
    pos = (xs > 0) & (ys - c0 > 0)
    g0 = 2.2
    if np.count_nonzero(pos) >= 2:
        g0 = float(np.clip(np.polyfit(np.log(xs[pos]), np.log(ys[pos] - c0), 1)[0], 0.3, 6.0))
    c1 = float(max(ys.max() - c0, 1e-9))

    def resid(p: F64) -> F64:
        return p[0] + p[1] * np.power(xs, p[2]) - ys

    sol = optimize.least_squares(
        resid,
        [c0, c1, g0],
        bounds=([-np.inf, 0.0, 0.05], [np.inf, np.inf, 20.0]),
        loss="soft_l1",
        f_scale=max(1.0, 0.01 * c1),
    )
    r = resid(sol.x)
    dof = max(1, xs.size - 3)
    s2 = float(np.sum(r * r) / dof)
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * s2
        stderr = float(np.sqrt(max(cov[2, 2], 0.0)))
    except np.linalg.LinAlgError:
        stderr = float("nan")
    return GammaFit(
        gamma=float(sol.x[2]),
        stderr=stderr,
        offset=float(sol.x[0]),
        scale=float(sol.x[1]),
        rms_residual=float(np.sqrt(np.mean(r * r))),
        method="uniform",
        levels=lv[keep],
        sent=sent[keep],
        dn=ys,
        projector_bit_depth=projector_bit_depth,
        n_samples=int(xs.size),
    )


def residual_nonlinearity(levels: ArrayLike, dn: ArrayLike) -> tuple[float, float]:
    """Max and RMS deviation of ``levels -> dn`` from its best straight line, in % of range."""
    x = np.asarray(levels, dtype=np.float64).ravel()
    y = np.asarray(dn, dtype=np.float64).ravel()
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size < 3:
        raise InputError("residual nonlinearity needs at least 3 samples")
    a, b = np.polyfit(x, y, 1)
    dev = y - (a * x + b)
    rng = float(np.ptp(a * x + b)) or 1.0
    return float(100 * np.abs(dev).max() / rng), float(100 * np.sqrt(np.mean(dev**2)) / rng)


def predicted_nonlinearity(
    fit: GammaFit, gamma_hat: float, imin: float = 0.0, migl: float | None = None
) -> tuple[float, float]:
    """Residual nonlinearity the fit predicts for patterns pre-compensated with ``gamma_hat``.

    The requested levels ``imin..migl`` are pre-compensated and rounded at the projector's bit
    depth (Eq. 2.17) and mapped through the fitted ``c0 + c1 (sent/full)^gamma``.
    """
    full = _full(fit.projector_bit_depth)
    top = full if migl is None else migl
    g = np.linspace(imin, top, 256)
    sent = precompensate_gamma(g, gamma_hat, fit.projector_bit_depth) / full
    return residual_nonlinearity(g, fit.offset + fit.scale * sent**fit.gamma)


def fit_gamma_fringes(
    sets: Sequence[tuple[FringeSpec, float, ArrayLike]],
    *,
    camera_bit_depth: int,
    projector_bit_depth: int = 8,
    max_pixels: int = 6000,
    phase_steps: int = 720,
    min_modulation: float | None = None,
    seed: int = 0,
) -> GammaFit:
    """Fit the projector gamma to the *shape* of sinusoidal fringes pre-distorted with known gammas.

    Model: a pattern value ``g = imin + (migl - imin) * (1 + cos(phi + delta_k)) / 2`` sent with
    pre-compensation gamma-hat reaches the camera as ``I_k = o + s * (g/full)^(gamma/gamma-hat)``
    (Eq. 2.16-2.17 and Eq. 3.3: ``o`` ambient light and black level, ``s`` reflectivity and
    sensitivity). Sets with the same pitch and orientation see the same ``phi`` at a pixel, and
    (same exposure) the same ``o`` and ``s``. For a trial gamma, each pixel's ``o``, ``s`` and
    ``phi`` are fitted (``o``, ``s`` in closed form on a grid of ``phi``); gamma minimises the
    mean squared residual over a random subsample of pixels. Only the wave's shape enters, so
    offsets, contrast loss (e.g. scattered light) and reflectivity do not bias the estimate, and
    no white or black capture is needed. Each pixel needs more samples than its three unknowns:
    two pre-distortions of a 3-step set, or one set of N >= 4 steps.

    Parameters
    ----------
    sets : sequence of (FringeSpec, gamma_hat, images)
        Sinusoidal sets (shift k at index k), their pre-compensation exponents and captures.
    camera_bit_depth : int
        Pixels saturated in any image are excluded.
    max_pixels : int
        Random subsample of usable pixels (deterministic with ``seed``).
    phase_steps : int
        Grid of ``phi`` per pixel (720: 0.5 degree).
    min_modulation : float, optional
        Minimum peak-to-peak DN of a pixel's samples (default 10 % of full scale).

    Returns
    -------
    GammaFit
        ``method = "fringes"``; ``rms_residual`` in DN per sample.
    """
    if not sets:
        raise InputError("fringe gamma fit: give at least one pre-distorted sinusoidal set")
    full_cam = _full(camera_bit_depth)
    full_p = _full(projector_bit_depth)
    thr = 0.1 * full_cam if min_modulation is None else float(min_modulation)
    groups: dict[tuple[float, str], list[tuple[FringeSpec, float, NDArray]]] = {}
    shape = None
    for spec, gh, imgs in sets:
        if spec.pattern != "sinusoidal":
            raise InputError("fringe gamma fit needs sinusoidal sets")
        arr = np.asarray(imgs, dtype=np.float64)
        if shape is None:
            shape = arr.shape[1:]
        if arr.ndim != 3 or arr.shape[0] != spec.steps or arr.shape[1:] != shape:
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has shape {arr.shape}; expected "
                f"({spec.steps}, *{shape})"
            )
        groups.setdefault((spec.pitch_px, spec.orientation), []).append((spec, float(gh), arr))
    rng = np.random.default_rng(seed)
    phis = np.linspace(0.0, 2 * np.pi, phase_steps, endpoint=False)
    prepared = []
    for members in groups.values():
        y = np.concatenate([m[2].reshape(m[2].shape[0], -1) for m in members])
        if y.shape[0] < 4:
            continue
        ok = np.all(y < full_cam, axis=0) & (np.ptp(y, axis=0) > thr)
        idx = np.flatnonzero(ok)
        if idx.size > max_pixels:
            idx = np.sort(rng.choice(idx, max_pixels, replace=False))
        if idx.size == 0:
            continue
        yc = y[:, idx] - y[:, idx].mean(axis=0)
        lin = [
            (spec.imin + (spec.migl - spec.imin) * 0.5 * (1 + np.cos(phis[:, None] + spec.shifts)))
            / full_p
            for spec, _, _ in members
        ]
        prepared.append((yc, (yc * yc).sum(axis=0), lin, [gh for _, gh, _ in members]))
    if not prepared:
        raise InputError(
            "fringe gamma fit: no pixel has more than 3 unsaturated, modulated samples; give two "
            "pre-distortions of a set (or N >= 4 steps) captured without saturation"
        )
    n_samples = sum(p[0].shape[0] * p[0].shape[1] for p in prepared)
    n_pixels = sum(p[0].shape[1] for p in prepared)

    def cost(gamma: float) -> float:
        total = 0.0
        for yc, syy, lin, ghs in prepared:
            basis = np.concatenate([v ** (gamma / gh) for v, gh in zip(lin, ghs, strict=True)], 1)
            basis -= basis.mean(axis=1, keepdims=True)
            sxy = basis @ yc
            sxx = (basis * basis).sum(axis=1)[:, None]
            total += float(np.sum(np.min(syy[None, :] - sxy * sxy / sxx, axis=0)))
        return total / n_samples

    res = optimize.minimize_scalar(
        cost, bounds=(0.2, 8.0), method="bounded", options={"xatol": 1e-5}
    )
    gamma = float(res.x)
    c = cost(gamma)
    h = 1e-2 * gamma
    curv = (cost(gamma + h) - 2 * c + cost(gamma - h)) / h**2
    # residual variance per sample / (n_samples * curvature/2): the LS standard error
    stderr = float(np.sqrt(2 * c / (curv * n_samples))) if curv > 0 else float("nan")
    nan = float("nan")
    empty = np.zeros(0)
    return GammaFit(
        gamma=gamma,
        stderr=stderr,
        offset=nan,
        scale=nan,
        rms_residual=float(np.sqrt(c)),
        method="fringes",
        levels=empty,
        sent=empty,
        dn=empty,
        projector_bit_depth=projector_bit_depth,
        n_samples=int(n_pixels),
    )


def plot_gamma_mapping(fit: GammaFit, path: str | Path, gamma_hat: float | None = None) -> None:
    """Thesis Fig. 2.6 b/c: input gray -> captured intensity without and with pre-compensation.

    (b) the captured means against the gray sent, with the fitted curve; (c) the mapping the fit
    predicts after pre-compensation with ``gamma_hat`` (default: the fitted gamma), against the
    ideal straight line.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if fit.method != "uniform":
        raise InputError("the mapping plot needs a uniform-gray fit (levels and intensities)")
    gh = fit.gamma if gamma_hat is None else gamma_hat
    full = _full(fit.projector_bit_depth)
    g = np.linspace(0, full, 256)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4), dpi=100)
    ax1.plot(fit.sent, fit.dn, "o", ms=4, label="captured")
    ax1.plot(
        g,
        fit.offset + fit.scale * (g / full) ** fit.gamma,
        "-",
        label=f"fit, gamma = {fit.gamma:.3f}",
    )
    ax1.set(
        xlabel="gray level sent to the projector",
        ylabel="captured intensity (DN)",
        title="(b) without correction",
    )
    ax1.legend()
    sent = precompensate_gamma(g, gh, fit.projector_bit_depth) / full
    pred = fit.offset + fit.scale * sent**fit.gamma
    line = np.polyval(np.polyfit(g, pred, 1), g)
    mx, _ = residual_nonlinearity(g, pred)
    ax2.plot(g, pred, "-", label=f"predicted, gamma-hat = {gh:.3f}")
    ax2.plot(g, line, "--", label=f"straight line (max dev. {mx:.2f} %)")
    ax2.set(
        xlabel="requested (linear) gray level",
        ylabel="captured intensity (DN)",
        title="(c) with pre-compensation",
    )
    ax2.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
