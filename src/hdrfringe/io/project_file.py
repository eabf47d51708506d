"""The project file (TOML) of ``hdrfringe run``: which stages run, on what, with which options.

A project file names the inputs once and holds, per stage, what that command's options hold
(docs/project_file.md; examples in ``docs/examples/*.toml``). :func:`load_project_file` reads
one with the bounded TOML reader and checks every table and key before anything runs: an
unknown table or key (with a did-you-mean), a value of the wrong type or range, a path that
does not exist, or options that contradict each other are refused with one line naming the
file, the table and the key.

Paths are relative to the project file's folder, or start with ``{name}/``: a root of the
``[paths]`` table (itself relative to the project file), which the environment variable
``HDRFRINGE_PATH_<NAME>`` replaces (relative to the working directory), e.g. the folder of the
real captures on another machine.
"""

from __future__ import annotations

import difflib
import hashlib
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hdrfringe.errors import InputError
from hdrfringe.io._read_limits import load_toml_bounded

__all__ = [
    "MAX_PROJECT_FILE_BYTES",
    "SCHEMA",
    "STAGES",
    "Key",
    "ProjectFile",
    "load_project_file",
    "parse_project",
]

#: Largest project file read (it holds paths and options).
MAX_PROJECT_FILE_BYTES = 64 << 10
DOC = "docs/project_file.md"
#: The stages in the order they run (each a table of the same name; a missing table: not run).
STAGES = ("import", "gamma", "phase", "calibrate", "calibrate_stereo", "measure")
#: Environment variable prefix that replaces a ``[paths]`` root (``HDRFRINGE_PATH_DATA``).
ENV_PREFIX = "HDRFRINGE_PATH_"


@dataclass(frozen=True)
class Key:
    """One key of a project file's table.

    Parameters
    ----------
    kind : str
        ``bool``, ``int``, ``float``, ``str``, ``harmonics``, ``file``, ``dir``, ``path`` (a
        file or a folder), ``dirs`` (a list of folders), ``int_pair``, ``range`` (two numbers,
        ``0 < a < b``), ``size`` (``"WxH"`` or ``[w, h]``), ``params`` (a table of numbers,
        strings and booleans).
    default : object
        The value when the key is left out (None: not given).
    required : bool
        The key must be given.
    choices : tuple of str
        The values a ``str`` key takes (empty: any).
    minimum : float or None
        Least value of an ``int`` or ``float`` key.
    help : str
        What the key is (docs/project_file.md lists it).

    Examples
    --------
    >>> Key("int", 21, minimum=1).default
    21
    """

    kind: str
    default: Any = None
    required: bool = False
    choices: tuple[str, ...] = ()
    minimum: float | None = None
    help: str = ""


_SATURATION = {
    "keep_saturated": Key("bool", False, help="keep the biased phase of saturated pixels"),
    "saturated": Key("str", "flag", choices=("flag", "exclude"), help="flag or exclude"),
    "min_shifts": Key("int", 3, minimum=3, help="with exclude: least unsaturated shifts"),
    "harmonics": Key("harmonics", "off", help="off, auto or a number of orders 1..8"),
    "uncertainty": Key("bool", True, help="write the predicted per-pixel std"),
    "noise_sigma": Key("float", minimum=0, help="camera noise std, DN (else estimated)"),
    "previews": Key("bool", True, help="a PNG preview beside every map"),
    "report": Key("bool", True, help="report.html and report.md (docs/report.md)"),
}
#: Every table and its keys (docs/project_file.md is this table in prose).
SCHEMA: dict[str, dict[str, Key]] = {
    "project": {"output": Key("out", help="the project's output folder")},
    "import": {
        "images": Key("dir", required=True, help="folder of camera images"),
        "description": Key("file", required=True, help="TOML import description"),
        "bit_depth": Key("int", minimum=1, help="camera bit depth (pattern manifest only)"),
        "crop_offset": Key("int_pair", help="[x0, y0] of cropped images"),
    },
    "gamma": {"captures": Key("dir", help="capture folder (default: the import's)")},
    "phase": {
        "captures": Key("dir", help="capture folder (default: the import's)"),
        "min_modulation": Key("float", minimum=0, help="least modulation I' of a valid pixel"),
        **_SATURATION,
        "map_dtype": Key("str", choices=("float32", "float64"), help="stored map precision"),
        "per_set_maps": Key("bool", False, help="also every set's maps"),
    },
    "calibrate": {
        "folders": Key("dirs", required=True, help="plate capture folders (or a folder of them)"),
        "model": Key("str", "linear", choices=("linear", "rational", "poly2", "poly3")),
        "window": Key("int", 21, minimum=1, help="filter window, px"),
        "border": Key("int", 10, minimum=0, help="unfiltered border, px"),
    },
    "calibrate_stereo": {
        "from": Key("path", help="a calibration to convert"),
        "poses": Key("dirs", help="board pose capture folders"),
        "rig": Key("str", choices=("sim",), help="the virtual calibration rig"),
        "board": Key("str", help="PATTERN:COLSxROWS:SPACING_MM"),
        "pose_count": Key("int", 10, minimum=1, help="with rig = sim: board poses"),
        "noise": Key("float", 1.0, minimum=0, help="with rig = sim: read noise, 8-bit levels"),
        "seed": Key("int", 0, minimum=0, help="with rig = sim: noise seed"),
        "window": Key("int", 12, minimum=1, help="local homography half window, camera px"),
        "min_valid": Key("float", minimum=0, help="least fraction of a window's valid pixels"),
        "distortion": Key("str", "standard", choices=("standard", "radial", "none", "full")),
        "fix_intrinsics": Key("bool", False, help="keep the separate intrinsics"),
        "camera_size": Key("size", help="with from: camera WIDTHxHEIGHT"),
        "projector_size": Key("size", help="with from: projector WIDTHxHEIGHT"),
    },
    "measure": {
        "captures": Key("dir", help="capture folder (default: the import's)"),
        "calibration": Key("file", help="calibration file (default: the calibrate stage's)"),
        "strategy": Key("str", help="saturation strategy (the folder is a MIGL sweep)"),
        "strategy_params": Key("params", help="the strategy's parameters by field name"),
        "stereo_directions": Key("str", "auto", choices=("auto", "u", "v")),
        "depth_range_mm": Key("range", help="[zmin, zmax] for fringe orders from the geometry"),
        "mesh": Key("str", "none", choices=("none", "ply", "stl"), help="the grid mesh's file"),
        "remove_outliers": Key("bool", False, help="leave statistical outliers out of the cloud"),
        **_SATURATION,
    },
}


@dataclass(frozen=True)
class ProjectFile:
    """A checked project file (:func:`load_project_file`).

    Parameters
    ----------
    source : Path
        The file.
    sha256 : str
        Digest of its bytes.
    output : Path or None
        ``[project] output``, resolved (None: not given).
    roots : mapping
        The ``[paths]`` roots, resolved.
    tables : mapping
        Stage name -> its checked options (every key of :data:`SCHEMA`, defaults filled in,
        paths resolved), for the stages the file has, in :data:`STAGES` order.

    Examples
    --------
    >>> p = parse_project({"measure": {"captures": "."}}, Path("p.toml"))
    >>> list(p.tables), p.tables["measure"]["stereo_directions"], p.tables["measure"]["captures"]
    (['measure'], 'auto', PosixPath('.'))
    """

    source: Path
    sha256: str = ""
    output: Path | None = None
    roots: Mapping[str, Path] = field(default_factory=dict)
    tables: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)


def _fail(where: str, table: str, key: str, what: str, fix: str = "fix it") -> InputError:
    at = f"[{table}] '{key}'" if key else f"[{table}]"
    return InputError(f"{where}: {at} {what}; {fix} ({DOC})")


def _unknown(name: str, known: Any, where: str, table: str, what: str) -> InputError:
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    hint = f"did you mean '{close[0]}'?" if close else f"known: {', '.join(known)}"
    if table:
        return _fail(where, table, name, f"is not a key of {what}", hint)
    return InputError(f"{where}: [{name}] is not a table of a project file; {hint} ({DOC})")


def _normal(path: Path) -> Path:
    """``path`` with ``.`` and ``dir/..`` removed (``docs/examples/../../build`` -> ``build``),
    as the shell reads them when the folders are not symbolic links."""
    return Path(os.path.normpath(path))


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


class _Checker:
    """Checks the values of one project file; paths resolved against its folder and roots."""

    def __init__(self, where: str, base: Path, roots: Mapping[str, Path]) -> None:
        self.where, self.base, self.roots = where, base, roots

    def path(self, value: Any, table: str, key: str) -> Path:
        if not isinstance(value, str) or not value.strip():
            raise _fail(self.where, table, key, f"must be a path (a string), got {_short(value)}")
        if value.startswith("{"):
            name, sep, rest = value[1:].partition("}")
            if not sep or name not in self.roots:
                known = ", ".join("{" + r + "}" for r in self.roots) or "none"
                raise _fail(
                    self.where, table, key, f"starts with an unknown root {value.split('/')[0]!r}",
                    f"name a root of [paths] (defined: {known})",
                )  # fmt: skip
            return _normal(self.roots[name] / rest.lstrip("/"))
        p = Path(value).expanduser()
        return _normal(p if p.is_absolute() else self.base / p)

    def existing(self, value: Any, table: str, key: str, kind: str) -> Path:
        p = self.path(value, table, key)
        ok = {"file": p.is_file(), "dir": p.is_dir(), "path": p.exists()}[kind]
        if not ok:
            what = {"file": "a file", "dir": "a folder", "path": "a file or folder"}[kind]
            fix = "check the path (relative to the project file's folder or a [paths] root)"
            raise _fail(self.where, table, key, f"{p} is not {what} that exists", fix)
        return p

    def number(self, value: Any, spec: Key, table: str, key: str) -> float | int:
        integer = spec.kind == "int"
        ok = not isinstance(value, bool) and isinstance(value, int if integer else int | float)
        if not ok or not math.isfinite(value):
            what = "an integer" if integer else "a finite number"
            raise _fail(self.where, table, key, f"must be {what}, got {_short(value)}")
        if spec.minimum is not None and value < spec.minimum:
            raise _fail(self.where, table, key, f"must be >= {spec.minimum:g}, got {value!r}")
        return int(value) if integer else float(value)

    def value(self, value: Any, spec: Key, table: str, key: str) -> Any:
        kind = spec.kind
        if kind == "bool":
            if not isinstance(value, bool):
                raise _fail(self.where, table, key, f"must be true or false, got {_short(value)}")
            return value
        if kind in ("int", "float"):
            return self.number(value, spec, table, key)
        if kind == "str":
            if not isinstance(value, str) or (spec.choices and value not in spec.choices):
                what = f"one of {', '.join(spec.choices)}" if spec.choices else "a string"
                raise _fail(self.where, table, key, f"must be {what}, got {_short(value)}")
            return value
        if kind == "harmonics":
            return self.harmonics(value, table, key)
        if kind in ("file", "dir", "path"):
            return self.existing(value, table, key, kind)
        if kind == "out":
            return self.path(value, table, key)
        if kind == "dirs":
            if not isinstance(value, list) or not value:
                raise _fail(
                    self.where, table, key, f"must be a list of folders, got {_short(value)}"
                )
            return tuple(self.existing(v, table, key, "dir") for v in value)
        return self.compound(value, kind, table, key)

    def harmonics(self, value: Any, table: str, key: str) -> str:
        from hdrfringe.core.harmonics import harmonics_mode

        try:
            harmonics_mode(value)
        except InputError:
            raise _fail(
                self.where, table, key, f"must be off, auto or 1..8, got {_short(value)}"
            ) from None
        return str(value)

    def compound(self, value: Any, kind: str, table: str, key: str) -> Any:
        if kind == "params":
            if not isinstance(value, Mapping) or not all(
                isinstance(v, bool | int | float | str) for v in value.values()
            ):
                raise _fail(self.where, table, key, "must be a table of numbers, strings or "
                            f"booleans, got {_short(value)}")  # fmt: skip
            return dict(value)
        if kind == "size" and isinstance(value, str):
            value = value.lower().split("x")
            try:
                value = [int(v) for v in value]
            except ValueError:
                value = None
        two = isinstance(value, list) and len(value) == 2
        ints = two and all(isinstance(v, int) and not isinstance(v, bool) for v in value)
        nums = two and all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for v in value
        )
        if kind == "int_pair" and ints:
            return (int(value[0]), int(value[1]))
        if kind == "size" and ints and min(value) >= 1:
            return (int(value[0]), int(value[1]))
        if kind == "range" and nums and 0 < value[0] < value[1]:
            return (float(value[0]), float(value[1]))
        what = {
            "int_pair": "a list of two integers [x0, y0]",
            "size": 'WIDTHxHEIGHT ("1024x768" or [1024, 768])',
            "range": "[zmin, zmax] in mm with 0 < zmin < zmax",
        }[kind]
        raise _fail(self.where, table, key, f"must be {what}, got {_short(value)}")


def _roots(table: Any, where: str, base: Path) -> dict[str, Path]:
    """The ``[paths]`` roots: relative to the file's folder, or the environment's override."""
    if not isinstance(table, Mapping):
        raise _fail(where, "paths", "", f"must be a table, got {_short(table)}", "write [paths]")
    roots = {}
    for name, value in table.items():
        env = os.environ.get(ENV_PREFIX + name.upper())
        if env:
            roots[name] = Path(env).expanduser().absolute()
            continue
        if not isinstance(value, str) or not value.strip():
            raise _fail(where, "paths", name, f"must be a path (a string), got {_short(value)}")
        p = Path(value).expanduser()
        roots[name] = _normal(p if p.is_absolute() else base / p)
    return roots


def _check_table(data: Mapping[str, Any], table: str, check: _Checker) -> dict[str, Any]:
    value = data[table]
    if not isinstance(value, Mapping):
        raise _fail(check.where, table, "", f"must be a table, got {_short(value)}",
                    f"write it as [{table}]")  # fmt: skip
    schema = SCHEMA[table]
    for key in value:
        if key not in schema:
            raise _unknown(key, schema, check.where, table, f"[{table}]")
    out: dict[str, Any] = {}
    for key, spec in schema.items():
        if key in value:
            out[key] = check.value(value[key], spec, table, key)
        elif spec.required:
            raise _fail(check.where, table, key, "is missing", "add it")
        else:
            out[key] = spec.default
    return out


def _check_together(tables: Mapping[str, Mapping[str, Any]], where: str) -> None:
    """Options that contradict each other, or a stage without its input."""
    if not tables:
        raise InputError(f"{where}: no stage to run; add at least one of "
                         f"{', '.join('[' + s + ']' for s in STAGES)} ({DOC})")  # fmt: skip
    if "calibrate" in tables and "calibrate_stereo" in tables:
        raise _fail(where, "calibrate_stereo", "", "and [calibrate] are both given",
                    "keep the one calibration the measurement uses")  # fmt: skip
    for stage in ("gamma", "phase", "measure"):
        if stage in tables and tables[stage]["captures"] is None and "import" not in tables:
            raise _fail(where, stage, "captures", "is missing (and there is no [import])",
                        "give the capture folder or add an [import] table")  # fmt: skip
    for stage in ("phase", "measure"):
        if stage in tables:
            _check_decoder(tables[stage], stage, where)
    if "measure" in tables:
        m = tables["measure"]
        calibrated = "calibrate" in tables or "calibrate_stereo" in tables
        if m["calibration"] is not None and calibrated:
            raise _fail(where, "measure", "calibration", "is given and a calibration stage "
                        "runs", "drop one of them")  # fmt: skip
        if m["depth_range_mm"] is not None and m["calibration"] is None and not calibrated:
            raise _fail(where, "measure", "depth_range_mm", "needs a stereo calibration",
                        "add [calibrate_stereo] or [measure] calibration")  # fmt: skip
        if m["strategy_params"] and m["strategy"] is None:
            raise _fail(where, "measure", "strategy_params", "is given without a strategy",
                        "add strategy = \"...\" or drop it")  # fmt: skip
    if "calibrate_stereo" in tables:
        _check_stereo(tables["calibrate_stereo"], where)


def _check_decoder(t: Mapping[str, Any], table: str, where: str) -> None:
    """The saturation, precision and noise options as ``phase`` and ``measure`` check them."""
    if t["saturated"] == "exclude" and t["keep_saturated"]:
        raise _fail(where, table, "keep_saturated", "and saturated = \"exclude\" contradict "
                    "each other", "give one of them")  # fmt: skip
    if t["saturated"] == "flag" and t["min_shifts"] != 3:
        raise _fail(where, table, "min_shifts", "applies to saturated = \"exclude\"",
                    "add it or drop min_shifts")  # fmt: skip
    if t["harmonics"] != "off" and t["saturated"] == "exclude":
        raise _fail(where, table, "harmonics", "does not apply to saturated = \"exclude\"",
                    "drop one of them")  # fmt: skip
    if t["noise_sigma"] is not None and not t["uncertainty"]:
        raise _fail(where, table, "noise_sigma", "is for the predicted std",
                    "drop it or set uncertainty = true")  # fmt: skip
    if t.get("map_dtype") == "float32" and t["saturated"] != "flag":
        raise _fail(where, table, "map_dtype", "float32 applies to saturated = \"flag\"",
                    "drop one of them")  # fmt: skip


def _check_stereo(t: Mapping[str, Any], where: str) -> None:
    sources = [k for k in ("from", "poses", "rig") if t[k] is not None]
    if len(sources) != 1:
        raise _fail(where, "calibrate_stereo", "from", f"gives {len(sources)} sources",
                    "give exactly one of from, poses or rig")  # fmt: skip
    if t["from"] is None and t["board"] is None:
        raise _fail(where, "calibrate_stereo", "board", "is missing",
                    "give PATTERN:COLSxROWS:SPACING_MM, e.g. checkerboard:9x6:25")  # fmt: skip
    if t["min_valid"] is not None and not 0 < t["min_valid"] <= 1:
        raise _fail(where, "calibrate_stereo", "min_valid", "must be a fraction in (0, 1]")


def parse_project(data: Mapping[str, Any], source: Path, sha256: str = "") -> ProjectFile:
    """Check a table parsed from a project file's TOML.

    Parameters
    ----------
    data : mapping
        The parsed document.
    source : Path
        The file (messages name it; relative paths are relative to its folder).
    sha256 : str
        Digest of the file's bytes.

    Returns
    -------
    ProjectFile

    Raises
    ------
    InputError
        One line naming the file, the table and the key.

    Examples
    --------
    >>> parse_project({"phase": {"previews": "no", "captures": "."}}, Path("p.toml"))
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: p.toml: [phase] 'previews' must be true or false, got 'no'; ...
    """
    where, base = str(source), source.parent
    for name, value in data.items():
        if name not in (*SCHEMA, "paths"):
            if not isinstance(value, Mapping):
                raise InputError(f"{where}: '{name}' is a key outside any table; put it in its "
                                 f"table, e.g. [project] output = \"...\" ({DOC})")  # fmt: skip
            raise _unknown(name, [*SCHEMA, "paths"], where, "", "")
    check = _Checker(where, base, _roots(data.get("paths", {}), where, base))
    output = None
    if "project" in data:
        output = _check_table(data, "project", check)["output"]
    tables = {s: _check_table(data, s, check) for s in STAGES if s in data}
    _check_together(tables, where)
    return ProjectFile(source, sha256, output, check.roots, tables)


def load_project_file(path: str | Path) -> ProjectFile:
    """Read and check a project file (TOML).

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file (docs/project_file.md).

    Returns
    -------
    ProjectFile
        With ``sha256`` of the bytes parsed.

    Raises
    ------
    InputError
        A missing, oversized or non-TOML file, or any table or key the checks refuse
        (:func:`parse_project`).

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "project.toml"
    >>> _ = p.write_text('[paths]\\ndata = "."\\n[measure]\\ncaptures = "{data}"\\n'
    ...                  'stereo_directions = "v"\\n')
    >>> load_project_file(p).tables["measure"]["captures"] == p.parent
    True
    >>> _ = p.write_text('[measure]\\ncaptures = "."\\nstereo_direction = "v"\\n')
    >>> load_project_file(p)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: ...: [measure] 'stereo_direction' is not a key of [measure]; ...
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path}: is a folder, not a project file; give the TOML file ({DOC})")
    hasher = hashlib.sha256()
    table = load_toml_bounded(
        path,
        what="project",
        max_bytes=MAX_PROJECT_FILE_BYTES,
        holds="holds paths and options",
        doc=DOC,
        missing=f"give the project's TOML file ({DOC}, docs/examples/)",
        on_bytes=hasher.update,
    )
    return parse_project(table, path, hasher.hexdigest())
