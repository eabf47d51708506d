"""``measure``'s strategy options, generated from the strategy registry.

Strategies declare their parameters (``Params`` dataclass fields with ``metadata={"help": ...,
"cli": "--option", "exclusive": ...}``, :mod:`hdrfringe.strategies.base`); this module makes
the command-line options of them (:func:`cli_options`, :func:`with_strategy_options`) and turns
the options given back into a ``Params`` object (:func:`params_from_options`).
"""

from __future__ import annotations

import dataclasses
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Union

import typer

from hdrfringe.cli._app import F
from hdrfringe.errors import InputError

__all__ = [
    "StrategyOption",
    "article",
    "cli_options",
    "params_from_options",
    "strategy_file_readers",
    "strategy_help",
    "strategy_option_type",
    "with_strategy_options",
]


def _type_name(hint: Any) -> str:
    """A type as messages name it (``float``, ``CorrectionPolynomial | None``)."""
    return getattr(hint, "__name__", None) or str(hint).replace("typing.", "")


def strategy_help() -> str:
    """``measure --strategy``'s help: the registered strategies, read when the CLI is imported.

    Returns
    -------
    str

    Examples
    --------
    >>> strategy_help()[:53]
    'Saturation avoidance: conventional, uniform, lpa, dpa'
    """
    from hdrfringe.strategies import available_strategies

    names = available_strategies()
    listed = f"{', '.join(names[:-1])} or {names[-1]}" if len(names) > 1 else "".join(names)
    return (
        f"Saturation avoidance: {listed} (a FOLDER must then be a MIGL sweep; --rig sim "
        "without it: conventional)."
    )


def strategy_file_readers() -> dict[type, tuple[Callable[[Any], Any], str]]:
    """Strategy parameter types the command line takes as a file: type -> (reader, what file).

    Strategies read no files; the front end turns the path into the parameter.

    Returns
    -------
    dict

    Examples
    --------
    >>> [t.__name__ for t in strategy_file_readers()]
    ['CorrectionPolynomial']
    """
    from hdrfringe.core.saturation.estimate import CorrectionPolynomial

    return {CorrectionPolynomial: (CorrectionPolynomial.load, "JSON from train-correction")}


def strategy_option_type(opt: Any) -> tuple[Any, str]:
    """The command-line type of a strategy option (bool, int, float, str, or a file as a
    Path) and, for a file, what it holds."""
    import types
    import typing

    hint = opt.hint
    union = typing.get_origin(hint) in (typing.Union, types.UnionType)
    args = typing.get_args(hint) if union else (hint,)
    base = [a for a in args if a is not type(None)]
    files = strategy_file_readers()
    if len(base) == 1 and base[0] in (bool, int, float, str):
        return (base[0] | None if type(None) in args else base[0]), ""
    if len(base) == 1 and base[0] in files and opt.default is None:
        return Path | None, files[base[0]][1]
    raise InputError(
        f"strategy option {opt.option} ({', '.join(opt.titles())}): the command line gives "
        f"bool, int, float, str or a file read into "
        f"{', '.join(t.__name__ for t in files)} (default None), not {hint}; change the Params "
        "field or drop its 'cli' name"
    )


def with_strategy_options(func: F) -> F:
    """Give a command one option per strategy parameter on the command line, after --strategy.

    The options come from the registry (:func:`cli_options`) when this
    module is imported: a strategy registered before that has its options here. The command
    receives them in ``**strategy_options`` by Python name (``bound_pending``).

    Parameters
    ----------
    func : callable
        A command with a ``strategy`` parameter and ``**strategy_options``.

    Returns
    -------
    The command, with a ``__signature__`` that typer reads.

    Examples
    --------
    >>> import inspect
    >>> from hdrfringe.cli.measure import measure
    >>> "bound_pending" in inspect.signature(measure).parameters
    True
    """
    import inspect

    sig = inspect.signature(func, eval_str=True)
    own = [p for p in sig.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
    at = [p.name for p in own].index("strategy") + 1
    extra = []
    for opt in cli_options():
        if opt.dest in sig.parameters:
            raise InputError(
                f"strategy option {opt.option} ({', '.join(opt.titles())}) is also an option of "
                f"{func.__name__}; give the Params field another 'cli' name"
            )
        kind, file = strategy_option_type(opt)
        decl = f"{opt.option}/--no-{opt.option[2:]}" if kind is bool else opt.option
        text = f"{opt.help} File: {file}." if file else opt.help
        extra.append(
            inspect.Parameter(
                opt.dest,
                inspect.Parameter.POSITIONAL_OR_KEYWORD,
                default=opt.default,
                annotation=Annotated[kind, typer.Option(decl, help=text)],
            )
        )
    func.__signature__ = sig.replace(parameters=[*own[:at], *extra, *own[at:]])  # type: ignore[attr-defined]
    return func


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
        Given with another strategy, the option is an error (else it is ignored there).

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
        from hdrfringe.strategies import get_strategy

        return [get_strategy(name).title for name in self.fields]


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
    from hdrfringe.strategies import available_strategies, get_strategy
    from hdrfringe.strategies.base import field_default

    out: dict[str, StrategyOption] = {}
    helps: dict[str, str] = {}
    for name in available_strategies():
        strategy = get_strategy(name)
        hints = typing.get_type_hints(strategy.Params)
        for f in dataclasses.fields(strategy.Params):
            opt = f.metadata.get("cli")
            if opt is None:
                continue
            default = field_default(f)
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


def article(title: str) -> str:
    """``a`` or ``an`` before ``title`` (acronyms are read letter by letter).

    Parameters
    ----------
    title : str
        A strategy's title.

    Returns
    -------
    str

    Examples
    --------
    >>> article("LPA"), article("DPA"), article("Tolerant")
    ('an', 'a', 'a')
    """
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

    Options of another strategy are ignored (one command line can serve several strategies),
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
        An unknown strategy or option, an exclusive option of another strategy (e.g.
        ``--bound-pending is a DPA option; use it with --strategy dpa (got lpa)``), a bad value.

    Examples
    --------
    >>> params_from_options("lpa", {"--step": 15.0, "--threshold": 0.2})
    LPAParams(step=15.0, min_migl=None)
    """
    from hdrfringe.strategies import get_strategy, make_params

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
                    f"{opt} is {article(titles[0])} {' or '.join(titles)} option; use it with "
                    f"--strategy {' or '.join(names)} (got {name})"
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
