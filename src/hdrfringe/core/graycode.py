"""Gray code: patterns, per-pixel decoding, and absolute phase from Gray code + wrapped phase.

A Gray code projects ``bits`` binary images; together they give every projector stripe of
``stripe_px`` pixels (the code's least-significant cell) its own code word, so each camera pixel
learns which stripe it sees. Combined with a phase-shifted fringe set of pitch ``p`` the stripe
index fixes the fringe order, per pixel, with no spatial unwrapping: the absolute phase of
isolated surfaces (islands) is right too. docs/graycode.md describes the conventions and the
method in full.

Conventions
-----------
- Stripe (cell) ``m`` covers projector pixels ``m*stripe_px .. (m+1)*stripe_px - 1`` (pixel
  centres at integers, so its centre is ``(m + 1/2)*stripe_px - 1/2``); cell index
  ``floor((x + 1/2) / stripe_px)`` at continuous coordinate ``x``.
- Bit ``b`` (0 = least significant) of the code word of cell ``m`` is lit (bright, bit 1) in the
  pattern and dark in its inverse. Code word = ``binary_to_gray(m)`` for the binary-reflected
  Gray code (``code="gray"``), ``m`` itself for plain binary (``code="binary"``).
- OpenCV's ``structured_light::GrayCodePattern`` (opencv_contrib) projects, for a projector of
  ``W x H`` code cells, ``ceil(log2 W)`` column (vertical-stripe) bits then ``ceil(log2 H)`` row
  bits, **most significant bit first**, each as a pair (pattern, inverse) with the pattern lit
  where the Gray bit is 1, and decodes ``bit = pattern > inverse`` (its "white threshold",
  default 5 DN, is the least ``|pattern - inverse|`` it accepts; its "black threshold", default
  40 DN, the least ``white - black``). Programs that scale the cells up to ``stripe_px``
  projector pixels (e.g. kamino410/phase-shifting: 100 px) give exactly the frames of
  :func:`hdrfringe.core.frames.opencv_graycode_frames`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.errors import InputError

__all__ = [
    "CODES",
    "GrayCodeDecode",
    "GrayCodePhase",
    "absolute_phase_graycode",
    "binary_to_gray",
    "bits_needed",
    "code_bit",
    "decode_graycode",
    "gray_to_binary",
    "graycode_patterns",
    "stripe_centre",
]

#: The code words a Gray-code frame may carry.
CODES = ("gray", "binary")
Code = Literal["gray", "binary"]

#: Most bits of one code (2^24 stripes: far beyond any projector).
MAX_BITS = 24

TWO_PI = 2.0 * np.pi

#: Most passes of the median cleanup (each pass fixes the pixels whose window has a correct
#: majority; a band of wrong orders shrinks from its edges, so a few passes suffice).
_CLEANUP_PASSES = 8


def _check_code(code: str) -> None:
    if code not in CODES:
        raise InputError(f"unknown code {code!r}; use one of {', '.join(CODES)}")


def _as_int(a: ArrayLike, what: str) -> NDArray[np.int64]:
    arr = np.asarray(a)
    if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.integer):
        raise InputError(f"{what} must hold integers, got dtype {arr.dtype}")
    if arr.size and int(arr.min()) < 0:
        raise InputError(f"{what} must be non-negative, got {int(arr.min())}")
    return arr.astype(np.int64)


def binary_to_gray(n: ArrayLike) -> NDArray[np.int64]:
    """Binary-reflected Gray code word of each non-negative integer: ``n ^ (n >> 1)``.

    Parameters
    ----------
    n : array_like of int
        Non-negative integers (stripe indices).

    Returns
    -------
    ndarray of int64

    Examples
    --------
    >>> binary_to_gray(np.arange(8)).tolist()
    [0, 1, 3, 2, 6, 7, 5, 4]
    """
    v = _as_int(n, "n")
    return v ^ (v >> 1)


def gray_to_binary(g: ArrayLike) -> NDArray[np.int64]:
    """Integer of each binary-reflected Gray code word (inverse of :func:`binary_to_gray`).

    Each binary bit is the XOR of the Gray bits at and above it: ``b = g ^ (g >> 1) ^ (g >> 2)
    ^ ...``, computed with log2(bits) shifts.

    Parameters
    ----------
    g : array_like of int
        Non-negative Gray code words.

    Returns
    -------
    ndarray of int64

    Examples
    --------
    >>> gray_to_binary([0, 1, 3, 2, 6, 7, 5, 4]).tolist()
    [0, 1, 2, 3, 4, 5, 6, 7]
    """
    b = _as_int(g, "g").copy()
    shift = 1
    while shift < 64:
        b ^= b >> shift
        shift *= 2
    return b


def bits_needed(extent_px: int, stripe_px: float) -> int:
    """Bits of a code giving every stripe of a projector axis its own word (OpenCV's count).

    ``ceil(log2(cells))`` with ``cells = ceil(extent_px / stripe_px)``; 0 for a single cell
    (OpenCV then projects no image for the axis).

    Parameters
    ----------
    extent_px : int
        Projector width (vertical stripes) or height (horizontal), pixels.
    stripe_px : float
        Stripe width (the code's least-significant cell), projector pixels.

    Returns
    -------
    int

    Examples
    --------
    >>> bits_needed(1920, 100), bits_needed(1080, 100), bits_needed(912, 114), bits_needed(8, 8)
    (5, 4, 3, 0)
    """
    if not (isinstance(extent_px, int | np.integer) and extent_px >= 1):
        raise InputError(f"extent must be a positive whole number of pixels, got {extent_px!r}")
    _check_stripe(stripe_px)
    cells = math.ceil(extent_px / stripe_px)
    return math.ceil(math.log2(cells)) if cells > 1 else 0


def _check_stripe(stripe_px: float) -> float:
    s = float(stripe_px)
    if not (math.isfinite(s) and s > 0):
        raise InputError(f"stripe width must be a positive number of pixels, got {stripe_px!r}")
    return s


def code_bit(coord: ArrayLike, bit: int, stripe_px: float, code: str = "gray") -> NDArray[np.bool_]:
    """Whether bit ``bit`` of the code word is 1 (lit) at projector coordinates ``coord``.

    Parameters
    ----------
    coord : array_like
        Projector column (vertical stripes) or row (horizontal); pixel centres at integers.
    bit : int
        Bit significance, 0 = least significant (the finest stripes).
    stripe_px : float
        Width of the code's cell in projector pixels.
    code : {"gray", "binary"}

    Returns
    -------
    ndarray of bool

    Examples
    --------
    >>> code_bit(np.arange(8), 0, 1.0).astype(int).tolist()
    [0, 1, 1, 0, 0, 1, 1, 0]
    >>> code_bit(np.arange(8), 0, 2.0, "binary").astype(int).tolist()
    [0, 0, 1, 1, 0, 0, 1, 1]
    """
    _check_code(code)
    s = _check_stripe(stripe_px)
    x = np.asarray(coord, dtype=np.float64)
    cell = np.floor((x + 0.5) / s)
    cell = np.where(cell < 0, 0, cell).astype(np.int64)
    word = binary_to_gray(cell) if code == "gray" else cell
    return ((word >> int(bit)) & 1).astype(bool)


def graycode_patterns(
    extent_px: int, stripe_px: float, bits: int | None = None, code: str = "gray"
) -> NDArray[np.bool_]:
    """Lines of a code along one projector axis: ``out[b, x]`` is bit ``b`` at pixel ``x``.

    Parameters
    ----------
    extent_px : int
        Projector pixels along the axis.
    stripe_px : float
        Cell width in projector pixels.
    bits : int, optional
        Number of bits; default :func:`bits_needed`.
    code : {"gray", "binary"}

    Returns
    -------
    ndarray of bool, shape (bits, extent_px)
        Row ``b`` = bit ``b`` (least significant first); a pattern lights its True pixels, its
        inverse the others.

    Examples
    --------
    >>> graycode_patterns(8, 2.0).astype(int).tolist()
    [[0, 0, 1, 1, 1, 1, 0, 0], [0, 0, 0, 0, 1, 1, 1, 1]]
    """
    n = max(1, bits_needed(extent_px, stripe_px)) if bits is None else int(bits)
    if not 1 <= n <= MAX_BITS:
        raise InputError(f"bits must be 1..{MAX_BITS}, got {bits!r}")
    x = np.arange(extent_px)
    return np.stack([code_bit(x, b, stripe_px, code) for b in range(n)])


def stripe_centre(index: ArrayLike, stripe_px: float) -> NDArray[np.float64]:
    """Projector coordinate of the centre of stripe ``index``: ``(index + 1/2)*s - 1/2``.

    Parameters
    ----------
    index : array_like
        Stripe indices (float, NaN allowed).
    stripe_px : float
        Cell width in projector pixels.

    Returns
    -------
    ndarray of float64

    Examples
    --------
    >>> stripe_centre([0, 3], 100.0).tolist()
    [49.5, 349.5]
    """
    s = _check_stripe(stripe_px)
    return (np.asarray(index, dtype=np.float64) + 0.5) * s - 0.5


@dataclass(frozen=True)
class GrayCodeDecode:
    """Per-pixel result of :func:`decode_graycode`.

    Parameters
    ----------
    index : ndarray of float64, shape (H, W)
        Stripe index (integer valued), NaN where invalid.
    valid : ndarray of bool, shape (H, W)
        Every bit decided with enough contrast and not saturated on both sides.
    reliability : ndarray of float64, shape (H, W)
        The smallest bit contrast of the pixel (``|pattern - inverse|`` or
        ``|image - threshold|``), DN.
    bits : ndarray of bool, shape (n_bits, H, W)
        The decided bits, least significant first.

    Examples
    --------
    >>> d = decode_graycode([[[0, 200]]], inverses=[[[200, 0]]])
    >>> d.index.tolist(), d.valid.tolist()
    ([[0.0, 1.0]], [[True, True]])
    """

    index: NDArray[np.float64]
    valid: NDArray[np.bool_]
    reliability: NDArray[np.float64]
    bits: NDArray[np.bool_]


def decode_graycode(
    images: ArrayLike,
    *,
    inverses: ArrayLike | None = None,
    threshold: ArrayLike | None = None,
    contrast: ArrayLike | None = None,
    code: str = "gray",
    min_contrast: float = 5.0,
    full_scale: float | None = None,
) -> GrayCodeDecode:
    """Decode bit images to a stripe index per camera pixel.

    Two ways to decide a bit:

    - with inverse pairs (``inverses``): ``bit = pattern > inverse``, reliability
      ``|pattern - inverse|`` (OpenCV's rule; robust to albedo and ambient light);
    - with a threshold image (``threshold``, e.g. ``(white + black) / 2`` or the mean of a
      phase-shifted set): ``bit = image > threshold``, reliability ``|image - threshold|``.

    Parameters
    ----------
    images : array_like, shape (n_bits, H, W)
        Camera images of the patterns, **least significant bit first**.
    inverses : array_like, shape (n_bits, H, W), optional
        Camera images of the inverse patterns, same order.
    threshold : array_like, shape (H, W), optional
        Per-pixel threshold (used without ``inverses``).
    contrast : array_like, shape (H, W), optional
        Per-pixel full contrast of the code (e.g. ``white - black``); pixels where it is below
        ``2 * min_contrast`` are invalid (unlit or shadowed). Optional.
    code : {"gray", "binary"}
    min_contrast : float
        Least reliability (DN) of every bit of a valid pixel. OpenCV's default is 5 DN for
        8-bit images.
    full_scale : float, optional
        Camera full scale ``2^B - 1``: a bit whose two sides (pattern and inverse, or image and
        threshold) are both saturated is undecidable, and its pixel invalid.

    Returns
    -------
    GrayCodeDecode

    Raises
    ------
    InputError
        Neither or both of ``inverses`` / ``threshold``, mismatched shapes, unknown code, a
        negative ``min_contrast``.

    Examples
    --------
    Cells 0..3 of a 2-bit Gray code, decided against a threshold of 100:

    >>> x = np.arange(4)
    >>> imgs = np.stack([code_bit(x, b, 1.0) for b in range(2)])[:, None, :] * 200.0
    >>> decode_graycode(imgs, threshold=np.full((1, 4), 100.0)).index.tolist()
    [[0.0, 1.0, 2.0, 3.0]]
    """
    _check_code(code)
    imgs = np.asarray(images, dtype=np.float64)
    if imgs.ndim == 2:
        imgs = imgs[None]
    if imgs.ndim != 3 or imgs.shape[0] < 1:
        raise InputError(f"Gray-code images must be (n_bits, H, W), got shape {imgs.shape}")
    if imgs.shape[0] > MAX_BITS:
        raise InputError(f"at most {MAX_BITS} Gray-code bits, got {imgs.shape[0]}")
    if (inverses is None) == (threshold is None):
        raise InputError("give either inverses (pattern/inverse pairs) or a threshold image")
    mc = float(min_contrast)
    if not (math.isfinite(mc) and mc >= 0):
        raise InputError(f"min_contrast must be a non-negative number of DN, got {min_contrast}")
    if inverses is not None:
        other = np.asarray(inverses, dtype=np.float64)
        if other.ndim == 2:
            other = other[None]
        if other.shape != imgs.shape:
            raise InputError(
                f"inverse images have shape {other.shape} but the patterns {imgs.shape}; "
                "give one inverse per pattern"
            )
    else:
        thr = np.asarray(threshold, dtype=np.float64)
        if thr.shape != imgs.shape[1:]:
            raise InputError(
                f"threshold has shape {thr.shape} but the images are {imgs.shape[1:]}; "
                "give one threshold per pixel"
            )
        other = np.broadcast_to(thr, imgs.shape)
    diff = imgs - other
    bits = diff > 0
    rel = np.abs(diff).min(axis=0)
    valid = np.isfinite(diff).all(axis=0) & (rel >= mc)
    if full_scale is not None:
        both = (imgs >= full_scale) & (other >= full_scale)
        valid &= ~both.any(axis=0)
    if contrast is not None:
        c = np.asarray(contrast, dtype=np.float64)
        if c.shape != imgs.shape[1:]:
            raise InputError(f"contrast has shape {c.shape} but the images are {imgs.shape[1:]}")
        valid &= c >= 2 * mc
    weights = np.left_shift(np.int64(1), np.arange(imgs.shape[0], dtype=np.int64))
    word = np.tensordot(weights, bits.astype(np.int64), axes=1)
    idx = gray_to_binary(word) if code == "gray" else word
    index = np.where(valid, idx.astype(np.float64), np.nan)
    return GrayCodeDecode(index, valid, np.where(np.isfinite(rel), rel, 0.0), bits)


@dataclass(frozen=True)
class GrayCodePhase:
    """Absolute phase from Gray code + wrapped phase (:func:`absolute_phase_graycode`).

    Parameters
    ----------
    phase : ndarray of float64, shape (H, W)
        Absolute phase ``2*pi*x/p``, NaN where either input is invalid.
    order : ndarray of float64, shape (H, W)
        Fringe order k (integer valued, NaN invalid): ``phase = wrapped + 2*pi*k``.
    corrected : int
        Pixels whose order the cleanup changed.
    method : str
        What was done, for reports.

    Examples
    --------
    >>> r = absolute_phase_graycode([[0.5]], [[2.0]], stripe_px=8.0, pitch_px=8.0)
    >>> round(float(r.order[0, 0])), r.corrected
    (2, 0)
    """

    phase: NDArray[np.float64]
    order: NDArray[np.float64]
    corrected: int
    method: str


def absolute_phase_graycode(
    wrapped: ArrayLike,
    index: ArrayLike,
    *,
    stripe_px: float,
    pitch_px: float,
    cleanup: bool = True,
    window: int = 7,
) -> GrayCodePhase:
    """Absolute phase from a wrapped phase and a Gray-code stripe index, edge errors handled.

    **Order.** With ``x_phi = p * phi / (2*pi)`` (the position inside the period) and
    ``x_gc`` the centre of the decoded stripe (:func:`stripe_centre`), the fringe order is the
    integer that puts the phase nearest the Gray code (phase-guided order):

        k = round((x_gc - x_phi) / p),     phase = phi + 2*pi*k

    It is right whenever ``|x_gc - x| < p/2``. The Gray code locates ``x`` to half a stripe
    (``s/2``), and a pixel on a stripe edge that decodes to the neighbouring stripe is still
    within ``s/2`` plus the width of the blurred edge; the phase's own wrap is resolved by the
    rounding, not by the code. So:

    - ``s <= p/2`` (a *complementary* Gray code: the capture has one bit finer than the
      fringe pitch, whose edges lie half a stripe from the others): margin ``p/4`` at every
      pixel, edge errors cannot occur. This is the complementary Gray code of Zhang et al.
      (2012) in one formula: its three-case rule picks, by the phase, the one of two codes
      whose edges are far from the pixel; rounding against the finer code does the same.
    - ``p/2 < s <= p``: a pixel within ``(s - p)/2 + edge blur`` of a stripe edge that decoded
      to the wrong stripe gets an order off by one (for ``s = p`` every misdecoded edge pixel).
      These are thin bands along stripe edges, and ``cleanup`` removes them: a pixel whose
      phase differs by more than ``pi`` from the median of the valid phases in a
      ``window x window`` neighbourhood takes the order that puts it nearest that median.
      An isolated wrong order is at most a few pixels wide, so the median follows the correct
      majority; a real depth step keeps a majority on each side and is left alone.
    - ``s > p``: ambiguous, refused.

    Parameters
    ----------
    wrapped : array_like, shape (H, W)
        Wrapped phase ``2*pi*x/p mod 2*pi`` (NaN invalid).
    index : array_like, shape (H, W)
        Stripe index from :func:`decode_graycode` (NaN invalid).
    stripe_px : float
        The code's cell width, projector pixels.
    pitch_px : float
        Fringe pitch, projector pixels; ``stripe_px <= pitch_px``.
    cleanup : bool
        Correct isolated order errors with the median rule (default True).
    window : int
        Odd size of the median window, >= 3.

    Returns
    -------
    GrayCodePhase

    Raises
    ------
    InputError
        Shapes differ, ``stripe_px > pitch_px``, bad window.

    References
    ----------
    Thesis Sec. 2.4-2.5 (fringe order, absolute phase); Sansoni et al. (1999) Appl. Opt. 38,
    6565 (Gray code + phase shift); Zhang Q. et al. (2012) Opt. Lasers Eng. 50, 574
    (complementary Gray code).

    Examples
    --------
    A ramp ``x = 0..399`` with pitch 100 and a Gray code of 100 px stripes:

    >>> x = np.arange(400.0)[None, :]
    >>> phi = np.mod(2 * np.pi * x / 100, 2 * np.pi)
    >>> r = absolute_phase_graycode(phi, np.floor((x + 0.5) / 100), stripe_px=100, pitch_px=100)
    >>> bool(np.allclose(r.phase, 2 * np.pi * x / 100))
    True
    """
    phi = np.asarray(wrapped, dtype=np.float64)
    idx = np.asarray(index, dtype=np.float64)
    if phi.shape != idx.shape or phi.ndim != 2:
        raise InputError(
            f"wrapped phase {phi.shape} and stripe index {idx.shape} must be equal 2-D shapes"
        )
    s = _check_stripe(stripe_px)
    p = float(pitch_px)
    if not (math.isfinite(p) and p > 0):
        raise InputError(f"pitch must be a positive number of pixels, got {pitch_px!r}")
    if s > p * (1 + 1e-9):
        raise InputError(
            f"Gray-code stripe {s:g} px is wider than the fringe pitch {p:g} px: the fringe "
            "order is ambiguous; pair the code with a set of pitch >= the stripe"
        )
    if isinstance(window, bool) or int(window) != window or window < 3 or window % 2 == 0:
        raise InputError(f"window must be an odd integer >= 3, got {window!r}")
    phi = np.mod(phi, TWO_PI)
    x_phi = phi * p / TWO_PI
    order = np.round((stripe_centre(idx, s) - x_phi) / p)
    phase = phi + TWO_PI * order
    corrected = 0
    complementary = s <= p / 2 * (1 + 1e-9)
    if cleanup:
        for _ in range(_CLEANUP_PASSES):
            fix = _median_correction(phase, int(window))
            n = int(np.count_nonzero(fix))
            if n == 0:
                break
            order = order + fix
            phase = phase + TWO_PI * fix
            corrected += n
    method = (
        "complementary Gray code (stripe <= p/2), phase-guided order"
        if complementary
        else "phase-guided order"
    )
    if cleanup:
        method += f", {window}x{window} median cleanup"
    return GrayCodePhase(phase, order, corrected, method)


def _median_correction(phase: NDArray[np.float64], window: int) -> NDArray[np.float64]:
    """Order change (integer, 0 mostly) of pixels more than pi from their neighbourhood median.

    Only pixels next to a jump of more than pi are candidates (an isolated order error always
    makes one), so the median is evaluated on few pixels.
    """
    valid = np.isfinite(phase)
    jump = np.zeros(phase.shape, dtype=bool)
    for axis in (0, 1):
        d = np.abs(np.diff(phase, axis=axis)) > np.pi
        d &= np.isfinite(np.diff(phase, axis=axis))
        if axis == 0:
            jump[1:, :] |= d
            jump[:-1, :] |= d
        else:
            jump[:, 1:] |= d
            jump[:, :-1] |= d
    cand = np.argwhere(jump & valid)
    fix = np.zeros(phase.shape)
    if cand.size == 0:
        return fix
    r = window // 2
    padded = np.pad(phase, r, constant_values=np.nan)
    offs = np.arange(-r, r + 1)
    out = np.empty(len(cand))
    chunk = 65536
    for first in range(0, len(cand), chunk):
        c = cand[first : first + chunk]
        rows = c[:, 0, None, None] + r + offs[None, :, None]
        cols = c[:, 1, None, None] + r + offs[None, None, :]
        win = padded[rows, cols].reshape(len(c), -1)
        out[first : first + chunk] = np.nanmedian(win, axis=1)
    here = phase[cand[:, 0], cand[:, 1]]
    step = np.round((out - here) / TWO_PI)
    step[~np.isfinite(step) | (np.abs(out - here) <= np.pi)] = 0.0
    fix[cand[:, 0], cand[:, 1]] = step
    return fix
