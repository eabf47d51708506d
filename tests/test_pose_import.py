"""Board poses from other rigs (issue 24): crops pasted back into the camera frame by
``hdrfringe import``, and projector coordinates from a Gray code alone
(:func:`hdrfringe.core.stereo_calibration.graycode_coordinates`), on synthetic images whose truth is
known. The real sets: tests/test_calibration_realdata.py."""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.frames import GrayCodeFrame, UniformFrame, opencv_graycode_frames
from hdrfringe.core.graycode import code_bit
from hdrfringe.core.stereo_calibration import graycode_coordinates, projector_coordinates
from hdrfringe.errors import InputError
from hdrfringe.io.captures import read_capture_folder
from hdrfringe.io.importer import import_captures
from tests.conftest import run_cli_in_process

CROP_TOML = """\
[camera]
bit_depth = 8
frame_size = [10, 8]

[[uniform]]
files = "{name}.png"
level = "{name}"
"""


def _crop_folder(tmp: Path) -> tuple[Path, Path, np.ndarray]:
    cam = tmp / "cam"
    cam.mkdir()
    crop = np.arange(30, dtype=np.uint8).reshape(5, 6) + 1
    iio.imwrite(cam / "white.png", crop)
    desc = tmp / "d.toml"
    desc.write_text(CROP_TOML.format(name="white"))
    return cam, desc, crop


def test_crop_pasted_at_its_offset(tmp_path: Path) -> None:
    cam, desc, crop = _crop_folder(tmp_path)
    rep = import_captures(cam, desc, tmp_path / "caps", crop_offset=(3, 2))
    caps = read_capture_folder(tmp_path / "caps")
    img = caps.images[0]
    assert img.shape == (8, 10)
    # x0 = 3 columns, y0 = 2 rows; a swapped offset puts the crop at rows 3.., columns 2..
    np.testing.assert_array_equal(img[2:7, 3:9], crop)
    assert img.sum() == crop.sum()  # zero outside the crop
    assert rep.manifest["import"]["crop_offset"] == [3, 2]
    assert rep.manifest["import"]["frame_size"] == [10, 8]


def test_crop_offset_from_the_cli_and_its_errors(tmp_path: Path) -> None:
    cam, desc, _ = _crop_folder(tmp_path)
    out = tmp_path / "caps"
    ok = run_cli_in_process(
        "import", str(cam), "-d", str(desc), "-o", str(out), "--crop-offset", "4,3"
    )
    assert ok.returncode == 0, ok.stderr
    assert read_capture_folder(out).images[0][3, 4] == 1
    cases = {
        "": "give --crop-offset X0,Y0",  # a crop smaller than the frame needs its offset
        "5,2": "does not fit in the camera frame 10x8",  # 5 + 6 > 10
        "a,b": "give X0,Y0 in camera pixels",
    }
    for offset, message in cases.items():
        extra = ["--crop-offset", offset] if offset else []
        res = run_cli_in_process(
            "import", str(cam), "-d", str(desc), "-o", str(tmp_path / "bad"), *extra
        )
        lines = res.stderr.strip().splitlines()
        assert res.returncode == 2 and len(lines) == 1 and message in lines[0], (offset, lines)
        assert not (tmp_path / "bad").exists()
    desc.write_text("[camera]\nbit_depth = 8\ncrop_offset = [1, 1]\n" + CROP_TOML.split("\n", 3)[3])
    with pytest.raises(InputError, match="crop_offset without frame_size"):
        import_captures(cam, desc, tmp_path / "bad")


def _code_images(frames: list, xx: np.ndarray, yy: np.ndarray, stripe: float) -> np.ndarray:
    out = []
    for f in frames:
        if isinstance(f, UniformFrame):
            out.append(np.full(xx.shape, 200.0 if f.level else 20.0))
            continue
        coord = xx if f.orientation == "vertical" else yy
        lit = code_bit(coord, f.bit, stripe) ^ f.inverse
        out.append(np.where(lit, 200.0, 20.0))
    return np.stack(out).astype(np.uint8)


def test_graycode_coordinates_are_the_stripe_centres() -> None:
    """SLStudio-like: 2-px stripes, no inverses, white and black frames; a projector of 13
    columns (the 4-bit code has 16 cells of 2 px): stripes beyond it are invalid."""
    xx, yy = np.meshgrid(np.arange(26.0), np.arange(2.0))
    frames = [GrayCodeFrame("vertical", b, 4, 2.0) for b in range(3, -1, -1)]
    frames += [UniformFrame(255.0), UniformFrame(0.0)]
    caps = Captures(frames, _code_images(frames, xx, yy, 2.0), 8, projector=ProjectorInfo(13, 2))
    u = graycode_coordinates(caps)["vertical"]
    cell = np.floor(xx / 2)
    expect = np.where(2 * cell + 0.5 <= 12.5, 2 * cell + 0.5, np.nan)  # centre (c + 1/2) s - 1/2
    np.testing.assert_array_equal(u, expect)


def test_projector_coordinates_from_a_code_of_one_pixel_stripes() -> None:
    """procam-calibration-like: OpenCV's code with inverses at the projector's resolution gives
    each camera pixel the projector pixel it sees (here the camera sees projector pixel
    (x // 2, y // 2)); a coarse code (8 px stripes) is refused with one line."""
    xx, yy = np.meshgrid(np.arange(32.0), np.arange(24.0))
    frames = [*opencv_graycode_frames(16, 12), UniformFrame(255.0), UniformFrame(0.0)]
    imgs = _code_images(frames, xx // 2, yy // 2, 1.0)
    u, v = projector_coordinates(Captures(frames, imgs, 8, projector=ProjectorInfo(16, 12)))
    np.testing.assert_array_equal(u, xx // 2)
    np.testing.assert_array_equal(v, yy // 2)
    coarse = [*opencv_graycode_frames(16, 12, 8.0), UniformFrame(255.0), UniformFrame(0.0)]
    caps = Captures(
        coarse, _code_images(coarse, xx // 2, yy // 2, 8.0), 8, projector=ProjectorInfo(16, 12)
    )
    with pytest.raises(InputError, match="Gray code of stripes of at most 2 projector px"):
        projector_coordinates(caps)


def test_graycode_poses_calibrate_the_virtual_rig() -> None:
    """Board poses captured with OpenCV's Gray code alone (10 + 10 bits with inverses, white,
    black; no fringes) on the virtual calibration rig: the calibration recovers the rig's true
    geometry. Targets: those of the fringe poses (docs/stereo_calibration.md) for focal
    lengths and baseline (0.2 %); the principal points 2 px instead of 1 px, as the quantised
    codes leave about twice the projector reprojection error of fringes."""
    from hdrfringe.core.stereo_calibration import BoardSpec, calibrate_stereo, observe_pose
    from hdrfringe.rig.board_poses import calibration_rig, default_board_poses

    boards = default_board_poses(8)
    rig = calibration_rig(boards[0], noise=1.0)
    proj = rig.projector
    frames = [*opencv_graycode_frames(proj.width, proj.height), UniformFrame(255.0)]
    frames.append(UniformFrame(0.0))
    spec = BoardSpec.parse("checkerboard:9x6:25")
    poses = [
        observe_pose(calibration_rig(b, noise=1.0, seed=k).capture_folder(frames), spec)
        for k, b in enumerate(boards)
    ]
    assert all(p.usable and p.mapped.all() for p in poses), [p.notes for p in poses]
    result = calibrate_stereo(poses, spec, (640, 480), (proj.width, proj.height))
    calib, truth = result.calibration, rig.stereo_calibration()
    for lens in ("camera", "projector"):
        k, kt = getattr(calib, lens).matrix, getattr(truth, lens).matrix
        assert np.all(np.abs(k[[0, 1], [0, 1]] / kt[[0, 1], [0, 1]] - 1) < 0.002), lens
        assert np.all(np.abs(k[:2, 2] - kt[:2, 2]) < 2.0), lens
    assert abs(calib.baseline_mm / truth.baseline_mm - 1) < 0.002
    assert calib.reprojection_px is not None and calib.reprojection_px["stereo"] < 0.2
