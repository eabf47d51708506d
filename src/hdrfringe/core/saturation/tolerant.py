"""Saturation-tolerant phase: each pixel decoded from its unsaturated shifts only.

A saturated shift (the project's one rule, :func:`hdrfringe.core._validation.is_saturated`:
value ``>= 2^B - 1``) carries a clipped intensity; putting it into Eq. 2.2 biases the phase
(thesis Ch. 3). The intensities that did not clip are still exact samples of
``I_k = a + b cos(phi + offset + delta_k)`` (Eq. 2.1), so the phase follows from them alone by
the generalised least squares of :func:`hdrfringe.core.phase.sinusoidal_phase_ls` restricted to the
pixel's unsaturated rows: three unknowns ``a``, ``c = b cos``, ``s = b sin``, so at least three
unsaturated shifts at three distinct angles are needed, else the pixel is invalid.

Pixels are grouped by their pattern of unsaturated shifts (``np.unique`` over the packed mask
bits) and every group is solved with one pseudo-inverse of its ``k x 3`` design matrix: no
Python loop over pixels, and at most as many small solves as there are distinct patterns.

An *inverted set* (the same fringes with a 180 degree phase offset, Jiang et al. 2016) joins
the system as N more rows with angles ``delta_k + 180``: where a normal shift clips, the
inverted frame of the same index is dark. For odd N its angles are new (a 3-step set and its
inverse are 6 equally spaced samples); for even N they repeat the normal set's angles, so it
adds samples (noise averaging), not angles.

This is its own core module rather than more of :mod:`hdrfringe.core.phase`: it has its own result
(:class:`TolerantPhaseResult`, with the shifts-used map), its own validity rule (enough
unsaturated shifts instead of none saturated) and the noise model of a partial fit
(:func:`tolerant_noise_gain`), and phase.py's functions and results stay exactly as they were.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core._validation import (
    as_stack,
    check_min_modulation,
    full_scale,
    is_saturated,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import (
    PhaseResult,
    _ls_design,
    data_modulation,
    default_min_modulation,
    wrap_phase,
)
from hdrfringe.errors import InputError

__all__ = [
    "DECODER_NAME",
    "MAX_TOLERANT_IMAGES",
    "TolerantPhaseResult",
    "decode_set_tolerant",
    "inverted_spec",
    "tolerant_noise_gain",
    "tolerant_phase",
]

#: The decoder's name in a measurement's metrics (``metrics.decoder.name``).
DECODER_NAME = "tolerant"

F64 = NDArray[np.float64]

#: Most images one tolerant system takes (the shifts-used map is uint8).
MAX_TOLERANT_IMAGES = 255


@dataclass(frozen=True)
class TolerantPhaseResult(PhaseResult):
    """A :class:`~hdrfringe.core.phase.PhaseResult` decoded from the unsaturated shifts only.

    Parameters
    ----------
    wrapped_phase, modulation, mean_intensity, data_modulation : ndarray
        As in :class:`~hdrfringe.core.phase.PhaseResult`, from the least-squares fit of each
        pixel's unsaturated shifts; NaN where invalid.
    saturation_count : ndarray of uint8
        Saturated images per pixel (normal and inverted set together).
    valid : ndarray of bool
        At least ``min_shifts`` unsaturated shifts at 3 or more distinct angles, enough
        modulation, inside the mask.
    spec : FringeSpec or None
        The (normal) set's specification.
    shifts_used : ndarray of uint8
        Number of images the pixel's fit used (0 where too few were unsaturated to fit).
    min_shifts : int
        The least number of unsaturated shifts a pixel needed.
    inverted : bool
        Whether an inverted set joined the system.

    References
    ----------
    Thesis Eq. 2.1-2.2 (model and phase), Ch. 3 (what clipping does to the phase).

    Examples
    --------
    >>> res = decode_set_tolerant(np.full((4, 1, 2), 100, np.uint8),
    ...                           FringeSpec("sinusoidal", 4, 8.0), 8)
    >>> res.shifts_used.tolist(), res.valid.tolist()  # no fringe: fitted, modulation too low
    ([[4, 4]], [[False, False]])
    """

    shifts_used: NDArray[np.uint8] = field(kw_only=True)
    min_shifts: int = field(default=3, kw_only=True)
    inverted: bool = field(default=False, kw_only=True)


def inverted_spec(spec: FringeSpec) -> FringeSpec:
    """The inverted set of ``spec``: the same fringes with 180 degrees more phase offset.

    Parameters
    ----------
    spec : FringeSpec
        A sinusoidal set.

    Returns
    -------
    FringeSpec
        ``spec`` with ``phase_offset_deg + 180`` (wrapped to (-180, 180]).

    Raises
    ------
    InputError
        For a triangular set (only sinusoidal sets take a phase offset).

    References
    ----------
    Jiang, Xu and Zhang, Opt. Lasers Eng. 2016 (inverted fringes); thesis Eq. 2.1.

    Examples
    --------
    >>> inverted_spec(FringeSpec("sinusoidal", 3, 8.0)).phase_offset_deg
    180.0
    >>> inverted_spec(FringeSpec("sinusoidal", 3, 8.0, phase_offset_deg=-90)).label()
    's3_p8_v_i40_g255_o90'
    """
    if spec.pattern != "sinusoidal":
        raise InputError(
            f"an inverted set needs sinusoidal fringes, got {spec.pattern}; use a sinusoidal set"
        )
    off = float(spec.phase_offset_deg) + 180.0
    off = off - 360.0 * np.ceil((off - 180.0) / 360.0)
    return replace(spec, phase_offset_deg=float(off))


def _patterns(usable: NDArray[np.bool_]) -> tuple[NDArray[np.bool_], NDArray[np.intp]]:
    """Distinct columns of ``usable`` (M, P) and each pixel's index into them."""
    packed = np.packbits(usable, axis=0)  # (ceil(M/8), P)
    if packed.shape[0] <= 8:
        code = np.zeros(packed.shape[1], dtype=np.uint64)
        for row in packed:
            code <<= np.uint64(8)
            code |= row
        _, first, inverse = np.unique(code, return_index=True, return_inverse=True)
    else:
        _, first, inverse = np.unique(packed.T, axis=0, return_index=True, return_inverse=True)
    return usable[:, first].T, inverse.ravel()


def tolerant_phase(
    images: ArrayLike,
    shifts_deg: ArrayLike,
    bit_depth: int,
    *,
    phase_offset_deg: float = 0.0,
    min_shifts: int = 3,
) -> tuple[F64, F64, F64, NDArray[np.uint8]]:
    """Wrapped phase of every pixel from its unsaturated shifts (least squares, known shifts).

    Image k shows ``I_k = a + b cos(phi + offset + delta_k)``. For each pixel, the rows of
    the unsaturated images of ``[1, cos(delta_k), -sin(delta_k)] (a, c, s)^T = I_k`` are
    solved by least squares and ``phi = atan2(s, c) - offset`` wrapped to [0, 2*pi). With
    nothing saturated this is :func:`hdrfringe.core.phase.sinusoidal_phase_ls`, and for the
    contract's equal shifts Eq. 2.2 (:func:`hdrfringe.core.phase.sinusoidal_phase`), to rounding.

    Parameters
    ----------
    images : array_like, shape (M, H, W)
        Image k taken with shift ``shifts_deg[k]`` (e.g. a set and its inverted set, M = 2N).
    shifts_deg : array_like, shape (M,)
        The shift angles in degrees; repeated angles are allowed (an even-N inverted set).
    bit_depth : int
        Camera bit depth B; a value ``>= 2^B - 1`` is saturated.
    phase_offset_deg : float
        Constant phase of every frame, removed from the result.
    min_shifts : int
        Least number of unsaturated images a pixel needs (>= 3); they must also span 3
        distinct angles.

    Returns
    -------
    phase : ndarray (H, W)
        In [0, 2*pi); NaN where the pixel has too few unsaturated shifts.
    modulation : ndarray (H, W)
        ``b = hypot(c, s)`` (Eq. 3.4's I'); NaN there too.
    mean_intensity : ndarray (H, W)
        ``a`` (Eq. 3.5's I''); NaN there too.
    shifts_used : ndarray of uint8 (H, W)
        Images in the pixel's fit (0 where it was not fitted).

    Raises
    ------
    InputError
        Fewer than 3 or more than 255 images, a shift count that is not M, degenerate angles,
        ``min_shifts`` outside 3..M.

    Notes
    -----
    Noise: with independent noise sigma in every image, the fit's covariance is
    ``sigma^2 (A^T A)^-1`` for the used rows A, and the phase's standard deviation is
    ``sigma / b * sqrt(g^T (A^T A)^-1 g)``, ``g = (0, -sin, cos)(phi + offset)``
    (:func:`tolerant_noise_gain` computes the factor). With all N equal shifts it is
    ``sqrt(2/N)``; dropping the brightest shifts raises it, and by how much depends on N
    and on how many clipped: docs/tolerant.md tabulates it, measured.

    References
    ----------
    Thesis Eq. 2.1-2.2, Ch. 3; the least squares with known shifts is the generalised
    phase-shifting algorithm (Greivenkamp, Opt. Eng. 23 (1984) 350).

    Examples
    --------
    An 8-step set whose three brightest shifts clip at 255: the five others give the phase.

    >>> x = np.linspace(0.0, 8.0, 5)
    >>> delta = 2 * np.pi * np.arange(8) / 8
    >>> true = 200 + 100 * np.cos(2 * np.pi * x / 8 + delta[:, None])
    >>> imgs = np.minimum(np.rint(true), 255).astype(np.uint8)[:, None]
    >>> phi, b, a, used = tolerant_phase(imgs, np.degrees(delta), 8)
    >>> used.tolist()
    [[5, 5, 5, 5, 5]]
    >>> from hdrfringe.core.phase import angle_difference
    >>> bool(np.abs(angle_difference(phi[0], 2 * np.pi * x / 8)).max() < 0.01)
    True
    """
    stack = as_stack(images, what="tolerant phase", n_min=3, n_max=MAX_TOLERANT_IMAGES)
    m = stack.shape[0]
    design = _ls_design(shifts_deg, m)
    offset = float(phase_offset_deg)
    if not np.isfinite(offset):
        raise InputError(f"phase_offset_deg must be finite, got {phase_offset_deg}")
    if isinstance(min_shifts, bool) or not isinstance(min_shifts, int | np.integer):
        raise InputError(f"min_shifts must be an integer 3..{m}, got {min_shifts!r}")
    if not 3 <= int(min_shifts) <= m:
        raise InputError(
            f"min_shifts must be 3..{m} (3 unknowns per pixel, {m} images), got {min_shifts}"
        )
    shape = stack.shape[1:]
    flat = stack.reshape(m, -1)
    usable = ~is_saturated(flat, bit_depth)
    patterns, inverse = _patterns(usable)
    order = np.argsort(inverse, kind="stable")
    bounds = np.cumsum(np.bincount(inverse, minlength=len(patterns)))[:-1]
    abc = np.full((3, flat.shape[1]), np.nan)
    used = np.zeros(flat.shape[1], dtype=np.uint8)
    for rows, idx in zip(patterns, np.split(order, bounds), strict=True):
        k = int(rows.sum())
        if k < min_shifts:
            continue
        sub = design[rows]
        if np.linalg.matrix_rank(sub) < 3:  # fewer than 3 distinct angles left
            continue
        abc[:, idx] = np.linalg.pinv(sub) @ flat[np.ix_(rows, idx)].astype(np.float64)
        used[idx] = k
    a, c, s = abc
    phase = np.arctan2(s, c)
    if offset != 0.0:
        phase -= np.radians(offset)
    phase = wrap_phase(phase)
    phase[np.isnan(a)] = np.nan
    return (
        phase.reshape(shape),
        np.hypot(c, s).reshape(shape),
        a.reshape(shape),
        used.reshape(shape),
    )


def tolerant_noise_gain(
    shifts_deg: ArrayLike, phase: ArrayLike, used: ArrayLike | None = None
) -> F64:
    """Phase noise of a least-squares fit in units of ``sigma / b``: ``sqrt(g^T (A^T A)^-1 g)``.

    ``A`` holds the rows ``[1, cos(delta_k), -sin(delta_k)]`` of the shifts used and
    ``g = (0, -sin(phi), cos(phi))`` the phase's gradient with respect to ``(a, c, s)``; the
    phase's standard deviation is this factor times ``sigma / b`` for independent noise
    ``sigma`` per image (first order in the noise).

    Parameters
    ----------
    shifts_deg : array_like, shape (M,)
        Every shift angle of the system, degrees.
    phase : array_like
        Phase(s) ``phi + offset`` at which to evaluate, radians.
    used : array_like of bool, shape (M,), optional
        The rows used (default all).

    Returns
    -------
    ndarray
        The factor, shape of ``phase``.

    Raises
    ------
    InputError
        Degenerate angles (rank < 3) among the rows used.

    References
    ----------
    Thesis Eq. 2.2 (the equal-shift case, factor ``sqrt(2/N)``); least-squares covariance.

    Examples
    --------
    All 8 equal shifts: ``sqrt(2/8) = 0.5`` at any phase. Only the 3 darkest of 8 (the 5
    brightest clipped): 2.0x that when the peak sits on a shift, 2.45x when it sits 10
    degrees off one (docs/tolerant.md has the full table, over phases).

    >>> d = np.arange(8) * 45.0
    >>> float(tolerant_noise_gain(d, 0.3).round(6))
    0.5
    >>> for phi in (0.0, np.radians(10.0)):
    ...     c = np.cos(phi + np.radians(d))
    ...     dark = c <= np.sort(c)[2]
    ...     print(int(dark.sum()), round(float(tolerant_noise_gain(d, phi, dark) / 0.5), 2))
    3 2.0
    3 2.45
    """
    deg = np.asarray(shifts_deg, dtype=np.float64).ravel()
    rows = np.ones(deg.size, bool) if used is None else np.asarray(used, dtype=bool).ravel()
    design = _ls_design(deg[rows], int(rows.sum()))
    cov = np.linalg.inv(design.T @ design)
    p = np.asarray(phase, dtype=np.float64)
    g = np.stack([np.zeros_like(p), -np.sin(p), np.cos(p)])
    return np.sqrt(np.einsum("i...,ij,j...->...", g, cov, g))


def decode_set_tolerant(
    images: ArrayLike,
    spec: FringeSpec,
    bit_depth: int,
    *,
    inverted: ArrayLike | None = None,
    mask: ArrayLike | None = None,
    min_modulation: float | None = None,
    min_shifts: int = 3,
) -> TolerantPhaseResult:
    """Decode one sinusoidal set from its unsaturated shifts, optionally with its inverted set.

    The saturation-tolerant counterpart of :func:`hdrfringe.core.phase.decode_set`: instead of
    invalidating a pixel with a saturated shift, it drops that shift and fits the rest
    (:func:`tolerant_phase`). Valid: fitted (at least ``min_shifts`` unsaturated images at 3
    distinct angles), ``I' >= min_modulation``, inside ``mask``.

    Parameters
    ----------
    images : array_like, shape (N, H, W)
        The set, shift k at index k (any N >= 3, the spec's shift angles and offset).
    spec : FringeSpec
        A sinusoidal set.
    bit_depth : int
        Camera bit depth B.
    inverted : array_like, shape (N, H, W), optional
        The inverted set (:func:`inverted_spec`: 180 degrees more phase), shift k at index k.
    mask : array_like of bool, optional
        Pixels to decode; others are invalid.
    min_modulation : float, optional
        Least I' in DN (default :func:`hdrfringe.core.phase.default_min_modulation`).
    min_shifts : int
        Least number of unsaturated images a pixel needs (3 .. N, or 2N with ``inverted``).

    Returns
    -------
    TolerantPhaseResult

    Raises
    ------
    InputError
        A triangular set, a wrong number of images, an inverted set of another shape,
        ``min_shifts`` out of range, values above ``2^B - 1``.

    References
    ----------
    Thesis Eq. 2.2, Sec. 3.3 (quality maps), Ch. 3 (saturation).

    Examples
    --------
    A 3-step set whose brightest shift clips: invalid for Eq. 2.2, but three images are all
    the fit has. With its inverted set (six images at six angles) five remain everywhere.

    >>> from hdrfringe.core.patterns import fringe_gray
    >>> spec = FringeSpec("sinusoidal", 3, 6.0, imin=60, migl=255)
    >>> x = np.arange(6.0)
    >>> def shot(s):
    ...     sig = np.stack([1.2 * fringe_gray(x, s, k) for k in range(3)])[:, None]
    ...     return np.minimum(np.rint(sig), 255).astype(np.uint8)
    >>> plain = decode_set_tolerant(shot(spec), spec, 8)
    >>> plain.shifts_used.tolist(), plain.valid.tolist()
    ([[0, 3, 0, 3, 0, 3]], [[False, True, False, True, False, True]])
    >>> both = decode_set_tolerant(shot(spec), spec, 8, inverted=shot(inverted_spec(spec)))
    >>> both.shifts_used.tolist(), bool(both.valid.all())
    ([[5, 5, 5, 5, 5, 5]], True)
    >>> err = np.angle(np.exp(1j * (both.wrapped_phase - 2 * np.pi * x / 6)))
    >>> bool(np.abs(err).max() < 0.01)  # rounding to integers only
    True
    """
    if not isinstance(spec, FringeSpec) or spec.pattern != "sinusoidal":
        pattern = getattr(spec, "pattern", type(spec).__name__)
        raise InputError(
            f"saturation-tolerant decoding needs a sinusoidal set, got {pattern}; decode "
            "triangular sets with decode_set"
        )
    stack = as_stack(images, what="tolerant decode", n_min=3, bit_depth=bit_depth)
    if stack.shape[0] != spec.steps:
        raise InputError(
            f"the sinusoidal {spec.steps}-step set has {stack.shape[0]} images; give exactly "
            f"{spec.steps}, shift 0 first"
        )
    shifts = np.degrees(spec.shifts)
    if inverted is not None:
        inv = as_stack(inverted, what="tolerant decode (inverted set)", bit_depth=bit_depth)
        if inv.shape != stack.shape:
            raise InputError(
                f"the inverted set has shape {inv.shape}, the set {stack.shape}; give the same "
                "N images of the same size"
            )
        stack = np.concatenate([stack, inv.astype(stack.dtype, copy=False)])
        shifts = np.concatenate([shifts, shifts + 180.0])
    phase, modulation, mean, used = tolerant_phase(
        stack, shifts, bit_depth, phase_offset_deg=spec.phase_offset_deg, min_shifts=min_shifts
    )
    thr = check_min_modulation(min_modulation, bit_depth)
    if thr is None:
        thr = default_min_modulation(bit_depth)
    valid = np.isfinite(phase) & (modulation >= thr)
    if mask is not None:
        msk = np.asarray(mask, dtype=bool)
        if msk.shape != phase.shape:
            raise InputError(f"mask shape {msk.shape} does not match image shape {phase.shape}")
        valid &= msk
    psi = data_modulation(modulation, mean)
    for arr in (phase, modulation, mean, psi):
        np.copyto(arr, np.nan, where=~valid)
    sat = np.zeros(phase.shape, dtype=np.uint8)
    full = full_scale(bit_depth)
    for image in stack:
        sat += image >= full
    return TolerantPhaseResult(
        wrapped_phase=phase,
        modulation=modulation,
        mean_intensity=mean,
        data_modulation=psi,
        saturation_count=sat,
        valid=valid,
        spec=spec,
        shifts_used=used,
        min_shifts=int(min_shifts),
        inverted=inverted is not None,
    )
