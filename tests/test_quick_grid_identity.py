"""Every number of the quick reproduction is bit-identical to the reference digest.

The reference (``tests/data/quick_grid_digest.json``, made by :mod:`tests.quick_grid_digest`)
was taken before the one-implementation-per-equation refactoring (issue 10); a refactoring
that changes any reproduced number, however slightly (e.g. the sweep's phase in float64
instead of float32), fails here and names the store and variable that changed. The quick run
is the session's shared ``quick_run`` fixture (tests/conftest.py): no extra sweep.

The digest is of raw bytes, so it is tied to the platform's floating point (NumPy's SIMD
kernels for sin, arctan2, ...): it was made, and checked to repeat run to run, on the project's
Linux x86-64 machine with the locked dependencies. Remake it there only for a change that is
meant to change reproduced numbers (``python -m tests.quick_grid_digest DIR``).
"""

from __future__ import annotations

import copy
import json

import pytest

from tests.quick_grid_digest import REFERENCE, differences, folder_digest


def _reference() -> dict:
    return json.loads(REFERENCE.read_text(encoding="utf-8"))


@pytest.mark.xdist_group("dask-cluster")
def test_quick_reproduction_matches_the_reference_digest(quick_run) -> None:
    changed = differences(_reference(), folder_digest(quick_run))
    assert not changed, "reproduced numbers changed:\n" + "\n".join(changed)


def test_differences_name_the_changed_variable() -> None:
    expected = _reference()
    assert {"ch4.zarr", "ch4_simulation.zarr", "ch5_plate.zarr", "checkerboard.zarr"} <= set(
        expected
    )
    assert differences(expected, copy.deepcopy(expected)) == []
    actual = copy.deepcopy(expected)
    actual["ch4.zarr"]["rmse_mm"]["sha256"] = "0" * 64
    actual["ch4_simulation.zarr"]["rmse_noise_mm"]["dtype"] = "float32"
    del actual["checkerboard.zarr"]["cdf_final"]
    del actual["ch6_plate.zarr"]
    lines = differences(expected, actual)
    assert len(lines) == 4
    assert lines[0].startswith("ch4.zarr/rmse_mm: sha256 ")
    assert lines[1].startswith("ch4_simulation.zarr/rmse_noise_mm: dtype float64 -> float32")
    assert lines[2] == "ch6_plate.zarr: store missing"
    assert lines[3] == "checkerboard.zarr/cdf_final: variable missing"
