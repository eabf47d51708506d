"""Digest of every number a quick reproduction stores, to prove a refactoring changes none.

``hdrfringe reproduce all --quick -o DIR`` writes one Zarr store per sweep; each opens as an
xarray Dataset (:func:`hdrfringe.reproduce.engine.open_results`) holding every reproduced
number. :func:`folder_digest` records, for each store and each of its data variables and
coordinates, the name, dtype, shape and the SHA-256 of the raw bytes (strings: of their UTF-8
JSON). Attributes are left out: they hold the run's timestamp and version, not results. The
two JSON results beside the stores are digested too, one entry per top-level key: DPA's
correction polynomial (``dpa_correction.json``) and the tables (``tables.json``, without
``timings_s``).

The reference ``tests/data/quick_grid_digest.json`` was made on the code before the
one-implementation-per-equation refactoring (issue 10) and checked to be reproducible run to
run on the same machine; ``tests/test_quick_grid_identity.py`` compares a fresh quick run to it.

Run as a script to (re)make the reference from a quick-run folder::

    python -m tests.quick_grid_digest DIR [tests/data/quick_grid_digest.json]
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

REFERENCE = Path(__file__).resolve().parent / "data" / "quick_grid_digest.json"


def array_digest(values: np.ndarray) -> dict[str, Any]:
    """dtype, shape and SHA-256 of one array's values (raw bytes, C order)."""
    arr = np.asarray(values)
    if arr.dtype.kind in "OUST":
        raw = json.dumps([str(v) for v in arr.ravel().tolist()]).encode()
    else:
        raw = np.ascontiguousarray(arr).tobytes()
    return {
        "dtype": str(arr.dtype),
        "shape": list(arr.shape),
        "sha256": hashlib.sha256(raw).hexdigest(),
    }


def store_digest(store: Path) -> dict[str, dict[str, Any]]:
    """Digest of each data variable and coordinate of one sweep store, by name."""
    from hdrfringe.reproduce.engine import open_results

    ds = open_results(store).load()
    return {str(name): array_digest(ds[name].values) for name in sorted(ds.variables)}


#: JSON results digested beside the stores, and the top-level keys left out (run times).
JSON_RESULTS: dict[str, tuple[str, ...]] = {
    "dpa_correction.json": (),
    "tables.json": ("timings_s",),
}


def json_digest(path: Path, skip: tuple[str, ...] = ()) -> dict[str, dict[str, Any]]:
    """Digest of each top-level entry of a JSON object file (canonical JSON text)."""
    data = json.loads(path.read_text(encoding="utf-8"))
    out = {}
    for key in sorted(data):
        if key in skip:
            continue
        raw = json.dumps(data[key], sort_keys=True).encode()
        out[key] = {"dtype": "json", "shape": [], "sha256": hashlib.sha256(raw).hexdigest()}
    return out


def folder_digest(folder: Path) -> dict[str, dict[str, dict[str, Any]]]:
    """Digest of every ``*.zarr`` store and of the JSON results in a reproduction folder, by
    store or file name."""
    folder = Path(folder)
    stores = sorted(p for p in folder.glob("*.zarr") if p.is_dir())
    out = {p.name: store_digest(p) for p in stores}
    for name, skip in JSON_RESULTS.items():
        if (folder / name).is_file():
            out[name] = json_digest(folder / name, skip)
    return out


def differences(
    expected: dict[str, dict[str, dict[str, Any]]], actual: dict[str, dict[str, dict[str, Any]]]
) -> list[str]:
    """One line per store or variable whose digest differs (missing, extra or changed)."""
    out: list[str] = []
    for store in sorted(set(expected) | set(actual)):
        if store not in actual:
            out.append(f"{store}: store missing")
            continue
        if store not in expected:
            out.append(f"{store}: store not in the reference")
            continue
        exp, act = expected[store], actual[store]
        for name in sorted(set(exp) | set(act)):
            if name not in act:
                out.append(f"{store}/{name}: variable missing")
            elif name not in exp:
                out.append(f"{store}/{name}: variable not in the reference")
            elif exp[name] != act[name]:
                changed = [k for k in ("dtype", "shape", "sha256") if exp[name][k] != act[name][k]]
                detail = ", ".join(f"{k} {exp[name][k]} -> {act[name][k]}" for k in changed)
                out.append(f"{store}/{name}: {detail}")
    return out


def main(argv: list[str]) -> int:
    if not 1 <= len(argv) <= 2:
        print(__doc__, file=sys.stderr)
        return 2
    target = Path(argv[1]) if len(argv) == 2 else REFERENCE
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(json.dumps(folder_digest(Path(argv[0])), indent=1, sort_keys=True) + "\n")
    print(f"wrote {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
