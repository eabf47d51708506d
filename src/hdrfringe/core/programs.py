"""Projector programs: the frame sequences ``patterns`` writes and ``simulate`` captures.

A program is a list of :mod:`hdrfringe.core.frames` in play order: phase-shifted fringe sets over
orientations, MIGLs and pitches, a centerline per orientation, then uniform grays.
:func:`fringe_program` builds one for a projector and checks it fits (levels within the
projector's range, counts within :mod:`hdrfringe.core.limits`) before anything is rendered or
captured.

Examples
--------
>>> from hdrfringe.core.captures import ProjectorInfo
>>> frames = fringe_program("sinusoidal", 3, [8.0], projector=ProjectorInfo(), grays=[128])
>>> [f.default_name() for f in frames]
['s3_p8_v_i40_g255_0', 's3_p8_v_i40_g255_1', 's3_p8_v_i40_g255_2', 'centerline_v_512_g255', \
'gray_128']
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from hdrfringe.core._validation import full_scale
from hdrfringe.core.captures import ProjectorInfo
from hdrfringe.core.frames import CenterlineFrame, Frame, UniformFrame, render_frame
from hdrfringe.core.limits import (
    MAX_PROGRAM_FRAMES,
    MAX_PROJECTOR_PIXELS,
    MAX_STEPS,
    check_count,
)
from hdrfringe.core.patterns import ORIENTATIONS, FringeSpec
from hdrfringe.errors import InputError

__all__ = [
    "DEFAULT_PITCHES_PX",
    "centerline_frame",
    "check_projector_size",
    "fringe_program",
    "fringe_specs",
]

#: The default pitch ladder in projector px, coarsest first: one period across a 1024 px wide
#: projector (the coarse phase is absolute without a fringe order), then 64 and 8 px (pitch
#: ratios 16 and 8 for temporal unwrapping, thesis Sec. 2.3.2). ``measure``, ``capture``,
#: ``compare`` and the demo use it; every other ladder is given explicitly.
DEFAULT_PITCHES_PX: tuple[float, ...] = (1024.0, 64.0, 8.0)


def check_projector_size(projector: ProjectorInfo) -> ProjectorInfo:
    """Refuse a projector whose images would not fit the resource limits.

    Parameters
    ----------
    projector : ProjectorInfo
        Resolution to check.

    Returns
    -------
    ProjectorInfo
        ``projector``, unchanged.

    Raises
    ------
    InputError
        A width or height below 1, or more than :data:`~hdrfringe.core.limits.MAX_PROJECTOR_PIXELS`
        pixels.

    Examples
    --------
    >>> check_projector_size(ProjectorInfo(1920, 1080)).width
    1920
    """
    w, h = projector.width, projector.height
    if w < 1 or h < 1:
        raise InputError(f"projector resolution must be positive, got {w}x{h}")
    check_count(
        w * h,
        MAX_PROJECTOR_PIXELS,
        f"projector pixels ({w}x{h})",
        fix="give a smaller --width/--height",
    )
    return projector


def fringe_program(
    pattern: str = "sinusoidal",
    steps: int = 3,
    pitches: Sequence[float] = (8.0,),
    orientations: Sequence[str] = ("vertical",),
    imin: float = 40.0,
    migls: Sequence[float] = (255.0,),
    *,
    projector: ProjectorInfo,
    centerline: bool = True,
    centerline_position: float | None = None,
    centerline_level: float | None = None,
    grays: Sequence[float] = (),
    level_bits: int | None = None,
) -> list[Frame]:
    """The frames of a fringe program, in play order, checked against the projector.

    For each orientation: for each MIGL, for each pitch, the ``steps`` frames of a
    :class:`~hdrfringe.core.patterns.FringeSpec`; then (``centerline``) that orientation's
    centerline frame. Last, one uniform frame per gray level.

    Parameters
    ----------
    pattern : {"sinusoidal", "triangular"}
        Fringe profile (thesis Eq. 2.1 / 2.7).
    steps : int
        Phase shifts N per set (at most :data:`~hdrfringe.core.limits.MAX_STEPS`).
    pitches : sequence of float
        Fringe pitches in projector pixels.
    orientations : sequence of {"vertical", "horizontal"}
        One family of sets (and one centerline) per orientation.
    imin : float
        Minimum input gray level of the fringes.
    migls : sequence of float
        Maximum input gray levels (MIGL, thesis Sec. 4.1); several make a MIGL sweep.
    projector : ProjectorInfo
        The projector the program plays on: its size places the default centerline, its bit
        depth bounds every level.
    centerline : bool
        Add a centerline frame per orientation (absolute phase, thesis Eq. 2.12-2.13).
    centerline_position : float, optional
        Projector coordinate of the line; default the middle (``extent // 2``).
    centerline_level : float, optional
        Gray level of the line; default the projector's full scale.
    grays : sequence of float
        Uniform gray levels added at the end (e.g. for :mod:`hdrfringe.core.gamma`).
    level_bits : int, optional
        None: ``imin``, ``migls``, ``grays`` and ``centerline_level`` are projector input levels.
        An int B: they are given on a B-bit scale and converted to the projector's,
        ``g * (2^Bp - 1) / (2^B - 1)`` (8-bit levels for the 16-bit ideal rig).

    Returns
    -------
    list of Frame

    Raises
    ------
    InputError
        An unknown orientation or pattern, too few or too many steps, an empty list of pitches
        or MIGLs, a pitch, MIGL or orientation given twice, more than
        :data:`~hdrfringe.core.limits.MAX_PROGRAM_FRAMES` frames, a level outside the projector's
        range, a centerline position off the projector.

    References
    ----------
    Thesis Sec. 2.2 (phase-shifted fringe sets, Eq. 2.1), Sec. 2.4 (centerline), Sec. 4.1
    (MIGL).

    Examples
    --------
    >>> p16 = ProjectorInfo(bit_depth=16)
    >>> frames = fringe_program(steps=4, migls=[255, 128], projector=p16, level_bits=8,
    ...                         orientations=["vertical", "horizontal"])
    >>> len(frames), frames[4].spec.migl, frames[8].migl, frames[9].spec.orientation
    (18, 32896.0, 65535, 'horizontal')
    """
    for o in orientations:
        if o not in ORIENTATIONS:
            raise InputError(f"unknown orientation {o!r}; use one of {', '.join(ORIENTATIONS)}")
    if not pitches or not migls:
        raise InputError("a fringe program needs at least one pitch and one MIGL")
    check_count(steps, MAX_STEPS, "phase shifts (steps)", fix="give fewer --steps")
    n_frames = len(orientations) * (
        len(migls) * len(pitches) * int(steps) + bool(centerline)
    ) + len(grays)
    check_count(
        n_frames,
        MAX_PROGRAM_FRAMES,
        "frames in the program",
        fix="use fewer steps, pitches, MIGLs or gray levels",
    )
    full = full_scale(projector.bit_depth, "projector bit depth")
    given = None if level_bits is None else full_scale(level_bits, "level_bits")

    def level(g: float) -> float:
        return g if given is None else g * full / given

    for what, values in (("pitch", pitches), ("MIGL", migls), ("orientation", orientations)):
        seen: set[object] = set()
        for v in values:
            if v in seen:
                shown = v if isinstance(v, str) else f"{v:g}"
                raise InputError(f"{what} {shown} appears twice in the program; give each once")
            seen.add(v)
    for g in grays:
        if not 0 <= level(g) <= full:
            raise InputError(
                f"gray level {g:g} is outside the projector's 0..{full} "
                f"({projector.bit_depth} bits); give levels within it"
            )
    frames: list[Frame] = []
    for o in orientations:
        for m in migls:
            for spec in fringe_specs(pattern, steps, pitches, o, level(imin), level(m)):
                frames += spec.frames()
        if centerline:
            lvl = None if centerline_level is None else level(centerline_level)
            frames.append(centerline_frame(projector, o, centerline_position, lvl))
    frames += [UniformFrame(level(g)) for g in grays]
    for f in frames:  # every level within the projector's range, before anything is rendered
        render_frame(f, 1, 1, projector.gamma_precompensation, projector.bit_depth)
    return frames


def fringe_specs(
    pattern: str = "sinusoidal",
    steps: int = 4,
    pitches: Sequence[float] = DEFAULT_PITCHES_PX,
    orientation: str = "vertical",
    imin: float = 40.0,
    migl: float = 255.0,
) -> list[FringeSpec]:
    """One fringe set per pitch, in the order given: the sets every program is built from.

    Parameters
    ----------
    pattern : {"sinusoidal", "triangular"}
        Fringe profile.
    steps : int
        Phase shifts N per set.
    pitches : sequence of float
        Pitches in projector px (default :data:`DEFAULT_PITCHES_PX`).
    orientation : {"vertical", "horizontal"}
        Fringe orientation.
    imin, migl : float
        Lowest and highest input gray level (projector levels).

    Returns
    -------
    list of FringeSpec

    Examples
    --------
    >>> [s.label() for s in fringe_specs()]
    ['s4_p1024_v_i40_g255', 's4_p64_v_i40_g255', 's4_p8_v_i40_g255']
    """
    return [FringeSpec(pattern, steps, p, orientation, imin, migl) for p in pitches]  # type: ignore[arg-type]


def centerline_frame(
    projector: ProjectorInfo,
    orientation: str = "vertical",
    position: float | None = None,
    level: float | None = None,
) -> CenterlineFrame:
    """The centerline frame of one orientation (thesis Sec. 2.4), checked against the projector.

    Parameters
    ----------
    projector : ProjectorInfo
        The projector: its extent across the fringes places the default line, its bit depth
        gives the default level.
    orientation : {"vertical", "horizontal"}
        Orientation of the fringes the line makes absolute.
    position : float, optional
        Projector coordinate of the line; default the middle (``extent // 2``).
    level : float, optional
        Gray level of the line (projector levels); default the projector's full scale.

    Returns
    -------
    CenterlineFrame

    Raises
    ------
    InputError
        A position off the projector.

    Examples
    --------
    >>> centerline_frame(ProjectorInfo(1024, 768, 8)).default_name()
    'centerline_v_512_g255'
    """
    extent = projector.width if orientation == "vertical" else projector.height
    pos = extent // 2 if position is None else position
    if not (math.isfinite(pos) and 0 <= pos <= extent - 1):
        raise InputError(
            f"centerline position {pos:g} is outside the projector's 0..{extent - 1} px "
            f"({orientation} fringes); give a position on the projector"
        )
    full = full_scale(projector.bit_depth, "projector bit depth")
    return CenterlineFrame(pos, orientation, full if level is None else level)  # type: ignore[arg-type]
