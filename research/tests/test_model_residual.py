"""The linear calibration model's own residual on the virtual rig's geometry (issue 15).

References the code under test did not produce:

* the issue's numbers, computed independently from the pinhole geometry: 0.146 mm RMS over the
  25 calibration depths 2..50 mm and -0.166 mm mean over the Ch. 6 depths 10..28 mm;
* the bias the sweep itself measures (rendered fringe images, sensor noise, the decoder, the
  same calibration procedure) at 0 lx and MIGL 255, where noise averages out of the mean.

Broken variants these reject: a residual without the reference-plane subtraction or with the
phase of one depth for all (bias 0 or grossly off), an unfiltered or differently filtered map
(the thesis depths' numbers move in the third decimal only for the filter, so the sweep
comparison below is what pins the procedure), the sign of the error flipped (the per-depth
bias runs from -0.18 mm at 18 mm to +0.29 mm at 50 mm), and a "model residual" that is
really the rational model's (1e-5 mm).
"""

from __future__ import annotations

import numpy as np
import pytest

from hdrfringe.errors import InputError
from hdrfringe_thesis.ch4 import THESIS_DEPTHS_MM, Ch4Setup, ch4_block
from hdrfringe_thesis.model_residual import model_residual

#: The thesis's geometry (1.9 m, 15 degrees, 320 mm field) on a coarser camera: the residual is
#: a property of the geometry, and 162 x 124 pixels give it to 1e-4 mm in 1 s.
GEOMETRY = Ch4Setup(width=162, height=124)
CH6_DEPTHS = tuple(float(d) for d in range(10, 29, 2))


@pytest.fixture(scope="module")
def thesis_residual():
    return model_residual(GEOMETRY, THESIS_DEPTHS_MM)


def test_linear_residual_on_the_thesis_geometry_matches_the_issue(thesis_residual) -> None:
    r = thesis_residual
    assert r.rms_total_mm == pytest.approx(0.146, abs=0.0005)
    assert r.over(CH6_DEPTHS).mean_mm == pytest.approx(-0.166, abs=0.0005)
    # the shape of the curve: negative in the middle, positive at the far end
    assert r.over([18.0]).bias_mm[0] == pytest.approx(-0.181, abs=0.002)
    assert r.over([50.0]).bias_mm[0] == pytest.approx(0.294, abs=0.002)
    # a geometric bias: nearly the same at every pixel of a depth
    assert np.all(np.abs(r.rms_mm) >= np.abs(r.bias_mm))
    assert np.all(r.rms_mm - np.abs(r.bias_mm) < 0.01)


def test_the_rational_model_leaves_no_residual() -> None:
    """The rational model is exact for pinhole optics: what the linear model leaves is its own."""
    r = model_residual(GEOMETRY, THESIS_DEPTHS_MM, CH6_DEPTHS, model="rational")
    assert r.rms_total_mm < 2e-4


def test_residual_equals_the_bias_the_sweep_measures() -> None:
    """At 0 lx and MIGL 255 the sweep's mean error per depth (noisy images, decoder,
    calibration) is the model residual: the two agree within 2 um at every depth."""
    setup = Ch4Setup(width=96, height=72, camera_field_mm=47.4)  # the thesis's sampling
    depths = (6.0, 18.0, 30.0, 42.0)
    sweep = ch4_block("sinusoidal-3", 6, (0.0,), (255.0,), depths, setup)
    predicted = model_residual(setup, depths)
    measured = sweep["mean_error_mm"][0, 0]
    assert np.abs(measured - predicted.bias_mm).max() < 0.002
    # the budget closes: RMSE^2 = bias^2 + std^2 per cell
    rmse, bias, std = (sweep[k][0, 0] for k in ("rmse_mm", "mean_error_mm", "std_mm"))
    np.testing.assert_allclose(rmse**2, bias**2 + std**2, rtol=1e-9)


def test_over_refuses_depths_not_evaluated(thesis_residual) -> None:
    with pytest.raises(InputError, match="not evaluated at"):
        thesis_residual.over([11.0])
    with pytest.raises(InputError, match="unknown calibration model"):
        model_residual(GEOMETRY, THESIS_DEPTHS_MM, model="cubic")
