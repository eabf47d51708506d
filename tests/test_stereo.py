"""Stereo geometry (issue 12, points 5-6): lens models, the stereo calibration, triangulation.

References are independent of the code under test: OpenCV's own ``cv2.projectPoints`` and
hand-computed pinhole projections.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from hdrfringe.errors import InputError
from hdrfringe.stereo import LensModel, StereoCalibration

CAM_K = np.array([[2400.0, 0.0, 1010.0], [0.0, 2390.0, 770.0], [0.0, 0.0, 1.0]])
CAM_D = np.array([-0.25, 0.18, 0.0012, -0.0008, -0.05])
PROJ_K = np.array([[1800.0, 0.0, 460.0], [0.0, 3600.0, 1130.0], [0.0, 0.0, 1.0]])
PROJ_D = np.array([0.12, -0.3, 0.002, 0.001, 0.2])


def _rotation(rx: float, ry: float, rz: float) -> np.ndarray:
    r, _ = cv2.Rodrigues(np.array([rx, ry, rz]))
    return np.asarray(r)


def synthetic_calibration(proj_distortion: np.ndarray = PROJ_D) -> StereoCalibration:
    cam = LensModel(CAM_K, CAM_D, (2048, 1536))
    proj = LensModel(PROJ_K, proj_distortion, (912, 1140))
    return StereoCalibration(cam, proj, _rotation(0.02, -0.35, 0.01), [180.0, -15.0, 40.0])


# --- the data model -----------------------------------------------------------------------


def test_lens_project_matches_opencv_and_pinhole() -> None:
    lens = LensModel(CAM_K, CAM_D, (2048, 1536))
    pts = np.random.default_rng(1).uniform([-200, -150, 600], [200, 150, 900], (50, 3))
    ref, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), CAM_K, CAM_D)
    u, v = lens.project(pts)
    assert np.allclose(np.stack([u, v], -1), ref.reshape(-1, 2), atol=1e-9)
    plain = LensModel(CAM_K, [], (2048, 1536))
    u0, v0 = plain.project(pts)
    assert np.allclose(u0, CAM_K[0, 0] * pts[:, 0] / pts[:, 2] + CAM_K[0, 2])
    assert np.allclose(v0, CAM_K[1, 1] * pts[:, 1] / pts[:, 2] + CAM_K[1, 2])


def test_lens_undistort_inverts_strong_distortion_to_micropixels() -> None:
    strong = np.array([-0.45, 0.25, 0.002, -0.003, -0.08])
    lens = LensModel(CAM_K, strong, (2048, 1536))
    xy = np.random.default_rng(2).uniform([-0.4, -0.3], [0.4, 0.3], (2000, 2))
    pts = np.concatenate([xy, np.ones((2000, 1))], axis=1)
    ref, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), CAM_K, strong)
    x, y = lens.undistort(ref[:, 0, 0], ref[:, 0, 1])
    # 1e-6 px in the image is ~4e-10 in normalised units at f = 2400
    assert np.abs(x - xy[:, 0]).max() * CAM_K[0, 0] < 1e-6
    assert np.abs(y - xy[:, 1]).max() * CAM_K[1, 1] < 1e-6


def test_lens_skew_round_trips() -> None:
    k = CAM_K.copy()
    k[0, 1] = 3.5
    lens = LensModel(k, CAM_D, (2048, 1536))
    pts = np.array([[30.0, -40.0, 700.0], [-100.0, 80.0, 650.0]])
    u, v = lens.project(pts)
    # hand model: u = fx*xd + s*yd + cx with (xd, yd) OpenCV's distorted coordinates
    ref, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), np.eye(3), CAM_D)
    xd, yd = ref[:, 0, 0], ref[:, 0, 1]
    assert np.allclose(u, k[0, 0] * xd + 3.5 * yd + k[0, 2], atol=1e-9)
    x, y = lens.undistort(u, v)
    assert np.allclose(x, pts[:, 0] / pts[:, 2], atol=1e-12)
    assert np.allclose(y, pts[:, 1] / pts[:, 2], atol=1e-12)


@pytest.mark.parametrize(
    ("matrix", "distortion", "size", "match"),
    [
        (np.eye(2), [], (10, 10), "shape"),
        ([[-1, 0, 0], [0, 1, 0], [0, 0, 1]], [], (10, 10), "positive"),
        ([[1, 0, 0], [0, 1, 0], [0, 1, 1]], [], (10, 10), r"\[0, 0, 1\]"),
        ([[1, 0, 0], [0, np.nan, 0], [0, 0, 1]], [], (10, 10), "finite"),
        (np.eye(3), [0.1, 0.2, 0.3], (10, 10), "3 coefficients"),
        (np.eye(3), [], (10,), "width, height"),
        (np.eye(3), [], (0, 5), "width, height"),
    ],
)
def test_lens_rejects_bad_values(matrix, distortion, size, match) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InputError, match=match):
        LensModel(matrix, distortion, size)


def test_stereo_calibration_properties_and_validation() -> None:
    calib = synthetic_calibration()
    r, t = calib.rotation, calib.translation_mm
    centre = calib.projector_center_mm
    assert np.allclose(r @ centre + t, 0.0)  # the projector centre maps to its own origin
    assert calib.baseline_mm == pytest.approx(np.linalg.norm(centre))
    cam, proj = calib.camera, calib.projector
    with pytest.raises(InputError, match="not a rotation"):
        StereoCalibration(cam, proj, np.diag([1.0, 1.0, -1.0]), t)
    with pytest.raises(InputError, match="not a rotation"):
        StereoCalibration(cam, proj, 1.01 * np.eye(3), t)
    with pytest.raises(InputError, match="zero baseline"):
        StereoCalibration(cam, proj, r, [0.0, 0.0, 0.0])
    with pytest.raises(InputError, match="translation T: shape"):
        StereoCalibration(cam, proj, r, [1.0, 2.0])
    with pytest.raises(InputError, match="reprojection"):
        StereoCalibration(cam, proj, r, t, reprojection_px={"stereo": -1.0})
    ok = StereoCalibration(cam, proj, r, t, reprojection_px={"stereo": 0.5}, source="x")
    assert dict(ok.reprojection_px or {}) == {"stereo": 0.5}
