"""Issue 24, item 7: ``simulate --resolution`` makes, from the command line alone, a plate
calibration at the loop camera's reduced size, and it measures a loop-camera capture of that size.

Before, ``simulate`` always rendered the virtual rig's 648x494 camera, so a capture taken with
``loop:...&size=162x124`` had no calibration it fitted (a test built one in Python). The
reference here is the scene itself: the loop camera looks at the white plate at ``DEPTH_MM``, so
the measured height must be that depth (no bias, an RMSE at the predicted noise level), which
fails if ``--resolution`` were ignored (the calibration would not fit the capture), read as
HEIGHTxWIDTH, or cropped the field of view instead of scaling it (heights off by the pixels'
different rays).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.io.calibration_file import load_calibration
from hdrfringe.io.results import read_map_tiff
from tests.conftest import run_cli, run_cli_in_process, xvfb_display

pytestmark = pytest.mark.xdist_group("xvfb")

SCREEN = (1024, 768)  # the virtual rig's projector: the loop camera sees the same rig
SIZE = (162, 124)  # a quarter of 648x494 each way
DEPTH_MM = 10.0
FRINGES = ["--pitch", "1024,64,8", "--no-centerline"]


@pytest.fixture(scope="module")
def xdisplay() -> Iterator[str]:
    with xvfb_display(*SCREEN) as display:
        yield display


def test_a_plate_calibration_at_the_loop_cameras_size_measures_its_capture(
    xdisplay: str, tmp_path: Path
) -> None:
    from hdrfringe.io.captures import read_capture_folder

    size = f"{SIZE[0]}x{SIZE[1]}"
    plates, cal = tmp_path / "plates", tmp_path / "cal.h5"
    r = run_cli_in_process("simulate", "white_plate", "--series", "8:24:8", "--resolution", size,
                           *FRINGES, "-o", str(plates))  # fmt: skip
    assert r.returncode == 0, r.stderr
    folders = sorted(plates.iterdir())
    assert len(folders) == 4  # the reference plane and 8, 16, 24 mm
    caps = read_capture_folder(folders[1])
    assert caps.images.shape[1:] == (SIZE[1], SIZE[0])
    r = run_cli_in_process("calibrate", str(plates), "--model", "rational", "-o", str(cal))
    assert r.returncode == 0, r.stderr

    captured = tmp_path / "caps"
    camera = f"loop:white_plate?display={xdisplay}&size={size}&depth={DEPTH_MM:g}"
    r = run_cli("capture", "--projector", f"screen:0@{xdisplay}", "--camera", camera, *FRINGES,
                "--settle", "0", "-o", str(captured))  # fmt: skip
    assert r.returncode == 0, r.stderr
    out = tmp_path / "out"
    r = run_cli_in_process("measure", str(captured), "-c", str(cal), "-o", str(out))
    assert r.returncode == 0, r.stderr

    height = read_map_tiff(out / "height.tiff")
    mask = load_calibration(cal).measurement_mask()
    assert height.shape == mask.shape == (SIZE[1], SIZE[0])
    assert np.isfinite(height[mask]).all()
    error = height[mask] - DEPTH_MM
    predicted = float(np.nanmedian(read_map_tiff(out / "height_std.tiff")[mask]))
    rmse = float(np.sqrt(np.mean(error**2)))
    # measured 0.066 mm against a predicted std of 0.046 mm (plus the calibration's own noise)
    assert rmse < 2 * predicted, (rmse, predicted)
    assert abs(float(np.mean(error))) < 0.01  # no bias (mm)


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        ("162", "'162'"),
        ("162x", "'162x'"),
        ("0x124", "'0x124'"),
        ("162x124x3", "'162x124x3'"),
        ("100000x124", "'100000x124'"),
        ("-162x124", "'-162x124'"),
        ("wide", "'wide'"),
    ],
)
def test_a_bad_resolution_is_one_line_and_writes_nothing(
    value: str, shown: str, tmp_path: Path
) -> None:
    out = tmp_path / "sim"
    r = run_cli_in_process("simulate", "plate", "--resolution", value, "-o", str(out))
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in r.stderr
    text = " ".join(r.stderr.split())
    assert "--resolution must be WIDTHxHEIGHT with each 16..4096" in text and shown in text
    assert not out.exists()
