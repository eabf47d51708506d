"""Constants, options and the calibrated artefacts of ``hdrfringe acceptance``
(:mod:`hdrfringe.tasks.acceptance`; split from it without a change of behaviour)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core import acceptance as acc
from hdrfringe.core.strict_json import plain
from hdrfringe.errors import InputError
from hdrfringe.io.acceptance_file import (
    AcceptanceFile,
    BallBarArtefact,
    PlaneArtefact,
    SphereArtefact,
    load_acceptance_file,
)

__all__ = [
    "ACCEPTANCE_JSON",
    "ACCEPTANCE_MD",
    "BALL_BAR_NECK_DEG",
    "CALIBRATION_REPEATS",
    "DEFAULT_BOARD",
    "DEFAULT_PITCHES",
    "DEFAULT_SIZE",
    "KINDS",
    "MAX_VIEW_DEG",
    "PLANE_BAND_FRACTION",
    "PLANE_SLAB_FRACTION",
    "POSITION_FILE",
    "SIM_MPES",
    "STEPS",
    "Artefacts",
    "parse_positions",
    "parse_size",
]

#: The sidecar of a position's capture folder: kind, index, label, nominal centres.
POSITION_FILE = "acceptance_position.json"
ACCEPTANCE_JSON = "acceptance.json"
ACCEPTANCE_MD = "acceptance.md"
#: The camera of the virtual rig unless ``--size`` says otherwise (the calibration rig's).
DEFAULT_SIZE = (640, 480)
#: The fringes every position is measured with: vertical sinusoidal 4-step sets, the coarsest
#: spanning the projector (absolute phase), the board poses' ladder.
DEFAULT_PITCHES = (1024.0, 96.0, 16.0)
STEPS = 4
#: The board of the virtual calibration (``calibrate-stereo --rig sim --board``).
DEFAULT_BOARD = "checkerboard:9x6:25"
#: The artefact kinds, in the order positions run and ``--positions`` names them.
KINDS = ("sphere", "ball_bar", "plane")
#: The selection band of a plane, a share of its width (a sphere's is 5 % of its diameter,
#: :func:`hdrfringe.core.acceptance.segment_sphere`): wide enough not to clip the noise of a
#: 640 x 480 virtual camera (F about 2 mm), narrow enough to leave the base out.
PLANE_BAND_FRACTION = 0.05
#: With a nominal plane (the virtual rig's positions, a sidecar's ``expected``), the plane is
#: searched among the points within this share of its width of the nominal plane.
PLANE_SLAB_FRACTION = 0.25
#: The MPEs of a run on the virtual rig without an acceptance file (mm; docs/acceptance.md,
#: "The acceptance command"): above the largest values the 640 x 480 virtual rig measures on
#: the matte artefacts with its own board calibration (PF 1.8, PS 0.02, SD 0.03, F 3.8 mm with
#: the edge rules; PF 4.4, PS 0.29, SD 0.22 mm before them), below what a calibration 1 % too
#: long gives (PS +0.7, SD +1.9 mm). Our choice for this rig, not a data sheet's.
SIM_MPES = acc.MpeSet(acc.Mpe(5.0), acc.Mpe(0.5), acc.Mpe(0.5), acc.Mpe(5.0))
#: Edge rules of the sphere fits (docs/acceptance.md, "Edge rules"): a sphere's points seen
#: at more than this angle between normal and line of sight are its rim, left out
#: (:func:`hdrfringe.core.acceptance.grazing_points`).
MAX_VIEW_DEG = 70.0
#: A ball-bar sphere's points within this angle of the axis to the other sphere are its neck,
#: where the rod joins it, left out (:func:`hdrfringe.core.acceptance.neck_points`): a rod up to
#: half the ball's radius (sin 30 deg) and the blur around it.
BALL_BAR_NECK_DEG = 30.0
#: Calibrations besides the run's own (``calibrate-stereo --rig sim`` with the next noise
#: seeds) whose spread of PS and SD is the calibration's part of the predicted std
#: (docs/acceptance.md, "The calibration's part").
CALIBRATION_REPEATS = 4

F64 = NDArray[np.float64]


# --------------------------------------------------------------------------------- options


def parse_size(text: str | None) -> tuple[int, int]:
    """``--size WIDTHxHEIGHT`` (None: :data:`DEFAULT_SIZE`).

    Parameters
    ----------
    text : str or None
        E.g. ``"320x240"``.

    Returns
    -------
    tuple of int
        ``(width, height)``, each 16..4096.

    Raises
    ------
    InputError
        Anything else.

    Examples
    --------
    >>> parse_size("96x72"), parse_size(None)
    ((96, 72), (640, 480))
    """
    if text is None:
        return DEFAULT_SIZE
    parts = [p.strip() for p in text.lower().split("x")]
    if len(parts) == 2 and all(p.isdigit() and len(p) <= 5 for p in parts):
        w, h = int(parts[0]), int(parts[1])
        if 16 <= w <= 4096 and 16 <= h <= 4096:
            return w, h
    raise InputError(f"--size must be WIDTHxHEIGHT with each 16..4096 (e.g. 320x240), got {text!r}")


def parse_positions(text: str | None, counts: Mapping[str, int]) -> list[tuple[str, int]]:
    """``--positions``: which positions to run, as ``(kind, index)`` with ``index`` from 1.

    Parameters
    ----------
    text : str or None
        Comma-separated ``KIND`` (all of its positions), ``KIND:N`` or ``KIND:N-M``, kinds
        ``sphere``, ``ball_bar``, ``plane``; None or ``"all"``: every position.
    counts : mapping
        Positions per kind in the plan (``{"sphere": 10, ...}``).

    Returns
    -------
    list of tuple
        In plan order (spheres, ball bars, planes; by index), without repeats.

    Raises
    ------
    InputError
        An unknown kind, a number that is no position of the plan.

    Examples
    --------
    >>> counts = {"sphere": 10, "ball_bar": 7, "plane": 6}
    >>> parse_positions("plane:2,sphere:1-2", counts)
    [('sphere', 1), ('sphere', 2), ('plane', 2)]
    >>> parse_positions("sphere:11", counts)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --positions 'sphere:11': the plan has sphere positions 1..10; \
give numbers in that range
    """
    if text is None or text.strip() in ("", "all"):
        return [(k, i) for k in KINDS for i in range(1, counts.get(k, 0) + 1)]
    wanted: set[tuple[str, int]] = set()
    for raw in text.split(","):
        item = raw.strip()
        kind, _, numbers = item.partition(":")
        if kind not in KINDS:
            raise InputError(
                f"--positions {item!r}: unknown artefact {kind!r}; use sphere, ball_bar or "
                "plane, e.g. sphere:1-3,ball_bar:1,plane"
            )
        n = counts.get(kind, 0)
        lo_text, _, hi_text = numbers.partition("-")
        try:
            lo = int(lo_text) if numbers else 1
            hi = int(hi_text) if hi_text else (lo if numbers else n)
        except ValueError:
            raise InputError(
                f"--positions {item!r}: give KIND, KIND:N or KIND:N-M with whole numbers"
            ) from None
        if not 1 <= lo <= hi <= n:
            raise InputError(
                f"--positions {item!r}: the plan has {kind} positions 1..{n}; give numbers in "
                "that range"
            )
        wanted.update((kind, i) for i in range(lo, hi + 1))
    return sorted(wanted, key=lambda p: (KINDS.index(p[0]), p[1]))


def _methods(names: Sequence[str]) -> list[Any]:
    """The strategies by their :data:`~hdrfringe.tasks.compare.METHODS` names."""
    from hdrfringe.strategies import available_strategies
    from hdrfringe.tasks.compare import METHODS

    known = {m.name: m for m in METHODS}
    out = []
    for name in names or ["conventional"]:
        if name not in known:
            raise InputError(
                f"--strategy {name!r}: unknown; use one of {', '.join(known)} (docs/compare.md)"
            )
        if known[name].strategy not in available_strategies():
            raise InputError(
                f"--strategy {name!r}: strategy {known[name].strategy!r} is not "
                "registered in this installation"
            )
        if known[name] not in out:
            out.append(known[name])
    return out


# --------------------------------------------------------------------------------- artefacts


@dataclass(frozen=True)
class Artefacts:
    """The calibrated artefacts and the MPEs a run compares with.

    Parameters
    ----------
    mpes : MpeSet
        The MPEs.
    sphere : SphereArtefact or None
        The sphere.
    ball_bar : BallBarArtefact or None
        The ball bar.
    plane : PlaneArtefact or None
        The plane.
    source : str
        Where they came from (the file, or the plan's guideline sizes).

    Examples
    --------
    >>> a = Artefacts(SIM_MPES, SphereArtefact(50.0), None, None, "doc")
    >>> a.has("sphere"), a.has("plane")
    (True, False)
    """

    mpes: acc.MpeSet
    sphere: SphereArtefact | None
    ball_bar: BallBarArtefact | None
    plane: PlaneArtefact | None
    source: str

    def has(self, kind: str) -> bool:
        """Whether the artefact of ``kind`` is calibrated.

        Parameters
        ----------
        kind : str
            One of :data:`KINDS`.

        Returns
        -------
        bool
        """
        return getattr(self, kind) is not None

    def to_dict(self) -> dict[str, Any]:
        """The MPEs and artefacts as JSON types.

        Returns
        -------
        dict
        """

        def mpe(m: acc.Mpe) -> dict[str, Any]:
            return {"a_mm": m.a_mm, "k": m.k}

        out: dict[str, Any] = {"source": self.source}
        out["mpe"] = {q: mpe(getattr(self.mpes, q)) for q in ("pf", "ps", "sd", "f")}
        for kind in KINDS:
            art = getattr(self, kind)
            out[kind] = None if art is None else plain(art.__dict__)
        return out


def _artefacts(file: Path | None, plan: Any) -> Artefacts:
    """From the acceptance file, else the plan's sizes with :data:`SIM_MPES`."""
    if file is not None:
        f: AcceptanceFile = load_acceptance_file(file)
        return Artefacts(f.mpe, f.sphere, f.ball_bar, f.plane, str(file))
    return Artefacts(
        SIM_MPES,
        SphereArtefact(plan.sphere_diameter_mm),
        BallBarArtefact(plan.ball_distance_mm, (plan.ball_diameter_mm, plan.ball_diameter_mm)),
        PlaneArtefact(plan.plane_length_mm, plan.plane_width_mm),
        "the plan's guideline sizes, MPEs of the virtual rig (hdrfringe.tasks.acceptance.SIM_MPES)",
    )
