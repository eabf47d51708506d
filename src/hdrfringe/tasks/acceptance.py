"""``hdrfringe acceptance``: the VDI/VDE 2634 Part 2 acceptance test, on the virtual rig or
on captured positions (issue 25; docs/acceptance.md, "The acceptance command").

- :func:`acceptance_sim`: the whole procedure on the virtual stereo rig. The rig is calibrated
  the way a user would (:func:`hdrfringe.tasks.calibrate_stereo.calibrate_stereo` with
  ``rig="sim"``, or a given calibration file), the measuring volume and the guideline's
  positions come from the calibration's board depths
  (:func:`hdrfringe.rig.artefact_positions.acceptance_positions`), and every position is
  captured and measured by each chosen strategy (:data:`hdrfringe.tasks.compare.METHODS`
  names) through :func:`hdrfringe.pipeline.measure`; then each artefact is segmented and its
  quantities compared with the MPEs.
- :func:`acceptance_offline`: the same evaluation of capture folders written earlier (each
  carrying :data:`POSITION_FILE`, which says which artefact and position it holds; the sim
  run writes its captures that way with ``keep_captures``).

Both write, staged (all or nothing), ``acceptance.json`` (strict JSON, no NaN),
``acceptance.md``, ``quantities.png`` (PF, PS, SD, F per position against the MPE, one series
per strategy) and ``residuals/<strategy>/<position>.tiff`` (the residual map of every position,
float32, NaN off the artefact) with its PNG preview.
The tasks print nothing: the front end gives ``progress``.
"""

from __future__ import annotations

import math
import signal
import time
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core import acceptance as acc
from hdrfringe.core.acceptance_noise import ray_depth_std, spacing_std, sphere_fit_std
from hdrfringe.core.stereo import StereoCalibration
from hdrfringe.core.strict_json import dumps, loads_strict, plain
from hdrfringe.errors import CaptureFormatError, HdrFringeError, InputError, StoppedError
from hdrfringe.io.acceptance_file import (
    AcceptanceFile,
    BallBarArtefact,
    PlaneArtefact,
    SphereArtefact,
    load_acceptance_file,
)
from hdrfringe.tasks._progress import Progress, Say, quiet, silent

__all__ = [
    "ACCEPTANCE_JSON",
    "ACCEPTANCE_MD",
    "DEFAULT_PITCHES",
    "DEFAULT_SIZE",
    "KINDS",
    "POSITION_FILE",
    "SIM_MPES",
    "AcceptanceReport",
    "PositionOutcome",
    "acceptance_hardware",
    "acceptance_markdown",
    "acceptance_offline",
    "acceptance_sim",
    "evaluate_cloud",
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
#: the matte artefacts with its own board calibration (PF 4.4, PS 0.29, SD 0.22, F 3.8 mm),
#: below what a calibration 1 % too long gives (PS +0.7, SD +1.9 mm). Our choice for this rig,
#: not a data sheet's.
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


# --------------------------------------------------------------------------------- evaluation


@dataclass
class PositionOutcome:
    """One position measured by one strategy, evaluated.

    Parameters
    ----------
    strategy : str
        The strategy's row name (or the captures' record offline).
    label : str
        ``sphere_01``, ...
    kind : str
        One of :data:`KINDS`.
    description : str
        Where the artefact stood.
    values : dict
        ``PF``/``PS`` (sphere), ``SD`` (ball bar) or ``F`` (plane): mm, None when not
        evaluated.
    note : str
        Why not evaluated ("" when evaluated).
    images : int or None
        Images captured for the position.
    details : dict
        Points, outliers, fitted sizes, the predicted std of PS/SD, errors against the
        virtual rig's truth (JSON types).
    residual_map : ndarray or None
        Residuals of the artefact's points on the camera grid (NaN elsewhere), mm.
    seconds : float
        Wall time (capture and evaluation).

    Examples
    --------
    >>> o = PositionOutcome("conventional", "plane_01", "plane", "level", {"F": 1.9}, "", 12)
    >>> o.to_dict()["values"]
    {'F': 1.9}
    """

    strategy: str
    label: str
    kind: str
    description: str
    values: dict[str, float | None]
    note: str = ""
    images: int | None = None
    details: dict[str, Any] = field(default_factory=dict)
    residual_map: F64 | None = None
    seconds: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """The outcome as strict JSON types (no NaN).

        Returns
        -------
        dict
        """
        return plain(
            {
                "strategy": self.strategy,
                "label": self.label,
                "kind": self.kind,
                "description": self.description,
                "values": self.values,
                "note": self.note,
                "images": self.images,
                "details": self.details,
                "seconds": round(self.seconds, 2),
            }
        )


def _quantities(kind: str) -> tuple[str, ...]:
    return {"sphere": ("PF", "PS"), "ball_bar": ("SD",), "plane": ("F",)}[kind]


def _point_std(
    xyz: F64, phase_std: F64 | None, pitch: float, calibration: StereoCalibration
) -> F64 | None:
    """Each point's predicted std along its camera ray (None without a phase std)."""
    if phase_std is None:
        return None
    coordinate_std = phase_std * pitch / (2 * math.pi)
    return ray_depth_std(xyz, coordinate_std, calibration, axis=0)


def evaluate_cloud(
    xyz: F64,
    kind: str,
    artefacts: Artefacts,
    *,
    expected: Mapping[str, Any] | None = None,
    point_std: F64 | None = None,
    max_view_deg: float | None = MAX_VIEW_DEG,
    neck_deg: float | None = BALL_BAR_NECK_DEG,
) -> tuple[dict[str, float | None], dict[str, Any], F64]:
    """Segment the artefact of ``kind`` from a measured cloud and compute its quantities.

    Parameters
    ----------
    xyz : ndarray, shape (H, W, 3)
        The triangulated points in the camera frame (NaN = invalid), mm.
    kind : str
        One of :data:`KINDS`.
    artefacts : Artefacts
        The calibrated artefacts and MPEs.
    expected : mapping, optional
        Nominal centres in the camera frame (``centre_mm``; ``centre_a_mm`` and
        ``centre_b_mm``) to search near; the plane needs none.
    point_std : ndarray, shape (H, W), optional
        Each point's predicted std along its camera ray, mm (the PS and SD stds).
    max_view_deg : float, optional
        The spheres' points seen at a larger angle are left out (the rim); None keeps them.
    neck_deg : float, optional
        A ball bar's points within this angle of its axis are left out (the rod's neck);
        None keeps them.

    Returns
    -------
    values : dict
        The quantities, mm.
    details : dict
        Points, outliers, fitted sizes, predicted stds (JSON types).
    residuals : ndarray, shape (H, W)
        The artefact's residuals on the camera grid, NaN elsewhere, mm.

    Raises
    ------
    ArtefactNotFoundError
        The artefact is not in the cloud.
    InputError
        The artefact is not in the acceptance file.

    Examples
    --------
    A flat 90 x 90 mm plate 600 mm away, one point 0.5 mm off (left out by the 0.3 % rule):

    >>> yy, xx = np.mgrid[-40:41:4.0, -40:41:4.0]
    >>> xyz = np.dstack([xx, yy, np.full_like(xx, 600.0)])
    >>> xyz[0, 0, 2] += 0.5
    >>> arts = Artefacts(SIM_MPES, None, None, PlaneArtefact(90.0, 90.0), "doc")
    >>> values, details, residuals = evaluate_cloud(xyz, "plane", arts)
    >>> round(values["F"], 9), details["points"], details["dropped"]
    (0.0, 441, 1)
    """
    art = getattr(artefacts, kind)
    if art is None:
        raise InputError(
            f"the acceptance file has no [{kind}]; add it to evaluate {kind} positions"
        )
    exp = expected or {}
    residuals = np.full(xyz.shape[:-1], np.nan)
    if kind == "sphere":
        seg = acc.segment_sphere(
            xyz, art.diameter_mm, expected_centre=exp.get("centre_mm"), max_view_deg=max_view_deg
        )
        pe = acc.probing_error(xyz[seg.mask], art.diameter_mm)
        residuals[seg.mask] = np.where(pe.sphere.kept, pe.sphere.residuals, np.nan)
        details = {
            "points": seg.n_points,
            "outliers": seg.n_outliers,
            "edge_points": seg.n_edge,
            "dropped": pe.sphere.n_dropped,
            "centre_mm": pe.sphere.centre,
            "diameter_mm": pe.sphere.diameter_mm,
        }
        if point_std is not None:
            std = sphere_fit_std(
                xyz[seg.mask][pe.sphere.kept], pe.sphere.centre, point_std[seg.mask][pe.sphere.kept]
            )
            details["predicted_std_mm"] = {"PS": std.diameter_std_mm}
        return {"PF": pe.form_mm, "PS": pe.size_mm}, details, residuals
    if kind == "ball_bar":
        centres = None if "centre_a_mm" not in exp else (exp["centre_a_mm"], exp["centre_b_mm"])
        sa, sb = acc.segment_ball_bar(
            xyz,
            art.diameters_mm,
            art.distance_mm,
            expected_centres=centres,
            max_view_deg=max_view_deg,
            neck_deg=neck_deg,
        )
        sd = acc.sphere_spacing_error(xyz[sa.mask], xyz[sb.mask], art.distance_mm)
        for seg, sph in zip((sa, sb), sd.spheres, strict=True):
            residuals[seg.mask] = np.where(sph.kept, sph.residuals, np.nan)
        details = {
            "points": [sa.n_points, sb.n_points],
            "outliers": [sa.n_outliers, sb.n_outliers],
            "edge_points": [sa.n_edge, sb.n_edge],
            "centres_mm": [s.centre for s in sd.spheres],
            "distance_mm": sd.distance_mm,
            "diameters_mm": [s.diameter_mm for s in sd.spheres],
        }
        if point_std is not None:
            stds = [
                sphere_fit_std(xyz[seg.mask][s.kept], s.centre, point_std[seg.mask][s.kept])
                for seg, s in zip((sa, sb), sd.spheres, strict=True)
            ]
            sigma = spacing_std(sd.spheres[0].centre, sd.spheres[1].centre, *stds)
            details["predicted_std_mm"] = {"SD": sigma}
        return {"SD": sd.spacing_mm}, details, residuals
    band = PLANE_BAND_FRACTION * art.width_mm
    if "centre_mm" in exp and "normal" in exp:
        xyz = _near_plane(xyz, exp["centre_mm"], exp["normal"], art)
    ps = acc.segment_plane(xyz, size_mm=(art.length_mm, art.width_mm), band_mm=band)
    fe = acc.flatness_error(xyz[ps.mask])
    residuals[ps.mask] = np.where(fe.kept, fe.residuals, np.nan)
    details = {
        "points": int(ps.mask.sum()),
        "outliers": ps.n_outliers,
        "dropped": fe.n_dropped,
        "band_mm": band,
    }
    return {"F": fe.flatness_mm}, details, residuals


def _near_plane(xyz: F64, centre: Any, normal: Any, art: PlaneArtefact) -> F64:
    """The points of a slab around the nominal plane (+-:data:`PLANE_SLAB_FRACTION` of its
    width), within its half diagonal of the nominal centre; the rest NaN. The dominant plane of
    the whole cloud can be the base under the artefact (larger, but darker and noisier)."""
    c = np.asarray(centre, dtype=float)
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    off = xyz - c
    with np.errstate(invalid="ignore"):
        near = np.abs(off @ n) <= PLANE_SLAB_FRACTION * art.width_mm
        near &= np.linalg.norm(off, axis=-1) <= math.hypot(art.length_mm, art.width_mm) / 2
    return np.where(near[..., None], xyz, np.nan)


def _truth_errors(
    kind: str, details: Mapping[str, Any], truth: Mapping[str, Any]
) -> dict[str, Any]:
    """The fitted sizes and centres against the virtual rig's truth (camera frame)."""
    if kind == "sphere":
        return {
            "diameter_mm": details["diameter_mm"] - truth["diameter_mm"],
            "centre_mm": float(
                np.linalg.norm(np.subtract(details["centre_mm"], truth["centre_mm"]))
            ),
        }
    if kind == "ball_bar":
        return {"distance_mm": details["distance_mm"] - truth["distance_mm"]}
    return {}


def _evaluate(
    xyz: F64,
    sidecar: Mapping[str, Any],
    artefacts: Artefacts,
    point_std: F64 | None,
) -> tuple[dict[str, float | None], str, dict[str, Any], F64 | None]:
    """:func:`evaluate_cloud`, an artefact not found as a row without values and its note."""
    kind = sidecar["kind"]
    try:
        values, details, residuals = evaluate_cloud(
            xyz, kind, artefacts, expected=sidecar.get("expected"), point_std=point_std
        )
    except InputError as err:  # not found, too few points: a row without values
        return dict.fromkeys(_quantities(kind)), str(err), {}, None
    truth = sidecar.get("truth_camera")
    if truth:
        details["error_vs_truth_mm"] = _truth_errors(kind, details, truth)
    return values, "", details, residuals


def _rows(outcome: PositionOutcome, artefacts: Artefacts) -> list[acc.PositionResult]:
    """The outcome's rows of the acceptance table."""
    art = getattr(artefacts, outcome.kind)
    length = None
    if outcome.kind == "ball_bar":
        length = art.distance_mm
    elif outcome.kind == "plane":
        length = art.length_mm
    return [
        acc.check_position(
            outcome.label,
            q,
            outcome.values.get(q),
            artefacts.mpes,
            length_mm=length,
            note=outcome.note,
        )
        for q in _quantities(outcome.kind)
    ]


# --------------------------------------------------------------------------------- the report


@dataclass(frozen=True)
class AcceptanceReport:
    """What ``acceptance`` wrote.

    Parameters
    ----------
    output : Path
        The folder.
    outcomes : list of PositionOutcome
        Every position and strategy.
    summaries : dict
        Per strategy: its :class:`~hdrfringe.core.acceptance.AcceptanceSummary`.
    artefacts : Artefacts
        The artefacts and MPEs.
    setup : dict
        How the run was made (rig, size, calibration, volume, timings).

    Examples
    --------
    >>> r = AcceptanceReport(Path("out"), [], {}, Artefacts(SIM_MPES, None, None, None, ""), {})
    >>> r.all_passed
    False
    """

    output: Path
    outcomes: list[PositionOutcome]
    summaries: dict[str, acc.AcceptanceSummary]
    artefacts: Artefacts
    setup: dict[str, Any]

    @property
    def all_passed(self) -> bool:
        """Whether every strategy passed every position."""
        return bool(self.summaries) and all(s.all_passed for s in self.summaries.values())

    def to_dict(self) -> dict[str, Any]:
        """``acceptance.json``: strict JSON types.

        Returns
        -------
        dict
        """
        return plain(
            {
                "setup": self.setup,
                "artefacts": self.artefacts.to_dict(),
                "strategies": {
                    name: {**s.to_dict(), "images": _images(self.outcomes, name)}
                    for name, s in self.summaries.items()
                },
                "positions": [o.to_dict() for o in self.outcomes],
            }
        )


def _images(outcomes: Sequence[PositionOutcome], strategy: str) -> dict[str, Any]:
    """Images captured by a strategy: per position (min, max) and in all."""
    counts = [o.images for o in outcomes if o.strategy == strategy and o.images is not None]
    if not counts:
        return {"total": None, "per_position_min": None, "per_position_max": None}
    return {"total": sum(counts), "per_position_min": min(counts), "per_position_max": max(counts)}


def _fmt(value: float | None, digits: int = 3) -> str:
    return "—" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def acceptance_markdown(report: AcceptanceReport) -> str:
    """``acceptance.md``: the verdict per strategy, the strategies side by side, every position.

    Parameters
    ----------
    report : AcceptanceReport
        The run.

    Returns
    -------
    str

    Examples
    --------
    >>> arts = Artefacts(SIM_MPES, None, None, None, "doc")
    >>> acceptance_markdown(AcceptanceReport(Path("out"), [], {}, arts, {})).splitlines()[0]
    '# Acceptance test (VDI/VDE 2634 Part 2)'
    """
    s, mp = report.setup, report.artefacts.mpes
    lines = ["# Acceptance test (VDI/VDE 2634 Part 2)", ""]
    lines += [f"- {k}: {v}" for k, v in s.items() if not isinstance(v, (dict, list))]
    lines += [
        f"- artefacts and MPEs: {report.artefacts.source}",
        f"- MPE: PF {mp.pf.a_mm:g} mm, PS {mp.ps.a_mm:g} mm, SD {_mpe_text(mp.sd)}, "
        f"F {_mpe_text(mp.f)}",
        "",
        "## Strategies side by side (largest |value| over the positions; passed/positions)",
        "",
        "| strategy | images (total) | PF mm | PS mm | SD mm | F mm | verdict |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, summ in report.summaries.items():
        q = summ.to_dict()["quantities"]
        cells = []
        for key in ("PF", "PS", "SD", "F"):
            c = q.get(key)
            cells.append(
                "—" if c is None else f"{_fmt(c['max_abs_mm'])} ({c['passed']}/{c['positions']})"
            )
        images = _images(report.outcomes, name)["total"]
        verdict = "pass" if summ.all_passed else "FAIL"
        lines.append(
            f"| {name} | {images if images is not None else '—'} | "
            f"{' | '.join(cells)} | {verdict} |"
        )
    lines += [
        "",
        "## Positions",
        "",
        "| strategy | position | where | images | values (mm) | predicted std (mm) | "
        "points | outliers | saturated | note |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for o in report.outcomes:
        vals = ", ".join(f"{k} {_fmt(v)}" for k, v in o.values.items())
        std = ", ".join(f"{k} {_fmt(v)}" for k, v in o.details.get("predicted_std_mm", {}).items())
        lines.append(
            f"| {o.strategy} | {o.label} | {o.description} | {o.images or '—'} | {vals} | "
            f"{std or '—'} | {o.details.get('points', '—')} | "
            f"{o.details.get('outliers', '—')} | {_percent(o.details.get('saturated_fraction'))} | "
            f"{o.note} |"
        )
    return "\n".join(lines) + "\n"


def _percent(value: float | None) -> str:
    return "—" if value is None else f"{100 * value:.2f} %"


def _mpe_text(m: acc.Mpe) -> str:
    return f"{m.a_mm:g} mm" if m.k is None else f"{m.a_mm:g} mm + L/{m.k:g}"


def _plot_quantities(report: AcceptanceReport, path: Path) -> None:
    """PF, PS, SD and F per position, one series per strategy, against the MPE (+-MPE for
    the signed PS and SD)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), squeeze=False)
    names = list(report.summaries)
    for ax, q in zip(axes.ravel(), ("PF", "PS", "SD", "F"), strict=True):
        labels = list(dict.fromkeys(o.label for o in report.outcomes if q in o.values))
        ax.set_title(q)
        ax.set_ylabel("mm")
        if not labels:
            ax.text(0.5, 0.5, "no positions", ha="center", transform=ax.transAxes)
            continue
        for k, name in enumerate(names):
            here = {o.label: o for o in report.outcomes if o.strategy == name and q in o.values}
            xs = [
                i + 0.08 * (k - (len(names) - 1) / 2)
                for i, lab in enumerate(labels)
                if lab in here and here[lab].values[q] is not None
            ]
            ys = [
                here[lab].values[q]
                for lab in labels
                if lab in here and here[lab].values[q] is not None
            ]
            ax.plot(xs, ys, "o", label=name, color=plt.get_cmap("tab10")(k % 10))
        rows = [r for s in report.summaries.values() for r in s.records if r.quantity == q]
        mpe = max(r.mpe_mm for r in rows)
        ax.axhline(mpe, color="k", ls="--", lw=1, label="MPE")
        if q in ("PS", "SD"):
            ax.axhline(-mpe, color="k", ls="--", lw=1)
            ax.axhline(0.0, color="0.7", lw=0.5)
        ax.set_xticks(range(len(labels)), labels, rotation=60, fontsize=7)
    seen: dict[str, Any] = {}
    for ax in axes.ravel():
        for handle, name in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(name, handle)
    if seen:
        fig.legend(
            list(seen.values()), list(seen), loc="upper center", ncol=min(len(seen), 8), fontsize=7
        )
    fig.subplots_adjust(left=0.07, right=0.98, top=0.9, bottom=0.14, hspace=0.55, wspace=0.2)
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _write_residuals(outcome: PositionOutcome, folder: Path) -> None:
    """The residual map of one position: float32 TIFF (NaN off the artefact) and its preview
    (symmetric colour range)."""
    from hdrfringe.io.results import write_map_tiff, write_preview_png

    res = outcome.residual_map
    assert res is not None
    write_map_tiff(folder / f"{outcome.label}.tiff", res.astype(np.float32))
    lim = float(np.nanmax(np.abs(res))) if np.isfinite(res).any() else 1.0
    vals = ", ".join(f"{k} {_fmt(v)}" for k, v in outcome.values.items())
    write_preview_png(
        folder / f"{outcome.label}.png",
        res,
        title=f"{outcome.strategy}: {outcome.label} ({vals})",
        label="residual (mm)",
        vmin=-lim,
        vmax=lim,
    )


def _write_report(tmp: Path, report: AcceptanceReport) -> None:
    """acceptance.json, acceptance.md and the plots into the staging folder."""
    text = dumps(report.to_dict(), indent=1)
    (tmp / ACCEPTANCE_JSON).write_text(text + "\n", encoding="utf-8")
    (tmp / ACCEPTANCE_MD).write_text(acceptance_markdown(report), encoding="utf-8")
    _plot_quantities(report, tmp / "quantities.png")
    for o in report.outcomes:
        if o.residual_map is not None:
            folder = tmp / "residuals" / o.strategy
            folder.mkdir(parents=True, exist_ok=True)
            _write_residuals(o, folder)


def _summaries(outcomes: Sequence[PositionOutcome], artefacts: Artefacts) -> dict[str, Any]:
    out: dict[str, acc.AcceptanceSummary] = {}
    for name in dict.fromkeys(o.strategy for o in outcomes):
        rows = [r for o in outcomes if o.strategy == name for r in _rows(o, artefacts)]
        out[name] = acc.summarize(rows)
    return out


# --------------------------------------------------------------------------------- the sim run


def _load_stereo(path: Path, size: tuple[int, int] | None = None) -> StereoCalibration:
    """A stereo calibration file, refused when it is not one or does not fit ``size``."""
    from hdrfringe.core.calibration import CalibrationMismatchError
    from hdrfringe.io.stereo_file import load_any_calibration

    cal = load_any_calibration(path)
    if not isinstance(cal, StereoCalibration):
        raise InputError(
            f"{path}: a phase-to-height calibration; the acceptance test triangulates: give a "
            "stereo calibration (calibrate-stereo)"
        )
    if size is not None and tuple(cal.camera.size) != tuple(size):
        raise CalibrationMismatchError(
            f"{path}: stereo calibration of a {cal.camera.size[0]}x{cal.camera.size[1]} camera "
            f"does not fit --size {size[0]}x{size[1]}; give the calibration of that camera "
            "or its size"
        )
    return cal


def _sidecar(position: Any, strategy: str, rig: Any) -> dict[str, Any]:
    """What a position's capture folder records about itself: kind, index, label, the
    nominal centres (camera frame, to search near) and the virtual rig's truth."""
    rot, t = rig.geometry.world_to_camera()
    truth = position.truth.to_frame(rot, t)
    if position.kind == "sphere":
        expected = {"centre_mm": truth.centre_mm}
        camera = {"centre_mm": truth.centre_mm, "diameter_mm": truth.diameter_mm}
    elif position.kind == "ball_bar":
        expected = {"centre_a_mm": truth.centre_a_mm, "centre_b_mm": truth.centre_b_mm}
        camera = {**expected, "distance_mm": truth.distance_mm}
    else:
        expected = {"centre_mm": truth.centre_mm, "normal": truth.normal}
        camera = dict(expected)
    return plain(
        {
            "kind": position.kind,
            "index": position.index,
            "label": position.label,
            "description": position.description,
            "strategy": strategy,
            "expected": expected,
            "truth_camera": camera,
        }
    )


@dataclass(frozen=True)
class _SimSetup:
    size: tuple[int, int]
    seed: int
    noise: float
    ambient_lux: float
    pitches: tuple[float, ...]


def _measure_position(
    position: Any,
    method: Any,
    cal: StereoCalibration,
    setup: _SimSetup,
    artefacts: Artefacts,
    others: Sequence[StereoCalibration] = (),
) -> tuple[PositionOutcome, Any, dict[str, Any]]:
    """Capture and measure one position with one strategy on the virtual rig; evaluate it
    (with ``others``, the calibration's part of the PS/SD std: :func:`_calibration_term`)."""
    from hdrfringe.core.programs import fringe_specs
    from hdrfringe.pipeline import measure
    from hdrfringe.rig.board_poses import calibration_rig
    from hdrfringe.rig.simulated import Lighting

    t0 = time.perf_counter()
    rig = calibration_rig(
        position.scene, camera_size=setup.size, noise=setup.noise, seed=setup.seed
    )
    if setup.ambient_lux:
        rig = rig.replace(lighting=Lighting(ambient_lux=setup.ambient_lux))
    specs = fringe_specs("sinusoidal", STEPS, list(setup.pitches))
    res = measure(
        rig,
        cal,
        strategy=method.strategy,
        params=dict(method.params),
        specs=specs,
        label=position.label,
    )
    images = sum(r.images_captured for r in res.strategy_results)
    sidecar = _sidecar(position, method.name, rig)
    outcome = _outcome(res, sidecar, artefacts, cal, images)
    if others:
        _calibration_term(outcome, res.captures, sidecar, artefacts, others)
    outcome.seconds = time.perf_counter() - t0
    return outcome, res.captures, sidecar


def _calibration_term(
    outcome: PositionOutcome,
    captures: Any,
    sidecar: Mapping[str, Any],
    artefacts: Artefacts,
    others: Sequence[StereoCalibration],
) -> None:
    """Add the calibration's part to the outcome's predicted PS/SD std: the same captures
    triangulated with each of ``others`` (calibrations of the same rig from other noise seeds)
    and evaluated again; the sample std of the value over them and the run's own calibration
    is the calibration's std, combined with the phase noise's in quadrature."""
    from hdrfringe.pipeline import measure

    std = outcome.details.get("predicted_std_mm")
    if not std or any(v is None for v in outcome.values.values()):
        return
    (q,) = std
    values = [float(outcome.values[q] or 0.0)]
    for cal in others:
        res = measure(captures, cal, uncertainty=False)
        if res.stereo is None:
            continue
        try:
            v, _, _ = evaluate_cloud(
                res.stereo.xyz, outcome.kind, artefacts, expected=sidecar.get("expected")
            )
        except InputError:  # not found with that calibration: no value to count
            continue
        values.append(float(v[q] or 0.0))
    if len(values) < 2:
        return
    term = float(np.std(values, ddof=1))
    outcome.details["predicted_std_parts_mm"] = {
        "phase": {q: std[q]},
        "calibration": {q: term},
        "calibrations": len(values),
    }
    outcome.details["predicted_std_mm"] = {q: math.hypot(std[q], term)}


def _outcome(
    res: Any,
    sidecar: Mapping[str, Any],
    artefacts: Artefacts,
    cal: StereoCalibration,
    images: int | None,
) -> PositionOutcome:
    """Evaluate one measurement (a :class:`~hdrfringe.pipeline.MeasurementResult`)."""
    if res.stereo is None:
        raise InputError(f"{sidecar['label']}: no points triangulated; check the calibration")
    xyz = res.stereo.xyz
    unc = res.uncertainty
    pitch = None if res.decoded.primary is None else float(res.decoded.primary.pitch_px)
    std = None
    if unc is not None and unc.phase_std is not None and pitch is not None:
        std = _point_std(xyz, unc.phase_std, pitch, cal)
    values, note, details, residuals = _evaluate(xyz, sidecar, artefacts, std)
    # pixels with a clipped shift (invalid): on the artefact, the dark base never clips
    details["saturated_fraction"] = res.metrics.saturated_fraction
    return PositionOutcome(
        sidecar["strategy"],
        sidecar["label"],
        sidecar["kind"],
        sidecar["description"],
        values,
        note,
        images,
        details,
        residuals,
    )


def _calibrate(
    tmp: Path,
    size: tuple[int, int],
    board: str,
    poses: int,
    seed: int,
    noise: float,
    progress: Progress,
) -> tuple[StereoCalibration, dict[str, Any]]:
    """``calibrate-stereo --rig sim`` at the run's camera size, written into the run's folder."""
    from hdrfringe.tasks.calibrate_stereo import calibrate_stereo

    done = calibrate_stereo(
        tmp / "calibration.h5",
        rig="sim",
        board=board,
        pose_count=poses,
        seed=seed,
        noise=noise,
        camera_size=size,
        progress=progress,
    )
    return done.calibration, {
        "calibration": "calibrate-stereo --rig sim (calibration.h5)",
        "calibration_errors_vs_truth": done.errors_vs_truth,
    }


def _repeat_calibrations(
    size: tuple[int, int],
    board: str,
    poses: int,
    seeds: Sequence[int],
    noise: float,
    progress: Progress,
) -> list[StereoCalibration]:
    """``calibrate-stereo --rig sim`` again with other noise seeds (files not kept)."""
    import tempfile

    from hdrfringe.tasks.calibrate_stereo import calibrate_stereo

    out = []
    with (
        tempfile.TemporaryDirectory() as tmp,
        progress("calibration repeats", len(seeds)) as advance,
    ):
        for seed in seeds:
            done = calibrate_stereo(
                Path(tmp) / f"calibration_{seed}.h5",
                rig="sim",
                board=board,
                pose_count=poses,
                seed=seed,
                noise=noise,
                camera_size=size,
            )
            out.append(done.calibration)
            advance()
    return out


def _plan(size: tuple[int, int], glossy: bool, file: Path | None) -> tuple[Any, Artefacts]:
    """The measuring volume over the calibration's board depths, the positions, the artefacts
    (the file's calibrated sizes when given: the virtual rig then makes those artefacts)."""
    from hdrfringe.rig.artefact_positions import (
        acceptance_positions,
        board_depth_range,
        measuring_volume,
    )
    from hdrfringe.rig.board_poses import calibration_rig, default_board_poses
    from hdrfringe.rig.scenes import GLOSSY_SPECULAR, white_plate

    volume = measuring_volume(
        calibration_rig(white_plate(), camera_size=size), board_depth_range(default_board_poses(10))
    )
    sizes: dict[str, Any] = {}
    if file is not None:
        f = load_acceptance_file(file)
        if f.sphere is not None:
            sizes["sphere_diameter_mm"] = f.sphere.diameter_mm
        if f.ball_bar is not None:
            sizes["ball_distance_mm"] = f.ball_bar.distance_mm
            sizes["ball_diameter_mm"] = float(np.mean(f.ball_bar.diameters_mm))
        if f.plane is not None:
            sizes["plane_length_mm"] = f.plane.length_mm
            sizes["plane_width_mm"] = f.plane.width_mm
    plan = acceptance_positions(volume, specular=GLOSSY_SPECULAR if glossy else 0.0, **sizes)
    return plan, _artefacts(file, plan)


def _wanted(
    positions: str | None, counts: Mapping[str, int], artefacts: Artefacts
) -> list[tuple[str, int]]:
    """The positions to run: ``--positions``, or every position of the artefacts the file
    calibrates; a kind named that the file lacks is refused."""
    wanted = parse_positions(positions, counts)
    if positions is None or positions.strip() in ("", "all"):
        wanted = [(k, i) for k, i in wanted if artefacts.has(k)]
    for kind, _ in wanted:
        if not artefacts.has(kind):
            raise InputError(
                f"--positions names {kind} positions but {artefacts.source} has no "
                f"[{kind}]; add it or leave {kind} out"
            )
    if not wanted:
        raise InputError(f"no positions to run: {artefacts.source} calibrates no artefact")
    return wanted


def _chosen(plan: Any, positions: str | None, artefacts: Artefacts) -> list[Any]:
    counts = {
        "sphere": len(plan.spheres),
        "ball_bar": len(plan.ball_bars),
        "plane": len(plan.planes),
    }
    by = {(p.kind, p.index): p for p in plan.positions}
    return [by[w] for w in _wanted(positions, counts, artefacts)]


def acceptance_sim(
    output: Path,
    *,
    file: Path | None = None,
    calibration: Path | None = None,
    strategies: Sequence[str] = ("conventional",),
    positions: str | None = None,
    glossy: bool = False,
    ambient_lux: float = 0.0,
    size: tuple[int, int] = DEFAULT_SIZE,
    seed: int = 0,
    noise: float = 1.0,
    board: str = DEFAULT_BOARD,
    poses: int = 10,
    pitches: Sequence[float] = DEFAULT_PITCHES,
    keep_captures: bool = False,
    calibration_repeats: int = CALIBRATION_REPEATS,
    force: bool = False,
    progress: Progress = quiet,
) -> AcceptanceReport:
    """The acceptance test on the virtual rig: calibrate, place, capture, measure, evaluate.

    Everything given is checked (output, acceptance file, calibration, positions, strategies)
    before any work; the folder is written staged, all or nothing.

    Parameters
    ----------
    output : Path
        The result folder.
    file : Path, optional
        The acceptance file (MPEs and calibrated artefacts; the virtual artefacts are made to
        its sizes). None: the plan's guideline sizes and :data:`SIM_MPES`.
    calibration : Path, optional
        A stereo calibration of the virtual rig at ``size``; None: calibrate it
        (``calibrate-stereo --rig sim``, written as ``OUT/calibration.h5``).
    strategies : sequence of str
        :data:`~hdrfringe.tasks.compare.METHODS` names; several: the HDR table.
    positions : str, optional
        :func:`parse_positions` (None: all 23).
    glossy : bool
        Glossy artefacts (:data:`~hdrfringe.rig.scenes.GLOSSY_SPECULAR`).
    ambient_lux : float
        Ambient light on the scene.
    size : tuple of int
        Camera ``(width, height)``.
    seed : int
        Noise seed (calibration and captures).
    noise : float
        Camera read noise sigma, 8-bit gray levels.
    board : str
        The calibration board of the virtual calibration.
    poses : int
        Its board poses.
    pitches : sequence of float
        Fringe pitches, coarsest first (the coarsest spanning the projector).
    keep_captures : bool
        Also write each position's capture folder (``OUT/captures/<strategy>/<position>``,
        with :data:`POSITION_FILE`): what :func:`acceptance_offline` reads.
    calibration_repeats : int
        Without ``calibration``: calibrate this many more times (the next noise seeds) and
        add the spread of PS and SD over the calibrations to their predicted std (0: the
        phase noise's std only; a given calibration: always that).
    force : bool
        Replace an existing output folder.
    progress : callable
        The calibration and the positions, as stages.

    Returns
    -------
    AcceptanceReport

    Examples
    --------
    >>> acceptance_sim(Path("out"), positions="cube:1")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --positions 'cube:1': unknown artefact 'cube'; use sphere, \
ball_bar or plane, e.g. sphere:1-3,ball_bar:1,plane
    """
    from hdrfringe.io.results import check_output_against_inputs, check_output_dir

    if not (math.isfinite(ambient_lux) and ambient_lux >= 0):
        raise InputError(f"--ambient-lux {ambient_lux}: give a number of lux >= 0")
    if not (math.isfinite(noise) and noise >= 0):
        raise InputError(f"--noise {noise}: give a read noise sigma >= 0 gray levels")
    if calibration_repeats < 0:
        raise InputError(f"--calibration-repeats {calibration_repeats}: give a count >= 0")
    methods = _methods(strategies)
    parse_positions(positions, {"sphere": 10, "ball_bar": 7, "plane": 6})  # syntax, early
    check_output_against_inputs(output, [file, calibration])
    checked = check_output_dir(output, force)
    plan, artefacts = _plan(size, glossy, file)
    chosen = _chosen(plan, positions, artefacts)
    cal = None if calibration is None else _load_stereo(calibration, size)
    setup = _SimSetup(size, seed, noise, ambient_lux, tuple(float(p) for p in pitches))
    info: dict[str, Any] = {
        "rig": "sim",
        "camera": f"{size[0]}x{size[1]}",
        "artefacts": "glossy" if glossy else "matte",
        "ambient_lux": ambient_lux,
        "seed": seed,
        "read_noise_dn": noise,
        "pitches": list(setup.pitches),
        "steps": STEPS,
        "L0_mm": plan.volume.l0_mm,
        "volume_mm": [list(plan.volume.x_mm), list(plan.volume.y_mm), list(plan.volume.z_mm)],
        "plan_notes": list(plan.notes),
    }
    return _run_sim(
        checked,
        force,
        chosen,
        methods,
        cal,
        calibration,
        setup,
        artefacts,
        info,
        (board, poses),
        keep_captures,
        progress,
        calibration_repeats,
    )


def _run_sim(
    checked: Any,
    force: bool,
    chosen: Sequence[Any],
    methods: Sequence[Any],
    cal: StereoCalibration | None,
    calibration: Path | None,
    setup: _SimSetup,
    artefacts: Artefacts,
    info: dict[str, Any],
    board: tuple[str, int],
    keep: bool,
    progress: Progress,
    repeats: int = CALIBRATION_REPEATS,
) -> AcceptanceReport:
    """The staged part of :func:`acceptance_sim`."""
    from hdrfringe.io.results import staged_output_dir

    t0 = time.perf_counter()
    outcomes: list[PositionOutcome] = []
    with staged_output_dir(checked, force=force) as tmp:
        others: list[StereoCalibration] = []
        if cal is None:
            cal, cal_info = _calibrate(
                tmp, setup.size, board[0], board[1], setup.seed, setup.noise, progress
            )
            seeds = [setup.seed + 1 + k for k in range(repeats)]
            if seeds:
                others = _repeat_calibrations(
                    setup.size, board[0], board[1], seeds, setup.noise, progress
                )
                cal_info["calibration_term"] = (
                    f"predicted std of PS/SD: phase noise and the spread over {len(seeds) + 1} "
                    f"calibrations (noise seeds {setup.seed}, {', '.join(map(str, seeds))})"
                )
            else:
                cal_info["calibration_term"] = "not computed (no repeats): phase noise only"
        else:
            cal_info = {
                "calibration": str(calibration),
                "calibration_term": "not computed (a given calibration): phase noise only",
            }
        info.update(cal_info)
        t1 = time.perf_counter()
        with progress("acceptance positions", len(chosen) * len(methods)) as advance:
            for method in methods:
                for position in chosen:
                    outcome, caps, sidecar = _measure_position(
                        position, method, cal, setup, artefacts, others
                    )
                    outcomes.append(outcome)
                    if keep:
                        _keep(
                            tmp / "captures" / method.name / position.label,
                            caps,
                            {**sidecar, "images": outcome.images},
                        )
                    advance()
        info["seconds"] = {
            "calibration": round(t1 - t0, 1),
            "positions": round(time.perf_counter() - t1, 1),
        }
        report = AcceptanceReport(
            checked, outcomes, _summaries(outcomes, artefacts), artefacts, info
        )
        _write_report(tmp, report)
    return report


def _keep(folder: Path, captures: Any, sidecar: Mapping[str, Any]) -> None:
    """A position's capture folder and its sidecar."""
    from hdrfringe.io.captures import write_capture_folder

    folder.parent.mkdir(parents=True, exist_ok=True)
    write_capture_folder(folder, captures)
    (folder / POSITION_FILE).write_text(dumps(sidecar, nonfinite="error") + "\n", encoding="utf-8")


# --------------------------------------------------------------------------------- offline


def read_sidecar(folder: Path) -> dict[str, Any]:
    """A position folder's :data:`POSITION_FILE`, checked.

    Parameters
    ----------
    folder : Path
        A capture folder of one position.

    Returns
    -------
    dict
        ``kind``, ``label``, ``description``, ``strategy`` and, when known, ``expected``
        (nominal centres, camera frame) and ``truth_camera``.

    Raises
    ------
    CaptureFormatError
        No sidecar, not JSON, a kind or label missing or unknown.

    Examples
    --------
    >>> read_sidecar(Path("no-such-folder"))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.CaptureFormatError: no-such-folder: no acceptance_position.json; ...
    """
    path = Path(folder) / POSITION_FILE
    fix = (
        'write {"kind": "sphere", "label": "sphere_01"} (kind sphere, ball_bar or plane) '
        "beside the manifest"
    )
    if not path.is_file():
        raise CaptureFormatError(f"{folder}: no {POSITION_FILE}; {fix}")
    try:
        data = loads_strict(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise CaptureFormatError(f"{path}: not readable JSON ({err}); {fix}") from None
    if not isinstance(data, dict) or data.get("kind") not in KINDS:
        raise CaptureFormatError(f"{path}: 'kind' must be sphere, ball_bar or plane; {fix}")
    if not isinstance(data.get("label"), str) or not data["label"]:
        raise CaptureFormatError(f"{path}: 'label' must be a non-empty string; {fix}")
    data.setdefault("description", "")
    data.setdefault("strategy", "captured")
    return data


def acceptance_offline(
    folders: Sequence[Path],
    output: Path,
    *,
    calibration: Path,
    file: Path,
    force: bool = False,
    progress: Progress = quiet,
) -> AcceptanceReport:
    """Evaluate captured positions: each folder a capture folder with :data:`POSITION_FILE`.

    Every folder's sidecar, the calibration (a stereo calibration that fits the captures) and
    the acceptance file are checked before any measurement; the output is written staged.

    Parameters
    ----------
    folders : sequence of Path
        The position folders.
    output : Path
        The result folder.
    calibration : Path
        The stereo calibration.
    file : Path
        The acceptance file.
    force : bool
        Replace an existing output folder.
    progress : callable
        The positions, as one stage.

    Returns
    -------
    AcceptanceReport

    Examples
    --------
    >>> acceptance_offline([], Path("out"), calibration=Path("c.h5"), file=Path("a.toml"))
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: no position folders given; give the capture folders of the \
positions (acceptance FOLDER... --calibration CAL --file acceptance.toml -o OUT)
    """
    from hdrfringe.io.captures import DECODE_BYTES_PER_PIXEL, read_capture_folder
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_dir,
        staged_output_dir,
    )
    from hdrfringe.pipeline import measure

    if not folders:
        raise InputError(
            "no position folders given; give the capture folders of the positions "
            "(acceptance FOLDER... --calibration CAL --file acceptance.toml -o OUT)"
        )
    sidecars = [read_sidecar(f) for f in folders]
    seen: dict[tuple[str, str], Path] = {}
    for f, s in zip(folders, sidecars, strict=True):
        key = (s["strategy"], s["label"])
        if key in seen:
            raise InputError(
                f"{f}: position {s['label']} ({s['strategy']}) is also {seen[key]}; "
                "give each position once"
            )
        seen[key] = f
    check_output_against_inputs(output, [*folders, calibration, file])
    checked = check_output_dir(output, force)
    artefacts = _artefacts(file, None)
    for s in sidecars:
        if not artefacts.has(s["kind"]):
            raise InputError(f"{file} has no [{s['kind']}] for position {s['label']}; add it")
    cal = _load_stereo(calibration)
    outcomes = []
    with progress("acceptance positions", len(folders)) as advance:
        for f, s in zip(folders, sidecars, strict=True):
            t0 = time.perf_counter()
            caps = read_capture_folder(f, work_bytes_per_pixel=DECODE_BYTES_PER_PIXEL)
            res = measure(caps, cal, label=str(f), calibration_source=str(calibration))
            outcome = _outcome(res, s, artefacts, cal, len(caps.frames))
            outcome.images = s.get("images", outcome.images)
            outcome.seconds = time.perf_counter() - t0
            outcomes.append(outcome)
            advance()
    outcomes.sort(key=lambda o: (o.strategy, KINDS.index(o.kind), o.label))
    info = {"rig": "captured positions", "calibration": str(calibration), "positions": len(folders)}
    report = AcceptanceReport(checked, outcomes, _summaries(outcomes, artefacts), artefacts, info)
    with staged_output_dir(checked, force=force) as tmp:
        _write_report(tmp, report)
    return report


# --------------------------------------------------------------------------------- live


#: The guideline's positions per artefact (the virtual rig's plan has the same counts).
GUIDELINE_COUNTS = {"sphere": 10, "ball_bar": 7, "plane": 6}


def _acceptance_rig(rig_config: Path | None, given: Collection[str], **options: Any) -> Any:
    """The (not yet open) hardware rig and its resolved configuration: the one place this
    task builds it (:func:`~hdrfringe.tasks.capture.hardware_rig`)."""
    from hdrfringe.tasks.capture import hardware_rig

    return hardware_rig(rig_config, given, **options)


@dataclass
class _Live:
    """A live run's state: the positions written, and why it stopped early."""

    outcomes: list[PositionOutcome] = field(default_factory=list)
    stopped: str | None = None
    code: int = 0
    failure: HdrFringeError | None = None
    dropped: bool = True


def acceptance_hardware(
    output: Path,
    rig_config: Path | None,
    hardware: Mapping[str, Any],
    *,
    wait: Callable[[int, int, str], bool],
    calibration: Path | None,
    file: Path | None,
    given: Collection[str] = (),
    strategy: str = "conventional",
    positions: str | None = None,
    force: bool = False,
    say: Say = silent,
) -> AcceptanceReport:
    """The acceptance test on a hardware rig: the user places the artefact at each position.

    Before each position ``wait(number, total, label)`` returns once the artefact is in place
    (False finishes); the strategy captures vertical fringe sets (pitches as ``capture-poses``
    takes them, :func:`~hdrfringe.tasks.capture_poses.board_pitches`), the position's capture
    folder is written with :data:`POSITION_FILE` under ``OUT/captures/STRATEGY/POSITION`` and
    evaluated (no nominal centres: the artefact is searched in the whole cloud). Ctrl-C,
    SIGTERM, SIGHUP or an error mid-run keeps the complete positions (their report written)
    and raises :class:`~hdrfringe.errors.StoppedError`; before the first position nothing is
    written.

    Parameters
    ----------
    output : Path
        The result folder.
    rig_config : Path or None
        The rig configuration file.
    hardware : mapping
        Hardware options by Python name (:data:`~hdrfringe.tasks.capture.RIG_OPTION_KEYS`).
    wait : callable
        ``wait(number, total, label)``.
    calibration : Path
        The stereo calibration of this camera and projector (required).
    file : Path
        The acceptance file (required).
    given : collection of str
        The hardware options given explicitly.
    strategy : str
        One :data:`~hdrfringe.tasks.compare.METHODS` name.
    positions : str, optional
        :func:`parse_positions` over the guideline's 10/7/6 (default: every position of the
        artefacts the file calibrates).
    force : bool
        Replace an existing output folder.
    say : callable
        Called with the line saying the rig is open and one line per position.

    Returns
    -------
    AcceptanceReport

    Examples
    --------
    >>> acceptance_hardware(Path("out"), None, {}, wait=lambda n, t, s: True,
    ...                     calibration=None, file=None)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --rig hardware needs --calibration CAL and --file acceptance.toml
    """
    from hdrfringe.io.results import check_output_against_inputs, check_output_dir

    if calibration is None or file is None:
        raise InputError("--rig hardware needs --calibration CAL and --file acceptance.toml")
    (method,) = _methods([strategy])
    artefacts = _artefacts(file, None)
    wanted = _wanted(positions, GUIDELINE_COUNTS, artefacts)
    cal = _load_stereo(calibration)
    rig, config = _acceptance_rig(rig_config, given, **hardware)
    check_output_against_inputs(output, [rig_config, config.gamma_file, calibration, file])
    checked = check_output_dir(output, force)
    info = {"rig": "hardware", "calibration": str(calibration), "strategy": method.name}
    return _run_live(checked, force, (rig, config, cal), method, wanted, artefacts, wait, say, info)


def _run_live(
    checked: Any,
    force: bool,
    devices: tuple[Any, Any, StereoCalibration],
    method: Any,
    wanted: Sequence[tuple[str, int]],
    artefacts: Artefacts,
    wait: Callable[[int, int, str], bool],
    say: Say,
    info: dict[str, Any],
) -> AcceptanceReport:
    """The staged part of :func:`acceptance_hardware`."""
    from hdrfringe.core.programs import fringe_specs
    from hdrfringe.io.results import staged_output_dir
    from hdrfringe.tasks.capture import announce_line
    from hdrfringe.tasks.capture_poses import board_pitches

    live = _Live()
    rig, config, _ = devices
    with rig, staged_output_dir(checked, force=force) as tmp:
        pitches = board_pitches(rig.projector.width, rig.projector.height)
        specs = fringe_specs("sinusoidal", STEPS, list(pitches))
        say(announce_line(method.strategy, rig, config))
        for number, (kind, index) in enumerate(wanted, 1):
            label = f"{kind}_{index:02d}"
            sidecar = {
                "kind": kind,
                "index": index,
                "label": label,
                "description": "",
                "strategy": method.name,
            }
            if not _live_step(
                live,
                number,
                len(wanted),
                sidecar,
                wait,
                devices,
                method,
                specs,
                artefacts,
                tmp,
                say,
            ):
                break
        if not live.outcomes:
            raise HdrFringeError(
                f"acceptance {live.stopped or 'stopped'} before the first position; nothing written"
            )
        info.update(pitches=list(pitches), positions=len(live.outcomes))
        info["complete"] = len(live.outcomes) == len(wanted)
        if live.stopped:
            info["stopped"] = live.stopped
        report = AcceptanceReport(
            checked, live.outcomes, _summaries(live.outcomes, artefacts), artefacts, info
        )
        _write_report(tmp, report)
    _raise_if_stopped(live, checked)
    return report


def _live_step(
    live: _Live,
    number: int,
    total: int,
    sidecar: dict[str, Any],
    wait: Callable[[int, int, str], bool],
    devices: tuple[Any, Any, StereoCalibration],
    method: Any,
    specs: Sequence[Any],
    artefacts: Artefacts,
    tmp: Path,
    say: Say,
) -> bool:
    """One position live; False when the run ends (q, a stop, an error after a position)."""
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.io.results import SignalStop, deferred_signals, signals_as_interrupt
    from hdrfringe.pipeline import measure
    from hdrfringe.tasks.capture import live_record, stop_reason, write_capture_output

    rig, config, cal = devices
    label = sidecar["label"]
    try:
        with signals_as_interrupt():
            if not wait(number, total, label):
                live.stopped = "finished with q"
                return False
            rig.rebaseline()  # the artefact moved: a new reference image of the screen
            start = len(rig.log)
            recorder = Recorder(rig)
            res = measure(
                recorder,
                cal,
                strategy=method.strategy,
                params=dict(method.params),
                specs=specs,
                label=label,
            )
            images = sum(r.images_captured for r in res.strategy_results)
            outcome = _outcome(res, sidecar, artefacts, cal, images)
            with deferred_signals(honour=False) as held:
                caps, state, log = live_record(
                    recorder,
                    rig,
                    config,
                    method.strategy,
                    label,
                    entries={"acceptance_position": label},
                    start=start,
                )
                folder = tmp / "captures" / method.name / label
                folder.mkdir(parents=True)
                write_capture_output(folder, caps, state, log)
                text = dumps({**sidecar, "images": images}, nonfinite="error")
                (folder / POSITION_FILE).write_text(text + "\n", encoding="utf-8")
                live.outcomes.append(outcome)
            say(
                f"{label}: {images} images, "
                + ", ".join(f"{k} {_fmt(v)} mm" for k, v in outcome.values.items())
                + (f" ({outcome.note})" if outcome.note else "")
            )
            if held() == signal.SIGINT:
                raise KeyboardInterrupt
            if held() is not None:
                raise SignalStop(int(held() or 0))
    except KeyboardInterrupt as stop:
        if not live.outcomes:
            raise
        live.stopped, live.code = stop_reason(stop)
        live.dropped = live.outcomes[-1].label != label
        return False
    except HdrFringeError as err:
        if not live.outcomes:
            raise
        live.stopped, live.failure = f"stopped by an error at {label}", err
        return False
    return True


def _raise_if_stopped(live: _Live, output: Path) -> None:
    """A run stopped by a signal or an error: its complete positions are written; say so."""
    if live.failure is None and not live.code:
        return
    what = (
        f"{len(live.outcomes)} complete positions ({live.outcomes[0].label} .. "
        f"{live.outcomes[-1].label})"
    )
    why = (
        live.stopped
        if live.failure is None
        else (f"{live.stopped}: {' '.join(str(live.failure).split())}")
    )
    raise StoppedError(
        f"acceptance {why}; {output} holds the {what} evaluated before it"
        + (", the position being captured was dropped" if live.dropped else ""),
        live.code or 2,
    )
