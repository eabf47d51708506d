"""Wrapped phase, intensity ratio and quality maps from one phase-shifted set.

Conventions (capture-folder contract): the decoded phase is ``phi = 2*pi*x/p (mod 2*pi)`` in
``[0, 2*pi)``, with ``x`` the projector coordinate seen by the pixel; invalid pixels are NaN.

* Sinusoidal N-step, N >= 3: thesis Eq. 2.2 (Eq. 2.4 is its N = 3 case). With the contract's
  patterns ``I_k = a + b*cos(phi + delta_k)``, ``delta_k = 2*pi*k/N`` (Eq. 2.1, 2.3, indices from
  0), ``S = sum I_k sin(delta_k) = -(N/2) b sin(phi)`` and ``C = sum I_k cos(delta_k) =
  (N/2) b cos(phi)``, so ``phi = atan2(-S, C)``.
* Sinusoidal with other known shift angles or a phase offset (capture format version 3,
  :attr:`FringeSpec.shifts_deg <hdrfringe.core.patterns.FringeSpec.shifts_deg>`): the generalised
  least-squares fit of ``I_k = a + c cos(delta_k) - s sin(delta_k)``, ``phi = atan2(s, c) -
  offset`` (:func:`sinusoidal_phase_ls`); exact for equal shifts, where it is Eq. 2.2.
* Triangular 3-step: intensity ratio of thesis Eq. 2.9, rescaled from [0, 2N) to radians.
* Triangular 2-step: intensity ratio of thesis Eq. 2.8. Two samples half a period apart determine
  only ``|P|`` and its sign, i.e. the *folded* phase ``min(phi, 2*pi - phi)``; the full phase is
  recovered by the direction of increase along the fringe axis (see :func:`triangular_2step`).

Quality maps (thesis Sec. 3.3): intensity modulation ``I'`` (Eq. 3.4, estimated as ``b``), average
intensity ``I''`` (Eq. 3.5, estimated as ``a``), data modulation ``psi = I'/I''`` (Eq. 3.6), and
the saturation count: the number of saturated shifts
(:func:`hdrfringe.core._validation.saturation_count`, re-exported here).

Each equation has one implementation: :func:`sinusoidal_phase` is the only Eq. 2.2 in hdrfringe
(sets with the contract's equal shifts and no offset always take it, so their results do not
depend on the least-squares path)
(float64 with quality maps for the product, float32 phase alone for the reproduction's sweeps),
and :func:`wrapped_phase` is the phase of any supported set, the sweeps' entry point.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from hdrfringe.core._validation import as_stack, check_min_modulation, full_scale, saturation_count
from hdrfringe.core.patterns import FringeSpec, fringe_profile
from hdrfringe.errors import InputError

__all__ = [
    "TWO_PI",
    "PhaseResult",
    "angle_difference",
    "data_modulation",
    "decode_set",
    "default_min_modulation",
    "saturation_count",
    "sinusoidal_phase",
    "sinusoidal_phase_ls",
    "triangular_2step",
    "triangular_3step",
    "wrap_phase",
    "wrapped_phase",
]

TWO_PI = 2.0 * np.pi

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class PhaseResult:
    """Everything decoded from one phase-shifted set (what :func:`decode_set` returns).

    Parameters
    ----------
    wrapped_phase : ndarray
        ``2*pi*x/p mod 2*pi`` in [0, 2*pi); NaN where ``valid`` is False.
    modulation : ndarray
        Intensity modulation I' in DN (Eq. 3.4); NaN where invalid.
    mean_intensity : ndarray
        Average intensity I'' in DN (Eq. 3.5); NaN where invalid.
    data_modulation : ndarray
        psi = I'/I'' (Eq. 3.6); NaN where invalid.
    saturation_count : ndarray of uint8
        Number of shifts at ``2^B - 1`` (every pixel, valid or not).
    valid : ndarray of bool
        Pixels whose phase is trusted (enough modulation, no rejected saturation, inside mask).
    spec : FringeSpec or None
        The set's pattern specification, when known.

    References
    ----------
    Thesis Eq. 2.2 (phase), Eq. 3.4-3.6 (quality maps), Sec. 5.1 (saturation).

    Examples
    --------
    A full-range 3-step set of pitch 6: at pixels 0, 2 and 4 one shift peaks at 255, so they
    are saturated and, by default, invalid.

    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> spec = FringeSpec("sinusoidal", 3, 6.0, imin=0, migl=255)
    >>> imgs = np.stack([fringe_gray(np.arange(6.0), spec, k) for k in range(3)])[:, None]
    >>> res = decode_set(np.rint(imgs).astype(np.uint8), spec, bit_depth=8)
    >>> res.wrapped_phase.shape, res.saturation_count.tolist()
    ((1, 6), [[1, 0, 1, 0, 1, 0]])
    >>> res.valid.tolist()
    [[False, True, False, True, False, True]]
    """

    wrapped_phase: F64
    modulation: F64
    mean_intensity: F64
    data_modulation: F64
    saturation_count: NDArray[np.uint8]
    valid: NDArray[np.bool_]
    spec: FringeSpec | None = None


def angle_difference(phase: ArrayLike, reference: ArrayLike) -> F64:
    """Difference of two phases as angles, ``phase - reference`` wrapped to (-pi, pi].

    Wrapped phases that agree as angles can differ by 2*pi as numbers: a phase a rounding
    error below 0 wraps to just under 2*pi, so ``np.allclose`` on wrapped phases depends on
    the last bit of the machine's ``arctan2``. Compare them through this difference instead.

    Parameters
    ----------
    phase, reference : array_like
        Phases in radians, any real values (broadcast against each other); NaN stays NaN.

    Returns
    -------
    ndarray of float64
        The difference in (-pi, pi].

    Examples
    --------
    >>> angle_difference([6.2832, 0.5, -np.pi], [0.0, 7.0, 0.0]).round(4).tolist()
    [0.0, -0.2168, 3.1416]
    """
    d = np.subtract(np.asarray(phase, dtype=np.float64), np.asarray(reference, dtype=np.float64))
    return np.asarray(np.pi - np.mod(np.pi - d, TWO_PI), dtype=np.float64)


def wrap_phase(phase: ArrayLike) -> F64:
    """Wrap to [0, 2*pi) exactly: ``np.mod`` alone can return 2*pi for tiny negative inputs.

    Parameters
    ----------
    phase : array_like
        Phase in radians, any real values.

    Returns
    -------
    ndarray of float64
        ``phase mod 2*pi``, in [0, 2*pi) (a result that rounds to 2*pi becomes 0).

    Examples
    --------
    >>> wrap_phase([-1e-18, 7.0, -np.pi]).round(4).tolist()
    [0.0, 0.7168, 3.1416]
    """
    out = np.mod(np.asarray(phase, dtype=np.float64), TWO_PI)
    out[out >= TWO_PI] = 0.0
    return out


def _float_dtype(dtype: DTypeLike, what: str) -> np.dtype:
    dt = np.dtype(dtype)
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise InputError(f"{what}: dtype must be float32 or float64, got {dt}")
    return dt


def sinusoidal_phase(
    images: ArrayLike, *, dtype: DTypeLike = np.float64, quality: bool = True
) -> tuple[NDArray, NDArray | None, NDArray | None]:
    """Wrapped phase of a sinusoidal N-step set (thesis Eq. 2.2; Eq. 2.4 for N = 3).

    The one implementation of Eq. 2.2 in hdrfringe: :func:`decode_set` uses its float64
    kernel with the quality maps, the reproduction's sweeps (:func:`wrapped_phase`) call it in
    float32 without them (about 2.5x faster; float32 rounding, ~1e-6 rad, is far below the
    phase noise of any capture). In float64 the stack is decoded in blocks of pixels, one fused
    pass per block on a small thread pool, without BLAS and without a float64 copy of the
    stack (:mod:`hdrfringe.core._blockdecode`); the result is bit-identical to the plain loop
    ``S += I_k sin(delta_k)``, ``C += I_k cos(delta_k)`` in float64.

    Parameters
    ----------
    images : array_like, shape (N, H, W) or (N, ..., H, W)
        Shift k at index k, ``delta_k = 2*pi*k/N``, N >= 3. Extra axes after the first make a
        batch of sets with the same N (e.g. ``(N, n_sets, H, W)``), decoded in one call; every
        returned map then has the shape ``images.shape[1:]``.
    dtype : {float64, float32}
        Precision of the computation and of the returned maps.
    quality : bool
        Also compute the modulation and mean maps (else they are returned as None).

    Returns
    -------
    phase : ndarray
        ``atan2(-S, C)`` wrapped to [0, 2*pi) (zero is +0.0).
    modulation : ndarray or None
        ``I' = (2/N) * sqrt(S^2 + C^2)`` in the images' units (Eq. 3.4).
    mean_intensity : ndarray or None
        ``I'' = mean_k I_k`` (Eq. 3.5).

    Examples
    --------
    >>> x = np.linspace(0, 20, 7)
    >>> imgs = np.stack([100 + 50*np.cos(2*np.pi*x/8 + 2*np.pi*k/4) for k in range(4)])[:, None]
    >>> phi, b, a = sinusoidal_phase(imgs)
    >>> bool(np.abs(angle_difference(phi[0], 2*np.pi*x/8)).max() < 1e-9)
    True
    >>> fast, _, _ = sinusoidal_phase(imgs, dtype=np.float32, quality=False)
    >>> fast.dtype, bool(np.abs(angle_difference(fast, phi)).max() < 1e-5)
    (dtype('float32'), True)
    >>> batch, _, _ = sinusoidal_phase(np.stack([imgs, imgs[..., ::-1]], axis=1))
    >>> batch.shape, bool(np.abs(angle_difference(batch, [phi, phi[..., ::-1]])).max() < 1e-9)
    ((2, 1, 7), True)

    References
    ----------
    Thesis Eq. 2.2 (phase), Eq. 3.4 and 3.5 (quality maps).
    """
    arr = np.asarray(images)
    shape = arr.shape[1:]
    if arr.ndim > 3:  # a batch of sets: checked as one (N, rows, W) stack
        arr = arr.reshape(arr.shape[0], -1, arr.shape[-1])
    stack = as_stack(arr, what="sinusoidal phase", n_min=3)
    dt = _float_dtype(dtype, "sinusoidal phase")
    n = stack.shape[0]
    if dt == np.float64:  # fused pixel blocks, both cores, no BLAS (hdrfringe.core._blockdecode)
        from hdrfringe.core._blockdecode import decode_sinusoidal_blocks

        maps = decode_sinusoidal_blocks(stack.reshape(n, -1), quality=quality)
        if not quality:
            return maps.phase.reshape(shape), None, None
        assert maps.modulation is not None and maps.mean is not None
        return maps.phase.reshape(shape), maps.modulation.reshape(shape), maps.mean.reshape(shape)
    # float32 (the reproduction's sweeps): unchanged, so that their reproduced numbers stay
    # those of the reference (research/tests/test_quick_grid_identity.py).
    delta = TWO_PI * np.arange(n) / n
    flat = stack.reshape(n, -1).astype(dt, copy=False)
    s = np.sin(delta).astype(dt, copy=False) @ flat
    c = np.cos(delta).astype(dt, copy=False) @ flat
    modulation = mean = None
    # In place, few temporaries (benchmarks/README.md): sqrt(S^2 + C^2) instead of np.hypot
    # (same value within an ulp, 5x faster), and [0, 2*pi) wrapping of atan2's (-pi, pi] by
    # adding 2*pi where <= 0 instead of np.mod: bit-identical to wrap_phase, zero is +0.0.
    if quality:
        modulation = np.multiply(s, s)
        modulation += c * c
        np.sqrt(modulation, out=modulation)
        modulation *= 2.0 / n
        modulation = modulation.reshape(shape)
        mean = flat.mean(axis=0).reshape(shape)
    phase = np.arctan2(np.negative(s, out=s), c, out=s)
    two_pi = dt.type(TWO_PI)
    np.add(phase, two_pi, out=phase, where=phase <= 0)
    phase[phase >= two_pi] = 0
    return phase.reshape(shape), modulation, mean


def sinusoidal_phase_ls(
    images: ArrayLike,
    shifts_deg: ArrayLike,
    *,
    phase_offset_deg: float = 0.0,
    dtype: DTypeLike = np.float64,
    quality: bool = True,
) -> tuple[NDArray, NDArray | None, NDArray | None]:
    """Wrapped phase of a sinusoidal set with any known shift angles (generalised phase shifting).

    Shift k shows ``I_k = a + b cos(phi + offset + delta_k)``. Writing ``c = b cos(phi +
    offset)`` and ``s = b sin(phi + offset)`` makes every pixel a linear least-squares problem
    ``I_k = a + c cos(delta_k) - s sin(delta_k)``, solved for all pixels at once with the
    pseudo-inverse of the N x 3 design matrix; then ``phi = atan2(s, c) - offset`` wrapped to
    [0, 2*pi), the modulation is ``hypot(c, s)`` and the mean ``a``. For the contract's equal
    shifts ``delta_k = 2*pi*k/N`` the normal matrix is ``diag(N, N/2, N/2)`` and this is exactly
    Eq. 2.2 (:func:`sinusoidal_phase`, which :func:`decode_set` keeps using for such sets).

    Parameters
    ----------
    images : array_like, shape (N, H, W) or (N, ..., H, W)
        Image k taken with shift ``shifts_deg[k]``; N >= 3. Extra axes make a batch, as in
        :func:`sinusoidal_phase`.
    shifts_deg : array_like, shape (N,)
        The shift angles ``delta_k`` in degrees, any order and sign; at least 3 distinct
        (modulo 360), else the fit is degenerate and refused.
    phase_offset_deg : float
        A constant phase of every frame, in degrees (a sine profile: -90); removed from the
        result.
    dtype : {float64, float32}
        Precision of the computation and of the returned maps (the pseudo-inverse is formed
        in float64 either way).
    quality : bool
        Also return the modulation and mean maps (else None).

    Returns
    -------
    phase : ndarray
        ``2*pi*x/p`` wrapped to [0, 2*pi).
    modulation : ndarray or None
        ``b = hypot(c, s)`` (Eq. 3.4's I').
    mean_intensity : ndarray or None
        ``a`` (Eq. 3.5's I'').

    Raises
    ------
    InputError
        Fewer than 3 images, a shift count that is not N, non-finite angles, or angles whose
        design matrix has rank < 3 (fewer than 3 distinct angles modulo 360).

    References
    ----------
    Thesis Eq. 2.1-2.2 (the model and its equal-shift solution), Eq. 3.4-3.5 (quality maps);
    the least-squares form is the standard generalised phase-shifting algorithm (e.g. Greivenkamp,
    Opt. Eng. 23 (1984) 350).

    Examples
    --------
    Four unequal shifts and a sine profile (offset -90 degrees):

    >>> x = np.linspace(0, 20, 7)
    >>> shifts = [0.0, 90.0, 200.0, 300.0]
    >>> imgs = np.stack([100 + 50*np.cos(2*np.pi*x/8 + np.radians(d - 90)) for d in shifts])
    >>> phi, b, a = sinusoidal_phase_ls(imgs[:, None], shifts, phase_offset_deg=-90)
    >>> bool(np.abs(angle_difference(phi[0], 2*np.pi*x/8)).max() < 1e-9), float(b.mean().round(9))
    (True, 50.0)
    >>> sinusoidal_phase_ls(imgs[:3, None], [0, 360, 720])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: shift angles (0, 360, 720) degrees are degenerate: ...
    """
    arr = np.asarray(images)
    shape = arr.shape[1:]
    if arr.ndim > 3:
        arr = arr.reshape(arr.shape[0], -1, arr.shape[-1])
    stack = as_stack(arr, what="sinusoidal phase", n_min=3)
    dt = _float_dtype(dtype, "sinusoidal phase")
    n = stack.shape[0]
    design = _ls_design(shifts_deg, n)
    offset = float(phase_offset_deg)
    if not np.isfinite(offset):
        raise InputError(f"phase_offset_deg must be finite, got {phase_offset_deg}")
    solve = np.linalg.pinv(design).astype(dt)  # (3, N): rows give a, c, s
    flat = stack.reshape(n, -1).astype(dt, copy=False)
    a, c, s = solve @ flat
    phase = np.arctan2(s, c)
    two_pi = dt.type(TWO_PI)
    if offset != 0.0:
        phase -= dt.type(np.radians(offset))
    np.mod(phase, two_pi, out=phase)
    phase[phase >= two_pi] = 0
    phase += 0.0  # -0.0 -> +0.0
    modulation = mean = None
    if quality:
        modulation = np.hypot(c, s).reshape(shape)
        mean = a.reshape(shape)
    return phase.reshape(shape), modulation, mean


def _ls_design(shifts_deg: ArrayLike, n: int) -> F64:
    """The N x 3 design matrix ``[1, cos(delta_k), -sin(delta_k)]``, refused when degenerate."""
    deg = np.asarray(shifts_deg, dtype=np.float64).ravel()
    text = "(" + ", ".join(f"{v:g}" for v in deg) + ")"
    if deg.size != n:
        raise InputError(f"{deg.size} shift angles {text} for {n} images; give one per image")
    if not np.isfinite(deg).all():
        raise InputError(f"shift angles {text} must be finite degrees")
    delta = np.radians(deg)
    design = np.column_stack([np.ones(n), np.cos(delta), -np.sin(delta)])
    rank = int(np.linalg.matrix_rank(design))
    if rank < 3:
        raise InputError(
            f"shift angles {text} degrees are degenerate: the least-squares design matrix has "
            f"rank {rank} < 3 (fewer than 3 distinct angles modulo 360); use at least 3 "
            "distinct shifts"
        )
    return design


@cache
def _tri3_region_table() -> tuple[NDArray[np.int8], NDArray[np.bool_]]:
    """Region index and ratio direction for each ordering of three triangular samples.

    The six regions of one period (length 1/6 each) are told apart by which shift is highest
    and which lowest. The table is built from the pattern convention itself, by sampling the
    middle of each region, so it cannot drift from :func:`hdrfringe.core.patterns.fringe_profile`.
    Returns arrays indexed by ``3*argmax + argmin``.
    """
    region = np.full(9, -1, dtype=np.int8)
    rising = np.zeros(9, dtype=bool)
    for k in range(6):
        t = (k + 0.5) / 6.0
        f = fringe_profile(t + np.arange(3) / 3.0, "triangular")
        code = 3 * int(np.argmax(f)) + int(np.argmin(f))
        region[code] = k
        # direction of the Eq. 2.9 ratio r0 = (high - med)/(high - low) inside region k
        t0 = (k + 0.25) / 6.0
        f0 = np.sort(fringe_profile(t0 + np.arange(3) / 3.0, "triangular"))
        f1 = np.sort(fringe_profile(t0 + 0.01 + np.arange(3) / 3.0, "triangular"))
        r_a = (f0[2] - f0[1]) / (f0[2] - f0[0])
        r_b = (f1[2] - f1[1]) / (f1[2] - f1[0])
        rising[code] = r_b > r_a
    return region, rising


def triangular_3step(
    images: ArrayLike, *, quality: bool = True
) -> tuple[F64, F64 | None, F64 | None]:
    """Intensity ratio of a triangular 3-step set (thesis Eq. 2.9), in radians.

    Eq. 2.9 gives ``r0 = (I_high - I_med + I_low - I_min) / I_m`` per region. For the triangular
    wave of three shifts a third of a period apart, ``I_high - I_low = (2/3) I_m`` in every
    region, and the numerator equals ``I_high - I_med`` scaled likewise, so Eq. 2.9 reduces to
    ``r0 = (I_high - I_med) / (I_high - I_low)``: it needs neither ``I_min`` nor ``I_m`` from a
    separate capture, and is insensitive to ambient light and reflectivity. The region (one of
    2N = 6 per period) follows from which shift is highest and which lowest; the unwrapped ratio
    ``r = region + r0`` (or ``region + 1 - r0`` on falling regions) runs over [0, 6) and is
    rescaled to ``phi = 2*pi*r/6``.

    Parameters
    ----------
    images : array_like, shape (3, H, W)
        Shift k at index k (a third of a period each).
    quality : bool
        Also compute the modulation and mean maps (else they are returned as None; the mean
        is the costly part).

    Returns
    -------
    phase : ndarray
        In [0, 2*pi).
    modulation : ndarray or None
        ``I_m / 2 = 0.75 * (I_high - I_low)`` (the triangular counterpart of b, Eq. 2.6).
    mean_intensity : ndarray or None
        ``I_min + I_m / 2``, the wave's mid level, from the fitted wave.

    Examples
    --------
    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> spec = FringeSpec("triangular", 3, 12.0)
    >>> x = np.linspace(0.5, 11.5, 12)
    >>> imgs = np.stack([fringe_gray(x, spec, k) for k in range(3)])[:, None]
    >>> phi, _, _ = triangular_3step(imgs, quality=False)
    >>> bool(np.abs(angle_difference(phi[0], 2*np.pi*x/12)).max() < 1e-9)
    True

    References
    ----------
    Thesis Eq. 2.9 (intensity ratio), Eq. 2.6 (triangular pattern).
    """
    stack = as_stack(images, what="triangular 3-step", n_min=3)
    if stack.shape[0] != 3:
        raise InputError(f"triangular 3-step decoding needs exactly 3 images, got {stack.shape[0]}")
    f = stack.astype(np.float64, copy=False)
    a, b, c = f[0], f[1], f[2]
    # Order statistics of three values by elementwise min/max, and the index of the first
    # highest / lowest shift (np.argmax/argmin's tie rule), without a strided sort along axis 0;
    # bit-identical to np.sort/argmax/argmin (tests/test_phase.py).
    ab_lo, ab_hi = np.minimum(a, b), np.maximum(a, b)
    low, high = np.minimum(ab_lo, c), np.maximum(ab_hi, c)
    med = np.maximum(ab_lo, np.minimum(ab_hi, c))
    hi_idx = np.where((a >= b) & (a >= c), 0, np.where(b >= c, 1, 2))
    lo_idx = np.where((a <= b) & (a <= c), 0, np.where(b <= c, 1, 2))
    span = high - low
    with np.errstate(invalid="ignore", divide="ignore"):
        r0 = (high - med) / span
    region_tab, rising_tab = _tri3_region_table()
    code = 3 * hi_idx + lo_idx
    region = region_tab[code].astype(np.float64)
    rising = rising_tab[code]
    ratio = region + np.where(rising, r0, 1.0 - r0)
    ratio[code == 3 * lo_idx + lo_idx] = np.nan  # flat pixel: all three equal
    phase = wrap_phase(TWO_PI * ratio / 6.0)
    if not quality:
        return phase, None, None
    modulation = 0.75 * span
    mean = _wave_mid_level(f, phase, modulation, "triangular")
    return phase, modulation, mean


def triangular_2step(
    images: ArrayLike,
    *,
    orientation: str = "vertical",
    direction: int = 1,
    envelope_px: int | None = None,
) -> tuple[F64, F64, F64, F64]:
    """Intensity ratio of a triangular 2-step set (thesis Eq. 2.8), and the phase it implies.

    With shifts half a period apart, ``I_1 - I_2 = I_m * P(t)`` and ``I_1 + I_2 = 2*I_min + I_m``:
    two images cannot tell ``t`` from ``-t``. Eq. 2.8, ``r0 = |I_1 - I_2| / I_m``, with the sign
    of ``I_1 - I_2`` gives ``P(t)`` and hence the **folded phase**
    ``theta = pi * (1 - P) / 2 = min(phi, 2*pi - phi)`` in [0, pi] (four ratio regions per
    period, the thesis's wrap of 2N = 4). ``I_m`` is not observable per pixel from two images;
    it is estimated as the local maximum of ``|I_1 - I_2|`` along the fringe axis over
    ``envelope_px`` camera pixels (about one fringe period; estimated from the zero crossings
    when not given), which assumes the modulation varies slowly.

    The full phase follows from the direction in which the projector coordinate grows along the
    camera's fringe axis: where ``theta`` increases in that direction ``phi = theta``, where it
    decreases ``phi = 2*pi - theta``. The two branches meet at 0 and pi, so the choice only
    matters away from the turning points, where the slope is well defined.

    Parameters
    ----------
    images : array_like, shape (2, H, W)
        Shift 0 and shift 1 (half a period apart).
    orientation : {"vertical", "horizontal"}
        Fringe orientation: "vertical" means the phase grows along camera rows (axis 1).
    direction : {1, -1}
        +1 when the projector coordinate increases with the camera column (row for horizontal).
    envelope_px : int, optional
        Window for the ``I_m`` envelope, in camera pixels.

    Returns
    -------
    phase : ndarray
        Unfolded phase in [0, 2*pi) (contract convention).
    folded : ndarray
        Folded phase in [0, pi] (what Eq. 2.8 alone determines).
    modulation : ndarray
        ``I_m / 2``.
    mean_intensity : ndarray
        ``(I_1 + I_2) / 2``, which equals ``I_min + I_m/2`` exactly for this pattern.

    References
    ----------
    Thesis Eq. 2.8 (intensity ratio), Eq. 2.6 (``I_m``), Sec. 2.3.

    Examples
    --------
    Two rows of a pitch-16 set: the unfolded phase gives back the projector coordinate.

    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> spec = FringeSpec("triangular", 2, 16.0, imin=0, migl=200)
    >>> x = np.arange(32.0)
    >>> imgs = np.stack([fringe_gray(x, spec, k) for k in range(2)])[:, None]
    >>> phi, folded, b, a = triangular_2step(imgs, envelope_px=16)
    >>> bool(np.abs(angle_difference(phi[0], 2*np.pi*x/16)).max() < 1e-9), float(folded.max())
    (True, 3.14159)
    >>> float(b[0, 0]), float(a[0, 0])
    (100.0, 100.0)
    """
    stack = as_stack(images, what="triangular 2-step", n_min=2)
    if stack.shape[0] != 2:
        raise InputError(f"triangular 2-step decoding needs exactly 2 images, got {stack.shape[0]}")
    if direction not in (1, -1):
        raise InputError(f"direction must be +1 or -1, got {direction}")
    axis = 1 if orientation == "vertical" else 0
    f = stack.astype(np.float64, copy=False)
    diff = f[0] - f[1]
    if envelope_px is None:
        envelope_px = _period_from_zero_crossings(diff, axis)
    envelope_px = max(3, int(envelope_px))
    from scipy import ndimage  # only this estimate needs it (cold start, docs/architecture.md)

    amp = ndimage.maximum_filter1d(np.abs(diff), size=envelope_px, axis=axis, mode="nearest")
    amp = ndimage.uniform_filter1d(amp, size=envelope_px, axis=axis, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        p = np.clip(diff / amp, -1.0, 1.0)
    folded = np.pi * (1.0 - p) / 2.0
    slope = direction * np.gradient(ndimage.uniform_filter1d(folded, 3, axis=axis), axis=axis)
    phase = wrap_phase(np.where(slope >= 0, folded, TWO_PI - folded))
    return phase, folded, amp / 2.0, f.mean(axis=0)


def _period_from_zero_crossings(diff: F64, axis: int) -> int:
    """Mean fringe period in camera pixels from sign changes of ``I_1 - I_2`` along ``axis``."""
    sign = np.signbit(diff)
    changes = np.count_nonzero(np.diff(sign, axis=axis))
    length = diff.shape[axis] * diff.shape[1 - axis]
    if changes == 0:
        return diff.shape[axis]
    return int(np.ceil(2.0 * length / changes))


def _wave_mid_level(f: F64, phase: F64, modulation: F64, pattern: str) -> F64:
    """Mid level of the captured wave: ``mean_k (I_k - b * P(t + k/N))`` with ``t = phi/2pi``."""
    n = f.shape[0]
    t = phase / TWO_PI
    acc = np.zeros_like(phase)
    for k in range(n):
        acc += f[k] - modulation * fringe_profile(t + k / n, pattern)
    return acc / n


def data_modulation(modulation: ArrayLike, mean_intensity: ArrayLike) -> F64:
    """Data modulation ``psi = I' / I''`` (thesis Eq. 3.6); NaN where ``I'' <= 0``.

    Parameters
    ----------
    modulation : array_like
        Intensity modulation I' (Eq. 3.4).
    mean_intensity : array_like
        Average intensity I'' (Eq. 3.5), broadcastable with ``modulation``.

    Returns
    -------
    ndarray of float64
        ``psi``, shape of the broadcast inputs.

    References
    ----------
    Thesis Sec. 3.3, Eq. 3.6.

    Examples
    --------
    >>> data_modulation([50.0, 20.0, 5.0], [100.0, 0.0, 10.0]).tolist()
    [0.5, nan, 0.5]
    """
    b = np.asarray(modulation, dtype=np.float64)
    a = np.asarray(mean_intensity, dtype=np.float64)
    out = np.full(np.broadcast_shapes(a.shape, b.shape), np.nan)
    return np.divide(b, a, out=out, where=a > 0)  # one allocation instead of three


def default_min_modulation(bit_depth: int) -> float:
    """Default validity threshold on I': 2 DN at 8 bits, scaled with the sensor's full scale.

    With Gaussian read noise sigma, the phase noise of N-step decoding is about
    ``sqrt(2/N) * sigma / I'``; at ``I' = 2`` DN and sigma = 1 DN that is 0.4-0.6 rad, the point
    below which the phase carries little more than noise.

    Parameters
    ----------
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    float
        ``2 * (2^B - 1) / 255`` DN.

    Examples
    --------
    >>> default_min_modulation(8), round(default_min_modulation(12), 2)
    (2.0, 32.12)
    """
    return 2.0 * full_scale(bit_depth) / 255.0


def _check_steps(stack: NDArray, spec: FringeSpec) -> None:
    if not isinstance(spec, FringeSpec):
        raise InputError(
            f"spec must be a FringeSpec (the set's pattern, steps and pitch), got "
            f"{type(spec).__name__} {spec!r}; e.g. FringeSpec('sinusoidal', {stack.shape[0]}, 8.0)"
        )
    n = stack.shape[0]
    if n != spec.steps:
        raise InputError(
            f"the {spec.pattern} {spec.steps}-step set has {n} images; "
            f"give exactly {spec.steps}, shift 0 first"
        )


def _decode(
    stack: NDArray, spec: FringeSpec, dtype: DTypeLike, quality: bool, direction: int
) -> tuple[NDArray, NDArray | None, NDArray | None]:
    """Phase and (with ``quality``) modulation and mean of a checked stack: the decoder that
    ``spec``'s pattern and steps choose."""
    if spec.pattern == "sinusoidal":
        if spec.has_standard_phase:  # the contract's shifts: Eq. 2.2, as always
            return sinusoidal_phase(stack, dtype=dtype, quality=quality)
        if spec.shifts_deg is None:
            # The contract's angles with an offset (e.g. a sine profile): Eq. 2.2, then the
            # offset removed. The same phase as the least-squares fit, and the same modulation
            # and mean bit for bit as a standard set, so validity at the modulation threshold
            # does not depend on how the profile was declared.
            phase, modulation, mean = sinusoidal_phase(stack, dtype=dtype, quality=quality)
            shifted = wrap_phase(phase.astype(np.float64) - np.radians(spec.phase_offset_deg))
            return shifted.astype(phase.dtype, copy=False), modulation, mean
        shifts = np.degrees(spec.shifts) if spec.shifts_deg is None else spec.shifts_deg
        return sinusoidal_phase_ls(
            stack,
            shifts,
            phase_offset_deg=spec.phase_offset_deg,
            dtype=dtype,
            quality=quality,
        )
    if spec.steps not in (2, 3):
        raise InputError(
            f"triangular {spec.steps}-step decoding is not supported; use 2 or 3 steps "
            "(thesis Eq. 2.8 and 2.9) or a sinusoidal set"
        )
    if _float_dtype(dtype, "triangular decoding") != np.float64:
        raise InputError(
            f"triangular decoding runs in float64 only, got dtype {np.dtype(dtype)}; "
            "leave dtype at float64 for triangular sets"
        )
    if spec.steps == 3:
        return triangular_3step(stack, quality=quality)
    phase, _, modulation, mean = triangular_2step(
        stack, orientation=spec.orientation, direction=direction
    )
    return phase, modulation, mean


def wrapped_phase(
    images: ArrayLike, spec: FringeSpec, *, dtype: DTypeLike = np.float64, direction: int = 1
) -> NDArray:
    """Wrapped phase in [0, 2*pi) of one set, every pixel kept (saturated and dark ones too).

    The phase of :func:`decode_set` without its quality maps and validity: what the
    reproduction's sweeps need, millions of times. Sinusoidal sets use :func:`sinusoidal_phase`
    (Eq. 2.2) in ``dtype``, or :func:`sinusoidal_phase_ls` when the spec declares shift angles
    or a phase offset; triangular sets :func:`triangular_3step` (Eq. 2.9) or
    :func:`triangular_2step` (Eq. 2.8), which compute in float64 only.

    Parameters
    ----------
    images : array_like, shape (N, H, W)
        Shift k at index k.
    spec : FringeSpec
        What was projected (pattern and steps choose the algorithm).
    dtype : {float64, float32}
        Precision of the sinusoidal decoding (float32: the sweeps); triangular sets refuse
        anything but float64.
    direction : {1, -1}
        For triangular 2-step only, see :func:`triangular_2step`.

    Returns
    -------
    ndarray, shape (H, W)
        The wrapped phase, in ``dtype``.

    Examples
    --------
    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> spec = FringeSpec("sinusoidal", 3, 8.0)
    >>> x = np.arange(16.0)
    >>> imgs = np.stack([100 + 50 * fringe_gray(x, spec, k) for k in range(3)])[:, None]
    >>> phi = wrapped_phase(imgs, spec, dtype=np.float32)
    >>> phi.dtype, bool(np.abs(angle_difference(phi[0], 2*np.pi*x/8)).max() < 1e-5)
    (dtype('float32'), True)

    References
    ----------
    Thesis Eq. 2.2 (sinusoidal), Eq. 2.8 and 2.9 (triangular intensity ratios).
    """
    stack = as_stack(images, what="wrapped phase", n_min=2)
    _check_steps(stack, spec)
    return _decode(stack, spec, dtype, False, direction)[0]


def decode_set(
    images: ArrayLike,
    spec: FringeSpec,
    bit_depth: int,
    *,
    mask: ArrayLike | None = None,
    min_modulation: float | None = None,
    reject_saturated: bool = True,
    direction: int = 1,
    dtype: DTypeLike = np.float64,
) -> PhaseResult:
    """Decode one phase-shifted set into phase and quality maps.

    Parameters
    ----------
    images : array_like, shape (N, H, W)
        Captured images, shift k at index k.
    spec : FringeSpec
        What was projected (pattern and steps choose the algorithm; shift angles or a phase
        offset choose the least-squares fit, :func:`sinusoidal_phase_ls`).
    bit_depth : int
        Camera bit depth B; values above ``2^B - 1`` are an error.
    mask : array_like of bool, optional
        Pixels to decode (True); others are invalid.
    min_modulation : float, optional
        Minimum I' in DN for a valid pixel (default :func:`default_min_modulation`).
    reject_saturated : bool
        When True (default) a pixel with any saturated shift is invalid: its phase is biased
        (thesis Ch. 3). When False its phase is kept, so that saturation error can be measured.
    direction : {1, -1}
        For triangular 2-step only, see :func:`triangular_2step`.
    dtype : {float64, float32}
        Storage of the four float maps (phase, modulation, mean, data modulation). Decoding
        and validity are computed in float64 either way; float32 maps are the float64 ones
        rounded to nearest, bit for bit (``astype(np.float32)``, what the result TIFFs store),
        so the phase is within half a float32 ulp, 2.4e-7 rad, of the float64 phase, and the
        validity and saturation count are identical. float32 halves the outputs of a large
        set: 8-step uint8, 4.25x the input stack in float64, 2.25x in float32
        (benchmarks/bench_memory.py). Note: a float64 phase less than 6.4e-8 rad below 2*pi
        rounds to float32(2*pi).

    Returns
    -------
    PhaseResult

    Examples
    --------
    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> spec = FringeSpec("sinusoidal", 4, 8.0)
    >>> x = np.arange(16.0)
    >>> imgs = np.stack([np.rint(100 + 90 * fringe_gray(x, spec, k) / 255)
    ...                  for k in range(4)]).astype(np.uint8)[:, None]
    >>> res = decode_set(imgs, spec, 8)
    >>> bool(res.valid.all()), int(res.saturation_count.max())
    (True, 0)
    >>> small = decode_set(imgs, spec, 8, dtype=np.float32)
    >>> same = small.wrapped_phase == res.wrapped_phase.astype(np.float32)
    >>> small.wrapped_phase.dtype, bool(same.all())
    (dtype('float32'), True)

    References
    ----------
    Thesis Eq. 2.2, 2.8, 2.9 (phase), Sec. 3.3 (quality maps, saturation).
    """
    stack = as_stack(images, what="decode", n_min=2, bit_depth=bit_depth)
    _check_steps(stack, spec)
    out_dt = _float_dtype(dtype, "decode_set")
    thr = check_min_modulation(min_modulation, bit_depth)
    if thr is None:
        thr = default_min_modulation(bit_depth)
    m = None
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != stack.shape[1:]:
            raise InputError(f"mask shape {m.shape} does not match image shape {stack.shape[1:]}")
    if spec.pattern == "sinusoidal" and spec.has_standard_phase:
        return _decode_set_blocks(stack, spec, bit_depth, thr, reject_saturated, m, out_dt)
    phase, modulation, mean = _decode(stack, spec, np.float64, True, direction)
    assert modulation is not None and mean is not None
    sat = saturation_count(stack, bit_depth)
    valid = np.isfinite(phase) & (modulation >= thr)
    if reject_saturated:
        valid &= sat == 0
    if m is not None:
        valid &= m
    psi = data_modulation(modulation, mean)
    # The decoders return fresh arrays: NaN-fill them in place. Every avoided full-size
    # allocation counts (page faults on fresh memory; see benchmarks/README.md).
    invalid = ~valid
    for arr in (phase, modulation, mean, psi):
        np.copyto(arr, np.nan, where=invalid)
    if out_dt != np.float64:
        phase, modulation, mean, psi = (a.astype(out_dt) for a in (phase, modulation, mean, psi))
    return PhaseResult(
        wrapped_phase=phase,
        modulation=modulation,
        mean_intensity=mean,
        data_modulation=psi,
        saturation_count=sat,
        valid=valid,
        spec=spec,
    )


def _decode_set_blocks(
    stack: NDArray,
    spec: FringeSpec,
    bit_depth: int,
    min_modulation: float,
    reject_saturated: bool,
    mask: NDArray[np.bool_] | None,
    dtype: np.dtype = np.dtype(np.float64),
) -> PhaseResult:
    """:func:`decode_set` of a standard sinusoidal set in one fused pass per block of pixels.

    The same maps as the general path (Eq. 2.2 through :func:`sinusoidal_phase`'s float64
    kernel, then saturation count, validity, data modulation and NaN filling), computed block
    by block (:func:`hdrfringe.core._blockdecode.decode_sinusoidal_blocks`): the peak memory is the
    returned maps plus a few cache-sized blocks.
    """
    from hdrfringe.core._blockdecode import decode_sinusoidal_blocks

    n = stack.shape[0]
    shape = stack.shape[1:]
    maps = decode_sinusoidal_blocks(
        stack.reshape(n, -1),
        full=full_scale(bit_depth),
        min_modulation=min_modulation,
        reject_saturated=reject_saturated,
        mask=None if mask is None else mask.reshape(-1),
        dtype=dtype.type,
    )
    assert maps.modulation is not None and maps.mean is not None
    assert maps.data_modulation is not None and maps.saturation_count is not None
    assert maps.valid is not None
    return PhaseResult(
        wrapped_phase=maps.phase.reshape(shape),
        modulation=maps.modulation.reshape(shape),
        mean_intensity=maps.mean.reshape(shape),
        data_modulation=maps.data_modulation.reshape(shape),
        saturation_count=maps.saturation_count.reshape(shape),
        valid=maps.valid.reshape(shape),
        spec=spec,
    )
