"""Every number a quick reproduction stores, kept as a reference and compared with tolerances.

``hdrfringe reproduce all --quick -o DIR`` writes one Zarr store per sweep; each opens as an
xarray Dataset (:func:`hdrfringe_thesis.engine.open_results`) holding every reproduced
number. :func:`folder_values` collects, for each store, every data variable and coordinate by
``"<store>/<name>"`` (attributes are left out: they hold the run's timestamp and version), and
for the two JSON results beside the stores every leaf by ``"<file>:<path>"``: DPA's correction
polynomial (``dpa_correction.json``) and the tables (``tables.json`` without ``timings_s``).

The reference ``research/tests/data/quick_grid_reference.npz`` holds those values as computed on
the project's machine; ``research/tests/test_quick_grid_identity.py`` compares a fresh quick run
with it by :func:`differences`, numerically:

- names, shapes, dtypes, strings, booleans and the NaN pattern must be equal;
- integers and floats must agree within :data:`RTOL` relative plus an absolute tolerance
  (:data:`ATOL` for error statistics in mm, :data:`ATOL_FRACTION` for pixel fractions), the
  bounds and the measurements behind them explained where they are defined.

Run as a script to (re)make the reference from a quick-run folder, or to compare a folder with
it (prints each variable's largest change in units of its tolerance)::

    python research/tests/quick_grid_reference.py make DIR [REFERENCE.npz]
    python research/tests/quick_grid_reference.py compare DIR [REFERENCE.npz]
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

REFERENCE = Path(__file__).resolve().parent / "data" / "quick_grid_reference.npz"

#: Relative tolerance on every reproduced number. The sweep quantises float32 signals to
#: integer grey levels, so a last-bit change of the signal (another BLAS kernel, numpy's SIMD
#: sin/arctan2 for another instruction set, another numpy release) moves a few pixels' grey
#: level by one where the signal sits at a rounding boundary: an error statistic over the
#: quick grid's 80 028 pixels then moves by ~1e-6 relative (measured: at most 7e-5, on a bias
#: of 0.09 mm; research/tests/test_quick_grid_identity.py). The sweep in float64 instead of float32
#: (other noise draws, other rounding everywhere) moves them by their Monte Carlo spread:
#: 1e-3 relative in the median, up to 6e-2 (measured).
RTOL = 1e-4
#: Absolute tolerance of the error statistics, in their unit (mm): a bias that is zero up to
#: rounding; 1e-5 mm is 1/100 of the smallest Monte Carlo change of the float64 sweep's RMSEs.
ATOL = 1e-5
#: Absolute tolerance of pixel fractions (CDFs, saturated and level fractions): 8 of the quick
#: grid's 80 028 pixels. Another CPU moved them by at most 2 pixels (2.35e-5, measured); the
#: float64 sweep by 3e-3 or more.
ATOL_FRACTION = 1e-4
#: Names of the variables that are pixel fractions.
FRACTION_NAMES = ("cdf", "fraction", "never_unsaturated")


def atol_of(name: str) -> float:
    """The absolute tolerance of the variable ``name`` (:data:`ATOL_FRACTION` for pixel
    fractions, else :data:`ATOL`)."""
    return ATOL_FRACTION if any(t in name for t in FRACTION_NAMES) else ATOL


#: JSON results digested beside the stores, and the top-level keys left out (run times).
JSON_RESULTS: dict[str, tuple[str, ...]] = {
    "dpa_correction.json": (),
    "tables.json": ("timings_s",),
}


def _json_leaves(obj: Any, path: str) -> Iterator[tuple[str, np.ndarray]]:
    """Each leaf of a JSON value as ``(path, 0-d array)``; ``None`` becomes the string
    ``"null"`` (so that it compares exactly)."""
    if isinstance(obj, Mapping):
        for key in sorted(obj):
            yield from _json_leaves(obj[key], f"{path}/{key}")
    elif isinstance(obj, list):
        for i, item in enumerate(obj):
            yield from _json_leaves(item, f"{path}/{i}")
    elif obj is None:
        yield path, np.array("null")
    elif isinstance(obj, bool):
        yield path, np.array(obj)
    elif isinstance(obj, int | float):
        yield path, np.array(float(obj))
    else:
        yield path, np.array(str(obj))


def json_values(path: Path, skip: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """Every leaf of a JSON object file, by ``"<file>:<key path>"``."""
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    kept = {k: v for k, v in data.items() if k not in skip}
    return {f"{Path(path).name}:{p}": v for p, v in _json_leaves(kept, "")}


def store_values(store: Path) -> dict[str, np.ndarray]:
    """Every data variable and coordinate of one sweep store, by ``"<store>/<name>"``."""
    from hdrfringe_thesis.engine import open_results

    ds = open_results(store).load()
    return {f"{store.name}/{name}": np.asarray(ds[name].values) for name in sorted(ds.variables)}


def folder_values(folder: Path) -> dict[str, np.ndarray]:
    """The values of every ``*.zarr`` store and of the JSON results in a reproduction folder."""
    folder = Path(folder)
    out: dict[str, np.ndarray] = {}
    for store in sorted(p for p in folder.glob("*.zarr") if p.is_dir()):
        out.update(store_values(store))
    for name, skip in JSON_RESULTS.items():
        if (folder / name).is_file():
            out.update(json_values(folder / name, skip))
    return out


def load_reference(path: Path = REFERENCE) -> dict[str, np.ndarray]:
    """The stored reference values, by name."""
    with np.load(path, allow_pickle=False) as data:
        return {name: data[name] for name in data.files}


def save_reference(values: Mapping[str, np.ndarray], path: Path = REFERENCE) -> None:
    """Store reference values (compressed ``.npz``, no pickles)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **{k: np.asarray(v) for k, v in values.items()})


def deviation(expected: np.ndarray, actual: np.ndarray, atol: float = ATOL) -> float:
    """Largest ``|actual - expected| / (atol + RTOL * |expected|)`` over the finite values: a
    number above 1 is outside the tolerance (0 for equal arrays)."""
    e = np.asarray(expected, dtype=np.float64)
    a = np.asarray(actual, dtype=np.float64)
    both = np.isfinite(e) & np.isfinite(a)
    if not both.any():
        return 0.0
    return float((np.abs(a[both] - e[both]) / (atol + RTOL * np.abs(e[both]))).max())


def _one_difference(name: str, exp: np.ndarray, act: np.ndarray) -> str | None:
    if exp.shape != act.shape:
        return f"{name}: shape {list(exp.shape)} -> {list(act.shape)}"
    if exp.dtype.kind != act.dtype.kind or (
        exp.dtype.kind in "fiub" and exp.dtype.itemsize != act.dtype.itemsize
    ):
        return f"{name}: dtype {exp.dtype} -> {act.dtype}"
    if exp.dtype.kind not in "fiu":
        if not np.array_equal(exp, act):
            n = int(np.sum(exp != act))
            return f"{name}: {n} of {exp.size} values differ"
        return None
    e, a = exp.astype(np.float64), act.astype(np.float64)
    if not np.array_equal(np.isnan(e), np.isnan(a)) or not np.array_equal(
        np.isinf(e), np.isinf(a)
    ):
        n = int(np.sum((np.isnan(e) != np.isnan(a)) | (np.isinf(e) != np.isinf(a))))
        return f"{name}: {n} of {e.size} values changed between finite and NaN/inf"
    atol = atol_of(name)
    if deviation(e, a, atol) > 1.0:
        finite = np.isfinite(e)
        change = np.abs(a - e)[finite]
        outside = int(np.sum(change > atol + RTOL * np.abs(e[finite])))
        return (
            f"{name}: {outside} of {e.size} values outside rtol {RTOL:g} + atol {atol:g}, "
            f"largest change {change.max():.3g}"
        )
    return None


def differences(expected: Mapping[str, np.ndarray], actual: Mapping[str, np.ndarray]) -> list[str]:
    """One line per variable that differs beyond the tolerances (missing, extra, another shape
    or dtype, other strings, another NaN pattern, numbers outside ``RTOL``/``ATOL``)."""
    out: list[str] = []
    for name in sorted(set(expected) | set(actual)):
        if name not in actual:
            out.append(f"{name}: missing")
        elif name not in expected:
            out.append(f"{name}: not in the reference")
        else:
            line = _one_difference(name, np.asarray(expected[name]), np.asarray(actual[name]))
            if line:
                out.append(line)
    return out


def main(argv: list[str]) -> int:
    if len(argv) not in (2, 3) or argv[0] not in ("make", "compare"):
        print(__doc__, file=sys.stderr)
        return 2
    target = Path(argv[2]) if len(argv) == 3 else REFERENCE
    values = folder_values(Path(argv[1]))
    if argv[0] == "make":
        save_reference(values, target)
        print(f"wrote {target} ({len(values)} variables)")
        return 0
    ref = load_reference(target)
    for name in sorted(set(ref) & set(values)):
        if ref[name].dtype.kind in "fiu" and values[name].shape == ref[name].shape:
            dev = deviation(ref[name], values[name], atol_of(name))
            if dev > 0:
                print(f"{dev:10.3g}  {name}")
    for line in differences(ref, values):
        print("DIFF", line)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
