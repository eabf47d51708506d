"""``measure``'s strategy options, generated from the strategy registry."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import F
from hdrfringe.errors import InputError

__all__ = ["method_help", "strategy_file_readers", "strategy_option_type", "with_strategy_options"]


def method_help() -> str:
    """``measure --method``'s help: the registered strategies, read when the CLI is imported.

    Returns
    -------
    str

    Examples
    --------
    >>> method_help()[:66]
    'Saturation avoidance: conventional, uniform, lpa, dpa or adaptive '
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
    from hdrfringe.saturation.estimate import CorrectionPolynomial

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
    """Give a command one option per strategy parameter on the command line, after --method.

    The options come from the registry (:func:`hdrfringe.strategies.cli_options`) when this
    module is imported: a strategy registered before that has its options here. The command
    receives them in ``**strategy_options`` by Python name (``bound_pending``).

    Parameters
    ----------
    func : callable
        A command with a ``method`` parameter and ``**strategy_options``.

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

    from hdrfringe.strategies import cli_options

    sig = inspect.signature(func, eval_str=True)
    own = [p for p in sig.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
    at = [p.name for p in own].index("method") + 1
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
