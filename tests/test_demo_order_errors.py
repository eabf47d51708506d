"""The demo's fringe-order error count: what makes its checkerboard "uniform auto" RMSE 5.2 mm.

The reference is the set of pixels where whole periods were added on purpose to a noisy error
map, on a calibration whose K varies across the image; the classification must find exactly
those (inside the border, valid). Broken variants rejected: a threshold of a whole period
(misses the jumps that noise pulls under it), a global K instead of the per-pixel map (misses
jumps where K is large), counting the border or NaN pixels, or an RMSE "without order errors"
that still includes them.
"""

from __future__ import annotations

import numpy as np
import pytest

from hdrfringe.core.calibration import Calibration
from hdrfringe.tasks.demo import fringe_order_errors, order_error_notes


@pytest.fixture(scope="module")
def case() -> dict:
    rng = np.random.default_rng(7)
    h, w = 60, 80
    k = np.linspace(1.2, 2.4, w)[None, :] * np.ones((h, 1))  # mm/rad, varies across the image
    cal = Calibration("linear", k, None, np.zeros((h, w)), np.array([10.0, 20.0]), border_px=5)
    noise = rng.normal(0.0, 0.1, (h, w))
    err = noise.copy()
    jumps = np.zeros((h, w), int)
    rows, cols = rng.integers(5, h - 5, 40), rng.integers(5, w - 5, 40)
    jumps[rows, cols] = rng.choice([-8, -1, 1, 8], 40)
    # a jump of one period less 0.45 of a period: a whole-period threshold misses these
    # (and at column 6, where K is smallest: a global K would miss it)
    jumps[10, 70], jumps[11, 70], jumps[12, 6] = 1, -1, 1
    err = err + 2 * np.pi * k * jumps
    for r, c, sign in ((10, 70, -1), (11, 70, 1), (12, 6, -1)):
        err[r, c] += sign * 0.45 * 2 * np.pi * k[r, c]
    err[2, 40] += 2 * np.pi * k[2, 40]  # in the border: not a measurement pixel
    err[30, 30] = np.nan  # invalid
    jumps[30, 30] = 0
    refl = np.where(np.arange(w)[None, :] < 40, 0.25, 1.0) * np.ones((h, 1))
    return {"cal": cal, "err": err, "jumps": jumps, "noise": noise, "refl": refl}


def test_counts_exactly_the_whole_period_errors(case) -> None:
    out = fringe_order_errors(case["err"], case["cal"], case["refl"])
    inside = np.zeros(case["err"].shape, bool)
    inside[5:-5, 5:-5] = True
    valid = inside & np.isfinite(case["err"])
    truth = valid & (case["jumps"] != 0)
    assert out["order_errors"] == int(truth.sum())
    assert out["order_error_fraction"] == pytest.approx(truth.sum() / valid.sum())
    assert out["order_error_periods"] == sorted({int(j) for j in case["jumps"][truth]})
    rest = case["noise"][valid & ~truth]
    assert out["rmse_mm_without_order_errors"] == pytest.approx(np.sqrt(np.mean(rest**2)))
    assert out["order_error_reflectivity"] == sorted(
        {float(r) for r in case["refl"][truth].tolist()}
    )
    assert out["order_error_max_abs_mm"] == pytest.approx(np.abs(case["err"][truth]).max())


def test_no_order_error_on_a_clean_map(case) -> None:
    out = fringe_order_errors(case["noise"], case["cal"])
    assert out["order_errors"] == 0 and out["order_error_periods"] == []
    assert "order_error_reflectivity" not in out
    assert order_error_notes({"scenes": {}}) == []


def test_the_note_names_the_numbers(case) -> None:
    out = fringe_order_errors(case["err"], case["cal"], case["refl"])
    row = {"params": {}, "rmse_mm": 5.227, "uniform_migl": [71.0, 71.0, 75.0], **out}
    study = {"scenes": {"b": {"label": "checkerboard, 0 lx", "methods": {"uniform": row}}}}
    (note,) = order_error_notes(study)
    assert note.startswith("checkerboard, 0 lx, uniform auto (MIGL 71/71/75): RMSE 5.227 mm")
    assert f"from {out['order_errors']} pixels" in note
    assert f"{out['rmse_mm_without_order_errors']:.3f} mm." in note
