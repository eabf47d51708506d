"""Fringe patterns for the projector: sinusoidal and triangular N-step, centerline, uniform gray.

All patterns follow the pattern convention of the capture-folder contract. For a projector
coordinate ``x`` (column for vertical fringes, row for horizontal; pixel centres at integers),
pitch ``p``, steps ``N`` and shift ``i``::

    g_i(x) = imin + (migl - imin) * (1 + P((x + i*p/N) / p)) / 2

with ``P`` of period 1 peaking at 0: ``cos(2*pi*t)`` for sinusoidal fringes (thesis Eq. 2.1,
phase shift ``delta_i = 2*pi*i/N``, Eq. 2.3) and ``1 - 4*|t - round(t)|`` for triangular fringes
(thesis Eq. 2.5 shifted by a quarter pitch; shifts ``(i-1)*T/N``, Eq. 2.7). The gray level sent to
a projector of bit depth ``Bp`` after gamma pre-compensation (thesis Eq. 2.17) is
``round((2^Bp - 1) * (g / (2^Bp - 1)) ** (1 / gamma_hat))``.

What the projector shows, frame by frame, is in :mod:`hdrfringe.frames`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe._validation import check_bit_depth, full_scale
from hdrfringe.errors import InputError

if TYPE_CHECKING:
    from hdrfringe.frames import FringeFrame

__all__ = [
    "ORIENTATIONS",
    "PATTERNS",
    "FringeSpec",
    "Orientation",
    "PatternKind",
    "fringe_gray",
    "fringe_profile",
    "precompensate_gamma",
]

PatternKind = Literal["sinusoidal", "triangular"]
Orientation = Literal["vertical", "horizontal"]

#: The fringe patterns, as :attr:`FringeSpec.pattern` spells them.
PATTERNS: tuple[str, ...] = ("sinusoidal", "triangular")
#: The fringe orientations, as :attr:`FringeSpec.orientation` spells them.
ORIENTATIONS: tuple[str, ...] = ("vertical", "horizontal")


def fringe_profile(t: ArrayLike, pattern: str) -> NDArray[np.float64]:
    """Periodic fringe profile ``P(t)`` of period 1, peaking at ``t = 0`` with value +1.

    Parameters
    ----------
    t : array_like
        Position in periods.
    pattern : {"sinusoidal", "triangular"}
        ``cos(2*pi*t)`` or the triangle wave ``1 - 4*|t - round(t)|``.

    Returns
    -------
    ndarray
        Values in [-1, 1].

    References
    ----------
    Thesis Eq. 2.1 (``cos``) and Eq. 2.5 (the triangle, shifted by a quarter pitch so that it
    peaks at 0 like the cosine); Eq. 3.1 calls it ``f(x)``.

    Examples
    --------
    >>> fringe_profile([0.0, 0.25, 0.5], "triangular").tolist()
    [1.0, 0.0, -1.0]
    """
    t = np.asarray(t, dtype=np.float64)
    if pattern == "sinusoidal":
        return np.cos(2.0 * np.pi * t)
    if pattern == "triangular":
        return 1.0 - 4.0 * np.abs(t - np.round(t))
    raise InputError(f"unknown fringe pattern {pattern!r}; use one of {', '.join(PATTERNS)}")


@dataclass(frozen=True)
class FringeSpec:
    """One phase-shifted fringe set as projected: pattern, steps, pitch, orientation, gray range.

    Parameters
    ----------
    pattern : {"sinusoidal", "triangular"}
        Fringe profile (:func:`fringe_profile`).
    steps : int
        Number of phase shifts N (N >= 3 sinusoidal, N >= 2 triangular).
    pitch_px : float
        Fringe pitch in projector pixels, any positive real number.
    orientation : {"vertical", "horizontal"}
        "vertical": the pattern varies along the projector's x axis (columns).
    imin, migl : float
        Minimum and maximum input gray level (thesis Eq. 3.8-3.9: ``a = (migl + imin)/2``,
        ``b = (migl - imin)/2``), ``0 <= imin < migl``.

    Raises
    ------
    InputError
        When a field is outside the ranges above.

    References
    ----------
    Thesis Eq. 2.1 and Eq. 2.5 (the patterns), Eq. 2.3 and Eq. 2.7 (the shifts, see
    :attr:`shifts`), Eq. 3.8-3.10 (the gray range; MIGL is the thesis's ``I_max``).

    Examples
    --------
    >>> spec = FringeSpec("sinusoidal", steps=4, pitch_px=8, imin=0, migl=200)
    >>> spec.shifts.round(4).tolist()
    [0.0, 1.5708, 3.1416, 4.7124]
    >>> spec.with_migl(150).label()
    's4_p8_v_i0_g150'
    """

    pattern: PatternKind = "sinusoidal"
    steps: int = 3
    pitch_px: float = 6.0
    orientation: Orientation = "vertical"
    imin: float = 40.0
    migl: float = 255.0

    def __post_init__(self) -> None:
        if self.pattern not in PATTERNS:
            raise InputError(
                f"unknown fringe pattern {self.pattern!r}; use one of {', '.join(PATTERNS)}"
            )
        if self.orientation not in ORIENTATIONS:
            raise InputError(
                f"unknown orientation {self.orientation!r}; use one of {', '.join(ORIENTATIONS)}"
            )
        min_steps = 3 if self.pattern == "sinusoidal" else 2
        if int(self.steps) != self.steps or self.steps < min_steps:
            raise InputError(
                f"{self.pattern} fringes need an integer number of steps >= {min_steps}, "
                f"got {self.steps}"
            )
        if not (math.isfinite(self.pitch_px) and self.pitch_px > 0):
            raise InputError(
                f"pitch must be a positive number of projector pixels, got {self.pitch_px}"
            )
        if not (0 <= self.imin < self.migl):
            raise InputError(
                f"need 0 <= imin < migl, got imin={self.imin}, migl={self.migl}; "
                "lower imin or raise migl"
            )

    @property
    def shifts(self) -> NDArray[np.float64]:
        """Phase shifts in radians, ``2*pi*i/N`` for i = 0..N-1."""
        return 2.0 * np.pi * np.arange(self.steps) / self.steps

    def with_migl(self, migl: float) -> FringeSpec:
        """The same set at another maximum input gray level."""
        return FringeSpec(
            self.pattern, self.steps, self.pitch_px, self.orientation, self.imin, migl
        )

    def frames(self) -> list[FringeFrame]:
        """The N frames of this set, shift 0 first."""
        from hdrfringe.frames import FringeFrame

        return [FringeFrame(self, i) for i in range(self.steps)]

    def label(self) -> str:
        """A short file-name-safe label, e.g. ``s4_p8_g255``."""
        pitch = f"{self.pitch_px:g}".replace(".", "p")
        return (
            f"{self.pattern[0]}{self.steps}_p{pitch}_{self.orientation[0]}"
            f"_i{self.imin:g}_g{self.migl:g}"
        )


def fringe_gray(coord: ArrayLike, spec: FringeSpec, shift: int) -> NDArray[np.float64]:
    """Input gray level ``g_i(x)`` of shift ``i`` at projector coordinate ``x``, before gamma.

    Parameters
    ----------
    coord : array_like
        Projector coordinate along the fringe axis (pixel centres at integers); any real value.
    spec : FringeSpec
    shift : int
        Shift index i in 0..N-1.

    Returns
    -------
    ndarray
        Gray level in [imin, migl] (float).

    References
    ----------
    Thesis Eq. 2.1 and Eq. 3.1 with ``a``, ``b`` from Eq. 3.8-3.9 (sinusoidal; the N = 4 case is
    Eq. 6.1), Eq. 2.5 with the shifts of Eq. 2.7 (triangular).

    Examples
    --------
    A 4-step sinusoidal set of pitch 8 between gray levels 0 and 200, at x = 0..3 for shift 1:

    >>> spec = FringeSpec("sinusoidal", steps=4, pitch_px=8, imin=0, migl=200)
    >>> fringe_gray([0, 1, 2, 3], spec, shift=1).round(2).tolist()
    [100.0, 29.29, 0.0, 29.29]
    """
    if not (0 <= shift < spec.steps):
        raise InputError(
            f"shift {shift} is outside 0..{spec.steps - 1} for a {spec.steps}-step set"
        )
    x = np.asarray(coord, dtype=np.float64)
    t = (x + shift * spec.pitch_px / spec.steps) / spec.pitch_px
    return spec.imin + (spec.migl - spec.imin) * (1.0 + fringe_profile(t, spec.pattern)) / 2.0


def precompensate_gamma(
    gray: ArrayLike, gamma_hat: float = 1.0, bit_depth: int = 8
) -> NDArray[np.integer]:
    """Gray level actually sent to the projector: gamma pre-compensation and rounding (Eq. 2.17).

    ``round((2^Bp - 1) * (g / (2^Bp - 1)) ** (1 / gamma_hat))``; with ``gamma_hat = 1`` this is
    only the rounding to the projector's integer levels.

    Parameters
    ----------
    gray : array_like
        Desired (linear) gray level in [0, 2^Bp - 1].
    gamma_hat : float
        Estimated projector gamma; 1.0 for none.
    bit_depth : int
        Projector input bit depth Bp (8 or 16 in practice).

    Returns
    -------
    ndarray of uint8 or uint16
        uint8 for ``bit_depth <= 8``.

    Raises
    ------
    InputError
        When ``gamma_hat`` is not a positive number or ``bit_depth`` is not an integer 1..16.

    References
    ----------
    Thesis Sec. 2.6, Eq. 2.17 (with the projector's nonlinearity ``w = u^gamma`` of Eq. 2.16,
    the light becomes proportional to ``gray``).

    Examples
    --------
    >>> precompensate_gamma([0.0, 63.75, 127.5, 255.0], gamma_hat=2.0).tolist()
    [0, 128, 180, 255]
    >>> precompensate_gamma([99.6, 1000.0], bit_depth=10).tolist()
    [100, 1000]
    """
    if not (math.isfinite(gamma_hat) and gamma_hat > 0):
        raise InputError(f"gamma pre-compensation must be a positive number, got {gamma_hat}")
    bits = check_bit_depth(bit_depth, "projector bit depth")
    full = float(full_scale(bits))
    g = np.clip(np.asarray(gray, dtype=np.float64), 0.0, full)
    if gamma_hat != 1.0:
        g = full * (g / full) ** (1.0 / gamma_hat)
    dtype = np.uint8 if bits <= 8 else np.uint16
    return np.rint(g).astype(dtype)


def same_fringes(a: FringeSpec, b: FringeSpec) -> bool:
    """Whether two sets have the same fringes: pattern, steps, pitch and orientation.

    The gray range (``imin``, ``migl``) may differ: a MIGL sweep holds the same fringes at many
    MIGLs, and a calibration serves any MIGL (thesis Sec. 4.1).

    Parameters
    ----------
    a, b : FringeSpec
        The sets compared.

    Returns
    -------
    bool

    Examples
    --------
    >>> same_fringes(FringeSpec("sinusoidal", 4, 8.0), FringeSpec("sinusoidal", 4, 8.0, migl=200))
    True
    >>> same_fringes(FringeSpec("sinusoidal", 4, 8.0), FringeSpec("sinusoidal", 3, 8.0))
    False
    """
    return (a.pattern, a.steps, a.pitch_px, a.orientation) == (
        b.pattern,
        b.steps,
        b.pitch_px,
        b.orientation,
    )
