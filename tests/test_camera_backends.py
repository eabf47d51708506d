"""Camera back ends through the camera protocol (issue 13), on the emulated devices that ship
with the hardware packages: Basler's camera emulation in pypylon, the GenTL producer in the
``genicam`` package (through harvesters), and a video file through OpenCV's VideoCapture.

Nothing here is skipped: the ``hardware`` extra is part of ``dev``. What each test proves and
what stays untested for lack of a device is listed in docs/hardware.md.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from hdrfringe.core.captures import CameraSettings
from hdrfringe.errors import HdrFringeError, InputError
from hdrfringe.hardware.backends import open_camera
from hdrfringe.hardware.camera import (
    MONO_FORMATS,
    Camera,
    CameraError,
    CameraNotFoundError,
    GrabTimeoutError,
    MissingPackageError,
    PixelFormatError,
)
from hdrfringe.hardware.genicam import GenICamCamera, bundled_producer
from hdrfringe.hardware.opencv_camera import OpenCVCamera
from hdrfringe.hardware.pylon import PylonCamera


@pytest.fixture
def emulated(monkeypatch: pytest.MonkeyPatch):
    """pylon's emulated camera, whatever PYLON_CAMEMU the developer has set (0, 3, unset)."""
    monkeypatch.delenv("PYLON_CAMEMU", raising=False)
    with open_camera("pylon:emu") as cam:
        yield cam


# -- Basler emulation -------------------------------------------------------------------------


def test_pylon_emulation_follows_the_protocol(emulated: PylonCamera) -> None:
    assert isinstance(emulated, Camera)
    assert emulated.trigger_mode == "software"
    # the device really is pylon's emulation, not a connected camera
    assert emulated._cam.GetDeviceInfo().GetDeviceClass() == "BaslerCamEmu"
    assert emulated.pixel_formats == ("Mono8", "Mono10", "Mono12", "Mono16")
    assert emulated.set_exposure(2.5) == pytest.approx(2.5)
    # read back from the device's own node, in its unit (microseconds)
    assert emulated._cam.ExposureTime.GetValue() == pytest.approx(2500.0)
    assert emulated.set_gain(6.0) == pytest.approx(6.0, abs=0.05)
    applied = emulated.apply(CameraSettings(exposure_ms=4.0))
    assert applied.exposure_ms == pytest.approx(4.0) and applied.gain_db is None


@pytest.mark.parametrize("fmt", ["Mono8", "Mono10", "Mono12", "Mono16"])
def test_pylon_pixel_formats_give_the_bit_depths_values(emulated: PylonCamera, fmt: str) -> None:
    emulated.set_pixel_format(fmt)
    bits = MONO_FORMATS[fmt]
    assert emulated.pixel_format == fmt and emulated.bit_depth == bits
    image = emulated.grab(timeout_s=2.0)
    assert image.shape == (1040, 1024)
    assert image.dtype == (np.uint8 if bits == 8 else np.uint16)
    assert int(image.max()) <= 2**bits - 1
    # the emulator's test pattern spans the range: above 8 bits it has values > 255
    assert int(image.max()) >= 2 ** (bits - 1)


def test_pylon_mono12_is_not_mono8_scaled(emulated: PylonCamera) -> None:
    emulated.set_pixel_format("Mono8")
    low = emulated.grab(timeout_s=2.0).astype(np.int64)
    emulated.set_pixel_format("Mono12")
    high = emulated.grab(timeout_s=2.0).astype(np.int64)
    assert (high > 255).any()
    # the same pattern at 12 bit: its top 8 bits are the Mono8 image
    assert np.abs((high >> 4) - low).max() <= 1


def test_pylon_unsupported_pixel_format_is_one_line(emulated: PylonCamera) -> None:
    with pytest.raises(PixelFormatError) as err:
        emulated.set_pixel_format("Mono32")
    msg = str(err.value)
    assert "\n" not in msg and "'Mono32'" in msg
    assert "Mono8, Mono10, Mono12, Mono16" in msg
    assert isinstance(err.value, InputError)
    # a format the camera offers but hdrfringe does not read (colour)
    with pytest.raises(PixelFormatError, match="RGB8Packed"):
        emulated.set_pixel_format("RGB8Packed")
    assert emulated.pixel_format == "Mono8"


def test_pylon_software_trigger_and_hardware_trigger_timeout(emulated: PylonCamera) -> None:
    emulated.set_trigger_mode("hardware")
    assert emulated._cam.TriggerSource.GetValue() == "Line1"
    start = time.monotonic()
    with pytest.raises(GrabTimeoutError, match=r"no image within 0\.2 s; check the trigger"):
        emulated.grab(timeout_s=0.2)
    assert 0.15 < time.monotonic() - start < 2.0
    emulated.set_trigger_mode("software")
    assert emulated._cam.TriggerSource.GetValue() == "Software"
    assert emulated.grab(timeout_s=2.0).shape == (1040, 1024)
    with pytest.raises(CameraError, match="'free'"):
        emulated.set_trigger_mode("free")


def test_pylon_bad_exposure_and_closed_camera(emulated: PylonCamera) -> None:
    with pytest.raises(CameraError, match="outside the camera's range"):
        emulated.set_exposure(1e9)
    with pytest.raises(InputError):
        emulated.set_exposure(-1.0)
    with pytest.raises(InputError):
        emulated.grab(timeout_s=0.0)
    emulated.close()
    emulated.close()  # twice is harmless
    with pytest.raises(CameraError, match="not open"):
        emulated.grab()


def test_pylon_serial_not_found_lists_cameras(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PYLON_CAMEMU", "1")
    with pytest.raises(CameraNotFoundError) as err:
        PylonCamera("no-such-serial").open()
    assert "\n" not in str(err.value)
    assert "pylon:no-such-serial: not found" in str(err.value)
    assert "0815-0000" in str(err.value)  # the emulated camera is listed


# -- optional packages ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("spec", "module"),
    [("pylon:emu", "pypylon"), ("genicam:x.cti", "harvesters"), ("opencv:0", "cv2")],
)
def test_missing_package_names_the_extra(
    monkeypatch: pytest.MonkeyPatch, spec: str, module: str
) -> None:
    for name in list(sys.modules):
        if name == module or name.startswith(module + "."):
            monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, module, None)  # import raises ImportError
    with pytest.raises(MissingPackageError) as err:
        open_camera(spec).open()
    msg = str(err.value)
    assert "\n" not in msg and module in msg
    assert msg.endswith("pip install hdrfringe[hardware]")
    assert isinstance(err.value, HdrFringeError)


# -- open_camera ------------------------------------------------------------------------------


def test_open_camera_parses_specifications(tmp_path: Path) -> None:
    assert isinstance(open_camera("pylon:21345678"), PylonCamera)
    assert open_camera("pylon:21345678").serial == "21345678"
    cam = open_camera("opencv:0")
    assert isinstance(cam, OpenCVCamera) and cam.device == 0
    assert open_camera("opencv:/dev/video2").device == "/dev/video2"
    g = open_camera("genicam:/opt/vendor/lib/producer.cti:ABC123")
    assert isinstance(g, GenICamCamera)
    assert (g.cti, g.serial) == (Path("/opt/vendor/lib/producer.cti"), "ABC123")
    g = open_camera("genicam:/opt/vendor/lib/producer.cti")
    assert (g.cti, g.serial) == (Path("/opt/vendor/lib/producer.cti"), None)
    for bad in ("usb:0", "pylon", "pylon:", "", "0"):
        with pytest.raises(InputError) as err:
            open_camera(bad)
        assert "\n" not in str(err.value) and "pylon:SERIAL" in str(err.value)


# -- GenICam through harvesters, with the genicam package's producer --------------------------


def test_genicam_bundled_producer_grabs_mono8() -> None:
    cti = bundled_producer()
    assert cti is not None and cti.is_file()
    with open_camera(f"genicam:{cti}:2") as cam:
        assert (cam._acquirer.device.serial_number, cam._acquirer.device.id_) == (
            "2",
            "VikyTL_DEV_blue",
        )  # the device asked for
        assert cam.pixel_format == "RGBa8"  # the producer's default: offered, not read
        with pytest.raises(PixelFormatError, match="'RGBa8' is not one hdrfringe reads"):
            _ = cam.bit_depth
        assert cam.pixel_formats == ("Mono8",)
        cam.set_pixel_format("Mono8")
        assert isinstance(cam, Camera) and cam.bit_depth == 8
        image = cam.grab(timeout_s=2.0)
        assert image.dtype == np.uint8 and image.shape == (400, 400)
        assert image.max() > image.min()  # a rendered scene, not an empty buffer
        with pytest.raises(CameraError, match="no ExposureTime feature"):
            cam.set_exposure(5.0)
        with pytest.raises(CameraError, match="'hardware' is not supported"):
            cam.set_trigger_mode("hardware")
        # one frame per second: right after a frame, a 0.1 s grab must time out
        cam._nodes.AcquisitionFrameRate.value = 1.0
        cam.grab(timeout_s=3.0)
        with pytest.raises(GrabTimeoutError, match=r"no image within 0\.1 s"):
            cam.grab(timeout_s=0.1)


def test_genicam_not_found(tmp_path: Path) -> None:
    with pytest.raises(CameraNotFoundError, match="no GenTL producer at"):
        open_camera(f"genicam:{tmp_path / 'missing.cti'}").open()
    with pytest.raises(CameraNotFoundError, match=r"devices of viky\.cti: 0, 1, 2"):
        open_camera(f"genicam:{bundled_producer()}:77").open()
    junk = tmp_path / "junk.cti"
    junk.write_bytes(b"not a library")
    with pytest.raises(CameraNotFoundError, match="not a GenTL producer"):
        open_camera(f"genicam:{junk}").open()


# -- OpenCV VideoCapture ----------------------------------------------------------------------


def test_opencv_not_found() -> None:
    with pytest.raises(CameraNotFoundError, match="no such device or file"):
        open_camera("opencv:/dev/video-nonexistent").open()
    # an index with no device behind it (no test machine has 64 cameras)
    with pytest.raises(CameraNotFoundError, match="OpenCV cannot open it"):
        open_camera("opencv:63").open()


def test_opencv_grabs_a_video_file_through_the_back_end(tmp_path: Path) -> None:
    """The grab path (open, read, colour to Mono8, dtype, end of stream) on a lossless file."""
    path = tmp_path / "clip.avi"
    rng = np.random.default_rng(13)
    frames = [rng.integers(0, 256, (48, 64), dtype=np.uint8) for _ in range(3)]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 10, (64, 48), False)
    for frame in frames:
        writer.write(frame)
    writer.release()
    with open_camera(f"opencv:{path}") as cam:
        assert isinstance(cam, Camera)
        assert (cam.pixel_formats, cam.bit_depth) == (("Mono8",), 8)
        for frame in frames:
            image = cam.grab(timeout_s=1.0)
            assert image.dtype == np.uint8 and image.shape == (48, 64)
            np.testing.assert_array_equal(image, frame)  # in order, pixel for pixel
        with pytest.raises(GrabTimeoutError, match="no frame within"):
            cam.grab(timeout_s=0.5)
        with pytest.raises(CameraError, match="refuses a manual exposure"):
            cam.set_exposure(5.0)
        with pytest.raises(CameraError, match="UVC gain has no unit"):
            cam.set_gain(3.0)
        with pytest.raises(CameraError, match="'hardware' is not supported"):
            cam.set_trigger_mode("hardware")
