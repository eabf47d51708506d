"""Resumable parameter sweeps on dask.distributed, stored as a labelled xarray Dataset in Zarr.

A sweep is a grid of named dimensions with coordinate values (:class:`SweepGrid`) and a task
function that computes one **block** of it: every cell along the grid's *block dims* for one
coordinate of each other dim (the *split dims*). The block is the unit of work, of storage
and of resumption:

* the task runs on a dask worker: ``func(block_coords, params) -> {variable: array}``, a
  plain top-level function, deterministic (seeds come from the coordinates);
* the driver (the process calling :func:`run_sweep`) is the store's only writer. It writes
  each finished block's variables (one Zarr chunk per variable: chunks are aligned to blocks)
  and then the block's flag in ``block_done``; a crash between the two costs one
  recomputation, never a wrong cell;
* a rerun opens the store, checks that it was made by the same grid, function, parameters and
  package version (its *fingerprint*), and submits only the blocks not done.

Each chunk file is replaced atomically (zarr >= 3.1.3 writes a temporary file and renames it),
a Ctrl-C is held back while a block is being written, and the store itself is created in a
temporary sibling folder and renamed into place: an interrupted run, a killed worker or a
killed driver leave a valid store that a rerun completes. research/docs/reproduction.md
describes the layout.
"""

from __future__ import annotations

import contextlib
import datetime
import hashlib
import itertools
import json
import logging
import math
import os
import shutil
import signal
import sys
import threading
import time
import uuid
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.errors import HdrFringeError, InputError

if TYPE_CHECKING:
    import xarray as xr
    import zarr
    from dask.distributed import Client
    from rich.progress import Progress

__all__ = [
    "DONE_VAR",
    "LOG_EVERY_S",
    "PARTIAL_INFIX",
    "RUNTIME_ATTRS",
    "SCHEDULER_TIMEOUT_S",
    "WORKER_ENV",
    "WORKER_ENV_KEY",
    "ZARR_FORMAT",
    "BlockFunc",
    "Coord",
    "SweepError",
    "SweepGrid",
    "SweepStatus",
    "Variable",
    "check_scheduler",
    "open_results",
    "run_sweep",
    "sweep_identity",
    "sweep_status",
]

log = logging.getLogger(__name__)

#: Name of the per-block flag variable (dims: the split dims; 1 once the block is stored).
DONE_VAR = "block_done"
#: Dataset attributes that record when the store was made (differ between identical sweeps).
RUNTIME_ATTRS: tuple[str, ...] = ("sweep_created",)
#: Seconds between progress lines on the ``hdrfringe_thesis.engine`` logger (INFO): the
#: record of a run that has no terminal for the progress bar (a batch job, nohup).
LOG_EVERY_S = 30.0
#: Store format written: Zarr v3 (zarr-python >= 3.1.3 for atomic chunk writes).
ZARR_FORMAT = 3

Coord = int | float | str
#: ``func(block_coords, params) -> {variable name: array shaped like the block}``.
BlockFunc = Callable[[dict[str, Any], dict[str, Any]], Mapping[str, Any]]


class SweepError(HdrFringeError):
    """A block of a sweep failed or returned unusable output; finished blocks stay stored."""


# --------------------------------------------------------------------------- grid description


def _coord_values(what: str, values: Sequence[Any]) -> tuple[Coord, ...]:
    """Validate and normalise coordinate values: all strings or all finite real numbers."""
    if isinstance(values, str | bytes) or not isinstance(values, Sequence | np.ndarray):
        raise InputError(
            f"{what}: coordinates must be a list of numbers or strings, got {values!r}"
        )
    out: list[Coord] = []
    for v in values:
        if isinstance(v, np.generic):
            v = v.item()
        if isinstance(v, bool) or not isinstance(v, int | float | str):
            raise InputError(f"{what}: coordinate {v!r} is not a number or a string")
        if isinstance(v, float) and not math.isfinite(v):
            raise InputError(f"{what}: coordinate {v!r} is not finite")
        out.append(v)
    if not out:
        raise InputError(f"{what}: needs at least one coordinate value")
    if len({isinstance(v, str) for v in out}) > 1:
        raise InputError(f"{what}: mixes strings and numbers; use one kind per dimension")
    if len(set(out)) != len(out):
        raise InputError(f"{what}: coordinate values repeat: {list(out)}")
    return tuple(out)


def _coord_array(values: Sequence[Coord]) -> NDArray[Any]:
    """Coordinate values as stored: numbers as int64/float64, strings as variable-length."""
    if isinstance(values[0], str):
        return np.array(values, dtype=object)  # Zarr v3 "string" (vlen-utf8), a specified type
    return np.asarray(values)


@dataclass(frozen=True)
class Variable:
    """One output variable of a sweep.

    Parameters
    ----------
    name : str
        Variable name in the Dataset.
    dtype : str
        NumPy dtype name: a float (missing cells are NaN), a signed or unsigned integer, or
        ``"bool"``.
    extra_dims : mapping of str to sequence
        Trailing dimensions of this variable that are not swept (e.g. ``{"shift": [1, 2, 3]}``),
        with their coordinates; a task returns them whole.
    fill : int, float, bool or None
        Value of cells not computed yet: NaN for floats (the only choice), required for
        integers, ``False`` by default for bool.
    attrs : mapping
        Attributes of the variable (e.g. ``{"units": "mm"}``); JSON values only.
    """

    name: str
    dtype: str = "float64"
    extra_dims: Mapping[str, Sequence[Coord]] = field(default_factory=dict)
    fill: int | float | bool | None = None
    attrs: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InputError(f"variable name must be a non-empty string, got {self.name!r}")
        try:
            dt = np.dtype(self.dtype)
        except TypeError:
            raise InputError(f"variable {self.name!r}: unknown dtype {self.dtype!r}") from None
        fill = self.fill
        if dt.kind == "f":
            if fill is not None and not (isinstance(fill, float) and math.isnan(fill)):
                raise InputError(
                    f"variable {self.name!r}: a float variable is filled with NaN, not {fill!r}"
                )
            fill = math.nan
        elif dt.kind in "iu":
            if isinstance(fill, bool) or not isinstance(fill, int | np.integer):
                raise InputError(
                    f"variable {self.name!r}: an integer variable needs fill=<int> for the "
                    "cells not computed yet (e.g. fill=-1)"
                )
            fill = int(fill)
            if not np.can_cast(np.min_scalar_type(fill), dt):
                raise InputError(f"variable {self.name!r}: fill {fill} does not fit {dt.name}")
        elif dt.kind == "b":
            fill = bool(fill) if fill is not None else False
        else:
            raise InputError(
                f"variable {self.name!r}: dtype {dt.name} is not supported; use a float, an "
                "integer or bool"
            )
        extra = {
            str(k): _coord_values(f"variable {self.name!r} extra dim {k!r}", v)
            for k, v in dict(self.extra_dims).items()
        }
        object.__setattr__(self, "dtype", dt.name)
        object.__setattr__(self, "fill", fill)
        object.__setattr__(self, "extra_dims", extra)
        object.__setattr__(self, "attrs", dict(self.attrs))

    def to_json(self) -> dict[str, Any]:
        """Plain-JSON description (order kept), part of :meth:`SweepGrid.to_json`.

        Returns
        -------
        dict
            ``name``, ``dtype``, ``extra_dims`` (a list of ``[dim, coordinates]`` pairs),
            ``fill`` and ``attrs``.

        Examples
        --------
        >>> Variable("sets", dtype="int16", fill=-1).to_json()
        {'name': 'sets', 'dtype': 'int16', 'extra_dims': [], 'fill': -1, 'attrs': {}}
        """
        return {
            "name": self.name,
            "dtype": self.dtype,
            "extra_dims": [[k, list(v)] for k, v in self.extra_dims.items()],
            "fill": self.fill,
            "attrs": dict(self.attrs),
        }


@dataclass(frozen=True)
class SweepGrid:
    """The grid of a sweep: dimensions, output variables and the block layout.

    Parameters
    ----------
    dims : mapping of str to sequence
        Ordered dimensions and their coordinate values (numbers or strings); the variables'
        dims follow this order, then their ``extra_dims``.
    variables : sequence of Variable
        The outputs of the task function.
    block_dims : sequence of str
        Dims that one task computes together (whole, every coordinate); each task gets one
        coordinate of every other dim (the *split dims*). Empty: one task per cell.
    attrs : mapping
        Attributes of the Dataset (JSON values), e.g. a description.

    Examples
    --------
    >>> grid = SweepGrid(
    ...     dims={"pattern": ["sin", "tri"], "pitch": [6, 8], "migl": [255.0, 205.0]},
    ...     variables=[Variable("rmse_mm")],
    ...     block_dims=["migl"],
    ... )
    >>> grid.n_blocks, grid.block_shape(grid.variables[0])
    (4, (2,))
    """

    dims: Mapping[str, Sequence[Coord]]
    variables: Sequence[Variable]
    block_dims: Sequence[str] = ()
    attrs: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        dims = {str(k): _coord_values(f"dim {k!r}", v) for k, v in dict(self.dims).items()}
        if not dims:
            raise InputError("a sweep grid needs at least one dimension")
        block = tuple(self.block_dims)
        unknown = [d for d in block if d not in dims]
        if unknown or len(set(block)) != len(block):
            raise InputError(
                f"block_dims {list(block)} must be distinct names among the dims {list(dims)}"
            )
        variables = tuple(self.variables)
        if not variables or not all(isinstance(v, Variable) for v in variables):
            raise InputError("a sweep grid needs at least one Variable in variables")
        names = [v.name for v in variables]
        if len(set(names)) != len(names):
            raise InputError(f"variable names repeat: {names}")
        taken = set(dims) | {DONE_VAR}
        extra: dict[str, Sequence[Coord]] = {}
        for v in variables:
            if v.name in taken:
                raise InputError(
                    f"variable name {v.name!r} is taken by a dim or the engine's {DONE_VAR!r}"
                )
            for d, vals in v.extra_dims.items():
                if d in dims or d in names or d == DONE_VAR:
                    raise InputError(f"variable {v.name!r}: extra dim {d!r} clashes with a name")
                if extra.setdefault(d, vals) != vals:
                    raise InputError(f"extra dim {d!r} has different coordinates in two variables")
        # Blocks follow the grid's dim order whatever order block_dims was given in.
        block = tuple(d for d in dims if d in block)
        attrs = dict(self.attrs)
        clash = [k for k in attrs if k.startswith("sweep_") or k == "hdrfringe_version"]
        if clash:
            raise InputError(f"grid attrs {clash} use names reserved for the engine")
        object.__setattr__(self, "dims", dims)
        object.__setattr__(self, "block_dims", block)
        object.__setattr__(self, "variables", variables)
        object.__setattr__(self, "attrs", attrs)

    @property
    def split_dims(self) -> tuple[str, ...]:
        """Dims with one coordinate per block, in grid order."""
        return tuple(d for d in self.dims if d not in self.block_dims)

    @property
    def blocks_shape(self) -> tuple[int, ...]:
        """Number of blocks along each split dim (the shape of ``block_done``)."""
        return tuple(len(self.dims[d]) for d in self.split_dims)

    @property
    def n_blocks(self) -> int:
        """Number of blocks, i.e. of tasks (1 when every dim is a block dim)."""
        return math.prod(self.blocks_shape)

    def block_indices(self) -> Iterator[tuple[int, ...]]:
        """Every block's position along the split dims, in grid order."""
        return itertools.product(*(range(n) for n in self.blocks_shape))

    def block_coords(self, index: Sequence[int]) -> dict[str, Any]:
        """What a task gets: each split dim's coordinate, each block dim's tuple of them."""
        pos = dict(zip(self.split_dims, index, strict=True))
        return {
            d: (vals if d in self.block_dims else vals[pos[d]]) for d, vals in self.dims.items()
        }

    def split_coords(self, index: Sequence[int]) -> dict[str, Coord]:
        """The coordinates that name a block: one per split dim."""
        return {d: self.dims[d][i] for d, i in zip(self.split_dims, index, strict=True)}

    def block_shape(self, var: Variable) -> tuple[int, ...]:
        """Shape of ``var`` in one block: the block dims in grid order, then its extra dims."""
        return (
            *(len(self.dims[d]) for d in self.block_dims),
            *(len(v) for v in var.extra_dims.values()),
        )

    def chunks(self, var: Variable) -> tuple[int, ...]:
        """Zarr chunk shape of ``var``: exactly one block."""
        return (
            *(len(v) if d in self.block_dims else 1 for d, v in self.dims.items()),
            *(len(v) for v in var.extra_dims.values()),
        )

    def selection(self, index: Sequence[int], var: Variable) -> tuple[int | slice, ...]:
        """Where a block of ``var`` goes in the full array."""
        pos = dict(zip(self.split_dims, index, strict=True))
        return (
            *(slice(None) if d in self.block_dims else pos[d] for d in self.dims),
            *(slice(None) for _ in var.extra_dims),
        )

    def to_json(self) -> dict[str, Any]:
        """Plain-JSON description (order kept), stored in the Dataset and fingerprinted."""
        return {
            "dims": [[d, list(v)] for d, v in self.dims.items()],
            "block_dims": list(self.block_dims),
            "variables": [v.to_json() for v in self.variables],
            "attrs": dict(self.attrs),
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> SweepGrid:
        """Inverse of :meth:`to_json`."""
        return cls(
            dims={d: v for d, v in data["dims"]},
            variables=[
                Variable(
                    name=v["name"],
                    dtype=v["dtype"],
                    extra_dims={d: vals for d, vals in v["extra_dims"]},
                    fill=v["fill"],
                    attrs=v["attrs"],
                )
                for v in data["variables"]
            ],
            block_dims=data["block_dims"],
            attrs=data["attrs"],
        )


# --------------------------------------------------------------------------- fingerprint


def _jsonable(value: Any, where: str) -> Any:
    """``value`` as plain JSON types (numpy scalars and arrays, tuples converted)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value
    if isinstance(value, Mapping):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise InputError(f"sweep params{where}: key {k!r} is not a string")
            out[k] = _jsonable(v, f"{where}[{k!r}]")
        return out
    if isinstance(value, list | tuple):
        return [_jsonable(v, f"{where}[{i}]") for i, v in enumerate(value)]
    raise InputError(
        f"sweep params{where}: {type(value).__name__} is not JSON (numbers, strings, lists, "
        "dicts); pass plain values, e.g. a setup's to_dict()"
    )


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=True)


def _function_name(func: BlockFunc) -> str:
    module = getattr(func, "__module__", None)
    qualname = getattr(func, "__qualname__", None)
    if not callable(func) or not module or not qualname or "<" in qualname:
        raise InputError(
            f"the sweep's task must be a top-level function (picklable by name), got {func!r}"
        )
    return f"{module}:{qualname}"


def sweep_identity(grid: SweepGrid, func: BlockFunc, params: Mapping[str, Any]) -> dict[str, str]:
    """The attributes that identify a sweep, with their fingerprint.

    Parameters
    ----------
    grid : SweepGrid
        The sweep's grid.
    func : callable
        The task function: a top-level function (recorded by ``module:qualname``).
    params : mapping
        The settings passed to every task (JSON values: numbers, strings, lists, dicts; numpy
        scalars and arrays are converted).

    Returns
    -------
    dict
        ``sweep_grid`` and ``sweep_params`` (canonical JSON), ``sweep_function``
        (``module:qualname``), ``hdrfringe_version`` and ``sweep_fingerprint``, the SHA-256 of
        all four. A store is resumed only by a sweep with the same fingerprint.

    Raises
    ------
    InputError
        If ``func`` is not a top-level function or ``params`` holds a value that is not JSON.

    Examples
    --------
    >>> def task(coords, params):
    ...     return {"rmse_mm": np.full(len(coords["migl"]), params["seed"] * 0.1)}
    >>> grid = SweepGrid({"pitch": [6, 8], "migl": [255.0, 205.0]}, [Variable("rmse_mm")], ["migl"])
    >>> a = sweep_identity(grid, task, {"seed": 0})
    >>> a["sweep_function"], len(a["sweep_fingerprint"])
    ('hdrfringe_thesis.engine:task', 64)
    >>> a == sweep_identity(grid, task, {"seed": 0}), a == sweep_identity(grid, task, {"seed": 1})
    (True, False)
    """
    from hdrfringe import __version__

    ident = {
        "sweep_grid": _canonical(grid.to_json()),
        "sweep_params": _canonical(_jsonable(dict(params), "")),
        "sweep_function": _function_name(func),
        "hdrfringe_version": __version__,
    }
    ident["sweep_fingerprint"] = hashlib.sha256(_canonical(ident).encode()).hexdigest()
    return ident


def _identity_differences(stored: Mapping[str, Any], new: Mapping[str, str]) -> str:
    parts = []
    if stored.get("sweep_grid") != new["sweep_grid"]:
        parts.append("grid")
    if stored.get("sweep_params") != new["sweep_params"]:
        try:
            old_p, new_p = json.loads(stored["sweep_params"]), json.loads(new["sweep_params"])
            keys = sorted(k for k in old_p.keys() | new_p.keys() if old_p.get(k) != new_p.get(k))
            parts.append(f"params ({', '.join(keys)})")
        except (KeyError, TypeError, ValueError):
            parts.append("params")
    if stored.get("sweep_function") != new["sweep_function"]:
        parts.append(f"function ({stored.get('sweep_function')} vs {new['sweep_function']})")
    if stored.get("hdrfringe_version") != new["hdrfringe_version"]:
        parts.append(
            f"hdrfringe version ({stored.get('hdrfringe_version')} vs {new['hdrfringe_version']})"
        )
    return ", ".join(parts) or "fingerprint"


# --------------------------------------------------------------------------- store


def _template(grid: SweepGrid, ident: Mapping[str, str]) -> tuple[xr.Dataset, dict[str, Any]]:
    """An empty Dataset (dask-backed, never computed) and the encoding of the store."""
    import dask.array as da
    import xarray as xr

    coords: dict[str, Any] = {d: _coord_array(v) for d, v in grid.dims.items()}
    data: dict[str, Any] = {}
    encoding: dict[str, Any] = {}
    for var in grid.variables:
        coords.update({d: _coord_array(v) for d, v in var.extra_dims.items()})
        shape = (*(len(v) for v in grid.dims.values()), *(len(v) for v in var.extra_dims.values()))
        chunks = grid.chunks(var)
        dims = (*grid.dims, *var.extra_dims)
        arr = da.full(shape, var.fill, dtype=var.dtype, chunks=chunks)
        data[var.name] = xr.Variable(dims, arr, attrs=dict(var.attrs))
        # Zarr's own fill value is what chunks never written read as: NaN, or the given fill.
        encoding[var.name] = {"chunks": chunks, "fill_value": var.fill}
    done_chunks = (1,) * len(grid.split_dims)
    data[DONE_VAR] = xr.Variable(
        grid.split_dims,
        da.zeros(grid.blocks_shape, dtype=bool, chunks=done_chunks or ()),
        attrs={"description": "True once every variable of the block is stored"},
    )
    encoding[DONE_VAR] = {"chunks": done_chunks, "fill_value": False}
    attrs = {
        **grid.attrs,
        **ident,
        "sweep_block_dims": list(grid.block_dims),
        "sweep_created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs), encoding


def _is_store(path: Path) -> bool:
    return (path / "zarr.json").is_file() or (path / ".zgroup").is_file()


#: A store being created is written in ``.{store}.partial-{PID}-{random}`` beside it; the PID of
#: the creating process marks it, as io/results.py marks staging folders (docs/safety.md).
PARTIAL_INFIX = ".partial-"


def _remove_dead_partials(path: Path) -> None:
    """Remove ``.{name}.partial-{PID}-*`` folders beside ``path`` whose process is gone.

    A run killed (SIGKILL) while creating the store leaves one; it never was a store. One of a
    live process (another run creating the store right now), of this process, or named
    otherwise (by an earlier version, without a PID) is left alone.
    """
    from hdrfringe.io.results import marked_pid, pid_alive

    with contextlib.suppress(OSError):
        for entry in path.parent.glob(f".{path.name}{PARTIAL_INFIX}*-*"):  # not "-{hex}" only
            pid = marked_pid(entry, path, PARTIAL_INFIX)
            if pid is None or pid == os.getpid() or pid_alive(pid):
                continue
            log.info("removing %s, left by a killed run (PID %d)", entry, pid)
            shutil.rmtree(entry, ignore_errors=True)


def _create_store(path: Path, grid: SweepGrid, ident: Mapping[str, str]) -> None:
    """Write the store's metadata and coordinates in a sibling folder, then rename it into
    place: a crash leaves either no store or a complete empty one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}{PARTIAL_INFIX}{os.getpid()}-{uuid.uuid4().hex[:8]}")
    ds, encoding = _template(grid, ident)
    try:
        ds.to_zarr(
            tmp,
            mode="w-",
            compute=False,
            consolidated=False,
            zarr_format=ZARR_FORMAT,
            encoding=encoding,
        )
        if path.is_dir() and not any(path.iterdir()):
            path.rmdir()
        os.rename(tmp, path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _read_identity(path: Path) -> dict[str, Any]:
    import zarr

    try:
        attrs = dict(zarr.open_group(str(path), mode="r").attrs)
    except Exception as exc:  # any reading failure means: not a sweep store
        raise InputError(f"{path}: cannot open as a Zarr store ({exc})") from None
    if "sweep_fingerprint" not in attrs:
        raise InputError(f"{path}: a Zarr store but not a sweep's (no sweep_fingerprint attr)")
    return attrs


def _open_or_create(path: Path, grid: SweepGrid, ident: Mapping[str, str]) -> zarr.Group:
    import zarr

    if path.exists() and not _is_store(path):
        if not path.is_dir() or any(path.iterdir()):
            raise InputError(f"{path} exists and is not a sweep store; choose another path")
    _remove_dead_partials(path)
    if not _is_store(path):
        _create_store(path, grid, ident)
        log.info("sweep store %s created (%d blocks)", path, grid.n_blocks)
    else:
        stored = _read_identity(path)
        if stored["sweep_fingerprint"] != ident["sweep_fingerprint"]:
            raise InputError(
                f"{path} holds another sweep (its {_identity_differences(stored, ident)} "
                "differ); rerun with the same settings to resume it, or use a new path"
            )
    return zarr.open_group(str(path), mode="r+")


def _done_flags(group: zarr.Group) -> NDArray[np.bool_]:
    """The ``block_done`` flags of an open sweep store, as a bool array over the split dims."""
    import zarr

    flags = group[DONE_VAR]
    if not isinstance(flags, zarr.Array):
        raise InputError(
            f"{group.store_path}: {DONE_VAR!r} is a group, not an array: the sweep store is "
            "damaged; remove it and rerun the sweep"
        )
    return np.asarray(flags[...], dtype=bool)


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class SweepStatus:
    """How far a stored sweep has got (made by :func:`sweep_status`).

    Parameters
    ----------
    total, done : int
        Blocks in the grid and blocks stored.
    missing : tuple of dict
        The split-dim coordinates of each block not stored yet, in grid order.
    fingerprint : str
        The store's sweep fingerprint (:func:`sweep_identity`).

    Examples
    --------
    >>> status = SweepStatus(4, 3, ({"pattern": "sin", "pitch": 8},), "ab12")
    >>> str(status), status.complete
    ('3 of 4 blocks done, 1 missing', False)
    """

    total: int
    done: int
    missing: tuple[dict[str, Coord], ...]
    fingerprint: str

    @property
    def complete(self) -> bool:
        """True when every block is stored."""
        return not self.missing

    def __str__(self) -> str:
        return f"{self.done} of {self.total} blocks done, {len(self.missing)} missing"


def _stored_sweep(path: Path) -> tuple[dict[str, Any], SweepGrid]:
    """The identity attributes and the grid of the sweep store at ``path``, or a clear error."""
    if not _is_store(path):
        raise InputError(f"{path}: no sweep store there (run the sweep first)")
    attrs = _read_identity(path)
    return attrs, SweepGrid.from_json(json.loads(attrs["sweep_grid"]))


def sweep_status(store_path: str | os.PathLike[str]) -> SweepStatus:
    """Count the done and missing blocks of a sweep store (cheap: reads the flags only).

    Parameters
    ----------
    store_path : path
        The sweep's Zarr store (a folder written by :func:`run_sweep`).

    Returns
    -------
    SweepStatus
        Blocks in the grid, blocks stored, the coordinates of those missing, the fingerprint.

    Raises
    ------
    InputError
        If ``store_path`` is not a sweep store.
    """
    import zarr

    path = Path(store_path)
    attrs, grid = _stored_sweep(path)
    flags = _done_flags(zarr.open_group(str(path), mode="r"))
    missing = tuple(grid.split_coords(i) for i in grid.block_indices() if not flags[i])
    return SweepStatus(
        total=grid.n_blocks,
        done=int(np.count_nonzero(flags)),
        missing=missing,
        fingerprint=attrs["sweep_fingerprint"],
    )


def open_results(store_path: str | os.PathLike[str]) -> xr.Dataset:
    """Open a sweep store as an xarray Dataset (lazily loaded; ``.load()`` reads it all).

    The variables have the grid's dims then their extra dims, in the grid's order, with
    NaN (or the integer fill) in the cells of blocks not done; ``block_done`` flags the blocks
    stored. String coordinates come back as NumPy ``str`` arrays.

    Parameters
    ----------
    store_path : path
        The sweep's Zarr store (a folder written by :func:`run_sweep`).

    Returns
    -------
    xarray.Dataset
        The grid's variables and ``block_done``, with the grid's coordinates and the store's
        attributes (the grid's, and the sweep identity of :func:`sweep_identity`).

    Raises
    ------
    InputError
        If ``store_path`` is not a sweep store.
    """
    import xarray as xr

    path = Path(store_path)
    _, grid = _stored_sweep(path)
    ds = xr.open_dataset(path, engine="zarr", chunks=None, consolidated=False)
    strings = {
        name: np.asarray(ds[name].values.tolist(), dtype=str)
        for name in ds.coords
        if ds[name].dtype.kind in "OTU"
    }
    ds = ds.assign_coords(strings)
    return ds[[v.name for v in grid.variables] + [DONE_VAR]]


# --------------------------------------------------------------------------- execution


#: Environment of local workers, on top of dask's own. Dask sets ``MALLOC_TRIM_THRESHOLD_``,
#: which turns off glibc's adaptive mmap threshold: every large numpy temporary then is a fresh
#: mmap and is page-faulted in again (the Ch. 4 quick sweep ran 3x slower, a third of it in the
#: kernel). Keeping arrays below 1 GiB on the heap restores the speed of a plain process.
#: Each worker runs one task thread, so the block decode (``hdrfringe.core._blockdecode``) uses one
#: thread too instead of one per CPU in every worker (same bits for any thread count).
WORKER_ENV: dict[str, str] = {
    "MALLOC_MMAP_THRESHOLD_": str(2**30),
    "HDRFRINGE_DECODE_THREADS": "1",
}
WORKER_ENV_KEY = "distributed.nanny.pre-spawn-environ"


#: Seconds :func:`check_scheduler` waits for a scheduler address to answer.
SCHEDULER_TIMEOUT_S = 10.0


async def _scheduler_identity(address: str, timeout: float) -> Any:
    from distributed.comm import connect

    # Dask's connect retries a refused connection until its own timeout: give it longer than
    # check_scheduler's, so the caller's deadline is the one that ends the wait (and says so).
    comm = await connect(address, timeout=timeout + 5.0)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def check_scheduler(address: str, timeout: float | None = None) -> None:
    """Check that ``address`` answers as a Dask scheduler within ``timeout`` seconds.

    Connects with Dask's own comm layer and asks for the peer's identity (the ``identity``
    operation of every Dask server); the answer must say ``type = "Scheduler"``. Meant to run
    before anything is written, so a wrong address costs nothing.

    Parameters
    ----------
    address : str
        Scheduler address, e.g. ``"tcp://10.0.0.5:8786"``.
    timeout : float, optional
        Seconds to wait for the connection and the answer (default
        :data:`SCHEDULER_TIMEOUT_S`, read when called).

    Raises
    ------
    InputError
        One line: the address has a port outside 1-65535, nothing answers, the peer stays
        silent, speaks another protocol (a web server, an SSH daemon), or is a Dask server
        other than a scheduler.

    Notes
    -----
    Not in the thesis: the sweeps (thesis Ch. 4-6) run on Dask (``docs/reproduce.md``).

    Examples
    --------
    >>> import socket
    >>> with socket.socket() as s:  # a port nothing listens on
    ...     s.bind(("127.0.0.1", 0))
    ...     port = s.getsockname()[1]
    >>> try:
    ...     check_scheduler(f"tcp://127.0.0.1:{port}", timeout=2)
    ... except InputError as exc:
    ...     print(str(exc).replace(str(port), "PORT").split(" (")[0])
    no Dask scheduler answered at 'tcp://127.0.0.1:PORT' within 2 s
    """
    import asyncio
    import concurrent.futures
    from urllib.parse import urlsplit

    hint = "check the address (e.g. tcp://host:8786) and that `dask scheduler` runs there"
    if timeout is None:
        timeout = SCHEDULER_TIMEOUT_S
    try:  # a port outside 1-65535 is refused at once, not after the connection timeout
        port = urlsplit(address if "://" in address else f"tcp://{address}").port
    except ValueError as exc:
        raise InputError(f"{address!r} is not a scheduler address ({exc}); {hint}") from None
    if port == 0:
        raise InputError(f"{address!r} is not a scheduler address (port 0); {hint}")

    def probe() -> Any:
        return asyncio.run(asyncio.wait_for(_scheduler_identity(address, timeout), timeout))

    # A thread of its own: the caller may be inside a running event loop (a notebook).
    pool = concurrent.futures.ThreadPoolExecutor(1)
    try:
        reply = pool.submit(probe).result(timeout + 5)
    except (TimeoutError, concurrent.futures.TimeoutError):
        raise InputError(
            f"no Dask scheduler answered at {address!r} within {timeout:g} s (nothing listens, "
            f"or it is silent); {hint}"
        ) from None
    except MemoryError:  # a non-Dask peer's bytes read as a gigantic frame length
        raise InputError(
            f"no Dask scheduler answered at {address!r} (the peer speaks another protocol); {hint}"
        ) from None
    except Exception as exc:  # connection refused, bad address, a protocol error
        reason = (str(exc).splitlines() or [type(exc).__name__])[0][:200]
        raise InputError(f"no Dask scheduler answered at {address!r} ({reason}); {hint}") from None
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
    kind = reply.get("type") if isinstance(reply, dict) else None
    if kind != "Scheduler":
        raise InputError(
            f"no Dask scheduler answered at {address!r} (the peer is {kind or 'not Dask'}); {hint}"
        )


@contextlib.contextmanager
def _connect(scheduler: str | Client | None, n_workers: int | None) -> Iterator[Client]:
    """A client: the one given, one on the scheduler at an address, or a new local cluster
    (``n_workers`` processes of one thread, no dashboard) closed on exit."""
    from dask.distributed import Client, LocalCluster

    if isinstance(scheduler, Client):
        yield scheduler
        return
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(
                f"cannot reach the dask scheduler at {scheduler!r} ({exc}); check the address "
                "(e.g. tcp://host:8786) and that `dask scheduler` runs there"
            ) from None
        try:
            yield client
        finally:
            client.close()
        return
    n = (os.cpu_count() or 1) if n_workers is None else int(n_workers)
    if n < 1:
        raise InputError(f"n_workers must be at least 1, got {n_workers}")
    import dask

    with (
        warnings.catch_warnings(),  # another cluster on this machine may hold port 8787
        dask.config.set({WORKER_ENV_KEY: {**dask.config.get(WORKER_ENV_KEY, {}), **WORKER_ENV}}),
    ):
        warnings.filterwarnings("ignore", message="Port .* is already in use")
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,  # no dashboard (its HTTP server picks a free port)
            silence_logs=logging.ERROR,
        )
    try:
        client = Client(cluster)
        try:
            # A Ctrl-C in a terminal reaches the whole process group: the driver alone handles
            # it (and closes the cluster), so the workers do not print their own tracebacks.
            client.run(_ignore_sigint)
            yield client
        finally:
            client.close()
    finally:
        cluster.close()


def _ignore_sigint() -> None:
    """Run on each local worker: leave SIGINT to the driver."""
    with contextlib.suppress(ValueError):  # not the main thread: nothing to do
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _sigint_deferred() -> Iterator[None]:
    """Hold a Ctrl-C (SIGINT) back until the block is written, then deliver it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if received:
            if callable(previous):
                previous(signal.SIGINT, None)
            elif previous == signal.SIG_DFL:
                signal.raise_signal(signal.SIGINT)


def _checked_output(grid: SweepGrid, index: tuple[int, ...], out: Any) -> dict[str, NDArray[Any]]:
    where = f"block {grid.split_coords(index)}"
    if not isinstance(out, Mapping):
        raise SweepError(f"{where}: the task returned {type(out).__name__}, not a dict of arrays")
    expected = [v.name for v in grid.variables]
    if set(out) != set(expected):
        raise SweepError(
            f"{where}: the task returned variables {sorted(out)}, expected {sorted(expected)}"
        )
    arrays = {}
    for var in grid.variables:
        a = np.asarray(out[var.name])
        shape = grid.block_shape(var)
        if a.shape != shape:
            dims = [*grid.block_dims, *var.extra_dims]
            raise SweepError(
                f"{where}: {var.name} has shape {a.shape}, expected {shape} (dims {dims})"
            )
        if not np.can_cast(a.dtype, var.dtype, casting="same_kind"):
            raise SweepError(f"{where}: {var.name} is {a.dtype}, cannot store it as {var.dtype}")
        arrays[var.name] = a.astype(var.dtype, copy=False)
    return arrays


def _write_block(
    arrays: Mapping[str, Any],
    grid: SweepGrid,
    index: tuple[int, ...],
    values: Mapping[str, NDArray[Any]],
) -> None:
    """Data first, then the done flag: each a whole-chunk, atomic file replacement."""
    with _sigint_deferred():
        for var in grid.variables:
            arrays[var.name][grid.selection(index, var)] = values[var.name]
        arrays[DONE_VAR][index] = True


def _progress_bar(progress: bool | Progress) -> contextlib.AbstractContextManager[Progress]:
    """The caller's running Progress (one live display at a time), or a new bar on stderr."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    if isinstance(progress, Progress):
        return contextlib.nullcontext(progress)
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        disable=not (progress and sys.stderr.isatty()),
    )


def run_sweep(
    store_path: str | os.PathLike[str],
    grid: SweepGrid,
    func: BlockFunc,
    params: Mapping[str, Any] | None = None,
    *,
    scheduler: str | Client | None = None,
    n_workers: int | None = None,
    retries: int = 2,
    progress: bool | Progress = True,
) -> xr.Dataset:
    """Compute every block of ``grid`` not yet in the store at ``store_path`` and return the
    results.

    Parameters
    ----------
    store_path : path
        Zarr store (a local folder): created if absent, resumed if it holds the same sweep.
    grid : SweepGrid
        Dimensions, variables and block layout.
    func : callable
        ``func(block_coords, params) -> {variable: array}``: a top-level function, importable
        on the workers, deterministic. ``block_coords`` maps every dim to its coordinate
        (split dims) or to the tuple of its coordinates (block dims); each array has the
        block dims in grid order, then the variable's extra dims.
    params : mapping, optional
        Settings shared by every block (JSON values), passed to ``func`` as given.
    scheduler : str or dask.distributed.Client, optional
        Address of a running dask scheduler (e.g. ``"tcp://10.0.0.5:8786"``), or a client;
        default: a local cluster of ``n_workers`` processes with one thread each, closed at
        the end.
    n_workers : int, optional
        Local cluster size (default: the CPU count); ignored with ``scheduler``.
    retries : int
        Times a block that raised is resubmitted before the sweep stops. A worker that dies
        (killed, out of memory) is handled by the scheduler: its blocks are rerun elsewhere,
        up to ``distributed.scheduler.allowed-failures`` deaths per block.
    progress : bool or rich.progress.Progress
        Show a rich progress bar on stderr (only when it is a terminal), or add this sweep's
        task to a Progress the caller already runs.

    Returns
    -------
    xarray.Dataset
        :func:`open_results` of the store.

    Raises
    ------
    InputError
        The store holds another sweep (different grid, function, params or hdrfringe version),
        the path is not a sweep store, or the scheduler cannot be reached.
    SweepError
        A block failed after its retries or returned the wrong variables, shapes or dtypes;
        the blocks finished before are stored and a rerun resumes from them.
    KeyboardInterrupt
        On Ctrl-C: pending blocks are cancelled, the cluster closed, the store left valid.
    """
    params = {} if params is None else params
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise InputError(f"retries must be a whole number >= 0, got {retries!r}")
    ident = sweep_identity(grid, func, params)
    if isinstance(scheduler, str):
        check_scheduler(scheduler)  # before the store is created
    path = Path(store_path)
    group = _open_or_create(path, grid, ident)
    arrays = {name: group[name] for name in [*(v.name for v in grid.variables), DONE_VAR]}
    flags = _done_flags(group)
    todo = [i for i in grid.block_indices() if not flags[i]]
    log.info(
        "sweep %s: %d of %d blocks done, %d to compute",
        path,
        grid.n_blocks - len(todo),
        grid.n_blocks,
        len(todo),
    )
    if todo:
        _compute(
            arrays,
            grid,
            func,
            params,
            todo,
            ident,
            scheduler,
            n_workers,
            retries,
            progress,
            path,
        )
    return open_results(path)


def _compute(
    arrays: Mapping[str, Any],
    grid: SweepGrid,
    func: BlockFunc,
    params: Mapping[str, Any],
    todo: Sequence[tuple[int, ...]],
    ident: Mapping[str, str],
    scheduler: str | Client | None,
    n_workers: int | None,
    retries: int,
    progress: bool | Progress,
    path: Path,
) -> None:
    from dask.distributed import as_completed

    run = f"sweep-{ident['sweep_fingerprint'][:10]}-{uuid.uuid4().hex[:8]}"
    stored = grid.n_blocks - len(todo)
    started = last_log = time.monotonic()
    with _connect(scheduler, n_workers) as client, _progress_bar(progress) as bar:
        task = bar.add_task(path.name, total=grid.n_blocks, completed=stored)
        pending: dict[Any, tuple[int, ...]] = {}
        try:
            for index in todo:
                key = f"{run}-{'-'.join(map(str, index)) or 'all'}"
                fut = client.submit(
                    func, grid.block_coords(index), params, key=key, retries=retries, pure=False
                )
                pending[fut] = index
            for fut in as_completed(list(pending)):
                index = pending.pop(fut)
                try:
                    out = fut.result()
                except Exception as exc:
                    raise SweepError(
                        f"block {grid.split_coords(index)} failed: {type(exc).__name__}: {exc}; "
                        "the blocks finished are stored, rerun to resume"
                    ) from exc
                _write_block(arrays, grid, index, _checked_output(grid, index, out))
                stored += 1
                bar.advance(task)
                now = time.monotonic()
                if now - last_log >= LOG_EVERY_S or stored == grid.n_blocks:
                    last_log = now
                    log.info(
                        "sweep %s: %d of %d blocks stored (%.0f s)",
                        path.name,
                        stored,
                        grid.n_blocks,
                        now - started,
                    )
        except KeyboardInterrupt:
            log.warning(
                "interrupted: %d of %d blocks are stored in %s; rerun to compute the rest",
                stored,
                grid.n_blocks,
                path,
            )
            raise
        finally:
            if pending:
                with contextlib.suppress(Exception):
                    client.cancel(list(pending))
