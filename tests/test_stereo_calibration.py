"""Projector-camera (stereo) calibration on the virtual rig (issue 12 points 5 and 7).

The truth is the simulator's own geometry (:meth:`RigGeometry.stereo_calibration`), checked
here against the simulator's traced pixel and projector coordinates, never produced by the
calibration under test.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from hdrfringe.core.stereo import triangulate
from hdrfringe.core.stereo_calibration import (
    BoardPose,
    BoardSpec,
    calibrate_stereo,
    detect_board,
    map_to_projector,
    observe_pose,
    projector_coordinates,
)
from hdrfringe.io.stereo_file import load_stereo_calibration
from hdrfringe.rig.board_poses import (
    CALIBRATION_GEOMETRY,
    board_program,
    calibration_rig,
    capture_board_poses,
    default_board_poses,
)
from hdrfringe.rig.scenes import board, mask, plate, scene_from_manifest
from hdrfringe.rig.simulated import CameraModel, ProjectorModel, RigGeometry, SimulatedRig
from hdrfringe.tasks.calibrate_stereo import report_path
from tests.conftest import run_cli

SPEC = BoardSpec.parse("checkerboard:9x6:25")
# one worker simulates and observes the poses (module fixtures) once
pytestmark = pytest.mark.xdist_group("stereo-calibration")


def _camera_frame(geometry: RigGeometry, xyz: np.ndarray) -> np.ndarray:
    rot, t = geometry.world_to_camera()
    return xyz @ rot.T + t


# --- 1. the exported geometry is the simulator's ------------------------------------------------


@pytest.mark.parametrize(
    ("geometry", "scene"),
    [
        (RigGeometry(), mask()),
        (CALIBRATION_GEOMETRY, board(centre_mm=(10, -5, 30), tilt_x_deg=30, tilt_y_deg=-20)),
        (RigGeometry(standoff_mm=800, angle_deg=-25, projector_distance_mm=900), mask()),
    ],
)
def test_exported_geometry_reprojects_the_simulators_pixels(geometry, scene) -> None:
    """Traced surface points projected through the exported lenses land on the simulator's
    own pixel centres (camera) and on its traced projector coordinates, to 1e-9 px.
    Rejects: a principal point at W/2 instead of (W-1)/2, a flipped row axis, R or t of the
    inverse motion (X_cam = R X_proj + t), the projector axes transposed."""
    cam = CameraModel(width=64, height=48)
    proj = ProjectorModel(width=320, height=200)
    rig = SimulatedRig(scene, camera=cam, projector_model=proj, geometry=geometry)
    truth = rig.truth()
    calib = rig.stereo_calibration()
    ok = truth.valid
    assert ok.mean() > 0.5
    xyz = np.stack([truth.x_mm, truth.y_mm, truth.height_mm], axis=-1)[ok]
    pc = _camera_frame(geometry, xyz)
    u, v = calib.camera.project(pc)
    rows, cols = np.nonzero(ok)
    assert np.abs(u - cols).max() < 1e-9
    assert np.abs(v - rows).max() < 1e-9
    pp = pc @ calib.rotation.T + calib.translation_mm
    up, vp = calib.projector.project(pp)
    assert np.abs(up - truth.u[ok]).max() < 1e-9
    assert np.abs(vp - truth.v[ok]).max() < 1e-9
    assert np.allclose(
        calib.projector_center_mm, _camera_frame(geometry, geometry.projector_center)
    )


def test_board_scene_truth_and_manifest() -> None:
    """The board's corners lie on its heightfield, its reflectivity is the printed pattern,
    and the scene rebuilds from its manifest entry (as capture folders store it)."""
    b = board(cols=5, rows=4, spacing_mm=20, centre_mm=(5, 5, 40), tilt_x_deg=35, spin_deg=10)
    pts = b.corners_world()
    assert np.allclose(b.height(pts[:, 0], pts[:, 1]), pts[:, 2])
    s, t = b.board_coordinates(pts[:, 0], pts[:, 1])
    assert np.allclose(np.stack([s, t, 0 * s], axis=1), b.object_points())
    # centres of squares: (i, j) = (-1, -1) black, (0, -1) white; far outside: white margin
    centres = b.board_to_world([[-10.0, -10.0, 0.0], [10.0, -10.0, 0.0], [500.0, 0.0, 0.0]])
    refl = b.reflectivity(centres[:, 0], centres[:, 1])
    assert refl.tolist() == [0.3, 0.9, 0.9]
    assert scene_from_manifest(b.to_manifest()) == b
    # antialiasing: on an edge the footprint average is the mean of the two colours
    soft = board(cols=5, rows=4, spacing_mm=20, footprint_mm=2.0)
    edge = soft.board_to_world([[0.0, 10.0, 0.0]])
    assert soft.reflectivity(edge[:, 0], edge[:, 1]).tolist() == pytest.approx([0.6])


# --- 2. calibration from 10 poses at sigma 1 DN -------------------------------------------------


@pytest.fixture(scope="session")  # kept across modules: xdist may interleave other modules
def observed():
    boards = default_board_poses(10)
    caps = capture_board_poses(boards, noise=1.0, seed=4)
    poses = [observe_pose(c, SPEC, name=f"pose_{k:02d}") for k, c in enumerate(caps)]
    truth = calibration_rig(boards[0]).stereo_calibration()
    return boards, caps, poses, truth


@pytest.fixture(scope="session")  # kept across modules: xdist may interleave other modules
def calibrated(observed):
    _, _, poses, _ = observed
    return calibrate_stereo(poses, SPEC, (640, 480), (800, 600))


def test_detected_corners_match_the_true_corners(observed) -> None:
    """The board scene and the detector agree: detected corners within 0.1 px RMS of the
    true corners projected by the exported camera (rejects a board drawn half a square off,
    or aliased edges that bias the corners)."""
    boards, _, poses, truth = observed
    errs = []
    for b, p in zip(boards, poses, strict=True):
        u, v = truth.camera.project(_camera_frame(CALIBRATION_GEOMETRY, b.corners_world()))
        expect = np.stack([u, v], axis=1)
        got = p.camera_points
        if np.linalg.norm(got[0] - expect[0]) > np.linalg.norm(got[0] - expect[-1]):
            got = got[::-1]  # the detector may start from the opposite corner
        errs.append(got - expect)
    rms = float(np.sqrt(np.mean(np.sum(np.concatenate(errs) ** 2, axis=1))))
    assert rms < 0.1


def test_projector_points_match_truth(observed) -> None:
    """Corners mapped into the projector by local homographies are within 0.05 px RMS of the
    projector's view of the detected camera corners (truth from the exported geometry, the
    board plane known). Rejects: rounding the corner to the nearest pixel's phase (the broken
    variant below is about 0.2 px off)."""
    boards, caps, poses, truth = observed
    errs, naive = [], []
    for b, c, p in zip(boards, caps, poses, strict=True):
        # ray of each detected corner intersected with the true board plane
        x, y = truth.camera.undistort(p.camera_points[:, 0], p.camera_points[:, 1])
        rays = np.stack([x, y, np.ones_like(x)], axis=1)
        plane_pts = _camera_frame(CALIBRATION_GEOMETRY, b.corners_world())
        n = np.cross(plane_pts[1] - plane_pts[0], plane_pts[b.cols] - plane_pts[0])
        depth = (plane_pts[0] @ n) / (rays @ n)
        pts = rays * depth[:, None]
        up, vp = truth.projector.project(pts @ truth.rotation.T + truth.translation_mm)
        expect = np.stack([up, vp], axis=1)
        assert p.mapped.all()
        errs.append(p.projector_points - expect)
        u, v = projector_coordinates(c)
        r = np.rint(p.camera_points).astype(int)
        naive.append(np.stack([u[r[:, 1], r[:, 0]], v[r[:, 1], r[:, 0]]], axis=1) - expect)
    rms = float(np.sqrt(np.mean(np.sum(np.concatenate(errs) ** 2, axis=1))))
    rms_naive = float(np.sqrt(np.nanmean(np.sum(np.concatenate(naive) ** 2, axis=1))))
    assert rms < 0.05
    assert rms_naive > 0.1  # what the accuracy targets below reject


def test_calibration_recovers_the_true_geometry(calibrated, observed) -> None:
    """Issue 12, Done when: focal lengths within 0.2 %, principal points within 1 px, the
    baseline within 0.2 %, reprojection errors under 0.1 px at sigma 1 DN.

    Rejects the broken variant that skips the local homography and takes the phase of the
    corner's nearest pixel (measured on these poses: projector RMS 0.40 px, stereo 0.29 px,
    principal points 2.4 px (camera) and 3.5 px (projector) off)."""
    truth = observed[3]
    calib = calibrated.calibration
    for lens, true in ((calib.camera, truth.camera), (calib.projector, truth.projector)):
        f, ft = lens.matrix[[0, 1], [0, 1]], true.matrix[[0, 1], [0, 1]]
        assert np.abs(f / ft - 1).max() < 0.002, (f, ft)
        assert np.abs(lens.matrix[:2, 2] - true.matrix[:2, 2]).max() < 1.0
    assert abs(calib.baseline_mm / truth.baseline_mm - 1) < 0.002
    rot_err = np.degrees(
        np.arccos(np.clip((np.trace(calib.rotation.T @ truth.rotation) - 1) / 2, -1, 1))
    )
    assert rot_err < 0.05
    rep = calib.reprojection_px
    assert max(rep["camera"], rep["projector"], rep["stereo"]) < 0.1
    for pose in calibrated.poses:
        # per pose the corner noise shows more (about 0.12 px at worst, the facing pose);
        # the target is on the calibration's errors above
        assert pose.used and not pose.flagged
        assert max(pose.camera_rms_px, pose.projector_rms_px, pose.stereo_rms_px) < 0.15


def test_bad_pose_is_flagged(observed) -> None:
    """A pose whose projector points are shifted by 2 px (a wrong fringe order, say) is
    flagged by the rule max(3 x median, 0.5 px); the others are not."""
    _, _, poses, _ = observed
    bad = [
        BoardPose(p.name, p.camera_points, p.projector_points, p.homography_residual_px)
        for p in poses
    ]
    bad[3].projector_points = bad[3].projector_points + np.where(
        np.arange(len(bad[3].projector_points))[:, None] % 2 == 0, 2.0, 0.0
    )
    result = calibrate_stereo(bad, SPEC, (640, 480), (800, 600))
    assert result.flagged == ["pose_03"]


def test_too_few_poses_and_no_board() -> None:
    """Fewer than 3 usable poses is refused with the reason per pose."""
    poses = [BoardPose(f"p{k}", None, None, None, ["board not found"]) for k in range(4)]
    with pytest.raises(Exception, match="at least 3 usable board poses, got 0 of 4"):
        calibrate_stereo(poses, SPEC, (640, 480), (800, 600))
    assert detect_board(np.full((48, 64), 100, np.uint8), SPEC) is None


def test_map_to_projector_rejects_sparse_windows() -> None:
    """A corner whose window is mostly invalid phase is rejected, not extrapolated."""
    yy, xx = np.mgrid[0:50, 0:60].astype(float)
    u, v = 2 * xx, 3 * yy
    u[:, 25:] = np.nan
    mapped, res = map_to_projector([[10.0, 20.0], [40.0, 20.0], [28.0, 20.0]], u, v, half_window=6)
    assert np.allclose(mapped[0], [20.0, 60.0])
    assert np.isnan(mapped[1]).all() and np.isnan(res[1])
    assert np.isnan(mapped[2]).all()  # 10 of 13 columns invalid


def _rigid_aligned_rms(points: np.ndarray, truth: np.ndarray) -> float:
    """RMS distance after the best rigid motion of ``points`` onto ``truth`` (Kabsch, SVD)."""
    pc, qc = points.mean(axis=0), truth.mean(axis=0)
    u, _, vt = np.linalg.svd((points - pc).T @ (truth - qc))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    moved = (points - pc) @ rot.T + qc
    return float(np.sqrt(np.mean(np.sum((moved - truth) ** 2, axis=1))))


@pytest.mark.parametrize(
    "scene",
    [
        pytest.param(plate(20.0, 0.9), id="plate_20mm"),
        pytest.param(plate(-40.0, 0.9), id="plate_-40mm"),
        pytest.param(
            board(centre_mm=(0, 0, 10), tilt_x_deg=20, tilt_y_deg=-15, black_reflectivity=0.9),
            id="tilted_plane",
        ),
    ],
)
def test_triangulated_plate_matches_truth(calibrated, scene) -> None:
    """Issue 12, Done when: plate points triangulated (``hdrfringe.core.stereo.triangulate``, camera
    ray against the projector column) with the calibration from the 10 noisy poses lie within
    0.05 mm RMS of the true surface points.

    The comparison is made after the best rigid motion: the calibration defines its own camera
    frame, which may be turned from the true one by the principal-point error the targets allow
    (1 px is 1/960 rad, 0.6 mm across at 600 mm); the test checks the measured shape and scale.
    The plate itself is captured without noise so that the number measures the calibration, not
    the plate's own phase noise (0.07 mm RMS per pixel at 1 DN, even with the true geometry).
    Rejects: the SB corners without the cornerSubPix refinement (0.06 mm on the 20 mm plate,
    measured while choosing the refinement), the inverse motion.
    """
    rig = calibration_rig(scene, noise=0.0)
    caps = rig.capture_folder(board_program(rig.projector))
    u, v = projector_coordinates(caps)
    yy, xx = np.mgrid[0 : u.shape[0], 0 : u.shape[1]].astype(float)
    # the coarse phase wraps at the projector's left edge (u ~ 0): keep clear of its border
    inner = (u > 2) & (u < 797) & (v > 2) & (v < 597)
    points = triangulate(calibrated.calibration, xx, yy, u_proj=u).xyz
    truth = rig.truth()
    true = _camera_frame(rig.geometry, np.stack([truth.x_mm, truth.y_mm, truth.height_mm], axis=-1))
    ok = inner & np.all(np.isfinite(points), axis=-1) & truth.valid
    assert ok.mean() > 0.8
    assert _rigid_aligned_rms(points[ok], true[ok]) < 0.05
    # and without alignment the frame error stays within what the targets allow
    assert np.sqrt(np.mean(np.sum((points[ok] - true[ok]) ** 2, axis=1))) < 1.5


# --- 3. the command ------------------------------------------------------------------------------

CIRCLES = "circles:9x6:25"


@pytest.fixture(scope="session")  # kept across modules: xdist may interleave other modules
def sim_run(tmp_path_factory: pytest.TempPathFactory):
    """``calibrate-stereo --rig sim`` on 3 circle-grid poses, keeping the pose folders."""
    root = tmp_path_factory.mktemp("sim")
    out, poses = root / "sim.h5", root / "poses"
    res = run_cli(
        "calibrate-stereo", "--rig", "sim", "--poses", "3", "--board", CIRCLES,
        "--save-poses", str(poses), "-o", str(out),
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    return out, sorted(poses.iterdir())


def _assert_refused(res, out, *needles: str) -> None:
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    assert "Traceback" not in res.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    assert not out.exists() and not report_path(out).exists()
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".")]


def test_cli_virtual_rig_reports_errors_against_truth(sim_run) -> None:
    """``--rig sim``: the report holds per-pose errors and the errors against the rig's true
    geometry (3 poses: loose bounds, the accuracy targets are tested above on 10)."""
    out, folders = sim_run
    report = json.loads(report_path(out).read_text())
    assert [p["name"] for p in report["poses"]] == [str(f) for f in folders]
    assert report["errors_vs_truth"]["baseline_error_percent"] < 0.5
    assert report["reprojection_rms_px"]["stereo"] < 0.1
    assert load_stereo_calibration(out).baseline_mm == pytest.approx(
        report["calibration"]["baseline_mm"]
    )


def test_cli_calibrates_pose_folders_and_converts(sim_run, tmp_path) -> None:
    """The saved pose folders calibrate to the same result as the run that wrote them; a
    second run without --force is refused; ``--from`` converts (here: reads back) a file."""
    sim_out, folders = sim_run
    out = tmp_path / "stereo.h5"
    args = [*map(str, folders), "--board", CIRCLES, "-o", str(out)]
    res = run_cli("calibrate-stereo", *args)
    assert res.returncode == 0, res.stderr
    back, sim = load_stereo_calibration(out), load_stereo_calibration(sim_out)
    assert np.allclose(back.translation_mm, sim.translation_mm, atol=1e-9)
    again = run_cli("calibrate-stereo", *args)
    assert again.returncode == 2 and "exists" in again.stderr
    conv = tmp_path / "copy.h5"
    res = run_cli("calibrate-stereo", "--from", str(out), "-o", str(conv))
    assert res.returncode == 0, res.stderr
    assert load_stereo_calibration(conv).baseline_mm == pytest.approx(back.baseline_mm)


def test_cli_board_not_found_in_any_pose(sim_run, tmp_path) -> None:
    """A board that is not detected in any pose (here: more dots than the board has; fewer
    would find a sub-grid, which is a valid target)."""
    _, folders = sim_run
    out = tmp_path / "stereo.h5"
    res = run_cli(
        "calibrate-stereo", *map(str, folders), "--board", "circles:10x7:25", "-o", str(out)
    )
    _assert_refused(res, out, "not found in any of the 3 poses")


def test_cli_fewer_poses_than_needed(sim_run, tmp_path) -> None:
    """Two poses are fewer than the 3 a calibration needs: refused before any reading."""
    _, folders = sim_run
    out = tmp_path / "stereo.h5"
    res = run_cli("calibrate-stereo", *map(str, folders[:2]), "--board", CIRCLES, "-o", str(out))
    _assert_refused(res, out, "at least 3")


def test_detection_does_not_depend_on_what_ran_before() -> None:
    # findChessboardCornersSB draws from OpenCV's global RNG: unseeded, this board was missed
    # at 6 of 200 consecutive calls (and the doctest failed in a loaded test worker).
    import cv2

    from hdrfringe.core.stereo_calibration import BoardSpec, detect_board

    yy, xx = np.mgrid[0:120, 0:160]
    img = np.where(((xx - 20) // 20 + (yy - 20) // 20) % 2 == 0, 60, 200)
    img[(xx < 20) | (xx >= 140) | (yy < 20) | (yy >= 100)] = 200
    board = BoardSpec("checkerboard", 5, 3, 10.0)
    cv2.setRNGSeed(12345)
    first = detect_board(img, board)
    assert first is not None
    for _ in range(200):
        pts = detect_board(img, board)
        assert pts is not None and np.array_equal(pts, first)
