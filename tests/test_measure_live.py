"""measure --rig sim (live virtual rig), DPA's CDF figure and metrics, train-correction.

Numbers asserted here were measured on the default virtual rig (seed 0) and are documented in
docs/measurement.md and docs/dpa.md.
"""

from __future__ import annotations

import itertools
import json
import subprocess
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from hdrfringe.core.captures import Captures
from hdrfringe.core.frames import CenterlineFrame, Frame, UniformFrame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.saturation.estimate import CorrectionPolynomial, training_data_from_rig
from hdrfringe.io.calibration_file import save_calibration
from hdrfringe.io.captures import write_capture_folder
from hdrfringe.pipeline import calibrate
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
from tests.conftest import run_cli, run_cli_in_process

RULES = {"initial", "threshold", "lowest"}
#: No PNG previews nor report in the measurements here: no test reads them (0.36 s of each
#: live run at 648x494; tests/test_previews.py and tests/test_report.py test them). The
#: figures (migl_pie.png, dpa_cdf.png) are written either way.
QUIET = ("--no-previews", "--no-report")


@pytest.fixture(scope="module")
def calibration(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Rational calibration on the white plate at 0, 8, 16, 24 mm: what ``simulate --series
    0,8,16,24`` and ``calibrate --model rational`` make (4-step, pitch 8, centerline)."""
    frames = [
        *FringeSpec("sinusoidal", 4, 8.0, "vertical", 40, 255).frames(),
        CenterlineFrame(512, "vertical", 255),
    ]
    folders = [SimulatedRig(white_plate(d)).capture_folder(frames) for d in (0, 8, 16, 24)]
    path = tmp_path_factory.mktemp("cal") / "cal.h5"
    save_calibration(path, calibrate(folders, model="rational"))
    return path


def _small_sweep(path: Path, pitch: float, lowest: int, *, uniform: bool = False) -> SimulatedRig:
    """A step-1 MIGL sweep 255..lowest of the white plate under 600 lx on a 162 x 124 camera
    (same field of view as the default rig, a quarter of its resolution: fast to write)."""
    rig = SimulatedRig(
        white_plate(),
        camera=CameraModel(width=162, height=124),
        lighting=Lighting(ambient_lux=600),
    )
    frames: list[Frame] = []
    for m in range(255, lowest - 1, -1):
        frames += FringeSpec("sinusoidal", 4, pitch, "vertical", 40, m).frames()
    if uniform:
        frames.append(UniformFrame(40))
    write_capture_folder(
        path,
        Captures(
            frames, rig.capture(frames), 8, projector=rig.projector, scene=rig.scene.to_manifest()
        ),
    )
    rig.reset_noise()
    return rig


def _metrics(out: Path) -> dict:
    return json.loads((out / "metrics.json").read_text())


# ---------------------------------------------------------------------------------------------
# live measurement per method
# ---------------------------------------------------------------------------------------------


def test_live_without_method_is_conventional(tmp_path: Path, calibration: Path) -> None:
    """Checkerboard, default fringes (pitches 1024, 64, 8 and the centerline): one set per
    pitch at MIGL 255; the white squares saturate and are lost, the black ones are measured."""
    out = tmp_path / "conv"
    res = run_cli(
        "measure", "--rig", "sim", "--scene", "checkerboard", "-c", str(calibration),
        "-o", str(out), *QUIET,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    m = _metrics(out)
    assert m["method"] == "conventional"
    assert m["sets_captured"] == 3 and m["images_captured"] == 12
    assert m["migls"] == [[255.0], [255.0], [255.0]]
    assert 0.40 < m["valid_fraction"] < 0.55  # measured 0.462: black squares only
    assert m["rmse_mm"] < 0.06  # measured 0.0447 mm on the black squares
    assert m["live_rig"]["scene"]["name"] == "checkerboard"
    assert (out / "migl_index.tiff").is_file() and not (out / "dpa_cdf.png").exists()


@pytest.mark.parametrize(
    ("method", "rmse_range"),
    [
        ("uniform", (0.060, 0.070)),  # measured 0.0647 mm (automatic MIGL 186)
        ("lpa", (0.050, 0.061)),  # measured 0.0582 mm: LPA S = 5 beats the uniform MIGL
        ("dpa", (0.050, 0.061)),  # measured 0.0584 mm
    ],
)
def test_live_strategies_on_white_plate_600lx(
    tmp_path: Path, calibration: Path, method: str, rmse_range: tuple[float, float]
) -> None:
    """Thesis Tables 4.3, 5.1 and 6.1 scene: white plate, 600 lx, sinusoidal 4-step, pitch 8."""
    out = tmp_path / method
    res = run_cli(
        "measure",
        "--rig",
        "sim",
        "--ambient-lux",
        "600",
        "--pitch",
        "8",
        "--strategy",
        method,
        *(["--step", "5"] if method == "lpa" else []),  # LPA's alone
        "-c",
        str(calibration),
        "-o",
        str(out),
        *QUIET,
    )
    assert res.returncode == 0, res.stderr
    m = _metrics(out)
    assert m["method"] == method and m["images_captured"] == 4 * m["sets_captured"]
    assert m["migls"][0] == 255.0 and m["valid_fraction"] == 1.0
    assert rmse_range[0] < m["rmse_mm"] < rmse_range[1], m["rmse_mm"]
    if method == "uniform":
        assert m["sets_captured"] <= 10 and 180 <= m["migls"][-1] <= 192
    if method == "lpa":
        assert m["migls"] == [float(v) for v in range(255, 184, -5)]
    if method == "dpa":
        assert m["sets_captured"] == 9  # 255, 223, 219, ..., 194, 182
        entry = m["dpa"]["sets"][0]
        assert m["dpa"]["correction"] == "none (identity)"
        assert entry["rules"][0] == "initial" and set(entry["rules"]) <= RULES
        assert [c["migl"] for c in entry["captures"]] == m["migls"]
        # 30 % of the saturated pixels have two saturated shifts (not estimable from the first
        # set): the first CDF cannot exceed 0.70, so it is at least 0.30 from the actual one
        # at the last capture. Measured: 0.428.
        assert 0.65 < entry["estimable_at_top"] < 0.75
        d = entry["max_abs_difference_initial_vs_actual"]
        assert 1.0 - entry["estimable_at_top"] - 1e-9 <= d < 0.46
        assert "DPA" in res.stdout and (out / "dpa_cdf.png").is_file()


def test_live_temporal_unwrapping_without_centerline(tmp_path: Path, calibration: Path) -> None:
    """LPA per pitch at 1024, 64 and 8 px on the checkerboard: the coarse pitches unwrap the
    finest temporally (no centerline), every pixel is recovered."""
    out = tmp_path / "lpa3"
    res = run_cli(
        "measure",
        "--rig",
        "sim",
        "--scene",
        "checkerboard",
        "--pitch",
        "8,64,1024",
        "--no-centerline",
        "--strategy",
        "lpa",
        "--step",
        "15",
        "-c",
        str(calibration),
        "-o",
        str(out),
        *QUIET,
    )
    assert res.returncode == 0, res.stderr
    m = _metrics(out)
    assert len(m["migls"]) == 3  # coarsest first
    assert all(migls[:3] == [255.0, 240.0, 225.0] for migls in m["migls"])
    assert m["sets_captured"] == sum(len(x) for x in m["migls"])
    assert m["valid_fraction"] == 1.0 and m["never_unsaturated_fraction"] == 0.0
    assert m["rmse_mm"] < 0.12, m["rmse_mm"]


def test_live_dpa_bound_pending_through_the_cli(tmp_path: Path) -> None:
    """``measure --strategy dpa --bound-pending`` on the checkerboard: the bound's captures are
    labelled in the dpa block and the flat stretch of the thesis's rule is skipped."""
    sets = {}
    for flag in ("--no-bound-pending", "--bound-pending"):
        out = tmp_path / flag
        res = run_cli(
            "measure", "--rig", "sim", "--scene", "checkerboard", "--pitch", "8",
            "--strategy", "dpa", flag, "-o", str(out), *QUIET,
        )  # fmt: skip
        assert res.returncode == 0, res.stderr
        m = _metrics(out)
        rules = m["dpa"]["sets"][0]["rules"]
        assert m["dpa"]["bound_pending"] is (flag == "--bound-pending")
        assert ("bound" in rules) is (flag == "--bound-pending")
        assert m["never_unsaturated_fraction"] == 0.0
        sets[flag] = m["sets_captured"]
    assert sets["--bound-pending"] < 0.4 * sets["--no-bound-pending"]
    out = tmp_path / "lpa"
    res = run_cli_in_process(
        "measure", "--rig", "sim", "--strategy", "lpa", "--bound-pending", "-o", str(out)
    )
    assert res.returncode == 2 and "--bound-pending is a DPA option" in res.stderr
    assert "Traceback" not in res.stderr and not out.exists()


def test_live_dpa_without_saturation_is_one_set(tmp_path: Path) -> None:
    """Requirement 4 through the CLI: nothing saturates at 0 lx, DPA captures one set and
    reports no CDF (the figure says so instead of plotting empty curves)."""
    out = tmp_path / "dpa"
    res = run_cli(
        "measure", "--rig", "sim", "--pitch", "8", "--strategy", "dpa", "-o", str(out), *QUIET
    )
    assert res.returncode == 0, res.stderr
    m = _metrics(out)
    assert m["migls"] == [255.0] and m["sets_captured"] == 1
    entry = m["dpa"]["sets"][0]
    assert entry["saturated_at_top"] == 0 and entry["rules"] == ["initial"]
    assert entry["captures"] == [{"migl": 255.0, "rule": "initial"}]
    assert "max_abs_difference_initial_vs_actual" not in entry
    assert (out / "dpa_cdf.png").is_file()


# ---------------------------------------------------------------------------------------------
# DPA: Fig. 6.3 and the metrics block on a replayed step-1 sweep (exact actual CDF)
# ---------------------------------------------------------------------------------------------


def test_dpa_cdf_on_a_step1_sweep(tmp_path: Path) -> None:
    sweep = tmp_path / "sweep"
    _small_sweep(sweep, 32.0, 175)
    out = tmp_path / "dpa"
    res = run_cli("measure", str(sweep), "--strategy", "dpa", "-o", str(out), *QUIET)
    assert res.returncode == 0, res.stderr
    m = _metrics(out)
    entry = m["dpa"]["sets"][0]
    caps = entry["captures"]
    assert [c["migl"] for c in caps] == m["migls"] and len(caps) == m["sets_captured"]
    assert entry["rules"] == [c["rule"] for c in caps] and entry["rules"][0] == "initial"
    assert set(entry["rules"]) <= RULES and entry["rules"][-1] == "lowest"
    assert all(a > b for a, b in itertools.pairwise(m["migls"]))
    for key in ("estimated_initial", "estimated_final", "actual", "actual_exact"):
        vals = [c[key] for c in caps]
        assert vals[0] == 0.0 and all(a <= b for a, b in itertools.pairwise(vals)), key
    # A pixel counted in the quantised CDF at a captured MIGL was unsaturated in a capture at
    # or above it, which LPA step 1 on the same images sees too: quantised <= exact. Noise
    # makes the exact N(x, y) optimistic (first lucky MIGL), measured up to 0.08 above.
    gaps = [c["actual_exact"] - c["actual"] for c in caps]
    assert min(gaps) >= 0.0 and max(gaps) < 0.12
    assert caps[-1]["actual"] == 1.0 and m["never_unsaturated_fraction"] == 0.0
    # measured 0.481 (quantised) and 0.519 (exact); the first CDF covers 59 % of the pixels
    d = entry["max_abs_difference_initial_vs_actual"]
    assert 1.0 - entry["estimable_at_top"] - 1e-9 <= d < 0.53
    assert 0.45 < entry["max_abs_difference_initial_vs_exact"] < 0.57
    # after its updates the CDF follows the actual one: measured at most 0.092 apart
    assert max(abs(c["estimated_final"] - c["actual"]) for c in caps) < 0.12
    img = iio.imread(out / "dpa_cdf.png")
    assert img.shape[:2] == (480, 640) and img.std() > 10
    assert "vs exact" in res.stdout


# ---------------------------------------------------------------------------------------------
# train-correction
# ---------------------------------------------------------------------------------------------


def test_train_correction_round_trip_into_dpa(tmp_path: Path) -> None:
    """Train live with Eq. 6.3's truth (thesis Sec. 6.1.2), then measure with it: the corrected
    first CDF lands on the actual one wherever it can (its only gap is the pixels it could not
    estimate), where the uncorrected one was 0.428 away."""
    corr = tmp_path / "corr.json"
    res = run_cli("train-correction", "--rig", "sim", "--truth", "thesis", "-o", str(corr))
    assert res.returncode == 0, res.stderr
    assert "71.05" in res.stdout and "2.99" in res.stdout
    poly = CorrectionPolynomial.load(corr)
    assert poly.truth == "thesis" and poly.metadata["pitch_px"] == 20.0
    assert 12.0 < poly.rmse_before < 13.5 and 3.3 < poly.rmse_after < 4.0  # 12.77 -> 3.68 DN
    before = corr.read_bytes()
    again = run_cli_in_process("train-correction", "--rig", "sim", "-o", str(corr))
    assert again.returncode == 2 and "--force" in again.stderr and corr.read_bytes() == before

    out = tmp_path / "dpa"
    res = run_cli(
        "measure",
        "--rig",
        "sim",
        "--ambient-lux",
        "600",
        "--pitch",
        "8",
        "--strategy",
        "dpa",
        "--correction",
        str(corr),
        "-o",
        str(out),
        *QUIET,
    )
    assert res.returncode == 0, res.stderr
    m = _metrics(out)
    assert m["dpa"]["correction"] == str(corr)
    entry = m["dpa"]["sets"][0]
    floor = 1.0 - entry["estimable_at_top"]
    assert floor - 1e-9 <= entry["max_abs_difference_initial_vs_actual"] < floor + 0.02  # 0.301
    assert max(abs(c["estimated_final"] - c["actual"]) for c in entry["captures"]) < 0.14


def test_train_correction_from_a_sweep_folder_equals_live(tmp_path: Path) -> None:
    """Replaying a step-1 sweep trains the same polynomial as the live rig with the same seed."""
    sweep = tmp_path / "sweep"
    rig = _small_sweep(sweep, 20.0, 160, uniform=True)
    corr = tmp_path / "corr.json"
    res = run_cli("train-correction", str(sweep), "-o", str(corr))
    assert res.returncode == 0, res.stderr
    poly = CorrectionPolynomial.load(corr)
    spec = FringeSpec("sinusoidal", 4, 20.0, "vertical", 40, 255)
    live = training_data_from_rig(rig, spec, lowest_migl=160, offset_captures=1).train(2)
    assert poly.n_samples == live.n_samples > 5000
    assert np.allclose(poly.coefficients, live.coefficients, rtol=0, atol=1e-9)
    assert poly.rmse_after < poly.rmse_before < 6.0


# ---------------------------------------------------------------------------------------------
# bad input: one line, exit code 2, no traceback, nothing written
# ---------------------------------------------------------------------------------------------


def _assert_clean_failure(res: subprocess.CompletedProcess, out: Path, *needles: str) -> None:
    assert res.returncode == 2, (res.stdout, res.stderr)
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert "Traceback" not in res.stderr
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    assert not out.exists()
    assert not [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.")]


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["{folder}", "--rig", "sim"], ["exactly one source"]),
        ([], ["no source"]),
        (["{folder}", "--ambient-lux", "600", "--pitch", "8"], ["--ambient-lux, --pitch", "--rig"]),
        (["{folder}", "--scene", "checkerboard"], ["--scene only applies", "--rig sim"]),
        (["{folder}", "--no-centerline"], ["--centerline"]),
        (["--rig", "camera"], ["unknown rig 'camera'"]),
        (["--rig", "sim", "--scene", "teapot"], ["unknown scene 'teapot'"]),
        (["--rig", "sim", "--aperture", "wide"], ["unknown aperture 'wide'"]),
        (["--rig", "sim", "--strategy", "magic"], ["unknown strategy 'magic'"]),
        (["--rig", "sim", "--strategy", "dpa", "--steps", "3"], ["at least 4 steps"]),
        (["--rig", "sim", "--pitch", "8,abc"], ["--pitch"]),
        (
            ["--rig", "sim", "--strategy", "dpa", "--correction", "{tmp}/no.json"],
            ["does not exist"],
        ),
    ],
)
def test_measure_bad_source_options(
    tmp_path: Path, capture_folder: Path, args: list[str], needles: list[str]
) -> None:
    out = tmp_path / "out"
    fill = {"folder": str(capture_folder), "tmp": str(tmp_path)}
    res = run_cli_in_process("measure", *[a.format(**fill) for a in args], "-o", str(out))
    _assert_clean_failure(res, out, *needles)


def test_measure_live_refuses_a_mismatched_calibration(tmp_path: Path, calibration: Path) -> None:
    out = tmp_path / "out"
    res = run_cli_in_process(
        "measure", "--rig", "sim", "--pitch", "6", "-c", str(calibration), "-o", str(out)
    )
    _assert_clean_failure(res, out, "pitch")


def test_measure_live_without_output(tmp_path: Path) -> None:
    res = run_cli_in_process("measure", "--rig", "sim")
    _assert_clean_failure(res, tmp_path / "out", "-o/--output")


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["{folder}", "--ambient-lux", "600"], ["--ambient-lux only applies"]),
        (["{folder}", "--rig", "sim"], ["exactly one source"]),
        (["{folder}"], ["every integer MIGL"]),
        (["--rig", "sim", "--steps", "3"], ["at least 4 steps"]),
        (["--rig", "sim", "--truth", "magic"], ["unknown truth 'magic'"]),
    ],
)
def test_train_correction_bad_input(
    tmp_path: Path, capture_folder: Path, args: list[str], needles: list[str]
) -> None:
    out = tmp_path / "corr.json"
    res = run_cli_in_process(
        "train-correction", *[a.format(folder=capture_folder) for a in args], "-o", str(out)
    )
    _assert_clean_failure(res, out, *needles)
