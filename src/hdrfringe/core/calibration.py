"""Phase-to-height calibration from a flat plate at known depths (thesis Sec. 2.4-2.5, 4.1).

A flat plate is measured at the reference position (depth 0) and at ``J >= 2`` known depths
``h_j``; for every camera pixel the phase difference to the reference (Eq. 2.10)::

    dphi_j(x, y) = phi_j(x, y) - phi_ref(x, y)

is mapped to height by a per-pixel model fitted by least squares on the height residual:

- ``"linear"``: ``h = K dphi`` (Eq. 2.11), ``K`` by the closed form of Eq. 2.15;
- ``"rational"``: ``h = dphi / (a + b dphi)``, i.e. ``1/h = a/dphi + b`` (the non-linear
  models of thesis refs. [61, 62]); exact for any pinhole camera and projector (see
  ``docs/calibration.md`` for the derivation);
- ``"poly2"``, ``"poly3"``: ``h = sum_{k=1..order} c_k dphi^k`` (no constant term: the
  reference plane is height 0 by definition).

Every coefficient map is then filtered with a median filter followed by a mean filter, both on
a square window of 21 pixels (Sec. 4.1), NaN-aware; a border of ``border_px`` pixels stays
unfiltered, as in the thesis, and is excluded from every metric (:func:`measurement_mask`).

Phases are in the units of the absolute phase maps (radians for every decoder of
:mod:`hdrfringe.core.phase`), depths in millimetres, so ``K`` is in mm/rad. All functions are pure
numpy/scipy and vectorised over pixels; invalid pixels are NaN throughout.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from typing import Any, ClassVar, NamedTuple, Protocol, runtime_checkable

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.reconstruct import CameraGeometry
from hdrfringe.errors import HdrFringeError, InputError

__all__ = [
    "MODELS",
    "NO_GEOMETRY",
    "N_COEFFICIENTS",
    "Calibration",
    "CalibrationMismatchError",
    "MeasurementCalibration",
    "ResidualStats",
    "calibrate",
    "check_calibration",
    "check_compatible",
    "evaluate_model",
    "filter_coefficients",
    "filter_map",
    "fit_linear_k",
    "fit_model",
    "measurement_mask",
    "phase_difference",
    "residual_rms",
]

#: The note of a measurement whose calibration records no camera geometry (``metrics.notes``).
NO_GEOMETRY = (
    "the calibration records no camera geometry (focal_px, standoff_mm): points.ply has "
    "x and y in pixels"
)

#: Calibration models by name.
MODELS: tuple[str, ...] = ("linear", "rational", "poly2", "poly3")
#: Number of coefficient maps of each model (``linear``: K alone).
N_COEFFICIENTS: dict[str, int] = {"linear": 1, "rational": 2, "poly2": 2, "poly3": 3}

#: Thesis Sec. 4.1: median then mean filter, square window of 21 pixels, 10 pixel border.
DEFAULT_WINDOW_PX = 21
DEFAULT_BORDER_PX = 10

# Determinant below which a per-pixel normal matrix (columns scaled to unit norm, so the
# determinant lies in [0, 1]) is treated as singular: the pixel gets NaN coefficients.
_SINGULAR_DET = 1e-13
#: Sanity bounds a calibration must meet on write and on read (:func:`check_calibration`).
#: Largest plate depth magnitude in mm (1 km: far beyond any bench rig, far below overflow).
MAX_DEPTH_MM = 1e6
#: Largest reference phase magnitude in rad (a projector of 1e5 px at a 2 px pitch spans
#: ~3e5 rad; float64 still resolves 1e-7 rad at 1e9).
MAX_PHASE_RAD = 1e9
#: Least fraction of the measurement pixels where the reference phase, K and the model's
#: coefficients are all finite (a plate filling 1 % of the view is still a calibration).
MIN_USABLE_FRACTION = 0.01
#: Range of the median phase shift ``|d_max / K|`` of the deepest plate, in rad: below it the
#: heights are all ~0, above it the phase does not depend on height.
PHASE_SHIFT_RANGE_RAD = (1e-3, 1e7)
#: Range of the median ratio of the model's height to the linear height at that shift: the
#: non-linear models correct K by a few per cent on a real rig, never by a factor of 2.
MODEL_RATIO_RANGE = (0.5, 2.0)

# Output rows per block of the sliding-window median (bounds the temporary to ~10 MB).
_MEDIAN_BLOCK_ROWS = 8


def _check_model(model: str) -> str:
    if model not in MODELS:
        raise InputError(f"unknown calibration model {model!r}; use one of {', '.join(MODELS)}")
    return model


# --------------------------------------------------------------------------------------------
# Fitting
# --------------------------------------------------------------------------------------------
def phase_difference(phase: ArrayLike, reference_phase: ArrayLike) -> NDArray[np.float64]:
    """Phase difference to the reference plane, ``dphi = phi - phi_ref`` (Eq. 2.10).

    Parameters
    ----------
    phase : array_like, shape (H, W) or (J, H, W)
        Absolute phase of the object (or of the plate at J positions); NaN = invalid.
    reference_phase : array_like, shape (H, W)
        Absolute phase of the reference plane.

    Returns
    -------
    ndarray, same shape as ``phase``
        NaN where either phase is NaN.

    Raises
    ------
    InputError
        When the shapes do not match.

    References
    ----------
    Thesis Sec. 2.4, Eq. 2.10.

    Examples
    --------
    >>> ref = np.array([[0.5, 1.0, np.nan]])
    >>> phase_difference(np.stack([ref + 1.0, ref + 2.5]), ref).tolist()
    [[[1.0, 1.0, nan]], [[2.5, 2.5, nan]]]
    """
    phi = np.asarray(phase, dtype=np.float64)
    ref = np.asarray(reference_phase, dtype=np.float64)
    if ref.ndim != 2 or phi.ndim not in (2, 3) or phi.shape[-2:] != ref.shape:
        raise InputError(
            f"phase map of shape {phi.shape} does not match the reference phase {ref.shape}; "
            "use maps from the same camera and region of interest"
        )
    return phi - ref


class _Samples(NamedTuple):
    """Calibration samples prepared once: NaN-free phase differences and their validity."""

    d: NDArray[np.float64]  # (J, H, W) phase differences, NaN where invalid
    dz: NDArray[np.float64]  # the same with 0 where invalid
    ok: NDArray[np.bool_]  # (J, H, W) finite samples
    n_ok: NDArray[np.intp]  # (H, W) number of finite samples
    h: NDArray[np.float64]  # (J,) depths in mm


def _samples(dphi: ArrayLike, depths: ArrayLike) -> _Samples:
    """Validate a (J, H, W) stack of phase differences and its (J,) depths."""
    d = np.asarray(dphi, dtype=np.float64)
    h = np.asarray(depths, dtype=np.float64)
    if d.ndim != 3:
        raise InputError(
            f"phase differences must be a (positions, height, width) stack, got shape {d.shape}"
        )
    if h.ndim != 1 or h.shape[0] != d.shape[0]:
        raise InputError(
            f"{h.size} depth(s) for {d.shape[0]} phase map(s); give one depth per plate position"
        )
    if not np.all(np.isfinite(h)):
        raise InputError(f"depths must be finite numbers in mm, got {h.tolist()}")
    ok = np.isfinite(d)
    dz = np.where(ok, d, 0.0)
    return _Samples(d, dz, ok, np.count_nonzero(ok, axis=0), h)


def _wsum(weights: NDArray[np.float64], stack: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum_j weights[j] * stack[j]`` for a (J,) vector and a (J, H, W) stack (one BLAS call)."""
    return np.tensordot(weights, stack, axes=1)


def _psum(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum_j a[j] * b[j]`` over the first axis of two (J, H, W) stacks, no temporary."""
    return np.einsum("j...,j...->...", a, b)


def _linear_k(s: _Samples) -> NDArray[np.float64]:
    num = _wsum(s.h, s.dz)
    den = _psum(s.dz, s.dz)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = num / den
    k[(s.n_ok < 2) | (den == 0)] = np.nan
    return k


def fit_linear_k(dphi: ArrayLike, depths: ArrayLike) -> NDArray[np.float64]:
    """Phase-to-height map ``K`` of the linear model ``h = K dphi`` (Eq. 2.11, 2.15).

    Per pixel, the least-squares solution over the positions where ``dphi`` is finite::

        K = sum_j dphi_j h_j / sum_j dphi_j^2                                   (Eq. 2.15)

    (Eq. 2.14 of the thesis prints the single-position ratio upside down; Eq. 2.11 and 2.15
    fix the meaning: ``K`` converts phase to height, mm/rad.)

    Parameters
    ----------
    dphi : array_like, shape (J, H, W)
        Phase differences ``dphi_j`` to the reference plane (Eq. 2.10); NaN = invalid.
    depths : array_like, shape (J,)
        Known plate depths ``h_j`` in mm.

    Returns
    -------
    ndarray, shape (H, W)
        ``K`` in mm per phase unit; NaN where fewer than 2 finite samples (or all zero).

    References
    ----------
    Thesis Sec. 2.5, Eq. 2.14-2.15 (and Eq. 2.11 for the model).

    Examples
    --------
    Three plate depths seen as phase differences 4, 8, 12 rad (one sample invalid at pixel
    (0, 0), which still has two):

    >>> dphi = np.array([4.0, 8.0, 12.0])[:, None, None] * np.ones((1, 2, 3))
    >>> dphi[0, 0, 0] = np.nan
    >>> fit_linear_k(dphi, [2.0, 4.0, 6.0]).tolist()
    [[0.5, 0.5, 0.5], [0.5, 0.5, 0.5]]
    """
    return _linear_k(_samples(dphi, depths))


def _solve_normal(
    gram: NDArray[np.float64], rhs: NDArray[np.float64], bad: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """Solve per-pixel normal equations ``gram p = rhs``; (H, W, M, M), (H, W, M) -> (M, H, W).

    The system is scaled to a unit diagonal first (equivalent to unit-norm columns), so the
    determinant lies in [0, 1]; pixels below ``_SINGULAR_DET``, with a zero column or flagged
    ``bad`` get NaN.
    """
    m = gram.shape[-1]
    diag = np.diagonal(gram, axis1=-2, axis2=-1)
    bad = bad | ~np.all(diag > 0, axis=-1) | ~np.all(np.isfinite(gram), axis=(-2, -1))
    scale = np.sqrt(np.where(bad[..., None], 1.0, diag))
    g = gram / (scale[..., :, None] * scale[..., None, :])
    r = rhs / scale
    with np.errstate(invalid="ignore"):
        bad |= ~(np.linalg.det(g) > _SINGULAR_DET)
    g[bad] = np.eye(m)
    r[bad] = 0.0
    sol = np.linalg.solve(g, r[..., None])[..., 0] / scale
    out = np.moveaxis(sol, -1, 0)
    out[:, bad] = np.nan
    return out


def _rational_fit(s: _Samples) -> NDArray[np.float64]:
    """``a h_j + b h_j dphi_j = dphi_j`` by least squares per pixel; (2, H, W) ``[a, b]``."""
    h = s.h
    h2 = h * h
    shape = s.n_ok.shape
    gram = np.empty((*shape, 2, 2))
    rhs = np.empty((*shape, 2))
    gram[..., 0, 0] = _wsum(h2, s.ok.astype(np.float64))
    gram[..., 0, 1] = gram[..., 1, 0] = _wsum(h2, s.dz)
    d2 = s.dz * s.dz
    gram[..., 1, 1] = _wsum(h2, d2)
    rhs[..., 0] = _wsum(h, s.dz)
    rhs[..., 1] = _wsum(h, d2)
    return _solve_normal(gram, rhs, s.n_ok < 2)


def _rational_sse(s: _Samples, coef: NDArray[np.float64]) -> NDArray[np.float64]:
    with np.errstate(divide="ignore", invalid="ignore"):
        e = s.dz / (coef[0] + coef[1] * s.dz) - s.h[:, None, None]
    e[~s.ok] = 0.0
    return _psum(e, e)


def _rational_refine(s: _Samples, coef: NDArray[np.float64]) -> NDArray[np.float64]:
    """One Gauss-Newton step of the rational model on the height residual, kept where it helps.

    The linear solve minimises ``sum (dphi_j - (a + b dphi_j) h_j)^2``, which is the height
    residual weighted by ``(a + b dphi_j)^2``; the step moves ``(a, b)`` towards the unweighted
    height least squares (what :func:`residual_rms` reports). It is accepted per pixel only
    where it does not increase the sum of squared height residuals.
    """
    a, b = coef
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        den = a + b * s.dz
        ja = -s.dz / (den * den)  # d(model)/da; d(model)/db = ja * dphi
        r = s.h[:, None, None] - s.dz / den
    use = s.ok & np.isfinite(ja) & np.isfinite(r)
    ja[~use] = 0.0
    r[~use] = 0.0
    shape = s.n_ok.shape
    gram = np.empty((*shape, 2, 2))
    rhs = np.empty((*shape, 2))
    w = ja * ja
    gram[..., 0, 0] = w.sum(axis=0)
    w *= s.dz
    gram[..., 0, 1] = gram[..., 1, 0] = w.sum(axis=0)
    gram[..., 1, 1] = _psum(w, s.dz)
    ja *= r
    rhs[..., 0] = ja.sum(axis=0)
    rhs[..., 1] = _psum(ja, s.dz)
    step = _solve_normal(gram, rhs, np.count_nonzero(use, axis=0) < 2)
    new = coef + np.where(np.isfinite(step), step, 0.0)
    better = _rational_sse(s, new) <= _rational_sse(s, coef)
    return np.where(better, new, coef)


def _poly_fit(s: _Samples, order: int) -> NDArray[np.float64]:
    """``h = sum_{k=1..order} c_k dphi^k`` by least squares per pixel; (order, H, W)."""
    shape = s.n_ok.shape
    psums = {}
    p = s.dz.copy()
    rhs = np.empty((*shape, order))
    for k in range(1, 2 * order + 1):
        if k > 1:
            p *= s.dz
        psums[k] = p.sum(axis=0)
        if k <= order:
            rhs[..., k - 1] = _wsum(s.h, p)
    gram = np.empty((*shape, order, order))
    for i in range(order):
        for j in range(order):
            gram[..., i, j] = psums[i + j + 2]
    return _solve_normal(gram, rhs, s.n_ok < max(2, order))


def _fit(s: _Samples, model: str, refine: bool) -> NDArray[np.float64]:
    if model == "linear":
        return _linear_k(s)[None]
    if model == "rational":
        coef = _rational_fit(s)
        return _rational_refine(s, coef) if refine else coef
    return _poly_fit(s, int(model[-1]))


def fit_model(
    dphi: ArrayLike, depths: ArrayLike, model: str, *, refine: bool = False
) -> NDArray[np.float64]:
    """Fit a calibration model per pixel by least squares.

    ``linear`` and the polynomials minimise the height residual ``sum_j (h(dphi_j) - h_j)^2``
    exactly (they are linear in their coefficients); ``rational`` minimises it weighted by
    ``(a + b dphi_j)^2`` unless ``refine``.

    Parameters
    ----------
    dphi : array_like, shape (J, H, W)
        Phase differences to the reference plane (Eq. 2.10); NaN = invalid sample.
    depths : array_like, shape (J,)
        Known plate depths in mm.
    model : {"linear", "rational", "poly2", "poly3"}
        - ``linear``: ``h = K dphi`` (Eq. 2.11, 2.15); coefficients ``[K]``.
        - ``rational``: ``h = dphi / (a + b dphi)``; coefficients ``[a, b]``, from the linear
          system ``a h_j + b h_j dphi_j = dphi_j`` (exact, so noise-free data are recovered to
          rounding), then, if ``refine``, one Gauss-Newton step on the height residual.
        - ``poly2``, ``poly3``: ``h = sum_{k=1..order} c_k dphi^k``; coefficients
          ``[c_1, ..., c_order]``.
    refine : bool
        Rational model only: follow the linear solve by one Gauss-Newton step on the height
        residual (default False: the linear solve already minimises the height residual
        weighted by ``(a + b dphi_j)^2``, which varies by a few percent over a calibration
        volume, so the step changes the fit by far less than the noise; see
        ``docs/calibration.md``).

    Returns
    -------
    ndarray, shape (M, H, W)
        Coefficient maps, M = ``N_COEFFICIENTS[model]``; NaN where a pixel has fewer than
        ``max(2, M)`` finite samples or a degenerate system.

    References
    ----------
    Thesis Sec. 2.5: Eq. 2.15 (linear); the non-linear models of its refs. [61, 62].

    Examples
    --------
    Noise-free heights of the rational model ``h = dphi / (1.5 + 0.05 dphi)`` give its
    coefficients back:

    >>> dphi = np.array([2.0, 4.0, 6.0])[:, None, None]
    >>> h = (dphi / (1.5 + 0.05 * dphi)).ravel()
    >>> fit_model(dphi, h, "rational").ravel().round(9).tolist()
    [1.5, 0.05]
    """
    _check_model(model)
    return _fit(_samples(dphi, depths), model, refine)


def evaluate_model(coefficients: ArrayLike, dphi: ArrayLike, model: str) -> NDArray[np.float64]:
    """Height in mm from phase differences with a fitted model (Eq. 2.11 for ``linear``).

    Parameters
    ----------
    coefficients : array_like, shape (M, H, W)
        As returned by :func:`fit_model` (``linear``: ``K[None]``).
    dphi : array_like, shape (H, W) or (J, H, W)
        Phase differences to the reference plane (Eq. 2.10).
    model : {"linear", "rational", "poly2", "poly3"}
        The model the coefficients belong to (see :func:`fit_model`).

    Returns
    -------
    ndarray, shape of ``dphi``
        Height in mm; NaN where ``dphi`` or a coefficient is NaN or the model diverges.

    Raises
    ------
    InputError
        Unknown model, or coefficients that do not fit it or ``dphi``.

    References
    ----------
    Thesis Sec. 2.4, Eq. 2.11 (``linear``).

    Examples
    --------
    >>> k = np.full((1, 1, 2), 0.5)
    >>> evaluate_model(k, np.array([[4.0, np.nan]]), "linear").tolist()
    [[2.0, nan]]
    >>> evaluate_model(np.array([[[1.5]], [[0.05]]]), np.array([[5.0]]), "rational").round(6)
    array([[2.857143]])
    """
    _check_model(model)
    c = np.asarray(coefficients, dtype=np.float64)
    d = np.asarray(dphi, dtype=np.float64)
    if c.ndim != 3 or c.shape[0] != N_COEFFICIENTS[model] or d.shape[-2:] != c.shape[1:]:
        raise InputError(
            f"{model} coefficients of shape {c.shape} do not fit phase differences of shape "
            f"{d.shape}; expected ({N_COEFFICIENTS[model]}, H, W) with the same H, W"
        )
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if model == "linear":
            out = c[0] * d
        elif model == "rational":
            out = d / (c[0] + c[1] * d)
        else:
            acc = c[-1] * d
            for k in range(c.shape[0] - 2, -1, -1):
                acc = (acc + c[k]) * d
            out = acc
    out = np.asarray(out, dtype=np.float64)
    out[~np.isfinite(out)] = np.nan
    return out


def _residual_rms(
    s: _Samples, coefficients: NDArray[np.float64], model: str
) -> NDArray[np.float64]:
    err = evaluate_model(coefficients, s.d, model)
    err -= s.h[:, None, None]
    fin = np.isfinite(err)
    err[~fin] = 0.0
    count = np.count_nonzero(fin, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.sqrt(_psum(err, err) / count)
    out[count == 0] = np.nan
    return out


def residual_rms(
    coefficients: ArrayLike, dphi: ArrayLike, depths: ArrayLike, model: str
) -> NDArray[np.float64]:
    """Per-pixel RMS over the plate positions of ``model height - true depth``, in mm.

    Parameters
    ----------
    coefficients : array_like, shape (M, H, W)
        Coefficient maps of ``model`` (as from :func:`fit_model`).
    dphi : array_like, shape (J, H, W)
        Phase differences of the plate positions (Eq. 2.10); NaN = invalid.
    depths : array_like, shape (J,)
        True plate depths in mm.
    model : {"linear", "rational", "poly2", "poly3"}
        The model the coefficients belong to.

    Returns
    -------
    ndarray, shape (H, W)
        RMS over the positions where the model height is finite; NaN where there is none.

    References
    ----------
    Thesis Sec. 4.1: the RMSE between measured and true depth.

    Examples
    --------
    ``K = 0.5`` predicts 1, 2, 3 mm where the plate was at 1, 2, 3.5 mm:

    >>> dphi = np.array([2.0, 4.0, 6.0])[:, None, None]
    >>> float(residual_rms(np.full((1, 1, 1), 0.5), dphi, [1.0, 2.0, 3.5], "linear")[0, 0])
    0.28867513459481287
    """
    return _residual_rms(_samples(dphi, depths), np.asarray(coefficients, np.float64), model)


# --------------------------------------------------------------------------------------------
# Filtering (thesis Sec. 4.1)
# --------------------------------------------------------------------------------------------
def measurement_mask(
    shape: tuple[int, int], border_px: int = DEFAULT_BORDER_PX
) -> NDArray[np.bool_]:
    """Pixels used for metrics: the whole image except a ``border_px`` border (Sec. 4.1).

    The border is where the calibration maps stay unfiltered (:func:`filter_map`).

    Parameters
    ----------
    shape : (int, int)
        Image (height, width).
    border_px : int
        Border width in pixels, >= 0.

    Returns
    -------
    ndarray of bool, shape ``shape``
        True inside, False on the border.

    References
    ----------
    Thesis Sec. 4.1: measurement pixels are the whole image except a 10 pixel border.

    Examples
    --------
    >>> measurement_mask((4, 5), border_px=1).astype(int)
    array([[0, 0, 0, 0, 0],
           [0, 1, 1, 1, 0],
           [0, 1, 1, 1, 0],
           [0, 0, 0, 0, 0]])
    """
    if len(shape) != 2 or min(shape) < 0:
        raise InputError(f"image shape must be (height, width), got {tuple(shape)}")
    b = _check_border(border_px)
    mask = np.zeros(tuple(int(s) for s in shape), dtype=bool)
    mask[b : shape[0] - b, b : shape[1] - b] = True
    return mask


def _check_border(border_px: int) -> int:
    if isinstance(border_px, bool) or int(border_px) != border_px or border_px < 0:
        raise InputError(f"border must be a whole number of pixels >= 0, got {border_px}")
    return int(border_px)


def _check_window(window_px: int) -> int:
    if (
        isinstance(window_px, bool)
        or int(window_px) != window_px
        or window_px < 1
        or window_px % 2 == 0
    ):
        raise InputError(
            f"filter window must be an odd whole number of pixels >= 1 (1: no filtering), "
            f"got {window_px}; the thesis uses 21"
        )
    return int(window_px)


def _median_interior(filled: NDArray[np.float64], window: int, border: int) -> NDArray[np.float64]:
    """Exact ``window`` x ``window`` median at the pixels inside ``border`` (edge padding).

    The values are replaced by their global ranks (int32) so the selection runs on half the
    bytes of float64; the median of the ranks is the rank of the median, so the result is
    exactly the median value of each window. About 0.5 s for 648 x 494 at window 21.
    """
    rows, cols = filled.shape
    r = window // 2
    top, left = border, border
    out_rows, out_cols = rows - 2 * border, cols - 2 * border
    padded = np.pad(filled, r, mode="edge")
    order = np.argsort(padded, axis=None, kind="stable")
    flat_ranks = np.empty(padded.size, dtype=np.int32)
    flat_ranks[order] = np.arange(padded.size, dtype=np.int32)
    ranks = flat_ranks.reshape(padded.shape)
    values = padded.ravel()[order]
    views = sliding_window_view(ranks, (window, window))[
        top : top + out_rows, left : left + out_cols
    ]
    med = np.empty((out_rows, out_cols), dtype=np.int32)
    kth = (window * window) // 2
    for r0 in range(0, out_rows, _MEDIAN_BLOCK_ROWS):
        block = views[r0 : r0 + _MEDIAN_BLOCK_ROWS].reshape(-1, window * window)
        block.partition(kth, axis=1)
        med[r0 : r0 + _MEDIAN_BLOCK_ROWS] = block[:, kth].reshape(-1, out_cols)
    return values[med]


def filter_map(
    data: ArrayLike, window_px: int = DEFAULT_WINDOW_PX, border_px: int = DEFAULT_BORDER_PX
) -> NDArray[np.float64]:
    """Median filter followed by mean filter, square windows, NaN-aware (thesis Sec. 4.1).

    Both stages change only the pixels at least ``border_px`` from the image edge; the border
    keeps its input values (the thesis leaves a 10 pixel border unfiltered and excludes it
    from the RMSE, see :func:`measurement_mask`), and those values take part in the windows of
    the pixels next to it.

    - Median: invalid (NaN) pixels are first filled with the value of the nearest valid pixel,
      so a NaN island does not poison its neighbours; pixels outside the image repeat the edge.
    - Mean: normalised box filter over the valid pixels inside the image only
      (``sum(valid * x) / sum(valid)`` over the window).

    Invalid pixels stay NaN. A linear ramp is reproduced exactly (to rounding): the median and
    the mean of a window of a ramp are its centre value.

    Parameters
    ----------
    data : array_like, shape (H, W)
        Map to filter (K, or one coefficient map); NaN = invalid.
    window_px : int
        Odd side of the square windows; 21 in the thesis; 1 returns the map unchanged.
    border_px : int
        Unfiltered border width; 10 in the thesis (= ``window_px // 2``).

    Returns
    -------
    ndarray, shape (H, W), float64
        The filtered map; NaN where ``data`` is NaN.

    References
    ----------
    Thesis Sec. 4.1: median then mean filter, square windows of 21 pixels, 10 pixel border.

    Examples
    --------
    A ramp with a spike and a NaN, 3 x 3 windows and a 1 pixel border: the spike is gone, the
    NaN stays, and the ramp alone comes back unchanged.

    >>> y, x = np.mgrid[0:5, 0:7]
    >>> ramp = 0.1 * x + 0.2 * y
    >>> spiky = ramp.copy()
    >>> spiky[2, 3], spiky[0, 0] = 50.0, np.nan
    >>> out = filter_map(spiky, window_px=3, border_px=1)
    >>> round(float(out[2, 3]), 3), bool(np.isnan(out[0, 0]))
    (0.756, True)
    >>> bool(np.allclose(filter_map(ramp, 3, 1), ramp))
    True
    """
    x = np.array(data, dtype=np.float64)
    if x.ndim != 2:
        raise InputError(f"filter_map expects a 2-D map, got shape {x.shape}")
    window = _check_window(window_px)
    border = _check_border(border_px)
    valid = np.isfinite(x)
    rows, cols = x.shape
    if window == 1 or not valid.any() or rows <= 2 * border or cols <= 2 * border:
        return x
    from scipy import ndimage  # here: measure imports this module (cold start, issue 16)

    inner = (slice(border, rows - border), slice(border, cols - border))
    # median stage
    if valid.all():
        filled = x
    else:
        idx = ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
        filled = x[tuple(idx)]
    med = x.copy()
    med[inner] = _median_interior(filled, window, border)
    med[~valid] = np.nan
    # mean stage: normalised box filter over valid in-image pixels
    vf = valid.astype(np.float64)
    num = ndimage.uniform_filter(np.where(valid, med, 0.0), window, mode="constant", cval=0.0)
    den = ndimage.uniform_filter(vf, window, mode="constant", cval=0.0)
    out = med.copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        out[inner] = num[inner] / den[inner]
    out[~valid] = np.nan
    return out


def filter_coefficients(
    coefficients: ArrayLike,
    window_px: int = DEFAULT_WINDOW_PX,
    border_px: int = DEFAULT_BORDER_PX,
) -> NDArray[np.float64]:
    """:func:`filter_map` applied to each map of an (M, H, W) coefficient stack separately.

    Parameters
    ----------
    coefficients : array_like, shape (M, H, W)
        Coefficient maps (as from :func:`fit_model`); NaN = invalid.
    window_px : int
        Odd side of the square windows; 21 in the thesis.
    border_px : int
        Unfiltered border width; 10 in the thesis.

    Returns
    -------
    ndarray, shape (M, H, W), float64
        Each map filtered by :func:`filter_map`.

    References
    ----------
    Thesis Sec. 4.1.

    Examples
    --------
    >>> y, x = np.mgrid[0:5, 0:7]
    >>> maps = np.stack([0.1 * x + 0.2 * y, np.ones((5, 7))])
    >>> out = filter_coefficients(maps, window_px=3, border_px=1)
    >>> out.shape, bool(np.allclose(out, maps))
    ((2, 5, 7), True)
    """
    c = np.asarray(coefficients, dtype=np.float64)
    if c.ndim != 3:
        raise InputError(f"coefficients must be an (M, H, W) stack, got shape {c.shape}")
    return np.stack([filter_map(m, window_px, border_px) for m in c])


# --------------------------------------------------------------------------------------------
# The calibration object
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ResidualStats:
    """Summary of a per-pixel residual map over the measurement pixels (mm).

    What :meth:`Calibration.residual_summary` returns for each model.

    Parameters
    ----------
    model : str
        Calibration model of the residual map.
    median_mm, mean_mm, max_mm : float
        Median, mean and maximum of the per-pixel RMS over the measurement pixels (NaN when
        there is none).
    pixels : int
        Number of measurement pixels with a finite RMS.

    Examples
    --------
    >>> ref = np.zeros((2, 3))
    >>> cal = calibrate(ref, np.stack([ref + 4.0, ref + 8.1]), [2.0, 4.0],
    ...                 window_px=1, border_px=0)
    >>> stats = cal.residual_summary()["linear"]
    >>> stats.model, round(stats.median_mm, 4), stats.pixels
    ('linear', 0.0157, 6)
    """

    model: str
    median_mm: float
    mean_mm: float
    max_mm: float
    pixels: int


_PROVENANCE_SCALARS = (str, int, float)


def _check_provenance(value: Any, where: str = "provenance") -> None:
    """Provenance must map names to str, int, float, lists of those, or nested such dicts."""
    if not isinstance(value, Mapping):
        raise InputError(f"{where} must be a dict, got {type(value).__name__}")
    for key, item in value.items():
        if not isinstance(key, str) or not key or "/" in key or key in (".", ".."):
            raise InputError(
                f"{where} key {key!r} is not usable as an HDF5 name; use a non-empty string "
                "without '/'"
            )
        path = f"{where}.{key}"
        if isinstance(item, Mapping):
            _check_provenance(item, path)
        elif isinstance(item, bool) or item is None:
            raise InputError(
                f"{path} = {item!r}: booleans and None are not stored; use a string or number"
            )
        elif isinstance(item, _PROVENANCE_SCALARS):
            continue
        elif isinstance(item, (list, tuple)):
            kinds = {type(v) for v in item}
            if not (kinds <= {str} or kinds <= {int} or kinds <= {int, float}):
                raise InputError(
                    f"{path}: a list must hold only strings or only numbers, got "
                    f"{sorted(k.__name__ for k in kinds)}"
                )
        else:
            raise InputError(
                f"{path}: unsupported type {type(item).__name__}; use str, int, float, a list of "
                "those, or a dict"
            )


# --------------------------------------------------------------------------------------------
# the interface a measurement uses
# --------------------------------------------------------------------------------------------
# A protocol has no constructor: numpydoc reads the (*args, **kwargs) of typing.Protocol as one.
@runtime_checkable
class MeasurementCalibration(Protocol):  # numpydoc ignore=PR01
    """What a measurement asks of a calibration, whichever kind it is.

    :class:`Calibration` (phase to height, Eq. 2.10-2.11) and
    :class:`~hdrfringe.core.stereo.StereoCalibration` (projector-camera, triangulation) both follow
    it; :func:`hdrfringe.io.stereo_file.load_any_calibration` reads either from its file and
    :func:`hdrfringe.pipeline.measure` takes either without asking which one it is.

    Attributes
    ----------
    kind : str
        The file's kind: ``"phase-to-height"`` or ``"stereo"``.
    output : str
        What a measurement makes of the absolute phase with it: ``"heights"`` (a height map
        above the reference plane) or ``"points"`` (triangulated 3D points).

    Examples
    --------
    >>> cal = Calibration("linear", np.ones((2, 3)), None, np.zeros((2, 3)), np.array([2.0]))
    >>> isinstance(cal, MeasurementCalibration), cal.output, cal.height_model() is cal
    (True, 'heights', True)
    """

    kind: ClassVar[str]
    output: ClassVar[str]

    def check_fits(
        self,
        spec: FringeSpec,
        image_shape: tuple[int, int],
        camera_bit_depth: int,
        *,
        source: str | None = None,
        projector_size: tuple[int, int] | None = None,
    ) -> None:
        """Refuse a measurement the calibration does not fit (:class:`CalibrationMismatchError`).

        Parameters
        ----------
        spec : FringeSpec
            The measurement's finest set.
        image_shape : (int, int)
            Camera image (height, width).
        camera_bit_depth : int
            Camera bit depth.
        source : str, optional
            Where the calibration came from, for the message.
        projector_size : (int, int), optional
            The projector (width, height) the captures record, when they record one.
        """
        ...

    def camera_geometry(self) -> CameraGeometry | None:
        """The camera's pinhole geometry a height map is placed with (None: pixels).

        Returns
        -------
        CameraGeometry or None
        """
        ...

    def notes(self) -> tuple[str, ...]:
        """What a measurement's outputs with it need said (``metrics.notes``).

        Returns
        -------
        tuple of str
        """
        ...

    def height_model(self) -> Calibration | None:
        """The phase-to-height model a predicted height std goes through; None: not modelled.

        Returns
        -------
        Calibration or None
        """
        ...

    def uncertainty_notes(self) -> tuple[str, ...]:
        """What a predicted uncertainty with it lacks (``metrics.uncertainty.notes``).

        Returns
        -------
        tuple of str
        """
        ...

    def projector_geometry(self) -> Any:
        """The projector-camera geometry it offers a strategy (a StereoCalibration), or None.

        Returns
        -------
        StereoCalibration or None
        """
        ...


@dataclass(frozen=True, eq=False)
class Calibration:
    """A per-pixel phase-to-height calibration and everything needed to reuse it safely.

    Made by :func:`calibrate`, stored by :func:`hdrfringe.io.calibration_file.save_calibration`.
    The constructor checks every field and converts the arrays to float64 (residual maps to
    float32).

    Parameters
    ----------
    model : {"linear", "rational", "poly2", "poly3"}
        Model :meth:`height` uses.
    k_map : ndarray (H, W)
        Linear phase-to-height map ``K`` (Eq. 2.15) in mm/rad, filtered; always present.
    coefficients : ndarray (M, H, W) or None
        Filtered coefficient maps of the non-linear model (see :func:`fit_model`); None for
        ``linear``.
    reference_phase : ndarray (H, W)
        Absolute phase of the reference plane (depth 0), subtracted by :meth:`height`.
    depths_mm : ndarray (J,)
        Plate depths used.
    residual_rms_mm : dict[str, ndarray (H, W) float32]
        Per model compared, per-pixel RMS over positions of ``model height - depth`` with the
        filtered maps (what a measurement gets).
    residual_rms_unfiltered_mm : dict[str, ndarray (H, W) float32]
        The same with the unfiltered maps (the fit's own residual).
    filter_window_px, border_px : int
        Filter window (Sec. 4.1: 21) and unfiltered border excluded from metrics (10).
    spec : FringeSpec or None
        Fringe set the calibration was measured with (pattern, steps, pitch, orientation
        must match a measurement; imin and migl may differ).
    gamma_precompensation : float or None
        Projector gamma pre-compensation used (Eq. 2.17).
    camera_bit_depth : int or None
        Bit depth of the camera the calibration was measured with.
    image_shape : (int, int) or None
        Camera image (height, width); from ``reference_phase`` when not given (always set
        after construction).
    provenance : dict
        Package version, date, input folders and their content hashes (given by the caller);
        values are str, int, float, lists of those or nested dicts.

    Raises
    ------
    InputError
        A field of the wrong shape or out of range.

    References
    ----------
    Thesis Sec. 2.4-2.5 (Eq. 2.10, 2.11, 2.15) and Sec. 4.1 (filtering, border).

    Examples
    --------
    A linear calibration with ``K = 0.5`` mm/rad over a 2 x 3 image:

    >>> cal = Calibration("linear", np.full((2, 3), 0.5), None, np.zeros((2, 3)),
    ...                   np.array([2.0, 4.0]))
    >>> cal.image_shape, cal.height(np.full((2, 3), 6.0)).tolist()
    ((2, 3), [[3.0, 3.0, 3.0], [3.0, 3.0, 3.0]])
    """

    model: str
    k_map: NDArray[np.float64]
    coefficients: NDArray[np.float64] | None
    reference_phase: NDArray[np.float64]
    depths_mm: NDArray[np.float64]
    residual_rms_mm: dict[str, NDArray[np.float32]] = field(default_factory=dict)
    residual_rms_unfiltered_mm: dict[str, NDArray[np.float32]] = field(default_factory=dict)
    filter_window_px: int = DEFAULT_WINDOW_PX
    border_px: int = DEFAULT_BORDER_PX
    spec: FringeSpec | None = None
    gamma_precompensation: float | None = None
    camera_bit_depth: int | None = None
    image_shape: tuple[int, int] | None = None
    provenance: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _check_model(self.model)
        ref = np.asarray(self.reference_phase, dtype=np.float64)
        if ref.ndim != 2:
            raise InputError(f"reference phase must be a 2-D map, got shape {ref.shape}")
        shape = (int(ref.shape[0]), int(ref.shape[1]))
        if self.image_shape is not None and tuple(self.image_shape) != shape:
            raise InputError(
                f"image shape {tuple(self.image_shape)} differs from the reference phase {shape}"
            )
        k = np.asarray(self.k_map, dtype=np.float64)
        if k.shape != shape:
            raise InputError(f"K map of shape {k.shape} differs from the image shape {shape}")
        coef = self.coefficients
        if self.model == "linear":
            if coef is not None:
                raise InputError("a linear calibration has no extra coefficient maps; pass None")
        else:
            if coef is None:
                raise InputError(f"a {self.model} calibration needs its coefficient maps")
            coef = np.asarray(coef, dtype=np.float64)
            want = (N_COEFFICIENTS[self.model], *shape)
            if coef.shape != want:
                raise InputError(
                    f"{self.model} coefficients of shape {coef.shape}, expected {want}"
                )
        depths = np.asarray(self.depths_mm, dtype=np.float64)
        if depths.ndim != 1:
            raise InputError(f"depths must be a 1-D list, got shape {depths.shape}")
        for name in ("residual_rms_mm", "residual_rms_unfiltered_mm"):
            maps = {}
            for key, val in dict(getattr(self, name)).items():
                _check_model(key)
                arr = np.asarray(val, dtype=np.float32)
                if arr.shape != shape:
                    raise InputError(f"{name}[{key!r}] of shape {arr.shape}, expected {shape}")
                maps[key] = arr
            object.__setattr__(self, name, maps)
        _check_window(self.filter_window_px)
        _check_border(self.border_px)
        if self.spec is not None and not isinstance(self.spec, FringeSpec):
            raise InputError(f"spec must be a FringeSpec, got {type(self.spec).__name__}")
        if self.gamma_precompensation is not None:
            g = float(self.gamma_precompensation)
            if not (math.isfinite(g) and g > 0):
                raise InputError(f"gamma pre-compensation must be positive, got {g}")
            object.__setattr__(self, "gamma_precompensation", g)
        if self.camera_bit_depth is not None:
            b = self.camera_bit_depth
            if isinstance(b, bool) or int(b) != b or not 1 <= b <= 32:
                raise InputError(f"camera bit depth must be a whole number 1..32, got {b}")
            object.__setattr__(self, "camera_bit_depth", int(b))
        _check_provenance(self.provenance)
        object.__setattr__(self, "reference_phase", ref)
        object.__setattr__(self, "k_map", k)
        object.__setattr__(self, "coefficients", coef)
        object.__setattr__(self, "depths_mm", depths)
        object.__setattr__(self, "image_shape", shape)
        object.__setattr__(self, "filter_window_px", int(self.filter_window_px))
        object.__setattr__(self, "border_px", int(self.border_px))
        object.__setattr__(self, "provenance", dict(self.provenance))

    @property
    def model_coefficients(self) -> NDArray[np.float64]:
        """Coefficient maps of :attr:`model` as (M, H, W) (``K[None]`` for linear)."""
        if self.coefficients is None:
            return self.k_map[None]
        return self.coefficients

    def phase_difference(self, absolute_phase: ArrayLike) -> NDArray[np.float64]:
        """``dphi = phi - phi_ref`` (Eq. 2.10) for an absolute phase map of this camera."""
        phi = np.asarray(absolute_phase, dtype=np.float64)
        if phi.shape != self.image_shape:
            raise InputError(
                f"phase map of shape {phi.shape} does not match the calibration's image "
                f"{self.image_shape}; measure with the calibrated camera and region of interest"
            )
        return phase_difference(phi, self.reference_phase)

    def height(self, absolute_phase: ArrayLike) -> NDArray[np.float64]:
        """Height in mm above the reference plane from an absolute phase map.

        ``h = K (phi - phi_ref)`` (Eq. 2.10-2.11) for the linear model, the fitted model of
        :func:`evaluate_model` otherwise. NaN where the phase, the reference or the calibration
        is invalid.

        Parameters
        ----------
        absolute_phase : array_like, shape (H, W)
            Absolute phase map of this camera (radians, NaN = invalid).

        Returns
        -------
        ndarray, shape (H, W)
            Height in mm.
        """
        dphi = self.phase_difference(absolute_phase)
        return evaluate_model(self.model_coefficients, dphi, self.model)

    def measurement_mask(self) -> NDArray[np.bool_]:
        """Pixels inside the unfiltered border (those the residual statistics use)."""
        return measurement_mask(_image_shape(self), self.border_px)

    def residual_summary(self, filtered: bool = True) -> dict[str, ResidualStats]:
        """Per model compared: median, mean and max over measurement pixels of the RMS map."""
        maps = self.residual_rms_mm if filtered else self.residual_rms_unfiltered_mm
        mask = self.measurement_mask()
        out: dict[str, ResidualStats] = {}
        for name, rms in maps.items():
            vals = rms[mask].astype(np.float64)
            vals = vals[np.isfinite(vals)]
            if vals.size:
                out[name] = ResidualStats(
                    name,
                    float(np.median(vals)),
                    float(np.mean(vals)),
                    float(np.max(vals)),
                    int(vals.size),
                )
            else:
                out[name] = ResidualStats(name, math.nan, math.nan, math.nan, 0)
        return out

    def describe_residuals(self, filtered: bool = True) -> str:
        """One line for the CLI, e.g. ``linear: 0.12 mm, rational: 0.004 mm``.

        The numbers are the median over measurement pixels of the per-pixel RMS over the
        plate positions.
        """
        stats = self.residual_summary(filtered)
        return ", ".join(f"{s.model}: {s.median_mm:.3g} mm" for s in stats.values())

    #: The file's kind (:class:`MeasurementCalibration`).
    kind: ClassVar[str] = "phase-to-height"
    #: What a measurement makes of the phase with it: a height map (Eq. 2.10-2.11).
    output: ClassVar[str] = "heights"

    def check_fits(
        self,
        spec: FringeSpec,
        image_shape: tuple[int, int],
        camera_bit_depth: int,
        *,
        source: str | None = None,
        projector_size: tuple[int, int] | None = None,
    ) -> None:
        """:func:`check_compatible` (the projector's size does not matter to it).

        Parameters
        ----------
        spec : FringeSpec
            The measurement's finest set.
        image_shape : (int, int)
            Camera image (height, width).
        camera_bit_depth : int
            Camera bit depth.
        source : str, optional
            Where the calibration came from, for the message.
        projector_size : (int, int), optional
            Unused.
        """
        check_compatible(self, spec, image_shape, camera_bit_depth, source=source)

    def camera_geometry(self) -> CameraGeometry | None:
        """Camera geometry recorded with the calibration (its reference-plane captures).

        Returns
        -------
        CameraGeometry or None
            None when the reference-plane captures recorded no ``focal_px`` and
            ``standoff_mm``.

        References
        ----------
        Thesis Sec. 2.1 (the camera perpendicular to the reference plane).
        """
        entry = self.provenance.get("camera_geometry")
        return CameraGeometry.from_manifest(entry) if isinstance(entry, dict) else None

    def notes(self) -> tuple[str, ...]:
        """:data:`NO_GEOMETRY` when no camera geometry is recorded (points in pixels).

        Returns
        -------
        tuple of str
        """
        return (NO_GEOMETRY,) if self.camera_geometry() is None else ()

    def height_model(self) -> Calibration:
        """The calibration itself: the height std goes through its model.

        Returns
        -------
        Calibration
        """
        return self

    def uncertainty_notes(self) -> tuple[str, ...]:
        """Nothing: phase and height std are both predicted.

        Returns
        -------
        tuple of str
        """
        return ()

    def projector_geometry(self) -> None:
        """None: a phase-to-height calibration knows no projector-camera geometry.

        Returns
        -------
        None
        """
        return None


def _image_shape(cal: Calibration) -> tuple[int, int]:
    """``cal.image_shape``, which ``Calibration.__post_init__`` always sets (never None)."""
    shape = cal.image_shape
    assert shape is not None, "Calibration.__post_init__ sets image_shape"
    return shape


def _check_depths(depths: NDArray[np.float64]) -> None:
    if depths.ndim != 1:
        raise InputError(f"depths must be a 1-D list of mm, got shape {depths.shape}")
    if not np.all(np.isfinite(depths)):
        raise InputError(f"depths must be finite numbers in mm, got {depths.tolist()}")
    far = np.flatnonzero(np.abs(depths) > MAX_DEPTH_MM)
    if far.size:
        raise InputError(
            f"plate position {int(far[0]) + 1} has depth {depths[far[0]]:g} mm, beyond "
            f"{MAX_DEPTH_MM:g} mm; give plate depths in mm"
        )
    zero = np.flatnonzero(depths == 0)
    if zero.size:
        raise InputError(
            f"plate position {int(zero[0]) + 1} has depth 0 mm, which is the reference plane: "
            "pass its phase as the reference and leave it out of the calibration positions"
        )
    values, counts = np.unique(depths, return_counts=True)
    dup = values[counts > 1]
    if dup.size:
        listed = ", ".join(f"{v:g} mm" for v in dup)
        raise InputError(
            f"duplicate calibration depth(s) {listed}; give each plate position once "
            "(average repeated captures before calibrating)"
        )
    if depths.size < 2:
        only = f" ({depths[0]:g} mm)" if depths.size else ""
        raise InputError(
            f"one position only{only}: a calibration needs at least 2 plate positions besides "
            "the reference (the thesis uses 25, 2..50 mm by 2 mm)"
        )


def calibrate(
    reference_phase: ArrayLike,
    phases: ArrayLike,
    depths_mm: ArrayLike,
    *,
    model: str = "linear",
    window_px: int = DEFAULT_WINDOW_PX,
    border_px: int = DEFAULT_BORDER_PX,
    compare: Sequence[str] | None = None,
    refine: bool = False,
    spec: FringeSpec | None = None,
    gamma_precompensation: float | None = None,
    camera_bit_depth: int | None = None,
    provenance: Mapping[str, Any] | None = None,
) -> Calibration:
    """Calibrate phase to height from a reference plane and plate positions (Sec. 2.5, 4.1).

    Steps: phase differences (Eq. 2.10); linear ``K`` (Eq. 2.15) and, for a non-linear
    ``model``, its coefficient maps (:func:`fit_model`); every map filtered by
    :func:`filter_map`; per-pixel residual RMS maps, filtered and unfiltered, for each model in
    ``compare``.

    Parameters
    ----------
    reference_phase : array_like, shape (H, W)
        Absolute phase of the reference plane (depth 0).
    phases : array_like, shape (J, H, W)
        Absolute phases of the plate at ``depths_mm``; NaN = invalid pixel.
    depths_mm : array_like, shape (J,)
        Distinct, non-zero plate depths in mm, J >= 2.
    model : {"linear", "rational", "poly2", "poly3"}
        Model used by :meth:`Calibration.height`.
    window_px, border_px : int
        Median/mean filter window and unfiltered border (thesis: 21 and 10).
    compare : sequence of str, optional
        Models whose residual maps are computed (each costs its fit and filtering); default
        ``linear`` and ``model``. Pass :data:`MODELS` to compare all.
    refine : bool
        Gauss-Newton step of the rational model (see :func:`fit_model`).
    spec, gamma_precompensation, camera_bit_depth, provenance
        Metadata stored with the calibration (see :class:`Calibration`).

    Returns
    -------
    Calibration
        The filtered maps, the residual maps of every compared model and the metadata.

    Raises
    ------
    InputError
        Mismatched shapes; fewer than 2 positions (or fewer than a model needs); a depth of 0
        or repeated or beyond :data:`MAX_DEPTH_MM`; a filter window or border that does not fit
        the image; an unknown model; a result that fails :func:`check_calibration` (e.g. too
        few valid pixels, or a fit that does not reproduce the depths).

    References
    ----------
    Thesis Sec. 2.4-2.5 (Eq. 2.10, 2.15) and Sec. 4.1 (filtering, border).

    Examples
    --------
    Three plate positions of a rig with ``K = 0.5`` mm/rad, no filtering:

    >>> ref = np.zeros((2, 3))
    >>> phases = np.stack([ref + h / 0.5 for h in (2.0, 4.0, 6.0)])
    >>> cal = calibrate(ref, phases, [2.0, 4.0, 6.0], window_px=1, border_px=0)
    >>> float(cal.k_map[0, 0]), float(cal.height(ref + 3.0)[1, 2])
    (0.5, 1.5)
    >>> cal.describe_residuals()
    'linear: 0 mm'
    """
    _check_model(model)
    ref = np.asarray(reference_phase, dtype=np.float64)
    phi = np.asarray(phases, dtype=np.float64)
    depths = np.asarray(depths_mm, dtype=np.float64)
    if ref.ndim != 2:
        raise InputError(f"reference phase must be a 2-D map, got shape {ref.shape}")
    if phi.ndim == 2:
        phi = phi[None]
    if phi.ndim != 3 or phi.shape[1:] != ref.shape:
        raise InputError(
            f"plate phases of shape {phi.shape} do not match the reference phase {ref.shape}; "
            "give a (positions, height, width) stack from the same camera"
        )
    if depths.ndim != 1 or depths.size != phi.shape[0]:
        raise InputError(
            f"{depths.size} depth(s) for {phi.shape[0]} plate phase map(s); give one depth "
            "per position"
        )
    _check_depths(depths)
    window = _check_window(window_px)
    border = _check_border(border_px)
    if not measurement_mask((ref.shape[0], ref.shape[1]), border).any():
        raise InputError(
            f"a {ref.shape[0]}x{ref.shape[1]} image has no pixel inside a {border} pixel "
            "border; lower border_px"
        )
    models = list(dict.fromkeys(["linear", model] if compare is None else list(compare)))
    for name in models:
        _check_model(name)
        need = N_COEFFICIENTS[name] if name != "linear" else 2
        if depths.size < need:
            raise InputError(
                f"the {name} model needs at least {need} plate positions, got {depths.size}; "
                "add positions or use a simpler model"
            )
    if model not in models:
        models.append(model)

    samples = _samples(phi - ref, depths)
    fitted: dict[str, NDArray[np.float64]] = {}
    filtered: dict[str, NDArray[np.float64]] = {}
    for name in dict.fromkeys(["linear", *models]):
        fitted[name] = _fit(samples, name, refine)
        filtered[name] = filter_coefficients(fitted[name], window, border)
    res_f: dict[str, NDArray[np.float32]] = {}
    res_u: dict[str, NDArray[np.float32]] = {}
    for name in models:
        res_f[name] = _residual_rms(samples, filtered[name], name).astype(np.float32)
        res_u[name] = _residual_rms(samples, fitted[name], name).astype(np.float32)
    cal = Calibration(
        model=model,
        k_map=filtered["linear"][0],
        coefficients=None if model == "linear" else filtered[model],
        reference_phase=ref.copy(),
        depths_mm=depths.copy(),
        residual_rms_mm=res_f,
        residual_rms_unfiltered_mm=res_u,
        filter_window_px=window,
        border_px=border,
        spec=spec,
        gamma_precompensation=gamma_precompensation,
        camera_bit_depth=camera_bit_depth,
        provenance=dict(provenance or {}),
    )
    check_calibration(cal)
    return cal


# --------------------------------------------------------------------------------------------
# sanity of a calibration (on write and on read)
# --------------------------------------------------------------------------------------------
def _no_inf(arr: NDArray[Any], dataset: str, where: str) -> None:
    n_inf = int(np.count_nonzero(np.isinf(arr)))
    if n_inf:
        raise InputError(
            f"{where}: {dataset} holds +-inf at {n_inf} value(s) (invalid pixels are NaN, never "
            "inf); the calibration is damaged, recalibrate"
        )


def check_calibration(cal: Calibration, where: str = "calibration") -> None:
    """Refuse a calibration that is damaged or cannot give heights (checked on write and read).

    :class:`Calibration` checks shapes and types; this checks the values. A calibration passes
    when all of these hold (the constants are module attributes):

    - every depth is finite, non-zero, distinct and at most :data:`MAX_DEPTH_MM` in magnitude;
    - no map holds +-inf (NaN marks an invalid pixel; :func:`calibrate` never writes inf);
      the reference phase is at most :data:`MAX_PHASE_RAD` in magnitude;
    - at least :data:`MIN_USABLE_FRACTION` of the measurement pixels (:func:`measurement_mask`)
      are usable: reference phase, ``K`` and the model's coefficients all finite;
    - over the usable pixels, the median phase shift ``|d_max / K|`` of the deepest plate lies
      in :data:`PHASE_SHIFT_RANGE_RAD` (``K`` neither ~0 nor huge), and for a non-linear model
      the median of its height at that shift divided by ``d_max`` lies in
      :data:`MODEL_RATIO_RANGE` (the model agrees with its own ``K``);
    - every residual map is >= 0 where finite, and the model's own residual map (when stored)
      has a finite median over the measurement pixels no larger than ``max |depth|``.

    Parameters
    ----------
    cal : Calibration
        The calibration to check.
    where : str
        What to name in the message (a file path when reading).

    Raises
    ------
    InputError
        One line naming ``where``, the dataset at fault and the fix.

    Notes
    -----
    Thesis Sec. 2.5 (Eq. 2.10-2.15): a height is ``K dphi``; a ``K`` that is not finite, ~0 or
    absurdly large, or a model that disagrees with it, gives heights that look valid but are not.

    Examples
    --------
    >>> good = Calibration("linear", np.full((2, 3), 0.5), None, np.zeros((2, 3)),
    ...                    np.array([2.0, 4.0]), border_px=0)
    >>> check_calibration(good)
    >>> bad = Calibration("linear", np.full((2, 3), np.inf), None, np.zeros((2, 3)),
    ...                   np.array([2.0, 4.0]), border_px=0)
    >>> try:
    ...     check_calibration(bad, "cal.h5")
    ... except InputError as exc:
    ...     print(str(exc).split(" (")[0])
    cal.h5: /k_map holds +-inf at 6 value(s)
    """
    depths = cal.depths_mm
    if depths.size == 0 or not np.all(np.isfinite(depths)):
        raise InputError(
            f"{where}: /depths_mm must be finite numbers in mm, got {depths.tolist()}; "
            "recalibrate with the plate depths"
        )
    if np.any(depths == 0) or np.unique(depths).size != depths.size:
        raise InputError(
            f"{where}: /depths_mm {depths.tolist()} has a zero or repeated depth; the "
            "calibration is damaged, recalibrate"
        )
    d_max = float(depths[np.argmax(np.abs(depths))])
    if abs(d_max) > MAX_DEPTH_MM:
        raise InputError(
            f"{where}: /depths_mm reaches {d_max:g} mm, beyond {MAX_DEPTH_MM:g} mm; give plate "
            "depths in mm"
        )
    ref = cal.reference_phase
    _no_inf(ref, "/reference_phase", where)
    _no_inf(cal.k_map, "/k_map", where)
    if cal.coefficients is not None:
        _no_inf(cal.coefficients, "/coefficients", where)
    big = np.nanmax(np.abs(ref)) if np.isfinite(ref).any() else 0.0
    if big > MAX_PHASE_RAD:
        raise InputError(
            f"{where}: /reference_phase reaches {big:g} rad, beyond {MAX_PHASE_RAD:g} rad; the "
            "calibration is damaged, recalibrate"
        )
    mask = cal.measurement_mask()
    usable = mask & np.isfinite(ref) & np.isfinite(cal.k_map)
    if cal.coefficients is not None:
        usable &= np.isfinite(cal.coefficients).all(axis=0)
    n_mask = int(np.count_nonzero(mask))
    n_usable = int(np.count_nonzero(usable))
    if n_usable < MIN_USABLE_FRACTION * n_mask or n_usable == 0:
        datasets = "/reference_phase, /k_map" + (
            "" if cal.coefficients is None else ", /coefficients"
        )
        raise InputError(
            f"{where}: {datasets} are finite at {n_usable} of {n_mask} measurement pixels "
            f"(fewer than {MIN_USABLE_FRACTION:.0%}); the calibration is empty or damaged, "
            "recalibrate with the plate filling the view"
        )
    k = cal.k_map[usable]
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        shift = float(np.median(np.abs(d_max / k)))
    lo, hi = PHASE_SHIFT_RANGE_RAD
    if not lo <= shift <= hi:
        raise InputError(
            f"{where}: /k_map gives a median phase shift of {shift:.3g} rad for the "
            f"{d_max:g} mm plate, outside {lo:g}..{hi:g} rad (K is ~0 or absurdly large); the "
            "calibration is damaged, recalibrate"
        )
    if cal.coefficients is not None:
        coef = cal.coefficients[:, usable][:, None, :]
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            dphi = (d_max / k)[None, :]
        ratio = evaluate_model(coef, dphi, cal.model)[0] / d_max
        ratio = ratio[np.isfinite(ratio)]
        med = float(np.median(ratio)) if ratio.size else math.nan
        rlo, rhi = MODEL_RATIO_RANGE
        if not rlo <= med <= rhi:
            raise InputError(
                f"{where}: /coefficients ({cal.model}) give {med:.3g} times the linear height "
                f"at the {d_max:g} mm plate, outside {rlo:g}..{rhi:g}; the calibration is "
                "damaged, recalibrate"
            )
    limit = float(np.max(np.abs(depths)))
    for group, maps in (
        ("residual_rms_mm", cal.residual_rms_mm),
        ("residual_rms_unfiltered_mm", cal.residual_rms_unfiltered_mm),
    ):
        for name, rms in maps.items():
            dataset = f"/{group}/{name}"
            _no_inf(rms, dataset, where)
            if np.any(rms < 0):
                raise InputError(
                    f"{where}: {dataset} holds negative RMS values; the calibration is "
                    "damaged, recalibrate"
                )
            if group == "residual_rms_mm" and name == cal.model:
                vals = rms[mask]
                vals = vals[np.isfinite(vals)]
                med = float(np.median(vals)) if vals.size else math.nan
                if not med <= limit:
                    raise InputError(
                        f"{where}: {dataset} has a median of {med:.3g} mm (the fit failed: "
                        f"not finite or above the {limit:g} mm depth range); check the plate "
                        "depths and captures and recalibrate"
                    )


# --------------------------------------------------------------------------------------------
# compatibility of a calibration with a measurement
# --------------------------------------------------------------------------------------------
class CalibrationMismatchError(HdrFringeError):
    """A calibration does not fit a measurement (fringe set, image size or bit depth).

    Raised by :func:`check_compatible`; its message lists every difference.

    Examples
    --------
    >>> err = CalibrationMismatchError("calibration does not fit this measurement: ...")
    >>> isinstance(err, HdrFringeError)
    True
    """


def _fmt(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def check_compatible(
    cal: Calibration,
    spec: FringeSpec,
    image_shape: tuple[int, int],
    camera_bit_depth: int,
    *,
    source: str | PathLike[str] | None = None,
) -> None:
    """Refuse a measurement the calibration does not fit.

    Compared: fringe pattern, steps, pitch and orientation (they set the phase-to-height
    relation and the phase errors the calibration absorbed), image size, camera bit depth.
    ``imin`` and ``migl`` may differ: the thesis measures at MIGL 105..255 with calibrations
    taken at MIGL 255 (Sec. 4.1), since the gray range does not change the phase. Fields the
    calibration does not record (None) are not compared.

    Parameters
    ----------
    cal : Calibration
        The calibration to use.
    spec : FringeSpec
        Fringe set of the measurement.
    image_shape : (int, int)
        Camera image (height, width) of the measurement.
    camera_bit_depth : int
        Camera bit depth of the measurement.
    source : str or path-like, optional
        Where the calibration came from, for the message.

    Raises
    ------
    CalibrationMismatchError
        One line listing every difference, then "recalibrate with ... or measure with ...".

    Notes
    -----
    Thesis Sec. 4.1: calibrations taken at MIGL 255 serve measurements at any MIGL.

    Examples
    --------
    >>> import numpy as np
    >>> cal = Calibration("linear", np.ones((2, 3)), None, np.zeros((2, 3)), np.array([2.0]),
    ...                   spec=FringeSpec("sinusoidal", 3, 6.0), camera_bit_depth=8)
    >>> check_compatible(cal, FringeSpec("sinusoidal", 3, 6.0, migl=150.0), (2, 3), 8)
    >>> check_compatible(cal, FringeSpec("sinusoidal", 4, 6.0), (2, 3), 8)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.core.calibration.CalibrationMismatchError: ... steps 3 (calibration) vs 4 ...
    """
    diffs: list[tuple[str, str, str]] = []  # (what, calibration value, measurement value)
    if cal.spec is not None:
        c = cal.spec
        for what, cv, mv in (
            ("pattern", c.pattern, spec.pattern),
            ("steps", c.steps, spec.steps),
            ("orientation", c.orientation, spec.orientation),
        ):
            if cv != mv:
                diffs.append((what, _fmt(cv), _fmt(mv)))
        if not math.isclose(c.pitch_px, spec.pitch_px, rel_tol=1e-9, abs_tol=1e-12):
            diffs.append(("pitch", f"{c.pitch_px:g} px", f"{spec.pitch_px:g} px"))
    shape = (int(image_shape[0]), int(image_shape[1]))
    if cal.image_shape != shape:
        ch, cw = _image_shape(cal)
        diffs.append(("image size", f"{cw}x{ch}", f"{shape[1]}x{shape[0]}"))
    if cal.camera_bit_depth is not None and cal.camera_bit_depth != int(camera_bit_depth):
        diffs.append(
            ("camera bit depth", f"{cal.camera_bit_depth} bits", f"{int(camera_bit_depth)} bits")
        )
    if not diffs:
        return
    name = f" {source}" if source is not None else ""
    listed = ", ".join(f"{w} {cv} (calibration) vs {mv} (measurement)" for w, cv, mv in diffs)
    redo = ", ".join(f"{w} {mv}" for w, _, mv in diffs)
    keep = ", ".join(f"{w} {cv}" for w, cv, _ in diffs)
    raise CalibrationMismatchError(
        f"calibration{name} does not fit this measurement: {listed}; recalibrate with {redo} "
        f"or measure with {keep}"
    )
