"""Evaluation of a measured position for ``hdrfringe acceptance``: segment the artefact,
compute its quantities and their predicted std (:mod:`hdrfringe.tasks.acceptance`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hdrfringe.core import acceptance as acc
from hdrfringe.core.acceptance_noise import ray_depth_std, spacing_std, sphere_fit_std
from hdrfringe.core.stereo import StereoCalibration
from hdrfringe.core.strict_json import plain
from hdrfringe.errors import InputError
from hdrfringe.io.acceptance_file import (
    PlaneArtefact,
)
from hdrfringe.tasks._acceptance_common import (
    BALL_BAR_NECK_DEG,
    F64,
    MAX_VIEW_DEG,
    PLANE_BAND_FRACTION,
    PLANE_SLAB_FRACTION,
    Artefacts,
)

__all__ = [
    "PositionOutcome",
    "evaluate_cloud",
]

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
    >>> from hdrfringe.tasks.acceptance import SIM_MPES
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
