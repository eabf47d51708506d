"""Bias, std, RMSE and the model residual in every report and in ``metrics.json`` (issue 15).

* ``measure``'s ``calibration_residual_mm`` is the calibration's own fit residual, and a linear
  calibration's measured bias on the virtual rig is the model residual computed from the
  geometry (an independent reference: noise-free phases, no images); the rational model has
  none. A metric that reported the rational map for a linear calibration, or the measurement's
  RMSE, fails here.
* The reports (read from the session's quick reproduction, no extra sweep): every cell
  decomposes (RMSE^2 = bias^2 + std^2 per measurement), the tables give bias / std beside the
  RMSE and the model residual under them, blank thesis cells carry a footnote, no ratio of a
  fringe-order failure or of a near-zero bias is printed, and the old wrong sentences are gone.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import xarray as xr

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.pipeline import calibrate, measure
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, SimulatedRig
from hdrfringe_thesis.ch4 import Ch4Setup
from hdrfringe_thesis.ch4_report import (
    FAILURE_MM,
    Notes,
    _onset_words,
    _vs,
    saturation_onset,
)
from hdrfringe_thesis.engine import open_results
from hdrfringe_thesis.model_residual import model_residual

CAMERA = CameraModel(width=162, height=124)
SPECS = [FringeSpec("sinusoidal", 4, p) for p in (1024.0, 64.0, 8.0)]
FRAMES = [f for s in SPECS for f in s.frames()]
CAL_DEPTHS = (10.0, 20.0, 30.0, 40.0)


def _rig(depth: float) -> SimulatedRig:
    return SimulatedRig(white_plate(depth), camera=CAMERA, seed=3)


@pytest.fixture(scope="module")
def plates() -> list:
    return [_rig(d).capture_folder(FRAMES) for d in (0.0, *CAL_DEPTHS)]


@pytest.fixture(scope="module")
def at_25mm():
    return _rig(25.0).capture_folder(FRAMES)


def test_metrics_give_the_calibration_residual_and_the_bias_is_the_models(plates, at_25mm):
    geometry = Ch4Setup(width=CAMERA.width, height=CAMERA.height)  # the rig's default geometry
    model = model_residual(geometry, CAL_DEPTHS, (25.0,))
    fit = {}
    for name in ("linear", "rational"):
        cal = calibrate(plates, model=name)
        m = measure(at_25mm, cal).metrics
        mask = cal.measurement_mask()
        by_hand = float(np.median(cal.residual_rms_mm[name][mask]))
        assert m.calibration_residual_mm == pytest.approx(by_hand, rel=1e-6)
        assert m.to_dict()["calibration_residual_mm"] == m.calibration_residual_mm
        fit[name] = m
    lin, rat = fit["linear"], fit["rational"]
    # the linear model's bias at 25 mm is the geometric model residual (-0.104 mm) within 5 um
    assert lin.bias_mm == pytest.approx(float(model.bias_mm[0]), abs=0.005)
    assert abs(rat.bias_mm) < 0.01  # the rational model has no model residual
    # the fit residual holds the model's residual (0.113 mm RMS at 10..40 mm) plus noise
    rms = model_residual(geometry, CAL_DEPTHS).rms_total_mm
    assert rms < lin.calibration_residual_mm < rms + 0.03
    assert rat.calibration_residual_mm < 0.6 * lin.calibration_residual_mm
    # and the std is the same with both models: the methods' own error
    assert lin.std_mm == pytest.approx(rat.std_mm, rel=0.05)


def test_thesis_cells_say_why_they_are_blank_and_ratios_that_mislead_are_left_out() -> None:
    notes = Notes()
    assert _vs(0.31, 0.127, "{:.3f}", notes) == "0.310 / 0.127 (0.41)"
    failure = _vs(373.42, 0.747, "{:.3f}", notes, failures=True)
    assert failure.startswith("373.420 / 0.747 [a]") and "(0.00)" not in failure
    assert FAILURE_MM < 85.05
    assert _vs(29.33, 71.0, "{:.2f}", notes) == "29.33 / 71.00 (2.42)"  # sets are no failures
    assert _vs(-0.02, -0.166, "{:.3f}", notes, ratio=False) == "-0.020 / -0.166"
    blank = _vs(None, 0.125, "{:.3f}", notes, missing="the thesis has no 300 lx row")
    assert blank == "- [b] / 0.125"
    assert notes.markdown().startswith("[a] no ratio: the thesis's value is dominated by")
    assert notes.markdown().endswith("[b] the thesis has no 300 lx row")


def test_saturation_onset_is_the_highest_clear_migl() -> None:
    sat = xr.DataArray(
        np.array([[[0.0, 0.4]], [[0.0, 0.0]], [[0.0, 0.0]]])[None],
        dims=("pattern", "migl", "depth_mm", "added_lux"),
        coords={"pattern": ["p"], "migl": [255.0, 240.0, 225.0], "added_lux": [300.0, 900.0]},
    )
    assert saturation_onset(xr.Dataset({"saturated_fraction_light": sat}), "p") == {
        300.0: 255.0,
        900.0: 240.0,
    }


def test_an_onset_that_never_clears_is_said_in_words() -> None:
    """A light level at which some pixel saturates at every MIGL swept (NaN onset: the
    gamma 2.2 preset at 900 lx) reads as such in the report, not "MIGL nan"."""
    assert _onset_words(float("nan")) == "some pixel saturated at every MIGL of the sweep"
    assert _onset_words(120.0) == "no pixel saturated at or below MIGL 120"


@pytest.mark.xdist_group("dask-cluster")
def test_ch4_stores_decompose_the_rmse(quick_run) -> None:
    ds = open_results(quick_run / "ch4.zarr")
    rmse, bias, std = (ds[v].values for v in ("rmse_mm", "mean_error_mm", "std_mm"))
    np.testing.assert_allclose(rmse**2, bias**2 + std**2, rtol=1e-6)
    sim = open_results(quick_run / "ch4_simulation.zarr")
    for kind in ("light", "noise"):
        r, b, s = (sim[f"{v}_{kind}_mm"].values for v in ("rmse", "mean_error", "std"))
        np.testing.assert_allclose(r**2, b**2 + s**2, rtol=1e-6)
    # the 0 lx, MIGL 255 bias is the model residual at every depth (the quick grid calibrates
    # on its own four depths)
    setup = Ch4Setup(**json.loads(ds.attrs["sweep_params"])["setup"])
    depths = [float(d) for d in ds["depth_mm"].values]
    predicted = model_residual(setup, depths).bias_mm
    measured = ds["mean_error_mm"].sel(pattern="sinusoidal-3", lux=0.0, migl=255.0).values
    assert np.abs(measured - predicted).max() < 0.002


@pytest.mark.xdist_group("dask-cluster")
def test_report_gives_the_error_budget_and_no_misleading_ratio(quick_run) -> None:
    report = (quick_run / "report.md").read_text()
    tables = json.loads((quick_run / "tables.json").read_text())
    assert report.count("Model residual at these depths") >= 7  # Tables 4.1-4.3, 5.1-6.2
    assert "(0.00)" not in report and "no ratio: the thesis's value is dominated" in report
    # every blank thesis cell ("- [x] / ours") has its footnote
    for marker in set(re.findall(r"- (\[[a-z]\]) / ", report)):
        assert f"{marker} " in report.replace(f"- {marker} /", "")
    for wrong in ("noise-level scale", "uniformly", "a scale factor in so narrow a range"):
        assert wrong not in report
    budget = tables["ch4"]["error_budget"]
    # the budget closes with the model residual's RMS (the bias changes sign over depth, so
    # its mean over depth does not carry it) and the std: 0.120^2 + 0.046^2 ~ 0.125^2
    assert budget["rmse_mm"] ** 2 == pytest.approx(
        budget["model_rms_mm"] ** 2 + budget["std_mm"] ** 2, rel=0.1
    )
    assert abs(budget["bias_mm"] - budget["model_mean_mm"]) < 0.002
    assert budget["std_mm"] < 0.5 * budget["rmse_mm"]  # the RMSE is mostly the model's
    for row in tables["ch4"]["table_4_1"]:
        assert {"bias_mm", "std_mm", "saturation_onset_migl"} <= set(row)
    adaptive = tables["adaptive"]
    assert set(adaptive["model_residual"]) == {"ch5_plate", "checkerboard", "ch6_plate"}
    for row in adaptive["table_5_1"]:
        assert len(row["bias_mm"]) == len(row["std_mm"]) == 3
