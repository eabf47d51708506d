"""Triangulation of real captures with the projector-camera calibrations they ship (issue 12).

thomriiii checkerboard (``dec2025_checkerboard_saturated_4step`` with ``calibration_dec2025``):
the conventions are found from the data and the calibration, not copied from the other
project (docs/stereo.md, "thomriiii checkerboard"):

* the direction of the stored extrinsics and the u/v mapping: the local camera -> projector
  Jacobian predicted by the calibration against the decoded one;
* the fringe order of the F = 4 sets (spatial unwrapping leaves it open): the row order from
  the epipolar geometry, the column order from the board itself (its squares must come out
  square, and at the scale and tilt that the camera alone sees);
* then the flat board's plane fit, clipped and unclipped pixels separately, beside the other
  project's own points.

Every test is marked ``realdata`` and skips when ``../shared/realdata`` is absent. Prints lines
``[realdata]`` with the measured numbers (``pytest -s``).
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.ndimage import map_coordinates

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set
from hdrfringe.core.stereo import (
    StereoCalibration,
    fit_plane,
    projector_coordinate,
    triangulate,
    triangulate_maps,
)
from hdrfringe.core.unwrap import unwrap_spatial, unwrap_temporal_levels
from hdrfringe.io.captures import load_image
from hdrfringe.io.stereo_file import convert_calibration
from tests.conftest import realdata_path

# one worker computes the module fixtures (the measured sphere, the decoded board) once
pytestmark = [pytest.mark.realdata, pytest.mark.xdist_group("stereo-realdata")]

TWO_PI = 2.0 * np.pi
CHECKER = ("thomriiii", "dec2025_checkerboard_saturated_4step")
CALIB = ("thomriiii", "calibration_dec2025")
FREQS = (4, 8, 16, 32)
PREFIX = {"vertical": "scan", "horizontal": "scanh"}
#: F periods across the projector's width (vertical fringes) and height (horizontal ones):
#: the height, not the width, is what the Jacobian test below finds for horizontal fringes.
EXTENT = {"vertical": 1920, "horizontal": 1080}
#: sin(t) = cos(t - pi/2): our decoder returns 2*pi*F*x - pi/2 (docs/realdata.md).
SINE_OFFSET = np.pi / 2


def measured(what: str, value: object) -> None:
    """Print a measured number (shown with ``pytest -s``; docs/stereo.md quotes them)."""
    print(f"[realdata] {what}: {value}")


@pytest.fixture(scope="session")  # kept across modules: xdist may interleave other modules
def checker() -> dict[str, np.ndarray]:
    """Projector coordinates up to the F = 4 fringe order, and the clipped pixels.

    ``u0``/``v0``: projector column/row (pattern px) with the F = 4 set spatially unwrapped
    (its order is fixed only up to an integer k: the true coordinate is ``u0 + k*1920/4``,
    ``v0 + k*1080/4``), the finer sets temporally; ``clipped``: a pixel at 255 in any shift of
    any set of either orientation.
    """
    root = realdata_path(*CHECKER) / "images"
    out: dict[str, np.ndarray] = {}
    clipped = np.zeros((720, 1280), bool)
    for orientation, prefix in PREFIX.items():
        pitches = [EXTENT[orientation] / f for f in FREQS]
        phis = []
        for f, p in zip(FREQS, pitches, strict=True):
            files = [root / f"{prefix}_f{f:03d}_n{k:02d}.png" for k in range(4)]
            spec = FringeSpec("sinusoidal", 4, p, orientation, 0, 255)  # type: ignore[arg-type]
            res = decode_set(np.stack([load_image(x, 8) for x in files]), spec, 8,
                             reject_saturated=False)  # fmt: skip
            clipped |= res.saturation_count > 0
            phis.append(
                np.where(res.valid, np.mod(res.wrapped_phase + SINE_OFFSET, TWO_PI), np.nan)
            )
        levels = unwrap_temporal_levels(
            [unwrap_spatial(phis[0]), *phis[1:]], pitches, coarse_unwrapped=True
        )
        key = "u0" if orientation == "vertical" else "v0"
        out[key] = projector_coordinate(levels.phase, pitches[-1])
    out["clipped"] = clipped
    return out


@pytest.fixture(scope="session")  # kept across modules: xdist may interleave other modules
def calibration() -> StereoCalibration:
    return convert_calibration(realdata_path(*CALIB))


@pytest.fixture(scope="session")  # kept across modules: xdist may interleave other modules
def corners() -> np.ndarray:
    """The board's 8 x 6 inner corners (camera px), from the mean of the F = 32 shifts."""
    root = realdata_path(*CHECKER) / "images"
    mean = np.mean([load_image(root / f"scan_f032_n{k:02d}.png", 8) for k in range(4)], axis=0)
    gray = np.clip(mean, 0, 255).astype(np.uint8)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    found, pts = cv2.findChessboardCorners(gray, (8, 6), flags=flags)
    assert found
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 50, 1e-3)
    return np.asarray(cv2.cornerSubPix(gray, pts, (5, 5), (-1, -1), crit)).reshape(-1, 2)


def _jacobian(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """d(u, v)/d(col, row) of projector-coordinate maps, least squares over the centre."""
    rows, cols = np.mgrid[300:420, 540:740]
    out = []
    for m in (u, v):
        z = m[rows, cols]
        ok = np.isfinite(z)
        a = np.c_[cols[ok], rows[ok], np.ones(ok.sum())]
        out.append(np.linalg.lstsq(a, z[ok], rcond=None)[0][:2])
    return np.array(out)


def _predicted_jacobian(calib: StereoCalibration, depth_mm: float) -> np.ndarray:
    """The same from the calibration (pinhole part) for a fronto-parallel plane at a depth."""
    k, kp = calib.camera.matrix, calib.projector.matrix

    def to_projector(col: float, row: float) -> np.ndarray:
        x = np.linalg.solve(k, [col, row, 1.0]) * depth_mm
        xp = calib.rotation @ x + calib.translation_mm
        return (kp @ (xp / xp[2]))[:2]

    p0 = to_projector(640, 360)
    return np.c_[to_projector(641, 360) - p0, to_projector(640, 361) - p0]


def test_checkerboard_extrinsics_direction_and_uv_mapping(checker, calibration) -> None:  # type: ignore[no-untyped-def]
    """The converted calibration predicts the decoded camera -> projector Jacobian; the file's
    R, T read as camera -> projector (and any flip or swap of u, v) do not.

    Measured: decoded [[0.519, 0.180], [-0.157, 0.536]] projector px per camera px;
    predicted 0.52/0.15/-0.16/0.54 at 500-800 mm; the stored direction predicts
    [[0.42, -0.13], [0.13, 0.44]] (the roll of the projector turned the other way).
    """
    decoded = _jacobian(checker["u0"], checker["v0"])
    measured("checkerboard decoded Jacobian d(u,v)/d(col,row)", decoded.round(3).tolist())
    stored = StereoCalibration(
        calibration.camera, calibration.projector, calibration.rotation.T,
        -calibration.rotation.T @ calibration.translation_mm,
    )  # fmt: skip
    flips = {
        "u, v": np.diag([1.0, 1.0]),
        "flip u": np.diag([-1.0, 1.0]),
        "flip v": np.diag([1.0, -1.0]),
        "flip both": np.diag([-1.0, -1.0]),
        "swap": np.array([[0.0, 1.0], [1.0, 0.0]]),
        "swap, flip u": np.array([[0.0, -1.0], [1.0, 0.0]]),
        "swap, flip v": np.array([[0.0, 1.0], [-1.0, 0.0]]),
    }
    for depth in (500.0, 650.0, 800.0):
        ours = _predicted_jacobian(calibration, depth)
        measured(f"checkerboard predicted Jacobian at {depth:g} mm", ours.round(3).tolist())
        assert np.abs(ours - decoded).max() < 0.05
        for name, m in flips.items():
            other = m @ _predicted_jacobian(stored, depth)
            assert np.abs(other - decoded).max() > 0.2, (name, depth)
        # horizontal fringes counted across the width (1920) instead of the height: 1.8x
        assert np.abs(ours[1] * 1920 / 1080 - decoded[1]).max() > 0.3


def _epipolar_px(calib: StereoCalibration, uc, vc, u, v) -> float:  # type: ignore[no-untyped-def]
    """Median distance (projector px) between (u, v) and the projection of the ray-ray point."""
    tri = triangulate(calib, uc, vc, u_proj=u, v_proj=v)
    pu, pv = calib.projector.project(tri.xyz @ calib.rotation.T + calib.translation_mm)
    return float(np.nanmedian(np.hypot(pu - u, pv - v)))


@pytest.fixture(scope="session")  # kept across modules: xdist may interleave other modules
def orders(checker, calibration, corners) -> dict[str, object]:  # type: ignore[no-untyped-def]
    """The F = 4 fringe orders (kv from the epipolar geometry, ku from the board's squares)."""
    rows, cols = np.mgrid[0:720:8, 0:1280:8]
    uc, vc = cols.ravel().astype(float), rows.ravel().astype(float)
    u0, v0 = checker["u0"][rows, cols].ravel(), checker["v0"][rows, cols].ravel()
    epipolar = {
        (ku, kv): _epipolar_px(calibration, uc, vc, u0 + 480 * ku, v0 + 270 * kv)
        for ku in range(4)
        for kv in range(4)
    }
    kv_best = {ku: min(range(4), key=lambda kv: epipolar[ku, kv]) for ku in range(4)}
    # the board: 8 x 6 corners; camera-only pose (PnP, squares of 1) for tilt and scale
    obj = np.zeros((48, 3))
    obj[:, :2] = np.mgrid[0:8, 0:6].T.reshape(-1, 2)
    cam = calibration.camera
    _, rvec, tvec = cv2.solvePnP(obj, corners, cam.matrix, cam.distortion)
    normal_cam = cv2.Rodrigues(rvec)[0][:, 2]
    cu, cv_ = corners[:, 0].astype(float), corners[:, 1].astype(float)
    cu0 = map_coordinates(checker["u0"], [cv_, cu], order=1)
    cv0 = map_coordinates(checker["v0"], [cv_, cu], order=1)
    board = {}
    for ku in range(4):
        kv = kv_best[ku]
        pts = triangulate(calibration, cu, cv_, u_proj=cu0 + 480 * ku, v_proj=cv0 + 270 * kv).xyz
        grid = pts.reshape(6, 8, 3)
        along_rows = np.linalg.norm(np.diff(grid, axis=1), axis=-1).mean()
        along_cols = np.linalg.norm(np.diff(grid, axis=0), axis=-1).mean()
        if not np.all(np.isfinite(pts)):
            board[ku] = {"aspect": np.inf}
            continue
        n = fit_plane(pts).normal
        board[ku] = {
            "square_mm": 0.5 * (along_rows + along_cols),
            "aspect": along_rows / along_cols,
            "tilt_deg": float(np.degrees(np.arccos(min(1.0, abs(n @ normal_cam))))),
            "pnp_square_mm": float(np.mean(grid[..., 2]) / tvec[2, 0]),
        }
    ku = min(range(4), key=lambda k: abs(np.log(board[k]["aspect"])))
    return {"ku": ku, "kv": kv_best[ku], "kv_best": kv_best, "epipolar": epipolar, "board": board}


def test_checkerboard_fringe_orders_from_epipolar_geometry_and_board(orders) -> None:  # type: ignore[no-untyped-def]
    """kv: the row order with the smallest epipolar distance, the same for every column
    order (measured 10 px at kv = 2 vs 130-170 px); ku: the only column order whose
    triangulated board has square squares, 10 mm (the camera's own PnP scale agrees), tilted
    like the camera alone sees it (measured 10.30 x 10.09 mm, PnP 10.01 mm, 4.8 degrees;
    ku = 3 gives 11.8 x 7.0 mm at 59 degrees, ku = 1 nonsense)."""
    for (ku, kv), d in sorted(orders["epipolar"].items()):
        measured(f"checkerboard epipolar distance ku={ku} kv={kv}", f"{d:.1f} px")
    for ku, b in orders["board"].items():
        measured(f"checkerboard board at ku={ku}", {k: round(float(v), 3) for k, v in b.items()})
    assert set(orders["kv_best"].values()) == {2}
    assert orders["ku"] == 2 and orders["kv"] == 2
    best = orders["board"][2]
    assert abs(best["aspect"] - 1) < 0.05 and best["tilt_deg"] < 6.0
    assert best["square_mm"] == pytest.approx(10.0, abs=0.5)
    assert best["pnp_square_mm"] == pytest.approx(best["square_mm"], rel=0.05)
    others = [b for k, b in orders["board"].items() if k != 2]
    assert all(abs(b["aspect"] - 1) > 0.3 or b["tilt_deg"] > 15 for b in others)


def test_checkerboard_flat_board_plane_fit(checker, calibration, orders) -> None:  # type: ignore[no-untyped-def]
    """The board's triangulated points fit a plane: 0.83 mm RMS where the calibration is
    valid (its own projector uv_bbox), clipped 0.74 / unclipped 1.00 mm; the other project's
    points_filtered__points: 5.2 mm RMS orthogonal (36.7 mm along z, the README's "about
    37 mm")."""
    u = checker["u0"] + 480 * orders["ku"]
    v = checker["v0"] + 270 * orders["kv"]
    maps = triangulate_maps(calibration, u_proj=u, v_proj=v)
    with np.load(realdata_path(*CALIB, "projector_intrinsics.npz")) as z:
        u_lo, u_hi, v_lo, v_hi = (float(b) for b in z["uv_bbox"])
    inside = (u > u_lo) & (u < u_hi) & (v > v_lo) & (v < v_hi) & maps.valid
    clipped = checker["clipped"]
    fit = fit_plane(np.where(inside[..., None], maps.xyz, np.nan))
    r = fit.residuals

    def rms(sel: np.ndarray) -> float:
        return float(np.sqrt(np.mean(r[sel] ** 2)))

    res_mm = float(np.nanmedian(maps.residual_mm[inside]))
    whole = fit_plane(maps.xyz)
    with np.load(realdata_path(*CHECKER, "reference_outputs.npz")) as z:
        theirs = z["points_filtered__points"].astype(np.float64) * 1000.0  # metres
    theirs_fit = fit_plane(theirs)
    a = np.c_[theirs[:, :2], np.ones(len(theirs))]
    theirs_z = theirs[:, 2] - a @ np.linalg.lstsq(a, theirs[:, 2], rcond=None)[0]
    measured(
        "checkerboard pixels inside the calibrated uv_bbox", f"{inside.sum()} of {inside.size}"
    )
    measured("checkerboard plane RMS inside (all / clipped / unclipped)",
             f"{fit.rms_mm:.3f} / {rms(inside & clipped):.3f} / {rms(inside & ~clipped):.3f} mm "
             f"({(inside & clipped).sum()} / {(inside & ~clipped).sum()} px)")  # fmt: skip
    measured("checkerboard ray-ray residual median inside", f"{res_mm:.2f} mm")
    measured(
        "checkerboard plane RMS, whole image (distortion extrapolated)", f"{whole.rms_mm:.2f} mm"
    )
    theirs_z_rms = float(np.sqrt(np.mean(theirs_z**2)))
    measured("their points_filtered__points plane RMS (orthogonal / along z)",
             f"{theirs_fit.rms_mm:.2f} / {theirs_z_rms:.2f} mm, {len(theirs)} points")  # fmt: skip
    assert inside.sum() > 200_000
    assert fit.rms_mm < 1.2
    assert rms(inside & clipped) < 1.2 and rms(inside & ~clipped) < 1.4
    assert res_mm < 8.0  # the calibration and the scene agree to a few mm only (README)
    assert fit.rms_mm < 0.5 * theirs_fit.rms_mm
    # the same pixels with the column order one off still fit a plane (1.5 mm), but one
    # tilted some 45 degrees away: the order test above is what rejects it
    wrong = triangulate_maps(calibration, u_proj=u + 480, v_proj=v)
    tilt = np.degrees(np.arccos(abs(fit_plane(wrong.xyz[inside]).normal @ fit.normal)))
    measured("checkerboard plane tilt with the column order one off", f"{tilt:.1f} deg")
    assert tilt > 20
