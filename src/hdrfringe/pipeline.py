"""The measurement pipeline: captures or a rig in, calibration, heights and metrics out.

* :func:`measure`: captures (or the live rig a saturation-avoidance strategy drives) ->
  absolute phase (:func:`hdrfringe.core.decode.decode_captures`) -> height with a calibration
  (Eq. 2.10-2.11 or the non-linear model), or 3D points triangulated with a projector-camera
  calibration (:mod:`hdrfringe.core.stereo`) -> :class:`MeasurementResult`: the captures measured,
  the decoded phase, the height map, the points (:meth:`MeasurementResult.points`), the typed
  :class:`MeasurementMetrics` (error against the truth the captures or the rig know) and, with a
  strategy, its results and what its metrics hook adds (DPA: the CDF analysis of thesis
  Fig. 6.3). The calibration is any :class:`~hdrfringe.core.calibration.MeasurementCalibration`
  and the strategy any registered one: nothing here asks which one it is.
* :func:`calibrate`: flat-plate captures at known ``scene.depth_mm`` -> :class:`Calibration`
  (Eq. 2.10, 2.15 and the non-linear models, Sec. 4.1 filtering) with provenance.
* :func:`composite_captures`: a strategy run per fringe set on a rig, as captures.
* :func:`tradeoff_search`: the uniform trade-off search of thesis Sec. 4.2.

Nothing here reads or writes files: :mod:`hdrfringe.io.captures` reads capture folders,
:func:`hdrfringe.tasks.measure.write_measurement` writes a result folder
(docs/measurement.md).
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from hdrfringe._renamed import renamed_fields, renamed_keyword
from hdrfringe.core._validation import json_safe
from hdrfringe.core.calibration import NO_GEOMETRY, Calibration, MeasurementCalibration
from hdrfringe.core.calibration import calibrate as fit_calibration
from hdrfringe.core.captures import CameraSettings, Captures
from hdrfringe.core.decode import (
    FolderPhase,
    decode_captures,
    group_families,
    no_absolute_phase_note,
)
from hdrfringe.core.frames import CenterlineFrame, Frame, GrayCodeFrame, UniformFrame
from hdrfringe.core.geometric_order import check_depth_range, family_geometric_order
from hdrfringe.core.harmonics import harmonics_mode
from hdrfringe.core.patterns import FringeSpec, same_fringes
from hdrfringe.core.reconstruct import CameraGeometry, height_errors, points_from_height
from hdrfringe.core.saturation.tolerant import DECODER_NAME
from hdrfringe.core.stereo import (
    DirectionCheck,
    StereoCalibration,
    StereoMaps,
    check_directions,
    coordinate_noise_px,
    projector_coordinate,
    triangulate_maps,
)
from hdrfringe.core.uncertainty import (
    NoiseModel,
    NoiseUnknownError,
    Uncertainty,
    predict_uncertainty,
)
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.rig.base import Rig
from hdrfringe.rig.replay import ReplayRig
from hdrfringe.strategies import (
    DEFAULT_STRATEGY,
    MetricsContext,
    RunContext,
    StrategyResult,
    get_strategy,
    make_params,
    prepare_params,
    run_strategy,
    strategy_metrics,
)

if TYPE_CHECKING:  # the types of two strategy blocks of the metrics; their hook fills them
    from hdrfringe.strategies.dpa_analysis import DPACDFs, DPAMetrics

__all__ = [
    "NO_CALIBRATION",
    "NO_GEOMETRY",
    "MeasurementMetrics",
    "MeasurementResult",
    "RigDescription",
    "SceneRig",
    "StrategySummary",
    "calibrate",
    "calibration_geometry",
    "composite_captures",
    "describe_rig",
    "height_points",
    "measure",
    "strategy_absolute_phases",
    "strategy_summary",
    "tradeoff_search",
]

#: The stage a measurement without a calibration skips (``metrics.skipped``).
NO_CALIBRATION = "height (no --calibration given)"

F64 = NDArray[np.float64]


# ---------------------------------------------------------------------------------------------
# geometry
# ---------------------------------------------------------------------------------------------


def calibration_geometry(cal: MeasurementCalibration) -> CameraGeometry | None:
    """Camera geometry recorded with a calibration (from its reference-plane captures).

    Parameters
    ----------
    cal : MeasurementCalibration
        Either kind (:meth:`~hdrfringe.core.calibration.Calibration.camera_geometry`).

    Returns
    -------
    CameraGeometry or None
        None when the reference-plane captures recorded no ``focal_px`` and ``standoff_mm``
        (and always for a stereo calibration: its points are triangulated).

    References
    ----------
    Thesis Sec. 2.1 (the camera perpendicular to the reference plane).

    Examples
    --------
    >>> cal = Calibration("linear", np.ones((2, 3)), None, np.zeros((2, 3)), np.array([2.0]))
    >>> calibration_geometry(cal) is None
    True
    """
    return cal.camera_geometry()


def height_points(
    height_mm: NDArray[np.float64], geometry: CameraGeometry | None
) -> tuple[F64, F64, F64]:
    """x, y, z maps of a height map: mm from the camera geometry, else pixels.

    Parameters
    ----------
    height_mm : ndarray (H, W)
        Height in mm (NaN = invalid).
    geometry : CameraGeometry or None
        The camera's pinhole geometry. None: x is the column and y minus the row, in pixels.

    Returns
    -------
    x, y, z : ndarray (H, W)
        ``z`` is the height (:func:`hdrfringe.core.reconstruct.points_from_height` with a geometry).

    References
    ----------
    Thesis Sec. 2.4, Eq. 2.11 (the height map).

    Examples
    --------
    >>> x, y, z = height_points(np.zeros((2, 3)), None)
    >>> x[1].tolist(), y[:, 0].tolist()
    ([0.0, 1.0, 2.0], [-0.0, -1.0])
    """
    if geometry is not None:
        return points_from_height(height_mm, geometry)
    rows_cols = np.indices(np.shape(height_mm), dtype=np.float64)
    return rows_cols[1], -rows_cols[0], np.asarray(height_mm, dtype=np.float64)


# ---------------------------------------------------------------------------------------------
# what a rig looks at
# ---------------------------------------------------------------------------------------------


@runtime_checkable
class SceneRig(Protocol):  # numpydoc ignore=PR01
    """A rig that knows what it looks at (the virtual rig,
    :class:`~hdrfringe.rig.simulated.SimulatedRig`).

    Attributes
    ----------
    scene
        Has ``name`` and ``to_manifest()`` (the scene description of a capture manifest).

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> rig = SimulatedRig(white_plate(5.0), camera=CameraModel(width=32, height=24))
    >>> isinstance(rig, SceneRig), describe_rig(rig).name
    (True, 'white_plate')
    """

    scene: Any

    def camera_manifest(self) -> dict[str, Any]:
        """The camera description of a capture manifest (``focal_px``, ``standoff_mm``)."""
        ...

    def truth(self) -> Any:
        """Ground truth per camera pixel; has ``height_mm`` (H, W)."""
        ...

    def to_manifest(self) -> dict[str, Any]:
        """Every parameter of the rig, JSON-friendly."""
        ...


@dataclass(frozen=True)
class RigDescription:
    """What captures made on a rig carry about it.

    Parameters
    ----------
    name : str
        Name of the captures (the scene's, or the replayed captures').
    scene, camera : dict
        Scene and camera description of a capture manifest.
    truth_height_mm : ndarray or None
        Ground-truth height map (gives a measurement its error metrics).
    parameters : dict or None
        The live rig's scene and every parameter (``metrics.live_rig``); None for a replay.

    Examples
    --------
    >>> RigDescription("plate", {}, {}, None, None).name
    'plate'
    """

    name: str
    scene: dict[str, Any]
    camera: dict[str, Any]
    truth_height_mm: NDArray[np.float64] | None = field(default=None, repr=False, compare=False)
    parameters: dict[str, Any] | None = None


def describe_rig(rig: Rig) -> RigDescription:
    """The description of a rig: from its captures (replay), its scene (:class:`SceneRig`), or
    nothing.

    Parameters
    ----------
    rig : Rig

    Returns
    -------
    RigDescription

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import SimulatedRig
    >>> desc = describe_rig(SimulatedRig(white_plate(12.0)))
    >>> desc.name, desc.scene["depth_mm"], desc.truth_height_mm.shape
    ('white_plate', 12.0, (494, 648))
    """
    if isinstance(rig, ReplayRig):
        c = rig.captures
        return RigDescription(c.name, dict(c.scene), dict(c.camera), c.map("truth_height_mm"))
    if isinstance(rig, SceneRig):
        scene = rig.scene.to_manifest()
        return RigDescription(
            rig.scene.name,
            dict(scene),
            dict(rig.camera_manifest()),
            rig.truth().height_mm,
            {"scene": scene, **rig.to_manifest()},
        )
    return RigDescription("<memory>", {}, {})


# ---------------------------------------------------------------------------------------------
# strategies on a rig
# ---------------------------------------------------------------------------------------------


def _strategy_params(name: str, params: Any) -> Any:
    """``params`` as the strategy's ``Params`` (a mapping goes through :func:`make_params`)."""
    strategy = get_strategy(name)
    if params is None:
        return make_params(name)
    if isinstance(params, strategy.Params):
        return params
    if isinstance(params, Mapping):
        return make_params(name, **params)
    raise InputError(
        f"params of {name} must be a {strategy.Params.__name__} or a mapping of its fields, "
        f"got {type(params).__name__}"
    )


def composite_captures(
    rig: Rig,
    specs: Sequence[FringeSpec],
    strategy: str | None = None,
    params: Any = None,
    *,
    centerline: Frame | None = None,
    description: RigDescription | None = None,
    extra_frames: Sequence[Frame] = (),
    method: str | None = None,
) -> tuple[Captures, tuple[StrategyResult, ...]]:
    """Run a strategy for every set in ``specs`` on ``rig`` and assemble the composites.

    Parameters
    ----------
    rig : Rig
        Live or replayed (:class:`~hdrfringe.rig.replay.ReplayRig`).
    specs : sequence of FringeSpec
        The sets at their highest MIGL (e.g. one per pitch, coarse first).
    strategy : str
        A registered strategy (:func:`hdrfringe.strategies.available_strategies`); required.
    params : Params or mapping, optional
        Its parameters (a mapping by field name goes through
        :func:`~hdrfringe.strategies.make_params`); None: the defaults.
    centerline : Frame, optional
        Captured once, after the sets.
    description : RigDescription, optional
        What the captures carry about the rig; default :func:`describe_rig`.
    extra_frames : sequence of Frame
        Captured once, after the centerline, as they are (a replayed folder's Gray code, its
        other centerlines and uniform frames).
    method : str, optional
        Deprecated spelling of ``strategy`` (a :class:`DeprecationWarning`).

    Returns
    -------
    captures : Captures
        Each set labelled at its highest MIGL (a strategy's ``extra_sets``, e.g. an inverted
        set, follow its set), then the centerline and the
        extra frames; with the scene, camera description, ground truth and name the rig offers
        (:func:`describe_rig`).
    results : tuple of StrategyResult
        One per spec.

    References
    ----------
    Thesis Ch. 4-6 (the strategies) and Eq. 5.1 (the composite).

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=81, height=62),
    ...                    lighting=Lighting(ambient_lux=600))
    >>> caps, (res,) = composite_captures(rig, [FringeSpec("sinusoidal", 4, 8.0)], "lpa",
    ...                                   {"step": 20.0})
    >>> caps.name, len(caps.frames), res.migls[:3]
    ('white_plate', 4, [255.0, 235.0, 215.0])
    """
    strategy = renamed_keyword("composite_captures", "strategy", strategy, "method", method)
    if strategy is None:
        raise InputError("composite_captures needs a strategy: give strategy=NAME, e.g. 'lpa'")
    chosen, p = get_strategy(strategy), _strategy_params(strategy, params)
    desc = describe_rig(rig) if description is None else description
    frames: list[Frame] = []
    images = []
    results = run_strategy(chosen, rig, specs, p)
    for spec, res in zip(specs, results, strict=True):
        frames += spec.frames()
        images.append(res.images)
        for extra in res.extra_sets:
            frames += extra.spec.frames()
            images.append(extra.images)
    if centerline is not None:
        frames.append(centerline)
        images.append(rig.capture([centerline]))
    if extra_frames:
        frames += list(extra_frames)
        images.append(rig.capture(list(extra_frames)))
    dtype = np.result_type(*[i.dtype for i in images])
    stack = np.concatenate([i.astype(dtype, copy=False) for i in images])
    out = Captures(
        frames,
        stack,
        rig.camera_bit_depth,
        projector=rig.projector,
        scene=desc.scene,
        camera=desc.camera,
        maps={} if desc.truth_height_mm is None else {"truth_height_mm": desc.truth_height_mm},
        name=desc.name,
    )
    return out, tuple(results)


def strategy_absolute_phases(results: Sequence[StrategyResult]) -> dict[str, F64]:
    """The absolute phases a strategy unwrapped itself, by orientation (the finest set's).

    A strategy that measures where each camera pixel looks on the projector (the adaptive
    projection's mapping) unwraps its finest set with those fringe orders and leaves the
    result in :attr:`StrategyResult.absolute_phase
    <hdrfringe.strategies.StrategyResult>`; :func:`hdrfringe.core.decode.decode_captures` takes
    them as ``given_phases``.

    Parameters
    ----------
    results : sequence of StrategyResult
        One per set of the measurement.

    Returns
    -------
    dict
        Orientation -> absolute phase of that orientation's finest set; empty for the
        strategies that leave unwrapping to the captures (all of the thesis's).

    Examples
    --------
    >>> strategy_absolute_phases([])
    {}
    """
    out: dict[str, F64] = {}
    finest: dict[str, float] = {}
    for r in results:
        phase = r.absolute_phase
        o = r.spec.orientation
        if phase is not None and r.spec.pitch_px < finest.get(o, np.inf):
            out[o], finest[o] = np.asarray(phase, np.float64), r.spec.pitch_px
    return out


# ---------------------------------------------------------------------------------------------
# metrics and result
# ---------------------------------------------------------------------------------------------


@renamed_fields(method="name")
@dataclass(frozen=True)
class StrategySummary:
    """What a strategy captured, summed over the pitches of a measurement.

    Parameters
    ----------
    name : str
        The strategy's registry name (``method`` before issue 29: a deprecated alias; the
        ``metrics.json`` key stays ``method``).
    sets_captured, images_captured : int
        Summed over the pitches.
    index_quantity : str
        What varied between the sets (``"migl"`` or ``"exposure_ms"``,
        :attr:`StrategyResult.index_quantity <hdrfringe.strategies.StrategyResult>`).
    values : tuple
        That quantity of every set, in capture order: one tuple per pitch (coarsest first)
        when there are several, else the sets of the one pitch.
    never_unsaturated_fraction : float
        Finest pitch: pixels saturated in every set captured.

    References
    ----------
    Thesis Sec. 5.1 (the composite and its MIGL index).

    Examples
    --------
    >>> s = StrategySummary("lpa", 3, 12, "migl", (255.0, 250.0, 245.0), 0.0)
    >>> s.to_dict()["migls"]
    [255.0, 250.0, 245.0]
    """

    name: str
    sets_captured: int
    images_captured: int
    index_quantity: str
    values: tuple[Any, ...]
    never_unsaturated_fraction: float

    def to_dict(self) -> dict[str, Any]:
        """The ``metrics.json`` keys: ``method`` (the strategy's name), ``sets_captured``,
        ``images_captured``, the values as ``migls`` (or ``index_quantity`` and
        ``exposures_ms`` for an exposure strategy), ``never_unsaturated_fraction``.

        Returns
        -------
        dict

        Examples
        --------
        >>> StrategySummary("x", 1, 4, "exposure_ms", (20.0,), 0.0).to_dict()["exposures_ms"]
        [20.0]
        """
        out: dict[str, Any] = {
            "method": self.name,
            "sets_captured": self.sets_captured,
            "images_captured": self.images_captured,
        }
        if self.index_quantity == "migl":
            out["migls"] = json_safe(self.values)
        else:
            out["index_quantity"] = self.index_quantity
            out[f"{self.index_quantity.removesuffix('_ms')}s_ms"] = json_safe(self.values)
        out["never_unsaturated_fraction"] = self.never_unsaturated_fraction
        return out


def strategy_summary(results: Sequence[StrategyResult]) -> StrategySummary:
    """The :class:`StrategySummary` of one result per pitch.

    Parameters
    ----------
    results : sequence of StrategyResult
        One per pitch of the measured family, coarsest first.

    Returns
    -------
    StrategySummary

    Examples
    --------
    >>> from hdrfringe.strategies import CapturedSet
    >>> res = StrategyResult(
    ...     images=np.zeros((4, 2, 2), np.uint8), spec=FringeSpec("sinusoidal", 4, 8.0),
    ...     captured=[CapturedSet(migl=m) for m in (255.0, 240.0)],
    ...     index_map=np.full((2, 2), 240.0, np.float32), newly_unsaturated=[0, 4],
    ...     never_unsaturated=np.zeros((2, 2), bool), strategy="lpa")
    >>> s = strategy_summary([res])
    >>> s.images_captured, s.values
    (8, (255.0, 240.0))
    """
    fine = min(results, key=lambda r: r.spec.pitch_px)
    q = fine.index_quantity

    def values(r: StrategyResult) -> tuple[float | None, ...]:
        return tuple(None if getattr(s, q) is None else float(getattr(s, q)) for s in r.captured)

    return StrategySummary(
        name=fine.strategy,
        sets_captured=int(sum(r.sets_captured for r in results)),
        images_captured=int(sum(r.images_captured for r in results)),
        index_quantity=q,
        values=tuple(values(r) for r in results) if len(results) > 1 else values(fine),
        never_unsaturated_fraction=float(fine.never_unsaturated.mean()),
    )


def _strategy_blocks(cls: type) -> tuple[str, ...]:
    """The fields of ``cls`` a strategy's metrics hook may fill (``strategy_block`` metadata),
    in order."""
    return tuple(f.name for f in dataclasses.fields(cls) if f.metadata.get("strategy_block"))


@dataclass(frozen=True)
class MeasurementMetrics:
    """Every figure of a measurement (``metrics.json``, docs/measurement.md).

    Fields are None where they do not apply (no primary fringe family, no calibration, no
    truth, no strategy).

    Parameters
    ----------
    source : str
        What was measured (a folder, the live rig).
    saturated_fraction : float or None
        Pixels with a saturated shift in any set of the primary family.
    phase_valid_fraction : float or None
        Valid pixels of the finest set's phase.
    model : str or None
        Calibration model.
    border_px : int or None
        The calibration's unfiltered border, excluded from the measurement pixels (Sec. 4.1).
    valid_fraction : float or None
        Valid heights among the measurement pixels.
    saturated_fraction_measurement_pixels : float or None
        ``saturated_fraction`` over the measurement pixels.
    calibration_residual_mm : float or None
        The calibration model's own residual: median over the measurement pixels of its fit
        residual RMS at the calibration depths (filtered maps, ``Calibration.residual_rms_mm``);
        an error every measurement with this calibration carries, noise or not (issue 15).
    truth : str or None
        What the errors are against (a ``truth_height_mm`` map or ``scene.depth_mm``).
    bias_mm, std_mm, rmse_mm, max_abs_mm : float or None
        Height error over the valid measurement pixels (NaN when none is valid).
    n_pixels : int or None
        Valid measurement pixels.
    live_rig : dict or None
        A live rig's scene and every parameter.
    strategy : StrategySummary or None
        What the strategy captured.
    dpa : DPAMetrics or None
        DPA's CDFs against the actual ones (thesis Fig. 6.3; its metrics hook,
        :meth:`DPA.metrics <hdrfringe.strategies.dpa.DPA.metrics>`).
    adaptive : dict or None
        The adaptive projection's steps per adapted orientation: images, sets and seconds
        per step, the mapping's pitches and MIGLs, the erosion radius and fitted blur
        (:func:`hdrfringe.strategies.adaptive.adaptive_summary`).
    stereo : dict or None
        With a stereo calibration: points, depth range, reference plane and triangulation
        residual (:meth:`hdrfringe.core.stereo.StereoMaps.summary`).
    skipped : tuple of str
        Stages not run, and why.
    notes : tuple of str
        What the decoding and the outputs need said.
    regions : dict or None
        With spatial unwrapping of the primary family: its regions
        (:meth:`FamilyResult.regions_summary <hdrfringe.core.decode.FamilyResult.regions_summary>`:
        ``islands`` flag, ``count``, ``pixels``, ...).
    decoder : dict or None
        With the saturation-tolerant decoder (``saturated="exclude"``, the ``tolerant``
        strategy): ``name``, ``min_shifts``, ``inverted`` and ``shifts_used_histogram`` (pixels
        of the finest set whose fit used k images, k = 0, 1, ...); None with the standard one.
    uncertainty : dict or None
        The predicted phase and height std (:meth:`Uncertainty.summary
        <hdrfringe.core.uncertainty.Uncertainty.summary>`: the noise model and its source, sigma_I
        used, median predicted std), or ``{"predicted": False, "reason": ...}``; None when not
        asked for (docs/uncertainty.md).
    harmonics : dict or None
        With harmonic compensation: ``mode`` and per set its estimated coefficients, RMS
        correction and whether it was applied (:attr:`FolderPhase.harmonics
        <hdrfringe.core.decode.FolderPhase>`, docs/harmonics.md); None when off.

    References
    ----------
    Thesis Sec. 4.1 (RMSE over the measurement pixels, the 10 px border).

    Examples
    --------
    >>> m = MeasurementMetrics("part", saturated_fraction=0.0, phase_valid_fraction=1.0)
    >>> list(m.to_dict())
    ['source', 'saturated_fraction', 'phase_valid_fraction', 'skipped', 'notes']
    """

    source: str
    saturated_fraction: float | None = None
    phase_valid_fraction: float | None = None
    model: str | None = None
    border_px: int | None = None
    valid_fraction: float | None = None
    saturated_fraction_measurement_pixels: float | None = None
    calibration_residual_mm: float | None = None
    truth: str | None = None
    bias_mm: float | None = None
    std_mm: float | None = None
    rmse_mm: float | None = None
    max_abs_mm: float | None = None
    n_pixels: int | None = None
    live_rig: Mapping[str, Any] | None = None
    strategy: StrategySummary | None = None
    # the blocks a strategy's metrics hook fills (StrategyMetrics.metrics), by field name
    dpa: DPAMetrics | None = field(default=None, metadata={"strategy_block": True})
    adaptive: Mapping[str, Any] | None = field(default=None, metadata={"strategy_block": True})
    stereo: Mapping[str, Any] | None = None
    skipped: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    regions: Mapping[str, Any] | None = None
    decoder: Mapping[str, Any] | None = None
    uncertainty: Mapping[str, Any] | None = None
    harmonics: Mapping[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """``metrics.json``: the fields that apply, in a fixed order, JSON-safe.

        Non-finite floats (an RMSE over no valid pixel) become None (JSON ``null``); the
        strategy's keys are at the top level (:meth:`StrategySummary.to_dict`).

        Returns
        -------
        dict

        Examples
        --------
        >>> m = MeasurementMetrics("part", model="linear", border_px=10, valid_fraction=0.0,
        ...                        truth="scene.depth_mm = 4", rmse_mm=float("nan"))
        >>> m.to_dict()["rmse_mm"] is None
        True
        """
        d: dict[str, Any] = {"source": self.source}
        if self.saturated_fraction is not None:
            d["saturated_fraction"] = self.saturated_fraction
            d["phase_valid_fraction"] = self.phase_valid_fraction
        if self.model is not None:
            d["model"] = self.model
            d["border_px"] = self.border_px
            d["valid_fraction"] = self.valid_fraction
            if self.saturated_fraction_measurement_pixels is not None:
                d["saturated_fraction_measurement_pixels"] = (
                    self.saturated_fraction_measurement_pixels
                )
            if self.calibration_residual_mm is not None:
                d["calibration_residual_mm"] = self.calibration_residual_mm
        if self.truth is not None:
            d["truth"] = self.truth
            for key in ("bias_mm", "std_mm", "rmse_mm", "max_abs_mm", "n_pixels"):
                d[key] = getattr(self, key)
        if self.live_rig is not None:
            d["live_rig"] = self.live_rig
        if self.strategy is not None:
            d.update(self.strategy.to_dict())
        for name in _strategy_blocks(MeasurementMetrics):
            block = getattr(self, name)
            if block is not None:
                d[name] = block.to_dict() if hasattr(block, "to_dict") else dict(block)
        if self.regions is not None:
            d["regions"] = dict(self.regions)
        if self.decoder is not None:
            d["decoder"] = dict(self.decoder)
        if self.stereo is not None:
            d["stereo"] = dict(self.stereo)
        if self.uncertainty is not None:
            d["uncertainty"] = dict(self.uncertainty)
        if self.harmonics is not None:
            d["harmonics"] = dict(self.harmonics)
        d["skipped"] = list(self.skipped)
        d["notes"] = list(self.notes)
        return json_safe(d)


@dataclass(frozen=True, eq=False)
class MeasurementResult:
    """What :func:`measure` returns.

    Parameters
    ----------
    captures : Captures
        The captures measured: the input, or the strategy's composite.
    decoded : FolderPhase
        Their phases (:func:`hdrfringe.core.decode.decode_captures`).
    height_mm : ndarray (H, W) or None
        Height in mm (NaN = invalid); None without a calibration. With a stereo calibration:
        the height over the fitted reference plane (:attr:`StereoMaps.height_mm
        <hdrfringe.core.stereo.StereoMaps.height_mm>`).
    calibration : MeasurementCalibration or None
        :class:`~hdrfringe.core.calibration.Calibration` or
        :class:`~hdrfringe.core.stereo.StereoCalibration`.
    metrics : MeasurementMetrics
    strategy_results : tuple of StrategyResult
        One per pitch with a strategy, coarsest first; empty without.
    dpa : tuple of DPACDFs or None
        DPA's CDFs (thesis Fig. 6.3), one per pitch (its metrics hook); None for another
        strategy.
    stereo : StereoMaps or None
        The triangulated points, with a stereo calibration.
    uncertainty : Uncertainty or None
        The predicted phase std of each family's finest set and, with a phase-to-height
        calibration, the height std (:func:`hdrfringe.core.uncertainty.predict_uncertainty`);
        None when not asked for or not predictable (``metrics.uncertainty`` says why).

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=81, height=62))
    >>> frames = [f for p in (1024.0, 64.0) for f in FringeSpec("sinusoidal", 4, p).frames()]
    >>> res = measure(rig.capture_folder(frames))
    >>> res.height_mm is None, res.skipped, res.metrics.saturated_fraction
    (True, ('height (no --calibration given)',), 0.0)
    >>> res.uncertainty.phase_std.shape, res.metrics.uncertainty["noise"]["source"]
    ((62, 81), 'manifest camera.read_noise_dn and camera.gain_dn_per_e')
    """

    captures: Captures
    decoded: FolderPhase
    height_mm: NDArray[np.float64] | None
    calibration: MeasurementCalibration | None
    metrics: MeasurementMetrics
    strategy_results: tuple[StrategyResult, ...] = ()
    dpa: tuple[DPACDFs, ...] | None = field(default=None, metadata={"strategy_block": True})
    stereo: StereoMaps | None = None
    uncertainty: Uncertainty | None = None

    @property
    def skipped(self) -> tuple[str, ...]:
        """Stages not run, and why (``metrics.skipped``)."""
        return self.metrics.skipped

    @property
    def notes(self) -> tuple[str, ...]:
        """What the decoding and the outputs need said (``metrics.notes``)."""
        return self.metrics.notes

    @property
    def geometry(self) -> CameraGeometry | None:
        """The calibration's camera geometry (:func:`calibration_geometry`), if any."""
        return None if self.calibration is None else calibration_geometry(self.calibration)

    def points(self) -> tuple[F64, F64, F64]:
        """x, y, z maps of the height (:func:`height_points` with the calibration's geometry).

        Returns
        -------
        x, y, z : ndarray (H, W)
            In mm with a recorded camera geometry; else x and y in pixels. With a stereo
            calibration: the triangulated points in the camera frame, mm.

        Raises
        ------
        InputError
            Without a height map (no calibration).
        """
        if self.stereo is not None:
            xyz = self.stereo.xyz
            return xyz[..., 0], xyz[..., 1], xyz[..., 2]
        if self.height_mm is None:
            raise InputError("no height map to place: measure with a calibration")
        return height_points(self.height_mm, self.geometry)


# ---------------------------------------------------------------------------------------------
# measuring
# ---------------------------------------------------------------------------------------------


def _absolute_phase(captures: Captures, decoded: FolderPhase) -> tuple[F64, FringeSpec]:
    """Absolute phase of the primary family and the spec of its finest set, or a clear error."""
    fam = decoded.primary
    if fam is None:
        raise CaptureFormatError(
            f"{captures.name}: no fringe sets; add a complete phase-shifted set"
        )
    if fam.absolute_phase is None:
        raise CaptureFormatError(
            f"{captures.name}: cannot make the phase absolute: add a {fam.orientation} "
            "centerline frame or a set whose pitch spans the projector (one period)"
        )
    return fam.absolute_phase, fam.sets[-1].spec


#: ``stereo_directions`` of :func:`measure`: the projector coordinates triangulation may use.
_STEREO_DIRECTIONS = ("auto", "u", "v")


def _projector_coordinates(
    caps: Captures, decoded: FolderPhase, directions: str = "auto"
) -> tuple[dict[str, F64], F64 | None]:
    """Projector coordinates of the first family of each orientation with an absolute phase
    (only ``u`` or only ``v`` when ``directions`` says so) and the quality: the data
    modulation of the first family used's finest set."""
    coords: dict[str, F64] = {}
    quality = None
    for fam in decoded.families:
        key = "u" if fam.orientation == "vertical" else "v"
        if key in coords or fam.absolute_phase is None or directions not in ("auto", key):
            continue
        coords[key] = projector_coordinate(fam.absolute_phase, fam.pitch_px)
        if quality is None:
            quality = decoded.set_results[fam.sets[-1].label].modulation
    if not coords:
        which = {"auto": "no", "u": "no vertical", "v": "no horizontal"}[directions]
        raise CaptureFormatError(
            f"{caps.name}: cannot triangulate: {which} fringe family has an absolute phase; add "
            "a set whose pitch spans the projector (one period), a Gray code or a centerline "
            "frame"
        )
    return coords, quality


def _triangulate(
    caps: Captures, decoded: FolderPhase, calibration: StereoCalibration, directions: str = "auto"
) -> StereoMaps:
    """The projector coordinates (:func:`_projector_coordinates`) triangulated, with their
    quality."""
    coords, quality = _projector_coordinates(caps, decoded, directions)
    maps = triangulate_maps(calibration, u_proj=coords.get("u"), v_proj=coords.get("v"))
    return dataclasses.replace(maps, quality=quality)


def _geometric_orders(
    caps: Captures,
    decoded: FolderPhase,
    calibration: StereoCalibration,
    depth_range_mm: tuple[float, float] | None,
    directions: str,
) -> tuple[FolderPhase, dict[str, Any]]:
    """The families triangulation will use that lack an absolute phase, ordered from the
    calibration and the depth range
    (:func:`~hdrfringe.core.geometric_order.family_geometric_order`);
    the ``stereo.fringe_order`` block of the metrics (empty without a depth range). Without a
    depth range and without any absolute phase: a one-line error naming the option."""
    keys = {id(f): "u" if f.orientation == "vertical" else "v" for f in decoded.families}
    used = [f for f in decoded.families if directions in ("auto", keys[id(f)])]
    if depth_range_mm is None:
        if used and all(f.absolute_phase is None for f in used):
            which = {"auto": "no", "u": "no vertical", "v": "no horizontal"}[directions]
            raise CaptureFormatError(
                f"{caps.name}: cannot triangulate: {which} fringe family has an absolute phase "
                "and no depth range was given; give the measuring volume's depths along the "
                "camera axis (measure --depth-range ZMIN:ZMAX, mm: the fringe order from the "
                "stereo calibration, docs/stereo.md), or add a set whose pitch spans the "
                "projector, a Gray code or a centerline frame"
            )
        return decoded, {}
    families, notes, block = [], list(decoded.notes), {}
    for fam in decoded.families:  # one family per orientation (group_families)
        key = keys[id(fam)]
        if not any(fam is f for f in used) or fam.absolute_phase is not None:
            families.append(fam)
            if any(fam is f for f in used):
                block[key] = {"method": fam.absolute_method}
            continue
        fam, order = family_geometric_order(decoded, fam, calibration, depth_range_mm)
        families.append(fam)
        # the family has its absolute phase now: the decoder's note that it has none goes
        notes = [n for n in notes if n != no_absolute_phase_note(fam.orientation)]
        block[key] = info = order.summary()
        notes.append(
            f"{fam.orientation} fringes: absolute phase from the stereo calibration and the depth "
            f"range {depth_range_mm[0]:g}..{depth_range_mm[1]:g} mm: "
            f"{100 * info['ambiguous_fraction']:.1f} % of the decoded pixels ambiguous (invalid), "
            f"{100 * info['no_candidate_fraction']:.1f} % without an order in the range"
        )
    return dataclasses.replace(decoded, families=families, notes=notes), block


def _triangulate_auto(
    caps: Captures,
    decoded: FolderPhase,
    calibration: StereoCalibration,
    noise: NoiseModel | float | None,
) -> tuple[StereoMaps, DirectionCheck | None]:
    """``stereo_directions="auto"``: with both projector coordinates, the ones that agree
    (:func:`hdrfringe.core.stereo.check_directions`) with the phase noise predicted
    (docs/uncertainty.md), else measured from the maps' roughness; the check (None with one
    coordinate)."""
    found, _ = _projector_coordinates(caps, decoded)
    if len(found) < 2:
        return _triangulate(caps, decoded, calibration, "auto"), None
    # the check looks at a subsample: the whole image is triangulated once, afterwards
    coords: dict[str, tuple[F64, str]] = {
        k: (c, "vertical" if k == "u" else "horizontal") for k, c in found.items()
    }
    sigma: dict[str, F64 | float]
    try:
        given = noise if isinstance(noise, NoiseModel) or noise is None else NoiseModel(noise)
        unc = predict_uncertainty(caps, decoded, noise=given, finest_only=True)
    except NoiseUnknownError as exc:
        sigma = {k: coordinate_noise_px(c) for k, (c, _) in coords.items()}
        source = f"measured from the maps' pixel-to-pixel roughness ({exc})"
    else:
        pitch = {fam.orientation: fam.pitch_px for fam in decoded.families}
        sigma = {
            k: unc.family_phase_std[o] * (pitch[o] / (2 * np.pi)) for k, (_, o) in coords.items()
        }
        source = f"predicted (docs/uncertainty.md), noise {unc.noise.source}"
    check = check_directions(
        calibration, coords["u"][0], coords["v"][0], sigma["u"], sigma["v"], sigma_source=source
    )
    kept = "auto" if check.directions == ("u", "v") else check.directions[0]
    del found, coords  # the triangulation makes the ones it keeps again
    return _triangulate(caps, decoded, calibration, kept), check


def _measure_captures(
    caps: Captures,
    calibration: MeasurementCalibration | None,
    reject_saturated: bool,
    calibration_source: str | None,
    stereo_directions: str = "auto",
    min_shifts: int | None = None,
    given_phases: Mapping[str, F64] | None = None,
    depth_range_mm: tuple[float, float] | None = None,
    harmonics: str | int = "off",
    noise: NoiseModel | float | None = None,
) -> tuple[FolderPhase, F64 | None, dict[str, Any], StereoMaps | None]:
    """Decode (``min_shifts`` given: saturation-tolerant, ``saturated="exclude"``); with a
    calibration, what it makes of the phase (:data:`_OUTPUTS`: height and its errors, or the
    triangulated points). Returns the metrics fields."""
    decoded = _decode_for_measurement(caps, reject_saturated, min_shifts, given_phases, harmonics)
    fam = decoded.primary
    fields: dict[str, Any] = {}
    if decoded.harmonics is not None:
        fields["harmonics"] = decoded.harmonics
    if min_shifts is not None:
        fields["decoder"] = _decoder_summary(decoded, min_shifts)
    sat = np.zeros(caps.image_shape, bool)
    if fam is not None:
        for s in fam.sets:
            sat |= decoded.set_results[s.label].saturation_count > 0
        fields["saturated_fraction"] = float(sat.mean())
        fields["phase_valid_fraction"] = float(decoded.set_results[fam.sets[-1].label].valid.mean())
        fields["regions"] = fam.regions_summary()
    if calibration is None:
        return decoded, None, fields, None
    stage = _OUTPUTS.get(calibration.output)
    if stage is None:
        raise InputError(
            f"calibration output {calibration.output!r} is unknown; a calibration makes "
            f"{' or '.join(_OUTPUTS)} of the phase"
        )
    options = _StageOptions(calibration_source, stereo_directions, depth_range_mm, noise)
    return stage(caps, decoded, calibration, sat, fields, options)


@dataclass(frozen=True)
class _StageOptions:
    """The options of :func:`measure` the reconstruction stages read."""

    calibration_source: str | None
    stereo_directions: str
    depth_range_mm: tuple[float, float] | None
    noise: NoiseModel | float | None


def _points_stage(
    caps: Captures,
    decoded: FolderPhase,
    calibration: StereoCalibration,
    sat: NDArray[np.bool_],
    fields: dict[str, Any],
    options: _StageOptions,
) -> tuple[FolderPhase, F64 | None, dict[str, Any], StereoMaps | None]:
    """Triangulated points (docs/stereo.md): the fringe orders from the depth range where the
    phase has none, the directions checked, the ``stereo`` block."""
    info = caps.projector
    projector = None if info is None else (int(info.width), int(info.height))
    finest = None if decoded.primary is None else decoded.primary.sets[-1].spec
    calibration.check_fits(
        finest,
        caps.image_shape,
        caps.camera_bit_depth,
        source=options.calibration_source,
        projector_size=projector,
    )
    directions = options.stereo_directions
    decoded, orders = _geometric_orders(
        caps, decoded, calibration, options.depth_range_mm, directions
    )
    check = None
    if directions == "auto":
        maps, check = _triangulate_auto(caps, decoded, calibration, options.noise)
    else:
        maps = _triangulate(caps, decoded, calibration, directions)
    fields["model"] = "stereo"
    fields["border_px"] = 0
    fields["valid_fraction"] = float(maps.valid.mean())
    fields["saturated_fraction_measurement_pixels"] = float(np.mean(sat))
    fields["stereo"] = maps.summary()
    if orders:
        fields["stereo"]["fringe_order"] = orders
    if check is not None:
        fields["stereo"]["direction_check"] = check.to_dict()
    return decoded, maps.height_mm, fields, maps


def _heights_stage(
    caps: Captures,
    decoded: FolderPhase,
    calibration: Calibration,
    sat: NDArray[np.bool_],
    fields: dict[str, Any],
    options: _StageOptions,
) -> tuple[FolderPhase, F64 | None, dict[str, Any], StereoMaps | None]:
    """The height map (Eq. 2.10-2.11) over the measurement pixels and its errors against the
    truth the captures know."""
    phi, spec = _absolute_phase(caps, decoded)
    calibration.check_fits(
        spec, caps.image_shape, caps.camera_bit_depth, source=options.calibration_source
    )
    height = calibration.height(phi)
    inside = calibration.measurement_mask()
    fields["model"] = calibration.model
    fields["border_px"] = calibration.border_px
    fields["valid_fraction"] = float(np.isfinite(height)[inside].mean())
    fields["saturated_fraction_measurement_pixels"] = float(np.mean(sat[inside]))
    fit = calibration.residual_summary().get(calibration.model)
    if fit is not None and fit.pixels:
        fields["calibration_residual_mm"] = fit.median_mm
    truth = caps.map("truth_height_mm")
    errors: dict[str, Any] = {}
    if truth is not None:
        fields["truth"] = "truth_height_mm map"
        errors = height_errors(height, truth, inside)
    elif "depth_mm" in caps.scene:
        fields["truth"] = f"scene.depth_mm = {float(caps.scene['depth_mm']):g}"
        errors = height_errors(height, float(caps.scene["depth_mm"]), inside)
    # valid_fraction is the height's (docs/measurement.md); the errors' own counts the pixels
    # where the truth is finite too and must not replace it (n_pixels reports that).
    errors.pop("valid_fraction", None)
    fields.update(errors)
    return decoded, height, fields, None


#: What a calibration makes of the phase (:attr:`MeasurementCalibration.output
#: <hdrfringe.core.calibration.MeasurementCalibration>`) -> the stage that does it.
_OUTPUTS: dict[str, Callable[..., tuple[FolderPhase, F64 | None, dict[str, Any], Any]]] = {
    "heights": _heights_stage,
    "points": _points_stage,
}


def _decode_for_measurement(
    caps: Captures,
    reject_saturated: bool,
    min_shifts: int | None,
    given_phases: Mapping[str, F64] | None,
    harmonics: str | int,
) -> FolderPhase:
    """:func:`decode_captures` as a measurement asks for it: saturation-tolerant with
    ``min_shifts``; ``harmonics`` only when not ``off`` (the decode is otherwise the same call
    as before harmonic compensation existed)."""
    extra: dict[str, Any] = {} if harmonics == "off" else {"harmonics": harmonics}
    if min_shifts is None:
        return decode_captures(
            caps, reject_saturated=reject_saturated, given_phases=given_phases, **extra
        )
    return decode_captures(
        caps, saturated="exclude", min_shifts=min_shifts, given_phases=given_phases, **extra
    )


def _decoder_summary(decoded: FolderPhase, min_shifts: int) -> dict[str, Any]:
    """``metrics.decoder`` of a saturation-tolerant measurement (its finest set's histogram)."""
    fam = decoded.primary
    out: dict[str, Any] = {
        "name": DECODER_NAME,
        "min_shifts": min_shifts,
        "inverted": bool(decoded.inverted_sets),
    }
    if fam is not None:
        res = decoded.set_results[fam.sets[-1].label]
        used = getattr(res, "shifts_used", None)
        if used is not None:
            out["shifts_used_histogram"] = np.bincount(used.ravel()).tolist()
    return out


def _replay(
    captures: Captures,
    calibration: MeasurementCalibration | None,
    strategy: str,
    params: Any,
    specs: Sequence[FringeSpec] | None,
    centerline: Frame | None,
    calibration_source: str | None,
    settings: CameraSettings | None = None,
    depth_range_mm: tuple[float, float] | None = None,
) -> tuple[Captures, tuple[StrategyResult, ...]]:
    """A strategy on a :class:`ReplayRig` over a MIGL sweep: every family's pitches at the top
    MIGL (or ``specs``), then the folder's other frames (:func:`_replay_frames`)."""
    if specs is None:  # (a recorded live run names its sets: its shots may form none)
        if not captures.sets:
            raise CaptureFormatError(f"{captures.name}: no fringe sets to run a strategy on")
        specs = [s.spec for fam in group_families(captures.sets) for s in fam]
    extra = _replay_frames(captures, {s.orientation for s in specs}, centerline is None)
    if calibration is not None:  # refused before the strategy runs
        finest = min(specs, key=lambda s: s.pitch_px)
        calibration.check_fits(
            finest, captures.image_shape, captures.camera_bit_depth, source=calibration_source
        )
    rig = ReplayRig(captures)
    if settings is not None:  # the live rig's own settings, which its strategy started from
        rig.camera_settings = settings
    # the calibration's projector-camera geometry, as a live run offers it (an adaptive
    # epipolar run recorded with --calibration replays with it)
    geometry = None if calibration is None else calibration.projector_geometry()
    context = RunContext(
        available_migls=rig.available_migls(),
        projector_geometry=geometry,
        depth_range_mm=depth_range_mm,
    )
    params = prepare_params(get_strategy(strategy), params, context)
    return composite_captures(
        rig, specs, strategy, params, centerline=centerline, extra_frames=extra
    )


def _replay_frames(captures: Captures, orientations: set[str], centerlines: bool) -> list[Frame]:
    """The frames a replay takes from the folder as they are, besides the strategy's sets:
    every Gray code frame and uniform frame, and (``centerlines``) the first centerline of
    each replayed orientation."""
    keep = {
        i for i, f in enumerate(captures.frames) if isinstance(f, GrayCodeFrame | UniformFrame)
    }  # the Gray code's patterns and inverses, white and black
    if centerlines:
        seen: set[str] = set()
        for i, f in enumerate(captures.frames):
            if isinstance(f, CenterlineFrame) and f.orientation in orientations - seen:
                seen.add(f.orientation)
                keep.add(i)
    return [captures.frames[i] for i in sorted(keep)]


def measure(
    source: Captures | Rig,
    calibration: MeasurementCalibration | None = None,
    *,
    strategy: str | None = None,
    params: Any = None,
    specs: Sequence[FringeSpec] | None = None,
    centerline: Frame | None = None,
    reject_saturated: bool = True,
    label: str | None = None,
    calibration_source: str | None = None,
    param_sources: Mapping[str, str] | None = None,
    stereo_directions: str = "auto",
    uncertainty: bool = True,
    noise: NoiseModel | float | None = None,
    depth_range_mm: tuple[float, float] | None = None,
    harmonics: str | int = "off",
    saturated: str = "flag",
    min_shifts: int = 3,
    method: str | None = None,
    replay_settings: CameraSettings | None = None,
) -> MeasurementResult:
    """Measure captures, a MIGL sweep replayed by a strategy, or a live rig.

    * Captures without ``strategy``: decoded and measured as they are.
    * Captures with ``strategy``: a MIGL sweep; the strategy runs on a
      :class:`~hdrfringe.rig.replay.ReplayRig` over it for every pitch of its primary family
      (or ``specs``) at its highest MIGL, with its first centerline of that orientation (or
      ``centerline``), and the composite is measured.
    * A rig: the strategy (default ``conventional``) runs live for every set in ``specs``, then
      ``centerline`` is captured once; the scene, camera description and ground truth come
      from the rig when it offers them (:func:`describe_rig`).

    A calibration that does not fit (fringes, image size, bit depth) is refused before anything
    is captured or replayed. Saturated pixels are invalid unless ``reject_saturated`` is False.

    Parameters
    ----------
    source : Captures or Rig
        What to measure.
    calibration : MeasurementCalibration, optional
        Without it the phase is decoded and the height skipped. A
        :class:`~hdrfringe.core.calibration.Calibration` gives heights; a
        :class:`~hdrfringe.core.stereo.StereoCalibration` triangulates every valid pixel from the
        absolute phase of the vertical and/or horizontal fringes
        (:func:`hdrfringe.core.stereo.triangulate_maps`, docs/stereo.md) and offers the strategy
        its projector-camera geometry (the adaptive projection's epipolar mapping).
    strategy : str, optional
        A registered strategy (:func:`hdrfringe.strategies.available_strategies`).
    params : Params or mapping, optional
        The strategy's parameters (:func:`hdrfringe.strategies.make_params` fields).
    specs : sequence of FringeSpec, optional
        The sets a strategy captures (required for a rig), coarsest first.
    centerline : Frame, optional
        Centerline frame for the absolute phase (Eq. 2.12-2.13).
    reject_saturated : bool
        Invalidate pixels with a saturated shift (the thesis, Ch. 4, kept them).
    label : str, optional
        How the metrics name the source; default the captures' name (the scene's for a rig).
    calibration_source : str, optional
        Where the calibration came from, for a mismatch message.
    param_sources : mapping, optional
        Where parameters read from files came from, by field name (the strategy's metrics
        hook records them, e.g. DPA's ``correction``).
    stereo_directions : {"auto", "u", "v"}
        With a stereo calibration: ``"auto"`` triangulates with every orientation that has an
        absolute phase (ray against ray when both do), unless the two disagree far beyond the
        phase noise (:func:`hdrfringe.core.stereo.check_directions`): then with the one that
        explains the disagreement, or with both and the calibration named as suspect
        (``metrics.stereo.direction_check``); ``"u"`` (vertical fringes) or ``"v"``
        (horizontal fringes) uses that projector coordinate alone, against the projector's
        column or row surface: the direction that carries the depth when the other one's
        convention is unknown (docs/stereo.md, kimthyung). Ignored without a stereo
        calibration.
    uncertainty : bool
        Predict the per-pixel phase std and, with a phase-to-height calibration, the height
        std (:func:`hdrfringe.core.uncertainty.predict_uncertainty`; docs/uncertainty.md).
    noise : NoiseModel or float, optional
        The camera noise for the prediction (a float: one sigma in DN). Default: the capture
        manifest's, else estimated from the sets with 4 or more shifts; when neither exists
        nothing is predicted and ``metrics.uncertainty`` says why.
    depth_range_mm : tuple of float, optional
        With a stereo calibration: ``(zmin, zmax)``, the scene's depths along the camera axis
        (mm). Every family triangulation uses that has no absolute phase (no set spanning the
        projector, no Gray code, no centerline) takes its fringe order from the calibration
        and this range (:func:`hdrfringe.core.geometric_order.family_geometric_order`; pixels where
        the range admits no order or several are invalid); ``metrics.stereo.fringe_order``
        records how each direction was ordered. A single pitch then suffices.
    harmonics : {"off", "auto"} or int
        Fringe-harmonic compensation of the decoded phases
        (:func:`hdrfringe.core.decode.decode_captures`, docs/harmonics.md); ``metrics.harmonics``
        records the estimates. Not with a saturation-tolerant strategy.
    saturated : {"flag", "exclude"}
        As ``phase --saturated``: ``"flag"`` marks a pixel with a saturated shift (invalid
        when ``reject_saturated``); ``"exclude"`` fits its phase from the unsaturated shifts,
        at least ``min_shifts`` of them (the saturation-tolerant decoder; a ``tolerant``
        strategy asks for it by itself).
    min_shifts : int
        With ``saturated="exclude"``: the least unsaturated shifts per pixel.
    method : str, optional
        Deprecated spelling of ``strategy`` (a :class:`DeprecationWarning`).
    replay_settings : CameraSettings, optional
        A replay's rig settings (None: none known): the live rig's default exposure and gain
        when the captures record a live run (a strategy may plan relative to them, e.g.
        adaptive ``max_images``'s exposure).

    Returns
    -------
    MeasurementResult

    Raises
    ------
    InputError
        Strategy options without a strategy, a rig without ``specs``, an unknown strategy or
        parameter, a source that is neither captures nor a rig.
    CalibrationMismatchError
        A calibration that does not fit the measurement.
    CaptureFormatError
        Captures without fringe sets, or whose phase cannot be made absolute for a height.

    References
    ----------
    Thesis Sec. 2.4-2.5 (height), 4.1 (measurement pixels), Ch. 4-6 (the strategies).

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=81, height=62),
    ...                    lighting=Lighting(ambient_lux=600))
    >>> res = measure(rig, strategy="lpa", params={"step": 20.0},
    ...               specs=[FringeSpec("sinusoidal", 4, 8.0)])
    >>> res.metrics.strategy.name, res.metrics.strategy.values[:2]
    ('lpa', (255.0, 235.0))
    """
    depth_range_mm = _check_measure_options(
        calibration, stereo_directions, depth_range_mm, harmonics, saturated, reject_saturated
    )
    strategy = renamed_keyword("measure", "strategy", strategy, "method", method)
    sources = dict(param_sources or {})
    if isinstance(source, Rig) and strategy is None:
        strategy = DEFAULT_STRATEGY
    caps, results, p, replay, description = _acquire(
        source, calibration, strategy, params, specs, centerline, calibration_source, sources,
        replay_settings, depth_range_mm,
    )  # fmt: skip
    decoded, height, fields, stereo = _measure_captures(
        caps,
        calibration,
        reject_saturated,
        calibration_source,
        stereo_directions,
        min_shifts=_decoder_min_shifts(results, saturated, min_shifts),
        given_phases=strategy_absolute_phases(results),
        depth_range_mm=depth_range_mm,
        harmonics=harmonics,
        noise=noise,
    )
    extra: Mapping[str, Any] = {}
    if strategy is not None:
        hooked = strategy_metrics(
            get_strategy(strategy), results, MetricsContext(p, replay, sources)
        )
        fields.update(_checked_blocks(strategy, hooked.metrics, MeasurementMetrics))
        extra = _checked_blocks(strategy, hooked.result, MeasurementResult)
    unc = None
    if uncertainty:
        unc, fields["uncertainty"] = _predict_uncertainty(caps, decoded, calibration, noise)
    notes = list(decoded.notes)
    if calibration is not None:
        notes += calibration.notes()
    metrics = MeasurementMetrics(
        source=caps.name if label is None else label,
        live_rig=None if description is None else description.parameters,
        strategy=strategy_summary(results) if results else None,
        skipped=(NO_CALIBRATION,) if calibration is None else (),
        notes=tuple(notes),
        **fields,
    )
    return MeasurementResult(
        caps,
        decoded,
        height,
        calibration,
        metrics,
        results,
        stereo=stereo,
        uncertainty=unc,
        **extra,
    )


def _check_measure_options(
    calibration: MeasurementCalibration | None,
    stereo_directions: str,
    depth_range_mm: tuple[float, float] | None,
    harmonics: str | int,
    saturated: str,
    reject_saturated: bool,
) -> tuple[float, float] | None:
    """:func:`measure`'s options refused before anything is captured; the depth range checked."""
    if calibration is not None and not isinstance(calibration, MeasurementCalibration):
        hint = (
            f"; load the file first: calibration=hdrfringe.load_any_calibration({calibration!r})"
            if isinstance(calibration, str | PathLike)
            else ""
        )
        raise InputError(
            "calibration must be a Calibration or StereoCalibration (or None), got "
            f"{type(calibration).__name__} {calibration!r}{hint}"
        )
    _check_saturated(saturated, reject_saturated)
    if stereo_directions not in _STEREO_DIRECTIONS:
        raise InputError(
            f"stereo_directions {stereo_directions!r} is unknown; give one of "
            f"{', '.join(_STEREO_DIRECTIONS)}"
        )
    if depth_range_mm is not None:
        depth_range_mm = check_depth_range(depth_range_mm)
        if calibration is None or calibration.output != "points":
            raise InputError(
                "a depth range fixes the fringe order with a stereo calibration; give one "
                "(measure -c STEREO.h5) or drop the depth range (--depth-range)"
            )
    harmonics_mode(harmonics)  # a bad value is refused before anything is captured
    return depth_range_mm


def _run_live(
    rig: Rig,
    calibration: MeasurementCalibration | None,
    strategy: str,
    params: Any,
    specs: Sequence[FringeSpec] | None,
    centerline: Frame | None,
    calibration_source: str | None,
    depth_range_mm: tuple[float, float] | None = None,
) -> tuple[Captures, tuple[StrategyResult, ...], Any, RigDescription]:
    """The strategy run live on ``rig``: the composite captures, the strategy's results, its
    parameters (prepared with what the measurement offers) and the rig's description."""
    p = _strategy_params(strategy, params)
    if not specs:
        raise InputError(
            "measuring on a rig needs specs: the fringe sets to capture (e.g. one per pitch)"
        )
    if calibration is not None:  # refused before anything is captured
        finest = min(specs, key=lambda s: s.pitch_px)
        calibration.check_fits(
            finest, rig.image_shape, rig.camera_bit_depth, source=calibration_source
        )
    # what the measurement offers the strategy: the projector-camera geometry of its
    # calibration (the adaptive projection's epipolar mapping takes the projector row
    # from it when given none, docs/adaptive.md)
    geometry = None if calibration is None else calibration.projector_geometry()
    context = RunContext(projector_geometry=geometry, depth_range_mm=depth_range_mm)
    p = prepare_params(get_strategy(strategy), p, context)
    description = describe_rig(rig)
    caps, results = composite_captures(
        rig, specs, strategy, p, centerline=centerline, description=description
    )
    return caps, results, p, description


def _acquire(
    source: Captures | Rig,
    calibration: MeasurementCalibration | None,
    strategy: str | None,
    params: Any,
    specs: Sequence[FringeSpec] | None,
    centerline: Frame | None,
    calibration_source: str | None,
    sources: Mapping[str, str],
    replay_settings: CameraSettings | None = None,
    depth_range_mm: tuple[float, float] | None = None,
) -> tuple[Captures, tuple[StrategyResult, ...], Any, Captures | None, RigDescription | None]:
    """What :func:`measure` measures: the captures (as given, replayed by the strategy, or
    captured live), the strategy's results and parameters, the replayed sweep and the rig's
    description (None where there is none)."""
    if isinstance(source, Captures):
        if strategy is None:
            given = [
                n
                for n, v in (("params", params), ("specs", specs), ("centerline", centerline))
                if v is not None
            ]
            if given or sources:
                raise InputError(
                    f"{', '.join(given or ['param_sources'])} given without a strategy; give "
                    "strategy= to replay the captures with a strategy, or drop them"
                )
            return source, (), None, None, None
        p = _strategy_params(strategy, params)
        caps, results = _replay(
            source, calibration, strategy, p, specs, centerline, calibration_source,
            replay_settings, depth_range_mm,
        )  # fmt: skip
        return caps, results, p, source, None
    if isinstance(source, Rig):
        strategy = DEFAULT_STRATEGY if strategy is None else strategy
        caps, results, p, description = _run_live(
            source, calibration, strategy, params, specs, centerline, calibration_source,
            depth_range_mm,
        )  # fmt: skip
        return caps, results, p, None, description
    raise InputError(
        f"measure takes Captures or a Rig, got {type(source).__name__}; read a capture "
        "folder with hdrfringe.io.captures.read_capture_folder"
    )


def _checked_blocks(strategy: str, blocks: Mapping[str, Any], cls: type) -> dict[str, Any]:
    """A strategy's metrics-hook blocks, refused unless each is a strategy block of ``cls``."""
    allowed = _strategy_blocks(cls)
    for name in blocks:
        if name not in allowed:
            raise InputError(
                f"strategy {strategy!r}: its metrics hook gives {name!r}, not a block of "
                f"{cls.__name__} ({', '.join(allowed)})"
            )
    return dict(blocks)


def _check_saturated(saturated: str, reject_saturated: bool) -> None:
    """``measure``'s saturation arguments, refused as ``phase`` refuses its options."""
    from hdrfringe.core._validation import SATURATED_MODES

    if saturated not in SATURATED_MODES:
        raise InputError(
            f"saturated {saturated!r} is unknown; give one of {', '.join(SATURATED_MODES)}"
        )
    if saturated == "exclude" and not reject_saturated:
        raise InputError(
            "reject_saturated=False keeps the biased phase of saturated pixels, "
            'saturated="exclude" leaves their saturated shifts out; give one of them'
        )


def _decoder_min_shifts(
    results: Sequence[StrategyResult], saturated: str, min_shifts: int
) -> int | None:
    """The least unsaturated shifts of the saturation-tolerant decoder, or None (flagging):
    ``saturated="exclude"``'s, else what a strategy that leaves saturation to the decoder
    asks for (:attr:`StrategyResult.decoder <hdrfringe.strategies.StrategyResult>`)."""
    if saturated == "exclude":
        return int(min_shifts)
    asked = [r.decoder.min_shifts for r in results if r.decoder is not None]
    return min(asked) if asked else None


def _predict_uncertainty(
    caps: Captures,
    decoded: FolderPhase,
    calibration: MeasurementCalibration | None,
    noise: NoiseModel | float | None,
) -> tuple[Uncertainty | None, dict[str, Any]]:
    """The uncertainty of a measurement and its ``metrics.json`` block; when no noise is given
    and none can be estimated (every set has 3 shifts), None and the reason."""
    cal = None if calibration is None else calibration.height_model()
    if noise is not None:  # a given noise is checked, never excused
        noise = noise if isinstance(noise, NoiseModel) else NoiseModel(noise, source="given")
    try:
        unc = predict_uncertainty(caps, decoded, noise=noise, calibration=cal, finest_only=True)
    except NoiseUnknownError as exc:
        return None, {"predicted": False, "reason": str(exc)}
    summary = unc.summary()
    if calibration is not None:
        summary["notes"] += calibration.uncertainty_notes()
    return unc, summary


# ---------------------------------------------------------------------------------------------
# calibrating
# ---------------------------------------------------------------------------------------------


def calibrate(
    captures: Sequence[Captures],
    *,
    model: str = "linear",
    window_px: int = 21,
    border_px: int = 10,
    progress: Callable[[], object] | None = None,
) -> Calibration:
    """Calibrate from flat-plate captures at known depths (thesis Sec. 2.5, 4.1).

    Every captures must give ``scene.depth_mm``; exactly one is at 0 (the reference plane);
    depths must be distinct; all must share the fringes, image size and camera bit depth.
    Everything is checked before any fitting. Each is decoded to the absolute phase of its
    primary family (a centerline or a one-period set, docs/phase.md).

    Parameters
    ----------
    captures : sequence of Captures
        The reference plane and at least 2 plate positions.
    model : {"linear", "rational", "poly2", "poly3"}
        The phase-to-height model (:func:`hdrfringe.core.calibration.calibrate`).
    window_px, border_px : int
        Median and mean filter window and the unfiltered border (Sec. 4.1: 21 and 10).
    progress : callable, optional
        Called once per captures decoded.

    Returns
    -------
    Calibration
        Its provenance records the package version, the date, each input's ``name`` (resolved
        as a path), depth and :meth:`Captures.content_hash
        <hdrfringe.core.captures.Captures.content_hash>`, and the reference plane's camera geometry.

    Raises
    ------
    InputError
        Too few positions, no or several reference planes, duplicate depths, mismatched image
        sizes, bit depths or fringes.
    CaptureFormatError
        No ``scene.depth_mm``, or a phase that cannot be made absolute.

    References
    ----------
    Thesis Sec. 2.5 (Eq. 2.10, 2.15) and Sec. 4.1 (filtering, the border).

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> frames = [f for p in (1024.0, 64.0) for f in FringeSpec("sinusoidal", 4, p).frames()]
    >>> camera = CameraModel(width=81, height=62)  # small: fast (the default is 648 x 494)
    >>> plates = [SimulatedRig(white_plate(d), camera=camera).capture_folder(frames)
    ...           for d in (0.0, 10.0, 20.0)]
    >>> cal = calibrate(plates)
    >>> cal.model, cal.depths_mm.tolist(), cal.spec.pitch_px
    ('linear', [10.0, 20.0], 64.0)
    """
    folders = list(captures)
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
    phases: dict[int, F64] = {}
    spec0: FringeSpec | None = None
    for f in folders:
        phi, spec = _absolute_phase(f, decode_captures(f))
        if spec0 is None:
            spec0 = spec
        elif not same_fringes(spec, spec0):
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
    from hdrfringe import __version__  # the installed version, looked up when recorded

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
    return fit_calibration(
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


# ---------------------------------------------------------------------------------------------
# the uniform trade-off search (thesis Sec. 4.2)
# ---------------------------------------------------------------------------------------------


def _nan_if_none(x: float | None) -> float:
    return float("nan") if x is None else float(x)


def tradeoff_search(
    rig: Rig,
    spec: FringeSpec,
    calibration: Calibration,
    migls: Sequence[float] | range,
    *,
    extra_frames: Sequence[Frame] | None = None,
) -> dict[str, Any]:
    """The thesis's uniform trade-off search (Sec. 4.2): sweep the MIGL on a known target.

    For every MIGL a set is captured (with ``extra_frames``, e.g. the centerline, captured once)
    and measured with the calibration, *keeping* saturated pixels as the thesis did, so that
    saturation error counts; the RMSE against the target's truth (a ``truth_height_mm`` map or
    ``scene.depth_mm`` the rig describes, :func:`describe_rig`) is recorded and the MIGL of the
    lowest RMSE (the highest among equals) is the trade-off point.

    Parameters
    ----------
    rig : Rig
        A rig that knows its target (e.g. the virtual rig).
    spec : FringeSpec
        The set; its MIGL is replaced by each of ``migls``.
    calibration : Calibration
    migls : sequence of float
        MIGLs to try.
    extra_frames : sequence of Frame, optional
        Captured once and added to every set (e.g. a centerline).

    Returns
    -------
    dict
        ``rmse_mm`` {migl: RMSE}, ``bias_mm`` {migl: mean error}, ``std_mm`` {migl: error
        standard deviation}, ``saturated_fraction`` {migl: fraction}, ``best_migl`` (lowest
        RMSE). Compare methods by ``std_mm``: with the linear model the RMSE is mostly the
        model's bias, the same at every MIGL (issue 15).

    References
    ----------
    Thesis Sec. 4.2 and Fig. 4.13 (RMSE against the MIGL).

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> camera = CameraModel(width=81, height=62)
    >>> spec = FringeSpec("sinusoidal", 4, 1024.0)  # one period: absolute without a centerline
    >>> cal = calibrate([SimulatedRig(white_plate(d), camera=camera).capture_folder(spec.frames())
    ...                  for d in (0.0, 10.0, 20.0)])
    >>> found = tradeoff_search(SimulatedRig(white_plate(5.0), camera=camera), spec, cal,
    ...                         [255, 200])
    >>> sorted(found["rmse_mm"]), found["best_migl"]
    ([200.0, 255.0], 255.0)
    """
    extra = list(extra_frames or [])
    extra_imgs = rig.capture(extra) if extra else None
    desc = describe_rig(rig)
    truth = desc.truth_height_mm
    rmse: dict[float, float] = {}
    bias: dict[float, float] = {}
    std: dict[float, float] = {}
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
            scene=desc.scene,
            maps={} if truth is None else {"truth_height_mm": truth},
        )
        res = measure(folder, calibration, reject_saturated=False)
        rmse[float(m)] = _nan_if_none(res.metrics.rmse_mm)
        bias[float(m)] = _nan_if_none(res.metrics.bias_mm)
        std[float(m)] = _nan_if_none(res.metrics.std_mm)
        sat[float(m)] = _nan_if_none(res.metrics.saturated_fraction)
    best = min(rmse, key=lambda k: (np.nan_to_num(rmse[k], nan=np.inf), -k))
    return {
        "rmse_mm": rmse,
        "bias_mm": bias,
        "std_mm": std,
        "saturated_fraction": sat,
        "best_migl": best,
    }
