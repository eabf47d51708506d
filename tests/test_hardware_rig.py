"""HardwareRig's synchronisation (issue 13) on a fake projector and camera with a latency.

The fake camera sees the fake projector's image through a fixed scene (offset, reflectivity,
Gaussian noise, clipping) and, after each change of the projected image, returns ``latency``
stale images (of the previous image) before fresh ones: the behaviour of a camera that had
already exposed or buffered frames when the pattern changed. Each test knows the noiseless
image of every projected frame, so "no stale frame accepted" is checked against a reference
the rig did not produce.
"""

from __future__ import annotations

import json
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import CameraSettings
from hdrfringe.core.frames import Frame, UniformFrame, render_frame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.hardware.camera import CameraBase
from hdrfringe.hardware.projector import _ProjectorBase
from hdrfringe.hardware.rig import HardwareRig, SyncError, SyncSettings, change_ratio
from hdrfringe.rig.base import Rig
from tests.conftest import run_cli, xvfb_display

W, H = 64, 48

# The loop tests share an Xvfb per module; one worker runs the file (as the window tests).
pytestmark = pytest.mark.xdist_group("xvfb")


class FakeProjector(_ProjectorBase):
    def __init__(self) -> None:
        self.image: np.ndarray | None = None
        self.listeners: list[Callable[[np.ndarray | None, np.ndarray], None]] = []

    @property
    def size(self) -> tuple[int, int]:
        return (W, H)

    def open(self) -> None:
        self._frame_counter = 0

    def close(self) -> None:
        pass

    def show(self, image: np.ndarray) -> int:
        img = self._check_image(image)
        changed = self.image is None or not np.array_equal(self.image, img)
        previous, self.image = self.image, img.copy()
        if changed:
            for listen in self.listeners:
                listen(previous, self.image)
        self._frame_counter += 1
        return self._frame_counter


class FakeCamera(CameraBase):
    """Sees the projector at half resolution; ``latency`` stale images after each change."""

    name = "fake"

    def __init__(
        self, projector: FakeProjector, latency: int | Iterator[int] = 0, noise: float = 1.0
    ) -> None:
        self.projector = projector
        self.latencies = latency
        self.noise = noise
        self.gain = 1.0
        self.rng = np.random.default_rng(5)
        self.stale: np.ndarray | None = None
        self.pending = 0
        self.grabs = 0
        projector.listeners.append(self._changed)
        reflect = np.linspace(0.3, 0.9, W // 2)[None, :] * np.ones((H // 2, 1))
        self.reflect = reflect

    def _supported_triggers(self) -> tuple[str, ...]:
        return ("software", "hardware")

    def set_exposure(self, ms: float) -> float:
        self.gain = ms / 10.0
        return ms

    def _changed(self, previous: np.ndarray | None, current: np.ndarray) -> None:
        k = self.latencies if isinstance(self.latencies, int) else next(self.latencies)
        self.stale, self.pending = previous, k

    def expected(self, image: np.ndarray | None) -> np.ndarray:
        """Noiseless camera image of a projected image."""
        if image is None:
            return np.full((H // 2, W // 2), 5.0)
        return np.clip(5.0 + self.gain * self.reflect * image[::2, ::2], 0, 255)

    def _grab(self, timeout_s: float) -> np.ndarray:
        self.grabs += 1
        if self.pending > 0:
            self.pending -= 1
            seen = self.stale
        else:
            seen = self.projector.image
        noisy = self.expected(seen) + self.rng.normal(0.0, self.noise, (H // 2, W // 2))
        return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)


def make_rig(
    latency: int | Iterator[int] = 0, noise: float = 1.0, **sync: object
) -> tuple[HardwareRig, FakeCamera]:
    projector = FakeProjector()
    camera = FakeCamera(projector, latency, noise)
    settings = SyncSettings(settle_s=0.0, **sync)  # type: ignore[arg-type]
    return HardwareRig(projector, camera, settings, sleep=lambda s: None), camera


def fringe_frames() -> list[Frame]:
    frames: list[Frame] = []
    for migl in (255.0, 200.0, 150.0):
        frames += FringeSpec("sinusoidal", 4, 16.0, imin=40.0, migl=migl).frames()
    return frames


def assert_fresh(images: np.ndarray, frames: list[Frame], camera: FakeCamera) -> None:
    """Each image is within noise of its own frame's noiseless image, not of the previous."""
    previous: np.ndarray | None = np.full((H, W), 255, np.uint8)  # the rig's white at open
    for i, (img, frame) in enumerate(zip(images, frames, strict=True)):
        shown = render_frame(frame, W, H, 1.0, 8).astype(np.uint8)
        err = np.abs(img - camera.expected(shown))
        assert err.max() < 6 * camera.noise + 1, f"image {i} is not frame {i}"
        stale_err = np.abs(img - camera.expected(previous))
        assert stale_err.max() > 6 * camera.noise + 1, f"image {i}: frames too alike to test"
        previous = shown


def test_the_rig_follows_the_rig_protocol() -> None:
    rig, _ = make_rig()
    assert isinstance(rig, Rig)
    with rig:
        assert rig.image_shape == (H // 2, W // 2)
        assert rig.camera_bit_depth == 8
        assert (rig.projector.width, rig.projector.height) == (W, H)
        assert 0.7 < rig.noise_var < 1.4  # the fake's sigma is 1 (plus rounding)


def test_the_fake_returns_stale_images_without_verification() -> None:
    # The broken variant the other tests reject: no verification accepts the stale images.
    frames = fringe_frames()
    rig, camera = make_rig(latency=2, verify=False)
    with rig:
        images = rig.capture(frames)
    with pytest.raises(AssertionError, match="is not frame 0"):
        assert_fresh(images, frames, camera)


@pytest.mark.parametrize("latency", [1, 3])
def test_no_stale_image_is_accepted_at_a_fixed_latency(latency: int) -> None:
    frames = fringe_frames()
    rig, camera = make_rig(latency=latency, max_grabs=latency + 1)
    with rig:
        images = rig.capture(frames)
    assert_fresh(images, frames, camera)
    assert [t.rejected for t in rig.log] == [latency] * len(frames)
    assert all(t.change is not None and t.change > 4 for t in rig.log)


def test_no_stale_image_is_accepted_when_the_latency_changes_mid_run() -> None:
    rng = np.random.default_rng(2)
    latencies = iter(rng.integers(0, 4, 100).tolist())
    frames = [*fringe_frames(), UniformFrame(255.0), UniformFrame(100.0)]
    rig, camera = make_rig(latency=latencies, max_grabs=5)
    with rig:
        images = rig.capture(frames)
    assert_fresh(images, frames, camera)
    assert len({t.rejected for t in rig.log}) > 2  # the latency really varied


def test_discarded_images_are_not_retried() -> None:
    frames = fringe_frames()
    rig, camera = make_rig(latency=2, discard=2, max_grabs=1)
    with rig:
        images = rig.capture(frames)
    assert_fresh(images, frames, camera)
    assert {(t.discarded, t.rejected) for t in rig.log} == {(2, 0)}


def test_too_many_stale_grabs_give_one_line_error() -> None:
    rig, camera = make_rig(latency=3, max_grabs=3)
    with rig, pytest.raises(SyncError) as err:
        rig.capture(fringe_frames())
    msg = str(err.value)
    assert "\n" not in msg
    assert "projector frame 5" in msg and "3 grabs" in msg and "rig check" in msg
    # open: discard + max_grabs + 2 for mid-gray, white, and the view check's black and white;
    # 3 for the frame
    assert camera.grabs == 4 * (0 + 3 + 2) + 3


def test_a_stale_image_from_a_camera_queue_two_frames_old_is_rejected() -> None:
    # A queue that returns the image of the frame before the previous one: it differs from
    # the previous frame's image, so only the comparison with the older one catches it.
    projector = FakeProjector()
    camera = FakeCamera(projector, 0, 1.0)
    older: list[np.ndarray | None] = []

    def queue(previous: np.ndarray | None, current: np.ndarray) -> None:
        older.append(previous)
        # from the second frame after the rig's mid-gray, white, black and white on
        if len(older) >= 6:
            camera.stale, camera.pending = older[-2], 1

    projector.listeners = [queue]
    frames = [UniformFrame(60.0), UniformFrame(120.0), UniformFrame(180.0), UniformFrame(240.0)]
    rig = HardwareRig(projector, camera, SyncSettings(settle_s=0.0), sleep=lambda s: None)
    with rig:
        images = rig.capture(frames)
    assert_fresh(images, frames, camera)
    assert [t.rejected for t in rig.log] == [0, 1, 1, 1]


def test_an_unchanged_frame_needs_no_change() -> None:
    frame = UniformFrame(128.0)
    rig, camera = make_rig(latency=1, max_grabs=2)
    with rig:
        images = rig.capture([frame, frame, frame])
    assert [t.rejected for t in rig.log] == [1, 0, 0]
    shown = render_frame(frame, W, H, 1.0, 8).astype(np.uint8)
    assert np.abs(images - camera.expected(shown)).max() < 7


def test_hardware_trigger_mode_grabs_once_and_fails_at_once() -> None:
    frames = fringe_frames()[:4]
    rig, camera = make_rig(latency=0, mode="hardware")
    with rig:
        assert camera.trigger_mode == "hardware"
        images = rig.capture(frames)
    assert_fresh(images, frames, camera)
    rig, camera = make_rig(latency=1, mode="hardware")
    with rig, pytest.raises(SyncError, match="hardware-triggered"):
        rig.capture(frames)


def test_a_new_exposure_takes_a_new_reference() -> None:
    # At a new exposure the stale image differs from the old reference by the exposure change
    # alone; the rig takes a new reference image first, so the stale one is still rejected.
    frames = fringe_frames()[:4]
    rig, camera = make_rig(latency=1, max_grabs=2)
    with rig:
        rig.capture(frames, CameraSettings(exposure_ms=10.0))
        camera.pending = 0
        images = rig.capture(frames, CameraSettings(exposure_ms=6.0))
    assert camera.gain == 0.6
    previous = render_frame(frames[-1], W, H, 1.0, 8).astype(np.uint8)
    first = render_frame(frames[0], W, H, 1.0, 8).astype(np.uint8)
    assert np.abs(images[0] - camera.expected(first)).max() < 7
    assert np.abs(images[0] - camera.expected(previous)).max() > 7


def test_after_the_scene_moves_a_new_reference_keeps_stale_images_out() -> None:
    # The scene changes between two runs (a board moved): the first grab after the next frame
    # is stale (the last frame, seen on the moved scene). It differs from the images of the
    # earlier frames by the move alone, so only a new reference image of the moved scene lets
    # the rig reject it.
    frames = fringe_frames()[:4]
    for rebaseline, accepted_stale in ((False, True), (True, False)):
        rig, camera = make_rig(latency=1, max_grabs=3)
        with rig:
            rig.capture(frames)
            camera.reflect = camera.reflect[:, ::-1]  # the scene moved
            if rebaseline:
                rig.rebaseline()
            images = rig.capture(frames[:1])
        last = render_frame(frames[-1], W, H, 1.0, 8).astype(np.uint8)
        stale = np.abs(images[0] - camera.expected(last)).max() < 6 * camera.noise + 1
        assert stale == accepted_stale
        assert rig.log[-1].rejected == (1 if rebaseline else 0)
    rig, _ = make_rig()
    with pytest.raises(InputError, match="not open"):
        rig.rebaseline()


def test_the_recorder_keeps_each_calls_gamma_pre_compensation() -> None:
    from hdrfringe.hardware.rig import Recorder

    frames = fringe_frames()[:4]
    rig, _ = make_rig()
    rig.gamma_hat = 2.0
    recorder = Recorder(rig)
    with rig:
        recorder.capture([UniformFrame(100.0)])
        rig.gamma_hat = 0.75
        recorder.capture(frames)
    caps = recorder.captures()
    assert caps.projector is not None and caps.projector.gamma_precompensation == 2.0
    assert caps.gamma_precompensation == (None, 0.75, 0.75, 0.75, 0.75)
    # the frames were really sent with 0.75 (the last image the projector was given)
    shown = rig.projector_device.image  # type: ignore[attr-defined]
    assert np.array_equal(shown, render_frame(frames[3], W, H, 0.75, 8))
    assert not np.array_equal(shown, render_frame(frames[3], W, H, 2.0, 8))
    with pytest.raises(InputError, match="must be a positive number"):
        rig.gamma_hat = 0.0


class BlindingCamera(FakeCamera):
    """Saturates every pixel whatever is shown (a scene far too bright for the exposure)."""

    def expected(self, image: np.ndarray | None) -> np.ndarray:
        return np.full((H // 2, W // 2), 300.0)


def test_a_camera_saturated_everywhere_is_refused_when_verifying() -> None:
    # Nothing to measure the noise on: the rig says so at opening instead of verifying
    # against the rounding floor (under which every stale image passes).
    projector = FakeProjector()
    rig = HardwareRig(projector, BlindingCamera(projector), SyncSettings(settle_s=0.0))
    with pytest.raises(SyncError) as err:
        rig.open()
    msg = str(err.value)
    assert "\n" not in msg and "saturates every pixel (at 255)" in msg and "exposure" in msg
    with pytest.raises(InputError, match="not open"):  # closed again
        rig.capture([UniformFrame(100.0)])
    # without verification the noise is not needed: the rig opens
    projector = FakeProjector()
    sync = SyncSettings(settle_s=0.0, verify=False)
    with HardwareRig(projector, BlindingCamera(projector), sync) as rig:
        assert rig.capture([UniformFrame(100.0)]).max() == 255


def test_change_ratio_is_about_one_for_noise_alone() -> None:
    rng = np.random.default_rng(0)
    a = np.clip(100 + rng.normal(0, 2, 10000), 0, 255)
    b = np.clip(100 + rng.normal(0, 2, 10000), 0, 255)
    assert 0.9 < change_ratio(a, b, 4.0, 8) < 1.1
    assert change_ratio(a + 20, b, 4.0, 8) > 40


# --- the loop rig: projector window on Xvfb, loop camera (issue 13's loop test) -------------
# The screen is the virtual rig's projector size (1024x768) and the loop camera the virtual
# rig's camera at a quarter of its resolution each way (same field of view, 162x123 instead of
# 648x494: a grab costs about a tenth), so the reference is the virtual rig of the same scene,
# options and resolution, measured in-process exactly as `measure --rig sim` does. One pitch of
# 1024 px (a single period over the projector: absolute without unwrapping) keeps the run short.

LOOP_W, LOOP_H = 1024, 768
LOOP_SIZE = (162, 123)
LOOP_CAMERA = f"size={LOOP_SIZE[0]}x{LOOP_SIZE[1]}"
LIVE = ["--pitch", "1024"]
STRATEGY = {"lpa": ["--step", "50"], "dpa": ["--bound-pending"]}
PARAMS: dict[str, dict[str, object]] = {"lpa": {"step": 50.0}, "dpa": {"bound_pending": True}}


@pytest.fixture(scope="module")
def xdisplay() -> Iterator[str]:
    """A private Xvfb server at the virtual rig's projector size, killed at the end."""
    with xvfb_display(LOOP_W, LOOP_H) as display:
        yield display


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    import sys

    return subprocess.run(
        [sys.executable, "-m", "hdrfringe.cli", *args], capture_output=True, text=True, timeout=600
    )


def phase_difference(pa: np.ndarray, pb: np.ndarray) -> tuple[float, float]:
    """Median and 99th percentile of |absolute phase a - b| over pixels valid in both."""
    ok = np.isfinite(pa) & np.isfinite(pb)
    assert ok.mean() > 0.3  # the dark squares of the checkerboard are invalid
    d = np.abs(pa - pb)[ok]
    return float(np.median(d)), float(np.percentile(d, 99))


def sim_phase(method: str, seed: int) -> np.ndarray:
    """`measure --rig sim --scene checkerboard --seed S --strategy M` (in-process, at the loop
    camera's resolution): the absolute phase of the live virtual rig."""
    from hdrfringe import pipeline
    from hdrfringe.rig.factory import virtual_rig
    from hdrfringe.strategies import make_params
    from hdrfringe.tasks.capture import LiveFringes

    sim = virtual_rig("checkerboard", seed=seed, resolution=LOOP_SIZE)
    specs, line = LiveFringes("sinusoidal", 4, [1024], 40.0, 255.0, True).build(sim.projector)
    params = make_params(method, **PARAMS[method])
    result = pipeline.measure(
        sim, None, strategy=method, params=params, specs=specs, centerline=line
    )
    assert result.decoded.primary is not None
    return np.asarray(result.decoded.primary.absolute_phase)


@pytest.mark.parametrize("method", ["lpa", "dpa"])
def test_live_capture_on_the_loop_rig_measures_as_the_virtual_rig(
    method: str, xdisplay: str, tmp_path: Path
) -> None:
    from hdrfringe.io.results import read_map_tiff

    caps = tmp_path / "caps"
    camera = f"loop:checkerboard?display={xdisplay}&latency=2&{LOOP_CAMERA}"
    options = [*LIVE, *STRATEGY[method], "--settle", "0", "-o", str(caps)]
    r = cli("capture", "--projector", f"screen:0@{xdisplay}", "--camera", camera,
            "--strategy", method, *options)  # fmt: skip
    assert r.returncode == 0, r.stderr
    log = json.loads((caps / "capture_log.json").read_text())
    assert log["complete"] is True
    # every frame differs from the one before: latency 2 means exactly 2 stale grabs rejected
    assert [f["rejected"] for f in log["frames"]] == [2] * len(log["frames"])
    manifest = json.loads((caps / "manifest.json").read_text())
    assert manifest["capture"]["complete"] is True
    assert len(manifest["frames"]) == len(log["frames"])

    out = tmp_path / "measured"  # the folder measured in this process (no window: run_cli)
    r = run_cli("measure", str(caps), "--strategy", method, *STRATEGY[method], "--no-previews",
                "-o", str(out))  # fmt: skip
    assert r.returncode == 0, r.stderr
    measured = read_map_tiff(out / "absolute_phase_vertical.tiff")
    sim, other_seed = sim_phase(method, 0), sim_phase(method, 1)
    assert measured.shape == sim.shape == LOOP_SIZE[::-1]
    noise_median, noise_p99 = phase_difference(sim, other_seed)
    median, p99 = phase_difference(measured, sim)
    # within noise: no worse than two virtual-rig runs with different noise seeds (x2)
    assert median <= 2 * noise_median + 1e-3, (median, noise_median)
    assert p99 <= 2 * noise_p99 + 1e-3, (p99, noise_p99)


@pytest.mark.parametrize("budget", [None, 20])
def test_adaptive_projection_runs_live_on_the_loop_rig(
    budget: int | None, xdisplay: str, tmp_path: Path
) -> None:
    """Issue 14: `--strategy adaptive` on the loop rig (per-pixel frames through a real window and
    the X display) measures as the virtual rig's own adaptive run of the same scene and
    resolution: same images captured, full coverage, absolute phase within noise (two virtual
    runs with different seeds set the noise). Rejects a per-pixel frame shown wrongly (scaled,
    shifted or at a uniform MIGL: the phase or the clipping would differ) or a stale frame
    accepted (the mapping, and so the map, would be wrong). ``measure`` of the recorded folder
    replays to the live maps exactly (rejects a replay on the folder's every set: the mapping
    ladders at a low MIGL are refused or measured instead).

    Issue 26: with ``--max-images 20`` (the least this run allows: no calibration, so both
    orientations are mapped) the budget's one-shift probe is recorded as the projector images
    it showed (no incomplete set in the folder). Rejects a record with an incomplete set
    (refused when written: the command fails), the probe left out or the completed shift
    recorded in its place (the replay would stop at the missing frame or decode other
    images)."""
    from hdrfringe import pipeline
    from hdrfringe.io.results import read_map_tiff
    from hdrfringe.rig.factory import virtual_rig
    from hdrfringe.strategies import make_params
    from hdrfringe.tasks.capture import LiveFringes

    out = tmp_path / "out"
    camera = f"loop:checkerboard?display={xdisplay}&latency=1&{LOOP_CAMERA}"
    # the budget plans its exposure relative to the rig's: the virtual rig's 10 ms given
    limit = ["--max-images", str(budget), "--exposure-ms", "10"] if budget else []
    r = cli("measure", "--rig", "hardware", "--projector", f"screen:0@{xdisplay}", "--camera",
            camera, "--settle", "0", "--strategy", "adaptive", "--pitch", "1024,64,16", *limit,
            "-o", str(out))  # fmt: skip
    assert r.returncode == 0, r.stderr
    metrics = json.loads((out / "metrics.json").read_text())
    log = json.loads((out / "captures" / "capture_log.json").read_text())
    assert [f["rejected"] for f in log["frames"]] == [1] * len(log["frames"])
    measured = read_map_tiff(out / "absolute_phase_vertical.tiff")

    def sim(seed: int) -> tuple[np.ndarray, int]:
        rig = virtual_rig("checkerboard", seed=seed, resolution=LOOP_SIZE)
        specs, line = LiveFringes("sinusoidal", 4, [1024, 64, 16], 40.0, 255.0, True).build(
            rig.projector
        )
        params = make_params("adaptive", **({"max_images": budget} if budget else {}))
        res = pipeline.measure(rig, None, strategy="adaptive", params=params, specs=specs,
                               centerline=line)  # fmt: skip
        assert res.decoded.primary is not None and res.metrics.strategy is not None
        return np.asarray(res.decoded.primary.absolute_phase), res.metrics.strategy.images_captured

    (ref, images), (other, _) = sim(0), sim(1)
    assert metrics["images_captured"] == images
    if budget:
        assert images == budget
        # the exposure chosen from the mapping: the replay needs the rig's recorded 10 ms
        assert metrics["adaptive"]["vertical"]["budget"]["exposure_ms"] not in (None, 10.0)
        manifest = json.loads((out / "captures" / "manifest.json").read_text())
        lone = [f for f in manifest["frames"] if f["kind"] == "image"]
        # the probe: shift 0 at the full MIGL, shifts 1..3 at the low mapping MIGL
        assert [f["name"][-1] for f in lone] == ["0", "1", "2", "3"], lone
        assert len(manifest["frames"]) == len(log["frames"]) == images + 1  # + the centerline
    # the folder replays to the live maps: the strategy on the sets the run measured (the
    # record's fringes), not on every set the folder holds (the mapping ladders at a low MIGL)
    replay = tmp_path / "replay"
    r = run_cli("measure", str(out / "captures"), "--no-previews", "-o", str(replay))
    assert r.returncode == 0, r.stderr
    assert "captured with --strategy adaptive (capture_log.json), replayed" in r.stdout
    maps = sorted(p.name for p in out.glob("*.tiff"))
    assert "absolute_phase_vertical.tiff" in maps
    for name in maps:
        np.testing.assert_array_equal(
            read_map_tiff(replay / name), read_map_tiff(out / name), err_msg=name
        )
    assert np.isfinite(measured).mean() == np.isfinite(ref).mean() == 1.0
    noise_median, noise_p99 = phase_difference(ref, other)
    median, p99 = phase_difference(measured, ref)
    assert median <= 1.5 * noise_median + 1e-3, (median, noise_median)
    assert p99 <= 1.5 * noise_p99 + 1e-3, (p99, noise_p99)


def test_no_stale_frame_is_accepted_when_the_loop_latency_changes_mid_run(xdisplay: str) -> None:
    from hdrfringe import pipeline
    from hdrfringe.hardware.loop_camera import LoopCamera
    from hdrfringe.hardware.projector import ScreenProjector
    from hdrfringe.rig.base import RigBase

    camera = LoopCamera(f"loop:checkerboard?display={xdisplay}&latency=1&{LOOP_CAMERA}")
    rig = HardwareRig(ScreenProjector(0, xdisplay), camera, SyncSettings(settle_s=0.0))
    latencies = iter([3, 0, 2, 1, 3, 0, 2, 1, 3, 0])
    in_force: list[int] = []

    class Changing(RigBase):  # a new latency before every set
        camera_bit_depth = property(lambda self: rig.camera_bit_depth)
        image_shape = property(lambda self: rig.image_shape)
        projector = property(lambda self: rig.projector)

        def capture(self, frames, settings=None):  # type: ignore[no-untyped-def]
            camera.set_latency(next(latencies))
            in_force.extend([camera.latency] * len(frames))
            return rig.capture(frames, settings)

    with rig:
        spec = FringeSpec("sinusoidal", 4, 1024.0, imin=40.0, migl=255.0)
        pipeline.composite_captures(Changing(), [spec], "lpa", {"step": 50.0})
    assert len(set(in_force)) >= 3  # the latency really changed between sets
    # fewer rejections than the latency would be a stale image accepted
    assert [t.rejected for t in rig.log] == in_force


def test_rig_check_on_the_loop_rig_reports_its_latency(xdisplay: str, tmp_path: Path) -> None:
    camera = f"loop:checkerboard?display={xdisplay}&latency=3&{LOOP_CAMERA}"
    report = tmp_path / "check.json"
    r = cli("rig", "check", "--projector", f"screen:0@{xdisplay}", "--camera", camera,
            "--changes", "3", "--max-latency", "5", "-o", str(report))  # fmt: skip
    assert r.returncode == 0, r.stderr
    got = json.loads(report.read_text())
    assert json.loads(r.stdout) == got
    assert abs(got["latency"] - 3) <= 1
    assert got["recommended"]["discard"] == got["latency"]
    assert got["clips"] == (got["white_saturated_fraction"] > 0)
    assert 0.5 < got["noise_std"] < 5  # the loop camera's read noise is 1 gray level, plus shot


def test_white_saturating_every_pixel_does_not_let_stale_images_through(xdisplay: str) -> None:
    # Issue 13's reproduction: white_plate under 600 lx at the default exposure saturates every
    # pixel of white. The noise measured on white alone fell to the rounding floor (1/12 DN^2),
    # under which a stale image (a new exposure of the previous frame) differs "enough": 0
    # rejections where the latency of 1 must reject one per frame. The rig also measures the
    # noise on mid-gray now.
    from hdrfringe.hardware.loop_camera import LoopCamera
    from hdrfringe.hardware.projector import ScreenProjector

    camera = LoopCamera(f"loop:white_plate?display={xdisplay}&latency=1&ambient=600&size=32x24")
    rig = HardwareRig(ScreenProjector(0, xdisplay), camera, SyncSettings(settle_s=0.0))
    frames = FringeSpec("sinusoidal", 4, 128.0, imin=40.0, migl=255.0).frames()
    with rig:
        assert (camera.grab() == 255).all()  # white, still on screen: saturated everywhere
        images = rig.capture(frames)
    assert (images < 255).any()  # the fringes leave pixels to compare
    assert [t.rejected for t in rig.log] == [1] * len(frames)
    assert rig.noise_var > 1.0  # read noise sigma 1 DN plus shot noise, not the 1/12 floor


#: Grabs when a rig with the default SyncSettings opens: discard + max_grabs + 2 images of
#: mid-gray, then as many of white (the noise estimate), then of black and white again (the
#: view check; the last white is the first reference image).
OPEN_GRABS = 4 * (0 + 5 + 2)


class InterruptingCamera(FakeCamera):
    """Ctrl-C on grab number ``at`` (as a KeyboardInterrupt arrives mid-grab)."""

    def __init__(self, projector: FakeProjector, at: int) -> None:
        super().__init__(projector, 0, 1.0)
        self.at = at
        self.gain = 2.0  # white saturates: LPA walks down over several sets

    def _grab(self, timeout_s: float) -> np.ndarray:
        if self.grabs + 1 == self.at:
            raise KeyboardInterrupt
        return super()._grab(timeout_s)


def run_capture(
    monkeypatch: pytest.MonkeyPatch, out: Path, at: int
) -> subprocess.CompletedProcess[str]:
    """`capture --strategy lpa` in-process on the fake rig, interrupted at grab ``at``."""
    from typer.testing import CliRunner

    from hdrfringe.cli import app
    from hdrfringe.tasks import capture

    def fake_rig(*args: object) -> HardwareRig:
        projector = FakeProjector()
        sync = SyncSettings(settle_s=0.0)
        return HardwareRig(projector, InterruptingCamera(projector, at), sync, sleep=lambda s: 0)

    monkeypatch.setattr(capture, "hardware_options", fake_rig)
    args = ["capture", "--projector", "screen:0", "--camera", "fake:0", "--strategy", "lpa"]
    args += ["--pitch", "64", "--step", "100", "-o", str(out)]
    r = CliRunner().invoke(app, args)
    return subprocess.CompletedProcess(args, r.exit_code, r.stdout, r.stderr)


def test_ctrl_c_mid_capture_keeps_complete_sets_and_says_so(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from hdrfringe.io.captures import read_capture_folder

    full = run_capture(monkeypatch, tmp_path / "full", at=10**6)
    assert full.returncode == 0, full.stderr
    n_full = len(read_capture_folder(tmp_path / "full").frames)
    assert n_full > 8
    # open takes 4 x (0 + 5 + 2) grabs; then one grab per frame: interrupt in the second set
    r = run_capture(monkeypatch, tmp_path / "cut", at=OPEN_GRABS + 4 + 2)
    assert r.returncode == 2
    assert "interrupted (Ctrl-C) after 1 complete sets" in " ".join(r.stderr.split())
    caps = read_capture_folder(tmp_path / "cut")
    assert len(caps.frames) == 4 < n_full and len(caps.sets) == 1
    manifest = json.loads((tmp_path / "cut" / "manifest.json").read_text())
    assert manifest["capture"]["complete"] is False
    # before the first complete set: nothing written, the shell's 130
    r = run_capture(monkeypatch, tmp_path / "none", at=OPEN_GRABS + 2)
    assert r.returncode == 130 and not (tmp_path / "none").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--camera", "fake:0"], "give both --projector SPEC and --camera SPEC"),
        (["--projector", "hdmi:1", "--camera", "pylon:emu"], "projector 'hdmi:1': unknown back"),
        (["--projector", "folder:x@12", "--camera", "pylon:emu"], "size '12' is not WIDTHxHEIGHT"),
        (["--projector", "screen:0", "--camera", "usb3:1"], "unknown back end 'usb3'"),
        (["--projector", "screen:0", "--camera", "pylon:emu", "--sync", "radio"], "sync mode"),
        (["--projector", "screen:0", "--camera", "pylon:emu", "--max-grabs", "0"], "max_grabs"),
    ],
)
def test_capture_refuses_bad_input_in_one_line(
    args: list[str], message: str, tmp_path: Path
) -> None:
    from typer.testing import CliRunner

    from hdrfringe.cli import app

    r = CliRunner().invoke(app, ["capture", *args, "-o", str(tmp_path / "out")])
    assert r.exit_code == 2
    assert message in " ".join(r.stderr.split()) and r.stderr.count("error:") == 1
    assert not (tmp_path / "out").exists()
