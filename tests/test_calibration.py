"""Phase-to-height calibration: fits, filter, residuals, calibration files, compatibility."""

from __future__ import annotations

import math
import os
from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy import ndimage

from hdrfringe.core.calibration import (
    MODELS,
    Calibration,
    CalibrationMismatchError,
    calibrate,
    check_compatible,
    evaluate_model,
    filter_map,
    fit_linear_k,
    fit_model,
    measurement_mask,
    residual_rms,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import HdrFringeError, InputError, OutputExistsError
from hdrfringe.io import calibration_file
from hdrfringe.io.calibration_file import (
    CalibrationFileError,
    load_calibration,
    save_calibration,
)

DEPTHS = np.arange(2.0, 51.0, 2.0)  # thesis Sec. 4.1: 25 positions, 2..50 mm by 2 mm
SHAPE = (40, 52)


def pinhole_maps(shape: tuple[int, int] = SHAPE) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel c (rad/mm) and e (1/mm) of ``dphi = c h / (1 + e h)``, smooth and varying.

    Linear in the pixel coordinates, so the calibration filter leaves them unchanged.
    """
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    c = 0.70 + 0.004 * cols + 0.002 * rows
    e = 4.5e-4 + 3e-6 * cols - 2e-6 * rows
    return c, e


def synthetic(
    depths: np.ndarray = DEPTHS, shape: tuple[int, int] = SHAPE, noise: float = 0.0, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Reference phase, plate phases (J, H, W), and the c, e maps of the exact relation."""
    c, e = pinhole_maps(shape)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    ref = 2 * np.pi * (100.0 + 0.9 * cols + 0.01 * rows) / 6.0
    h = np.asarray(depths, dtype=np.float64)[:, None, None]
    phases = ref + c * h / (1.0 + e * h)
    if noise:
        phases = phases + noise * np.random.default_rng(seed).standard_normal(phases.shape)
    return ref, phases, c, e


def exact_dphi(h: float, shape: tuple[int, int] = SHAPE) -> np.ndarray:
    c, e = pinhole_maps(shape)
    return c * h / (1.0 + e * h)


# --------------------------------------------------------------------------------------------
# fits
# --------------------------------------------------------------------------------------------
def test_linear_k_is_eq_2_15_closed_form_with_nan_samples() -> None:
    ref, phases, _, _ = synthetic(noise=0.01)
    dphi = phases - ref
    dphi[3, 5, 7] = np.nan
    dphi[:, 2, 2] = np.nan  # no sample at all
    dphi[1:, 4, 4] = np.nan  # a single sample: K needs 2
    k = fit_linear_k(dphi, DEPTHS)
    for r, c in [(0, 0), (5, 7), (20, 31), (39, 51)]:
        d = dphi[:, r, c]
        ok = np.isfinite(d)
        expected = np.sum(d[ok] * DEPTHS[ok]) / np.sum(d[ok] ** 2)
        assert k[r, c] == pytest.approx(expected, rel=1e-13)
    assert np.isnan(k[2, 2]) and np.isnan(k[4, 4])
    assert np.isfinite(np.delete(k.ravel(), [2 * SHAPE[1] + 2, 4 * SHAPE[1] + 4])).all()


def test_rational_model_recovers_heights_exactly() -> None:
    ref, phases, c, e = synthetic()
    coef = fit_model(phases - ref, DEPTHS, "rational")
    # h = dphi / (a + b dphi) inverts dphi = c h / (1 + e h) with a = c, b = -e
    np.testing.assert_allclose(coef[0], c, rtol=1e-10)
    np.testing.assert_allclose(coef[1], -e, rtol=1e-7)
    for h in [*DEPTHS, 0.5, 13.7, 37.1, 55.0]:
        got = evaluate_model(coef, exact_dphi(h), "rational")
        assert np.max(np.abs(got - h)) < 1e-9
    assert np.nanmax(residual_rms(coef, phases - ref, DEPTHS, "rational")) < 1e-9


def test_rational_exact_with_missing_samples_and_refine_harmless() -> None:
    ref, phases, _, _ = synthetic()
    dphi = phases - ref
    rng = np.random.default_rng(3)
    dphi[rng.random(dphi.shape) < 0.3] = np.nan
    for refine in (False, True):
        coef = fit_model(dphi, DEPTHS, "rational", refine=refine)
        assert np.nanmax(residual_rms(coef, dphi, DEPTHS, "rational")) < 1e-9


def test_refine_never_increases_height_residual() -> None:
    ref, phases, _, _ = synthetic(noise=0.05)
    dphi = phases - ref
    plain = residual_rms(fit_model(dphi, DEPTHS, "rational"), dphi, DEPTHS, "rational")
    refined = residual_rms(
        fit_model(dphi, DEPTHS, "rational", refine=True), dphi, DEPTHS, "rational"
    )
    assert np.all(refined <= plain * (1 + 1e-12))
    # and the change is far below the noise-level residual (why refine defaults to False)
    assert np.max(np.abs(refined - plain)) < 0.01 * np.median(plain)


def test_polynomials_beat_linear_and_pass_through_zero() -> None:
    ref, phases, _, _ = synthetic()
    dphi = phases - ref
    med = {}
    for model in MODELS:
        coef = fit_model(dphi, DEPTHS, model)
        med[model] = float(np.median(residual_rms(coef, dphi, DEPTHS, model)))
        assert np.all(evaluate_model(coef, np.zeros(SHAPE), model) == 0.0)
    assert 0.05 < med["linear"] < 1.0  # tenths of a mm over 2..50 mm
    assert med["poly2"] < med["linear"] / 20
    assert med["poly3"] < med["poly2"] / 5
    assert med["rational"] < 1e-9


def test_fit_model_needs_enough_samples_per_pixel() -> None:
    ref, phases, _, _ = synthetic(depths=np.array([10.0, 20.0, 30.0]))
    dphi = phases - ref
    dphi[1:, 0, 0] = np.nan  # 1 sample
    dphi[2, 1, 1] = np.nan  # 2 samples: enough for poly2 / rational, not poly3
    for model, want_nan_11 in [("rational", False), ("poly2", False), ("poly3", True)]:
        coef = fit_model(dphi, [10.0, 20.0, 30.0], model)
        assert np.isnan(coef[:, 0, 0]).all()
        assert np.isnan(coef[:, 1, 1]).all() == want_nan_11
        assert np.isfinite(coef[:, 5, 5]).all()


def test_evaluate_model_checks_shapes_and_model() -> None:
    with pytest.raises(InputError, match="expected \\(2, H, W\\)"):
        evaluate_model(np.ones((3, 4, 5)), np.ones((4, 5)), "rational")
    with pytest.raises(InputError, match="unknown calibration model 'cubic'"):
        fit_model(np.ones((3, 4, 5)), [1.0, 2.0, 3.0], "cubic")


# --------------------------------------------------------------------------------------------
# filter and border
# --------------------------------------------------------------------------------------------
def ramp(shape: tuple[int, int] = (80, 100)) -> np.ndarray:
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    return 1.25 + 0.013 * cols - 0.007 * rows


def test_filter_preserves_a_linear_ramp_everywhere() -> None:
    x = ramp()
    out = filter_map(x, 21, 10)
    assert np.max(np.abs(out - x)) < 1e-12


def test_filter_is_median_then_mean_with_unfiltered_border() -> None:
    rng = np.random.default_rng(5)
    x = rng.normal(size=(60, 70))
    window, border = 7, 3
    out = filter_map(x, window, border)
    inner = measurement_mask(x.shape, border)
    med = x.copy()
    med[inner] = ndimage.median_filter(x, size=window)[inner]
    expected = x.copy()
    expected[inner] = ndimage.uniform_filter(med, window)[inner]
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)
    assert np.array_equal(out[~inner], x[~inner])  # the border stays unfiltered


def test_filter_handles_nan_islands_and_outliers() -> None:
    x = ramp()
    x[30:36, 40:47] = np.nan  # an island
    x[60, 20] = np.nan  # a lone invalid pixel
    x[5, 5] = np.nan  # invalid pixel in the border
    spiky = x.copy()
    spiky[50, 70] = 1e6  # an outlier the median removes
    out = filter_map(spiky, 21, 10)
    invalid = np.isnan(x)
    assert np.array_equal(np.isnan(out), invalid)  # invalid stays NaN, nothing else does
    # far (more than a window) from the NaNs and the outlier the ramp is untouched
    near = ndimage.binary_dilation(invalid, np.ones((43, 43), bool))
    near[28:73, 48:93] = True
    far = measurement_mask(x.shape, 10) & ~near
    assert far.sum() > 500
    assert np.max(np.abs(out[far] - x[far])) < 1e-6
    # near them: no poisoning, error bounded by the ramp's variation over one window
    ok = ~invalid
    assert np.max(np.abs(out[ok] - x[ok])) < 0.02 * 21


def test_filter_map_trivial_cases() -> None:
    x = ramp((15, 15))
    assert np.array_equal(filter_map(x, 1, 0), x)  # window 1: no filtering
    assert np.array_equal(filter_map(x, 21, 10), x)  # image is all border
    assert np.isnan(filter_map(np.full((30, 30), np.nan))).all()
    with pytest.raises(InputError, match="odd"):
        filter_map(x, 20)
    with pytest.raises(InputError, match="border"):
        filter_map(x, 21, -1)


def test_measurement_mask() -> None:
    m = measurement_mask((30, 40), 10)
    assert m.shape == (30, 40) and m.sum() == 10 * 20
    assert m[10, 10] and m[19, 29] and not m[9, 20] and not m[20, 30]
    assert measurement_mask((5, 5), 0).all()


# --------------------------------------------------------------------------------------------
# calibrate
# --------------------------------------------------------------------------------------------
SPEC = FringeSpec("sinusoidal", 3, 6.0, "vertical", 40.0, 255.0)
PROVENANCE = {
    "package_version": "0.1.0",
    "created": "2025-01-02T03:04:05+00:00",
    "inputs": {
        "reference": {"path": "captures/plate_00mm", "sha256": "0" * 64},
        "plate_02mm": {"path": "captures/plate_02mm", "sha256": "f" * 64, "depth_mm": 2.0},
    },
    "depths_mm": [2.0, 4.0],
    "folders": ["captures/plate_00mm", "captures/plate_02mm"],
    "count": 25,
    "note": "h\u00e9ight / \u00fc",
}


def make_cal(model: str = "rational", noise: float = 0.0, **kw: object) -> Calibration:
    ref, phases, _, _ = synthetic(noise=noise)
    phases[:, 3, 4] = np.nan
    args: dict = {
        "model": model,
        "spec": SPEC,
        "gamma_precompensation": 2.812,
        "camera_bit_depth": 8,
        "provenance": PROVENANCE,
        "window_px": 5,
        "border_px": 2,
    }
    args.update(kw)
    return calibrate(ref, phases, DEPTHS, **args)


def test_calibrate_rational_heights_and_residual_maps() -> None:
    cal = make_cal("rational")
    assert cal.image_shape == SHAPE and cal.coefficients.shape == (2, *SHAPE)
    ref, _, _, _ = synthetic()
    near = np.zeros(SHAPE, bool)
    near[0:8, 0:9] = True  # windows (5 px, median then mean) reaching (3, 4)
    for h in (7.0, 31.3):
        got = cal.height(ref + exact_dphi(h))
        assert np.isnan(got[3, 4])  # invalid in the calibration stays invalid
        assert np.max(np.abs(got[~near] - h)) < 1e-9  # c, e are ramps: the filter keeps them
        # next to the invalid pixel the nearest-valid fill shifts the median by a fraction of
        # the maps' (steep: 0.5 %/px) gradient; finite, not poisoned
        near[3, 4] = False
        assert np.max(np.abs(got[near] - h)) < 2e-3 * h
        near[3, 4] = True
    assert set(cal.residual_rms_mm) == {"linear", "rational"}
    for maps in (cal.residual_rms_mm, cal.residual_rms_unfiltered_mm):
        for rms in maps.values():
            assert rms.dtype == np.float32 and rms.shape == SHAPE and np.isnan(rms[3, 4])
    stats = cal.residual_summary()
    assert 0.05 < stats["linear"].median_mm < 1.0
    assert stats["rational"].median_mm < 1e-6
    assert stats["linear"].pixels == (SHAPE[0] - 4) * (SHAPE[1] - 4) - 1
    line = cal.describe_residuals()
    assert line.startswith("linear: 0.") and ", rational: " in line and line.endswith(" mm")


def test_calibrate_noisy_filtered_vs_unfiltered_and_compare_all() -> None:
    cal = make_cal("poly2", noise=0.03, compare=MODELS)
    assert list(cal.residual_rms_mm) == list(MODELS)
    f = cal.residual_summary(filtered=True)
    u = cal.residual_summary(filtered=False)
    for model in MODELS:
        # the unfiltered fit minimises each pixel's own residual; filtering can only add to it
        assert u[model].median_mm <= f[model].median_mm * (1 + 1e-6)
        assert f[model].median_mm < 0.3
    assert f["rational"].median_mm < f["linear"].median_mm


def test_calibrate_linear_height_is_eq_2_11() -> None:
    cal = make_cal("linear", window_px=1)
    assert cal.coefficients is None
    ref, phases, _, _ = synthetic()
    phases[:, 3, 4] = np.nan
    k = fit_linear_k(phases - ref, DEPTHS)
    phi = ref + exact_dphi(20.0)
    np.testing.assert_allclose(cal.height(phi), k * (phi - ref), rtol=1e-15, atol=0)
    with pytest.raises(InputError, match="does not match the calibration's image"):
        cal.height(np.zeros((3, 3)))


@pytest.mark.parametrize(
    ("depths", "message"),
    [
        ([2.0, 4.0, 4.0, 6.0, 2.0], r"duplicate calibration depth\(s\) 2 mm, 4 mm"),
        ([5.0], r"one position only \(5 mm\)"),
        ([0.0, 2.0, 4.0], r"depth 0 mm, which is the reference plane"),
        ([2.0, math.nan], "finite"),
    ],
)
def test_calibrate_refuses_bad_depths(depths: list[float], message: str) -> None:
    ref, phases, _, _ = synthetic(depths=np.array([1.0] * len(depths)))
    with pytest.raises(InputError, match=message) as info:
        calibrate(ref, phases, depths)
    assert "\n" not in str(info.value)


def test_calibrate_refuses_shape_and_model_problems() -> None:
    ref, phases, _, _ = synthetic()
    with pytest.raises(InputError, match="do not match the reference phase"):
        calibrate(ref[:-1], phases, DEPTHS)
    with pytest.raises(InputError, match="25 depth\\(s\\) for 24"):
        calibrate(ref, phases[1:], DEPTHS)
    with pytest.raises(InputError, match="unknown calibration model"):
        calibrate(ref, phases, DEPTHS, model="spline")
    with pytest.raises(InputError, match="poly3 model needs at least 3 plate positions"):
        calibrate(ref, phases[:2], DEPTHS[:2], model="poly3")
    with pytest.raises(InputError, match="no pixel inside a 30 pixel border"):
        calibrate(ref, phases, DEPTHS, border_px=30)
    with pytest.raises(InputError, match="booleans"):
        calibrate(ref, phases, DEPTHS, provenance={"dirty": True})


# --------------------------------------------------------------------------------------------
# virtual rig, end to end (exact phases from the true projector column)
# --------------------------------------------------------------------------------------------
def test_rig_linear_vs_rational_residual() -> None:
    from hdrfringe.rig.scenes import THESIS_CALIBRATION_DEPTHS_MM, white_plate
    from hdrfringe.rig.simulated import CameraModel, SimulatedRig

    # the thesis geometry (1.9 m, 15 degrees, 320 mm field) on a quarter-resolution sensor
    camera = CameraModel(
        width=162, height=124, bit_depth=16, read_noise_dn8=0.0, full_well_e=None, blur_px=0.0
    )
    pitch = 6.0

    def phase(depth: float) -> np.ndarray:
        return 2 * np.pi * SimulatedRig.ideal(white_plate(depth), camera=camera).truth().u / pitch

    depths = np.array(THESIS_CALIBRATION_DEPTHS_MM)
    ref = phase(0.0)
    phases = np.stack([phase(d) for d in depths])
    cal = calibrate(ref, phases, depths, model="rational", compare=MODELS)
    f = cal.residual_summary()
    u = cal.residual_summary(filtered=False)
    assert 0.1 < f["linear"].median_mm < 0.2  # about 0.146 mm
    assert u["rational"].max_mm < 1e-9  # exact model
    assert f["rational"].max_mm < 1e-3  # the filter's curvature bias only
    assert f["poly2"].median_mm < 2e-3 and f["poly3"].median_mm < 1e-4
    h = cal.height(phase(23.0))
    assert np.nanmax(np.abs(h[cal.measurement_mask()] - 23.0)) < 1e-3


# --------------------------------------------------------------------------------------------
# calibration files
# --------------------------------------------------------------------------------------------
def assert_same(a: Calibration, b: Calibration) -> None:
    assert a.model == b.model
    for name in ("k_map", "reference_phase", "depths_mm"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True), name
    if a.coefficients is None:
        assert b.coefficients is None
    else:
        assert np.array_equal(a.coefficients, b.coefficients, equal_nan=True)
    for name in ("residual_rms_mm", "residual_rms_unfiltered_mm"):
        x, y = getattr(a, name), getattr(b, name)
        assert list(x) == list(y), name
        for key in x:
            assert x[key].dtype == y[key].dtype
            assert np.array_equal(x[key], y[key], equal_nan=True)
    for name in (
        "filter_window_px",
        "border_px",
        "spec",
        "gamma_precompensation",
        "camera_bit_depth",
        "image_shape",
        "provenance",
    ):
        assert getattr(a, name) == getattr(b, name), name


@pytest.mark.parametrize("model", ["linear", "rational", "poly3"])
def test_save_load_round_trip_is_exact(tmp_path: Path, model: str) -> None:
    cal = make_cal(model, noise=0.01)
    path = save_calibration(tmp_path / "sub" / "cal.h5", cal)
    back = load_calibration(path)
    assert_same(cal, back)
    assert back.provenance["inputs"]["plate_02mm"]["depth_mm"] == 2.0
    assert isinstance(back.provenance["count"], int)
    assert os.listdir(tmp_path / "sub") == ["cal.h5"]  # no temporary left behind


def test_round_trip_without_optional_metadata(tmp_path: Path) -> None:
    ref, phases, _, _ = synthetic()
    cal = calibrate(ref, phases, DEPTHS, window_px=3, border_px=1)
    back = load_calibration(save_calibration(tmp_path / "c.h5", cal))
    assert_same(cal, back)
    assert back.spec is None and back.camera_bit_depth is None and back.provenance == {}


def test_file_is_plain_for_matlab(tmp_path: Path) -> None:
    path = save_calibration(tmp_path / "c.h5", make_cal("rational"))
    seen = []

    def check_dtype(dt: np.dtype, where: str) -> None:
        assert dt.kind in "fiuS", f"{where}: {dt}"  # plain numbers or fixed-length strings
        assert h5py.check_vlen_dtype(dt) is None, where
        if dt.kind == "S":
            assert h5py.check_string_dtype(dt).length is not None, where

    def visit(name: str, obj: h5py.HLObject) -> None:
        seen.append(name)
        if isinstance(obj, h5py.Dataset):
            check_dtype(obj.dtype, name)
        for key in obj.attrs:
            check_dtype(obj.attrs.get_id(key).dtype, f"{name}@{key}")

    with h5py.File(path, "r") as f:
        for key in f.attrs:
            check_dtype(f.attrs.get_id(key).dtype, f"/@{key}")
        f.visititems(visit)
        assert f.attrs["format"] == b"hdrfringe-calibration" and f.attrs["version"] == 1
        assert f["k_map"].dtype == np.float64 and f["k_map"].shape == SHAPE
        assert f["coefficients"].shape == (2, *SHAPE)
        assert f["spec"].attrs["pitch_px"] == 6.0 and f["spec"].attrs["steps"] == 3
        assert f.attrs["image_height"] == SHAPE[0] and f.attrs["image_width"] == SHAPE[1]
        assert f["provenance/inputs/reference"].attrs["sha256"] == b"0" * 64
    assert {"k_map", "reference_phase", "depths_mm", "residual_rms_mm/rational"} <= set(seen)


def test_save_refuses_overwrite_without_force(tmp_path: Path) -> None:
    path = tmp_path / "cal.h5"
    first = make_cal("linear")
    save_calibration(path, first)
    with pytest.raises(OutputExistsError, match="pass --force"):
        save_calibration(path, make_cal("rational"))
    assert load_calibration(path).model == "linear"
    save_calibration(path, make_cal("rational"), force=True)
    assert load_calibration(path).model == "rational"
    with pytest.raises(OutputExistsError, match="is a folder"):
        save_calibration(tmp_path, first)


def test_failed_write_leaves_old_file_and_no_temporary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "cal.h5"
    save_calibration(path, make_cal("linear"))

    def boom(f: object, cal: object) -> None:
        raise RuntimeError("disk full")

    monkeypatch.setattr(calibration_file, "_write", boom)
    with pytest.raises(RuntimeError):
        save_calibration(path, make_cal("rational"), force=True)
    assert os.listdir(tmp_path) == ["cal.h5"]
    assert load_calibration(path).model == "linear"


def one_line(exc: pytest.ExceptionInfo) -> str:
    msg = str(exc.value)
    assert "\n" not in msg and isinstance(exc.value, HdrFringeError)
    return msg


def test_load_errors(tmp_path: Path) -> None:
    with pytest.raises(CalibrationFileError, match="not found") as e:
        load_calibration(tmp_path / "missing.h5")
    one_line(e)
    with pytest.raises(CalibrationFileError, match="is a folder"):
        load_calibration(tmp_path)
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"this is not HDF5 at all" * 10)
    with pytest.raises(CalibrationFileError, match="not an HDF5 file or corrupt") as e:
        load_calibration(junk)
    one_line(e)
    good = save_calibration(tmp_path / "good.h5", make_cal("rational"))
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(good.read_bytes()[:2000])
    with pytest.raises(CalibrationFileError) as e:
        load_calibration(truncated)
    one_line(e)
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["data"] = np.zeros(3)
    with pytest.raises(CalibrationFileError, match="not an hdrfringe calibration") as e:
        load_calibration(foreign)
    one_line(e)


def test_load_errors_version_and_missing_dataset(tmp_path: Path) -> None:
    newer = save_calibration(tmp_path / "v2.h5", make_cal("rational"))
    with h5py.File(newer, "a") as f:
        f.attrs["version"] = np.int64(2)
    with pytest.raises(CalibrationFileError, match=r"version 2 is not supported.*upgrade"):
        load_calibration(newer)
    for name in ("k_map", "coefficients", "reference_phase", "depths_mm"):
        path = save_calibration(tmp_path / f"no_{name}.h5", make_cal("rational"))
        with h5py.File(path, "a") as f:
            del f[name]
        with pytest.raises(CalibrationFileError, match=f"dataset /{name} is missing") as e:
            load_calibration(path)
        one_line(e)
    odd = save_calibration(tmp_path / "odd.h5", make_cal("rational"))
    with h5py.File(odd, "a") as f:
        del f["k_map"]
        f["k_map"] = np.zeros((3, 3))
    with pytest.raises(CalibrationFileError, match="inconsistent") as e:
        load_calibration(odd)
    one_line(e)


# --------------------------------------------------------------------------------------------
# compatibility
# --------------------------------------------------------------------------------------------
def test_check_compatible_accepts_other_migl_and_imin() -> None:
    cal = make_cal("linear")
    check_compatible(cal, SPEC, SHAPE, 8)
    check_compatible(cal, FringeSpec("sinusoidal", 3, 6.0, "vertical", 10.0, 150.0), SHAPE, 8)


@pytest.mark.parametrize(
    ("spec", "shape", "bits", "pattern"),
    [
        (FringeSpec("sinusoidal", 3, 8.0), SHAPE, 8, r"pitch 6 px \(calibration\) vs 8 px"),
        (FringeSpec("sinusoidal", 4, 6.0), SHAPE, 8, r"steps 3 \(calibration\) vs 4"),
        (FringeSpec("triangular", 3, 6.0), SHAPE, 8, "pattern sinusoidal"),
        (FringeSpec("sinusoidal", 3, 6.0, "horizontal"), SHAPE, 8, "orientation vertical"),
        (SPEC, (40, 50), 8, r"image size 52x40 \(calibration\) vs 50x40"),
        (SPEC, SHAPE, 12, r"camera bit depth 8 bits \(calibration\) vs 12 bits"),
    ],
)
def test_check_compatible_refusals(
    spec: FringeSpec, shape: tuple[int, int], bits: int, pattern: str
) -> None:
    with pytest.raises(CalibrationMismatchError, match=pattern) as e:
        check_compatible(make_cal("linear"), spec, shape, bits, source="cal.h5")
    msg = one_line(e)
    assert "calibration cal.h5 does not fit" in msg
    assert "recalibrate with" in msg and "or measure with" in msg


def test_check_compatible_lists_every_difference() -> None:
    with pytest.raises(CalibrationMismatchError) as e:
        check_compatible(make_cal("linear"), FringeSpec("sinusoidal", 4, 8.0), (10, 10), 12)
    msg = one_line(e)
    assert msg.endswith(
        "recalibrate with steps 4, pitch 8 px, image size 10x10, camera bit depth 12 bits "
        "or measure with steps 3, pitch 6 px, image size 52x40, camera bit depth 8 bits"
    )
