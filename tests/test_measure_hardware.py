"""``measure --rig hardware``, ``capture --rig-config`` and ``rig check --write-config`` on the
loop rig (issue 13, items 4 and 5).

The loop rig is a projector window on a private Xvfb screen of the virtual rig's projector
size (1024x768) and the loop camera (``loop:SCENE``, docs/hardware.md), at a quarter of the
virtual camera's resolution (162x124, same field of view) to keep the grabs cheap. References
are made without the code under test: the virtual rig itself (``virtual_rig`` +
``pipeline.measure``, what ``measure --rig sim`` runs, at the same camera resolution) for the
height error, and ``measure FOLDER`` of the capture folder for the replay.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.io.calibration_file import load_calibration, save_calibration
from hdrfringe.io.results import read_map_tiff
from hdrfringe.io.rig_config import load_rig_config
from hdrfringe.pipeline import calibrate
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, SimulatedRig
from tests.conftest import xvfb_display

# One worker runs the Xvfb tests (as the window and loop tests).
pytestmark = pytest.mark.xdist_group("xvfb")

SCREEN = (1024, 768)  # the virtual rig's projector
SIZE = (162, 124)  # a quarter of the virtual camera's 648x494, same field of view
DEPTH_MM = 10.0
AMBIENT_LX = 600.0  # the white plate saturates at MIGL 255: LPA walks down
STRATEGY = ["--strategy", "lpa", "--step", "50"]
# The coarse pitches unwrap the finest temporally: a one-pixel centerline is too thin for the
# quarter-resolution camera (a sixth of a camera pixel).
FRINGES = ["--pitch", "1024,64,8", "--no-centerline"]


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "hdrfringe.cli", *args], capture_output=True, text=True, timeout=600
    )


def one_error_line(r: subprocess.CompletedProcess[str]) -> str:
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), r.stderr
    assert "Traceback" not in r.stderr
    return lines[0]


@pytest.fixture(scope="module")
def xdisplay() -> Iterator[str]:
    with xvfb_display(*SCREEN) as display:
        yield display


def loop_camera(display: str, latency: int = 0) -> str:
    return (
        f"loop:white_plate?display={display}&size={SIZE[0]}x{SIZE[1]}&depth={DEPTH_MM:g}"
        f"&ambient={AMBIENT_LX:g}&latency={latency}"
    )


@pytest.fixture(scope="module")
def calibration(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Rational calibration of the virtual rig at the loop camera's resolution (white plate at
    0, 8, 16, 24 mm; 4-step pitches 1024, 64 and 8), as calibrate would make it."""
    frames = [f for p in (1024.0, 64.0, 8.0) for f in FringeSpec("sinusoidal", 4, p).frames()]
    camera = CameraModel(width=SIZE[0], height=SIZE[1])
    folders = [
        SimulatedRig(white_plate(d), camera=camera).capture_folder(frames) for d in (0, 8, 16, 24)
    ]
    path = tmp_path_factory.mktemp("cal") / "cal.h5"
    save_calibration(path, calibrate(folders, model="rational"))
    return path


@pytest.fixture(scope="module")
def rig_toml(xdisplay: str, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A rig configuration of the loop rig (latency 1 grab), as a lab would write it."""
    path = tmp_path_factory.mktemp("cfg") / "rig.toml"
    path.write_text(
        f'name = "loop rig"\ngamma = 2.812\n\n[projector]\nspec = "screen:0@{xdisplay}"\n'
        f"width = {SCREEN[0]}\nheight = {SCREEN[1]}\n\n"
        f'[camera]\nspec = "{loop_camera(xdisplay, latency=1)}"\npixel_format = "Mono8"\n\n'
        "[sync]\nsettle_s = 0.0\nmax_grabs = 3\n"
    )
    return path


@pytest.fixture(scope="module")
def hardware_run(
    rig_toml: Path, calibration: Path, tmp_path_factory: pytest.TempPathFactory
) -> Path:
    """``measure --rig hardware`` from the configuration, with --discard 1 given on the
    command line (overrides the file's default 0: the latency is dropped unverified)."""
    out = tmp_path_factory.mktemp("hw") / "out"
    r = cli("measure", "--rig", "hardware", "--rig-config", str(rig_toml), "--discard", "1",
            *STRATEGY, *FRINGES, "-c", str(calibration), "-o", str(out))  # fmt: skip
    assert r.returncode == 0, r.stderr
    return out


def height_error(height: np.ndarray, mask: np.ndarray) -> np.ndarray:
    ok = mask & np.isfinite(height)
    assert ok.mean() > 0.5 * mask.mean()
    return (height - DEPTH_MM)[ok]


def test_measure_hardware_records_the_capture_folder_and_the_resolved_rig(
    hardware_run: Path, rig_toml: Path
) -> None:
    caps = hardware_run / "captures"
    manifest = json.loads((caps / "manifest.json").read_text())
    log = json.loads((caps / "capture_log.json").read_text())
    state = manifest["capture"]
    assert state["complete"] is True and log["complete"] is True
    assert len(log["frames"]) == len(manifest["frames"])
    rig = state["rig"]
    digest = hashlib.sha256(rig_toml.read_bytes()).hexdigest()
    assert rig["config_file"] == {"path": str(rig_toml), "sha256": digest}
    assert rig["name"] == "loop rig" and rig["gamma"] == 2.812
    assert rig["sync"]["discard"] == 1  # the command line overrode the file
    assert rig["sync"]["max_grabs"] == 3 and rig["sync"]["settle_s"] == 0.0  # the file's
    assert state["sync"]["discard"] == 1 and log["rig"] == rig
    # discard 1 drops the loop camera's one stale grab: nothing left to reject
    assert {(f["discarded"], f["rejected"]) for f in log["frames"]} == {(1, 0)}
    metrics = json.loads((hardware_run / "metrics.json").read_text())
    assert metrics["capture"] == state
    assert metrics["method"] == "lpa" and len(metrics["migls"]) == 3
    assert all(len(m) > 1 for m in metrics["migls"])  # LPA walked down below MIGL 255
    assert len(manifest["frames"]) == 4 * metrics["sets_captured"]


def test_measure_hardware_equals_measure_of_its_capture_folder(
    hardware_run: Path, calibration: Path, tmp_path: Path
) -> None:
    replay = tmp_path / "replay"
    r = cli("measure", str(hardware_run / "captures"), *STRATEGY, "-c", str(calibration),
            "-o", str(replay))  # fmt: skip
    assert r.returncode == 0, r.stderr
    maps = sorted(p.name for p in hardware_run.glob("*.tiff"))
    assert "height.tiff" in maps and "absolute_phase_vertical.tiff" in maps
    assert maps == sorted(p.name for p in replay.glob("*.tiff"))
    for name in maps:
        a, b = read_map_tiff(hardware_run / name), read_map_tiff(replay / name)
        np.testing.assert_array_equal(a, b, err_msg=name)
    live = json.loads((hardware_run / "metrics.json").read_text())
    again = json.loads((replay / "metrics.json").read_text())
    assert live["migls"] == again["migls"] and live["sets_captured"] == again["sets_captured"]


def test_measure_hardware_height_error_is_the_virtual_rigs_within_noise(
    hardware_run: Path, calibration: Path
) -> None:
    from hdrfringe import pipeline
    from hdrfringe.rig.factory import virtual_rig
    from hdrfringe.tasks.capture import LiveFringes

    cal = load_calibration(calibration)
    mask = cal.measurement_mask()
    heights = []
    for seed in (0, 1, 2):  # what measure --rig sim runs, at the loop camera's resolution
        sim = virtual_rig("white_plate", depth_mm=DEPTH_MM, ambient_lux=AMBIENT_LX, seed=seed,
                          resolution=SIZE)  # fmt: skip
        specs, line = LiveFringes("sinusoidal", 4, [1024, 64, 8], 40.0, 255.0, False).build(
            sim.projector
        )
        res = pipeline.measure(sim, cal, strategy="lpa", params={"step": 50.0}, specs=specs,
                               centerline=line)  # fmt: skip
        heights.append(res.height_mm)
    hw = read_map_tiff(hardware_run / "height.tiff")
    rms = [float(np.sqrt(np.mean(height_error(h, mask) ** 2))) for h in (hw, *heights)]
    # within noise: the hardware run's RMSE differs from the virtual rig's (seed 0) by no more
    # than twice the largest change another noise seed makes (or 2 % of it)
    spread = max(rms[1:]) - min(rms[1:])
    assert abs(rms[0] - rms[1]) <= max(2 * spread, 0.02 * rms[1]), rms
    # and pixel for pixel: hardware vs virtual differ as two virtual runs do (noise only)
    ok = mask & np.isfinite(hw) & np.isfinite(heights[0]) & np.isfinite(heights[1])
    d_hw = np.abs(hw - heights[0])[ok]
    d_seed = np.abs(heights[1] - heights[0])[ok]
    assert np.median(d_hw) <= 1.5 * np.median(d_seed), (np.median(d_hw), np.median(d_seed))
    assert np.percentile(d_hw, 99) <= 1.5 * np.percentile(d_seed, 99)
    assert abs(float(np.mean(height_error(hw, mask)))) < 0.01  # no bias of its own (mm)


def test_capture_with_a_rig_config_and_a_wrong_projector_size(
    rig_toml: Path, xdisplay: str, tmp_path: Path
) -> None:
    caps = tmp_path / "caps"
    noisy = tmp_path / "noisy.toml"  # with the noise rig check writes: the manifest records it
    noisy.write_text(rig_toml.read_text().replace("[camera]\n", "[camera]\nread_noise_dn = 1.25\n"))
    r = cli("capture", "--rig-config", str(noisy), "--pitch", "1024", "--no-centerline",
            "--exposure-ms", "6", "-o", str(caps))  # fmt: skip
    assert r.returncode == 0, r.stderr
    manifest = json.loads((caps / "manifest.json").read_text())
    assert manifest["camera"]["read_noise_dn"] == 1.25
    assert manifest["capture"]["rig"]["camera"]["read_noise_dn"] == 1.25
    rig = manifest["capture"]["rig"]
    # given: overrides the camera's own 10 ms, at which white saturates every pixel here
    assert rig["camera"]["exposure_ms"] == 6.0
    assert rig["camera"]["spec"] == loop_camera(xdisplay, latency=1)  # from the file
    assert set(manifest["capture"]) >= {"method", "complete", "projector", "camera", "sync"}
    assert {f.get("exposure_ms") for f in manifest["frames"]} == {6.0}
    log = json.loads((caps / "capture_log.json").read_text())
    assert [f["rejected"] for f in log["frames"]] == [1] * len(log["frames"])  # latency 1

    wrong = tmp_path / "wrong.toml"
    wrong.write_text(rig_toml.read_text().replace(f"width = {SCREEN[0]}", "width = 1920"))
    wrong.write_text(wrong.read_text().replace(f"height = {SCREEN[1]}", "height = 1080"))
    out = tmp_path / "never"
    r = cli("capture", "--rig-config", str(wrong), "--pitch", "1024", "-o", str(out))
    line = one_error_line(r)
    assert "is 1024x768 but" in line and "expects 1920x1080" in line
    assert not out.exists()


def test_rig_check_writes_the_config_with_the_measured_settle_and_discard(
    rig_toml: Path, xdisplay: str, tmp_path: Path
) -> None:
    written = tmp_path / "checked.toml"
    args = ["rig", "check", "--rig-config", str(rig_toml), "--changes", "3", "--max-latency", "5"]
    three = loop_camera(xdisplay, latency=3)
    r = cli(*args, "--camera", three, "--write-config", str(written))
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    assert abs(report["latency"] - 3) <= 1
    cfg = load_rig_config(written)
    assert cfg.sync.discard == report["recommended"]["discard"] == report["latency"]
    # the loop camera's latency counts grabs: the discard covers it, no settle (issue 24)
    assert cfg.sync.settle_s == report["recommended"]["settle"] == 0.0
    assert cfg.camera.spec == three  # the option given, not the file's latency-1 camera
    # the camera noise the report gives, for capture to record (the file had none)
    assert cfg.camera.read_noise_dn == round(report["noise_std"], 4) > 0
    assert cfg.name == "loop rig" and cfg.gamma == 2.812 and cfg.sync.max_grabs == 3
    assert cfg.projector.size == SCREEN
    assert report["rig"]["config_file"]["path"] == str(rig_toml)
    # like every output: not replaced without --force, nothing else written
    before = written.read_bytes()
    r = cli(*args, "--write-config", str(written))
    assert "exists" in one_error_line(r)
    assert written.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checked.toml"]
