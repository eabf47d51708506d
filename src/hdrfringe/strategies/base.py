"""The strategy plug-in interface: the protocol, typed parameters, the registry, the result.

A saturation-avoidance strategy decides which fringe sets to capture on a rig and builds the
composite the phase stage decodes (thesis Ch. 4-6). Each one is an object with

* ``name`` (what ``--method`` takes), ``title`` (how messages and help name it) and ``help``
  (one line),
* ``Params``: a frozen dataclass whose fields are its parameters, each with a type, a default
  and ``field(metadata={"help": ..., "cli": "--option"})`` (``cli`` absent: not on the command
  line),
* ``run(rig, spec, params) -> StrategyResult`` and ``describe(params) -> str`` (a short label
  for tables and figures, e.g. ``"LPA S=5"``).

:func:`register` adds one to the registry (it also works as a class decorator);
:func:`get_strategy` and :func:`available_strategies` read it. Importing
:mod:`hdrfringe.strategies` registers the built-in ones. Front ends never list the methods
themselves: ``measure --method`` and its per-method options come from :func:`cli_options`, and
:func:`params_from_options` turns the options given into a ``Params`` object.

:class:`StrategyResult` says what varied between the sets captured: one :class:`CapturedSet`
per set (its MIGL, exposure or per-pixel MIGL map) and a per-pixel ``index_map`` of the
``index_quantity`` each pixel's composite intensities come from (Fig. 5.2c's MIGL index image
is the ``"migl"`` case).
"""

from __future__ import annotations

import dataclasses
import numbers
import re
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, Union, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from hdrfringe._validation import full_scale
from hdrfringe.errors import InputError
from hdrfringe.patterns import FringeSpec
from hdrfringe.rig.base import Rig

__all__ = [
    "CapturedSet",
    "FunctionStrategy",
    "Strategy",
    "StrategyOption",
    "StrategyResult",
    "available_strategies",
    "capture_set",
    "check_fringe_spec",
    "cli_options",
    "default_min_migl",
    "get_strategy",
    "make_params",
    "merge_into_composite",
    "param_values",
    "params_from_options",
    "register",
    "unregister",
]

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
    method : str
        The strategy's registry name.
    index_quantity : str
        What ``index_map`` holds: ``"migl"`` or ``"exposure_ms"``.
    details : dict
        Strategy-specific information (e.g. the uniform strategy's saturated fractions).

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
    ...     never_unsaturated=np.zeros((2, 3), bool), method="lpa")
    >>> res.migls, res.sets_captured, res.images_captured
    ([255.0, 250.0], 2, 8)
    """

    images: NDArray
    spec: FringeSpec
    captured: list[CapturedSet]
    index_map: NDArray[np.float32]
    newly_unsaturated: list[int]
    never_unsaturated: NDArray[np.bool_]
    method: str
    index_quantity: str = "migl"
    details: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        """Refuse records that do not fit together (counts per set, maps per pixel)."""
        where = f"strategy {self.method!r} result"
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
                f"strategy {self.method!r}: a captured set has no single MIGL; read .captured"
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
                f"strategy {self.method!r}: the index map holds {self.index_quantity}, not the "
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
        Registry name, what ``measure --method`` takes: lower case, digits, ``-`` and ``_``.
    title : str
        How messages and help text name it (``"DPA"``, ``"Uniform"``).
    help : str
        One line: what it captures.
    Params : type
        Frozen dataclass of its parameters; every field has a default and
        ``metadata={"help": ...}``, and ``"cli": "--option"`` to appear on the command line
        (``"exclusive": True``: that option given with another method is an error).

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


class FunctionStrategy:
    """Base of a strategy whose work is one function, ``function(rig, spec, **params)``.

    A subclass sets ``name``, ``title``, ``help``, ``Params`` (a frozen dataclass whose fields
    are the function's keyword arguments) and ``function``; :meth:`run` passes the parameters'
    fields as keywords, and :meth:`describe` gives the name unless the subclass labels runs
    itself. The built-in strategies are written this way.

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
    _REGISTRY[obj.name] = obj
    try:
        cli_options()  # a clash with another strategy's option is refused here, not in the CLI
    except InputError:
        del _REGISTRY[obj.name]
        raise
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
        ``unknown method 'x'; use one of conventional, uniform, lpa, dpa``.

    Examples
    --------
    >>> get_strategy("dpa").title
    'DPA'
    """
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise InputError(
            f"unknown method {name!r}; use one of {', '.join(available_strategies())}"
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


@dataclass(frozen=True)
class StrategyOption:
    """One command-line option of the strategies (:func:`cli_options`).

    Parameters
    ----------
    option : str
        The option, e.g. ``"--step"``.
    dest : str
        Its Python name, e.g. ``"bound_pending"``.
    hint : type
        The parameter's type (from the ``Params`` field).
    default : object
        The field's default.
    help : str
        Help text, prefixed with the titles of the strategies it belongs to.
    fields : dict
        Strategy name -> field name, for every strategy that takes the option.
    exclusive : bool
        Given with another method, the option is an error (else it is ignored there).

    Examples
    --------
    >>> [o.option for o in cli_options() if "lpa" in o.fields]
    ['--step']
    """

    option: str
    dest: str
    hint: Any
    default: Any
    help: str
    fields: dict[str, str]
    exclusive: bool

    def titles(self) -> list[str]:
        """Titles of the strategies that take the option, in registry order.

        Returns
        -------
        list of str

        Examples
        --------
        >>> [o.titles() for o in cli_options() if o.option == "--step"]
        [['LPA']]
        """
        return [_REGISTRY[name].title for name in self.fields]


def cli_options() -> list[StrategyOption]:
    """The command-line options of every registered strategy, in registry and field order.

    Two strategies may share an option (same name, type and default); it then sets the
    field of whichever strategy runs.

    Returns
    -------
    list of StrategyOption
        One per option name.

    Raises
    ------
    InputError
        When two strategies use one option name with different types or defaults.

    Examples
    --------
    >>> [o.option for o in cli_options()][:3]
    ['--uniform-migl', '--tolerance', '--step']
    """
    out: dict[str, StrategyOption] = {}
    helps: dict[str, str] = {}
    for name, strategy in _REGISTRY.items():
        hints = typing.get_type_hints(strategy.Params)
        for f in dataclasses.fields(strategy.Params):
            opt = f.metadata.get("cli")
            if opt is None:
                continue
            default = _field_default(f)
            exclusive = bool(f.metadata.get("exclusive", False))
            if opt in out:
                prev = out[opt]
                if prev.hint != hints[f.name] or prev.default != default:
                    raise InputError(
                        f"strategy {name!r}: option {opt} is already {'/'.join(prev.titles())}'s "
                        f"with type {_type_name(prev.hint)} and default {prev.default!r}; "
                        "use the same type and default or another option name"
                    )
                fields = {**prev.fields, name: f.name}
                exclusive = prev.exclusive or exclusive
            else:
                fields = {name: f.name}
                helps[opt] = f.metadata["help"]
            out[opt] = StrategyOption(
                option=opt,
                dest=opt[2:].replace("-", "_"),
                hint=hints[f.name],
                default=default,
                help="",
                fields=fields,
                exclusive=exclusive,
            )
    return [
        dataclasses.replace(o, help=f"{', '.join(o.titles())}: {helps[o.option]}")
        for o in out.values()
    ]


def _field_default(f: dataclasses.Field[Any]) -> Any:
    """A dataclass field's default value (from its default factory if it has one)."""
    if f.default is not dataclasses.MISSING:
        return f.default
    factory: Callable[[], Any] = f.default_factory  # type: ignore[assignment]
    return factory()


def _article(title: str) -> str:
    """``a`` or ``an`` before ``title`` (acronyms are read letter by letter)."""
    first = title[:1]
    if title.isupper():  # an acronym, read letter by letter: an LPA, a DPA
        return "an" if first in "AEFHILMNORSX" else "a"
    return "an" if first.lower() in "aeiou" else "a"


def params_from_options(
    name: str | None,
    options: Mapping[str, Any],
    *,
    readers: Mapping[type, Callable[[Any], Any]] | None = None,
) -> Any:
    """The ``Params`` of strategy ``name`` from command-line options, checked.

    Options of another strategy are ignored (one command line can serve several methods),
    except the ``exclusive`` ones, which are refused when set away from their default.

    Parameters
    ----------
    name : str or None
        The strategy chosen; None: no strategy (exclusive options are then refused).
    options : mapping
        Option (``"--step"``) -> value, for the options the user gave.
    readers : mapping, optional
        Parameter type -> function turning the option's value into it (the CLI passes the
        file readers here, e.g. ``{CorrectionPolynomial: CorrectionPolynomial.load}``:
        strategies read no files).

    Returns
    -------
    Params or None
        The strategy's ``Params``; None when ``name`` is None.

    Raises
    ------
    InputError
        An unknown strategy or option, an exclusive option of another method (e.g.
        ``--bound-pending is a DPA option; use it with --method dpa (got lpa)``), a bad value.

    Examples
    --------
    >>> params_from_options("lpa", {"--step": 15.0, "--threshold": 0.2})
    LPAParams(step=15.0, min_migl=None)
    """
    if name is not None:
        get_strategy(name)
    known = {o.option: o for o in cli_options()}
    values: dict[str, Any] = {}
    for opt, value in options.items():
        spec = known.get(opt)
        if spec is None:
            raise InputError(
                f"unknown strategy option {opt}; the strategies take {', '.join(known) or 'none'}"
            )
        if name not in spec.fields:
            if spec.exclusive and value != spec.default:
                titles, names = spec.titles(), list(spec.fields)
                raise InputError(
                    f"{opt} is {_article(titles[0])} {' or '.join(titles)} option; use it with "
                    f"--method {' or '.join(names)} (got {name})"
                )
            continue
        if value is not None:
            for typ, read in (readers or {}).items():
                if _conforms_base(spec.hint, typ):
                    value = read(value)
                    break
        values[spec.fields[name]] = value
    return None if name is None else make_params(name, **values)


def _conforms_base(hint: Any, typ: type) -> bool:
    """Whether ``typ`` is the parameter type ``hint`` (None aside)."""
    args = typing.get_args(hint) if typing.get_origin(hint) in (Union, types.UnionType) else ()
    return hint is typ or typ in args


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
        Where none of its N shifts is saturated (:func:`hdrfringe._validation.unsaturated_mask`).
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
