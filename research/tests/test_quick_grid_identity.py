"""Every number of the quick reproduction matches the reference, within stated tolerances.

The reference (``research/tests/data/quick_grid_reference.npz``, made by
:mod:`quick_grid_reference`) holds every number a quick reproduction stores (671 variables and
table entries). A refactoring that changes reproduced numbers fails here and names the store
and variable that changed; a machine with another CPU or other library releases passes. The
quick run is the session's shared ``quick_run`` fixture (research/tests/conftest.py): no extra
sweep.

Why tolerances, and these (defined and explained in :mod:`quick_grid_reference`): the
sweep draws float32 noise, adds it to a float32 signal and rounds to grey levels. Another CPU
computes the signal's matrix products (OpenBLAS kernels) and numpy's SIMD ``sin``/``arctan2``
with other last bits, which moves a grey level by one wherever the signal sits at a rounding
boundary. Measured on the project's machine (2026-12-06, numpy 2.4.6) between its full dispatch
(AVX-512) and the narrowed run of ``make test`` (numpy's baseline dispatch, OpenBLAS's Haswell
kernels, ``HDRFRINGE_NATIVE=0``): 262 of the 671 values moved, the largest by 0.31 of its
tolerance (``ch6_plate.zarr/std_mm``, 7e-6 mm on 0.125 mm); pixel fractions by at most 2 of
80 028 pixels. The sweep in float64 instead of float32 (``SWEEP_DTYPE``: other noise draws,
other rounding of every pixel) put 205 variables outside, e.g. 1028 of the 1056 Ch. 4 RMSEs,
the largest by 3.8e-3 mm; the sweep's phase alone in float64 (``sweep_phase``) put 6 outside,
the checkerboard's uniform-MIGL errors by up to 5e3 times the tolerance.
:func:`test_a_float64_sweep_fails_the_reference` shows the float64 sweep failing on one block
recomputed both ways. To measure a run: ``reproduce all --quick -o DIR`` under the environment
(``env $(python tests/narrow_cpu.py) ...`` for the narrowed one), then ``python
research/tests/quick_grid_reference.py compare DIR`` prints each variable's largest change in
units of its tolerance.

Remake the reference only for a change that is meant to change reproduced numbers
(``python research/tests/quick_grid_reference.py make DIR``).
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np
import pytest

from quick_grid_reference import (
    ATOL,
    ATOL_FRACTION,
    RTOL,
    differences,
    folder_values,
    load_reference,
)


@pytest.mark.xdist_group("dask-cluster")
def test_quick_reproduction_matches_the_reference(quick_run: Path) -> None:
    changed = differences(load_reference(), folder_values(quick_run))
    assert not changed, "reproduced numbers changed:\n" + "\n".join(changed)


def _block_values(store: Path, index: tuple[int, ...]) -> tuple[dict, dict]:
    """One block of a stored sweep recomputed in this process (name -> values), and the same
    block's slice of the reference."""
    from hdrfringe_thesis.engine import _checked_output, _stored_sweep

    attrs, grid = _stored_sweep(store)
    module, qualname = attrs["sweep_function"].split(":")
    func = getattr(importlib.import_module(module), qualname)
    params = json.loads(attrs["sweep_params"])
    out = _checked_output(grid, index, func(grid.block_coords(index), params))
    ref = load_reference()
    computed, expected = {}, {}
    for var in grid.variables:
        name = f"{store.name}/{var.name}"
        computed[name] = out[var.name]
        expected[name] = ref[name][grid.selection(index, var)]
    return computed, expected


@pytest.mark.xdist_group("dask-cluster")
def test_a_float64_sweep_fails_the_reference(
    quick_run: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The change the regression was written for: the sweep in float64 instead of float32.
    One Ch. 4 block (3-step sinusoidal at pitch 4 px, every MIGL, depth and light level)
    recomputed in this process with the shipped float32 matches the reference; in float64 it
    is outside the tolerance."""
    from hdrfringe_thesis import ch4

    store = quick_run / "ch4.zarr"
    index = (0, 0)  # the first pattern (sinusoidal 3-step) at the first pitch (4 px)
    computed, expected = _block_values(store, index)
    assert differences(expected, computed) == []
    monkeypatch.setattr(ch4, "SWEEP_DTYPE", np.float64)
    computed64, _ = _block_values(store, index)
    changed = differences(expected, computed64)
    assert any(line.startswith("ch4.zarr/rmse_mm:") for line in changed), changed
    assert any(line.startswith("ch4.zarr/std_mm:") for line in changed), changed


def test_differences_name_the_changed_variable() -> None:
    expected = load_reference()
    stores = {name.split("/")[0] for name in expected if "/" in name and ".zarr" in name}
    assert {"ch4.zarr", "ch4_simulation.zarr", "ch5_plate.zarr", "checkerboard.zarr"} <= stores
    assert differences(expected, dict(expected)) == []
    actual = dict(expected)
    rmse = expected["ch4.zarr/rmse_mm"]
    # within the tolerance: a relative change of RTOL / 10 on every value passes
    actual["ch4.zarr/rmse_mm"] = rmse * (1 + RTOL / 10)
    assert differences(expected, actual) == []
    # outside: 10 um on one value, another dtype, a value turned NaN, a variable missing
    bumped = rmse.copy()
    bumped.flat[np.flatnonzero(np.isfinite(rmse))[0]] += 0.01
    actual["ch4.zarr/rmse_mm"] = bumped
    actual["ch4_simulation.zarr/rmse_noise_mm"] = expected[
        "ch4_simulation.zarr/rmse_noise_mm"
    ].astype(np.float32)
    nan = expected["ch5_plate.zarr/std_mm"].copy()
    nan.flat[np.flatnonzero(np.isfinite(nan))[0]] = np.nan
    actual["ch5_plate.zarr/std_mm"] = nan
    del actual["checkerboard.zarr/cdf_final"]
    lines = differences(expected, actual)
    assert len(lines) == 4, lines
    assert lines[0].startswith("ch4.zarr/rmse_mm: 1 of ")
    assert lines[1] == "ch4_simulation.zarr/rmse_noise_mm: dtype float64 -> float32"
    assert lines[2].startswith("ch5_plate.zarr/std_mm: 1 of ")
    assert "NaN" in lines[2]
    assert lines[3] == "checkerboard.zarr/cdf_final: missing"


def test_values_near_zero_compare_absolutely() -> None:
    """A bias that is zero up to rounding (1e-15 mm against -1e-15 mm) is equal, one of 10 ATOL
    is not; fractions take ATOL_FRACTION; strings compare exactly."""
    exp = {"s.zarr/bias": np.array([1e-15, 0.5])}
    assert differences(exp, {"s.zarr/bias": np.array([-1e-15, 0.5])}) == []
    assert differences(exp, {"s.zarr/bias": np.array([10 * ATOL, 0.5])}) != []
    frac = {"s.zarr/cdf_final": np.array([0.25])}
    assert differences(frac, {"s.zarr/cdf_final": np.array([0.25 + ATOL_FRACTION / 2])}) == []
    assert differences(frac, {"s.zarr/cdf_final": np.array([0.25 + 2 * ATOL_FRACTION])}) != []
    strings = {"s.zarr/strategy": np.array(["lpa", "dpa"])}
    assert differences(strings, {"s.zarr/strategy": np.array(["lpa", "dpa+"])}) == [
        "s.zarr/strategy: 1 of 2 values differ"
    ]
