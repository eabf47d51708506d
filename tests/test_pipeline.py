"""The pipeline on the virtual rig: calibration and height (thesis Sec. 2.4-2.5, 4.1, Table 4.3),
measure on captures, on the live rig with a strategy and on a replayed sweep, the writer."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.calibration import (
    Calibration,
    CalibrationMismatchError,
    filter_map,
    fit_linear_k,
    measurement_mask,
)
from hdrfringe.core.captures import Captures
from hdrfringe.core.frames import CenterlineFrame, Frame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError, OutputExistsError
from hdrfringe.io.results import read_map_tiff
from hdrfringe.pipeline import MeasurementMetrics, calibrate, measure, strategy_summary
from hdrfringe.rig.scenes import THESIS_CALIBRATION_DEPTHS_MM, mask, white_plate
from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
from hdrfringe.strategies import CapturedSet, StrategyResult
from hdrfringe.strategies.lpa import lpa
from hdrfringe.tasks.measure import write_measurement, write_strategy_outputs
from tests.conftest import shared_once

DEPTHS = np.array(THESIS_CALIBRATION_DEPTHS_MM)
#: Where the calibrated plate is measured: every sixth calibration depth (2, 14, 26, 38, 50 mm),
#: both ends of the range and its middle; measuring all 25 cost 4x the time and told the same.
CHECK = np.arange(0, len(DEPTHS), 6)
#: Thesis Table 4.3, white plate, 0 lx, MIGL 255, pitch 6: mean RMSE over the 25 depths (mm).
THESIS_TABLE_4_3 = {("sinusoidal", 3): 0.27, ("triangular", 3): 0.33, ("triangular", 2): 1.03}


def plate_rig(depth: float, *, noise: bool, seed: int) -> SimulatedRig:
    rig = SimulatedRig(white_plate(depth), seed=seed)
    if not noise:
        cam = dataclasses.replace(rig.camera, read_noise_dn8=0.0, full_well_e=None)
        rig = rig.replace(camera=cam)
    return rig


def captured(rig: SimulatedRig, frames: list[Frame]) -> Captures:
    """What `hdrfringe simulate` would write, kept in memory."""
    return rig.capture_folder(frames)


def frames_for(spec: FringeSpec) -> list[Frame]:
    return [*spec.frames(), CenterlineFrame(512, spec.orientation, 255)]


def series(spec: FringeSpec, *, noise: bool, seed: int) -> list[Captures]:
    fr = frames_for(spec)
    return [captured(plate_rig(d, noise=noise, seed=seed), fr) for d in (0.0, *DEPTHS)]


def thesis_calibration(
    tmp_path_factory: pytest.TempPathFactory, pattern: str, steps: int
) -> Calibration:
    """The linear calibration of thesis Table 4.3's conditions (``pattern``, ``steps``, pitch
    6): the noisy :func:`series` of seed 11, calibrated once for the whole run and read back
    from its HDF5 file (:func:`tests.conftest.shared_once`): research/tests/test_tradeoff.py
    measures with the sinusoidal 3-step one too (5 s of CPU each)."""
    from hdrfringe.io.calibration_file import load_calibration, save_calibration

    def make(folder: Path) -> None:
        spec = FringeSpec(pattern, steps, 6.0)  # type: ignore[arg-type]
        cal = calibrate(series(spec, noise=True, seed=11), model="linear")
        save_calibration(folder / "cal.h5", cal)

    folder = shared_once(tmp_path_factory, f"thesis_calibration_{pattern}_{steps}", make)
    return load_calibration(folder / "cal.h5")


def pooled_rmse(results: list[MeasurementMetrics]) -> float:
    return float(np.sqrt(np.mean([r.rmse_mm**2 for r in results])))


def test_linear_model_error_matches_geometry_and_rational_is_5x_lower() -> None:
    """Noise off, nothing saturated: the measured linear RMSE is the model's own error.

    Model error from the rig geometry: for every pixel, the true projector column u(h) at each
    depth is the pinhole projection (into the projector) of the camera ray's intersection with
    the plate z = h; Delta-phi_j = 2*pi*(u(h_j) - u(0))/p exactly. K* from Eq. 2.15 on those
    exact phases, filtered like the calibration (median + mean, 21 px), predicts heights
    K* Delta-phi_j; its error against h_j, pooled over the measured depths (:data:`CHECK`) and
    the measurement pixels
    (10 px border excluded), is the linear model's error. The pipeline's RMSE (images -> phase
    -> centerline -> calibration -> height) must match it within 10 %.
    """
    spec = FringeSpec("sinusoidal", 4, 8.0)
    folders = series(spec, noise=False, seed=0)
    assert all(f.images.max() < 255 for f in folders)  # nothing saturated
    lin = calibrate(folders, model="linear")
    rat = calibrate(folders, model="rational")
    checked = [folders[1 + j] for j in CHECK]
    measured_lin = pooled_rmse([measure(f, lin).metrics for f in checked])
    measured_rat = pooled_rmse([measure(f, rat).metrics for f in checked])

    u = [plate_rig(d, noise=False, seed=0).truth().u for d in (0.0, *DEPTHS)]
    dphi = np.stack([2 * np.pi * (uj - u[0]) / spec.pitch_px for uj in u[1:]])
    k_star = filter_map(fit_linear_k(dphi, DEPTHS), 21, 10)  # fitted on all 25, as calibrate
    inside = measurement_mask(k_star.shape, 10)
    err = (k_star[None] * dphi - DEPTHS[:, None, None])[CHECK]  # the measured depths
    model_rmse = float(np.sqrt(np.mean(err[:, inside] ** 2)))
    print(
        f"\nlinear model error from geometry {model_rmse:.4f} mm; measured linear "
        f"{measured_lin:.4f} mm; measured rational {measured_rat:.4f} mm"
    )
    assert 0.05 < model_rmse < 0.5  # a real, non-trivial model error at 1.9 m standoff
    assert measured_lin == pytest.approx(model_rmse, rel=0.10)
    assert measured_rat * 5 < measured_lin


@pytest.mark.parametrize(("pattern", "steps"), list(THESIS_TABLE_4_3))
def test_thesis_conditions_white_plate(
    pattern: str, steps: int, tmp_path: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    """sigma = 1 gray level, no ambient light, MIGL 255, pitch 6, linear model (as the thesis).

    Calibrated on one capture series (the 25 depths), measured on a second one (other noise)
    at the :data:`CHECK` depths (the thesis's table averages all 25).
    """
    spec = FringeSpec(pattern, steps, 6.0)  # type: ignore[arg-type]
    cal = thesis_calibration(tmp_path_factory, pattern, steps)
    frames = frames_for(spec)
    second = [captured(plate_rig(DEPTHS[j], noise=True, seed=12), frames) for j in CHECK]
    results = [measure(f, cal).metrics for f in second]
    mean_rmse = float(np.mean([r.rmse_mm for r in results]))
    thesis = THESIS_TABLE_4_3[(pattern, steps)]
    line = (
        f"{pattern} {steps}-step, pitch 6, 0 lx, MIGL 255: mean RMSE over {len(CHECK)} depths "
        f"{mean_rmse:.3f} mm (thesis Table 4.3: {thesis} mm, ratio {mean_rmse / thesis:.2f})"
    )
    print("\n" + line)
    (tmp_path / "report.json").write_text(json.dumps({"line": line}))
    assert min(r.valid_fraction for r in results) > 0.99
    assert mean_rmse < 0.5


def test_mask_height_matches_truth_and_ply_opens(tmp_path) -> None:
    """The mask measured with a rational calibration (sinusoidal 4-step, pitch 8, sigma 1).

    Tolerance: the plate gives about 0.05 mm RMSE at these settings; on the mask, camera and
    projector blur average the height over about a pixel (0.5 mm) where the surface is steep
    (slopes up to ~1.7), adding error at the mask's edges. 0.15 mm RMSE and 99 % valid pixels
    leave room for those without hiding a wrong calibration (the linear model's own error is
    0.15 mm; a wrong fringe order costs mm).
    """
    import trimesh

    from hdrfringe.pipeline import calibration_geometry
    from hdrfringe.tasks.measure import write_height_outputs

    spec = FringeSpec("sinusoidal", 4, 8.0)
    cal = calibrate(series(spec, noise=True, seed=3), model="rational")
    rig = SimulatedRig(mask(), seed=4)
    res = measure(captured(rig, frames_for(spec)), cal)
    m = res.metrics
    print(
        f"\nmask vs truth: RMSE {m.rmse_mm:.4f} mm, bias {m.bias_mm:+.4f} mm, "
        f"max {m.max_abs_mm:.3f} mm, valid {100 * m.valid_fraction:.2f} %"
    )
    assert m.valid_fraction > 0.99
    assert m.rmse_mm < 0.15
    assert abs(m.bias_mm) < 0.05
    write_height_outputs(tmp_path, res.height_mm, calibration_geometry(cal))
    cloud = trimesh.load(tmp_path / "points.ply")
    pts = np.asarray(cloud.vertices)
    assert len(pts) == int(np.isfinite(res.height_mm).sum())
    # x, y in mm at the camera's 0.49 mm/px: the field is about 320 x 244 mm
    assert 300 < np.ptp(pts[:, 0]) < 340 and 220 < np.ptp(pts[:, 1]) < 260
    assert np.nanmax(res.height_mm) == pytest.approx(pts[:, 2].max(), abs=1e-3)


# ---------------------------------------------------------------------------------------------
# pipeline.measure on captures, on the live rig with a strategy, on a replayed sweep
# ---------------------------------------------------------------------------------------------

#: A quarter-resolution camera (same field of view): fast. At 6.3 projector px per camera px a
#: pitch of 8 would alias, so the family is 1024 px (one period: absolute) and 64 px.
SMALL = CameraModel(width=162, height=124)
SMALL_SPECS = [FringeSpec("sinusoidal", 4, p) for p in (1024.0, 64.0)]
SMALL_FRAMES = [f for s in SMALL_SPECS for f in s.frames()]


def small_rig(depth: float = 25.0, lux: float = 0.0, seed: int = 0) -> SimulatedRig:
    return SimulatedRig(white_plate(depth), camera=SMALL, lighting=Lighting(lux), seed=seed)


@pytest.fixture(scope="module")
def small_cal() -> Calibration:
    plates = [small_rig(d, seed=5).capture_folder(SMALL_FRAMES) for d in (0, 10, 20, 30, 40)]
    return calibrate(plates, model="rational")


def errors_by_hand(height: np.ndarray, truth: np.ndarray, border: int) -> tuple:
    """Bias, std, RMSE and count of the finite errors inside the border (numpy only)."""
    err = (height - truth)[border:-border, border:-border]
    err = err[np.isfinite(err)]
    return float(err.mean()), float(err.std()), float(np.sqrt(np.mean(err**2))), err.size


def assert_errors_match(m: MeasurementMetrics, height: np.ndarray, truth: np.ndarray) -> None:
    bias, std, rmse, n = errors_by_hand(height, truth, m.border_px)
    assert m.n_pixels == n > 0
    assert m.bias_mm == pytest.approx(bias, rel=1e-9, abs=1e-12)
    assert m.std_mm == pytest.approx(std, rel=1e-9)
    assert m.rmse_mm == pytest.approx(rmse, rel=1e-9)


def test_measure_captures_metrics_against_the_rig_truth(small_cal: Calibration) -> None:
    """Partly saturated plate (250 lx): saturated pixels are invalid, the rest measured; every
    figure recomputed here from the images, the height and the rig's ground truth."""
    rig = small_rig(17.0, lux=250, seed=9)
    caps = rig.capture_folder(SMALL_FRAMES)
    res = measure(caps, small_cal, label="plate at 17 mm")
    m = res.metrics
    saturated = (caps.images >= 255).any(axis=0)
    inside = np.zeros(saturated.shape, bool)
    inside[10:-10, 10:-10] = True
    assert m.saturated_fraction == float(saturated.mean()) and 0.1 < m.saturated_fraction < 0.3
    assert m.saturated_fraction_measurement_pixels == pytest.approx(saturated[inside].mean())
    assert m.valid_fraction == pytest.approx(np.isfinite(res.height_mm)[inside].mean())
    assert not np.isfinite(res.height_mm[saturated]).any()  # saturated pixels are invalid
    assert m.truth == "truth_height_mm map" and m.source == "plate at 17 mm"
    assert_errors_match(m, res.height_mm, rig.truth().height_mm)
    # and the heights are right: measured 0.31 mm RMSE (the noise grows with the 64 px pitch);
    # a wrong fringe order or calibration costs millimetres
    assert m.rmse_mm < 0.5 and abs(m.bias_mm) < 0.05
    assert m.strategy is None and m.live_rig is None and res.strategy_results == ()
    x, y, z = res.points()  # camera geometry recorded with the calibration: mm
    assert (
        np.nanmax(x) - np.nanmin(x) > 250
        and np.nanmax(y) - np.nanmin(y) > 180
        and np.array_equal(z, res.height_mm, equal_nan=True)
    )


def test_measure_live_rig_with_a_strategy(small_cal: Calibration) -> None:
    """LPA per pitch on the live rig = LPA run by hand on the same rig (same seed, same images);
    the typed metrics sum its sets and measure against the rig's truth."""
    res = measure(
        small_rig(lux=600), small_cal, strategy="lpa", params={"step": 10.0}, specs=SMALL_SPECS
    )
    by_hand = small_rig(lux=600)
    ref = [lpa(by_hand, s, step=10.0) for s in SMALL_SPECS]
    assert np.array_equal(res.captures.images, np.concatenate([r.images for r in ref]))
    s = res.metrics.strategy
    assert s is not None and s.name == "lpa" and s.index_quantity == "migl"
    assert s.values == tuple(tuple(r.migls) for r in ref) and len(s.values[1]) > 3
    assert s.sets_captured == sum(len(r.migls) for r in ref) and s.images_captured == 4 * (
        s.sets_captured
    )
    assert s.never_unsaturated_fraction == float(ref[-1].never_unsaturated.mean()) == 0.0
    m = res.metrics
    assert m.valid_fraction == 1.0 and m.saturated_fraction == 0.0
    assert_errors_match(m, res.height_mm, by_hand.truth().height_mm)
    assert m.live_rig["scene"]["name"] == "white_plate" and m.live_rig["seed"] == 0
    assert m.source == "white_plate" and res.dpa is None and m.dpa is None


def test_a_mismatched_calibration_is_refused_before_capturing(
    small_cal: Calibration, monkeypatch: pytest.MonkeyPatch
) -> None:
    rig = small_rig()
    calls: list[int] = []
    capture = rig.capture
    monkeypatch.setattr(rig, "capture", lambda *a, **k: calls.append(1) or capture(*a, **k))
    with pytest.raises(CalibrationMismatchError, match=r"pitch 64 px \(calibration\) vs 32 px"):
        measure(rig, small_cal, strategy="lpa", specs=[FringeSpec("sinusoidal", 4, 32.0)])
    assert calls == []
    measure(rig, None, strategy="lpa", specs=[FringeSpec("sinusoidal", 4, 32.0)])
    assert calls  # the spy sees captures


@pytest.fixture(scope="module")
def replayed(small_cal: Calibration) -> tuple:
    """DPA replayed on a step-1 sweep 255..150 of the plate under 600 lx, and live on the same
    rig after its noise is reset (same images for the same frames)."""
    rig = small_rig(lux=600)
    frames = [f for m in range(255, 149, -1) for s in SMALL_SPECS for f in s.with_migl(m).frames()]
    sweep = rig.capture_folder(frames)
    rig.reset_noise()
    replay = measure(sweep, small_cal, strategy="dpa")
    live = measure(rig, small_cal, strategy="dpa", specs=SMALL_SPECS)
    return replay, live, rig


def test_replayed_sweep_equals_the_live_run(replayed: tuple) -> None:
    replay, live, rig = replayed
    assert np.array_equal(replay.captures.images, live.captures.images)
    assert replay.metrics.strategy == live.metrics.strategy
    assert replay.metrics.strategy.sets_captured > 2 * len(SMALL_SPECS)
    assert replay.metrics.rmse_mm == live.metrics.rmse_mm
    assert_errors_match(replay.metrics, replay.height_mm, rig.truth().height_mm)
    assert replay.metrics.live_rig is None and live.metrics.live_rig is not None
    # DPA's analysis: only the replay holds every integer MIGL, for LPA step 1's exact CDF
    assert all(c.exact is not None for c in replay.dpa) and all(c.exact is None for c in live.dpa)
    for block, res in ((replay.metrics.dpa, replay), (live.metrics.dpa, live)):
        assert block.correction == "none (identity)" and block.threshold == 0.1
        assert [list(e.rules) for e in block.sets] == [
            r.details["rules"] for r in res.strategy_results
        ]
        assert [[c["migl"] for c in e.captures] for e in block.sets] == [
            r.migls for r in res.strategy_results
        ]


def test_write_measurement_round_trip(tmp_path: Path, replayed: tuple) -> None:
    replay = replayed[0]
    out = tmp_path / "out"
    files = write_measurement(replay, out)
    assert files == sorted(p.name for p in out.iterdir())
    assert {"height.tiff", "points.ply", "migl_index.tiff", "migl_pie.png", "dpa_cdf.png"} <= set(
        files
    )
    written = json.loads((out / "metrics.json").read_text())
    assert written == replay.metrics.to_dict()
    assert written["migls"] == [list(v) for v in replay.metrics.strategy.values]
    assert "max_abs_difference_initial_vs_exact" in written["dpa"]["sets"][1]
    height32 = replay.height_mm.astype(np.float32)  # the TIFF holds float32
    assert np.array_equal(read_map_tiff(out / "height.tiff"), height32, equal_nan=True)
    with pytest.raises(OutputExistsError, match="--force"):
        write_measurement(replay, out)


def test_metrics_are_strict_json_and_name_what_varied(tmp_path: Path) -> None:
    """No valid pixel: the error figures are NaN in memory, null in metrics.json. A strategy
    that varies the exposure gets its index map and values named after it."""
    nan = float("nan")
    m = MeasurementMetrics(
        "x", model="linear", border_px=10, valid_fraction=0.0, truth="scene.depth_mm = 4",
        bias_mm=nan, std_mm=nan, rmse_mm=nan, max_abs_mm=nan, n_pixels=0,
    )  # fmt: skip
    assert json.loads(json.dumps(m.to_dict(), allow_nan=False))["rmse_mm"] is None
    index = np.array([[10.0, 2.5]], np.float32)
    res = StrategyResult(
        images=np.zeros((4, 1, 2), np.uint8), spec=FringeSpec("sinusoidal", 4, 8.0),
        captured=[CapturedSet(exposure_ms=10.0), CapturedSet(exposure_ms=2.5)], index_map=index,
        newly_unsaturated=[1, 1], never_unsaturated=np.zeros((1, 2), bool), strategy="exposures",
        index_quantity="exposure_ms",
    )  # fmt: skip
    d = strategy_summary([res]).to_dict()
    assert d["index_quantity"] == "exposure_ms" and d["exposures_ms"] == [10.0, 2.5]
    assert "migls" not in d
    names = write_strategy_outputs(tmp_path, [res])
    assert names == ["exposure_ms_index.tiff", "exposure_ms_index.png", "exposure_ms_pie.png"]
    assert np.array_equal(read_map_tiff(tmp_path / "exposure_ms_index.tiff"), index)


def test_measure_refuses_what_it_cannot_use(small_cal: Calibration) -> None:
    caps = small_rig().capture_folder(SMALL_FRAMES)
    with pytest.raises(InputError, match="params given without a strategy"):
        measure(caps, params={"step": 5.0})
    with pytest.raises(InputError, match="centerline given without a strategy"):
        measure(caps, centerline=CenterlineFrame(512, "vertical", 255))
    with pytest.raises(InputError, match="needs specs"):
        measure(small_rig(), strategy="lpa")
    with pytest.raises(InputError, match="takes Captures or a Rig"):
        measure("some/folder")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="lpa has no parameter 'threshold'"):
        measure(caps, strategy="lpa", params={"threshold": 0.1})


def test_the_docs_python_api_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """docs/measurement.md's "Python API" example runs as written and writes its folder."""
    root = Path(__file__).resolve().parents[1]
    text = (root / "docs" / "measurement.md").read_text(encoding="utf-8")
    code = text.split("## Python API", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(code, "docs/measurement.md", "exec"), scope)
    m = scope["result"].metrics
    assert m.strategy.name == "dpa" and m.valid_fraction > 0.99 and m.rmse_mm < 0.5
    assert "dpa_cdf.png" in scope["files"] and (tmp_path / "out" / "metrics.json").is_file()


def test_valid_fraction_is_the_heights_not_the_truth_maps(small_cal: Calibration) -> None:
    """docs/measurement.md: valid_fraction is the finite fraction of the height over the
    measurement pixels. Before issue 11, a truth map with NaN overwrote it with the fraction
    where height and truth are both finite."""
    from dataclasses import replace

    caps = small_rig(17.0, seed=3).capture_folder(SMALL_FRAMES)
    truth = caps.maps["truth_height_mm"].copy()
    truth[:, : truth.shape[1] // 2] = np.nan  # ground truth known on the right half only
    res = measure(replace(caps, maps={**caps.maps, "truth_height_mm": truth}), small_cal)
    inside = small_cal.measurement_mask()
    height_valid = np.isfinite(res.height_mm)[inside].mean()
    assert height_valid > 0.9
    assert res.metrics.valid_fraction == pytest.approx(height_valid)
    assert res.metrics.n_pixels == int(
        (np.isfinite(res.height_mm) & np.isfinite(truth))[inside].sum()
    )
