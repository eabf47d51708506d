"""Modification of existing captures: simulated added light and noise (thesis Sec. 4.3, Eq. 4.1).

The thesis simulated added ambient light by modifying real images captured without it::

    I*_i(x, y) = min(2^B - 1, I_i(x, y) + D(x, y))                          (Eq. 4.1)

with ``D`` uniform, the gray level of a given illuminance on the white plate (0.17 gray level/lux
at 8 bits, Fig. 4.14c), optionally plus zero-mean Gaussian intensity noise (Sec. 4.3.1, sigma 1 to
8 gray levels).

:func:`modify_intensity` is the one implementation of Eq. 4.1 (float64 for the ``modify``
command through :func:`modify_captures`, which checks its input and draws the noise; float32
for the reproduction's Sec. 4.3 sweep, with pre-drawn noise).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from hdrfringe.core._validation import full_scale
from hdrfringe.errors import InputError

__all__ = ["lux_to_dn", "modify_captures", "modify_intensity"]

_THESIS_DN_PER_LUX = 0.17


def lux_to_dn(lux: ArrayLike, bit_depth: int, dn_per_lux: float = _THESIS_DN_PER_LUX) -> NDArray:
    """Camera DN at bit depth B for an illuminance in lux (8-bit slope scaled by (2^B-1)/255).

    Parameters
    ----------
    lux : float or array_like
        Added illuminance on the white plate, in lux.
    bit_depth : int
        Camera bit depth B of the DN returned.
    dn_per_lux : float
        8-bit gray levels per lux (thesis 0.17).

    Returns
    -------
    ndarray of float64
        ``lux * dn_per_lux * (2^B - 1) / 255``, same shape as ``lux``.

    Examples
    --------
    >>> round(float(lux_to_dn(600, 8)), 9)
    102.0
    >>> lux_to_dn([0, 100], 12).round(3).tolist()  # the same light at 12 bits
    [0.0, 273.0]

    References
    ----------
    Thesis Fig. 4.14c (0.17 gray level per lux on the white plate, 8 bits).
    """
    if (
        isinstance(dn_per_lux, bool)
        or not (isinstance(dn_per_lux, int | float | np.number) and math.isfinite(dn_per_lux))
        or dn_per_lux < 0
    ):
        raise InputError(
            f"dn_per_lux must be a finite number >= 0 (8-bit gray levels per lux, thesis 0.17), "
            f"got {dn_per_lux!r}; added light never darkens"
        )
    return np.asarray(lux, dtype=np.float64) * dn_per_lux * full_scale(bit_depth) / 255.0


def modify_intensity(
    images: NDArray[np.integer],
    bit_depth: int,
    added_dn: ArrayLike = 0.0,
    noise: ArrayLike | None = None,
    *,
    dtype: DTypeLike = np.float64,
) -> NDArray[np.integer]:
    """Thesis Eq. 4.1: ``I* = clip(rint(I + D + n), 0, 2^B - 1)``, computed in ``dtype``.

    The one implementation of Eq. 4.1, unchecked (a sweep calls it millions of times):
    :func:`modify_captures` checks the images and draws the noise for the ``modify`` command.

    Parameters
    ----------
    images : ndarray of unsigned integers
        Captured images, any shape, values in [0, 2^B - 1].
    bit_depth : int
        Camera bit depth B.
    added_dn : float or array_like
        Added intensity ``D`` in DN, broadcasting to the images' shape (cast to ``dtype``
        before it is added).
    noise : array_like, optional
        Added noise ``n`` in DN, already drawn and scaled to its standard deviation,
        broadcasting to the images' shape.
    dtype : {float64, float32}
        Precision of the sum: float64 for :func:`modify_captures`, float32 for sweeps. Without
        noise the two agree exactly when ``D`` is a whole number of DN.

    Returns
    -------
    ndarray
        The modified images, same shape and dtype as ``images``.

    Examples
    --------
    >>> modify_intensity(np.array([100, 200], dtype=np.uint8), 8, 102.0).tolist()
    [202, 255]
    >>> modify_intensity(np.array([10], np.uint8), 8, 0.0, np.array([-20.3]), dtype=np.float32)
    array([0], dtype=uint8)

    References
    ----------
    Thesis Eq. 4.1 (Sec. 4.3).
    """
    dt = np.dtype(dtype)
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise InputError(f"Eq. 4.1: dtype must be float32 or float64, got {dt}")
    out = images.astype(dt)
    out += np.asarray(added_dn, dtype=dt)
    if noise is not None:
        out += noise
    np.rint(out, out=out)
    np.clip(out, 0, full_scale(bit_depth), out=out)
    return out.astype(images.dtype)


def modify_captures(
    images: ArrayLike,
    bit_depth: int,
    add_dn: ArrayLike = 0.0,
    add_lux: ArrayLike | None = None,
    dn_per_lux: float = _THESIS_DN_PER_LUX,
    noise_sigma: float = 0.0,
    seed: int | np.random.Generator | None = 0,
) -> NDArray[np.integer]:
    """Add light and noise to captured images with sensor clipping (thesis Eq. 4.1).

    ``I* = clip(round(I + D + n), 0, 2^B - 1)`` with ``D = add_dn + lux_to_dn(add_lux)`` and
    ``n`` zero-mean Gaussian noise of standard deviation ``noise_sigma``; without noise and for
    ``D >= 0`` this is exactly ``min(2^B - 1, I + D)``.

    Parameters
    ----------
    images : array_like of unsigned integers
        Captured images, any shape (e.g. (n, H, W) or (H, W)), values in [0, 2^B - 1].
    bit_depth : int
        Camera bit depth B of the images.
    add_dn : float or array_like
        Added intensity ``D`` in DN of the images' bit depth; an array broadcasts against the
        images (e.g. a (H, W) distribution applied to every frame).
    add_lux : float or array_like, optional
        Added illuminance in lux, converted with ``dn_per_lux`` (8-bit gray levels per lux,
        thesis 0.17) scaled to B bits; added to ``add_dn``.
    dn_per_lux : float
        Conversion slope at 8 bits.
    noise_sigma : float
        Standard deviation of the added zero-mean Gaussian noise, in DN of the images.
    seed : int, Generator or None
        Noise seed (ignored without noise).

    Returns
    -------
    ndarray
        The modified images, same shape and dtype as ``images``.

    Examples
    --------
    >>> import numpy as np
    >>> modify_captures(np.array([100, 200], dtype=np.uint8), 8, add_lux=600).tolist()
    [202, 255]

    References
    ----------
    Thesis Eq. 4.1 and Sec. 4.3.1 (added light and Gaussian noise).
    """
    arr = np.asarray(images)
    if arr.dtype.kind not in "ui":
        raise InputError(
            f"images must hold integer camera values, got dtype {arr.dtype}; "
            "pass the captured uint8/uint16 arrays"
        )
    full = full_scale(bit_depth)
    if arr.size and (int(arr.min()) < 0 or int(arr.max()) > full):
        raise InputError(
            f"image values must lie in 0..{full} for a {bit_depth}-bit camera, found "
            f"{int(arr.min())}..{int(arr.max())}; check bit_depth"
        )
    if np.iinfo(arr.dtype).max < full:
        raise InputError(f"dtype {arr.dtype} cannot hold {bit_depth}-bit values; use uint16 images")
    if not (math.isfinite(noise_sigma) and noise_sigma >= 0):
        raise InputError(f"noise_sigma must be a finite number >= 0, got {noise_sigma}")
    d = np.asarray(add_dn, dtype=np.float64)
    if add_lux is not None:
        d = d + lux_to_dn(add_lux, bit_depth, dn_per_lux)
    if not np.all(np.isfinite(d)):
        raise InputError("added intensity D must be finite everywhere")
    try:
        shape = np.broadcast_shapes(arr.shape, d.shape)
    except ValueError:
        raise InputError(
            f"added intensity of shape {d.shape} does not broadcast to images of shape {arr.shape}"
        ) from None
    if shape != arr.shape:
        raise InputError(
            f"added intensity of shape {d.shape} would change the images' shape {arr.shape}"
        )
    noise = None
    if noise_sigma > 0:
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        noise = noise_sigma * rng.standard_normal(arr.shape)
    return modify_intensity(arr, bit_depth, d, noise)
