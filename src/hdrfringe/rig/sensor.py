"""The camera's readout: sensor noise, quantisation and clipping of a noise-free signal.

Thesis Eq. 3.3 gives the noise-free intensity a pixel receives; a camera then reads it with
noise, rounds it to an integer and clips it to its range ``[0, 2^B - 1]`` (saturation,
thesis Ch. 3). :func:`sensor_readout` is that last step, the one implementation shared by
the virtual rig (:meth:`hdrfringe.rig.simulated.SimulatedRig.capture`, float64) and the
reproduction's sweeps (:mod:`hdrfringe_thesis.ch4`, float32 with common random numbers).

It lives apart from :mod:`hdrfringe.rig.simulated` because it needs none of the rig's
geometry or radiometry, only the sensor's noise parameters (:class:`SensorParameters`, which
:class:`~hdrfringe.rig.simulated.CameraModel` provides): the sweeps compute their own signal
and call it directly.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from hdrfringe.errors import InputError

__all__ = ["SensorParameters", "sensor_readout"]


# A protocol has no constructor: numpydoc reads the (*args, **kwargs) of typing.Protocol as one.
class SensorParameters(Protocol):  # numpydoc ignore=PR01
    """What :func:`sensor_readout` needs of a camera (a
    :class:`~hdrfringe.rig.simulated.CameraModel`).

    Attributes
    ----------
    read_noise_dn : float
        Gaussian read-noise standard deviation in DN (0: none).
    full_well_e : float or None
        Electrons at full scale, setting the shot noise (None: none).
    full_scale : int
        Saturation value ``2^B - 1``.
    dtype : type
        Integer type of the images (uint8 for B <= 8, else uint16).

    References
    ----------
    Thesis Sec. 3.1 (saturation at ``2^B - 1``).

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel
    >>> cam: SensorParameters = CameraModel(bit_depth=12)
    >>> cam.full_scale, round(cam.read_noise_dn, 3), cam.dtype.__name__
    (4095, 16.059, 'uint16')
    """

    @property
    def read_noise_dn(self) -> float: ...

    @property
    def full_well_e(self) -> float | None: ...

    @property
    def full_scale(self) -> int: ...

    @property
    def dtype(self) -> type[np.unsignedinteger]: ...


def sensor_readout(
    signal: ArrayLike,
    camera: SensorParameters,
    rng: np.random.Generator | None = None,
    *,
    normals: ArrayLike | None = None,
    dtype: DTypeLike = np.float64,
    gain: float = 1.0,
) -> NDArray[np.unsignedinteger]:
    """Camera values of a noise-free signal: read and shot noise, rounding, clipping.

    ``I = clip(rint(s + sqrt(sigma_r^2 + g * max(s, 0)) * z), 0, 2^B - 1)`` with ``s`` the
    signal in DN, ``sigma_r`` the read noise, ``g = (2^B - 1) / full_well`` the shot-noise gain
    (a signal of ``s`` DN holds ``s / g`` electrons, Poisson: variance ``g * s`` DN^2, here in
    its Gaussian approximation) and ``z`` standard normal draws. Without read and shot noise
    nothing is drawn and the signal is only rounded and clipped.

    Parameters
    ----------
    signal : array_like
        Noise-free signal in DN, any shape (one image or a stack).
    camera : SensorParameters
        The camera (:class:`~hdrfringe.rig.simulated.CameraModel`).
    rng : numpy.random.Generator, optional
        Source of the standard normal draws, drawn in ``dtype``.
    normals : array_like, optional
        The standard normal draws themselves, same shape as ``signal`` (common random numbers:
        captures that share them differ by their signals alone); used instead of ``rng``.
    dtype : {float64, float32}
        Precision of the computation (and of the draws from ``rng``): float64 for the virtual
        rig, float32 for the sweeps. The two draw different numbers from the same generator.
    gain : float
        Linear analogue gain ``G`` the signal was already scaled by: the read noise and the
        shot-noise gain scale by it too (1.0: the camera's reference gain).

    Returns
    -------
    ndarray of ``camera.dtype``, same shape as ``signal``

    Raises
    ------
    InputError
        When the camera has noise but neither ``rng`` nor ``normals`` is given, or
        ``normals`` does not have the signal's shape.

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel
    >>> cam = CameraModel(read_noise_dn8=0.0, full_well_e=None)
    >>> sensor_readout(np.array([-3.0, 10.4, 300.0]), cam).tolist()
    [0, 10, 255]
    >>> noisy = sensor_readout(np.full(1000, 100.0), CameraModel(), np.random.default_rng(0))
    >>> 1.4 < float(noisy.std()) < 1.7  # sqrt(1 + 255/20000 * 100 + 1/12) = 1.54
    True

    References
    ----------
    Thesis Eq. 3.3 (the signal) and Sec. 3.1 (saturation at ``2^B - 1``).
    """
    dt = np.dtype(dtype)
    scalar: type[np.float32] | type[np.float64]
    if dt == np.dtype(np.float32):
        scalar = np.float32
    elif dt == np.dtype(np.float64):
        scalar = np.float64
    else:
        raise InputError(f"sensor readout: dtype must be float32 or float64, got {dt}")
    s = np.asarray(signal).astype(dt, copy=False)
    read = scalar(camera.read_noise_dn * gain)
    well = camera.full_well_e
    shot = scalar((camera.full_scale / well if well is not None else 0.0) * gain)
    if read > 0 or shot > 0:
        if normals is not None:
            z = np.asarray(normals).astype(dt, copy=False)
            if z.shape != s.shape:
                raise InputError(
                    f"sensor readout: normal draws of shape {z.shape} for a signal of shape "
                    f"{s.shape}; give one draw per signal value"
                )
        elif rng is not None:
            z = rng.standard_normal(s.shape, dtype=scalar)
        else:
            raise InputError(
                "sensor readout: the camera has read or shot noise; give a generator (rng) "
                "or the normal draws (normals)"
            )
        # In place on one temporary: std = sqrt(read^2 + shot * max(s, 0)), then s + std * z.
        noisy = np.maximum(s, 0)
        noisy *= shot
        noisy += read * read
        np.sqrt(noisy, out=noisy)
        noisy *= z
        noisy += s
    else:
        noisy = s.copy()
    np.rint(noisy, out=noisy)
    np.clip(noisy, 0, camera.full_scale, out=noisy)
    return noisy.astype(camera.dtype)
