"""Input validation shared by every stage: bit depths, full scale, image stacks, saturation.

There is one saturation rule in hdrfringe, :func:`is_saturated`: a camera value is saturated
when it reaches the sensor's full scale ``2^B - 1`` (the capture-folder contract says "equals";
values above it are invalid for a B-bit sensor, and are counted as saturated rather than as
valid data when a 12-bit sensor's images arrive in 16-bit containers unchecked). Every module
that asks "is this pixel saturated?" calls it, or :func:`saturation_count` /
:func:`unsaturated_mask` built on it.

These functions raise :class:`~hdrfringe.errors.InputError` with a one-line message naming
what is wrong and how to fix it.
"""

from __future__ import annotations

import math
import stat
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.errors import InputError

__all__ = [
    "MAX_BIT_DEPTH",
    "SATURATED_MODES",
    "as_stack",
    "check_bit_depth",
    "check_min_modulation",
    "check_regular_file",
    "check_tolerance",
    "describe_saturated",
    "full_scale",
    "is_saturated",
    "json_safe",
    "saturation_count",
    "unsaturated_mask",
]

#: How a decoder treats saturated shifts: ``flag`` (a pixel with one is flagged and, by
#: default, invalid) or ``exclude`` (the shift is left out of the pixel's fit,
#: :func:`hdrfringe.core.saturation.tolerant.decode_set_tolerant`); :data:`hdrfringe.core.decode.
#: SATURATED_MODES` is this tuple.
SATURATED_MODES = ("flag", "exclude")

#: Largest bit depth of a camera or projector value (16-bit containers).
MAX_BIT_DEPTH = 16


def check_bit_depth(bit_depth: object, what: str = "camera bit depth") -> int:
    """``bit_depth`` as an int, checked to be an integer in 1..16.

    Parameters
    ----------
    bit_depth : int
        Bit depth B of a camera or projector value.
    what : str
        Name used in the error message.

    Returns
    -------
    int

    Raises
    ------
    InputError
        When ``bit_depth`` is not an integer in 1..16.

    Examples
    --------
    >>> check_bit_depth(12)
    12
    """
    if isinstance(bit_depth, bool) or not isinstance(bit_depth, int | np.integer):
        if not (isinstance(bit_depth, float) and bit_depth.is_integer()):
            raise InputError(f"{what} must be an integer 1..{MAX_BIT_DEPTH}, got {bit_depth!r}")
    bits = int(bit_depth)
    if not 1 <= bits <= MAX_BIT_DEPTH:
        raise InputError(f"{what} must be an integer 1..{MAX_BIT_DEPTH}, got {bit_depth!r}")
    return bits


def check_regular_file(path: str | Path, what: str, fix: str) -> Path:
    """``path`` as a Path, checked to be an existing regular file (or a link to one).

    A FIFO would block the reader forever, a device could stream without end and a folder
    raises ``IsADirectoryError``: each is refused in one line before the file is opened.

    Parameters
    ----------
    path : str or Path
        The file to read.
    what : str
        What the file is, for messages (``"correction polynomial"``).
    fix : str
        How to fix a missing file (``"train one with train-correction"``).

    Returns
    -------
    Path

    Raises
    ------
    InputError
        ``path`` does not exist, is a folder, or is not a regular file.

    Examples
    --------
    >>> check_regular_file("/dev/null", "correction polynomial", "train one")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: /dev/null: correction polynomial is a character device, not \
a regular file; give the file itself
    """
    p = Path(path)
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        raise InputError(f"{p}: {what} does not exist; {fix}") from None
    except (OSError, ValueError) as exc:  # a NUL byte, a name too long, no permission
        raise InputError(f"{p}: cannot read the {what} ({exc}); {fix}") from None
    if stat.S_ISDIR(mode):
        raise InputError(f"{p}: is a folder, not a {what} file; give the file itself")
    if not stat.S_ISREG(mode):
        kinds = {
            stat.S_ISFIFO: "a FIFO",
            stat.S_ISCHR: "a character device",
            stat.S_ISBLK: "a block device",
            stat.S_ISSOCK: "a socket",
        }
        kind = next((name for test, name in kinds.items() if test(mode)), "a special file")
        raise InputError(f"{p}: {what} is {kind}, not a regular file; give the file itself")
    return p


def full_scale(bit_depth: object, what: str = "camera bit depth") -> int:
    """Full-scale value ``2^B - 1`` of a B-bit camera or projector value.

    Parameters
    ----------
    bit_depth : int
        Bit depth B, 1..16.
    what : str
        Name used in the error message.

    Returns
    -------
    int

    Examples
    --------
    >>> full_scale(8), full_scale(12)
    (255, 4095)
    """
    return (1 << check_bit_depth(bit_depth, what)) - 1


def is_saturated(values: ArrayLike, bit_depth: int) -> NDArray[np.bool_]:
    """The saturation rule: True where a camera value reaches ``2^B - 1``.

    Parameters
    ----------
    values : array_like
        Camera values (any shape).
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    ndarray of bool, same shape as ``values``

    References
    ----------
    Thesis Sec. 5.1: an intensity is saturated when it equals the maximum gray level
    ``2^B - 1`` (255 for an 8-bit camera); Eq. 6.2 marks the saturated shift the same way.

    Examples
    --------
    >>> is_saturated([4094, 4095, 4096], 12).tolist()
    [False, True, True]
    """
    return np.asarray(values) >= full_scale(bit_depth)


def saturation_count(images: ArrayLike, bit_depth: int) -> NDArray[np.unsignedinteger]:
    """Number of images in which each pixel is saturated (:func:`is_saturated`).

    Parameters
    ----------
    images : array_like, shape (N, H, W)
        Phase-shifted images.
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    ndarray of uint8 (N <= 255) or uint16 (more images), shape (H, W)
        The count never wraps: up to :data:`~hdrfringe.limits.MAX_STEPS` shifts are allowed.

    Examples
    --------
    >>> saturation_count(np.array([[[255, 3]], [[255, 255]]]), 8).tolist()
    [[2, 1]]
    >>> int(saturation_count(np.full((256, 1, 1), 255), 8)[0, 0])
    256
    """
    stack = as_stack(images, what="saturation count")
    full = full_scale(bit_depth)
    # One image at a time into a uint8 accumulator: 4x faster than counting a full boolean stack.
    # A wider one past 255 images, where uint8 would wrap (256 saturated images counted as 0).
    count = np.zeros(stack.shape[1:], dtype=np.uint8 if stack.shape[0] <= 255 else np.uint16)
    for image in stack:
        count += image >= full
    return count


def unsaturated_mask(images: ArrayLike, bit_depth: int) -> NDArray[np.bool_]:
    """True where none of the N images is saturated at the pixel (thesis Eq. 5.1's condition).

    Parameters
    ----------
    images : array_like, shape (N, H, W)
        Phase-shifted images of one set.
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    ndarray of bool, shape (H, W)

    References
    ----------
    Thesis Sec. 5.1, Eq. 5.1: the condition ``I_i < 2^B - 1`` for every shift i under which a
    pixel's intensities enter the LPA composite.

    Examples
    --------
    >>> unsaturated_mask(np.array([[[255, 3]], [[4, 5]]]), 8).tolist()
    [[False, True]]
    """
    stack = as_stack(images, what="unsaturated mask")
    full = full_scale(bit_depth)
    out = np.ones(stack.shape[1:], dtype=bool)
    for image in stack:
        out &= image < full
    return out


def as_stack(
    images: ArrayLike,
    *,
    what: str = "images",
    n_min: int = 1,
    n_max: int | None = None,
    bit_depth: int | None = None,
) -> NDArray:
    """``images`` as a numeric array of shape (N, H, W), checked.

    Parameters
    ----------
    images : array_like, shape (N, H, W)
        A stack of camera images, image k at index k.
    what : str
        Name used in error messages (e.g. the function asking).
    n_min, n_max : int
        Allowed number of images N (``n_max`` None: no upper limit).
    bit_depth : int, optional
        When given, integer images are also checked to lie in ``0..2^B - 1`` (one pass over
        the data; leave it out where the caller has checked already).

    Returns
    -------
    ndarray
        The input as an array (no copy when it already is one).

    Examples
    --------
    >>> as_stack(np.zeros((4, 2, 3), np.uint8), n_min=3).shape
    (4, 2, 3)
    """
    arr = np.asarray(images)
    if arr.ndim != 3:
        raise InputError(
            f"{what}: expected a stack of shape (N, height, width), got shape {arr.shape}; "
            "stack the images along axis 0"
        )
    n = arr.shape[0]
    if n < n_min or (n_max is not None and n > n_max):
        allowed = f"at least {n_min}" if n_max is None else f"{n_min}..{n_max}"
        raise InputError(f"{what}: needs {allowed} images, got {n}")
    if arr.dtype.kind not in "uif":
        raise InputError(f"{what}: images must be numeric, got dtype {arr.dtype}")
    if bit_depth is not None and arr.dtype.kind in "ui" and arr.size:
        full = full_scale(bit_depth)
        hi, lo = int(arr.max()), int(arr.min())
        if hi > full:
            raise InputError(
                f"{what}: image values reach {hi}, above 2^B - 1 = {full} for bit depth "
                f"{bit_depth}; pass the bit depth the images were captured with"
            )
        if lo < 0:
            raise InputError(
                f"{what}: image values go down to {lo}; camera counts are never negative, "
                "check the image type"
            )
    return arr


def check_tolerance(value: object) -> float:
    """Check the uniform strategy's saturated fraction allowed (``--tolerance``): 0..1.

    The one check of this value: :class:`~hdrfringe.strategies.uniform.UniformParams`, the
    function :func:`~hdrfringe.strategies.uniform.uniform` and so the command line use it, so
    each refuses the same values with the same message.

    Parameters
    ----------
    value : float
        The fraction of measurement pixels allowed to saturate.

    Returns
    -------
    float
        ``value`` as a float.

    Raises
    ------
    InputError
        Not a finite number in [0, 1] (a percentage such as 5 is pointed out).

    References
    ----------
    Thesis Ch. 4, Sec. 4.2 (the trade-off MIGL the tolerance selects).

    Examples
    --------
    >>> check_tolerance(0.01)
    0.01
    >>> check_tolerance(5)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --tolerance ... in [0, 1], got 5; give 0.05 for 5 %
    """
    try:
        tol = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        tol = math.nan
    if not (math.isfinite(tol) and 0.0 <= tol <= 1.0):
        hint = f"; give {tol / 100:g} for {tol:g} %" if 1.0 < tol <= 100.0 else ""
        raise InputError(
            f"--tolerance (uniform: saturated fraction allowed) must be a fraction in [0, 1], "
            f"got {value}{hint}"
        )
    return tol


def check_min_modulation(value: object, bit_depth: int) -> float | None:
    """Check a minimum modulation ``I'`` (``--min-modulation``): DN in ``0 .. (2^B - 1) / 2``.

    The one check of this value, used by :func:`hdrfringe.core.phase.decode_set` and
    :func:`hdrfringe.core.decode.decode_captures` (and so the command line). A full-swing fringe
    has ``I' = (2^B - 1) / 2``; a larger threshold, a negative one or NaN would make every
    pixel invalid (NaN) or accept noise.

    Parameters
    ----------
    value : float or None
        The threshold in DN; None: the default (returned as None).
    bit_depth : int
        Camera bit depth B.

    Returns
    -------
    float or None
        ``value`` as a float, or None.

    Raises
    ------
    InputError
        Not a finite number of DN in the range.

    References
    ----------
    Thesis Eq. 2.8 (the modulation), Sec. 3.3 (the quality threshold).

    Examples
    --------
    >>> check_min_modulation(12, 8), check_min_modulation(None, 8)
    (12.0, None)
    >>> check_min_modulation(float("nan"), 8)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --min-modulation (min_modulation) must be ... in 0..127.5 ...
    """
    if value is None:
        return None
    top = full_scale(bit_depth) / 2  # I' of a full-swing fringe
    try:
        thr = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        thr = math.nan
    if not (math.isfinite(thr) and 0.0 <= thr <= top):
        raise InputError(
            f"--min-modulation (min_modulation) must be a number of DN in 0..{top:g} (the "
            f"largest modulation of a {bit_depth}-bit camera), got {value}; omit it for the "
            "default"
        )
    return thr


def describe_saturated(count: int, total: int) -> str:
    """How hdrfringe reports saturated pixels: the count, then the share of ``total``.

    A share alone hides small counts ("0.0 %" when 311 of 4.4 million pixels clip); the share
    is given to two significant digits below 1 %.

    Parameters
    ----------
    count : int
        Saturated pixels (:func:`is_saturated` in at least one image).
    total : int
        Pixels they are counted among.

    Returns
    -------
    str
        E.g. ``"311 px (0.0071 %)"``.

    Examples
    --------
    >>> describe_saturated(311, 4_400_000), describe_saturated(0, 100)
    ('311 px (0.0071 %)', '0 px (0 %)')
    >>> describe_saturated(2_000_000, 4_400_000)
    '2000000 px (45.5 %)'
    """
    count, total = int(count), int(total)
    if total <= 0:
        return f"{count} px"
    pct = 100.0 * count / total
    if count == 0:
        share = "0"
    elif pct >= 1.0:
        share = f"{pct:.1f}"
    else:
        share = np.format_float_positional(
            pct, precision=2, unique=False, fractional=False, trim="-"
        )
    return f"{count} px ({share} %)"


def json_safe(value: Any) -> Any:
    """``value`` with non-finite floats as None and tuples as lists (valid JSON).

    Parameters
    ----------
    value : object
        Nested mappings, lists, tuples and scalars.

    Returns
    -------
    object
        The same structure: mappings as dicts, tuples as lists, NaN and inf as None.

    Examples
    --------
    >>> json_safe({"a": (1.0, float("nan")), "b": float("inf")})
    {'a': [1.0, None], 'b': None}
    """
    if isinstance(value, Mapping):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
