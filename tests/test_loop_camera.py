"""The loop camera (issue 13): a projector window on Xvfb, grabbed and seen through the virtual rig.

References are computed here with an independent :func:`~hdrfringe.rig.factory.virtual_rig`
(never the camera's own rig): the virtual rig capturing the projected frame itself, and the
same rig capturing the 8-bit image the projector was sent. Xvfb runs at 640x480 (a small
projector keeps the file fast); the window's pixel exactness at 1920x1080 is
tests/test_projector_window.py's job.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import CameraSettings
from hdrfringe.core.frames import FringeFrame, ImageFrame, PixelwiseFringeFrame, UniformFrame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.hardware.backends import open_camera
from hdrfringe.hardware.camera import Camera, PixelFormatError
from hdrfringe.hardware.loop_camera import LoopCamera
from hdrfringe.hardware.projector import ScreenProjector, render_for_projector
from hdrfringe.rig.factory import virtual_rig
from hdrfringe.rig.simulated import SimulatedRig
from tests.conftest import xvfb_display

WIDTH, HEIGHT = 640, 480
CAMERA = (160, 120)
GAMMA = 2.2

# The Xvfb tests share one group: one worker runs them (make test: --dist loadgroup).
pytestmark = pytest.mark.xdist_group("xvfb")


@pytest.fixture(scope="module")
def xdisplay() -> Iterator[str]:
    """A private Xvfb server (a free display number chosen by Xvfb itself), killed at the end."""
    with xvfb_display(WIDTH, HEIGHT) as display:
        yield display


def reference_rig(gamma: float = GAMMA, bit_depth: int = 8) -> SimulatedRig:
    """The noise-free virtual rig the loop camera should reproduce, built independently."""
    rig = virtual_rig(
        "checkerboard",
        noise=0.0,
        shot_noise=False,
        gamma=gamma,
        bit_depth=bit_depth,
        resolution=CAMERA,
    )
    proj = dataclasses.replace(rig.projector_model, width=WIDTH, height=HEIGHT)
    return rig.replace(projector_model=proj)


def sent(frame: object) -> np.ndarray:
    return render_for_projector(frame, WIDTH, HEIGHT, gamma_hat=GAMMA)  # type: ignore[arg-type]


def seen(image: np.ndarray, settings: CameraSettings | None = None, bits: int = 8) -> np.ndarray:
    """What the noise-free camera records of a projector image (levels already sent)."""
    rig = reference_rig(gamma=1.0, bit_depth=bits)
    return rig.capture([ImageFrame(image.astype(np.float64), "sent")], settings)[0]


def loop_spec(display: str, extra: str = "") -> str:
    return f"loop:checkerboard?display={display}&noise=0&shot=off&size=160x120{extra}"


FRINGE = FringeFrame(FringeSpec(steps=4, pitch_px=17.3, imin=10.0, migl=250.0), 1)


def test_a_grab_is_the_virtual_rigs_capture_of_the_projected_frame(xdisplay: str) -> None:
    rng = np.random.default_rng(5)
    spec = FringeSpec(steps=3, pitch_px=9.0, imin=5.0, migl=200.0, orientation="horizontal")
    pixelwise = PixelwiseFringeFrame(spec, 2, rng.uniform(60.0, 200.0, (HEIGHT, WIDTH)))
    ref = reference_rig()
    with ScreenProjector(display=xdisplay) as projector, open_camera(loop_spec(xdisplay)) as cam:
        assert isinstance(cam, Camera) and isinstance(cam, LoopCamera)
        assert cam.projector_size == projector.size == (WIDTH, HEIGHT)
        for frame in (FRINGE, pixelwise):
            projector.show(sent(frame))
            grab = cam.grab()
            assert grab.dtype == np.uint8 and grab.shape == CAMERA[::-1]
            # exact: the rig's capture of the image the projector was sent (a flipped, shifted
            # or cropped grab, a second gamma pre-compensation or another scene all differ)
            np.testing.assert_array_equal(grab, seen(sent(frame)))
            # the rig's capture of the frame itself: a line frame's renderer samples a fine
            # 1-D grid, an image frame's exact box*Gaussian taps; the signals differ by < 0.05
            # DN, so rounding moves a few pixels by 1 DN
            expected = ref.capture([frame])[0].astype(int)
            assert np.abs(grab.astype(int) - expected).max() <= 1
            assert np.mean(grab != expected) < 0.01
            assert len(np.unique(grab)) > 30 and grab.max() == 255  # pattern, clipped whites


def test_latency_returns_the_previous_screen_for_exactly_k_grabs(xdisplay: str) -> None:
    levels = (40.0, 80.0, 120.0, 160.0, 200.0)
    frames = [UniformFrame(g) for g in levels[:2]] + [
        FringeFrame(FringeSpec(steps=3, pitch_px=13.0, imin=20.0, migl=180.0), k) for k in range(3)
    ]
    expected = [seen(sent(f)) for f in frames]
    assert all(not np.array_equal(a, b) for a, b in itertools.combinations(expected, 2))

    def which(image: np.ndarray) -> int:
        (index,) = [i for i, e in enumerate(expected) if np.array_equal(image, e)]
        return index

    with (
        ScreenProjector(display=xdisplay) as projector,
        open_camera(loop_spec(xdisplay, "&latency=2")) as cam,
    ):
        assert isinstance(cam, LoopCamera) and cam.latency == 2
        projector.show(sent(frames[0]))
        assert [which(cam.grab()) for _ in range(2)] == [0, 0]  # the first content: no wait
        projector.show(sent(frames[1]))
        assert [which(cam.grab()) for _ in range(4)] == [0, 0, 1, 1]
        cam.set_latency(1)  # changed mid-run
        projector.show(sent(frames[2]))
        assert [which(cam.grab()) for _ in range(3)] == [1, 2, 2]
        cam.set_latency(3)
        projector.show(sent(frames[3]))
        assert [which(cam.grab()) for _ in range(2)] == [2, 2]
        cam.set_latency(0)  # during a wait: the next grab follows the new value
        assert which(cam.grab()) == 3
        projector.show(sent(frames[4]))
        assert which(cam.grab()) == 4
        cam.set_latency(2)  # a change during the wait restarts it
        projector.show(sent(frames[0]))
        assert which(cam.grab()) == 4
        projector.show(sent(frames[1]))
        assert [which(cam.grab()) for _ in range(4)] == [4, 4, 1, 1]
        with pytest.raises(InputError, match="latency must be a whole number of grabs >= 0"):
            cam.set_latency(-1)


def test_exposure_gain_and_pixel_format_act_as_on_the_virtual_rig(xdisplay: str) -> None:
    dim = UniformFrame(25.0)
    ref12 = reference_rig(bit_depth=12)
    t_ref = ref12.camera.exposure_ms
    with ScreenProjector(display=xdisplay) as projector, open_camera(loop_spec(xdisplay)) as cam:
        projector.show(sent(dim))
        cam.set_pixel_format("Mono12")
        base = cam.grab().astype(float)
        assert cam.set_exposure(2 * t_ref) == 2 * t_ref
        double = cam.grab()
        assert double.dtype == np.uint16 and cam.bit_depth == 12
        np.testing.assert_array_equal(double, ref12.capture([dim], CameraSettings(2 * t_ref))[0])
        lit = base > 100  # well above the rounding step
        assert lit.mean() > 0.2 and double.max() < 4095  # no clipping at 2x
        np.testing.assert_allclose(double[lit] / base[lit], 2.0, atol=0.02)
        cam.set_exposure(t_ref)
        assert cam.set_gain(6.0) == 6.0
        np.testing.assert_array_equal(
            cam.grab(), ref12.capture([dim], CameraSettings(t_ref, 6.0))[0]
        )
        cam.set_pixel_format("Mono16")
        assert cam.grab().max() > 4095
        with pytest.raises(PixelFormatError, match="'Mono10' is not available; use one of Mono8"):
            cam.set_pixel_format("Mono10")


def test_screen_and_projector_size_mismatches_are_one_line_errors(xdisplay: str) -> None:
    with pytest.raises(InputError, match=r"is 640x480, not the projector=1920x1080") as err:
        open_camera(f"loop:plate?display={xdisplay}&projector=1920x1080").open()
    assert "\n" not in str(err.value)
    with pytest.raises(InputError, match=r"screen 2 does not exist .*\(it has 0: 640x480\+0\+0\)"):
        open_camera(f"loop:plate?display={xdisplay}&screen=2").open()
    unused = next(n for n in range(4000, 5000) if not Path(f"/tmp/.X11-unix/X{n}").exists())
    with pytest.raises(InputError, match=f"X display ':{unused}' not found"):
        open_camera(f"loop:plate?display=:{unused}").open()
    cam = open_camera(f"loop:plate?display={xdisplay}")
    with pytest.raises(Exception, match="not open"):
        cam.grab()


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("loop:", "no scene given"),
        ("loop:teapot", "unknown scene 'teapot'; use one of white_plate"),
        ("loop:plate?lag=2", "unknown option 'lag'; use display, screen, latency"),
        ("loop:plate?latency", "option 'latency' is not key=value"),
        ("loop:plate?latency=2&&seed=1", "option '' is not key=value"),
        ("loop:plate?latency=-1", "latency='-1' is not valid; latency must be a whole number"),
        ("loop:plate?latency=1.5", "latency='1.5' is not valid"),
        ("loop:plate?latency=1&latency=2", "option 'latency' is given twice"),
        ("loop:plate?noise=abc", "noise='abc' is not valid; noise must be a number >= 0"),
        ("loop:plate?noise=nan", "noise='nan' is not valid"),
        ("loop:plate?shot=yes", "shot='yes' is not valid; shot must be on or off"),
        ("loop:plate?aperture=wide", "aperture must be auto or white or black"),
        ("loop:plate?size=160", "size must be WIDTHxHEIGHT"),
        ("loop:plate?projector=0x480", "projector='0x480' is not valid"),
        ("loop:plate?pose=1", "pose= is for the scene board only"),
        ("loop:board?pose=100", "pose=100 is not valid; pose must be 0..99"),
        ("loop:board?pose=1&depth=5", "depth= does not apply with pose="),
    ],
)
def test_bad_specifications_are_one_line_input_errors(spec: str, message: str) -> None:
    with pytest.raises(InputError) as err:
        open_camera(spec)
    assert message in str(err.value)
    assert "\n" not in str(err.value) and str(err.value).startswith(f"camera {spec!r}")


def test_the_board_pose_moves_the_board_seen() -> None:
    from hdrfringe.rig.board_poses import calibration_rig, default_board_poses

    cam = LoopCamera("loop:board?pose=0&projector=800x600&size=64x48")
    assert cam.pose == 0 and cam.rig.scene == default_board_poses(1)[0]
    cam.set_pose(3)
    board = default_board_poses(4)[3]
    assert cam.pose == 3 and cam.rig.scene == board
    # the stereo-calibration rig of that pose, with no pre-compensation (the screen has it)
    truth = calibration_rig(board, camera_size=(64, 48), projector_size=(800, 600))
    assert cam.rig.geometry == truth.geometry and cam.rig.gamma_precompensation == 1.0
    with pytest.raises(InputError, match="set_pose needs a board camera"):
        LoopCamera("loop:plate").set_pose(1)
    with pytest.raises(InputError, match="pose must be a whole number"):
        cam.set_pose(1.5)  # type: ignore[arg-type]
