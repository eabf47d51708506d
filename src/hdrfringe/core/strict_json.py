"""Strict JSON text for every JSON file hdrfringe writes (issue 27): no bare NaN or Infinity.

Python's :func:`json.dumps` writes a non-finite float as the bare words ``NaN``, ``Infinity`` and
``-Infinity``, which are not JSON (RFC 8259): strict parsers (JavaScript's ``JSON.parse``, jq,
Go, Rust's serde_json, ``json.loads`` with a ``parse_constant`` that raises) refuse the whole
file. Every JSON file of the product is written through :func:`dumps`, in one of two modes:

- results (``summary.json``, ``metrics.json``, ``phase_summary.json``, ``gamma.json``, the
  ``rig check`` report, capture logs, ...): a number that has no value (an RMSE over no valid
  pixel, a fit that could not be made) is written as ``null``, the documented "no value"
  (docs/json_outputs.md). ``nonfinite="null"``, the default.
- contracts read back by hdrfringe and other tools (capture and pattern ``manifest.json``, the
  projector play list, a correction polynomial): a non-finite number there is a bug, not a
  missing value, so it is refused (``nonfinite="error"``: :class:`ValueError` naming the field)
  rather than written in any form.

Finite numbers are written exactly as :func:`json.dumps` writes them (``repr`` of the float),
so a file without non-finite values is byte for byte what ``json.dumps`` gave. numpy scalars
and arrays are written as the Python numbers and lists they hold.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np

__all__ = ["dumps", "loads_strict", "plain"]

Nonfinite = Literal["null", "error"]


def plain(obj: Any, *, nonfinite: Nonfinite = "null", where: str = "") -> Any:
    """``obj`` with JSON's types only: non-finite floats as ``None`` (or refused).

    Parameters
    ----------
    obj : Any
        Dicts, lists, tuples, strings, numbers (Python or numpy), booleans, None and numpy
        arrays, nested.
    nonfinite : {"null", "error"}
        What a NaN or infinity becomes: ``None`` (JSON ``null``), or a :class:`ValueError`.
    where : str
        Path of ``obj`` in the document, for the error message.

    Returns
    -------
    Any
        The same structure with tuples and arrays as lists, numpy scalars as Python ones and
        non-finite floats as ``None``. Dict keys are kept (:func:`json.dumps` writes them).

    Raises
    ------
    ValueError
        A non-finite float with ``nonfinite="error"``.
    TypeError
        An object JSON cannot hold (as :func:`json.dumps` would raise).

    Examples
    --------
    >>> plain({"rmse_mm": float("nan"), "n": np.int64(3), "x": (np.float64(0.5), np.inf)})
    {'rmse_mm': None, 'n': 3, 'x': [0.5, None]}
    >>> plain({"pitch": [8.0, float("nan")]}, nonfinite="error")
    Traceback (most recent call last):
    ...
    ValueError: pitch[1] is nan, which JSON cannot hold
    """
    if obj is None or isinstance(obj, str | bool):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, int | np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        if math.isfinite(obj):
            return obj if type(obj) is float else float(obj)
        if nonfinite == "error":
            raise ValueError(f"{where or 'the value'} is {float(obj)}, which JSON cannot hold")
        return None
    if isinstance(obj, Mapping):
        return {
            k: plain(v, nonfinite=nonfinite, where=f"{where}.{k}" if where else str(k))
            for k, v in obj.items()
        }
    if isinstance(obj, list | tuple | np.ndarray):
        items = obj.tolist() if isinstance(obj, np.ndarray) else obj
        return [
            plain(v, nonfinite=nonfinite, where=f"{where}[{i}]") for i, v in enumerate(items)
        ]
    raise TypeError(f"{where or 'the value'}: {type(obj).__name__} is not JSON-serialisable")


def dumps(
    obj: Any, *, indent: int | None = 1, sort_keys: bool = False, nonfinite: Nonfinite = "null"
) -> str:
    """Strict JSON text of ``obj`` (no ``NaN``/``Infinity``), without a trailing newline.

    Parameters
    ----------
    obj : Any
        What to write (see :func:`plain`).
    indent : int or None
        As :func:`json.dumps` (the product writes 1 unless a file's format says otherwise).
    sort_keys : bool
        As :func:`json.dumps`.
    nonfinite : {"null", "error"}
        A non-finite number: ``null`` (results) or a :class:`ValueError` (contracts).

    Returns
    -------
    str
        The JSON text; with only finite numbers, what ``json.dumps(obj, indent=indent)`` gives.

    Raises
    ------
    ValueError
        A non-finite number with ``nonfinite="error"``.

    Examples
    --------
    >>> dumps({"rmse_mm": float("nan"), "valid_fraction": 0.0}, indent=None)
    '{"rmse_mm": null, "valid_fraction": 0.0}'
    >>> loads_strict(dumps([float("inf")]))
    [None]
    """
    return json.dumps(
        plain(obj, nonfinite=nonfinite), indent=indent, sort_keys=sort_keys, allow_nan=False
    )


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"not strict JSON: bare {name}")


def loads_strict(text: str) -> Any:
    """Parse JSON text the way a strict parser does: a bare ``NaN``/``Infinity`` is refused.

    Parameters
    ----------
    text : str
        JSON text.

    Returns
    -------
    Any
        The parsed document.

    Raises
    ------
    ValueError
        A bare ``NaN``, ``Infinity`` or ``-Infinity`` (or any JSON syntax error).

    Examples
    --------
    >>> loads_strict('{"a": null}')
    {'a': None}
    >>> loads_strict('{"a": NaN}')
    Traceback (most recent call last):
    ...
    ValueError: not strict JSON: bare NaN
    """
    return json.loads(text, parse_constant=_refuse_constant)
