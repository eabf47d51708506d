"""The typer application, its error handling and the helpers every command shares."""

from __future__ import annotations

import contextlib
import errno
import functools
import importlib
import math
import os
import shutil
import sys
from collections.abc import Callable, Iterator, Mapping, MutableMapping
from typing import Annotated, Any, TypeVar

import numpy as np
import typer
import typer.core
import typer.main
from rich.console import Console
from rich.markup import escape

from hdrfringe.core.limits import MAX_PROGRAM_FRAMES, check_count
from hdrfringe.errors import (
    HdrFringeError,
    InputError,
    ResourceError,
    environment_fault,
    memory_note,
)

__all__ = [
    "COMMAND_MODULES",
    "MIN_ADDRESS_SPACE_MIB",
    "PLUGIN_GROUP",
    "PLUGIN_INSTALL",
    "F",
    "LazyGroup",
    "app",
    "console",
    "err_console",
    "handle_errors",
    "main",
    "parse_floats",
    "parse_range",
    "plugin_commands",
    "progress_bar",
    "progress_stage",
]

#: Every command (in ``--help`` order) and the module that declares it. A command's module,
#: and with it what the module imports (the strategy registry for ``measure``, ``capture`` and
#: ``train-correction``), is loaded only when that command is run or listed; ``tests/
#: test_cli_lazy.py`` checks the table against the modules.
COMMAND_MODULES: dict[str, str] = {
    "calibrate": "calibrate",
    "calibrate-stereo": "calibrate_stereo",
    "compare": "compare",
    "capture": "capture",
    "capture-gamma": "capture_gamma",
    "capture-poses": "capture_poses",
    "demo": "demo",
    "gamma": "gamma",
    "import": "import_",
    "measure": "measure",
    "modify": "modify",
    "patterns": "patterns",
    "phase": "phase",
    "simulate": "simulate",
    "train-correction": "train",
    "rig": "rig_check",
    "acceptance": "acceptance",
    "fit": "fit",
    "run": "run",
}


#: The entry-point group through which an installed package adds commands to ``hdrfringe``
#: (as xarray's backends register): ``name = "module:function"``, the function a typer command
#: (annotated parameters, its docstring the help) that runs under :func:`handle_errors`. The
#: group is read only for the command listing and for a name that is no product command; the
#: module is imported only when its command runs.
PLUGIN_GROUP = "hdrfringe.commands"
#: Commands another package provides -> where they come from and how to install it: without
#: that package, running the command prints this in one line (exit code 2).
PLUGIN_INSTALL: dict[str, str] = {
    "reproduce": "the research package hdrfringe-thesis (the thesis's experiments); install it "
    "from a clone of hdrfringe with `pip install -e research` (`make install` does)",
}
#: What ``--help`` lists for a command of :data:`PLUGIN_INSTALL` whose package is missing.
PLUGIN_LISTED = {"reproduce": "The thesis's experiments (not installed: hdrfringe-thesis)."}


@functools.cache
def plugin_commands() -> dict[str, str]:
    """The commands installed packages add (entry-point group :data:`PLUGIN_GROUP`): name ->
    ``"module:function"``; a product command's name is not taken over.

    Returns
    -------
    dict
        In name order; empty when no such package is installed.

    Examples
    --------
    >>> set(plugin_commands()) <= set(PLUGIN_INSTALL) | {"my-command"}
    True
    """
    from importlib.metadata import entry_points

    found = {ep.name: ep.value for ep in entry_points(group=PLUGIN_GROUP)}
    return {name: found[name] for name in sorted(found) if name not in COMMAND_MODULES}


def _command_names() -> list[str]:
    """Every command name: the product's (:data:`COMMAND_MODULES`), then the installed plug-ins'
    and those of :data:`PLUGIN_INSTALL` not installed, by name."""
    extra = set(plugin_commands()) | set(PLUGIN_INSTALL)
    return [*COMMAND_MODULES, *sorted(extra - set(COMMAND_MODULES))]


def _not_installed(name: str, reason: str | None = None) -> Any:
    """The stand-in for plug-in command ``name`` when its package is missing (or, with
    ``reason``, cannot be imported): whatever it is given, it says so in one line (exit code
    2); ``--help`` lists it."""
    where = PLUGIN_INSTALL.get(name, "its package")
    message = (
        f"`hdrfringe {name}` is not installed: it comes with {where}"
        if reason is None
        else f"`hdrfringe {name}` cannot be loaded ({reason}); reinstall {where}"
    )

    @handle_errors
    def run() -> None:
        raise InputError(message)

    return typer.core.TyperCommand(
        name=name,
        callback=run,
        help=PLUGIN_LISTED.get(name) if reason is None else f"Cannot be loaded: {reason}.",
        add_help_option=False,
        context_settings={"ignore_unknown_options": True, "allow_extra_args": True},
    )


class _LazyCommands(MutableMapping[str, Any]):
    """The click commands of :class:`LazyGroup` by name: a command's module is imported on
    first access; iteration lists every name (:func:`_command_names`) without importing."""

    def __init__(self, loaded: Mapping[str, Any], load: Callable[[str], Any]) -> None:
        self._loaded = dict(loaded)
        self._load = load

    def __getitem__(self, name: str) -> Any:
        if name not in self._loaded:
            if name not in COMMAND_MODULES and name not in _command_names():
                raise KeyError(name)
            self._loaded[name] = self._load(name)
        return self._loaded[name]

    def __setitem__(self, name: str, command: Any) -> None:
        self._loaded[name] = command

    def __delitem__(self, name: str) -> None:
        del self._loaded[name]

    def __iter__(self) -> Iterator[str]:
        names = _command_names()
        yield from names
        yield from (n for n in self._loaded if n not in names)

    def __len__(self) -> int:
        names = _command_names()
        return len(names) + sum(n not in names for n in self._loaded)

    def is_loaded(self, name: str) -> bool:
        """Whether the command ``name`` has been built (its module imported)."""
        return name in self._loaded


def _listed_command(name: str) -> Any:
    """A help-listing entry (name and help text) for command ``name``, read from its module's
    source with :mod:`ast`, or None when the source is not in the plain form this reads.

    Plain forms: a function decorated with ``@app.command()`` or ``@app.command("name")`` (no
    other argument), its docstring being the help; or ``app.add_typer(X, name="name")`` with
    ``X = typer.Typer(help="...", no_args_is_help=...)``; for a plug-in (:func:`plugin_commands`)
    the function its entry point names. Anything else (a help panel, hidden, deprecated, a short
    help) returns None and the module is imported instead.
    """
    import ast
    import importlib.util

    if name in COMMAND_MODULES:
        module, function = f"hdrfringe.cli.{COMMAND_MODULES[name]}", None
    elif name in plugin_commands():
        module, _, function = plugin_commands()[name].partition(":")
    else:
        return _not_installed(name) if name in PLUGIN_INSTALL else None
    try:
        spec = importlib.util.find_spec(module)
    except ImportError:  # a parent package missing
        spec = None
    if spec is None and function is not None:  # a plug-in whose module is gone
        return _not_installed(name, f"no module {module}")
    if spec is None or spec.origin is None:
        return None
    try:
        with open(spec.origin, encoding="utf-8") as f:
            tree = ast.parse(f.read())
    except (OSError, SyntaxError):
        return None
    typers: dict[str, str] = {}
    for node in tree.body:
        if function is not None:
            if isinstance(node, ast.FunctionDef) and node.name == function:
                return typer.core.TyperCommand(name=name, help=ast.get_docstring(node))
            continue
        if isinstance(node, ast.FunctionDef):
            for dec in node.decorator_list:
                if not (
                    isinstance(dec, ast.Call)
                    and isinstance(dec.func, ast.Attribute)
                    and isinstance(dec.func.value, ast.Name)
                    and dec.func.value.id == "app"
                    and dec.func.attr == "command"
                ):
                    continue
                if dec.keywords or len(dec.args) > 1:
                    return None
                if dec.args:
                    arg = dec.args[0]
                    if not (isinstance(arg, ast.Constant) and isinstance(arg.value, str)):
                        return None
                    declared = arg.value
                else:
                    declared = typer.main.get_command_name(node.name)
                if declared == name:
                    return typer.core.TyperCommand(name=name, help=ast.get_docstring(node))
        elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Call):
            call, target = node.value, node.targets[0]
            if (
                isinstance(target, ast.Name)
                and isinstance(call.func, ast.Attribute)
                and call.func.attr == "Typer"
                and not call.args
                and {k.arg for k in call.keywords} <= {"help", "no_args_is_help"}
            ):
                text = next((k.value for k in call.keywords if k.arg == "help"), None)
                if isinstance(text, ast.Constant) and isinstance(text.value, str):
                    typers[target.id] = text.value
        elif isinstance(node, ast.Expr) and isinstance(node.value, ast.Call):
            call = node.value
            if (
                isinstance(call.func, ast.Attribute)
                and call.func.attr == "add_typer"
                and isinstance(call.func.value, ast.Name)
                and call.func.value.id == "app"
                and len(call.args) == 1
                and isinstance(call.args[0], ast.Name)
                and call.args[0].id in typers
                and [k.arg for k in call.keywords] == ["name"]
                and isinstance(call.keywords[0].value, ast.Constant)
                and call.keywords[0].value.value == name
            ):
                return typer.core.TyperGroup(name=name, help=typers[call.args[0].id])
    return None


class LazyGroup(typer.core.TyperGroup):
    """The ``hdrfringe`` command group: a command's module is imported when the command is
    run, so ``hdrfringe phase`` pays for ``phase`` only; ``--help`` lists the commands from
    their modules' source without importing them.

    Examples
    --------
    >>> import typer.main
    >>> group = typer.main.get_command(app)
    >>> list(group.commands)[:3]
    ['calibrate', 'calibrate-stereo', 'compare']
    >>> group.commands["phase"].name
    'phase'
    """

    def __init__(self, **attrs: Any) -> None:
        super().__init__(**attrs)
        self.commands = _LazyCommands(self.commands, self._load)
        self._listing = False

    def format_help(self, ctx: Any, formatter: Any) -> None:
        """The group's help: commands not loaded yet are listed from their module's source
        (:func:`_listed_command`) without importing it."""
        self._listing = True
        try:
            super().format_help(ctx, formatter)
        finally:
            self._listing = False

    def list_commands(self, ctx: Any) -> list[str]:
        """Every command name, in registration order, without importing any module."""
        return list(self.commands)

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        """The command ``cmd_name`` (its module imported), or while the help is formatted a
        listing entry read from the module's source when that gives the same entry."""
        commands = self.commands
        if self._listing and isinstance(commands, _LazyCommands) and cmd_name in _command_names():
            if not commands.is_loaded(cmd_name):
                listed = _listed_command(cmd_name)
                if listed is not None:
                    return listed
        return commands.get(cmd_name)

    def _load(self, name: str) -> Any:
        opts: dict[str, Any] = {
            "pretty_exceptions_short": app.pretty_exceptions_short,
            "rich_markup_mode": app.rich_markup_mode,
        }
        if name not in COMMAND_MODULES:  # a plug-in (_LazyCommands checked the name)
            if name not in plugin_commands():
                return _not_installed(name)
            from typer.models import CommandInfo

            module, _, function = plugin_commands()[name].partition(":")
            try:
                callback = getattr(importlib.import_module(module), function)
            except (ImportError, AttributeError) as exc:  # a broken install: one line, exit 2
                return _not_installed(name, f"{type(exc).__name__}: {exc}")
            info = CommandInfo(name=name, callback=handle_errors(callback))
            return typer.main.get_command_from_info(info, **opts)
        importlib.import_module(f"hdrfringe.cli.{COMMAND_MODULES[name]}")
        for info in app.registered_commands:
            assert info.callback is not None
            if (info.name or typer.main.get_command_name(info.callback.__name__)) == name:
                return typer.main.get_command_from_info(info, **opts)
        for group in app.registered_groups:
            if group.name == name:
                return typer.main.get_group_from_info(
                    group, suggest_commands=app.suggest_commands, **opts
                )
        raise KeyError(name)  # pragma: no cover - COMMAND_MODULES names a missing command


app = typer.Typer(
    cls=LazyGroup,
    name="hdrfringe",
    help="3D surface measurement by phase-shifting fringe projection that copes with saturation.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
# --- the process's environment (issue 31; docs/safety.md, "Fault policy") -------------------
#: The smallest address-space limit (``ulimit -v``, MiB) under which a command is started: far
#: below it loading numpy, OpenCV and HDF5 fails (a library cannot be mapped, or OpenBLAS, out of
#: memory for its buffer, ends the process itself with exit 1), so the command refuses in one
#: line first. tests/test_fault_policy.py runs ``measure`` under 460 MiB and refuses below this.
MIN_ADDRESS_SPACE_MIB = 400


def columns() -> int | None:
    """``COLUMNS`` when it is a usable width (a positive integer), else None.

    Returns
    -------
    int or None

    Examples
    --------
    >>> old = os.environ.get("COLUMNS")
    >>> os.environ["COLUMNS"] = "0"
    >>> columns() is None
    True
    >>> os.environ["COLUMNS"] = "120"
    >>> columns()
    120
    >>> _ = os.environ.pop("COLUMNS") if old is None else os.environ.update(COLUMNS=old)
    """
    value = os.environ.get("COLUMNS", "").strip()
    return int(value) if value.isdigit() and int(value) > 0 else None


def working_directory_problem() -> str | None:
    """The one-line error for a working directory that no longer exists, else None.

    Relative paths cannot be resolved there (``os.getcwd`` fails), so a command refuses to
    start instead of failing half-way with a traceback.

    Returns
    -------
    str or None

    Examples
    --------
    >>> working_directory_problem() is None
    True
    """
    try:
        os.getcwd()
    except FileNotFoundError:
        pwd = os.environ.get("PWD", "the working directory")
        return (
            f"{pwd}: the working directory no longer exists (it was deleted or moved); cd to "
            "an existing folder and run the command again"
        )
    return None


def memory_limit_problem() -> str | None:
    """The one-line error for an address-space limit too small to start a command, else None.

    Under a limit (``ulimit -v``) the BLAS buffer is also taken now, while the process is
    small: OpenBLAS allocates it at its first use and ends the process (exit 1, no message of
    ours) when that fails, which a later, larger moment of the command would risk.

    Returns
    -------
    str or None

    Examples
    --------
    >>> memory_limit_problem() is None  # no limit, or a large one
    True
    """
    import resource

    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    if soft == resource.RLIM_INFINITY:
        return None
    if soft < MIN_ADDRESS_SPACE_MIB * 2**20:
        return (
            f"the address-space limit (ulimit -v) is {soft / 2**20:.0f} MiB, below the "
            f"{MIN_ADDRESS_SPACE_MIB} MiB hdrfringe needs to load numpy, OpenCV and HDF5; "
            "raise the limit"
        )
    import numpy as np

    np.dot(np.ones((256, 256)), np.ones((256, 256)))  # takes OpenBLAS's buffer now
    return None


#: Width of standard output when it is not a terminal (a log file, a pipe, CI): rich would take
#: 80 columns and cut the demo's tables to ellipses; COLUMNS, when exported, still sets it.
PIPE_WIDTH = 160


def _width(stream: Any, pipe_width: int | None) -> int | None:
    """The width a console on ``stream`` is given: None (rich's choice: COLUMNS, the
    terminal) where that is usable, else the terminal's or ``pipe_width``. ``COLUMNS=0`` or
    junk would make rich print in zero columns, i.e. nothing at all (issue 31)."""
    tty = stream is not None and stream.isatty()
    if columns() is not None or ("COLUMNS" not in os.environ and (tty or pipe_width is None)):
        return None
    fallback = pipe_width or 80
    return shutil.get_terminal_size((fallback, 24)).columns if tty else fallback


#: Exit code of a command whose standard output's reader went away (``| head -1``): the
#: shell's code for SIGPIPE, as a C tool killed by it gives (rich would say 1, a failure).
BROKEN_PIPE_EXIT_CODE = 141


class _Console(Console):
    """A rich console whose closed pipe ends the command quietly with
    :data:`BROKEN_PIPE_EXIT_CODE`."""

    def on_broken_pipe(self) -> None:
        """The reader of the stream went away: nothing more is written to it; stop."""
        with contextlib.suppress(OSError, ValueError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self.file.fileno())
        raise SystemExit(BROKEN_PIPE_EXIT_CODE)


console = _Console(width=_width(sys.stdout, PIPE_WIDTH))
err_console = _Console(stderr=True, soft_wrap=True, width=_width(sys.stderr, None))

F = TypeVar("F", bound=Callable[..., Any])


def _say_error(message: str) -> None:
    """Print ``error: message`` on one line of stderr; a stderr that cannot take it (closed,
    full, a closed pipe) is given up on silently: the exit code still tells."""
    msg = " ".join(message.split())
    # The message is user text (paths, regexes): escaped, so "[a-z]" prints verbatim.
    with contextlib.suppress(OSError, ValueError):
        err_console.print(f"[bold red]error:[/] {escape(msg)}", markup=True, highlight=False)


def _environment_error(exc: BaseException) -> HdrFringeError | None:
    """The one-line error for a fault of the user's environment raised outside a staged
    write (which names its output itself): an errno of the fault policy or memory."""
    if isinstance(exc, OSError) and exc.filename is not None:
        action = "write" if exc.errno in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT) else "use"
        return environment_fault(exc, exc.filename, action)
    if isinstance(exc, MemoryError) or (
        isinstance(exc, ImportError) and "failed to map segment" in str(exc)
    ):  # a library that cannot be mapped under an address-space limit
        return ResourceError(
            f"out of memory ({memory_note()}); free memory, raise the limit or use smaller images"
        )
    return None


def _stdout_failed() -> None:
    """Standard output refused the command's report: a reader that went away (``| head -1``)
    ends the command quietly with the shell's code for SIGPIPE, as a C tool would end; a full
    or broken device is said in one line (exit code 2). The output files are in place."""
    exc = sys.exc_info()[1]
    with contextlib.suppress(OSError, ValueError):  # nothing more goes to the dead stream
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    if isinstance(exc, BrokenPipeError):
        raise typer.Exit(code=BROKEN_PIPE_EXIT_CODE)
    reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
    code = errno.errorcode.get(exc.errno or 0, "?") if isinstance(exc, OSError) else "?"
    _say_error(
        f"standard output: cannot write: {reason} (errno {code}); the command's files were "
        "written, its report not: send standard output elsewhere"
    )
    raise typer.Exit(code=2)


def _say_stopped(stop: BaseException) -> None:
    """The line for a run stopped by a signal: nothing was written (outputs are staged), or,
    for a signal held during an output's final move (``io.results.InterruptedAfterWriting``,
    ``StoppedAfterWriting``), that the output is complete and where."""
    name = getattr(stop, "name", None)
    written = getattr(stop, "written", None)
    what = "interrupted" if name in (None, "SIGINT") else f"stopped by {name}"
    if written is not None:
        line = f"{what} once the output was in place: the complete output is at {written}"
    else:
        line = f"{what}: nothing was written"
    with contextlib.suppress(OSError, ValueError):
        err_console.print(escape(line), highlight=False)


def handle_errors(func: F) -> F:
    """Turn an HdrFringeError, and a fault of the user's environment (full disk, file size
    limit, quota, name length, permission, memory; docs/safety.md), into a one-line message and
    exit code 2, Ctrl-C into exit code 130; a signal-stopped run exits with the signal's code."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        problem = working_directory_problem() or memory_limit_problem()
        if problem is not None:
            _say_error(problem)
            raise typer.Exit(code=2)
        try:
            result = func(*args, **kwargs)
            with contextlib.suppress(AttributeError, ValueError):
                sys.stdout.flush()  # a broken pipe shows here if the report was buffered
            return result
        except HdrFringeError as exc:
            _say_error(str(exc))
            raise typer.Exit(code=getattr(exc, "exit_code", 2)) from None
        except KeyboardInterrupt as stop:  # Ctrl-C: nothing written (outputs are staged)
            # the shell's 130; a SIGTERM/SIGHUP turned into one (io.results.SignalStop): 143/129
            _say_stopped(stop)
            raise typer.Exit(code=getattr(stop, "exit_code", 130)) from None
        except SystemExit as stop:  # a signal's 143/129: after the final move, say so
            if getattr(stop, "written", None) is not None:
                _say_stopped(stop)
            raise
        except (OSError, MemoryError, ImportError) as exc:
            if isinstance(exc, OSError) and _is_stdout_error(exc):
                _stdout_failed()
            fault = _environment_error(exc)
            if fault is None:
                raise
            _say_error(str(fault))
            raise typer.Exit(code=2) from None

    return wrapper  # type: ignore[return-value]


def _is_stdout_error(exc: OSError) -> bool:
    """Whether ``exc`` was raised writing to standard output (a pipe closed by its reader, a
    full device): the report's write, not the command's files."""
    if isinstance(exc, BrokenPipeError):
        return True
    if exc.filename is not None:
        return False
    tb = exc.__traceback__
    while tb is not None:  # the console's write
        if tb.tb_frame.f_globals.get("__name__", "").startswith("rich."):
            return True
        tb = tb.tb_next
    try:  # a print(): what it could not write is still buffered
        sys.stdout.flush()
    except OSError:
        return True
    except (AttributeError, ValueError):
        pass
    return False


def _version_callback(value: bool) -> None:
    if value:
        from hdrfringe import __version__  # importlib.metadata: only for --version

        console.print(f"hdrfringe {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[
        bool,
        typer.Option(
            "--version",
            callback=_version_callback,
            is_eager=True,
            help="Print the version and exit.",
        ),
    ] = False,
) -> None:
    """hdrfringe: fringe patterns, virtual rig, phase, unwrapping and saturation avoidance."""


def progress_bar() -> Any:
    """A rich progress bar for long work (quiet when stderr is not a terminal)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err_console,
        transient=True,
        disable=not sys.stderr.isatty(),
    )


@contextlib.contextmanager
def progress_stage(label: str, total: int | None = None) -> Iterator[Callable[[], Any]]:
    """A task's long stage shown as a :func:`progress_bar` (the front end's side of
    :data:`hdrfringe.tasks._progress.Progress`).

    Parameters
    ----------
    label : str
        The bar's description.
    total : int or None
        Units of work (None: unknown).

    Yields
    ------
    callable
        ``advance()``: one unit done.
    """
    with progress_bar() as prog:
        task = prog.add_task(label, total=total)
        yield lambda: prog.advance(task)


def parse_floats(text: str, what: str) -> list[float]:
    """A comma-separated list of finite numbers (``8,64``) given for option ``what``."""
    try:
        vals = [float(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError:
        raise InputError(
            f"{what}: cannot read {text!r} as numbers; give a comma-separated list such as 8,64"
        ) from None
    if not vals:
        raise InputError(f"{what}: empty list; give at least one value")
    _check_finite(vals, text, what)
    return vals


def _check_finite(vals: list[float], text: str, what: str) -> None:
    bad = next((v for v in vals if not math.isfinite(v)), None)
    if bad is not None:
        shown = text if len(text) <= 40 else f"{text[:20]}...{text[-8:]}"
        raise InputError(f"{what}: {shown!r} holds {bad}; give finite numbers")


def parse_range(text: str, what: str, max_count: int = MAX_PROGRAM_FRAMES) -> list[float]:
    """``start:stop:step`` (stop included) or a comma-separated list.

    A range of more than ``max_count`` values is refused before it is built.
    """

    if ":" not in text:
        return parse_floats(text, what)
    try:
        start, stop, step = (float(v) for v in text.split(":"))
    except ValueError:
        raise InputError(
            f"{what}: cannot read {text!r}; use start:stop:step, e.g. 2:50:2"
        ) from None
    _check_finite([start, stop, step], text, what)
    if step != 0 and (stop - start) * step < 0:
        step = -step  # 255:60:1 means downwards
    if step == 0:
        raise InputError(f"{what}: {text!r} is an empty range; use e.g. 2:50:2 or 255:60:-5")
    count = float(np.floor((stop - start) / step + 1e-9)) + 1
    n = check_count(
        count, max_count, f"values in {what} {text}", fix="use a larger step or a shorter range"
    )
    return [round(start + i * step, 9) for i in range(n)]
