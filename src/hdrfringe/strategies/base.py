"""The strategy plug-in interface: the protocol, typed parameters, the registry, the result.

A saturation-avoidance strategy decides which fringe sets to capture on a rig and builds the
composite the phase stage decodes (thesis Ch. 4-6). Each one is an object with

* ``name`` (what ``--strategy`` takes), ``title`` (how messages and help name it) and ``help``
  (one line),
* ``Params``: a frozen dataclass whose fields are its parameters, each with a type, a default
  and ``field(metadata={"help": ..., "cli": "--option"})`` (``cli`` absent: not on the command
  line),
* ``run(rig, spec, params) -> StrategyResult`` and ``describe(params) -> str`` (a short label
  for tables and figures, e.g. ``"LPA S=5"``),
* optionally (:class:`FunctionStrategy` has the defaults, as xarray's ``BackendEntrypoint``
  has): ``run_sets(rig, specs, params)`` (all sets of a measurement at once),
  ``prepare(params, context)`` (its parameters completed from what the measurement offers,
  :class:`RunContext`) and ``metrics(results, context)`` (its own ``metrics.json`` block,
  :class:`StrategyMetrics`); the measurement calls them through :func:`run_strategy`,
  :func:`prepare_params` and :func:`strategy_metrics`, and so names no strategy.

:func:`register` adds one to the registry (it also works as a class decorator);
:func:`get_strategy` and :func:`available_strategies` read it. Importing
:mod:`hdrfringe.strategies` registers the built-in ones. Front ends never list the strategies
themselves: the command-line options are generated from the ``Params`` fields by
:mod:`hdrfringe.cli._strategy_options`.

:class:`StrategyResult` says what varied between the sets captured: one :class:`CapturedSet`
per set (its MIGL, exposure or per-pixel MIGL map) and a per-pixel ``index_map`` of the
``index_quantity`` each pixel's composite intensities come from (Fig. 5.2c's MIGL index image
is the ``"migl"`` case); its typed fields tell the measurement what else to do with it: sets
to add to the captures (:class:`ExtraSet`), an absolute phase the strategy unwrapped itself,
and the decoder it needs (:class:`DecoderSettings`).
"""

from __future__ import annotations

import dataclasses
import numbers
import re
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, Union, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from hdrfringe._renamed import renamed_fields
from hdrfringe.core._validation import full_scale
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.rig.base import Rig

if TYPE_CHECKING:
    from hdrfringe.core.captures import Captures
    from hdrfringe.core.stereo import StereoCalibration

__all__ = [
    "DEFAULT_STRATEGY",
    "CapturedSet",
    "DecoderSettings",
    "ExtraSet",
    "FunctionStrategy",
    "MetricsContext",
    "RunContext",
    "Strategy",
    "StrategyMetrics",
    "StrategyResult",
    "available_strategies",
    "capture_set",
    "check_fringe_spec",
    "default_min_migl",
    "field_default",
    "get_strategy",
    "make_params",
    "merge_into_composite",
    "param_values",
    "prepare_params",
    "register",
    "run_strategy",
    "strategy_metrics",
    "unregister",
]

#: The strategy a measurement on a rig runs when none is named: one set at the highest MIGL.
DEFAULT_STRATEGY = "conventional"

#: What a result's ``index_map`` can hold: the quantity that varies between the captured sets.
INDEX_QUANTITIES = ("migl", "exposure_ms")

_NAME = re.compile(r"[a-z][a-z0-9_-]*\Z")
_OPTION = re.compile(r"--[a-z][a-z0-9-]*\Z")


# ---------------------------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CapturedSet:
    """One fringe set a strategy captured, and what was set for it.

    Parameters
    ----------
    migl : float or None
        The highest input gray level the set was projected at (thesis Ch. 4-6); None when the
        set has no single MIGL (a per-pixel ``migl_map``).
    exposure_ms : float or None
        Camera exposure time, when the strategy chose it; None: the rig's own setting.
    migl_map : ndarray or None
        Per projector pixel MIGL of a per-pixel adaptive projection; None for a global MIGL.

    Examples
    --------
    >>> CapturedSet(migl=240.0)
    CapturedSet(migl=240.0, exposure_ms=None, migl_map=None)
    """

    migl: float | None = None
    exposure_ms: float | None = None
    migl_map: NDArray | None = field(default=None, compare=False)


@dataclass(frozen=True)
class ExtraSet:
    """A set a strategy captured besides its composite, that the measurement decodes with it.

    Parameters
    ----------
    spec : FringeSpec
        The set as projected (e.g. the tolerant strategy's inverted set, phase offset 180 deg).
    images : ndarray (N, H, W)
        Its camera images, shift 0 first.

    Examples
    --------
    >>> extra = ExtraSet(FringeSpec("sinusoidal", 4, 8.0), np.zeros((4, 2, 3), np.uint8))
    >>> extra.images.shape
    (4, 2, 3)
    """

    spec: FringeSpec
    images: NDArray = field(compare=False, repr=False)


@dataclass(frozen=True)
class DecoderSettings:
    """The decoder a strategy's composite needs (instead of the standard one).

    Parameters
    ----------
    min_shifts : int
        The saturation-tolerant decoder (``saturated="exclude"``): each pixel's phase from its
        unsaturated shifts, at least ``min_shifts`` of them.

    Examples
    --------
    >>> DecoderSettings(min_shifts=3)
    DecoderSettings(min_shifts=3)
    """

    min_shifts: int


@renamed_fields(method="strategy")
@dataclass
class StrategyResult:
    """What a strategy returns: the composite and a record of what it captured.

    Parameters
    ----------
    images : ndarray (N, H, W)
        Composite phase-shifted images (camera dtype), shift 0 first.
    spec : FringeSpec
        The set as projected at the highest MIGL (pattern, steps, pitch, orientation, imin).
    captured : list of CapturedSet
        The sets captured, in capture order.
    index_map : ndarray (H, W)
        Per pixel, the ``index_quantity`` of the set its composite intensities come from
        (float32; for ``"migl"`` the MIGL index image N(x, y) of thesis Fig. 5.2c).
    newly_unsaturated : list of int
        Per captured set, the pixels that became unsaturated (copied to the composite) there.
    never_unsaturated : ndarray (H, W) bool
        Pixels saturated in every set captured (their composite comes from the last set).
    strategy : str
        The strategy's registry name (``method`` before issue 29: a deprecated alias).
    index_quantity : str
        What ``index_map`` holds: ``"migl"`` or ``"exposure_ms"``.
    details : dict
        Strategy-specific information (e.g. the uniform strategy's saturated fractions), for
        the strategy's own metrics hook and for reports; the measurement reads none of it.
    extra_sets : tuple of ExtraSet
        Sets to add to the captures after this one's (the tolerant strategy's inverted set).
    absolute_phase : ndarray (H, W) or None
        The set's absolute phase when the strategy unwrapped it itself (the adaptive
        projection, from its camera-to-projector mapping); the decoder takes it as given.
    decoder : DecoderSettings or None
        The decoder the composite needs; None: the standard one.
    projector_migl_map : ndarray (H_p, W_p) float32 or None
        A strategy that projects a per-pixel MIGL (the adaptive projection): the projector's
        MIGL map of its last pass, which the measurement writes (``projector_migl_map.tiff``).
    camera_migl : ndarray (H, W) float32 or None
        With ``projector_migl_map``: the per-camera-pixel levels the map was built from
        (``camera_migl.tiff``).

    Notes
    -----
    ``migls`` and ``migl_index`` are views of ``captured`` and ``index_map`` for the strategies
    that vary the MIGL (all of the thesis's, Ch. 4-6).

    Examples
    --------
    >>> spec = FringeSpec("sinusoidal", 4, 8.0)
    >>> res = StrategyResult(
    ...     images=np.zeros((4, 2, 3), np.uint8), spec=spec,
    ...     captured=[CapturedSet(migl=255.0), CapturedSet(migl=250.0)],
    ...     index_map=np.full((2, 3), 250.0, np.float32), newly_unsaturated=[0, 6],
    ...     never_unsaturated=np.zeros((2, 3), bool), strategy="lpa")
    >>> res.migls, res.sets_captured, res.images_captured
    ([255.0, 250.0], 2, 8)
    """

    images: NDArray
    spec: FringeSpec
    captured: list[CapturedSet]
    index_map: NDArray[np.float32]
    newly_unsaturated: list[int]
    never_unsaturated: NDArray[np.bool_]
    strategy: str
    index_quantity: str = "migl"
    details: dict[str, Any] = field(default_factory=dict)
    extra_sets: tuple[ExtraSet, ...] = ()
    absolute_phase: NDArray[np.float64] | None = None
    decoder: DecoderSettings | None = None
    projector_migl_map: NDArray[np.float32] | None = None
    camera_migl: NDArray[np.float32] | None = None

    def __post_init__(self) -> None:
        """Refuse records that do not fit together (counts per set, maps per pixel)."""
        where = f"strategy {self.strategy!r} result"
        if self.index_quantity not in INDEX_QUANTITIES:
            raise InputError(
                f"{where}: index_quantity {self.index_quantity!r} is not one of "
                f"{', '.join(INDEX_QUANTITIES)}"
            )
        if len(self.newly_unsaturated) != len(self.captured):
            raise InputError(
                f"{where}: {len(self.newly_unsaturated)} newly-unsaturated counts for "
                f"{len(self.captured)} captured sets; give one count per set"
            )
        shape = np.shape(self.images)[1:]
        for what in ("index_map", "never_unsaturated"):
            if np.shape(getattr(self, what)) != shape:
                raise InputError(
                    f"{where}: {what} has shape {np.shape(getattr(self, what))}, the images "
                    f"{shape}; give one value per pixel"
                )

    @property
    def migls(self) -> list[float]:
        """MIGL of every captured set, in capture order (sets with one global MIGL only).

        Returns
        -------
        list of float

        Raises
        ------
        AttributeError
            When a set has no single MIGL (a per-pixel MIGL map): read ``captured``.
        """
        out = [s.migl for s in self.captured]
        if any(m is None for m in out):
            raise AttributeError(
                f"strategy {self.strategy!r}: a captured set has no single MIGL; read .captured"
            )
        return [float(m) for m in out if m is not None]

    @property
    def migl_index(self) -> NDArray[np.float32]:
        """The MIGL index image N(x, y) (Fig. 5.2c): ``index_map`` when it holds MIGLs.

        Returns
        -------
        ndarray (H, W) float32

        Raises
        ------
        AttributeError
            When ``index_quantity`` is not ``"migl"``: read ``index_map``.
        """
        if self.index_quantity != "migl":
            raise AttributeError(
                f"strategy {self.strategy!r}: the index map holds {self.index_quantity}, not the "
                "MIGL; read .index_map"
            )
        return self.index_map

    @property
    def sets_captured(self) -> int:
        """Number of fringe sets captured.

        Returns
        -------
        int
        """
        return len(self.captured)

    @property
    def images_captured(self) -> int:
        """Number of images captured: ``spec.steps`` per set.

        Returns
        -------
        int
        """
        return len(self.captured) * self.spec.steps


# ---------------------------------------------------------------------------------------------
# the protocol and the registry
# ---------------------------------------------------------------------------------------------


# A protocol has no constructor: numpydoc reads the (*args, **kwargs) of typing.Protocol as one.
@runtime_checkable
class Strategy(Protocol):  # numpydoc ignore=PR01
    """A saturation-avoidance strategy (thesis Ch. 4-6), as the registry holds it.

    Attributes
    ----------
    name : str
        Registry name, what ``measure --strategy`` takes: lower case, digits, ``-`` and ``_``.
    title : str
        How messages and help text name it (``"DPA"``, ``"Uniform"``).
    help : str
        One line: what it captures.
    Params : type
        Frozen dataclass of its parameters; every field has a default and
        ``metadata={"help": ...}``, and ``"cli": "--option"`` to appear on the command line
        (``"exclusive": True``: that option given with another strategy is an error).

    Examples
    --------
    >>> isinstance(get_strategy("lpa"), Strategy)
    True
    """

    name: str
    title: str
    help: str
    Params: type

    def run(self, rig: Rig, spec: FringeSpec, params: Any) -> StrategyResult:
        """Capture on ``rig`` what the strategy asks for and return the composite.

        Parameters
        ----------
        rig : Rig
            Any rig (virtual, replay, hardware).
        spec : FringeSpec
            The fringe set, at its highest MIGL.
        params : Params
            The strategy's parameters.

        Returns
        -------
        StrategyResult
        """
        ...

    def describe(self, params: Any) -> str:
        """Short label of a run for tables and figures (e.g. ``"LPA S=5"``).

        Parameters
        ----------
        params : Params
            The strategy's parameters.

        Returns
        -------
        str
        """
        ...


@dataclass(frozen=True)
class RunContext:
    """What a measurement offers a strategy before it runs (its ``prepare`` hook).

    Parameters
    ----------
    available_migls : sequence of float or None
        The MIGLs the rig can show, when it replays a MIGL sweep; None: any MIGL.
    projector_geometry : StereoCalibration or None
        The projector-camera calibration the measurement was given
        (:meth:`MeasurementCalibration.projector_geometry
        <hdrfringe.core.calibration.MeasurementCalibration.projector_geometry>`); None: none.
    depth_range_mm : tuple of float or None
        The scene's depth range along the camera axis the measurement was given (mm,
        ``measure --depth-range``); None: none.

    Examples
    --------
    >>> RunContext().available_migls is None
    True
    """

    available_migls: Sequence[float] | None = None
    projector_geometry: StereoCalibration | None = field(default=None, repr=False)
    depth_range_mm: tuple[float, float] | None = None


@dataclass(frozen=True)
class MetricsContext:
    """What a strategy's ``metrics`` hook gets besides its results.

    Parameters
    ----------
    params : Params
        The parameters it ran with.
    replay : Captures or None
        The MIGL sweep it was replayed on; None on a live rig.
    param_sources : mapping
        Where parameters read from files came from, by field name.

    Examples
    --------
    >>> MetricsContext(params=None).replay is None
    True
    """

    params: Any
    replay: Captures | None = field(default=None, repr=False)
    param_sources: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class StrategyMetrics:
    """What a strategy's ``metrics`` hook adds to a measurement.

    Parameters
    ----------
    metrics : mapping
        Blocks of the measurement's metrics by field name (e.g. ``{"dpa": DPAMetrics}``,
        ``{"adaptive": {...}}``): :class:`~hdrfringe.pipeline.MeasurementMetrics` fields marked
        as strategy blocks.
    result : mapping
        Fields of the :class:`~hdrfringe.pipeline.MeasurementResult` by name (e.g. DPA's CDFs,
        ``{"dpa": (DPACDFs, ...)}``).

    Examples
    --------
    >>> StrategyMetrics().metrics
    {}
    """

    metrics: Mapping[str, Any] = field(default_factory=dict)
    result: Mapping[str, Any] = field(default_factory=dict)


class FunctionStrategy:
    """Base of a strategy whose work is one function, ``function(rig, spec, **params)``.

    A subclass sets ``name``, ``title``, ``help``, ``Params`` (a frozen dataclass whose fields
    are the function's keyword arguments) and ``function``; :meth:`run` passes the parameters'
    fields as keywords, and :meth:`describe` gives the name unless the subclass labels runs
    itself; :meth:`prepare` and :meth:`metrics` are the optional hooks, doing nothing until a
    subclass overrides them. The built-in strategies are written this way.

    Examples
    --------
    >>> from hdrfringe.strategies.lpa import LPA, LPAParams
    >>> isinstance(LPA(), FunctionStrategy), LPA().describe(LPAParams(step=5.0))
    (True, 'LPA S=5')
    """

    name: str
    title: str
    help: str
    Params: type
    function: Callable[..., StrategyResult]

    def run(self, rig: Rig, spec: FringeSpec, params: Any) -> StrategyResult:
        """Run the strategy's function with the fields of ``params`` as keyword arguments.

        Parameters
        ----------
        rig : Rig
            Any rig (virtual, replay, hardware).
        spec : FringeSpec
            The set, at its highest MIGL.
        params : Params
            The strategy's parameters.

        Returns
        -------
        StrategyResult
        """
        return type(self).function(rig, spec, **param_values(params))

    def describe(self, params: Any) -> str:
        """Label of a run: the strategy's name.

        Parameters
        ----------
        params : Params
            The strategy's parameters (unused here; subclasses label runs by them).

        Returns
        -------
        str
        """
        return self.name

    def prepare(self, params: Any, context: RunContext) -> Any:
        """The parameters completed from what the measurement offers (here: unchanged).

        Parameters
        ----------
        params : Params
            The strategy's parameters.
        context : RunContext
            What the measurement offers (a replay's MIGLs, a projector-camera calibration).

        Returns
        -------
        Params
        """
        return params

    def metrics(
        self, results: Sequence[StrategyResult], context: MetricsContext
    ) -> StrategyMetrics:
        """The strategy's own blocks of a measurement's metrics (here: none).

        Parameters
        ----------
        results : sequence of StrategyResult
            One per set of the measurement, coarsest first.
        context : MetricsContext
            The parameters, the replayed sweep, the parameters' files.

        Returns
        -------
        StrategyMetrics
        """
        return StrategyMetrics()


_REGISTRY: dict[str, Strategy] = {}


def _type_hints(params_type: type, where: str) -> dict[str, Any]:
    """The resolved field types of a Params dataclass; a clear error when they do not resolve."""
    try:
        return typing.get_type_hints(params_type)
    except (NameError, TypeError) as exc:
        raise InputError(
            f"{where}: cannot resolve the Params field types ({exc}); import the types the "
            "fields name at the top of the strategy's module"
        ) from None


def _check_strategy(strategy: Any) -> None:
    """Refuse anything the registry, the CLI and :func:`make_params` could not use."""
    where = f"strategy {getattr(strategy, 'name', strategy)!r}"
    if not isinstance(strategy, Strategy):
        raise InputError(
            f"{where} is not a Strategy: it needs name, title, help, Params, run and describe"
        )
    if not isinstance(strategy.name, str) or not _NAME.match(strategy.name):
        raise InputError(
            f"{where}: name must be lower case letters, digits, '-' or '_' (e.g. 'lpa')"
        )
    for what in ("title", "help"):
        if not (isinstance(getattr(strategy, what), str) and getattr(strategy, what).strip()):
            raise InputError(f"{where}: {what} must be a non-empty string")
    params = strategy.Params
    if not (dataclasses.is_dataclass(params) and isinstance(params, type)):
        raise InputError(f"{where}: Params must be a dataclass type")
    if not params.__dataclass_params__.frozen:  # type: ignore[attr-defined]
        raise InputError(f"{where}: Params must be frozen, @dataclass(frozen=True)")
    _type_hints(params, where)
    for f in dataclasses.fields(params):
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            raise InputError(f"{where}: parameter {f.name} needs a default")
        if not isinstance(f.metadata.get("help"), str):
            raise InputError(
                f"{where}: parameter {f.name} needs help text, field(metadata={{'help': ...}})"
            )
        opt = f.metadata.get("cli")
        if opt is not None and not (isinstance(opt, str) and _OPTION.match(opt)):
            raise InputError(
                f"{where}: parameter {f.name}'s cli name {opt!r} must look like '--some-option'"
            )


def register(strategy: Any) -> Any:
    """Add a strategy to the registry; returns its argument, so it also decorates a class.

    Parameters
    ----------
    strategy : Strategy or type
        A strategy object, or a class whose no-argument instance is one (as a decorator).

    Returns
    -------
    Strategy or type
        The argument, unchanged.

    Raises
    ------
    InputError
        When the name is taken or the object does not follow :class:`Strategy` (missing
        members, a ``Params`` that is not a frozen dataclass, a field without default or help).

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class NoParams:
    ...     pass
    >>> @register
    ... class TopOnly:
    ...     name, title, help, Params = "top-only", "Top only", "one set at the top", NoParams
    ...     def run(self, rig, spec, params):
    ...         return get_strategy("conventional").run(rig, spec, params)
    ...     def describe(self, params):
    ...         return "top only"
    >>> "top-only" in available_strategies()
    True
    >>> unregister("top-only").describe(NoParams())
    'top only'
    """
    obj = strategy() if isinstance(strategy, type) else strategy
    _check_strategy(obj)
    if obj.name in _REGISTRY:
        raise InputError(
            f"strategy {obj.name!r} is already registered; choose another name or unregister it"
        )
    _check_option_names(obj)  # a clash with another strategy's option is refused here
    _REGISTRY[obj.name] = obj
    return strategy


def unregister(name: str) -> Strategy:
    """Remove a strategy from the registry and return it (e.g. after a test).

    Parameters
    ----------
    name : str
        Registry name.

    Returns
    -------
    Strategy
        The strategy removed.

    Examples
    --------
    >>> from hdrfringe.strategies.lpa import LPA
    >>> class LPACopy(LPA):
    ...     name = "lpa-copy"
    >>> _ = register(LPACopy)
    >>> unregister("lpa-copy").name, "lpa-copy" in available_strategies()
    ('lpa-copy', False)
    """
    strategy = get_strategy(name)
    del _REGISTRY[name]
    return strategy


def get_strategy(name: str) -> Strategy:
    """The registered strategy called ``name``.

    Parameters
    ----------
    name : str
        Registry name, e.g. ``"lpa"``.

    Returns
    -------
    Strategy

    Raises
    ------
    InputError
        ``unknown strategy 'x'; use one of conventional, uniform, lpa, dpa``.

    Examples
    --------
    >>> get_strategy("dpa").title
    'DPA'
    """
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise InputError(
            f"unknown strategy {name!r}; use one of {', '.join(available_strategies())}"
        ) from None


def available_strategies() -> tuple[str, ...]:
    """Names of the registered strategies, in registration order.

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> available_strategies()[:4]
    ('conventional', 'uniform', 'lpa', 'dpa')
    """
    return tuple(_REGISTRY)


def run_strategy(
    strategy: Strategy, rig: Rig, specs: Sequence[FringeSpec], params: Any
) -> list[StrategyResult]:
    """A strategy's results for every set of a measurement: its ``run_sets`` when it plans all
    sets together (one mapping for every pitch, the adaptive projection), else ``run`` per set.

    Parameters
    ----------
    strategy : Strategy
        A registered strategy.
    rig : Rig
        The rig it drives.
    specs : sequence of FringeSpec
        The sets at their highest MIGL, coarsest first.
    params : Params
        Its parameters.

    Returns
    -------
    list of StrategyResult
        One per spec.

    Raises
    ------
    InputError
        When ``run_sets`` returns another number of results.

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=32, height=24))
    >>> lpa = get_strategy("lpa")
    >>> [r.strategy for r in run_strategy(lpa, rig, [FringeSpec("sinusoidal", 4, 8.0)],
    ...                                 make_params("lpa"))]
    ['lpa']
    """
    run_sets = getattr(strategy, "run_sets", None)
    if not callable(run_sets):
        return [strategy.run(rig, spec, params) for spec in specs]
    results = list(run_sets(rig, list(specs), params))
    if len(results) != len(specs):
        raise InputError(
            f"strategy {strategy.name!r} returned {len(results)} results for {len(specs)} sets"
        )
    return results


def prepare_params(strategy: Strategy, params: Any, context: RunContext) -> Any:
    """A strategy's parameters completed by its ``prepare`` hook (unchanged without one).

    Parameters
    ----------
    strategy : Strategy
        A registered strategy.
    params : Params
        Its parameters.
    context : RunContext
        What the measurement offers.

    Returns
    -------
    Params

    Examples
    --------
    >>> prepare_params(get_strategy("uniform"), make_params("uniform"),
    ...                RunContext(available_migls=[200.0, 255.0])).candidates
    [200.0, 255.0]
    """
    prepare = getattr(strategy, "prepare", None)
    return params if prepare is None else prepare(params, context)


def strategy_metrics(
    strategy: Strategy, results: Sequence[StrategyResult], context: MetricsContext
) -> StrategyMetrics:
    """A strategy's blocks of a measurement's metrics from its ``metrics`` hook (none without).

    Parameters
    ----------
    strategy : Strategy
        A registered strategy.
    results : sequence of StrategyResult
        Its results, one per set of the measurement.
    context : MetricsContext
        The parameters, the replayed sweep, the parameters' files.

    Returns
    -------
    StrategyMetrics

    Examples
    --------
    >>> strategy_metrics(get_strategy("lpa"), [], MetricsContext(make_params("lpa")))
    StrategyMetrics(metrics={}, result={})
    """
    hook = getattr(strategy, "metrics", None)
    if hook is None:
        return StrategyMetrics()
    out = hook(results, context)
    if not isinstance(out, StrategyMetrics):
        raise InputError(
            f"strategy {strategy.name!r}: metrics() returned {type(out).__name__}, not a "
            "StrategyMetrics"
        )
    return out


# ---------------------------------------------------------------------------------------------
# parameters
# ---------------------------------------------------------------------------------------------


def _conforms(value: Any, hint: Any) -> bool:
    """Whether ``value`` has the type ``hint`` (the simple types a parameter field uses)."""
    origin = typing.get_origin(hint)
    if hint is Any:
        return True
    if origin in (Union, types.UnionType):
        return any(_conforms(value, arg) for arg in typing.get_args(hint))
    if hint is type(None):
        return value is None
    if hint is bool:
        return isinstance(value, bool | np.bool_)
    if hint is int:
        return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)
    if hint is float:
        return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)
    if origin is typing.Literal:
        return value in typing.get_args(hint)
    base = origin if origin is not None else hint
    return isinstance(value, base) if isinstance(base, type) else True


def _type_name(hint: Any) -> str:
    """A type as messages name it (``float``, ``CorrectionPolynomial | None``)."""
    return getattr(hint, "__name__", None) or str(hint).replace("typing.", "")


def make_params(name: str, **values: Any) -> Any:
    """The ``Params`` of strategy ``name`` with ``values`` (the rest at their defaults), checked.

    Parameters
    ----------
    name : str
        Registry name.
    **values
        Parameter values by field name.

    Returns
    -------
    Params
        The strategy's ``Params`` instance.

    Raises
    ------
    InputError
        For an unknown strategy, a parameter it does not have, or a value of the wrong type.

    Examples
    --------
    >>> make_params("lpa", step=15.0)
    LPAParams(step=15.0, min_migl=None)
    """
    strategy = get_strategy(name)
    hints = typing.get_type_hints(strategy.Params)
    fields = [f.name for f in dataclasses.fields(strategy.Params)]
    for key, value in values.items():
        if key not in fields:
            raise InputError(
                f"{name} has no parameter {key!r}; its parameters: {', '.join(fields) or 'none'}"
            )
        if not _conforms(value, hints[key]):
            raise InputError(
                f"{name} parameter {key} must be {_type_name(hints[key])}, got {value!r}"
            )
    return strategy.Params(**values)


def param_values(params: Any) -> dict[str, Any]:
    """The fields of a ``Params`` object as a dict (shallow: values are not copied).

    Parameters
    ----------
    params : Params
        A strategy's parameters.

    Returns
    -------
    dict
        Field name -> value, e.g. to pass on as keyword arguments.

    Examples
    --------
    >>> param_values(make_params("lpa", step=15.0))
    {'step': 15.0, 'min_migl': None}
    """
    return {f.name: getattr(params, f.name) for f in dataclasses.fields(params)}


def field_default(f: dataclasses.Field[Any]) -> Any:
    """A ``Params`` field's default value (from its default factory if it has one).

    Parameters
    ----------
    f : dataclasses.Field
        A field of a strategy's ``Params``.

    Returns
    -------
    object

    Examples
    --------
    >>> from hdrfringe.strategies.lpa import LPAParams
    >>> [field_default(f) for f in dataclasses.fields(LPAParams)]
    [5.0, None]
    """
    if f.default is not dataclasses.MISSING:
        return f.default
    factory: Callable[[], Any] = f.default_factory  # type: ignore[assignment]
    return factory()


def _check_option_names(strategy: Strategy) -> None:
    """Refuse a strategy whose ``cli`` option name another registered strategy declares with
    another type or default (the front ends then could not give both one option)."""
    hints = typing.get_type_hints(strategy.Params)
    for f in dataclasses.fields(strategy.Params):
        opt = f.metadata.get("cli")
        if opt is None:
            continue
        owners = []
        for other in _REGISTRY.values():
            if other is strategy:
                continue
            other_hints = typing.get_type_hints(other.Params)
            for g in dataclasses.fields(other.Params):
                if g.metadata.get("cli") == opt:
                    owners.append((other, other_hints[g.name], field_default(g)))
        if owners and any((h, d) != (hints[f.name], field_default(f)) for _, h, d in owners):
            _, hint, default = owners[0]
            titles = "/".join(o.title for o, _, _ in owners)
            raise InputError(
                f"strategy {strategy.name!r}: option {opt} is already {titles}'s "
                f"with type {_type_name(hint)} and default {default!r}; "
                "use the same type and default or another option name"
            )


# ---------------------------------------------------------------------------------------------
# shared helpers of the strategies
# ---------------------------------------------------------------------------------------------


def check_fringe_spec(spec: FringeSpec, rig: Rig) -> None:
    """Refuse a set the rig's projector cannot show: not a FringeSpec, MIGL above full scale.

    Parameters
    ----------
    spec : FringeSpec
        The set at its highest MIGL.
    rig : Rig
        The rig the strategy drives.

    Raises
    ------
    InputError

    Examples
    --------
    >>> from hdrfringe.rig.simulated import SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> check_fringe_spec(FringeSpec("sinusoidal", 4, 8.0), SimulatedRig(white_plate()))
    >>> check_fringe_spec(FringeSpec("sinusoidal", 4, 8.0, migl=300), SimulatedRig(white_plate()))
    Traceback (most recent call last):
        ...
    hdrfringe.errors.InputError: highest MIGL 300 exceeds the projector's 255
    """
    if not isinstance(spec, FringeSpec):
        raise InputError(f"strategy needs a FringeSpec, got {type(spec).__name__}")
    full = full_scale(rig.projector.bit_depth, "projector bit depth")
    if spec.migl > full:
        raise InputError(f"highest MIGL {spec.migl:g} exceeds the projector's {full}")


def capture_set(rig: Rig, spec: FringeSpec, migl: float) -> NDArray:
    """Capture the set ``spec`` at MIGL ``migl`` on ``rig``.

    Parameters
    ----------
    rig : Rig
        Any rig.
    spec : FringeSpec
        The set (its own MIGL is replaced).
    migl : float
        The MIGL to project it at.

    Returns
    -------
    ndarray (N, H, W)
        The camera images, shift 0 first.

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=64, height=48))
    >>> capture_set(rig, FringeSpec("sinusoidal", 4, 8.0), 200).shape
    (4, 48, 64)
    """
    return rig.capture(spec.with_migl(float(migl)).frames())


def merge_into_composite(
    composite: NDArray,
    index: NDArray[np.float32],
    remaining: NDArray[np.bool_],
    images: NDArray,
    unsaturated: NDArray[np.bool_],
    value: float,
) -> int:
    """One step of Eq. 5.1, in place; returns the number of newly unsaturated pixels.

    Pixels still ``remaining`` (saturated in every set so far) that are ``unsaturated`` in
    ``images`` take these intensities, their ``index`` becomes ``value`` (the set's MIGL, or
    whatever the index map holds) and they leave ``remaining``; pixels still saturated carry
    the latest (least saturated) set's intensities and value.

    Parameters
    ----------
    composite : ndarray (N, H, W)
        The composite so far, updated in place.
    index : ndarray (H, W)
        The index map so far, updated in place.
    remaining : ndarray (H, W) bool
        Pixels saturated in every set so far, updated in place.
    images : ndarray (N, H, W)
        The set just captured.
    unsaturated : ndarray (H, W) bool
        Where none of its N shifts is saturated
        (:func:`hdrfringe.core._validation.unsaturated_mask`).
    value : float
        The set's index value (its MIGL for LPA and DPA).

    Returns
    -------
    int
        Pixels that left ``remaining``.

    References
    ----------
    Thesis Eq. 5.1 (the LPA composite).

    Examples
    --------
    >>> comp = np.array([[[255, 255]]], np.uint8); idx = np.full((1, 2), 255, np.float32)
    >>> left = np.array([[True, True]])
    >>> merge_into_composite(comp, idx, left, np.array([[[200, 255]]], np.uint8),
    ...                      np.array([[True, False]]), 250.0)
    1
    >>> comp.tolist(), idx.tolist(), left.tolist()
    ([[[200, 255]]], [[250.0, 250.0]], [[False, True]])
    """
    new = remaining & unsaturated
    composite[:, new] = images[:, new]
    index[new] = value
    remaining &= ~new
    composite[:, remaining] = images[:, remaining]
    index[remaining] = value
    return int(new.sum())


def default_min_migl(spec: FringeSpec) -> float:
    """Lowest MIGL that still carries a fringe: ``imin + 20`` gray levels (amplitude b >= 10).

    Parameters
    ----------
    spec : FringeSpec
        The set.

    Returns
    -------
    float

    References
    ----------
    Thesis Sec. 5.2.2: the checkerboard sweeps ran from MIGL 255 down to 60.

    Examples
    --------
    >>> default_min_migl(FringeSpec("sinusoidal", 4, 8.0, imin=40))
    60.0
    """
    return float(spec.imin + 20)
