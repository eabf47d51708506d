"""``phase`` and ``measure`` write the predicted std and leave every other output as it was.

With ``--no-uncertainty`` the folders are what they were before the prediction existed; with it
(the default) they gain ``phase_std*.tiff`` (+ previews), ``height_std.tiff`` (measure with a
calibration) and an ``uncertainty`` block, and every other file is byte for byte the same.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.io.calibration_file import load_calibration, save_calibration
from hdrfringe.io.captures import write_capture_folder
from hdrfringe.io.report import REPORT_FILES
from hdrfringe.io.results import read_map_tiff
from hdrfringe.pipeline import calibrate
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, SimulatedRig
from tests.conftest import run_cli_in_process

CAMERA = CameraModel(width=64, height=48)


def _frames(steps: int) -> list:
    return [f for p in (1024.0, 16.0) for f in FringeSpec("sinusoidal", steps, p).frames()]


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("unc_cli")
    out = {}
    for steps in (4, 3):
        caps = SimulatedRig(white_plate(4.0), camera=CAMERA).capture_folder(_frames(steps))
        write_capture_folder(root / f"part{steps}", caps)
        out[f"part{steps}"] = root / f"part{steps}"
    # a folder whose manifest records no noise model (a camera that does not know it)
    bare = {k: v for k, v in caps.camera.items() if k not in ("read_noise_dn", "gain_dn_per_e")}
    write_capture_folder(root / "part3_bare", dataclasses.replace(caps, camera=bare))
    out["part3_bare"] = root / "part3_bare"
    plates = [
        SimulatedRig(white_plate(d), camera=CAMERA).capture_folder(_frames(4)) for d in (0, 5, 10)
    ]
    save_calibration(root / "cal.h5", calibrate(plates))
    out["cal"] = root / "cal.h5"
    return out


def _files(folder: Path) -> dict[str, bytes]:
    """The folder's files but the report (it lists the settings, which differ)."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.name not in REPORT_FILES}


def _without(summary: dict, key: str = "uncertainty") -> dict:
    out = {k: v for k, v in summary.items() if k != key}
    if "files" in out:
        out["files"] = [f for f in out["files"] if not f.startswith("phase_std")]
    return out


def test_phase_writes_the_std_of_every_set_and_nothing_else_changes(
    folders: dict, tmp_path: Path
) -> None:
    on, off = tmp_path / "on", tmp_path / "off"
    every = "--per-set-maps"  # every set's maps, so every set's std
    res = run_cli_in_process("phase", str(folders["part4"]), "-o", str(on), every)
    assert res.returncode == 0, res.stderr
    assert "predicted phase std: median" in res.stdout
    assert run_cli_in_process(
        "phase", str(folders["part4"]), "-o", str(off), "--no-uncertainty", every
    )
    a, b = _files(on), _files(off)
    added = sorted(set(a) - set(b))
    assert added == [
        "phase_std.png",
        "phase_std.tiff",
        "phase_std__s4_p1024_v_i40_g255.png",
        "phase_std__s4_p1024_v_i40_g255.tiff",
        "phase_std__s4_p16_v_i40_g255.png",
        "phase_std__s4_p16_v_i40_g255.tiff",
    ]
    assert set(b) <= set(a)
    for name in b:
        if name != "phase_summary.json":
            assert a[name] == b[name], name
    summary = json.loads(a["phase_summary.json"])
    assert _without(summary) == json.loads(b["phase_summary.json"])
    unc = summary["uncertainty"]
    # the virtual rig's folder records its noise model (the sensor's: read 1 DN, rounding,
    # 255 / 20000 DN per electron), and phase uses it
    assert unc["predicted"] and unc["noise"]["source"].startswith("manifest camera.read_noise_dn")
    assert unc["noise"]["read_noise_dn"] == pytest.approx(np.sqrt(1 + 1 / 12))
    assert unc["noise"]["gain_dn_per_e"] == pytest.approx(255 / 20000)
    std = read_map_tiff(on / "phase_std.tiff")
    valid = np.isfinite(read_map_tiff(on / "wrapped_phase.tiff"))
    assert np.isfinite(std[valid]).all() and np.isnan(std[~valid]).all()
    # the textbook form at the manifest's sigma (N = 4: exact for read + shot noise at a)
    b_map = read_map_tiff(on / "modulation.tiff").astype(np.float64)
    a_map = read_map_tiff(on / "mean_intensity.tiff").astype(np.float64)
    noise = unc["noise"]
    sigma = np.sqrt(noise["read_noise_dn"] ** 2 + noise["gain_dn_per_e"] * a_map)
    np.testing.assert_allclose(std[valid], (np.sqrt(2 / 4) * sigma / b_map)[valid], rtol=1e-5)


def test_measure_writes_phase_and_height_std(folders: dict, tmp_path: Path) -> None:
    on, off = tmp_path / "on", tmp_path / "off"
    args = ("measure", str(folders["part4"]), "-c", str(folders["cal"]))
    res = run_cli_in_process(*args, "-o", str(on))
    assert res.returncode == 0, res.stderr
    assert "height std median" in res.stdout
    res = run_cli_in_process(*args, "-o", str(off), "--no-uncertainty")
    assert res.returncode == 0, res.stderr
    a, b = _files(on), _files(off)
    assert sorted(set(a) - set(b)) == [
        "height_std.png",
        "height_std.tiff",
        "phase_std.png",
        "phase_std.tiff",
    ]
    for name in b:
        if name not in ("phase_summary.json", "metrics.json"):
            assert a[name] == b[name], name
    metrics = json.loads(a["metrics.json"])
    assert _without(metrics) == json.loads(b["metrics.json"])
    assert metrics["uncertainty"]["noise"]["source"].startswith("manifest camera.read_noise_dn")
    assert _without(json.loads(a["phase_summary.json"])) == json.loads(b["phase_summary.json"])
    cal = load_calibration(folders["cal"])
    phase_std = read_map_tiff(on / "phase_std.tiff").astype(np.float64)
    height_std = read_map_tiff(on / "height_std.tiff").astype(np.float64)
    np.testing.assert_allclose(height_std, np.abs(cal.k_map) * phase_std, rtol=1e-6)
    inside = cal.measurement_mask()
    assert metrics["uncertainty"]["height_std_median_mm"] == pytest.approx(
        float(np.nanmedian(height_std[inside])), rel=1e-6
    )


def test_three_step_folder_needs_the_noise(folders: dict, tmp_path: Path) -> None:
    res = run_cli_in_process("phase", str(folders["part3_bare"]), "-o", str(tmp_path / "a"))
    assert res.returncode == 0, res.stderr
    reason = "no predicted std: no sinusoidal set with 4 or more shifts"
    assert reason in " ".join(res.stdout.split())
    assert not list((tmp_path / "a").glob("phase_std*"))
    # the summary says why, as measure's metrics do; every other key as without the block
    summary = json.loads((tmp_path / "a" / "phase_summary.json").read_text())
    block = summary["uncertainty"]
    assert block["predicted"] is False and "--noise-sigma" in block["reason"]
    assert block["reason"].startswith(reason.removeprefix("no predicted std: "))
    assert list(summary)[-2:] == ["uncertainty", "files"]
    written = sorted(_files(tmp_path / "a"))
    assert sorted([*summary["files"], "phase_summary.json"]) == written
    # the rig's folder records its noise: predicted from the manifest
    res = run_cli_in_process("phase", str(folders["part3"]), "-o", str(tmp_path / "m"))
    assert res.returncode == 0, res.stderr
    summary = json.loads((tmp_path / "m" / "phase_summary.json").read_text())
    assert summary["uncertainty"]["noise"]["source"].startswith("manifest")
    assert (tmp_path / "m" / "phase_std.tiff").is_file()
    out = tmp_path / "b"
    res = run_cli_in_process(
        "phase", str(folders["part3_bare"]), "-o", str(out), "--noise-sigma", "1.6"
    )
    assert res.returncode == 0, res.stderr
    summary = json.loads((out / "phase_summary.json").read_text())
    assert summary["uncertainty"]["noise"]["source"] == "given (--noise-sigma)"
    assert (out / "phase_std.tiff").is_file()
    for bad, message in (
        (("--noise-sigma", "-1"), "--noise-sigma must be a finite number of DN >= 0, got -1"),
        (("--noise-sigma", "1", "--no-uncertainty"), "drop --no-uncertainty"),
    ):
        res = run_cli_in_process(
            "phase", str(folders["part3_bare"]), "-o", str(tmp_path / "c"), *bad
        )
        assert res.returncode == 2 and message in " ".join(res.stderr.split()), res.stderr
        assert not (tmp_path / "c").exists()
