"""Issue 24, item 7: the hardware rig checks that its camera sees the projector, and ``rig
check`` recommends a settle in the unit its latency counts.

View check: Basler's emulated camera (``pylon:emu``) delivers a test pattern that moves by itself
at every grab, so every image differs from the one before and per-frame verification passes a
camera that never sees the projector. The rig now shows white, black and white at opening and
requires both changes to stand out against the noise *and* against the difference of the two
white images, which are twice as far apart in time as each is from the black: a pattern that
moves by itself differs between the whites at least as much as across the change. References:
the emulation (refused), the loop camera (it renders the projector's screen: passed), fakes that
drift by themselves or see the projector (known by construction).

Settle: the loop camera's latency counts grabs (its first ``k`` grabs after a change are stale,
whatever the wait), so discarding ``k`` grabs covers it and a settle adds time for nothing;
``rig check`` recommended ``(k + 1)`` grab periods of settle on top (1.43 s per frame on a busy
machine). A fake camera whose latency is a time (it shows what was on screen ``LAG_S`` ago) is
the other case: there the settle must cover ``LAG_S`` and nothing is left to discard.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.hardware.camera import CameraBase
from hdrfringe.hardware.config import RigConfig
from hdrfringe.hardware.rig import (
    HardwareRig,
    SyncError,
    SyncSettings,
    check_rig,
    recommend_sync,
)
from tests.conftest import xvfb_display
from tests.test_hardware_rig import FakeCamera, FakeProjector

pytestmark = pytest.mark.xdist_group("xvfb")

SCREEN = (320, 240)
LOOP = "size=64x48"


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYLON_CAMEMU"}
    return subprocess.run(
        [sys.executable, "-m", "hdrfringe.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )


def one_error_line(r: subprocess.CompletedProcess[str]) -> str:
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), r.stderr
    return " ".join(r.stderr.split())


@pytest.fixture(scope="module")
def xdisplay() -> Iterator[str]:
    with xvfb_display(*SCREEN) as display:
        yield display


# -- the view check ---------------------------------------------------------------------------


CAPTURE = ["--pitch", "1024", "--no-centerline", "--settle", "0"]


def test_capture_refuses_pylons_emulation_which_does_not_see_the_projector(
    tmp_path: Path,
) -> None:
    # a folder projector: the emulated camera cannot see it, nor anything else
    out = tmp_path / "caps"
    projector = f"folder:{tmp_path / 'shown'}@64x48"
    r = cli("capture", "--projector", projector, "--camera", "pylon:emu", *CAPTURE, "-o", str(out))
    line = one_error_line(r)
    assert "camera pylon:emu does not see the projector" in line
    assert "--no-view-check" in line and "Traceback" not in r.stderr
    ratio = float(line.split("(change ")[1].split("x")[0])
    assert ratio < 1.0  # its moving pattern: no more change across the projector's than without
    assert not out.exists()

    # the explicit opt-out: the same capture runs (the moving pattern passes verification)
    projector = f"folder:{tmp_path / 'shown2'}@64x48"
    r = cli("capture", "--projector", projector, "--camera", "pylon:emu", *CAPTURE,
            "--no-view-check", "-o", str(out))  # fmt: skip
    assert r.returncode == 0, r.stderr
    log = json.loads((out / "capture_log.json").read_text())
    assert log["view_change"] is None and log["rig"]["sync"]["view_check"] is False

    # or from the rig configuration (sync.view_check = false); an option given overrides it
    toml = tmp_path / "rig.toml"
    projector = f"folder:{tmp_path / 'shown3'}@64x48"
    toml.write_text(
        f'[projector]\nspec = "{projector}"\n[camera]\nspec = "pylon:emu"\n'
        "[sync]\nsettle_s = 0.0\nview_check = false\n"
    )
    r = cli("capture", "--rig-config", str(toml), "--pitch", "1024", "--no-centerline",
            "-o", str(tmp_path / "from_file"))  # fmt: skip
    assert r.returncode == 0, r.stderr
    toml.write_text(toml.read_text().replace("shown3", "shown4"))
    r = cli("capture", "--rig-config", str(toml), "--pitch", "1024", "--no-centerline",
            "--view-check", "-o", str(tmp_path / "overridden"))  # fmt: skip
    assert "does not see the projector" in one_error_line(r)


def test_measure_hardware_has_the_same_view_check_and_opt_out(tmp_path: Path) -> None:
    """``measure --rig hardware`` on the emulation: refused in one line naming
    --no-view-check, nothing written; with --no-view-check it measures (as capture does);
    the option is a hardware option (refused on a folder)."""
    out = tmp_path / "m"
    hw = ["measure", "--rig", "hardware", "--camera", "pylon:emu", *CAPTURE, "--no-previews"]
    r = cli(*hw, "--projector", f"folder:{tmp_path / 'shown'}@64x48", "-o", str(out))
    line = one_error_line(r)
    assert "camera pylon:emu does not see the projector" in line and "--no-view-check" in line
    assert not out.exists()
    r = cli(*hw, "--projector", f"folder:{tmp_path / 'shown2'}@64x48", "--no-view-check",
            "-o", str(out))  # fmt: skip
    assert r.returncode == 0, r.stderr
    log = json.loads((out / "captures" / "capture_log.json").read_text())
    assert log["view_change"] is None and log["rig"]["sync"]["view_check"] is False
    r = cli("measure", str(out / "captures"), "--no-view-check", "-o", str(tmp_path / "f"))
    assert "--view-check only applies to --rig hardware" in one_error_line(r)
    assert not (tmp_path / "f").exists()


def test_capture_on_the_loop_camera_passes_the_view_check(xdisplay: str, tmp_path: Path) -> None:
    out = tmp_path / "caps"
    camera = f"loop:checkerboard?display={xdisplay}&latency=1&{LOOP}"
    r = cli("capture", "--projector", f"screen:0@{xdisplay}", "--camera", camera, *CAPTURE,
            "-o", str(out))  # fmt: skip
    assert r.returncode == 0, r.stderr
    log = json.loads((out / "capture_log.json").read_text())
    assert log["rig"]["sync"]["view_check"] is True
    assert log["view_change"] > 100  # black to white on a checkerboard: far above the noise
    assert [f["rejected"] for f in log["frames"]] == [1] * 4  # and the reference is right


class DriftingCamera(CameraBase):
    """Blind to the projector; its image is a ramp that moves one level per grab (as pylon's
    emulation does), plus noise."""

    name = "drifting"

    def __init__(self, step: int = 1) -> None:
        self.step, self.count = step, 0
        self.rng = np.random.default_rng(2)
        y, x = np.mgrid[0:24, 0:32]
        self.ramp = x + y

    def _grab(self, timeout_s: float) -> np.ndarray:
        self.count += 1
        image = (self.ramp + self.step * self.count) % 256 + self.rng.normal(0, 1, self.ramp.shape)
        return np.clip(np.rint(image), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("discard", [0, 3])
def test_a_camera_whose_image_moves_by_itself_is_refused(discard: int) -> None:
    sync = SyncSettings(settle_s=0.0, discard=discard)
    rig = HardwareRig(FakeProjector(), DriftingCamera(), sync)
    with pytest.raises(SyncError, match="camera drifting does not see the projector"):
        rig.open()
    assert rig.view_ratio is not None and rig.view_ratio < 1.0
    # frame verification alone lets the same camera through: each frame gets an image that
    # differs from the previous frames' (a few grabs later, the ramp has moved on)
    sync = SyncSettings(settle_s=0.0, discard=discard, view_check=False)
    with HardwareRig(FakeProjector(), DriftingCamera(), sync) as rig:
        images = rig.capture(FringeSpec("sinusoidal", 4, 16.0).frames())
    assert len(images) == len(rig.log) == 4 and rig.view_ratio is None


def test_rig_check_refuses_pylons_emulation_which_does_not_see_the_projector(
    tmp_path: Path,
) -> None:
    """``rig check`` ran no view check and reported the emulation's latency as 0 (its moving
    pattern changes at every grab); now one line, exit 2, no report written; the same
    opt-out as capture (--no-view-check) gives the old report, view_change null."""
    report = tmp_path / "check.json"
    base = ["rig", "check", "--camera", "pylon:emu", "--changes", "2", "--max-latency", "2"]
    r = cli(*base, "--projector", f"folder:{tmp_path / 'shown'}@64x48", "-o", str(report))
    line = one_error_line(r)
    assert "camera pylon:emu does not see the projector" in line and "--no-view-check" in line
    assert not report.exists()
    r = cli(*base, "--projector", f"folder:{tmp_path / 'shown2'}@64x48", "--no-view-check")
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    assert got["latencies"] == [0, 0] and got["view_change"] is None
    assert got["rig"]["sync"]["view_check"] is False


def test_check_rig_runs_the_view_check_of_the_rig() -> None:
    """The drifting ramp (blind to the projector) fools the latency timing (its drift since
    the reference passes for the change: a report, not an error) but not the view check; a
    fake that sees the projector passes it."""
    with pytest.raises(SyncError, match="camera drifting does not see the projector"):
        check_rig(FakeProjector(), DriftingCamera(), changes=2, max_latency=3)
    blind = check_rig(FakeProjector(), DriftingCamera(), changes=2, max_latency=3,
                      view_check=False)  # fmt: skip
    assert blind.latency <= 3 and blind.view_change is None
    projector = FakeProjector()
    seen = check_rig(projector, FakeCamera(projector, latency=1), changes=2, max_latency=3)
    assert seen.view_change is not None and seen.view_change > 1000 and seen.latency == 1


def test_a_camera_that_sees_the_projector_passes_with_its_latency() -> None:
    projector = FakeProjector()
    camera = FakeCamera(projector, latency=2)
    sync = SyncSettings(settle_s=0.0, max_grabs=3)
    with HardwareRig(projector, camera, sync, sleep=lambda s: None) as rig:
        images = rig.capture(FringeSpec("sinusoidal", 4, 16.0).frames())
    assert rig.view_ratio is not None and rig.view_ratio > 1000
    assert [t.rejected for t in rig.log] == [2] * 4
    # the last reference is the view check's white, so the first frame's stale grabs (white)
    # were rejected: each image is its own frame's within noise
    white = camera.expected(np.full((48, 64), 255, np.uint8))
    assert np.abs(images[0] - white).mean() > 20


def test_the_view_check_key_is_checked_like_every_sync_key() -> None:
    assert SyncSettings().view_check is True
    assert RigConfig.from_dict({"sync": {"view_check": False}}).sync.view_check is False
    with pytest.raises(InputError, match=r"'sync\.view_check' must be true or false"):
        RigConfig.from_dict({"sync": {"view_check": "no"}})


# -- the recommended settle -------------------------------------------------------------------


def test_rig_check_on_the_loop_camera_recommends_no_settle_for_a_latency_in_grabs(
    xdisplay: str, tmp_path: Path
) -> None:
    camera = f"loop:checkerboard?display={xdisplay}&latency=2&{LOOP}"
    r = cli("rig", "check", "--projector", f"screen:0@{xdisplay}", "--camera", camera,
            "--changes", "3", "--max-latency", "5")  # fmt: skip
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    assert got["latencies"] == [2, 2, 2]
    assert got["view_change"] > 100  # the view check ran and the loop camera passed it
    # waiting as long as the latency took did not shorten it: it counts grabs
    assert got["latency_after_settle"] == 2 and got["latency_unit"] == "grabs"
    assert got["latency_s"] >= 3 * 0.5 * got["grab_period_s"]  # three grabs took that long
    # so the discard covers it, and the settle is bounded by what waiting removes: nothing
    assert got["recommended"] == {"settle": 0.0, "discard": 2}
    # the recommendation works: a capture with it rejects no stale grab and waits for nothing
    caps = tmp_path / "caps"
    r = cli("capture", "--projector", f"screen:0@{xdisplay}", "--camera", camera,
            "--pitch", "1024", "--no-centerline", "--settle", "0", "--discard", "2",
            "-o", str(caps))  # fmt: skip
    assert r.returncode == 0, r.stderr
    log = json.loads((caps / "capture_log.json").read_text())
    assert {(f["discarded"], f["rejected"]) for f in log["frames"]} == {(2, 0)}


#: The time-lag camera's latency (seconds) and the time one of its grabs takes.
LAG_S, GRAB_S = 0.04, 0.004


class LaggingCamera(FakeCamera):
    """Shows what the projector showed ``LAG_S`` seconds before the grab (a projector's input
    lag): the latency is a time, and waiting it out is enough."""

    def __init__(self, projector: FakeProjector) -> None:
        super().__init__(projector, 0, 1.0)
        self.shown: list[tuple[float, np.ndarray | None]] = [(-np.inf, None)]
        projector.listeners = [self._changed_at]

    def _changed_at(self, previous: np.ndarray | None, current: np.ndarray) -> None:
        self.shown.append((time.perf_counter(), current))

    def _grab(self, timeout_s: float) -> np.ndarray:
        now = time.perf_counter()
        time.sleep(GRAB_S)
        seen = [image for t, image in self.shown if t <= now - LAG_S][-1]
        noisy = self.expected(seen) + self.rng.normal(0.0, self.noise, self.reflect.shape)
        return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)


def test_rig_check_recommends_a_settle_for_a_latency_in_time() -> None:
    projector = FakeProjector()
    got = check_rig(projector, LaggingCamera(projector), changes=3, max_latency=60)
    assert got.latency >= 2  # without a wait, several grabs are stale
    assert got.latency_after_settle == 0 and got.latency_unit == "seconds"
    # the settle covers the lag, and is no longer than the first fresh grab took to end
    assert LAG_S <= got.settle_s <= got.latency_s + 1e-4
    assert got.discard == 0
    # the recommendation works: no stale grab to reject, none discarded
    projector = FakeProjector()
    sync = SyncSettings(settle_s=got.settle_s, discard=got.discard)
    with HardwareRig(projector, LaggingCamera(projector), sync) as rig:
        rig.capture(FringeSpec("sinusoidal", 4, 16.0).frames())
    assert [t.rejected for t in rig.log] == [0] * 4


def test_rig_check_on_a_latency_in_grabs_without_x() -> None:
    # the fake of test_hardware_rig: k stale grabs after each change, whatever the wait
    projector = FakeProjector()
    got = check_rig(projector, FakeCamera(projector, latency=3), changes=2, max_latency=5)
    assert (got.latency, got.latency_after_settle, got.latency_unit) == (3, 3, "grabs")
    assert (got.settle_s, got.discard) == (0.0, 3)
    projector = FakeProjector()
    got = check_rig(projector, FakeCamera(projector, latency=0), changes=2, max_latency=5)
    assert (got.latency, got.latency_unit, got.settle_s, got.discard) == (0, "none", 0.0, 0)


def test_recommend_sync_covers_a_mixed_latency_with_both() -> None:
    # waiting shortened 4 stale grabs to 1: a time, then a queue of one image
    assert recommend_sync(4, 0.25, 1) == (0.25, 1, "mixed")


# -- docs/hardware.md's X server recipe -------------------------------------------------------


def test_the_documented_xvfb_recipe_opens_a_free_display(tmp_path: Path) -> None:
    """The sh block of docs/hardware.md that starts Xvfb with -displayfd runs (without its
    ``hdrfringe`` line): it opens a display other than a fixed number, whose screen is the
    size asked for, and stops it again."""
    text = (Path(__file__).parents[1] / "docs" / "hardware.md").read_text()
    blocks = [b.split("```", 1)[0] for b in text.split("```sh\n")[1:]]
    (block,) = [b for b in blocks if "-displayfd" in b]
    # no command of the page starts Xvfb on a fixed display number
    assert not [b for b in blocks if re.search(r"Xvfb\s+:\d", b)]
    lines = [ln for ln in block.splitlines() if not ln.startswith("hdrfringe ")]
    grab = f'{sys.executable} -c "from PIL import ImageGrab; import os; '
    grab += "print(os.environ['DISPLAY'], *ImageGrab.grab(xdisplay=os.environ['DISPLAY']).size)\""
    kill = lines.index('kill "$XVFB_PID"')
    script = "\n".join([*lines[:kill], grab, *lines[kill:], 'wait "$XVFB_PID" 2>/dev/null; true'])
    (tmp_path / "recipe.sh").write_text(script + "\n")
    r = subprocess.run(["bash", str(tmp_path / "recipe.sh")], capture_output=True, text=True,
                       timeout=60)  # fmt: skip
    assert r.returncode == 0, r.stderr
    display, width, height = r.stdout.split()
    assert display.startswith(":") and display[1:].isdigit()
    assert (int(width), int(height)) == (1024, 768)
