"""Fringe order from the projector-camera geometry and a depth range (issue 24, item 1).

References the code under test does not produce:

* the closed form of a parallel rig, ``1/z2 = 1/z1 - p / (f_p * B)``, for the unambiguous depth;
* the virtual rig's ray tracer (:meth:`SimulatedRig.truth`: the projector column every camera
  pixel sees, and the surface point), for the orders and the points;
* ``calibrate-stereo --rig sim`` for a calibration the measurement did not make.

Broken variants rejected: taking the candidate nearest the range's middle where the range admits
several (wrong orders on a range too deep for the pitch), leaving isolated orders in (a pixel
one order off survives), an unambiguous depth off by any amount (the traced columns would move
by more or less than a pitch).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import tifffile

from hdrfringe.core.captures import Captures
from hdrfringe.core.decode import decode_captures
from hdrfringe.core.geometric_order import (
    DEFAULT_MARGIN,
    geometric_order,
    ray_coordinate_span,
    unambiguous_depth_mm,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.stereo import LensModel, StereoCalibration
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.io.captures import write_capture_folder
from hdrfringe.pipeline import measure
from hdrfringe.rig.board_poses import calibration_rig
from hdrfringe.rig.scenes import mask, plate
from tests.conftest import run_cli

pytestmark = pytest.mark.xdist_group("geometric-order")

TWO_PI = 2.0 * np.pi
#: One fine pitch: 20 periods across the 800 px projector of the calibration rig.
PITCH = 40.0
#: The mask (scale 0.5: 0..27 mm on the plane 600 mm from the camera) lies at 573-600 mm.
RANGE = (570.0, 605.0)
#: Too deep for 40 px: the column moves by 48-74 px per ray over it, so most pixels have two.
DEEP = (565.0, 680.0)
#: Far too deep, and off-centre: the scene near the near end.
FAR_TOO_DEEP = (560.0, 900.0)


def _parallel(baseline: tuple[float, float, float]) -> StereoCalibration:
    cam = LensModel([[900, 0, 99.5], [0, 900, 74.5], [0, 0, 1]], [], (200, 150))
    proj = LensModel([[1200, 0, 1000], [0, 1200, 750], [0, 0, 1]], [], (2000, 1500))
    return StereoCalibration(cam, proj, np.eye(3), -np.asarray(baseline))


@pytest.mark.parametrize(
    ("orientation", "baseline"), [("vertical", (150.0, 0, 0)), ("horizontal", (0, -90.0, 0))]
)
def test_unambiguous_depth_is_the_parallel_rigs_closed_form(orientation, baseline) -> None:  # type: ignore[no-untyped-def]
    """``z2 = z1 / (1 - p z1 / (f_p B))`` at every pixel (no lens distortion), ``inf`` where
    the ray's vanishing point is within a pitch; the span over ``[z1, z2]`` is one pitch."""
    calib = _parallel(baseline)
    b = float(np.linalg.norm(baseline))
    rng = np.random.default_rng(3)
    uc, vc = rng.uniform(0, 199, 50), rng.uniform(0, 149, 50)
    for pitch, near in ((24.0, 500.0), (64.0, 800.0)):
        z = unambiguous_depth_mm(calib, pitch, orientation, near, u_cam=uc, v_cam=vc)
        closed = near / (1 - pitch * near / (1200 * b))
        np.testing.assert_allclose(z, closed, rtol=1e-9)
        lo, hi = ray_coordinate_span(calib, orientation, (near, closed), u_cam=uc, v_cam=vc)
        np.testing.assert_allclose(hi - lo, pitch, rtol=1e-9)
    # p z1 >= f_p B: the coordinate never moves a pitch beyond z1
    far = unambiguous_depth_mm(calib, 64.0, orientation, 1200 * b / 64 + 1, u_cam=uc, v_cam=vc)
    assert np.all(np.isinf(far))


def test_unambiguous_depth_matches_the_virtual_rigs_traced_columns() -> None:
    """On the calibration rig's true geometry (20 degrees, 218 mm baseline, 600 mm standoff),
    the simulator's ray tracer sees a plate at the returned far depth one pitch away (in
    projector columns) from a plate at the near depth, at every pixel tested.

    Measured (docs/stereo.md): from 570 mm, 40 px reach 644.4 mm at the image centre; with the
    default margins (30 px) 624.3 mm."""
    rig = calibration_rig(plate(0.0))
    calib = rig.stereo_calibration()
    near, standoff = 570.0, rig.geometry.standoff_mm
    pixels = [(319.0, 239.0), (20.0, 30.0), (620.0, 450.0)]
    base = rig.replace(scene=plate(standoff - near)).truth()
    for col, row in pixels:
        z = float(unambiguous_depth_mm(calib, PITCH, "vertical", near, u_cam=col, v_cam=row))
        far = rig.replace(scene=plate(standoff - z)).truth()
        moved = far.u[int(row), int(col)] - base.u[int(row), int(col)]
        assert abs(abs(moved) - PITCH) < 1e-6, (col, row, z, moved)
    centre = dict(u_cam=319.5, v_cam=239.5)
    full = float(unambiguous_depth_mm(calib, PITCH, "vertical", near, **centre))
    usable = float(
        unambiguous_depth_mm(calib, (1 - 2 * DEFAULT_MARGIN) * PITCH, "vertical", near, **centre)
    )
    print(f"[geometric] 40 px from 570 mm: {full:.1f} mm, with the margins {usable:.1f} mm")
    assert full == pytest.approx(644.4, abs=0.1) and usable == pytest.approx(624.3, abs=0.1)
    assert usable > RANGE[1] and full < DEEP[1]


@pytest.fixture(scope="module")
def scene() -> dict:
    """The mask seen through one vertical set of pitch 40 px by the calibration rig, with the
    rig's true geometry and its traced columns and points (camera frame)."""
    rig = calibration_rig(mask(scale=0.5))
    caps = rig.capture_folder(FringeSpec("sinusoidal", 4, PITCH).frames())
    decoded = decode_captures(caps)
    truth = rig.truth()
    rot, t = rig.geometry.world_to_camera()
    xyz = np.stack([truth.x_mm, truth.y_mm, truth.height_mm], axis=-1) @ rot.T + t
    return {
        "rig": rig,
        "calibration": rig.stereo_calibration(),
        "captures": caps,
        "phase": decoded.set_results[decoded.sets[0].label].wrapped_phase,
        "u": np.where(truth.valid, truth.u, np.nan),
        "xyz": xyz,
    }


def _wrong(coordinate: np.ndarray, true_u: np.ndarray) -> np.ndarray:
    """Pixels whose coordinate is a whole order (half a pitch or more) off the traced one."""
    with np.errstate(invalid="ignore"):
        return np.asarray(np.abs(coordinate - true_u) >= PITCH / 2)


def test_single_pitch_orders_equal_the_traced_ones(scene) -> None:  # type: ignore[no-untyped-def]
    """A range holding the mask: every pixel gets one order, the traced one (the decoded
    column within 1.2 px of the traced one), with one pitch of 40 px and no other set."""
    z = scene["xyz"][..., 2]
    assert RANGE[0] < z.min() and z.max() < RANGE[1]
    lo, hi = ray_coordinate_span(scene["calibration"], "vertical", RANGE)
    assert np.nanmax(hi - lo) + 2 * DEFAULT_MARGIN * PITCH < PITCH  # 16-25 px + 2 x 5 px
    g = geometric_order(scene["phase"], PITCH, "vertical", scene["calibration"], RANGE)
    u = g.absolute_phase * PITCH / TWO_PI
    s = g.summary()
    assert s["valid_fraction"] == 1.0 and s["ambiguous_fraction"] == 0.0
    assert np.nanmax(np.abs(u - scene["u"])) < 1.5
    within = u - g.order * PITCH  # the order counts whole pitches below the coordinate
    assert np.all((within > -1e-9) & (within < PITCH + 1e-9))


def test_a_too_deep_range_leaves_pixels_invalid_never_wrong(scene) -> None:  # type: ignore[no-untyped-def]
    """Where the range admits two orders the pixel is invalid: on DEEP 77 % of the pixels (the
    rest keep the traced order), on FAR_TOO_DEEP all. Taking the candidate nearest the middle
    of the range's projector interval instead gets 99 % of the pixels wrong on FAR_TOO_DEEP."""
    calib, phi, true_u = scene["calibration"], scene["phase"], scene["u"]
    lo, hi = ray_coordinate_span(calib, "vertical", DEEP)
    assert 48 < np.nanmin(hi - lo) and np.nanmax(hi - lo) < 75
    for depths, ambiguous in ((DEEP, (0.6, 0.9)), (FAR_TOO_DEEP, (1.0, 1.0))):
        g = geometric_order(phi, PITCH, "vertical", calib, depths)
        u = g.absolute_phase * PITCH / TWO_PI
        s = g.summary()
        print(f"[geometric] range {depths}: {s}")
        assert ambiguous[0] <= s["ambiguous_fraction"] <= ambiguous[1]
        assert not np.any(_wrong(u, true_u))
        assert s["valid_fraction"] == pytest.approx(1 - s["ambiguous_fraction"], abs=0.002)
    # the broken variant: the candidate nearest the middle of [lo, hi]
    lo, hi = ray_coordinate_span(calib, "vertical", FAR_TOO_DEEP)
    frac = np.mod(phi, TWO_PI) * PITCH / TWO_PI
    nearest = frac + PITCH * np.round((0.5 * (lo + hi) - frac) / PITCH)
    wrong = _wrong(nearest, true_u).mean()
    print(f"[geometric] nearest the middle on {FAR_TOO_DEEP}: {100 * wrong:.1f} % wrong")
    assert wrong > 0.9


def test_an_isolated_order_is_invalid() -> None:
    """A plane near the range's near end; one pixel's phase 8 px low drops its own order out
    of the range and brings the next one in: alone, it is one order off (the check off); the
    neighbourhood check makes it invalid and keeps every other pixel."""
    cam = LensModel([[1000, 0, 15.5], [0, 1000, 11.5], [0, 0, 1]], [], (32, 24))
    proj = LensModel([[1000, 0, 400], [0, 1000, 300], [0, 0, 1]], [], (800, 600))
    calib = StereoCalibration(cam, proj, np.eye(3), [-100.0, 0, 0])
    # column along a ray: c(z) = 1000 x + 400 - 1e5 / z; the range spans 36 of the 40 px
    z1 = 405.0
    z2 = 1 / (1 / z1 - 36 / 1e5)
    plane = 1 / (1 / z1 - 2 / 1e5)  # 2 px inside the near end
    x = (np.tile(np.arange(32.0), (24, 1)) - 15.5) / 1000
    u = 1000 * x + 400 - 1e5 / plane
    u_bad = u.copy()
    u_bad[10, 12] -= 8.0
    phi = np.mod(TWO_PI * u_bad / PITCH, TWO_PI)
    loose = geometric_order(phi, PITCH, "vertical", calib, (z1, z2), margin=0, neighbours=False)
    off = loose.absolute_phase * PITCH / TWO_PI - u
    assert off[10, 12] == pytest.approx(PITCH - 8.0)
    off[10, 12] = 0
    assert np.abs(off).max() < 1e-9
    g = geometric_order(phi, PITCH, "vertical", calib, (z1, z2), margin=0)
    assert np.isnan(g.absolute_phase[10, 12]) and g.isolated[10, 12]
    assert int(g.isolated.sum()) == 1 and g.summary()["valid_fraction"] == 1 - 1 / u.size


def test_measure_with_a_depth_range_triangulates_a_single_pitch(scene) -> None:  # type: ignore[no-untyped-def]
    """``measure(..., depth_range_mm=)`` on captures of one pitch: the points are the traced
    ones (median 0.17 mm: the phase error of the 8-bit set; an order off moves a point by
    about 60 mm), metrics record the geometric order; without the range the error
    names the option; a range without a stereo calibration is refused."""
    res = measure(scene["captures"], scene["calibration"], depth_range_mm=RANGE)
    order = res.metrics.to_dict()["stereo"]["fringe_order"]["u"]
    assert order["method"] == "geometric" and order["ambiguous_fraction"] == 0.0
    assert order["depth_range_mm"] == list(RANGE) and order["pitch_px"] == PITCH
    assert res.decoded.primary is not None
    assert res.decoded.primary.absolute_method.startswith("geometric")
    # the notes agree: the decoder's "no absolute phase" note (it is there after decoding
    # alone) gives way to the geometric one
    from hdrfringe.core.decode import decode_captures, no_absolute_phase_note

    assert no_absolute_phase_note("vertical") in decode_captures(scene["captures"]).notes
    assert no_absolute_phase_note("vertical") not in res.notes
    assert sum("absolute phase from the stereo calibration" in n for n in res.notes) == 1
    assert res.stereo is not None
    err = np.linalg.norm(res.stereo.xyz - scene["xyz"], axis=-1)
    assert np.nanmedian(err) < 0.3 and np.isfinite(err).mean() > 0.99
    with pytest.raises(CaptureFormatError, match=r"measure --depth-range ZMIN:ZMAX"):
        measure(scene["captures"], scene["calibration"])
    with pytest.raises(InputError, match="a depth range fixes the fringe order with a stereo"):
        measure(scene["captures"], None, depth_range_mm=RANGE)
    with pytest.raises(InputError, match="0 < ZMIN < ZMAX"):
        measure(scene["captures"], scene["calibration"], depth_range_mm=(600, 500))


def test_cli_measure_depth_range_with_a_calibrate_stereo_calibration(scene, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """``calibrate-stereo --rig sim`` (3 poses), then ``measure -c --depth-range`` on the
    mask's one-pitch captures: the traced columns (every pixel), the traced points within
    the calibration's frame error (median 0.5 mm); bad ranges are one-line errors, nothing
    written."""
    cal = tmp_path / "sim.h5"
    res = run_cli(
        "calibrate-stereo", "--rig", "sim", "--poses", "3", "--board", "circles:9x6:25",
        "-o", str(cal),
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    caps = write_capture_folder(tmp_path / "caps", scene["captures"])
    out = tmp_path / "out"
    res = run_cli(
        "measure", str(caps), "-c", str(cal), "--depth-range", "570:605", "--no-previews",
        "--no-uncertainty", "-o", str(out),
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    printed = " ".join(res.stdout.split())  # the console wraps long lines
    assert "absolute phase from the stereo calibration and the depth range 570..605" in printed
    assert "so no absolute phase" not in printed  # no note contradicts it
    u = tifffile.imread(out / "absolute_phase_vertical.tiff").astype(np.float64) * PITCH / TWO_PI
    assert np.isfinite(u).mean() > 0.99 and not np.any(_wrong(u, scene["u"]))
    xyz = tifffile.imread(out / "xyz.tiff").astype(np.float64)
    assert np.nanmedian(np.linalg.norm(xyz - scene["xyz"], axis=-1)) < 1.5
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["stereo"]["fringe_order"]["u"]["method"] == "geometric"
    for args, needle in (
        (["--depth-range", "605:570"], "--depth-range '605:570': give ZMIN:ZMAX with 0 < ZMIN"),
        (["--depth-range", "570"], "--depth-range '570': give ZMIN:ZMAX in mm"),
        ([], "cannot triangulate: no fringe family has an absolute phase and no depth range"),
    ):
        bad = tmp_path / "bad"
        res = run_cli("measure", str(caps), "-c", str(cal), *args, "-o", str(bad))
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        assert res.returncode == 2 and len(lines) == 1 and needle in lines[0], res.stderr
        assert not bad.exists()
    res = run_cli("measure", str(caps), "--depth-range", "570:605", "-o", str(tmp_path / "b"))
    assert res.returncode == 2 and "give -c STEREO.h5" in res.stderr


def test_depth_range_with_captures_of_another_camera_is_refused(scene) -> None:  # type: ignore[no-untyped-def]
    """The phase must be the calibrated camera's size."""
    caps: Captures = scene["captures"]
    with pytest.raises(InputError, match="calibration's camera is 640x480"):
        geometric_order(caps.images[0, :10, :10] * 0.0, PITCH, "vertical",
                        scene["calibration"], RANGE)  # fmt: skip


def test_a_ray_leaving_the_projectors_front_has_no_interval() -> None:
    """A range reaching behind the projector (its centre 500 mm ahead of the camera): the ray
    does not project at the near depths, so the pixel has no interval (not the one of the far
    samples alone, which a running minimum over the samples would keep); one that stays in
    front is clipped to the projector's extent."""
    cam = LensModel([[1000, 0, 15.5], [0, 1000, 11.5], [0, 0, 1]], [], (32, 24))
    proj = LensModel([[1000, 0, 400], [0, 1000, 300], [0, 0, 1]], [], (800, 600))
    calib = StereoCalibration(cam, proj, np.eye(3), [-100.0, 0, -500.0])
    lo, hi = ray_coordinate_span(calib, "vertical", (400.0, 2000.0), u_cam=15.5, v_cam=11.5)
    assert np.isnan(lo) and np.isnan(hi)
    lo, hi = ray_coordinate_span(calib, "vertical", (600.0, 2000.0), u_cam=15.5, v_cam=11.5)
    # u = 400 - 1e5 / (z - 500): -600 at 600 mm (clipped to the pattern's edge), 333 at 2 m
    assert float(lo) == -0.5 and float(hi) == pytest.approx(400 - 1e5 / 1500)


def test_projection_in_blocks_is_opencvs_point_by_point() -> None:
    """``LensModel.project`` evaluates OpenCV's model in numpy blocks (the rays of a whole
    image at every sampled depth): across the block boundaries every pixel is OpenCV's own
    ``cv2.projectPoints`` to 1e-9 px (a block written to the wrong place, or a term of the
    model dropped, misses by pixels)."""
    import cv2

    from hdrfringe.core.stereo import _LENS_BLOCK

    lens = LensModel([[900, 0, 640], [0, 905, 360], [0, 0, 1]], [-0.2, 0.1, 1e-3, -2e-3, 0.05],
                     (1280, 720))  # fmt: skip
    rng = np.random.default_rng(5)
    n = 4 * _LENS_BLOCK + 123  # several blocks and a partial one
    pts = np.c_[rng.uniform(-0.5, 0.5, (n, 2)), np.ones(n)] * rng.uniform(300, 900, 1)
    u, v = lens.project(pts)
    ref, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), lens.matrix, lens.distortion)
    assert np.abs(np.c_[u, v] - ref.reshape(-1, 2)).max() < 1e-9
