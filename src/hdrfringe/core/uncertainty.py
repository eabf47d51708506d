"""Predicted per-pixel phase and height standard deviation from the camera noise (issue 15).

Every decoder of :mod:`hdrfringe.core.phase` and :mod:`hdrfringe.core.saturation.tolerant` is a
smooth function of the N intensities of a pixel, so to first order in the noise its phase varies by
``dphi = sum_k w_k dI_k`` and, for independent noise ``sigma_k`` in each image,

    ``sigma_phi^2 = sum_k w_k^2 sigma_k^2``.

The weights ``w_k`` per decoder (derivations in docs/uncertainty.md):

* **Sinusoidal, least squares** (Eq. 2.2 and its generalisation; the saturation-tolerant fit of
  a pixel's unsaturated shifts): with the design rows ``A_k = [1, cos delta_k, -sin delta_k]``
  of the shifts used and ``theta = phi + offset``, ``w_k = A_k (A^T A)^-1 g / b`` with
  ``g = (0, -sin theta, cos theta)`` and ``b`` the modulation I' (Eq. 3.4). For equal noise
  ``sigma`` this is ``sigma / b * sqrt(g^T (A^T A)^-1 g)``
  (:func:`hdrfringe.core.saturation.tolerant.tolerant_noise_gain`), which for the contract's N equal
  shifts is the textbook ``sqrt(2/N) * sigma / b`` (:func:`phase_std_sinusoidal`).
* **Triangular 3-step** (Eq. 2.9): ``phi = (2 pi / 6)(region +- r0)``,
  ``r0 = (H - M)/(H - L)`` of the highest, middle and lowest intensity, so
  ``sigma_phi = (pi/3) sqrt((M-L)^2 s_H^2 + (H-L)^2 s_M^2 + (H-M)^2 s_L^2) / (H-L)^2``; with
  equal noise and ``H - L = 4b/3``: ``(pi/4) sqrt(1 + u^2 + (1-u)^2) sigma / b``, ``u = r0``.
* **Triangular 2-step** (Eq. 2.8): ``theta = pi (1 - (I_1 - I_2)/I_m) / 2``, ``I_m = 2b``:
  ``sigma_phi = (pi/4) sqrt(s_1^2 + s_2^2) / b``. The envelope ``I_m`` (a smoothed local
  maximum) is taken as exact; its own noise adds ``(pi/2) P dI_m / I_m``, which the
  prediction leaves out: measured up to +34 % near the turning points (``|P| -> 1``) with a
  one-period envelope, within 10 % where ``|P| < 1/2`` (tests/test_uncertainty.py).

``sigma_k`` comes from a :class:`NoiseModel`, ``sigma^2 = read^2 + gain * I`` (read noise and
shot noise; ``gain = 0``: one sigma for every intensity) evaluated at the pixel's *model*
intensity ``I_k = a + b cos(theta + delta_k)`` of each shift. The model is given, read from the
capture manifest (``camera.read_noise_dn``, ``camera.gain_dn_per_e``: the virtual rig writes its
true model, ``capture`` the rig configuration's ``rig check`` noise), or estimated from the
data (:func:`estimate_noise`: the residual of the least-squares sinusoid fit of every set with
N >= 4 shifts, N - 3 degrees of freedom per pixel, pooled over the image by mean intensity).

Where the model does not hold the prediction is NaN: invalid pixels, and pixels with a
saturated shift decoded with it (``decode_set(..., reject_saturated=False)``: the clipped value
biases the phase, thesis Ch. 3). Unwrapping (temporal, spatial, Gray code, centerline) adds a
multiple of 2 pi and no noise when the fringe order is right, so the absolute phase has the
finest set's std. The height std is ``|dh/dphi| sigma_phi`` through the calibration
(:func:`height_std`): ``|K|`` for the linear model of Eq. 2.15, the model's derivative for the
non-linear ones.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core._validation import as_stack, is_saturated
from hdrfringe.core.captures import Captures
from hdrfringe.core.decode import FolderPhase
from hdrfringe.core.patterns import FringeSpec, fringe_profile
from hdrfringe.core.phase import TWO_PI, PhaseResult
from hdrfringe.core.saturation.tolerant import TolerantPhaseResult, _patterns
from hdrfringe.errors import InputError

if TYPE_CHECKING:  # the calibration module loads scipy.ndimage: only measure needs it
    from hdrfringe.core.calibration import Calibration

__all__ = [
    "NOISE_KEYS",
    "NoiseModel",
    "NoiseUnknownError",
    "Uncertainty",
    "describe_uncertainty",
    "estimate_noise",
    "fit_noise_model",
    "height_derivative",
    "height_std",
    "noise_from_manifest",
    "phase_std_least_squares",
    "phase_std_sinusoidal",
    "phase_std_triangular",
    "predict_phase_std",
    "predict_uncertainty",
    "resolve_noise",
]

F64 = NDArray[np.float64]

#: Manifest ``camera`` keys of a recorded noise model (read noise in DN, shot-noise gain in DN
#: per electron).
NOISE_KEYS = ("read_noise_dn", "gain_dn_per_e")

#: Least number of pixels :func:`fit_noise_model` pools (fewer: refused).
MIN_NOISE_PIXELS = 64
#: Most pixels per set :func:`estimate_noise` uses (an even stride over the image beyond).
MAX_NOISE_PIXELS = 1 << 15


class NoiseUnknownError(InputError):
    """No noise given or recorded, and too little in the data to estimate it from.

    ``measure`` and ``phase`` then predict nothing and say why (``metrics.json``'s
    ``uncertainty.reason``) instead of failing; every other bad input stays an error.

    References
    ----------
    docs/uncertainty.md, "Where sigma_I comes from".

    Examples
    --------
    >>> issubclass(NoiseUnknownError, InputError)
    True
    """


@dataclass(frozen=True)
class NoiseModel:
    """Camera noise per image: ``sigma_I^2 = read_dn^2 + gain_dn_per_e * I`` (DN^2).

    Parameters
    ----------
    read_dn : float
        Intensity-independent standard deviation in DN (read noise, plus quantisation when
        estimated from data).
    gain_dn_per_e : float
        Shot-noise gain in DN per electron: a signal of ``I`` DN holds ``I / gain`` electrons,
        Poisson, so its variance is ``gain * I`` DN^2 (0: no shot noise).
    source : str
        Where the numbers come from (recorded in ``metrics.json``).
    pixels : int or None
        Pixels the estimate pooled (None: not estimated).

    Raises
    ------
    InputError
        A negative or non-finite value.

    References
    ----------
    Thesis Sec. 3.1 (the camera's response, saturation); the virtual rig's readout
    (:func:`hdrfringe.rig.sensor.sensor_readout`) uses the same model.

    Examples
    --------
    >>> m = NoiseModel(1.0, 0.0125)
    >>> m.sigma(np.array([0.0, 100.0])).round(4).tolist()
    [1.0, 1.5]
    """

    read_dn: float
    gain_dn_per_e: float = 0.0
    source: str = "given"
    pixels: int | None = None

    def __post_init__(self) -> None:
        for name in ("read_dn", "gain_dn_per_e"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float | np.floating | np.integer):
                raise InputError(f"noise {name} must be a number, got {v!r}")
            if not (math.isfinite(float(v)) and float(v) >= 0):
                raise InputError(
                    f"noise {name} must be finite and >= 0, got {v}; give the camera noise "
                    "std in DN (and the shot-noise gain in DN per electron)"
                )
            object.__setattr__(self, name, float(v))

    def variance(self, intensity: ArrayLike) -> F64:
        """``read^2 + gain * max(I, 0)`` in DN^2.

        Parameters
        ----------
        intensity : array_like
            Intensity in DN.

        Returns
        -------
        ndarray
            The variance, shape of ``intensity``.
        """
        i = np.maximum(np.asarray(intensity, dtype=np.float64), 0.0)
        return self.read_dn**2 + self.gain_dn_per_e * i

    def sigma(self, intensity: ArrayLike) -> F64:
        """Standard deviation ``sqrt(variance(I))`` in DN.

        Parameters
        ----------
        intensity : array_like
            Intensity in DN.

        Returns
        -------
        ndarray
            The standard deviation, shape of ``intensity``.
        """
        return np.sqrt(self.variance(intensity))

    def to_dict(self) -> dict[str, Any]:
        """``metrics.json``'s description: model, both coefficients, source, pixels pooled.

        Returns
        -------
        dict
        """
        out: dict[str, Any] = {
            "model": "sigma_I^2 = read_noise_dn^2 + gain_dn_per_e * I",
            "read_noise_dn": self.read_dn,
            "gain_dn_per_e": self.gain_dn_per_e,
            "source": self.source,
        }
        if self.pixels is not None:
            out["pixels"] = self.pixels
        return out


def phase_std_sinusoidal(modulation: ArrayLike, sigma: ArrayLike, steps: int) -> F64:
    """The textbook N-step phase std ``sqrt(2/N) * sigma / b`` (equal shifts, equal noise).

    Parameters
    ----------
    modulation : array_like
        Intensity modulation ``b = I'`` in DN (Eq. 3.4).
    sigma : array_like
        Intensity noise std in DN, broadcastable with ``modulation``.
    steps : int
        N >= 3.

    Returns
    -------
    ndarray
        Phase std in rad (inf where ``b <= 0``, NaN where ``b`` is NaN).

    Raises
    ------
    InputError
        ``steps < 3``.

    References
    ----------
    Thesis Eq. 2.2 (the N-step phase).

    Examples
    --------
    >>> float(phase_std_sinusoidal(50.0, 1.0, 8))
    0.01
    """
    if isinstance(steps, bool) or int(steps) != steps or steps < 3:
        raise InputError(f"the sinusoidal phase std needs N >= 3 shifts, got {steps}")
    b = np.asarray(modulation, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(2.0 / steps) * np.asarray(sigma, dtype=np.float64) / b


def _design(shifts_deg: ArrayLike) -> F64:
    d = np.radians(np.asarray(shifts_deg, dtype=np.float64).ravel())
    if d.size < 3 or not np.isfinite(d).all():
        raise InputError(f"a least-squares phase needs 3 or more finite shift angles, got {d.size}")
    return np.column_stack([np.ones(d.size), np.cos(d), -np.sin(d)])


#: Pixels per block of :func:`phase_std_least_squares` (256 KiB of float64: in cache).
_STD_BLOCK = 32768


def _each_block(work: Callable[[int], None], n: int) -> None:
    """``work(i0)`` for every block start ``i0`` of ``n`` pixels, on the decode's threads
    (:func:`hdrfringe.core._blockdecode.decode_threads`; numpy releases the GIL in its loops,
    and each block writes its own slice of the result, so the bits do not depend on them)."""
    from concurrent.futures import ThreadPoolExecutor

    from hdrfringe.core._blockdecode import decode_threads

    starts = range(0, n, _STD_BLOCK)
    threads = decode_threads(len(starts))
    if threads <= 1:
        for i0 in starts:
            work(i0)
        return
    with ThreadPoolExecutor(max_workers=threads, thread_name_prefix="hdrfringe-std") as pool:
        for _ in pool.map(work, starts):  # re-raises a block's error
            pass


def phase_std_least_squares(
    shifts_deg: ArrayLike,
    phase: ArrayLike,
    modulation: ArrayLike,
    mean_intensity: ArrayLike,
    noise: NoiseModel,
    *,
    phase_offset_deg: float = 0.0,
    usable: ArrayLike | None = None,
) -> F64:
    """Phase std of a least-squares sinusoid fit (Eq. 2.2 for equal shifts), per pixel.

    ``sigma_phi^2 = sum_k w_k^2 sigma_k^2`` with ``w_k = u_k A_k M^-1 g / b``,
    ``M = sum_k u_k A_k A_k^T``, ``A_k = [1, cos delta_k, -sin delta_k]``,
    ``g = (0, -sin theta, cos theta)``, ``theta = phi + offset`` and ``sigma_k^2`` the noise
    model at the model intensity ``a + b cos(theta + delta_k)``.

    Parameters
    ----------
    shifts_deg : array_like, shape (M,)
        The shift angles of the images, degrees.
    phase : array_like, shape (H, W)
        Decoded phase ``phi`` (NaN: not predicted).
    modulation, mean_intensity : array_like, shape (H, W)
        ``b`` and ``a`` of the fit (Eq. 3.4, 3.5).
    noise : NoiseModel
        The camera noise.
    phase_offset_deg : float
        The set's phase offset (``theta = phi + offset``).
    usable : array_like of bool, shape (M, H, W), optional
        The images each pixel's fit used (the tolerant decoder's unsaturated shifts); default
        all.

    Returns
    -------
    ndarray, shape (H, W)
        Phase std in rad; NaN where the phase is NaN, ``b <= 0`` or fewer than 3 distinct
        angles were used.

    Raises
    ------
    InputError
        Fewer than 3 angles, or maps of different shapes.

    References
    ----------
    Thesis Eq. 2.1-2.2; :func:`hdrfringe.core.saturation.tolerant.tolerant_noise_gain` (the same
    covariance for equal noise).

    Examples
    --------
    Four equal shifts, read noise only: ``sqrt(2/4) * 2 / 40``.

    >>> s = phase_std_least_squares([0, 90, 180, 270], [[0.3]], [[40.0]], [[100.0]],
    ...                             NoiseModel(2.0))
    >>> round(float(s[0, 0]), 6), round(float(np.sqrt(0.5) * 2 / 40), 6)
    (0.035355, 0.035355)
    """
    A = _design(shifts_deg)
    m = A.shape[0]
    phi, b, a = np.asarray(phase), np.asarray(modulation), np.asarray(mean_intensity)
    if b.shape != phi.shape or a.shape != phi.shape:
        raise InputError(
            f"phase {phi.shape}, modulation {b.shape} and mean {a.shape} must have one shape"
        )
    offset = np.radians(float(phase_offset_deg))
    delta_cos, delta_sin = A[:, 1], -A[:, 2]
    if usable is None:  # one normal matrix for all: w_k = alpha_k cos(theta) - beta_k sin(theta)
        inv = np.linalg.inv(A.T @ A)
        alpha, beta = A @ inv[:, 2], A @ inv[:, 1]
        std = np.empty(phi.shape)
        # block by block of pixels, in float64 (every operation is per pixel, so the blocks
        # give the maps' bits): nothing of image size but the result, whatever the maps' dtype
        flat, flat_phi, flat_b, flat_a = (x.reshape(-1) for x in (std, phi, b, a))

        def one_block(i0: int) -> None:
            part = slice(i0, i0 + _STD_BLOCK)
            pb = flat_b[part].astype(np.float64)
            pa = flat_a[part].astype(np.float64)
            pphi = flat_phi[part].astype(np.float64)
            with np.errstate(invalid="ignore", divide="ignore"):  # invalid pixels: NaN below
                theta = pphi + offset
                sin_t, cos_t = np.sin(theta), np.cos(theta)
                var = np.zeros(pphi.shape)
                for k in range(m):
                    w = alpha[k] * cos_t
                    w -= beta[k] * sin_t
                    w *= w
                    level = delta_cos[k] * cos_t  # the model intensity a + b cos(theta + delta_k)
                    level -= delta_sin[k] * sin_t
                    level *= pb
                    level += pa
                    var += w * noise.variance(level)
                part_std = np.sqrt(var)
                part_std /= pb
                ok = np.isfinite(pphi) & np.isfinite(pa) & (pb > 0)
                flat[part] = np.where(ok, part_std, np.nan)

        _each_block(one_block, flat.size)
        return std
    phi = phi.astype(np.float64, copy=False)
    b = b.astype(np.float64, copy=False)
    a = a.astype(np.float64, copy=False)
    out = np.full(phi.shape, np.nan)
    ok = np.isfinite(phi) & np.isfinite(a) & (b > 0)
    u_all = np.asarray(usable, dtype=bool)
    if u_all.shape != (m, *phi.shape):
        raise InputError(f"usable mask {u_all.shape}, expected {(m, *phi.shape)}")
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return out
    theta = phi.ravel()[idx] + offset
    bb, aa = b.ravel()[idx], a.ravel()[idx]
    sin_t, cos_t = np.sin(theta), np.cos(theta)
    u = u_all.reshape(m, -1)[:, idx]
    normal = np.einsum("kp,ki,kj->pij", u.astype(np.float64), A, A)
    good = np.abs(np.linalg.det(normal)) > 1e-9 * m**3
    normal[~good] = np.eye(3)
    g = np.stack([np.zeros_like(theta), -sin_t, cos_t])  # (3, P)
    q = np.linalg.solve(normal, g.T[..., None])[..., 0].T  # M^-1 g per pixel
    q[:, ~good] = np.nan
    var = np.zeros_like(theta)
    for k in range(m):
        w = q[0] + delta_cos[k] * q[1] - delta_sin[k] * q[2]  # A_k . q
        w[~u[k]] = 0.0
        level = aa + bb * (delta_cos[k] * cos_t - delta_sin[k] * sin_t)
        var += w * w * noise.variance(level)
    out.ravel()[idx] = np.sqrt(var) / bb
    return out


def phase_std_triangular(
    phase: ArrayLike,
    modulation: ArrayLike,
    mean_intensity: ArrayLike,
    noise: NoiseModel,
    steps: int,
) -> F64:
    """Phase std of the triangular intensity-ratio decoders (Eq. 2.8 and 2.9), per pixel.

    The model intensities ``I_k = a + b P(phi/2pi + k/N)`` (``P`` the triangle profile) give
    the noise of each shift. 3-step: ``sigma_phi = (pi/3) sqrt((M-L)^2 s_H^2 + (H-L)^2 s_M^2
    + (H-M)^2 s_L^2) / (H-L)^2`` (H, M, L: highest, middle, lowest). 2-step:
    ``sigma_phi = (pi/4) sqrt(s_1^2 + s_2^2) / b``, the envelope ``I_m`` taken as exact (its
    noise adds up to about a third near the turning points, see the module's notes).

    Parameters
    ----------
    phase : array_like, shape (H, W)
        Decoded phase (NaN: not predicted).
    modulation : array_like
        ``b``: ``I_m / 2`` (what the triangular decoders return as modulation).
    mean_intensity : array_like
        ``a``: the wave's mid level.
    noise : NoiseModel
        The camera noise.
    steps : {2, 3}
        The set's shifts.

    Returns
    -------
    ndarray, shape (H, W)
        Phase std in rad; NaN where the phase is NaN or ``b <= 0``.

    Raises
    ------
    InputError
        ``steps`` other than 2 or 3.

    References
    ----------
    Thesis Eq. 2.8 (2-step), Eq. 2.9 (3-step), Eq. 2.6 (the triangle pattern).

    Examples
    --------
    Read noise 1 DN, ``b = 30``: in the middle of a region (``u = 1/2``) the 3-step std is
    ``(pi/4) sqrt(1.5) / 30``; the 2-step one is ``(pi/4) sqrt(2) / 30`` everywhere.

    >>> t = np.array([[2 * np.pi * 0.5 / 6]])
    >>> s3 = phase_std_triangular(t, [[30.0]], [[100.0]], NoiseModel(1.0), 3)
    >>> round(float(s3[0, 0]), 5), round(float(np.pi / 4 * np.sqrt(1.5) / 30), 5)
    (0.03206, 0.03206)
    >>> round(float(phase_std_triangular(t, [[30.0]], [[100.0]], NoiseModel(1.0), 2)[0, 0]), 5)
    0.03702
    """
    if steps not in (2, 3):
        raise InputError(f"triangular phase std for 2 or 3 steps, got {steps}")
    phi = np.asarray(phase, dtype=np.float64)
    b = np.asarray(modulation, dtype=np.float64)
    a = np.asarray(mean_intensity, dtype=np.float64)
    out = np.full(phi.shape, np.nan)
    ok = np.isfinite(phi) & np.isfinite(a) & (b > 0)
    t, bb, aa = phi[ok] / TWO_PI, b[ok], a[ok]
    levels = np.stack([aa + bb * fringe_profile(t + k / steps, "triangular") for k in range(steps)])
    var = noise.variance(levels)
    if steps == 2:
        out[ok] = np.pi / 4.0 * np.sqrt(var[0] + var[1]) / bb
        return out
    order = np.argsort(levels, axis=0)
    lo, mid, hi = (np.take_along_axis(levels, order[i : i + 1], 0)[0] for i in range(3))
    v_lo, v_mid, v_hi = (np.take_along_axis(var, order[i : i + 1], 0)[0] for i in range(3))
    span = hi - lo
    num = (mid - lo) ** 2 * v_hi + span**2 * v_mid + (hi - mid) ** 2 * v_lo
    out[ok] = np.pi / 3.0 * np.sqrt(num) / span**2
    return out


def predict_phase_std(
    result: PhaseResult,
    noise: NoiseModel,
    *,
    images: ArrayLike | None = None,
    bit_depth: int | None = None,
) -> F64:
    """Predicted phase std of one decoded set (the decoder its result says), NaN where invalid.

    Parameters
    ----------
    result : PhaseResult
        From :func:`hdrfringe.core.phase.decode_set` or
        :func:`hdrfringe.core.saturation.tolerant.decode_set_tolerant` (its ``spec`` set).
    noise : NoiseModel
        The camera noise.
    images : array_like, shape (M, H, W), optional
        The images decoded (a tolerant result: required, with its inverted set after the set
        when it had one): which shifts each pixel's fit used.
    bit_depth : int, optional
        Camera bit depth (required with ``images``).

    Returns
    -------
    ndarray, shape (H, W)
        Phase std in rad. NaN where the result is invalid and, for the standard decoder, where
        a saturated shift was kept (``reject_saturated=False``: the model does not hold).

    Raises
    ------
    InputError
        A result without its spec, or a tolerant result without its images.

    References
    ----------
    Thesis Eq. 2.2, 2.8, 2.9; docs/uncertainty.md.

    Examples
    --------
    >>> from hdrfringe.core.patterns import fringe_gray
    >>> from hdrfringe.core.phase import decode_set
    >>> spec = FringeSpec("sinusoidal", 4, 8.0, imin=40, migl=200)
    >>> x = np.arange(8.0)
    >>> imgs = np.stack([np.rint(fringe_gray(x, spec, k)) for k in range(4)])[:, None]
    >>> res = decode_set(imgs.astype(np.uint8), spec, 8)
    >>> std = predict_phase_std(res, NoiseModel(1.0))
    >>> bool(np.allclose(std, np.sqrt(2 / 4) / res.modulation))  # sqrt(2/N) sigma / b
    True
    """
    spec = result.spec
    if spec is None:
        raise InputError("the phase result has no spec; decode with decode_set(images, spec, ...)")
    if images is not None:
        shape = np.shape(images)
        if len(shape) != 3 or tuple(shape[1:]) != result.wrapped_phase.shape:
            raise InputError(
                f"images of shape {shape} are not the decoded set's: expected (M, "
                f"{', '.join(map(str, result.wrapped_phase.shape))}) like the result's maps; "
                "pass the images that were decoded"
            )
    tolerant = result if isinstance(result, TolerantPhaseResult) else None
    if spec.pattern == "triangular":
        std = phase_std_triangular(
            result.wrapped_phase, result.modulation, result.mean_intensity, noise, spec.steps
        )
    else:
        shifts = np.degrees(spec.shifts)
        usable = None
        if tolerant is not None:
            if images is None or bit_depth is None:
                raise InputError(
                    "a saturation-tolerant result needs its images and bit depth to know which "
                    "shifts each pixel used; pass images= and bit_depth="
                )
            stack = as_stack(images, what="phase std", n_min=3, bit_depth=bit_depth)
            if tolerant.inverted:
                shifts = np.concatenate([shifts, shifts + 180.0])
            if stack.shape[0] != shifts.size:
                raise InputError(
                    f"{stack.shape[0]} images for a tolerant fit of {shifts.size} shifts; give "
                    "the set (and its inverted set after it, when it had one)"
                )
            usable = ~is_saturated(stack, bit_depth)
        std = phase_std_least_squares(
            shifts,
            result.wrapped_phase,
            result.modulation,
            result.mean_intensity,
            noise,
            phase_offset_deg=spec.phase_offset_deg,
            usable=usable,
        )
    std[~result.valid] = np.nan
    if tolerant is None:
        std[result.saturation_count > 0] = np.nan
    return std


#: Upper chi-square quantile beyond which a variance estimate is an outlier (edges, model error).
_CUT_QUANTILE = 0.999


#: ``_chi2_factors`` for nu = 1, 2, ..., 32 degrees of freedom (a fit of k <= 35 unclipped
#: shifts), precomputed so that a ``phase`` run does not import scipy (cold start, issue 16):
#: rows (median of chi2_nu / nu, cut q / nu, kept mean), from :func:`_chi2_factors_scipy`
#: (``python -c "from hdrfringe.core.uncertainty import _chi2_factors_scipy as f; print(f(range(1,
#: 33)))"``); tests/test_uncertainty.py checks them against it.
_CHI2_TABLE: tuple[tuple[float, float, float], ...] = (
    (0.454936423119572, 10.827566170662733, 0.9873042153129739),
    (0.6931471805599455, 6.907755278982137, 0.9920922447210179),
    (0.7886579614584459, 5.422078732079377, 0.9938763305065146),
    (0.8391734950083306, 4.616706738225792, 0.994834433709568),
    (0.8702920382191053, 4.103001130486574, 0.9954416306130075),
    (0.891353437907853, 3.7429574141375537, 0.9958651272363155),
    (0.9065444565030736, 3.474555192550979, 0.9961796004358563),
    (0.9180151872127242, 3.2655601947970174, 0.9964236764322908),
    (0.9269814102503283, 3.097462763472952, 0.9966194487712161),
    (0.9341817765591969, 2.9588298445074424, 0.9967805193818983),
    (0.9400907340356206, 2.8421939654763624, 0.996915747162438),
    (0.945026864785345, 2.742457533946684, 0.9970311645017024),
    (0.9492119909664543, 2.6560137672977606, 0.9971310301389925),
    (0.9528052963642528, 2.580233834314152, 0.9972184418989705),
    (0.9559239673971097, 2.513153214556922, 0.9972957105862568),
    (0.9586561803126005, 2.453272174423029, 0.9973645973663302),
    (0.9610695516113216, 2.3994245121707367, 0.9974264696406424),
    (0.9632167982633744, 2.3506886850933313, 0.9974824064136149),
    (0.9651396261450775, 2.3063261033956595, 0.9975332713381367),
    (0.9668714614714128, 2.265737330906293, 0.9975797644892784),
    (0.9684394077879969, 2.2284303829314913, 0.9976224597882319),
    (0.9698656730760288, 2.1939973768561445, 0.9976618325313878),
    (0.9711686270949675, 2.162097063757891, 0.9976982799613765),
    (0.9723635960870639, 2.1324415740573914, 0.9977321368582281),
    (0.9734634679153717, 2.1047862310469134, 0.997763687509157),
    (0.9744791583645102, 2.0789216303298708, 0.9977931750064546),
    (0.9754199743922753, 2.0546674150276, 0.9978208085477954),
    (0.9762938999532071, 2.0318673354769152, 0.997846769224878),
    (0.9771078229856707, 2.0103852927515486, 0.9978712146552982),
    (0.9778677172220528, 1.9901021434809978, 0.9978942827200776),
    (0.9785787889741332, 1.9709130993889719, 0.997916094603121),
    (0.9792455965198277, 1.9527255955340148, 0.9979367572809544),
)


def _chi2_factors_scipy(dof: ArrayLike) -> tuple[F64, F64, F64]:
    """:func:`_chi2_factors` computed by scipy (any ``nu > 0``)."""
    from scipy.special import gammainc, gammaincinv

    nu = np.asarray(dof, dtype=np.float64)
    values, inverse = np.unique(nu, return_inverse=True)  # a few distinct values: one call each
    half = values / 2.0
    median = 2.0 * gammaincinv(half, 0.5) / values
    cut = 2.0 * gammaincinv(half, _CUT_QUANTILE)
    kept_mean = gammainc(half + 1.0, cut / 2.0)
    median, cut, kept_mean = (
        f[inverse].reshape(nu.shape) for f in (median, cut / values, kept_mean)
    )
    return median, cut, kept_mean


def _chi2_factors(dof: ArrayLike) -> tuple[F64, F64, F64]:
    """Per estimate of ``nu`` degrees of freedom (``v = sigma^2 chi2_nu / nu``): the median of
    ``chi2_nu / nu``, the cut ``q / nu`` at :data:`_CUT_QUANTILE` and ``E[chi2_nu / nu ; below
    the cut] = P(chi2_(nu+2) < q)``. Whole ``nu`` up to 32 from :data:`_CHI2_TABLE`, others
    from scipy."""
    nu = np.asarray(dof, dtype=np.float64)
    whole = np.rint(nu)
    if nu.size and np.all(whole == nu) and whole.min() >= 1 and whole.max() <= len(_CHI2_TABLE):
        table = np.asarray(_CHI2_TABLE, dtype=np.float64)[whole.astype(np.intp) - 1]
        return table[..., 0], table[..., 1], table[..., 2]
    return _chi2_factors_scipy(nu)


def fit_noise_model(
    intensity: ArrayLike,
    variance: ArrayLike,
    dof: ArrayLike,
    *,
    bins: int = 16,
    source: str = "estimated",
) -> NoiseModel:
    """Fit ``sigma^2 = read^2 + gain * I`` to per-pixel variance estimates, robustly.

    The pixels are split into ``bins`` groups of equal size by intensity. In each, with
    ``v = sigma^2 chi2_nu / nu`` for Gaussian noise (``nu = dof``), the median of
    ``v / (median(chi2_nu) / nu)`` gives a first level ``L``; estimates above ``L`` times the
    chi-square's 0.999 quantile over ``nu`` are outliers (edges, model error) and dropped, and
    the level is ``sum(v kept) / sum(E[chi2_nu / nu; below the cut])``: unbiased for Gaussian
    noise, and unlike a median unaffected by integer-valued data (a 4-step residual of
    rounded images takes few values; its median is 15 % low in variance,
    tests/test_uncertainty.py). A weighted least-squares line through the bins (weights
    ``count / var^2``) gives ``read^2`` and ``gain``, each constrained to be >= 0; when the
    bins' intensities spread over less than 10 % of their median, one sigma for all
    (``gain = 0``).

    Parameters
    ----------
    intensity : array_like
        Mean intensity of each estimate in DN.
    variance : array_like
        Unbiased variance estimates in DN^2 (same shape).
    dof : array_like
        Their degrees of freedom (scalar or same shape).
    bins : int
        Intensity groups (fewer when there are fewer than 50 pixels per group).
    source : str
        Recorded in the model.

    Returns
    -------
    NoiseModel
        With ``pixels`` the number of estimates used.

    Raises
    ------
    NoiseUnknownError
        Fewer than :data:`MIN_NOISE_PIXELS` finite estimates.
    InputError
        Shapes that differ.

    References
    ----------
    Thesis Sec. 3.1 (camera response); the chi-square of a variance estimate is standard.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> i = rng.uniform(10, 200, 20000)
    >>> v = (1.0 + 0.02 * i) * rng.chisquare(3, i.size) / 3
    >>> m = fit_noise_model(i, v, 3)
    >>> round(m.read_dn, 1), round(m.gain_dn_per_e, 3)
    (1.0, 0.02)
    """
    i = np.asarray(intensity, dtype=np.float64).ravel()
    v = np.asarray(variance, dtype=np.float64).ravel()
    if i.shape != v.shape:
        raise InputError(f"intensity {i.shape} and variance {v.shape} must have one shape")
    nu = np.broadcast_to(np.asarray(dof, dtype=np.float64), np.shape(intensity)).ravel()
    ok = np.isfinite(i) & np.isfinite(v) & np.isfinite(nu) & (nu > 0)
    i, v, nu = i[ok], v[ok], nu[ok]
    if i.size < MIN_NOISE_PIXELS:
        raise NoiseUnknownError(
            f"only {i.size} pixels to estimate the camera noise from (at least "
            f"{MIN_NOISE_PIXELS}); give the noise (noise_sigma / --noise-sigma DN)"
        )
    median, cut, kept_mean = _chi2_factors(nu)
    nbins = max(1, min(int(bins), i.size // 50))
    order = np.argsort(i, kind="stable")
    groups = np.array_split(order, nbins)
    centre = np.array([np.median(i[g]) for g in groups])
    level = np.empty(nbins)
    for j, g in enumerate(groups):
        first = np.median(v[g] / median[g])
        kept = v[g] < first * cut[g]
        level[j] = np.sum(v[g][kept]) / np.sum(kept_mean[g])
    count = np.array([g.size for g in groups], dtype=np.float64)
    if not np.isfinite(level).all() or level.max() <= 0:  # noise-free data (synthetic images)
        return NoiseModel(0.0, 0.0, source=source, pixels=int(i.size))
    w = count / np.maximum(level, 1e-6 * level.max()) ** 2
    read2, gain = 0.0, 0.0
    # a slope needs intensities that differ: over a spread below 10 % of the level it is
    # noise, and one sigma (the level's) is what the data support
    if nbins >= 2 and np.ptp(centre) > 0.1 * np.median(centre):
        x = np.column_stack([np.ones(nbins), centre]) * np.sqrt(w)[:, None]
        read2, gain = np.linalg.lstsq(x, level * np.sqrt(w), rcond=None)[0]
    if gain <= 0 or nbins < 2:
        read2, gain = float(np.sum(w * level) / np.sum(w)), 0.0
    elif read2 < 0:
        read2, gain = 0.0, float(np.sum(w * centre * level) / np.sum(w * centre**2))
    return NoiseModel(
        float(np.sqrt(max(read2, 0.0))), float(gain), source=source, pixels=int(i.size)
    )


def estimate_noise(sets: Sequence[tuple[ArrayLike, FringeSpec]], bit_depth: int) -> NoiseModel:
    """The camera noise estimated from sinusoidal sets with N >= 4 shifts.

    Per set and pixel, the least-squares sinusoid (three unknowns) leaves ``N - 3`` degrees of
    freedom; its residual sum of squares over ``N - 3`` estimates ``sigma^2`` without bias.
    Shifts at 0 or at ``2^B - 1`` (clipped: the model does not hold) are left out of a pixel's
    fit, which then has ``k - 3`` degrees of freedom for its ``k`` others (none below 4); all
    pixels of every set are pooled by :func:`fit_noise_model` against the mean of the shifts
    each used (the fitted ``a`` when all N equal shifts are used, the level of the darker
    shifts that noise was measured at when the bright ones clipped). A
    set of more than :data:`MAX_NOISE_PIXELS` pixels contributes every k-th (an even stride,
    enough for 16 medians and cheap on a 648 x 494 camera).

    Parameters
    ----------
    sets : sequence of (images, FringeSpec)
        The sets; triangular ones and those with fewer than 4 shifts are ignored.
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    NoiseModel
        ``source`` names the sets used.

    Raises
    ------
    NoiseUnknownError
        No usable set, or too few unclipped pixels.

    References
    ----------
    Thesis Eq. 2.1 (the sinusoid every shift samples).

    Notes
    -----
    The estimate includes whatever the sinusoid does not explain: quantisation (1/12 DN^2),
    and harmonics of a projector gamma left uncorrected (for N = 4 the residual is the
    pattern's second harmonic). The median per intensity group keeps edges and other model
    errors of a few pixels out; an uncompensated gamma across the image raises the estimate.

    Examples
    --------
    >>> from hdrfringe.core.patterns import fringe_gray
    >>> spec = FringeSpec("sinusoidal", 8, 16.0, imin=40, migl=200)
    >>> x = np.tile(np.arange(64.0), (48, 1))
    >>> rng = np.random.default_rng(0)
    >>> imgs = [fringe_gray(x, spec, k) + rng.normal(0, 2.0, x.shape) for k in range(8)]
    >>> m = estimate_noise([(np.rint(np.stack(imgs)).astype(np.uint8), spec)], 8)
    >>> round(float(m.sigma(120.0)), 2), m.gain_dn_per_e, m.source
    (2.0, 0.0, 'estimated from the residual of 1 set with N >= 4 (8 shifts)')
    """
    means, variances, dofs = [], [], []
    used: list[int] = []
    for images, spec in sets:
        if spec.pattern != "sinusoidal" or spec.steps < 4:
            continue
        arr = np.asarray(images)
        if arr.ndim != 3:
            raise InputError(f"noise estimate: a set must be (N, H, W) images, got {arr.shape}")
        n = arr.shape[0]
        flat = arr.reshape(n, -1)
        flat = flat[:, :: -(-flat.shape[1] // MAX_NOISE_PIXELS)]  # at most MAX_NOISE_PIXELS
        flat = as_stack(flat[:, None], what="noise estimate", n_min=4, bit_depth=bit_depth)[:, 0]
        A = _design(np.degrees(spec.shifts))
        if np.linalg.matrix_rank(A) < 3:
            continue
        # each pixel's unclipped shifts (neither 0 nor 2^B - 1), grouped by which they are: a
        # group of k >= 4 shifts at 3 or more distinct angles leaves k - 3 degrees of freedom
        usable = ~(is_saturated(flat, bit_depth) | (flat <= 0))
        patterns, inverse = _patterns(usable)
        order = np.argsort(inverse, kind="stable")
        bounds = np.cumsum(np.bincount(inverse, minlength=len(patterns)))[:-1]
        for rows, idx in zip(patterns, np.split(order, bounds), strict=True):
            k = int(rows.sum())
            if k < 4 or np.linalg.matrix_rank(A[rows]) < 3:
                continue
            vals = flat[np.ix_(rows, idx)].astype(np.float64)
            coef = np.linalg.pinv(A[rows]) @ vals
            resid = vals - A[rows] @ coef
            means.append(vals.mean(axis=0))  # = a with all N equal shifts; the shifts used
            variances.append(np.einsum("kp,kp->p", resid, resid) / (k - 3))
            dofs.append(np.full(idx.size, k - 3.0))
        used.append(n)
    if not used:
        raise NoiseUnknownError(
            "no sinusoidal set with 4 or more shifts to estimate the camera noise from; give "
            "the noise (noise_sigma / --noise-sigma DN)"
        )
    if not means:
        raise NoiseUnknownError(
            "no pixel has 4 or more unclipped shifts to estimate the camera noise from; give "
            "the noise (noise_sigma / --noise-sigma DN)"
        )
    steps = ", ".join(str(n) for n in sorted(set(used)))
    plural = "s" if len(used) > 1 else ""
    return fit_noise_model(
        np.concatenate(means),
        np.concatenate(variances),
        np.concatenate(dofs),
        source=(
            f"estimated from the residual of {len(used)} set{plural} with N >= 4 ({steps} shifts)"
        ),
    )


def noise_from_manifest(camera: Mapping[str, Any]) -> NoiseModel | None:
    """The noise model a capture manifest's ``camera`` records, if it does.

    Parameters
    ----------
    camera : mapping
        :attr:`Captures.camera <hdrfringe.core.captures.Captures>`: ``read_noise_dn`` (required for
        a model) and ``gain_dn_per_e`` (optional, default 0), as the virtual rig
        (:meth:`~hdrfringe.rig.simulated.CameraModel.noise_manifest`) and ``capture`` (the rig
        configuration's ``camera.read_noise_dn``) write them.

    Returns
    -------
    NoiseModel or None
        None when ``read_noise_dn`` is absent.

    Raises
    ------
    InputError
        A value that is not a finite number >= 0.

    Examples
    --------
    >>> noise_from_manifest({"read_noise_dn": 1.5}).to_dict()["source"]
    'manifest camera.read_noise_dn'
    >>> noise_from_manifest({"focal_px": 800.0}) is None
    True
    """
    if NOISE_KEYS[0] not in camera:
        return None
    source = "manifest camera." + " and camera.".join(k for k in NOISE_KEYS if k in camera)
    return NoiseModel(camera[NOISE_KEYS[0]], camera.get(NOISE_KEYS[1], 0.0), source=source)


def height_derivative(coefficients: ArrayLike, dphi: ArrayLike, model: str) -> F64:
    """``dh/d(dphi)`` of a calibration model at the phase differences ``dphi``.

    Parameters
    ----------
    coefficients : array_like, shape (M, H, W)
        As :func:`hdrfringe.core.calibration.evaluate_model` takes them (``linear``: ``K[None]``).
    dphi : array_like, shape (H, W)
        Phase differences to the reference plane (Eq. 2.10).
    model : {"linear", "rational", "poly2", "poly3"}
        The model.

    Returns
    -------
    ndarray, shape (H, W)
        mm/rad: ``K`` (Eq. 2.15), ``a / (a + b dphi)^2`` (rational), ``sum_k k c_k dphi^(k-1)``
        (polynomial); NaN where not finite.

    Raises
    ------
    InputError
        Unknown model or coefficients that do not fit it.

    References
    ----------
    Thesis Eq. 2.11, 2.15.

    Examples
    --------
    >>> float(height_derivative(np.array([[[2.0]], [[0.5]]]), np.array([[2.0]]), "rational")[0, 0])
    0.2222222222222222
    """
    from hdrfringe.core.calibration import N_COEFFICIENTS

    c = np.asarray(coefficients, dtype=np.float64)
    d = np.asarray(dphi, dtype=np.float64)
    if model not in N_COEFFICIENTS:
        raise InputError(
            f"unknown calibration model {model!r}; use one of {', '.join(N_COEFFICIENTS)}"
        )
    if c.ndim != 3 or c.shape[0] != N_COEFFICIENTS[model] or c.shape[1:] != d.shape:
        raise InputError(f"{model} coefficients of shape {c.shape} do not fit dphi {d.shape}")
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if model == "linear":
            out = c[0] * np.ones_like(d)
            out[~np.isfinite(d)] = np.nan
        elif model == "rational":
            out = c[0] / (c[0] + c[1] * d) ** 2
        else:
            out = np.zeros_like(d)
            for k in range(c.shape[0] - 1, -1, -1):  # Horner on sum (k+1) c_k d^k
                out = out * d + (k + 1) * c[k]
    out = np.asarray(out, dtype=np.float64)
    out[~np.isfinite(out)] = np.nan
    return out


def height_std(calibration: Calibration, absolute_phase: ArrayLike, phase_std: ArrayLike) -> F64:
    """Predicted height std ``|dh/dphi| * sigma_phi`` in mm through a calibration.

    Parameters
    ----------
    calibration : Calibration
        The phase-to-height calibration (its model).
    absolute_phase : array_like, shape (H, W)
        The measurement's absolute phase (rad).
    phase_std : array_like, shape (H, W)
        Its predicted std (rad).

    Returns
    -------
    ndarray, shape (H, W)
        mm; NaN where either input or the calibration is NaN.

    References
    ----------
    Thesis Eq. 2.10, 2.11, 2.15.

    Examples
    --------
    >>> from hdrfringe.core.calibration import Calibration
    >>> cal = Calibration("linear", np.full((1, 2), -0.5), None, np.zeros((1, 2)),
    ...                   np.array([2.0, 4.0]))
    >>> height_std(cal, np.array([[3.0, 4.0]]), np.array([[0.02, np.nan]])).tolist()
    [[0.01, nan]]
    """
    dphi = calibration.phase_difference(absolute_phase)
    slope = height_derivative(calibration.model_coefficients, dphi, calibration.model)
    return np.asarray(np.abs(slope) * np.asarray(phase_std, dtype=np.float64), dtype=np.float64)


def _finite_median(values: ArrayLike) -> float | None:
    """Median of the finite values, the value ``np.median`` gives for them in float64: the
    middle one, or the float64 mean of the middle two; from one compacted copy in the values'
    own dtype, partitioned in place (no image-sized float64 copy of a float32 map)."""
    v = np.asarray(values)
    v = v[np.isfinite(v)]  # boolean indexing copies
    if not v.size:
        return None
    k = v.size // 2
    middle = [k - 1, k] if v.size % 2 == 0 else [k]
    v.partition(middle)
    return float(np.mean(v[middle].astype(np.float64)))


@dataclass(frozen=True, eq=False)
class Uncertainty:
    """Predicted phase (and height) std of a decoded measurement, with the noise it used.

    Parameters
    ----------
    noise : NoiseModel
        The camera noise.
    set_phase_std : dict of str to ndarray (H, W)
        Per set label: the wrapped phase's std in rad (NaN where not predicted).
    family_phase_std : dict of str to ndarray (H, W)
        Per family orientation: the std of its unwrapped (and absolute) phase, its finest
        set's where the unwrapped phase is finite.
    primary : str or None
        The primary family's orientation (the height's).
    height_std_mm : ndarray (H, W) or None
        With a calibration: ``|dh/dphi| sigma_phi`` of the primary family.
    measurement_mask : ndarray of bool or None
        The calibration's measurement pixels (the summary's median of the height std).
    median_intensity_dn : float or None
        Median mean intensity I'' of the valid pixels of the primary family's finest set (the
        summary's ``sigma_i_dn`` is the noise there).
    notes : tuple of str
        What the prediction needs said.

    References
    ----------
    Thesis Eq. 2.2, 2.15; docs/uncertainty.md.

    Examples
    --------
    >>> u = Uncertainty(NoiseModel(1.0), {"s": np.full((2, 2), 0.01)}, {}, None)
    >>> u.summary()["phase_std_median_rad"]
    0.01
    """

    noise: NoiseModel
    set_phase_std: dict[str, F64]
    family_phase_std: dict[str, F64]
    primary: str | None
    height_std_mm: F64 | None = None
    measurement_mask: NDArray[np.bool_] | None = None
    median_intensity_dn: float | None = None
    notes: tuple[str, ...] = field(default=())

    @property
    def phase_std(self) -> F64 | None:
        """The primary family's phase std (the one the height comes from), else the first
        set's; None without sets."""
        if self.primary is not None:
            return self.family_phase_std[self.primary]
        return next(iter(self.set_phase_std.values()), None)

    def summary(self) -> dict[str, Any]:
        """The ``uncertainty`` block of ``metrics.json`` and ``phase_summary.json``.

        Returns
        -------
        dict
            ``predicted`` (True), the noise model (:meth:`NoiseModel.to_dict`),
            ``median_intensity_dn`` and ``sigma_i_dn``, the noise at that intensity (None
            without valid pixels), ``phase_std_median_rad`` (primary family, valid pixels), with a
            calibration ``height_std_median_mm`` (measurement pixels), and ``notes``.
        """
        out: dict[str, Any] = {"predicted": True, "noise": self.noise.to_dict()}
        level = self.median_intensity_dn
        out["median_intensity_dn"] = level
        out["sigma_i_dn"] = None if level is None else float(self.noise.sigma(level))
        std = self.phase_std
        out["phase_std_median_rad"] = None if std is None else _finite_median(std)
        if self.height_std_mm is not None:
            h = self.height_std_mm
            if self.measurement_mask is not None:
                h = h[self.measurement_mask]
            out["height_std_median_mm"] = _finite_median(h)
        out["notes"] = list(self.notes)
        return out


def resolve_noise(captures: Captures, noise: NoiseModel | float | None = None) -> NoiseModel:
    """The camera noise :func:`predict_uncertainty` uses: given, recorded or estimated.

    Parameters
    ----------
    captures : Captures
        The captures (their manifest's camera entry; their images when the noise is
        estimated).
    noise : NoiseModel or float, optional
        A model, or one sigma in DN for every intensity. Default: the manifest's
        (:func:`noise_from_manifest`), else estimated from the sets with N >= 4 shifts
        (:func:`estimate_noise`).

    Returns
    -------
    NoiseModel

    Raises
    ------
    NoiseUnknownError
        None given or recorded, and no set to estimate it from.

    Examples
    --------
    >>> from hdrfringe.core.frames import UniformFrame
    >>> caps = Captures([UniformFrame(128)], np.zeros((1, 2, 3), np.uint8), 8)
    >>> resolve_noise(caps, 1.5).read_dn
    1.5
    """
    if isinstance(noise, NoiseModel):
        return noise
    if noise is not None:
        return NoiseModel(noise, 0.0, source="given")
    recorded = noise_from_manifest(captures.camera)
    if recorded is not None:
        return recorded
    return estimate_noise(
        [(captures.set_images(s), s.spec) for s in captures.sets], captures.camera_bit_depth
    )


def predict_uncertainty(
    captures: Captures,
    decoded: FolderPhase,
    *,
    noise: NoiseModel | float | None = None,
    calibration: Calibration | None = None,
    finest_only: bool = False,
) -> Uncertainty:
    """Predicted phase std of every decoded set and family, and the height std.

    Parameters
    ----------
    captures : Captures
        The captures decoded.
    decoded : FolderPhase
        From :func:`hdrfringe.core.decode.decode_captures`.
    noise : NoiseModel or float, optional
        The camera noise: a model, or one sigma in DN for every intensity. Default: the
        manifest's (:func:`noise_from_manifest`), else estimated from the sets with N >= 4
        shifts (:func:`estimate_noise`).
    calibration : Calibration, optional
        With it and an absolute phase of the primary family: the height std
        (:func:`height_std`).
    finest_only : bool
        Predict only the finest set of each family (what the absolute phases and the height
        come from; ``measure`` writes no other).

    Returns
    -------
    Uncertainty

    Raises
    ------
    NoiseUnknownError
        No noise given or recorded and no set to estimate it from (all N = 3, or triangular).

    References
    ----------
    Thesis Eq. 2.2, 2.8, 2.9, 2.15; docs/uncertainty.md.

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> from hdrfringe.core.decode import decode_captures
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=64, height=48))
    >>> frames = [f for p in (1024.0, 16.0) for f in FringeSpec("sinusoidal", 8, p).frames()]
    >>> caps = rig.capture_folder(frames)
    >>> decoded = decode_captures(caps)
    >>> s = predict_uncertainty(caps, decoded).summary()  # the rig records its noise model
    >>> s["noise"]["source"]
    'manifest camera.read_noise_dn and camera.gain_dn_per_e'
    >>> level = s["median_intensity_dn"]  # read noise 1 DN, rounding, gain 255/20000 DN/e
    >>> truth = float(np.sqrt(1 + 1 / 12 + 0.01275 * level))
    >>> round(level), round(s["sigma_i_dn"], 4) == round(truth, 4)
    (118, True)
    >>> round(s["phase_std_median_rad"], 4)  # sqrt(2/8) * sigma_I / b
    0.012
    >>> import dataclasses  # without the manifest's model: estimated from the residuals
    >>> bare = dataclasses.replace(caps, camera={"focal_px": 1.0})
    >>> e = predict_uncertainty(bare, decoded).summary()
    >>> e["noise"]["source"][:9], round(e["sigma_i_dn"], 2)
    ('estimated', 1.62)
    """
    model = resolve_noise(captures, noise)
    bits = captures.camera_bit_depth
    by_label = {s.label: s for s in captures.sets}
    set_std: dict[str, F64] = {}
    wanted = {f.sets[-1].label for f in decoded.families} if finest_only else None
    for s in decoded.sets:
        if wanted is not None and s.label not in wanted:
            continue
        res = decoded.set_results[s.label]
        images = None
        if isinstance(res, TolerantPhaseResult):
            images = captures.set_images(s)
            inv = decoded.inverted_sets.get(s.label)
            if inv is not None:
                images = np.concatenate([images, captures.set_images(by_label[inv])])
        set_std[s.label] = predict_phase_std(res, model, images=images, bit_depth=bits)
    fam_std: dict[str, F64] = {}
    for fam in decoded.families:
        phase = fam.unwrapped_phase if fam.absolute_phase is None else fam.absolute_phase
        std = set_std[fam.sets[-1].label]
        finite = np.isfinite(phase)
        if (np.isfinite(std) & ~finite).any():  # else the set's map is the family's: shared
            std = np.where(finite, std, np.nan)
        fam_std[fam.orientation] = std
    primary = decoded.primary
    notes: list[str] = []
    kept = [  # valid pixels decoded with a saturated shift (reject_saturated=False)
        s.label
        for s in decoded.sets
        if not isinstance(decoded.set_results[s.label], TolerantPhaseResult)
        and (
            decoded.set_results[s.label].valid & (decoded.set_results[s.label].saturation_count > 0)
        ).any()
    ]
    if kept:
        notes.append(
            "no std is predicted where a saturated shift was decoded (NaN; the clipped value "
            "biases the phase)"
        )
    level = None
    if primary is not None:
        fine = decoded.set_results[primary.sets[-1].label]
        level = _finite_median(fine.mean_intensity[fine.valid])
    h_std = mask = None
    if calibration is not None and primary is not None and primary.absolute_phase is not None:
        h_std = height_std(calibration, primary.absolute_phase, fam_std[primary.orientation])
        mask = calibration.measurement_mask()
    return Uncertainty(
        noise=model,
        set_phase_std=set_std,
        family_phase_std=fam_std,
        primary=None if primary is None else primary.orientation,
        height_std_mm=h_std,
        measurement_mask=mask,
        median_intensity_dn=level,
        notes=tuple(notes),
    )


def describe_uncertainty(block: dict[str, Any]) -> str:
    """The line ``phase`` and ``measure`` print about the predicted std (one line, no I/O).

    Parameters
    ----------
    block : dict
        The ``uncertainty`` block of ``metrics.json`` or ``phase_summary.json``.

    Returns
    -------
    str

    Examples
    --------
    >>> describe_uncertainty({"predicted": False, "reason": "no noise"})
    'no predicted std: no noise'
    """
    if not block.get("predicted"):
        return f"no predicted std: {block.get('reason')}"

    def num(v: Any) -> str:
        return "n/a" if v is None else f"{v:.4g}"

    line = f"predicted phase std: median {num(block.get('phase_std_median_rad'))} rad"
    if "height_std_median_mm" in block:
        line += f", height std median {num(block['height_std_median_mm'])} mm"
    if block.get("sigma_i_dn") is not None:
        line += (
            f" (sigma_I {num(block['sigma_i_dn'])} DN at {num(block['median_intensity_dn'])} DN,"
            f" {block['noise']['source']})"
        )
    return line
