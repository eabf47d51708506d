"""Saturated-intensity estimation and its error correction: the DPA building blocks (thesis 6.1).

The DPA method (thesis Ch. 6) needs, for every pixel saturated at the initial MIGL, the highest
intensity its N shifts *would* have had without saturation. This module provides:

* :func:`estimate_saturated_eq62`: thesis Eq. 6.2, sinusoidal 4-step with exactly one saturated
  shift.
* :func:`estimate_saturated_lsq`: the same by least squares on the sinusoid model, for N steps
  with up to N - 3 saturated shifts; for N = 4 and one saturated shift it is Eq. 6.2.
* :func:`true_peak_thesis` (Eq. 6.3) and :func:`true_peak_scaled`: the training "truth" from an
  LPA step-1 index image, and :func:`unsaturation_migl`, the inverse of the same models.
* :class:`CorrectionPolynomial` and :func:`train_correction` (Sec. 6.1.2, Eq. 6.4).
* :func:`training_data_from_rig`: the LPA step-1 sweep on any rig that produces the training data.

Index mapping for Eq. 6.2
-------------------------
The thesis numbers the four shifts ``i = 1..4`` with phase shift ``2*pi*i/4``; the capture-folder
contract numbers them ``k = 0..3`` with shift ``2*pi*k/4``. Shift ``2*pi*4/4 = 2*pi`` is shift 0,
so thesis ``I_i`` is our ``I_(i mod 4)``: ``I_4 -> I_0`` and ``I_1, I_2, I_3`` keep their
numbers. For ``I_k = a + b*cos(phi + k*pi/2)``, ``I_k + I_(k+2) = 2a = I_(k+1) + I_(k+3)``, hence

    I_k = I_(k-1) + I_(k+1) - I_(k+2)        (indices mod 4)

which is each line of Eq. 6.2 after the mapping (thesis ``I_1 = I_4 - I_3 + I_2`` is our
``I_1 = I_0 + I_2 - I_3``). The identity is invariant under any cyclic relabelling, so the mapping
cannot introduce an error; it is spelled out only so the code can be checked against the thesis.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal, Protocol

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core import strict_json
from hdrfringe.core._validation import (
    as_stack,
    check_bit_depth,
    check_regular_file,
    full_scale,
    is_saturated,
    unsaturated_mask,
)
from hdrfringe.core.frames import Frame, UniformFrame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError, OutputExistsError

__all__ = [
    "CORRECTION_FORMAT",
    "TRUTH_MODELS",
    "CorrectionPolynomial",
    "TrainingData",
    "TruthModel",
    "check_correction_order",
    "correction_samples",
    "estimate_saturated_eq62",
    "estimate_saturated_lsq",
    "fit_unsaturated_sinusoid",
    "peak_and_trough",
    "saturated_peak_lower_bound",
    "saturation_pattern",
    "sinusoid_trough",
    "train_correction",
    "training_data_from_rig",
    "true_peak_scaled",
    "true_peak_thesis",
    "unsaturation_migl",
]

F64 = NDArray[np.float64]

#: How an MIGL index converts to a true intensity (and back): see :func:`true_peak_thesis` and
#: :func:`true_peak_scaled`.
TruthModel = Literal["scaled", "thesis"]
#: The truth models by name (the values of :data:`TruthModel`).
TRUTH_MODELS: tuple[str, ...] = ("scaled", "thesis")

#: ``format`` tag of a saved correction polynomial.
CORRECTION_FORMAT = "hdrfringe-correction-polynomial"
_CORRECTION_VERSION = 1

#: Largest number of shifts handled (saturation patterns are bit masks).
_MAX_STEPS = 16


class _CapturingRig(Protocol):
    """What :func:`training_data_from_rig` needs of a rig (any :class:`hdrfringe.rig.base.Rig`
    has it): its camera bit depth and ``capture(frames)`` returning an (n, H, W) image stack.
    Declared here so that this core module does not depend on the acquisition layer."""

    @property
    def camera_bit_depth(self) -> int: ...

    def capture(self, frames: Sequence[Frame]) -> NDArray[np.integer]: ...


# --------------------------------------------------------------------------------------------
# input checks
# --------------------------------------------------------------------------------------------
def _stack(images: ArrayLike, bit_depth: int, what: str, n_min: int = 3) -> F64:
    """The images as float64 (N, H, W), checked (:func:`hdrfringe.core._validation.as_stack`)."""
    full_scale(bit_depth)  # a bad bit depth is an error for float stacks too
    stack = as_stack(images, what=what, n_min=n_min, n_max=_MAX_STEPS, bit_depth=bit_depth)
    return stack.astype(np.float64, copy=False)


def saturation_pattern(images: ArrayLike, bit_depth: int) -> NDArray[np.bool_]:
    """Saturated samples, (N, H, W) bool: value ``>= 2^B - 1`` (the contract's ``== 2^B - 1``
    for integer images; float stacks clipped at full scale behave the same).

    Parameters
    ----------
    images : array_like, shape (N, H, W), 1 <= N <= 16
        Phase-shifted images (integer, or float clipped at ``2^B - 1``).
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    ndarray of bool, shape (N, H, W)
        True where the sample is saturated (:func:`hdrfringe.core._validation.is_saturated`).

    References
    ----------
    Thesis Sec. 5.1 (a saturated intensity equals ``2^B - 1``).

    Examples
    --------
    >>> saturation_pattern(np.array([[[255, 10]], [[254, 255]]], np.uint8), 8).tolist()
    [[[True, False]], [[False, True]]]
    """
    stack = _stack(images, bit_depth, "saturation pattern", n_min=1)
    return is_saturated(stack, bit_depth)


def _design(n: int) -> F64:
    """Rows ``[1, cos d_k, sin d_k]``, ``d_k = 2*pi*k/N``: ``I_k = a + C cos d_k + S sin d_k``
    with ``C = b cos(phi)``, ``S = -b sin(phi)``."""
    d = 2.0 * np.pi * np.arange(n) / n
    return np.stack([np.ones(n), np.cos(d), np.sin(d)], axis=1)


# --------------------------------------------------------------------------------------------
# Eq. 6.2 and its least-squares generalisation
# --------------------------------------------------------------------------------------------
def estimate_saturated_eq62(
    images: ArrayLike, bit_depth: int, *, return_stack: bool = False
) -> F64 | tuple[F64, F64]:
    """Saturated intensity by thesis Eq. 6.2 (sinusoidal 4-step, one saturated shift; Sec. 6.1.1).

    With shift k saturated, ``I_k = I_(k-1) + I_(k+1) - I_(k+2)`` (indices mod 4; the thesis's
    1-based ``I_4`` is our ``I_0``, see the module docstring).

    Parameters
    ----------
    images : array_like, shape (4, H, W)
        Shift k at index k, ``I_k = a + b cos(phi + 2*pi*k/4)``.
    bit_depth : int
        Camera bit depth B; saturated samples equal ``2^B - 1``.
    return_stack : bool
        Also return the stack with the saturated sample replaced by its estimate.

    Returns
    -------
    peak : ndarray (H, W)
        Highest true intensity among the four shifts: the maximum of the estimated stack where
        exactly one shift is saturated, the observed maximum where none is, NaN where two or more
        are (Eq. 6.2 does not apply).
    stack : ndarray (4, H, W), only with ``return_stack``
        Observed samples with the estimate in place of the saturated one; NaN columns where
        ``peak`` is NaN.

    References
    ----------
    Thesis Sec. 6.1.1, Eq. 6.1-6.2.

    Examples
    --------
    Two pixels of an 8-bit camera: true shifts (270, 150, 30, 150), the first clipped at 255,
    and (269.7, 128.3, 130.3, 271.7), two of them clipped:

    >>> images = np.array([[[255, 255]], [[150, 128]], [[30, 130]], [[150, 255]]], np.uint8)
    >>> estimate_saturated_eq62(images, 8).tolist()
    [[270.0, nan]]
    >>> peak, stack = estimate_saturated_eq62(images, 8, return_stack=True)
    >>> stack[:, 0, 0].tolist()
    [270.0, 150.0, 30.0, 150.0]
    """
    stack = _stack(images, bit_depth, "Eq. 6.2 estimate")
    if stack.shape[0] != 4:
        raise InputError(
            f"Eq. 6.2 is the sinusoidal 4-step case, got {stack.shape[0]} shifts; "
            "use estimate_saturated_lsq for other N"
        )
    sat = is_saturated(stack, bit_depth)
    count = sat.sum(axis=0)
    est = stack.copy()
    for k in range(4):
        one = sat[k] & (count == 1)
        formula = stack[(k - 1) % 4] + stack[(k + 1) % 4] - stack[(k + 2) % 4]
        est[k][one] = formula[one]
    est[:, count > 1] = np.nan
    peak = est.max(axis=0)  # NaN propagates where not estimable
    return (peak, est) if return_stack else peak


def _estimate_lsq(stack: F64, bit_depth: int) -> tuple[F64, F64, NDArray[np.intp]]:
    """Coefficients ``(a, C, S)`` per pixel (NaN where > N - 3 saturated), the estimated stack,
    and the saturation count.

    Pixels are grouped by saturation pattern (a bit mask, at most 2^N of them); every group is
    one small least-squares problem on its unsaturated rows, solved for all its pixels at once
    with a precomputed pseudo-inverse.
    """
    n = stack.shape[0]
    shape = stack.shape[1:]
    flat = stack.reshape(n, -1)
    sat = is_saturated(flat, bit_depth)
    # N <= 16 shifts: the pattern codes fit 16 bits, so the stable argsort below is numpy's
    # radix sort (linear time) and the groups' sizes one bincount.
    codes = np.zeros(flat.shape[1], dtype=np.uint16)
    for k in range(n):
        codes |= sat[k].astype(np.uint16) << np.uint16(k)
    design = _design(n)
    coef = np.full((3, flat.shape[1]), np.nan)
    est = flat.copy()
    counts = np.bincount(codes, minlength=1)
    patterns = np.flatnonzero(counts)
    order = np.argsort(codes, kind="stable")  # pixels grouped by pattern, in pixel order
    starts = np.concatenate([[0], np.cumsum(counts[patterns])])
    for g, code in enumerate(patterns.tolist()):
        idx = order[starts[g] : starts[g + 1]]
        bad = np.array([(code >> k) & 1 for k in range(n)], dtype=bool)
        if bad.sum() > n - 3:
            est[:, idx] = np.nan
            continue
        good = ~bad
        c = np.linalg.pinv(design[good]) @ flat[np.ix_(good, idx)]
        coef[:, idx] = c
        if bad.any():
            est[np.ix_(bad, idx)] = design[bad] @ c
    count = sat.sum(axis=0).reshape(shape)
    return coef.reshape((3, *shape)), est.reshape(stack.shape), count


def estimate_saturated_lsq(
    images: ArrayLike, bit_depth: int, *, return_stack: bool = False
) -> F64 | tuple[F64, F64]:
    """Saturated intensities by least squares on the sinusoid model (generalises Eq. 6.2).

    Thesis Sec. 6.1.1: a sinusoidal pattern with m saturated shifts needs ``3 + m`` shifts. Per
    pixel, ``a``, ``b cos(phi)``, ``b sin(phi)`` of ``I_k = a + b cos(phi + 2*pi*k/N)`` are fitted
    to the unsaturated samples (exact with three, least squares with more), and the saturated
    samples are predicted from the fit. For N = 4 and one saturated shift the three remaining
    samples determine the sinusoid exactly and the prediction is Eq. 6.2.

    Parameters
    ----------
    images : array_like, shape (N, H, W), 3 <= N <= 16
        Shift k at index k.
    bit_depth : int
        Camera bit depth B.
    return_stack : bool
        Also return the estimated stack.

    Returns
    -------
    peak : ndarray (H, W)
        Highest true intensity among the N shifts (observed samples where unsaturated, predicted
        where saturated); NaN where more than N - 3 shifts are saturated.
    stack : ndarray (N, H, W), only with ``return_stack``
        Observed samples with predictions in place of the saturated ones; NaN where not
        estimable.

    References
    ----------
    Thesis Sec. 6.1.1 (``3 + m`` shifts for ``m`` saturated ones; Eq. 6.2 for N = 4, m = 1).

    Examples
    --------
    A 5-step pixel whose true shifts are ``200 + 100 cos(0.3 + 2 pi k / 5)`` =
    (295.5, 201.4, 105.3, 140.1, 257.6): two are clipped at 255 and the three others, rounded,
    give the peak back within a fraction of a gray level.

    >>> images = np.array([255, 201, 105, 140, 255], np.uint8)[:, None, None]
    >>> peak, stack = estimate_saturated_lsq(images, 8, return_stack=True)
    >>> peak.round(1).tolist(), stack[:, 0, 0].round(1).tolist()
    ([[295.3]], [295.3, 201.0, 105.0, 140.0, 257.6])
    """
    stack = _stack(images, bit_depth, "least-squares saturated estimate")
    _, est, _ = _estimate_lsq(stack, bit_depth)
    peak = est.max(axis=0)
    return (peak, est) if return_stack else peak


def peak_and_trough(
    images: ArrayLike, bit_depth: int, pixels: ArrayLike | None = None
) -> tuple[F64, F64]:
    """:func:`estimate_saturated_lsq`'s peak and :func:`sinusoid_trough` from one fit, only at
    ``pixels``: what the DPA loop needs per capture for the pixels still pending, without
    fitting the whole image twice.

    Parameters
    ----------
    images : array_like, shape (N, H, W), 3 <= N <= 16
        Shift k at index k.
    bit_depth : int
        Camera bit depth B.
    pixels : array_like of bool, shape (H, W), optional
        Pixels to fit; default all.

    Returns
    -------
    peak : ndarray (H, W)
        As :func:`estimate_saturated_lsq`; NaN outside ``pixels``.
    trough : ndarray (H, W)
        As :func:`sinusoid_trough`; NaN outside ``pixels``.

    References
    ----------
    Thesis Sec. 6.1.1.

    Examples
    --------
    >>> images = np.array([[[255, 255]], [[150, 150]], [[30, 30]], [[150, 150]]], np.uint8)
    >>> peak, trough = peak_and_trough(images, 8, pixels=[[True, False]])
    >>> peak.tolist(), trough.tolist()
    ([[270.0, nan]], [[30.0, nan]])
    """
    full_scale(bit_depth)  # as _stack, without converting the pixels not fitted
    stack = as_stack(images, what="saturated estimate", n_min=3, n_max=_MAX_STEPS,
                     bit_depth=bit_depth)  # fmt: skip
    shape = stack.shape[1:]
    peak = np.full(shape, np.nan)
    trough = np.full(shape, np.nan)
    sel = np.ones(shape, dtype=bool) if pixels is None else np.asarray(pixels, dtype=bool)
    if sel.shape != shape:
        raise InputError(f"pixel mask shape {sel.shape} does not match the images' {shape}")
    if not sel.any():
        return peak, trough
    picked = stack[:, sel].astype(np.float64, copy=False)[:, :, None]
    coef, est, _ = _estimate_lsq(picked, bit_depth)
    a, c, s = coef[..., 0]
    peak[sel] = est[..., 0].max(axis=0)
    trough[sel] = a - np.hypot(c, s)
    return peak, trough


def saturated_peak_lower_bound(images: ArrayLike, bit_depth: int) -> F64:
    """A lower bound on the true peak of pixels too saturated to estimate (beyond the thesis).

    Where more than N - 3 shifts are saturated the sinusoid cannot be fitted, but it is still
    constrained: every saturated sample's true value is at least ``F = 2^B - 1``, the mean
    ``a`` of equally spaced shifts is the mean of all N samples and, for even N, of each pair of
    opposite shifts; so ``a >= a_lb``, the largest of those means with ``F`` in place of each
    saturated sample. Every sample is at least ``a - b``, hence ``b >= a - I_min`` over the
    unsaturated samples and the peak ``a + b >= 2 a_lb - I_min``.

    For N = 4 with three saturated shifts this is ``2F - I_u`` (the unsaturated one ``I_u``).
    The bound holds whatever the phase, amplitude and offset, up to the rounding of the
    unsaturated samples (at most 1.5 DN); noise on them moves it by about their noise.

    Parameters
    ----------
    images : array_like, shape (N, H, W), 3 <= N <= 16
        Shift k at index k.
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    ndarray (H, W)
        The bound where at least one shift is saturated and at least one is not; NaN elsewhere
        (nothing saturated, or every shift saturated: no information beyond ``F``).

    Examples
    --------
    Pixel 0 is 4-step with three shifts clipped (bound ``2F - I_u``); pixel 1 has true shifts
    (269.7, 128.3, 130.3, 271.7), two clipped, too many for :func:`estimate_saturated_lsq`:

    >>> images = np.array([[[255, 255]], [[255, 128]], [[200, 130]], [[255, 255]]], np.uint8)
    >>> saturated_peak_lower_bound(images, 8).tolist()
    [[310.0, 257.0]]
    """
    stack = _stack(images, bit_depth, "saturated peak bound")
    full = float(full_scale(bit_depth))
    n = stack.shape[0]
    sat = is_saturated(stack, bit_depth)
    lb = np.where(sat, full, stack)
    a_lb = lb.mean(axis=0)
    if n % 2 == 0:
        half = n // 2
        a_lb = np.maximum(a_lb, ((lb[:half] + lb[half:]) / 2.0).max(axis=0))
    low = np.where(sat, np.inf, stack).min(axis=0)
    bound = np.maximum(2.0 * a_lb - low, full)
    count = sat.sum(axis=0)
    bound[(count == 0) | (count == n)] = np.nan
    return bound


def fit_unsaturated_sinusoid(images: ArrayLike, bit_depth: int) -> tuple[F64, F64, F64]:
    """Sinusoid fitted to each pixel's unsaturated samples: mean ``a``, amplitude ``b``, phase.

    The phase follows the contract (``I_k = a + b cos(phi + 2*pi*k/N)``, phi in [0, 2*pi)). NaN
    where more than N - 3 shifts are saturated.

    Parameters
    ----------
    images : array_like, shape (N, H, W), 3 <= N <= 16
        Shift k at index k.
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    a, b, phi : ndarray (H, W)
        Mean, amplitude and phase (radians) of the fitted sinusoid.

    References
    ----------
    Thesis Eq. 2.1 (the model) and Sec. 6.1.1 (fitting the unsaturated shifts).

    Examples
    --------
    >>> images = np.array([255, 150, 30, 150], np.uint8)[:, None, None]
    >>> a, b, phi = fit_unsaturated_sinusoid(images, 8)
    >>> float(a[0, 0]), float(b[0, 0]), round(float(phi[0, 0]), 6)
    (150.0, 120.0, 0.0)
    """
    stack = _stack(images, bit_depth, "sinusoid fit")
    coef, _, _ = _estimate_lsq(stack, bit_depth)
    a, c, s = coef
    b = np.hypot(c, s)
    phi = np.mod(np.arctan2(-s, c), 2.0 * np.pi)
    return a, b, phi


def sinusoid_trough(images: ArrayLike, bit_depth: int) -> F64:
    """``a - b`` of the sinusoid fitted to the unsaturated samples, in DN.

    Under the linear model ``I = o + s*g`` this is the pixel's intensity at input gray ``imin``
    (the offset of the MIGL scaling in :func:`true_peak_scaled` and :func:`unsaturation_migl`).
    Blur lowers ``b`` slightly, so it reads a little high for fine pitches (about 1 % of ``b``
    at a 20 px pitch on the virtual rig). NaN where more than N - 3 shifts are saturated.

    Parameters
    ----------
    images : array_like, shape (N, H, W), 3 <= N <= 16
        Shift k at index k.
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    ndarray (H, W)
        ``a - b`` in DN.

    Examples
    --------
    >>> images = np.array([255, 150, 30, 150], np.uint8)[:, None, None]
    >>> sinusoid_trough(images, 8).tolist()
    [[30.0]]
    """
    a, b, _ = fit_unsaturated_sinusoid(images, bit_depth)
    return a - b


# --------------------------------------------------------------------------------------------
# MIGL <-> intensity: the training truth (Eq. 6.3) and its inverse
# --------------------------------------------------------------------------------------------
def _index(index_image: ArrayLike) -> F64:
    idx = np.asarray(index_image, dtype=np.float64)
    if idx.ndim != 2:
        raise InputError(f"MIGL index image must be 2-D (H, W), got shape {idx.shape}")
    return idx


def true_peak_thesis(index_image: ArrayLike, bit_depth: int, top_migl: float = 255.0) -> F64:
    """Thesis Eq. 6.3: ``I** = 2^B - 1 + (top_migl - N(x, y))``.

    The thesis writes ``2^B - 1 + (2^B - 1 - N)`` for an 8-bit camera and projector, where the
    second ``2^B - 1`` is the initial MIGL, 255. It assumes that one gray level of MIGL moves the
    peak intensity by one DN, and that the peak is exactly ``2^B - 1`` at ``N``.

    Parameters
    ----------
    index_image : array_like (H, W)
        ``N(x, y)``: the highest MIGL at which all shifts of the pixel are unsaturated (LPA with
        step 1 from ``top_migl``). Negative or non-finite values mark pixels never unsaturated;
        they give NaN.
    bit_depth : int
        Camera bit depth B.
    top_migl : float
        The initial MIGL of the LPA sweep.

    Returns
    -------
    ndarray of float64 (H, W)
        ``I**`` in DN; NaN where the pixel never unsaturated.

    References
    ----------
    Thesis Sec. 6.1.2, Eq. 6.3.

    Examples
    --------
    >>> true_peak_thesis(np.array([[250, 231, -1]]), 8).tolist()
    [[260.0, 279.0, nan]]
    """
    full = full_scale(bit_depth)
    idx = _index(index_image)
    out = full + (float(top_migl) - idx)
    out[~np.isfinite(idx) | (idx < 0)] = np.nan
    return out


def true_peak_scaled(
    images: ArrayLike,
    migl_of_images: ArrayLike,
    bit_depth: int,
    top_migl: float = 255.0,
    imin: float = 40.0,
    *,
    offset: ArrayLike | None = None,
) -> F64:
    """Physically scaled training truth: the pixel's own unsaturated peak, scaled to ``top_migl``.

    The pattern is ``g_k = imin + (migl - imin) c_k`` with ``c_k`` in [0, 1] fixed per pixel and
    shift (blur included), and the camera is linear, ``I = o + s*g``; so every shift obeys
    ``I_k(m) = A + (I_k(M) - A) (m - imin) / (M - imin)`` with ``A = o + s*imin``, the pixel's
    intensity at input gray ``imin``. From a set captured at any MIGL ``M`` where the pixel is
    unsaturated, the highest shift at the top MIGL is therefore::

        I** = A + (max_k I_k(M) - A) * (top_migl - imin) / (M - imin)

    Unlike Eq. 6.3 it does not assume one DN per gray level, nor a peak of exactly ``2^B - 1``
    at ``N(x, y)``. With ``M = N(x, y)`` (the LPA composite) it inherits a selection bias: the
    sweep stops at the first MIGL whose *noisy* reading is below full scale, so the peak read
    there is biased low by about one noise standard deviation. A set a few gray levels below
    ``N``, captured independently, has no such bias (what :func:`training_data_from_rig` keeps).

    Parameters
    ----------
    images : array_like (N, H, W)
        Each pixel's shifts captured at ``migl_of_images`` (all unsaturated there), e.g. the LPA
        composite.
    migl_of_images : array_like (H, W) or float
        The MIGL each pixel's samples were captured at, e.g. the index image ``N(x, y)``;
        negative, non-finite or ``<= imin``: NaN out.
    bit_depth : int
        Camera bit depth B.
    top_migl : float
        The MIGL the truth refers to (the initial MIGL).
    imin : float
        The pattern's minimum input gray.
    offset : array_like (H, W), optional
        ``A`` per pixel, e.g. an image captured under uniform ``imin``. Default: the trough
        ``a - b`` of the sinusoid fitted to ``images`` (:func:`sinusoid_trough`; blur makes it
        read about 1 % of ``b`` high, which biases ``I**`` by about -1 DN on the virtual rig).

    Returns
    -------
    ndarray of float64 (H, W)
        ``I**`` in DN; NaN where a sample is saturated or the MIGL is unusable.

    References
    ----------
    Thesis Sec. 6.1.2 (the role of Eq. 6.3, with its assumptions replaced as above).

    Examples
    --------
    A camera ``I = 10 + 1.2 g`` (so ``A = 58``), a pixel whose shifts at MIGL 200 see the grays
    (200, 120, 40, 120): its peak at MIGL 255 would be ``10 + 1.2 * 255 = 316``.

    >>> images = np.array([250.0, 154.0, 58.0, 154.0])[:, None, None]
    >>> true_peak_scaled(images, 200.0, 8).tolist()
    [[316.0]]
    """
    stack = _stack(images, bit_depth, "scaled true peak")
    shape = stack.shape[1:]
    mig = _image(migl_of_images, shape, "MIGL of the images")
    a0 = sinusoid_trough(stack, bit_depth) if offset is None else _image(offset, shape)
    peak = stack.max(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = a0 + (peak - a0) * (float(top_migl) - imin) / (mig - imin)
    out[~np.isfinite(mig) | (mig <= imin) | is_saturated(stack, bit_depth).any(axis=0)] = np.nan
    return out


def _image(values: ArrayLike, shape: tuple[int, ...], what: str = "offset") -> F64:
    arr = np.asarray(values, dtype=np.float64)
    try:
        return np.broadcast_to(arr, shape)
    except ValueError:
        raise InputError(
            f"{what} of shape {arr.shape} does not fit images of shape {shape}; "
            "give one value or one per pixel"
        ) from None


def unsaturation_migl(
    peak: ArrayLike,
    capture_migl: float,
    imin: float,
    bit_depth: int,
    *,
    model: TruthModel = "scaled",
    offset: ArrayLike | None = None,
) -> F64:
    """The (continuous) MIGL at which a pixel with true peak ``peak`` at ``capture_migl`` stops
    saturating: the inverse of the training truth, so the CDF uses the same model.

    * ``"thesis"``: inverse of Eq. 6.3, ``m = capture_migl - (peak - (2^B - 1))``.
    * ``"scaled"``: ``m = imin + (capture_migl - imin) (2^B - 1.5 - A) / (peak - A)`` with ``A``
      the pixel's intensity at input ``imin`` (``offset``, required; e.g.
      :func:`sinusoid_trough` of the same images). ``2^B - 1.5`` is where the rounded reading
      drops below full scale. Pixels whose ``A`` alone reaches it, or whose peak is not above
      ``A``, never unsaturate: ``-inf``.

    The integer MIGL at which the pixel is first unsaturated is ``floor(m)``. NaN in, NaN out.

    Parameters
    ----------
    peak : array_like
        True (estimated) peak intensities in DN at ``capture_migl``.
    capture_migl : float
        The MIGL the peaks refer to.
    imin : float
        The pattern's minimum input gray.
    bit_depth : int
        Camera bit depth B.
    model : {"scaled", "thesis"}
        The truth model (the one the correction polynomial was trained with).
    offset : array_like, optional
        ``A`` per pixel (broadcast to ``peak``); required by the scaled model.

    Returns
    -------
    ndarray of float64
        The continuous MIGL ``m``, shape of ``peak``; ``-inf`` where the pixel never
        unsaturates.

    Raises
    ------
    InputError
        Unknown model, or the scaled model without ``offset``.

    References
    ----------
    Thesis Sec. 6.1.3 (converting the saturated intensities to MIGL for the CDF); the
    ``"thesis"`` model inverts Eq. 6.3.

    Examples
    --------
    A peak of 270 DN at MIGL 255 under Eq. 6.3, and a pixel ``I = 10 + 1.2 g`` (peak 316, offset
    58) under the scaled model, whose peak reads 253.6 at MIGL 203 and rounds below 255:

    >>> unsaturation_migl([270.0], 255, 40, 8, model="thesis").tolist()
    [240.0]
    >>> unsaturation_migl([316.0], 255, 40, 8, offset=58.0).tolist()
    [203.75]
    """
    if model not in TRUTH_MODELS:
        raise InputError(f"unknown truth model {model!r}; use one of {', '.join(TRUTH_MODELS)}")
    full = full_scale(bit_depth)
    p = np.asarray(peak, dtype=np.float64)
    if model == "thesis":
        return float(capture_migl) - (p - full)
    if offset is None:
        raise InputError(
            "the scaled MIGL model needs each pixel's offset A (its intensity at input imin); "
            "pass offset=sinusoid_trough(images, bit_depth) or use model='thesis'"
        )
    a0 = _image(offset, p.shape)
    thr = full - 0.5
    with np.errstate(invalid="ignore", divide="ignore"):
        m = np.array(imin + (float(capture_migl) - imin) * (thr - a0) / (p - a0), dtype=float)
    never = (a0 >= thr) | (p <= a0)
    m[never & np.isfinite(p) & np.isfinite(a0)] = -np.inf
    return m


# --------------------------------------------------------------------------------------------
# Sec. 6.1.2: the error-correction polynomial
# --------------------------------------------------------------------------------------------
def _rmse(x: F64) -> float:
    return float(np.sqrt(np.mean(x * x))) if x.size else math.nan


@dataclass(frozen=True)
class CorrectionPolynomial:
    """Expected error ``eps(estimate)`` of the saturated-intensity estimate (thesis Sec. 6.1.2).

    ``apply`` subtracts it: ``corrected = estimate - eps(estimate)``. The polynomial is evaluated
    with the estimate clipped to the training ``domain`` (constant extrapolation): a polynomial
    fitted over a few tens of DN must not be extrapolated to brighter scenes.

    Parameters
    ----------
    coefficients : tuple of float
        Coefficients in the scaled variable (``numpy.polynomial.Polynomial`` convention, lowest
        degree first), mapping ``domain`` onto ``window``.
    domain, window : (float, float)
        Range of the training estimates (DN), and the range it is mapped onto.
    order : int
        Polynomial degree.
    truth : {"scaled", "thesis"}
        Which training truth it was fitted to; the CDF must convert with the same model.
    rmse_before, rmse_after : float
        RMSE of ``estimate - truth`` on the training pixels before and after correction (Eq. 6.4;
        the thesis reports 71.05 and 2.99 gray levels).
    n_samples : int
        Training pixels.
    bit_depth : int
        Camera bit depth B of the training data.
    top_migl, imin : float
        Initial MIGL and minimum input gray of the training set.
    metadata : dict
        Anything else worth keeping (rig description, pitch, seed ...), JSON-friendly.

    References
    ----------
    Thesis Sec. 6.1.2, Eq. 6.4 and Fig. 6.2.

    Examples
    --------
    ``eps`` rising from -1 DN at 255 to 3 DN at 355 (coefficients in the scaled variable):

    >>> poly = CorrectionPolynomial((1.0, 2.0), domain=(255.0, 355.0))
    >>> poly.error([255.0, 305.0, 400.0]).tolist()
    [-1.0, 1.0, 3.0]
    >>> poly.apply([305.0, np.nan]).tolist()
    [304.0, nan]
    >>> CorrectionPolynomial.from_dict(poly.to_dict()) == poly
    True
    """

    coefficients: tuple[float, ...]
    domain: tuple[float, float]
    window: tuple[float, float] = (-1.0, 1.0)
    order: int = 2
    truth: TruthModel = "scaled"
    rmse_before: float = math.nan
    rmse_after: float = math.nan
    n_samples: int = 0
    bit_depth: int = 8
    top_migl: float = 255.0
    imin: float = 40.0
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def polynomial(self) -> Polynomial:
        """The error polynomial ``eps`` as a numpy Polynomial (no clipping)."""
        return Polynomial(self.coefficients, domain=self.domain, window=self.window)

    def error(self, estimate: ArrayLike, *, outside: str = "clip") -> F64:
        """Expected error ``eps`` of an estimate.

        ``outside`` says what happens beyond the training domain: ``"clip"`` (default) evaluates
        at the nearest domain end, ``"zero"`` applies no correction there.
        """
        e = np.asarray(estimate, dtype=np.float64)
        eps = self.polynomial(np.clip(e, *self.domain))
        if outside == "zero":
            return np.where((e < self.domain[0]) | (e > self.domain[1]), 0.0, eps)
        if outside != "clip":
            raise InputError(f"outside must be 'clip' or 'zero', got {outside!r}")
        return eps

    def apply(self, estimate: ArrayLike, *, outside: str = "clip") -> F64:
        """Corrected estimate ``estimate - eps(estimate)``; NaN stays NaN (see :meth:`error`)."""
        e = np.asarray(estimate, dtype=np.float64)
        return e - self.error(e, outside=outside)

    @classmethod
    def identity(cls, bit_depth: int = 8) -> CorrectionPolynomial:
        """No correction (``eps = 0``), for strategies run without training data."""
        full = float(full_scale(bit_depth))
        return cls((0.0,), (full, 2.0 * full), order=0, bit_depth=bit_depth)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dict (what :meth:`save` writes; non-finite RMSEs become None)."""
        return {
            "format": CORRECTION_FORMAT,
            "version": _CORRECTION_VERSION,
            "coefficients": [float(c) for c in self.coefficients],
            "domain": [float(d) for d in self.domain],
            "window": [float(w) for w in self.window],
            "order": int(self.order),
            "truth": self.truth,
            "rmse_before": _json_float(self.rmse_before),
            "rmse_after": _json_float(self.rmse_after),
            "n_samples": int(self.n_samples),
            "bit_depth": int(self.bit_depth),
            "top_migl": float(self.top_migl),
            "imin": float(self.imin),
            "metadata": dict(self.metadata),
        }

    @classmethod
    def from_dict(
        cls, data: Mapping[str, Any], where: str = "correction data"
    ) -> CorrectionPolynomial:
        """The polynomial from :meth:`to_dict`'s dict, checked; ``where`` names it in errors."""
        if not isinstance(data, Mapping) or data.get("format") != CORRECTION_FORMAT:
            raise InputError(
                f"{where} is not a correction polynomial (format must be {CORRECTION_FORMAT!r}); "
                "write one with CorrectionPolynomial.save"
            )
        if data.get("version") != _CORRECTION_VERSION:
            raise InputError(
                f"{where}: unsupported correction-polynomial version {data.get('version')!r}; "
                f"this hdrfringe reads version {_CORRECTION_VERSION}"
            )
        try:
            coef = tuple(float(c) for c in data["coefficients"])
            domain = tuple(float(d) for d in data["domain"])
            window = tuple(float(w) for w in data.get("window", (-1.0, 1.0)))
            truth = data.get("truth", "scaled")
            out = cls(
                coefficients=coef,
                domain=(domain[0], domain[1]),
                window=(window[0], window[1]),
                order=int(data.get("order", len(coef) - 1)),
                truth=truth,
                rmse_before=_from_json_float(data.get("rmse_before")),
                rmse_after=_from_json_float(data.get("rmse_after")),
                n_samples=int(data.get("n_samples", 0)),
                bit_depth=int(data.get("bit_depth", 8)),
                top_migl=float(data.get("top_migl", 255.0)),
                imin=float(data.get("imin", 40.0)),
                metadata=dict(data.get("metadata", {})),
            )
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise InputError(
                f"{where}: malformed correction polynomial ({exc}); re-create it with "
                "train_correction and save"
            ) from None
        if not coef or len(domain) != 2 or not domain[0] < domain[1] or truth not in TRUTH_MODELS:
            raise InputError(
                f"{where}: correction polynomial needs coefficients, a domain [lo, hi] with "
                f"lo < hi and truth in {TRUTH_MODELS}; re-create it with train_correction"
            )
        _check_correction_values(out, where)
        return out

    def save(self, path: str | Path, *, force: bool = False) -> Path:
        """Write the polynomial as JSON; refuses to overwrite unless ``force``."""
        p = Path(path)
        if p.exists() and not force:
            raise OutputExistsError(
                f"correction polynomial {p} already exists; pass force=True to replace it"
            )
        text = strict_json.dumps(self.to_dict(), indent=2, nonfinite="error") + "\n"
        p.write_text(text, encoding="utf-8")
        return p

    @classmethod
    def load(cls, path: str | Path) -> CorrectionPolynomial:
        """Read a polynomial written by :meth:`save`."""
        p = check_regular_file(
            path, "correction polynomial", "train one with train_correction (train-correction)"
        )
        with p.open("rb") as fh:  # at most the limit, even from a file that grows meanwhile
            raw = fh.read(_MAX_CORRECTION_BYTES + 1)
        if len(raw) > _MAX_CORRECTION_BYTES:
            raise InputError(
                f"{p}: more than {_MAX_CORRECTION_BYTES} bytes, not a correction polynomial (it "
                "holds a few coefficients); give the JSON file train-correction wrote"
            )
        try:
            data = json.loads(raw.decode("utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(f"correction polynomial {p} is not valid JSON ({exc})") from None
        except (ValueError, RecursionError):  # a huge integer, arrays nested thousands deep
            raise InputError(
                f"correction polynomial {p}: a number with too many digits or arrays nested too "
                "deep; give the JSON file train-correction wrote"
            ) from None
        return cls.from_dict(data, where=str(p))


#: Largest correction-polynomial file read (one written by save takes well under 2 KB).
_MAX_CORRECTION_BYTES = 1 << 20


def _check_correction_values(poly: CorrectionPolynomial, where: str) -> None:
    """Refuse values no training gives: a NaN coefficient makes every estimate NaN (DPA then
    captures far more sets than needed, silently), an infinite domain, an impossible bit depth."""
    checks = (
        ("coefficients", poly.coefficients),
        ("domain", poly.domain),
        ("window", poly.window),
        ("top_migl", (poly.top_migl,)),
        ("imin", (poly.imin,)),
    )
    for name, values in checks:
        if not all(math.isfinite(v) for v in values):
            raise InputError(
                f"{where}: correction polynomial field '{name}' holds {list(values)}, not "
                "finite numbers; re-create it with train-correction"
            )
    if not poly.window[0] < poly.window[1]:
        raise InputError(
            f"{where}: correction polynomial field 'window' must be [lo, hi] with lo < hi, got "
            f"{list(poly.window)}; re-create it with train-correction"
        )
    try:
        check_bit_depth(poly.bit_depth, f"{where}: correction polynomial field 'bit_depth'")
    except InputError as exc:
        raise InputError(f"{exc}; re-create it with train-correction") from None
    if poly.order < 0 or poly.n_samples < 0:
        raise InputError(
            f"{where}: correction polynomial fields 'order' ({poly.order}) and 'n_samples' "
            f"({poly.n_samples}) cannot be negative; re-create it with train-correction"
        )


def _json_float(x: float) -> float | None:
    return None if not math.isfinite(x) else float(x)


def _from_json_float(x: Any) -> float:
    return math.nan if x is None else float(x)


def correction_samples(
    index_image: ArrayLike,
    images_at_top: ArrayLike,
    bit_depth: int,
    top_migl: float = 255.0,
    imin: float = 40.0,
    *,
    truth: TruthModel = "scaled",
    unsaturated_images: ArrayLike | None = None,
    unsaturated_migl: ArrayLike | None = None,
    offset: ArrayLike | None = None,
    mask: ArrayLike | None = None,
) -> tuple[F64, F64]:
    """Training (or test) pairs ``(estimate, I**)`` over the usable saturated pixels.

    Usable: saturated at ``top_migl`` and estimable there (exactly one saturated shift for
    N = 4, at most N - 3 in general), with a valid index ``imin < N(x, y) < top_migl``, inside
    ``mask``. The estimate is :func:`estimate_saturated_lsq` (Eq. 6.2 for N = 4). The truth is
    Eq. 6.3 (:func:`true_peak_thesis`) or :func:`true_peak_scaled` from ``unsaturated_images``
    captured at ``unsaturated_migl`` (default: the index image, i.e. ``unsaturated_images`` is
    the LPA composite).

    Parameters
    ----------
    index_image : array_like (H, W)
        ``N(x, y)`` from LPA with step 1 down from ``top_migl``.
    images_at_top : array_like (N, H, W)
        The set captured at ``top_migl``.
    bit_depth : int
        Camera bit depth B.
    top_migl, imin : float
        Initial MIGL and the pattern's minimum input gray.
    truth : {"scaled", "thesis"}
        Training truth (see :func:`train_correction`).
    unsaturated_images, unsaturated_migl, offset : array_like, optional
        For the scaled truth (see :func:`true_peak_scaled`).
    mask : array_like (H, W) of bool, optional
        Pixels allowed.

    Returns
    -------
    estimate, truth : ndarray of float64 (n,)
        The estimate and the truth ``I**`` of each usable pixel, in DN.

    References
    ----------
    Thesis Sec. 6.1.2, Eq. 6.2-6.4.

    Examples
    --------
    Five pixels with one clipped shift (Eq. 6.2 gives ``E``) and their LPA index ``N``:

    >>> E = np.array([260.5, 271.5, 282.5, 293.5, 304.5])
    >>> top = np.stack([np.full(5, 255.0), np.full(5, 160.0), 320 - E, np.full(5, 160.0)])
    >>> index = np.array([[250, 240, 230, 220, 210]])
    >>> est, true = correction_samples(index, top[:, None], 8, truth="thesis")
    >>> est.tolist(), true.tolist()
    ([260.5, 271.5, 282.5, 293.5, 304.5], [260.0, 270.0, 280.0, 290.0, 300.0])
    """
    if truth not in TRUTH_MODELS:
        raise InputError(f"unknown truth model {truth!r}; use one of {', '.join(TRUTH_MODELS)}")
    top = _stack(images_at_top, bit_depth, "images at the top MIGL")
    idx = _index(index_image)
    if idx.shape != top.shape[1:]:
        raise InputError(
            f"index image shape {idx.shape} does not match the images' {top.shape[1:]}"
        )
    _, est_stack, count = _estimate_lsq(top, bit_depth)
    estimate = est_stack.max(axis=0)
    if truth == "thesis":
        true = true_peak_thesis(idx, bit_depth, top_migl)
    else:
        if unsaturated_images is None:
            raise InputError(
                "the scaled truth needs unsaturated images of each pixel (e.g. the LPA composite "
                "at the index MIGL); pass unsaturated_images=... or use truth='thesis'"
            )
        at = idx if unsaturated_migl is None else unsaturated_migl
        true = true_peak_scaled(unsaturated_images, at, bit_depth, top_migl, imin, offset=offset)
    use = (count >= 1) & np.isfinite(estimate) & np.isfinite(true)
    use &= (idx > imin) & (idx < top_migl)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != idx.shape:
            raise InputError(f"mask shape {m.shape} does not match the images' {idx.shape}")
        use &= m
    return estimate[use], true[use]


def check_correction_order(order: object) -> int:
    """The degree of DPA's correction polynomial, checked: an integer 0..6 (Sec. 6.1.2).

    Front ends call it before capturing training data, so a bad degree fails at once.

    Parameters
    ----------
    order : int
        Polynomial degree.

    Returns
    -------
    int

    Raises
    ------
    InputError
        When ``order`` is not an integer in 0..6.

    Examples
    --------
    >>> check_correction_order(2)
    2
    >>> check_correction_order(-1)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: correction polynomial order must be an integer 0..6, got -1

    References
    ----------
    Thesis Sec. 6.1.2 (the error-correction polynomial, of low order).
    """
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or not 0 <= order <= 6:
        raise InputError(f"correction polynomial order must be an integer 0..6, got {order!r}")
    return int(order)


def train_correction(
    index_image: ArrayLike,
    images_at_top: ArrayLike,
    bit_depth: int,
    top_migl: float = 255.0,
    imin: float = 40.0,
    order: int = 2,
    *,
    truth: TruthModel = "scaled",
    unsaturated_images: ArrayLike | None = None,
    unsaturated_migl: ArrayLike | None = None,
    offset: ArrayLike | None = None,
    mask: ArrayLike | None = None,
    metadata: Mapping[str, Any] | None = None,
) -> CorrectionPolynomial:
    """Fit the error-correction polynomial of thesis Sec. 6.1.2 (Eq. 6.3-6.4).

    For every usable saturated pixel (see :func:`correction_samples`) the error
    ``eps = estimate - I**`` (Eq. 6.4) is computed and a polynomial of degree ``order`` is fitted
    to ``eps(estimate)`` by least squares (``numpy.polynomial.Polynomial.fit``).

    Parameters
    ----------
    index_image : array_like (H, W)
        ``N(x, y)`` from LPA with step 1 down from ``top_migl`` (negative/NaN: never unsaturated).
    images_at_top : array_like (N, H, W)
        The set captured at ``top_migl``.
    bit_depth : int
        Camera bit depth B.
    top_migl, imin : float
        Initial MIGL and the pattern's minimum input gray.
    order : int
        Polynomial degree (thesis: "low order"; default 2).
    truth : {"scaled", "thesis"}
        Training truth: :func:`true_peak_scaled` (default; needs ``unsaturated_images``) or
        Eq. 6.3 (:func:`true_peak_thesis`).
    unsaturated_images, unsaturated_migl, offset : array_like, optional
        For the scaled truth: each pixel's unsaturated set (N, H, W), the MIGL it was captured
        at (default: ``index_image``), and the pixel's intensity at input ``imin``.
    mask : array_like (H, W) of bool, optional
        Pixels allowed in the training set.
    metadata : mapping, optional
        Stored with the polynomial (JSON-friendly values).

    Returns
    -------
    CorrectionPolynomial
        The fitted polynomial, with the training RMSE before and after correction.

    Raises
    ------
    InputError
        Bad order, or too few usable pixels for the order.

    References
    ----------
    Thesis Sec. 6.1.2, Eq. 6.3-6.4 and Fig. 6.2.

    Examples
    --------
    Estimates that overshoot the Eq. 6.3 truth by 10 % of its excess over 255 DN: a straight
    line removes the error.

    >>> E = np.array([260.5, 271.5, 282.5, 293.5, 304.5])
    >>> top = np.stack([np.full(5, 255.0), np.full(5, 160.0), 320 - E, np.full(5, 160.0)])
    >>> index = np.array([[250, 240, 230, 220, 210]])
    >>> poly = train_correction(index, top[:, None], 8, order=1, truth="thesis")
    >>> poly.n_samples, round(poly.rmse_before, 3), round(poly.rmse_after, 9)
    (5, 2.872, 0.0)
    >>> poly.apply([282.5]).round(9).tolist()
    [280.0]
    """
    check_correction_order(order)
    est, true = correction_samples(
        index_image,
        images_at_top,
        bit_depth,
        top_migl,
        imin,
        truth=truth,
        unsaturated_images=unsaturated_images,
        unsaturated_migl=unsaturated_migl,
        offset=offset,
        mask=mask,
    )
    if est.size < order + 2 or np.ptp(est) == 0:
        raise InputError(
            f"only {est.size} usable training pixels with distinct estimates for a degree-{order} "
            "polynomial; capture training data with a large pitch (thesis: 20 px) on a plate "
            "where the peaks saturate (e.g. 600 lx ambient or a wider aperture)"
        )
    eps = est - true
    poly = Polynomial.fit(est, eps, int(order))
    out = CorrectionPolynomial(
        coefficients=tuple(float(c) for c in poly.coef),
        domain=(float(poly.domain[0]), float(poly.domain[1])),
        window=(float(poly.window[0]), float(poly.window[1])),
        order=int(order),
        truth=truth,
        n_samples=int(est.size),
        bit_depth=int(bit_depth),
        top_migl=float(top_migl),
        imin=float(imin),
        metadata=dict(metadata or {}),
    )
    after = out.apply(est) - true
    return replace(out, rmse_before=_rmse(eps), rmse_after=_rmse(after))


# --------------------------------------------------------------------------------------------
# training data: LPA with step 1 on a rig
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TrainingData:
    """An LPA step-1 sweep: what :func:`train_correction` needs, plus simulation ground truth.

    Parameters
    ----------
    index_image : ndarray (H, W) int32
        ``N(x, y)``: highest MIGL at which all shifts are unsaturated; -1 if none in the sweep.
    images_at_top : ndarray (N, H, W)
        The set at the top MIGL (camera dtype).
    composite : ndarray (N, H, W)
        The LPA composite: each pixel's set at its index MIGL (at the lowest MIGL swept where
        the index is -1).
    reference : ndarray (N, H, W)
        Each pixel's set at ``reference_migl``, ``margin`` gray levels below its index: an
        independent capture, free of the composite's selection bias (see
        :func:`true_peak_scaled`).
    reference_migl : ndarray (H, W) int32
        MIGL of ``reference`` per pixel (-1 where not captured).
    offset : ndarray (H, W) float64 or None
        Mean of captures under uniform input ``imin`` (the pixel's ``A``), when taken.
    expected_at_top : ndarray (N, H, W) or None
        The rig's noise-free, unclipped signal at the top MIGL, when the rig can tell
        (``SimulatedRig.expected_signal``): the true saturated intensities.
    spec : FringeSpec
        The set at the top MIGL.
    bit_depth : int
        Camera bit depth B.
    sets_captured : int
        Phase-shifted sets captured by the sweep.

    References
    ----------
    Thesis Sec. 6.1.2 (the training data: LPA with a step of one gray level).

    Examples
    --------
    A sweep on a small virtual camera (see :func:`training_data_from_rig`) whose response keeps
    a residual nonlinearity ``g^1.2``: 26 pixels are usable, their estimates (DN) span 253..367,
    and the correction trained on them reduces the error:

    >>> class Rig:
    ...     camera_bit_depth = 8
    ...     def capture(self, frames):
    ...         gain = np.linspace(1.1, 1.6, 40)
    ...         light = [gain * 255 * (f.gray(np.arange(40.0)) / 255) ** 1.2 for f in frames]
    ...         return np.clip(np.rint(light), 0, 255).astype(np.uint8)[:, None, :]
    >>> data = training_data_from_rig(Rig())
    >>> est, true = data.samples()
    >>> est.size, float(est.min()), float(est.max())
    (26, 253.0, 367.0)
    >>> poly = data.train(order=2)
    >>> round(poly.rmse_before, 1), round(poly.rmse_after, 1)
    (8.7, 3.5)
    """

    index_image: NDArray[np.int32]
    images_at_top: NDArray
    composite: NDArray
    reference: NDArray
    reference_migl: NDArray[np.int32]
    offset: F64 | None
    expected_at_top: F64 | None
    spec: FringeSpec
    bit_depth: int
    sets_captured: int

    def _truth_args(self, truth: str, source: str) -> dict[str, Any]:
        if truth != "scaled":
            return {}
        if source == "reference":
            mig = self.reference_migl.astype(np.float64)
            mig[self.reference_migl < 0] = np.nan
            return {"unsaturated_images": self.reference, "unsaturated_migl": mig}
        if source == "composite":
            return {"unsaturated_images": self.composite}
        raise InputError(f"unknown truth source {source!r}; use 'reference' or 'composite'")

    def samples(
        self, *, truth: TruthModel = "scaled", source: str = "reference", **kwargs: Any
    ) -> tuple[F64, F64]:
        """:func:`correction_samples` on this sweep (``source``: which unsaturated set the
        scaled truth uses, the independent ``"reference"`` or the ``"composite"``; ``kwargs``
        go to :func:`correction_samples`)."""
        kwargs.setdefault("offset", self.offset)
        return correction_samples(
            self.index_image,
            self.images_at_top,
            self.bit_depth,
            self.spec.migl,
            self.spec.imin,
            truth=truth,
            **self._truth_args(truth, source),
            **kwargs,
        )

    def train(
        self,
        order: int = 2,
        *,
        truth: TruthModel = "scaled",
        source: str = "reference",
        **kwargs: Any,
    ) -> CorrectionPolynomial:
        """:func:`train_correction` on this sweep (see :meth:`samples` for ``source``)."""
        kwargs.setdefault("offset", self.offset)
        meta = {
            "pitch_px": float(self.spec.pitch_px),
            "steps": int(self.spec.steps),
            "truth_source": source if truth == "scaled" else "index",
            "sets_captured": int(self.sets_captured),
        }
        meta.update(kwargs.pop("metadata", None) or {})
        return train_correction(
            self.index_image,
            self.images_at_top,
            self.bit_depth,
            self.spec.migl,
            self.spec.imin,
            order,
            truth=truth,
            metadata=meta,
            **self._truth_args(truth, source),
            **kwargs,
        )


def training_data_from_rig(
    rig: _CapturingRig,
    spec: FringeSpec | None = None,
    *,
    lowest_migl: float | None = None,
    margin: int = 10,
    offset_captures: int = 4,
) -> TrainingData:
    """Capture the training sweep of thesis Sec. 6.1.2 on ``rig``: LPA with a step of 1 gray level.

    Sets are captured at MIGL ``top, top - 1, ...``; ``N(x, y)`` is the first (highest) MIGL at
    which none of the pixel's shifts is saturated. The sweep goes on ``margin`` gray levels below
    the last pixel's ``N`` so that every pixel also gets an independent unsaturated set at
    ``N - margin`` (the reference for :func:`true_peak_scaled`), and stops at ``lowest_migl``.

    Parameters
    ----------
    rig : Rig
        Anything with ``capture(frames)`` and ``camera_bit_depth`` (every
        :class:`hdrfringe.rig.base.Rig`); when it also has ``expected_signal(frames)``, the
        noise-free signal at the top MIGL is kept.
    spec : FringeSpec, optional
        Sinusoidal set at the top MIGL. Default: the thesis's training set, 4-step, 20 px pitch,
        vertical, imin 40, MIGL 255.
    lowest_migl : float, optional
        Lowest MIGL swept; default ``imin + 1``.
    margin : int
        Gray levels between ``N(x, y)`` and the reference set (0: the reference is the
        composite). Large enough that noise rarely saturates the peak again: 10 levels lower the
        peak by 7-8 DN on the default virtual rig, about four times its noise.
    offset_captures : int
        Uniform ``imin`` images averaged into ``offset`` (0: none, the scaled truth then takes
        the offset from the sinusoid fit).

    Returns
    -------
    TrainingData
        The index image, the sets at the top MIGL, the composite and the reference, the offset.

    Raises
    ------
    InputError
        A non-sinusoidal or non-integer top set, or a bad ``lowest_migl`` or ``margin``.

    References
    ----------
    Thesis Sec. 6.1.2 (training data: LPA with a constant step of one gray level, a 4-step
    sinusoidal pattern of pitch 20 px) and Sec. 5.1 (LPA, the index image ``N(x, y)``).

    Examples
    --------
    A virtual 8-bit camera looking at 40 pixels of a 4-step, 20 px set, with a gain rising from
    1.1 to 1.6 along the row and a residual nonlinearity ``g^1.2``:

    >>> class Rig:
    ...     camera_bit_depth = 8
    ...     def capture(self, frames):
    ...         gain = np.linspace(1.1, 1.6, 40)
    ...         light = [gain * 255 * (f.gray(np.arange(40.0)) / 255) ** 1.2 for f in frames]
    ...         return np.clip(np.rint(light), 0, 255).astype(np.uint8)[:, None, :]
    >>> data = training_data_from_rig(Rig())
    >>> data.sets_captured, int(data.index_image.min()), int(data.index_image.max())
    (91, 175, 250)
    >>> bool(np.all(data.reference_migl == data.index_image - 10)), data.offset.shape
    (True, (1, 40))
    """
    if spec is None:
        spec = FringeSpec("sinusoidal", 4, 20.0, "vertical", 40.0, 255.0)
    if not isinstance(spec, FringeSpec) or spec.pattern != "sinusoidal":
        raise InputError(
            "training data need a sinusoidal FringeSpec (the estimate is the sinusoid model), "
            f"got {spec!r}"
        )
    top = round(spec.migl)
    if top != spec.migl:
        raise InputError(f"the top MIGL must be an integer gray level, got {spec.migl}")
    low = math.floor(spec.imin) + 1 if lowest_migl is None else math.ceil(lowest_migl)
    if not spec.imin < low <= top:
        raise InputError(
            f"lowest MIGL {low} must be above imin {spec.imin:g} and at most the top MIGL {top}"
        )
    if isinstance(margin, bool) or int(margin) != margin or margin < 0:
        raise InputError(f"margin must be a non-negative integer of gray levels, got {margin!r}")
    bits = check_bit_depth(rig.camera_bit_depth)
    first = rig.capture(spec.frames())
    shape = first.shape[1:]
    composite = first.copy()
    reference = first.copy()
    index = np.full(shape, -1, dtype=np.int32)
    ref_migl = np.full(shape, -1, dtype=np.int32)
    sets = 0
    m = top
    images = first
    while True:
        sets += 1
        new = (index < 0) & unsaturated_mask(images, bits)
        index[new] = m
        composite[:, new] = images[:, new]
        due = (index >= 0) & (index - m == margin)
        reference[:, due] = images[:, due]
        ref_migl[due] = m
        if (not (index < 0).any() and not (ref_migl < 0).any()) or m <= low:
            break
        m -= 1
        images = rig.capture(spec.with_migl(float(m)).frames())
        composite[:, index < 0] = images[:, index < 0]
    offset = None
    if offset_captures > 0:
        uniform = rig.capture([UniformFrame(float(spec.imin))] * int(offset_captures))
        offset = uniform.astype(np.float64).mean(axis=0)
    expected = None
    if hasattr(rig, "expected_signal"):
        expected = np.asarray(rig.expected_signal(spec.frames()), dtype=np.float64)
    return TrainingData(
        index_image=index,
        images_at_top=first,
        composite=composite,
        reference=reference,
        reference_migl=ref_migl,
        offset=offset,
        expected_at_top=expected,
        spec=spec,
        bit_depth=bits,
        sets_captured=sets,
    )
