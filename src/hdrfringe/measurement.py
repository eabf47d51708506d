"""Folder-level calibration and measurement: captures in, calibration and heights out.

* :func:`calibrate_folders`: flat-plate capture folders at known ``scene.depth_mm`` (one at 0, the
  reference plane) -> absolute phase per folder (centerline or one-period set, docs/phase.md) ->
  :func:`hdrfringe.calibration.calibrate` (Eq. 2.10, 2.15 and the non-linear models, Sec. 4.1
  filtering) with provenance (package version, date, input folders and content hashes);
  :func:`calibrate_captures` does the same on :class:`~hdrfringe.captures.Captures` in memory.
* :func:`measure_folder`: captures and a calibration -> height (Eq. 2.10-2.11 or the
  non-linear model), point cloud coordinates, and error metrics when the captures know their
  truth (``scene.depth_mm`` or a ``truth_height_mm`` map).

This module orchestrates and still reads capture folders (:func:`calibrate_folders`), so it
sits in the I/O layer.
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe import __version__
from hdrfringe.calibration import Calibration, calibrate, check_compatible
from hdrfringe.captures import Captures
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.io.captures import read_capture_folder
from hdrfringe.patterns import FringeSpec
from hdrfringe.process import FolderPhase, decode_captures
from hdrfringe.reconstruct import CameraGeometry, height_errors

if TYPE_CHECKING:
    from hdrfringe.saturation.dpa_rules import SaturationCDF
    from hdrfringe.saturation.estimate import TrainingData
    from hdrfringe.strategies.base import StrategyResult


def expand_capture_dirs(paths: list[Path]) -> list[Path]:
    """Capture folders among ``paths``; a folder without a manifest contributes its sub-folders."""
    out: list[Path] = []
    for p in paths:
        if p.is_dir() and not (p / "manifest.json").exists():
            subs = sorted(d for d in p.iterdir() if (d / "manifest.json").is_file())
            if subs:
                out += subs
                continue
        out.append(p)
    return out


def absolute_phase_of(folder: Captures, decoded: FolderPhase) -> tuple[NDArray, FringeSpec]:
    """Absolute phase of the primary family and the spec of its finest set, or a clear error."""
    fam = decoded.primary
    if fam is None:
        raise CaptureFormatError(f"{folder.name}: no fringe sets; add a complete phase-shifted set")
    if fam.absolute_phase is None:
        raise CaptureFormatError(
            f"{folder.name}: cannot make the phase absolute: add a {fam.orientation} centerline "
            "frame or a set whose pitch spans the projector (one period)"
        )
    return fam.absolute_phase, fam.sets[-1].spec


def _same_spec(a: FringeSpec, b: FringeSpec) -> bool:
    return (a.pattern, a.steps, a.pitch_px, a.orientation) == (
        b.pattern,
        b.steps,
        b.pitch_px,
        b.orientation,
    )


def calibrate_folders(
    paths: list[Path],
    *,
    model: str = "linear",
    window_px: int = 21,
    border_px: int = 10,
    progress: Any = None,
) -> Calibration:
    """Calibrate from flat-plate capture folders (thesis Sec. 2.5, 4.1).

    Every folder must give ``scene.depth_mm``; exactly one is at 0 (the reference plane); depths
    must be distinct; all must share pattern spec, image size and camera bit depth. Everything
    is read and checked before any fitting.
    """
    folders = [read_capture_folder(p) for p in expand_capture_dirs(paths)]
    return calibrate_captures(
        folders, model=model, window_px=window_px, border_px=border_px, progress=progress
    )


def calibrate_captures(
    folders: list[Captures],
    *,
    model: str = "linear",
    window_px: int = 21,
    border_px: int = 10,
    progress: Any = None,
) -> Calibration:
    """:func:`calibrate_folders` on captures already read (or made in memory).

    The provenance records each input's ``name`` and its :meth:`Captures.content_hash
    <hdrfringe.captures.Captures.content_hash>`.
    """
    if len(folders) < 3:
        raise InputError(
            f"calibration needs the reference plane and at least 2 plate positions, got "
            f"{len(folders)} folder(s); give more plate positions"
        )
    depths = []
    for f in folders:
        d = f.scene.get("depth_mm")
        if d is None:
            raise CaptureFormatError(
                f"{f.name}: manifest has no scene.depth_mm; calibration folders must state the "
                "plate depth (0 for the reference plane)"
            )
        depths.append(float(d))
    refs = [f for f, d in zip(folders, depths, strict=True) if d == 0.0]
    if not refs:
        raise InputError(
            "no reference plane: none of the folders has scene.depth_mm = 0; add the "
            "reference-plane captures"
        )
    if len(refs) > 1:
        raise InputError(
            f"several reference planes (depth 0): {', '.join(r.name for r in refs)}; keep one"
        )
    seen: dict[float, str] = {}  # duplicate depths, named by folder
    for f, d in zip(folders, depths, strict=True):
        if d in seen:
            raise InputError(
                f"duplicate depth {d:g} mm in {seen[d]} and {f.name}; each position once"
            )
        seen[d] = f.name
    ref = refs[0]
    for f in folders[1:] if folders[0] is ref else folders:
        if f.image_shape != ref.image_shape:
            raise InputError(
                f"{f.name}: images are {f.image_shape[1]}x{f.image_shape[0]} but the reference "
                f"plane's are {ref.image_shape[1]}x{ref.image_shape[0]}; use one camera setting"
            )
        if f.camera_bit_depth != ref.camera_bit_depth:
            raise InputError(
                f"{f.name}: camera bit depth {f.camera_bit_depth} differs from the reference "
                f"plane's {ref.camera_bit_depth}"
            )
    phases: dict[int, NDArray] = {}
    spec0: FringeSpec | None = None
    for f in folders:
        phi, spec = absolute_phase_of(f, decode_captures(f))
        if spec0 is None:
            spec0 = spec
        elif not _same_spec(spec, spec0):
            raise InputError(
                f"{f.name}: fringes {spec.label()} differ from {spec0.label()} in the other "
                "folders; calibrate with one pattern, steps, pitch and orientation"
            )
        phases[id(f)] = phi
        if progress is not None:
            progress()
    assert spec0 is not None
    order = sorted(
        ((d, f) for d, f in zip(depths, folders, strict=True) if f is not ref), key=lambda t: t[0]
    )
    geometry = CameraGeometry.from_manifest(ref.camera)
    provenance: dict[str, Any] = {
        "package_version": __version__,
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "inputs": {
            f"{i:02d}": {
                "path": str(Path(f.name).resolve()),
                "depth_mm": d,
                "sha256": f.content_hash(),
            }
            for i, (d, f) in enumerate([(0.0, ref), *order])
        },
    }
    if geometry is not None:
        provenance["camera_geometry"] = geometry.to_manifest()
    gamma = ref.projector.gamma_precompensation if ref.projector is not None else 1.0
    return calibrate(
        phases[id(ref)],
        np.stack([phases[id(f)] for _, f in order]),
        np.array([d for d, _ in order]),
        model=model,
        window_px=window_px,
        border_px=border_px,
        spec=spec0,
        gamma_precompensation=gamma,
        camera_bit_depth=ref.camera_bit_depth,
        provenance=provenance,
    )


def calibration_geometry(cal: Calibration) -> CameraGeometry | None:
    """Camera geometry recorded with a calibration (from its reference-plane folder)."""
    entry = cal.provenance.get("camera_geometry")
    return CameraGeometry.from_manifest(entry) if isinstance(entry, dict) else None


@dataclass
class Measurement:
    """Height and metrics of one set of captures."""

    decoded: FolderPhase
    height_mm: NDArray[np.float64] | None
    metrics: dict[str, Any] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)


def measure_folder(
    folder: Captures,
    calibration: Calibration | None,
    *,
    calibration_source: str | None = None,
    reject_saturated: bool = True,
) -> Measurement:
    """Decode captures and, with a calibration, compute their height map and metrics.

    The calibration is refused (one-line error) when its pattern spec, image size or camera bit
    depth differ from the folder's. Metrics cover the measurement pixels (the calibration's
    border excluded, thesis Sec. 4.1): valid and saturated fractions always; bias, standard
    deviation and RMSE against ``truth_height_mm`` (a map in the folder) or ``scene.depth_mm``
    when the folder gives one.
    """
    decoded = decode_captures(folder, reject_saturated=reject_saturated)
    fam = decoded.primary
    skipped: list[str] = []
    metrics: dict[str, Any] = {"source": folder.name}
    if fam is not None:
        finest = decoded.set_results[fam.sets[-1].label]
        sat = np.zeros(folder.image_shape, bool)
        for s in fam.sets:
            sat |= decoded.set_results[s.label].saturation_count > 0
        metrics["saturated_fraction"] = float(sat.mean())
        metrics["phase_valid_fraction"] = float(finest.valid.mean())
    if calibration is None:
        skipped.append("height (no --calibration given)")
        return Measurement(decoded, None, metrics, skipped)
    phi, spec = absolute_phase_of(folder, decoded)
    check_compatible(
        calibration, spec, folder.image_shape, folder.camera_bit_depth, source=calibration_source
    )
    height = calibration.height(phi)
    inside = calibration.measurement_mask()
    metrics["model"] = calibration.model
    metrics["border_px"] = calibration.border_px
    metrics["valid_fraction"] = float(np.isfinite(height)[inside].mean())
    if fam is not None:
        metrics["saturated_fraction_measurement_pixels"] = float(
            np.mean(
                np.logical_or.reduce(
                    [decoded.set_results[s.label].saturation_count > 0 for s in fam.sets]
                )[inside]
            )
        )
    truth = folder.map("truth_height_mm")
    if truth is not None:
        metrics["truth"] = "truth_height_mm map"
        metrics.update(height_errors(height, truth, inside))
    elif "depth_mm" in folder.scene:
        metrics["truth"] = f"scene.depth_mm = {float(folder.scene['depth_mm']):g}"
        metrics.update(height_errors(height, float(folder.scene["depth_mm"]), inside))
    return Measurement(decoded, height, metrics, skipped)


def composite_captures(
    rig: Any,
    specs: list[FringeSpec],
    method: str,
    *,
    centerline: Any = None,
    scene: dict[str, Any] | None = None,
    camera_extra: dict[str, Any] | None = None,
    truth_height_mm: NDArray | None = None,
    label: str = "",
    **params: Any,
) -> tuple[Captures, list[Any]]:
    """Run ``method`` for every set in ``specs`` on ``rig`` (live or replayed) and assemble the
    composites as in-memory :class:`~hdrfringe.captures.Captures` that :func:`measure_folder`
    treats like any other.

    ``method`` is any registered strategy (:func:`hdrfringe.strategies.available_strategies`);
    ``params`` are its parameters by name (:func:`hdrfringe.strategies.make_params`).

    Each set is labelled at its highest MIGL; ``centerline`` (a frame, optional) is captured once
    at the end. ``scene``, ``camera_extra`` (the camera description besides its bit depth) and
    ``truth_height_mm`` go into the captures' scene, camera and maps (ground truth gives the
    measurement its error metrics); ``label`` becomes their name.
    """
    from hdrfringe.frames import Frame
    from hdrfringe.strategies import get_strategy, make_params

    strategy, strategy_params = get_strategy(method), make_params(method, **params)
    frames: list[Frame] = []
    images = []
    results = []
    for spec in specs:
        res = strategy.run(rig, spec, strategy_params)
        results.append(res)
        frames += spec.frames()
        images.append(res.images)
    if centerline is not None:
        frames.append(centerline)
        images.append(rig.capture([centerline]))
    dtype = np.result_type(*[i.dtype for i in images])
    stack = np.concatenate([i.astype(dtype, copy=False) for i in images])
    out = Captures(
        frames,
        stack,
        rig.camera_bit_depth,
        projector=rig.projector,
        scene=dict(scene or {}),
        camera=dict(camera_extra or {}),
        maps={} if truth_height_mm is None else {"truth_height_mm": truth_height_mm},
        name=label or "<memory>",
    )
    return out, results


def simulated_composite(
    rig: Any,
    specs: list[FringeSpec],
    method: str,
    *,
    centerline: Any = None,
    **params: Any,
) -> tuple[Captures, list[Any]]:
    """:func:`composite_captures` on the live virtual rig, carrying its scene, camera geometry
    and ground truth (as :meth:`SimulatedRig.capture_folder` does for plain captures)."""
    return composite_captures(
        rig,
        specs,
        method,
        centerline=centerline,
        scene=rig.scene.to_manifest(),
        camera_extra=rig.camera_manifest(),
        truth_height_mm=rig.truth().height_mm,
        label=rig.scene.name,
        **params,
    )


def composite_folder(folder: Captures, method: str, **params: Any) -> tuple[Captures, list[Any]]:
    """Run a saturation-avoidance strategy on replayed captures (a MIGL sweep).

    For every pitch of the primary family (vertical first) at the folder's highest MIGL, the
    strategy (any registered one: ``conventional``, ``uniform``, ``lpa``, ``dpa``, ...; see
    :mod:`hdrfringe.strategies`) drives a :class:`~hdrfringe.rig.replay.ReplayRig`
    over the captures (:func:`composite_captures`). Their first centerline frame of the
    family's orientation, their camera description and their ground truth come along.
    """
    from hdrfringe.process import group_families
    from hdrfringe.rig.replay import ReplayRig
    from hdrfringe.strategies import get_strategy

    get_strategy(method)  # an unknown method is refused before the folder is examined
    if not folder.sets:
        raise CaptureFormatError(f"{folder.name}: no fringe sets to run a strategy on")
    families = group_families(folder.sets)
    rig = ReplayRig(folder)
    if method == "uniform" and params.get("migl") is None:
        params = {**params, "candidates": rig.available_migls()}
    lines = [f for f, _ in folder.centerlines() if f.orientation == families[0][0].spec.orientation]
    return composite_captures(
        rig,
        [s.spec for s in families[0]],
        method,
        centerline=lines[0] if lines else None,
        scene=folder.scene,
        camera_extra=folder.camera,
        truth_height_mm=folder.map("truth_height_mm"),
        label=folder.name,
        **params,
    )


def tradeoff_search(
    rig: Any,
    spec: FringeSpec,
    calibration: Calibration,
    migls: Any,
    *,
    extra_frames: list | None = None,
) -> dict[str, Any]:
    """The thesis's uniform trade-off search (Sec. 4.2): sweep the MIGL on a known target.

    For every MIGL a set is captured (with ``extra_frames``, e.g. the centerline, captured once)
    and measured with the calibration, *keeping* saturated pixels as the thesis did, so that
    saturation error counts; the RMSE against the target's truth (a ``truth_height_mm`` map or
    ``scene.depth_mm`` from the rig's scene) is recorded and the MIGL of the lowest RMSE is the
    trade-off point.

    Returns
    -------
    dict
        ``rmse_mm`` {migl: RMSE}, ``saturated_fraction`` {migl: fraction}, ``best_migl``.
    """
    extra = list(extra_frames or [])
    extra_imgs = rig.capture(extra) if extra else None
    truth = rig.truth().height_mm if hasattr(rig, "truth") else None
    scene = rig.scene.to_manifest() if hasattr(rig, "scene") else {}
    rmse: dict[float, float] = {}
    sat: dict[float, float] = {}
    for m in migls:
        frames = spec.with_migl(float(m)).frames()
        imgs = rig.capture(frames)
        if extra_imgs is not None:
            imgs = np.concatenate([imgs, extra_imgs])
        folder = Captures(
            [*frames, *extra],
            imgs,
            rig.camera_bit_depth,
            projector=rig.projector,
            scene=scene,
            maps={} if truth is None else {"truth_height_mm": truth},
        )
        res = measure_folder(folder, calibration, reject_saturated=False)
        rmse[float(m)] = float(res.metrics.get("rmse_mm", np.nan))
        sat[float(m)] = float(res.metrics.get("saturated_fraction", np.nan))
    best = min(rmse, key=lambda k: (np.nan_to_num(rmse[k], nan=np.inf), -k))
    return {"rmse_mm": rmse, "saturated_fraction": sat, "best_migl": best}


# ---------------------------------------------------------------------------------------------
# DPA: estimated versus actual CDF (thesis Fig. 6.3) and the correction's training data
# ---------------------------------------------------------------------------------------------

#: Thesis Sec. 6.1.2: RMSE (gray levels) of the saturated-intensity estimate against Eq. 6.3's
#: truth before and after the error correction (Eq. 6.4).
THESIS_CORRECTION_RMSE: tuple[float, float] = (71.05, 2.99)


@dataclass
class DPACDFs:
    """The CDFs of thesis Fig. 6.3 for one DPA set.

    Attributes
    ----------
    spec : FringeSpec
        The set at its highest MIGL.
    migls, rules : list
        MIGLs captured, in capture order, and the rule that asked for each (``"initial"`` first).
    saturated_at_top : int
        Pixels saturated at the highest MIGL (the CDFs' denominator).
    initial, final : SaturationCDF or None
        Estimated CDF from the first set and after the last update (None: nothing saturated).
    actual : SaturationCDF or None
        From the DPA index image over the pixels saturated at the top: each pixel counts at the
        MIGL of the capture where it became unsaturated, so the CDF is quantised to the captured
        MIGLs (at a captured MIGL it is the fraction unsaturated at or above it).
    exact : SaturationCDF or None
        From LPA with a step of 1 (every integer MIGL) on a replayed sweep, when the folder holds
        every integer MIGL down to DPA's lowest capture: the thesis's actual CDF (Eq. 6.3 is the
        same histogram of ``N(x, y)``).
    """

    spec: FringeSpec
    migls: list[float]
    rules: list[str]
    saturated_at_top: int
    initial: SaturationCDF | None = None
    final: SaturationCDF | None = None
    actual: SaturationCDF | None = None
    exact: SaturationCDF | None = None

    def max_abs_difference(self, which: str = "actual") -> float | None:
        """Largest ``|F_initial(m) - F_actual(m)|``: over the captured MIGLs for ``"actual"``
        (where the quantised CDF is a sample of the exact one), over every integer MIGL from the
        top down to DPA's lowest capture for ``"exact"``. None when the CDF is not available."""
        other = self.actual if which == "actual" else self.exact
        if self.initial is None or other is None:
            return None
        if which == "actual":
            ms = [round(m) for m in self.migls]
        else:
            ms = list(range(round(min(self.migls)), self.initial.migl0 + 1))
        return float(max(abs(self.initial.at(m) - other.at(m)) for m in ms))


def _index_without_never(result: StrategyResult) -> NDArray[np.float64]:
    """The index image with pixels never unsaturated marked -1 (they count as ``beyond``)."""
    idx = np.asarray(result.migl_index, dtype=np.float64).copy()
    idx[result.never_unsaturated] = -1.0
    return idx


def dpa_cdfs(result: StrategyResult, replay: Captures | None = None) -> DPACDFs:
    """Estimated and actual CDFs (thesis Fig. 6.3) of a DPA :class:`StrategyResult`.

    Parameters
    ----------
    result : StrategyResult
        From :func:`hdrfringe.strategies.dpa.dpa` (``details`` holds ``initial_cdf``,
        ``final_cdf`` and ``saturated_at_top`` when a pixel saturated at the top).
    replay : Captures, optional
        The MIGL sweep DPA was replayed on. When it holds this set at every integer MIGL from the
        top down to DPA's lowest capture, LPA with step 1 runs on it (images are in memory) and
        its index image gives the exact actual CDF.
    """
    from hdrfringe.rig.replay import ReplayRig
    from hdrfringe.saturation.dpa_rules import index_image_cdf
    from hdrfringe.strategies.lpa import lpa

    d = result.details
    rules = list(d.get("rules", ["initial"]))
    out = DPACDFs(result.spec, list(map(float, result.migls)), rules, 0)
    if "initial_cdf" not in d:  # requirement 4: nothing saturated, one set
        return out
    initial, final = d["initial_cdf"], d["final_cdf"]
    top = np.asarray(d["saturated_at_top"], dtype=bool)
    out.saturated_at_top = int(top.sum())
    out.initial, out.final = initial, final
    out.actual = index_image_cdf(
        _index_without_never(result), top, initial.migl0, initial.lowest_migl
    )
    if replay is not None:
        spec = result.spec
        have = {
            float(s.spec.migl)
            for s in replay.sets
            if _same_spec(s.spec, spec) and s.spec.imin == spec.imin
        }
        lowest = round(min(out.migls))
        if all(float(m) in have for m in range(lowest, initial.migl0 + 1)):
            exact = lpa(ReplayRig(replay), spec, step=1.0, min_migl=float(lowest))
            out.exact = index_image_cdf(
                _index_without_never(exact), top, initial.migl0, initial.lowest_migl
            )
    return out


def training_data_from_folder(
    folder: Captures, pitch: float | None = None, *, margin: int = 10
) -> TrainingData:
    """The correction's training data (thesis Sec. 6.1.2) from a step-1 MIGL sweep folder.

    The folder must hold a sinusoidal set of at least 4 steps at every integer MIGL from its
    highest down to its lowest one (``hdrfringe simulate white_plate --migl-sweep 255:60:1
    --pitch 20 --ambient-lux 600``); :func:`training_data_from_rig` then replays LPA with a
    step of 1 on it. ``pitch`` picks the set when the folder holds several pitches. Uniform
    frames at ``imin``, when present, give the offset ``A``.

    Returns
    -------
    TrainingData
    """
    from hdrfringe.frames import UniformFrame
    from hdrfringe.rig.replay import ReplayRig
    from hdrfringe.saturation.estimate import training_data_from_rig

    sets = [s for s in folder.sets if s.spec.pattern == "sinusoidal" and s.spec.steps >= 4]
    if not sets:
        raise CaptureFormatError(
            f"{folder.name}: no sinusoidal set of 4 or more steps; the correction is trained on "
            "sinusoidal sets (thesis: 4-step, 20 px pitch)"
        )
    pitches = sorted({s.spec.pitch_px for s in sets})
    if pitch is None:
        if len(pitches) > 1:
            raise InputError(
                f"{folder.name}: holds pitches {', '.join(f'{p:g}' for p in pitches)} px; choose "
                "one with --pitch (the thesis trains at 20 px)"
            )
        pitch = pitches[0]
    chosen = [s for s in sets if s.spec.pitch_px == pitch]
    if not chosen:
        raise InputError(
            f"{folder.name}: no sinusoidal set at pitch {pitch:g} px; it holds "
            + ", ".join(f"{p:g}" for p in pitches)
        )
    top_set = max(chosen, key=lambda s: s.spec.migl)
    spec = top_set.spec
    migls = {float(s.spec.migl) for s in chosen if _same_spec(s.spec, spec)}
    low = min(migls)
    missing = [m for m in range(round(low), round(spec.migl) + 1) if float(m) not in migls]
    if len(migls) < 2 or missing or spec.migl != round(spec.migl):
        what = (
            f"{len(missing)} integer MIGLs between {low:g} and {spec.migl:g} are missing"
            if missing
            else f"it holds MIGLs {', '.join(f'{m:g}' for m in sorted(migls, reverse=True)[:5])}"
        )
        raise CaptureFormatError(
            f"{folder.name}: training needs the set at every integer MIGL from the top down "
            f"(LPA with a step of 1), but {what}; capture e.g. hdrfringe simulate "
            "--migl-sweep 255:60:1"
        )
    n_offset = sum(1 for f in folder.frames if isinstance(f, UniformFrame) and f.level == spec.imin)
    return training_data_from_rig(
        ReplayRig(folder),
        spec,
        lowest_migl=max(low, math.floor(spec.imin) + 1),
        margin=margin,
        offset_captures=min(n_offset, 1),
    )
