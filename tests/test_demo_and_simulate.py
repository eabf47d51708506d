"""The demo end to end, and the simulate/modify commands."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from hdrfringe.demo import run_demo
from hdrfringe.io.captures import read_capture_folder
from tests.conftest import run_cli


def test_demo_runs_and_meets_its_own_numbers(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    summary = run_demo(out, seed=1)
    for name in (
        "overview.png",
        "summary.json",
        "mask_3d.png",
        "calibration_white_plate_linear.h5",
        "calibration_white_plate_rational.h5",
        "mask/measurement/height.tiff",
        "mask/measurement/points.ply",
        "mask/measurement/height.png",
        "checkerboard/captures/manifest.json",
    ):
        assert (out / name).is_file(), name
    sc = summary["scenes"]
    for d in (10, 25, 40):
        plate = sc[f"white_plate_{d}mm"]
        assert plate["saturated_fraction"] == 0.0 and plate["valid_fraction"] > 0.99
        # the linear model's own error (0.15 mm over 2..50 mm) dominates; rational: noise only
        assert plate["rmse_mm"]["linear"] < 0.25
        assert plate["rmse_mm"]["rational"] < 0.08
    assert sc["mask"]["valid_fraction"] > 0.99 and sc["mask"]["rmse_mm"]["rational"] < 0.12
    board = sc["checkerboard"]
    # the white squares (about half the board) saturate at MIGL 255; the black ones are right
    assert 0.35 < board["saturated_fraction"] < 0.65
    assert 0.3 < board["valid_fraction"] < 0.6
    assert board["rmse_mm"]["rational"] < 0.08


def test_simulate_writes_a_contract_folder(tmp_path: Path) -> None:
    out = tmp_path / "caps"
    res = run_cli(
        "simulate",
        "white_plate",
        "-o",
        str(out),
        "--depth-mm",
        "12",
        "--steps",
        "3",
        "--pitch",
        "6,48",
        "--bit-depth",
        "12",
        "--gray",
        "0,128,255",
        "--ambient-lux",
        "600",
        "--seed",
        "4",
    )
    assert res.returncode == 0, res.stderr
    caps = read_capture_folder(out)
    assert caps.camera_bit_depth == 12 and caps.image_shape == (494, 648)
    assert caps.scene["depth_mm"] == 12.0
    assert len(caps.sets) == 2 and len(caps.uniforms()) == 3 and len(caps.centerlines()) == 1
    assert caps.images.max() <= 4095
    # 600 lx on the white plate saturates the fringe peaks at MIGL 255 (thesis Ch. 4)
    assert np.any(caps.images[:3] == 4095)
    again = tmp_path / "again"
    run_cli(
        "simulate",
        "white_plate",
        "-o",
        str(again),
        "--depth-mm",
        "12",
        "--steps",
        "3",
        "--pitch",
        "6,48",
        "--bit-depth",
        "12",
        "--gray",
        "0,128,255",
        "--ambient-lux",
        "600",
        "--seed",
        "4",
    )
    assert np.array_equal(read_capture_folder(again).images, caps.images)  # deterministic


def test_modify_applies_eq_4_1(tmp_path: Path) -> None:
    src = tmp_path / "caps"
    assert run_cli("simulate", "white_plate", "-o", str(src), "--no-centerline").returncode == 0
    out = tmp_path / "mod"
    res = run_cli("modify", str(src), "-o", str(out), "--add-lux", "600")
    assert res.returncode == 0, res.stderr
    a = read_capture_folder(src).images.astype(int)
    b = read_capture_folder(out).images.astype(int)
    assert np.array_equal(b, np.minimum(255, a + 102))  # 600 lx * 0.17 DN/lx, clipped
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["modification"]["add_lux"] == 600
    truth = read_capture_folder(out).read_map("truth_height_mm")  # ground truth travels along
    assert truth is not None and np.allclose(truth, 0.0)


def test_simulate_bad_scene_is_one_line(tmp_path: Path) -> None:
    res = run_cli("simulate", "teapot", "-o", str(tmp_path / "x"))
    assert res.returncode == 2 and "unknown scene" in res.stderr and "Traceback" not in res.stderr
    assert not (tmp_path / "x").exists()
