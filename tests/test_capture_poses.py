"""``hdrfringe capture-poses`` (issue 13): the board poses of a stereo calibration, live.

On the loop rig (Xvfb at the calibration rig's 800x600 projector, ``loop:board?pose=K``,
described by a rig configuration file) the test moves the board while the command waits for
Enter, as a user does, and ``calibrate-stereo`` calibrates from the folders written; the
reference is the calibration rig's true geometry, which the commands never see. The stopping
rules (q, Ctrl-C, an error mid-run) run on the fake projector and camera of
tests/test_hardware_rig.py.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from hdrfringe.hardware.rig import HardwareRig, SyncSettings
from tests.conftest import xvfb_display
from tests.test_hardware_rig import OPEN_GRABS, FakeCamera, FakeProjector, InterruptingCamera

# The Xvfb tests share one group: one worker runs them (make test: --dist loadgroup).
pytestmark = pytest.mark.xdist_group("xvfb")

WIDTH, HEIGHT = 800, 600  # the calibration rig's projector (rig.board_poses.calibration_rig)
CAMERA_SIZE = (320, 240)


@pytest.fixture(scope="module")
def xdisplay() -> Iterator[str]:
    with xvfb_display(WIDTH, HEIGHT) as display:
        yield display


def invoke(args: list[str], stdin: str = "") -> Any:
    from hdrfringe.cli import app

    return CliRunner().invoke(app, ["capture-poses", *args], input=stdin)


def test_calibrate_stereo_reads_the_poses_captured_on_the_loop_rig(
    xdisplay: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from hdrfringe.cli import capture_poses
    from hdrfringe.hardware.loop_camera import LoopCamera
    from hdrfringe.rig.board_poses import calibration_rig, default_board_poses
    from hdrfringe.tasks import capture_poses as task

    cameras: list[LoopCamera] = []
    make_rig, wait = task._poses_rig, capture_poses._wait_for_pose

    def keep_camera(*args: Any, **kwargs: Any) -> tuple[HardwareRig, Any]:
        rig, config = make_rig(*args, **kwargs)
        cameras.append(rig.camera)
        return rig, config

    def user_moves_the_board(number: int, total: int, interval: float | None) -> bool:
        go = wait(number, total, interval)  # the prompt and the Enter key
        cameras[0].set_pose(number - 1)  # pose k is default_board_poses' k-1
        return go

    monkeypatch.setattr(task, "_poses_rig", keep_camera)
    monkeypatch.setattr(capture_poses, "_wait_for_pose", user_moves_the_board)
    out = tmp_path / "poses"
    size = f"{CAMERA_SIZE[0]}x{CAMERA_SIZE[1]}"
    camera = f"loop:board?display={xdisplay}&pose=0&size={size}&latency=1"
    # the rig from a configuration file (its gamma applies; --settle overrides its settle)
    config = tmp_path / "rig.toml"
    config.write_text(
        f'name = "loop"\ngamma = 2.8\n[projector]\nspec = "screen:0@{xdisplay}"\n'
        f'width = {WIDTH}\nheight = {HEIGHT}\n[camera]\nspec = "{camera}"\n'
        "[sync]\nsettle_s = 0.5\nmax_grabs = 3\n"
    )
    args = ["--rig-config", str(config), "--settle", "0", "--poses", "3", "--steps", "3"]
    board = ["--board", "checkerboard:9x6:25"]
    r = invoke([*args, *board, "-o", str(out)], stdin="\n\n\n")
    assert r.exit_code == 0, r.output
    assert r.output.count("place the board, then press Enter") == 3
    summary = json.loads((out / "capture_poses.json").read_text())
    assert summary["poses"] == ["pose_01", "pose_02", "pose_03"] and summary["complete"] is True
    digest = hashlib.sha256(config.read_bytes()).hexdigest()
    for name in summary["poses"]:
        log = json.loads((out / name / "capture_log.json").read_text())
        # latency 1: every frame rejects exactly one stale grab, the first one of a pose too
        # (after the board moved the stale image differs from the old pose's images: without
        # a new reference image it would be accepted)
        assert [f["rejected"] for f in log["frames"]] == [1] * 19, name
        manifest = json.loads((out / name / "manifest.json").read_text())
        assert manifest["projector"]["gamma_precompensation"] == 2.8  # the file's gamma
        for record in (manifest["capture"], log, summary):  # the resolved rig, and its file
            rig = record["rig"]
            assert rig["config_file"] == {"path": str(config), "sha256": digest}
            assert rig["name"] == "loop" and rig["gamma"] == 2.8
            assert rig["sync"]["settle_s"] == 0.0 and rig["sync"]["max_grabs"] == 3
            assert record["camera"] == camera and record["sync"]["settle_s"] == 0.0
        assert manifest["capture"]["pose"] == log["pose"] == int(name[-2:])

    # the closing hint (--board given) is the calibrate-stereo command, and it runs as printed
    from tests.test_next_hints import run_hint

    assert summary["board"] == "checkerboard:9x6:25"
    command, r2 = run_hint(r.output, tmp_path / "unused")
    assert command == "calibrate-stereo" and r2.returncode == 0, r2.stderr
    report = json.loads((out / "stereo_report.json").read_text())
    assert report["settings"]["poses_used"] == 3
    truth = calibration_rig(
        default_board_poses(1)[0], camera_size=CAMERA_SIZE, projector_size=(WIDTH, HEIGHT)
    ).stereo_calibration()
    got = report["calibration"]
    assert got["baseline_mm"] == pytest.approx(truth.baseline_mm, rel=0.05)
    focal = np.asarray(got["projector"]["matrix"])[0, 0]
    assert focal == pytest.approx(truth.projector.matrix[0, 0], rel=0.05)


def fake_rig(camera: type[FakeCamera] = FakeCamera, **kwargs: Any) -> Any:
    """A ``_poses_rig`` on the fake projector and camera (the configuration resolved as the
    command's own, the devices fake)."""
    from hdrfringe.tasks.capture import resolve_rig_config

    def build(rig_config: Path | None, given: Any, **options: Any) -> tuple[HardwareRig, Any]:
        projector = FakeProjector()
        sync = SyncSettings(settle_s=0.0)
        rig = HardwareRig(projector, camera(projector, **kwargs), sync, sleep=lambda s: None)
        return rig, resolve_rig_config(rig_config, given, **options)

    return build


FAKE = ["--projector", "screen:0", "--camera", "fake:0", "--pitch", "64,16"]
#: Grabs: OPEN_GRABS when the rig opens (4 x (0 discarded + 5 + 2): mid-gray, white and the
#: view check's black and white), per pose 7 for the new reference image and one per frame of
#: the 17 (2 orientations x 2 pitches x 4 steps + white).
OPEN, PER_POSE = OPEN_GRABS, 7 + 17


def test_q_finishes_after_the_complete_poses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from hdrfringe.io.captures import read_capture_folder
    from hdrfringe.tasks import capture_poses

    monkeypatch.setattr(capture_poses, "_poses_rig", fake_rig())
    out = tmp_path / "poses"
    r = invoke([*FAKE, "--poses", "5", "-o", str(out)], stdin="\n\nq\n")
    assert r.exit_code == 0, r.output
    text = " ".join(r.output.split())
    assert "2 complete poses (pose_01 .. pose_02), finished with q" in text
    assert "calibrate-stereo needs at least 3 poses" in text
    # no --board: no next: hint (it could not run as printed), the instruction instead
    assert "next:" not in text
    assert f"to calibrate: hdrfringe calibrate-stereo {out}/pose_* --board PATTERN:" in text
    summary = json.loads((out / "capture_poses.json").read_text())
    assert summary["complete"] is False and summary["stopped"] == "finished with q"
    assert sorted(p.name for p in out.iterdir()) == ["capture_poses.json", "pose_01", "pose_02"]
    caps = read_capture_folder(out / "pose_02")
    assert len(caps.frames) == 17 and caps.frames[-1].kind == "uniform"
    # with --board but too few poses for calibrate-stereo: still no next: hint
    r = invoke([*FAKE, "--board", "circles:4x11:20", "-o", str(tmp_path / "b")], stdin="\nq\n")
    assert r.exit_code == 0 and "next:" not in r.output and "to calibrate" not in r.output
    # q at the first prompt: nothing written
    r = invoke([*FAKE, "-o", str(tmp_path / "none")], stdin="q\n")
    assert r.exit_code == 2 and "before the first pose; nothing written" in r.stderr
    assert not (tmp_path / "none").exists()


def test_ctrl_c_keeps_the_complete_poses_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from hdrfringe.tasks import capture_poses

    at = OPEN + 2 * PER_POSE + 10  # mid pose 3
    monkeypatch.setattr(capture_poses, "_poses_rig", fake_rig(InterruptingCamera, at=at))
    out = tmp_path / "poses"
    r = invoke([*FAKE, "--poses", "4", "--interval", "0", "-o", str(out)])
    assert r.exit_code == 2
    message = " ".join(r.stderr.split())
    assert r.stderr.count("error:") == 1
    assert "interrupted (Ctrl-C); " in message and "holds the 2 complete poses" in message
    assert sorted(p.name for p in out.iterdir()) == ["capture_poses.json", "pose_01", "pose_02"]
    summary = json.loads((out / "capture_poses.json").read_text())
    assert summary["complete"] is False and summary["stopped"] == "interrupted (Ctrl-C)"
    # Ctrl-C in the first pose: nothing written, the shell's 130
    monkeypatch.setattr(capture_poses, "_poses_rig", fake_rig(InterruptingCamera, at=OPEN + 9))
    r = invoke([*FAKE, "--interval", "0", "-o", str(tmp_path / "none")])
    assert r.exit_code == 130 and not (tmp_path / "none").exists()


def test_an_error_mid_run_keeps_the_complete_poses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from hdrfringe.tasks import capture_poses

    # latency 0 for the rig's mid-gray, white, black and white and pose 1, then 9 stale grabs:
    # a sync error in pose 2
    latencies = iter([0] * 21 + [9] * 100)
    monkeypatch.setattr(capture_poses, "_poses_rig", fake_rig(latency=latencies))
    out = tmp_path / "poses"
    r = invoke([*FAKE, "--poses", "3", "--interval", "0", "-o", str(out)])
    assert r.exit_code == 2
    message = " ".join(r.stderr.split())
    assert "stopped by an error at pose 2: projector frame" in message
    assert "holds the 1 complete poses (pose_01 .. pose_01)" in message
    assert sorted(p.name for p in out.iterdir()) == ["capture_poses.json", "pose_01"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--poses", "0"], "--poses 0: give 1..100"),
        (["--interval", "-1"], "--interval -1.0: give a number of seconds >= 0"),
        (["--pitch", "a,b"], "--pitch: cannot read"),
        (["--camera", "usb3:1"], "unknown back end 'usb3'"),
        (["--board", "checkerboard:9x6"], "board 'checkerboard:9x6': give PATTERN:COLSxROWS"),
    ],
)
def test_capture_poses_refuses_bad_input_in_one_line(
    args: list[str], message: str, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    r = invoke(["--projector", "screen:0@:4999", "--camera", "pylon:emu", *args, "-o", str(out)])
    assert r.exit_code == 2
    assert message in " ".join(r.stderr.split()) and r.stderr.count("error:") == 1
    assert not out.exists()


@pytest.mark.usefixtures("stop_signals_not_ignored")
@pytest.mark.parametrize(
    ("signum", "code", "said"),
    [
        (signal.SIGTERM, 143, "stopped by SIGTERM"),
        (signal.SIGHUP, 129, "stopped by SIGHUP"),
        (signal.SIGINT, 2, "interrupted (Ctrl-C)"),
    ],
)
def test_a_signal_while_a_pose_is_written_keeps_the_poses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, signum: int, code: int, said: str
) -> None:
    """The signal arrives while pose 2's folder is being written (sent from inside the writer,
    in this process: no timer). SIGTERM and SIGHUP there removed the whole staging, every pose
    lost (issue 31); now, as Ctrl-C, they are held until the pose is complete, then stop the
    run keeping poses 1 and 2."""
    from hdrfringe.tasks import capture_poses

    original = capture_poses.write_capture_output
    written: list[Path] = []

    def signalled_in_pose_2(folder: Path, *args: Any) -> None:
        written.append(folder)
        if folder.name == "pose_02":
            os.kill(os.getpid(), signum)
        original(folder, *args)

    monkeypatch.setattr(capture_poses, "_poses_rig", fake_rig())
    monkeypatch.setattr(capture_poses, "write_capture_output", signalled_in_pose_2)
    out = tmp_path / "poses"
    r = invoke([*FAKE, "--poses", "4", "--interval", "0", "-o", str(out)])
    assert r.exit_code == code, r.output
    message = " ".join(r.stderr.split())
    assert r.stderr.count("error:") == 1 and f"capture-poses {said};" in message
    assert "holds the 2 complete poses (pose_01 .. pose_02)" in message
    assert "dropped" not in message  # pose 2 was complete when the signal was honoured
    assert [p.name for p in written] == ["pose_01", "pose_02"]
    assert sorted(p.name for p in out.iterdir()) == ["capture_poses.json", "pose_01", "pose_02"]
    assert len(list((out / "pose_02").glob("*.png"))) == 17
    summary = json.loads((out / "capture_poses.json").read_text())
    assert summary["complete"] is False and summary["stopped"] == said
