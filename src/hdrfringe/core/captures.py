"""What a rig saw: the in-memory :class:`Captures` and the projector and camera descriptions.

A :class:`Captures` is a capture folder's content held in memory: the frames that were
projected, one camera image per frame, the camera bit depth, projector and camera descriptions,
the scene, per-frame exposure and set labels, and float maps such as the ground-truth height.
It holds data, not paths: :mod:`hdrfringe.io.captures` reads and writes it as a capture folder
(docs/capture_format.md), rigs produce it, and the pipeline (:mod:`hdrfringe.core.decode`) consumes
it.

This module is core: it imports nothing above the core layer and touches no file.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core._validation import check_bit_depth, full_scale
from hdrfringe.core.frames import (
    IMAGE_FRAMES,
    CenterlineFrame,
    Frame,
    FringeFrame,
    GrayCodeFrame,
    PixelwiseFringeFrame,
    UniformFrame,
    frame_from_manifest,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import CaptureFormatError, HdrFringeError, InputError

if TYPE_CHECKING:
    from collections.abc import Callable

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "FORMAT_VERSIONS",
    "GAIN_DB_RANGE",
    "CameraSettings",
    "Captures",
    "FringeSet",
    "GrayCodeSet",
    "ProjectorInfo",
    "frames_format_version",
    "group_fringe_sets",
    "group_graycode_sets",
    "partial_set_frames",
]

#: The capture manifest's ``format`` field (docs/capture_format.md).
FORMAT_NAME = "hdrfringe-captures"
#: The newest capture-folder contract version this hdrfringe reads and writes.
FORMAT_VERSION = 3
#: Every capture-folder contract version this hdrfringe reads. It writes the lowest version the
#: captures fit in (:attr:`Captures.format_version`), so folders stay readable by older readers.
FORMAT_VERSIONS = (1, 2, 3)
#: The camera gains (dB) a frame may record, inclusive.
GAIN_DB_RANGE = (-20.0, 48.0)


@dataclass(frozen=True)
class ProjectorInfo:
    """Projector input as recorded in a capture manifest's ``projector`` entry.

    Parameters
    ----------
    width, height : int
        Projector resolution in pixels.
    bit_depth : int
        Projector input bit depth Bp.
    gamma_precompensation : float
        Exponent gamma-hat used when the patterns were generated (thesis Eq. 2.17; 1.0: none).

    Examples
    --------
    >>> ProjectorInfo().to_manifest()["width"]
    1024
    """

    width: int = 1024
    height: int = 768
    bit_depth: int = 8
    gamma_precompensation: float = 1.0

    def to_manifest(self) -> dict[str, Any]:
        """The manifest's ``projector`` entry.

        Returns
        -------
        dict
        """
        return {
            "width": int(self.width),
            "height": int(self.height),
            "bit_depth": int(self.bit_depth),
            "gamma_precompensation": float(self.gamma_precompensation),
        }

    @classmethod
    def from_manifest(cls, entry: Mapping[str, Any]) -> ProjectorInfo:
        """From a manifest's (validated) ``projector`` entry; absent fields take the defaults.

        Parameters
        ----------
        entry : mapping
            Optional ``width``, ``height``, ``bit_depth``, ``gamma_precompensation``.

        Returns
        -------
        ProjectorInfo

        Examples
        --------
        >>> ProjectorInfo.from_manifest({"gamma_precompensation": 2.2})
        ProjectorInfo(width=1024, height=768, bit_depth=8, gamma_precompensation=2.2)
        """
        return cls(
            width=int(entry.get("width", 1024)),
            height=int(entry.get("height", 768)),
            bit_depth=int(entry.get("bit_depth", 8)),
            gamma_precompensation=float(entry.get("gamma_precompensation", 1.0)),
        )


@dataclass(frozen=True)
class CameraSettings:
    """Camera settings a capture is taken with (None: leave the rig's current setting).

    Parameters
    ----------
    exposure_ms : float, optional
        Exposure time in milliseconds. On the virtual rig the signal of thesis Eq. 3.3 scales
        linearly with it (noise and clipping follow).
    gain_db : float, optional
        Analogue gain in dB (signal and read noise scale by ``10**(gain_db/20)``).

    Examples
    --------
    >>> CameraSettings(exposure_ms=8.0).exposure_ms
    8.0
    """

    exposure_ms: float | None = None
    gain_db: float | None = None

    def __post_init__(self) -> None:
        if self.exposure_ms is not None and not (
            math.isfinite(self.exposure_ms) and self.exposure_ms > 0
        ):
            raise InputError(
                f"exposure time must be a positive number of milliseconds, got {self.exposure_ms}"
            )
        lo, hi = GAIN_DB_RANGE
        if self.gain_db is not None and not (
            math.isfinite(self.gain_db) and lo <= self.gain_db <= hi
        ):
            raise InputError(f"camera gain must be {lo:g}..{hi:g} dB, got {self.gain_db}")


@dataclass(frozen=True)
class FringeSet:
    """One complete phase-shifted set inside a :class:`Captures`.

    Parameters
    ----------
    label : str
        The manifest's ``set`` label, or a label built from the pattern specification (with
        ``_map<8 hex>`` for a pixelwise set, ``_e<exposure>``, ``_gain<gain>dB`` and
        ``_gp<gamma>`` appended when the frames give them).
    spec : FringeSpec
        The set's pattern specification (for a pixelwise set its ``migl`` is the nominal MIGL;
        decoding uses the pattern, steps and orientation only).
    frame_indices : tuple of int
        Indices into :attr:`Captures.frames`, ordered by shift (shift 0 first).
    exposure_ms : float or None
        Exposure time of the set's first frame, when given.
    gamma_precompensation : float or None
        Per-set pre-compensation exponent when the frames give one (an hdrfringe addition to
        the contract); None: the projector's ``gamma_precompensation``.
    gain_db : float or None
        Camera gain of the set's frames, when given (capture format version 2).
    migl_map_sha256 : str or None
        For a set of :class:`~hdrfringe.core.frames.PixelwiseFringeFrame`: the content digest of its
        one MIGL map; None for a set of line frames.

    Notes
    -----
    Thesis Sec. 2.2: N phase-shifted images of one pattern decode to one wrapped phase
    (:func:`hdrfringe.core.phase.decode_set`), whether the pattern's MIGL is one number or a map.

    Examples
    --------
    >>> spec = FringeSpec("sinusoidal", 3, 8.0)
    >>> group_fringe_sets(spec.frames())[0].frame_indices
    (0, 1, 2)
    """

    label: str
    spec: FringeSpec
    frame_indices: tuple[int, ...]
    exposure_ms: float | None = None
    gamma_precompensation: float | None = None
    gain_db: float | None = None
    migl_map_sha256: str | None = None

    @property
    def is_pixelwise(self) -> bool:
        """Whether the frames carry a MIGL map
        (:class:`~hdrfringe.core.frames.PixelwiseFringeFrame`).

        Returns
        -------
        bool

        Examples
        --------
        >>> group_fringe_sets(FringeSpec(steps=3).frames())[0].is_pixelwise
        False
        """
        return self.migl_map_sha256 is not None


def _per_frame(values: Sequence[Any] | None, n: int, what: str, where: str) -> tuple[Any, ...]:
    """A per-frame column as a tuple of length ``n`` (None or empty: all None)."""
    if values is None or (len(values) == 0 and n > 0):
        return (None,) * n
    out = tuple(values)
    if len(out) != n:
        raise InputError(
            f"{where}: {what} has {len(out)} entries for {n} frames; give one per frame "
            "(None where it does not apply)"
        )
    return out


def _is_real(value: Any) -> bool:
    return (
        not isinstance(value, bool)
        and isinstance(value, int | float | np.integer | np.floating)
        and math.isfinite(value)
    )


def _gain_or_none(value: Any, where: str) -> float | None:
    if value is None:
        return None
    lo, hi = GAIN_DB_RANGE
    if not _is_real(value) or not lo <= value <= hi:
        raise CaptureFormatError(
            f"{where}: gain_db must be a number in {lo:g}..{hi:g} dB, got {value!r}"
        )
    return float(value)


def _positive_or_none(value: Any, what: str, where: str) -> float | None:
    if value is None:
        return None
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float | np.integer | np.floating)
        or not math.isfinite(value)
        or value <= 0
    ):
        raise CaptureFormatError(f"{where}: {what} must be a positive number, got {value!r}")
    return float(value)


def group_fringe_sets(
    frames: Sequence[Frame],
    *,
    exposure_ms: Sequence[float | None] | None = None,
    set_labels: Sequence[str | None] | None = None,
    gamma_precompensation: Sequence[float | None] | None = None,
    names: Sequence[str] | None = None,
    gain_db: Sequence[float | None] | None = None,
) -> list[FringeSet]:
    """Group fringe frames into complete phase-shifted sets (the capture-folder contract).

    Frames with a ``set`` label form one set per label; the others form one set per pattern
    specification, exposure time, gain and gamma pre-compensation, and, for
    :class:`~hdrfringe.core.frames.PixelwiseFringeFrame`, per MIGL map (by content digest). Every
    set must hold one kind of frame, one specification, one map and one gain, and each shift
    0..N-1 exactly once.

    Parameters
    ----------
    frames : sequence of Frame
        Only the :class:`~hdrfringe.core.frames.FringeFrame` and
        :class:`~hdrfringe.core.frames.PixelwiseFringeFrame` entries are grouped.
    exposure_ms, set_labels, gamma_precompensation : sequence, optional
        Per-frame values (None where not given); default: all None.
    names : sequence of str, optional
        Per-frame names for the messages (e.g. the image files); default: ``frame <index>``.
    gain_db : sequence of float or None, optional
        Per-frame camera gain (None where not given); default: all None.

    Returns
    -------
    list of FringeSet
        In order of each set's first frame.

    Raises
    ------
    CaptureFormatError
        A labelled set mixes kinds, specifications, maps or gains, or a set misses or repeats
        a shift.

    Notes
    -----
    Thesis Sec. 2.2 (N-step phase shifting); the grouping rule is the capture-folder
    contract's (docs/capture_format.md).

    Examples
    --------
    >>> frames = FringeSpec("sinusoidal", 3, 8.0).frames()
    >>> [s.label for s in group_fringe_sets(frames[::-1])]
    ['s3_p8_v_i40_g255']
    >>> group_fringe_sets(frames[:2])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.CaptureFormatError: set 's3_p8_v_i40_g255': has shifts [0, 1] but a 3-step ...
    """
    n = len(frames)
    exposures = _per_frame(exposure_ms, n, "exposure_ms", "fringe sets")
    labels = _per_frame(set_labels, n, "set_labels", "fringe sets")
    gammas = _per_frame(gamma_precompensation, n, "gamma_precompensation", "fringe sets")
    gains = _per_frame(gain_db, n, "gain_db", "fringe sets")
    frame_names = [f"frame {i}" for i in range(n)] if names is None else list(names)
    groups = _set_groups(frames, labels, exposures, gammas, gains)
    sets: list[FringeSet] = []
    problems: list[str] = []
    for key, idx in groups.items():
        try:
            sets.append(_one_set(key, idx, frames, frame_names, exposures, gammas, gains))
        except CaptureFormatError as exc:  # every set's problem, reported together
            problems.extend(exc.problems)
    if problems:
        raise CaptureFormatError.from_problems(problems)
    return sets


def _set_groups(
    frames: Sequence[Frame],
    labels: tuple[Any, ...],
    exposures: tuple[Any, ...],
    gammas: tuple[Any, ...],
    gains: tuple[Any, ...],
) -> dict[tuple[Any, ...], list[int]]:
    """The fringe frames' indices per set key (the contract's grouping rule), in frame order."""
    groups: dict[tuple[Any, ...], list[int]] = {}
    for i, frame in enumerate(frames):
        if not isinstance(frame, FringeFrame | PixelwiseFringeFrame):
            continue
        key: tuple[Any, ...]
        if labels[i] is not None:
            key = ("label", labels[i])
        elif isinstance(frame, FringeFrame):
            # the key of version 1 (a gain, absent there, splits sets only where given)
            key = ("spec", frame.spec, exposures[i], gammas[i], gains[i])
        else:
            key = ("map", frame.spec, frame.content_sha256, exposures[i], gammas[i], gains[i])
        groups.setdefault(key, []).append(i)
    return groups


def partial_set_frames(
    frames: Sequence[Frame],
    *,
    exposure_ms: Sequence[float | None] | None = None,
    gamma_precompensation: Sequence[float | None] | None = None,
    gain_db: Sequence[float | None] | None = None,
) -> list[int]:
    """The fringe frames that belong to no complete set: their set misses a shift.

    Grouped as :func:`group_fringe_sets` groups unlabelled frames. A set that repeats a shift
    is not partial (it is malformed, and :func:`group_fringe_sets` refuses it).

    Parameters
    ----------
    frames : sequence of Frame
        The frames, e.g. everything a live run captured.
    exposure_ms, gamma_precompensation, gain_db : sequence, optional
        Per-frame values (None where not given); default: all None.

    Returns
    -------
    list of int
        Indices into ``frames``, ascending.

    Examples
    --------
    >>> frames = FringeSpec("sinusoidal", 4, 8.0).frames()
    >>> partial_set_frames(frames[:1] + FringeSpec("sinusoidal", 4, 8.0, migl=60).frames()[1:])
    [0, 1, 2, 3]
    >>> partial_set_frames(frames[:1] + frames[1:])
    []
    """
    n = len(frames)
    groups = _set_groups(
        frames,
        (None,) * n,
        _per_frame(exposure_ms, n, "exposure_ms", "fringe sets"),
        _per_frame(gamma_precompensation, n, "gamma_precompensation", "fringe sets"),
        _per_frame(gain_db, n, "gain_db", "fringe sets"),
    )
    out: list[int] = []
    for idx in groups.values():
        members = [f for i in idx if isinstance(f := frames[i], FringeFrame | PixelwiseFringeFrame)]
        shifts = {f.shift for f in members}
        if len(shifts) == len(members) < members[0].spec.steps:
            out.extend(idx)
    return sorted(out)


def _one_set(
    key: tuple[Any, ...],
    idx: list[int],
    frames: Sequence[Frame],
    frame_names: list[str],
    exposures: tuple[Any, ...],
    gammas: tuple[Any, ...],
    gains: tuple[Any, ...],
) -> FringeSet:
    """One group of :func:`group_fringe_sets` checked and made a :class:`FringeSet`."""
    first = frames[idx[0]]
    assert isinstance(first, FringeFrame | PixelwiseFringeFrame)
    spec = first.spec
    digest = first.content_sha256 if isinstance(first, PixelwiseFringeFrame) else None
    exposure, gamma, gain = exposures[idx[0]], gammas[idx[0]], gains[idx[0]]
    if key[0] == "label":
        label = str(key[1])
    else:
        label = spec.label()
        if digest is not None:
            label = f"{label}_map{digest[:8]}"
        if exposure is not None:
            label = f"{label}_e{exposure:g}"
        if gain is not None:
            label = f"{label}_gain{gain:g}dB"
        if gamma is not None:
            label = f"{label}_gp{gamma:g}"
    shifts = []
    for i in idx:
        f = frames[i]
        assert isinstance(f, FringeFrame | PixelwiseFringeFrame)
        if type(f) is not type(first):
            raise CaptureFormatError(
                f"set {label!r}: frame {frame_names[i]} is a {f.kind} frame but "
                f"{frame_names[idx[0]]} a {first.kind} frame; give each set one kind"
            )
        if f.spec != spec and replace(f.spec, phase_offset_deg=spec.phase_offset_deg) == spec:
            raise CaptureFormatError(
                f"set {label!r}: frame {frame_names[i]} has phase_offset_deg "
                f"{f.spec.phase_offset_deg:g} but {frame_names[idx[0]]} "
                f"{spec.phase_offset_deg:g}; all frames of a set must agree on the offset"
            )
        if f.spec != spec:
            raise CaptureFormatError(
                f"set {label!r}: frame {frame_names[i]} has a different pattern "
                "specification from the rest of its set; give each set one specification"
            )
        if isinstance(f, PixelwiseFringeFrame) and f.content_sha256 != digest:
            raise CaptureFormatError(
                f"set {label!r}: frame {frame_names[i]} has a different MIGL map from "
                f"{frame_names[idx[0]]}; give the frames of a set one map"
            )
        if gains[i] != gain:
            raise CaptureFormatError(
                f"set {label!r}: frame {frame_names[i]} has gain {gains[i]} dB but "
                f"{frame_names[idx[0]]} {gain} dB; give the frames of a set one gain"
            )
        shifts.append(f.shift)
    if sorted(shifts) != list(range(spec.steps)):
        raise CaptureFormatError(
            f"set {label!r}: has shifts {sorted(shifts)} but a {spec.steps}-step set needs "
            f"each of 0..{spec.steps - 1} exactly once; add or remove frames"
        )
    ordered = tuple(i for _, i in sorted(zip(shifts, idx, strict=True)))
    return FringeSet(
        label,
        spec,
        ordered,
        exposure,
        None if gamma is None else float(gamma),
        None if gain is None else float(gain),
        digest,
    )


def frames_format_version(frames: Sequence[Frame], gain_db: Sequence[float | None] = ()) -> int:
    """The lowest capture-format version that describes these frames (and gains).

    The one place that decides it, for capture folders (:attr:`Captures.format_version`) and
    pattern folders alike: 3 when a fringe set declares shift angles or a phase offset, or
    leaves out its gray levels, or a frame is Gray code; else 2 when a frame has 2-D data
    (:data:`hdrfringe.core.frames.IMAGE_FRAMES`) or a gain is recorded; else 1
    (docs/capture_format.md).

    Parameters
    ----------
    frames : sequence of Frame
        The frames a folder describes.
    gain_db : sequence of float or None, optional
        Per-frame camera gains (None: not recorded).

    Returns
    -------
    int
        1, 2 or 3.

    Examples
    --------
    >>> frames_format_version(FringeSpec(steps=3).frames())
    1
    >>> frames_format_version(FringeSpec(steps=3, phase_offset_deg=-90).frames())
    3
    """
    needs = [1]
    if any(
        isinstance(f, FringeFrame) and not (f.spec.has_standard_phase and f.spec.gray_levels_given)
        for f in frames
    ):
        needs.append(3)  # shift angles, phase offset, gray levels left out
    if any(isinstance(f, GrayCodeFrame) for f in frames):
        needs.append(3)  # Gray-code frames (docs/capture_format.md, "Version 3 extensions")
    if any(isinstance(f, IMAGE_FRAMES) for f in frames):
        needs.append(2)
    if any(g is not None for g in gain_db):
        needs.append(2)
    return max(needs)


def _frame_or_fail(
    entry: dict[str, Any],
    i: int,
    load_array: Callable[[str], NDArray[Any]] | None,
    shifts_deg: tuple[float, ...] | None = None,
    default_migl: float = 255.0,
) -> Frame:
    """:func:`frame_from_manifest` with its errors naming the frame; a fringe frame without
    gray levels gets ``default_migl`` (the projector's full scale)."""
    try:
        if shifts_deg is None:
            frame = frame_from_manifest(entry, load_array)
        else:
            frame = frame_from_manifest(entry, load_array, shifts_deg=shifts_deg)
        if isinstance(frame, FringeFrame) and not frame.spec.gray_levels_given:
            frame = FringeFrame(replace(frame.spec, migl=default_migl), frame.shift)
        return frame
    except HdrFringeError as exc:
        raise CaptureFormatError(f"manifest frame {i} ({entry.get('file')}): {exc}") from None


@dataclass(frozen=True)
class GrayCodeSet:
    """The complete Gray code of one orientation inside a :class:`Captures`.

    Parameters
    ----------
    orientation : {"vertical", "horizontal"}
    bits : int
        Number of bits.
    stripe_px : float
        The code's cell width in projector pixels.
    code : {"gray", "binary"}
    frame_indices : tuple of int
        Index into :attr:`Captures.frames` of each bit's pattern, least significant bit first.
    inverse_indices : tuple of int or None
        Index of each bit's inverse, same order; None when the code has no inverses (bits are
        then decided against a threshold, docs/graycode.md).

    Notes
    -----
    Decoded by :func:`hdrfringe.core.graycode.decode_graycode`; conventions in docs/graycode.md.

    Examples
    --------
    >>> from hdrfringe.core.frames import opencv_graycode_frames
    >>> gc = group_graycode_sets(opencv_graycode_frames(16, 8, 2.0))
    >>> [(g.orientation, g.bits, g.frame_indices, g.inverse_indices) for g in gc]
    [('vertical', 3, (4, 2, 0), (5, 3, 1)), ('horizontal', 2, (8, 6), (9, 7))]
    """

    orientation: str
    bits: int
    stripe_px: float
    code: str
    frame_indices: tuple[int, ...]
    inverse_indices: tuple[int, ...] | None


def group_graycode_sets(
    frames: Sequence[Frame], names: Sequence[str] | None = None
) -> list[GrayCodeSet]:
    """Group the Gray-code frames into one complete code per orientation.

    Parameters
    ----------
    frames : sequence of Frame
        Only the :class:`~hdrfringe.core.frames.GrayCodeFrame` entries are grouped.
    names : sequence of str, optional
        Per-frame names for the messages (e.g. the image files); default ``frame <index>``.

    Returns
    -------
    list of GrayCodeSet
        Vertical first.

    Raises
    ------
    CaptureFormatError
        Two different codes for one orientation, a bit given twice, a missing bit, or an
        inverse without its pattern (or pattern without inverse, when the code has inverses).

    Notes
    -----
    The capture-folder contract, version 3 (docs/capture_format.md, "Gray-code frames").

    Examples
    --------
    >>> from hdrfringe.core.frames import GrayCodeFrame
    >>> group_graycode_sets([GrayCodeFrame("vertical", 1, 2, 8.0)])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.CaptureFormatError: vertical Gray code: bit 0 of 0..1 is missing; ...
    """
    frame_names = [f"frame {i}" for i in range(len(frames))] if names is None else list(names)
    by_orient: dict[str, list[int]] = {}
    for i, f in enumerate(frames):
        if isinstance(f, GrayCodeFrame):
            by_orient.setdefault(f.orientation, []).append(i)
    out: list[GrayCodeSet] = []
    for orient in ("vertical", "horizontal"):
        idx = by_orient.get(orient)
        if not idx:
            continue
        first = frames[idx[0]]
        assert isinstance(first, GrayCodeFrame)
        where = f"{orient} Gray code"
        slots: dict[tuple[int, bool], int] = {}
        for i in idx:
            f = frames[i]
            assert isinstance(f, GrayCodeFrame)
            if f.set_key() != first.set_key():
                raise CaptureFormatError(
                    f"{where}: {frame_names[i]} has another code (bits, stripe, code, migl or "
                    f"convention) than {frame_names[idx[0]]}; give one code per orientation"
                )
            key = (f.bit, f.inverse)
            if key in slots:
                kind = "inverse" if f.inverse else "pattern"
                raise CaptureFormatError(
                    f"{where}: bit {f.bit} {kind} given twice ({frame_names[slots[key]]} and "
                    f"{frame_names[i]}); remove one"
                )
            slots[key] = i
        has_inverse = any(inv for _, inv in slots)
        for bit in range(first.bits):
            if (bit, False) not in slots:
                what = " (its inverse is there)" if (bit, True) in slots else ""
                raise CaptureFormatError(
                    f"{where}: bit {bit} of 0..{first.bits - 1} is missing{what}; "
                    "add its frame or lower 'bits'"
                )
            if has_inverse and (bit, True) not in slots:
                raise CaptureFormatError(
                    f"{where}: bit {bit} has no inverse ({frame_names[slots[(bit, False)]]}) but "
                    "other bits have one; give every bit its inverse or none"
                )
        out.append(
            GrayCodeSet(
                orient,
                first.bits,
                first.stripe_px,
                first.code,
                tuple(slots[(b, False)] for b in range(first.bits)),
                tuple(slots[(b, True)] for b in range(first.bits)) if has_inverse else None,
            )
        )
    return out


def _check_projector_frames(
    frames: Sequence[Frame], projector: ProjectorInfo | None, name: str
) -> None:
    """Frames with 2-D data need the projector, and must fit its size and bit depth."""
    for i, f in enumerate(frames):
        if not isinstance(f, IMAGE_FRAMES):
            continue
        if projector is None:
            raise CaptureFormatError(
                f"{name}: frame {i} is a {f.kind} frame, whose data covers the projector; "
                "give the projector (ProjectorInfo with its width, height and bit depth)"
            )
        try:
            f.check_projector(projector.width, projector.height, projector.bit_depth)
        except InputError as exc:
            raise CaptureFormatError(f"{name}: frame {i} ({f.kind}): {exc}") from None


#: Top-level manifest fields :meth:`Captures.to_manifest` writes itself.
_MANIFEST_FIELDS = ("format", "version", "camera", "projector", "scene", "maps", "frames")


@dataclass(frozen=True, eq=False)
class Captures:
    """Captured images with what was projected for each: a capture folder held in memory.

    Validated on construction: one (H, W) image per frame, values within ``0..2^B - 1``
    (:func:`hdrfringe.core._validation.full_scale`), maps of the image size, complete fringe sets
    (:func:`group_fringe_sets`), and frames with 2-D data
    (:class:`~hdrfringe.core.frames.PixelwiseFringeFrame`,
    :class:`~hdrfringe.core.frames.ImageFrame`)
    that fit the projector, which must then be given. It holds no path:
    :mod:`hdrfringe.io.captures` reads and writes it as a capture folder
    (docs/capture_format.md; version 2 when it holds 2-D frames or gains,
    :attr:`format_version`).

    Parameters
    ----------
    frames : sequence of Frame
        What the projector showed for each image.
    images : ndarray, shape (n_frames, H, W)
        Camera counts (integers; float32 only for luma converted from RGB).
    camera_bit_depth : int
        Sensor bit depth B; a pixel is saturated at ``2^B - 1``.
    projector : ProjectorInfo, optional
        Projector input description (None: not recorded).
    camera : dict, optional
        Camera description besides the bit depth, e.g. the geometry ``focal_px`` and
        ``standoff_mm`` (what a manifest's ``camera`` holds besides ``bit_depth``).
    scene : dict, optional
        Scene description, e.g. ``{"depth_mm": 12.0}`` for a flat plate.
    exposure_ms : sequence of float or None, optional
        Per-frame exposure time in milliseconds (None: not given); default all None.
    set_labels : sequence of str or None, optional
        Per-frame ``set`` label grouping fringe frames into sets; default all None.
    gamma_precompensation : sequence of float or None, optional
        Per-frame gamma pre-compensation overriding the projector's (an hdrfringe addition,
        docs/gamma.md); default all None.
    maps : dict of str to ndarray, optional
        Float maps of the image size, e.g. ``truth_height_mm``.
    name : str
        A label for messages only (the folder reader sets it to the folder path).
    gain_db : sequence of float or None, optional
        Per-frame camera gain in dB, -20..48 (None: not given); default all None.

    Raises
    ------
    CaptureFormatError
        Images that do not match the frames or the bit depth, maps of another size, invalid
        per-frame values, or incomplete fringe sets.
    InputError
        An invalid bit depth or per-frame columns of the wrong length.

    Notes
    -----
    Thesis Sec. 2.2: a set of N phase-shifted images per fringe specification; the saturation
    rule (a value of ``2^B - 1``) is :func:`hdrfringe.core._validation.is_saturated`.

    Examples
    --------
    >>> import numpy as np
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> frames = FringeSpec("sinusoidal", 4, 8.0).frames()
    >>> caps = Captures(frames, np.zeros((4, 3, 5), np.uint8), 8, scene={"depth_mm": 0.0})
    >>> caps
    Captures('<memory>': 4 frames of 5x3 at 8 bits, 1 fringe set)
    >>> caps.image_shape, caps.sets[0].label
    ((3, 5), 's4_p8_v_i40_g255')
    >>> caps.set_images(caps.sets[0]).shape
    (4, 3, 5)
    """

    frames: list[Frame]
    images: NDArray[Any] = field(repr=False)
    camera_bit_depth: int
    projector: ProjectorInfo | None = None
    camera: dict[str, Any] = field(default_factory=dict)
    scene: dict[str, Any] = field(default_factory=dict)
    exposure_ms: tuple[float | None, ...] = ()
    set_labels: tuple[str | None, ...] = ()
    gamma_precompensation: tuple[float | None, ...] = ()
    maps: dict[str, NDArray[Any]] = field(default_factory=dict, repr=False)
    name: str = "<memory>"
    gain_db: tuple[float | None, ...] = ()
    _sets: tuple[FringeSet, ...] = field(init=False, repr=False, default=())

    def __post_init__(self) -> None:
        name = str(self.name)
        bits = check_bit_depth(self.camera_bit_depth)
        frames = list(self.frames)
        for i, f in enumerate(frames):
            if not isinstance(f, Frame):
                raise InputError(
                    f"{name}: frame {i} is a {type(f).__name__}; give frames from "
                    "hdrfringe.core.frames (FringeFrame, CenterlineFrame, UniformFrame)"
                )
        images = np.asarray(self.images)
        if images.ndim != 3 or images.shape[0] != len(frames):
            raise CaptureFormatError(
                f"{name}: {len(frames)} frames but images of shape {images.shape}; "
                "give one (H, W) image per frame"
            )
        if images.dtype.kind not in "uif":
            raise CaptureFormatError(
                f"{name}: images of dtype {images.dtype}; give camera counts as integers"
            )
        full = full_scale(bits)
        if images.size:
            hi = images.max()
            lo = images.min() if images.dtype.kind != "u" else 0
            if not hi <= full:  # NaN fails too
                raise CaptureFormatError(
                    f"{name}: values reach {hi}, above 2^B - 1 = {full}; fix the bit depth"
                )
            if not lo >= 0:
                raise CaptureFormatError(
                    f"{name}: values go down to {lo}; camera counts are never negative"
                )
        n = len(frames)
        exposure = tuple(
            _positive_or_none(v, "exposure_ms", f"{name}: frame {i}")
            for i, v in enumerate(_per_frame(self.exposure_ms, n, "exposure_ms", name))
        )
        gamma = tuple(
            _positive_or_none(v, "gamma_precompensation", f"{name}: frame {i}")
            for i, v in enumerate(
                _per_frame(self.gamma_precompensation, n, "gamma_precompensation", name)
            )
        )
        gain = tuple(
            _gain_or_none(v, f"{name}: frame {i}")
            for i, v in enumerate(_per_frame(self.gain_db, n, "gain_db", name))
        )
        labels = _per_frame(self.set_labels, n, "set_labels", name)
        for i, label in enumerate(labels):
            if label is not None and not isinstance(label, str):
                raise CaptureFormatError(
                    f"{name}: frame {i} set label must be a string, got {label!r}"
                )
        camera = dict(self.camera)
        if "bit_depth" in camera:
            raise InputError(
                f"{name}: camera holds 'bit_depth'; give the bit depth as camera_bit_depth "
                "and the rest of the camera description in camera"
            )
        shape = (int(images.shape[1]), int(images.shape[2]))
        maps: dict[str, NDArray[Any]] = {}
        for key, data in self.maps.items():
            arr = np.asarray(data)
            if arr.shape != shape:
                got = f"{arr.shape[1]}x{arr.shape[0]}" if arr.ndim == 2 else str(arr.shape)
                raise CaptureFormatError(
                    f"{name}: map {key!r} is {got} but the images are {shape[1]}x{shape[0]}; "
                    "regenerate it"
                )
            maps[str(key)] = arr
        _check_projector_frames(frames, self.projector, name)
        sets = group_fringe_sets(
            frames,
            exposure_ms=exposure,
            set_labels=labels,
            gamma_precompensation=gamma,
            gain_db=gain,
        )
        group_graycode_sets(frames)  # a missing bit or an unpaired inverse: refused here
        for attr, value in (
            ("frames", frames),
            ("images", images),
            ("camera_bit_depth", bits),
            ("camera", camera),
            ("scene", dict(self.scene)),
            ("exposure_ms", exposure),
            ("gain_db", gain),
            ("set_labels", labels),
            ("gamma_precompensation", gamma),
            ("maps", maps),
            ("name", name),
            ("_sets", tuple(sets)),
        ):
            object.__setattr__(self, attr, value)

    def __repr__(self) -> str:
        h, w = self.image_shape
        n_sets = len(self._sets)
        return (
            f"Captures({self.name!r}: {len(self.frames)} frames of {w}x{h} at "
            f"{self.camera_bit_depth} bits, {n_sets} fringe set{'s' if n_sets != 1 else ''})"
        )

    # --- views ------------------------------------------------------------------------------
    @property
    def sets(self) -> tuple[FringeSet, ...]:
        """The complete fringe sets (:func:`group_fringe_sets`), in order of first frame."""
        return self._sets

    @property
    def format_version(self) -> int:
        """The capture-format version a folder of these captures needs.

        The lowest version that describes every frame (docs/capture_format.md): 3 when a
        fringe set declares shift angles or a phase offset, or leaves out its gray levels;
        else 2 when a frame has 2-D data (:data:`hdrfringe.core.frames.IMAGE_FRAMES`) or records a
        gain; else 1.

        Returns
        -------
        int
            1, 2 or 3.

        Examples
        --------
        >>> import dataclasses
        >>> import numpy as np
        >>> from hdrfringe.core.frames import UniformFrame
        >>> caps = Captures([UniformFrame(9)], np.zeros((1, 2, 2), np.uint8), 8)
        >>> caps.format_version, dataclasses.replace(caps, gain_db=[6.0]).format_version
        (1, 2)
        """
        return frames_format_version(self.frames, self.gain_db)

    @property
    def image_shape(self) -> tuple[int, int]:
        """Camera image (height, width)."""
        return (int(self.images.shape[1]), int(self.images.shape[2]))

    def set_images(self, fringe_set: FringeSet) -> NDArray[Any]:
        """Stack of a set's images, shape (N, H, W), shift 0 first.

        Parameters
        ----------
        fringe_set : FringeSet
            One of :attr:`sets`.

        Returns
        -------
        ndarray
        """
        return self.images[list(fringe_set.frame_indices)]

    def graycode_sets(self) -> list[GrayCodeSet]:
        """The Gray code of each orientation (:func:`group_graycode_sets`), vertical first.

        Returns
        -------
        list of GrayCodeSet

        Examples
        --------
        >>> import numpy as np
        >>> from hdrfringe.core.frames import opencv_graycode_frames
        >>> frames = opencv_graycode_frames(8, 2, 2.0)
        >>> caps = Captures(frames, np.zeros((len(frames), 2, 2), np.uint8), 8)
        >>> [(g.orientation, g.bits) for g in caps.graycode_sets()]
        [('vertical', 2)]
        """
        return group_graycode_sets(self.frames)

    def centerlines(self) -> list[tuple[CenterlineFrame, NDArray[Any]]]:
        """Every centerline frame with its image, in frame order.

        Returns
        -------
        list of (CenterlineFrame, ndarray (H, W))
        """
        return [
            (f, self.images[i]) for i, f in enumerate(self.frames) if isinstance(f, CenterlineFrame)
        ]

    def uniforms(self) -> list[tuple[UniformFrame, NDArray[Any]]]:
        """Every uniform-gray frame with its image, in frame order.

        Returns
        -------
        list of (UniformFrame, ndarray (H, W))
        """
        return [
            (f, self.images[i]) for i, f in enumerate(self.frames) if isinstance(f, UniformFrame)
        ]

    def map(self, key: str) -> NDArray[Any] | None:
        """A float map (e.g. ``truth_height_mm``), or None when the captures carry none.

        Parameters
        ----------
        key : str

        Returns
        -------
        ndarray (H, W) or None

        Examples
        --------
        >>> import numpy as np
        >>> from hdrfringe.core.frames import UniformFrame
        >>> caps = Captures([UniformFrame(128)], np.zeros((1, 2, 2), np.uint8), 8,
        ...                 maps={"truth_height_mm": np.ones((2, 2))})
        >>> float(caps.map("truth_height_mm").sum()), caps.map("depth")
        (4.0, None)
        """
        return self.maps.get(key)

    # --- manifest (no file access) ----------------------------------------------------------
    def _entry(self, i: int, file: str) -> dict[str, Any]:
        entry = self.frames[i].manifest_entry(file)
        if self.exposure_ms[i] is not None:
            entry["exposure_ms"] = self.exposure_ms[i]
        if self.gain_db[i] is not None:
            entry["gain_db"] = self.gain_db[i]
        if self.set_labels[i] is not None:
            entry["set"] = self.set_labels[i]
        if self.gamma_precompensation[i] is not None:
            entry["gamma_precompensation"] = self.gamma_precompensation[i]
        return entry

    def to_manifest(
        self, files: Sequence[str] | None = None, *, extra: Mapping[str, Any] | None = None
    ) -> dict[str, Any]:
        """The capture manifest describing these captures (docs/capture_format.md).

        Parameters
        ----------
        files : sequence of str, optional
            Image file name of each frame; default ``0000.png``, ``0001.png``, ...
        extra : mapping, optional
            Additional top-level fields (the contract allows additions), e.g. ``simulator``.

        Returns
        -------
        dict
            JSON-ready, of version :attr:`format_version`; maps are listed as ``<key>.tiff``,
            2-D frames name their side files by content (``default_data_file()``).

        Examples
        --------
        >>> import numpy as np
        >>> from hdrfringe.core.frames import UniformFrame
        >>> m = Captures([UniformFrame(128)], np.zeros((1, 2, 2), np.uint8), 8).to_manifest()
        >>> m["camera"], m["frames"]
        ({'bit_depth': 8}, [{'file': '0000.png', 'kind': 'uniform', 'level': 128}])
        """
        n = len(self.frames)
        names = [f"{i:04d}.png" for i in range(n)] if files is None else list(files)
        if len(names) != n:
            raise InputError(f"{self.name}: {len(names)} file names for {n} frames; give one each")
        manifest: dict[str, Any] = {
            "format": FORMAT_NAME,
            "version": self.format_version,
            "camera": {"bit_depth": self.camera_bit_depth, **self.camera},
        }
        if self.projector is not None:
            manifest["projector"] = self.projector.to_manifest()
        if self.scene:
            manifest["scene"] = dict(self.scene)
        for key, value in (extra or {}).items():
            if key in _MANIFEST_FIELDS:
                raise InputError(
                    f"extra manifest field {key!r} would replace the captures' own; "
                    "give it through the Captures fields"
                )
            manifest[key] = value
        if self.maps:
            manifest["maps"] = {k: f"{k}.tiff" for k in self.maps}
        manifest["frames"] = [self._entry(i, f) for i, f in enumerate(names)]
        return manifest

    @classmethod
    def from_manifest(
        cls,
        manifest: Mapping[str, Any],
        images: ArrayLike,
        maps: Mapping[str, ArrayLike] | None = None,
        *,
        name: str = "<memory>",
        load_array: Callable[[str], NDArray[Any]] | None = None,
    ) -> Captures:
        """Captures from a (validated) capture manifest and the images it lists, in its order.

        The manifest's fields are checked by :func:`hdrfringe.io.captures.read_manifest`; this
        builds the frames, the per-frame ``exposure_ms`` (any frame), ``gain_db`` (any frame,
        version 2 only: version 1 gives it no meaning), ``set`` and ``gamma_precompensation``
        (fringe and pixelwise fringe frames), and names the image files in its messages.

        Parameters
        ----------
        manifest : mapping
            ``camera.bit_depth`` and ``frames`` required; ``projector`` and ``scene`` optional.
            Other top-level fields are not kept.
        images : array_like, shape (n_frames, H, W)
            The camera images, in the manifest's frame order.
        maps : mapping of str to array_like, optional
            The maps' data (the manifest's ``maps`` lists only their files).
        name : str
            Label for messages.
        load_array : callable, optional
            ``load_array(path)`` returns the array of a frame's side file (the path as the
            entry writes it); needed for frames with 2-D data, see
            :func:`hdrfringe.core.frames.frame_from_manifest`.

        Returns
        -------
        Captures

        Raises
        ------
        CaptureFormatError
            Frames that cannot be built (including a side file ``load_array`` refuses or whose
            content differs from the entry's digest), incomplete sets (naming the files), or
            anything :class:`Captures` refuses.

        Examples
        --------
        >>> import numpy as np
        >>> m = {"camera": {"bit_depth": 10, "focal_px": 800.0},
        ...      "frames": [{"file": "g.png", "kind": "uniform", "level": 64, "exposure_ms": 5}]}
        >>> caps = Captures.from_manifest(m, np.zeros((1, 2, 2), np.uint16))
        >>> caps.camera, caps.exposure_ms
        ({'focal_px': 800.0}, (5.0,))
        """
        entries = list(manifest["frames"])
        # a fringe entry's shift_deg (version 3) gives one angle of its set: the frames are
        # built without it, grouped, and rebuilt with their set's angles
        angled = {
            i for i, e in enumerate(entries) if e.get("kind") == "fringe" and "shift_deg" in e
        }
        # a fringe entry without imin/migl (version 3) gets migl = the projector's 2^Bp - 1
        proj = manifest.get("projector") or {}
        full_p = float(full_scale(int(proj.get("bit_depth", 8)), "projector bit depth"))
        frames: list[Frame] = []
        for i, entry in enumerate(entries):
            if i in angled:
                entry = {k: v for k, v in entry.items() if k != "shift_deg"}
            frames.append(_frame_or_fail(entry, i, load_array, default_migl=full_p))
        fringe = [isinstance(f, FringeFrame | PixelwiseFringeFrame) for f in frames]
        exposure = tuple(e.get("exposure_ms") for e in entries)
        has_gain = manifest.get("version", FORMAT_VERSION) != 1  # no meaning in version 1
        gain = tuple(e.get("gain_db") if has_gain else None for e in entries)
        labels = tuple(e.get("set") if fr else None for e, fr in zip(entries, fringe, strict=True))
        gamma = tuple(
            e.get("gamma_precompensation") if fr else None
            for e, fr in zip(entries, fringe, strict=True)
        )
        names = [str(e.get("file", f"frame {i}")) for i, e in enumerate(entries)]
        # Validate the grouping first, so that its messages name the image files.
        sets = group_fringe_sets(
            frames,
            exposure_ms=exposure,
            set_labels=labels,
            gamma_precompensation=gamma,
            names=names,
            gain_db=gain,
        )
        if angled:
            for fs in sets:
                idx = fs.frame_indices
                given = [i for i in idx if i in angled]
                if not given:
                    continue
                if len(given) != len(idx):
                    missing = next(i for i in idx if i not in angled)
                    raise CaptureFormatError(
                        f"set {fs.label!r}: frame {names[given[0]]} gives shift_deg but "
                        f"{names[missing]} does not; give every frame of the set its shift_deg "
                        "or none"
                    )
                angles = tuple(float(entries[i]["shift_deg"]) for i in idx)  # by shift index
                try:
                    replace(fs.spec, shifts_deg=angles)
                except InputError as exc:
                    raise CaptureFormatError(
                        f"set {fs.label!r} ({', '.join(names[i] for i in idx)}): {exc}"
                    ) from None
                for i in idx:
                    frames[i] = _frame_or_fail(entries[i], i, load_array, angles, full_p)
            group_fringe_sets(
                frames,
                exposure_ms=exposure,
                set_labels=labels,
                gamma_precompensation=gamma,
                names=names,
                gain_db=gain,
            )
        group_graycode_sets(frames, names=names)
        camera = manifest["camera"]
        projector = manifest.get("projector")
        return cls(
            frames,
            np.asarray(images),
            int(camera["bit_depth"]),
            projector=None if projector is None else ProjectorInfo.from_manifest(projector),
            camera={k: v for k, v in camera.items() if k != "bit_depth"},
            scene=dict(manifest.get("scene") or {}),
            exposure_ms=exposure,
            set_labels=labels,
            gamma_precompensation=gamma,
            maps={k: np.asarray(v) for k, v in (maps or {}).items()},
            name=name,
            gain_db=gain,
        )

    def content_hash(self) -> str:
        """SHA-256 of the content: manifest fields, images and maps (not file names or name).

        Returns
        -------
        str
            64 hex digits; equal for captures that hold equal frames, values (and dtypes),
            descriptions and maps, whether read from a folder or made in memory.

        Examples
        --------
        >>> import numpy as np
        >>> from hdrfringe.core.frames import UniformFrame
        >>> a = Captures([UniformFrame(128)], np.zeros((1, 2, 2), np.uint8), 8, name="a")
        >>> b = Captures([UniformFrame(128)], np.zeros((1, 2, 2), np.uint8), 8, name="b")
        >>> a.content_hash() == b.content_hash()
        True
        """
        h = hashlib.sha256()
        h.update(json.dumps(self.to_manifest(), sort_keys=True, default=repr).encode())
        for key, arr in [("images", self.images), *sorted(self.maps.items())]:
            data = np.ascontiguousarray(arr)
            h.update(f"{key}:{data.dtype.str}:{data.shape}".encode())
            h.update(data.data)
        return h.hexdigest()
