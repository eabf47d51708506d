"""Polygon files of a region of interest (``hdrfringe fit --roi FILE``): JSON or CSV.

JSON: a list of ``[x, y]`` vertices, or an object whose ``"polygon"`` is one
(``{"polygon": [[10, 5], [60, 5], [35, 40]]}``). CSV: one vertex ``x,y`` per line, an optional
header line ``x,y`` first. Coordinates are camera pixels (``x`` the column, ``y`` the row);
:func:`hdrfringe.core.roi.polygon_mask` turns them into a mask.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from hdrfringe.errors import InputError

__all__ = ["POLYGON_SUFFIXES", "read_polygon"]

#: The polygon file formats, by suffix.
POLYGON_SUFFIXES = (".json", ".csv")
#: Most vertices read (a hand-drawn polygon has tens; a file with more is not one).
MAX_VERTICES = 100_000


def read_polygon(path: str | Path) -> np.ndarray:
    """The vertices ``(x, y)`` of a polygon file.

    Parameters
    ----------
    path : str or Path
        A ``.json`` or ``.csv`` file (see the module's description).

    Returns
    -------
    ndarray of float64, shape (N, 2)
        N >= 3 finite vertices.

    Raises
    ------
    InputError
        No such file, another suffix, a malformed file, fewer than 3 vertices, a vertex that is
        not two finite numbers; one line naming the file and the line or vertex.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "roi.csv"
    >>> _ = path.write_text("x,y\\n10,5\\n60,5\\n35,40\\n")
    >>> read_polygon(path).tolist()
    [[10.0, 5.0], [60.0, 5.0], [35.0, 40.0]]
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in POLYGON_SUFFIXES:
        raise InputError(
            f"--roi {p}: not x0,y0,x1,y1, auto, or a polygon file ({' or '.join(POLYGON_SUFFIXES)})"
        )
    if not p.is_file():
        raise InputError(f"--roi {p}: no such polygon file")
    if p.stat().st_size > 64 * MAX_VERTICES:
        raise InputError(f"{p}: {p.stat().st_size} bytes, too large for a polygon file")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{p}: cannot read the polygon file ({exc})") from None
    rows = _json_rows(p, text) if suffix == ".json" else _csv_rows(p, text)
    vertices = []
    for i, row in enumerate(rows, 1):
        if (
            not isinstance(row, list | tuple)
            or len(row) != 2
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in row)
            or not all(math.isfinite(v) for v in row)
        ):
            raise InputError(
                f"{p}: vertex {i} is {row!r}; give each vertex as two finite numbers x, y"
            )
        vertices.append([float(row[0]), float(row[1])])
    if len(vertices) < 3:
        raise InputError(f"{p}: {len(vertices)} vertices; a polygon needs at least 3")
    return np.asarray(vertices, dtype=np.float64)


def _json_rows(path: Path, text: str) -> list[object]:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not JSON ({exc}); give a list of [x, y] vertices") from None
    if isinstance(data, dict):
        data = data.get("polygon")
    if not isinstance(data, list):
        raise InputError(
            f"{path}: give a list of [x, y] vertices or an object with a \"polygon\" list"
        )
    if len(data) > MAX_VERTICES:
        raise InputError(f"{path}: {len(data)} vertices, more than {MAX_VERTICES}")
    return data


def _csv_rows(path: Path, text: str) -> list[object]:
    rows: list[object] = []
    for n, cells in enumerate(csv.reader(text.splitlines()), 1):
        if not cells or all(not c.strip() for c in cells):
            continue
        if n == 1 and [c.strip().lower() for c in cells] == ["x", "y"]:
            continue  # the header
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            raise InputError(
                f"{path}: line {n} is {','.join(cells)!r}; give one vertex x,y per line"
            ) from None
    return rows
