"""Damaged or hostile inputs (issue 11): calibrations, small cases (the Dask scheduler address:
research/tests/test_reproduce_errors.py).

Each case failed on the code before issue 11 (exit 0 with wrong numbers, a traceback or a
hang); each now gives a one-line error, exit 2, and writes nothing.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.calibration import Calibration, calibrate, check_calibration
from hdrfringe.core.unwrap import centerline_phase
from hdrfringe.errors import InputError
from hdrfringe.io.calibration_file import (
    CalibrationFileError,
    load_calibration,
    save_calibration,
)
from tests.conftest import run_cli, run_cli_in_process


def _one_line_failure(res, *needles: str) -> None:
    assert res.returncode == 2, res.stdout + res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    assert "Traceback" not in res.stderr
    for n in needles:
        assert n in lines[0], lines[0]


# --------------------------------------------------------------------------------------------
# calibrations: finite, sane values on write and on read
# --------------------------------------------------------------------------------------------
SHAPE = (30, 40)
DEPTHS = np.array([2.0, 4.0, 6.0, 8.0])


def _synthetic_cal(model: str = "rational") -> Calibration:
    """A calibration of a rig with a column-dependent ``h = dphi / (a + b dphi)``."""
    yy, xx = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]].astype(float)
    a = 2.0 + 0.01 * xx
    b = 0.002 + 0.0001 * yy
    ref = 0.3 * xx
    phases = np.stack([ref + a * h / (1 - b * h) for h in DEPTHS])
    return calibrate(ref, phases, DEPTHS, model=model, window_px=5, border_px=2)


@pytest.fixture(scope="module")
def good_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return save_calibration(tmp_path_factory.mktemp("cal") / "good.h5", _synthetic_cal())


def _damaged(good: Path, tmp_path: Path, dataset: str, value: float, name: str) -> Path:
    import h5py

    path = tmp_path / name
    shutil.copyfile(good, path)
    with h5py.File(path, "r+") as f:
        data = f[dataset][()]
        data[...] = value
        f[dataset][...] = data
    return path


def test_good_calibration_passes_and_round_trips(good_file: Path) -> None:
    cal = load_calibration(good_file)
    check_calibration(cal)
    assert cal.model == "rational" and np.isfinite(cal.k_map).all()


@pytest.mark.parametrize(
    ("dataset", "value", "needle"),
    [
        ("coefficients", np.inf, "/coefficients holds +-inf"),
        ("k_map", np.inf, "/k_map holds +-inf"),
        ("k_map", np.nan, "finite at 0 of"),
        ("coefficients", np.nan, "finite at 0 of"),
        ("reference_phase", np.nan, "finite at 0 of"),
        ("k_map", 1e-30, "/k_map gives a median phase shift"),
        ("coefficients", 1e12, "/coefficients (rational) give"),
        ("residual_rms_mm/rational", np.nan, "/residual_rms_mm/rational has a median of nan"),
        ("residual_rms_mm/rational", 1e6, "/residual_rms_mm/rational has a median of 1e+06"),
        ("depths_mm", np.nan, "/depths_mm must be finite"),
    ],
)
def test_damaged_calibration_refused_on_read(
    good_file: Path, tmp_path: Path, dataset: str, value: float, needle: str
) -> None:
    path = _damaged(good_file, tmp_path, dataset, value, "bad.h5")
    with pytest.raises(CalibrationFileError) as info:
        load_calibration(path)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(str(path)) and needle in msg, msg
    assert "recalibrate" in msg or "depths" in msg


def test_damaged_calibration_refused_on_write(tmp_path: Path) -> None:
    good = _synthetic_cal("linear")
    bad = Calibration(
        "linear",
        np.full(SHAPE, np.inf),
        None,
        good.reference_phase,
        good.depths_mm,
        border_px=2,
    )
    out = tmp_path / "bad.h5"
    with pytest.raises(InputError, match=r"refusing to write.*/k_map holds"):
        save_calibration(out, bad)
    assert list(tmp_path.iterdir()) == []


def test_calibrate_refuses_an_absurd_depth_before_computing() -> None:
    ref = np.zeros(SHAPE)
    phases = np.stack([ref + 1.0, ref + 2.0])
    with pytest.raises(InputError, match="depth 1e\\+300 mm, beyond 1e\\+06 mm"):
        calibrate(ref, phases, [2.0, 1e300])


def test_calibrate_refuses_a_result_without_usable_pixels() -> None:
    ref = np.zeros(SHAPE)
    phases = np.full((2, *SHAPE), np.nan)
    with pytest.raises(InputError, match="finite at 0 of"):
        calibrate(ref, phases, [2.0, 4.0], window_px=5, border_px=2)


def test_sane_bounds_keep_noisy_and_partly_invalid_calibrations() -> None:
    """The bounds accept a noisy calibration with 95 % of its pixels invalid."""
    rng = np.random.default_rng(1)
    xx = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]][1].astype(float)
    ref = 0.3 * xx
    phases = np.stack([ref + h / 0.4 for h in DEPTHS]) + rng.normal(0, 0.2, (4, *SHAPE))
    phases[:, rng.random(SHAPE) < 0.95] = np.nan
    for model in ("linear", "rational", "poly2", "poly3"):
        cal = calibrate(ref, phases, DEPTHS, model=model, window_px=1, border_px=0)
        check_calibration(cal)


@pytest.fixture(scope="module")
def plates(white_plate_series: Path) -> Path:
    """The calibration series of conftest (simulated once per session; read-only here)."""
    return white_plate_series


def test_cli_measure_with_inf_coefficients_refused(
    plates: Path, good_file: Path, tmp_path: Path
) -> None:
    """Before: "valid 100 %" and every height 0 mm."""
    path = _damaged(good_file, tmp_path, "coefficients", np.inf, "inf.h5")
    out = tmp_path / "m"
    folder = sorted(plates.iterdir())[1]
    res = run_cli_in_process("measure", str(folder), "-c", str(path), "-o", str(out))
    _one_line_failure(res, "inf.h5", "/coefficients")
    assert not out.exists()


def test_cli_calibrate_with_depth_1e300_refused(plates: Path, tmp_path: Path) -> None:
    """Before: wrote a calibration whose residual was "nan mm"."""
    series = tmp_path / "series"
    shutil.copytree(plates, series)
    manifest = sorted(series.iterdir())[2] / "manifest.json"
    data = json.loads(manifest.read_text())
    data["scene"]["depth_mm"] = 1e300
    manifest.write_text(json.dumps(data))
    out = tmp_path / "cal.h5"
    res = run_cli_in_process("calibrate", str(series), "-o", str(out))
    _one_line_failure(res, "1e+300 mm")
    assert not out.exists() and not list(tmp_path.glob(".cal.h5*"))


# --------------------------------------------------------------------------------------------
# options blamed on the centerline before: each now names itself
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("sweep") / "sweep"
    res = run_cli(
        "simulate", "white_plate", "-o", str(root), "--migl-sweep", "255:155:50", "--steps",
        "3", "--pitch", "6", "--ambient-lux", "600",
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    return root


@pytest.mark.parametrize("value", ["5", "-0.1", "nan"])
def test_cli_tolerance_out_of_range_names_the_option(
    sweep: Path, tmp_path: Path, value: str
) -> None:
    out = tmp_path / "m"
    res = run_cli_in_process(
        "measure", str(sweep), "--strategy", "uniform", "--tolerance", value, "-o", str(out)
    )
    _one_line_failure(res, "--tolerance", "[0, 1]")
    assert not out.exists()


@pytest.mark.parametrize("value", ["nan", "-1", "inf", "200"])
def test_cli_min_modulation_out_of_range_names_the_option(
    plates: Path, tmp_path: Path, value: str
) -> None:
    out = tmp_path / "p"
    folder = sorted(plates.iterdir())[1]
    res = run_cli_in_process("phase", str(folder), "--min-modulation", value, "-o", str(out))
    _one_line_failure(res, "--min-modulation", "0..127.5")
    assert "centerline" not in res.stderr
    assert not out.exists()


@pytest.mark.parametrize(
    ("phase", "positions", "needle"),
    [
        (np.full((3, 5), np.nan), [1.0, 2.0, 3.0], "phase map has no valid pixel"),
        (np.ones((3, 5)), [np.nan, -4.0, 9.0], "not detected in any image row"),
        (np.where(np.arange(5) < 3, np.nan, 1.0) * np.ones((3, 1)), [1.0, 2.0, 1.5], "crosses"),
    ],
)
def test_centerline_failure_names_its_cause(
    phase: np.ndarray, positions: list[float], needle: str
) -> None:
    with pytest.raises(InputError, match="N_c = 0") as info:
        centerline_phase(phase, positions)
    assert needle in str(info.value)


# --------------------------------------------------------------------------------------------
# absolute phase keeps float64 precision at large centerline positions
# --------------------------------------------------------------------------------------------
def test_absolute_phase_file_not_quantised_at_a_large_centerline_position(tmp_path: Path) -> None:
    """Before: absolute_phase.tiff was float32, ~4e-3 rad off at projector column 150000."""
    from hdrfringe.core.captures import Captures, ProjectorInfo
    from hdrfringe.core.decode import decode_captures
    from hdrfringe.core.frames import CenterlineFrame
    from hdrfringe.core.patterns import FringeSpec, fringe_gray
    from hdrfringe.io.phase_maps import write_phase_maps
    from hdrfringe.io.results import read_map_tiff

    pos, pitch = 150000.0, 8.0
    spec = FringeSpec("sinusoidal", 4, pitch, "vertical", 40.0, 250.0)
    x = np.tile(pos - 16 + np.arange(64.0) * 0.5, (8, 1))  # projector column of each pixel
    fringes = [np.rint(fringe_gray(x, spec, k)) for k in range(4)]
    line = 10 + 240 * np.exp(-(((x - pos) / 1.5) ** 2))
    caps = Captures(
        [*spec.frames(), CenterlineFrame(pos, "vertical", 255)],
        np.stack([*fringes, line]).astype(np.uint8),
        8,
        projector=ProjectorInfo(width=200000, height=768),
    )
    decoded = decode_captures(caps)
    absolute = decoded.primary.absolute_phase
    truth = 2 * np.pi * x / pitch
    assert absolute.dtype == np.float64
    assert np.nanmax(np.abs(absolute - truth)) < 5e-3  # 8-bit rounding of the fringes only
    write_phase_maps(tmp_path, decoded, "memory")
    back = read_map_tiff(tmp_path / "absolute_phase_vertical.tiff")
    ok = np.isfinite(absolute)
    assert ok.mean() > 0.9 and np.array_equal(np.isfinite(back), ok)
    # the file keeps float64: no quantisation (float32 spacing at 1.2e5 rad is 7.8e-3 rad)
    assert np.abs(back[ok] - absolute[ok]).max() <= np.spacing(np.abs(truth).max())
    assert np.abs(absolute[ok].astype(np.float32) - absolute[ok]).max() > 1e-3


# --------------------------------------------------------------------------------------------
# degenerate gamma fits: a warning, and a refusal where the fit cannot be a gamma
# --------------------------------------------------------------------------------------------
def _uniform_captures(response, seed: int = 0):
    from hdrfringe.core.captures import Captures
    from hdrfringe.core.frames import UniformFrame

    levels = [0, 64, 128, 192, 255]
    rng = np.random.default_rng(seed)
    images = np.stack([np.full((4, 4), response(g)) + rng.normal(0, 1, (4, 4)) for g in levels])
    images = np.clip(np.rint(images), 0, 255).astype(np.uint8)
    return Captures([UniformFrame(g) for g in levels], images, 8)


def test_degenerate_gamma_fit_is_reported_with_a_warning() -> None:
    from hdrfringe.core.gamma.report import gamma_report

    good = gamma_report(_uniform_captures(lambda g: 10 + 200 * (g / 255) ** 2.2), source="good")
    assert good.report["uniform"]["degenerate"] is False
    assert not any("degenerate" in line for line in good.lines)
    # a camera that barely responds: gamma 0.51 +- 0.33
    weak = gamma_report(_uniform_captures(lambda g: 100 + 0.01 * g), source="weak")
    u = weak.report["uniform"]
    assert u["degenerate"] is True and u["stderr"] > 0.25 * u["gamma"]
    warning = [line for line in weak.lines if line.startswith("warning:")]
    assert len(warning) == 1 and "uniform-gray fit is degenerate" in warning[0]
    json.dumps(weak.report, allow_nan=False)


def test_gamma_fit_on_its_bound_is_refused(tmp_path: Path) -> None:
    """Before: a flat response was reported as gamma = 0.05 +- 2.4, exit 0."""
    from hdrfringe.io.captures import write_capture_folder

    folder = tmp_path / "flat"
    write_capture_folder(folder, _uniform_captures(lambda g: 100 + 0 * g))
    out = tmp_path / "g"
    res = run_cli_in_process("gamma", str(folder), "-o", str(out))
    _one_line_failure(res, "uniform-gray fit gives gamma = 0.05", "cannot be a projector gamma")
    assert not out.exists()
