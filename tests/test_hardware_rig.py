"""HardwareRig's synchronisation (issue 13) on a fake projector and camera with a latency.

The fake camera sees the fake projector's image through a fixed scene (offset, reflectivity,
Gaussian noise, clipping) and, after each change of the projected image, returns ``latency``
stale images (of the previous image) before fresh ones: the behaviour of a camera that had
already exposed or buffered frames when the pattern changed. Each test knows the noiseless
image of every projected frame, so "no stale frame accepted" is checked against a reference
the rig did not produce.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np
import pytest

from hdrfringe.captures import CameraSettings
from hdrfringe.frames import Frame, UniformFrame, render_frame
from hdrfringe.hardware.camera import CameraBase
from hdrfringe.hardware.projector import _ProjectorBase
from hdrfringe.hardware.rig import HardwareRig, SyncError, SyncSettings, change_ratio
from hdrfringe.patterns import FringeSpec
from hdrfringe.rig.base import Rig

W, H = 64, 48


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
    assert "projector frame 2" in msg and "3 grabs" in msg and "rig check" in msg
    assert camera.grabs == (0 + 3 + 2) + 3  # open: discard + max_grabs + 2; 3 for the frame


def test_a_stale_image_from_a_camera_queue_two_frames_old_is_rejected() -> None:
    # A queue that returns the image of the frame before the previous one: it differs from
    # the previous frame's image, so only the comparison with the older one catches it.
    projector = FakeProjector()
    camera = FakeCamera(projector, 0, 1.0)
    older: list[np.ndarray | None] = []

    def queue(previous: np.ndarray | None, current: np.ndarray) -> None:
        older.append(previous)
        if len(older) >= 3:  # from the second frame after the rig's white on
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


def test_change_ratio_is_about_one_for_noise_alone() -> None:
    rng = np.random.default_rng(0)
    a = np.clip(100 + rng.normal(0, 2, 10000), 0, 255)
    b = np.clip(100 + rng.normal(0, 2, 10000), 0, 255)
    assert 0.9 < change_ratio(a, b, 4.0, 8) < 1.1
    assert change_ratio(a + 20, b, 4.0, 8) > 40
