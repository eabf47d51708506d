"""Stereo geometry (issue 12, points 5-6): lens models, the stereo calibration, triangulation.

References are independent of the code under test: OpenCV's own ``cv2.projectPoints`` and
hand-computed pinhole projections.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from hdrfringe.core.stereo import LensModel, StereoCalibration
from hdrfringe.errors import InputError

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
    r = _rotation(0.02, 0.3, 0.01)  # the projector 250 mm to the right, turned toward the field
    return StereoCalibration(cam, proj, r, -r @ np.array([250.0, -20.0, 30.0]))


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


# --- triangulation against OpenCV's projection ----------------------------------------------


def _scene_points(n: int, seed: int = 3) -> np.ndarray:
    """Points over the whole projector field, 650-950 mm from it, that the camera sees."""
    calib = synthetic_calibration()
    rng = np.random.default_rng(seed)
    out = np.empty((0, 3))
    while out.shape[0] < n:
        uvz = rng.uniform([5, 5, 650], [907, 1135, 950], (n, 3))
        rays = np.linalg.solve(PROJ_K, np.c_[uvz[:, :2], np.ones(n)].T).T
        pts = (rays * uvz[:, 2:] - calib.translation_mm) @ calib.rotation  # R.T (X_p - t)
        img = pts[:, :2] / pts[:, 2:] * np.diag(CAM_K)[:2] + CAM_K[:2, 2]
        keep = np.all((img > 5) & (img < [2043, 1531]), axis=1)
        out = np.concatenate([out, pts[keep]])
    return out[:n]


def _observe(calib_k: tuple[np.ndarray, np.ndarray], pts: np.ndarray, r: np.ndarray, t: np.ndarray):  # type: ignore[no-untyped-def]
    """Pixels of ``pts`` in a lens at pose (r, t), by OpenCV (the reference)."""
    rvec, _ = cv2.Rodrigues(r)
    img, _ = cv2.projectPoints(pts, rvec, np.asarray(t, np.float64), calib_k[0], calib_k[1])
    return img[:, 0, 0], img[:, 0, 1]


def _pixels(pts: np.ndarray):  # type: ignore[no-untyped-def]
    calib = synthetic_calibration()
    uc, vc = _observe((CAM_K, CAM_D), pts, np.eye(3), np.zeros(3))
    up, vp = _observe((PROJ_K, PROJ_D), pts, calib.rotation, calib.translation_mm)
    return uc, vc, up, vp


@pytest.mark.parametrize("which", ["u", "v", "both"])
def test_triangulate_recovers_points_projected_by_opencv(which: str) -> None:
    from hdrfringe.core.stereo import triangulate

    pts = _scene_points(3000)
    uc, vc, up, vp = _pixels(pts)
    # the points cover the projector's field, corners (strongest distortion) included
    assert -20 < up.min() < 50 and 860 < up.max() < 932
    assert -20 < vp.min() < 50 and 1090 < vp.max() < 1160
    kw = {"u": {"u_proj": up}, "v": {"v_proj": vp}, "both": {"u_proj": up, "v_proj": vp}}[which]
    res = triangulate(synthetic_calibration(), uc, vc, **kw)
    assert res.xyz.shape == (3000, 3)
    assert np.abs(res.xyz - pts).max() < 1e-6
    if which == "both":
        assert res.residual_mm.max() < 1e-6
    else:
        assert np.all(np.isnan(res.residual_mm))
    # the same pixels with the projector's distortion ignored: off by far more than 1e-6 mm
    flat = synthetic_calibration(proj_distortion=np.zeros(5))
    wrong = triangulate(flat, uc, vc, **kw)
    assert np.nanmax(np.abs(wrong.xyz - pts)) > 1e-2


def test_triangulate_keeps_shape_and_marks_invalid_pixels() -> None:
    from hdrfringe.core.stereo import triangulate

    pts = _scene_points(12).reshape(3, 4, 3)
    uc, vc, up, vp = _pixels(pts.reshape(-1, 3))
    up, vp = up.reshape(3, 4), vp.reshape(3, 4)
    up[0, 0] = np.nan  # no phase
    uc = uc.reshape(3, 4)
    uc[1, 1] = np.nan
    res = triangulate(synthetic_calibration(), uc, vc.reshape(3, 4), u_proj=up)
    assert res.xyz.shape == (3, 4, 3) and res.residual_mm.shape == (3, 4)
    bad = np.zeros((3, 4), bool)
    bad[0, 0] = bad[1, 1] = True
    assert np.all(np.isnan(res.xyz[bad])) and np.all(np.isfinite(res.xyz[~bad]))
    assert np.abs(res.xyz[~bad] - pts[~bad]).max() < 1e-6
    both = triangulate(synthetic_calibration(), uc, vc.reshape(3, 4), u_proj=up, v_proj=vp)
    assert np.all(np.isnan(both.residual_mm[bad])) and np.all(both.residual_mm[~bad] < 1e-6)


def test_triangulate_ray_ray_residual_is_the_ray_distance() -> None:
    """A projector row moved by dv px: the rays miss by a distance computed by hand."""
    from hdrfringe.core.stereo import triangulate

    cam = LensModel([[1000, 0, 500], [0, 1000, 500], [0, 0, 1]], [], (1000, 1000))
    proj = LensModel([[1000, 0, 500], [0, 1000, 500], [0, 0, 1]], [], (1000, 1000))
    calib = StereoCalibration(cam, proj, np.eye(3), [-100.0, 0.0, 0.0])
    # camera ray along the optical axis; projector ray from (100, 0, 0) to (0, 0, 1000) in
    # direction (-0.1, 0, 1), lifted by dy = 0.01 -> the projector ray (-0.1, 0.01, 1)
    res = triangulate(calib, 500.0, 500.0, u_proj=400.0, v_proj=510.0)
    d1, d2, c = np.array([0, 0, 1.0]), np.array([-0.1, 0.01, 1.0]), np.array([100.0, 0, 0])
    n = np.cross(d1, d2)
    assert float(res.residual_mm) == pytest.approx(abs(c @ n) / np.linalg.norm(n), rel=1e-12)
    # the closest points: (0, 0, a) on the camera ray and c + b d2; the midpoint between them
    a, b = np.linalg.lstsq(np.stack([d1, -d2], 1), c, rcond=None)[0]
    assert np.allclose(res.xyz, 0.5 * (a * d1 + c + b * d2), rtol=1e-12)


def test_triangulate_rejects_bad_arguments() -> None:
    from hdrfringe.core.stereo import triangulate

    calib = synthetic_calibration()
    with pytest.raises(InputError, match="u_proj and/or v_proj"):
        triangulate(calib, 1.0, 2.0)
    with pytest.raises(InputError, match="do not broadcast"):
        triangulate(calib, np.zeros(3), np.zeros(4), u_proj=np.zeros(3))
    with pytest.raises(InputError, match="StereoCalibration"):
        triangulate("calib", 1.0, 2.0, u_proj=3.0)  # type: ignore[arg-type]


# --- plane and sphere fits ---------------------------------------------------------------------


def test_fit_plane_recovers_a_tilted_plane_and_is_least_squares() -> None:
    from hdrfringe.core.stereo import fit_plane

    rng = np.random.default_rng(4)
    normal = np.array([0.2, -0.1, -1.0])
    normal /= np.linalg.norm(normal)
    basis = np.linalg.svd(normal[None, :])[2][1:]  # two unit vectors in the plane
    on = rng.uniform(-100, 100, (4000, 2)) @ basis + 900.0 * -normal  # 900 mm from the origin
    noisy = on + rng.normal(0, 0.05, (4000, 1)) * normal
    grid = noisy.reshape(40, 100, 3).copy()
    grid[0, :5] = np.nan
    fit = fit_plane(grid)
    assert fit.residuals.shape == (40, 100) and np.all(np.isnan(fit.residuals[0, :5]))
    assert np.allclose(fit.normal, normal, atol=2e-4)
    assert fit.offset == pytest.approx(-900, abs=0.01)
    assert fit.rms_mm == pytest.approx(0.05, rel=0.05)
    # least squares: no small tilt of the normal lowers the sum of squared distances
    pts = grid[np.isfinite(grid[..., 0])]
    best = np.sum((pts @ fit.normal - fit.offset) ** 2)
    for k in range(3):
        n2 = fit.normal + 1e-4 * np.eye(3)[k]
        n2 /= np.linalg.norm(n2)
        assert np.sum((pts @ n2 - np.mean(pts @ n2)) ** 2) > best


def test_fit_plane_robust_ignores_an_object_on_the_plane() -> None:
    from hdrfringe.core.stereo import fit_plane

    rng = np.random.default_rng(5)
    xy = rng.uniform(-100, 100, (3000, 2))
    pts = np.c_[xy, 700.0 + rng.normal(0, 0.02, 3000)]
    box = (np.abs(xy[:, 0]) < 40) & (np.abs(xy[:, 1]) < 40)  # ~16 % of the points
    pts[box, 2] -= 25.0  # 25 mm toward the camera
    plain, robust = fit_plane(pts), fit_plane(pts, robust=True)
    assert plain.rms_mm > 5
    assert robust.offset == pytest.approx(-700.0, abs=0.01) and robust.rms_mm < 0.03
    assert not np.any(robust.inliers[box]) and robust.inliers[~box].mean() > 0.98  # 3 sigma
    assert np.allclose(robust.residuals[box], 25.0, atol=0.1)  # heights toward the camera


def test_fit_sphere_geometric_fit_of_a_noisy_cap() -> None:
    from hdrfringe.core.stereo import fit_sphere

    rng = np.random.default_rng(6)
    d = rng.normal(size=(5000, 3))
    d[:, 2] = -np.abs(d[:, 2]) - 1.0  # a cap facing the camera, about 70 degrees
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    centre, radius = np.array([12.0, -8.0, 720.0]), 25.4
    pts = centre + (radius + rng.normal(0, 0.05, (5000, 1))) * d
    fit = fit_sphere(pts)
    assert np.allclose(fit.centre, centre, atol=0.02)
    assert fit.radius == pytest.approx(radius, abs=0.02)
    assert fit.rms_mm == pytest.approx(0.05, rel=0.05)

    # least squares in the geometric distance: the gradient vanishes
    def cost(c: np.ndarray, r: float) -> float:
        return float(np.sum((np.linalg.norm(pts - c, axis=1) - r) ** 2))

    base = cost(fit.centre, fit.radius)
    for k in range(4):
        step = 1e-3 * np.eye(4)[k]
        assert cost(fit.centre + step[:3], fit.radius + step[3]) > base
        assert cost(fit.centre - step[:3], fit.radius - step[3]) > base


def test_fits_reject_degenerate_points() -> None:
    from hdrfringe.core.stereo import fit_plane, fit_sphere

    with pytest.raises(InputError, match="at least 3"):
        fit_plane(np.full((10, 3), np.nan))
    with pytest.raises(InputError, match="collinear"):
        fit_plane(np.c_[np.arange(5.0), np.arange(5.0), np.arange(5.0)])
    with pytest.raises(InputError, match="one plane"):
        fit_sphere(np.c_[np.random.default_rng(0).uniform(size=(20, 2)), np.ones(20)])
    with pytest.raises(InputError, match=r"shape \(\.\.\., 3\)"):
        fit_plane(np.zeros((4, 2)))


# --- measure with a stereo calibration (pipeline, outputs, CLI) ------------------------------

SMALL_CAM = LensModel(
    [[300.0, 0, 79.5], [0, 300.0, 59.5], [0, 0, 1]], [-0.1, 0.05, 0, 0], (160, 120)
)
SMALL_PROJ = LensModel(
    [[260.0, 0, 100.0], [0, 260.0, 75.0], [0, 0, 1]], [0.05, 0, 0, 0], (200, 150)
)


def small_calibration() -> StereoCalibration:
    r = _rotation(-0.15, 0.18, 0.0)  # a diagonal baseline: rows and columns both carry depth
    return StereoCalibration(SMALL_CAM, SMALL_PROJ, r, -r @ np.array([90.0, 70.0, 0.0]))


def small_scene() -> tuple[np.ndarray, np.ndarray]:
    """Camera rays of every pixel cast on a tilted wall at ~500 mm with a 20 mm box on it.

    Returns the true points (H, W, 3) and whether each is on the box. Rays from OpenCV's
    undistortPoints (the reference), intersected with the planes by hand.
    """
    rows, cols = np.mgrid[0:120, 0:160].astype(float)
    k = SMALL_CAM.matrix
    pix = np.stack([cols, rows], -1).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4.x (4.11: the last for numpy 1.x)
        und = cv2.undistortPointsIter(pix, k, SMALL_CAM.distortion, None, None, criteria)
    else:  # OpenCV 5: the criteria are a keyword of undistortPoints
        und = cv2.undistortPoints(pix, k, SMALL_CAM.distortion, criteria=criteria)
    und = und.reshape(120, 160, 2)
    ray = np.dstack([und, np.ones((120, 160))])
    n = np.array([0.1, -0.05, -1.0])
    n /= np.linalg.norm(n)
    wall = (n @ [0, 0, 500.0]) / (ray @ n)
    box = (n @ ([0, 0, 500.0] + 20.0 * n)) / (ray @ n)  # 20 mm toward the camera
    pts_wall, pts_box = ray * wall[..., None], ray * box[..., None]
    on_box = (np.abs(pts_box[..., 0]) < 40) & (np.abs(pts_box[..., 1] - 10) < 30)
    return np.where(on_box[..., None], pts_box, pts_wall), on_box


def small_captures(directions: str = "uv"):  # type: ignore[no-untyped-def]
    """16-bit captures of the scene: one-period and 10 px sets per decoded direction."""
    from hdrfringe.core.captures import Captures, ProjectorInfo
    from hdrfringe.core.patterns import FringeSpec, fringe_gray

    calib = small_calibration()
    pts, _ = small_scene()
    rvec = cv2.Rodrigues(calib.rotation)[0]
    img, _ = cv2.projectPoints(pts.reshape(-1, 3), rvec, calib.translation_mm,
                               SMALL_PROJ.matrix, SMALL_PROJ.distortion)  # fmt: skip
    u, v = img[:, 0, 0].reshape(120, 160), img[:, 0, 1].reshape(120, 160)
    frames, images = [], []
    for key, coord, extent, orient in (("u", u, 200, "vertical"), ("v", v, 150, "horizontal")):
        if key not in directions:
            continue
        for pitch in (float(extent), 10.0):
            spec = FringeSpec("sinusoidal", 4, pitch, orient, 2000, 60000)  # type: ignore[arg-type]
            for f in spec.frames():
                frames.append(f)
                images.append(np.rint(fringe_gray(coord, spec, f.shift)).astype(np.uint16))
    return Captures(frames, np.stack(images), 16, projector=ProjectorInfo(200, 150, 16))


@pytest.mark.parametrize("directions", ["u", "v", "uv"])
def test_measure_triangulates_against_the_ray_cast_scene(directions: str) -> None:
    from hdrfringe.pipeline import measure

    truth, on_box = small_scene()
    res = measure(small_captures(directions), small_calibration())
    assert res.stereo is not None and res.metrics.model == "stereo"
    err = np.linalg.norm(res.stereo.xyz - truth, axis=-1)
    ok = np.isfinite(err)
    # 16-bit fringes, no noise: rounding only (measured: median 1-2e-4 mm, max 6e-4 mm)
    assert ok.mean() > 0.99 and np.median(err[ok]) < 1e-3 and np.percentile(err[ok], 99) < 2e-3
    # the height over the robust reference plane: the wall at 0, the box at +20 mm
    h = res.height_mm
    assert h is not None
    assert np.nanmedian(np.abs(h[~on_box])) < 0.01
    assert np.nanmedian(h[on_box]) == pytest.approx(20.0, abs=0.005)
    summary = res.metrics.to_dict()["stereo"]
    assert summary["directions"] == "+".join(directions)
    assert ("triangulation_residual_mm" in summary) == (directions == "uv")
    if directions == "uv":
        assert summary["triangulation_residual_mm"]["median"] < 1e-3


def test_measure_refuses_a_stereo_calibration_of_another_size() -> None:
    from hdrfringe.core.calibration import CalibrationMismatchError
    from hdrfringe.pipeline import measure

    calib = small_calibration()
    other = StereoCalibration(
        LensModel(SMALL_CAM.matrix, [], (320, 240)), calib.projector, calib.rotation,
        calib.translation_mm,
    )  # fmt: skip
    with pytest.raises(
        CalibrationMismatchError, match=r"camera image 160x120 vs calibrated \(320, 240\)"
    ):
        measure(small_captures("u"), other)
    other = StereoCalibration(
        calib.camera, LensModel(SMALL_PROJ.matrix, [], (400, 150)), calib.rotation,
        calib.translation_mm,
    )  # fmt: skip
    with pytest.raises(CalibrationMismatchError, match="projector 200x150"):
        measure(small_captures("u"), other)


def test_cli_measure_with_a_stereo_calibration_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import json

    import tifffile
    from plyfile import PlyData

    from hdrfringe.io.captures import write_capture_folder
    from hdrfringe.io.stereo_file import save_stereo_calibration
    from tests.conftest import run_cli

    caps = write_capture_folder(tmp_path / "caps", small_captures("uv"))
    cal = save_stereo_calibration(tmp_path / "stereo.h5", small_calibration())
    out = tmp_path / "out"
    res = run_cli("measure", str(caps), "-c", str(cal), "-o", str(out))
    assert res.returncode == 0, res.stderr
    assert "triangulated" in res.stdout and "ray-ray residual" in res.stdout
    truth, _ = small_scene()
    xyz = tifffile.imread(out / "xyz.tiff")
    assert xyz.shape == (120, 160, 3) and xyz.dtype == np.float32
    assert np.nanmedian(np.linalg.norm(xyz - truth, axis=-1)) < 0.01
    depth = tifffile.imread(out / "depth.tiff")
    np.testing.assert_array_equal(depth, xyz[..., 2])
    for name in ("height.tiff", "height.png", "triangulation_residual.tiff"):
        assert (out / name).is_file()
    ply = PlyData.read(str(out / "points.ply"))["vertex"]
    assert ply.count == int(np.isfinite(xyz).all(-1).sum())
    assert float(np.median(ply["intensity"])) > 1000  # modulation in DN of 16-bit fringes
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["model"] == "stereo"
    assert metrics["stereo"]["reference_plane"]["rms_mm"] < 0.01


def test_measure_without_an_absolute_phase_cannot_triangulate() -> None:
    from hdrfringe.core.captures import Captures
    from hdrfringe.errors import CaptureFormatError
    from hdrfringe.pipeline import measure

    caps = small_captures("u")
    fine = [i for i, f in enumerate(caps.frames) if f.spec.pitch_px == 10.0]  # type: ignore[attr-defined]
    only_fine = Captures(
        [caps.frames[i] for i in fine], caps.images[fine], 16, projector=caps.projector
    )
    with pytest.raises(CaptureFormatError, match="cannot triangulate: no fringe family has an"):
        measure(only_fine, small_calibration())


@pytest.mark.parametrize("only", ["u", "v"])
def test_measure_stereo_directions_uses_one_coordinate(only: str) -> None:
    """With both directions decoded, ``stereo_directions`` triangulates with one alone (the
    kimthyung sphere's rows: docs/stereo.md); a direction that was not decoded is refused."""
    from hdrfringe.errors import CaptureFormatError
    from hdrfringe.pipeline import measure

    truth, _ = small_scene()
    res = measure(small_captures("uv"), small_calibration(), stereo_directions=only)
    assert res.stereo is not None
    summary = res.metrics.to_dict()["stereo"]
    assert summary["directions"] == only and "triangulation_residual_mm" not in summary
    err = np.linalg.norm(res.stereo.xyz - truth, axis=-1)
    assert np.median(err[np.isfinite(err)]) < 1e-3
    other = "v" if only == "u" else "u"
    which = "horizontal" if only == "v" else "vertical"
    with pytest.raises(CaptureFormatError, match=f"cannot triangulate: no {which} fringe family"):
        measure(small_captures(other), small_calibration(), stereo_directions=only)


def test_cli_measure_refuses_unknown_stereo_directions(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from hdrfringe.io.captures import write_capture_folder
    from hdrfringe.io.stereo_file import save_stereo_calibration
    from tests.conftest import run_cli

    caps = write_capture_folder(tmp_path / "caps", small_captures("u"))
    cal = save_stereo_calibration(tmp_path / "stereo.h5", small_calibration())
    out = tmp_path / "out"
    res = run_cli("measure", str(caps), "-c", str(cal), "--stereo-directions", "w", "-o", str(out))
    assert res.returncode == 2
    assert "stereo_directions 'w' is unknown; give one of auto, u, v" in res.stderr
    assert not out.exists()
