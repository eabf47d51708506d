"""Decoding captures: every fringe set of a :class:`~hdrfringe.core.captures.Captures` to phases.

This is the one place that chains the array stages (phase -> unwrap -> absolute phase) for a
set of captures (read from a capture folder or made in memory); the command-line ``phase``
command and later stages call it.

Rules (documented in docs/phase.md):

* Every complete fringe set is decoded (:func:`hdrfringe.core.phase.decode_set`).
* Sets that differ only in pitch form a *family* (same orientation, pattern, steps, imin, migl,
  exposure, gain and, for sets of per-pixel fringes, MIGL map). The primary family is the
  vertical one at the highest MIGL (horizontal if there is no vertical set); a horizontal
  family is processed as well when present.
* In a family with several pitches, the coarsest is unwrapped spatially unless one period covers
  the projector (then it needs no unwrapping), and the finer ones temporally, coarse to fine.
  With one pitch, the phase is unwrapped spatially.
* The absolute phase ``2*pi*x/p`` comes from a centerline frame of the same orientation
  (thesis Eq. 2.12-2.13), or directly when the coarsest set spans the projector with one period.
* Gray code (docs/graycode.md): when the captures hold a Gray code of the family's orientation
  and the coarsest set does not span the projector, the coarsest set's fringe order comes from
  the Gray code, pixel by pixel (:func:`hdrfringe.core.graycode.absolute_phase_graycode`), instead
  of from spatial unwrapping, and the finer sets follow temporally. What wins: a one-period set
  (temporal unwrapping from an absolute coarse level, which needs no binarisation) first, then
  Gray code, then spatial unwrapping (with a centerline for the absolute phase). A Gray code
  whose stripe is wider than the coarsest pitch cannot fix its order: it is not used (a note
  says so).
* Given phase: a strategy that unwraps its finest set itself (the adaptive projection, with its
  mapping's fringe orders, docs/adaptive.md) passes that absolute phase as ``given_phases``;
  it is used wherever the captured finest set decodes, and the coarser sets are not used.
* Islands: where the order comes from spatial unwrapping, the valid area is split into regions
  separated by invalid pixels or phase discontinuities
  (:func:`hdrfringe.core.unwrap.phase_regions`);
  with two or more, their relative fringe order is unknown, and a note says so.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core._validation import SATURATED_MODES, check_min_modulation, full_scale
from hdrfringe.core.captures import Captures, FringeSet, GrayCodeSet
from hdrfringe.core.graycode import GrayCodeDecode, absolute_phase_graycode, decode_graycode
from hdrfringe.core.harmonics import compensate_sets, harmonics_mode
from hdrfringe.core.phase import PhaseResult, decode_set
from hdrfringe.core.saturation.tolerant import decode_set_tolerant
from hdrfringe.core.unwrap import (
    PhaseRegions,
    absolute_phase_from_centerline,
    phase_regions,
    unwrap_spatial,
    unwrap_temporal,
)
from hdrfringe.errors import CaptureFormatError, InputError

__all__ = [
    "SATURATED_MODES",
    "FamilyResult",
    "FolderPhase",
    "decode_captures",
    "group_families",
    "no_absolute_phase_note",
]


@dataclass
class FamilyResult:
    """Unwrapped (and, when possible, absolute) phase of one family of sets.

    Parameters
    ----------
    orientation : {"vertical", "horizontal"}
        Fringe orientation of the family.
    pitch_px : float
        Pitch of the finest set, the one the phases refer to (``2*pi*x/pitch_px``).
    sets : list of FringeSet
        The family's sets, coarse to fine (:func:`group_families`).
    unwrapped_phase : ndarray of float64, shape (H, W)
        Unwrapped phase of the finest set (radians, NaN invalid).
    absolute_phase : ndarray of float64, shape (H, W), or None
        Absolute phase ``2*pi*x/pitch_px``; None when the captures cannot fix it (no
        centerline frame and no set spanning the projector).
    method : str
        How the phase was unwrapped, for reports.
    absolute_method : str or None
        How the absolute phase was obtained, for reports; None with ``absolute_phase``.
    unwrapping : {"one-period", "graycode", "spatial", "given"}
        Where the coarsest set's fringe order came from: a set spanning the projector, the
        Gray code, or spatial unwrapping (finer sets always follow temporally); ``"given"``:
        the finest set's absolute phase came from ``given_phases`` of
        :func:`decode_captures` (a strategy's own mapping).
    regions : PhaseRegions or None
        With spatial unwrapping: the regions whose relative fringe order is unknown
        (:func:`hdrfringe.core.unwrap.phase_regions`); None otherwise.
    graycode_valid : ndarray of bool, shape (H, W), or None
        With Gray code: the pixels whose code was decoded.

    References
    ----------
    Thesis Sec. 2.4 (unwrapping), Sec. 2.5, Eq. 2.12-2.13 (absolute phase).

    Examples
    --------
    Pitches 1024 and 16 px on a 1024 px wide projector: the coarse set needs no unwrapping and
    gives the fine one its fringe order, so the phase is absolute without a centerline.

    >>> from hdrfringe.core.captures import ProjectorInfo
    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> frames = [f for p in (1024.0, 16.0) for f in FringeSpec(pitch_px=p, migl=200).frames()]
    >>> x = np.tile(np.arange(32.0), (2, 1))
    >>> images = np.stack([np.rint(fringe_gray(x, f.spec, f.shift)) for f in frames])
    >>> caps = Captures(frames, images.astype(np.uint8), 8, projector=ProjectorInfo(width=1024))
    >>> fam = decode_captures(caps).primary
    >>> fam.orientation, fam.pitch_px
    ('vertical', 16.0)
    >>> fam.method
    'temporal 1024 -> 16 px (coarse set spans the projector with one period first)'
    >>> fam.absolute_method, bool(np.allclose(fam.absolute_phase * 16 / (2 * np.pi), x, atol=0.05))
    ('one-period coarse set', True)
    """

    orientation: str
    pitch_px: float
    sets: list[FringeSet]
    unwrapped_phase: NDArray[np.float64]
    absolute_phase: NDArray[np.float64] | None
    method: str
    absolute_method: str | None
    unwrapping: str = "spatial"
    regions: PhaseRegions | None = None
    graycode_valid: NDArray[np.bool_] | None = None

    @property
    def islands(self) -> bool:
        """Whether spatial unwrapping left two or more regions of unknown relative order."""
        return self.regions is not None and self.regions.islands

    def regions_summary(self) -> dict[str, Any] | None:
        """The regions in JSON form (``metrics.json``, ``phase_summary.json``), None without.

        Returns
        -------
        dict or None
            ``islands`` (flag: two or more significant regions, relative order unknown),
            ``count`` (significant regions), ``pixels`` (their pixel counts, largest first),
            ``specks`` and ``speck_pixels`` (the smaller regions).
        """
        r = self.regions
        if r is None:
            return None
        return {
            "islands": r.islands,
            "count": r.significant,
            "pixels": list(r.sizes[: r.significant]),
            "specks": len(r.sizes) - r.significant,
            "speck_pixels": int(sum(r.sizes[r.significant :])),
        }


@dataclass
class FolderPhase:
    """Everything :func:`decode_captures` computed.

    Parameters
    ----------
    set_results : dict of str to PhaseResult
        The decoded phase and quality maps of every fringe set, by set label.
    sets : list of FringeSet
        The fringe sets of the captures, in capture order.
    families : list of FamilyResult
        Unwrapped (and absolute) phase per family, primary family first: one per orientation.
    notes : list of str
        What could not be done and why (e.g. no centerline frame for an absolute phase).
    saturated : {"flag", "exclude"}
        How saturated shifts were treated (:data:`SATURATED_MODES`).
    inverted_sets : dict of str to str
        With ``saturated="exclude"``: set label -> label of its inverted set, decoded with
        it (the inverted sets are not in :attr:`sets`).
    harmonics : dict or None
        With harmonic compensation (``decode_captures(harmonics=...)`` not ``off``): ``mode``
        and per set label its estimate and whether it was ``applied``
        (:func:`hdrfringe.core.harmonics.compensate_sets`); None without.
    gamma_families : list of FamilyResult
        The families that differ from an orientation's family in :attr:`families` only in
        their gamma pre-compensation (a gamma capture: one set or pitch ladder per exponent),
        each unwrapped (and made absolute where it can be) within itself, in capture order.

    Attributes
    ----------
    primary : FamilyResult or None
        The first family (vertical at the highest MIGL), None without fringe sets.

    Examples
    --------
    One set of pitch 16 px and no centerline frame: unwrapped spatially, not absolute.

    >>> from hdrfringe.core.captures import ProjectorInfo
    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> spec = FringeSpec(steps=4, pitch_px=16.0, migl=200)
    >>> x = np.tile(np.arange(32.0), (2, 1))
    >>> images = np.stack([np.rint(fringe_gray(x, spec, k)) for k in range(4)]).astype(np.uint8)
    >>> out = decode_captures(Captures(spec.frames(), images, 8, projector=ProjectorInfo()))
    >>> list(out.set_results), out.primary.method, out.primary.absolute_phase
    (['s4_p16_v_i40_g200'], 'spatial', None)
    >>> out.notes
    ['vertical fringes: no vertical centerline frame, so no absolute phase']
    """

    set_results: dict[str, PhaseResult]
    sets: list[FringeSet]
    families: list[FamilyResult] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    saturated: str = "flag"
    inverted_sets: dict[str, str] = field(default_factory=dict)
    harmonics: dict[str, Any] | None = None
    gamma_families: list[FamilyResult] = field(default_factory=list)

    @property
    def primary(self) -> FamilyResult | None:
        """The primary family (the first of :attr:`families`), None when there is none."""
        return self.families[0] if self.families else None


def _family_key(s: FringeSet) -> tuple:
    sp = s.spec
    # gain and map are None for every set of a version-1 folder: the same families as before;
    # so is the per-set gamma pre-compensation of a folder that gives none (or one per folder).
    # Sets pre-distorted with different exponents (a gamma capture: the kamino410 sheet) are
    # separate families, each unwrapped on its own, not one pitch ladder with repeated pitches.
    return (
        sp.orientation,
        sp.pattern,
        sp.steps,
        sp.imin,
        sp.migl,
        s.exposure_ms,
        s.gain_db,
        s.migl_map_sha256,
        s.gamma_precompensation,
    )


def group_families(sets: Sequence[FringeSet]) -> list[list[FringeSet]]:
    """Group sets into families (same everything but pitch), primary family first.

    Parameters
    ----------
    sets : sequence of FringeSet
        E.g. :attr:`Captures.sets <hdrfringe.core.captures.Captures.sets>`.

    Returns
    -------
    list of list of FringeSet
        One family per orientation (the vertical one first, then by highest MIGL), each
        ordered coarse to fine.

    Examples
    --------
    >>> from hdrfringe.core.captures import group_fringe_sets
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> frames = [*FringeSpec(pitch_px=8.0).frames(), *FringeSpec(pitch_px=48.0).frames()]
    >>> [[s.spec.pitch_px for s in fam] for fam in group_families(group_fringe_sets(frames))]
    [[48.0, 8.0]]
    """
    fams: dict[tuple, list[FringeSet]] = {}
    for s in sets:
        fams.setdefault(_family_key(s), []).append(s)
    ordered = sorted(
        fams.values(),
        key=lambda f: (f[0].spec.orientation != "vertical", -f[0].spec.migl, f[0].spec.pattern),
    )
    out: list[list[FringeSet]] = []
    seen_orient: set[str] = set()
    for fam in ordered:
        o = fam[0].spec.orientation
        if o in seen_orient:
            continue
        seen_orient.add(o)
        out.append(sorted(fam, key=lambda s: -s.spec.pitch_px))
    return out


def no_absolute_phase_note(orientation: str) -> str:
    """The note :func:`decode_captures` adds for a family it cannot make absolute.

    Parameters
    ----------
    orientation : str
        ``"vertical"`` or ``"horizontal"``.

    Returns
    -------
    str
        The note; a later step that gives the family its absolute phase (the geometric fringe
        order of ``measure --depth-range``) replaces it.

    Examples
    --------
    >>> no_absolute_phase_note("vertical")
    'vertical fringes: no vertical centerline frame, so no absolute phase'
    """
    return f"{orientation} fringes: no {orientation} centerline frame, so no absolute phase"


def _check_pitch_ladders(captures: Captures, families: Sequence[Sequence[FringeSet]]) -> None:
    """Refuse a family with two sets at one pitch: its sets do not form a pitch ladder
    (coarse to fine) that temporal unwrapping could follow; the message names the sets to keep
    one of. (Sets of one pitch pre-distorted with different exponents, a gamma capture, are
    separate families: :func:`_family_key`.)
    """
    for fam in families:
        by_pitch: dict[float, list[FringeSet]] = {}
        for s in fam:
            by_pitch.setdefault(s.spec.pitch_px, []).append(s)
        same = [group for group in by_pitch.values() if len(group) > 1]
        if not same:
            continue
        group = same[0]
        orient, pitch = group[0].spec.orientation, group[0].spec.pitch_px
        labels = ", ".join(s.label for s in group)
        offsets = {round((s.spec.phase_offset_deg % 360.0), 6) for s in group}
        if len(group) == 2 and len(offsets) == 2:
            a, b = sorted(offsets)
            if abs((b - a) - 180.0) < 1e-6:
                raise CaptureFormatError(
                    f"{captures.name}: the {orient} fringe sets {labels} have pitch {pitch:g} px "
                    "and are a set and its inverse (180 degrees apart), not a pitch ladder; "
                    "decode them as a pair with --saturated exclude (phase or measure), or keep "
                    "one of them"
                )
        raise CaptureFormatError(
            f"{captures.name}: the {orient} fringe sets {labels} all have pitch {pitch:g} px, so "
            "they do not form a pitch ladder (one set per pitch, coarse to fine); keep one of "
            "them (remove the others' frames from manifest.json)"
        )


def _other_gamma_families(
    captures: Captures,
    sets: Sequence[FringeSet],
    families: Sequence[Sequence[FringeSet]],
    notes: list[str],
) -> list[list[FringeSet]]:
    """The families of sets that differ from an unwrapped family only in their gamma
    pre-compensation (a gamma capture), coarse to fine each, in capture order; a note names
    them. Each is unwrapped within itself (issue 31): one family per orientation is what
    :func:`group_families` gives."""
    gamma0 = captures.projector.gamma_precompensation if captures.projector else 1.0
    unwrapped = {id(s) for fam in families for s in fam}
    out: list[list[FringeSet]] = []
    for fam in families:
        key = _family_key(fam[0])[:-1]
        others = [s for s in sets if id(s) not in unwrapped and _family_key(s)[:-1] == key]
        if not others:
            continue
        groups: dict[tuple, list[FringeSet]] = {}
        for s in others:
            groups.setdefault(_family_key(s), []).append(s)
        out += [sorted(g, key=lambda s: -s.spec.pitch_px) for g in groups.values()]
        exponents = sorted({s.gamma_precompensation or gamma0 for s in others})
        notes.append(
            f"{fam[0].spec.orientation} fringes: the sets "
            f"{', '.join(s.label for s in others)} (gamma pre-compensation "
            f"{', '.join(f'{g:g}' for g in exponents)}) are unwrapped as families of their own, "
            f"one per exponent, beside the one pre-compensated with "
            f"{fam[0].gamma_precompensation or gamma0:g}"
        )
    return out


def _check_decode_options(
    captures: Captures,
    min_modulation: float | None,
    saturated: str,
    map_dtype: str,
    harmonics: str | int,
) -> None:
    """InputError for options :func:`decode_captures` cannot combine or does not know."""
    check_min_modulation(min_modulation, captures.camera_bit_depth)
    if saturated not in SATURATED_MODES:
        raise InputError(
            f"saturated mode {saturated!r} is unknown; give one of {', '.join(SATURATED_MODES)}"
        )
    if map_dtype not in ("float64", "float32"):
        raise InputError(f"map_dtype {map_dtype!r} is unknown; give float64 or float32")
    if map_dtype != "float64" and saturated != "flag":
        raise InputError(
            f"map_dtype {map_dtype} applies to saturated='flag'; leave map_dtype at float64 "
            "with saturated='exclude'"
        )
    if harmonics_mode(harmonics)[0] != "off" and saturated != "flag":
        raise InputError(
            "harmonic compensation needs every shift in each pixel's phase; it does not apply "
            "to saturated='exclude' (drop one of them)"
        )


def _decode_every_set(
    captures: Captures,
    min_modulation: float | None,
    reject_saturated: bool,
    saturated: str,
    min_shifts: int,
    map_dtype: str,
    final_only: bool = False,
) -> FolderPhase:
    """Each set's wrapped phase (no family yet): the tolerant decoder with ``exclude``;
    ``final_only``: the quality maps of the sets not finest in their family dropped."""
    if saturated == "exclude":
        return _decode_excluding(captures, min_modulation, min_shifts)
    finest = {fam[-1].label for fam in group_families(captures.sets)}
    results = {}
    for s in captures.sets:
        res = decode_set(
            captures.set_images(s),
            s.spec,
            captures.camera_bit_depth,
            min_modulation=min_modulation,
            reject_saturated=reject_saturated,
            dtype=np.dtype(map_dtype),
        )
        if final_only and s.label not in finest:
            gone = np.broadcast_to(res.wrapped_phase.dtype.type(np.nan), res.wrapped_phase.shape)
            res = dataclasses.replace(
                res, modulation=gone, mean_intensity=gone, data_modulation=gone
            )
        results[s.label] = res
    return FolderPhase(set_results=results, sets=list(captures.sets))


@dataclass
class _Unwrapped:
    """A family's phase unwrapped from its coarsest set down (internal to decode_captures)."""

    phase: NDArray[np.float64]
    method: str
    unwrapping: str
    #: the coarsest set spans the projector; the Gray code used (None: none); its valid pixels
    spans: bool
    code: GrayCodeSet | None
    graycode_valid: NDArray[np.bool_] | None


def _unwrap_family(
    captures: Captures,
    fam: Sequence[FringeSet],
    results: Mapping[str, PhaseResult],
    codes: Mapping[str, GrayCodeSet],
    notes: list[str],
) -> _Unwrapped:
    """The coarsest set's fringe order (one period, Gray code or spatial), then temporal
    unwrapping down the family's pitches."""
    orient = fam[0].spec.orientation
    coarse = fam[0]
    extent = None
    if captures.projector is not None:
        extent = captures.projector.width if orient == "vertical" else captures.projector.height
    spans = extent is not None and coarse.spec.pitch_px >= extent
    coarse_phase = results[coarse.label].wrapped_phase
    code = None if spans else codes.get(orient)
    if code is not None and code.stripe_px > coarse.spec.pitch_px:
        notes.append(
            f"{orient} fringes: the Gray code's stripe ({code.stripe_px:g} px) is wider than "
            f"the coarsest pitch ({coarse.spec.pitch_px:g} px), so it cannot fix the fringe "
            "order; not used"
        )
        code = None
    gc_valid = None
    if spans:
        # float32 maps: float64 phases (unwrap_temporal widens them block by block itself)
        base = coarse_phase if len(fam) > 1 else np.asarray(coarse_phase, dtype=np.float64)
        method = "coarse set spans the projector with one period"
        unwrapping = "one-period"
    elif code is not None:
        gdec, how = _decode_graycode(captures, code, results[coarse.label])
        gc_phase = absolute_phase_graycode(
            coarse_phase, gdec.index, stripe_px=code.stripe_px, pitch_px=coarse.spec.pitch_px
        )
        base = gc_phase.phase
        gc_valid = gdec.valid
        method = f"Gray code + phase ({gc_phase.method}; bits {how})"
        unwrapping = "graycode"
    else:
        base = unwrap_spatial(coarse_phase)
        method = "spatial"
        unwrapping = "spatial"
    if len(fam) > 1:
        phases = [base] + [results[s.label].wrapped_phase for s in fam[1:]]
        unwrapped = unwrap_temporal(
            phases, [s.spec.pitch_px for s in fam], coarse_unwrapped=not spans
        )
        method = f"temporal {' -> '.join(f'{s.spec.pitch_px:g}' for s in fam)} px ({method} first)"
    else:
        unwrapped = base
    return _Unwrapped(unwrapped, method, unwrapping, spans, code, gc_valid)


def _absolute_of_family(
    captures: Captures,
    fam: Sequence[FringeSet],
    results: Mapping[str, PhaseResult],
    unw: _Unwrapped,
    given: NDArray[np.float64] | None,
    notes: list[str],
) -> tuple[NDArray[np.float64] | None, str | None]:
    """The family's absolute phase and how it was obtained (None, None: it cannot be).
    A ``given`` phase replaces ``unw``'s phase, method and unwrapping."""
    orient = fam[0].spec.orientation
    coarse, finest = fam[0], fam[-1]
    if given is not None:  # the caller's phase replaces the family's own unwrapping
        phi = results[finest.label].wrapped_phase
        ref = np.asarray(given, dtype=np.float64)
        if ref.shape != phi.shape:
            raise InputError(
                f"given {orient} absolute phase has shape {ref.shape}, the images {phi.shape}; "
                "give one absolute phase per camera pixel"
            )
        # the caller's phase, where the captured finest set decodes (its validity rules)
        unw.phase = np.where(np.isfinite(phi), ref, np.nan)
        unw.method = f"absolute phase given for the {finest.spec.pitch_px:g} px set"
        unw.unwrapping = "given"
        return unw.phase, unw.method
    if unw.spans:
        return unw.phase, "one-period coarse set"
    if unw.code is not None:
        return unw.phase, (
            f"Gray code ({unw.code.bits} bits, stripe {unw.code.stripe_px:g} px) + phase of the "
            f"{coarse.spec.pitch_px:g} px set"
        )
    lines = [(f, img) for f, img in captures.centerlines() if f.orientation == orient]
    if lines:
        frame, img = lines[0]
        absolute = absolute_phase_from_centerline(
            unw.phase, img, frame.position, finest.spec.pitch_px, orient
        )
        return absolute, f"centerline at {frame.position:g} px (Eq. 2.12-2.13)"
    notes.append(no_absolute_phase_note(orient))
    return None, None


def _family_result(
    captures: Captures,
    fam: list[FringeSet],
    results: Mapping[str, PhaseResult],
    codes: Mapping[str, GrayCodeSet],
    given: NDArray[np.float64] | None,
    notes: list[str],
) -> FamilyResult:
    """One family unwrapped, made absolute where it can be, with its spatial regions."""
    unw = _unwrap_family(captures, fam, results, codes, notes)
    absolute, abs_method = _absolute_of_family(captures, fam, results, unw, given, notes)
    return FamilyResult(
        fam[0].spec.orientation,
        fam[-1].spec.pitch_px,
        fam,
        unw.phase,
        absolute,
        unw.method,
        abs_method,
        unw.unwrapping,
        _spatial_regions(fam, results, unw, notes),
        unw.graycode_valid,
    )


def _spatial_regions(
    fam: Sequence[FringeSet],
    results: Mapping[str, PhaseResult],
    unw: _Unwrapped,
    notes: list[str],
) -> PhaseRegions | None:
    """With spatial unwrapping, the regions whose relative fringe order is unknown (a note
    where there are several)."""
    if unw.unwrapping != "spatial":
        return None
    orient = fam[0].spec.orientation
    regions = phase_regions([results[s.label].wrapped_phase for s in fam], np.isfinite(unw.phase))
    if regions.islands:
        sizes = ", ".join(str(v) for v in regions.sizes[: regions.significant])
        notes.append(
            f"{orient} fringes: the valid area falls into {regions.significant} separate "
            f"regions ({sizes} pixels); spatial unwrapping cannot relate their fringe "
            "orders, so their phases are not comparable (see the region map; a Gray "
            "code or a one-period set gives every pixel its absolute order)"
        )
    return regions


def decode_captures(
    captures: Captures,
    *,
    min_modulation: float | None = None,
    reject_saturated: bool = True,
    saturated: str = "flag",
    min_shifts: int = 3,
    given_phases: Mapping[str, NDArray[np.float64]] | None = None,
    map_dtype: str = "float64",
    harmonics: str | int = "off",
    quality_maps: str = "every",
) -> FolderPhase:
    """Decode every set of the captures; unwrap and make absolute where the captures allow.

    Parameters
    ----------
    captures : Captures
        Read from a capture folder or made in memory.
    min_modulation : float, optional
        Validity threshold on I' in DN (default per bit depth, see
        :func:`hdrfringe.core.phase.default_min_modulation`).
    reject_saturated : bool
        Invalidate pixels with any saturated shift (default True; ``saturated="flag"`` only).
    saturated : {"flag", "exclude"}
        ``flag`` (default): every set by :func:`hdrfringe.core.phase.decode_set`. ``exclude``:
        every sinusoidal set by :func:`hdrfringe.core.saturation.tolerant.decode_set_tolerant`,
        each pixel from its unsaturated shifts; a set whose inverted set (the same set with
        180 degrees more phase offset, same exposure, gain and map) is in the captures is
        decoded with it, and the inverted set is not a set of its own. Triangular sets are
        decoded as with ``flag``.
    min_shifts : int
        With ``exclude``: least number of unsaturated images per pixel (>= 3).
    given_phases : mapping, optional
        Orientation -> the absolute phase of that family's finest set as a strategy computed
        it (the adaptive projection unwraps it with its mapping's fringe orders and corrects
        its map's bias, :mod:`hdrfringe.strategies.adaptive`); it replaces the family's own
        unwrapping wherever the captured finest set decodes (valid, unsaturated).
    map_dtype : {"float64", "float32"}
        Storage of each set's float maps, ``saturated="flag"`` only (``dtype`` of
        :func:`hdrfringe.core.phase.decode_set`: computed in float64, float32 rounds the stored
        maps, halving their memory). The unwrapped and absolute phases are float64 either way,
        computed from the stored wrapped phases.
    harmonics : {"off", "auto"} or int
        Fringe-harmonic compensation (docs/harmonics.md, :mod:`hdrfringe.core.harmonics`): ``off``
        (default) decodes as always; ``auto`` estimates each sinusoidal set's harmonic phase
        error from its own wrapped phase and removes it where it is significant; a number K
        removes K orders whatever their size. It acts on the wrapped phases before any
        unwrapping; :attr:`FolderPhase.harmonics` records what was estimated and applied.
        Only with ``saturated="flag"``.
    quality_maps : {"every", "final"}
        ``every`` (default): every set's result holds its modulation, mean intensity and data
        modulation. ``final``: only each family's finest set keeps them (what ``phase`` writes
        without ``--per-set-maps``); the other sets' are dropped as soon as the set is decoded,
        and their wrapped phases once their family is unwrapped, and read as NaN (read-only
        views of one value, no memory), which bounds a large folder's memory to one set's maps
        plus the others' phases. The finest sets' maps, every set's validity and saturation
        count, and the unwrapped and absolute phases are the same either way. With a Gray
        code in the captures (its threshold may come from the coarsest set's mean) or
        ``saturated="exclude"``, every set keeps them.

    Returns
    -------
    FolderPhase
        Per-set results and, per family, the unwrapped and absolute phase.

    Raises
    ------
    InputError
        ``min_modulation`` not a number of DN in ``0 .. full_scale / 2`` (NaN made every pixel
        invalid and was blamed on the centerline); an unknown ``saturated`` mode or
        ``map_dtype``, or float32 maps with ``saturated="exclude"``.

    References
    ----------
    Thesis Eq. 2.2/2.4 (wrapped phase), Sec. 2.4 (unwrapping), Eq. 2.12-2.13 (absolute phase
    from a centerline).

    Examples
    --------
    >>> import numpy as np
    >>> from hdrfringe.core.captures import ProjectorInfo
    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> spec = FringeSpec("sinusoidal", 4, 1024.0)
    >>> x = np.tile(np.arange(16.0), (4, 1))
    >>> images = np.stack([np.rint(fringe_gray(x, spec, k)) for k in range(4)]).astype(np.uint8)
    >>> decoded = decode_captures(Captures(spec.frames(), images, 8, projector=ProjectorInfo()))
    >>> decoded.primary.absolute_method
    'one-period coarse set'
    """
    _check_decode_options(captures, min_modulation, saturated, map_dtype, harmonics)
    if quality_maps not in ("every", "final"):
        raise InputError(f"quality_maps {quality_maps!r} is unknown; give every or final")
    final_only = quality_maps == "final" and saturated == "flag" and not captures.graycode_sets()
    out = _decode_every_set(
        captures, min_modulation, reject_saturated, saturated, min_shifts, map_dtype, final_only
    )
    _compensate_harmonics(out, harmonics)
    results = out.set_results  # the families unwrap the compensated phases
    if not captures.sets:
        out.notes.append("no fringe sets: nothing to decode")
        return out
    codes = {g.orientation: g for g in captures.graycode_sets()}
    families = group_families(out.sets)
    _check_pitch_ladders(captures, families)
    others = _other_gamma_families(captures, out.sets, families, out.notes)
    _check_pitch_ladders(captures, others)
    for fam in families:
        given = None if given_phases is None else given_phases.get(fam[0].spec.orientation)
        out.families.append(_family_result(captures, fam, results, codes, given, out.notes))
    for fam in others:  # a gamma capture's other exponents: each family on its own
        notes: list[str] = []  # the orientation's notes are said once, by its family above
        out.gamma_families.append(_family_result(captures, fam, results, codes, None, notes))
        out.notes += [n for n in notes if n not in out.notes]
    if final_only:  # the coarser sets' phases served their families: dropped as well
        finest = {f.sets[-1].label for f in [*out.families, *out.gamma_families]}
        for label, res in list(results.items()):
            if label not in finest:
                gone = np.broadcast_to(res.wrapped_phase.dtype.type(np.nan), res.valid.shape)
                results[label] = dataclasses.replace(res, wrapped_phase=gone)
    return out


def _compensate_harmonics(out: FolderPhase, harmonics: str | int) -> None:
    """Replace the sets' wrapped phases by their harmonic-compensated ones (not with ``off``:
    the decode stays bit for bit what it was) and record the estimates."""
    if harmonics_mode(harmonics)[0] == "off":
        return
    out.set_results, out.harmonics = compensate_sets(out.sets, out.set_results, harmonics)


# --- saturated="exclude": the saturation-tolerant decoder (docs/tolerant.md) -----------------


def _is_inverse(a: FringeSet, b: FringeSet) -> bool:
    """Whether ``b`` is ``a``'s inverted set: 180 degrees more phase, everything else equal."""
    if a.spec.pattern != "sinusoidal" or b.spec.pattern != "sinusoidal":
        return False
    turn = (b.spec.phase_offset_deg - a.spec.phase_offset_deg) % 360.0
    same = dataclasses.replace(b.spec, phase_offset_deg=a.spec.phase_offset_deg) == a.spec
    return (
        abs(turn - 180.0) < 1e-9
        and same
        and (a.exposure_ms, a.gain_db, a.migl_map_sha256)
        == (b.exposure_ms, b.gain_db, b.migl_map_sha256)
    )


def _decode_excluding(
    captures: Captures, min_modulation: float | None, min_shifts: int
) -> FolderPhase:
    """Every set decoded from its unsaturated shifts, with its inverted set where there is one."""
    sets = list(captures.sets)
    partner: dict[str, FringeSet] = {}
    taken: set[str] = set()
    for i, a in enumerate(sets):
        if a.label in taken:
            continue
        for b in sets[i + 1 :]:
            if b.label not in taken and b.label not in partner and _is_inverse(a, b):
                partner[a.label] = b
                taken.add(b.label)
                break
    kept = [s for s in sets if s.label not in taken]
    results: dict[str, PhaseResult] = {}
    bits = captures.camera_bit_depth
    for s in kept:
        if s.spec.pattern != "sinusoidal":
            results[s.label] = decode_set(
                captures.set_images(s), s.spec, bits, min_modulation=min_modulation
            )
            continue
        inv = partner.get(s.label)
        results[s.label] = decode_set_tolerant(
            captures.set_images(s),
            s.spec,
            bits,
            inverted=None if inv is None else captures.set_images(inv),
            min_modulation=min_modulation,
            min_shifts=min_shifts,
        )
    return FolderPhase(
        set_results=results,
        sets=kept,
        saturated="exclude",
        inverted_sets={k: v.label for k, v in partner.items()},
    )


def _decode_graycode(
    captures: Captures, code: GrayCodeSet, fringe: PhaseResult
) -> tuple[GrayCodeDecode, str]:
    """Stripe index of every pixel and how its bits were decided (docs/graycode.md).

    Inverse pairs: ``pattern > inverse``. Otherwise a threshold: ``(white + black) / 2`` from
    uniform frames at the code's level and at 0; without them, the mean intensity of the
    family's coarsest fringe set (the level halfway between its dark and bright stripes when
    the fringes span the code's levels), with ``2 I'`` as the contrast.
    """
    fs = full_scale(captures.camera_bit_depth)
    min_contrast = 5.0 * fs / 255.0  # OpenCV's default "white threshold", 5 DN at 8 bits
    images = captures.images  # only the code's frames in float64, not the whole stack
    pattern = images[list(code.frame_indices)].astype(np.float64)
    if code.inverse_indices is not None:
        dec = decode_graycode(
            pattern,
            inverses=images[list(code.inverse_indices)].astype(np.float64),
            code=code.code,
            min_contrast=min_contrast,
            full_scale=fs,
        )
        return dec, "from pattern/inverse pairs"
    uniforms = captures.uniforms()
    whites = [img for f, img in uniforms if f.level > 0]
    blacks = [img for f, img in uniforms if f.level == 0]
    if whites and blacks:
        top = max(f.level for f, _ in uniforms)
        white = next(img for f, img in uniforms if f.level == top).astype(np.float64)
        black = blacks[0].astype(np.float64)
        threshold, contrast = (white + black) / 2, white - black
        how = f"against (white + black)/2 (uniform frames at {top:g} and 0)"
    else:
        threshold, contrast = fringe.mean_intensity, 2 * fringe.modulation
        how = "against the mean intensity of the coarsest fringe set (no white frame)"
    dec = decode_graycode(
        pattern,
        threshold=threshold,
        contrast=contrast,
        code=code.code,
        min_contrast=min_contrast,
        full_scale=fs,
    )
    return dec, how
