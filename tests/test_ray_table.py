"""The camera ray table (issue 30): every pixel undistorted once per calibration and image size.

References independent of the code under test: OpenCV's own ``cv2.undistortPoints`` (run to
1e-10 px) on a random sample of pixels, and the hand-made pinhole rays.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from hdrfringe.core.stereo import LensModel, StereoCalibration, ray_table, triangulate_maps
from hdrfringe.errors import InputError

SIZE = (320, 240)  # (W, H): small, so the tests stay fast
K = np.array([[400.0, 0.0, 161.3], [0.0, 398.0, 118.7], [0.0, 0.0, 1.0]])
#: a strong lens (corners moved by ~20 px) and a rational one (k4..k6)
STRONG = np.array([-0.42, 0.23, 0.0021, -0.0027, -0.07])
RATIONAL = np.array([-0.3, 0.1, 0.001, -0.002, 0.02, 0.2, 0.05, 0.01])
#: OpenCV's iteration limits of the reference: 200 steps or 1e-10 px.
CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-10)


def _opencv_rays(lens: LensModel, u: np.ndarray, v: np.ndarray, criteria=CRITERIA) -> np.ndarray:  # type: ignore[no-untyped-def]
    """``cv2.undistortPoints`` of pixels (OpenCV 4: ``undistortPointsIter`` takes criteria)."""
    src = np.c_[u, v].reshape(-1, 1, 2).astype(np.float64)
    iterative = getattr(cv2, "undistortPointsIter", None)
    if criteria is None:
        out = cv2.undistortPoints(src, lens.matrix, lens.distortion)
    elif iterative is not None:
        out = iterative(src, lens.matrix, lens.distortion, None, None, criteria)
    else:
        out = cv2.undistortPoints(src, lens.matrix, lens.distortion, criteria=criteria)
    return np.asarray(out).reshape(-1, 2)


@pytest.mark.parametrize("distortion", [STRONG, RATIONAL], ids=["k1-k3,p1,p2", "rational"])
def test_ray_table_is_opencvs_undistortion_of_every_pixel(distortion: np.ndarray) -> None:
    """On 3000 random pixels (corners included) the table is OpenCV's undistortion to 1e-6 px.

    Rejects: a table with rows and columns swapped, or built with OpenCV's default 5
    iterations (which leave more than 1e-3 px at these corners: checked below), or a term of
    the model dropped."""
    ray_table.cache_clear()
    lens = LensModel(K, distortion, SIZE)
    table = ray_table(lens)
    assert table.shape == (2, SIZE[1], SIZE[0]) and table.dtype == np.float64
    rng = np.random.default_rng(30)
    rows = np.r_[0, 0, SIZE[1] - 1, SIZE[1] - 1, rng.integers(0, SIZE[1], 2996)]
    cols = np.r_[0, SIZE[0] - 1, 0, SIZE[0] - 1, rng.integers(0, SIZE[0], 2996)]
    ref = _opencv_rays(lens, cols.astype(float), rows.astype(float))
    got = table[:, rows, cols].T
    assert np.isfinite(got).all()
    miss_px = np.abs(got - ref).max() * K[0, 0]
    assert miss_px < 1e-6, miss_px
    # the tolerance tells OpenCV's default iterations apart (a table built that way fails)
    coarse = _opencv_rays(lens, cols.astype(float), rows.astype(float), criteria=None)
    assert np.abs(coarse - ref).max() * K[0, 0] > 1e-3


def test_ray_table_is_cached_per_calibration_and_size() -> None:
    """The second call with the same numbers (even another LensModel object, as when the
    calibration file is read again) returns the same table without computing it; another
    distortion or size computes its own.

    Rejects: no cache (a new array each call), a cache keyed by the object's identity (the
    re-read lens misses), a cache keyed by the size alone (the changed distortion would get the
    stale table)."""
    ray_table.cache_clear()
    lens = LensModel(K, STRONG, SIZE)
    first = ray_table(lens)
    assert ray_table.cache_info().misses == 1 and ray_table.cache_info().hits == 0
    again = ray_table(LensModel(K.copy(), STRONG.copy(), SIZE))
    assert again is first and ray_table.cache_info().hits == 1
    assert not first.flags.writeable
    other = ray_table(LensModel(K, STRONG * 0.5, SIZE))
    assert other is not first and np.abs(other - first).max() * K[0, 0] > 1.0
    smaller = ray_table(LensModel(K, STRONG, (SIZE[0] // 2, SIZE[1])))
    assert smaller.shape == (2, SIZE[1], SIZE[0] // 2)
    np.testing.assert_array_equal(smaller, first[:, :, : SIZE[0] // 2])
    assert ray_table.cache_info().misses == 3


def test_triangulate_maps_undistorts_the_camera_once() -> None:
    """Triangulating a second measurement with the same calibration reuses the table, and its
    rays are the pinhole rays of a distortion-free camera (hand-computed).

    Rejects: ``triangulate_maps`` undistorting every pixel per call (no cache hit)."""
    ray_table.cache_clear()
    size = (64, 48)  # the dominant-plane fit of every call is the slow part: few pixels
    cam = LensModel(K, [], size)
    proj = LensModel([[800, 0, 456], [0, 800, 570], [0, 0, 1]], [], (912, 1140))
    calib = StereoCalibration(cam, proj, np.eye(3), [0.0, -100.0, 0.0])
    rows, cols = np.mgrid[0 : size[1], 0 : size[0]]
    y = (rows - K[1, 2]) / K[1, 1]
    v = 800 * (y * 600 - 100) / 600 + 570  # the projector row lighting a wall at 600 mm
    triangulate_maps(calib, v_proj=v)
    maps = triangulate_maps(calib, v_proj=v)
    assert ray_table.cache_info().misses == 1 and ray_table.cache_info().hits == 1
    x = (cols - K[0, 2]) / K[0, 0]
    want = np.dstack([x * 600, y * 600, np.full(x.shape, 600.0)])
    assert np.abs(maps.xyz - want).max() < 1e-9


def test_float32_table_error_is_far_below_the_coordinate_noise() -> None:
    """A float32 table differs from the float64 one by less than 1e-4 px (6e-6 px measured
    here at f = 400 px; rounding a normalised coordinate below 0.5 moves it by at most 3e-8,
    1e-4 px even at f = 4000 px), three orders below the 0.05-0.5 px noise of decoded
    projector coordinates; float64 stays the default.

    Rejects: a half-precision table (about 0.05 px here)."""
    ray_table.cache_clear()
    lens = LensModel(K, STRONG, SIZE)
    t64, t32 = ray_table(lens), ray_table(lens, np.float32)
    assert t32.dtype == np.float32 and ray_table.cache_info().misses == 2
    error_px = float(np.abs(t32.astype(np.float64) - t64).max() * K[0, 0])
    print(f"[measured] float32 ray table vs float64: {error_px:.2e} px")
    assert error_px < 1e-4
    assert np.abs(t64.astype(np.float16) - t64).max() * K[0, 0] > 1e-3
    with pytest.raises(InputError, match="float32 or float64"):
        ray_table(lens, np.float16)
