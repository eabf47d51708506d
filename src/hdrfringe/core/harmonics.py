"""Fringe-harmonic (projector nonlinearity) phase error: estimated from the data, removed.

A projector whose response is not linear (a gamma left uncompensated, near-square fringes of a
DLP, camera nonlinearity) adds harmonics to the fringes: shift ``i`` of an N-step set shows
``a + sum_m b_m cos(m (theta + delta_i))`` with ``delta_i = 2 pi i / N`` (plus any offset).
The N-step decoder sees harmonic ``m`` wherever ``m = j N +- 1``, and the decoded phase carries
an error that repeats N times per fringe period. Written against the *decoded* phase ``phi``
(the inverse of ``phi = theta + delta(theta)``), the true phase is::

    theta = phi - eps(phi),   eps(phi) = sum_k a_k cos(k N phi) + b_k sin(k N phi),  k = 1..K

(no constant term: a constant is indistinguishable from the phase offset). Near-square
fringes (odd harmonics 3, 5, 7, ...) decoded with N = 3 give the ``6 phi`` and ``12 phi``
terms (5 and 7 alias to 6, 11 and 13 to 12); a gamma (every harmonic) gives ``3 phi`` too.

Estimate (:func:`estimate_harmonic_error`), from one wrapped phase map, no reference plane:
the surface's true phase is smooth on the scale of a fringe period while ``eps`` oscillates
``k N`` times per period. Let ``H = 1 - S`` with ``S`` a symmetric moving average along an
image axis over about one period of ``eps`` (``2h + 1`` px, ``h = P / (2N)`` for a fringe
period of ``P`` px along that axis). ``S`` keeps any phase that is linear over the window, so
``H[theta] ~ 0`` and::

    H[phi] = sum_k a_k H[cos(k N phi)] + b_k H[sin(k N phi)]

a linear least-squares problem in ``a_k, b_k`` over every pixel whose window is valid (rows
and columns both give equations). ``H[phi]`` is computed from wrapped differences,
``H[phi](x) = -sum_j w_j wrap(phi(x + j) - phi(x))``, so no unwrapping is needed; the
regressors are computed from the same decoded phase. Equations with a residual beyond
4 robust standard deviations (depth edges, where ``theta`` is not smooth) are dropped and the
fit repeated. The standard errors are a delete-one-tile jackknife over 4 x 4 image tiles
(neighbouring equations are correlated, so a per-equation error would be far too small).

Remove (:meth:`HarmonicError.correct`): ``theta = wrap(phi - eps(phi))``, pixel by pixel.

Limits: the sets' shifts must be equally spaced (else the error does not repeat N times per
period); the surface must be smooth over ``h`` px (curvature that correlates with
``cos(k N phi)`` biases the fit); one set of coefficients serves the whole image (harmonics
that change across it, e.g. with defocus, are corrected on average); orders whose period
along the phase gradient is below 2.5 camera px are not resolved and left out. See
docs/harmonics.md for the measured numbers.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core.captures import FringeSet
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import PhaseResult, wrap_phase
from hdrfringe.errors import InputError

__all__ = [
    "DEFAULT_ORDERS",
    "FLOOR_RAD",
    "HARMONIC_MODES",
    "SIGNIFICANCE",
    "HarmonicError",
    "compensate_sets",
    "estimate_harmonic_error",
    "harmonics_mode",
    "not_applicable",
]

F64 = NDArray[np.float64]
TWO_PI = 2.0 * np.pi

#: ``harmonics`` values besides a number of orders.
HARMONIC_MODES = ("off", "auto")
#: Orders ``k N``, k = 1..K, that ``auto`` estimates.
DEFAULT_ORDERS = 6
#: Most orders a caller may ask for.
MAX_ORDERS = 8
#: ``auto`` removes the error only when a coefficient is this many standard errors from zero ...
SIGNIFICANCE = 5.0
#: ... and the RMS correction is at least this (rad).
FLOOR_RAD = 1e-3
#: Shortest period (camera px along the phase gradient) of an order that is estimated.
MIN_ORDER_PERIOD_PX = 2.5
#: Largest half window ``h`` (px) of the moving average.
MAX_HALF_WINDOW = 48
#: Offsets ``j`` of the moving average per side (spread over 1..h).
OFFSETS_PER_SIDE = 8
#: Centre pixels per axis the estimate aims at (the grid is subsampled to about this many).
TARGET_EQUATIONS = 250_000
#: Fewest equations (per coefficient) for an estimate.
MIN_EQUATIONS_PER_COEFFICIENT = 200
#: Tiles per image side of the jackknife.
TILES = 4
#: A window whose wrapped difference to its centre exceeds this (rad) is not smooth: skipped.
LOCAL_JUMP_RAD = 0.9 * np.pi


def harmonics_mode(value: str | int) -> tuple[str, int]:
    """Parse a ``harmonics`` setting.

    Parameters
    ----------
    value : str or int
        ``"off"``, ``"auto"`` or a number of orders ``K`` (1..8, int or digits).

    Returns
    -------
    (mode, orders) : tuple of str and int
        ``("off", 0)``; ``("auto", DEFAULT_ORDERS)``: estimate, remove when significant;
        ``("force", K)``: estimate K orders and remove them whatever their size.

    Raises
    ------
    InputError
        Anything else.

    Examples
    --------
    >>> harmonics_mode("auto"), harmonics_mode("2"), harmonics_mode("off")
    (('auto', 6), ('force', 2), ('off', 0))
    """
    if isinstance(value, str) and value in HARMONIC_MODES:
        return (value, 0 if value == "off" else DEFAULT_ORDERS)
    text = str(value).strip()
    if not isinstance(value, bool) and text.isdigit() and 1 <= int(text) <= MAX_ORDERS:
        return ("force", int(text))
    raise InputError(
        f"harmonics {value!r} is unknown; give off, auto or a number of harmonic orders "
        f"1..{MAX_ORDERS}"
    )


def not_applicable(spec: FringeSpec) -> str | None:
    """Why a set's phase error is not of the form :class:`HarmonicError` models, or None.

    Parameters
    ----------
    spec : FringeSpec

    Returns
    -------
    str or None
        None for a sinusoidal set of N >= 3 equally spaced shifts (any order, any offset).

    Examples
    --------
    >>> not_applicable(FringeSpec(steps=3, shifts_deg=(-90, 30, -210))) is None
    True
    >>> not_applicable(FringeSpec(steps=3, shifts_deg=(0, 90, 180)))
    'shifts 0, 90, 180 degrees are not equally spaced'
    """
    if spec.pattern != "sinusoidal":
        return f"{spec.pattern} fringes (sinusoidal sets only)"
    n = spec.steps
    if n < 3:
        return f"{n} steps (3 or more needed)"
    angles = np.sort(np.mod(np.degrees(spec.shifts), 360.0))
    gaps = np.diff(np.append(angles, angles[0] + 360.0))
    if not np.allclose(gaps, 360.0 / n, atol=1e-6):
        shown = ", ".join(f"{v:g}" for v in np.degrees(spec.shifts))
        return f"shifts {shown} degrees are not equally spaced"
    return None


@dataclass(frozen=True)
class HarmonicError:
    """The phase error of one set's fringe harmonics, ``eps(phi)`` of the module docstring.

    Parameters
    ----------
    steps : int
        N: the error repeats N times per fringe period.
    orders : tuple of int
        The frequencies ``k N`` of ``eps`` (cycles per fringe period), k = 1..K.
    cos, sin : tuple of float
        ``a_k``, ``b_k`` in rad.
    cos_se, sin_se : tuple of float
        Their jackknife standard errors (rad; NaN with fewer than 4 tiles).
    equations : int
        Equations the fit kept.
    residual_rad : float
        Robust standard deviation of the fit's residual (noise and what the model misses).
    period_px : float
        Fringe period along the phase gradient (camera px, from the median gradient).
    reason : str
        Empty when estimated; else why not (the coefficients are then empty).

    Examples
    --------
    >>> e = HarmonicError(3, (3, 6), (0.0, 0.1), (0.0, 0.0), (1e-4,) * 2, (1e-4,) * 2)
    >>> round(e.rms_rad, 4), e.significant
    (0.0707, True)
    >>> phi = np.array([0.0, 1.0, np.nan])
    >>> np.round(e.correct(phi), 4).tolist()
    [6.1832, 0.904, nan]
    """

    steps: int
    orders: tuple[int, ...]
    cos: tuple[float, ...]
    sin: tuple[float, ...]
    cos_se: tuple[float, ...]
    sin_se: tuple[float, ...]
    equations: int = 0
    residual_rad: float = math.nan
    period_px: float = math.nan
    reason: str = ""

    @property
    def rms_rad(self) -> float:
        """RMS of ``eps`` over a uniformly distributed phase: ``sqrt(sum(a^2 + b^2) / 2)``."""
        c = np.asarray(self.cos + self.sin, dtype=np.float64)
        return float(np.sqrt(np.sum(c**2) / 2)) if c.size else 0.0

    @property
    def significant(self) -> bool:
        """Whether ``auto`` removes it: RMS >= :data:`FLOOR_RAD` and a coefficient at least
        :data:`SIGNIFICANCE` standard errors from zero."""
        if self.reason or self.rms_rad < FLOOR_RAD:
            return False
        c = np.abs(np.asarray(self.cos + self.sin))
        se = np.asarray(self.cos_se + self.sin_se)
        return bool(np.any(np.isfinite(se) & (c > SIGNIFICANCE * se)))

    def error(self, phase: ArrayLike) -> F64:
        """``eps(phi)`` at the decoded phase (rad; NaN stays NaN).

        Parameters
        ----------
        phase : array_like
            Decoded (wrapped) phase, rad.

        Returns
        -------
        ndarray of float64
        """
        phi = np.asarray(phase, dtype=np.float64)
        out = np.zeros(phi.shape)
        for m, a, b in zip(self.orders, self.cos, self.sin, strict=True):
            out += a * np.cos(m * phi) + b * np.sin(m * phi)
        return np.where(np.isfinite(phi), out, np.nan)

    def correct(self, phase: ArrayLike) -> F64:
        """The true phase ``wrap(phi - eps(phi))`` in [0, 2 pi) (NaN stays NaN).

        Parameters
        ----------
        phase : array_like
            Decoded (wrapped) phase, rad.

        Returns
        -------
        ndarray of float64
        """
        phi = np.asarray(phase, dtype=np.float64)
        out = wrap_phase(np.where(np.isfinite(phi), phi - self.error(phi), 0.0))
        out[~np.isfinite(phi)] = np.nan
        return out

    def summary(self) -> dict[str, Any]:
        """JSON form (``metrics.json``, ``phase_summary.json``).

        Returns
        -------
        dict
            ``orders``, ``cos_rad``, ``sin_rad``, their ``*_se_rad``, ``rms_rad``,
            ``significant``, ``equations``, ``residual_rad``, ``period_px``; or ``reason``.
        """
        if self.reason:
            return {"steps": self.steps, "reason": self.reason}

        def r(v: Sequence[float]) -> list[float | None]:
            return [float(f"{x:.6g}") if math.isfinite(x) else None for x in v]

        return {
            "steps": self.steps,
            "orders": list(self.orders),
            "cos_rad": r(self.cos),
            "sin_rad": r(self.sin),
            "cos_se_rad": r(self.cos_se),
            "sin_se_rad": r(self.sin_se),
            "rms_rad": float(f"{self.rms_rad:.6g}"),
            "significant": self.significant,
            "equations": self.equations,
            "residual_rad": float(f"{self.residual_rad:.6g}"),
            "period_px": float(f"{self.period_px:.6g}"),
        }


def _not_estimated(steps: int, reason: str) -> HarmonicError:
    return HarmonicError(steps, (), (), (), (), (), reason=reason)


def _wrap_pi(a: F64) -> F64:
    """Wrap to [-pi, pi] (rounding, several times faster than ``np.mod``)."""
    return a - TWO_PI * np.rint(a / TWO_PI)


def _axis_period(phi: F64, axis: int) -> float:
    """Fringe period (px) along an image axis: 2 pi over the median |wrapped difference|."""
    d = np.abs(_wrap_pi(np.diff(phi, axis=axis)))
    d = d[np.isfinite(d)]
    if d.size == 0:
        return math.inf
    g = float(np.median(d))
    return TWO_PI / g if g > 0 else math.inf


def _powers(z: NDArray[np.complex128], k: int) -> NDArray[np.complex128]:
    """``z, z^2, ..., z^k`` stacked (repeated products: faster than complex powers)."""
    out = np.empty((k, *z.shape), complex)
    out[0] = z
    for i in range(1, k):
        np.multiply(out[i - 1], z, out=out[i])
    return out


def _axis_equations(
    phi: F64,
    n: int,
    k: int,
    half: int,
    stride: int,
    axis: int,
    origin: tuple[int, int] = (0, 0),
    shape: tuple[int, int] | None = None,
) -> tuple[F64, F64, NDArray[np.intp]]:
    """``H[phi]``, the regressors ``H[cos k N phi], H[sin k N phi]`` and the tile of every
    valid centre pixel, for the moving average of half width ``half`` along ``axis``
    (orders ``N, 2N, ..., kN``); centre pixels on a grid of ``stride`` px. ``phi`` may be a
    window of a larger image, at row and column ``origin`` (multiples of ``stride``) of an image
    of ``shape``: the tiles are the whole image's."""
    a = (phi if axis == 0 else phi.T)[:, ::stride]  # the columns of the centre grid
    rows = a.shape[0]
    full_rows, full_cols = shape if shape is not None else phi.shape
    r0, c0 = origin
    if axis == 1:
        full_rows, full_cols, r0, c0 = full_cols, full_rows, c0, r0
    za = np.exp(1j * n * a)
    if rows <= 2 * half:
        return np.empty(0), np.empty((0, 2 * k)), np.empty(0, np.intp)
    offsets = np.unique(np.rint(np.linspace(1, half, OFFSETS_PER_SIDE)).astype(int))
    offsets = np.concatenate([-offsets[::-1], offsets])
    w = 1.0 / (len(offsets) + 1)
    centre = a[half : rows - half : stride]
    valid = np.isfinite(centre)
    powers0 = _powers(za[half : rows - half : stride], k)
    acc_phi = np.zeros(centre.shape)
    acc_z = np.zeros(powers0.shape, complex)
    for j in offsets:
        d = _wrap_pi(a[half + j : rows - half + j : stride] - centre)
        with np.errstate(invalid="ignore"):
            valid &= np.abs(d) < LOCAL_JUMP_RAD  # False where NaN
        acc_phi += d
        acc_z += _powers(za[half + j : rows - half + j : stride], k)
    y = -w * acc_phi[valid]
    hz = (1.0 - w) * powers0[:, valid] - w * acc_z[:, valid]
    x = np.concatenate([hz.real, hz.imag]).T
    r_idx, c_idx = np.nonzero(valid)
    r_img = r0 + half + r_idx * stride  # centre coordinates in the whole image's ``a``
    c_img = c0 + c_idx * stride
    if axis == 1:  # ``a`` is the transpose: its rows are image columns
        r_img, c_img = c_img, r_img
        full_rows, full_cols = full_cols, full_rows
    tile = (r_img * TILES // full_rows) * TILES + (c_img * TILES // full_cols)
    return y, x, tile.astype(np.intp)


def estimate_harmonic_error(
    wrapped_phase: ArrayLike,
    steps: int,
    *,
    orders: int = DEFAULT_ORDERS,
    mask: ArrayLike | None = None,
) -> HarmonicError:
    """Estimate the fringe-harmonic phase error ``eps`` of one decoded set from its own phase.

    Parameters
    ----------
    wrapped_phase : array_like, shape (H, W)
        The set's wrapped phase (rad, NaN invalid), as decoded (sinusoidal N-step, equally
        spaced shifts: :func:`not_applicable` is None for its spec).
    steps : int
        N.
    orders : int
        K: estimate the frequencies ``k N``, k = 1..K (fewer when the higher ones are not
        resolved, period below 2.5 px along the phase gradient).
    mask : array_like of bool, optional
        Pixels to estimate from (default every finite phase), e.g. a flat region.

    Returns
    -------
    HarmonicError
        With ``reason`` set (and no coefficients) when too few pixels or no resolved order.

    Raises
    ------
    InputError
        A phase map that is not 2-D, a mask of another shape, ``steps < 3`` or ``orders``
        outside 1..8.

    Notes
    -----
    The method is the module docstring's; its bias on the virtual rig's sinusoidal fringes and
    its accuracy with a gamma mismatch are measured in tests/test_harmonics.py.

    Examples
    --------
    A tilted plane's phase ``theta`` decoded as ``phi = theta + 0.05 sin(6 theta)``: the
    inverse is ``eps(phi) = 0.05 sin(6 phi) - 0.0075 sin(12 phi) + ...``, found from ``phi``
    alone, and the corrected phase is within 0.002 rad of ``theta``:

    >>> yy, xx = np.mgrid[0:200, 0:300]
    >>> theta = 2 * np.pi * (xx + 0.3 * yy) / 40.0
    >>> phi = np.mod(theta + 0.05 * np.sin(6 * theta), 2 * np.pi)
    >>> est = estimate_harmonic_error(phi, 3, orders=4)
    >>> est.orders, np.round(est.sin, 3).tolist()
    ((3, 6, 9, 12), [0.0, 0.049, -0.0, -0.008])
    >>> float(np.abs(_wrap_pi(est.correct(phi) - theta)).max()) < 0.002
    True
    """
    phi = np.asarray(wrapped_phase, dtype=np.float64)
    if phi.ndim != 2:
        raise InputError(f"wrapped_phase must be a 2-D map, got shape {phi.shape}")
    if int(steps) != steps or steps < 3:
        raise InputError(f"steps must be an integer >= 3, got {steps!r}")
    if isinstance(orders, bool) or int(orders) != orders or not 1 <= orders <= MAX_ORDERS:
        raise InputError(f"orders must be an integer 1..{MAX_ORDERS}, got {orders!r}")
    n = int(steps)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != phi.shape:
            raise InputError(f"mask has shape {m.shape}, the phase {phi.shape}; give one per pixel")
        phi = np.where(m, phi, np.nan)
    finite = np.isfinite(phi)
    n_valid = int(finite.sum())
    stride = max(1, round(math.sqrt(n_valid / TARGET_EQUATIONS)))
    shape = phi.shape
    origin = (0, 0)
    if n_valid:
        # The bounding box of the finite pixels, its start on the centre grid (a multiple of
        # the stride): outside it every centre is NaN or has a NaN neighbour, so the equations,
        # their order and their tiles are the whole image's, at the box's cost (a small mask).
        rows = np.flatnonzero(finite.any(axis=1))
        cols = np.flatnonzero(finite.any(axis=0))
        origin = (int(rows[0]) // stride * stride, int(cols[0]) // stride * stride)
        phi = phi[origin[0] : rows[-1] + 1, origin[1] : cols[-1] + 1]
    periods = [_axis_period(phi, 0), _axis_period(phi, 1)]
    gradient = math.hypot(*(TWO_PI / p for p in periods))
    if gradient == 0:
        return _not_estimated(n, "no phase variation")
    period = TWO_PI / gradient
    k_max = min(int(orders), int(period / (MIN_ORDER_PERIOD_PX * n)))
    if k_max < 1:
        return _not_estimated(
            n, f"fringe period {period:.3g} px too short to resolve {n} cycles per period"
        )
    ks = np.arange(1, k_max + 1)
    parts = []
    for axis in (0, 1):
        half = int(np.clip(min(periods[axis] / (2 * n), MAX_HALF_WINDOW), 1, None) + 0.5)
        parts.append(_axis_equations(phi, n, len(ks), half, stride, axis, origin, shape))
    y = np.concatenate([p[0] for p in parts])
    x = np.concatenate([p[1] for p in parts])
    tile = np.concatenate([p[2] for p in parts])
    if len(y) < MIN_EQUATIONS_PER_COEFFICIENT * x.shape[1]:
        return _not_estimated(n, f"too few smooth pixels ({len(y)} equations)")
    keep = np.ones(len(y), bool)
    sigma = math.nan
    for _ in range(5):
        xk = x[keep]
        coef = np.linalg.lstsq(xk.T @ xk, xk.T @ y[keep], rcond=None)[0]
        res = y - x @ coef
        sigma = float(1.4826 * np.median(np.abs(res[keep])))
        new = np.abs(res) < 4 * sigma
        if np.array_equal(new, keep):
            break
        keep = new
    coef, se = _jackknife(x[keep], y[keep], tile[keep])
    k = len(ks)
    return HarmonicError(
        n,
        tuple(int(n * v) for v in ks),
        tuple(float(v) for v in coef[:k]),
        tuple(float(v) for v in coef[k:]),
        tuple(float(v) for v in se[:k]),
        tuple(float(v) for v in se[k:]),
        equations=int(keep.sum()),
        residual_rad=sigma,
        period_px=period,
    )


def _jackknife(x: F64, y: F64, tile: NDArray[np.intp]) -> tuple[F64, F64]:
    """Least-squares coefficients and their delete-one-tile jackknife standard errors."""
    p = x.shape[1]
    ata = np.zeros((TILES * TILES, p, p))
    aty = np.zeros((TILES * TILES, p))
    order = np.argsort(tile, kind="stable")
    bounds = np.searchsorted(tile[order], np.arange(TILES * TILES + 1))
    for t in range(TILES * TILES):
        rows = order[bounds[t] : bounds[t + 1]]
        ata[t] = x[rows].T @ x[rows]
        aty[t] = x[rows].T @ y[rows]
    full_a, full_b = ata.sum(0), aty.sum(0)
    coef = np.linalg.lstsq(full_a, full_b, rcond=None)[0]
    used = [t for t in range(TILES * TILES) if np.any(ata[t])]
    if len(used) < 4:
        return coef, np.full(p, np.nan)
    loo = np.stack([np.linalg.lstsq(full_a - ata[t], full_b - aty[t], rcond=None)[0] for t in used])
    g = len(used)
    se = np.sqrt((g - 1) / g * np.sum((loo - loo.mean(0)) ** 2, axis=0))
    return coef, se


def compensate_sets(
    sets: Sequence[FringeSet], results: Mapping[str, PhaseResult], harmonics: str | int
) -> tuple[dict[str, PhaseResult], dict[str, Any]]:
    """Estimate every set's harmonic error and remove it (``decode_captures(harmonics=)``).

    Parameters
    ----------
    sets : sequence of FringeSet
        The decoded sets.
    results : mapping of str to PhaseResult
        Their decoded phases, by label.
    harmonics : str or int
        :func:`harmonics_mode`: ``auto`` removes a significant error
        (:attr:`HarmonicError.significant`), a number K removes K orders whatever their size.

    Returns
    -------
    (results, summary) : tuple
        The results with each corrected set's ``wrapped_phase`` replaced (the same dtype;
        everything else unchanged), and ``{"mode": ..., "sets": {label: entry}}`` with each
        set's :meth:`HarmonicError.summary` (or ``reason``) and ``applied``. The error is
        estimated from the valid pixels without a saturated shift and removed from every
        valid pixel.

    Examples
    --------
    A 3-step set whose projector has a gamma of 2.2 (0.29 rad error), compensated:

    >>> from hdrfringe.core.phase import decode_set
    >>> spec = FringeSpec(steps=3, pitch_px=30.0)
    >>> yy, xx = np.mgrid[0:120, 0:160]
    >>> theta = 2 * np.pi * (xx + 0.3 * yy) / 30.0
    >>> light = [((1 + np.cos(theta + 2 * np.pi * k / 3)) / 2) ** 2.2 for k in range(3)]
    >>> res = decode_set(np.rint(20 + 200 * np.stack(light)).astype(np.uint8), spec, 8)
    >>> out, summary = compensate_sets([FringeSet("s", spec, (0, 1, 2))], {"s": res}, "auto")
    >>> e = summary["sets"]["s"]
    >>> e["applied"], e["orders"], round(e["rms_rad"], 3)
    (True, [3, 6, 9, 12], 0.205)
    >>> def worst(p):
    ...     return round(float(np.abs(np.angle(np.exp(1j * (p - theta)))).max()), 3)
    >>> worst(res.wrapped_phase), worst(out["s"].wrapped_phase)
    (0.292, 0.018)
    """
    mode, k = harmonics_mode(harmonics)
    out = dict(results)
    entries: dict[str, Any] = {}
    summary: dict[str, Any] = {"mode": mode if mode != "force" else str(k), "sets": entries}
    if mode == "off":
        return out, summary
    for s in sets:
        res = results[s.label]
        why = not_applicable(s.spec)
        if why is not None:
            entries[s.label] = {"applied": False, "reason": why}
            continue
        # estimated where no shift clipped (--keep-saturated keeps clipped pixels valid: their
        # error is clipping's, not the projector's), applied to every valid pixel
        clean = res.valid & (res.saturation_count == 0)
        est = estimate_harmonic_error(res.wrapped_phase, s.spec.steps, orders=k, mask=clean)
        apply = not est.reason and (mode == "force" or est.significant)
        if apply:
            phi = est.correct(res.wrapped_phase).astype(res.wrapped_phase.dtype)
            out[s.label] = dataclasses.replace(res, wrapped_phase=phi)
        entries[s.label] = {"applied": apply, **est.summary()}
    return out, summary
