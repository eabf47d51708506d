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

A sinusoidal set may declare other shift angles and a phase offset (capture format version 3,
:attr:`FringeSpec.shifts_deg`, :attr:`FringeSpec.phase_offset_deg`): shift ``i`` then shows
``cos(2*pi*x/p + phase_offset + delta_i)`` with ``delta_i = radians(shifts_deg[i])``, and
decoding still returns ``2*pi*x/p`` (the offset removed).

A set's frames (:meth:`FringeSpec.frames`) are :class:`FringeFrame` objects, defined here so that
this module needs nothing from :mod:`hdrfringe.core.frames`; the other frames, and everything about
rendering and manifests, are in :mod:`hdrfringe.core.frames`, which re-exports :class:`FringeFrame`.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core._validation import check_bit_depth, full_scale
from hdrfringe.errors import InputError

__all__ = [
    "MAX_ANGLE_DEG",
    "ORIENTATIONS",
    "PATTERNS",
    "FringeFrame",
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


#: Largest |angle| in degrees accepted for a shift or phase offset: beyond ~1e6 degrees an
#: angle can no longer be reduced modulo 360 to the 1e-9 degrees that tell the contract's
#: shifts apart (float64 spacing at 1e6 is 1.2e-10), so 1e308 would decode to noise.
MAX_ANGLE_DEG = 1.0e6


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
    shifts_deg : tuple of float, optional
        Sinusoidal sets only: the phase shift of each shift index in degrees, ``delta_i =
        radians(shifts_deg[i])``, N distinct values (modulo 360) in any order and sign, e.g.
        ``(-120, 0, 120)``. None (default): the contract's equal shifts ``360*i/N``; a tuple
        equal to those (modulo 360, within 1e-9 degrees) is stored as None, so it is the same
        set.
    phase_offset_deg : float
        Sinusoidal sets only: a constant phase added to every shift, in degrees (0: the
        contract's cosine). A sine profile ``sin(t) = cos(t - pi/2)`` is ``-90``.
    gray_levels_given : bool
        False when the capture manifest gave no ``imin``/``migl`` (version 3): ``imin`` and
        ``migl`` then hold the documented defaults 0 and ``2^Bp - 1``, which serve decoding
        (the phase does not depend on them) but not the features that need the true levels
        (gamma from fringes, MIGL strategies), which refuse such sets. Such a set's label
        leaves the levels out (``s3_p8_v``).

    Raises
    ------
    InputError
        When a field is outside the ranges above, or a triangular set declares shift angles or
        an offset.

    Notes
    -----
    Shift ``i`` shows ``imin + (migl - imin) * (1 + cos(2*pi*x/p + phase_offset + delta_i))/2``
    (docs/capture_format.md, "Version 3 extensions"); with the defaults this is the contract's
    ``P((x + i*p/N)/p)``. Decoding returns ``2*pi*x/p`` whatever the shifts and offset
    (:func:`hdrfringe.core.phase.decode_set`).

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
    >>> FringeSpec(steps=3, shifts_deg=(-120, 0, 120), phase_offset_deg=-90).label()
    's3_p6_v_i40_g255_o-90_d-120_0_120'
    >>> FringeSpec(steps=3, shifts_deg=(0, 120, -120)).shifts_deg is None  # the contract's
    True
    """

    pattern: PatternKind = "sinusoidal"
    steps: int = 3
    pitch_px: float = 6.0
    orientation: Orientation = "vertical"
    imin: float = 40.0
    migl: float = 255.0
    shifts_deg: tuple[float, ...] | None = None
    phase_offset_deg: float = 0.0
    gray_levels_given: bool = True

    def __post_init__(self) -> None:
        if self.pattern not in PATTERNS:
            raise InputError(
                f"unknown fringe pattern {self.pattern!r}; use one of {', '.join(PATTERNS)}"
            )
        if self.orientation not in ORIENTATIONS:
            raise InputError(
                f"unknown orientation {self.orientation!r}; use one of {', '.join(ORIENTATIONS)}"
            )
        for name in ("steps", "pitch_px", "imin", "migl"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float | np.number):
                raise InputError(
                    f"FringeSpec {name} must be a number, got {type(value).__name__} {value!r}"
                    + (f"; write {name}={value.strip()}" if isinstance(value, str) else "")
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
        self._check_phase()

    def _check_phase(self) -> None:
        """Validate and normalise ``shifts_deg`` and ``phase_offset_deg`` (version 3)."""
        offset = self.phase_offset_deg
        if isinstance(offset, bool) or not isinstance(offset, int | float | np.number):
            raise InputError(f"phase_offset_deg must be a number of degrees, got {offset!r}")
        offset = float(offset)
        if not (math.isfinite(offset) and abs(offset) <= MAX_ANGLE_DEG):
            raise InputError(
                f"phase_offset_deg must be a finite angle within +-{MAX_ANGLE_DEG:g} degrees, "
                f"got {offset}; reduce it modulo 360"
            )
        object.__setattr__(self, "phase_offset_deg", offset + 0.0)  # -0.0 -> 0.0
        shifts = self.shifts_deg
        if shifts is not None:
            if isinstance(shifts, str) or not hasattr(shifts, "__len__"):
                raise InputError(f"shifts_deg must be a sequence of degrees, got {shifts!r}")
            values = []
            for v in shifts:
                if isinstance(v, bool) or not isinstance(v, int | float | np.number):
                    raise InputError(f"shifts_deg must hold numbers of degrees, got {v!r}")
                if not (math.isfinite(float(v)) and abs(float(v)) <= MAX_ANGLE_DEG):
                    raise InputError(
                        f"shifts_deg must hold finite angles within +-{MAX_ANGLE_DEG:g} degrees, "
                        f"got {v}; reduce it modulo 360"
                    )
                values.append(float(v) + 0.0)
            if len(values) != self.steps:
                raise InputError(
                    f"shifts_deg has {len(values)} angles for a {self.steps}-step set; give one "
                    "per shift index"
                )
            wrapped = [round(v % 360.0, 9) % 360.0 for v in values]
            if len(set(wrapped)) != len(wrapped):
                raise InputError(
                    f"shifts_deg {_fmt_degrees(values)} repeats an angle (modulo 360); the "
                    "shifts of a set must be distinct"
                )
            equal = [360.0 * i / self.steps for i in range(self.steps)]
            if all(abs(_wrap180(v - e)) <= 1e-9 for v, e in zip(values, equal, strict=True)):
                shifts = None  # the contract's equal shifts: one representation
            else:
                shifts = tuple(values)
            object.__setattr__(self, "shifts_deg", shifts)
        if self.pattern != "sinusoidal" and (shifts is not None or offset != 0.0):
            raise InputError(
                f"{self.pattern} fringes follow the contract's shifts only; shifts_deg and "
                "phase_offset_deg apply to sinusoidal sets (leave them out for this set)"
            )

    @property
    def has_standard_phase(self) -> bool:
        """Whether the set uses the contract's equal shifts and no phase offset.

        Such sets are version 1 of the capture format; others need version 3.

        Returns
        -------
        bool

        Examples
        --------
        >>> FringeSpec().has_standard_phase, FringeSpec(phase_offset_deg=-90).has_standard_phase
        (True, False)
        """
        return self.shifts_deg is None and self.phase_offset_deg == 0.0

    @property
    def shifts(self) -> NDArray[np.float64]:
        """Phase shifts ``delta_i`` in radians: ``2*pi*i/N``, or ``radians(shifts_deg)``.

        The phase offset is not included (see :attr:`phase_offset_deg`).
        """
        if self.shifts_deg is None:
            return 2.0 * np.pi * np.arange(self.steps) / self.steps
        return np.radians(np.asarray(self.shifts_deg, dtype=np.float64))

    def with_migl(self, migl: float) -> FringeSpec:
        """The same set at another maximum input gray level."""
        return replace(self, migl=migl)

    def frames(self) -> list[FringeFrame]:
        """The N frames of this set, shift 0 first."""
        return [FringeFrame(self, i) for i in range(self.steps)]

    def label(self) -> str:
        """A short file-name-safe label, e.g. ``s4_p8_g255``."""
        pitch = f"{self.pitch_px:g}".replace(".", "p")
        label = f"{self.pattern[0]}{self.steps}_p{pitch}_{self.orientation[0]}"
        if self.gray_levels_given:
            label += f"_i{self.imin:g}_g{self.migl:g}"
        if self.phase_offset_deg != 0.0:
            label += "_o" + f"{self.phase_offset_deg:g}".replace(".", "p")
        if self.shifts_deg is not None:
            if len(self.shifts_deg) <= 8:
                label += "_d" + "_".join(f"{v:g}".replace(".", "p") for v in self.shifts_deg)
            else:  # many shifts: a digest of the angles keeps the label short
                text = ",".join(repr(v) for v in self.shifts_deg)
                label += "_d" + hashlib.sha256(text.encode()).hexdigest()[:8]
        return label


def fringe_gray(
    coord: ArrayLike, spec: FringeSpec, shift: int, migl: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Input gray level ``g_i(x)`` of shift ``i`` at projector coordinate ``x``, before gamma.

    Parameters
    ----------
    coord : array_like
        Projector coordinate along the fringe axis (pixel centres at integers); any real value.
    spec : FringeSpec
    shift : int
        Shift index i in 0..N-1.
    migl : array_like, optional
        A MIGL per coordinate (broadcast against ``coord``) in place of ``spec.migl``: the
        per-pixel adaptive projection's frames
        (:class:`~hdrfringe.core.frames.PixelwiseFringeFrame`)
        are this equation with a MIGL map.

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
    if spec.has_standard_phase:
        t = (x + shift * spec.pitch_px / spec.steps) / spec.pitch_px
    else:  # version 3: cos(2*pi*x/p + offset + delta_i), with the angles in periods
        if spec.shifts_deg is not None:
            turn = (spec.phase_offset_deg + spec.shifts_deg[shift]) / 360.0
        else:
            turn = spec.phase_offset_deg / 360.0 + shift / spec.steps
        t = x / spec.pitch_px + turn
    top = spec.migl if migl is None else np.asarray(migl, dtype=np.float64)
    return spec.imin + (top - spec.imin) * (1.0 + fringe_profile(t, spec.pattern)) / 2.0


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
    g = np.asarray(gray)
    if g.dtype != np.float32 or gamma_hat != 1.0:
        # float32 levels only rounded (no gamma): the same integers in float32 (exact in
        # float64, the same rounding), at half the memory traffic (a projector image per frame)
        g = g.astype(np.float64, copy=False)
    if not np.isfinite(g).all():  # NaN would be sent as gray 0, inf as full scale
        bad = g[~np.isfinite(g)].ravel()[0]
        raise InputError(
            f"gray holds {np.count_nonzero(~np.isfinite(g))} non-finite value(s) (e.g. {bad}); "
            "give gray levels in 0..2^Bp - 1"
        )
    g = np.clip(g, 0.0, full)
    if gamma_hat != 1.0:
        g = full * (g / full) ** (1.0 / gamma_hat)
    dtype = np.uint8 if bits <= 8 else np.uint16
    return np.rint(g).astype(dtype)


def same_fringes(a: FringeSpec, b: FringeSpec) -> bool:
    """Whether two sets have the same fringes: pattern, steps, pitch and orientation.

    The gray range (``imin``, ``migl``) may differ: a MIGL sweep holds the same fringes at many
    MIGLs, and a calibration serves any MIGL (thesis Sec. 4.1). So may the shift angles and the
    phase offset (capture format version 3): every set decodes to ``2*pi*x/p`` whatever they
    are, so a calibration made with one convention serves another.

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


def _wrap180(deg: float) -> float:
    """An angle in degrees wrapped to [-180, 180)."""
    return (deg + 180.0) % 360.0 - 180.0


def _fmt_degrees(values: list[float] | tuple[float, ...]) -> str:
    return "(" + ", ".join(f"{v:g}" for v in values) + ")"


# --- the fringe frame (here, not in frames.py, so FringeSpec.frames() needs no import of
# frames.py: frames.py builds on this module, never the other way; issue 29) ------------


class _LineFrameMethods:
    """What the line frames share: they vary along one projector axis, so a full image is one
    rendered line broadcast along the other axis (the separable fast path)."""

    def gray(self, coord: ArrayLike) -> NDArray[np.float64]:  # pragma: no cover - abstract
        raise NotImplementedError

    def _axis(self) -> Orientation:  # pragma: no cover - abstract
        """The projector axis the frame varies along (:func:`hdrfringe.core.frames.frame_axis`)."""
        raise NotImplementedError

    def _check_levels(self, bit_depth: int) -> None:
        """Refuse gray levels the projector cannot show (none to check by default)."""

    def gray_at(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """Linear gray level at continuous projector coordinates (column ``u``, row ``v``).

        Parameters
        ----------
        u, v : array_like
            Projector column and row, broadcast together.

        Returns
        -------
        ndarray of float64
        """
        return _line_gray_at(self, u, v)

    def render(
        self, width: int, height: int, gamma_hat: float = 1.0, bit_depth: int = 8
    ) -> NDArray[np.integer]:
        """Projector input image, shape (height, width); see :func:`render_frame`.

        Parameters
        ----------
        width, height : int
            Projector resolution.
        gamma_hat : float
            Gamma pre-compensation exponent (1.0: none).
        bit_depth : int
            Projector input bit depth.

        Returns
        -------
        ndarray of uint8 or uint16
        """
        self._check_levels(bit_depth)
        return _render_line(self, width, height, gamma_hat, bit_depth)


@dataclass(frozen=True)
class FringeFrame(_LineFrameMethods):
    """Shift ``shift`` of the fringe set ``spec`` (a line frame).

    Parameters
    ----------
    spec : FringeSpec
        Pattern, steps, pitch, orientation, imin and MIGL of the set, and for sinusoidal sets
        its shift angles and phase offset (version 3 of the capture format).
    shift : int
        Shift index i in 0..N-1 (its angle is ``spec.shifts[i]``).

    References
    ----------
    Pattern convention: docs/capture_format.md; thesis Eq. 2.1 (sinusoidal), Eq. 2.5 (triangular).

    Examples
    --------
    >>> frame = FringeFrame(FringeSpec(steps=4, pitch_px=8.0, imin=0.0, migl=200.0), 0)
    >>> frame.gray([0.0, 4.0]).tolist()
    [200.0, 0.0]
    >>> sine = FringeSpec(steps=3, pitch_px=8.0, imin=0.0, migl=200.0, phase_offset_deg=-90)
    >>> FringeFrame(sine, 0).gray([0.0, 2.0]).round(6).tolist()
    [100.0, 200.0]
    >>> FringeFrame(sine, 0).manifest_entry("a.png")["phase_offset_deg"]
    -90
    """

    spec: FringeSpec
    shift: int

    kind: str = field(default="fringe", init=False)

    def gray(self, coord: ArrayLike) -> NDArray[np.float64]:
        """Linear gray level at projector coordinates along the fringe axis.

        Parameters
        ----------
        coord : array_like
            Projector column (vertical fringes) or row (horizontal); pixel centres at integers.

        Returns
        -------
        ndarray of float64
        """
        return fringe_gray(coord, self.spec, self.shift)

    def _axis(self) -> Orientation:
        return self.spec.orientation

    def _check_levels(self, bit_depth: int) -> None:
        full = full_scale(bit_depth, "projector bit depth")
        if self.spec.migl > full:
            raise InputError(
                f"migl {self.spec.migl:g} exceeds the projector's maximum {full} at "
                f"{bit_depth} bits"
            )

    def manifest_entry(self, file: str) -> dict[str, Any]:
        """The frame's capture-manifest entry (docs/capture_format.md).

        Parameters
        ----------
        file : str
            Image file name the entry refers to.

        Returns
        -------
        dict
        """
        s = self.spec
        entry: dict[str, Any] = {
            "file": file,
            "kind": "fringe",
            "pattern": s.pattern,
            "steps": int(s.steps),
            "shift": int(self.shift),
            "pitch": float(s.pitch_px),
            "orientation": s.orientation,
            "imin": _num(s.imin),
            "migl": _num(s.migl),
        }
        # version 3 (docs/capture_format.md): only where the set needs them, so a standard set's
        # entry stays the version-1 entry byte for byte
        if not s.gray_levels_given:
            del entry["imin"], entry["migl"]
        if s.shifts_deg is not None:
            entry["shift_deg"] = _num(s.shifts_deg[self.shift])
        if s.phase_offset_deg != 0.0:
            entry["phase_offset_deg"] = _num(s.phase_offset_deg)
        return entry

    def default_name(self) -> str:
        """A file-name-safe stem, e.g. ``s3_p6_v_i40_g255_0``.

        Returns
        -------
        str
        """
        return f"{self.spec.label()}_{self.shift}"


def _line_gray_at(frame: Any, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    uu, vv = np.broadcast_arrays(np.asarray(u, np.float64), np.asarray(v, np.float64))
    return frame.gray(uu if frame._axis() == "vertical" else vv)


def _render_line(
    frame: Any, width: int, height: int, gamma_hat: float, bit_depth: int
) -> NDArray[np.integer]:
    """The separable path: one line along the frame's axis, broadcast to the full image."""
    if width < 1 or height < 1:
        raise InputError(f"projector resolution must be positive, got {width}x{height}")
    axis = frame._axis()
    n = width if axis == "vertical" else height
    line = precompensate_gamma(frame.gray(np.arange(n)), gamma_hat, bit_depth)
    if axis == "vertical":
        return np.ascontiguousarray(np.broadcast_to(line[None, :], (height, width)))
    return np.ascontiguousarray(np.broadcast_to(line[:, None], (height, width)))


def _num(v: float) -> float | int:
    """JSON-friendly number: an int when integral."""
    f = float(v)
    return int(f) if f.is_integer() else f
